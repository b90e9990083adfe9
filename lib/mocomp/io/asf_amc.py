"""Acclaim ASF (skeleton) / AMC (motion) reading, as written by Vicon for the
CMU and HDM05 databases.

Conventions (Acclaim ASF v1.10 definition, M. Schafer 1995; CMU's "Acclaim
format - ASF line details" note for Vicon BodyBuilder output):

* ``:units``: ``length L`` means one file unit is ``1/L`` inch, so lengths are
  converted to metres with ``0.0254 / L`` (CMU and HDM05: ``length 0.45`` ->
  0.056444 m per unit); ``angle deg|rad`` is the unit of ASF axis angles, limits
  and (unless the AMC says ``:DEGREES``/``:RADIANS``) of the AMC values.
* Every bone has a ``direction`` (unit vector, global rest frame) and a
  ``length``: it runs from the end of its parent (or the root) to
  ``start + length * direction``. All rest frames are aligned with the world.
* ``axis a b c XYZ``: the bone's local frame ``C`` is the rotation by the three
  angles about fixed (global) axes in the order given, i.e.
  ``C = Rotation.from_euler("xyz", (a, b, c))`` (lower case = extrinsic in scipy).
* ``dof rx ry rz``: the AMC values of the bone in this order; the motion
  rotation ``M`` applies them about the bone's local axes in the listed order
  (first listed first, about fixed axes of the frame ``C``), ``M = ...R2 R1``.
  The bone's rotation relative to its parent, in the world-aligned rest frame,
  is ``L = C M C^-1`` and the global rotation ``G = G_parent L``.
* Root: ``order TX TY TZ RX RY RZ`` gives the order of the root values in the
  AMC and, for rotations, the order of application about fixed global axes;
  ``position`` and ``orientation`` (composed in ``axis`` order) pre-set the
  root: ``P_root = position + T`` and ``G_root = O M`` (the whole motion is
  offset; CMU and HDM05 set both to zero, which is the case tested on data).

Mapping to :class:`~mocomp.core.Skeleton`: a joint sits at the *start* of each
bone and carries that bone's rotation ``L``; its offset is the parent bone's
vector (children of the root have offset 0); bones without children end in an
:class:`~mocomp.core.skeleton.EndSite` at their tip. Joints are ordered
depth-first as in the ``:hierarchy`` section, which reproduces the joint order
of the CMU BVH conversions.

Checked against B. Hahne's cgspeed BVH of the same CMU take (``01_01``; the BVH
has an extra T-pose first frame): all 31 global joint rotations agree within
0.0003 deg and the root within 0.003 mm; joint positions agree within 0.005 mm
up to the thorax. The BVH drops the length of the bones that have several
children (``thorax`` 116.5 mm, ``lwrist``/``rwrist`` ~98 mm): its Neck,
shoulders, thumbs and finger bases sit at the *start* of those bones, so its
upper body is shorter. With the ASF offsets put back, every BVH joint and end
site matches within 0.005 mm. Flight phases of ``01_01.amc`` at 120 Hz with
``0.0254/0.45`` m per unit give g = 9.4 m/s^2 (median over the hops).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.motion import Motion, SourceInfo
from ..core.rotations import quat_inverse, quat_multiply
from ..core.skeleton import EndSite, Skeleton
from ..errors import MotionFormatError
from .bvh import _euler_columns_to_quat
from .units import check_height, resolve_scale, standing_height
from .validate import MAX_ANGLE_DEG, MAX_JOINTS, MAX_LENGTH_M, check_counts, check_fps, check_motion

__all__ = ["Asf", "AsfBone", "read_asf", "parse_asf", "read_amc", "parse_amc", "find_asf", "DEFAULT_AMC_FPS"]

#: AMC files state no frame rate; CMU and HDM05 captured at 120 Hz (but see the
#: data MANIFEST: some CMU subjects are really 60 Hz - pass ``fps=``).
DEFAULT_AMC_FPS = 120.0

_ROOT_TOKENS = ("TX", "TY", "TZ", "RX", "RY", "RZ")
_DOF_TOKENS = ("rx", "ry", "rz", "tx", "ty", "tz", "l")
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
_JOINT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")


@dataclass(frozen=True, eq=False)
class AsfBone:
    """One ``begin ... end`` block of an ASF ``:bonedata`` section (file units).

    Attributes
    ----------
    name: bone name.
    id: the ``id`` field (``None`` if absent).
    direction: ``(3,)`` unit vector, global rest frame.
    length: length in file length units.
    axis: ``(3,)`` local-frame angles in the file's angle unit.
    axis_order: order of ``axis`` rotations about fixed axes, e.g. ``"XYZ"``.
    dof: degrees of freedom in AMC value order, e.g. ``("rx", "ry", "rz")``.
    limits: ``(len(dof), 2)`` lower/upper limit per dof in file units
        (angles in the file's angle unit), ``+-inf`` allowed; ``None`` if absent.
    line: line of ``begin`` in the ASF file.
    """

    name: str
    id: int | None
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str
    dof: tuple[str, ...]
    limits: np.ndarray | None
    line: int


@dataclass(frozen=True, eq=False)
class Asf:
    """A parsed ASF skeleton file (values as in the file; see :meth:`skeleton`).

    Attributes
    ----------
    path: the file, if read from one.
    name: ``:name``.
    units: the ``:units`` block, e.g. ``{"mass": 1.0, "length": 0.45, "angle": "deg"}``.
    root_order: root value order in the AMC, e.g. ``("TX", "TY", "TZ", "RX", "RY", "RZ")``.
    root_axis: order of the root pre-set ``orientation``, e.g. ``"XYZ"``.
    root_position, root_orientation: ``(3,)`` pre-sets (file length / angle units).
    bones: the bones in file order.
    children: ``{parent: (child, ...)}`` from ``:hierarchy`` (``"root"`` is the root).
    order: joint order used for the skeleton: ``("root", ...)`` depth-first.
    """

    path: str | None
    name: str
    units: dict
    root_order: tuple[str, ...]
    root_axis: str
    root_position: np.ndarray
    root_orientation: np.ndarray
    bones: tuple[AsfBone, ...]
    children: dict
    order: tuple[str, ...]

    # ------------------------------------------------------------------ facts
    @property
    def angle_unit(self) -> str:
        return self.units.get("angle", "deg")

    @property
    def length_scale(self) -> float:
        """Metres per file length unit by the CMU/Vicon convention: ``0.0254 / length``."""
        return 0.0254 / float(self.units.get("length", 1.0))

    def bone(self, name: str) -> AsfBone:
        for b in self.bones:
            if b.name == name:
                return b
        raise KeyError(f"no bone {name!r} in {self.path or 'ASF'}; bones: {[b.name for b in self.bones]}")

    @property
    def limits(self) -> dict:
        """``{bone: {dof: (lo, hi)}}`` in SI units (radians, metres) for bones with limits."""
        out = {}
        to_rad = math.pi / 180.0 if self.angle_unit == "deg" else 1.0
        for b in self.bones:
            if b.limits is None:
                continue
            d = {}
            for k, dof in enumerate(b.dof):
                f = to_rad if dof.startswith("r") else self.length_scale
                d[dof] = (float(b.limits[k, 0]) * f, float(b.limits[k, 1]) * f)
            out[b.name] = d
        return out

    def _angle(self, a):
        return np.deg2rad(a) if self.angle_unit == "deg" else np.asarray(a, dtype=float)

    def local_frames(self) -> dict:
        """``{bone: C}`` the bone frames as scalar-last quaternions (``axis`` field)."""
        return {b.name: Rotation.from_euler(b.axis_order.lower(), self._angle(b.axis)).as_quat() for b in self.bones}

    def skeleton(self, scale: float | None = None) -> Skeleton:
        """The rest skeleton in metres (``scale`` metres per file unit; default :attr:`length_scale`)."""
        s = self.length_scale if scale is None else float(scale)
        by = {b.name: b for b in self.bones}
        parent = {c: p for p, cs in self.children.items() for c in cs}
        names = list(self.order)
        idx = {n: i for i, n in enumerate(names)}
        parents = [-1] + [idx[parent[n]] for n in names[1:]]
        offsets = np.zeros((len(names), 3))
        offsets[0] = self.root_position * s
        for i, n in enumerate(names[1:], 1):
            p = parent[n]
            if p != "root":
                offsets[i] = by[p].direction * by[p].length * s
        ends = tuple(EndSite(idx[n], by[n].direction * by[n].length * s, f"{n}_end")
                     for n in names[1:] if not self.children.get(n))
        channels = tuple(_ROOT_CHANNELS if i == 0 else _JOINT_CHANNELS for i in range(len(names)))
        return Skeleton(tuple(names), np.array(parents), offsets, channels, ends)


# ---------------------------------------------------------------------------- ASF
#: longest line accepted in an ASF/AMC file (real lines are < 200 characters)
MAX_LINE_BYTES = 1 << 16


def _file_lines(path: Path):
    """The lines of a file, as ``str.splitlines`` of the decoded text would give them
    (LF, CRLF, CR, ...), read one at a time so that a 200 MB file of junk is refused at
    its first line instead of being decoded and split whole. Read in 1 MB blocks cut at
    line ends; each block is UTF-8, or latin-1 where it is not (HDM05 headers have
    German umlauts). A line longer than :data:`MAX_LINE_BYTES` raises MotionFormatError."""
    try:
        f = open(path, "rb")  # opened now, so that a missing file is reported before anything else
    except OSError as e:
        raise MotionFormatError(f"cannot read file: {e.strerror}", path) from None
    return itertools.chain.from_iterable(_line_blocks(f, path))


def _line_blocks(f, path, block: int = 1 << 20):
    """Lists of the lines of the open binary file ``f``, read in blocks of ``block`` bytes
    cut at line ends."""
    with f:
        ln = 0
        buf = b""
        while True:
            try:
                chunk = f.read(block)
            except OSError as e:
                raise MotionFormatError(f"cannot read file: {e.strerror}", path) from None
            buf += chunk
            if chunk:
                cut = max(buf.rfind(b"\n"), buf.rfind(b"\r"))
                if cut == len(buf) - 1 and buf[cut] == 13:  # a CR that may be the first half of CRLF
                    cut = max(buf.rfind(b"\n", 0, cut), buf.rfind(b"\r", 0, cut))
                if cut < 0:
                    if len(buf) > MAX_LINE_BYTES:
                        raise MotionFormatError(f"line {ln + 1} is longer than {MAX_LINE_BYTES} bytes (not an "
                                                "ASF/AMC file?)", path, ln + 1)
                    continue
                part, buf = buf[:cut + 1], buf[cut + 1:]
            else:
                part, buf = buf, b""
            if not part:
                return
            try:
                text = part.decode("utf-8")
            except UnicodeDecodeError:
                text = part.decode("latin-1")
            lines = text.splitlines()
            if lines and max(map(len, lines)) > MAX_LINE_BYTES:
                k = next(k for k, line in enumerate(lines) if len(line) > MAX_LINE_BYTES)
                raise MotionFormatError(f"line {ln + k + 1} is longer than {MAX_LINE_BYTES} characters (not an "
                                        "ASF/AMC file?)", path, ln + k + 1)
            ln += len(lines)
            yield lines
            if len(buf) > MAX_LINE_BYTES:
                raise MotionFormatError(f"line {ln + 1} is longer than {MAX_LINE_BYTES} bytes (not an ASF/AMC "
                                        "file?)", path, ln + 1)


def read_asf(path) -> Asf:
    """Read an ASF skeleton file (see the module docstring for conventions)."""
    path = Path(path)
    return _parse_asf_lines(_file_lines(path), str(path))


def _float(tok: str, path, line: int, what: str, allow_inf: bool = False) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise MotionFormatError(f"{what}: {tok!r} is not a number", path, line) from None
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise MotionFormatError(f"{what}: {tok!r} is not a finite number", path, line)
    return v


def _floats(toks, n: int, path, line: int, what: str) -> np.ndarray:
    if len(toks) != n:
        raise MotionFormatError(f"{what} needs {n} numbers, got {len(toks)}", path, line)
    return np.array([_float(t, path, line, what) for t in toks])


def _axis_order(tok: str, path, line: int, what: str) -> str:
    o = tok.upper()
    if sorted(o) != ["X", "Y", "Z"]:
        raise MotionFormatError(f"{what} order {tok!r} is not a permutation of XYZ", path, line)
    return o


def parse_asf(text: str, path: str | None = None) -> Asf:
    """Parse ASF text (see :func:`read_asf`)."""
    return _parse_asf_lines(text.splitlines(), path)


def _parse_asf_lines(lines, path) -> Asf:
    section = None
    units: dict = {}
    name = ""
    root: dict = {}
    bones: list[AsfBone] = []
    cur: dict | None = None
    children: dict[str, tuple[str, ...]] = {}
    child_line: dict[str, int] = {}
    in_hier = False
    pending_limits = 0
    n_lines = 0

    def finish_bone(ln: int):
        nonlocal cur
        b = cur
        if "name" not in b:
            raise MotionFormatError("bone block without a name", path, b["line"])
        for key in ("direction", "length"):
            if key not in b:
                raise MotionFormatError(f"bone {b['name']!r} has no {key}", path, b["line"])
        d = b["direction"]
        nd = float(np.linalg.norm(d))
        if nd == 0.0:
            if b["length"] != 0.0:
                raise MotionFormatError(f"bone {b['name']!r} has a zero direction but length {b['length']}",
                                        path, b["line"])
        else:
            d = d / nd
        dof = b.get("dof", ())
        lim = b.get("limits")
        if lim is not None and len(lim) != len(dof):
            raise MotionFormatError(f"bone {b['name']!r} has {len(dof)} dofs but {len(lim)} limit pairs", path, ln)
        if any(x.name == b["name"] for x in bones):
            raise MotionFormatError(f"duplicate bone name {b['name']!r}", path, b["line"])
        if b["name"] == "root":
            raise MotionFormatError("a bone may not be called 'root' (reserved for the root)", path, b["line"])
        bones.append(AsfBone(
            name=b["name"], id=b.get("id"), direction=d, length=b["length"],
            axis=b.get("axis", np.zeros(3)), axis_order=b.get("axis_order", "XYZ"), dof=tuple(dof),
            limits=None if lim is None else np.array(lim, dtype=float).reshape(-1, 2), line=b["line"]))
        cur = None

    for ln, raw in enumerate(lines, 1):
        n_lines = ln
        line = raw.split("#", 1)[0]
        toks = line.replace(",", " ").replace("(", " ").replace(")", " ").split()
        if not toks:
            continue
        key = toks[0]
        if key.startswith(":"):
            if cur is not None:
                raise MotionFormatError(f"bone block opened at line {cur['line']} has no 'end'", path, ln)
            if pending_limits:
                raise MotionFormatError("limits list ended early", path, ln)
            section = key.lower()
            if section == ":name":
                name = " ".join(toks[1:])
            elif section == ":hierarchy":
                in_hier = False
            elif section not in (":version", ":units", ":documentation", ":root", ":bonedata", ":skin"):
                raise MotionFormatError(f"unknown ASF section {key!r}", path, ln)
            continue
        if section is None:
            raise MotionFormatError(f"text before the first ':' section: {line.strip()[:40]!r}", path, ln)
        if section in (":documentation", ":skin", ":version", ":name"):
            continue
        low = key.lower()
        if section == ":units":
            if len(toks) != 2:
                raise MotionFormatError(f"units line needs a name and a value, got {line.strip()!r}", path, ln)
            if low == "angle":
                if toks[1].lower() not in ("deg", "rad"):
                    raise MotionFormatError(f"angle unit must be 'deg' or 'rad', got {toks[1]!r}", path, ln)
                units["angle"] = toks[1].lower()
            else:
                v = _float(toks[1], path, ln, f"units {key}")
                if v <= 0:
                    raise MotionFormatError(f"units {key} must be positive, got {v}", path, ln)
                units[low] = v
        elif section == ":root":
            if low == "order":
                order = tuple(t.upper() for t in toks[1:])
                bad = [t for t in order if t not in _ROOT_TOKENS]
                if bad or len(set(order)) != len(order):
                    raise MotionFormatError(f"root order {toks[1:]} must list distinct tokens from {_ROOT_TOKENS}",
                                            path, ln)
                root["order"] = order
            elif low == "axis":
                if len(toks) != 2:
                    raise MotionFormatError("root axis needs one token such as XYZ", path, ln)
                root["axis"] = _axis_order(toks[1], path, ln, "root axis")
            elif low in ("position", "orientation"):
                root[low] = _floats(toks[1:], 3, path, ln, f"root {low}")
            else:
                raise MotionFormatError(f"unknown root field {key!r}", path, ln)
        elif section == ":bonedata":
            if pending_limits and (not low.isalpha() or low in ("inf", "infinity")):  # a "(lo hi)" line
                vals = [_float(t, path, ln, "limits", allow_inf=True) for t in toks]
                if len(vals) != 2:
                    raise MotionFormatError(f"a limits line needs 2 numbers (lo hi), got {len(vals)}", path, ln)
                cur["limits"].append(vals)
                pending_limits -= 1
                continue
            if pending_limits:
                raise MotionFormatError(f"bone {cur.get('name')!r}: {pending_limits} limit pair(s) missing", path, ln)
            if low == "begin":
                if cur is not None:
                    raise MotionFormatError(f"'begin' inside the bone block opened at line {cur['line']}", path, ln)
                cur = {"line": ln}
                continue
            if cur is None:
                raise MotionFormatError(f"{key!r} outside a begin/end bone block", path, ln)
            if low == "end":
                finish_bone(ln)
            elif low == "id":
                try:
                    cur["id"] = int(toks[1])
                except (IndexError, ValueError):
                    raise MotionFormatError("bone id must be a whole number", path, ln) from None
            elif low == "name":
                if len(toks) != 2:
                    raise MotionFormatError("bone name must be one word", path, ln)
                cur["name"] = toks[1]
            elif low == "direction":
                cur["direction"] = _floats(toks[1:], 3, path, ln, "direction")
            elif low == "length":
                cur["length"] = float(_floats(toks[1:], 1, path, ln, "length")[0])
                if cur["length"] < 0:
                    raise MotionFormatError(f"negative bone length {cur['length']}", path, ln)
            elif low == "axis":
                if len(toks) != 5:
                    raise MotionFormatError("axis needs 3 angles and an order such as XYZ", path, ln)
                cur["axis"] = _floats(toks[1:4], 3, path, ln, "axis")
                cur["axis_order"] = _axis_order(toks[4], path, ln, "axis")
            elif low == "dof":
                dof = tuple(t.lower() for t in toks[1:])
                bad = [t for t in dof if t not in _DOF_TOKENS]
                if bad or len(set(dof)) != len(dof) or not dof:
                    raise MotionFormatError(f"dof {toks[1:]} must list distinct tokens from {_DOF_TOKENS}", path, ln)
                cur["dof"] = dof
            elif low == "limits":
                if "dof" not in cur:
                    raise MotionFormatError("limits before dof", path, ln)
                cur["limits"] = []
                pending_limits = len(cur["dof"])
                rest = toks[1:]
                if rest:
                    vals = [_float(t, path, ln, "limits", allow_inf=True) for t in rest]
                    if len(vals) != 2:
                        raise MotionFormatError(f"a limits line needs 2 numbers (lo hi), got {len(vals)}", path, ln)
                    cur["limits"].append(vals)
                    pending_limits -= 1
            elif low in ("bodymass", "cofmass"):
                cur[low] = _float(toks[1], path, ln, low) if len(toks) > 1 else None
            else:
                raise MotionFormatError(f"unknown bone field {key!r}", path, ln)
        elif section == ":hierarchy":
            if low == "begin":
                in_hier = True
                continue
            if low == "end":
                in_hier = False
                continue
            if not in_hier:
                raise MotionFormatError("hierarchy line outside begin/end", path, ln)
            if len(toks) < 2:
                raise MotionFormatError(f"hierarchy line names a parent but no children: {key!r}", path, ln)
            if key in children:
                raise MotionFormatError(f"{key!r} has a second hierarchy line", path, ln)
            for c in toks[1:]:
                if c in child_line:
                    raise MotionFormatError(f"bone {c!r} has two parents (also on line {child_line[c]})", path, ln)
                child_line[c] = ln
            children[key] = tuple(toks[1:])
    if cur is not None:
        raise MotionFormatError(f"bone block opened at line {cur['line']} has no 'end' (file truncated?)", path, n_lines)
    if pending_limits:
        raise MotionFormatError("limits list ended early (file truncated?)", path, n_lines)
    if not bones:
        raise MotionFormatError("no :bonedata bones (file truncated or not an ASF file?)", path, n_lines)
    if len(bones) + 1 > MAX_JOINTS:
        raise MotionFormatError(f"{len(bones)} bones (more than the {MAX_JOINTS - 1} accepted)", path,
                                bones[MAX_JOINTS - 1].line)
    if not children:
        raise MotionFormatError("no :hierarchy section (file truncated?)", path, n_lines)
    known = {b.name for b in bones} | {"root"}
    for p, cs in children.items():
        for n in (p, *cs):
            if n not in known:
                ln = child_line.get(n) if n in cs else None
                raise MotionFormatError(f"hierarchy names bone {n!r}, which :bonedata does not define", path, ln)
    if "root" in child_line:
        raise MotionFormatError("the root cannot be a child", path, child_line["root"])
    order = ["root"]
    stack = list(reversed(children.get("root", ())))
    while stack:
        n = stack.pop()
        order.append(n)
        stack.extend(reversed(children.get(n, ())))
        if len(order) > len(known):
            raise MotionFormatError("hierarchy has a cycle", path, child_line.get(n))
    missing = [b.name for b in bones if b.name not in order]
    if missing:
        raise MotionFormatError(f"bones {missing} are not connected to the root in :hierarchy", path,
                                next(b.line for b in bones if b.name == missing[0]))
    return Asf(
        path=path, name=name, units=units,
        root_order=root.get("order", _ROOT_TOKENS), root_axis=root.get("axis", "XYZ"),
        root_position=root.get("position", np.zeros(3)), root_orientation=root.get("orientation", np.zeros(3)),
        bones=tuple(bones), children=children, order=tuple(order),
    )


# ---------------------------------------------------------------------------- AMC
def find_asf(amc_path) -> Path:
    """The ASF skeleton for an AMC file in the same folder.

    Tried in turn: same stem (``01_01.asf``), then the stem cut at each ``_``
    from the right (``01_01`` -> ``01``; ``HDM_dg_06-03_03_120`` -> ... ->
    ``HDM_dg``), then the only ``.asf`` in the folder. Raises
    :class:`MotionFormatError` listing what was tried.
    """
    amc = Path(amc_path)
    parts = amc.stem.split("_")
    tried = []
    for k in range(len(parts), 0, -1):
        for ext in (".asf", ".ASF"):
            cand = amc.with_name("_".join(parts[:k]) + ext)
            tried.append(cand.name)
            if cand.is_file():
                return cand
    asfs = sorted(p for p in amc.parent.glob("*") if p.suffix.lower() == ".asf")
    if len(asfs) == 1:
        return asfs[0]
    raise MotionFormatError(
        f"no ASF skeleton found for this AMC (tried {sorted(set(tried))} and a single .asf in the folder; "
        f"found {[p.name for p in asfs]}); pass asf=...", amc)


def read_amc(path, asf=None, scale=None, fps: float | None = None, height_check: bool = True) -> Motion:
    """Read an AMC motion with its ASF skeleton into a :class:`Motion` in metres.

    Parameters
    ----------
    path: the ``.amc`` file.
    asf: an :class:`Asf`, a path to the ``.asf`` file, or ``None`` to look for it
        beside the AMC (:func:`find_asf`).
    scale: metres per file length unit (number), a unit name (``"cmu"``,
        ``"inch"``, ...), ``"auto"`` (guess from height) or ``None``: the ASF
        units block (``0.0254 / length``; 0.056444 for CMU/HDM05).
    fps: frame rate; AMC files state none, default :data:`DEFAULT_AMC_FPS`.
    height_check: warn (:class:`~mocomp.io.UnitWarning`) if the standing height is outside 1.2-2.2 m.
    """
    path = Path(path)
    lines = _file_lines(path)
    if asf is None:
        asf = find_asf(path)
    if not isinstance(asf, Asf):
        asf = read_asf(asf)
    return _parse_amc_lines(lines, asf, str(path), scale, fps, height_check)


def _dof_columns(dofs: tuple[str, ...]):
    """(rotation axes in dof order e.g. "xz", their columns, translation columns by axis, l column)."""
    rot_axes = "".join(d[1] for d in dofs if d.startswith("r"))
    rot_cols = [k for k, d in enumerate(dofs) if d.startswith("r")]
    trans = {d[1]: k for k, d in enumerate(dofs) if d.startswith("t")}
    lcol = dofs.index("l") if "l" in dofs else None
    return rot_axes, rot_cols, trans, lcol


def _extrinsic_quats(axes: str, angles_rad: list[np.ndarray], T: int) -> np.ndarray:
    """``(T, 4)`` rotations applying ``angles`` about fixed axes in order ``axes``
    (``R = R_n ... R_1``) = intrinsic ``axes[::-1]`` with the angles reversed."""
    out = np.empty((T, 1, 4))
    if not axes:
        out[:, 0] = (0.0, 0.0, 0.0, 1.0)
        return out[:, 0]
    deg = [np.rad2deg(a)[:, None] for a in angles_rad[::-1]]
    _euler_columns_to_quat(axes[::-1].upper(), deg, out, [0])
    return out[:, 0]


def parse_amc(text: str, asf: Asf, path: str | None = None, scale=None, fps: float | None = None,
              height_check: bool = True) -> Motion:
    """Parse AMC text against a parsed :class:`Asf` (see :func:`read_amc`)."""
    return _parse_amc_lines(text.splitlines(), asf, path, scale, fps, height_check)


def _parse_amc_lines(lines, asf: Asf, path, scale, fps, height_check) -> Motion:
    dof_of = {b.name: b.dof for b in asf.bones}
    dof_of["root"] = tuple(t.lower() for t in asf.root_order)
    expected = {n: len(d) for n, d in dof_of.items()}
    vals: dict[str, list[str]] = {n: [] for n in dof_of}
    lines_of: dict[str, list[int]] = {n: [] for n in dof_of}
    last: dict[str, int] = {n: -1 for n in dof_of}
    frame_lines: list[int] = []
    frame_no: int | None = None
    angle = None
    fi = -1
    n_lines = 0
    for ln, raw in enumerate(lines, 1):
        n_lines = ln
        toks = raw.split("#", 1)[0].split() if "#" in raw else raw.split()
        if not toks:
            continue
        key = toks[0]
        if key[0] == ":":
            if fi >= 0:
                raise MotionFormatError(f"header keyword {key!r} after the first frame", path, ln)
            k = key.upper()
            if k == ":DEGREES":
                angle = "deg"
            elif k == ":RADIANS":
                angle = "rad"
            continue  # :FULLY-SPECIFIED and others carry no data
        if len(toks) == 1 and key.isascii() and key.isdigit():  # not '²' or '٣' (str.isdigit accepts them)
            n = int(key)
            if frame_no is not None and n != frame_no + 1:
                raise MotionFormatError(f"frame number {n} follows frame {frame_no} (frames must be consecutive)",
                                        path, ln)
            frame_no = n
            fi += 1
            frame_lines.append(ln)
            continue
        if fi < 0:
            raise MotionFormatError(f"data before the first frame number: {raw.strip()[:40]!r}", path, ln)
        if key not in expected:
            raise MotionFormatError(f"bone {key!r} is not in the skeleton {asf.path or '(ASF)'}", path, ln)
        if len(toks) - 1 != expected[key]:
            raise MotionFormatError(
                f"bone {key!r} has {len(toks) - 1} values, its ASF dofs {dof_of[key]} need {expected[key]}", path, ln)
        if last[key] == fi:
            raise MotionFormatError(f"bone {key!r} appears twice in frame {frame_no}", path, ln)
        if last[key] != fi - 1:
            raise MotionFormatError(f"bone {key!r} is missing from frame {frame_no - 1}", path, frame_lines[-2])
        last[key] = fi
        vals[key].extend(toks[1:])
        lines_of[key].append(ln)
    T = fi + 1
    if T <= 0:
        raise MotionFormatError("no frames (an AMC file needs frame numbers followed by bone lines)", path,
                                n_lines or None)
    for n, d in dof_of.items():
        if d and last[n] != T - 1:
            f = last[n] + 1  # first frame where the bone is missing (earlier gaps were caught above)
            hint = " (file truncated?)" if f == T - 1 else ""
            raise MotionFormatError(f"bone {n!r} is missing from frame {frame_no - (T - 1) + f}{hint}", path,
                                    frame_lines[f])
    # ---- numbers
    data: dict[str, np.ndarray] = {}
    for n, d in dof_of.items():
        if not d:
            continue
        try:
            a = np.array(vals[n], dtype=float).reshape(T, len(d))
        except ValueError:
            for r, ln in enumerate(lines_of[n]):
                for t in vals[n][r * len(d):(r + 1) * len(d)]:
                    try:
                        float(t)
                    except ValueError:
                        raise MotionFormatError(f"bone {n!r}: value {t!r} is not a number", path, ln) from None
            raise MotionFormatError(f"bone {n!r}: values could not be read as numbers", path, lines_of[n][0])
        if not np.all(np.isfinite(a)):
            r, c = np.argwhere(~np.isfinite(a))[0]
            raise MotionFormatError(f"bone {n!r} dof {d[c]}: value {a[r, c]} is not finite", path, lines_of[n][r])
        data[n] = a
    angle = angle or asf.angle_unit
    to_rad = (math.pi / 180.0) if angle == "deg" else 1.0
    check_counts(T, len(dof_of), path, frame_lines[-1])
    for n, a in data.items():  # rotation values: a corrupt 1e308 is not an angle
        rc = [k for k, d in enumerate(dof_of[n]) if d.startswith("r")]
        if rc and np.abs(a[:, rc]).max() * to_rad > MAX_ANGLE_DEG * math.pi / 180.0:
            r, c = (int(i) for i in np.argwhere(np.abs(a[:, rc]) * to_rad > MAX_ANGLE_DEG * math.pi / 180.0)[0])
            raise MotionFormatError(f"bone {n!r} dof {dof_of[n][rc[c]]}: angle {a[r, rc[c]]:.6g} {angle} is beyond the "
                                    f"accepted +-{MAX_ANGLE_DEG:g} degrees", path, lines_of[n][r])

    # ---- kinematics
    sk_file = asf.skeleton(scale=1.0)
    names = sk_file.names
    J = len(names)
    rots = np.empty((T, J, 4))
    notes = []
    C = asf.local_frames()
    for j, n in enumerate(names):
        d = dof_of[n]
        rot_axes, rot_cols, trans, lcol = _dof_columns(d)
        a = data.get(n)
        if (trans and n != "root") or lcol is not None:
            cols = list(trans.values()) + ([lcol] if lcol is not None else [])
            if np.any(a[:, cols] != 0.0):
                bone = asf.bone(n)
                raise MotionFormatError(
                    f"bone {n!r} has non-zero translation/length dofs; only rotations are supported below the root",
                    asf.path, bone.line)
        M = _extrinsic_quats(rot_axes, [a[:, c] * to_rad for c in rot_cols] if rot_cols else [], T)
        if n == "root":
            O = Rotation.from_euler(asf.root_axis.lower(), asf._angle(asf.root_orientation)).as_quat()
            rots[:, 0] = quat_multiply(O, M)
        else:
            c = C[n]
            rots[:, j] = quat_multiply(quat_multiply(c, M), quat_inverse(c))
    root_T = np.zeros((T, 3))
    rd = dof_of["root"]
    for ax_i, ax in enumerate("xyz"):
        if "t" + ax in rd:
            root_T[:, ax_i] = data["root"][:, rd.index("t" + ax)]
    root_pos = asf.root_position + root_T

    step = max(1, T // 200)
    probe = Motion(sk_file, 1.0, root_pos[::step], rots[::step])
    height_units = standing_height(probe)
    if scale is None:
        s = asf.length_scale
        reason = (f"ASF units length {asf.units.get('length', 1.0):g}: 1 unit = 1/{asf.units.get('length', 1.0):g} "
                  f"inch (CMU/Vicon convention)" + ("" if "length" in asf.units else "; no length in :units, 1 assumed"))
    else:
        s, reason = resolve_scale(scale, height_units)
    # lengths in metres within +-1e4 m (validate.MAX_LENGTH_M), named by their line
    for b in asf.bones:
        if b.length * s > MAX_LENGTH_M:
            raise MotionFormatError(f"bone {b.name!r} is {b.length * s:.6g} m long after scaling by {s:g} m/unit "
                                    f"(beyond the accepted {MAX_LENGTH_M:g} m; a corrupt number or wrong unit?)",
                                    asf.path, b.line)
    far = np.abs(root_pos * s) > MAX_LENGTH_M
    if far.any():
        r, k = (int(i) for i in np.argwhere(far)[0])
        ln = lines_of["root"][r] if lines_of["root"] else None
        raise MotionFormatError(f"root position {'xyz'[k]} = {root_pos[r, k] * s:.6g} m at frame {r} (beyond the "
                                f"accepted +-{MAX_LENGTH_M:g} m)", path if ln else asf.path, ln)
    if height_check:
        check_height(height_units * s, path or "<amc text>", probe, s)
    if fps is None:
        fps = DEFAULT_AMC_FPS
        notes.append(f"AMC files state no frame rate; {DEFAULT_AMC_FPS:g} Hz assumed (CMU/HDM05 rate)")
    else:
        fps = check_fps(fps, path, what="fps argument")
    notes.append(f"skeleton from {asf.path or 'ASF text'}; AMC angles in {angle}")
    src = SourceInfo(path=path, format="asf/amc", unit_scale=s, unit_reason=reason, header_fps=None,
                     notes=tuple(notes))
    return check_motion(Motion(sk_file.scaled(s), fps, root_pos * s, rots, source=src))
