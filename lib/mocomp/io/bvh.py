"""BVH (Biovision hierarchy) reading and writing, exact round trips.

Supports any rotation-channel order per joint, 3- and 6-channel joints (non-root
position channels must be constant and then replace the OFFSET, as in the
Bandai Namco files), End Sites, any frame time, CRLF or LF line ends.

A static root whose only child carries the root motion (Bandai's ``joint_Root``
above ``Hips``) is removed on reading -- the loaded skeleton is rooted at the
child -- and recorded as :attr:`Skeleton.removed_root`; the writer re-emits it
by default (``restore_root=False`` drops it), so read -> write reproduces the
file's hierarchy, channel layout and joint positions.
Lengths are converted to metres on reading (``scale``) and recorded in
``Motion.source``; the writer writes metres unless told otherwise.

Speed: frame blocks of 256 kB and more (about 350 CMU frames) are parsed and
converted to quaternions by the compiled kernels of :mod:`mocomp.io._bvh_kernels`
(numba, one pass each; the same bits as the numpy code, which handles small files,
anything the kernels decline, and every error report). A 31-joint, 2000-frame CMU
file reads in ~12-20 ms, ~30x faster than ``bvhio.readAsBvh``
(``benchmarks/bench_io.py``).
"""
from __future__ import annotations

import io
import re
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.motion import Motion, SourceInfo
from ..core.rotations import euler_sequence
from ..core.skeleton import EndSite, RemovedRoot, Skeleton
from ..errors import MotionFormatError
from .units import HEIGHT_RANGE, check_height, resolve_scale, standing_height
from .validate import MAX_ANGLE_DEG, MAX_FRAMES, MAX_JOINTS, MAX_LENGTH_M, check_counts, check_fps, check_motion

__all__ = ["read_bvh", "write_bvh", "parse_bvh", "format_bvh", "reorder_joints"]

_POS = ("Xposition", "Yposition", "Zposition")
#: relative spread above which a non-root joint's position channels count as moving
_MOVING_TOL = 1e-6
_ROT = ("Xrotation", "Yrotation", "Zrotation")


def _num(tok: str, path, line: int, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise MotionFormatError(f"{what}: {tok!r} is not a number", path, line) from None
    if not np.isfinite(v):
        raise MotionFormatError(f"{what}: {tok!r} is not a finite number", path, line)
    return v


def read_bvh(path, scale=None, fps: float | None = None, height_check: bool = True) -> Motion:
    """Read a BVH file into a :class:`Motion` in metres.

    Parameters
    ----------
    path: the file.
    scale: metres per file unit (number), a unit name (``"cm"``, ``"inch"``,
        ``"cmu"``, ``"m"``, ``"mm"``) or ``None``/``"auto"`` to guess from the
        rest-pose height (recorded in ``motion.source.unit_reason``).
    fps: override the header's frame rate (some clips have wrong headers).
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:  # the first bytes first: a 200 MB file of anything else is refused at once
            _check_starts_with_hierarchy(f.read(_SNIFF_BYTES), str(path))
            f.seek(0)
            raw = f.read()  # one copy (first + rest would briefly hold two)
    except OSError as e:
        raise MotionFormatError(f"cannot read file: {e.strerror}", path) from None
    # Only the header is decoded and split into lines; the frame block stays bytes
    # and is parsed in one go.
    m_ft = _FRAME_TIME_B.search(raw)
    head_end = m_ft.end() if m_ft else len(raw)
    try:
        head = raw[:head_end].decode("utf-8")
    except UnicodeDecodeError:
        head = raw[:head_end].decode("latin-1")
    return _parse(head, raw, head_end, str(path), scale, fps, height_check)


#: bytes read before anything else to check that the file starts with HIERARCHY
_SNIFF_BYTES = 1 << 16
_FIRST_WORD = re.compile(rb"\A(?:\xef\xbb\xbf)?(\s*)(\S{0,40})")


def _check_starts_with_hierarchy(first: bytes, path) -> None:
    """Refuse a file whose first word (after a UTF-8 byte-order mark and blank lines)
    is not ``HIERARCHY``, from its first bytes only."""
    m = _FIRST_WORD.match(first)
    word = m.group(2)
    if word.upper() == b"HIERARCHY" or (not word and len(first) == _SNIFF_BYTES):
        return  # (64 kB of white space: let the parser decide)
    line = m.group(1).count(b"\n") + 1 if m.group(1).count(b"\n") else (m.group(1).count(b"\r") + 1)
    if not word:
        raise MotionFormatError("file does not start with HIERARCHY (it is empty or blank)", path)
    raise MotionFormatError(f"file does not start with HIERARCHY (starts with {word.decode('latin-1')[:20]!r}; "
                            "not a BVH file?)", path, line)


# the "Frame Time:" line with its line end (LF, CRLF or old-Mac CR)
_FRAME_TIME = re.compile(r"(?:^|(?<=\r))[ \t]*Frame[ \t]+Time:[^\r\n]*(?:\r\n|\r|\n)?", flags=re.MULTILINE | re.IGNORECASE)
_NON_SPACE = re.compile(rb"\S")
_LONE_CR = re.compile(rb"\r(?!\n)")
_FRAME_TIME_B = re.compile(rb"(?:^|(?<=\r))[ \t]*Frame[ \t]+Time:[^\r\n]*(?:\r\n|\r|\n)?",
                           flags=re.MULTILINE | re.IGNORECASE)


def parse_bvh(text: str, path: str | None = None, scale=None, fps: float | None = None,
              height_check: bool = True) -> Motion:
    """Parse BVH text (see :func:`read_bvh`)."""
    m_ft = _FRAME_TIME.search(text)
    head_end = m_ft.end() if m_ft else len(text)
    return _parse(text[:head_end], text[head_end:].encode("utf-8"), 0, path, scale, fps, height_check)


def _parse(head: str, raw: bytes, start: int, path, scale, fps, height_check) -> Motion:
    """Header text (through the ``Frame Time:`` line) + the frame block, which is
    ``raw[start:]`` (not sliced: a 2 MB copy is measurable) -> Motion."""
    if head.startswith(("\ufeff", "\xef\xbb\xbf")):  # a UTF-8 byte-order mark (decoded as UTF-8 or latin-1)
        head = head[1 if head[0] == "\ufeff" else 3:]
    lines = head.splitlines()
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    end_sites: list[tuple[int, list[float], str]] = []
    offset_lines: dict[int, int] = {}  # joint -> line of its OFFSET
    end_lines: list[int] = []  # line of each End Site OFFSET, in end_sites order
    end_line = 0
    stack: list[int] = []  # joint indices; -2 marks an End Site block
    pending: int | None = None  # index of the joint/end-site awaiting "{"
    pending_end = False
    n = len(lines)
    i = 0
    # ---- header
    while i < n and not lines[i].strip():
        i += 1
    if i >= n or lines[i].split()[0].upper() != "HIERARCHY":
        raise MotionFormatError("file does not start with HIERARCHY", path, i + 1 if i < n else None)
    i += 1
    motion_line = None
    current_end: list | None = None
    while i < n:
        toks = lines[i].split()
        ln = i + 1
        i += 1
        if not toks:
            continue
        key = toks[0]
        ukey = key.upper()
        if key != "{" and (pending is not None or pending_end):
            what = "End Site" if pending_end else f"joint {names[pending]!r}"
            raise MotionFormatError(f"expected '{{' after {what}, found {key!r}", path, ln)
        if ukey in ("ROOT", "JOINT"):
            if len(toks) < 2:
                raise MotionFormatError(f"{key} without a joint name", path, ln)
            if ukey == "ROOT" and names:
                raise MotionFormatError("more than one ROOT (multiple skeletons are not supported)", path, ln)
            if ukey == "JOINT" and not stack:
                raise MotionFormatError("JOINT outside any ROOT block", path, ln)
            name = " ".join(toks[1:])
            if len(names) >= MAX_JOINTS:
                raise MotionFormatError(f"more than {MAX_JOINTS} joints (the most accepted)", path, ln)
            if name in names:
                raise MotionFormatError(f"duplicate joint name {name!r}", path, ln)
            names.append(name)
            parents.append(stack[-1] if stack else -1)
            offsets.append(None)  # type: ignore[arg-type]
            channels.append(None)  # type: ignore[arg-type]
            pending = len(names) - 1
            pending_end = False
        elif ukey == "END":
            if not stack or stack[-1] < 0:
                raise MotionFormatError("End Site outside a joint", path, ln)
            pending_end = True
            pending = None
            current_end = [stack[-1], None, f"{names[stack[-1]]}_end"]
        elif key == "{":
            if pending is not None:
                stack.append(pending)
                pending = None
            elif pending_end:
                stack.append(-2)
                pending_end = False
            else:
                raise MotionFormatError("'{' without a ROOT, JOINT or End Site before it", path, ln)
        elif key == "}":
            if not stack:
                raise MotionFormatError("unbalanced '}'", path, ln)
            top = stack.pop()
            if top == -2:
                if current_end is None or current_end[1] is None:
                    raise MotionFormatError("End Site without OFFSET", path, ln)
                end_sites.append(tuple(current_end))  # type: ignore[arg-type]
                end_lines.append(end_line)
                current_end = None
            else:
                if offsets[top] is None:
                    raise MotionFormatError(f"joint {names[top]!r} has no OFFSET", path, ln)
                if channels[top] is None:
                    raise MotionFormatError(f"joint {names[top]!r} has no CHANNELS", path, ln)
        elif ukey == "OFFSET":
            if len(toks) != 4:
                raise MotionFormatError(f"OFFSET needs 3 numbers, got {len(toks) - 1}", path, ln)
            vals = [_num(t, path, ln, "OFFSET") for t in toks[1:]]
            if stack and stack[-1] == -2:
                current_end[1] = vals  # type: ignore[index]
                end_line = ln
            elif stack:
                offsets[stack[-1]] = vals
                offset_lines[stack[-1]] = ln
            else:
                raise MotionFormatError("OFFSET outside a joint block", path, ln)
        elif ukey == "CHANNELS":
            if not stack or stack[-1] < 0:
                raise MotionFormatError("CHANNELS outside a joint block", path, ln)
            try:
                k = int(toks[1])
            except (IndexError, ValueError):
                raise MotionFormatError("CHANNELS needs a count", path, ln) from None
            ch = tuple(toks[2:])
            if len(ch) != k:
                raise MotionFormatError(f"CHANNELS says {k} channels but lists {len(ch)}", path, ln)
            for c in ch:
                if c not in _POS and c not in _ROT:
                    raise MotionFormatError(f"unknown channel {c!r}", path, ln)
            if len(set(ch)) != len(ch):
                raise MotionFormatError(f"repeated channel in {ch}", path, ln)
            channels[stack[-1]] = ch
        elif ukey == "MOTION":
            motion_line = ln
            break
        else:
            raise MotionFormatError(f"unexpected keyword {key!r} in HIERARCHY", path, ln)
    if stack:
        raise MotionFormatError("HIERARCHY ends inside an open block (missing '}')", path, n)
    if motion_line is None:
        raise MotionFormatError("no MOTION section (file truncated?)", path, n)
    if not names:
        raise MotionFormatError("HIERARCHY has no joints", path, motion_line)
    for j, nm in enumerate(names):
        if offsets[j] is None or channels[j] is None:
            raise MotionFormatError(f"joint {nm!r} has no {'OFFSET' if offsets[j] is None else 'CHANNELS'}",
                                    path, motion_line)

    # ---- motion header
    def header(prefix: str):
        nonlocal i
        while i < n and not lines[i].strip():
            i += 1
        if i >= n:
            raise MotionFormatError(f"missing '{prefix}' line (file truncated?)", path, n)
        ln = i + 1
        s = " ".join(lines[i].split())  # "Frame\tTime:" and "Frame  Time:" too
        i += 1
        if not s.lower().startswith(prefix.lower()):
            raise MotionFormatError(f"expected '{prefix}', found {s[:40]!r}", path, ln)
        return s[len(prefix):].strip(), ln

    val, ln = header("Frames:")
    frames_line = ln
    try:
        n_frames = int(val)
    except ValueError:
        raise MotionFormatError(f"Frames: {val!r} is not a whole number", path, ln) from None
    if n_frames <= 0:
        raise MotionFormatError(f"Frames: {n_frames} (a motion needs at least one frame)", path, ln)
    if n_frames > MAX_FRAMES:
        raise MotionFormatError(f"Frames: {n_frames} (more than the {MAX_FRAMES:,} accepted)", path, ln)
    check_counts(n_frames, len(names), path, ln)
    val, ln = header("Frame Time:")
    frame_time = _num(val, path, ln, "Frame Time")
    if frame_time <= 0:
        raise MotionFormatError(f"Frame Time must be positive, got {frame_time}", path, ln)
    check_fps(1.0 / frame_time, path, ln, f"Frame Time {val} s gives a frame rate of")
    first_data = len(lines)  # 0-based index of the first line after "Frame Time:"
    nch = sum(len(c) for c in channels)
    room = n_frames * (nch * _MAX_VALUE_BYTES + 2) + (1 << 16)
    if len(raw) - start > room:  # before parsing: 200 MB of junk after a valid header is not read as frames
        raise MotionFormatError(
            f"the frame block has {len(raw) - start} bytes, more than Frames: {n_frames} lines of {nch} values can "
            f"hold ({room} at {_MAX_VALUE_BYTES} bytes a value): a wrong Frames: count, or junk after the frames",
            path, frames_line)
    # large frame blocks: the compiled parse and Euler conversion (same bits as the numpy code)
    compiled = len(raw) - start >= _FAST_MIN_BYTES
    data = _fast_frames(raw, start, n_frames, nch) if compiled else None
    if data is None and len(raw) - start > _STREAM_ERRORS_BYTES:
        # a large block the compiled parser declined: no line may be longer than nch values can be
        # (numpy.loadtxt would split a 200 MB line into 25 million tokens, ~2 GB)
        cap = nch * _MAX_VALUE_BYTES + 2
        m = re.compile(rb"(?<![^\r\n])[^\r\n]{%d}" % (cap + 1)).search(raw, start)
        if m:
            raise MotionFormatError(f"frame line is longer than {cap} bytes ({nch} values of at most "
                                    f"{_MAX_VALUE_BYTES} bytes): not a frame line", path,
                                    first_data + sum(1 for _ in _EOL_B.finditer(raw, start, m.start())) + 1)
    if data is None:  # not a plain table of exact numbers: the general reader (and its error reports)
        data = _parse_frames(raw, start)
    if data is None or data.shape != (n_frames, nch):
        if len(raw) - start > _STREAM_ERRORS_BYTES:  # large: find the bad line without decoding the block whole
            _frame_block_error_streamed(raw, start, first_data, n_frames, nch, path)
        _frame_block_error(raw[start:], first_data, n_frames, nch, path)  # always raises, naming the line
    if not np.all(np.isfinite(data)):
        r, c = np.argwhere(~np.isfinite(data))[0]
        line = _nth_data_line(raw[start:], r) + first_data + 1
        raise MotionFormatError(f"frame value {data[r, c]} in channel {c} is not finite", path, line)
    rot_cols = [k for k, c in enumerate(c for ch in channels for c in ch) if c in _ROT]
    if rot_cols and np.abs(data[:, rot_cols]).max() > MAX_ANGLE_DEG:
        r, k = (int(i) for i in np.argwhere(np.abs(data[:, rot_cols]) > MAX_ANGLE_DEG)[0])
        line = _nth_data_line(raw[start:], r) + first_data + 1
        raise MotionFormatError(f"frame value {data[r, rot_cols[k]]:.6g} in rotation channel {rot_cols[k]} is beyond "
                                f"the accepted +-{MAX_ANGLE_DEG:g} degrees", path, line)

    # ---- assemble (vectorized over frames; joints with the same rotation order in one batch)
    J = len(names)
    off = np.array(offsets, dtype=float)
    root_pos = np.broadcast_to(off[0], (n_frames, 3)).copy()
    rots = np.empty((n_frames, J, 4))
    col = 0
    moving: list[int] = []
    moving_pos: dict[int, np.ndarray] = {}
    by_seq: dict[str, tuple[list[int], list[list[int]]]] = {}
    for j in range(J):
        ch = channels[j]
        pos_idx = [ch.index(a) for a in _POS if a in ch]
        rot_cols = [col + k for k, c in enumerate(ch) if c in _ROT]
        if pos_idx:
            if len(pos_idx) != 3:
                raise MotionFormatError(f"joint {names[j]!r} has {len(pos_idx)} position channels; need 0 or 3",
                                        path, motion_line)
            pvals = data[:, [col + ch.index(a) for a in _POS]]
            if j == 0:
                root_pos = off[0] + pvals
            else:
                spread = np.ptp(pvals, axis=0).max()
                ref = np.abs(pvals).max() + 1.0
                if spread > _MOVING_TOL * ref:
                    moving.append(j)
                    moving_pos[j] = pvals
                off[j] = pvals[0]
        if rot_cols:
            seq = euler_sequence([c for c in ch if c in _ROT])
            js, cols = by_seq.setdefault(seq, ([], []))
            js.append(j)
            cols.append(rot_cols)
        else:
            rots[:, j] = (0.0, 0.0, 0.0, 1.0)
        col += len(ch)
    if by_seq and not (compiled and _euler_all_nb(by_seq, data, rots)):
        for seq, (js, cols) in by_seq.items():
            ca = np.array(cols)
            _euler_columns_to_quat(seq, [data[:, _as_slice(ca[:, k])] for k in range(ca.shape[1])], rots, js)

    notes = []
    removed = None
    parents_arr = np.array(parents)
    if moving:
        # Only supported shape: a static root (e.g. Bandai's joint_Root) whose single
        # child carries the real root motion. Re-root at that child.
        j = moving[0]
        if len(moving) > 1 or parents[j] != 0 or int(np.sum(parents_arr == 0)) != 1:
            raise MotionFormatError(
                f"joint {names[j]!r} has position channels that change over time; only the root (or the single "
                "child of the root) may translate", path, motion_line)
        # The root's only child translates: fold the root's transform into it and drop the root.
        from ..core.rotations import quat_apply, quat_multiply
        q0 = rots[:, 0]
        root_pos = root_pos + quat_apply(q0, moving_pos[j])
        rots[:, j] = quat_multiply(q0, rots[:, j])
        off[j] = 0.0
        keep = np.arange(1, J)
        k0 = len(channels[0])
        removed = RemovedRoot(names[0], offsets[0], channels[0], data[0, :k0], offsets[j],
                              constant=bool(np.all(data[:, :k0] == data[0, :k0])))
        notes.append(f"root joint {names[0]!r} removed; its transform was folded into {names[j]!r}, which "
                     "carries the root motion and became the root (kept as skeleton.removed_root: "
                     "write_bvh writes it again)")
        end_lines = [ln for (p, _, _), ln in zip(end_sites, end_lines) if p != 0]
        end_sites = [(p - 1, o, nm) for p, o, nm in end_sites if p != 0]
        names = [names[k] for k in keep]
        parents_arr = np.array([-1] + [parents[k] - 1 for k in keep[1:]])
        channels = [channels[k] for k in keep]
        off = off[keep]
        rots = rots[:, keep]
        root_pos = root_pos + 0.0
    sk_file = Skeleton(
        tuple(names), parents_arr, off, tuple(channels),
        tuple(EndSite(p, o, nm) for p, o, nm in end_sites), removed,
    )
    step = max(1, n_frames // 64)  # the height estimate needs only a sample of frames

    def probe() -> Motion:
        return Motion(sk_file, 1.0, root_pos[::step], rots[::step])

    def motion_height() -> float:
        return standing_height(probe())

    where = path or "<bvh text>"
    if scale is None or (isinstance(scale, str) and scale == "auto"):
        height_units = motion_height()
        s, reason = resolve_scale(scale, height_units)
        if height_check:
            check_height(height_units * s, where, probe(), s)
    else:
        s, reason = resolve_scale(scale, float("nan"))
        # A given unit: the rest pose's height settles it when plausible (no FK needed);
        # otherwise (e.g. the Bandai rigs' rest pose is not upright) the motion's own
        # standing height decides whether to warn.
        if height_check and not (HEIGHT_RANGE[0] <= sk_file.height() * s <= HEIGHT_RANGE[1]):
            check_height(motion_height() * s, where, probe(), s)
    # lengths in metres within +-1e4 m (validate.MAX_LENGTH_M), named by their line
    for j, o in enumerate(sk_file.offsets):
        if not np.all(np.abs(o * s) <= MAX_LENGTH_M):
            ln = offset_lines.get(j + (1 if removed is not None else 0), motion_line)
            raise MotionFormatError(f"offset of joint {names[j]!r} is {o * s} m after scaling by {s:g} m/unit (beyond the "
                                    f"accepted +-{MAX_LENGTH_M:g} m; a corrupt number or wrong unit?)", path, ln)
    for e, ln in zip(sk_file.end_sites, end_lines):
        if not np.all(np.abs(e.offset * s) <= MAX_LENGTH_M):
            raise MotionFormatError(f"End Site {e.name!r} offset is {e.offset * s} m (beyond the accepted "
                                    f"+-{MAX_LENGTH_M:g} m)", path, ln)
    far = np.abs(root_pos * s) > MAX_LENGTH_M
    if far.any():
        r, k = (int(i) for i in np.argwhere(far)[0])
        line = _nth_data_line(raw[start:], r) + first_data + 1
        raise MotionFormatError(f"root position {'xyz'[k]} = {root_pos[r, k] * s:.6g} m at frame {r} (beyond the "
                                f"accepted +-{MAX_LENGTH_M:g} m)", path, line)
    sk = sk_file.scaled(s)
    header_fps = 1.0 / frame_time
    if fps is not None:
        fps = check_fps(fps, path, what="fps argument")
        notes.append(f"header says {header_fps:.6g} fps; caller set {fps:g} fps")
    src = SourceInfo(path=path, format="bvh", unit_scale=s, unit_reason=reason, header_fps=header_fps,
                     notes=tuple(notes))
    return check_motion(Motion(sk, fps if fps is not None else header_fps, root_pos * s, rots, source=src))


# (output component, a component, b component, sign) of the Hamilton product a*b in (x, y, z, w) order
_HAMILTON = (
    (0, 3, 0, 1), (0, 0, 3, 1), (0, 1, 2, 1), (0, 2, 1, -1),
    (1, 3, 1, 1), (1, 0, 2, -1), (1, 1, 3, 1), (1, 2, 0, 1),
    (2, 3, 2, 1), (2, 0, 1, 1), (2, 1, 0, -1), (2, 2, 3, 1),
    (3, 3, 3, 1), (3, 0, 0, -1), (3, 1, 1, -1), (3, 2, 2, -1),
)


def _sparse_quat_multiply(a: list, b: list) -> list:
    """Hamilton product of quaternions given as 4 component arrays, ``None`` = 0.

    Elementary rotations have only two non-zero components; skipping the zero
    terms makes a 3-axis Euler conversion about twice as fast as full products.
    """
    out: list = [None] * 4
    for o, i, k, sg in _HAMILTON:
        if a[i] is None or b[k] is None:
            continue
        t = a[i] * b[k]
        if out[o] is None:
            out[o] = t if sg > 0 else -t
        elif sg > 0:
            out[o] += t
        else:
            out[o] -= t
    return out


def _as_slice(idx: np.ndarray):
    """A slice equal to the index array when it is an arithmetic progression (a
    view instead of a gathered copy), else the array itself."""
    if idx.size == 1:
        return slice(int(idx[0]), int(idx[0]) + 1)
    d = np.diff(idx)
    if d[0] > 0 and np.all(d == d[0]):
        return slice(int(idx[0]), int(idx[-1]) + 1, int(d[0]))
    return idx


_EULER_PROGRAMS: dict = {}
#: frame blocks from this size on (about 350 CMU frames) take the compiled path
#: (:mod:`mocomp.io._bvh_kernels`; same bits as the numpy path). Below it numpy is
#: faster overall: numba's import and cached-kernel load cost ~0.5-0.9 s once per
#: process, loadtxt on 256 kB ~8 ms.
_FAST_MIN_BYTES = 1 << 18


def _euler_all_nb(by_seq: dict, data: np.ndarray, rots: np.ndarray) -> bool:
    """All joints' Euler channels to quaternions in one compiled pass
    (:func:`mocomp.io._bvh_kernels.euler_to_quat_nb`: the operations of
    :func:`_euler_columns_to_quat`, same order, same bits; ~4x faster); False when
    numba is missing (the caller then runs the numpy version)."""
    from . import _bvh_kernels as kern

    if not kern.AVAILABLE:  # pragma: no cover - numba is a dependency
        return False
    J = rots.shape[1]
    cols = np.zeros((J, 3), dtype=np.int64)
    axes = np.full((J, 3), -1, dtype=np.int64)
    steps = np.zeros((J, 3, 16, 4), dtype=np.int64)
    n_steps = np.zeros((J, 3), dtype=np.int64)
    present = np.zeros((J, 4), dtype=np.bool_)
    for seq, (js, cs) in by_seq.items():
        prog = _EULER_PROGRAMS.get(seq)
        if prog is None:
            prog = _EULER_PROGRAMS[seq] = kern.euler_program(seq)
        for j, c in zip(js, cs):
            cols[j, :len(c)] = c
            axes[j], steps[j], n_steps[j], present[j] = prog
    kern.euler_to_quat_nb(data, cols, axes, steps, n_steps, present, rots)
    return True


def _euler_columns_to_quat(seq: str, angles_deg: list, out: np.ndarray, joints: list) -> None:
    """Intrinsic Euler angles (BVH channel order ``seq``, e.g. ``"ZYX"``; one
    ``(T, Jg)`` array of degrees per axis) to quaternions written into
    ``out[:, joints]``. Same rotations as ``Rotation.from_euler(seq, ...)``
    (tested against scipy for every sequence); this is the BVH reader's hot path.
    Works in blocks of about 8k values so that the temporaries stay in cache
    (twice as fast as whole-array operations for a 2000-frame clip).
    """
    T = out.shape[0]
    sel = slice(joints[0], joints[-1] + 1) if joints == list(range(joints[0], joints[-1] + 1)) else joints
    rows = max(1, 8192 // max(1, len(joints)))
    axes = ["XYZ".index(ax) for ax in seq]
    for r0 in range(0, T, rows):
        blk = slice(r0, r0 + rows)
        q = None
        for ax, a in zip(axes, angles_deg):
            h = a[blk] * (np.pi / 360.0)
            e: list = [None, None, None, np.cos(h)]
            e[ax] = np.sin(h)
            q = e if q is None else _sparse_quat_multiply(q, e)
        o = out[blk]
        for c in range(4):
            o[:, sel, c] = 0.0 if q[c] is None else q[c]


def _fast_frames(raw: bytes, start: int, n_frames: int, nch: int) -> np.ndarray | None:
    """The frame block as an ``(n_frames, nch)`` array by the compiled one-pass parser
    (:func:`mocomp.io._bvh_kernels.parse_table`, ~10x faster than ``numpy.loadtxt``,
    the same doubles as ``float(token)``), or ``None`` when the block is not exactly
    such a table of decimal numbers (or numba is missing); the caller then uses
    :func:`_parse_frames`, whose failures name the bad line."""
    # every value takes at least two bytes (a digit and a separator), so a larger
    # "Frames:" cannot be right; checked before allocating (a corrupt header may say 10**12)
    if nch == 0 or n_frames * nch > (len(raw) - start + 1) // 2:
        return None
    from . import _bvh_kernels as kern

    if not kern.AVAILABLE:  # pragma: no cover - numba is a dependency
        return None
    out = np.empty((n_frames, nch))
    slow = np.empty((max(64, out.size // 4), 4), dtype=np.int64)  # more: loadtxt is as fast
    status, n_slow = kern.parse_table(np.frombuffer(raw, dtype=np.uint8), start, out, slow)
    if status != kern.OK:
        return None
    for r, c, a, b in slow[:n_slow].tolist():  # numbers outside the exact fast range: float() itself
        out[r, c] = float(raw[a:b])
    return out


def _parse_frames(raw: bytes, start: int = 0) -> np.ndarray | None:
    """All frame values as a (rows, columns) array, or ``None`` if the block is
    not a clean table of numbers (the caller then finds and reports the bad line).

    The general reader: small blocks, and whatever the compiled one
    (:func:`_fast_frames`) declines. ``numpy.loadtxt`` on bytes is the fastest
    exact (correctly rounded) whitespace-table reader in numpy and pandas: 8 ms
    for a 2000x96 block (Nov 2026, quiet host) against 14 ms for ``np.fromstring``,
    10 ms for ``pandas.read_csv``, 12 ms for ``np.array(block.split(), float)``
    and 8 ms for pyarrow's threaded CSV reader; blank lines are skipped, ragged
    rows and non-numbers raise. The values are identical to ``float(token)``.
    """
    if _NON_SPACE.search(raw, start) is None:
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # bytes input is ~1.5x faster than a StringIO; latin-1 never fails to decode
            f = io.BytesIO(raw)  # shares the bytes object's buffer; no copy
            f.seek(start)
            return np.loadtxt(f, dtype=float, comments=None, ndmin=2, encoding="latin1")
    except (ValueError, UnicodeError):
        pass
    if _LONE_CR.search(raw, start):  # old-Mac line ends, which loadtxt does not split on
        return _parse_frames(raw[start:].replace(b"\r\n", b"\n").replace(b"\r", b"\n"))
    return None


def _nth_data_line(block: bytes, r: int) -> int:
    """0-based line index (within ``block``) of the ``r``-th non-blank line."""
    k = -1
    for i, l in enumerate(block.decode("utf-8", "replace").splitlines()):
        if l.strip():
            k += 1
            if k == r:
                return i
    return i


#: most bytes one frame value may take with its separator (a 17-digit repr with exponent
#: and sign takes 24); the frame block may not be longer than Frames: x channels x this
_MAX_VALUE_BYTES = 64
#: frame blocks larger than this are searched for their first bad line in a streaming pass
_STREAM_ERRORS_BYTES = 1 << 24
_LINE_B = re.compile(rb"([^\r\n]*)(\r\n|\r|\n|\Z)")
_EOL_B = re.compile(rb"\r\n|\r|\n")


def _frame_block_error_streamed(raw: bytes, start: int, first_data: int, n_frames: int, nch: int, path) -> None:
    """:func:`_frame_block_error` for a large block (``raw[start:]``, not copied), in
    memory proportional to one line: an over-long line, then the line count, then the
    first line with the wrong number of values or a non-number. Lines end at LF, CRLF
    or CR."""
    cap = nch * _MAX_VALUE_BYTES + 2
    m = re.compile(rb"(?<![^\r\n])[^\r\n]{%d}" % (cap + 1)).search(raw, start)
    if m:
        ln = first_data + sum(1 for _ in _EOL_B.finditer(raw, start, m.start())) + 1
        raise MotionFormatError(f"frame line is longer than {cap} bytes ({nch} values of at most {_MAX_VALUE_BYTES} "
                                "bytes): not a frame line", path, ln)
    count, last, extra_line = 0, first_data, None
    for k, mm in enumerate(_LINE_B.finditer(raw, start)):
        if not mm.group(0):
            break
        if mm.group(1).strip():
            count += 1
            last = first_data + k
            if count == n_frames + 1:
                extra_line = last + 1
    if count < n_frames:
        raise MotionFormatError(f"Frames: {n_frames} but only {count} frame lines (file truncated?)", path,
                                last + 1 if count else first_data)
    if count > n_frames:
        raise MotionFormatError(f"Frames: {n_frames} but {count} frame lines follow", path, extra_line)
    for k, mm in enumerate(_LINE_B.finditer(raw, start)):
        toks = mm.group(1).split()
        if not toks:
            if not mm.group(0):
                break
            continue
        if len(toks) != nch:
            raise MotionFormatError(f"frame line has {len(toks)} values, the hierarchy declares {nch} channels",
                                    path, first_data + k + 1)
        for t in toks:
            try:
                float(t)
            except ValueError:
                raise MotionFormatError(f"frame value {t.decode('latin-1')!r} is not a number", path,
                                        first_data + k + 1) from None
    raise MotionFormatError("frame data could not be read as numbers", path, first_data + 1)


def _frame_block_error(block: bytes, first_data: int, n_frames: int, nch: int, path) -> None:
    """Find the first problem in the frame block and raise MotionFormatError naming its line."""
    text = block.decode("utf-8", "replace")
    data_lines = [(first_data + k, l) for k, l in enumerate(text.splitlines()) if l.strip()]
    if len(data_lines) < n_frames:
        raise MotionFormatError(
            f"Frames: {n_frames} but only {len(data_lines)} frame lines (file truncated?)",
            path, data_lines[-1][0] + 1 if data_lines else first_data,
        )
    if len(data_lines) > n_frames:
        raise MotionFormatError(
            f"Frames: {n_frames} but {len(data_lines)} frame lines follow", path, data_lines[n_frames][0] + 1
        )
    for k, l in data_lines:
        toks = l.split()
        if len(toks) != nch:
            raise MotionFormatError(f"frame line has {len(toks)} values, the hierarchy declares {nch} channels",
                                    path, k + 1)
        for t in toks:
            try:
                float(t)
            except ValueError:
                raise MotionFormatError(f"frame value {t!r} is not a number", path, k + 1) from None
    raise MotionFormatError("frame data could not be read as numbers", path, first_data + 1)


def _fmt(values: np.ndarray, precision: int) -> list[str]:
    row = " ".join([f"%.{precision}f"] * values.shape[1])  # one format per row: ~1.5x faster than per value
    return [row % tuple(r) for r in values.tolist()]


#: indentation levels written at most by :func:`format_bvh`
_MAX_INDENT = 64


def format_bvh(motion: Motion, scale: float = 1.0, precision: int = 8, channels=None,
               restore_root: bool = True) -> str:
    """BVH text for ``motion``. Lengths are written in file units of ``scale``
    metres (default 1: metres). ``channels`` overrides the per-joint channel layout
    (default: the skeleton's, as loaded).

    ``restore_root`` (default): when the skeleton records a static root the reader
    removed (:attr:`Skeleton.removed_root`, Bandai's ``joint_Root``), write it again
    as the ROOT, with its offset, channels and (constant) channel values, and joint 0
    below it as a JOINT with the file's OFFSET line. Joint 0's channels then hold the
    motion relative to that constant transform ``(p_R, q_R)``: position
    ``q_R^-1 (root - p_R)``, rotation ``q_R^-1 q_0``, so every joint position is
    reproduced exactly whatever ``(p_R, q_R)`` is. The root is not restored when
    joint 0 lacks its three position channels or does not translate over the clip
    (the reader would then keep the static root, so the file would read back with
    one joint more): ``read_bvh(write_bvh(m))`` always has ``m``'s joints.
    ``False``: start the file at joint 0.
    """
    sk = motion.skeleton
    chans = sk.channels if channels is None else tuple(tuple(c) for c in channels)
    inv = 1.0 / scale
    rr = sk.removed_root if restore_root else None
    if rr is not None and not all(a in chans[0] for a in _POS):
        rr = None
    root_pos_ch = motion.root_positions - sk.offsets[0]  # joint 0's position channel values (metres)
    root_rot = motion.rotations[:, 0]
    if rr is not None:
        from ..core.rotations import quat_apply, quat_inverse, quat_multiply

        p_r, q_r = rr.transform()
        q_inv = quat_inverse(q_r)
        local = quat_apply(q_inv, motion.root_positions - p_r)
        pv = local * inv
        # The reader folds the root only when joint 0's position channels change over the
        # clip; when they would not (one frame, a motion standing still) the file would
        # read back with one joint more, so the root is not restored.
        if np.ptp(pv, axis=0).max() > _MOVING_TOL * 10 * (np.abs(pv).max() + 1.0):
            root_pos_ch = local
            root_rot = quat_multiply(q_inv, root_rot)
        else:
            rr = None
    out = ["HIERARCHY"]
    kids = {j: [] for j in range(sk.n_joints)}
    for j in range(1, sk.n_joints):
        kids[int(sk.parents[j])].append(j)
    ends = {j: [] for j in range(sk.n_joints)}
    for e in sk.end_sites:
        ends[e.parent].append(e)
    num = f"%.{precision + 3}f"

    order: list[int] = []  # joints in the order the hierarchy lists them = frame column order

    def emit(j0: int, depth0: int):
        """The block of joint ``j0`` and everything below it, depth first, with an explicit
        stack (no recursion: any depth works). Indentation is one tab per level up to
        :data:`_MAX_INDENT` levels (deeper blocks are not indented further, so a
        10,000-deep chain does not write 10,000**2 tabs)."""
        stack: list[tuple[int, int, bool]] = [(j0, depth0, False)]  # (joint, depth, children done)
        while stack:
            j, depth, done = stack.pop()
            ind = "\t" * min(depth, _MAX_INDENT)
            if not done:
                order.append(j)
                out.append(f"{ind}{'ROOT' if depth == 0 else 'JOINT'} {sk.names[j]}")
                out.append(f"{ind}{{")
                o = (rr.child_offset if (rr is not None and j == 0) else sk.offsets[j]) * inv
                out.append(f"{ind}\tOFFSET " + " ".join(num % v for v in o))
                out.append(f"{ind}\tCHANNELS {len(chans[j])} " + " ".join(chans[j]))
                stack.append((j, depth, True))
                stack.extend((c, depth + 1, False) for c in reversed(kids[j]))
                continue
            for e in ends[j]:
                out.append(f"{ind}\tEnd Site")
                out.append(f"{ind}\t{{")
                out.append(f"{ind}\t\tOFFSET " + " ".join(num % v for v in e.offset * inv))
                out.append(f"{ind}\t}}")
            out.append(f"{ind}}}")

    T = motion.n_frames
    cols = []
    if rr is not None:
        out.append(f"ROOT {rr.name}")
        out.append("{")
        out.append("\tOFFSET " + " ".join(num % v for v in rr.offset * inv))
        out.append(f"\tCHANNELS {len(rr.channels)} " + " ".join(rr.channels))
        emit(0, 1)
        out.append("}")
        for c, v in zip(rr.channels, rr.values):
            cols.append(np.full(T, v * inv if c in _POS else v))
    else:
        emit(0, 0)
    for j in order:
        ch = chans[j]
        rot_ch = [c for c in ch if c in _ROT]
        eul = None
        if rot_ch:
            seq = euler_sequence(rot_ch)
            # Fewer than 3 rotation channels (e.g. a hinge "CHANNELS 1 Zrotation"): decompose
            # with the missing axes appended and require their angles to vanish.
            full = seq + "".join(a for a in "XYZ" if a not in seq)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # gimbal lock: angles differ, rotation is exact
                q = root_rot if j == 0 else motion.rotations[:, j]
                eul = Rotation.from_quat(q).as_euler(full, degrees=True)
            if len(seq) < 3:
                extra = np.abs(eul[:, len(seq):]).max()
                if extra > 1e-6:
                    raise MotionFormatError(
                        f"joint {sk.names[j]!r} rotates up to {extra:.3g} deg about axes its channels {ch} lack; "
                        "pass channels=... with three rotation channels")
                eul = eul[:, :len(seq)]
        elif not np.allclose(np.abs((root_rot if j == 0 else motion.rotations[:, j])[:, 3]), 1.0, atol=1e-12):
            raise MotionFormatError(f"joint {sk.names[j]!r} rotates but its channel layout {ch} has no rotation channels")
        for c in ch:
            if c in _POS:
                a = _POS.index(c)
                if j == 0:
                    cols.append(root_pos_ch[:, a] * inv)
                else:
                    cols.append(np.full(T, sk.offsets[j, a] * inv))
            else:
                cols.append(eul[:, rot_ch.index(c)])
        if j == 0 and not any(c in _POS for c in ch):
            if not np.allclose(motion.root_positions, sk.offsets[0], atol=1e-9):
                raise MotionFormatError("the root moves but its channel layout has no position channels")
    data = np.column_stack(cols) if cols else np.zeros((T, 0))
    out.append("MOTION")
    out.append(f"Frames: {T}")
    # shortest exact repr: reading it back gives the frame rate to the last bit or so
    # (a fixed 10 decimals turned 120 fps into 120.00000048)
    out.append(f"Frame Time: {float(1.0 / motion.fps)!r}")
    out.extend(_fmt(data, precision))
    return "\n".join(out) + "\n"


def write_bvh(motion: Motion, path, scale: float = 1.0, precision: int = 8, channels=None,
              restore_root: bool = True) -> Path:
    """Write ``motion`` as BVH (see :func:`format_bvh`, also for ``restore_root``); returns the path.

    With the default 8 decimals in metres and degrees, a
    read-write-read round trip reproduces joint positions within 1e-6 m for
    human-sized skeletons.
    """
    path = Path(path)
    path.write_text(format_bvh(motion, scale=scale, precision=precision, channels=channels,
                               restore_root=restore_root))
    return path


def reorder_joints(motion: Motion, names) -> Motion:
    """``motion`` with its joints listed in the order ``names`` (the same joints), everything else kept.

    A BVH file lists its joints depth first (the frame columns follow the hierarchy), so a skeleton
    whose order is not depth first -- DeepMimic's humanoid lists ``right_hip`` (ID 3) before
    ``right_shoulder`` (ID 6), a child of ``chest`` (ID 1) -- comes back from
    ``read_bvh(write_bvh(m))`` in another order with the same joints, parents, offsets and poses.
    ``reorder_joints(read_bvh(path), m.skeleton.names)`` restores ``m``'s order exactly (it is a
    permutation: joint positions, rotations and end sites are unchanged). ``names`` must hold each
    joint once, with the root first and every parent before its children."""
    sk = motion.skeleton
    names = tuple(names)
    old = tuple(sk.names)
    if len(names) != len(old) or set(names) != set(old):
        missing, extra = sorted(set(old) - set(names)), sorted(set(names) - set(old))
        raise MotionFormatError(f"reorder_joints: the order must list the skeleton's {len(old)} joints once each "
                                f"(missing {missing}, unknown {extra}, {len(names)} given)")
    if names == old:
        return motion
    idx = np.array([old.index(n) for n in names])
    new_of = np.empty(len(old), dtype=int)
    new_of[idx] = np.arange(len(old))
    par_old = np.asarray(sk.parents)[idx]
    parents = np.where(par_old < 0, -1, new_of[np.maximum(par_old, 0)])
    bad = [names[j] for j in range(len(names)) if (j == 0) != (parents[j] < 0) or parents[j] >= j]
    if bad:
        raise MotionFormatError(f"reorder_joints: in the order given, joint {bad[0]!r} comes before its parent "
                                "(or is not the root yet listed first); the root must be first and parents "
                                "precede children")
    # end sites in the order of the joints they hang from (stable: a joint's own sites keep their order)
    ends = tuple(sorted((EndSite(int(new_of[e.parent]), e.offset, e.name) for e in sk.end_sites),
                        key=lambda e: e.parent))
    new_sk = Skeleton(names, parents, np.asarray(sk.offsets)[idx], tuple(sk.channels[k] for k in idx), ends,
                      sk.removed_root)
    return motion.replace(skeleton=new_sk, rotations=np.asarray(motion.rotations)[:, idx])
