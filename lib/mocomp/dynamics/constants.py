"""Physical constants shared by every layer above ``dynamics``."""

__all__ = ["G_STANDARD"]

#: standard gravity, m/s^2 (the magnitude; the world is y-up so gravity is ``(0, -G_STANDARD, 0)``).
#: Generated flights fall with it by default; a gravity fitted to a clip is a diagnostic of the
#: clip's frame rate and units, never the truth (issue #13 section 3).
G_STANDARD = 9.81
