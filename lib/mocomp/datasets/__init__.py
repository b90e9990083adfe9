"""Named example motions (synthetic, embedded) and real clips from the data directory.

>>> from mocomp import datasets
>>> m = datasets.load("backflip")          # embedded, generated on first use, cached
>>> truth = datasets.load_example("backflip")  # the generator's full result (ground truth)
>>> m = datasets.load("88_01")             # real clip by CMU trial id (needs MOCOMP_DATA_DIR)
>>> m = datasets.load("cmu_88_01_backflip", raw=True)   # ... without the known corrections
>>> datasets.list()                        # DataFrame: name, kind, description, ...

Lookup order for ``load(name)``: an embedded example name; an existing file
path; a clip in the data directory (``$MOCOMP_DATA_DIR``) by file stem
(``01_01``; a derived file ``ase_rl_Fall_Left.derived.bvh`` also by ``ase_rl_Fall_Left``),
file name (``01_01.amc``), path relative to the directory (``jumps/01_01.amc``) or CMU trial id (``88_01`` finds ``cmu_88_01_backflip.bvh``).
When several files share a name, BVH wins over ASF/AMC over DeepMimic.

Real clips get the known corrections of :mod:`mocomp.datasets.clips` (true
frame rate, source unit, T-pose first frame), each recorded in
``motion.source.notes``; ``fps=``/``scale=`` override them, ``raw=True`` skips them.
They apply only to files that *are* known clips (:func:`mocomp.datasets.known.identify`):
files in the data directory or the CMU download cache, and byte copies (same SHA-256) of a
file the data MANIFEST lists or of the data-directory clip their name matches. Any other
file, whatever its name (``88_01_x2.bvh`` written by ``mocomp flips``), is read as
written: header frame rate, the reader's unit; a note says when its name matches a clip.
"""
from __future__ import annotations

import builtins
import dataclasses
import difflib
import functools
import importlib
import os
import re
from pathlib import Path
from typing import Any

from ..errors import DataNotFoundError, MotionFormatError
from .clips import ClipFacts, facts_for, is_tpose_frame
from .config import ENV_VAR, data_dir
from .download import CMU_REGISTRY, fetch_cmu, normalize_trial
from .examples import EXAMPLES, Example, register
from .known import KnownClip, file_sha256, identify

__all__ = ["load", "load_example", "list", "find_clip", "real_clips", "examples", "data_dir", "ENV_VAR",
           "fetch_cmu", "facts_for", "ClipFacts", "Example", "register", "EXAMPLES", "rounded_frame_rate",
           "identify", "KnownClip"]

#: file kinds that hold a skeleton motion, in order of preference when names collide
_PREFERENCE = (".bvh", ".amc", ".txt", ".json")


# ------------------------------------------------------------------ examples
def examples() -> dict[str, Example]:
    """The registered embedded examples (importing :mod:`mocomp.synth` registers them)."""
    try:
        importlib.import_module("mocomp.synth")
    except ModuleNotFoundError as e:  # synth not written yet; anything else is a real error
        if e.name not in ("mocomp.synth",):
            raise
    return EXAMPLES


@functools.lru_cache(maxsize=None)
def _make_example(name: str) -> Any:
    return EXAMPLES[name].make()


def load_example(name: str) -> Any:
    """The full generated result of embedded example ``name`` (its ``.motion`` and ground
    truth), generated once per process and cached (results are immutable)."""
    ex = examples()
    if name not in ex:
        raise DataNotFoundError(f"no embedded example {name!r}; examples: {', '.join(sorted(ex)) or 'none registered'}")
    return _make_example(name)


# ---------------------------------------------------------------- real clips
def _sniff_motion_json(path: Path) -> bool:
    """A DeepMimic motion (``{"Loop": ..., "Frames": [...]}``), not a character file."""
    try:
        with open(path, "rb") as f:
            head = f.read(512)
    except OSError:
        return False
    return b'"Frames"' in head


def real_clips(root: str | Path | None = None) -> builtins.list[Path]:
    """Motion files (BVH, AMC, DeepMimic motion JSON) below the data directory, sorted."""
    root = Path(root) if root is not None else data_dir()
    if root is None:
        return []
    out = []
    for p in sorted(root.rglob("*")):
        if not p.is_file():
            continue
        ext = p.suffix.lower()
        if ext in (".bvh", ".amc") or (ext in (".txt", ".json") and _sniff_motion_json(p)):
            out.append(p)
    return out


def _prefer(paths: builtins.list[Path]) -> builtins.list[Path]:
    """Paths of the most preferred format only."""
    best = min(_PREFERENCE.index(p.suffix.lower()) if p.suffix.lower() in _PREFERENCE else 99 for p in paths)
    return [p for p in paths if (_PREFERENCE.index(p.suffix.lower()) if p.suffix.lower() in _PREFERENCE else 99)
            == best]


def _trial_of(stem: str) -> str | None:
    from .clips import cmu_trial

    t = cmu_trial(stem)
    return None if t is None else f"{t[0]}_{t[1]:02d}"


def find_clip(name: str, root: str | Path | None = None) -> Path:
    """The file of real clip ``name`` in the data directory (see the module docstring).

    Raises :class:`DataNotFoundError` naming the directory searched, near names,
    and how to obtain the clip.
    """
    root = Path(root) if root is not None else data_dir()
    if root is None:
        raise DataNotFoundError(_not_found_message(name, None, []))
    clips = real_clips(root)
    key = name.strip().replace("\\", "/")
    low = key.lower()
    # relative path or file name
    hits = [p for p in clips if p.relative_to(root).as_posix().lower() == low or p.name.lower() == low]
    if not hits:
        hits = [p for p in clips if p.stem.lower() == low]
    if not hits:  # derived files (ase_rl_Fall_Left.derived.bvh) also answer to their source's stem
        hits = [p for p in clips if p.stem.lower().endswith(".derived") and p.stem.lower()[:-8] == low]
    if not hits and re.fullmatch(r"\d{1,3}_\d{1,3}", key):
        tid = normalize_trial(key)
        hits = [p for p in clips if _trial_of(p.stem) == tid]
    if hits:
        hits = _prefer(hits)
        if len(hits) > 1:
            rel = ", ".join(p.relative_to(root).as_posix() for p in hits)
            raise DataNotFoundError(f"clip name {name!r} is ambiguous in {root}: {rel}; pass the relative path")
        return hits[0]
    raise DataNotFoundError(_not_found_message(name, root, clips))


def _not_found_message(name: str, root: Path | None, clips: builtins.list[Path]) -> str:
    ex = sorted(examples())
    tid = None
    if re.fullmatch(r"\d{1,3}_\d{1,3}", name.strip()):
        tid = normalize_trial(name.strip())
    how = []
    if tid is not None and tid in CMU_REGISTRY:
        how.append(f"CMU {tid} can be downloaded: mocomp.datasets.load({name!r}, download=True) "
                   f"(from {CMU_REGISTRY[tid].repo})")
    elif tid is not None:
        how.append(f"get CMU trial {tid} from mocap.cs.cmu.edu (cgspeed BVH release) and put it in the data directory")
    else:
        hint = _source_hint(name, root)
        if hint:
            how.append(hint)
    if root is None:
        msg = (f"{name!r} is not an embedded example ({', '.join(ex) or 'none registered'}) nor an existing file, "
               f"and no real-data directory is set: set {ENV_VAR} to the folder of capture clips "
               "(e.g. export MOCOMP_DATA_DIR=../shared/data/mocap)")
    else:
        cands = sorted({p.stem for p in clips} | set(ex))
        close = difflib.get_close_matches(name, cands, n=4, cutoff=0.5)
        msg = (f"no clip {name!r} in {root} ({len(clips)} clips; looked for an example name, a file stem, "
               f"a file name or relative path, and a CMU trial id like 88_01)")
        if close:
            msg += f"; close: {', '.join(close)}"
    return "; ".join([msg] + how)


#: data set of each non-CMU file-name prefix (as :func:`mocomp.datasets.clips.facts_for` reads them)
_SOURCE_NAMES = {
    "sfu": "SFU Motion Capture Database",
    "bandai": "Bandai Namco Research Motion Dataset",
    "deepmimic": "DeepMimic motion (its character file goes in skeletons/)",
    "mass": "MASS (retargeted BVH)",
    "hdm05": "HDM05 (ASF/AMC, C3D markers)",
    "ase": "ASE / Reallusion sword-and-shield library (BVH derived from ASE's npy motions)",
}


def _source_hint(name: str, root: Path | None) -> str:
    """How to obtain a non-CMU clip: its data set (from the name's prefix: ``sfu_``,
    ``bandai``, ``deepmimic_``, ``mass_``, ``hdm05``/``HDM_``, ``ase_``) and where its origin is
    recorded (the data MANIFEST.md's source column; quoted when a row names the clip)."""
    stem = Path(name.strip().replace("\\", "/")).name
    low = stem.lower()
    source = "hdm05" if low.startswith("hdm05") else facts_for(Path(stem)).source
    if source not in _SOURCE_NAMES:
        return ""
    manifest = "the data set's MANIFEST.md" if root is None else str(root / "MANIFEST.md")
    hint = (f"{stem!r} is named like a clip of the {_SOURCE_NAMES[source]} data: the 'source' column "
            f"of {manifest} says where each staged clip comes from; fetch the file from there and put it in "
            + ("the data directory" if root is None else str(root)))
    row = _manifest_source(str(root), Path(stem).stem) if root is not None else ""
    if row:
        hint += f" (MANIFEST row for it: {row})"
    return hint


def _manifest_source(root: str, stem: str) -> str:
    """The source column of the MANIFEST.md row whose file has stem ``stem``, or ``''``."""
    try:
        text = (Path(root) / "MANIFEST.md").read_text(encoding="utf-8")
    except OSError:
        return ""
    lines = [ln for ln in text.splitlines() if ln.startswith("|")]
    header = next((ln for ln in lines if "source" in ln.lower() and "file" in ln.lower()), None)
    if header is None:
        return ""
    cols = [c.strip().lower() for c in header.strip("|").split("|")]
    k = next((i for i, c in enumerate(cols) if c.startswith("source")), None)
    if k is None:
        return ""
    for ln in lines:
        cells = [c.strip() for c in ln.strip("|").split("|")]
        m = re.match(r"`([^`]+)`", cells[0]) if cells else None
        if m and Path(m.group(1)).stem.lower() == stem.lower() and len(cells) > k:
            return cells[k].replace("`", "")
    return ""


# ---------------------------------------------------------------------- load
def _read(path: Path, scale=None, fps=None, **kw):
    """Read any motion file: ``mocomp.io.load`` when available, else the BVH reader."""
    io = importlib.import_module("mocomp.io")
    args = dict(kw)
    if scale is not None:
        args["scale"] = scale
    if fps is not None:
        args["fps"] = fps
    reader = getattr(io, "load", None)
    if reader is not None:
        return reader(path, **args)
    if path.suffix.lower() == ".bvh":
        return io.read_bvh(path, **args)
    raise MotionFormatError(f"no reader for {path.suffix or 'extension-less'} files", path)


def _printed_decimals(x: float) -> int | None:
    """Decimals of the shortest decimal text that reads back as ``x`` (to 4 ulp), ``None`` past 15."""
    import numpy as np

    for d in range(1, 16):
        if abs(round(x, d) - x) <= 4 * np.spacing(x):
            return d
    return None


def rounded_frame_rate(header_fps: float) -> int | None:
    """The whole frame rate ``N`` whose frame time ``1/N``, cut or rounded to the decimals the
    header printed, is the header's frame time (``.0083333`` -> 120, ``0.033333`` -> 30), else ``None``.

    The header's frame time is ``1/header_fps``; the decimals it was printed with are those of
    its shortest decimal text. It is a rounded ``1/N`` when it differs from ``1/N`` by less than
    one unit of its last printed digit. Rates a source states on purpose with more digits than a
    rounded whole rate would need (ASE's ``Frame Time: 0.0334925`` = 29.857 Hz, ``0.0333346008``
    = 29.9988 Hz) are not whole rates.
    """
    if not (0 < header_fps < float("inf")):  # also NaN
        return None
    n = round(header_fps)
    if n < 1:
        return None
    ft = 1.0 / header_fps
    d = _printed_decimals(ft)
    tol = 10.0 ** -d if d is not None else 1e-15
    return int(n) if abs(ft - 1.0 / n) < tol else None


def _facts_would_be(facts: ClipFacts) -> str:
    """The corrections ``facts`` would make, as keyword advice (``scale='cmu', fps=60``)."""
    parts = []
    if facts.unit is not None:
        parts.append(f"scale={facts.unit!r}")
    if facts.fps is not None:
        parts.append(f"fps={facts.fps:g}")
    return ", ".join(parts)


def _twin(path: Path) -> Path | None:
    """The data-directory clip that ``path``'s name matches (its stem, or its CMU trial id:
    ``88_01_x2`` -> ``88_01``), or ``None``."""
    if data_dir() is None:
        return None
    for key in dict.fromkeys(k for k in (path.stem, _trial_of(path.stem)) if k):
        try:
            return find_clip(key)
        except (DataNotFoundError, MotionFormatError, OSError):
            continue
    return None


def _identify(path: Path) -> KnownClip | None:
    """The known clip ``path`` is: :func:`~mocomp.datasets.known.identify` (data directory, download
    cache, MANIFEST SHA-256), else a byte copy of the data-directory clip its name matches."""
    known = identify(path)
    if known is not None:
        return known
    twin = _twin(path)
    if twin is None:
        return None
    try:
        if twin.stat().st_size == path.stat().st_size and file_sha256(twin) == file_sha256(path):
            return KnownClip(twin.relative_to(data_dir()).as_posix(), "sha256")
    except OSError:
        return None
    return None


def _unknown_name_note(path: Path) -> str:
    """The note for a file named like a known clip (or data source) that is not one, else ``''``."""
    named = facts_for(path)
    if named == ClipFacts():
        return ""
    advice = _facts_would_be(named)
    advice = f"; if it really is that clip, pass {advice}" if advice else ""
    twin = _twin(path)
    if twin is not None:
        root = data_dir()
        rel = twin.relative_to(root).as_posix() if root is not None else twin.name
        return (f"name matches known clip {rel} but content differs: its facts (unit, frame rate, T-pose frame) "
                f"are not applied{advice}")
    return (f"named like a {named.source} clip but not a known clip file (not in the data directory, SHA-256 not "
            f"in its MANIFEST.md): that source's facts (unit, frame rate, T-pose frame) are not applied{advice}")


def _apply_facts(path: Path, fps, scale, raw: bool, known: KnownClip | None = None, **kw):
    """Read ``path`` and apply the facts of the known clip ``known`` (``None``: a file that is
    no known clip, read as written -- header fps, the reader's unit)."""
    facts = facts_for(Path(known.name)) if known is not None else ClipFacts()
    use_scale = scale if (scale is not None or raw) else facts.unit
    use_fps = fps if (fps is not None or raw) else facts.fps
    m = _read(path, scale=use_scale, fps=use_fps, **kw)
    if raw:
        return m
    src = m.source
    notes = builtins.list(src.notes)
    unit_reason = src.unit_reason
    if scale is None and facts.unit is not None:
        unit_reason = f"{facts.unit_reason} (mocomp.datasets.clips; override with scale=)"
    hdr = src.header_fps
    if fps is None and facts.fps is not None:
        if hdr and abs(hdr - facts.fps) <= 1e-4 * facts.fps:
            notes.append(f"frame rate {facts.fps:g} Hz (the header's {hdr:.7g} Hz is a rounded frame time)")
        else:
            notes.append(f"frame rate {facts.fps:g} Hz used instead of the header's "
                         f"{hdr:.6g} Hz: {facts.fps_reason}; override with fps= or raw=True" if hdr else
                         f"frame rate {facts.fps:g} Hz: {facts.fps_reason}")
    elif fps is None and hdr and src.format == "bvh" and round(hdr) != hdr and rounded_frame_rate(hdr):
        # BVH "Frame Time: .0083333" means 120 Hz: snap rates that are whole numbers up to the printed
        # digits of the frame time; a rate such as ASE's 29.857 Hz (Frame Time 0.0334925) is kept
        if abs(hdr - round(hdr)) > 1e-7 * hdr:
            notes.append(f"frame rate {round(hdr)} Hz (the header's {hdr:.7g} Hz is a rounded frame time)")
        m = m.replace(fps=float(round(hdr)))
    if facts.tpose_first_frame and is_tpose_frame(m):
        m = m[1:]
        notes.append("dropped file frame 0, a T-pose that is not part of the take (file frame k is motion frame "
                     "k-1); raw=True keeps it")
    notes.extend(facts.notes)
    if known is not None and known.how == "sha256":
        notes.append(f"identified by its SHA-256 as the data directory's {known.name}: that clip's known "
                     "facts apply")
    elif known is None:
        note = _unknown_name_note(path)
        if note:
            notes.append(note)
    src = dataclasses.replace(src, unit_reason=unit_reason, notes=tuple(notes))
    return m.replace(source=src)


def load(name_or_path, *, fps: float | None = None, scale=None, raw: bool = False, download: bool = False,
         **kw):
    """A :class:`~mocomp.core.Motion` by example name, file path or real-clip name.

    Parameters
    ----------
    name_or_path: an embedded example name (``datasets.list()``), a path to a motion
        file, or the name of a real clip in the data directory (stem, file name,
        relative path or CMU trial id).
    fps: frame rate to use instead of the header's / the known correction.
    scale: metres per file unit (number or unit name) instead of the source's known unit.
    raw: skip the known corrections of :mod:`mocomp.datasets.clips` (header fps,
        the reader's own unit choice, T-pose frame kept).
    download: fetch a CMU trial that is not in the data directory (see :func:`fetch_cmu`).
    kw: passed to the file reader.

    Examples are generated once per process and cached; ``fps``/``scale`` do not
    apply to them (they are generated in metres at their own rate).
    """
    if isinstance(name_or_path, str) and name_or_path in examples():
        if fps is not None or scale is not None or kw:
            raise ValueError(f"{name_or_path!r} is a generated example (metres, its own frame rate): fps=, scale= "
                             "and reader options apply to files only; use motion.resample()/with_fps()")
        return load_example(name_or_path).motion
    p = Path(os.fspath(name_or_path)).expanduser()
    if p.is_file():
        return _apply_facts(p, fps, scale, raw, _identify(p), **kw)
    if p.is_dir() and ("/" in str(name_or_path) or os.sep in str(name_or_path) or not isinstance(name_or_path, str)):
        raise DataNotFoundError(f"{p} is a directory, not a motion file")
    if not isinstance(name_or_path, str):
        raise DataNotFoundError(f"no such file: {p}")
    try:
        path = find_clip(name_or_path)
    except DataNotFoundError:
        tid = name_or_path.strip()
        if download and re.fullmatch(r"\d{1,3}_\d{1,3}", tid) and normalize_trial(tid) in CMU_REGISTRY:
            path = fetch_cmu(tid)
            return _apply_facts(path, fps, scale, raw, KnownClip(path.name, "location"), **kw)
        elif "/" in tid or os.sep in tid or tid.startswith("~"):
            root = data_dir()
            raise DataNotFoundError(f"no such file: {p}" + (f" (nor a clip of that name in {root})" if root else ""))
        else:
            raise
    return _apply_facts(path, fps, scale, raw, identify(path) or KnownClip(path.name, "location"), **kw)


# ---------------------------------------------------------------------- list
@functools.lru_cache(maxsize=8)
def _manifest_descriptions(root: str, mtime: float) -> dict[str, str]:
    """``relative path -> one-line description`` from the data directory's MANIFEST.md tables."""
    f = Path(root) / "MANIFEST.md"
    out: dict[str, str] = {}
    try:
        text = f.read_text(encoding="utf-8")
    except OSError:
        return out
    for line in text.splitlines():
        m = re.match(r"^\|\s*`([^`]+)`\s*\|[^|]*\|([^|]*)\|", line)
        if m:
            desc = m.group(2).strip()
            desc = re.split(r"(?<=[a-z0-9)])\.\s+(?=[A-Z])", desc.replace("**", ""))[0].rstrip(".")
            out[m.group(1)] = desc[:100]
    return out


def list(downloadable: bool = False):  # noqa: A001 - the documented name
    """A :class:`pandas.DataFrame` of what ``load`` can find, one row per clip.

    Columns: ``name`` (what to pass to :func:`load`), ``kind`` (``example``,
    ``real`` or ``downloadable``), ``description`` (one line), ``path`` (file,
    relative to the data directory; empty for examples), ``format``.
    Real clips appear when ``$MOCOMP_DATA_DIR`` is set, their descriptions
    taken from its MANIFEST.md; ``downloadable=True`` adds the CMU trials of
    the download registry that are not in the data directory.
    """
    import pandas as pd

    rows = [{"name": n, "kind": "example", "description": e.description, "path": "", "format": "synthetic"}
            for n, e in sorted(examples().items())]
    root = data_dir()
    have_trials = set()
    if root is not None:
        man = root / "MANIFEST.md"
        desc = _manifest_descriptions(str(root), man.stat().st_mtime if man.is_file() else 0.0)
        clips = real_clips(root)
        by_stem: dict[str, builtins.list[Path]] = {}
        by_name: dict[str, int] = {}
        for p in clips:
            by_stem.setdefault(p.stem.lower(), []).append(p)
            by_name[p.name.lower()] = by_name.get(p.name.lower(), 0) + 1
        for p in clips:
            rel = p.relative_to(root).as_posix()
            same = by_stem[p.stem.lower()]
            if _prefer(same) == [p]:
                name = p.stem  # the shortest name that find_clip resolves to this file
            elif by_name[p.name.lower()] == 1:
                name = p.name
            else:
                name = rel
            ext = p.suffix.lower()
            fmt = {".bvh": "bvh", ".amc": "asf/amc"}.get(ext, "deepmimic")
            tid = _trial_of(p.stem)
            if tid:
                have_trials.add(tid)
            d = desc.get(rel) or (f"CMU {tid}: {CMU_REGISTRY[tid].description}" if tid in CMU_REGISTRY else "")
            rows.append({"name": name, "kind": "real", "description": d,
                         "path": rel, "format": fmt})
    if downloadable:
        for tid, loc in sorted(CMU_REGISTRY.items()):
            if tid not in have_trials:
                rows.append({"name": tid, "kind": "downloadable", "description": f"CMU {tid}: {loc.description}",
                             "path": "", "format": "bvh"})
    return pd.DataFrame(rows, columns=["name", "kind", "description", "path", "format"])
