"""One finding of the audit: which check, which frames, how big, against which threshold."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.contacts import label_intervals

__all__ = ["Finding", "runs_above"]

SEVERITIES = ("violation", "advisory", "expected")


@dataclass(frozen=True)
class Finding:
    """A measure of the motion that exceeds its threshold.

    Attributes
    ----------
    check: what was measured: ``"floor_penetration"``, ``"foot_slide"``, ``"hand_slide"``,
        ``"com_velocity_jump"``, ``"gravity"``, ``"L_direction"``, ``"L_magnitude"``,
        ``"zmp_outside"``, ``"bone_length"``, ``"joint_speed"``, ``"root_speed"``,
        ``"point_speed"``, ``"pose_jump"`` (against the input).
    severity: ``"violation"`` (the motion breaks physics or kinematic sanity),
        ``"advisory"`` (a model-dependent measure: ZMP, hand slide) or ``"expected"`` (it lies
        in frames the caller declared under an external force, :mod:`mocomp.audit.force`:
        expected there, not judged; neither a violation nor an advisory).
    frames: half-open ``(start, stop)`` motion frame range the finding covers.
    peak_frame: the frame of the largest value.
    size: the largest value, in ``unit``.
    threshold: the limit it exceeds (same unit; the :class:`~mocomp.audit.AuditThresholds`
        field named by ``threshold_name``).
    threshold_name: field of :class:`~mocomp.audit.AuditThresholds`.
    unit: ``"m"``, ``"m/s"``, ``"m/s^2"``, ``"rad"``, ``"rad/s"``, ``"relative"``.
    where: the effector, joint, flight or event concerned (``"toe_l"``, ``"flight 1"``,
        ``"take-off of flight 1"``, ...).
    message: one line in words.
    """

    check: str
    severity: str
    frames: tuple[int, int]
    peak_frame: int
    size: float
    threshold: float
    threshold_name: str
    unit: str
    where: str
    message: str

    def __post_init__(self):
        if self.severity not in SEVERITIES:
            raise ValueError(f"severity must be one of {SEVERITIES}, got {self.severity!r}")

    @property
    def is_violation(self) -> bool:
        return self.severity == "violation"

    @property
    def is_expected(self) -> bool:
        return self.severity == "expected"

    def frames_text(self) -> str:
        a, b = self.frames
        return f"frame {a}" if b - a <= 1 else f"frames {a}-{b - 1}"

    def line(self) -> str:
        return f"[{self.severity}] {self.check} ({self.where}), {self.frames_text()}: {self.message}"

    def to_dict(self) -> dict:
        return {"check": self.check, "severity": self.severity, "frames": [int(self.frames[0]), int(self.frames[1])],
                "peak_frame": int(self.peak_frame), "size": float(self.size), "threshold": float(self.threshold),
                "threshold_name": self.threshold_name, "unit": self.unit, "where": self.where,
                "message": self.message}


def runs_above(values: np.ndarray, limit, min_len: int = 1) -> list[tuple[int, int, int]]:
    """``(start, stop, peak)`` runs of frames where ``values > limit`` (NaN never counts),
    at least ``min_len`` long; ``peak`` is the frame of the largest value in the run."""
    v = np.asarray(values, dtype=float)
    over = np.zeros(v.shape, bool)
    ok = np.isfinite(v)
    over[ok] = v[ok] > np.broadcast_to(limit, v.shape)[ok]
    out = []
    for a, b in label_intervals(over):
        if b - a >= min_len:
            out.append((a, b, a + int(np.argmax(v[a:b]))))
    return out
