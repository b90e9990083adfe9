"""The ZMP distance outside the support polygon measured on frames alone (what the touch-up
results are judged by; nothing of :func:`mocomp.touchup.touchup` is used).

:func:`zmp_outside` is the audit's ZMP measure (:func:`mocomp.audit.audit`: eq. 4 of Shin et al.
2003 on the Gaussian-smoothed motion, the floor at the audit's floor height, the polygon of the
planted foot points of the project's contact detector) with two choices the audit does not offer:

* ``polygon="contact"``: the polygon of the *touching* points (the paper's "convex hull of the
  contact region", sec. 3.1) instead of the planted ones; the detector's planted labels leave the
  landing heel out for the frames it still moves, so the audit measures an unedited walk's ZMP
  10-26 cm outside on every step (:meth:`mocomp.touchup.stages.Stages.polygon_mask`);
* ``floor="support"``: eq. 4's floor plane at each frame's support level (the mean floor height
  under the touching foot points) instead of one horizontal floor for the clip: on a walk rotated onto a
  slope the feet climb 0.8 m over the clip and a single floor puts the ZMP's plane up to 0.8 m
  away from the feet (``Z_x`` moves by that times the horizontal over the vertical acceleration).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ZmpMeasure", "zmp_outside", "POLYGONS", "FLOORS"]

POLYGONS = ("planted", "contact")
FLOORS = ("audit", "support")


@dataclass(frozen=True, eq=False)
class ZmpMeasure:
    """``distance`` ``(T,)`` m signed (positive outside; NaN where the ZMP or the polygon is
    undefined), ``mean_outside`` m (mean of the distance clipped at 0 over the frames with one),
    ``max_outside`` m, ``frames`` measured, ``polygon`` and ``floor`` used."""

    distance: np.ndarray
    mean_outside: float
    max_outside: float
    frames: int
    polygon: str
    floor: str

    def to_dict(self) -> dict:
        return {"mean_outside_m": self.mean_outside, "max_outside_m": self.max_outside, "frames": self.frames,
                "polygon": self.polygon, "floor": self.floor}


def zmp_outside(motion, body=None, *, polygon: str = "planted", floor: str = "audit", thresholds=None) -> ZmpMeasure:
    """The ZMP's distance outside the support polygon of ``motion`` (module docstring); with the
    defaults it is the audit's ``zmp.distance``. ``thresholds``: the audit's
    :class:`~mocomp.audit.thresholds.AuditThresholds` (default: the audit's own), e.g. another
    ``zmp_smooth_sigma`` to see how much the measure owes to the smoothing before differentiation."""
    from ..audit import audit, default_body
    from ..audit.zmp import smoothed_segment_positions
    from ..dynamics.contacts import detect_contacts
    from ..dynamics.derivatives import second_difference
    from ..dynamics.zmp import support_polygon_distance, zmp_of_point_masses
    from .zmp import MIN_SUPPORT

    if polygon not in POLYGONS:
        raise ValueError(f"polygon must be one of {', '.join(POLYGONS)}, got {polygon!r}")
    if floor not in FLOORS:
        raise ValueError(f"floor must be one of {', '.join(FLOORS)}, got {floor!r}")
    body = default_body(motion) if body is None else body
    rep = audit(motion, body) if thresholds is None else audit(motion, body, thresholds=thresholds)
    c = detect_contacts(motion)                     # the audit's detector, as the audit calls it
    pts, planted = c.contact_points()
    mask = planted if polygon == "planted" else np.asarray(c.touching, bool)
    if floor == "audit":
        Z = rep.zmp.zmp
        if polygon == "planted":
            d = np.asarray(rep.zmp.distance, float)
        else:
            keep = mask.any(axis=0)
            d = support_polygon_distance(Z, pts[:, keep], mask[:, keep])
    else:
        # the floor under a touching point: its height less its resting height (the ankle rests
        # ~10 cm, the toe tip ~2 cm above the floor it stands on)
        lv = np.where(mask, c.heights - np.asarray(c.levels)[None], np.nan)
        n = np.isfinite(lv).sum(axis=1)
        y0 = c.ground_y + np.where(n > 0, np.nansum(lv, axis=1) / np.maximum(n, 1), 0.0)
        sigma = rep.thresholds.zmp_smooth_sigma or None
        r = smoothed_segment_positions(body, motion, sigma)
        a = second_difference(r, motion.times)
        shift = np.zeros((motion.n_frames, 1, 3))
        shift[:, 0, 1] = y0
        Z, _, _ = zmp_of_point_masses(body.masses, r - shift, a, 0.0, 9.81, MIN_SUPPORT * body.total_mass * 9.81)
        Z[:, 1] += y0
        keep = mask.any(axis=0)
        d = support_polygon_distance(Z, pts[:, keep], mask[:, keep])
    ok = np.isfinite(d)
    out = np.clip(d[ok], 0.0, None)
    return ZmpMeasure(d, float(out.mean()) if ok.any() else float("nan"),
                      float(out.max()) if ok.any() else float("nan"), int(ok.sum()), polygon, floor)
