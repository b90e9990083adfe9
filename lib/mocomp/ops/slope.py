"""Slope rotation: a motion rotated onto a tilted ground plane (issue 15, item 5): the touch-up
paper's "walk uphill" input (Shin et al. 2003, sec. 4.4: the ground and the motion rotated
together, so the body leans back relative to gravity until touch-up adds the forward lean).

The whole motion is turned rigidly by ``degrees`` about a horizontal ``axis`` through ``pivot``
(default: the root's ground point on the first frame, on the floor). The default axis is
perpendicular to the motion's overall travel direction, oriented so that positive degrees make
the motion climb (the ground ahead rises). The floor becomes the plane through the pivot with
normal ``R (0, 1, 0)``; the evidence gives it, the climb over the clip and the feet's heights above
the tilted plane (unchanged from their heights above the flat floor, to rounding). Note that the
audit, which assumes a horizontal floor, measures a tilted motion against a horizontal one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_exp

__all__ = ["SlopeResult", "slope", "travel_direction"]


def travel_direction(motion: Motion) -> np.ndarray:
    """``(3,)`` unit horizontal direction from the root's first to its last ground position (the
    root's facing on the first frame, its local forward axis projected, when it does not travel)."""
    d = motion.root_positions[-1] - motion.root_positions[0]
    d[1] = 0.0
    if np.linalg.norm(d) < 0.05:
        from .align import headings

        h = headings(motion)[0]
        d = np.array([np.sin(h), 0.0, np.cos(h)])
    return d / np.linalg.norm(d)


@dataclass(frozen=True, eq=False)
class SlopeResult:
    """A motion on a slope and its evidence.

    Attributes
    ----------
    motion: the rotated motion.
    degrees: the slope; axis: ``(3,)`` unit horizontal rotation axis; pivot: ``(3,)`` m.
    normal: ``(3,)`` the tilted floor's normal; floor_y: m, the floor height used for the pivot.
    climb: m, the rise of the root from the first to the last frame.
    """

    motion: Motion
    degrees: float
    axis: np.ndarray
    pivot: np.ndarray
    normal: np.ndarray
    floor_y: float
    climb: float
    seconds: float = 0.0
    notes: tuple[str, ...] = field(default=())

    def heights_above_floor(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) of world points ``(..., 3)`` above the tilted floor."""
        return (np.asarray(points, dtype=float) - self.pivot) @ self.normal

    def to_dict(self) -> dict:
        return {"degrees": self.degrees, "axis": self.axis.tolist(), "pivot_m": self.pivot.tolist(),
                "normal": self.normal.tolist(), "floor_y_m": self.floor_y, "climb_m": self.climb,
                "seconds": self.seconds, "notes": list(self.notes)}


def slope(motion: Motion, degrees: float, *, axis=None, pivot=None) -> SlopeResult:
    """Rotate ``motion`` onto a slope of ``degrees`` (see the module docstring).

    Parameters
    ----------
    degrees: the slope, within (-90, 90); positive climbs along the travel direction (with the
        default axis).
    axis: ``(3,)`` a horizontal axis (the y component must be 0 to 1e-9 after normalising), or
        ``None`` for the default.
    pivot: ``(3,)`` m, a point on the floor the slope turns about (default: the root's ground point
        on frame 0 at the floor height of the contact detector).
    """
    t0 = time.perf_counter()
    if not (np.isfinite(degrees) and -90.0 < degrees < 90.0):
        raise ValueError(f"slope must be a finite angle between -90 and 90 degrees, got {degrees!r}")
    if axis is None:
        d = travel_direction(motion)
        ax = np.cross(d, [0.0, 1.0, 0.0])            # R(d x y, +a) turns d toward +y: a climb
        ax = ax / np.linalg.norm(ax)
    else:
        ax = np.asarray(axis, dtype=float).reshape(3)
        n = np.linalg.norm(ax)
        if not n > 0 or abs(ax[1] / n) > 1e-9:
            raise ValueError(f"the slope axis must be a horizontal direction (y = 0), got {ax.tolist()}")
        ax = ax / n
    floor_y = 0.0
    notes = []
    if pivot is None:
        from ..dynamics.contacts import detect_contacts

        try:
            floor_y = float(detect_contacts(motion).ground_y)
        except Exception as e:                     # a motion the detector cannot read: the lowest root
            floor_y = float(motion.positions[..., 1].min())
            notes.append(f"floor from the lowest joint ({e})")
        piv = np.array([motion.root_positions[0, 0], floor_y, motion.root_positions[0, 2]])
    else:
        piv = np.asarray(pivot, dtype=float).reshape(3)
    q = quat_exp(ax * np.radians(degrees))
    out = motion if degrees == 0 else motion.rotated(q, center=piv)
    normal = quat_apply(q, np.array([0.0, 1.0, 0.0]))
    climb = float(out.root_positions[-1, 1] - out.root_positions[0, 1])
    return SlopeResult(out, float(degrees), ax, piv, normal, floor_y, climb, time.perf_counter() - t0, tuple(notes))
