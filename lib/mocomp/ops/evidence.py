"""Numbers the operations report from :mod:`mocomp.audit` (measured on the frames, never planned)."""
from __future__ import annotations

import numpy as np

__all__ = ["foot_slide", "max_penetration", "audit_numbers"]


def foot_slide(report, effectors: tuple[str, ...] = ("foot_l", "foot_r", "toe_l", "toe_r")) -> float:
    """m: the largest slide of a planted foot point over all contacts the audit found (0 without any)."""
    s = [c.slide for c in report.contacts if c.effector in effectors]
    return float(max(s)) if s else 0.0


def max_penetration(report) -> float:
    """m: the deepest floor penetration the audit measured."""
    return float(report.penetration.max_depth)


def audit_numbers(report) -> dict:
    """The audit's numbers an editing primitive is judged by: foot slide (largest and per contact
    count), floor penetration, the largest joint rotation rate, root speed and point speed between
    frames, and the verdict."""
    k = report.kinematics
    feet = [c for c in report.contacts if not c.effector.startswith("hand")]
    return {"verdict": report.verdict, "violations": len(report.violations),
            "foot_slide_max_m": foot_slide(report),
            "foot_slide_mean_m": float(np.mean([c.slide for c in feet])) if feet else 0.0,
            "foot_contacts": len(feet),
            "penetration_max_m": max_penetration(report),
            "joint_speed_max_rad_s": float(k.joint_speed), "root_speed_max_m_s": float(k.root_speed),
            "point_speed_max_m_s": float(k.point_speed)}
