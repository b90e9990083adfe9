"""Physical constants shared by every layer above ``dynamics``."""

import numpy as np

from ..errors import PhysicsError

__all__ = ["G_STANDARD", "GRAVITY_CHOICES", "resolve_gravity"]

#: standard gravity, m/s^2 (the magnitude; the world is y-up so gravity is ``(0, -G_STANDARD, 0)``).
#: Generated flights fall with it by default; a gravity fitted to a clip is a diagnostic of the
#: clip's frame rate and units, never the truth (issue #13 section 3).
G_STANDARD = 9.81

#: the named values of a method's ``gravity`` parameter (besides a number in m/s^2)
GRAVITY_CHOICES = ("standard", "clip")


def resolve_gravity(gravity, fitted: float = float("nan")) -> tuple[float, str]:
    """The gravity a generated flight falls with, and its source in words.

    ``gravity``: ``"standard"`` (9.81 m/s^2, :data:`G_STANDARD`), ``"clip"``
    (``fitted``, the gravity fitted to the input's flight: the paper's choice, which carries a clip's frame-rate or unit error into the output) or a number of m/s^2
    in [0.5, 100] (as a float, or a string such as ``"9.6"``; source ``"given"``). Raises
    ``ValueError`` naming the value otherwise, :class:`~mocomp.errors.PhysicsError` for ``"clip"``
    without a downward fit. One resolution for every method that generates a flight (flips, edit,
    join, twist)."""
    if isinstance(gravity, str):
        key = gravity.strip().lower()
        if key == "standard":
            return float(G_STANDARD), "standard"
        if key == "clip":
            if not (np.isfinite(fitted) and fitted > 0):
                raise PhysicsError(f"gravity='clip' needs a downward flight fit, but the clip's fitted gravity is "
                                   f"{fitted!r}")
            return float(fitted), "clip"
        try:
            value = float(key)
        except ValueError:
            raise ValueError(f"gravity must be 'standard', 'clip' or a number of m/s^2, got {gravity!r}") from None
    elif isinstance(gravity, bool) or not isinstance(gravity, (int, float, np.integer, np.floating)):
        raise ValueError(f"gravity must be 'standard', 'clip' or a number of m/s^2, got {gravity!r}")
    else:
        value = float(gravity)
    if not (np.isfinite(value) and 0.5 <= value <= 100.0):
        raise ValueError(f"gravity must be a finite number of m/s^2 in [0.5, 100], got {gravity!r}")
    return value, "given"
