"""Plausibility checks shared by every reader: what a loaded motion may contain.

Every reader (:func:`~mocomp.io.read_bvh`, :func:`~mocomp.io.read_amc`,
:func:`~mocomp.io.read_deepmimic`, :func:`~mocomp.io.read_c3d`) returns a value
that passes these checks or raises :class:`~mocomp.errors.MotionFormatError`
naming the file and the field (and the line where the reader knows it). The
ranges are wide enough for any human (or animal, or robot) capture in SI units
and narrow enough that a corrupt number cannot pass as data:

==================  =====================  ===============================================
quantity            accepted range         why
==================  =====================  ===============================================
frame rate          1 Hz - 10,000 Hz       key-framed clips run at >= 8 Hz, high-speed
                                           optical capture at <= 2,000 Hz
lengths (offsets,   ``|x| <= 1e4 m``       bones are < 10 m; a root may travel kilometres
root positions,     per component          but not 10 km in one clip. The bound also keeps
markers, end sites) after unit conversion  every forward-kinematics position finite
angles in files     ``|a| <= 1e6 deg``     unwrapped real angles stay within a few thousand
joints              1 - 1,000              full-body rigs with fingers and face have < 300
frames              1 - 1,000,000          2.3 h at 120 Hz
frames x joints     <= 50,000,000          1.6 GB of quaternions: the memory budget of a Motion
==================  =====================  ===============================================

Readers check claimed counts (``Frames:``, key-frame durations, C3D header
frame numbers) against :data:`MAX_FRAMES` and the file's size *before*
allocating, and call :func:`check_motion` (or :func:`check_markers`) on what
they return.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import MotionFormatError

__all__ = ["FPS_RANGE", "MAX_LENGTH_M", "MAX_ANGLE_DEG", "MAX_JOINTS", "MAX_FRAMES", "MAX_SAMPLES",
           "check_fps", "check_counts", "check_lengths", "check_motion", "check_markers"]

#: accepted frame rates, Hz (inclusive)
FPS_RANGE = (1.0, 10_000.0)
#: largest accepted |coordinate| of an offset, end site, root position or marker, metres
MAX_LENGTH_M = 1e4
#: largest accepted |angle| in a file's rotation channels, degrees (real files stay within
#: a few thousand even when unwrapped; 1e308 is a corrupt number, not an angle)
MAX_ANGLE_DEG = 1e6
#: most joints a skeleton may have
MAX_JOINTS = 1000
#: most frames a motion may have
MAX_FRAMES = 1_000_000
#: most frames x joints (or markers) a motion may have (memory budget: 32 bytes each)
MAX_SAMPLES = 50_000_000


def check_fps(fps, path=None, line: int | None = None, what: str = "frame rate") -> float:
    """``fps`` as a float if it is finite and within :data:`FPS_RANGE`, else MotionFormatError."""
    try:
        f = float(fps)
    except (TypeError, ValueError, OverflowError):
        raise MotionFormatError(f"{what} {fps!r} is not a number", path, line) from None
    lo, hi = FPS_RANGE
    if not (math.isfinite(f) and lo <= f <= hi):
        raise MotionFormatError(f"{what} {f:.6g} Hz is outside the accepted {lo:g}-{hi:g} Hz", path, line)
    return f


def check_counts(n_frames: int, n_joints: int, path=None, line: int | None = None, what: str = "frames",
                 joints_word: str = "joints") -> None:
    """Frame and joint counts within :data:`MAX_FRAMES`, :data:`MAX_JOINTS`, :data:`MAX_SAMPLES`."""
    if n_joints > MAX_JOINTS:
        raise MotionFormatError(f"{n_joints} {joints_word} (more than the {MAX_JOINTS} accepted)", path, line)
    if n_frames > MAX_FRAMES:
        raise MotionFormatError(f"{n_frames} {what} (more than the {MAX_FRAMES:,} accepted)", path, line)
    if n_frames * max(n_joints, 1) > MAX_SAMPLES:
        raise MotionFormatError(f"{n_frames} {what} x {n_joints} {joints_word} = {n_frames * n_joints:,} samples "
                                f"(more than the {MAX_SAMPLES:,} accepted)", path, line)


def check_lengths(values, what: str, path=None, line: int | None = None, names=None) -> None:
    """All of ``values`` (metres, any shape, last axis xyz) finite and within :data:`MAX_LENGTH_M`.

    ``names`` (optional) labels the entries along the first axis (joint names)
    for the message; otherwise the message gives the index.
    """
    a = np.asarray(values, dtype=float)
    bad = ~np.isfinite(a)
    if not bad.any():
        bad = np.abs(a) > MAX_LENGTH_M
        if not bad.any():
            return
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    v = a[idx]
    if names is not None and a.ndim >= 1:
        label = f"{what} of {names[idx[0]]!r}"
    else:
        label = f"{what} at index {idx[:-1] if len(idx) > 1 else idx}"
    reason = "not finite" if not np.isfinite(v) else f"beyond the accepted +-{MAX_LENGTH_M:g} m"
    raise MotionFormatError(f"{label} is {v:.6g} m ({reason}; wrong unit or a corrupt number?)", path, line)


def check_motion(motion, path=None):
    """Raise MotionFormatError unless ``motion`` is finite and plausible (see the module
    docstring for the ranges); returns ``motion``. ``path`` defaults to ``motion.source.path``."""
    if path is None and motion.source is not None:
        path = motion.source.path
    sk = motion.skeleton
    check_counts(motion.n_frames, sk.n_joints, path)
    check_fps(motion.fps, path)
    check_lengths(sk.offsets, "offset", path, names=sk.names)
    for e in sk.end_sites:
        check_lengths(e.offset[None], "end-site offset", path, names=[e.name])
    rp = motion.root_positions
    bad = ~np.isfinite(rp) | (np.abs(rp) > MAX_LENGTH_M)
    if bad.any():
        t, k = (int(i) for i in np.argwhere(bad)[0])
        raise MotionFormatError(f"root position {'xyz'[k]} at frame {t} is {rp[t, k]:.6g} m (not finite or beyond "
                                f"the accepted +-{MAX_LENGTH_M:g} m)", path)
    if not np.all(np.isfinite(motion.rotations)):  # Motion normalises; a huge component gives NaN
        t, j = (int(i) for i in np.argwhere(~np.isfinite(motion.rotations))[0][:2])
        raise MotionFormatError(f"rotation of joint {sk.names[j]!r} at frame {t} is not finite", path)
    return motion


def check_markers(markers, path=None):
    """Raise MotionFormatError unless the seen samples of ``markers`` are finite and within
    :data:`MAX_LENGTH_M`, the rate within :data:`FPS_RANGE` and the counts within the limits."""
    path = markers.source if path is None else path
    T, M = markers.mask.shape
    check_counts(T, M, path, joints_word="markers")
    check_fps(markers.fps, path)
    P = markers.positions
    bad = markers.mask & ~np.all(np.isfinite(P) & (np.abs(P) <= MAX_LENGTH_M), axis=2)
    if bad.any():
        t, m = (int(i) for i in np.argwhere(bad)[0])
        raise MotionFormatError(f"marker {markers.names[m]!r} at frame {t} is at {P[t, m].tolist()} m (not finite or "
                                f"beyond the accepted +-{MAX_LENGTH_M:g} m)", path)
    return markers
