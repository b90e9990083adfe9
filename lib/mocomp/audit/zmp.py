"""ZMP distance outside the support polygon, per ground stage.

The ZMP is the project's :func:`mocomp.dynamics.zmp.zmp` (touch-up paper,
Shin et al. 2003, eq. 4: point masses at the segment COMs, gravity 9.81 m/s^2,
the floor at the audit's floor height), on the motion smoothed with a Gaussian
of ``zmp_smooth_sigma`` frames before the second differences. Its signed distance to
the support polygon (the convex hull of the planted effectors' points in the
floor plane, :func:`mocomp.dynamics.zmp.support_polygon_distance`; positive
outside) is measured on every frame where both exist. Per ground stage the
audit reports the fraction of those frames with the ZMP more than
``zmp_outside`` outside and the largest distance; runs outside lasting at
least ``zmp_min_time`` are findings (advisory unless ``zmp_is_violation``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.zmp import support_polygon_distance, zmp
from .findings import Finding, runs_above

__all__ = ["ZmpStage", "ZmpAudit", "zmp_audit"]


@dataclass(frozen=True)
class ZmpStage:
    """One ground stage: half-open ``frames``, ``measured`` frames (ZMP and polygon defined),
    ``outside_fraction`` of them beyond ``zmp_outside``, ``max_outside`` m (NaN: none measured)."""

    frames: tuple[int, int]
    measured: int
    outside_fraction: float
    max_outside: float

    def to_dict(self) -> dict:
        return {"frames": list(self.frames), "measured": self.measured, "outside_fraction": self.outside_fraction,
                "max_outside_m": self.max_outside}


@dataclass(frozen=True)
class ZmpAudit:
    """``distance`` ``(T,)`` m (NaN where undefined), ``zmp`` ``(T, 3)`` m, the stages, and over the
    whole clip the ``outside_fraction`` of measured frames and ``max_outside`` m."""

    distance: np.ndarray
    zmp: np.ndarray
    stages: tuple[ZmpStage, ...]
    outside_fraction: float
    max_outside: float
    smooth_sigma: float


def zmp_audit(body, motion, contacts, floor_y: float, phases, thresholds) -> tuple[ZmpAudit, list]:
    T = motion.n_frames
    if T < 3:
        nan = np.full(T, np.nan)
        return ZmpAudit(nan, np.full((T, 3), np.nan), (), float("nan"), float("nan"), thresholds.zmp_smooth_sigma), []
    z = zmp(body, motion, ground_y=floor_y, smooth_sigma=thresholds.zmp_smooth_sigma or None)
    pts, lab = contacts.contact_points()
    d = support_polygon_distance(z.zmp, pts, lab)
    lim = thresholds.zmp_outside
    stages = []
    for a, b in phases.ground:
        seg = d[a:b]
        ok = np.isfinite(seg)
        n = int(ok.sum())
        stages.append(ZmpStage((a, b), n, float(np.mean(seg[ok] > lim)) if n else float("nan"),
                               float(seg[ok].max()) if n else float("nan")))
    ok = np.isfinite(d)
    frac = float(np.mean(d[ok] > lim)) if ok.any() else float("nan")
    mx = float(d[ok].max()) if ok.any() else float("nan")
    res = ZmpAudit(d, z.zmp, tuple(stages), frac, mx, thresholds.zmp_smooth_sigma)
    min_len = max(1, int(np.ceil(thresholds.zmp_min_time * motion.fps - 1e-9)))
    sev = "violation" if thresholds.zmp_is_violation else "advisory"
    findings = [Finding("zmp_outside", sev, (a, b), p, float(d[p]), lim, "zmp_outside", "m", "support polygon",
                        f"ZMP up to {d[p] * 100:.1f} cm outside the support polygon for {b - a} frames "
                        f"({(b - a) / motion.fps:.2f} s); limit {lim * 100:.1f} cm for at least "
                        f"{thresholds.zmp_min_time:g} s")
                for a, b, p in runs_above(d, lim, min_len)]
    return res, findings
