"""Gesture phases of dissertation Table 6.1 (after Kita et al. [28]), as labels
for reports and plots.

| phase           | profile of the hand marker            |
| --------------- | ------------------------------------- |
| Stroke (S)      | ``a > 0`` or ``a < 0`` (force exerted) |
| Hold (H)        | ``a = 0, v = 0``                       |
| Preparation (P) | ``a = 0, v > 0`` (outwards)            |
| Retraction (R)  | ``a = 0, v < 0`` (towards the body)    |

``v`` is the radial velocity of the hand marker away from the shoulder and
``a`` the tangential acceleration (rate of change of its speed). "Zero" means
below a threshold relative to the sequence's own 95th percentile, so the
labels do not depend on the performance's amplitude. Runs shorter than
``min_duration`` are merged into their longer neighbour.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from .markers import HandMarkers, MARKER_ROLES, require_frames
from .metrics import smoothing_frames

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
    radial_velocity: ``(T,)`` m/s, positive away from the shoulder.
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
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [len(labels)]])
    return [[labels[s], int(s), int(e)] for s, e in zip(starts, stops)]


def _merge_short(labels: np.ndarray, min_len: int) -> np.ndarray:
    labels = labels.copy()
    while True:
        runs = _runs(labels)
        if len(runs) == 1:
            return labels
        lens = [e - s for _, s, e in runs]
        k = int(np.argmin(lens))
        if lens[k] >= min_len:
            return labels
        left = runs[k - 1] if k > 0 else None
        right = runs[k + 1] if k + 1 < len(runs) else None
        if right is None or (left is not None and (left[2] - left[1]) >= (right[2] - right[1])):
            labels[runs[k][1]:runs[k][2]] = left[0]
        else:
            labels[runs[k][1]:runs[k][2]] = right[0]


def motion_phases(hm: HandMarkers, *, marker: str = "hand", smooth: float = 0.2, hold_speed: float = 0.15,
                  stroke_acceleration: float = 0.35, min_duration: float = 0.1) -> PhaseLabels:
    """Label every frame with a Table 6.1 phase.

    ``hold_speed`` and ``stroke_acceleration`` are fractions of the 95th
    percentile of the hand marker's speed and absolute tangential acceleration
    in this sequence; derivatives are Savitzky-Golay over ``smooth`` seconds.
    """
    k = smoothing_frames(hm.fps, smooth)
    require_frames(hm, k, f"phase labelling with a {k}-frame derivative window", "input")
    q = MARKER_ROLES.index(marker)
    r = hm.relative[:, q]
    dt = 1.0 / hm.fps
    vel = savgol_filter(r, k, 3, deriv=1, delta=dt, axis=0, mode="interp")
    speed = np.linalg.norm(vel, axis=1)
    dist = np.linalg.norm(r, axis=1)
    radial = savgol_filter(dist, k, 3, deriv=1, delta=dt, mode="interp")
    acc_t = savgol_filter(speed, k, 3, deriv=1, delta=dt, mode="interp")
    v_hold = hold_speed * float(np.percentile(speed, 95))
    a_stroke = stroke_acceleration * float(np.percentile(np.abs(acc_t), 95))
    lab = np.where(radial > 0, "P", "R")
    lab = np.where((speed < v_hold) & (np.abs(acc_t) < a_stroke), "H", lab)
    lab = np.where(np.abs(acc_t) >= a_stroke, "S", lab)
    lab = _merge_short(lab.astype("<U1"), max(1, int(round(min_duration * hm.fps))))
    phases = tuple(Phase(str(l), s, e) for l, s, e in _runs(lab))
    for a in (lab, speed, radial, acc_t):
        a.setflags(write=False)
    return PhaseLabels(lab, phases, speed, radial, acc_t,
                       {"hold_speed": v_hold, "stroke_acceleration": a_stroke}, hm.fps)
