"""Length units of motion files and the standing-height sanity check."""
from __future__ import annotations

import math
import warnings

from ..errors import MotionFormatError

__all__ = ["UNITS", "guess_unit_scale", "check_height", "resolve_scale", "standing_height"]

#: metres per file unit for the units real clips use (see shared MANIFEST).
UNITS = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "cmu": 0.0254 / 0.45,  # CMU ASF/BVH: length 0.45 => 1 unit = 1/0.45 inch
}

TYPICAL_HEIGHT = 1.7
HEIGHT_RANGE = (1.2, 2.2)


def guess_unit_scale(height_in_file_units: float) -> tuple[float, str]:
    """Pick the unit whose scale puts a rest-pose height closest to 1.7 m (log ratio).

    Returns ``(metres_per_unit, reason)``. Only a guess: callers that know the
    source's unit pass it explicitly.
    """
    if not (height_in_file_units > 0 and math.isfinite(height_in_file_units)):
        return 1.0, "no height to guess from; assumed metres"
    best = min(UNITS.items(), key=lambda kv: abs(math.log(height_in_file_units * kv[1] / TYPICAL_HEIGHT)))
    return best[1], f"guessed '{best[0]}' from standing height {height_in_file_units:.4g} file units"


def resolve_scale(scale, height_in_file_units: float, default_unit: str | None = None) -> tuple[float, str]:
    """Turn a user ``scale`` argument into metres-per-unit and a reason.

    ``scale`` may be a number (metres per file unit), a unit name from
    :data:`UNITS`, ``"auto"`` (guess from height) or ``None`` (use
    ``default_unit`` if the format defines one, else guess).
    """
    if scale is None:
        if default_unit is not None:
            return UNITS[default_unit], f"format default unit '{default_unit}'"
        scale = "auto"
    if isinstance(scale, str):
        if scale == "auto":
            return guess_unit_scale(height_in_file_units)
        if scale not in UNITS:
            raise ValueError(f"unknown unit {scale!r}; use a number (metres per unit) or one of {sorted(UNITS)}")
        return UNITS[scale], f"unit '{scale}' given by caller"
    s = float(scale)
    if not (s > 0 and math.isfinite(s)):
        raise ValueError(f"scale must be a positive number of metres per file unit, got {scale!r}")
    return s, f"scale {s:g} m/unit given by caller"


def check_height(height_m: float, where: str, motion=None, scale: float = 1.0) -> None:
    """Warn when a skeleton's standing height (metres) is outside 1.2-2.2 m.

    ``height_m`` is the cheap all-joints estimate (:func:`standing_height`, times ``scale``).
    It underestimates clips that never stand upright (a crouching charge: 1.195 m), so when it
    is outside the range and ``motion`` (in file units) is given, the height is measured again
    by :func:`mocomp.body.height.estimate_height` (head top to feet, or the skeleton's stature
    from bone lengths when the clip never stands upright) and only that decides the warning.
    """
    lo, hi = HEIGHT_RANGE
    if not (lo <= height_m <= hi) and motion is not None:
        from ..body.height import estimate_height  # only for the rare suspicious clip

        try:
            better = estimate_height(motion).value * scale
        except (MotionFormatError, ValueError):
            better = float("nan")
        if math.isfinite(better) and better > 0:
            height_m = better
    if not (lo <= height_m <= hi):
        warnings.warn(
            f"{where}: standing height {height_m:.3f} m is outside {lo}-{hi} m; "
            "check the length unit (pass scale=...)",
            UnitWarning,
            stacklevel=3,
        )


class UnitWarning(UserWarning):
    """A loaded skeleton has an implausible size for its assumed unit."""


def standing_height(motion) -> float:
    """Standing-height estimate from the motion itself, in the motion's length unit.

    The 95th percentile over frames of the vertical (y) extent of all joints and
    end sites. Unlike the rest pose (which for some rigs is not upright, e.g. the
    Bandai Namco files), this works for any rig; for clips that never stand
    straight it underestimates.
    """
    import numpy as np

    P = motion.positions
    E = motion.end_site_positions()
    allp = np.concatenate([P, E], axis=1) if E.shape[1] else P
    ext = allp[..., 1].max(axis=1) - allp[..., 1].min(axis=1)
    return float(np.percentile(ext, 95))
