"""ZMP of a motion and its place relative to the support polygon (touch-up paper, Shin et al.
2003, eq. 4, sec. 3.3).

The ZMP is eq. 4 for point masses at the segment COMs (:func:`mocomp.dynamics.zmp.zmp_of_point_masses`),
with accelerations by finite differences of the motion smoothed by a Gaussian first (the paper's
remark: "a gaussian filter of width 5", here ``smooth_sigma`` frames, by default the audit's, so
that what touch-up drives to zero is what :func:`mocomp.audit.audit` measures). The support polygon
is the convex hull of the planted foot points on each frame; the distance is the project's signed
distance (:func:`mocomp.dynamics.zmp.support_polygon_distance`, positive outside) and the
projection ``Z'`` (the target of eq. 7) is the nearest point of the polygon.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..audit.thresholds import AuditThresholds
from ..dynamics.constants import G_STANDARD
from ..dynamics.zmp import nearest_on_polygon, zmp_of_point_masses
from . import _fast
from ._fast import SegmentChains, polygon_distance_and_target

__all__ = ["ZmpState", "zmp_state", "project_to_polygon", "DEFAULT_SMOOTH_SIGMA", "floor_levels", "MIN_SUPPORT"]

#: frames: Gaussian smoothing before differentiating (the audit's default)
DEFAULT_SMOOTH_SIGMA = AuditThresholds().zmp_smooth_sigma
#: fraction of the body weight below which the vertical ground force leaves the ZMP undefined
MIN_SUPPORT = 0.05


@dataclass(frozen=True, eq=False)
class ZmpState:
    """Eq. 4 on every frame, with everything eq. 6-7 need.

    Attributes
    ----------
    r: ``(T, S, 3)`` m, segment COMs of the smoothed motion.
    a: ``(T, S, 3)`` m/s^2, their accelerations.
    zmp: ``(T, 3)`` m (NaN where undefined: flight, or vertical force below ``MIN_SUPPORT``).
    distance: ``(T,)`` m, signed distance to the support polygon (positive outside, NaN without
        polygon or ZMP).
    target: ``(T, 3)`` m, the ZMP's projection onto the support polygon (the ZMP itself inside).
    ground_y: ``(T,)`` m, the floor height of eq. 4 on each frame.
    """

    r: np.ndarray
    a: np.ndarray
    zmp: np.ndarray
    distance: np.ndarray
    target: np.ndarray
    ground_y: np.ndarray

    def outside(self, tol: float = 0.0) -> np.ndarray:
        """``(T,)`` bool: ZMP defined and more than ``tol`` m outside the polygon."""
        d = self.distance
        return np.isfinite(d) & (np.nan_to_num(d, nan=-1.0) > tol)

    def summary(self, ground: np.ndarray | None = None) -> dict:
        """Mean and max distance outside (m; inside counts 0) over the frames with a distance."""
        d = self.distance if ground is None else np.where(ground, self.distance, np.nan)
        ok = np.isfinite(d)
        out = np.clip(d[ok], 0.0, None)
        return {"frames": int(ok.sum()), "mean_outside_m": float(out.mean()) if ok.any() else float("nan"),
                "max_outside_m": float(out.max()) if ok.any() else float("nan"),
                "frames_outside": int((out > 0).sum())}


def project_to_polygon(p: np.ndarray, pts: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``(T, 2)``: the nearest point to ``p`` ``(T, 2)`` of the support polygon of the masked points
    ``pts`` ``(T, K, 2)`` (:func:`mocomp.dynamics.zmp.nearest_on_polygon`); callers use it only for
    a ``p`` outside the polygon (eq. 7's target). NaN where a frame has no masked point."""
    return nearest_on_polygon(p, pts, mask)


def floor_levels(levels: np.ndarray, default: float) -> np.ndarray:
    """``(T,)`` m: the mean support level of each frame's planted points (``levels`` ``(T, K)``, NaN
    where not planted; :attr:`mocomp.ops.FootPlants.levels`), ``default`` on frames with none."""
    lv = np.asarray(levels, float)
    n = np.isfinite(lv).sum(axis=1)
    return np.where(n > 0, np.nansum(lv, axis=1) / np.maximum(n, 1), default)


def zmp_state(body, motion, contact_points: np.ndarray, contact_mask: np.ndarray, ground_y: float, *,
              smooth_sigma: float | None = DEFAULT_SMOOTH_SIGMA, g: float = G_STANDARD, chains=None) -> ZmpState:
    """Eq. 4 of ``motion`` with ``body``'s masses; support polygons from ``contact_points``
    ``(T, K, 3)`` where ``contact_mask`` ``(T, K)``; the floor at ``ground_y`` (m, a number or
    ``(T,)`` per frame: on a slope, eq. 4's plane ``y = y0`` is the support level of the frame's
    planted points, :func:`floor_levels`). ``chains``: the body's
    :class:`~mocomp.touchup._fast.SegmentChains` when the caller has it (a touch-up run: made once)."""
    if smooth_sigma is not None and not (np.isfinite(smooth_sigma) and smooth_sigma >= 0):
        raise ValueError(f"smooth_sigma must be 0 or more frames, got {smooth_sigma!r}")
    if motion.n_frames < 3:
        raise ValueError("the ZMP needs accelerations: at least 3 frames")
    if chains is None:
        chains = SegmentChains(body, motion.skeleton)
    y0 = np.broadcast_to(np.asarray(ground_y, float), (motion.n_frames,))
    if _fast.COMPILED:                             # the steps below in one compiled call
        r, a, Z, d, tgt = chains.zmp_state(motion, smooth_sigma or None, y0, g, MIN_SUPPORT * body.total_mass * g,
                                           contact_points, contact_mask)
        return ZmpState(r, a, Z, d, tgt, y0)
    r, a = chains.positions_and_accelerations(motion, smooth_sigma or None)
    shift = np.zeros((motion.n_frames, 1, 3))
    shift[:, 0, 1] = y0
    Z, _, _ = zmp_of_point_masses(body.masses, r - shift, a, 0.0, g, MIN_SUPPORT * body.total_mass * g)
    Z[:, 1] += y0
    d, tgt = polygon_distance_and_target(Z, contact_points, contact_mask)
    return ZmpState(r, a, Z, d, tgt, y0)
