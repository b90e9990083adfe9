"""The Motion-Graph baseline of issue 17 (Kovar et al. 2002's point-cloud distance, closed-form 2-D
alignment): known answers and the paper's argument (the baseline stops between the actions)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from mocomp import datasets
from mocomp.concat import concatenate, momentum_track, motion_graph_concatenate, point_cloud_table
from mocomp.ops.align import yaw_quaternion


@pytest.fixture(scope="module")
def flip():
    return datasets.load("backflip")


def test_point_cloud_distance_recovers_a_rigid_ground_transform(flip):
    b = flip.rotated(yaw_quaternion(0.7)).translated([1.0, 0.0, 2.0])
    tab = point_cloud_table(flip, b, 10)
    i = 150
    assert tab.D[i, i] == pytest.approx(0.0, abs=1e-10)
    assert tab.theta[i, i] == pytest.approx(-0.7, abs=1e-9)
    moved = tab.transform(i, i).apply(b)
    np.testing.assert_allclose(moved.positions[i:i + 10], flip.positions[i:i + 10], atol=1e-9)
    assert tab.D[i].min() == pytest.approx(0.0, abs=1e-10) and tab.D[i, i + 20] > 1e-3


def test_point_cloud_distance_equals_the_direct_sum(flip):
    a, b = flip[100:140], flip.rotated(yaw_quaternion(-1.2))[60:100]
    k = 5
    tab = point_cloud_table(a, b, k)
    for i, j in [(0, 0), (7, 30), (35, 3)]:
        moved = tab.transform(i, j).apply(b).positions[j:j + k]
        direct = np.mean(np.sum((a.positions[i:i + k] - moved) ** 2, axis=-1))
        assert tab.D[i, j] == pytest.approx(direct, rel=1e-7, abs=1e-12)
        # no other turn about the vertical does better (the closed form is the optimum)
        for dth in (-0.05, 0.05):
            from mocomp.ops import GroundTransform

            t = tab.transform(i, j)
            tb = GroundTransform(t.yaw + dth, (0.0, 0.0, 0.0), t.shift).apply(b).positions[j:j + k]
            ca, cb = a.positions[i:i + k].reshape(-1, 3), tb.reshape(-1, 3)
            off = ca.mean(0) - cb.mean(0)
            off[1] = 0.0
            assert np.mean(np.sum((ca - cb - off) ** 2, axis=-1)) > tab.D[i, j]


def test_baseline_stops_between_the_flips_ours_does_not(flip):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = concatenate(flip, flip)
        base = motion_graph_concatenate(flip, flip, r.phases, r.baseline_window)
    tr = base.transition
    assert tr.i >= r.phases[0].main[1] and tr.j + tr.window <= r.phases[1].main[0]
    assert r.motion.n_frames < base.motion.n_frames
    level = r.L_reference
    L = momentum_track(r.motion).magnitude
    sh = r.T + r.window_frames_out - (r.window[1] - r.window[0] + 1)
    ours = L[r.phases[0].t_m:r.phases[1].t_m + sh + 1].min()
    Lb = momentum_track(base.motion).magnitude
    theirs = Lb[r.phases[0].t_m:r.phases[1].t_m + tr.i - tr.j + 1].min()
    assert ours > 0.3 * level and theirs < 0.05 * level


def test_motion_graph_window_shortened_to_fit(real_data_dir):
    """The DeepMimic punch's main phase reaches the clip's end (peak at frame 57 of 65): a 12-frame
    window cannot follow A's peak; the longest that fits (8 frames) is used, and said."""
    from mocomp import datasets as ds
    from mocomp.concat import concatenate, motion_graph_concatenate

    m = ds.load(str(real_data_dir / "kicks_punches/deepmimic_punch.txt"))
    r = concatenate(m, m, plant=False)
    mg = motion_graph_concatenate(m, m, r.phases, 12, plant=False)
    assert mg.transition.window == min(r.phases[1].t_m, m.n_frames - r.phases[0].t_m) == 8
    assert "window shortened from 12 to 8 frames" in mg.transition.constraint
    assert mg.motion.n_frames == mg.transition.i - mg.transition.j + m.n_frames
