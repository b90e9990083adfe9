"""The body kept out of the floor by a vertical lift of the whole body (beyond the papers).

A motion put together from pieces (a concatenation, a blend) inherits each piece's floor contact:
a DeepMimic landing whose toe tips end 3.6 cm below the level the clip took off from, a CMU toe sunk
through the floor. Holding the supporting feet (:func:`mocomp.ops.enforce_footplants`) fixes their
horizontal slide but keeps each plant on its own resting level, so the landing stays below the start.

:func:`lift_out_of_floor` moves the root up, frame by frame, by exactly the depth of the body's
lowest point (every joint and end site) below the floor: ``lift(t) = max(0, floor - lowest(t))``.
It is what a floor does to a body that would sink into it: the point that reaches the floor stops
there and the body is held up. Horizontal positions are untouched (a foot held still stays still),
and a translation of the whole body leaves the angular momentum about the centre of mass unchanged.

The floor is the audit's (:func:`mocomp.audit.contacts.floor_level`): the median height of the
lowest body point over the planted frames of the clip's first ground stage. Lifting frames whose
lowest point lies below that median exactly up to it (``smooth=0``) leaves the median where it is, so
the floor the audit reads on the result is the same and the result's measured penetration is zero (to
the rounding of a file written and read back). A smoothed lift (``smooth > 0``, fewer COM velocity
steps) also raises frames of that stage above the median, so the floor read on the result rises and
another pass lifts the rest to it (up to ``passes``; what is left is ``depth_after``: a 2 cm sink in
the synthetic back flip's take-off stance leaves 0.58 cm after two passes), unless ``keep_floor``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import Motion

__all__ = ["FloorDepth", "LiftResult", "floor_depth", "lift_out_of_floor"]


@dataclass(frozen=True, eq=False)
class FloorDepth:
    """The audit's floor and how deep the body reaches below it.

    floor_y: m; depth: ``(T,)`` m, ``max(0, floor_y - lowest)``; lowest: ``(T,)`` m, the lowest body
    point's height per frame; contacts: the detector's result the floor was read from."""

    floor_y: float
    depth: np.ndarray
    lowest: np.ndarray
    contacts: object

    @property
    def max_depth(self) -> float:
        return float(self.depth.max(initial=0.0))


def floor_depth(motion: Motion, floor_y: float | None = None, contacts=None) -> FloorDepth:
    """The floor (the audit's, or ``floor_y`` given) and the depth of the lowest body point below it per
    frame, from the audit's own functions (:mod:`mocomp.audit.contacts`); ``contacts``: a
    :func:`~mocomp.dynamics.contacts.detect_contacts` result of ``motion`` already computed."""
    from ..audit.contacts import floor_level, lowest_points, phases_of
    from ..dynamics.contacts import detect_contacts

    from .plants import effectors_of

    # the detector's default effectors (the audit's), their body-segment mapping cached per skeleton
    c = detect_contacts(motion, effectors=effectors_of(motion.skeleton)) if contacts is None else contacts
    low, _, _ = lowest_points(motion)
    fy, _ = floor_level(low, c, phases_of(c, motion.n_frames), floor_y)
    return FloorDepth(float(fy), np.maximum(0.0, fy - low), low, c)


@dataclass(frozen=True, eq=False)
class LiftResult:
    """A motion lifted out of the floor.

    motion: the result (root heights changed, nothing else); lift: ``(T,)`` m added to the root's
    height; floor_y: m, the floor lifted to; depth_before, depth_after: m, the deepest point below the
    floor before and after (``depth_after`` measured on the result, its own floor); passes: lifts run;
    contacts: the detector's result on the returned motion (the floor's)."""

    motion: Motion
    lift: np.ndarray
    floor_y: float
    depth_before: float
    depth_after: float
    passes: int
    notes: tuple[str, ...] = field(default=())
    contacts: object = None

    @property
    def lifted_frames(self) -> int:
        return int((self.lift > 0).sum())

    def to_dict(self) -> dict:
        return {"floor_y_m": self.floor_y, "depth_before_m": self.depth_before, "depth_after_m": self.depth_after,
                "max_lift_m": float(self.lift.max(initial=0.0)), "lifted_frames": self.lifted_frames,
                "passes": self.passes, "notes": list(self.notes)}


def lift_out_of_floor(motion: Motion, *, floor_y: float | None = None, tol: float = 1e-4, passes: int = 2,
                      contacts=None, smooth: float = 0.0, ballistic: bool = True,
                      keep_floor: bool = False) -> LiftResult:
    """``motion`` with the root raised on every frame where the body's lowest point is more than ``tol``
    (m) below the floor, by that depth (see the module docstring). ``floor_y``: the floor (default: the
    audit's, read from the motion; then read again on the result, and lifted again when it moved, up to
    ``passes`` lifts in all). ``contacts``: the detector's result on ``motion``, if already computed.
    ``smooth``: s; 0 lifts each frame by its own depth; above 0 the lift is the depths spread over
    ``2 smooth`` on each side (a running maximum) and Gaussian-smoothed with sigma ``smooth``, never
    below a frame's own depth: the body rises and settles over that time instead of stopping at the
    floor in a frame (fewer COM velocity steps; the lifted frames around stand above the floor). Spread
    over the ground stage the floor is read from, the lift raises the median the floor is: the floor
    read on the result rises with it (DeepMimic back flip x2: 0.054 -> 0.08 m) and a second pass lifts
    the rest to it. ``keep_floor``: on that stage each frame is lifted by its own depth only, so the
    floor stays -- measured: its frames then stop at the floor one by one, which the audit reads as
    COM velocity steps (SFU Wushu kicks 2 -> 6, cartwheels 0 -> 9 findings), so it is off by default.
    ``ballistic``: over each flight (no effector touching, :func:`mocomp.dynamics.contacts.airborne_intervals`)
    the lift runs linearly between its values at the flight's ends (never below a frame's own depth),
    so the flight's vertical acceleration stays the input's (a linear lift adds a constant velocity)."""
    if passes < 1:
        raise ValueError(f"passes must be at least 1, got {passes}")
    if not tol >= 0:
        raise ValueError(f"tol must be 0 or more m, got {tol!r}")
    fd = floor_depth(motion, floor_y, contacts)
    before = fd.max_depth
    total = np.zeros(motion.n_frames)
    out, k = motion, 0
    notes = []
    while k < passes and fd.max_depth > tol:
        need = np.where(fd.depth > tol, fd.depth, 0.0)
        up = _envelope(need, smooth * motion.fps) if smooth > 0 else need
        if keep_floor and smooth > 0 and floor_y is None:
            # the floor's own stage lifted exactly: its frames below the median come up to it and the
            # others stay, so the median -- the floor -- stays where it is
            a, b = _floor_stage(fd.contacts, out.n_frames)
            up[a:b] = need[a:b]
        if ballistic:
            up = _linear_in_flights(up, need, fd.contacts)
        rp = np.array(out.root_positions)
        rp[:, 1] += up
        out = out.replace(root_positions=rp)
        total += up
        k += 1
        prev = fd.floor_y
        fd = floor_depth(out, floor_y)
        if floor_y is None and abs(fd.floor_y - prev) > tol:
            notes.append(f"pass {k}: the floor read on the lifted frames moved {100 * (fd.floor_y - prev):+.2f} cm")
    if k:
        runs = _runs(total > 0)
        notes.insert(0, f"root lifted by up to {100 * total.max():.2f} cm on {int((total > 0).sum())} frame(s) ("
                        + ", ".join(f"{a}-{b - 1}" for a, b in runs[:6]) + (", ..." if len(runs) > 6 else "")
                        + f"): the lowest body point was {100 * before:.2f} cm below the floor (y = {fd.floor_y:.3f} m)")
    return LiftResult(out, total, fd.floor_y, before, fd.max_depth, k, tuple(notes), fd.contacts)


def _floor_stage(contacts, n: int) -> tuple[int, int]:
    """The ground stage the audit's floor is read from (:func:`mocomp.audit.contacts.floor_level`: the
    first with two planted frames); ``(0, 0)`` when none."""
    from ..audit.contacts import phases_of

    planted = contacts.any_contact
    for a, b in phases_of(contacts, n).ground:
        if int(planted[a:b].sum()) >= 2:
            return a, b
    return 0, 0


def _envelope(up: np.ndarray, sigma: float) -> np.ndarray:
    """The lift spread: a running maximum over ``2 sigma`` frames on each side, Gaussian-smoothed
    (sigma frames), and never below ``up`` itself."""
    from scipy.ndimage import gaussian_filter1d, maximum_filter1d

    r = max(1, int(np.ceil(2 * sigma)))
    return np.maximum(up, gaussian_filter1d(maximum_filter1d(up, 2 * r + 1, mode="nearest"), sigma, mode="nearest"))


def _linear_in_flights(up: np.ndarray, need: np.ndarray, contacts) -> np.ndarray:
    """``up`` made linear over each flight between its values at the flight's ends (the last supported
    frame before, the first after; a flight at the clip's edge takes the other end's value), never
    below ``need`` (each frame's own depth)."""
    from ..dynamics.contacts import airborne_intervals

    out = np.array(up)
    n = len(up)
    for a, b in airborne_intervals(contacts, min_frames=1):
        i0, i1 = a - 1, b                      # supported frames around the flight
        v0 = up[i0] if i0 >= 0 else (up[i1] if i1 < n else 0.0)
        v1 = up[i1] if i1 < n else v0
        t = (np.arange(a, b) - i0) / max(i1 - i0, 1)
        out[a:b] = np.maximum(need[a:b], v0 + (v1 - v0) * t)
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    from ..dynamics.contacts import label_intervals

    return list(label_intervals(mask))
