"""Banded DTW (dissertation eq. 6.1-6.5, Algorithm 1): cross-checks against
dtw-python (GPL; imported here only, never by the library), a plain
reference recurrence, and known answers."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from mocomp.errors import AlignmentError
from mocomp.splice import MatchPoint, dtw, full_band, matching_band, slanted_band
from mocomp.splice.dtw import dtw_band_costs, feature_band_costs, path_row_median

dtwpy = pytest.importorskip("dtw")  # dtw-python

from conftest import real_files  # noqa: E402


def reference_dtw(C: np.ndarray, mask: np.ndarray):
    """Plain eq. 6.1-6.2 on the cells of ``mask`` (inf elsewhere), dtw-python's
    tie order (diagonal, (i, j-1), (i-1, j)); returns cost and path."""
    n, m = C.shape
    G = np.full((n, m), np.inf)
    S = np.zeros((n, m), dtype=int)
    for i in range(n):
        for j in range(m):
            if not mask[i, j]:
                continue
            if i == 0 and j == 0:
                G[0, 0] = C[0, 0]
                continue
            best, s = np.inf, 0
            for code, (a, b) in ((1, (i - 1, j - 1)), (2, (i, j - 1)), (3, (i - 1, j))):
                if a >= 0 and b >= 0 and G[a, b] + C[i, j] < best:
                    best, s = G[a, b] + C[i, j], code
            G[i, j], S[i, j] = best, s
    path = [(n - 1, m - 1)]
    i, j = n - 1, m - 1
    while (i, j) != (0, 0):
        s = S[i, j]
        i, j = {1: (i - 1, j - 1), 2: (i, j - 1), 3: (i - 1, j)}[s]
        path.append((i, j))
    return G[-1, -1], np.array(path[::-1])


def dtwpy_align(C, radius=None):
    kw = {} if radius is None else {"window_type": "slantedband", "window_args": {"window_size": radius}}
    return dtwpy.dtw(C, step_pattern=dtwpy.symmetric1, **kw)


def assert_same_as_dtwpy(C, ours, radius=None):
    ref = dtwpy_align(C, radius)
    assert ours.cost == pytest.approx(ref.distance, rel=1e-12, abs=1e-12)
    np.testing.assert_array_equal(ours.path[:, 0], ref.index1)
    np.testing.assert_array_equal(ours.path[:, 1], ref.index2)


# ------------------------------------------------------------------ dtw-python
@pytest.mark.parametrize("seed", range(12))
def test_unconstrained_equals_dtw_python_random(seed):
    rng = np.random.default_rng(seed)
    n, m = rng.integers(2, 70, size=2)
    C = rng.random((n, m)) if seed % 2 else rng.integers(0, 4, size=(n, m)).astype(float)  # integer costs: many ties
    assert_same_as_dtwpy(C, dtw(cost=C))


@pytest.mark.parametrize("seed", range(12))
def test_slanted_band_equals_dtw_python_random(seed):
    rng = np.random.default_rng(100 + seed)
    n, m = rng.integers(5, 80, size=2)
    radius = float(rng.uniform(1.0, 0.5 * max(n, m)))
    radius = max(radius, abs(m - n) / min(n, m) + 1.0)  # wide enough for a path
    C = rng.random((n, m)) if seed % 2 else rng.integers(0, 3, size=(n, m)).astype(float)
    res = dtw(cost=C, radius=radius)
    assert_same_as_dtwpy(C, res, radius)
    # the band is exactly dtw-python's window (before pruning)
    ii, jj = np.indices((n, m))
    win = dtwpy.window.slantedBandWindow(ii, jj, n, m, radius)
    j = np.arange(m)[None, :]
    np.testing.assert_array_equal((j >= res.band.raw_lo[:, None]) & (j <= res.band.raw_hi[:, None]), win)
    assert np.all(res.band.mask() <= win)  # pruning only removes cells


def test_feature_sequences_equal_dtw_python():
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(90, 6)), rng.normal(size=(110, 6))
    for metric in ("sqeuclidean", "euclidean", "cityblock"):
        C = cdist(a, b, metric)
        assert_same_as_dtwpy(C, dtw(a, b, metric=metric), None)
        assert_same_as_dtwpy(C, dtw(a, b, metric=metric, radius=25), 25)


@pytest.mark.parametrize("path", real_files("hands/bandai2_wave-*.bvh")[:2], ids=lambda p: p.name)
def test_real_inputs_equal_dtw_python(path, real_data_dir):
    """Real costs: the eq. 6.6 sign metric (integer-valued: exact ties) and the
    eq. 6.9 hand angle between a real gesture clip and a warped copy of it."""
    from mocomp.io import read_bvh
    from mocomp.splice import virtual_hand_markers
    from mocomp.splice.metrics import angle_band_costs, arm_features, sign_band_costs
    from mocomp.splice.synthetic import make_splice_pair

    hand = read_bvh(path)
    walk = read_bvh(real_data_dir / "walks" / "bandai2_walk_normal_001.bvh")
    side = "left" if "left" in path.name else "right"
    pair = make_splice_pair(hand, walk, 3, side=side)
    fb = arm_features(virtual_hand_markers(pair.body, side))
    fh = arm_features(virtual_hand_markers(pair.hand, side))
    full = full_band(fb.n_frames, fh.n_frames)
    for C in (full.to_dense(sign_band_costs(fb, fh, full)),
              full.to_dense(angle_band_costs(fb.forearm, fb.hand, fh.forearm, fh.hand, full))):
        assert_same_as_dtwpy(C, dtw(cost=C))
        r = 0.3 * np.hypot(*C.shape)
        assert_same_as_dtwpy(C, dtw(cost=C, radius=r), r)


# ----------------------------------------------------------- reference + bands
@pytest.mark.parametrize("seed", range(6))
def test_matching_band_equals_reference_recurrence(seed):
    rng = np.random.default_rng(200 + seed)
    n, m = int(rng.integers(30, 60)), int(rng.integers(30, 60))
    C = rng.random((n, m))
    xs = np.sort(rng.choice(np.arange(3, n - 3), size=2, replace=False))
    ys = np.sort(rng.choice(np.arange(3, m - 3), size=2, replace=False))
    pts = [MatchPoint(int(xs[0]), int(ys[0]), 0), MatchPoint(int(xs[1]), int(ys[1]), int(rng.integers(0, 3)))]
    band = matching_band(n, m, 8.0, pts)
    res = dtw(cost=C, band=band)
    cost, path = reference_dtw(C, band.mask())
    assert res.cost == pytest.approx(cost, rel=1e-12)
    np.testing.assert_array_equal(res.path, path)
    # unpruned raw band gives the same optimum (pruning is exact)
    raw = (np.arange(m)[None, :] >= band.raw_lo[:, None]) & (np.arange(m)[None, :] <= band.raw_hi[:, None])
    cost_raw, path_raw = reference_dtw(C, raw)
    assert cost_raw == pytest.approx(cost, rel=1e-12)
    np.testing.assert_array_equal(path_raw, path)


def test_exact_point_is_on_path_and_tolerance_is_respected():
    rng = np.random.default_rng(3)
    C = rng.random((120, 100))
    free = dtw(cost=C, width=20)
    # choose points the free path does not take
    p1 = MatchPoint(40, int(free.row_median()[40]) + 15, 0)
    p2 = MatchPoint(80, int(free.row_median()[80]) - 12, 3)
    res = dtw(cost=C, width=20, points=[p1, p2])
    assert p1.y not in free.matches(p1.x)
    np.testing.assert_array_equal(res.matches(p1.x), [p1.y])  # exactly through (x1, y1), nothing else in row x1
    js = res.matches(p2.x)
    assert np.all(np.abs(js - p2.y) <= p2.tol)
    assert res.cost >= free.cost  # constraints cannot lower the optimum


def test_known_answers():
    x = np.sin(np.linspace(0, 3, 50))[:, None] + np.linspace(0, 1, 50)[:, None]  # strictly increasing
    r = dtw(x, x, width=5)
    assert r.cost == 0.0
    np.testing.assert_array_equal(r.path, np.stack([np.arange(50)] * 2, axis=1))
    # y repeats every 3rd frame of x twice: the path must undo exactly that
    idx = np.sort(np.concatenate([np.arange(50), np.arange(0, 50, 3)]))
    y = x[idx]
    r = dtw(x, y)
    assert r.cost == 0.0
    np.testing.assert_array_equal(r.path[:, 1], np.arange(len(idx)))
    np.testing.assert_array_equal(r.path[:, 0], idx)
    np.testing.assert_allclose(path_row_median(r.path, 50),
                               [np.median(np.nonzero(idx == i)[0]) for i in range(50)])
    assert r.step_counts() == {"diagonal": 49, "horizontal": len(idx) - 50, "vertical": 0}


def test_band_storage_is_proportional_to_band_not_matrix():
    n, m = 1000, 1200
    band = slanted_band(n, m, radius=120)
    assert band.cells <= n * (2 * 120 + 1)
    assert band.cells < 0.25 * n * m
    x = np.random.default_rng(0).normal(size=(n, 4))
    y = np.random.default_rng(1).normal(size=(m, 4))
    r = dtw(x, y, band=band)
    for a in (r.local_cost, r.cumulative, r.steps):
        assert a.shape == (band.cells,)


def test_feature_costs_equal_cdist_on_band():
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(200, 60)), rng.normal(size=(230, 60))
    band = slanted_band(200, 230, width=30)
    r, c = band.cell_indices()
    for metric in ("sqeuclidean", "euclidean", "cosine"):
        np.testing.assert_allclose(feature_band_costs(a, b, band, metric), cdist(a, b, metric)[r, c], rtol=1e-9, atol=1e-9)


def test_callable_cost():
    rng = np.random.default_rng(9)
    C = rng.random((40, 35))
    res = dtw(cost=lambda i, j: C[i, j], shape=(40, 35), width=6)
    ref = dtw(cost=C, width=6)
    assert res.cost == ref.cost
    np.testing.assert_array_equal(res.path, ref.path)


def test_bad_input():
    C = np.ones((10, 12))
    C[3, 4] = np.nan
    with pytest.raises(AlignmentError, match=r"\(3, 4\)"):
        dtw(cost=C)
    with pytest.raises(AlignmentError, match="non-finite"):
        dtw(np.full((5, 2), np.nan), np.zeros((6, 2)))
    with pytest.raises(AlignmentError, match="dimensions differ"):
        dtw(np.zeros((5, 2)), np.zeros((6, 3)))
    with pytest.raises(AlignmentError, match="width"):
        dtw(cost=np.ones((5, 5)), points=[(2, 2)])
    with pytest.raises(AlignmentError, match="too short|too narrow"):  # 40x4 with a thin band: rows without cells
        dtw(cost=np.ones((40, 4)), radius=0.2)
    with pytest.raises(AlignmentError, match="both"):
        dtw(np.zeros((5, 1)), np.zeros((5, 1)), band=full_band(5, 5), width=2)
    with pytest.raises(AlignmentError, match="5x5"):
        dtw(cost=np.ones((5, 6)), band=full_band(5, 5))
