"""The compiled banded-DTW kernels (mocomp.splice.dtw) against a plain dense
recurrence on arbitrary row ranges, including rows the run-split fast path
does not take, and the deferred input checks of the feature path."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from mocomp.errors import AlignmentError
from mocomp.splice import Band, dtw, slanted_band
from mocomp.splice.dtw import dtw_band_costs, feature_band_costs


def dense_reference(C: np.ndarray, mask: np.ndarray):
    """Eq. 6.1-6.2 on the cells of ``mask``: cumulative costs (inf outside or
    unreachable) and step codes (dtw-python's order: diagonal, (i, j-1), (i-1, j))."""
    n, m = C.shape
    G = np.full((n, m), np.inf)
    S = np.full((n, m), -1, dtype=int)
    for i in range(n):
        for j in range(m):
            if not mask[i, j]:
                continue
            if i == 0 and j == 0:
                G[0, 0], S[0, 0] = C[0, 0], 0
                continue
            best = np.inf
            for code, (a, b) in ((1, (i - 1, j - 1)), (2, (i, j - 1)), (3, (i - 1, j))):
                if a >= 0 and b >= 0 and G[a, b] + C[i, j] < best:
                    best, S[i, j] = G[a, b] + C[i, j], code
            G[i, j] = best
    return G, S


def check_band(C, band):
    res = dtw_band_costs(band, C[band.cell_indices()])
    G, S = dense_reference(C, band.mask())
    r, c = band.cell_indices()
    np.testing.assert_array_equal(res.cumulative, G[r, c])  # bit for bit, inf where unreachable
    np.testing.assert_array_equal(res.steps, S[r, c])
    return res


@pytest.mark.parametrize("seed", range(10))
def test_arbitrary_row_ranges_equal_dense_recurrence(seed):
    """Custom bands whose rows move left, jump, or are unreachable (the general
    row path) and pruned bands (the run-split path), with many ties."""
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(2, 40)), int(rng.integers(2, 40))
    lo = rng.integers(0, m, size=n)
    hi = np.minimum(lo + rng.integers(0, 12, size=n), m - 1)
    lo[0], hi[-1] = 0, m - 1
    lo[-1] = min(lo[-1], hi[-1])
    hi[0] = max(hi[0], lo[0])
    C = rng.integers(0, 3, size=(n, m)).astype(float) if seed % 2 else rng.random((n, m))
    band = Band(n, m, lo, hi)
    G, _ = dense_reference(C, band.mask())
    if np.isfinite(G[-1, -1]):
        check_band(C, band)
    else:
        with pytest.raises(AlignmentError, match="no path"):
            check_band(C, band)
    radius = float(rng.uniform(1.0, 10.0)) + abs(m - n)
    check_band(C, slanted_band(n, m, radius=radius))


def test_every_row_shape_against_its_predecessor():
    """Rows starting at, inside and one past the previous row's span, ending
    at or past it (the run boundaries of the fast path), all reachable."""
    rng = np.random.default_rng(7)
    lo = np.array([0, 0, 2, 3, 3, 8, 8, 9, 12, 13])
    hi = np.array([2, 3, 4, 7, 8, 8, 11, 12, 13, 14])
    n, m = len(lo), 15
    for C in (rng.random((n, m)), np.ones((n, m)), rng.integers(0, 2, size=(n, m)).astype(float)):
        res = check_band(C, Band(n, m, lo, hi))
        assert np.isfinite(res.cost)
    # unpruned rows that start left of the previous row or end before it (the general path)
    lo = np.array([0, 0, 1, 0, 2, 1, 4, 3, 5])
    hi = np.array([3, 2, 5, 6, 6, 8, 7, 9, 9])
    n, m = len(lo), 10
    for C in (rng.random((n, m)), np.ones((n, m)), rng.integers(0, 2, size=(n, m)).astype(float)):
        res = check_band(C, Band(n, m, lo, hi))
        assert np.isfinite(res.cost) and np.isinf(res.cumulative).any()  # some cells unreachable


@pytest.mark.parametrize("d", [1, 3, 4, 7, 20, 61])
def test_squared_euclidean_is_cdist(d):
    # to 1e-12, not bit for bit: scipy's C loop and the compiled kernel are different code, and a
    # compiler may contract d * d + s into an FMA on one host and not on another
    rng = np.random.default_rng(d)
    a, b = rng.normal(size=(90, d)) * 10, rng.normal(size=(110, d)) * 10
    band = slanted_band(90, 110, radius=15)
    r, c = band.cell_indices()
    np.testing.assert_allclose(feature_band_costs(a, b, band), cdist(a, b, "sqeuclidean")[r, c], rtol=1e-12, atol=0)
    np.testing.assert_allclose(feature_band_costs(a[:, 0], b[:, 0], band), cdist(a[:, :1], b[:, :1], "sqeuclidean")[r, c],
                               rtol=1e-12, atol=0)


def test_non_finite_features_and_overflow_are_named():
    x, y = np.zeros((30, 5)), np.ones((40, 5))
    y[17, 2] = np.inf
    with pytest.raises(AlignmentError, match="second sequence has a non-finite value at frame 17"):
        dtw(x, y, radius=20)
    x[4, 0] = np.nan
    with pytest.raises(AlignmentError, match="first sequence has a non-finite value at frame 4"):
        feature_band_costs(x, y, slanted_band(30, 40, radius=20))
    big = np.full((30, 5), 1e200)
    with pytest.raises(AlignmentError, match=r"local cost is inf at cell \(0, 0\)"):
        dtw(big, -np.ones((40, 5)) * 1e200, radius=20)
    # the cdist metrics check their inputs up front
    with pytest.raises(AlignmentError, match="frame 4"):
        dtw(x, np.ones((40, 5)), radius=20, metric="cityblock")


def test_band_arrays_are_private_and_read_only():
    lo = np.array([0, 0, 1], dtype=np.int64)
    hi = np.array([1, 2, 2], dtype=np.int64)
    band = Band(3, 3, lo, hi)
    lo[1] = 2  # the caller's array is copied
    assert band.lo[1] == 0
    assert not band.lo.flags.writeable and not band.raw_hi.flags.writeable
    built = slanted_band(50, 60, radius=5)
    for a in (built.lo, built.hi, built.raw_lo, built.raw_hi):
        assert not a.flags.writeable
