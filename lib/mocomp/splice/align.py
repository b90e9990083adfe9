"""Two-stage alignment of a full-body motion and a hand motion (dissertation ch. 6.1-6.2).

1. *Phase matching*: DTW with the sign metric of eq. 6.6 (rotation ``theta``
   of eq. 6.7) in a band of ``W = 0.30 n`` frames (``n`` = body length),
   reshaped by the user's matching points (eq. 6.4-6.5, Algorithm 1).
2. *Within-phase refinement*: the hand motion is warped onto the body's frames
   along the first path; a second DTW with the hand-angle metric of eq.
   6.8-6.9 in a narrower band (``W = 0.10 n``) around the new diagonal
   adjusts frames inside each phase. Before it, the warped hand's forearm and
   hand vectors are turned about the vertical into the body's heading at each
   matched frame (``SpliceConfig.refine_theta``: the trunk-heading difference,
   or eq. 6.7 pooled over 4 s): eq. 6.9 compares vectors in world
   coordinates, and without the turn a hand recording facing 70 (120) degrees
   away, or a body that turns while walking, misaligned the second pass by
   3-22 frames although the first pass was within 1. The user's points are re-mapped into the
   warped hand's frame numbers first ("we recompute the user's input so the
   frame numbers that need to be matched correspond to frames in the aligned
   motion").

Frame maps (``SpliceConfig.frame_map``):

* ``"taut"`` (default): after each pass the map is the least-distorting one
  among the near-optimal alignments (:mod:`~mocomp.splice.warpmap`): within
  a phase the sign metric cannot tell frames apart (Figure 6.5 c), and in a
  hold no metric can, so instead of the arbitrary member of the tie that the
  backtracking returns (an L-shaped staircase) we take the straight line
  through the tube of alignments whose cost exceeds the optimum by at most
  ``tie_cells`` times the optimal path's mean cost per matched pair. The hand is warped by this map for the second pass, and the final
  map is the second pass's taut map composed with the first's.
* ``"median"``: the paper taken literally: each pass's map is the median of
  the frames its optimal path matches to each body frame, and the final
  correspondence composes both paths (body frame ``i`` matches the hand
  frames that the first pass matched to the warped frames the second pass
  matched to ``i``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import AlignmentError
from .bands import MatchPoint, as_points, matching_band
from .dtw import DTWResult, dtw_band_costs, path_row_median, warp_values
from .markers import HandMarkers
from .warpmap import frame_map as taut_frame_map, rasterize_map
from .metrics import (ArmFeatures, angle_band_costs, arm_features, matched_theta, rotate_vertical, sign_band_costs,
                      value_band_costs)

__all__ = ["SpliceConfig", "Alignment", "align_hands", "refine_theta", "remap_points", "compose_paths", "alignment_error"]


@dataclass(frozen=True)
class SpliceConfig:
    """Parameters of the two-stage alignment (defaults: the paper's).

    Attributes
    ----------
    phase_width: band half-width ``W`` of the first pass as a fraction of the
        body motion's length (paper: 30 %).
    refine_width: same for the second pass (paper: 10 %).
    theta: ``"window"`` (eq. 6.7 over ``theta_window`` frames), ``"trunk"``
        (trunk-heading difference, as the paper did for the dance) or ``"none"``.
    theta_window: frames per eq. 6.7 window (paper: 5, i.e. 20 marker positions).
    metric: ``"sign"`` (eq. 6.6) or ``"values"`` (the derivative-value foil of Figure 6.4).
    value_tau: seconds weighting accelerations in the value metric.
    smooth: Savitzky-Golay window for the derivatives, seconds.
    dead_zone: sign dead zone relative to each derivative's 95th percentile.
    refine: run the second (eq. 6.9) pass.
    refine_step_cost: radians added to every cell of the second pass (a cost
        per matched pair, so the path does not wander where the hand angle is flat).
    frame_map: ``"taut"`` (least-distorting near-optimal map, see the module
        docstring) or ``"median"`` (the optimal paths' row medians, the paper's).
    tie_cells: cost margin of the near-optimal tube (``"taut"``) in units of
        the optimal path's mean cost per matched pair: alignments costing at
        most that much more than the optimum count as equally good.
    refine_theta: rotation about the vertical that turns the hand
        recording's eq. 6.8 vectors into the body's heading before the second
        pass (eq. 6.9 compares vectors in world coordinates, so without it the
        cost changes with the direction the performers face):
        ``"auto"`` (default) the trunk-heading difference when both recordings
        have a trunk heading, else the first pass's ``theta`` mode;
        ``"window"`` eq. 6.7 between each body frame and its matched hand frame
        (pooled over ``refine_theta_span``); ``"trunk"``; ``"none"`` (the
        vectors as recorded). See :func:`~mocomp.splice.metrics.matched_theta`.
    refine_theta_span: seconds over which ``"window"``'s eq. 6.7 sums are pooled
        (a heading changes over seconds, while one 5-frame window also
        answers to the arm's own swing, which differs between the
        performances: on 25 turned/turning ground-truth pairs the mean final
        error was 1.06 frames with 1 s, 1.02 with 4 s, 1.42 with 8 s,
        4.2 with one angle for the whole take, 0.90 with the trunk headings
        and 9.1 without any turn).
    band_width_kind: how ``phase_width``/``refine_width`` are read: ``"half"``
        (default; the paper's "band width equal to 30 % ... of the full-body
        motion length" read as the half-width ``W`` of eq. 6.3, the band's
        extent on *each* side of the diagonal, measured perpendicular to it:
        the reading of all earlier versions; on the real pairs the 30 % band
        then covers 69-78 % of the matrix) or ``"full"`` (the fraction is the
        band's whole width, so ``W`` is half of it: a 30 % band covers about
        half the matrix).
    subsequence: open-begin/open-end alignment (issue #19 item 9): before the
        two passes, the whole hand recording is located inside the body
        recording by subsequence DTW on the pass-1 metric
        (:mod:`~mocomp.splice.subsequence`), and only that interval is
        aligned (``Alignment.interval``). Off by default: the paper stretches
        the whole hand clip over the whole body clip.
    locate_smooth, locate_dead_zone: derivative window (s) and sign dead zone
        of the eq. 6.6 features of the subsequence search only. The search has
        no pinned corners, so it is at the mercy of noise at the gesture's
        slow ends: on 20 embedded ground-truth pairs (3 s gesture in a 20 s
        walk, warp strength 0.3, default noise) the interval's ends were within
        2 frames for 14 with the pass-1 values (0.2 s, 0.05), 16 with
        (0.3 s, 0.05), 16 with (0.2 s, 0.15), 19 with (0.3 s, 0.15; worst 5
        frames) and 18 with (0.4 s, 0.10).
    strict_points: a user point outside the first pass's eq. 6.3 band raises
        :class:`~mocomp.errors.AlignmentError` (naming the point and the band's
        columns in its row) instead of reshaping the band (Algorithm 1, the
        default; see :func:`~mocomp.splice.bands.matching_band`).
    """

    phase_width: float = 0.30
    refine_width: float = 0.10
    theta: str = "window"
    theta_window: int = 5
    metric: str = "sign"
    value_tau: float = 0.1
    smooth: float = 0.2
    dead_zone: float = 0.05
    refine: bool = True
    refine_step_cost: float = 0.05
    frame_map: str = "taut"
    tie_cells: float = 2.0
    refine_theta: str = "auto"
    refine_theta_span: float = 4.0
    strict_points: bool = False
    band_width_kind: str = "half"
    subsequence: bool = False
    locate_smooth: float = 0.3
    locate_dead_zone: float = 0.15

    def half_width(self, fraction: float, n: int) -> float:
        """``W`` of eq. 6.3 in frames for a band stated as ``fraction`` of the body length ``n``
        (``band_width_kind``: the fraction is the half-width, or the full width)."""
        return fraction * n * (1.0 if self.band_width_kind == "half" else 0.5)

    def __post_init__(self):
        if self.band_width_kind not in ("half", "full"):
            raise ValueError(f"band_width_kind must be 'half' or 'full', got {self.band_width_kind!r}")
        for name in ("phase_width", "refine_width"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise AlignmentError(f"{name} must be a positive fraction of the body length, got {v!r}")
        if self.theta not in ("window", "trunk", "none"):
            raise ValueError(f"theta must be 'window', 'trunk' or 'none', got {self.theta!r}")
        if self.metric not in ("sign", "values"):
            raise ValueError(f"metric must be 'sign' or 'values', got {self.metric!r}")
        if self.refine_theta not in ("auto", "window", "trunk", "none"):
            raise ValueError(f"refine_theta must be 'auto', 'window', 'trunk' or 'none', got {self.refine_theta!r}")
        if not (np.isfinite(self.refine_theta_span) and self.refine_theta_span >= 0):
            raise AlignmentError(f"refine_theta_span must be >= 0 seconds, got {self.refine_theta_span!r}")
        if self.frame_map not in ("taut", "median"):
            raise ValueError(f"frame_map must be 'taut' or 'median', got {self.frame_map!r}")
        if not (np.isfinite(self.tie_cells) and self.tie_cells >= 0):
            raise AlignmentError(f"tie_cells must be a non-negative number of cells, got {self.tie_cells!r}")
        if not (np.isfinite(self.refine_step_cost) and self.refine_step_cost >= 0):
            raise AlignmentError(f"refine_step_cost must be >= 0 radians, got {self.refine_step_cost!r}")


@dataclass(frozen=True, eq=False)
class Alignment:
    """Frame correspondence between a body motion (``n`` frames) and a hand motion (``m``).

    Attributes
    ----------
    n, m: lengths.
    pass1: the phase-matching DTW (``n x m``).
    pass2: the refinement DTW (``n x n``: body vs. the hand warped by pass 1), or ``None``.
    stage1_map: ``(n,)`` hand frame (fractional) matched to each body frame by pass 1.
    hand_frame: ``(n,)`` final hand frame (fractional) per body frame.
    path: ``(K, 2)`` monotone integer correspondence ``(body frame, hand frame)``:
        the composed optimal paths (``"median"``) or the final map rasterised
        (``"taut"``, :func:`~mocomp.splice.warpmap.rasterize_map`); the median
        merge uses it.
    tubes: per pass (``"pass1"``, ``"pass2"``) the near-optimal tube ``(lo, hi)``
        the taut map runs through (``"taut"`` only).
    stage2_map: ``(n,)`` warped-hand frame per body frame from pass 2, or ``None``.
    points: user matching points (body frame, hand frame).
    points2: the same re-mapped for pass 2 (body frame, warped-hand frame).
    config: the :class:`SpliceConfig` used.
    body_features, hand_features: the per-frame quantities of the metrics.
    timings: seconds per stage (``features``, ``pass1``, ``pass2``, ``total``).
    """

    n: int
    m: int
    pass1: DTWResult
    pass2: DTWResult | None
    stage1_map: np.ndarray
    hand_frame: np.ndarray
    path: np.ndarray
    points: tuple[MatchPoint, ...]
    points2: tuple[MatchPoint, ...]
    config: SpliceConfig
    body_features: ArmFeatures = field(repr=False)
    hand_features: ArmFeatures = field(repr=False)
    timings: dict = field(default_factory=dict)
    tubes: dict = field(default_factory=dict, repr=False)
    stage2_map: np.ndarray | None = field(default=None, repr=False)
    interval: tuple[int, int] | None = None
    locate: object | None = field(default=None, repr=False)

    @property
    def offset(self) -> int:
        """Body-clip frame of this alignment's row 0 (the matched interval's start in subsequence mode)."""
        return 0 if self.interval is None else self.interval[0]

    def matches(self, i: int) -> np.ndarray:
        """Hand frames matched to body frame ``i``."""
        return self.path[self.path[:, 0] == i, 1]

    def error(self, truth: np.ndarray) -> dict:
        """Alignment error against a known map ``truth (n,)`` (hand frame per body frame)."""
        return alignment_error(self.hand_frame, truth)

    def point_residuals(self) -> np.ndarray:
        """For each user point, the distance (hand frames) from ``y`` to the nearest
        hand frame matched to body frame ``x`` (0 when the point is honoured exactly)."""
        out = []
        for p in self.points:
            js = self.matches(p.x - self.offset)
            out.append(float(np.min(np.abs(js - p.y))))
        return np.array(out)


def alignment_error(estimate: np.ndarray, truth: np.ndarray) -> dict:
    """Mean/median/max absolute frame error and the share within 1 and 2 frames."""
    e = np.abs(np.asarray(estimate, float) - np.asarray(truth, float))
    if e.shape != np.shape(truth):
        raise ValueError(f"estimate {np.shape(estimate)} and truth {np.shape(truth)} differ in shape")
    return {"mean": float(e.mean()), "median": float(np.median(e)), "max": float(e.max()),
            "within_1": float(np.mean(e <= 1.0)), "within_2": float(np.mean(e <= 2.0))}


def remap_points(points: tuple[MatchPoint, ...], stage1_map: np.ndarray, n2: int) -> tuple[MatchPoint, ...]:
    """Re-express user points ``(x, y)`` (body, hand frames) as ``(x, y')`` with ``y'``
    the warped-hand frame whose source hand frame is ``y`` (nearest to ``x``
    among equals); a tolerance ``T`` becomes the span of warped frames whose
    source lies within ``[y - T, y + T]``."""
    out = []
    f = np.asarray(stage1_map, float)
    for k, p in enumerate(points):
        d = np.abs(f - p.y)
        cand = np.nonzero(d == d.min())[0]
        y2 = int(cand[np.argmin(np.abs(cand - p.x))])
        inside = np.nonzero((f >= p.y - p.tol) & (f <= p.y + p.tol))[0]
        tol2 = 0 if p.tol == 0 or inside.size == 0 else int(max(y2 - inside.min(), inside.max() - y2))
        y2 = min(max(y2, 1), n2 - 2)
        out.append(MatchPoint(p.x, y2, tol2))
    for k in range(1, len(out)):
        if out[k].y <= out[k - 1].y:
            raise AlignmentError(
                f"matching points {points[k - 1]} and {points[k]} fall on the same warped frame after the first pass; "
                f"move them further apart"
            )
    return tuple(out)


def compose_paths(path2: np.ndarray, path1: np.ndarray, n_mid: int) -> np.ndarray:
    """Compose ``path2 (i, a)`` with ``path1 (a, j)`` into the unique sorted pairs ``(i, j)``."""
    path1 = np.asarray(path1)
    rows = path1[:, 0]
    starts = np.searchsorted(rows, np.arange(n_mid), side="left")
    stops = np.searchsorted(rows, np.arange(n_mid), side="right")
    counts = (stops - starts)[path2[:, 1]]
    i = np.repeat(path2[:, 0], counts)
    idx = np.concatenate([np.arange(starts[a], stops[a]) for a in path2[:, 1]])
    j = path1[idx, 1]
    pairs = np.unique(np.stack([i, j], axis=1), axis=0)
    return pairs


def refine_theta(body: ArmFeatures, hand: ArmFeatures, stage1_map: np.ndarray, config: SpliceConfig) -> np.ndarray:
    """Per body frame, the angle (radians) about the vertical by which the
    second pass turns the hand recording's eq. 6.8 vectors, warped by
    ``stage1_map``, before eq. 6.9 (``SpliceConfig.refine_theta``)."""
    mode = config.refine_theta
    if mode == "auto":
        mode = "trunk" if body.heading is not None and hand.heading is not None else config.theta
    span = max(1, int(round(config.refine_theta_span * body.fps)) | 1)
    return matched_theta(body, hand, stage1_map, mode, span)


def align_hands(body: HandMarkers, hand: HandMarkers, points=(), config: SpliceConfig | None = None,
                **overrides) -> Alignment:
    """Align a body recording's hand markers with a hand recording's (two-stage DTW, ch. 6.1-6.2).

    ``points`` are user matching points ``(body frame, hand frame[, tolerance])``
    (or :class:`MatchPoint` / ``"x:y~t"``), strictly increasing in both frames.
    A point outside the first pass's band reshapes it (Algorithm 1) unless
    ``strict_points=True``, which raises instead; a point on every body frame
    works only for equal lengths (:func:`~mocomp.splice.bands.matching_band`).
    Both recordings must have the same
    frame rate (resample first). Keyword overrides change single
    :class:`SpliceConfig` fields.
    """
    cfg = config or SpliceConfig()
    if overrides:
        from dataclasses import replace

        cfg = replace(cfg, **overrides)
    if abs(body.fps - hand.fps) > 1e-6 * body.fps:
        raise AlignmentError(f"body ({body.fps:g} fps) and hand ({hand.fps:g} fps) must share a frame rate; resample the hand motion")
    pts = as_points(points)
    if cfg.subsequence:
        return _align_subsequence(body, hand, pts, cfg)
    t0 = time.perf_counter()
    fb = arm_features(body, smooth=cfg.smooth, dead_zone=cfg.dead_zone, theta_window=cfg.theta_window, role="body")
    fh = arm_features(hand, smooth=cfg.smooth, dead_zone=cfg.dead_zone, theta_window=cfg.theta_window, role="hand")
    n, m = fb.n_frames, fh.n_frames
    t1 = time.perf_counter()
    band1 = matching_band(n, m, cfg.half_width(cfg.phase_width, n), pts, strict=cfg.strict_points)
    if cfg.metric == "sign":
        c1 = sign_band_costs(fb, fh, band1, cfg.theta)
    else:
        c1 = value_band_costs(fb, fh, band1, cfg.theta, cfg.value_tau)
    tc = time.perf_counter()
    r1 = dtw_band_costs(band1, c1, cost_seconds=tc - t1)
    taut = cfg.frame_map == "taut"
    tubes = {}
    if taut:
        map1, tubes["pass1"] = taut_frame_map(r1, cfg.tie_cells)
    else:
        map1 = r1.row_median()
    t2 = time.perf_counter()
    r2 = map2 = None
    pts2: tuple[MatchPoint, ...] = ()
    if cfg.refine and n >= 3:
        # the hand recording's eq. 6.8 vectors, warped onto the body's frames
        f2, h2 = warp_values(fh.forearm, map1), warp_values(fh.hand, map1)
        # ... turned into the body's heading at each matched frame (eq. 6.9
        # compares world-frame vectors, so without this its cost changes
        # with the hand recording's heading)
        th2 = refine_theta(fb, fh, map1, cfg)
        f2, h2 = rotate_vertical(f2, th2), rotate_vertical(h2, th2)
        pts2 = remap_points(pts, map1, n)
        band2 = matching_band(n, n, cfg.half_width(cfg.refine_width, n), pts2)
        ts = time.perf_counter()
        c2 = angle_band_costs(fb.forearm, fb.hand, f2, h2, band2) + cfg.refine_step_cost
        r2 = dtw_band_costs(band2, c2, cost_seconds=time.perf_counter() - ts)
        if taut:
            map2, tubes["pass2"] = taut_frame_map(r2, cfg.tie_cells)
            final = np.interp(map2, np.arange(n), map1)
        else:
            map2 = r2.row_median()
            path = compose_paths(r2.path, r1.path, n)
    else:
        final = map1
        path = r1.path
    if taut:
        # a matching point's row keeps to its window y +- T (the map does; the
        # rasterised time cell of a steep map could reach past it)
        lo_b, hi_b = np.zeros(n, dtype=np.int64), np.full(n, m - 1, dtype=np.int64)
        for p in pts:
            lo_b[p.x], hi_b[p.x] = max(p.y - p.tol, 0), min(p.y + p.tol, m - 1)
        path = rasterize_map(final, m, lo_b, hi_b)
    elif r2 is not None:
        final = path_row_median(path, n)
    t3 = time.perf_counter()
    for a in (map1, final, path, map2):
        if a is not None:
            a.setflags(write=False)
    return Alignment(
        n=n, m=m, pass1=r1, pass2=r2, stage1_map=map1, hand_frame=final, path=path,
        points=pts, points2=pts2, config=cfg, body_features=fb, hand_features=fh,
        timings={"features": t1 - t0, "pass1": t2 - t1, "pass2": t3 - t2, "total": t3 - t0}, tubes=tubes,
        stage2_map=map2,
    )


def _align_subsequence(body: HandMarkers, hand: HandMarkers, pts: tuple[MatchPoint, ...], cfg: SpliceConfig) -> Alignment:
    """``SpliceConfig.subsequence``: locate the hand recording inside the body
    recording (open-begin/open-end DTW, :func:`~mocomp.splice.subsequence.subsequence_dtw`,
    on the pass-1 metric of eq. 6.6 over the whole matrix), then align that
    interval with the two passes. User points are in body-clip frames and
    must fall inside the interval found."""
    from dataclasses import replace

    from .bands import full_band
    from .subsequence import subsequence_dtw

    t0 = time.perf_counter()
    fb = arm_features(body, smooth=cfg.locate_smooth, dead_zone=cfg.locate_dead_zone, theta_window=cfg.theta_window, role="body")
    fh = arm_features(hand, smooth=cfg.locate_smooth, dead_zone=cfg.locate_dead_zone, theta_window=cfg.theta_window, role="hand")
    band = full_band(fb.n_frames, fh.n_frames)
    if cfg.metric == "sign":
        c = sign_band_costs(fb, fh, band, cfg.theta)
    else:
        c = value_band_costs(fb, fh, band, cfg.theta, cfg.value_tau)
    loc = subsequence_dtw(c.reshape(band.n, band.m))
    a, e = loc.start, loc.end
    t1 = time.perf_counter()
    need = max(fb.smooth_frames, 3)
    if e - a + 1 < need:
        raise AlignmentError(
            f"subsequence search matched the {fh.n_frames}-frame hand recording to only body frames {a}-{e} "
            f"({e - a + 1} frames; at least {need} are needed): the hand gesture was not found in the body recording"
        )
    for k, p in enumerate(pts, 1):
        if not (a < p.x < e):
            raise AlignmentError(
                f"matching point {k} ({p}) lies outside the body interval {a}-{e} where the subsequence search "
                f"placed the hand recording; drop the point or align without --subsequence"
            )
    inner = align_hands(body[a:e + 1], hand, tuple(MatchPoint(p.x - a, p.y, p.tol) for p in pts),
                        replace(cfg, subsequence=False))
    tm = dict(inner.timings)
    tm["locate"] = t1 - t0
    tm["total"] = time.perf_counter() - t0
    return replace(inner, points=pts, interval=(a, e), locate=loc, config=cfg, timings=tm)
