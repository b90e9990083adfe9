"""Phases, floor penetration and foot slide, measured from the frames.

* **Phases** come from the project's contact detector
  (:func:`mocomp.dynamics.contacts.detect_contacts`, height + speed per end
  effector): a *flight* is a run of frames with no effector near its support
  level (:func:`~mocomp.dynamics.contacts.airborne_intervals`), a *ground stage*
  a run with at least one.
* **Floor penetration**: per frame, the depth of the body's lowest point (every
  joint and end site of the forward kinematics) below the floor,
  ``max(0, floor_y - min_j y_j(t))``. The floor is the resting level of that
  lowest point during the clip's *first* ground stage (the median of its heights
  over the stage's planted frames): the floor the motion started on, so that a
  landing which ends below it is measured against the level the motion took off
  from, not against a floor re-estimated from the sunken frames. A scene whose
  floors really differ (a jump down from a box) needs ``floor_y`` given.
* **Foot slide**: per planted contact of an effector (the detector's
  ``labels``: near its support level and slower than its speed threshold), the
  largest horizontal (x, z) distance of the effector from where it was planted,
  and the horizontal path length over the contact.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.contacts import airborne_intervals, label_intervals
from .findings import Finding, runs_above

__all__ = ["Phases", "ContactAudit", "PenetrationAudit", "phases_of", "body_points", "lowest_points", "floor_level", "body_support",
           "penetration", "contact_audits"]


@dataclass(frozen=True)
class Phases:
    """Flights and ground stages of a motion (half-open frame ranges, in time order).

    Attributes
    ----------
    flights: runs with no effector touching and the COM high enough (see :func:`phases_of`);
        ground: the other runs (an effector touching, or the trunk on the floor).
    takeoffs: first airborne frame of each flight (``None`` when the flight starts the clip).
    landings: first ground frame after each flight (``None`` when the flight ends the clip).
    """

    flights: tuple[tuple[int, int], ...]
    ground: tuple[tuple[int, int], ...]
    takeoffs: tuple[int | None, ...]
    landings: tuple[int | None, ...]


def phases_of(contacts, n_frames: int, com_height: np.ndarray | None = None,
              min_com_height: float = 0.0, body_support: np.ndarray | None = None) -> Phases:
    """Flights: runs with no effector touching (:func:`~mocomp.dynamics.contacts.airborne_intervals`)
    and, when ``com_height`` (``(T,)`` m above the floor) is given, the COM at least
    ``min_com_height`` above the floor -- a body lying, sitting or rolling on the floor touches it
    with its trunk, not with an effector -- and not ``body_support`` (``(T,)`` bool, see
    :func:`body_support`). Ground stages: the other frames."""
    air = np.zeros(n_frames, bool)
    for a, b in airborne_intervals(contacts, min_frames=1):
        air[a:b] = True
    if com_height is not None:
        air &= np.asarray(com_height) >= min_com_height
    if body_support is not None:
        air &= ~np.asarray(body_support, dtype=bool)
    fl = tuple(label_intervals(air))
    gr = tuple(label_intervals(~air))
    return Phases(fl, gr, tuple(a if a > 0 else None for a, _ in fl),
                  tuple(b if b < n_frames else None for _, b in fl))


def body_points(motion) -> tuple[np.ndarray, tuple[str, ...]]:
    """``(points (T, J + E, 3), names)``: every joint and end site of the forward kinematics."""
    P, _ = motion.fk()
    names = tuple(motion.skeleton.names)
    sites = motion.skeleton.end_sites
    if not sites:
        return P, names
    return (np.concatenate([P, motion.end_site_positions()], axis=1),
            names + tuple(f"{e.name or motion.skeleton.names[e.parent] + ' end'}" for e in sites))


def lowest_points(motion, points=None) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """``(heights (T,), index (T,), names)``: the lowest y of all joints and end sites per
    frame, which point it is, and the point names (joints, then end sites). ``points``: the
    output of :func:`body_points`, if already computed."""
    pts, names = body_points(motion) if points is None else points
    y = pts[..., 1]
    k = np.argmin(y, axis=1)
    return y[np.arange(y.shape[0]), k], k, names


def body_support(pts: np.ndarray, fps: float, lowest: np.ndarray, lowest_index: np.ndarray, floor_y: float,
                 clearance: float, speed: float) -> np.ndarray:
    """``(T,)`` bool: the body's lowest point (any joint or end site) lies within ``clearance`` of
    the floor and moves slower than ``speed`` (central difference of that point's track) -- the body
    rests on the floor there, whether or not the contact detector's effectors see it (a knee, a hip,
    a foot lying on its side). ``pts``: ``(T, N, 3)`` every body point (:func:`body_points`)."""
    T = pts.shape[0]
    if T < 3:
        return np.zeros(T, bool)
    i = np.arange(T)
    lo, hi = np.clip(i - 1, 0, T - 1), np.clip(i + 1, 0, T - 1)
    v = np.linalg.norm(pts[hi, lowest_index] - pts[lo, lowest_index], axis=-1) * fps / (hi - lo)
    return (lowest - floor_y <= clearance) & (v < speed)


def floor_level(lowest: np.ndarray, contacts, phases: Phases, floor_y: float | None = None) -> tuple[float, str]:
    """The floor height (m) and how it was chosen (see the module docstring)."""
    if floor_y is not None:
        return float(floor_y), "given (thresholds.floor_y)"
    planted = contacts.any_contact
    for a, b in phases.ground:
        sel = np.flatnonzero(planted[a:b]) + a
        if sel.size >= 2:
            return float(np.median(lowest[sel])), (
                f"median height of the lowest body point over the {sel.size} planted frames of the first "
                f"ground stage (frames {a}-{b - 1})")
    if planted.any():
        return float(np.percentile(lowest[planted], 5)), "5th percentile of the lowest body point over planted frames"
    return float(np.percentile(lowest, 2)), "no planted frame: 2nd percentile of the lowest body point"


@dataclass(frozen=True)
class PenetrationAudit:
    """Depth of the lowest body point below the floor.

    Attributes
    ----------
    floor_y: m, the floor; floor_source: how it was chosen.
    depth: ``(T,)`` m, ``max(0, floor_y - lowest)``.
    lowest: ``(T,)`` m, the lowest body point's height; lowest_name: ``(T,)`` which point.
    max_depth: m; max_frame: where.
    """

    floor_y: float
    floor_source: str
    depth: np.ndarray
    lowest: np.ndarray
    lowest_name: tuple[str, ...]
    max_depth: float
    max_frame: int


def penetration(lowest, lowest_index, names, floor_y, floor_source, thresholds) -> tuple[PenetrationAudit, list]:
    depth = np.maximum(0.0, floor_y - lowest)
    lname = tuple(names[i] for i in lowest_index)
    k = int(np.argmax(depth))
    res = PenetrationAudit(float(floor_y), floor_source, depth, lowest, lname, float(depth[k]), k)
    thr = thresholds.penetration
    out = []
    for a, b, p in runs_above(depth, thr):
        out.append(Finding("floor_penetration", "violation", (a, b), p, float(depth[p]), thr, "penetration", "m",
                           lname[p], f"{lname[p]} {depth[p] * 100:.1f} cm below the floor (y = {floor_y:.3f} m) over "
                           f"{b - a} frames; limit {thr * 100:.1f} cm"))
    return res, out


@dataclass(frozen=True)
class ContactAudit:
    """One planted contact of one effector.

    Attributes
    ----------
    effector: detector name (``foot_l``, ``toe_r``, ``hand_l``, ...).
    frames: half-open ``(start, stop)``.
    slide: m, largest horizontal distance from the planting position.
    path: m, horizontal path length over the contact.
    max_penetration: m, deepest floor penetration of the body during the contact.
    """

    effector: str
    frames: tuple[int, int]
    slide: float
    path: float
    max_penetration: float

    def to_dict(self) -> dict:
        return {"effector": self.effector, "frames": list(self.frames), "slide_m": self.slide, "path_m": self.path,
                "max_penetration_m": self.max_penetration}


def contact_audits(contacts, depth: np.ndarray, thresholds) -> tuple[tuple[ContactAudit, ...], list]:
    out, findings = [], []
    for e, name in enumerate(contacts.effectors):
        hand = name.startswith("hand")
        thr = thresholds.hand_slide if hand else thresholds.foot_slide
        for a, b in contacts.intervals[name]:
            p = contacts.positions[a:b, e][:, [0, 2]]
            d = np.linalg.norm(p - p[0], axis=1)
            k = int(np.argmax(d))
            path = float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
            c = ContactAudit(name, (a, b), float(d[k]), path, float(depth[a:b].max()))
            out.append(c)
            if c.slide > thr:
                findings.append(Finding(
                    "hand_slide" if hand else "foot_slide", "advisory" if hand else "violation", (a, b), a + k,
                    c.slide, thr, "hand_slide" if hand else "foot_slide", "m", name,
                    f"planted {name} moves {c.slide * 100:.1f} cm horizontally (path {path * 100:.1f} cm) over "
                    f"{b - a} frames; limit {thr * 100:.1f} cm"))
    out.sort(key=lambda c: (c.frames[0], c.effector))
    return tuple(out), findings
