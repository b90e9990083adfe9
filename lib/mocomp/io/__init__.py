"""File input/output: every reader returns a :class:`~mocomp.core.Motion` in metres
(C3D returns :class:`Markers`). :func:`load` picks the reader by file extension."""
from __future__ import annotations

from pathlib import Path

from ..errors import MotionFormatError
from .asf_amc import Asf, read_amc, read_asf
from .bvh import format_bvh, parse_bvh, read_bvh, reorder_joints, write_bvh
from .c3d import read_c3d
from .deepmimic import match_character, read_deepmimic, read_deepmimic_body, read_deepmimic_character, recognized_body
from .markers import Markers
from .units import UNITS, UnitWarning

__all__ = [
    "load", "LOADERS",
    "read_bvh", "write_bvh", "parse_bvh", "format_bvh", "reorder_joints",
    "read_amc", "read_asf", "Asf",
    "read_deepmimic", "read_deepmimic_character", "read_deepmimic_body", "match_character", "recognized_body",
    "read_c3d", "Markers",
    "UNITS", "UnitWarning",
]

#: extension -> (reader, description)
LOADERS = {
    ".bvh": (read_bvh, "BVH"),
    ".amc": (read_amc, "Acclaim AMC motion (needs its .asf skeleton: beside it, or asf=...)"),
    ".txt": (read_deepmimic, "DeepMimic motion JSON (needs its character file: found nearby, or character=...)"),
    ".json": (read_deepmimic, "DeepMimic motion JSON"),
}


def load(path, scale=None, fps: float | None = None, **kw):
    """Read any supported motion file into a :class:`~mocomp.core.Motion` (metres, y-up).

    ``.bvh`` -> :func:`read_bvh`; ``.amc`` -> :func:`read_amc` (``asf=`` or the
    ``.asf`` beside it); ``.txt``/``.json`` -> :func:`read_deepmimic`
    (``character=`` or the character file nearby). ``scale`` (metres per file
    unit or a unit name) and ``fps`` (frame-rate override) are passed on, as
    are reader-specific keywords (``height_check``, ``asf``, ``character``).
    Raises :class:`MotionFormatError` for an unknown extension.
    """
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".asf":
        raise MotionFormatError("an .asf file holds only a skeleton; load its .amc motion (read_asf() gives the "
                                "skeleton)", p)
    if ext == ".c3d":
        raise MotionFormatError("a .c3d file holds marker trajectories, not a skeleton motion; use read_c3d()", p)
    if ext not in LOADERS:
        known = ", ".join(sorted(LOADERS))
        raise MotionFormatError(f"unknown motion file extension {p.suffix!r}; supported: {known}", p)
    if not p.exists():
        raise MotionFormatError("no such file", p)
    reader = LOADERS[ext][0]
    return reader(p, scale=scale, fps=fps, **kw)
