"""The motion search of the impact response (dissertation sec. 4.1, eq. 4.1-4.2, Appendix A).

Given a query window (frames ``start .. stop-1`` of the simulated reaction) find the library clip,
frame and root transform whose window continues it best. The window distance is eq. 4.1:

    D(W1, W2) = sum_{i=s}^{e} w_i sum_b ( w_p,b |p_b(f1_i) - p_b(f2_i)| + w_theta,b |theta_b(f1_i) - theta_b(f2_i)| )

with the 16 body parts of :mod:`mocomp.impact.features` (segment COMs and orientations; the angular
term is the geodesic angle in radians), both windows aligned at their first frame in the ground
plane (root heading and ground point), Table A.1's per-body weights, the supporting foot (the foot
on the ground nearest the centre of mass at the query's first frame) weighted 1.0 / 0.10 instead of
0.1 / 0.01, and the quadratic window weights of eq. A.1

    w_i = -((i - s) / (e - s))^2 + 1

(1 at the first frame, 0 at the last).

Search (sec. 4.1): windows starting at the clips' **unique frames** (eq. 4.2, :mod:`.index`) are
compared first; then "all possible windows in the surrounding intervals between the neighbouring
unique frames" of the best ones. Beyond the paper (all exact with respect to the windows they
visit, i.e. they change how many frames are compared, never which of the visited windows wins):

* early abandoning (:mod:`._kernels`): every term of eq. 4.1 is >= 0, so a window whose partial
  sum exceeds the threshold is dropped; the remaining frames are also bounded below by the
  triangle inequality of the frame distance (a metric, invariant under the windows' rigid
  alignment): ``d_j >= d_f - (query steps + library steps between frames f and j)``, with the
  frame-to-frame steps precomputed as prefix sums. Windows are visited best-first by their
  first-frame term plus that bound, so the threshold is tight early, and a pass ends at the first
  window whose key exceeds it;
* two stages per window (compiled search): first a lower bound of every frame term -- the angle
  ``2 acos|d|`` replaced by its chord ``2 sqrt(2 (1 - |d|)) <= 2 acos|d|``, no ``acos`` -- which
  drops most windows; the survivors are then summed exactly (bit-identical to the exhaustive
  kernel), dropped as soon as the exact partial sum plus the bounds of the remaining frames
  exceeds the threshold. A window dropped against one threshold is not visited again by a later
  pass with the same or a lower threshold;
* the intervals around every unique-frame window within ``margin_factor * T * sum_i w_i`` of the
  best one (at most ``max_regions``; the paper refines only the best) are refined, abandoning
  against the running best. On the shared library (1739 frames at 30 Hz, 394 unique) with 0.9 s
  windows the result is the exhaustive one in 59 of 60 random queries (58 with ``margin_factor=0``)
  and 23 of 23 in the test set of ``tests/test_impact_search.py`` (the benchmark's queries), at
  11x fewer frame pairs, of which ~1 in 10 is computed exactly (the others only on the bound);
* the **runner-up** is not the exact second-best window: it is the least distance, among the
  windows this search computed completely, over the windows far from the best (in another clip or
  at least ``L`` frames away, ``L`` the window length at the index rate) -- those are the
  unique-frame windows within the margin of the best and the refined intervals; when none is far,
  the far unique-frame windows are computed first -- after the interval between the unique frames
  around it has been refined against its distance. It matches the exhaustive runner-up (the least
  distance over *all* far windows, which ``exhaustive=True`` returns) in 16 of the benchmark's 23
  queries; otherwise it is a worse far window (up to 3.3x the distance there). Computing the far
  windows with the same guarantees as the best (their own unique-frame pass with the margin, then
  their regions) gave 22 of 23 but cost 1.6x the frame pairs of the whole search, so it is not done.
  Tried again (2026-12-02, the runner-up's distance as a second threshold in the compiled search): every
  far unique-frame window below it completed, then the intervals of the far unique-frame windows within
  the margin of it refined: 22/23 at 7.5x fewer frame pairs than the exhaustive search (the goal is 10x);
  the intervals alone 19/23 at 8.7x; the far unique-frame windows alone 18/23 at 9.3x; the search as it
  is: 16/23 at 11.1x. The exact runner-up stays with ``exhaustive=True``, or ``runner_up="exact"``: the
  best from the unique-frame search, then every far window it left uncomputed summed, abandoned above the
  fast runner-up's distance (the exhaustive runner-up whenever the best is the exhaustive best).

The compiled search (numba) runs the passes above in one call (:func:`._kernels.search_nb`); the
query window's body parts come from one compiled function too. Without numba (``MOCOMP_NO_NUMBA=1``)
the same passes run in Python over the numpy twin of the kernel (whole windows, no abandoning; the
same results, tested). Measured on the benchmark's 23 queries (``benchmarks/bench_impact.py``, 2 shared
cores): CPU 0.85 vs 10.94 ms per query for the exhaustive search at load 4 (12.9x), 1.49 vs 16.27 ms
at load 6 (10.9x); before the compiled control flow 3.1-3.5 ms, 4.4x.

``exhaustive=True`` compares every window of every clip in full: the reference.

Query and index rates: the query window is resampled to the index rate when they differ by more
than 2 %. Result frames are the clip's own (native) frame numbers
(:meth:`~mocomp.impact.index.LibraryIndex.motion` gives that clip on the victim's skeleton).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_apply
from ..errors import MotionFormatError
from ..ops.align import GroundTransform
from .features import BODY_PARTS, FOOT_PARTS, body_model_for, ground_frame_features, part_weights
from . import _kernels
from .index import RATE_TOLERANCE, LibraryIndex, frame_distances

__all__ = ["RootTransform", "SearchResult", "search", "window_weights", "window_distance", "support_foot_of",
           "reentry_frame_costs"]

_CHUNK = 192            # candidate windows per vectorised block (keeps the gathered arrays ~10 MB)
_SUPPORT_HEIGHT = 0.05  # m: a foot within this height of the lowest foot counts as on the ground


@dataclass(frozen=True)
class RootTransform:
    """``p -> R_y(yaw) p + translation``: maps the clip (at the found frame) onto the query (at
    ``start``): the clip's root ground point goes to the query's and its heading to the query's.

    yaw: rad about +y (counter-clockwise seen from above). translation: ``(3,)`` m, ``y = 0``.
    Unpacks as ``yaw, translation = result.root_transform``.
    """

    yaw: float
    translation: np.ndarray

    def __iter__(self):
        return iter((self.yaw, self.translation))

    def ground_transform(self) -> GroundTransform:
        """The same map as a :class:`mocomp.ops.align.GroundTransform` (pivot at the origin)."""
        return GroundTransform(float(self.yaw), (0.0, 0.0, 0.0), tuple(float(x) for x in self.translation))

    def apply_points(self, p) -> np.ndarray:
        return self.ground_transform().apply_points(p)

    def apply(self, motion: Motion) -> Motion:
        """``motion`` (the found clip) moved rigidly onto the query."""
        return self.ground_transform().apply(motion)


@dataclass(frozen=True)
class SearchResult:
    """The best library window for a query window.

    Attributes
    ----------
    clip: path of the clip file.
    frame: first frame of the matched window, in the clip's own frame numbers.
    root_transform: :class:`RootTransform` mapping the clip's root at ``frame`` onto the query's
        root at ``start`` (heading and ground point).
    distance: eq. 4.1 window distance (at the index rate).
    runner_up: the best match in another clip or at least one window length away from ``frame``
        among the windows the search compared in full (module docstring: the exact one with
        ``exhaustive=True``); ``None`` when there is none; its own ``runner_up`` is ``None``.
    stats: ``frames_compared`` (frame pairs whose eq. 4.1 term or its lower bound was computed),
        ``frames_exact`` (of them, the pairs whose exact term was computed), ``frames_exhaustive``
        (frame pairs of the exhaustive search), ``windows_compared``, ``windows_exhaustive``,
        ``unique_windows`` (candidate windows at unique frames), ``window_frames``,
        ``support_foot``, ``index_frame`` (frame in the index's numbering), ``clip_name``,
        ``exhaustive``, ``seconds`` (wall time of the search), ``seconds_query`` (of it: the query
        window's features, the same for both searches), ``seconds_matching`` (the comparisons).
    """

    clip: str
    frame: int
    root_transform: RootTransform
    distance: float
    runner_up: "SearchResult | None" = None
    stats: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready summary (for reports)."""
        out = {"clip": self.clip, "frame": int(self.frame), "distance": float(self.distance),
               "yaw_deg": float(np.degrees(self.root_transform.yaw)),
               "translation_m": [float(x) for x in self.root_transform.translation]}
        if self.runner_up is not None:
            out["runner_up"] = self.runner_up.to_dict()
        out["stats"] = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in self.stats.items()}
        return out


def window_weights(n: int) -> np.ndarray:
    """Eq. A.1 over a window of ``n`` frames: ``w_i = 1 - (i / (n - 1))^2`` (``n >= 2``)."""
    if n < 2:
        raise ValueError(f"a search window needs at least 2 frames, got {n}")
    i = np.arange(n)
    return 1.0 - (i / (n - 1)) ** 2


def support_foot_of(com: np.ndarray, positions: np.ndarray) -> str:
    """``"left"``/``"right"``: the ground-support foot nearest (in the ground plane) to the centre of
    mass ``com (3,)``, among the feet within 5 cm of the lowest foot (body parts ``positions (16, 3)``)."""
    feet = {s: positions[BODY_PARTS.index(b)] for s, b in FOOT_PARTS.items()}
    low = min(p[1] for p in feet.values())
    on = {s: p for s, p in feet.items() if p[1] <= low + _SUPPORT_HEIGHT}
    return min(on, key=lambda s: float(np.hypot(on[s][0] - com[0], on[s][2] - com[2])))


def window_distance(pos_a, ori_a, pos_b, ori_b, support: str | None = None) -> float:
    """Eq. 4.1, written out (the reference for the vectorised search): two windows of body parts
    ``(L, 16, 3)``/``(L, 16, 4)`` already aligned at their first frames."""
    wp, wr = part_weights(support)
    w = window_weights(pos_a.shape[0])
    return float(np.sum(w * frame_distances(pos_a, ori_a, pos_b, ori_b, wp, wr)))


class _Query:
    """The query window aligned at its first frame, and the per-frame kernel against the library."""

    def __init__(self, index: LibraryIndex, motion: Motion, start: int, stop: int, support: str | None):
        # the window's 16 body parts from the motion's (cached) core FK and the body model: the
        # same numbers as body_features (tested)
        joints, coms, masses = _parts(index)
        P, G = motion.fk()
        root0, q0 = motion.root_positions[start], motion.rotations[start, 0]
        self.L = L = stop - start
        self.ground0 = np.array([root0[0], 0.0, root0[2]])
        self.heading0 = float(2.0 * np.arctan2(q0[1], q0[3]))         # twist about +y (ops.align.headings)
        F = L - 1                                        # eq. A.1: the last frame has weight 0
        key = ("window", L)                              # per window length, cached in the index
        cat = index.concatenated()
        if key not in cat:
            cat[key] = (np.arange(F, dtype=np.int64), np.ascontiguousarray(window_weights(L)[:F]))
            for a in cat[key]:
                a.setflags(write=False)
        self.frames, self.w = cat[key]
        if _kernels.AVAILABLE:
            pos, qp, qo, yq = (np.empty((L, joints.size, k)) for k in (3, 3, 4, 4))
            _kernels.query_nb(P[start:stop], G[start:stop], joints, coms, self.ground0[0], self.ground0[2],
                              self.heading0, pos, qp, qo, yq)
        else:
            P, G = P[start:stop, joints], G[start:stop, joints]
            pos = P + quat_apply(G, coms)
            qp, qo = ground_frame_features(pos, G, self.ground0, self.heading0)
            # Y (x) Q with Y = (0, 1, 0, 0) (the yaw of each candidate enters as cos/sin(psi/2) weights):
            # the Hamilton product with Y is the signed permutation (z, w, -x, -y) of Q
            yq = qo[..., [2, 3, 0, 1]] * np.array([1.0, 1.0, -1.0, -1.0])
        com0 = masses @ pos[0] / masses.sum()
        self.support = support_foot_of(com0, pos[0]) if support is None else support
        self.qp, self.qo, self.yqo = qp[:F], qo[:F], yq[:F]
        self.wp, self.wr = part_weights(self.support)
        cat = index.concatenated()
        self.P, self.O, self.G, self.H = cat["positions"], cat["orientations"], cat["ground"], cat["heading"]
        # prefix sums of frame-to-frame distances (the triangle-inequality bound of _kernels)
        key = ("steps", self.support)
        if key not in cat:
            step = frame_distances(self.P[:-1], self.O[:-1], self.P[1:], self.O[1:], self.wp, self.wr)
            cat[key] = np.concatenate([[0.0], np.cumsum(step)])
        self.Cl = cat[key]
        if "trig" not in cat:                            # cos/sin of every library heading and its half
            T = np.empty((self.H.shape[0], 4))
            if _kernels.AVAILABLE:
                _kernels.trig_nb(self.H, T)
            else:
                T[:] = np.stack([np.cos(self.H), np.sin(self.H), np.cos(0.5 * self.H), np.sin(0.5 * self.H)], axis=1)
            cat["trig"] = T
        self.T = cat["trig"]
        self.first = np.full(self.P.shape[0], np.nan)   # first-frame terms computed so far, per library row
        if _kernels.AVAILABLE:
            self.Cq = np.empty(F)
            _kernels.steps_nb(qp, qo, self.wp, self.wr, F, self.Cq)
        else:
            qstep = frame_distances(qp[:-1], qo[:-1], qp[1:], qo[1:], self.wp, self.wr)[:F]
            self.Cq = np.concatenate([[0.0], np.cumsum(qstep)])[:F]

    def terms(self, starts: np.ndarray, sel: slice | np.ndarray = slice(None)) -> np.ndarray:
        """``(K, F)`` weighted eq. 4.1 terms of the windows starting at library rows ``starts`` for the
        query frames ``self.frames[sel]``. Compares ``R_y(-psi_c)(p - g_c)`` with the aligned query
        as ``(p - g_c) - R_y(psi_c) q`` and the orientations as ``<o, q_y(psi_c) Q>``."""
        fr = self.frames[sel]
        qp, qo, yqo, w = self.qp[sel], self.qo[sel], self.yqo[sel], self.w[sel]
        out = np.empty((starts.size, fr.size))
        for a in range(0, starts.size, _CHUNK):
            s = starts[a:a + _CHUNK]
            idx = s[:, None] + fr[None, :]
            psi = self.H[s][:, None, None]
            c, sn = np.cos(psi), np.sin(psi)
            d = self.P[idx] - self.G[s][:, None, None, :]
            d[..., 0] -= c * qp[..., 0] + sn * qp[..., 2]
            d[..., 1] -= qp[..., 1]
            d[..., 2] -= c * qp[..., 2] - sn * qp[..., 0]
            lin = np.sqrt(np.einsum("kfbi,kfbi->kfb", d, d)) @ self.wp
            o = self.O[idx]
            dot = np.abs(np.cos(0.5 * psi) * np.einsum("kfbi,fbi->kfb", o, qo)
                         + np.sin(0.5 * psi) * np.einsum("kfbi,fbi->kfb", o, yqo))
            ang = (2.0 * np.arccos(np.minimum(dot, 1.0))) @ self.wr
            out[a:a + _CHUNK] = w * (lin + ang)
        return out


def _parts(index: LibraryIndex):
    """``(carrier joints (16,), local COMs (16, 3), masses (16,))`` of the body parts on the index's
    skeleton (:func:`~mocomp.impact.features.body_model_for`), cached in the index."""
    cat = index.concatenated()
    if "parts" not in cat:
        body = body_model_for(index.skeleton)
        order = [body.segment_names.index(b) for b in BODY_PARTS]
        cat["parts"] = (body.segment_joint[order], body.local_coms[order], body.masses[order])
    return cat["parts"]


def _unique_rows(index: LibraryIndex, n_valid: np.ndarray, L: int) -> np.ndarray:
    """Library rows of the unique frames that can start a window of ``L`` frames, plus each clip's
    last valid start (cached per ``L``)."""
    cat = index.concatenated()
    key = ("unique_rows", L)
    if key not in cat:
        u = np.concatenate([s + c.unique for c, s in zip(index.clips, cat["start"])]).astype(np.int64)
        ci = cat["row_clip"][u]
        keep = (u - cat["start"][ci]) < n_valid[ci]
        cat[key] = np.union1d(u[keep], (cat["start"] + n_valid - 1)[n_valid > 0]).astype(np.int64)
    return cat[key]


def _unique_table(index: LibraryIndex) -> tuple[np.ndarray, np.ndarray]:
    """Every clip's unique frames end to end (clip-local numbers) and the offsets of each clip's run
    (``(C + 1,)``), for the compiled search (cached)."""
    cat = index.concatenated()
    if "unique_table" not in cat:
        U = np.concatenate([c.unique for c in index.clips]).astype(np.int64)
        off = np.concatenate([[0], np.cumsum([c.unique.size for c in index.clips])]).astype(np.int64)
        cat["unique_table"] = (U, off)
    return cat["unique_table"]


def _valid_starts(index: LibraryIndex, L: int):
    """Per clip: first row, number of valid window starts (``n - L + 1``, may be <= 0; cached per ``L``)."""
    cat = index.concatenated()
    key = ("n_valid", L)
    if key not in cat:
        cat[key] = np.ascontiguousarray(cat["length"] - L + 1, dtype=np.int64)
        cat[key].setflags(write=False)
    return cat["start"], cat[key]


def _distances(q: _Query, rows: np.ndarray, threshold: float = np.inf, margin: float = -1.0, *,
               first_only: bool = False, acc0: np.ndarray | None = None, bound: bool = False
               ) -> tuple[np.ndarray, int]:
    """Eq. 4.1 distances of the windows at library ``rows`` in the given order (``inf`` for windows
    abandoned above ``threshold``, which with ``margin >= 0`` follows the best complete window + margin),
    and the number of frame pairs compared. ``first_only``: the first-frame terms alone. ``acc0``:
    the first-frame terms already computed (the windows continue from the second frame). ``bound``:
    also abandon on the triangle-inequality bound of the remaining frames (:mod:`._kernels`).
    Compiled kernel or, without numba, the numpy reference (no abandoning)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    if rows.size == 0:
        return np.empty(0), 0
    sel = slice(0, 1) if first_only else slice(None)
    f_start = 1 if acc0 is not None else 0
    acc0 = np.zeros(rows.size) if acc0 is None else np.ascontiguousarray(acc0, dtype=float)
    if _kernels.AVAILABLE:
        out = np.empty(rows.size)
        Cl, Cq = (q.Cl, q.Cq) if bound and not first_only else (_EMPTY, _EMPTY)
        n = _kernels.window_distances_nb(q.P, q.O, q.G, q.T, rows, q.frames[sel], q.qp[sel], q.qo[sel], q.yqo[sel],
                                         q.w[sel], q.wp, q.wr, f_start, acc0, acc0, Cl, Cq, float(threshold),
                                         float(margin), out)
        return out, int(n)
    d = acc0 + q.terms(rows, slice(f_start, None) if not first_only else sel).sum(axis=1)
    thr = min(threshold, d.min() + margin) if margin >= 0 else threshold
    return np.where(d <= thr, d, np.inf), int(d.size * (q.frames[sel].size - f_start))


_EMPTY = np.zeros(0)


def _rest_bounds(q: _Query, rows: np.ndarray, first: np.ndarray) -> np.ndarray:
    """``(K,)`` the kernel's triangle-inequality lower bound of frames 1.. of each window from its
    first-frame term (:func:`mocomp.impact._kernels._rest_bound`, vectorised)."""
    if _kernels.AVAILABLE:
        out = np.empty(rows.size)
        _kernels.rest_bounds_nb(np.ascontiguousarray(rows, dtype=np.int64), np.ascontiguousarray(first), q.frames,
                                q.w, q.Cl, q.Cq, out)
        return out
    f = q.frames
    steps = q.Cl[rows[:, None] + f[None, 1:]] - q.Cl[rows][:, None] + q.Cq[None, 1:]
    return np.maximum(first[:, None] - steps, 0.0) @ q.w[1:]


def _evaluate(q: _Query, rows: np.ndarray, D: np.ndarray, threshold: float = np.inf, margin: float = -1.0) -> int:
    """Record in ``D`` (per library row, NaN = not computed) the distance of every window at ``rows``
    not computed yet that is at most ``threshold`` (and, with ``margin >= 0``, at most the best +
    ``margin``), visiting them best-first by their first-frame term plus the bound of the rest, so
    that the running threshold is tight early. Exact: no window within the final threshold is missed.
    Returns the frame pairs compared."""
    rows = rows[np.isnan(D[rows])]
    if rows.size == 0:
        return 0
    first = q.first[rows]
    need = np.isnan(first)
    n0 = 0
    if need.any():                                       # first-frame terms are kept for later passes
        first[need], n0 = _distances(q, rows[need], first_only=True)
        q.first[rows[need]] = first[need]
    order = np.argsort(first + _rest_bounds(q, rows, first), kind="stable")
    rows = rows[order]
    d, n = _distances(q, rows, threshold, margin, acc0=first[order], bound=True)
    ok = np.isfinite(d)
    D[rows[ok]] = d[ok]
    return n0 + n


def _refine(index: LibraryIndex, q: _Query, uniq: np.ndarray, D: np.ndarray, margin: float, max_regions: int,
            L: int) -> tuple[int, int]:
    """Sec. 4.1's search over the unique-frame windows ``uniq``: 1. every one within ``margin`` of the
    best of them, exactly; 2. every window between the neighbouring unique frames of those (at most
    ``max_regions``, best first) that is within the best one's distance. Returns (frame pairs
    compared, regions refined); the numpy twin of :func:`mocomp.impact._kernels._refine`."""
    compared = _evaluate(q, uniq, D, np.inf, margin)
    ev = uniq[~np.isnan(D[uniq])]
    if ev.size == 0:
        return compared, 0
    best_u = float(D[ev].min())
    ev = ev[D[ev] <= best_u + margin]
    regions = ev[np.argsort(D[ev], kind="stable")][:max_regions]
    rows = np.unique(np.concatenate([_interval_rows(index, int(r), L) for r in regions]))
    return compared + _evaluate(q, rows, D, best_u, 0.0), int(regions.size)


def _interval_rows(index: LibraryIndex, row: int, L: int) -> np.ndarray:
    """Library rows of every valid window start strictly between the unique frames neighbouring ``row``."""
    cat = index.concatenated()
    ci = int(np.searchsorted(cat["start"], row, side="right") - 1)
    s0, n_valid = int(cat["start"][ci]), int(cat["length"][ci] - L + 1)
    u = index.clips[ci].unique
    f = row - s0
    k = int(np.searchsorted(u, f))
    lo = int(u[k - 1]) + 1 if k > 0 else 0
    hi = int(u[k + 1]) - 1 if k + 1 < u.size else n_valid - 1
    hi = min(hi, n_valid - 1)
    return s0 + np.arange(lo, hi + 1, dtype=np.int64)


def _clip_of(index: LibraryIndex, row: int) -> int:
    return int(index.concatenated()["row_clip"][row])


def _result(index: LibraryIndex, q: _Query, row: int, dist: float, stats: dict) -> SearchResult:
    ci = _clip_of(index, row)
    clip = index.clips[ci]
    k = row - int(index.concatenated()["start"][ci])
    f = clip.native_frame(k)
    yaw = q.heading0 - float(clip.native_heading[f])
    yaw = float((yaw + np.pi) % (2 * np.pi) - np.pi)
    g = clip.native_ground[f]
    c, s = np.cos(yaw), np.sin(yaw)                      # t = ground0 - R_y(yaw) g, in the ground plane
    t = np.array([q.ground0[0] - (c * g[0] + s * g[2]), 0.0, q.ground0[2] - (c * g[2] - s * g[0])])
    st = dict(stats, index_frame=int(k), clip_name=clip.name)
    return SearchResult(clip.path, int(f), RootTransform(yaw, t), float(dist), None, st)


def _same_skeleton(index: LibraryIndex, skeleton) -> bool:
    """``skeleton`` equals the index's (the equal skeleton objects seen are remembered: the
    comparison costs more than a small search)."""
    if skeleton is index.skeleton:
        return True
    seen = index.concatenated().setdefault("same_skeletons", [])
    if any(skeleton is s for s in seen):
        return True
    if skeleton != index.skeleton:
        return False
    seen[:] = seen[-31:] + [skeleton]                    # strong references: no id reuse
    return True


def _far_mask(index: LibraryIndex, rows: np.ndarray, best: int, L: int) -> np.ndarray:
    """Rows in another clip than ``best`` or at least ``L`` frames from it."""
    rc = index.concatenated()["row_clip"]
    return (rc[rows] != rc[best]) | (np.abs(rows - best) >= L)


def _runner_up(index: LibraryIndex, D: np.ndarray, L: int) -> int | None:
    """The row of the best computed window far from the best one (``None`` if there is none)."""
    rows = np.flatnonzero(~np.isnan(D))
    far = rows[_far_mask(index, rows, int(rows[np.argmin(D[rows])]), L)]
    return int(far[np.argmin(D[far])]) if far.size else None


def _runner_up_distance(index: LibraryIndex, D: np.ndarray, L: int) -> float:
    ru = _runner_up(index, D, L)
    return np.inf if ru is None else float(D[ru])


def search(index: LibraryIndex, query: Motion, start: int, stop: int, *, support_foot: str | None = None,
           exhaustive: bool = False, margin_factor: float = 0.25, max_regions: int = 16,
           runner_up: str = "fast") -> SearchResult:
    """The library window that best continues ``query`` frames ``start .. stop-1`` (module docstring).

    Parameters
    ----------
    index: :func:`~mocomp.impact.index.build_index` of the library for the query's skeleton.
    query: a motion on the index's skeleton (e.g. the naive simulation), at any rate.
    start, stop: the query window, frames ``start`` (inclusive) to ``stop`` (exclusive), >= 2 frames.
    support_foot: ``"left"``/``"right"`` to force the supporting foot; ``None`` picks the foot on
        the ground nearest the centre of mass at ``start``.
    exhaustive: compare every window in full (the reference) instead of the unique-frame search.
    margin_factor, max_regions: the intervals of every unique-frame window within
        ``margin_factor * T * sum_i w_i`` of the best unique-frame window (at most ``max_regions``,
        best first) are refined (module docstring).
    runner_up: ``"fast"`` (default): the runner-up among the windows the search computed (module
        docstring; the exhaustive one in 16 of the benchmark's 23 queries); ``"exact"``: every far window
        the search left uncomputed is computed as well (abandoned once above the fast runner-up's distance,
        on the exact partial sums and the triangle bound), so the runner-up is the least distance over all
        windows far from the search's best -- the exhaustive runner-up whenever the best is the exhaustive
        best -- at the cost of those frame pairs (``stats["frames_runner_up"]``).
    """
    t0 = time.perf_counter()
    if not _same_skeleton(index, query.skeleton):
        raise MotionFormatError(
            f"the query's skeleton ({query.skeleton.n_joints} joints, root {query.skeleton.names[0]!r}) is not the "
            f"index's ({index.skeleton.n_joints} joints, root {index.skeleton.names[0]!r}); build the index for "
            "the victim's skeleton")
    start, stop = int(start), int(stop)
    if not (0 <= start < stop <= query.n_frames):
        raise ValueError(f"query window {start}..{stop} must satisfy 0 <= start < stop <= {query.n_frames} "
                         "(the query's frame count)")
    if support_foot is not None and support_foot not in FOOT_PARTS:
        raise ValueError(f"support_foot must be 'left', 'right' or None, got {support_foot!r}")
    if runner_up not in ("fast", "exact"):
        raise ValueError(f"runner_up must be 'fast' or 'exact', got {runner_up!r}")
    if not (margin_factor >= 0 and max_regions >= 1):
        raise ValueError(f"margin_factor must be >= 0 and max_regions >= 1, got {margin_factor!r}, {max_regions!r}")
    resampled = abs(query.fps / index.fps - 1.0) > RATE_TOLERANCE
    if resampled:                                        # the window at the index rate
        query = query.slice(start, stop).resample(index.fps)
        start, stop = 0, query.n_frames
    if stop - start < 2:
        raise ValueError(f"query window {start}..{stop} has {stop - start} frame at the index rate "
                         f"{index.fps:g} Hz; a window needs at least 2")
    q = _Query(index, query, start, stop, support_foot)
    t1 = time.perf_counter()
    L = q.L
    starts, n_valid = _valid_starts(index, L)
    if not np.any(n_valid > 0):
        longest = max(c.n_frames for c in index.clips)
        raise ValueError(f"the query window has {L} frames at {index.fps:g} Hz; the longest library clip has "
                         f"{longest}: no clip can hold the window")
    n_windows = int(np.maximum(n_valid, 0).sum())
    nF = q.frames.size
    stats = {"frames_exhaustive": int(n_windows * nF), "windows_exhaustive": n_windows,
             "window_frames": int(L), "support_foot": q.support, "exhaustive": bool(exhaustive),
             "query_resampled": bool(resampled),
             "clips_too_short": [c.name for c, n in zip(index.clips, n_valid) if n <= 0]}
    D = np.full(q.P.shape[0], np.nan)                   # complete window distances per library row
    if exhaustive:
        all_rows = np.concatenate([s + np.arange(max(n, 0)) for s, n in zip(starts, n_valid)]).astype(np.int64)
        D[all_rows], _ = _distances(q, all_rows)
        stats.update(frames_compared=stats["frames_exhaustive"], frames_exact=stats["frames_exhaustive"],
                     windows_compared=n_windows, unique_windows=0)
    elif _kernels.AVAILABLE:                             # the whole search in one compiled call
        uniq = _unique_rows(index, n_valid, L)
        U, Uoff = _unique_table(index)
        first = np.full(q.P.shape[0], np.nan)
        out = np.empty(6, np.int64)
        _kernels.search_nb(q.P, q.O, q.G, q.T, q.Cl, index.concatenated()["row_clip"], starts,
                           n_valid, U, Uoff, uniq, q.frames, q.qp, q.qo,
                           q.yqo, q.w, q.wp, q.wr, q.Cq, L, float(margin_factor * index.tolerance * q.w.sum()),
                           int(max_regions), D, first, out)
        stats.update(frames_compared=int(out[2]), frames_exact=int(out[3]), windows_compared=int(out[4]),
                     unique_windows=int(uniq.size), refined_regions=int(out[5]))
        best, ru = int(out[0]), (int(out[1]) if out[1] >= 0 else None)
    else:                                                # the numpy reference of search_nb
        uniq = _unique_rows(index, n_valid, L)
        margin = float(margin_factor * index.tolerance * q.w.sum())
        compared, n_regions = _refine(index, q, uniq, D, margin, max_regions, L)
        # 3. the runner-up: the best complete window far from the best (if none, the far unique-frame
        #    windows are computed first), refined in its interval
        best = int(np.nanargmin(D))
        if _runner_up(index, D, L) is None:
            compared += _evaluate(q, uniq[_far_mask(index, uniq, best, L)], D, np.inf, 0.0)
        ru = _runner_up(index, D, L)
        if ru is not None:
            more = _interval_rows(index, ru, L)
            compared += _evaluate(q, more[_far_mask(index, more, best, L)], D, float(D[ru]))
        stats.update(frames_compared=int(compared), frames_exact=int(compared),
                     windows_compared=int(np.count_nonzero(~np.isnan(q.first))), unique_windows=int(uniq.size),
                     refined_regions=int(n_regions))
    if exhaustive or not _kernels.AVAILABLE:
        best = int(np.nanargmin(D))
        ru = _runner_up(index, D, L)
    stats["runner_up_mode"] = "exact" if exhaustive else runner_up
    if runner_up == "exact" and not exhaustive:
        # every far window not computed in full by the search, computed now: the runner-up is exact
        all_rows = np.concatenate([s + np.arange(max(n, 0)) for s, n in zip(starts, n_valid)]).astype(np.int64)
        far = all_rows[_far_mask(index, all_rows, best, L)]
        todo = far[~np.isfinite(D[far])]
        cnt = 0
        if todo.size:
            # abandoned above the fast runner-up's distance (the exact one is no larger): those windows
            # cannot be the runner-up (inf), the others are summed in full
            thr = float(D[ru]) if ru is not None and np.isfinite(D[ru]) else np.inf
            D[todo], cnt = _distances(q, todo, thr, 0.0, bound=True)
        stats["frames_runner_up"] = int(cnt)
        ru = int(far[np.argmin(D[far])]) if far.size else None
    t2 = time.perf_counter()
    stats.update(seconds=t2 - t0, seconds_query=t1 - t0, seconds_matching=t2 - t1)
    runner = _result(index, q, ru, float(D[ru]), stats) if ru is not None else None
    res = _result(index, q, best, float(D[best]), stats)
    return SearchResult(res.clip, res.frame, res.root_transform, res.distance, runner, res.stats)


def reentry_frame_costs(state: Motion, clip: Motion, frame: int, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """``(frames (K,), costs (K,))``: eq. 4.1's frame term between the simulated state ``state``
    (one frame, or its last frame) and each frame of ``clip`` within ``radius`` frames of ``frame``,
    each in its own ground frame (root ground point and heading removed, height kept), with the
    Table A.1 weights and the supporting foot of the state (sec. 4.1). The search matched the
    *naive* simulation; this re-scores the found clip's frames against the *active* simulation's
    state at the re-entry, for :class:`~mocomp.impact.pipeline.ImpactConfig` ``reentry_radius``
    (beyond the paper: it blends onto the frame the search found)."""
    from .features import body_features, ground_frame_features, part_weights
    from .index import frame_distances

    if radius < 0:
        raise ValueError(f"radius must be >= 0, got {radius}")
    if state.skeleton.names != clip.skeleton.names:
        raise ValueError("reentry_frame_costs: the state and the clip must share one skeleton")
    frames = np.arange(max(0, frame - radius), min(clip.n_frames - 1, frame + radius) + 1)
    if frames.size == 0:
        raise ValueError(f"reentry_frame_costs: frame {frame} outside the clip's {clip.n_frames} frames")
    fs = body_features(state.slice(state.n_frames - 1, state.n_frames), velocities=False)
    fc = body_features(clip.slice(int(frames[0]), int(frames[-1]) + 1), velocities=False)
    ps, os_ = ground_frame_features(fs.positions, fs.orientations, fs.ground, fs.heading)
    pc, oc = ground_frame_features(fc.positions, fc.orientations, fc.ground, fc.heading)
    wp, wr = part_weights(support_foot_of(fs.com[0], fs.positions[0]))
    return frames, frame_distances(ps[0][None], os_[0][None], pc, oc, wp, wr)
