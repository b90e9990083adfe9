"""Gesture phases of dissertation Table 6.1 (after Kita et al. [28]), as labels
for reports and plots.

| phase           | profile of the hand marker            |
| --------------- | ------------------------------------- |
| Stroke (S)      | ``a > 0`` or ``a < 0`` (force exerted) |
| Hold (H)        | ``a = 0, v = 0``                       |
| Preparation (P) | ``a = 0, v > 0`` (outwards)            |
| Retraction (R)  | ``a = 0, v < 0`` (towards the body)    |

``v`` is the velocity of the hand marker away from its resting position and
``a`` the tangential acceleration (rate of change of its speed). "Zero" means
below a threshold relative to the sequence's own 95th percentile, so the
labels do not depend on the performance's amplitude. Labels are given per
movement segment (between changes of direction), not per frame, because
the profiles of Table 6.1 describe whole phases; by default each stroke
between two reversals of direction is its own phase (``strokes="individual"``),
as the dissertation counts them ("phase boundaries in hand movement are
marked by an abrupt change of direction", ch. 6); ``strokes="merged"`` keeps
the earlier reading, in which consecutive strokes form one phase.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from .markers import HandMarkers, MARKER_ROLES, require_frames
from .metrics import savgol, smoothing_frames

__all__ = ["PHASE_NAMES", "Phase", "PhaseLabels", "motion_phases"]

PHASE_NAMES = {"S": "stroke", "H": "hold", "P": "preparation", "R": "retraction"}


@dataclass(frozen=True)
class Phase:
    """One phase: ``label`` in ``"SHPR"`` over frames ``start`` (inclusive) to ``stop`` (exclusive)."""

    label: str
    start: int
    stop: int

    @property
    def name(self) -> str:
        return PHASE_NAMES[self.label]

    def __len__(self) -> int:
        return self.stop - self.start


@dataclass(frozen=True, eq=False)
class PhaseLabels:
    """Per-frame phase labels and the evidence they were derived from.

    Attributes
    ----------
    labels: ``(T,)`` one of ``"S", "H", "P", "R"`` per frame (after merging short runs).
    phases: the runs of equal labels.
    speed: ``(T,)`` m/s of the hand marker relative to the shoulder.
    radial_velocity: ``(T,)`` m/s, positive away from the resting position.
    tangential_acceleration: ``(T,)`` m/s^2, ``d speed / dt``.
    thresholds: ``{"hold_speed": m/s, "stroke_acceleration": m/s^2}`` used.
    fps: frames per second.
    """

    labels: np.ndarray
    phases: tuple[Phase, ...]
    speed: np.ndarray
    radial_velocity: np.ndarray
    tangential_acceleration: np.ndarray
    thresholds: dict
    fps: float

    @property
    def n_phases(self) -> int:
        return len(self.phases)

    def counts(self) -> dict:
        """Number of phases of each type."""
        return {k: sum(p.label == k for p in self.phases) for k in PHASE_NAMES}

    def sequence(self) -> str:
        """The phase labels in order, e.g. ``"PSHR"``."""
        return "".join(p.label for p in self.phases)

    def at(self, frame: int) -> Phase:
        for p in self.phases:
            if p.start <= frame < p.stop:
                return p
        raise IndexError(f"frame {frame} outside 0..{len(self.labels) - 1}")


def _runs(labels: np.ndarray) -> list[list]:
    change = np.nonzero(labels[1:] != labels[:-1])[0] + 1
    starts = np.concatenate([[0], change]).tolist()
    stops = np.concatenate([change, [len(labels)]]).tolist()
    labs = labels[starts].tolist()
    return [[l, s, e] for l, s, e in zip(labs, starts, stops)]


def _absorb_short(runs: list[list], min_len: int, joinable=lambda label: True) -> list[list]:
    """Relabel the shortest run shorter than ``min_len`` with its longer
    neighbour's label, join it with equal neighbours whose label is
    ``joinable``, repeat."""
    runs = [list(r) for r in runs]
    while len(runs) > 1:
        lens = [e - s for _, s, e in runs]
        k = min(range(len(runs)), key=lens.__getitem__)
        if lens[k] >= min_len:
            break
        if k + 1 == len(runs) or (k > 0 and lens[k - 1] >= lens[k + 1]):
            runs[k - 1][2] = runs[k][2]
            del runs[k]
            k -= 1
        else:
            runs[k + 1][1] = runs[k][1]
            del runs[k]
        # join the merged run with an equal neighbour
        if k + 1 < len(runs) and runs[k + 1][0] == runs[k][0] and joinable(runs[k][0]):
            runs[k][2] = runs[k + 1][2]
            del runs[k + 1]
        if k > 0 and runs[k - 1][0] == runs[k][0] and joinable(runs[k][0]):
            runs[k - 1][2] = runs[k][2]
            del runs[k]
    return runs


def _merge_short(labels: np.ndarray, min_len: int) -> np.ndarray:
    """Label runs: the shortest run shorter than ``min_len`` takes its longer
    neighbour's label, equal neighbours join, repeat (``strokes="merged"``)."""
    out = labels.copy()
    for l, s0, e0 in _absorb_short(_runs(labels), min_len):
        out[s0:e0] = l
    return out


def _reversals(vel: np.ndarray, moving: np.ndarray, d: int, cos_max: float) -> np.ndarray:
    """Frames where the hand's direction of travel turns back: local minima of the
    cosine between the velocities ``d`` frames before and after, below ``cos_max``
    (the zero crossings of the velocity along the stroke's axis, the sign changes
    of eq. 6.6's first-derivative term), where the hand moves."""
    from scipy.signal import find_peaks

    T = len(vel)
    if T < 2 * d + 3:
        return np.zeros(0, dtype=int)
    a, b = vel[:-2 * d], vel[2 * d:]
    c = np.sum(a * b, axis=1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-12)
    cos = np.concatenate([np.ones(d), c, np.ones(d)])
    pk = find_peaks(-cos, height=-cos_max, distance=max(1, d))[0]
    near = np.zeros(T, bool)
    for s in (-d, 0, d):
        near |= np.roll(moving, s)
    return pk[near[pk]]


def _segments_merge(segs: list[list], min_len: int) -> list[list]:
    """Segments shorter than ``min_len`` frames merge into their longer
    neighbour (taking its label); neighbours that are both holds, both
    preparations or both retractions join; neighbouring strokes stay separate
    (each is one movement between reversals)."""
    joinable = lambda label: label != "S"  # noqa: E731
    out = [list(segs[0])]
    for lab, s, e in segs[1:]:
        if lab == out[-1][0] and joinable(lab):
            out[-1][2] = e
        else:
            out.append([lab, s, e])
    return _absorb_short(out, min_len, joinable)


def motion_phases(hm: HandMarkers, *, marker: str = "hand", smooth: float = 0.2, hold_speed: float = 0.15,
                  stroke_acceleration: float = 0.6, split: float = 0.2, min_duration: float | None = None,
                  still_speed: float = 0.03, min_stroke_acceleration: float = 0.5, strokes: str = "individual",
                  reversal_cos: float = 0.0) -> PhaseLabels:
    """Segment a hand-marker sequence into Table 6.1 phases.

    Frames whose speed is below ``hold_speed`` (fraction of the sequence's
    95th-percentile speed) are holds. Movements between holds are cut at the
    speed minima that mark a change of direction (prominence at least
    ``split`` times the 95th-percentile speed), the phase boundaries of the
    paper's section 6.2. Each movement segment is a stroke if its peak
    tangential acceleration reaches ``stroke_acceleration`` times the
    sequence's 95th percentile ("more force is exerted than in neighbouring
    phases"), otherwise a preparation or a retraction by the sign of its net
    displacement away from the resting position (the median hand position
    over the 10 % of frames where the hand is lowest relative to the shoulder). Derivatives are Savitzky-Golay
    over ``smooth`` seconds. Absolute floors (``still_speed`` m/s,
    ``min_stroke_acceleration`` m/s^2) keep a motionless hand a hold.

    ``strokes`` (issue #19 item 10):

    * ``"individual"`` (default): movements are also cut where the direction
      of travel turns back (the cosine between the velocities 0.05 s before
      and after drops below ``reversal_cos``: the zero crossings of the
      velocity along the stroke, where eq. 6.6's first-derivative signs
      flip), and every movement between two cuts is its own phase: a wave of
      six swings is six strokes, a walk's arm swing alternates its phases
      swing by swing, so phase counts mean what Tables 6.1/6.2 count.
      Segments shorter than ``min_duration`` (default 0.1 s) merge into their
      longer neighbour; neighbouring holds, preparations or retractions join,
      neighbouring strokes stay apart.
    * ``"merged"``: the behaviour of earlier versions: labels per segment,
      then runs of equal labels form one phase (consecutive strokes merge: a
      whole wave is one "S"), runs shorter than ``min_duration`` (default 0.2 s)
      merging into their longer neighbour.
    """
    from scipy.signal import find_peaks

    if strokes not in ("individual", "merged"):
        raise ValueError(f"strokes must be 'individual' or 'merged', got {strokes!r}")
    if min_duration is None:
        min_duration = 0.1 if strokes == "individual" else 0.2
    k = smoothing_frames(hm.fps, smooth)
    require_frames(hm, k, f"phase labelling with a {k}-frame derivative window", "input")
    q = MARKER_ROLES.index(marker)
    r = hm.relative[:, q]
    dt = 1.0 / hm.fps
    vel = savgol(r, k, 1, dt)
    speed = np.linalg.norm(vel, axis=1)
    # "outwards" = away from the resting position: the median hand position
    # (relative to the shoulder) over the 10 % of frames where it is lowest
    low = r[:, 1] <= np.percentile(r[:, 1], 10)
    rest = np.median(r[low], axis=0)
    dist = savgol(np.linalg.norm(r - rest, axis=1), k)
    radial = savgol(dist, k, 1, dt)
    acc_t = savgol(speed, k, 1, dt)
    p95 = float(np.percentile(speed, 95))
    v_hold = max(hold_speed * p95, still_speed)
    a_stroke = max(stroke_acceleration * float(np.percentile(np.abs(acc_t), 95)), min_stroke_acceleration)
    T = len(speed)
    lab = np.full(T, "H", dtype="<U1")
    moving = speed >= v_hold
    cuts = find_peaks(-speed, prominence=split * p95)[0] if p95 > 0 else np.zeros(0, dtype=int)
    if strokes == "individual" and p95 > 0:
        d = max(1, int(round(0.05 * hm.fps)))
        cuts = np.union1d(cuts, _reversals(vel, moving, d, reversal_cos))
    edges = np.diff(np.concatenate([[0], moving.astype(int), [0]]))
    segs = []
    pos = 0
    for a0, b0 in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]):
        if a0 > pos:
            segs.append(["H", pos, int(a0)])
        inside = cuts[np.searchsorted(cuts, a0, side="right"):np.searchsorted(cuts, b0, side="left")]
        bounds = [int(a0), *inside.tolist(), int(b0)]
        for a, b in zip(bounds[:-1], bounds[1:]):
            if np.max(np.abs(acc_t[a:b])) >= a_stroke:
                lab[a:b] = "S"
            else:
                lab[a:b] = "P" if dist[b - 1] - dist[a] > 0 else "R"
            segs.append([str(lab[a]), a, b])
        pos = int(b0)
    if pos < T:
        segs.append(["H", pos, T])
    min_len = max(1, int(round(min_duration * hm.fps)))
    if strokes == "merged":
        lab = _merge_short(lab, min_len)
        runs = _runs(lab)
    else:
        runs = _segments_merge(segs, min_len)
        for l, s0, e0 in runs:
            lab[s0:e0] = l
    phases = tuple(Phase(str(l), s, e) for l, s, e in runs)
    for arr in (lab, speed, radial, acc_t):
        arr.setflags(write=False)
    return PhaseLabels(lab, phases, speed, radial, acc_t,
                       {"hold_speed": v_hold, "stroke_acceleration": a_stroke}, hm.fps)
