"""Frames under a declared external force (a hit, a push): airborne there is *forced*, not free flight.

The audit measures a motion from its frames alone, so it cannot tell a body knocked into the air
from one that jumped: both leave the floor, and while the blow lasts the COM does not fall at
9.81 m/s^2 and L is not conserved. A caller that knows when an external force acts (the impact
response's simulated contact frames, issue 18) declares those frames:

    audit(victim, external_force_frames=slice(120, 131))          # or a (T,) bool mask,
    audit(victim, external_force_frames=[(120, 131), (300, 304)]) # frame indices, (start, stop) pairs
    mocomp audit victim.bvh --external-force 120:131 --external-force 300:304

and the audit then

* labels each flight that has a forced frame ``kind == "forced"`` and judges the ballistic fit and
  the L measures only on its longest free part (the frames after the force ended, typically);
  with no free part of ``min_flight_frames`` the flight gets no fit and no L measure;
* reports the findings of the force-dependent checks (:data:`FORCE_CHECKS`) whose frames touch a
  forced frame with severity ``"expected"`` ("expected under the declared external force"), which
  is neither a violation nor an advisory, so it does not change the verdict; a COM velocity jump is
  measured with one-sided fits of ``w`` frames, so a jump within ``w`` frames of a forced frame
  counts as touching it;
* leaves the floor penetration and the kinematic checks (bone lengths, joint rates, root and point
  speeds) as they are: no force excuses a foot in the floor or a joint flipping in one frame.

Declared frames are half-open ranges of motion frames (0-based).
"""
from __future__ import annotations

import numpy as np

from ..dynamics.contacts import label_intervals
from ..errors import MotionFormatError

__all__ = ["FORCE_CHECKS", "forced_mask", "parse_frame_ranges", "dilate", "ranges_text"]

#: checks whose findings are expected where an external force acts (they assume the body is moved by
#: gravity and its supports only)
FORCE_CHECKS = frozenset({"com_velocity_jump", "gravity", "L_direction", "L_magnitude", "zmp_outside", "foot_slide",
                          "hand_slide", "pose_jump"})


def parse_frame_ranges(items) -> list[tuple[int, int]]:
    """``["120:131", "300:304", "57"]`` -> ``[(120, 131), (300, 304), (57, 58)]`` (half-open, like a
    Python slice; ``A:B`` needs ``0 <= A < B``). Comma-separated items in one string are split too."""
    out = []
    for item in items or ():
        for part in str(item).split(","):
            part = part.strip()
            if not part:
                continue
            a, sep, b = part.partition(":")
            try:
                lo = int(a)
                hi = int(b) if sep else lo + 1
            except ValueError:
                raise MotionFormatError(f"external force frames {part!r}: not START:STOP (integers)") from None
            if lo < 0 or hi <= lo:
                raise MotionFormatError(f"external force frames {part!r}: need 0 <= START < STOP")
            out.append((lo, hi))
    return out


def forced_mask(spec, n_frames: int, label: str = "motion") -> np.ndarray | None:
    """``(n_frames,)`` bool mask of the frames under external force, or ``None`` for ``spec`` None.

    ``spec``: a ``slice``; a ``(n_frames,)`` bool array; an array/list of frame indices; a list of
    ``(start, stop)`` half-open pairs; or ``"A:B"`` strings (:func:`parse_frame_ranges`). Frames past
    the motion's end are an error naming ``label``."""
    if spec is None:
        return None
    mask = np.zeros(n_frames, bool)
    if isinstance(spec, slice):
        if spec.step not in (None, 1):
            raise MotionFormatError(f"{label}: external force frames: a slice with a step is not a frame range")
        a, b, _ = spec.indices(n_frames)
        if (spec.stop is not None and spec.stop > n_frames) or (spec.start is not None and spec.start >= n_frames):
            raise MotionFormatError(f"{label}: external force frames {spec.start}:{spec.stop} lie beyond the "
                                    f"motion's {n_frames} frames")
        mask[a:b] = True
        return mask
    if isinstance(spec, str):
        spec = parse_frame_ranges([spec])
    arr = np.asarray(spec, dtype=object) if not isinstance(spec, np.ndarray) else spec
    if arr.dtype == bool:
        if arr.shape != (n_frames,):
            raise MotionFormatError(f"{label}: external force mask has shape {arr.shape}, the motion has "
                                    f"{n_frames} frames")
        return arr.copy()
    items = list(spec)
    if items and all(isinstance(x, str) for x in items):
        items = parse_frame_ranges(items)
    if items and all(np.ndim(x) == 1 and len(x) == 2 for x in items):
        for a, b in items:
            a, b = int(a), int(b)
            if a < 0 or b <= a:
                raise MotionFormatError(f"{label}: external force range ({a}, {b}) needs 0 <= start < stop")
            if b > n_frames:
                raise MotionFormatError(f"{label}: external force range {a}:{b} lies beyond the motion's "
                                        f"{n_frames} frames")
            mask[a:b] = True
        return mask
    try:
        idx = np.asarray(items, dtype=float)
    except (TypeError, ValueError):
        raise MotionFormatError(f"{label}: external force frames must be a slice, a bool mask, frame indices or "
                                f"(start, stop) pairs, got {spec!r}") from None
    if idx.ndim != 1 or (idx.size and (np.any(idx != np.round(idx)))):
        raise MotionFormatError(f"{label}: external force frame indices must be whole numbers, got {spec!r}")
    idx = idx.astype(int)
    if idx.size and (idx.min() < 0 or idx.max() >= n_frames):
        raise MotionFormatError(f"{label}: external force frame {int(idx.min() if idx.min() < 0 else idx.max())} "
                                f"lies outside the motion's frames 0-{n_frames - 1}")
    mask[idx] = True
    return mask


def dilate(mask: np.ndarray, reach: int) -> np.ndarray:
    """``mask`` widened by ``reach`` frames on both sides."""
    if reach <= 0 or not mask.any():
        return mask.copy()
    out = np.zeros_like(mask)
    T = mask.size
    for a, b in label_intervals(mask):
        out[max(0, a - reach):min(T, b + reach)] = True
    return out


def ranges_text(mask: np.ndarray) -> str:
    return ", ".join(f"{a}-{b - 1}" if b - a > 1 else f"{a}" for a, b in label_intervals(mask))
