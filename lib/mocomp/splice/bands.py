"""Search bands for dynamic time warping: the slanted band (dissertation eq. 6.3)
and its piecewise reshaping by user matching points (eq. 6.4-6.5, Algorithm 1).

Indices are 0-based: the first sequence ``p`` (rows, the full-body motion) has
``n`` frames ``i = 0..n-1``, the second ``q`` (columns, the hand motion) has
``m`` frames ``j = 0..m-1``. A band is stored as one contiguous column range
``lo[i]..hi[i]`` (inclusive) per row, so its cells are addressed in a flat,
row-major array of length ``band.cells`` (offsets ``band.offsets``): memory is
O(number of band cells), never O(n m).

The paper writes the diagonal as ``j = (m/n) i`` with 1-based frames ending
at ``(n, m)``. With 0-based frames the same line joins the corner cells
``(0, 0)`` and ``(n-1, m-1)`` (as dtw-python's ``slantedband`` does), so we use
the slope ``(m-1)/(n-1)`` and ``rho = W sqrt((n-1)^2 + (m-1)^2) / (n-1)``:
``W`` is then exactly the band's half-width measured perpendicular to the
diagonal, in frames.

Matching points, as Algorithm 1 defines them, *reshape* the band: between
consecutive points (and the corners) each segment gets its own slanted band
(eq. 6.4), so a point far off the diagonal -- outside the band of eq. 6.3 --
is honoured, not rejected (that is what the reshaping is for; Figure 6.3 b).
This is the default. ``strict=True`` (:func:`matching_band`,
``SpliceConfig.strict_points``, ``mocomp splice --strict-points``) instead
raises :class:`~mocomp.errors.AlignmentError` for a point whose window
``y +- T`` misses the eq. 6.3 band's columns in its row, naming the point and
those limits (for users who take a point far off the diagonal to be a typo).
What a band cannot contain, and what raises
:class:`~mocomp.errors.AlignmentError` naming the point, is: a point outside
the matrix (a frame at or beyond either sequence's ends, which are anchors
already), points out of order (eq. 6.4 requires ``x_{k-1} < x_k`` and
``y_{k-1} < y_k``), and consecutive points on adjacent body frames whose
hand frames are too far apart for any monotone path to match the frames in
between (the band would be cut). Tolerance windows ``y +- T`` are clipped to
the matrix, as the ``max{1, ...}``/``min{m, ...}`` of eq. 6.5 do.

The "fully specified" end of the continuum (an exact point on every inner
body frame) works only for sequences of equal length: points must increase
strictly in both frames (eq. 6.4), so with ``m < n`` two of them would share
a hand frame ("out of order"), and exact points on consecutive body frames
must be on consecutive hand frames (the row of an exact point admits only
its own column, so hand frames between them would be matched to no body
frame), so with ``m > n`` the surplus hand frames could only go to the first
and last body frames. For unequal lengths, leave gaps between the points
or give them tolerances.

One deliberate difference from Algorithm 1 read literally: it assigns row
``x_k`` to segment ``k`` only (``x_{k-1} < i <= x_k``), bounding it by
``j <= y_k + T`` from above and the next row by ``j >= y_k - T`` from below,
which with ``T = 0`` still lets a diagonal step from ``(x_k, y_k - 1)`` to
``(x_k + 1, y_k)`` pass beside the point. Here row ``x_k`` belongs to both
segments and takes the intersection, ``y_k - T <= j <= y_k + T``: an exact
point is matched exactly ("band limited to one point", Figure 6.3 b).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np

from ..core._compiled import njit
from ..errors import AlignmentError

__all__ = [
    "MatchPoint",
    "Band",
    "full_band",
    "slanted_band",
    "matching_band",
    "corridor_band",
    "band_radius",
    "parse_match",
    "as_points",
]


@dataclass(frozen=True)
class MatchPoint:
    """A user matching point (x_k, y_k) of eq. 6.4-6.5.

    Attributes
    ----------
    x: frame of the first sequence (full-body motion, matrix row), 0-based.
    y: frame of the second sequence (hand motion, matrix column), 0-based.
    tol: tolerance ``T`` in frames of the second sequence: the optimal path
        must cross row ``x`` within columns ``[y - tol, y + tol]``
        (``tol = 0``: the path passes exactly through ``(x, y)``).
    """

    x: int
    y: int
    tol: int = 0

    def __post_init__(self):
        for name in ("x", "y", "tol"):
            v = getattr(self, name)
            ok = isinstance(v, (int, np.integer)) or (isinstance(v, (float, np.floating)) and float(v).is_integer())
            if isinstance(v, (bool, np.bool_)) or not ok:
                raise AlignmentError(f"matching point {name} must be an integer frame number, got {v!r}")
            object.__setattr__(self, name, int(v))
        if self.tol < 0:
            raise AlignmentError(f"matching point ({self.x}, {self.y}) has a negative tolerance {self.tol}")

    def __str__(self) -> str:
        return f"{self.x}:{self.y}" + (f"~{self.tol}" if self.tol else "")


_MATCH_RE = re.compile(r"^\s*(-?\d+)\s*:\s*(-?\d+)\s*(?:~\s*(-?\d+)\s*)?$")


def parse_match(text: str) -> MatchPoint:
    """Parse ``"BODY:HAND"`` or ``"BODY:HAND~TOL"`` (frames), e.g. ``"300:280~5"``."""
    mt = _MATCH_RE.match(text)
    if not mt:
        raise AlignmentError(
            f"cannot read matching point {text!r}: expected BODY_FRAME:HAND_FRAME or BODY_FRAME:HAND_FRAME~TOLERANCE, e.g. 120:95 or 300:280~5"
        )
    x, y, t = mt.groups()
    return MatchPoint(int(x), int(y), int(t) if t is not None else 0)


def as_points(points) -> tuple[MatchPoint, ...]:
    """Normalise matching points given as MatchPoint, ``(x, y)``, ``(x, y, tol)`` or ``"x:y~t"``."""
    if points is None:
        return ()
    out = []
    for p in points:
        if isinstance(p, MatchPoint):
            out.append(p)
        elif isinstance(p, str):
            out.append(parse_match(p))
        else:
            p = tuple(p)
            if len(p) not in (2, 3):
                raise AlignmentError(f"matching point {p!r} must be (x, y) or (x, y, tolerance)")
            out.append(MatchPoint(*p))
    return tuple(out)


def band_radius(width: float, dx: float, dy: float) -> float:
    """``rho = W sqrt(dx^2 + dy^2) / dx`` (eq. 6.3; eq. 6.4's ``rho_k`` per segment):
    the vertical half-height of a band of perpendicular half-width ``W`` about a
    line of slope ``dy/dx``."""
    if dx <= 0:
        raise AlignmentError(f"band segment has no rows (dx = {dx})")
    return float(width) * float(np.hypot(dx, dy)) / float(dx)


_UNBOUNDED = int(np.iinfo(np.int64).max)


def _frozen_rows(a) -> np.ndarray:
    """A read-only 1-D int64 array of ``a``: a private copy, unless ``a`` is
    already a read-only int64 array owning its data (what the band
    constructors hand over), which is kept as is."""
    if (isinstance(a, np.ndarray) and a.dtype == np.int64 and a.ndim == 1 and a.flags.owndata
            and not a.flags.writeable and a.flags.c_contiguous):
        return a
    a = np.array(a, dtype=np.int64).reshape(-1)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Band:
    """Cells of an ``n x m`` DTW matrix that may be visited: columns ``lo[i]..hi[i]`` of each row.

    Build with :func:`full_band`, :func:`slanted_band`, :func:`matching_band`
    or :func:`corridor_band`; they return bands already *pruned* to the cells
    that lie on at least one monotone path from ``(0, 0)`` to ``(n-1, m-1)``
    (which leaves every DTW result unchanged) and raise
    :class:`~mocomp.errors.AlignmentError` if no such path exists.

    Attributes
    ----------
    n, m: matrix size (rows = first sequence, columns = second).
    lo, hi: ``(n,)`` int64, inclusive column range per row; both non-decreasing.
    kind: ``"full"``, ``"slanted"``, ``"points"`` or ``"corridor"``.
    width: the band half-width ``W`` in frames (perpendicular to the diagonal), if any.
    radii: ``rho_k`` per segment between consecutive anchor points (eq. 6.4).
    points: the user matching points the band was shaped by.
    raw_lo, raw_hi: the row ranges before pruning (what eq. 6.3-6.5 define), for plots.
    """

    n: int
    m: int
    lo: np.ndarray
    hi: np.ndarray
    kind: str = "custom"
    width: float | None = None
    radii: tuple[float, ...] = ()
    points: tuple[MatchPoint, ...] = ()
    raw_lo: np.ndarray | None = None
    raw_hi: np.ndarray | None = None
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        lo = _frozen_rows(self.lo)
        hi = _frozen_rows(self.hi)
        if lo.shape != (self.n,) or hi.shape != (self.n,):
            raise AlignmentError(f"band row ranges must have {self.n} rows, got {lo.shape} and {hi.shape}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        for name in ("raw_lo", "raw_hi"):
            v = getattr(self, name)
            v = (lo if name == "raw_lo" else hi) if v is None else _frozen_rows(v)
            object.__setattr__(self, name, v)

    # ------------------------------------------------------------- geometry
    @property
    def counts(self) -> np.ndarray:
        """``(n,)`` number of cells in each row."""
        return self.hi - self.lo + 1

    @property
    def offsets(self) -> np.ndarray:
        """``(n+1,)`` start of each row in the flat cell arrays."""
        if "off" not in self._cache:
            off = np.zeros(self.n + 1, dtype=np.int64)
            np.cumsum(self.counts, out=off[1:])
            off.setflags(write=False)
            self._cache["off"] = off
        return self._cache["off"]

    @property
    def cells(self) -> int:
        """Total number of band cells (the memory the DTW needs, per array)."""
        return int(self.offsets[-1])

    @property
    def max_width(self) -> int:
        return int(self.counts.max())

    @property
    def fill(self) -> float:
        """Fraction of the full ``n x m`` matrix covered by the band."""
        return self.cells / float(self.n * self.m)

    def cell_indices(self, start: int = 0, stop: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of every cell of rows ``start..stop-1``, in flat order."""
        stop = self.n if stop is None else stop
        off = self.offsets
        counts = self.counts[start:stop]
        total = int(off[stop] - off[start])
        rows = np.repeat(np.arange(start, stop, dtype=np.int64), counts)
        # column = lo[row] + position within the row
        within = np.arange(total, dtype=np.int64) - np.repeat(off[start:stop] - off[start], counts)
        cols = self.lo[rows] + within
        return rows, cols

    def contains(self, i, j) -> np.ndarray:
        """Whether cells ``(i, j)`` (arrays broadcast) lie in the band."""
        i = np.asarray(i)
        j = np.asarray(j)
        ok = (i >= 0) & (i < self.n)
        ic = np.clip(i, 0, self.n - 1)
        return ok & (j >= self.lo[ic]) & (j <= self.hi[ic])

    def flat_index(self, i, j) -> np.ndarray:
        """Flat index of cells ``(i, j)`` (which must lie in the band)."""
        i = np.asarray(i, dtype=np.int64)
        j = np.asarray(j, dtype=np.int64)
        if not np.all(self.contains(i, j)):
            raise AlignmentError("flat_index() of a cell outside the band")
        return self.offsets[i] + (j - self.lo[i])

    def mask(self) -> np.ndarray:
        """Dense ``(n, m)`` boolean mask (for plots and small problems only)."""
        jj = np.arange(self.m)
        return (jj[None, :] >= self.lo[:, None]) & (jj[None, :] <= self.hi[:, None])

    def to_dense(self, values: np.ndarray, fill: float = np.nan) -> np.ndarray:
        """Scatter flat band values into a dense ``(n, m)`` array (for plots)."""
        values = np.asarray(values)
        if values.shape != (self.cells,):
            raise ValueError(f"expected {self.cells} band values, got {values.shape}")
        out = np.full((self.n, self.m), fill, dtype=np.result_type(values.dtype, np.asarray(fill).dtype))
        r, c = self.cell_indices()
        out[r, c] = values
        return out

    def __repr__(self) -> str:
        w = "" if self.width is None else f", W={self.width:g}"
        p = f", {len(self.points)} points" if self.points else ""
        return f"Band({self.kind}, {self.n}x{self.m}, {self.cells} cells ({100 * self.fill:.1f}%){w}{p})"


@njit
def _prune_kernel(lo, hi, m, raw_lo, raw_hi, lo_p, hi_p):  # pragma: no cover - compiled
    """Clip ``lo, hi`` to the matrix into ``raw_lo, raw_hi`` and prune them into
    ``lo_p, hi_p`` (see :func:`_prune`). Returns ``(code, row)``: 0 fine, 1 an
    empty row, 2 no start cell, 3 no end cell, 4 the band is cut at ``row``."""
    n = lo.shape[0]
    for i in range(n):
        raw_lo[i] = min(max(lo[i], 0), m - 1)
        raw_hi[i] = min(max(hi[i], 0), m - 1)
        lo_p[i] = max(lo[i], 0)
        hi_p[i] = min(hi[i], m - 1)
    for i in range(n):
        if hi_p[i] < lo_p[i]:
            return 1, i
    if lo_p[0] != 0:
        return 2, 0
    if hi_p[n - 1] != m - 1:
        return 3, n - 1
    for i in range(1, n):
        lo_p[i] = max(lo_p[i], lo_p[i - 1])
    for i in range(n - 2, -1, -1):
        hi_p[i] = min(hi_p[i], hi_p[i + 1])
    for i in range(n):
        if hi_p[i] < lo_p[i]:
            return 4, i
    for i in range(1, n):
        if lo_p[i] > hi_p[i - 1] + 1:
            return 4, i
    return 0, 0


def _prune(n: int, m: int, lo: np.ndarray, hi: np.ndarray, what: str) -> tuple[np.ndarray, ...]:
    """Keep the cells on some monotone path (0,0) -> (n-1,m-1); raise if there is none.

    Returns the pruned ``lo, hi`` and the unpruned ones clipped to the matrix
    (``raw_lo, raw_hi``), all read-only.

    Forward: a path reaches column ``j`` of row ``i`` only from a column ``<= j``
    of row ``i-1``, so ``lo[i] <- max(lo[i], lo[i-1])``. Backward: from column
    ``j`` the path continues in row ``i+1`` at a column ``>= j``, so
    ``hi[i] <- min(hi[i], hi[i+1])``. Pruned cells can neither be reached from
    the start nor reach the end, so no DTW value on the kept cells changes.
    """
    lo = np.ascontiguousarray(lo, dtype=np.int64)
    hi = np.ascontiguousarray(hi, dtype=np.int64)
    out = [np.empty(n, dtype=np.int64) for _ in range(4)]
    code, i = _prune_kernel(lo, hi, m, *out)
    if code == 1:
        raise AlignmentError(
            f"{what}: row {i} of the {n}x{m} matrix has no cell in the band "
            f"(sequences too short for the band, or the band is too narrow)"
        )
    if code == 2:
        raise AlignmentError(f"{what}: the band does not contain the start cell (0, 0)")
    if code == 3:
        raise AlignmentError(f"{what}: the band does not contain the end cell ({n - 1}, {m - 1})")
    if code == 4:
        raise AlignmentError(
            f"{what}: no monotone path from (0, 0) to ({n - 1}, {m - 1}) stays inside the band "
            f"(it is cut at row {i}); widen the band or check the matching points"
        )
    raw_lo, raw_hi, lo_p, hi_p = out
    for a in out:
        a.setflags(write=False)
    return lo_p, hi_p, raw_lo, raw_hi


def _check_size(n: int, m: int):
    for name, v in (("n", n), ("m", m)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise AlignmentError(f"sequence length {name} must be a positive integer, got {v!r}")


def full_band(n: int, m: int) -> Band:
    """The whole ``n x m`` matrix (unconstrained DTW, eq. 6.1-6.2)."""
    _check_size(n, m)
    return Band(int(n), int(m), np.zeros(n, dtype=np.int64), np.full(n, m - 1, dtype=np.int64), kind="full")


@njit
def _segment_rows(m, x0, y0, x1, y1, rho, jmin, jmax, lo, hi):  # pragma: no cover - compiled
    """Intersect rows ``x0..x1`` of ``lo, hi`` with the segment (x0,y0)-(x1,y1)'s
    band (eq. 6.4, clipped as eq. 6.5): ``|j - c_i| <= rho`` with
    ``c_i = y0 + (i - x0)(y1 - y0)/(x1 - x0)``, ``jmin <= j <= jmax``."""
    jlo = float(max(jmin, 0))
    jhi = float(min(jmax, m - 1))
    for i in range(x0, x1 + 1):
        if x1 > x0:
            c = y0 + ((i - x0) * (y1 - y0)) / (x1 - x0)
        else:  # a single-row sequence
            c = float(y0)
        a = np.ceil(c - rho)
        b = np.floor(c + rho)
        # Exact float boundaries the way dtw-python tests them: |j - c| <= rho.
        if abs((a - 1) - c) <= rho:
            a = a - 1
        if abs(a - c) > rho:
            a = a + 1
        if abs((b + 1) - c) <= rho:
            b = b + 1
        if abs(b - c) > rho:
            b = b - 1
        a = max(a, jlo)
        b = min(b, jhi)
        lo[i] = max(lo[i], np.int64(a))
        hi[i] = min(hi[i], np.int64(b))


def slanted_band(n: int, m: int, width: float | None = None, *, radius: float | None = None) -> Band:
    """The slanted band of eq. 6.3: cells with ``|j - i (m-1)/(n-1)| <= rho``.

    Give either ``width`` (``W``, the half-width perpendicular to the diagonal,
    in frames; ``rho = W sqrt((n-1)^2+(m-1)^2)/(n-1)``) or ``radius`` (``rho``
    directly, the vertical half-height; this is dtw-python's ``window_size``
    of ``window_type="slantedband"``). Exactly those cells, pruned to the ones
    on some monotone path.
    """
    return matching_band(n, m, width, (), radius=radius)


def matching_band(n: int, m: int, width: float | None, points: Iterable = (), *, radius: float | None = None,
                  strict: bool = False) -> Band:
    """The band reshaped by user matching points (eq. 6.4-6.5, Algorithm 1).

    The anchors ``(0, 0)``, the points ``(x_k, y_k)`` (strictly increasing in
    both coordinates, inside the matrix) and ``(n-1, m-1)`` split the matrix
    into segments. Rows ``x_{k-1} <= i <= x_k`` of segment ``k`` get the slanted
    band of that segment, ``|j - y_{k-1} - (i - x_{k-1}) |y_k|/|x_k|| <= rho_k``
    with ``rho_k = W sqrt(|x_k|^2 + |y_k|^2) / |x_k|`` (eq. 6.4), clipped to
    ``y_{k-1} - T_{k-1} <= j <= y_k + T_k`` (the ``lb``/``ub`` of eq. 6.5).
    A row shared by two segments (a point's row ``x_k``) takes the
    intersection, so the path crosses row ``x_k`` within ``[y_k - T_k, y_k + T_k]``
    and passes exactly through ``(x_k, y_k)`` when ``T_k = 0``. With no points
    this is the slanted band of eq. 6.3.

    ``radius`` instead of ``width`` fixes ``rho`` for every segment (only
    meaningful without points; used for the dtw-python cross-check).

    A point outside the band of eq. 6.3 reshapes the band (Algorithm 1: the
    default). With ``strict=True`` it raises
    :class:`~mocomp.errors.AlignmentError` instead, naming the point and the
    columns the eq. 6.3 band allows in its row: a point counts as inside when
    its window ``[y - T, y + T]`` overlaps them.

    Points must increase strictly in both frames (eq. 6.4) and exact points
    on consecutive body frames must be on consecutive hand frames, so a
    point on every body frame ("fully specified") works only for ``n == m``
    (see the module docstring).
    """
    _check_size(n, m)
    n, m = int(n), int(m)
    pts = as_points(points)
    if (width is None) == (radius is None):
        raise AlignmentError("give exactly one of width (W, frames) or radius (rho, frames)")
    if width is not None and not (np.isfinite(width) and width >= 0):
        raise AlignmentError(f"band width must be a non-negative number of frames, got {width!r}")
    if radius is not None and not (np.isfinite(radius) and radius >= 0):
        raise AlignmentError(f"band radius must be a non-negative number of frames, got {radius!r}")
    prev = None
    for k, p in enumerate(pts, 1):
        if not (0 < p.x < n - 1):
            raise AlignmentError(
                f"matching point {k} ({p}) is outside the matrix (and so outside any band): its body frame must lie "
                f"strictly between 0 and {n - 1}, the first and last frames being matched already"
            )
        if not (0 < p.y < m - 1):
            raise AlignmentError(
                f"matching point {k} ({p}) is outside the matrix (and so outside any band): its hand frame must lie "
                f"strictly between 0 and {m - 1}, the first and last frames being matched already"
            )
        if prev is not None and not (p.x > prev.x and p.y > prev.y):
            raise AlignmentError(
                f"matching points out of order: point {k} ({p}) must come after point {k - 1} ({prev}) in both sequences"
                + (" (a point on every body frame needs as many hand frames as body frames)" if p.y <= prev.y and p.x == prev.x + 1 else "")
            )
        if prev is not None and p.x == prev.x + 1 and p.y - p.tol > prev.y + prev.tol + 1:
            raise AlignmentError(
                f"matching points {k - 1} ({prev}) and {k} ({p}) are on consecutive body frames but "
                f"{p.y - prev.y} hand frames apart: the hand frames between them could not be matched to any body frame; "
                f"put them at least 2 body frames apart or give a tolerance (exact points on every body frame work "
                f"only when both sequences have the same length)"
            )
        prev = p
    if strict and pts:
        base = matching_band(n, m, width, (), radius=radius)
        for k, p in enumerate(pts, 1):
            a, b = int(base.raw_lo[p.x]), int(base.raw_hi[p.x])
            if p.y + p.tol < a or p.y - p.tol > b:
                win = f"hand frame {p.y}" + (f" +- {p.tol}" if p.tol else "")
                band_w = f"W = {width:g} frames" if width is not None else f"rho = {radius:g} frames"
                raise AlignmentError(
                    f"matching point {k} ({p}) is outside the band ({band_w}, eq. 6.3): body frame {p.x} allows hand "
                    f"frames {a}..{b}, the point asks for {win}; widen the band, fix the point, or drop strict mode "
                    f"to let the point reshape the band (Algorithm 1)"
                )
    xs = [0] + [p.x for p in pts] + [n - 1]
    ys = [0] + [p.y for p in pts] + [m - 1]
    ts = [0] + [p.tol for p in pts] + [0]
    lo = np.full(n, -_UNBOUNDED, dtype=np.int64)
    hi = np.full(n, _UNBOUNDED, dtype=np.int64)
    radii = []
    for k in range(1, len(xs)):
        x0, y0, x1, y1 = xs[k - 1], ys[k - 1], xs[k], ys[k]
        if x1 > x0:
            rho = radius if radius is not None else band_radius(width, x1 - x0, y1 - y0)
        else:  # n == 1: one row, every column must be allowed
            rho = float(m)
        radii.append(float(rho))
        jmin = y0 - ts[k - 1] if k > 1 else 0
        jmax = y1 + ts[k] if k < len(xs) - 1 else m - 1
        _segment_rows(m, x0, y0, x1, y1, float(rho), jmin, jmax, lo, hi)
    what = "band" if not pts else f"band shaped by {len(pts)} matching point(s)"
    lo_p, hi_p, raw_lo, raw_hi = _prune(n, m, lo, hi, what)
    return Band(
        n, m, lo_p, hi_p,
        kind="points" if pts else "slanted",
        width=None if width is None else float(width),
        radii=tuple(radii),
        points=pts,
        raw_lo=raw_lo,
        raw_hi=raw_hi,
    )


def corridor_band(path: np.ndarray, n: int, m: int, radius: int) -> Band:
    """Cells within ``radius`` columns of a monotone path (e.g. a coarse alignment).

    Row ``i`` spans ``[min_j(path at i) - radius, max_j(path at i) + radius]``.
    """
    _check_size(n, m)
    path = np.asarray(path, dtype=np.int64)
    if path.ndim != 2 or path.shape[1] != 2:
        raise AlignmentError(f"path must be (K, 2) pairs of frames, got shape {path.shape}")
    if radius < 0:
        raise AlignmentError(f"corridor radius must be >= 0, got {radius}")
    rows = path[:, 0]
    if rows.min() != 0 or rows.max() != n - 1:
        raise AlignmentError(f"path must cover rows 0..{n - 1}")
    lo = np.full(n, m, dtype=np.int64)
    hi = np.full(n, -1, dtype=np.int64)
    np.minimum.at(lo, rows, path[:, 1])
    np.maximum.at(hi, rows, path[:, 1])
    lo, hi = lo - int(radius), hi + int(radius)
    lo_p, hi_p, raw_lo, raw_hi = _prune(n, m, lo, hi, "corridor band")
    return Band(n, m, lo_p, hi_p, kind="corridor", radii=(float(radius),), raw_lo=raw_lo, raw_hi=raw_hi)


def _as_band(n: int, m: int, band: Band | None, width=None, radius=None, points: Sequence = ()) -> Band:
    """Resolve the band arguments of :func:`mocomp.splice.dtw.dtw`."""
    if band is not None:
        if width is not None or radius is not None or points:
            raise AlignmentError("give either a Band or width/radius/points, not both")
        if (band.n, band.m) != (n, m):
            raise AlignmentError(f"band is for a {band.n}x{band.m} matrix, the sequences give {n}x{m}")
        return band
    if width is None and radius is None:
        if points:
            raise AlignmentError("matching points need a band width")
        return full_band(n, m)
    return matching_band(n, m, width, points, radius=radius)
