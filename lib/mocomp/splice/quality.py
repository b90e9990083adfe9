"""The splice measures its own quality (issue #19 item 7).

The dissertation's pipeline (ch. 6.1-6.2: eq. 6.1-6.9, Algorithm 1, the
median merge) has no failure signal: the DTW always returns *a* path. On
periodic gestures (a wave), every alignment that is off by a whole number of
cycles costs about the same under eq. 6.6, and the optimal path can park the
hand on one frame for a second or more while the body's own hand keeps
waving (Bandai ``wave-both-hands`` <- ``wave-right-hand``: 47 frames frozen
with the taut map, 54 with the paper's row medians). This module measures,
on the frames the splice writes:

* **frozen** stretches: the spliced hand marker (shoulder-relative) moves at
  less than ``frozen_fraction`` of *both* inputs' speeds averaged over a window -- the
  body recording's own hand at the same body frames, and the hand recording
  over the hand frames the window shows, whatever the pace (a map that stalls on a *hold* of the
  hand recording is a stretched hold, not a freeze, by this definition: the
  warp-slope check reports it);
* **reversed** stretches: the spliced hand moves against the body's own hand
  (windowed cosine of the two velocity sequences below ``-reversed_cosine``
  while both move), e.g. a wave half a cycle off;
* **warp slope** outside ``slope_range``: the local playback rate of the hand
  recording ``d(hand frame)/d(body frame)``, over a window, relative to the
  clip pair's mean rate ``(m-1)/(n-1)``, where the body's own hand moves
  (a hold played at any rate looks the same);
* **residual misalignment after pass 2**: eq. 6.9's hand angle between the
  body's frame and the hand frame it finally shows (eq. 6.8 vectors, forearms
  aligned), windowed, above ``residual_deg``.

Speeds and velocities are those of the shoulder-relative hand marker turned
into the trunk's heading frame (when both recordings have a trunk heading),
so the trunk's own yaw does not count as hand movement. Each finding is a
:class:`Stretch` of body frames. :func:`suggest_points`
proposes two tolerant matching points (``--match A:B~T``, eq. 6.5) inside the
longest frozen stretch and *verifies* the proposal by splicing again with it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..errors import AlignmentError
from .bands import MatchPoint

__all__ = ["QualityThresholds", "Stretch", "SpliceQuality", "Suggestion", "measure_quality", "suggest_points",
           "dominant_period"]


@dataclass(frozen=True)
class QualityThresholds:
    """What counts as a failure of the splice (all stated, none hidden).

    Attributes
    ----------
    window: seconds over which speeds, velocity cosines, slopes and residuals are averaged.
    frozen_fraction: the spliced hand is frozen where its speed is below this
        fraction of both inputs' windowed speeds.
    reversed_cosine: the spliced hand is reversed where the windowed cosine
        between its velocity and the body's own hand velocity is below
        ``-reversed_cosine`` (both moving faster than ``frozen_fraction`` of the body's
        95th-percentile speed).
    slope_range: allowed local playback rate of the hand recording, relative to
        the pair's mean rate ``(m-1)/(n-1)`` (1 = uniform stretch).
    residual_deg: windowed eq. 6.9 residual (degrees) above which a stretch is
        reported as misaligned after pass 2.
    min_duration: seconds; shorter stretches are not reported.
    """

    window: float = 0.5
    frozen_fraction: float = 0.1
    reversed_cosine: float = 0.5
    slope_range: tuple[float, float] = (1.0 / 3.0, 3.0)
    residual_deg: float = 60.0
    min_duration: float = 0.2

    def __post_init__(self):
        lo, hi = self.slope_range
        if not (0 <= lo < 1 < hi):
            raise AlignmentError(f"slope_range must satisfy 0 <= low < 1 < high, got {self.slope_range}")
        for name in ("window", "frozen_fraction", "reversed_cosine", "residual_deg", "min_duration"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise AlignmentError(f"quality threshold {name} must be a non-negative number, got {v!r}")


@dataclass(frozen=True)
class Stretch:
    """A run of body frames ``start..stop-1`` where the splice fails a check.

    kind: ``"frozen"``, ``"reversed"``, ``"slope"`` or ``"residual"``.
    value: the worst windowed value inside (speed ratio, cosine, slope ratio, degrees).
    """

    kind: str
    start: int
    stop: int
    value: float
    fps: float

    @property
    def frames(self) -> int:
        return self.stop - self.start

    def frames_text(self) -> str:
        return f"body frames {self.start}-{self.stop - 1} ({self.frames} frames, {self.frames / self.fps:.2f} s)"

    def describe(self) -> str:
        what = {
            "frozen": f"hand frozen (speed {self.value:.2f}x the slower input's)",
            "reversed": f"hand moves against the body's own hand (velocity cosine {self.value:+.2f})",
            "slope": f"warp slope {self.value:.2f}x the mean rate",
            "residual": f"residual hand angle after pass 2 up to {self.value:.0f} deg (eq. 6.9)",
        }[self.kind]
        return f"{what} at {self.frames_text()}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "start": self.start, "stop": self.stop, "frames": self.frames,
                "seconds": self.frames / self.fps, "value": float(self.value)}


@dataclass(frozen=True, eq=False)
class Suggestion:
    """Two tolerant matching points for the longest frozen stretch, verified by splicing again.

    points: the suggested points (with any the user gave), body frame : hand frame ~ tolerance.
    frozen_before, frozen_after: frozen frames (all stretches) without and with them.
    tried: ``(points, frozen frames)`` for every candidate tried.
    """

    points: tuple[MatchPoint, ...]
    new_points: tuple[MatchPoint, ...]
    frozen_before: int
    frozen_after: int
    stretches_after: tuple[Stretch, ...] = ()
    tried: tuple = ()

    def text(self) -> str:
        args = " ".join(f"--match {p}" for p in self.new_points)
        return (f"{args} (verified: frozen frames {self.frozen_before} -> {self.frozen_after})")

    def to_dict(self) -> dict:
        return {"points": [str(p) for p in self.points], "new_points": [str(p) for p in self.new_points],
                "frozen_before": self.frozen_before, "frozen_after": self.frozen_after,
                "stretches_after": [s.to_dict() for s in self.stretches_after],
                "tried": [{"points": [str(p) for p in pts], "frozen": f} for pts, f in self.tried]}


@dataclass(frozen=True, eq=False)
class SpliceQuality:
    """The splice's own quality measures for one arm (see the module docstring).

    Per-frame curves are over the body frames the alignment covers
    (``offset .. offset + n - 1`` of the body clip); stretches are in body-clip frames.

    speed: ``(n,)`` m/s of the spliced hand marker relative to the shoulder.
    body_speed, hand_speed: ``(n,)`` windowed reference speeds (body's own hand;
        hand recording around the shown frames).
    cosine: ``(n,)`` windowed velocity cosine spliced vs. body's own hand.
    slope: ``(n,)`` windowed playback rate relative to the mean rate.
    residual_deg: ``(n,)`` eq. 6.9 angle after the final map, or ``None`` without pass 2.
    stretches: every :class:`Stretch` found.
    suggestion: a verified :class:`Suggestion`, or ``None``.
    map_stall_frames: body frames where the final map advances by less than 5 %
        of the mean rate to the next frame (the map's own count of a stall, any length).
    """

    side: str
    offset: int
    fps: float
    speed: np.ndarray
    body_speed: np.ndarray
    hand_speed: np.ndarray
    cosine: np.ndarray
    slope: np.ndarray
    residual_deg: np.ndarray | None
    stretches: tuple[Stretch, ...]
    thresholds: QualityThresholds
    suggestion: Suggestion | None = None
    map_stall_frames: int = 0

    def of_kind(self, kind: str) -> tuple[Stretch, ...]:
        return tuple(s for s in self.stretches if s.kind == kind)

    @property
    def frozen_frames(self) -> int:
        return sum(s.frames for s in self.of_kind("frozen"))

    @property
    def ok(self) -> bool:
        return not self.stretches

    def with_suggestion(self, suggestion: "Suggestion | None") -> "SpliceQuality":
        from dataclasses import replace

        return replace(self, suggestion=suggestion)

    def warnings(self) -> list[str]:
        """One line per stretch (and the suggestion), for ``mocomp splice: warning: ...``."""
        out = [f"{self.side} arm: {s.describe()}" for s in self.stretches]
        if self.suggestion is not None:
            out.append(f"{self.side} arm: two tolerant matching points would cut the freeze: {self.suggestion.text()}")
        return out

    def to_dict(self) -> dict:
        res = self.residual_deg
        return {
            "side": self.side, "ok": self.ok, "frozen_frames": self.frozen_frames,
            "stretches": [s.to_dict() for s in self.stretches],
            "thresholds": {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.thresholds.__dict__.items()},
            "map_stall_frames": self.map_stall_frames,
            "median_residual_deg": None if res is None else float(np.median(res)),
            "slope_range_seen": [float(self.slope.min()), float(self.slope.max())],
            "suggestion": None if self.suggestion is None else self.suggestion.to_dict(),
        }


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    from ..dynamics.contacts import label_intervals

    return label_intervals(mask)


def _speed(rel: np.ndarray, fps: float, smooth_frames: int) -> tuple[np.ndarray, np.ndarray]:
    from .metrics import savgol

    k = min(smooth_frames, rel.shape[0] - (1 - rel.shape[0] % 2))
    if k < 5:
        v = np.gradient(rel, 1.0 / fps, axis=0)
    else:
        v = savgol(rel, k, 1, 1.0 / fps)
    return v, np.linalg.norm(v, axis=1)


def dominant_period(speed: np.ndarray, fps: float, lo: float = 0.15, hi: float = 3.0) -> float | None:
    """Seconds of the strongest repetition in a speed curve (first autocorrelation
    peak between ``lo`` and ``hi`` seconds with correlation above 0.3), or ``None``."""
    from scipy.signal import find_peaks

    x = np.asarray(speed, float) - np.mean(speed)
    if x.size < 8 or not np.any(x):
        return None
    ac = np.correlate(x, x, "full")[x.size - 1:]
    ac = ac / ac[0]
    a, b = max(1, int(lo * fps)), min(x.size - 1, int(hi * fps))
    if b <= a:
        return None
    pk, _ = find_peaks(ac[: b + 1])
    pk = pk[(pk >= a) & (ac[pk] > 0.3)]
    return None if pk.size == 0 else float(pk[np.argmax(ac[pk])]) / fps


def measure_quality(alignment, spliced_rel: np.ndarray, *, side: str = "right", offset: int = 0,
                    thresholds: QualityThresholds | None = None) -> SpliceQuality:
    """Measure one arm's splice (module docstring) from ``spliced_rel (n, 3)``:
    the spliced hand marker (p4 of eq. 6.8) relative to the shoulder on the
    frames written, for the body frames ``alignment`` covers.

    The references come from the alignment's own features: the body
    recording's hand marker (``alignment.body_features.rel``) and the hand
    recording's (``alignment.hand_features.rel``), both shoulder-relative.
    The eq. 6.9 residual uses the eq. 6.8 vectors of both recordings at the
    final map ``alignment.hand_frame`` (pass 2 only).
    """
    from .dtw import warp_values
    from .markers import MARKER_ROLES

    th = thresholds or QualityThresholds()
    fb, fh = alignment.body_features, alignment.hand_features
    fps = fb.fps
    n = alignment.n
    spliced_rel = np.asarray(spliced_rel, float)
    if spliced_rel.shape != (n, 3):
        raise AlignmentError(f"spliced hand marker must be ({n}, 3), got {spliced_rel.shape}")
    w = max(3, int(round(th.window * fps)) | 1)
    q = MARKER_ROLES.index("hand")
    k = fb.smooth_frames
    # in the trunk's heading frame when both recordings have one: a walking body's counter-rotating chest
    # swings even a frozen arm about the vertical (0.14 m/s at the hand on the ground-truth walk)
    body_rel, hand_rel = fb.rel[:, q], fh.rel[:, q]
    if fb.heading is not None and fh.heading is not None:
        from .metrics import rotate_vertical

        spliced_rel = rotate_vertical(spliced_rel, -fb.heading)
        body_rel = rotate_vertical(body_rel, -fb.heading)
        hand_rel = rotate_vertical(hand_rel, -fh.heading)
    v_out, s_out = _speed(spliced_rel, fps, k)
    v_body, s_body = _speed(body_rel, fps, k)
    _, s_hand_rec = _speed(hand_rel, fps, k)
    f = np.asarray(alignment.hand_frame, float)
    avg = lambda x: uniform_filter1d(x, w, axis=0, mode="nearest")  # noqa: E731
    body_w = avg(s_body)
    # the hand recording's speed over the hand frames the window shows (f[i-h] .. f[i+h]; during a stall the
    # one frame shown): what the spliced hand would do if the map played those frames at any pace without stopping
    h = w // 2
    idx = np.arange(n)
    a_, b_ = np.clip(idx - h, 0, n - 1), np.clip(idx + h, 0, n - 1)
    grid = np.arange(len(s_hand_rec), dtype=float)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (s_hand_rec[1:] + s_hand_rec[:-1]))])
    span = f[b_] - f[a_]
    at = np.interp(f, grid, s_hand_rec)
    hand_w = np.where(span > 1.0, (np.interp(f[b_], grid, cum) - np.interp(f[a_], grid, cum)) / np.maximum(span, 1e-9), at)
    out_w = avg(s_out)
    ref = np.minimum(body_w, hand_w)
    floor = 0.02 * max(float(np.percentile(s_body, 95)), float(np.percentile(s_hand_rec, 95)), 1e-9)
    # windowed speeds decide (a short hold of the gesture is no freeze); each run found then grows over the
    # neighbouring frames whose own speed is also below the limit, to the stall's real ends
    ratio = out_w / np.maximum(ref, floor)
    core = (out_w < th.frozen_fraction * ref) & (ref > floor)
    slow = (s_out < th.frozen_fraction * ref) & (ref > floor)
    frozen = core.copy()
    for s0, e0 in _runs(core):
        while s0 > 0 and slow[s0 - 1]:
            s0 -= 1
        while e0 < n and slow[e0]:
            e0 += 1
        frozen[s0:e0] = True
    # reversed: windowed cosine between spliced and body velocities, where both move
    dot = avg(np.sum(v_out * v_body, axis=1))
    nrm = np.sqrt(avg(np.sum(v_out ** 2, axis=1)) * avg(np.sum(v_body ** 2, axis=1)))
    cos = dot / np.maximum(nrm, 1e-12)
    moving = th.frozen_fraction * float(np.percentile(s_body, 95))
    reversed_ = (cos < -th.reversed_cosine) & (out_w > moving) & (body_w > moving)
    # warp slope over the window, relative to the mean rate
    mean_rate = (alignment.m - 1) / max(alignment.n - 1, 1)
    slope = (f[b_] - f[a_]) / np.maximum(b_ - a_, 1) / max(mean_rate, 1e-12)
    lo, hi = th.slope_range
    # where the body's own hand holds, any playback rate of a hold looks the same: not reported
    bad_slope = ((slope < lo) | (slope > hi)) & (body_w > moving)
    # eq. 6.9 residual at the final map (after pass 2)
    res = None
    bad_res = np.zeros(n, bool)
    if alignment.pass2 is not None:
        from .align import refine_theta
        from .metrics import rotate_vertical

        th2 = refine_theta(fb, fh, f, alignment.config)
        f2 = rotate_vertical(warp_values(fh.forearm, f), th2)
        h2 = rotate_vertical(warp_values(fh.hand, f), th2)
        res = np.degrees(_pair_angles(fb.forearm, fb.hand, f2, h2))
        res_w = avg(res)
        bad_res = res_w > th.residual_deg
    min_len = max(1, int(round(th.min_duration * fps)))
    found = []
    for kind, mask, val in (("frozen", frozen, lambda s, e: float(ratio[s:e].min())),
                            ("reversed", reversed_, lambda s, e: float(cos[s:e].min())),
                            ("slope", bad_slope, lambda s, e: float(slope[s:e][np.argmax(np.abs(np.log(np.maximum(slope[s:e], 1e-9))))])),
                            ("residual", bad_res, lambda s, e: float(res_w[s:e].max()))):
        for s, e in _runs(mask):
            if e - s >= min_len:
                found.append(Stretch(kind, s + offset, e + offset, val(s, e), fps))
    for a in (s_out, body_w, hand_w, cos, slope) + ((res,) if res is not None else ()):
        a.setflags(write=False)
    stall = int(np.sum(np.diff(f) < 0.05 * mean_rate))
    return SpliceQuality(side, offset, fps, s_out, body_w, hand_w, cos, slope, res, tuple(found), th, None, stall)


def _pair_angles(fb, hb, fh, hh) -> np.ndarray:
    """Eq. 6.9 for row-aligned pairs: the angle between ``h`` and ``R h'``, ``R`` the
    smallest rotation taking ``f'`` onto ``f`` (a one-cell-per-row band of the compiled kernel)."""
    from .bands import Band
    from .metrics import angle_band_costs

    n = len(fb)
    diag = np.arange(n, dtype=np.int64)
    return angle_band_costs(fb, hb, fh, hh, Band(n, n, diag, diag, kind="custom"))


def suggest_points(quality: SpliceQuality, alignment, points, rerun, *, hand_period: float | None = None,
                   offset: int = 0) -> Suggestion | None:
    """Two tolerant matching points (eq. 6.5) that cut the longest frozen stretch, verified.

    Candidates: body frames a third and two thirds into the stretch; hand
    frames on three lines through it (the pair's diagonal ``j = i (m-1)/(n-1)``,
    the line from the stretch's start to the clip's end, and from the clip's
    start to the stretch's end); tolerances a quarter and half of the hand
    recording's dominant period (``hand_period`` seconds, else 0.25 s), so the
    DTW can pick the gesture's phase. Each candidate, with the user's
    ``points``, is spliced again by ``rerun(points) -> SpliceQuality``; the one
    with the fewest frozen frames wins if it has fewer than now. ``None`` when
    nothing is frozen or nothing helps. Frames are body-clip frames; ``offset``
    is where the alignment's row 0 lies in the body clip (subsequence mode).
    """
    from .bands import as_points

    frozen = sorted(quality.of_kind("frozen"), key=lambda s: -s.frames)
    if not frozen:
        return None
    st = frozen[0]
    n, m = alignment.n, alignment.m
    f = np.asarray(alignment.hand_frame, float)
    a, b = st.start - offset, st.stop - 1 - offset
    x1, x2 = a + (b - a) // 3, a + 2 * (b - a) // 3
    if not (0 < x1 < x2 < n - 1):
        return None
    fps = quality.fps
    period = hand_period or 1.0
    tols = sorted({max(1, int(round(period * fps / 4))), max(2, int(round(period * fps / 2)))})
    rate = (m - 1) / max(n - 1, 1)
    ya = f[max(a - 1, 0)]
    yb = f[min(b + 1, n - 1)]
    lines = {
        "diagonal": lambda x: x * rate,
        "from start of stretch": lambda x: ya + (x - a) * (m - 1 - ya) / max(n - 1 - a, 1),
        "to end of stretch": lambda x: x * yb / max(b, 1),
    }
    user = as_points(points)
    cands, seen = [], set()
    for name, line in lines.items():
        for tol in tols:
            y1, y2 = int(round(line(x1))), int(round(line(x2)))
            y1, y2 = min(max(y1, 1), m - 3), min(max(y2, 2), m - 2)
            if y2 <= y1:
                continue
            new = (MatchPoint(x1 + offset, y1, tol), MatchPoint(x2 + offset, y2, tol))
            key = tuple((p.x, p.y, p.tol) for p in new)
            if key in seen:
                continue
            seen.add(key)
            cands.append(new)
    tried, best = [], None
    for new in cands:
        allp = tuple(sorted(user + new, key=lambda p: p.x))
        try:
            q2 = rerun(allp)
        except AlignmentError:
            continue
        tried.append((new, q2.frozen_frames))
        key = (q2.frozen_frames, len(q2.stretches))
        if best is None or key < best[0]:
            best = (key, allp, new, q2)
    if best is None or best[0][0] >= quality.frozen_frames:
        return None
    _, allp, new, q2 = best
    return Suggestion(allp, new, quality.frozen_frames, q2.frozen_frames, q2.stretches, tuple(tried))
