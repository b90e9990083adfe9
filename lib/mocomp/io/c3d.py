"""C3D marker trajectories (via ``ezc3d``) into :class:`~mocomp.io.markers.Markers`.

* Lengths: ``POINT:UNITS`` (``mm``, ``cm``, ``m``) -> metres, unless ``scale`` is
  given; the factor is recorded in ``Markers.unit_scale``.
* Frame rate: ``POINT:RATE`` (``fps=`` overrides it, e.g. for a wrong header).
* Gaps: a sample is missing when its residual is negative (the C3D convention
  for an invalid point) or when all three coordinates are exactly zero (how many
  exporters write gaps); it becomes NaN with ``mask == False``. Nothing else is
  altered; a non-finite coordinate with a valid residual is corruption and raises.
* Axes: the library's world is y-up; C3D files are usually z-up (Vicon, HDM05).
  ``up="auto"`` reads ``POINT:Y_SCREEN`` (the axis drawn upwards, e.g. ``+Z``)
  and otherwise assumes z-up. The conversion is a proper rotation (no mirror):
  z-up ``(x, y, z) -> (x, z, -y)`` (-90 deg about x); x-up ``(x, y, z) -> (-z, x, -y)``;
  y-up unchanged. The mapping is recorded in ``Markers.notes``.

Robustness: ezc3d (C++) trusts the file. On truncated or corrupt files it
segfaults, loops for minutes or silently returns the frames that happen to be
there. So before ezc3d sees a file, :func:`inspect_c3d` checks it in pure Python
(C3D file format, C3D.org "The C3D File Format User Guide", 2008, ch. 3-4):
the 512-byte header (parameter block pointer, the 0x50 key byte, point and analog
counts, first/last frame, scale factor, data start block, frame rate), the
parameter section (its processor type 84/85/86 = Intel/DEC/MIPS and block count,
then every group and parameter record walked with bounds checks: name length,
offset to the next record strictly forward and inside the section, type -1/1/2/4,
dimensions and data inside the record, every parameter in a defined group),
the consistency of the header with ``POINT:USED``/``ANALOG:USED`` and the size
the data section needs: ``frames * (4 * points + analog samples)`` values of 4
bytes (float data, scale < 0) or 2 bytes (integer data). A short file is refused
naming how many frames are missing. Only then is ezc3d called, and the frame
count it returns is checked against the header's. The result is checked by
:func:`mocomp.io.validate.check_markers` (finite, +-1e4 m, 1-10,000 Hz).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MotionFormatError
from .markers import Markers
from .units import UNITS
from .validate import MAX_FRAMES, check_counts, check_fps, check_markers

__all__ = ["read_c3d", "inspect_c3d", "C3dLayout", "UP_AXIS_MAPS"]

#: world (y-up) coordinates as a matrix times the file's (x, y, z), per file up axis
UP_AXIS_MAPS = {
    "y": np.eye(3),
    "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),  # (x, z, -y)
    "x": np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),  # (-z, x, -y)
}
_MAP_TEXT = {"y": "(x, y, z) -> (x, y, z)", "z": "(x, y, z) -> (x, z, -y)", "x": "(x, y, z) -> (-z, x, -y)"}
_UNIT_ALIASES = {"mm": "mm", "millimeter": "mm", "millimeters": "mm", "cm": "cm", "m": "m", "meter": "m",
                 "meters": "m", "metre": "m", "metres": "m", "in": "inch", "inch": "inch", "inches": "inch"}


#: parameter section byte 4 (processor type) -> (name, struct byte order)
_PROCESSORS = {84: ("Intel", "<"), 85: ("DEC", "<"), 86: ("MIPS", ">")}
_PARAM_TYPES = {-1: "char", 1: "byte", 2: "int16", 4: "float"}
_BLOCK = 512


@dataclass(frozen=True)
class C3dLayout:
    """What the header and parameter section of a C3D file say (checked by :func:`inspect_c3d`).

    Attributes
    ----------
    processor: ``"Intel"``, ``"DEC"`` or ``"MIPS"`` (number and byte format).
    n_points: 3-D points per frame (header word 2 = ``POINT:USED``).
    n_analog: analog samples per 3-D frame, all channels (header word 3).
    first_frame, last_frame: header words 4-5 (1-based frame numbers).
    n_frames: frames the data section holds (``last - first + 1``; ``POINT:FRAMES``
        when the header's 16-bit last frame is saturated at 65535).
    scale: header scale factor; negative = float data (4-byte values), else
        integer data (2-byte values times ``|scale|``).
    rate: header frame rate, Hz.
    data_start: 1-based 512-byte block where the data section starts.
    bytes_per_frame: size of one frame in the data section.
    n_param_blocks: size of the parameter section in blocks.
    first_param_byte: byte 1 of the parameter section (1 in files that start the
        records right after the 4-byte section header).
    parameters: ``{group: {name: value}}`` as decoded here (numbers as numpy
        arrays, character parameters as lists of stripped strings).
    """

    processor: str
    n_points: int
    n_analog: int
    first_frame: int
    last_frame: int
    n_frames: int
    scale: float
    rate: float
    data_start: int
    bytes_per_frame: int
    n_param_blocks: int
    parameters: dict
    first_param_byte: int = 1

    @property
    def data_bytes(self) -> int:
        """Bytes from the file start to the end of the last frame."""
        return (self.data_start - 1) * _BLOCK + self.n_frames * self.bytes_per_frame


def _dec_float(b: bytes) -> float:
    """A DEC (VAX F) 4-byte float: the IEEE float of the word-swapped bytes, divided by 4
    (exponent bias 128 and hidden bit 0.1f instead of 127 and 1.f)."""
    return struct.unpack("<f", b[2:4] + b[0:2])[0] / 4.0


def inspect_c3d(path) -> C3dLayout:
    """Check the header and parameter section of a C3D file in pure Python, without ezc3d,
    and return what they say (:class:`C3dLayout`).

    Raises :class:`MotionFormatError` naming the file and the header word, parameter
    record (byte offset) or the missing frames when the file is malformed or shorter
    than its header says. Reads only the first blocks of the file (at most the
    parameter section, < 131 kB) whatever its size.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        with open(path, "rb") as f:
            head = f.read(_BLOCK)
            if len(head) < _BLOCK:
                raise MotionFormatError(f"not a C3D file: {len(head)} bytes, shorter than the 512-byte header", path)
            pblock, key = head[0], head[1]
            if key != 0x50:
                raise MotionFormatError(f"not a C3D file: header byte 2 is 0x{key:02x}, not the C3D key 0x50", path)
            if pblock < 2:
                raise MotionFormatError(f"header word 1: parameter section at block {pblock} (must be >= 2)", path)
            f.seek((pblock - 1) * _BLOCK)
            phead = f.read(4)
            if len(phead) < 4:
                raise MotionFormatError(f"header word 1 puts the parameter section at block {pblock}, beyond the end "
                                        f"of the file ({size} bytes)", path)
            n_blocks, ptype = phead[2], phead[3]
            if ptype not in _PROCESSORS:
                raise MotionFormatError(f"parameter section byte 4: processor type {ptype} (known: 84 Intel, 85 DEC, "
                                        "86 MIPS)", path)
            if n_blocks < 1:
                raise MotionFormatError("parameter section byte 3: 0 parameter blocks", path)
            f.seek((pblock - 1) * _BLOCK)
            psec = f.read(n_blocks * _BLOCK)
    except OSError as e:
        raise MotionFormatError(f"cannot read file: {e.strerror}", path) from None
    if len(psec) < n_blocks * _BLOCK:
        raise MotionFormatError(f"the parameter section should have {n_blocks} blocks ({n_blocks * _BLOCK} bytes from "
                                f"byte {(pblock - 1) * _BLOCK}), the file ends after {len(psec)} (file truncated?)",
                                path)
    proc, bo = _PROCESSORS[ptype]

    def flt(b: bytes) -> float:
        return _dec_float(b) if proc == "DEC" else struct.unpack(bo + "f", b)[0]

    words = struct.unpack(bo + "6H", head[:12])
    n_points, n_analog, first, last = words[1], words[2], words[3], words[4]
    scale = flt(head[12:16])
    data_start, analog_per_frame = struct.unpack(bo + "2H", head[16:20])
    rate = flt(head[20:24])
    params = _walk_parameters(psec, (pblock - 1) * _BLOCK, bo, flt, path)

    def pval(group, name):
        return params.get(group, {}).get(name)

    # ---- header against itself and the parameters
    if not np.isfinite(scale) or scale == 0:
        raise MotionFormatError(f"header words 7-8: scale factor {scale} (must be finite and non-zero)", path)
    used = pval("POINT", "USED")
    if used is not None and (np.size(used) != 1 or int(np.ravel(used)[0]) % 65536 != n_points):
        raise MotionFormatError(f"header word 2 says {n_points} points but POINT:USED is {np.ravel(used).tolist()}",
                                path)
    if n_analog:
        if analog_per_frame == 0 or n_analog % analog_per_frame:
            raise MotionFormatError(f"header words 3 and 10: {n_analog} analog samples per frame is not a multiple "
                                    f"of {analog_per_frame} samples per channel", path)
        a_used = pval("ANALOG", "USED")
        if a_used is not None and (np.size(a_used) != 1 or int(np.ravel(a_used)[0]) * analog_per_frame != n_analog):
            raise MotionFormatError(f"header words 3 and 10 say {n_analog // analog_per_frame} analog channels but "
                                    f"ANALOG:USED is {np.ravel(a_used).tolist()}", path)
    if first < 1 or last < first:
        raise MotionFormatError(f"header words 4-5: first frame {first}, last frame {last} (need 1 <= first <= last)",
                                path)
    n_frames = last - first + 1
    pf = pval("POINT", "FRAMES")
    if last == 65535 and pf is not None and np.size(pf) == 1:
        v = float(np.ravel(pf)[0])
        v = v + 65536 if v < 0 else v  # an int16 parameter holding up to 65535
        if np.isfinite(v) and v > n_frames:
            n_frames = int(v)
    if n_frames > MAX_FRAMES:
        raise MotionFormatError(f"header says {n_frames} frames (more than the {MAX_FRAMES:,} accepted)", path)
    check_counts(n_frames, n_points, path, joints_word="points")
    if data_start < pblock + n_blocks:
        raise MotionFormatError(f"header word 9: data section at block {data_start}, inside the header or the "
                                f"parameter section (blocks 1-{pblock + n_blocks - 1})", path)
    ds = pval("POINT", "DATA_START")
    if ds is not None and (np.size(ds) != 1 or int(np.ravel(ds)[0]) % 65536 != data_start):
        raise MotionFormatError(f"header word 9 says the data start at block {data_start} but POINT:DATA_START is "
                                f"{np.ravel(ds).tolist()}", path)
    bpv = 4 if scale < 0 else 2
    per_frame = (4 * n_points + n_analog) * bpv
    if per_frame == 0:
        raise MotionFormatError("header words 2-3: no points and no analog samples", path)
    layout = C3dLayout(proc, n_points, n_analog, first, last, n_frames, float(scale), float(rate), data_start,
                       per_frame, n_blocks, params, psec[0])
    if size < layout.data_bytes:
        have = max(0, size - (data_start - 1) * _BLOCK) // per_frame
        raise MotionFormatError(
            f"file has {size} bytes but its header describes {n_frames} frames (frames {first}-{last}) of "
            f"{per_frame} bytes from block {data_start}, {layout.data_bytes} bytes in all: {n_frames - have} of "
            f"{n_frames} frames are missing (only {have} complete; file truncated?)", path)
    return layout


def _walk_parameters(sec: bytes, base: int, bo: str, flt, path) -> dict:
    """Walk the group and parameter records of a parameter section (``sec``, starting at
    file byte ``base``) with bounds checks; ``{group: {name: value}}``."""
    end = len(sec)
    groups: dict[int, str] = {}
    raw_params: list[tuple[int, str, object, int]] = []
    pos = 3 + sec[0]  # byte 1 points to the first record, 1 = right after the 4-byte header (as ezc3d reads it)
    while True:
        if pos + 2 > end:
            raise MotionFormatError(f"parameter record at byte {base + pos} runs past the parameter section "
                                    f"(ends at byte {base + end})", path)
        nchar = struct.unpack("b", sec[pos:pos + 1])[0]
        gid = struct.unpack("b", sec[pos + 1:pos + 2])[0]
        if nchar == 0:
            break
        n = abs(nchar)
        q = pos + 2 + n
        if q + 2 > end:
            raise MotionFormatError(f"parameter record at byte {base + pos}: its name runs past the parameter "
                                    "section", path)
        name_b = sec[pos + 2:q]
        if gid == 0 or not all(32 < c < 127 for c in name_b):
            raise MotionFormatError(f"parameter record at byte {base + pos}: group id {gid}, name {name_b!r} (not "
                                    "a C3D group or parameter record)", path)
        name = name_b.decode("ascii").upper()
        off = struct.unpack(bo + "h", sec[q:q + 2])[0]
        nxt = q + off if off else None
        if nxt is not None and not (q + 2 < nxt <= end):
            raise MotionFormatError(f"parameter record {name!r} at byte {base + pos}: offset {off} to the next "
                                    "record points outside the parameter section or backwards", path)
        rec_end = end if nxt is None else nxt
        q += 2
        if gid < 0:
            if q + 1 > rec_end or q + 1 + sec[q] > rec_end:
                raise MotionFormatError(f"group record {name!r} at byte {base + pos} is cut short", path)
            if -gid in groups:
                raise MotionFormatError(f"group id {-gid} defined twice ({groups[-gid]!r}, {name!r})", path)
            groups[-gid] = name
        else:
            if q + 2 > rec_end:
                raise MotionFormatError(f"parameter {name!r} at byte {base + pos} is cut short", path)
            ptype = struct.unpack("b", sec[q:q + 1])[0]
            ndims = sec[q + 1]
            if ptype not in _PARAM_TYPES or ndims > 7:
                raise MotionFormatError(f"parameter {name!r} at byte {base + pos}: type {ptype} with {ndims} "
                                        "dimensions (types -1, 1, 2, 4; at most 7 dimensions)", path)
            q += 2
            if q + ndims > rec_end:
                raise MotionFormatError(f"parameter {name!r} at byte {base + pos} is cut short", path)
            dims = list(sec[q:q + ndims])
            q += ndims
            count = int(np.prod(dims)) if dims else 1
            nbytes = abs(ptype) * count
            if q + nbytes + 1 > rec_end or q + nbytes + 1 + sec[q + nbytes] > rec_end:
                raise MotionFormatError(f"parameter {name!r} at byte {base + pos}: {dims} values of type "
                                        f"{_PARAM_TYPES[ptype]} do not fit in its record", path)
            data = sec[q:q + nbytes]
            if ptype == -1:
                w = dims[0] if dims else 1
                value = [data[i:i + w].decode("latin-1").strip() for i in range(0, len(data), w)] if w else []
            elif ptype == 1:
                value = np.frombuffer(data, dtype=np.uint8).astype(int)
            elif ptype == 2:
                value = np.frombuffer(data, dtype=np.dtype(bo + "i2")).astype(int)
            else:
                value = np.array([flt(data[i:i + 4]) for i in range(0, len(data), 4)])
            raw_params.append((gid, name, value, pos))
        if nxt is None:
            break
        pos = nxt
    out: dict[str, dict] = {g: {} for g in groups.values()}
    for gid, name, value, pos in raw_params:
        if gid not in groups:
            raise MotionFormatError(f"parameter {name!r} at byte {base + pos} belongs to group id {gid}, which the "
                                    "parameter section does not define", path)
        out[groups[gid]][name] = value
    return out


def _canonical(layout: C3dLayout) -> bool:
    """Whether ezc3d can read the file in this process: the parameter section starts at
    its first record (byte 1 = 1) and holds every parameter ezc3d indexes without checks,
    with the right type and enough entries (``POINT:USED/SCALE/RATE/DATA_START/FRAMES``
    single numbers, a label per point in ``POINT:LABELS``, ``LABELS2``, ...; with analog
    data ``ANALOG:USED/RATE/GEN_SCALE`` and a label, scale and offset per channel).
    Anything else (a renamed, retyped or missing record that still walks cleanly) is
    read in a child process (:func:`_ezc3d_read_guarded`)."""
    P = layout.parameters
    if layout.first_param_byte != 1:
        return False
    point = P.get("POINT", {})
    for name in ("USED", "SCALE", "RATE", "DATA_START", "FRAMES"):
        v = point.get(name)
        if not isinstance(v, np.ndarray) or v.size != 1:
            return False
    labels, k = [], 1
    while True:
        v = point.get("LABELS" if k == 1 else f"LABELS{k}")
        if not isinstance(v, list):
            break
        labels += v
        k += 1
    if len(labels) < layout.n_points or not isinstance(point.get("UNITS", []), list):
        return False
    if layout.n_analog:
        a = P.get("ANALOG", {})
        n_ch = int(np.ravel(a["USED"])[0]) if isinstance(a.get("USED"), np.ndarray) and a["USED"].size == 1 else -1
        if n_ch < 0:
            return False
        for name in ("RATE", "GEN_SCALE"):
            if not isinstance(a.get(name), np.ndarray) or a[name].size != 1:
                return False
        if not (isinstance(a.get("LABELS"), list) and len(a["LABELS"]) >= n_ch):
            return False
        for name in ("SCALE", "OFFSET"):
            if not (isinstance(a.get(name), np.ndarray) and a[name].size >= n_ch):
                return False
    return True


def _ezc3d_read(path) -> dict:
    """ezc3d's reading of the file as plain Python/numpy values (what :func:`read_c3d` uses)."""
    import ezc3d

    try:
        c = ezc3d.c3d(str(path))
    except Exception as e:  # ezc3d raises plain RuntimeError/IOError for malformed files
        raise MotionFormatError(f"not a readable C3D file: {e}", path) from None
    want = {"POINT": ("LABELS", "UNITS", "RATE", "Y_SCREEN")}
    params: dict = {}
    for g, names in want.items():
        grp = c["parameters"].get(g, {}) if hasattr(c["parameters"], "get") else {}
        params[g] = {}
        for n in list(grp.keys()) if hasattr(grp, "keys") else []:
            if n in names or n.startswith("LABELS"):
                try:
                    params[g][n] = {"value": grp[n]["value"]}
                except (KeyError, TypeError):
                    pass
    meta = c["data"]["meta_points"] if "meta_points" in c["data"] else {}
    res = meta.get("residuals") if hasattr(meta, "get") else None
    return {"parameters": params,
            "data": {"points": np.asarray(c["data"]["points"], dtype=float),
                     "meta_points": {"residuals": None if res is None else np.asarray(res)}},
            "header": {"points": {"frame_rate": float(c["header"]["points"]["frame_rate"]),
                                  "first_frame": c["header"]["points"].get("first_frame")}}}


#: seconds the child reader may take: this plus 2 s per MB of file
_CHILD_TIMEOUT = 20.0


def _ezc3d_read_guarded(path) -> dict:
    """:func:`_ezc3d_read` in a child process (``python -c``) with a timeout, for files
    whose parameter section :func:`_canonical` does not vouch for: a crash (signal) or
    a hang inside ezc3d becomes a :class:`MotionFormatError` instead of taking this
    process down. Costs one interpreter start and the ezc3d import (~0.3-0.6 s)."""
    import pickle
    import signal
    import subprocess
    import sys

    path = Path(path)
    timeout = _CHILD_TIMEOUT + 2.0 * path.stat().st_size / 1e6
    code = ("import pickle, sys\n"
            "from mocomp.errors import MotionFormatError\n"
            "from mocomp.io.c3d import _ezc3d_read\n"
            "try:\n    out = ('ok', _ezc3d_read(sys.argv[1]))\n"
            "except MotionFormatError as e:\n    out = ('error', e.reason)\n"
            "sys.stdout.buffer.write(pickle.dumps(out, protocol=4))\n")
    try:
        r = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise MotionFormatError(f"ezc3d did not finish reading the file within {timeout:.0f} s (a corrupt header or "
                                "parameter section makes it loop)", path) from None
    if r.returncode != 0:
        if r.returncode < 0:
            try:
                sig = signal.Signals(-r.returncode).name
            except ValueError:
                sig = f"signal {-r.returncode}"
            why = f"ezc3d crashed ({sig}) reading the file"
        else:
            tail = r.stderr.decode("utf-8", "replace").strip().splitlines()
            why = f"the C3D reader process failed ({tail[-1] if tail else f'exit status {r.returncode}'})"
        raise MotionFormatError(f"{why}: its parameter section is corrupt or not one ezc3d supports", path)
    kind, val = pickle.loads(r.stdout)
    if kind == "error":
        raise MotionFormatError(val, path)
    return val


def _param(params: dict, group: str, name: str):
    try:
        return params[group][name]["value"]
    except (KeyError, TypeError):
        return None


def read_c3d(path, scale=None, up: str = "auto", fps: float | None = None, labeled_only: bool = False) -> Markers:
    """Read the 3-D points of a C3D file as :class:`Markers` in metres, y-up.

    Parameters
    ----------
    path: the ``.c3d`` file.
    scale: metres per file unit (number) or a unit name (``"mm"``, ...); default
        from ``POINT:UNITS``.
    up: the file's vertical axis, ``"x"``, ``"y"``, ``"z"`` or ``"auto"``
        (``POINT:Y_SCREEN`` if present, else ``"z"``); or a ``(3, 3)`` proper
        rotation taking file coordinates to the y-up world (e.g. HDM05's own
        AMC frame is the cyclic ``(x, y, z) -> (y, z, x)``, our z-up mapping
        yawed by 90 deg about the vertical; tested on the HDM05 sample).
    fps: override ``POINT:RATE``.
    labeled_only: drop unlabelled points (Vicon names them ``*0``, ``*1``, ...).
    """
    path = Path(path)
    if not path.is_file():
        raise MotionFormatError("no such file", path)
    layout = inspect_c3d(path)  # before ezc3d: it crashes or hangs on what this refuses
    c = _ezc3d_read(path) if _canonical(layout) else _ezc3d_read_guarded(path)
    params = c["parameters"]
    pts = np.asarray(c["data"]["points"], dtype=float)
    if pts.ndim != 3 or pts.shape[0] < 3:
        raise MotionFormatError(f"unexpected point block shape {pts.shape}", path)
    n_pts, T = pts.shape[1], pts.shape[2]
    if T == 0:
        raise MotionFormatError("the file has no frames", path)
    if (n_pts, T) != (layout.n_points, layout.n_frames):
        raise MotionFormatError(f"ezc3d read {T} frames of {n_pts} points; the header describes {layout.n_frames} "
                                f"frames of {layout.n_points} points", path)
    notes = []
    # ---- labels (LABELS, then LABELS2, LABELS3, ... for more than 255 points)
    labels = list(_param(params, "POINT", "LABELS") or [])
    k = 2
    while len(labels) < n_pts and _param(params, "POINT", f"LABELS{k}") is not None:
        labels += list(_param(params, "POINT", f"LABELS{k}"))
        k += 1
    labels = [str(s).strip() for s in labels[:n_pts]]
    if len(labels) < n_pts:
        notes.append(f"{n_pts - len(labels)} points had no label; named P<index>")
        labels += [f"P{i}" for i in range(len(labels), n_pts)]
    seen: dict[str, int] = {}
    for i, lab in enumerate(labels):
        if not lab:
            labels[i] = lab = f"P{i}"
        if lab in seen:
            seen[lab] += 1
            labels[i] = f"{lab}#{seen[lab]}"
            notes.append(f"duplicate label {lab!r} renamed {labels[i]!r}")
        else:
            seen[lab] = 1
    # ---- units
    if scale is None:
        u = _param(params, "POINT", "UNITS")
        unit = str(u[0]).strip().lower() if u else ""
        if unit not in _UNIT_ALIASES:
            raise MotionFormatError(f"POINT:UNITS is {unit!r}, not a known length unit; pass scale=...", path)
        s = UNITS[_UNIT_ALIASES[unit]]
        notes.append(f"POINT:UNITS '{unit}' -> {s:g} m per unit")
    elif isinstance(scale, str):
        if scale not in UNITS:
            raise ValueError(f"unknown unit {scale!r}; use a number or one of {sorted(UNITS)}")
        s = UNITS[scale]
        notes.append(f"unit '{scale}' given by caller")
    else:
        s = float(scale)
        if not (s > 0 and np.isfinite(s)):
            raise ValueError(f"scale must be positive, got {scale!r}")
        notes.append(f"scale {s:g} m/unit given by caller")
    # ---- rate
    rate = _param(params, "POINT", "RATE")
    header_rate = float(rate[0]) if rate is not None and len(rate) else float(c["header"]["points"]["frame_rate"])
    if fps is None:
        fps = check_fps(header_rate, path, what="POINT:RATE" if rate is not None and len(rate) else "header rate")
    else:
        fps = check_fps(fps, path, what="fps argument")
        notes.append(f"file rate {header_rate:g} Hz; caller set {fps:g} Hz")
    # ---- up axis
    if isinstance(up, str) and up == "auto":
        ys = _param(params, "POINT", "Y_SCREEN")
        tok = str(ys[0]).strip().upper() if ys else ""
        if tok in ("+X", "X", "+Y", "Y", "+Z", "Z"):
            up = tok[-1].lower()
            notes.append(f"up axis {up} from POINT:Y_SCREEN {tok!r}")
        else:
            up = "z"
            notes.append("up axis z assumed (no usable POINT:Y_SCREEN)")
    if isinstance(up, str):
        if up not in UP_AXIS_MAPS:
            raise ValueError(f"up must be 'x', 'y', 'z', 'auto' or a 3x3 rotation matrix, got {up!r}")
        R = UP_AXIS_MAPS[up]
        notes.append(f"axes to y-up: {_MAP_TEXT[up]}")
    else:
        R = np.asarray(up, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("up as a matrix must be a 3x3 proper rotation (orthonormal, det +1)")
        notes.append(f"axes to y-up: caller's matrix {np.round(R, 6).tolist()}")
    # ---- gaps
    xyz = pts[:3]  # (3, M, T)
    res = c["data"]["meta_points"].get("residuals") if "meta_points" in c["data"] else None
    seen_mask = ~np.all(xyz == 0.0, axis=0)
    if res is not None and np.size(res):
        seen_mask &= ~(np.asarray(res)[0] < 0)
    bad = seen_mask & ~np.all(np.isfinite(xyz), axis=0)  # not a gap by either convention: corrupt
    if bad.any():
        m, t = (int(i) for i in np.argwhere(bad)[0])
        raise MotionFormatError(f"point {labels[m]!r} at frame {t} (file frame {layout.first_frame + t}) has "
                                f"non-finite coordinates {xyz[:, m, t].tolist()} but a valid residual", path)
    P = np.einsum("ij,jmt->tmi", R, np.where(seen_mask[None], xyz, 0.0)) * s
    mask = seen_mask.T
    n_gaps = int((~mask).sum())
    if n_gaps:
        notes.append(f"{n_gaps} missing samples (of {mask.size}) set to NaN")
    first = c["header"]["points"].get("first_frame")
    if first is not None:
        notes.append(f"first frame number {first}")
    names = tuple(labels)
    if labeled_only:
        keep = [i for i, n in enumerate(names) if not n.startswith("*")]
        names = tuple(names[i] for i in keep)
        P, mask = P[:, keep], mask[:, keep]
        notes.append(f"{n_pts - len(keep)} unlabelled points dropped")
    return check_markers(Markers(names, P, float(fps), mask, str(path), s, tuple(notes)))
