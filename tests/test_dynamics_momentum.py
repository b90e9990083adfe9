"""Momentum (dissertation eq. 5.4-5.5): invariants, rigid-body ground truth, MuJoCo cross-check."""
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dyn_helpers import rigid_spin, wavy_motion
from mocomp.body import BodyModel
from mocomp.dynamics import center_of_mass, composite_inertia, momentum, segment_positions, segment_rotations
from mocomp.errors import MotionFormatError


@pytest.fixture(scope="module")
def body():
    return BodyModel.from_skeleton(wavy_motion(60).skeleton, 72.0, shape="cuboid")


def _rel(a, b):
    return np.max(np.linalg.norm(a - b, axis=-1)) / np.max(np.linalg.norm(b, axis=-1))


def test_com_and_segment_frames(body):
    m = wavy_motion(60)
    pos = segment_positions(body, m)
    assert pos.shape == (m.n_frames, body.n_segments, 3)
    assert np.allclose(center_of_mass(body, m), body.masses @ pos / body.total_mass)
    assert np.allclose(segment_rotations(body, m), m.global_rotations[:, body.segment_joint])


def test_linear_momentum_is_mass_times_com_velocity(body):
    m = wavy_motion(120)
    r = momentum(body, m)
    assert np.allclose(r.linear, body.total_mass * r.com_velocity)
    # finite differences commute with the (linear) mass average
    dc = np.gradient(r.com, r.times, axis=0)
    assert np.allclose(r.com_velocity, dc, atol=1e-10)


def test_translation_leaves_momentum_unchanged(body):
    m = wavy_motion(60)
    r0 = momentum(body, m)
    r1 = momentum(body, m.translated([3.0, -1.0, 12.0]))
    assert np.allclose(r1.angular, r0.angular, atol=1e-9, rtol=0)
    assert np.allclose(r1.linear, r0.linear, atol=1e-9, rtol=0)
    assert np.allclose(r1.com, r0.com + [3.0, -1.0, 12.0])


def test_rigid_rotation_rotates_momentum(body):
    m = wavy_motion(60)
    q = Rotation.from_rotvec([0.4, -1.2, 2.0])
    r0 = momentum(body, m)
    r1 = momentum(body, m.rotated(q.as_quat(), center=[1.0, 0.5, -2.0]))
    assert np.allclose(r1.angular, q.apply(r0.angular), atol=1e-8 * np.abs(r0.angular).max())
    assert np.allclose(r1.linear, q.apply(r0.linear), atol=1e-8 * np.abs(r0.linear).max())


@pytest.mark.parametrize("n", [2.0, 0.5])
def test_retiming_scales_momentum_by_n(body, n):
    """eq. 5.8: retiming by n scales p and L by n; the finite-difference error shrinks
    (second order) as the frame rate rises."""
    errs = []
    for fps in (30, 60, 120, 240):
        m = wavy_motion(fps, duration=2.0)
        r0 = momentum(body, m)
        mr = m.retime(n)
        r1 = momentum(body, mr)
        # retimed frame k is original time k*n/fps; compare in the interior against n x the
        # original sampled at those times (exact frames for n=2; for n=0.5 every other retimed frame)
        k = np.arange(2, mr.n_frames - 2)
        src = k * n
        sel = np.abs(src - np.round(src)) < 1e-9
        k, src = k[sel], np.round(src[sel]).astype(int)
        keep = (src >= 2) & (src < m.n_frames - 2)
        k, src = k[keep], src[keep]
        errs.append(max(_rel(r1.angular[k], n * r0.angular[src]), _rel(r1.linear[k], n * r0.linear[src])))
    assert errs[-1] < 5e-3
    assert all(a > 2.5 * b for a, b in zip(errs, errs[1:])), errs


def test_rigid_spin_gives_L_equals_I_omega(body):
    w = np.array([0.0, 0.0, 0.0])
    I = None
    for fps in (60, 240):
        m0, _ = rigid_spin(body, np.zeros(3), fps, duration=0.1)
        I = composite_inertia(body, m0)[0]
        evals, evecs = np.linalg.eigh(I)
        w = 2 * np.pi * 1.3 * evecs[:, 2]  # 1.3 rev/s about the principal axis of largest inertia
        m, _ = rigid_spin(body, w, fps, duration=1.0, com_velocity=[0.5, 2.0, -0.3])
        kin = momentum(body, m, velocity="kinematic")
        assert np.allclose(kin.angular, evals[2] * w, rtol=1e-10, atol=1e-10)
        assert np.allclose(composite_inertia(body, m) @ w, evals[2] * w, atol=1e-9)
        fd = momentum(body, m)
        # central differences of points on circles: |error| / |L| <~ (w h)^2 / 6
        bound = (np.linalg.norm(w) / fps) ** 2 / 6 * 1.05
        inner = slice(1, -1)  # the end frames use one-sided (first-order) differences
        assert _rel(fd.angular[inner], np.broadcast_to(evals[2] * w, fd.angular[inner].shape)) < bound
        assert np.allclose(fd.linear[inner], body.total_mass * np.array([0.5, 2.0, -0.3]), rtol=bound)


def test_rotating_a_flight_about_L_through_the_com_keeps_L(body):
    """flips paper eq. 5.7 (a free rigid spin about a principal axis: L constant)."""
    m0, _ = rigid_spin(body, np.zeros(3), 120, duration=0.1)
    w = 7.0 * np.linalg.eigh(composite_inertia(body, m0)[0])[1][:, 0]
    m, c0 = rigid_spin(body, w, 120, duration=0.5)
    r = momentum(body, m, velocity="kinematic")
    L = r.angular.mean(axis=0)
    q = Rotation.from_rotvec(L / np.linalg.norm(L) * np.deg2rad(140))
    r2 = momentum(body, m.rotated(q.as_quat(), center=c0), velocity="kinematic")
    assert np.allclose(r2.angular, r.angular, rtol=1e-9, atol=1e-9)
    # but rotating about another axis does change it
    q3 = Rotation.from_rotvec(np.cross(L, [0, 1, 0]) / np.linalg.norm(np.cross(L, [0, 1, 0])) * 0.5)
    r3 = momentum(body, m.rotated(q3.as_quat(), center=c0), velocity="kinematic")
    assert _rel(r3.angular, r.angular) > 0.1


def test_smoothing_is_recorded_and_damps_noise(body):
    m = wavy_motion(120)
    rng = np.random.default_rng(5)
    noisy = m.replace(root_positions=m.root_positions + rng.normal(0, 0.002, m.root_positions.shape))
    raw = momentum(body, noisy)
    sm = momentum(body, noisy, smooth_sigma=3.0)
    clean = momentum(body, m)
    assert raw.smooth_sigma is None and sm.smooth_sigma == 3.0
    inner = slice(10, -10)
    assert _rel(sm.linear[inner], clean.linear[inner]) < 0.3 * _rel(raw.linear[inner], clean.linear[inner])


def test_mismatched_skeleton_is_rejected(body):
    m = wavy_motion(60, height=1.6)
    with pytest.raises(MotionFormatError, match="bone offsets"):
        momentum(body, m)
    with pytest.raises(ValueError, match="velocity"):
        momentum(body, wavy_motion(60), velocity="analytic")


# ------------------------------------------------------------------ MuJoCo peer
def _cross_check(body, motion, label):
    from mocomp.dynamics.mujoco_check import mujoco_momentum

    ours = momentum(body, motion, velocity="kinematic")
    fd = momentum(body, motion)
    mj = mujoco_momentum(body, motion)
    com_rel = np.abs(ours.com - mj.com).max() / np.abs(mj.com).max()
    L_rel = _rel(ours.angular, mj.angular)
    v_rel = _rel(ours.com_velocity, mj.com_velocity)
    fd_rel = _rel(fd.angular, ours.angular)
    print(f"\n[MuJoCo cross-check] {label}: {motion.n_frames} frames at {motion.fps:g} Hz, "
          f"{body.n_segments} segments, {body.total_mass:.1f} kg\n"
          f"  COM max rel err {com_rel:.2e}; COM velocity {v_rel:.2e}; angular momentum {L_rel:.2e} "
          f"(max |L| {np.linalg.norm(mj.angular, axis=1).max():.2f} kg m^2/s)\n"
          f"  our finite-difference velocities vs matched rigid-body velocities: L differs by {fd_rel:.2e}")
    assert com_rel < 1e-6 and L_rel < 1e-6 and v_rel < 1e-6
    return L_rel


@pytest.mark.parametrize("shape", ["ellipsoid", "cuboid"])
def test_mujoco_cross_check_analytic_motion(shape):
    m = wavy_motion(120, duration=1.0)
    _cross_check(BodyModel.from_skeleton(m.skeleton, 70.0, shape=shape), m, f"analytic tumbling motion, {shape}")


@pytest.mark.realdata
def test_mujoco_cross_check_real_flip(real_data_dir):
    from mocomp.io import read_bvh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = read_bvh(real_data_dir / "flips" / "cmu_88_01_backflip.bvh", scale="cmu", fps=60.0)[1:]
    body = BodyModel.from_skeleton(m.skeleton, 70.0)
    _cross_check(body, m, "CMU 88_01 backflip (60 Hz, cmu units)")


def test_mujoco_cross_check_synthetic_flip():
    from mocomp.datasets import load_example

    ex = load_example("backflip")
    _cross_check(ex.body, ex.motion, "synthetic backflip (mocomp.synth, true masses)")


def test_plot_momentum_draws_three_panels(body):
    import matplotlib

    matplotlib.use("Agg")
    from mocomp.plots.dynamics import plot_momentum

    r = momentum(body, wavy_motion(30))
    fig = plot_momentum(r, airborne=[(3, 10)], title="test")
    assert len(fig.axes) == 3
    assert len(fig.axes[2].lines) == 4  # L_x, L_y, L_z, |L|


def test_fourth_order_momentum_matches_rigid_body_velocities_closer(body):
    m = wavy_motion(120)
    inner = slice(2, -2)
    kin2 = momentum(body, m, velocity="kinematic")
    kin4 = momentum(body, m, velocity="kinematic", order=4)
    fd2 = momentum(body, m)
    fd4 = momentum(body, m, order=4)
    assert fd4.order == 4 and fd2.order == 2
    # order 2: the two velocity models differ by O(h^2); order 4: by O(h^4)
    d2 = _rel(fd2.angular[inner], kin2.angular[inner])
    d4 = _rel(fd4.angular[inner], kin4.angular[inner])
    assert d4 < 0.02 * d2
    # a finer sampling of the same continuous motion agrees better at order 4
    fine = momentum(body, wavy_motion(480), velocity="kinematic", order=4)
    assert _rel(kin4.angular[inner], fine.angular[::4][inner]) < 0.05 * _rel(kin2.angular[inner], fine.angular[::4][inner])
