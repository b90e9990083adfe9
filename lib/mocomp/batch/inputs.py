"""The inputs of a batch: every file below a folder (or matching a glob), each either a motion a
command can read or a file skipped with its reason.

What counts as a motion follows :func:`mocomp.io.load` (the reader ``mocomp info`` and every other
command end up in): an extension in :data:`mocomp.io.LOADERS` (BVH, Acclaim AMC; DeepMimic motion
JSON ``.txt``/``.json``, recognised by its ``"Frames"`` key, so a DeepMimic character file or a
licence text beside it is not taken for one). Everything else is listed with ``status="skipped"``
and a reason, never silently dropped, so the results table accounts for every file:

- ``.asf``: an Acclaim skeleton, read with the ``.amc`` motions beside it;
- ``.c3d``: marker trajectories (:func:`mocomp.io.read_c3d`), not a skeleton motion, which is what
  the commands take (``mocomp info`` refuses it too); it becomes a clip as soon as
  :func:`mocomp.io.load` reads it (``.c3d`` in ``LOADERS``);
- a DeepMimic character file (JSON with ``"Skeleton"``), other ``.txt``/``.json`` files;
- anything else (``MANIFEST.md``, ``.xml`` skeletons, ``.csv`` tables, ...): not a motion file.

Hidden files and folders (``.name``) and the batch's own output folder are not walked. A folder is
walked recursively in sorted order; clip ids are paths relative to the folder (for a glob: relative
to the glob's folder part), with ``/`` separators, so they are stable across machines and runs.
"""
from __future__ import annotations

import glob as _glob
import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["InputFile", "discover", "classify"]


@dataclass(frozen=True)
class InputFile:
    """One file of a batch's input.

    clip: id of the file, its path relative to the input root (``flips/cmu_88_01_backflip.bvh``).
    path: absolute path.
    format: ``BVH``, ``ASF/AMC``, ``DeepMimic`` for a motion; the kind of file otherwise.
    skip_reason: ``None`` for a motion the command is run on, else why the file is skipped.
    """

    clip: str
    path: Path
    format: str
    skip_reason: str | None = None

    @property
    def is_motion(self) -> bool:
        return self.skip_reason is None


def _head(path: Path, n: int = 2048) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read(n)
    except OSError:
        return b""


def classify(path: Path) -> tuple[str, str | None]:
    """``(format, skip_reason)`` of one file (see the module docstring); ``skip_reason`` ``None`` =
    a motion a command can read."""
    from ..io import LOADERS

    ext = path.suffix.lower()
    if ext in (".txt", ".json"):
        head = _head(path)
        if b'"Frames"' in head:
            return "DeepMimic", None
        if b'"Skeleton"' in head:
            return "DeepMimic character", ("DeepMimic character file (skeleton and bodies), read with the "
                                           "DeepMimic motions beside it")
        return f"text ({ext})", f"{ext} file that is not a DeepMimic motion (no \"Frames\" key)"
    if ext == ".asf":
        return "ASF skeleton", "Acclaim ASF skeleton, read with the .amc motions beside it"
    if ext == ".c3d":
        if ext in LOADERS:  # pragma: no cover - once mocomp.io.load reads C3D it is a clip
            return "C3D", None
        return "C3D markers", ("C3D marker trajectories, not a skeleton motion (mocomp.io.read_c3d); the "
                               "commands take skeleton motions (BVH, ASF/AMC, DeepMimic)")
    if ext in LOADERS:
        return {".bvh": "BVH", ".amc": "ASF/AMC"}.get(ext, ext.lstrip(".").upper()), None
    return (ext.lstrip(".").upper() or "no extension"), (
        f"not a motion file ({ext or 'no extension'}; motions: {', '.join(sorted(LOADERS))})")


def _hidden(rel: Path) -> bool:
    return any(part.startswith(".") for part in rel.parts)


def discover(source: str | os.PathLike, exclude: str | os.PathLike | None = None) -> list[InputFile]:
    """Every file of a batch's input, sorted by clip id.

    source: a folder (walked recursively), a glob (``data/flips/*.bvh``, ``data/**/*.amc``; ``**``
        recursive) or a single file.
    exclude: a folder left out (the batch's output folder when it lies inside the input).

    Raises ``FileNotFoundError`` naming ``source`` when it is neither an existing folder/file nor a
    glob that matches a file.
    """
    text = os.fspath(source)
    src = Path(text).expanduser()
    excl = Path(os.path.abspath(Path(exclude).expanduser())) if exclude is not None else None
    if src.is_dir():
        root = src
        files = [p for p in src.rglob("*")]
    elif src.is_file():
        root = src.parent
        files = [src]
    elif _glob.has_magic(text):
        parts = Path(text).expanduser().parts
        fixed = list(parts[:next(i for i, p in enumerate(parts) if _glob.has_magic(p))])
        root = Path(*fixed) if fixed else Path(".")
        files = [Path(p) for p in _glob.glob(os.path.expanduser(text), recursive=True)]
        if not any(p.is_file() for p in files):
            raise FileNotFoundError(f"input {text}: no file matches this pattern")
    else:
        raise FileNotFoundError(f"input {text}: no such folder or file")
    out: list[InputFile] = []
    for p in files:
        if not p.is_file():
            continue
        ap = Path(os.path.abspath(p))
        if excl is not None and (ap == excl or excl in ap.parents):
            continue
        try:
            rel = Path(os.path.abspath(p)).relative_to(Path(os.path.abspath(root)))
        except ValueError:
            rel = Path(p.name)
        if _hidden(rel):
            continue
        fmt, reason = classify(p)
        out.append(InputFile(rel.as_posix(), Path(os.path.abspath(p)), fmt, reason))
    out.sort(key=lambda f: f.clip)
    return out
