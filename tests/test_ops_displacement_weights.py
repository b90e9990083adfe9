"""ops.displacement: the per-frame weight of a hierarchical displacement map (touch-up keeps its
ground maps off the flights, Shin et al. 2003 Fig. 4) and the elementwise log/exp maps."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.ops import DisplacementMap, HierarchyStep, apply_hierarchy
from mocomp.ops.displacement import _exp, _log
from mocomp.ops.synthetic import synthetic_walk


def test_log_exp_equal_scipy():
    r = Rotation.random(5000, random_state=3)
    q = r.as_quat()
    q[::3] *= -1                                       # either sign of a quaternion: one rotation
    np.testing.assert_allclose(_log(q), Rotation.from_quat(q).as_rotvec(), atol=1e-12)
    v = r.as_rotvec()
    v[:50] *= 1e-9                                     # the small-angle series
    v[50:60] = 0.0
    e = _exp(v)
    ref = Rotation.from_rotvec(v).as_quat()
    np.testing.assert_allclose(np.abs(np.einsum("nk,nk->n", e, ref)), 1.0, atol=1e-12)
    np.testing.assert_allclose(_log(e), v, atol=1e-12)
    assert _log(q.reshape(50, 100, 4)).shape == (50, 100, 3)


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
