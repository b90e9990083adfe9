"""DeepMimic motion files (JSON key frames) and character files (skeleton + bodies).

Format (X. B. Peng et al., "DeepMimic", SIGGRAPH 2018; ``xbpeng/DeepMimic``
``data/motions/*.txt`` and ``data/characters/humanoid3d.txt``), as read here:

* Character file: ``{"Skeleton": {"Joints": [...]}, "BodyDefs": [...], ...}``.
  Each joint has ``ID``, ``Name``, ``Type`` (``none`` for the root,
  ``spherical``, ``revolute``, ``fixed``), ``Parent``, its position in the
  parent frame ``AttachX/Y/Z`` (metres) and a fixed attachment rotation
  ``AttachThetaX/Y/Z`` (radians, ``R = Rz Ry Rx``, i.e. scipy extrinsic
  ``"xyz"``; DeepMimic ``cMathUtil::EulerToAxisAngle``). Body ``i`` is carried
  by joint ``i``: ``Mass`` (kg), centre ``AttachX/Y/Z`` and orientation
  ``AttachThetaX/Y/Z`` in the joint frame, ``Shape`` with ``Param0..2``
  (``cSimCharacter::BuildCollisionShape``: sphere radius ``Param0/2``; capsule
  radius ``Param0/2`` and cylinder length ``Param1`` along the body y axis;
  box full side lengths ``Param0..2``; cylinder radius ``Param0/2``, length
  ``Param1`` along y).
* Motion file: ``{"Loop": "wrap"|"none", "Frames": [[dt, root pos (3), root
  quat (w, x, y, z), then per non-root joint in ID order: spherical -> quat
  (w, x, y, z), revolute -> angle (rad) about the joint's z axis, fixed ->
  nothing], ...]}``. ``dt`` is the duration of that key frame (the last one's is
  0). Y-up, metres.

The local rotation of joint ``j`` in our model is ``A_j q_j`` (attachment
rotation, then the pose rotation), so forward kinematics matches DeepMimic's
``cKinTree`` transforms. Quaternions in the hand-made clips are not exactly
unit (up to 40 % off); like DeepMimic we normalise them, and record how far
off they were in ``Motion.source.notes``.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..body.model import BodyModel
from ..core.motion import Motion, SourceInfo, slerp
from ..core.rotations import make_continuous, quat_multiply
from ..core.skeleton import EndSite, Skeleton
from ..errors import MotionFormatError
from .units import check_height, resolve_scale, standing_height
from .validate import MAX_FRAMES, MAX_LENGTH_M, check_counts, check_fps, check_motion

__all__ = [
    "DeepMimicCharacter", "read_deepmimic_character", "read_deepmimic", "parse_deepmimic",
    "read_deepmimic_body", "find_character", "solid_inertia",
    "match_character", "recognized_body", "known_characters", "MATCH_TOL_M",
]

_PARAM_SIZE = {"none": 7, "spherical": 4, "revolute": 1, "fixed": 0}
_CHANNELS = {
    "none": ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),
    "spherical": ("Zrotation", "Yrotation", "Xrotation"),
    "revolute": ("Zrotation",),
    "fixed": (),
}


@dataclass(frozen=True, eq=False)
class DeepMimicCharacter:
    """A parsed DeepMimic character file.

    Attributes
    ----------
    path: the file.
    skeleton: joints in ID order, offsets = ``Attach`` (metres); end sites at
        the centres of the bodies of leaf joints (head, feet, hands).
    joint_types: ``(J,)`` DeepMimic joint type per joint.
    attach_rotations: ``(J, 4)`` fixed attachment rotations (scalar-last).
    joints: the raw joint dicts (limits, torque limits, ...).
    bodies: the raw ``BodyDefs`` dicts, by joint ID (``None`` where a joint has no body).
    """

    path: str | None
    skeleton: Skeleton
    joint_types: tuple[str, ...]
    attach_rotations: np.ndarray
    joints: tuple[dict, ...]
    bodies: tuple[dict | None, ...]

    @property
    def n_params(self) -> int:
        """Numbers per motion frame after ``dt``."""
        return sum(_PARAM_SIZE[t] for t in self.joint_types)


#: longest accepted key-frame duration ``dt``, seconds (DeepMimic's clips use 1/60-1/16 s;
#: a corrupt ``dt`` of 1e4 s would otherwise be resampled into 160,000 frames)
MAX_KEY_DT = 10.0


# ------------------------------------------------------------------ JSON helpers
def _json_int(s: str):
    """JSON integers: Python ints up to 308 digits (all convertible to float); longer
    ones become float (inf), which the value checks then report with their frame and
    line, instead of ``int()``'s ValueError (> 4300 digits) or an OverflowError
    later when the frame table is converted to floats."""
    return int(s) if len(s) <= 308 else float(s)


def _parse_json(text: str, path, what: str):
    """``json.loads`` whose every failure is a MotionFormatError naming the file (and line)."""
    try:
        return json.loads(text, parse_int=_json_int)
    except json.JSONDecodeError as e:
        raise MotionFormatError(f"not valid JSON ({what}): {e.msg}", path, e.lineno) from None
    except RecursionError:
        raise MotionFormatError(f"not a {what}: JSON nested too deeply (thousands of '[' or '{{')", path) from None
    except (ValueError, OverflowError) as e:
        raise MotionFormatError(f"not valid JSON ({what}): {e}", path) from None


def _load_json(path: Path, what: str):
    try:
        with open(path, "rb") as f:
            first = f.read(1 << 16)
            # both file kinds are JSON objects: anything else (e.g. 200 MB of junk) is refused from its first bytes
            lead = first.lstrip()
            if lead and not lead.startswith(b"{"):
                line = first[:len(first) - len(lead)].count(b"\n") + 1
                raise MotionFormatError(f"not valid JSON ({what}): it starts with "
                                        f"{lead[:20].decode('latin-1')!r}, not with an object '{{'", path, line)
            raw = first + f.read()
    except OSError as e:
        raise MotionFormatError(f"cannot read file: {e.strerror}", path) from None
    text = raw.decode("utf-8", errors="replace")
    del raw
    return _parse_json(text, path, what), text


def _element_line(text: str, key: str, k: int) -> int | None:
    """1-based line where element ``k`` of the JSON array under ``key`` starts (best effort)."""
    i = text.find(f'"{key}"')
    if i < 0:
        return None
    i = text.find("[", i)
    depth, n, in_str, esc = 0, -1, False, False
    for pos in range(i, len(text)):
        ch = text[pos]
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
            continue
        if ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            if depth == 2:
                n += 1
                if n == k:
                    return text.count("\n", 0, pos) + 1
        elif ch in "]}":
            depth -= 1
            if depth == 0:
                break
        elif depth == 1 and not ch.isspace() and ch != ",":
            # scalar element at depth 1
            if pos == 0 or text[pos - 1] in " \t\r\n,[":
                n += 1
                if n == k:
                    return text.count("\n", 0, pos) + 1
    return None


def _num(d: dict, key: str, path, line, what: str, default=None) -> float:
    if key not in d:
        if default is not None:
            return default
        raise MotionFormatError(f"{what}: missing field {key!r}", path, line)
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MotionFormatError(f"{what}: field {key!r} = {v!r} is not a finite number", path, line)
    return float(v)


# ------------------------------------------------------------------ character
def read_deepmimic_character(path) -> DeepMimicCharacter:
    """Read a DeepMimic character file (skeleton, joint types, bodies)."""
    path = Path(path)
    doc, text = _load_json(path, "character file")
    if not isinstance(doc, dict) or not isinstance(doc.get("Skeleton"), dict) or \
            not isinstance(doc["Skeleton"].get("Joints"), list):
        raise MotionFormatError("character file needs {'Skeleton': {'Joints': [...]}}", path, 1)
    joints = doc["Skeleton"]["Joints"]
    if not joints:
        raise MotionFormatError("character file has no joints", path, 1)
    check_counts(1, len(joints), path, 1)
    names, parents, offsets, types, attach = [], [], [], [], []
    for k, jd in enumerate(joints):
        line = _element_line(text, "Joints", k)
        what = f"joint {k}"
        if not isinstance(jd, dict):
            raise MotionFormatError(f"{what} is not an object", path, line)
        if int(_num(jd, "ID", path, line, what)) != k:
            raise MotionFormatError(f"{what} has ID {jd.get('ID')}; joints must be listed in ID order 0..J-1",
                                    path, line)
        name = jd.get("Name")
        if not isinstance(name, str) or not name:
            raise MotionFormatError(f"{what} has no Name", path, line)
        what = f"joint {name!r}"
        jt = str(jd.get("Type", "")).lower()
        if jt not in _PARAM_SIZE:
            raise MotionFormatError(f"{what} has type {jd.get('Type')!r}; supported: {sorted(_PARAM_SIZE)}",
                                    path, line)
        p = int(_num(jd, "Parent", path, line, what))
        if (k == 0) != (p == -1) or p >= k:
            raise MotionFormatError(f"{what} has parent {p}; the root must be joint 0 and parents precede children",
                                    path, line)
        if (jt == "none") != (k == 0):
            raise MotionFormatError(f"{what}: only the root (joint 0) may have type 'none'", path, line)
        off = [_num(jd, f"Attach{a}", path, line, what, 0.0) for a in "XYZ"]
        th = [_num(jd, f"AttachTheta{a}", path, line, what, 0.0) for a in "XYZ"]
        if max(abs(v) for v in off + th) > MAX_LENGTH_M:
            raise MotionFormatError(f"{what}: Attach position/angle {max(off + th, key=abs):.6g} is beyond the "
                                    f"accepted +-{MAX_LENGTH_M:g} (metres, radians)", path, line)
        if k == 0 and (any(off) or any(th)):
            raise MotionFormatError("a root with a non-zero Attach position/rotation is not supported", path, line)
        names.append(name)
        parents.append(p)
        offsets.append(off)
        types.append(jt)
        attach.append(Rotation.from_euler("xyz", th).as_quat())
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise MotionFormatError(f"duplicate joint name {dup!r}", path, _element_line(text, "Joints", names.index(dup)))
    bodies: list = [None] * len(names)
    for k, bd in enumerate(doc.get("BodyDefs", []) or []):
        line = _element_line(text, "BodyDefs", k)
        if not isinstance(bd, dict):
            raise MotionFormatError(f"body {k} is not an object", path, line)
        bid = int(_num(bd, "ID", path, line, f"body {k}"))
        if not 0 <= bid < len(names):
            raise MotionFormatError(f"body {k} has ID {bid}, which is not a joint ID", path, line)
        if bodies[bid] is not None:
            raise MotionFormatError(f"two bodies for joint {names[bid]!r}", path, line)
        bodies[bid] = dict(bd, _line=line)
    A = np.array(attach)
    # rotation channels only where the local rotation is really a pure z hinge / identity
    chans = []
    for k, t in enumerate(types):
        ident = np.allclose(np.abs(A[k, 3]), 1.0, atol=1e-12)
        chans.append(_CHANNELS[t] if ident or t == "spherical" or t == "none" else _CHANNELS["spherical"])
    ends = []
    for k, n in enumerate(names):
        if k not in parents and bodies[k] is not None:
            c = [_num(bodies[k], f"Attach{a}", path, bodies[k]["_line"], f"body {k}", 0.0) for a in "XYZ"]
            if max(abs(v) for v in c) > MAX_LENGTH_M:
                raise MotionFormatError(f"body {k}: Attach {max(c, key=abs):.6g} m is beyond the accepted "
                                        f"+-{MAX_LENGTH_M:g} m", path, bodies[k]["_line"])
            if any(c):
                ends.append(EndSite(k, np.array(c), f"{n}_end"))
    sk = Skeleton(tuple(names), np.array(parents), np.array(offsets), tuple(chans), tuple(ends))
    char = DeepMimicCharacter(str(path), sk, tuple(types), A, tuple(joints), tuple(bodies))
    key = str(path.resolve())
    _SEEN.pop(key, None)
    _SEEN[key] = char
    while len(_SEEN) > _SEEN_MAX:  # the oldest first (a data-directory file is read again when needed)
        _SEEN.pop(next(iter(_SEEN)))
    return char


def find_character(motion_path) -> Path:
    """The character file for a DeepMimic motion: ``*character*.txt``/``humanoid3d*.txt``
    beside it or in a ``skeletons``/``characters`` folder next to it or one level up."""
    mp = Path(motion_path).resolve()
    cands: list[Path] = []
    for base in (mp.parent, mp.parent.parent):
        for sub in ("", "skeletons", "characters"):
            d = base / sub if sub else base
            if d.is_dir():
                cands += sorted(p for p in d.glob("*.txt") if "character" in p.name or p.name.startswith("humanoid3d"))
    cands = [c for c in dict.fromkeys(cands) if c != mp]
    if not cands:
        raise MotionFormatError("no DeepMimic character file found beside the motion or in a skeletons/ or "
                                "characters/ folder next to it; pass character=...", mp)
    return cands[0]


# ------------------------------------------------------------------ motion
def read_deepmimic(path, character=None, fps: float | None = None, scale=None,
                   height_check: bool = True) -> Motion:
    """Read a DeepMimic motion file into a :class:`Motion` (metres, y-up).

    Parameters
    ----------
    path: the motion JSON (``.txt``/``.json``).
    character: a :class:`DeepMimicCharacter`, a path to the character file, or
        ``None`` to find it (:func:`find_character`).
    fps: frame rate of the result. Uniform key frames (all ``dt`` equal within
        1e-4 relative) keep their frames, at ``1/dt`` unless ``fps`` relabels
        them. Non-uniform key frames are resampled (linear root position, slerp
        per joint, the semantics of :meth:`Motion.sample`) at ``fps`` or, by
        default, at ``1/dt`` of the most common ``dt``; ``source.notes`` says so.
    scale: metres per file unit; DeepMimic files are in metres (default 1).
    """
    path = Path(path)
    char = character if isinstance(character, DeepMimicCharacter) else \
        read_deepmimic_character(find_character(path) if character is None else character)
    doc, text = _load_json(path, "motion file")
    return _motion_from_doc(doc, text, char, str(path), fps, scale, height_check)


def parse_deepmimic(text: str, character, path: str | None = None, fps: float | None = None, scale=None,
                    height_check: bool = True) -> Motion:
    """Parse DeepMimic motion JSON text (see :func:`read_deepmimic`)."""
    char = character if isinstance(character, DeepMimicCharacter) else read_deepmimic_character(character)
    doc = _parse_json(text, path, "motion file")
    return _motion_from_doc(doc, text, char, path, fps, scale, height_check)


def _quat_wxyz(a: np.ndarray) -> np.ndarray:
    return a[..., [1, 2, 3, 0]]


def _motion_from_doc(doc, text, char: DeepMimicCharacter, path, fps, scale, height_check) -> Motion:
    if not isinstance(doc, dict) or "Frames" not in doc:
        raise MotionFormatError("motion file needs a 'Frames' list", path, 1)
    frames = doc["Frames"]
    if not isinstance(frames, list) or not frames:
        raise MotionFormatError("'Frames' must be a non-empty list of frames (zero frames)", path,
                                _element_line(text, "Frames", 0) or 1)
    width = 1 + char.n_params
    check_counts(len(frames), char.skeleton.n_joints, path, _element_line(text, "Frames", 0), what="key frames")
    for k, f in enumerate(frames):
        if not isinstance(f, list) or len(f) != width:
            n = len(f) if isinstance(f, list) else type(f).__name__
            raise MotionFormatError(
                f"frame {k} has {n} values; the character {Path(char.path).name if char.path else ''} needs "
                f"{width} (dt + {char.n_params} pose numbers)", path, _element_line(text, "Frames", k))
        for c, v in enumerate(f):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise MotionFormatError(f"frame {k} value {c} ({v!r}) is not a number", path,
                                        _element_line(text, "Frames", k))
    F = np.array(frames, dtype=float)
    if not np.all(np.isfinite(F)):
        k, c = np.argwhere(~np.isfinite(F))[0]
        raise MotionFormatError(f"frame {k} value {c} is {F[k, c]} (not finite)", path,
                                _element_line(text, "Frames", int(k)))
    T = F.shape[0]
    dt = F[:, 0]
    if T > 1 and np.any(dt[:-1] <= 0):
        k = int(np.argmax(dt[:-1] <= 0))
        raise MotionFormatError(f"frame {k} has duration dt = {dt[k]} (must be > 0)", path,
                                _element_line(text, "Frames", k))
    if T > 1 and np.any(dt[:-1] > MAX_KEY_DT):
        k = int(np.argmax(dt[:-1] > MAX_KEY_DT))
        raise MotionFormatError(f"frame {k} has duration dt = {dt[k]:.6g} s (more than the {MAX_KEY_DT:g} s accepted "
                                "for one key frame)", path, _element_line(text, "Frames", k))
    if np.any(np.abs(F[:, 1:4]) > MAX_LENGTH_M):
        k, c = (int(i) for i in np.argwhere(np.abs(F[:, 1:4]) > MAX_LENGTH_M)[0])
        raise MotionFormatError(f"frame {k}: root position {'xyz'[c]} = {F[k, 1 + c]:.6g} m is beyond the accepted "
                                f"+-{MAX_LENGTH_M:g} m", path, _element_line(text, "Frames", k))
    # ---- pose
    J = char.skeleton.n_joints
    rots = np.empty((T, J, 4))
    col = 1
    root_pos = F[:, col:col + 3]
    col += 3
    raw_quats = []
    for j, t in enumerate(char.joint_types):
        if t == "none":
            q = _quat_wxyz(F[:, col:col + 4])
            raw_quats.append((j, q))
            col += 4
        elif t == "spherical":
            q = _quat_wxyz(F[:, col:col + 4])
            raw_quats.append((j, q))
            col += 4
        elif t == "revolute":
            h = 0.5 * F[:, col]
            q = np.zeros((T, 4))
            q[:, 2] = np.sin(h)
            q[:, 3] = np.cos(h)
            col += 1
        else:  # fixed
            q = np.zeros((T, 4))
            q[:, 3] = 1.0
        rots[:, j] = q
    notes = []
    worst = 0.0
    for j, q in raw_quats:
        nrm = np.linalg.norm(q, axis=1)
        if np.any(nrm < 1e-6):
            k = int(np.argmax(nrm < 1e-6))
            raise MotionFormatError(f"frame {k}: quaternion of joint {char.skeleton.names[j]!r} is zero", path,
                                    _element_line(text, "Frames", k))
        worst = max(worst, float(np.abs(nrm - 1).max()))
        rots[:, j] = q / nrm[:, None]
    if worst > 1e-6:
        notes.append(f"quaternions normalised (largest |norm - 1| was {worst:.3g})")
    A = char.attach_rotations
    nontrivial = ~np.isclose(np.abs(A[:, 3]), 1.0, atol=1e-12)
    if np.any(nontrivial[1:]):
        for j in np.nonzero(nontrivial)[0]:
            rots[:, j] = quat_multiply(A[j], rots[:, j])
    rots = make_continuous(rots, axis=0)
    loop = doc.get("Loop")
    if loop is not None:
        notes.append(f"Loop: {loop}")
    notes.append(f"character {char.path}")

    # ---- timing
    if fps is not None:
        fps = check_fps(fps, path, what="fps argument")
    key_dt = dt[:-1] if T > 1 else np.array([])
    if key_dt.size == 0:
        header_fps = None
        out_fps = fps if fps is not None else 30.0
        if fps is None:
            notes.append("single key frame: no timing; fps set to 30")
    else:
        vals, counts = np.unique(np.round(key_dt, 9), return_counts=True)
        mode_dt = float(vals[np.argmax(counts)])
        if mode_dt <= 0:  # every dt rounds to 0 at 1e-9 s
            mode_dt = float(np.median(key_dt))
        header_fps = 1.0 / mode_dt
        uniform = np.all(np.abs(key_dt - key_dt[0]) <= 1e-4 * key_dt[0])
        if uniform:
            out_fps = check_fps(1.0 / float(np.mean(key_dt)), path, _element_line(text, "Frames", 0),
                                "key-frame rate 1/dt") if fps is None else fps
            if fps is not None:
                notes.append(f"key frames every {key_dt[0]:.6g} s ({1 / key_dt[0]:.6g} fps); caller set {fps:g} fps")
        else:
            times = np.concatenate([[0.0], np.cumsum(key_dt)])
            out_fps = check_fps(header_fps, path, _element_line(text, "Frames", 0),
                                "most common key-frame rate 1/dt") if fps is None else fps
            n_float = np.floor(times[-1] * out_fps + 1e-9) + 1
            if n_float > MAX_FRAMES:  # checked before allocating
                raise MotionFormatError(f"resampling {times[-1]:.6g} s of key frames at {out_fps:.6g} fps would make "
                                        f"{n_float:.0f} frames (more than the {MAX_FRAMES:,} accepted)", path)
            n = int(n_float)
            check_counts(n, J, path, what="resampled frames")
            tq = np.arange(n) / out_fps
            i = np.clip(np.searchsorted(times, tq, side="right") - 1, 0, T - 2)
            a = np.clip((tq - times[i]) / (times[i + 1] - times[i]), 0.0, 1.0)
            root_pos = (1 - a)[:, None] * root_pos[i] + a[:, None] * root_pos[i + 1]
            rots = slerp(rots[i], rots[i + 1], np.broadcast_to(a[:, None], (n, J)))
            notes.append(f"key frames not uniformly spaced (dt {key_dt.min():.6g}-{key_dt.max():.6g} s): resampled "
                         f"{T} keys over {times[-1]:.6g} s to {n} frames at {out_fps:.6g} fps (linear root, slerp)")
    s, reason = (1.0, "DeepMimic files are in metres") if scale is None else resolve_scale(scale, 0.0)
    sk = char.skeleton if s == 1.0 else char.skeleton.scaled(s)
    motion = Motion(sk, out_fps, root_pos * s, rots,
                    source=SourceInfo(path=path, format="deepmimic", unit_scale=s, unit_reason=reason,
                                      header_fps=header_fps, notes=tuple(notes)))
    check_motion(motion, path)
    if height_check:
        check_height(standing_height(motion), path or "<deepmimic text>", motion)
    return motion


# ------------------------------------------------------------------ body model
def solid_inertia(shape: str, mass: float, params) -> np.ndarray:
    """``(3, 3)`` inertia tensor (kg m^2) of a solid of uniform density about its
    centre, in its own frame, for DeepMimic/Bullet shape parameters.

    * sphere, radius ``r = p0/2``: ``I = 2/5 m r^2`` on each axis.
    * box with full sides ``a, b, c = p0, p1, p2``: ``Ixx = m (b^2 + c^2) / 12``, etc.
    * cylinder, ``r = p0/2``, length ``h = p1`` along y: ``Iyy = m r^2 / 2``,
      ``Ixx = Izz = m (3 r^2 + h^2) / 12``.
    * capsule, ``r = p0/2``, cylinder length ``h = p1`` along y, two hemispherical
      caps; the mass splits by volume, ``m_c = m h / (h + 4r/3)`` (cylinder) and
      ``m_s = m - m_c`` (both caps). ``Iyy = m_c r^2/2 + 2/5 m_s r^2``;
      ``Ixx = Izz = m_c (r^2/4 + h^2/12) + m_s (2/5 r^2 + h^2/4 + 3 h r/8)``
      (each cap: ``83/320 m r^2`` about its own centroid, which lies ``3r/8``
      from the flat face; parallel-axis theorem).

    Standard results (e.g. Meriam & Kraige, *Engineering Mechanics: Dynamics*,
    App. D table D/4). Bullet, which DeepMimic simulates with, approximates a
    capsule's inertia by its bounding box (``btCapsuleShape::calculateLocalInertia``),
    so DeepMimic's simulated capsule inertias differ from these exact ones.
    """
    p = [float(x) for x in params]
    shape = shape.lower()
    if shape == "sphere":
        r = p[0] / 2
        d = [0.4 * mass * r * r] * 3
    elif shape == "box":
        a, b, c = p[0], p[1], p[2]
        d = [mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12, mass * (a * a + b * b) / 12]
    elif shape == "cylinder":
        r, h = p[0] / 2, p[1]
        perp = mass * (3 * r * r + h * h) / 12
        d = [perp, mass * r * r / 2, perp]
    elif shape == "capsule":
        r, h = p[0] / 2, p[1]
        vc, vs = math.pi * r * r * h, 4.0 / 3.0 * math.pi * r ** 3
        mc = mass * vc / (vc + vs) if vc + vs > 0 else 0.0
        ms = mass - mc
        axial = mc * r * r / 2 + 0.4 * ms * r * r
        perp = mc * (r * r / 4 + h * h / 12) + ms * (0.4 * r * r + h * h / 4 + 3 * h * r / 8)
        d = [perp, axial, perp]
    else:
        raise ValueError(f"unknown shape {shape!r}; known: sphere, box, cylinder, capsule")
    return np.diag(d)


def read_deepmimic_body(character_path, skeleton: Skeleton | None = None) -> BodyModel:
    """The character file's own mass distribution as a :class:`BodyModel`.

    One segment per ``BodyDefs`` entry, carried by the joint of the same ID
    (matched into ``skeleton`` by joint name; default: the character's own
    skeleton). Mass from ``Mass``; COM at the body's ``Attach`` point in the
    joint frame; inertia about the COM from the body shape as a solid of
    uniform density (:func:`solid_inertia`), rotated into the joint frame by
    ``AttachTheta`` (``I_joint = R I_body R^T``).
    """
    char = character_path if isinstance(character_path, DeepMimicCharacter) else \
        read_deepmimic_character(character_path)
    sk = char.skeleton if skeleton is None else skeleton
    seg_names, seg_joint, masses, coms, inertias = [], [], [], [], []
    massless = []
    for j, bd in enumerate(char.bodies):
        jname = char.skeleton.names[j]
        if bd is None:
            massless.append(jname)
            continue
        line = bd.get("_line")
        what = f"body {bd.get('Name', jname)!r}"
        k = sk.find(jname)
        if k is None:
            raise MotionFormatError(f"{what}: joint {jname!r} is not in the given skeleton", char.path, line)
        m = _num(bd, "Mass", char.path, line, what)
        if m < 0:
            raise MotionFormatError(f"{what}: negative mass {m}", char.path, line)
        shape = str(bd.get("Shape", "")).lower()
        params = [_num(bd, f"Param{i}", char.path, line, what, 0.0) for i in range(3)]
        try:
            I_body = solid_inertia(shape, m, params)
        except ValueError as e:
            raise MotionFormatError(f"{what}: {e}", char.path, line) from None
        R = Rotation.from_euler("xyz", [_num(bd, f"AttachTheta{a}", char.path, line, what, 0.0) for a in "XYZ"]
                                ).as_matrix()
        seg_names.append(str(bd.get("Name", jname)))
        seg_joint.append(k)
        masses.append(m)
        coms.append([_num(bd, f"Attach{a}", char.path, line, what, 0.0) for a in "XYZ"])
        inertias.append(R @ I_body @ R.T)
        if m == 0:
            massless.append(jname)
    return BodyModel(sk, tuple(seg_names), np.array(seg_joint), np.array(masses), np.array(coms),
                     np.array(inertias), tuple(massless), table=f"DeepMimic character file {char.path}",
                     shape="given")


# ------------------------------------------------------------------ recognising a character's skeleton
#: largest difference of any bone offset (metres) for a skeleton to count as a DeepMimic character's:
#: a BVH the project wrote keeps offsets to 1e-11 m; another person's (or a rescaled) skeleton differs
#: by centimetres
MATCH_TOL_M = 1e-4

#: characters read in this process, by resolved path (read_deepmimic_character registers them)
_SEEN: dict[str, DeepMimicCharacter] = {}
_SEEN_MAX = 32


def known_characters() -> list[DeepMimicCharacter]:
    """DeepMimic characters a skeleton may be matched against: those read in this process and the
    character files of the data directory (``$MOCOMP_DATA_DIR/skeletons``: ``*character*.txt``,
    ``humanoid3d*.txt``). Files that do not parse are skipped."""
    from ..datasets.config import data_dir

    try:
        root = data_dir()
    except Exception:  # a set but missing directory: only the characters already read
        root = None
    if root is not None:
        d = root / "skeletons"
        if d.is_dir():
            for c in sorted(p for p in d.glob("*.txt") if "character" in p.name or p.name.startswith("humanoid3d")):
                if str(c.resolve()) not in _SEEN:
                    try:
                        read_deepmimic_character(c)
                    except MotionFormatError:
                        continue
    return list(_SEEN.values())


def _skeleton_difference(sk: Skeleton, ref: Skeleton) -> tuple[float | None, str]:
    """``(max offset difference in metres, "")`` when ``sk`` has ``ref``'s joints (names, each joint's
    parent by name; any order) else ``(None, why not)``."""
    na, nb = tuple(sk.names), tuple(ref.names)
    if set(na) != set(nb):
        miss, extra = sorted(set(nb) - set(na)), sorted(set(na) - set(nb))
        return None, (f"joints differ ({len(na)} vs {len(nb)}; missing {miss[:4]}{'...' if len(miss) > 4 else ''}, "
                      f"extra {extra[:4]}{'...' if len(extra) > 4 else ''})")
    idx = np.array([nb.index(n) for n in na])
    pa = [None if p < 0 else na[p] for p in np.asarray(sk.parents)]
    pb = [None if p < 0 else nb[p] for p in np.asarray(ref.parents)[idx]]
    bad = [n for n, x, y in zip(na, pa, pb) if x != y]
    if bad:
        return None, f"joint {bad[0]!r} hangs from {pa[na.index(bad[0])]!r}, not {pb[na.index(bad[0])]!r}"
    # the root's offset is its rest position, not a bone: not compared
    nonroot = np.array([k for k in range(len(na)) if pa[k] is not None], dtype=int)
    d = np.abs(np.asarray(sk.offsets)[nonroot] - np.asarray(ref.offsets)[idx[nonroot]])
    return (float(d.max()) if d.size else 0.0), ""


def match_character(skeleton: Skeleton, candidates=None, tol: float = MATCH_TOL_M):
    """The DeepMimic character whose skeleton ``skeleton`` is, and why: ``(character or None, reason)``.

    A skeleton matches a character when it has exactly the character's joints (names and each
    joint's parent by name, in any order: a BVH lists them depth first, DeepMimic by ID) and every
    bone offset agrees within ``tol`` metres (:data:`MATCH_TOL_M`). A skeleton that merely
    resembles one (same names, other bone lengths; a rescaled copy; a joint missing) does not
    match, and ``reason`` says what differed. ``candidates``: characters or character-file paths
    (default :func:`known_characters`)."""
    if candidates is None:
        cands = known_characters()
    else:
        cands = [c if isinstance(c, DeepMimicCharacter) else read_deepmimic_character(c) for c in candidates]
    if not cands:
        return None, "no DeepMimic character file known (none read, none in $MOCOMP_DATA_DIR/skeletons)"
    why, hits = [], []
    for c in cands:
        diff, whynot = _skeleton_difference(skeleton, c.skeleton)
        name = Path(c.path).name if c.path else "character"
        if diff is None:
            why.append(f"{name}: {whynot}")
        elif diff > tol:
            why.append(f"{name}: same joints, but a bone offset differs by {diff * 1000:.3g} mm "
                       f"(> {tol * 1000:.3g} mm)")
        else:
            hits.append((c, name, diff))
    if not hits:
        return None, "not a DeepMimic character's skeleton (" + "; ".join(why) + ")"
    # several characters with this skeleton: only if their bodies agree is the choice safe
    sigs = {_bodies_signature(c) for c, _, _ in hits}
    if len(sigs) > 1:
        return None, (f"skeleton matches {len(hits)} DeepMimic characters with different bodies "
                      f"({', '.join(n for _, n, _ in hits)}): ambiguous, none chosen")
    c, name, diff = hits[0]
    return c, (f"skeleton recognised as DeepMimic character {name}: its {skeleton.n_joints} joints by name "
               f"and parent, bone offsets within {diff * 1000:.2g} mm (tolerance {tol * 1000:.3g} mm)")


def _bodies_signature(c: DeepMimicCharacter) -> tuple:
    """The mass-relevant fields of a character's bodies, by joint name (to tell characters apart)."""
    keys = ("Mass", "Shape", "AttachX", "AttachY", "AttachZ", "AttachThetaX", "AttachThetaY", "AttachThetaZ",
            "Param0", "Param1", "Param2")
    return tuple(sorted((n, tuple(str(b.get(k)) for k in keys)) for n, b in zip(c.skeleton.names, c.bodies)
                        if b is not None))


def recognized_body(skeleton: Skeleton, candidates=None, tol: float = MATCH_TOL_M) -> BodyModel | None:
    """The body model of the DeepMimic character whose skeleton ``skeleton`` is (:func:`match_character`),
    its masses, COMs and inertias mapped by joint name (any joint order), with the reason for the
    choice as the model's first note; ``None`` when the skeleton is no known character's."""
    import dataclasses

    char, reason = match_character(skeleton, candidates, tol)
    if char is None:
        return None
    body = read_deepmimic_body(char, skeleton)
    return dataclasses.replace(body, notes=(reason,) + tuple(body.notes))
