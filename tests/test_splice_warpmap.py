"""Near-optimal tube and taut-string frame map (mocomp.splice.warpmap):
known answers and brute-force references."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.errors import AlignmentError
from mocomp.splice import dtw
from mocomp.splice.warpmap import frame_map, near_optimal_tube, rasterize_map, taut_string, through_costs


def _dense_forward(C):
    n, m = C.shape
    G = np.full((n + 1, m + 1), np.inf)
    G[0, 0] = 0.0
    for i in range(n):
        for j in range(m):
            prev = 0.0 if i == 0 and j == 0 else min(G[i, j], G[i, j + 1], G[i + 1, j])
            G[i + 1, j + 1] = C[i, j] + prev
    return G[1:, 1:]


@pytest.mark.parametrize("seed", range(6))
def test_through_costs_equal_brute_force(seed):
    rng = np.random.default_rng(seed)
    n, m = rng.integers(3, 25, size=2)
    C = rng.random((n, m)) if seed % 2 else rng.integers(0, 3, size=(n, m)).astype(float)
    res = dtw(cost=C)  # full band: the dense reference applies
    F = _dense_forward(C)
    B = _dense_forward(C[::-1, ::-1])[::-1, ::-1]
    np.testing.assert_allclose(res.band.to_dense(through_costs(res)), F + B - C, rtol=1e-12, atol=1e-12)
    thr = res.band.to_dense(through_costs(res))
    assert thr.min() == pytest.approx(res.cost)
    np.testing.assert_allclose(thr[res.path[:, 0], res.path[:, 1]], res.cost)  # the optimal path is optimal through every cell


def test_through_costs_on_a_band_with_points():
    rng = np.random.default_rng(7)
    C = rng.random((40, 50))
    res = dtw(cost=C, width=6.0, points=[(15, 22, 2)])
    thr = through_costs(res)
    assert np.min(thr) == pytest.approx(res.cost)
    # brute force on the band: costs outside it are infinite
    mask = res.band.mask()
    Cb = np.where(mask, C, 1e6)
    F = _dense_forward(Cb)
    B = _dense_forward(Cb[::-1, ::-1])[::-1, ::-1]
    ref = (F + B - Cb)[mask]
    np.testing.assert_allclose(res.band.to_dense(thr)[mask], ref, rtol=1e-9)


def test_tube_spans_a_flat_block_and_is_monotone():
    """A zero-cost block (a phase in which the sign metric cannot tell frames
    apart) between costly surroundings: every cell of the block is on an
    optimal path, so the exact-tie tube is the block; the backtracked path is
    an L inside it, the taut map its diagonal."""
    n, m = 30, 20
    C = np.ones((n, m))
    C[5:25, 5:15] = 0.0  # block: 20 rows x 10 columns
    for k in range(5):  # cheap diagonal lead-in and lead-out
        C[k, k] = 0.0
        C[25 + k, 15 + k] = 0.0
    res = dtw(cost=C)
    lo, hi = near_optimal_tube(res, 0.0)
    assert np.all(np.diff(lo) >= 0) and np.all(np.diff(hi) >= 0)
    np.testing.assert_array_equal(lo[5:25], 5)
    np.testing.assert_array_equal(hi[5:25], 14)
    np.testing.assert_array_equal(lo[:5], np.arange(5))
    s, _ = frame_map(res, 0.0)
    # the taut string runs straight across the block, from its first cell (5, 5) to its last (24, 14)
    np.testing.assert_allclose(s[5:25], 5 + 9 * np.arange(20) / 19, atol=1e-12)
    np.testing.assert_allclose(s[:5], np.arange(5), atol=1e-12)
    # the optimal path itself is an L (all steps of one kind grouped), far from that diagonal
    assert np.max(np.abs(res.row_median()[5:25] - s[5:25])) > 3


def test_taut_string_known_answers():
    # a wide tube: the straight line between the ends
    np.testing.assert_allclose(taut_string(np.zeros(5), np.full(5, 10.0), 0.0, 8.0), [0, 2, 4, 6, 8])
    # a ceiling at x = 1 forces a bend there: (0,0) -> (1,0.5) -> (4,4)
    lo = np.array([0.0, 0, 0, 0, 4])
    hi = np.array([0.0, 0.5, 4, 4, 4])
    np.testing.assert_allclose(taut_string(lo, hi), [0, 0.5, 0.5 + 3.5 / 3, 0.5 + 7 / 3, 4])
    # a floor: bends upwards around (2, 3)
    lo = np.array([0.0, 0, 3, 3, 3])
    hi = np.array([0.0, 9, 9, 9, 3])
    np.testing.assert_allclose(taut_string(lo, hi), [0, 1.5, 3, 3, 3])
    # a one-cell tube is the tube itself
    y = np.array([0.0, 1, 1, 2, 5, 6])
    np.testing.assert_allclose(taut_string(y, y), y)
    assert taut_string([2.0], [4.0])[0] == 3.0


def test_taut_string_is_shortest_among_feasible_curves():
    rng = np.random.default_rng(3)
    n = 60
    c = np.cumsum(rng.uniform(0, 2, n))
    lo, hi = c - rng.uniform(0, 3, n), c + rng.uniform(0, 3, n)
    lo[0] = hi[0] = 0.5 * (lo[0] + hi[0])
    lo[-1] = hi[-1] = 0.5 * (lo[-1] + hi[-1])
    s = taut_string(lo, hi)
    assert np.all(s >= lo - 1e-9) and np.all(s <= hi + 1e-9)
    length = lambda y: np.sum(np.hypot(1.0, np.diff(y)))
    for _ in range(200):  # random feasible perturbations are never shorter
        t = np.clip(s + rng.normal(scale=0.3, size=n) * (rng.random(n) < 0.2), lo, hi)
        assert length(t) >= length(s) - 1e-9


def test_rasterize_map():
    s = np.array([0.0, 0.4, 0.8, 2.0, 4.0, 5.0])
    path = rasterize_map(s, 6)
    np.testing.assert_array_equal(path, [[0, 0], [1, 0], [2, 1], [3, 2], [3, 3], [4, 4], [5, 5]])
    # every column is matched once a map never stalls over several columns
    s = np.linspace(0, 30, 10)
    p = rasterize_map(s, 31)
    np.testing.assert_array_equal(np.unique(p[:, 1]), np.arange(31))
    assert np.all(np.diff(p[:, 0]) >= 0) and np.all(np.diff(p[:, 1]) >= 0)
    # bounds clip a row to a window
    lo = np.zeros(10, dtype=int)
    hi = np.full(10, 30)
    lo[5], hi[5] = 17, 17
    p = rasterize_map(s, 31, lo, hi)
    np.testing.assert_array_equal(p[p[:, 0] == 5, 1], [17])
    with pytest.raises(AlignmentError, match="non-decreasing"):
        rasterize_map(np.array([0.0, 2.0, 1.0]), 3)
    with pytest.raises(AlignmentError, match="inside the tube"):
        taut_string([0.0, 0.0], [1.0, 1.0], 2.0, 0.5)
    with pytest.raises(AlignmentError, match="non-negative"):
        near_optimal_tube(dtw(cost=np.ones((3, 3))), -0.1)
