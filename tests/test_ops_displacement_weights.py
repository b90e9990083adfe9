"""ops.displacement: the per-frame weight of a hierarchical displacement map (touch-up keeps its
ground maps off the flights, Shin et al. 2003 Fig. 4) and the elementwise log/exp maps."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.ops import DisplacementMap, HierarchyStep, apply_displacement, apply_hierarchy
from mocomp.ops.synthetic import synthetic_walk


def test_between_and_apply_equal_scipy_rotvecs():
    """The map between two motions is scipy's rotation vector of ``q_base^-1 q_target`` per joint (core's
    log map), zero exactly on the joints that do not change; applying it gives the target back."""
    m = synthetic_walk(duration=0.5, fps=60).motion
    T, J = m.n_frames, m.skeleton.n_joints
    rot = np.array(m.rotations)
    turn = Rotation.random(T * 3, random_state=3).as_quat().reshape(T, 3, 4)
    turn[::3] *= -1                                    # either sign of a quaternion: one rotation
    rot[:, [2, 5, 9]] = (Rotation.from_quat(rot[:, [2, 5, 9]].reshape(-1, 4))
                         * Rotation.from_quat(turn.reshape(-1, 4))).as_quat().reshape(T, 3, 4)
    other = m.replace(rotations=rot)
    d = DisplacementMap.between(m, other)
    ref = (Rotation.from_quat(m.rotations.reshape(-1, 4)).inv()
           * Rotation.from_quat(rot.reshape(-1, 4))).as_rotvec().reshape(T, J, 3)
    np.testing.assert_allclose(d.rotations, ref, atol=1e-12)
    np.testing.assert_array_equal(d.moving_joints(), [2, 5, 9])
    assert not np.any(d.rotations[:, [0, 1, 3, 4, 6, 7, 8]])
    back = apply_displacement(m, d)
    np.testing.assert_allclose(np.abs(np.einsum("tjk,tjk->tj", back.rotations, rot)), 1.0, atol=1e-12)
    np.testing.assert_array_equal(back.rotations[:, 0], m.rotations[:, 0])     # untouched joints: the same bits


def test_gaussian_smoothing_by_fft_equals_scipy():
    """Long kernels (touch-up's 40-paper-frame maps are 215 taps at 120 Hz) are convolved by FFT: the same
    numbers as scipy's direct ``gaussian_filter1d`` (mode nearest) to 1e-12, zero columns left zero."""
    from scipy.ndimage import gaussian_filter1d

    from mocomp.ops.displacement import FFT_TAPS, smooth_offsets

    rng = np.random.default_rng(5)
    x = np.cumsum(rng.normal(size=(3000, 4, 3)), axis=0)
    x[:, 1] = 0.0
    for sigma in (2.0, 26.7, 400.0):
        got = smooth_offsets(x, sigma)
        np.testing.assert_allclose(got, gaussian_filter1d(x, sigma, axis=0, mode="nearest"),
                                   atol=1e-12 * np.abs(x).max())
        assert not np.any(got[:, 1])
    assert 2 * int(4.0 * 2.0 + 0.5) + 1 < FFT_TAPS < 2 * int(4.0 * 26.7 + 0.5) + 1     # both paths ran


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration=1.0, fps=60).motion


def _shift(cur, step):
    return cur.translated((0.2, 0.0, 0.0))


def test_weight_zero_frames_untouched_and_half_weight_halves(walk):
    T = walk.n_frames
    w = np.ones(T)
    w[20:30] = 0.0
    w[40:] = 0.5
    r = apply_hierarchy(walk, _shift, [HierarchyStep(0, 1.0)], weights=w)
    dx = r.motion.root_positions[:, 0] - walk.root_positions[:, 0]
    np.testing.assert_allclose(dx[20:30], 0.0, atol=1e-15)
    np.testing.assert_allclose(dx[:20], 0.2, atol=1e-12)
    np.testing.assert_allclose(dx[40:], 0.1, atol=1e-12)
    assert np.allclose(r.maps[0].root[40:, 0], 0.1)    # the map as added
    # the weight acts after the smoothing: a smoothed map still vanishes where the weight is 0
    r2 = apply_hierarchy(walk, _shift, [HierarchyStep(5, 1.0)], weights=w)
    assert np.abs(r2.motion.root_positions[20:30] - walk.root_positions[20:30]).max() < 1e-15


def test_weights_per_step_and_none_is_unweighted(walk):
    T = walk.n_frames
    w = np.zeros(T)
    sched = [HierarchyStep(0, 0.5), HierarchyStep(0, 0.5)]
    r = apply_hierarchy(walk, _shift, sched, weights=[w, None])
    np.testing.assert_allclose(r.motion.root_positions[:, 0] - walk.root_positions[:, 0], 0.1, atol=1e-12)
    base = apply_hierarchy(walk, _shift, sched)
    same = apply_hierarchy(walk, _shift, sched, weights=[None, None])
    np.testing.assert_array_equal(base.motion.root_positions, same.motion.root_positions)


def test_weight_errors(walk):
    with pytest.raises(ValueError, match="one entry per step"):
        apply_hierarchy(walk, _shift, [HierarchyStep(0, 1.0)], weights=[None, None])
    with pytest.raises(ValueError, match=r"weights of step 1: expected %d finite numbers" % walk.n_frames):
        apply_hierarchy(walk, _shift, [HierarchyStep(0, 1.0)], weights=[np.ones(3)])
    with pytest.raises(ValueError, match="per-frame weight"):
        DisplacementMap.zeros(4, 2).weighted(np.array([1.0, np.nan, 1.0, 1.0]))


def test_compiled_and_numpy_paths_agree(monkeypatch):
    """The fused compiled kernels (ops._kernels) and the numpy path agree to rounding (the same operations;
    the compiled sin/cos/atan2 may differ in the last bit)."""
    import mocomp.ops.displacement as dm
    from mocomp.core._compiled import AVAILABLE

    if not AVAILABLE:
        pytest.skip("numba not available")
    m = synthetic_walk(duration=0.5, fps=60).motion
    rng = np.random.default_rng(2)
    v = np.zeros((m.n_frames, m.skeleton.n_joints, 3))
    v[:, [1, 4, 7]] = rng.normal(scale=0.4, size=(m.n_frames, 3, 3))
    d = DisplacementMap(rng.normal(size=(m.n_frames, 3)), v)
    out = {}
    for flag in (True, False):
        monkeypatch.setattr(dm, "USE_COMPILED", flag)
        moved = apply_displacement(m, d)
        out[flag] = (moved.rotations, DisplacementMap.between(m, moved).rotations)
    np.testing.assert_allclose(out[True][0], out[False][0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[True][1], out[False][1], rtol=0, atol=1e-14)


def test_between_drops_rounding_only_joints_on_both_paths(monkeypatch):
    """A joint turned by 1e-14 rad (rounding of a local <-> world round trip) gets a zero offset, one turned
    by 1e-9 rad keeps its offset; ``negligible=0`` keeps both (exact). Same on the compiled and numpy paths."""
    import mocomp.ops.displacement as dm
    from mocomp.core.rotations import quat_exp, quat_multiply

    m = synthetic_walk(duration=0.3, fps=60).motion
    rot = np.array(m.rotations)
    rot[:, 3] = quat_multiply(rot[:, 3], quat_exp(np.array([1e-14, 0.0, 0.0])))
    rot[:, 6] = quat_multiply(rot[:, 6], quat_exp(np.array([0.0, 1e-9, 0.0])))
    other = m.replace_trusted(m.root_positions, rot)          # no renormalisation of the other joints
    for flag in (True, False):
        monkeypatch.setattr(dm, "USE_COMPILED", flag)
        assert list(DisplacementMap.between(m, other).moving_joints()) == [6]
        assert list(DisplacementMap.between(m, other, negligible=0.0).moving_joints()) == [3, 6]
