"""Dynamic time warping on a band (dissertation eq. 6.1-6.5, Algorithm 1).

The cumulative cost follows eq. 6.1-6.2,

    gamma(i, j) = D(p_i, q_j) + min(gamma(i-1, j-1), gamma(i, j-1), gamma(i-1, j)),

with ``gamma(0, 0) = D(p_0, q_0)``: diagonal, horizontal and vertical steps of
weight 1 (dtw-python's ``symmetric1`` step pattern). Only the cells of a
:class:`~mocomp.splice.bands.Band` are computed and stored, in flat arrays of
``band.cells`` entries (memory O(n x band width)). The recurrence and the
backtracking run in compiled loops (numba), as does the squared-Euclidean
local cost of feature sequences on the band cells.

Ties are broken exactly as dtw-python does (the first minimum in the order
diagonal, horizontal ``(i, j-1)``, vertical ``(i-1, j)``, comparing the sums
``gamma + D``), so paths agree step for step with it (tested).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial.distance import cdist

from ..core._compiled import njit
from ..errors import AlignmentError
from .bands import Band, _as_band

__all__ = ["DTWResult", "dtw", "dtw_band_costs", "band_costs", "feature_band_costs", "warp_values"]

#: step codes stored per cell
STEP_START, STEP_DIAGONAL, STEP_HORIZONTAL, STEP_VERTICAL, STEP_NONE = 0, 1, 2, 3, -1


@njit(inline="always")
def _row_general(c, g, st, gamma, off, lo, hi, i, l, w):  # pragma: no cover - compiled
    """One row of any shape (rows of custom, unpruned bands)."""
    inf = np.inf
    lp = lo[i - 1] if i > 0 else 0
    wp = hi[i - 1] - lp + 1 if i > 0 else 0
    left = inf
    for t in range(w):
        d = c[t]
        p = t + l - lp  # previous-row position of column j = l + t
        a = gamma[off[i - 1] + p - 1] + d if i > 0 and 1 <= p <= wp else inf
        v = gamma[off[i - 1] + p] + d if i > 0 and 0 <= p < wp else inf
        h = left + d
        if i == 0 and l + t == 0:
            a = d  # the start cell: gamma(0, 0) = D(0, 0)
        left = min(min(a, v), h)
        g[t] = left
        s = np.int8(3)
        s = np.int8(2) if h == left else s
        s = np.int8(1) if a == left else s
        st[t] = s if left < inf else np.int8(-1)
    if i == 0 and l == 0:
        st[0] = 0


@njit(inline="always")
def _row_monotone(c, g, st, gp, l, w, lp, wp):  # pragma: no cover - compiled
    """One row ``i > 0`` whose previous row ``gp`` spans columns ``lp..hp``
    with ``lp <= l <= hp + 1 <= h + 1`` (every pruned band): the row split
    into column runs with a fixed set of predecessors, so the loops carry no
    branches and no negative indices."""
    inf = np.inf
    hp = lp + wp - 1
    left = inf
    t = 0
    if l == lp:  # first column: only the vertical predecessor (i-1, l)
        left = gp[0] + c[0]
        g[0] = left
        st[0] = np.int8(3) if left < inf else np.int8(-1)
        t = 1
    nb = hp - l + 1 - t  # columns l+t..hp: diagonal and vertical predecessors
    if nb > 0:
        cs = c[t:t + nb]
        gs = g[t:t + nb]
        ss = st[t:t + nb]
        dg = gp[l + t - 1 - lp:l + t - 1 - lp + nb]
        vg = gp[l + t - lp:l + t - lp + nb]
        for u in range(nb):
            d = cs[u]
            a = dg[u] + d
            h = left + d
            left = min(min(a, vg[u] + d), h)
            gs[u] = left
            # off the serial path: the first of diagonal, horizontal, vertical attaining the minimum
            s = np.int8(3)
            s = np.int8(2) if h == left else s
            s = np.int8(1) if a == left else s
            ss[u] = s if left < inf else np.int8(-1)
        t += nb
    if t < w:  # column hp+1: only the diagonal predecessor (i-1, hp)
        d = c[t]
        a = gp[wp - 1] + d
        h = left + d
        left = min(a, h)
        g[t] = left
        st[t] = np.int8(-1) if not left < inf else (np.int8(1) if a == left else np.int8(2))
        t += 1
    if t < w:  # columns beyond hp+1: horizontal steps only
        cs = c[t:w]
        gs = g[t:w]
        ss = st[t:w]
        for u in range(w - t):
            left = left + cs[u]
            gs[u] = left
            ss[u] = np.int8(2) if left < inf else np.int8(-1)


@njit
def _accumulate(cost, lo, hi, off, gamma, step):  # pragma: no cover - compiled
    """Eq. 6.1-6.2 on the band cells, row by row, and the step into each cell.

    In each row the horizontal chain ``gamma(i, j) = min(diag, vert,
    gamma(i, j-1) + D)`` is the only serial dependency; it runs branch-free
    over column runs with a fixed set of predecessors (:func:`_row_monotone`;
    rows of other shapes go through :func:`_row_general`). The step code
    (computed off the serial path) is the first of diagonal, horizontal,
    vertical whose sum equals the minimum, i.e. exactly dtw-python's strict
    ``<`` scan in that order. Row slices and ``range`` indices keep numba's
    negative-index wraparound out of the loops.
    """
    n = lo.shape[0]
    for i in range(n):
        l = lo[i]
        w = hi[i] - l + 1
        if w <= 0:
            continue
        c = cost[off[i]:off[i] + w]
        g = gamma[off[i]:off[i] + w]
        st = step[off[i]:off[i] + w]
        mono = False
        if i > 0:
            lp = lo[i - 1]
            wp = hi[i - 1] - lp + 1
            mono = wp > 0 and lp <= l <= lp + wp and lp + wp <= l + w
        if mono:
            _row_monotone(c, g, st, gamma[off[i - 1]:off[i - 1] + wp], l, w, lp, wp)
        else:
            _row_general(c, g, st, gamma, off, lo, hi, i, l, w)


@njit
def _backtrack(lo, off, step, n, m):  # pragma: no cover - compiled
    out = np.empty((n + m - 1, 2), dtype=np.int64)
    i = n - 1
    j = m - 1
    K = 0
    while True:
        out[K, 0] = i
        out[K, 1] = j
        K += 1
        if i == 0 and j == 0:
            break
        s = step[off[i] + j - lo[i]]
        if s == 1:
            i -= 1
            j -= 1
        elif s == 2:
            j -= 1
        elif s == 3:
            i -= 1
        else:
            return out[:0]
    return out[:K][::-1].copy()


@njit
def _sqeuclidean_band(lo, hi, off, x, yT, out):  # pragma: no cover - compiled
    """Squared Euclidean distances of the band cells; ``yT`` is the second
    sequence transposed, ``(d, m)`` C-contiguous, so the inner loops run over
    a row's contiguous columns (vectorised across cells, not across the few
    feature dimensions), eight, four, then one feature at a time. Each cell's
    sum is accumulated in feature order ``((u_0^2 + u_1^2) + u_2^2) + ...``
    without fused multiply-adds, exactly as :func:`scipy.spatial.distance.cdist`
    ``"sqeuclidean"`` does (tested bit for bit).
    Returns the number of cells whose cost is not finite (an overflow or a
    non-finite feature; an integer count, so the check vectorises too)."""
    d = x.shape[1]
    d8 = d - d % 8
    d4 = d - d % 4
    bad = 0
    inf = np.inf
    for i in range(lo.shape[0]):
        l = lo[i]
        w = hi[i] - l + 1
        o = out[off[i]:off[i] + w]
        o[:] = 0.0
        for k in range(0, d8, 8):
            x0, x1, x2, x3 = x[i, k], x[i, k + 1], x[i, k + 2], x[i, k + 3]
            x4, x5, x6, x7 = x[i, k + 4], x[i, k + 5], x[i, k + 6], x[i, k + 7]
            y0, y1, y2, y3 = yT[k, l:l + w], yT[k + 1, l:l + w], yT[k + 2, l:l + w], yT[k + 3, l:l + w]
            y4, y5, y6, y7 = yT[k + 4, l:l + w], yT[k + 5, l:l + w], yT[k + 6, l:l + w], yT[k + 7, l:l + w]
            for t in range(w):
                u0, u1, u2, u3 = y0[t] - x0, y1[t] - x1, y2[t] - x2, y3[t] - x3
                u4, u5, u6, u7 = y4[t] - x4, y5[t] - x5, y6[t] - x6, y7[t] - x7
                o[t] = (((((((o[t] + u0 * u0) + u1 * u1) + u2 * u2) + u3 * u3) + u4 * u4) + u5 * u5)
                        + u6 * u6) + u7 * u7
        for k in range(d8, d4, 4):
            x0, x1, x2, x3 = x[i, k], x[i, k + 1], x[i, k + 2], x[i, k + 3]
            y0, y1, y2, y3 = yT[k, l:l + w], yT[k + 1, l:l + w], yT[k + 2, l:l + w], yT[k + 3, l:l + w]
            for t in range(w):
                u0, u1, u2, u3 = y0[t] - x0, y1[t] - x1, y2[t] - x2, y3[t] - x3
                o[t] = (((o[t] + u0 * u0) + u1 * u1) + u2 * u2) + u3 * u3
        for k in range(d4, d):
            xk = x[i, k]
            yk = yT[k, l:l + w]
            for t in range(w):
                u = yk[t] - xk
                o[t] += u * u
        for t in range(w):
            bad += 0 if o[t] < inf else 1
    return bad


@dataclass(frozen=True, eq=False)
class DTWResult:
    """An optimal monotone alignment of two sequences inside a band.

    Attributes
    ----------
    path: ``(K, 2)`` int64 matched frame pairs ``(i, j)`` from ``(0, 0)`` to
        ``(n-1, m-1)``, each step diagonal, horizontal or vertical.
    cost: total cost ``gamma(n-1, m-1)`` (sum of the local costs along the path).
    band: the :class:`~mocomp.splice.bands.Band` searched.
    local_cost: ``(band.cells,)`` local costs ``D`` of the band cells (flat).
    cumulative: ``(band.cells,)`` cumulative costs ``gamma`` (``inf`` where unreachable).
    steps: ``(band.cells,)`` int8 step into each cell: 1 diagonal, 2 horizontal,
        3 vertical, 0 the start cell, -1 unreachable.
    timings: seconds spent per stage (``cost``, ``recurrence``, ``backtrack``).
    """

    path: np.ndarray
    cost: float
    band: Band
    local_cost: np.ndarray
    cumulative: np.ndarray
    steps: np.ndarray
    timings: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return self.band.n

    @property
    def m(self) -> int:
        return self.band.m

    @property
    def normalized_cost(self) -> float:
        """Cost per matched pair, ``cost / len(path)``."""
        return self.cost / len(self.path)

    def step_counts(self) -> dict:
        """How many diagonal, horizontal and vertical steps the path takes."""
        d = np.diff(self.path, axis=0)
        return {
            "diagonal": int(np.sum((d[:, 0] == 1) & (d[:, 1] == 1))),
            "horizontal": int(np.sum((d[:, 0] == 0) & (d[:, 1] == 1))),
            "vertical": int(np.sum((d[:, 0] == 1) & (d[:, 1] == 0))),
        }

    def matches(self, i: int) -> np.ndarray:
        """Columns ``j`` matched to row ``i``."""
        return self.path[self.path[:, 0] == i, 1]

    def row_median(self) -> np.ndarray:
        """``(n,)`` median of the columns matched to each row (a frame map p -> q)."""
        return path_row_median(self.path, self.n)

    def col_median(self) -> np.ndarray:
        """``(m,)`` median of the rows matched to each column (a frame map q -> p)."""
        return path_row_median(self.path[:, ::-1], self.m)

    def dense(self, which: str = "local") -> np.ndarray:
        """Dense ``(n, m)`` copy of ``local`` or ``cumulative`` costs, NaN outside the band (plots only)."""
        vals = {"local": self.local_cost, "cumulative": self.cumulative}[which]
        return self.band.to_dense(vals)

    def __repr__(self) -> str:
        return f"DTWResult({self.n}x{self.m}, cost={self.cost:.6g}, path {len(self.path)} steps, {self.band!r})"


def path_row_median(path: np.ndarray, n: int) -> np.ndarray:
    """``(n,)`` median column matched to each row of a monotone path covering rows ``0..n-1``."""
    path = np.asarray(path)
    rows = path[:, 0]
    starts = np.searchsorted(rows, np.arange(n), side="left")
    stops = np.searchsorted(rows, np.arange(n), side="right")
    if np.any(stops <= starts):
        raise AlignmentError("path does not visit every row")
    cols = path[:, 1].astype(float)
    # the columns of a row are consecutive and sorted: the median is the mean of the middle pair
    lo_mid = starts + (stops - starts - 1) // 2
    hi_mid = starts + (stops - starts) // 2
    return 0.5 * (cols[lo_mid] + cols[hi_mid])


def _check_costs(band: Band, costs: np.ndarray, what: str = "local cost") -> np.ndarray:
    costs = np.ascontiguousarray(costs, dtype=np.float64)
    if costs.shape != (band.cells,):
        raise AlignmentError(f"{what}: expected {band.cells} band values, got shape {costs.shape}")
    bad = ~np.isfinite(costs)
    if bad.any():
        k = int(np.argmax(bad))
        i = int(np.searchsorted(band.offsets, k, side="right") - 1)
        j = int(band.lo[i] + k - band.offsets[i])
        raise AlignmentError(f"{what} is {costs[k]} at cell ({i}, {j}); costs must be finite")
    return costs


def dtw_band_costs(band: Band, costs: np.ndarray, *, cost_seconds: float = 0.0) -> DTWResult:
    """DTW (eq. 6.1-6.2 restricted to the band, eq. 6.3-6.5) from the band's local costs.

    ``costs`` holds ``D(p_i, q_j)`` for every band cell in flat order
    (see :func:`band_costs`).
    """
    return _dtw_checked(band, _check_costs(band, costs), cost_seconds)


def _dtw_checked(band: Band, costs: np.ndarray, cost_seconds: float) -> DTWResult:
    """Recurrence and backtracking on validated costs (float64, contiguous, finite)."""
    t0 = time.perf_counter()
    cells = band.cells
    gamma = np.empty(cells, dtype=np.float64)
    step = np.empty(cells, dtype=np.int8)
    lo, off = band.lo, band.offsets
    _accumulate(costs, lo, band.hi, off, gamma, step)
    t1 = time.perf_counter()
    total = float(gamma[-1])
    if not total < np.inf:  # cannot happen for a pruned band with finite costs
        raise AlignmentError(f"no path through the band reaches ({band.n - 1}, {band.m - 1})")
    path = _backtrack(lo, off, step, band.n, band.m)
    t2 = time.perf_counter()
    for a in (path, costs, gamma, step):
        a.setflags(write=False)
    return DTWResult(
        path=path,
        cost=total,
        band=band,
        local_cost=costs,
        cumulative=gamma,
        steps=step,
        timings={"cost": cost_seconds, "recurrence": t1 - t0, "backtrack": t2 - t1},
    )


def _as_features(a, name: str, check_finite: bool = True) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise AlignmentError(f"{name} must be a sequence of feature vectors (T, d), got shape {a.shape}")
    if a.shape[0] < 1:
        raise AlignmentError(f"{name} is empty")
    if check_finite and not np.isfinite(a).all():
        t = int(np.argwhere(~np.isfinite(a))[0, 0])
        raise AlignmentError(f"{name} has a non-finite value at frame {t}")
    return a


def feature_band_costs(x: np.ndarray, y: np.ndarray, band: Band, metric: str = "sqeuclidean", block_rows: int = 64) -> np.ndarray:
    """Local costs ``D(x_i, y_j)`` of the band cells for feature sequences.

    ``metric`` is ``"sqeuclidean"`` or ``"euclidean"`` (a compiled loop over
    the band cells: no matrix-product cancellation, and no multi-threaded BLAS
    call, which stalls badly on an oversubscribed machine) or any
    :func:`scipy.spatial.distance.cdist` metric name (``"cityblock"``,
    ``"cosine"``, ...; evaluated block-wise over the rows' column spans).
    """
    return _feature_costs(x, y, band, metric, block_rows)


def _feature_costs(x, y, band: Band, metric: str = "sqeuclidean", block_rows: int = 64) -> np.ndarray:
    """:func:`feature_band_costs`, returning finite costs (or raising).

    For the compiled metrics the inputs' finiteness is checked only when a
    cost comes out non-finite (every frame has band cells, so a non-finite
    feature always shows up there); the error then names the frame, as the
    up-front check does for the ``cdist`` metrics.
    """
    compiled = metric in ("sqeuclidean", "euclidean")
    xf = _as_features(x, "first sequence", check_finite=not compiled)
    yf = _as_features(y, "second sequence", check_finite=not compiled)
    if xf.shape[1] != yf.shape[1]:
        raise AlignmentError(f"feature dimensions differ: {xf.shape[1]} vs {yf.shape[1]}")
    if (len(xf), len(yf)) != (band.n, band.m):
        raise AlignmentError(f"band is {band.n}x{band.m}, sequences are {len(xf)}x{len(yf)}")
    out = np.empty(band.cells)
    if compiled:
        bad = _sqeuclidean_band(band.lo, band.hi, band.offsets, np.ascontiguousarray(xf), np.ascontiguousarray(yf.T), out)
        if bad:
            _as_features(xf, "first sequence")
            _as_features(yf, "second sequence")
            _check_costs(band, out)  # an overflow: names the cell
        if metric == "euclidean":
            np.sqrt(out, out=out)
        return out
    off = band.offsets
    for s in range(0, band.n, block_rows):
        e = min(band.n, s + block_rows)
        j0 = int(band.lo[s])
        j1 = int(band.hi[s:e].max()) + 1
        rows, cols = band.cell_indices(s, e)
        sub = cdist(xf[s:e], yf[j0:j1], metric=metric)
        out[off[s]:off[e]] = sub[rows - s, cols - j0]
    return _check_costs(band, out)


def band_costs(band: Band, cost) -> np.ndarray:
    """Local costs of the band cells from a dense ``(n, m)`` matrix or a callable.

    A callable is called as ``cost(i, j)`` with int arrays of cell rows and
    columns (in blocks) and must return one cost per cell.
    """
    if callable(cost):
        out = np.empty(band.cells)
        off = band.offsets
        step = max(1, int(2_000_000 // max(band.max_width, 1)))
        for s in range(0, band.n, step):
            e = min(band.n, s + step)
            r, c = band.cell_indices(s, e)
            v = np.asarray(cost(r, c), dtype=np.float64)
            if v.shape != r.shape:
                raise AlignmentError(f"cost callable returned shape {v.shape} for {r.shape[0]} cells")
            out[off[s]:off[e]] = v
        return out
    C = np.asarray(cost, dtype=np.float64)
    if C.shape != (band.n, band.m):
        raise AlignmentError(f"cost matrix is {C.shape}, the band is {band.n}x{band.m}")
    r, c = band.cell_indices()
    return C[r, c]


def dtw(x=None, y=None, *, cost=None, metric: str = "sqeuclidean", band: Band | None = None,
        width: float | None = None, radius: float | None = None, points=(), shape=None) -> DTWResult:
    """Banded DTW with optional user matching points (eq. 6.1-6.5, Algorithm 1).

    Either feature sequences ``x (n, d)`` and ``y (m, d)`` compared with
    ``metric``, or ``cost``: a dense ``(n, m)`` matrix, or a callable
    ``cost(i, j)`` over arrays of cells together with ``shape=(n, m)``.

    The band: a :class:`Band`, or ``width`` (``W`` of eq. 6.3, frames
    perpendicular to the diagonal) / ``radius`` (``rho``, vertical) with
    optional matching ``points`` (``(x, y)``, ``(x, y, tol)``,
    :class:`MatchPoint` or ``"x:y~tol"``); nothing: the full matrix.
    """
    t0 = time.perf_counter()
    if cost is None:
        if x is None or y is None:
            raise AlignmentError("dtw() needs two sequences x, y or a cost")
        xf = _as_features(x, "first sequence", check_finite=False)
        yf = _as_features(y, "second sequence", check_finite=False)
        b = _as_band(len(xf), len(yf), band, width, radius, points)
        return _dtw_checked(b, _feature_costs(xf, yf, b, metric), time.perf_counter() - t0)
    else:
        if x is not None or y is not None:
            raise AlignmentError("give either sequences x, y or a cost, not both")
        if callable(cost):
            if shape is None and band is None:
                raise AlignmentError("a cost callable needs shape=(n, m) or a band")
            n, m = (band.n, band.m) if shape is None else shape
        else:
            cost = np.asarray(cost, dtype=np.float64)
            if cost.ndim != 2:
                raise AlignmentError(f"cost matrix must be 2-D, got shape {cost.shape}")
            n, m = cost.shape
        b = _as_band(int(n), int(m), band, width, radius, points)
        costs = band_costs(b, cost)
    return dtw_band_costs(b, costs, cost_seconds=time.perf_counter() - t0)


def warp_values(values: np.ndarray, frame_map: np.ndarray) -> np.ndarray:
    """Sample ``values (m, ...)`` at fractional frames ``frame_map (n,)`` by linear interpolation.

    Used to build the aligned second sequence from a frame map (e.g.
    :meth:`DTWResult.row_median`).
    """
    values = np.asarray(values, dtype=float)
    f = np.asarray(frame_map, dtype=float)
    m = values.shape[0]
    if np.any(~np.isfinite(f)) or f.min() < 0 or f.max() > m - 1:
        raise AlignmentError(f"frame map must lie in [0, {m - 1}]")
    i0 = np.minimum(np.floor(f).astype(np.int64), m - 1)
    i1 = np.minimum(i0 + 1, m - 1)
    a = (f - i0).reshape((-1,) + (1,) * (values.ndim - 1))
    return (1 - a) * values[i0] + a * values[i1]
