"""Stimulus-set specifications: which base motions, which perturbations, how rendered.

A specification is a TOML (or JSON) file in ``stimuli/``; ``stimuli/paper_table2.toml``
describes the flips paper's design (section 7, Table 2). Layout (all keys
except ``[[base]]`` and ``[[condition]]`` entries are optional; defaults below)::

    [study]
    name = "paper_table2"              # used in the render log
    title = "..."
    reference = "..."

    [render]
    width = 640                         # pixels (even)
    height = 480
    fps = 30                            # video frame rate (stated in the manifest)
    crf = 18                            # H.264 quality (lower = better)
    preset = "veryfast"
    poster_frame = 0                    # which video frame becomes the poster PNG
    filmstrip = false                   # also write a filmstrip PNG per stimulus
    filmstrip_poses = 7
    camera = "auto"                     # or a table {position, focal_point, view_angle}
    view_angle = 30.0                   # degrees, for camera = "auto"
    elevation = 6.0                     # degrees the auto camera looks down
    margin = 0.12                       # free border for camera = "auto"

    [clip]
    pre_s = 0.7                         # seconds shown before take-off
    post_s = 1.0                        # seconds shown after landing

    [flight]
    gravity = 9.81                      # m/s^2 of every rebuilt flight
    switch_fraction = 0.5               # abrupt errors switch on at this fraction of the flight
    contact_height = 0.05               # m, for real clips' flight detection (see stimuli.py)
    com = "capture"                     # "capture" (control = the capture) | "ballistic" (study/perturb.py)
    am_mode = "rotation"                # angular-momentum errors: "rotation" (only the orientation about L
                                        # retimed; COM, flight time, take-off and landing kept) | "retime"
                                        # (the paper's flight retiming); study/perturb.py
    base_correction = "ballistic"       # "ballistic": bases' flight COM put on a 9.81 parabola first
                                        # (study.stimuli.make_ballistic) | "none"
    max_correction_m = 0.2              # m: a base whose correction moves its COM further is refused
    takeoff_levels = "velocity"         # take-off levels mean: "velocity" (percent of the horizontal
                                        # speed) | "angle" (degrees of take-off angle, from the vertical)

    [[base]]                            # one per base motion
    id = "synthetic_backflip"
    source = "example:backflip"         # example:NAME | clip:NAME | data:RELATIVE/PATH.bvh | file:PATH.bvh
    fps = 60                            # only for files with a wrong frame-rate header
    first_frame = 1                     # drop leading frames (e.g. a T-pose)
    last_frame = -1                     # inclusive; -1 = end
    required = true                     # false: skipped (with a note) when its data are missing

    [[condition]]                       # one per perturbation type
    perturbation = "am_abrupt"          # am_abrupt | am_smooth | takeoff
    directions = ["increase", "decrease"]
    levels = [17, 25, 37, 50]           # percent (take-off with takeoff_levels = "angle": degrees)

Every base gets one unperturbed stimulus (``perturbation = "none"``) plus one
stimulus per condition x direction x level. Errors name the file and the key.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from mocomp.errors import StudyDataError

__all__ = ["StudySpec", "BaseSpec", "ConditionSpec", "RenderSettings", "load_spec", "PERTURBATION_TYPES"]

#: Perturbation types a condition may name (``none`` is implicit: one control per base).
PERTURBATION_TYPES = ("am_abrupt", "am_smooth", "takeoff")
#: Kinds of base sources (see :mod:`study.stimuli`).
SOURCE_KINDS = ("example", "clip", "data", "file")
DIRECTIONS = ("increase", "decrease")


@dataclass(frozen=True)
class BaseSpec:
    """One base motion of the study (see module docstring for the keys)."""

    id: str
    source: str
    fps: float | None = None
    first_frame: int = 0
    last_frame: int = -1
    required: bool = True
    scale: str | float | None = None


@dataclass(frozen=True)
class ConditionSpec:
    """One perturbation type with its directions and levels (percent)."""

    perturbation: str
    directions: tuple[str, ...]
    levels: tuple[float, ...]


@dataclass(frozen=True)
class RenderSettings:
    """How every stimulus is rendered (identical for all stimuli of a study)."""

    width: int = 640
    height: int = 480
    fps: float = 30.0
    crf: int = 18
    preset: str = "veryfast"
    poster_frame: int = 0
    filmstrip: bool = False
    filmstrip_poses: int = 7
    camera: str | dict = "auto"
    view_angle: float = 30.0
    elevation: float = 6.0
    margin: float = 0.12


@dataclass(frozen=True)
class StudySpec:
    """A parsed, validated stimulus-set specification."""

    path: Path | None
    name: str
    title: str
    reference: str
    render: RenderSettings
    bases: tuple[BaseSpec, ...]
    conditions: tuple[ConditionSpec, ...]
    pre_s: float = 0.7
    post_s: float = 1.0
    gravity: float = 9.81
    switch_fraction: float = 0.5
    contact_height: float = 0.05
    com_mode: str = "capture"
    am_mode: str = "rotation"
    base_correction: str = "ballistic"
    max_correction_m: float = 0.2
    takeoff_levels: str = "velocity"
    raw: dict = field(default_factory=dict, repr=False, compare=False)

    def design(self) -> list[tuple[str, str, str, float]]:
        """``(base_id, perturbation, direction, level_percent)`` for every stimulus, in order."""
        out = []
        for b in self.bases:
            out.append((b.id, "none", "none", 0.0))
            for c in self.conditions:
                for d in c.directions:
                    for lv in c.levels:
                        out.append((b.id, c.perturbation, d, float(lv)))
        return out


def _err(path, key, msg):
    return StudyDataError(msg, path, column=key)


def _get(d: dict, key: str, typ, default, path, where: str, check=None):
    if key not in d:
        return default
    v = d[key]
    name = f"{where}.{key}" if where else key
    if typ is float and isinstance(v, int) and not isinstance(v, bool):
        v = float(v)
    if typ is int and isinstance(v, float) and v.is_integer():
        v = int(v)
    if not isinstance(v, typ) or (typ in (int, float) and isinstance(v, bool)):
        tn = typ.__name__ if isinstance(typ, type) else "/".join(t.__name__ for t in typ)
        raise _err(path, name, f"must be {tn}, got {v!r}")
    if check is not None:
        msg = check(v)
        if msg:
            raise _err(path, name, msg)
    return v


def _unknown(d: dict, allowed: set, path, where: str):
    extra = sorted(set(d) - allowed)
    if extra:
        raise _err(path, where or "top level", f"unknown key(s) {', '.join(extra)}; allowed: {', '.join(sorted(allowed))}")


def parse_spec(data: dict, path: str | Path | None = None) -> StudySpec:
    """Validate a specification given as a dict (the parsed TOML/JSON)."""
    if not isinstance(data, dict):
        raise _err(path, "top level", "specification must be a table/object")
    _unknown(data, {"study", "render", "clip", "flight", "base", "condition"}, path, "")
    st = data.get("study", {})
    _unknown(st, {"name", "title", "reference"}, path, "study")
    name = _get(st, "name", str, Path(path).stem if path else "study", path, "study")
    title = _get(st, "title", str, "", path, "study")
    reference = _get(st, "reference", str, "", path, "study")

    r = data.get("render", {})
    _unknown(r, set(RenderSettings.__dataclass_fields__), path, "render")
    even = lambda v: None if (16 <= v <= 4096 and v % 2 == 0) else "must be an even number of pixels in [16, 4096]"  # noqa: E731
    pos = lambda v: None if (math.isfinite(v) and v > 0) else "must be > 0"  # noqa: E731
    cam = r.get("camera", "auto")
    if cam != "auto":
        if not isinstance(cam, dict) or not {"position", "focal_point"} <= set(cam) or \
                set(cam) - {"position", "focal_point", "view_up", "view_angle"}:
            raise _err(path, "render.camera", 'must be "auto" or a table with position, focal_point '
                                              '[, view_up, view_angle]')
    render = RenderSettings(
        width=_get(r, "width", int, 640, path, "render", even),
        height=_get(r, "height", int, 480, path, "render", even),
        fps=_get(r, "fps", float, 30.0, path, "render", pos),
        crf=_get(r, "crf", int, 18, path, "render", lambda v: None if 0 <= v <= 51 else "must be in [0, 51]"),
        preset=_get(r, "preset", str, "veryfast", path, "render"),
        poster_frame=_get(r, "poster_frame", int, 0, path, "render", lambda v: None if v >= 0 else "must be >= 0"),
        filmstrip=_get(r, "filmstrip", bool, False, path, "render"),
        filmstrip_poses=_get(r, "filmstrip_poses", int, 7, path, "render",
                             lambda v: None if 2 <= v <= 30 else "must be in [2, 30]"),
        camera=cam,
        view_angle=_get(r, "view_angle", float, 30.0, path, "render",
                        lambda v: None if 5 <= v <= 120 else "must be in [5, 120] degrees"),
        elevation=_get(r, "elevation", float, 6.0, path, "render",
                       lambda v: None if -30 <= v <= 60 else "must be in [-30, 60] degrees"),
        margin=_get(r, "margin", float, 0.12, path, "render", lambda v: None if 0 <= v < 0.9 else "must be in [0, 0.9)"),
    )
    c = data.get("clip", {})
    _unknown(c, {"pre_s", "post_s"}, path, "clip")
    nonneg = lambda v: None if (math.isfinite(v) and v >= 0) else "must be >= 0"  # noqa: E731
    pre_s = _get(c, "pre_s", float, 0.7, path, "clip", nonneg)
    post_s = _get(c, "post_s", float, 1.0, path, "clip", nonneg)
    f = data.get("flight", {})
    _unknown(f, {"gravity", "switch_fraction", "contact_height", "com", "am_mode", "base_correction",
                 "max_correction_m", "takeoff_levels"}, path, "flight")
    gravity = _get(f, "gravity", float, 9.81, path, "flight", pos)
    switch = _get(f, "switch_fraction", float, 0.5, path, "flight",
                  lambda v: None if 0.05 <= v <= 0.95 else "must be in [0.05, 0.95]")
    contact_h = _get(f, "contact_height", float, 0.05, path, "flight", pos)
    com_mode = _get(f, "com", str, "capture", path, "flight",
                    lambda v: None if v in ("capture", "ballistic") else 'must be "capture" or "ballistic"')
    am_mode = _get(f, "am_mode", str, "rotation", path, "flight",
                   lambda v: None if v in ("rotation", "retime") else 'must be "rotation" or "retime"')
    base_corr = _get(f, "base_correction", str, "ballistic", path, "flight",
                     lambda v: None if v in ("ballistic", "none") else 'must be "ballistic" or "none"')
    max_corr = _get(f, "max_correction_m", float, 0.2, path, "flight", pos)
    to_levels = _get(f, "takeoff_levels", str, "velocity", path, "flight",
                     lambda v: None if v in ("velocity", "angle") else 'must be "velocity" or "angle"')

    bases_raw = data.get("base")
    if not isinstance(bases_raw, list) or not bases_raw:
        raise _err(path, "base", "needs at least one [[base]] entry")
    bases = []
    seen = set()
    for i, b in enumerate(bases_raw):
        w = f"base[{i}]"
        if not isinstance(b, dict):
            raise _err(path, w, "must be a table")
        _unknown(b, set(BaseSpec.__dataclass_fields__), path, w)
        if "id" not in b or "source" not in b:
            raise _err(path, w, "needs id and source")
        bid = _get(b, "id", str, None, path, w, lambda v: None if v and all(ch.isalnum() or ch in "-_" for ch in v)
                   and "__" not in v else "must be non-empty letters, digits, '-' or '_' (no '__')")
        if bid in seen:
            raise _err(path, f"{w}.id", f"duplicate base id {bid!r}")
        seen.add(bid)
        src = _get(b, "source", str, None, path, w, lambda v: None if v.split(":", 1)[0] in SOURCE_KINDS
                   and v.split(":", 1)[1:] not in ([], [""]) else
                   f'must be KIND:NAME with KIND one of {", ".join(SOURCE_KINDS)}')
        scale = b.get("scale")
        if scale is not None and not isinstance(scale, (str, int, float)):
            raise _err(path, f"{w}.scale", f"must be a unit name or a number, got {scale!r}")
        bases.append(BaseSpec(
            id=bid, source=src, fps=_get(b, "fps", float, None, path, w, pos),
            first_frame=_get(b, "first_frame", int, 0, path, w, lambda v: None if v >= 0 else "must be >= 0"),
            last_frame=_get(b, "last_frame", int, -1, path, w),
            required=_get(b, "required", bool, True, path, w), scale=scale))
    conds_raw = data.get("condition", [])
    if not isinstance(conds_raw, list):
        raise _err(path, "condition", "must be a list of [[condition]] tables")
    conds = []
    seen_c = set()
    for i, cd in enumerate(conds_raw):
        w = f"condition[{i}]"
        if not isinstance(cd, dict):
            raise _err(path, w, "must be a table")
        _unknown(cd, {"perturbation", "directions", "levels"}, path, w)
        p = cd.get("perturbation")
        if p not in PERTURBATION_TYPES:
            raise _err(path, f"{w}.perturbation", f"must be one of {', '.join(PERTURBATION_TYPES)}, got {p!r}")
        if p in seen_c:
            raise _err(path, f"{w}.perturbation", f"{p} listed twice; put all its levels in one [[condition]]")
        seen_c.add(p)
        dirs = cd.get("directions", ["increase"])
        if not isinstance(dirs, list) or not dirs or any(d not in DIRECTIONS for d in dirs) or len(set(dirs)) != len(dirs):
            raise _err(path, f"{w}.directions", f"must be a non-empty list of distinct {DIRECTIONS}, got {dirs!r}")
        lv = cd.get("levels")
        if not isinstance(lv, list) or not lv or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in lv):
            raise _err(path, f"{w}.levels", f"must be a non-empty list of numbers (percent), got {lv!r}")
        hi = 95.0 if p != "takeoff" else (300.0 if to_levels == "velocity" else 45.0)
        unit = "degrees" if (p == "takeoff" and to_levels == "angle") else "percent"
        bad = [x for x in lv if not (0 < x <= hi)]
        if bad:
            raise _err(path, f"{w}.levels", f"levels are {unit} in (0, {hi:g}], got {bad}")
        if "decrease" in dirs and p == "takeoff" and to_levels == "velocity" and max(lv) >= 100:
            raise _err(path, f"{w}.levels", "a take-off decrease of 100% or more reverses the jump direction")
        if len(set(lv)) != len(lv):
            raise _err(path, f"{w}.levels", f"duplicate levels in {lv}")
        conds.append(ConditionSpec(p, tuple(dirs), tuple(float(x) for x in lv)))
    return StudySpec(path=None if path is None else Path(path), name=name, title=title, reference=reference,
                     render=render, bases=tuple(bases), conditions=tuple(conds), pre_s=pre_s, post_s=post_s,
                     gravity=gravity, switch_fraction=switch, contact_height=contact_h, com_mode=com_mode,
                     am_mode=am_mode, base_correction=base_corr, max_correction_m=max_corr,
                     takeoff_levels=to_levels, raw=data)


def load_spec(path: str | Path) -> StudySpec:
    """Read and validate a ``.toml`` or ``.json`` specification."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"stimulus specification not found: {path}")
    text = path.read_text(encoding="utf-8")
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise StudyDataError(f"invalid JSON: {e.msg}", path, line=e.lineno) from None
    elif path.suffix.lower() == ".toml":
        try:
            import tomllib
        except ModuleNotFoundError:  # Python 3.10
            try:
                import tomli as tomllib  # type: ignore[no-redef]
            except ModuleNotFoundError:
                raise StudyDataError("reading TOML needs Python >= 3.11 (or the tomli package); "
                                     "or write the specification as JSON", path) from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise StudyDataError(f"invalid TOML: {e}", path) from None
    else:
        raise StudyDataError(f"unknown specification format {path.suffix!r} (use .toml or .json)", path)
    return parse_spec(data, path)
