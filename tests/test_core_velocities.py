"""Core's joint and segment velocities (mocomp.core.kinematics): angular velocity from sampled
orientations (world and body axes, numpy reference and compiled backend), rigid-body propagation
down the tree, and agreement with the implementation dynamics carried before (the oracle below)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import Motion, Skeleton, forward_kinematics
from mocomp.core import _compiled
from mocomp.core.kinematics import (angular_velocity, angular_velocity_numpy, frame_times, path_matrix,
                                    point_velocities, propagate_velocities, world_angular_velocities)
from mocomp.core.rotations import quat_apply, quat_exp, quat_inverse, quat_multiply

needs_numba = pytest.mark.skipif(not _compiled.AVAILABLE, reason="compiled backend off (MOCOMP_NO_NUMBA or no numba)")


# ------------------------------------------------------------------ the former implementation (oracle)
def _old_angular_velocity(quats, times, order=2):
    """``mocomp.dynamics.derivatives.angular_velocity`` as it was before it moved to core (scipy's
    ``as_rotvec`` of ``q_{i+1} q_i^-1``, central-difference weights, Richardson for order 4)."""
    q = np.asarray(quats, dtype=float)
    T = q.shape[0]
    t = np.arange(T) / float(times) if np.ndim(times) == 0 else np.asarray(times, dtype=float)

    def rv(a, b):
        d = quat_multiply(b, quat_inverse(a))
        return Rotation.from_quat(d.reshape(-1, 4)).as_rotvec().reshape(d.shape[:-1] + (3,))

    h = np.diff(t).reshape((-1,) + (1,) * (q.ndim - 1))
    step = rv(q[:-1], q[1:]) / h
    out = np.empty(q.shape[:-1] + (3,))
    out[0], out[-1] = step[0], step[-1]
    out[1:-1] = (h[:-1] * step[1:] + h[1:] * step[:-1]) / (h[:-1] + h[1:])
    if order == 4 and T >= 5:
        hu = float(t[1] - t[0])
        out[2:-2] = (8 * rv(q[1:-3], q[3:-1]) - rv(q[:-4], q[4:])) / (12 * hu)
    return out


def _old_joint_velocities(motion, w, v0):
    """``dynamics.momentum.joint_velocities``' propagation as it was (np.cross, path matrix)."""
    P, _ = motion.fk()
    par = np.asarray(motion.skeleton.parents).copy()
    par[0] = 0
    step = np.cross(w[:, par], P - P[:, par])
    step[:, 0] = 0.0
    J = motion.skeleton.n_joints
    A = np.zeros((J, J))
    for j in range(1, J):
        A[j] = A[motion.skeleton.parents[j]]
        A[j, j] = 1.0
    return v0[:, None] + A @ step


def _uneven_times(T, rng):
    return np.cumsum(rng.uniform(0.5, 1.5, size=T) / 100.0)


def _both(fn):
    """Run ``fn(angular_velocity_fn)`` with the numpy reference and with the dispatching function
    (compiled when numba is loaded, which it is once _compiled imported it)."""
    return [fn(angular_velocity_numpy), fn(angular_velocity)]


# ------------------------------------------------------------------ known answers
@pytest.mark.parametrize("order", [2, 4])
def test_constant_world_rate_gives_that_rate_in_world_and_body_axes(order):
    """q(t) = Exp(w t) q0: a rotation at the constant world rate w about a fixed axis. The world
    rate is w at every frame; the body rate is R(t)^T w = R0^T w (constant, since R(t) = Exp(wt) R0
    and Exp(wt) leaves w unchanged)."""
    rng = np.random.default_rng(1)
    w = np.array([0.4, -1.1, 2.3])  # rad/s, |w| = 2.58
    q0 = Rotation.random(random_state=3).as_quat()
    T = 40
    t = np.arange(T) / 120.0 if order == 4 else _uneven_times(T, rng)
    q = quat_multiply(quat_exp(t[:, None] * w), q0)
    q[::3] *= -1.0  # sign flips are the same rotations
    body = quat_apply(quat_inverse(q0), w)
    for av in (angular_velocity_numpy, angular_velocity):
        np.testing.assert_allclose(av(q, t, order=order), np.broadcast_to(w, (T, 3)), atol=1e-10)
        np.testing.assert_allclose(av(q, t, order=order, frame="body"), np.broadcast_to(body, (T, 3)), atol=1e-10)


def test_constant_body_rate_about_an_axis():
    """q(t) = q0 Exp(w_b t): spinning at w_b about a body axis (3 rad/s about the body's own x).
    The body rate is w_b; the world rate is R(t) w_b, i.e. the body's x axis (turned by q0) times 3."""
    T, fps = 25, 60.0
    t = np.arange(T) / fps
    wb = np.array([3.0, 0.0, 0.0])
    q0 = Rotation.from_euler("zy", [30, 50], degrees=True).as_quat()
    q = quat_multiply(q0, quat_exp(t[:, None] * wb))
    world_expected = 3.0 * Rotation.from_quat(q0).apply([1.0, 0.0, 0.0])
    for res in _both(lambda av: av(q, fps, frame="body")):
        np.testing.assert_allclose(res, np.broadcast_to(wb, (T, 3)), atol=1e-10)
    for res in _both(lambda av: av(q, fps)):
        np.testing.assert_allclose(res, np.broadcast_to(world_expected, (T, 3)), atol=1e-10)


def test_ninety_degrees_per_second_about_y_by_hand():
    """Frames every 0.1 s turning 9 degrees about y each: 0.5 pi rad/s about +y."""
    q = Rotation.from_euler("y", np.arange(6)[:, None] * 9.0, degrees=True).as_quat()
    for res in _both(lambda av: av(q, 10.0)):
        np.testing.assert_allclose(res, [[0.0, 0.5 * np.pi, 0.0]] * 6, atol=1e-12)


def test_world_and_body_rates_differ_by_the_orientation_on_a_first_step():
    """On the one-sided first step the two are exactly related: w_body(0) = R_0^T w_world(0)."""
    rng = np.random.default_rng(4)
    q = Rotation.random(2 * 30, random_state=8).as_quat().reshape(2, 30, 4)
    q[1] = quat_multiply(quat_exp(rng.normal(scale=0.2, size=(30, 3))), q[0])
    for world, body in zip(_both(lambda av: av(q, 100.0)), _both(lambda av: av(q, 100.0, frame="body"))):
        np.testing.assert_allclose(body[0], quat_apply(quat_inverse(q[0]), world[0]), atol=1e-12)


def test_second_order_convergence_on_a_varying_rate():
    """A rotation whose rate changes (two axes at different rates): the error falls ~4x per halving
    of the step in both frames (order 2)."""
    def motion(t):
        return quat_multiply(quat_exp(np.outer(np.sin(2 * t), [0.0, 0.0, 1.0])),
                             quat_exp(np.outer(3 * t, [1.0, 0.0, 0.0])))

    def exact(t, frame):  # from a much finer central difference of the same motion
        e = 1e-6
        qm, qp, q = motion(t - e), motion(t + e), motion(t)
        if frame == "world":
            d = quat_multiply(qp, quat_inverse(qm))
        else:
            d = quat_multiply(quat_inverse(qm), qp)
        from mocomp.core.rotations import quat_log
        w = quat_log(d) / (2 * e)
        return w

    for frame in ("world", "body"):
        errs = []
        for fps in (50.0, 100.0, 200.0):
            t = np.arange(0.0, 1.0, 1.0 / fps)
            w = angular_velocity(motion(t), t, frame=frame)
            errs.append(np.max(np.abs(w[1:-1] - exact(t, frame)[1:-1])))
        assert errs[0] / errs[1] > 3.5 and errs[1] / errs[2] > 3.5, (frame, errs)


# ------------------------------------------------------------------ agreement with the old implementation
def _real_or_random_rotations(real_data_dir):
    from mocomp.io import read_bvh

    m = read_bvh(real_data_dir / "flips" / "cmu_88_01_backflip.bvh", scale="cmu", fps=60.0)
    return m


@pytest.mark.parametrize("order", [2, 4])
def test_agrees_with_the_former_dynamics_implementation_on_a_real_clip(real_data_dir, order):
    """CMU 88_01 (a back flip: fast spins) global joint rotations: core's rates equal the former
    scipy-based implementation within 1e-9 rad/s (rates reach tens of rad/s)."""
    m = _real_or_random_rotations(real_data_dir)
    _, G = m.fk()
    old = _old_angular_velocity(G, m.times, order=order)
    assert np.max(np.abs(old)) > 10.0
    for res in _both(lambda av: av(G, m.times, order=order)):
        np.testing.assert_allclose(res, old, rtol=0, atol=1e-9)
    # the dynamics name is core's function
    from mocomp.dynamics.derivatives import angular_velocity as dyn_av

    assert dyn_av is angular_velocity


def test_joint_velocities_agree_with_the_former_propagation(real_data_dir):
    from mocomp.dynamics.derivatives import central_difference
    from mocomp.dynamics.momentum import joint_velocities

    m = _real_or_random_rotations(real_data_dir)
    _, G = m.fk()
    w_old = _old_angular_velocity(G, m.times)
    v_old = _old_joint_velocities(m, w_old, central_difference(m.root_positions, m.times))
    v, w = joint_velocities(m)
    np.testing.assert_allclose(w, w_old, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v, v_old, rtol=0, atol=1e-9)


@needs_numba
def test_compiled_equals_numpy_reference_to_rounding():
    rng = np.random.default_rng(11)
    T, K = 200, 7
    q = Rotation.random(T * K, random_state=2).as_quat().reshape(T, K, 4)
    # a smooth path: small random increments
    q = np.cumsum(rng.normal(scale=0.05, size=(T, K, 3)), axis=0)
    q = quat_exp(q)
    t = _uneven_times(T, rng)
    for frame in ("world", "body"):
        a = angular_velocity_numpy(q, t, frame=frame)
        b = _compiled.angular_velocity(np.ascontiguousarray(q), t, frame == "body")
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
        c = angular_velocity(q.reshape(T, 7, 1, 4), t, frame=frame)  # any middle shape
        assert c.shape == (T, 7, 1, 3)
        np.testing.assert_allclose(c[:, :, 0], a, rtol=1e-12, atol=1e-12)


def test_bad_arguments_raise_clear_errors():
    q = Rotation.random(5, random_state=0).as_quat()
    with pytest.raises(ValueError, match="frame must be one of"):
        angular_velocity(q, 30.0, frame="local")
    with pytest.raises(ValueError, match="order must be 2 or 4"):
        angular_velocity(q, 30.0, order=3)
    with pytest.raises(ValueError, match="at least 2 frames"):
        angular_velocity(q[:1], 30.0)
    with pytest.raises(ValueError, match=r"shape \(T, \.\.\., 4\)"):
        angular_velocity(q[:, :3], 30.0)
    with pytest.raises(ValueError, match="increase strictly"):
        angular_velocity(q, [0.0, 0.1, 0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="uniformly spaced"):
        angular_velocity(q, [0.0, 0.1, 0.3, 0.4, 0.5], order=4)
    with pytest.raises(ValueError, match="frame rate and must be positive"):
        frame_times(0.0, 5)


# ------------------------------------------------------------------ propagation down the tree
def _chain():
    # root -> a (+1 m y) -> b (+1 m x); root -> c (+0.5 m z)
    return Skeleton(("root", "a", "b", "c"), [-1, 0, 1, 0], [[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 0.5]])


def test_rigid_spin_moves_every_joint_origin_as_one_body():
    """The whole chain turning rigidly at w about the root (all joints share w): v_j = v0 + w x (P_j - P_0)."""
    sk = _chain()
    rng = np.random.default_rng(2)
    T = 6
    rot = Rotation.random(T * 4, random_state=5).as_quat().reshape(T, 4, 4)
    P, _ = forward_kinematics(sk.parents, sk.offsets, rng.normal(size=(T, 3)), rot)
    w = np.broadcast_to(np.array([0.3, -2.0, 1.0]), (T, 4, 3))
    v0 = rng.normal(size=(T, 3))
    v = propagate_velocities(sk.parents, P, w, v0)
    np.testing.assert_allclose(v, v0[:, None] + np.cross(w, P - P[:, :1]), atol=1e-12)


def test_only_ancestors_rates_move_a_joint_origin():
    """Rest pose, only joint a spinning at 2 rad/s about z: b (1 m along x from a) moves at 2 m/s
    along +y; a and c (children of the root) do not move; a's own rate does not move a."""
    sk = _chain()
    P = sk.rest_positions()[None]
    w = np.zeros((1, 4, 3))
    w[0, 1] = [0.0, 0.0, 2.0]
    v = propagate_velocities(sk.parents, P, w, np.zeros((1, 3)))
    np.testing.assert_allclose(v[0], [[0, 0, 0], [0, 0, 0], [0, 2, 0], [0, 0, 0]], atol=1e-15)
    np.testing.assert_array_equal(path_matrix(sk.parents), [[0, 0, 0, 0], [0, 1, 0, 0], [0, 1, 1, 0], [0, 0, 0, 1]])


def test_world_rates_from_local_rates_add_along_the_chain():
    """Root spinning 1 rad/s about world y; joint a turned 90 deg about x relative to the root and
    spinning 2 rad/s about its own z (which, turned by Rx(90), is world -y); b spinning 0.5 rad/s
    about its own x (world x). World rates: root (0,1,0), a (0,1,0) + (0,-2,0) = (0,-1,0),
    b (0,-1,0) + (0.5,0,0)."""
    sk = _chain()
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (1, 4, 1))
    rot[0, 1] = Rotation.from_euler("x", 90, degrees=True).as_quat()
    _, G = forward_kinematics(sk.parents, sk.offsets, np.zeros((1, 3)), rot)
    local = np.zeros((1, 4, 3))
    local[0, 1] = [0, 0, 2.0]
    local[0, 2] = [0.5, 0, 0]
    w = world_angular_velocities(sk.parents, G, np.array([[0.0, 1.0, 0.0]]), local)
    np.testing.assert_allclose(w[0], [[0, 1, 0], [0, -1, 0], [0.5, -1, 0], [0, 1, 0]], atol=1e-12)


def test_propagated_velocities_match_differentiated_positions():
    """On a smooth motion, joint-origin velocities from finite-difference rates propagated down the
    tree match the finite differences of the FK positions (both second order: within 1e-3 m/s)."""
    from mocomp.dynamics.derivatives import central_difference

    sk = _chain()
    fps = 400.0
    t = np.arange(200) / fps
    rot = np.empty((len(t), 4, 4))
    rot[:, 0] = quat_exp(np.outer(np.sin(t), [0.0, 1.0, 0.0]))
    rot[:, 1] = quat_exp(np.outer(2 * t, [0.0, 0.0, 1.0]))
    rot[:, 2] = quat_exp(np.outer(np.cos(3 * t), [1.0, 0.0, 0.0]))
    rot[:, 3] = quat_exp(np.outer(t, [1.0, 1.0, 0.0]))
    root = np.stack([t, np.sin(t), 0 * t], axis=1)
    m = Motion(sk, fps, root, rot)
    P, G = m.fk()
    w = angular_velocity(G, t)
    v = propagate_velocities(sk.parents, P, w, central_difference(root, t))
    np.testing.assert_allclose(v[1:-1], central_difference(P, t)[1:-1], atol=1e-3)


def test_point_velocity_by_hand():
    """A point 2 m along x from an origin moving at (1,0,0), frame spinning 3 rad/s about z:
    v = (1,0,0) + (0,0,3) x (2,0,0) = (1,6,0); broadcasting over leading axes."""
    v = point_velocities([1.0, 0, 0], [0, 0, 3.0], [5.0, 5, 5], [[7.0, 5, 5], [5.0, 5, 5]])
    np.testing.assert_allclose(v, [[1, 6, 0], [1, 0, 0]], atol=1e-15)
