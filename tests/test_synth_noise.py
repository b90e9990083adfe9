"""The capture-noise model: statistics of the jitter, unit and frame-rate errors, seeding."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import Motion
from mocomp.core.rotations import quat_inverse, quat_multiply
from mocomp.dynamics import center_of_mass
from mocomp.synth import capture_noise, make_example, position_noise, synthetic_skeleton


@pytest.fixture(scope="module")
def still():
    """A long motionless clip (many samples for the statistics)."""
    sk = synthetic_skeleton(1.75)
    T = 3000
    rot = np.zeros((T, sk.n_joints, 4))
    rot[..., 3] = 1.0
    return Motion(sk, 120.0, np.tile([0.0, 1.0, 0.0], (T, 1)), rot)


def _applied(noisy):
    """Rotation vectors q_clean^-1 q_noisy, recovered from the two motions."""
    d = quat_multiply(quat_inverse(noisy.clean.rotations), noisy.motion.rotations)
    return Rotation.from_quat(d.reshape(-1, 4)).as_rotvec().reshape(d.shape[:-1] + (3,))


def test_joint_jitter_statistics(still):
    sigma = 1.5
    n = capture_noise(still, seed=3, joint_jitter_deg=sigma)
    rv = _applied(n)
    assert np.allclose(rv, n.joint_noise, atol=1e-12)        # what was applied is what is recorded
    deg = np.degrees(rv).reshape(-1, 3)
    assert np.std(deg, axis=0) == pytest.approx([sigma] * 3, rel=0.02)
    assert np.abs(deg.mean(axis=0)).max() < 4 * sigma / np.sqrt(deg.shape[0])
    # white noise: neighbouring frames uncorrelated
    x = deg.reshape(still.n_frames, -1)
    r1 = np.mean(np.sum((x[1:] - x[1:].mean(0)) * (x[:-1] - x[:-1].mean(0)), 0) / (len(x) - 1) / x.var(0))
    assert abs(r1) < 0.02
    assert np.array_equal(n.motion.root_positions, still.root_positions)


def test_correlated_jitter_keeps_sigma_and_has_gaussian_autocorrelation(still):
    sigma, s = 1.0, 3.0
    n = capture_noise(still, seed=4, joint_jitter_deg=sigma, root_jitter_m=0.002, correlation_frames=s)
    x = np.degrees(n.joint_noise).reshape(still.n_frames, -1)
    assert np.std(x) == pytest.approx(sigma, rel=0.05)
    assert np.std(n.root_noise) == pytest.approx(0.002, rel=0.15)
    xc = x - x.mean(0)
    for k in (1, 3, 6):
        rho = np.mean(np.sum(xc[k:] * xc[:-k], 0) / np.sum(xc * xc, 0))
        assert rho == pytest.approx(np.exp(-k * k / (4 * s * s)), abs=0.03), k


def test_root_noise_and_selected_joints(still):
    n = capture_noise(still, seed=5, root_jitter_m=0.004, joint_jitter_deg=2.0, joints=["LeftArm", "Head"])
    assert np.std(n.motion.root_positions - still.root_positions, axis=0) == pytest.approx([0.004] * 3, rel=0.05)
    moved = np.flatnonzero(np.abs(n.joint_noise).max(axis=(0, 2)) > 0)
    assert sorted(still.skeleton.names[j] for j in moved) == ["Head", "LeftArm"]


def test_unit_error_scales_lengths_only():
    r = make_example("jump")
    n = capture_noise(r.motion, seed=0, length_scale=2.54)
    assert np.allclose(n.motion.positions, r.motion.positions * 2.54, atol=1e-12)
    assert n.motion.skeleton.height() == pytest.approx(2.54 * r.motion.skeleton.height())
    assert any("lengths x2.54" in note for note in n.motion.source.notes)


def test_frame_rate_mislabel_quadruples_fitted_gravity():
    """60 Hz data labelled 120 Hz: a ballistic fit gives 4 g (why the datasets correct headers)."""
    r = make_example("backflip")
    n = capture_noise(r.motion, seed=0, fps_scale=2.0)
    assert n.motion.fps == 240.0 and n.motion.duration == pytest.approx(r.motion.duration / 2)
    a, b = r.flight
    com = center_of_mass(r.body, n.motion)[a:b]
    g_fit = -2 * np.polyfit(n.motion.times[a:b], com[:, 1], 2)[0]
    assert g_fit == pytest.approx(4 * 9.81, rel=1e-9)


def test_seeding():
    m = make_example("jump").motion
    a = capture_noise(m, seed=1, joint_jitter_deg=1.0)
    b = capture_noise(m, seed=1, joint_jitter_deg=1.0)
    c = capture_noise(m, seed=2, joint_jitter_deg=1.0)
    assert np.array_equal(a.motion.rotations, b.motion.rotations)
    assert not np.allclose(a.motion.rotations, c.motion.rotations)
    assert np.array_equal(capture_noise(m, seed=np.random.default_rng(9), joint_jitter_deg=1.0).joint_noise,
                          capture_noise(m, seed=9, joint_jitter_deg=1.0).joint_noise)
    with pytest.raises(ValueError, match="seed"):
        capture_noise(m, seed=None, joint_jitter_deg=1.0)
    with pytest.raises(ValueError):
        capture_noise(m, seed=0, joint_jitter_deg=-1.0)
    with pytest.raises(ValueError):
        capture_noise(m, seed=0, fps_scale=0.0)


def test_position_noise_markers():
    m = make_example("jump").motion
    mk = position_noise(m, 0.003, seed=2)
    E = len(m.skeleton.end_sites)
    assert mk.positions.shape == (m.n_frames, m.skeleton.n_joints + E, 3)
    assert mk.names[:31] == m.skeleton.names and mk.fps == m.fps
    err = mk.positions[:, :31] - m.positions
    assert np.std(err) == pytest.approx(0.003, rel=0.03)
    assert np.array_equal(position_noise(m, 0.003, seed=2).positions, mk.positions)
