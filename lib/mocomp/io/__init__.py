"""File input/output: every reader returns a :class:`~mocomp.core.Motion` in metres."""
from .bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from .units import UNITS, UnitWarning

__all__ = ["read_bvh", "write_bvh", "parse_bvh", "format_bvh", "UNITS", "UnitWarning"]
