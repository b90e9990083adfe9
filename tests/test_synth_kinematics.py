"""Building blocks of the generator: SO(3) calculus, smooth scripts, body-frame mass
properties (against the project's dynamics) and the planted-foot leg IK."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import Motion
from mocomp.dynamics import center_of_mass, composite_inertia, momentum
from mocomp.errors import PhysicsError
from mocomp.synth._bodyframe import body_frame
from mocomp.core.rotations import quat_exp as exp_quat, quat_log as log_quat, quat_matrix as quat_to_matrix
from mocomp.synth._so3 import left_jacobian, right_jacobian
from mocomp.synth.bodies import true_body
from mocomp.synth.legs import leg_chain, leg_ik
from mocomp.synth.poses import mirror_rotvec, pose
from mocomp.synth.script import KeyTrack, bump_ramp, quintic_hermite, smoothstep7
from mocomp.synth.skeleton import synthetic_skeleton

RNG = np.random.default_rng(7)


# ------------------------------------------------------------------------ SO(3)
def test_exp_log_agree_with_scipy():
    phi = RNG.normal(0, 1.0, (50, 3))
    phi[0] = 0.0
    phi[1] = [1e-10, 0, 0]
    q = exp_quat(phi)
    ref = Rotation.from_rotvec(phi).as_quat()
    assert np.allclose(np.abs(np.sum(q * ref, axis=1)), 1.0, atol=1e-12)
    small = np.linalg.norm(phi, axis=1) < np.pi
    assert np.allclose(log_quat(q)[small], phi[small], atol=1e-9)
    assert np.allclose(quat_to_matrix(q), Rotation.from_rotvec(phi).as_matrix(), atol=1e-12)


def test_jacobians_give_angular_velocity():
    """Body rate J_r(phi) phi_dot and spatial rate J_l(phi) phi_dot, against finite differences."""
    h = 1e-6
    for _ in range(10):
        phi = RNG.normal(0, 1.2, 3)
        dphi = RNG.normal(0, 2.0, 3)
        Rp = Rotation.from_rotvec(phi + h * dphi)
        Rm = Rotation.from_rotvec(phi - h * dphi)
        body = (Rm.inv() * Rp).as_rotvec() / (2 * h)
        space = (Rp * Rm.inv()).as_rotvec() / (2 * h)
        assert np.allclose(right_jacobian(phi) @ dphi, body, atol=1e-7)
        assert np.allclose(left_jacobian(phi) @ dphi, space, atol=1e-7)
    assert np.allclose(right_jacobian(np.zeros(3)), np.eye(3))


# ---------------------------------------------------------------------- scripts
def test_smoothstep7_is_c3_and_monotonic():
    u = np.linspace(0, 1, 2001)
    S = smoothstep7(u)
    assert S[0] == 0 and S[-1] == pytest.approx(1.0) and np.all(np.diff(S) >= 0)
    du = u[1] - u[0]
    assert np.allclose(np.gradient(S, du), smoothstep7(u, 1), atol=1e-5)
    assert np.allclose(np.gradient(smoothstep7(u, 1), du), smoothstep7(u, 2), atol=1e-3)
    for k in (1, 2):
        assert smoothstep7(0.0, k) == 0 and smoothstep7(1.0, k) == pytest.approx(0, abs=1e-12)


def test_keytrack_values_and_rates():
    tr = KeyTrack(np.array([0.0, 0.5, 1.2, 2.0]), RNG.normal(0, 1, (4, 5, 3)))
    v, r = tr(tr.times)
    assert np.allclose(v, tr.values) and np.allclose(r, 0)
    t = np.linspace(-0.3, 2.3, 3001)
    v, r = tr(t)
    num = np.gradient(v, t, axis=0)
    assert np.allclose(num[5:-5], r[5:-5], atol=2e-4 * np.abs(r).max())
    with pytest.raises(ValueError):
        KeyTrack(np.array([0.0, 0.0]), np.zeros((2, 3)))


def test_quintic_hermite_boundary_conditions():
    pa, va, aa, pb, vb, ab = RNG.normal(0, 1, (6, 3))
    p, v, a = quintic_hermite(np.array([0.3, 1.1]), 0.3, 1.1, pa, va, aa, pb, vb, ab)
    assert np.allclose([p[0], v[0], a[0], p[1], v[1], a[1]], [pa, va, aa, pb, vb, ab])
    t = np.linspace(0.3, 1.1, 4001)
    p, v, a = quintic_hermite(t, 0.3, 1.1, pa, va, aa, pb, vb, ab)
    assert np.allclose(np.gradient(p, t, axis=0)[2:-2], v[2:-2], atol=1e-5)


def test_bump_ramp_adds_an_initial_rate_only():
    s = np.linspace(-0.1, 0.3, 4001)
    f, df = bump_ramp(s, 0.1)
    assert f[s <= 0].max() == 0 and f[s >= 0.1].max() == 0
    i0 = np.argmin(np.abs(s))
    assert df[i0] == pytest.approx(1.0, abs=1e-6)
    away = np.abs(s) > 2 * (s[1] - s[0])          # f starts at s = 0 with slope 1 (a kink by design)
    assert np.allclose(np.gradient(f, s)[away], df[away], atol=1e-4)


# ------------------------------------------------------------------ body frame
@pytest.fixture(scope="module")
def performer():
    sk = synthetic_skeleton(1.75)
    return sk, true_body(sk, 70.0)


def _random_motion(sk, n, fps, rng):
    """A smooth random motion: joints and root turn about fixed random axes at random rates."""
    t = np.arange(n) / fps
    axes = rng.normal(0, 1, (sk.n_joints, 3))
    rates = rng.normal(0, 3.0, sk.n_joints)
    base = rng.normal(0, 0.4, (sk.n_joints, 3))
    phi = base[None] + np.sin(t[:, None, None] * rates[None, :, None]) * axes[None] * 0.3
    root = np.stack([0.5 * t, 1.0 + 0.2 * np.sin(3 * t), -0.3 * t], axis=1)
    return Motion(sk, fps, root, exp_quat(phi)), phi, t


def test_body_frame_matches_project_dynamics(performer):
    """COM, composite inertia and L of the root-frame decomposition equal the project's
    center_of_mass / composite_inertia / momentum (eq. 5.5) on the same motion."""
    sk, body = performer
    m, phi, t = _random_motion(sk, 400, 4000.0, np.random.default_rng(3))
    R = quat_to_matrix(m.rotations[:, 0])
    # local body rates of every joint by central differences of the script
    dphi = np.gradient(phi, t, axis=0)
    w = np.einsum("njab,njb->nja", right_jacobian(phi), dphi)
    bf = body_frame(sk, body, quat_to_matrix(m.rotations), w)
    com = m.root_positions + np.einsum("nab,nb->na", R, bf.C)
    assert np.allclose(com, center_of_mass(body, m), atol=1e-12)
    Iw = R @ bf.I_c @ np.swapaxes(R, 1, 2)
    assert np.allclose(Iw, composite_inertia(body, m), atol=1e-10)
    # L = R (I_c R^T w_root + h): root angular velocity from the motion
    w_root_body = np.einsum("njab,njb->nja", right_jacobian(phi[:, :1]), dphi[:, :1])[:, 0]
    L = np.einsum("nab,nb->na", R, np.einsum("nab,nb->na", bf.I_c, w_root_body) + bf.h)
    ref = momentum(body, m).angular
    inner = slice(5, -5)
    assert np.allclose(L[inner], ref[inner], rtol=0, atol=2e-4 * np.abs(ref).max())


def test_body_frame_rigid_rotation(performer):
    """A rigid pose spinning at constant w: L = I_c w and the relative momentum h is zero."""
    sk, body = performer
    p = pose(sk, hip_flex=90, knee=100, shoulder_flex=40, elbow=60)
    bf = body_frame(sk, body, quat_to_matrix(exp_quat(p))[None], np.zeros((1, sk.n_joints, 3)))
    assert np.allclose(bf.h, 0) and np.allclose(bf.C_dot, 0)
    evals = np.linalg.eigvalsh(bf.I_c[0])
    assert np.all(evals > 0.5) and np.all(evals < 20)


def test_pose_mirror_is_left_right_symmetric(performer):
    sk, body = performer
    p = pose(sk, flex=20, shoulder_flex=70, shoulder_abd=30, shoulder_rot=40, elbow=50, hip_flex=60, knee=80,
             ankle=20)
    m = Motion(sk, 120.0, np.array([[0, 1.0, 0]]), exp_quat(p)[None])
    P = m.positions[0]
    mm = sk.mirror_map()
    assert np.allclose(P[mm] * [-1, 1, 1], P, atol=1e-12)
    assert np.allclose(mirror_rotvec(mirror_rotvec(p)), p)


# --------------------------------------------------------------------- leg IK
def test_leg_ik_plants_the_toe_exactly(performer):
    sk, _ = performer
    n = 20
    rng = np.random.default_rng(11)
    root = np.array([0.0, 0.85, 0.02]) + rng.normal(0, 0.03, (n, 3))
    R = Rotation.from_rotvec(rng.normal(0, 0.25, (n, 3))).as_matrix()
    rot = np.tile([0.0, 0, 0, 1], (n, sk.n_joints, 1))
    rot[:, 0] = Rotation.from_matrix(R).as_quat()
    toes = {"left": np.array([0.09, 0.021, 0.14]), "right": np.array([-0.09, 0.021, 0.14])}
    beta = np.linspace(0, 0.6, n)
    knees = {}
    for side in ("left", "right"):
        ch = leg_chain(sk, side)
        lp = leg_ik(ch, root, R, toes[side], 0.2, beta)
        for k, j in enumerate((ch.hip, ch.knee, ch.ankle, ch.toe)):
            rot[:, j] = Rotation.from_matrix(lp.R_local[:, k]).as_quat()
        # the knee is a pure hinge about its local x and the toe flat: R_x(-beta)
        assert np.allclose(Rotation.from_matrix(lp.R_local[:, 1]).as_rotvec()[:, 1:], 0, atol=1e-12)
        knees[side] = lp.knee_angle
        # law of cosines
        d = np.linalg.norm(lp.ankle - lp.hip, axis=1)
        l1, l2 = ch.l_thigh, ch.l_shank
        assert np.allclose(d**2, l1**2 + l2**2 + 2 * l1 * l2 * np.cos(lp.knee_angle), atol=1e-12)
    m = Motion(sk, 120.0, root, rot)
    for side, name in (("left", "LeftToeBase"), ("right", "RightToeBase")):
        assert np.abs(m.joint_positions(name) - toes[side]).max() < 1e-12
        G = m.global_rotations[:, sk.index(name)]
        expect = Rotation.from_rotvec([0, 0.2, 0]).as_quat()
        assert np.allclose(np.abs(G @ expect), 1.0, atol=1e-12)     # flat, heading 0.2 rad
    assert np.all(knees["left"] > 0)


def test_leg_ik_refuses_unreachable_feet(performer):
    sk, _ = performer
    with pytest.raises(PhysicsError, match="cannot reach"):
        leg_ik(leg_chain(sk, "left"), np.array([[0, 1.2, 0]]), np.eye(3)[None], np.array([0.09, 0.02, 0.14]), 0, 0)


def test_body_frame_takes_quaternions_or_matrices_alike(performer):
    """The same poses as quaternions (N, J, 4) or matrices (N, J, 3, 3): the same kinematics (core's
    FK and velocity propagation behind both), and a clear error for any other shape."""
    sk, body = performer
    phi = RNG.normal(0, 0.6, (7, sk.n_joints, 3))
    w = RNG.normal(0, 2.0, (7, sk.n_joints, 3))
    a = body_frame(sk, body, exp_quat(phi), w)
    b = body_frame(sk, body, quat_to_matrix(exp_quat(phi)), w)
    for name in ("P", "G", "Om", "V", "C", "C_dot", "I_c", "h"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-12, err_msg=name)
    with pytest.raises(ValueError, match=r"\(N, J, 3, 3\) or \(N, J, 4\)"):
        body_frame(sk, body, phi, w)
