"""Merging and smoothing (dissertation ch. 6.2, "Merging and smoothing").

"Whenever a single frame from the full-body motion is matched to multiple
frames from the hand sequence, we choose the median position of each marker
from the frames and use it in the matched sequence. Because this frame
averaging process can produce small discontinuities in the hand motion, as a
final step, we blend discontinuities over a window of frames."

* :func:`median_frames` takes, per body frame, the component-wise median over
  the matched hand frames (markers; for skeleton data :func:`median_rotations`,
  the joint quaternions hemisphere-aligned and renormalised). A body frame
  matched to a single hand frame takes that frame or, given the fractional
  frame map, the hand motion at that fractional frame (linear interpolation /
  slerp): with a smooth map (:mod:`~mocomp.splice.warpmap`) a slower hand
  performance is then played back smoothly instead of frame by frame.
* :func:`blend_discontinuities` finds the body frames where the matched hand
  time jumps or stalls relative to its local rate, and blends a smoothed
  version of the merged signal in over a raised-cosine window around each.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d, median_filter

from ..core.motion import slerp
from ..core.rotations import make_continuous
from ..errors import AlignmentError

__all__ = ["median_frames", "median_rotations", "BlendReport", "blend_discontinuities"]


def _row_ranges(path: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    rows = np.asarray(path)[:, 0]
    starts = np.searchsorted(rows, np.arange(n), side="left")
    stops = np.searchsorted(rows, np.arange(n), side="right")
    if np.any(stops <= starts):
        raise AlignmentError("the alignment path does not match every body frame")
    return starts, stops


def _single_frames(frame, m: int, n: int):
    """Fractional hand frame of the single-match rows (``None``: the matched frame itself)."""
    if frame is None:
        return None
    f = np.asarray(frame, dtype=float)
    if f.shape != (n,):
        raise AlignmentError(f"frame map must have {n} entries, got {f.shape}")
    if not np.all(np.isfinite(f)) or f.min() < 0 or f.max() > m - 1:
        raise AlignmentError(f"frame map must lie in [0, {m - 1}]")
    return f


def median_frames(values: np.ndarray, path: np.ndarray, n: int, frame: np.ndarray | None = None) -> np.ndarray:
    """``(n, ...)``: for each body frame the component-wise median of
    ``values (m, ...)`` over the hand frames the path matches to it.

    With ``frame (n,)`` (the fractional hand frame of each body frame), a
    body frame matched to a single hand frame takes ``values`` linearly
    interpolated at ``frame`` instead."""
    values = np.asarray(values, dtype=float)
    path = np.asarray(path)
    starts, stops = _row_ranges(path, n)
    f = _single_frames(frame, values.shape[0], n)
    if f is None:
        out = values[path[starts, 1]].copy()
    else:
        from .dtw import warp_values

        out = warp_values(values, f)
    multi = np.nonzero(stops - starts > 1)[0]
    for i in multi:
        out[i] = np.median(values[path[starts[i]:stops[i], 1]], axis=0)
    return out


def median_rotations(quats: np.ndarray, path: np.ndarray, n: int, frame: np.ndarray | None = None) -> np.ndarray:
    """``(n, J, 4)``: per body frame and joint, the median rotation over the
    matched hand frames: quaternions put in the hemisphere of the first
    matched one, component-wise median, renormalised (the rotation analogue of
    the paper's per-marker median; exact when one frame is matched, and equal
    to the middle frame when each component is monotone over the matched run).

    With ``frame (n,)``, a body frame matched to a single hand frame takes the
    slerp of the hand rotations at the fractional ``frame``."""
    q = np.asarray(quats, dtype=float)
    path = np.asarray(path)
    starts, stops = _row_ranges(path, n)
    f = _single_frames(frame, q.shape[0], n)
    if f is None:
        out = q[path[starts, 1]].copy()
    else:
        i0 = np.minimum(np.floor(f).astype(np.int64), q.shape[0] - 1)
        i1 = np.minimum(i0 + 1, q.shape[0] - 1)
        out = slerp(q[i0], q[i1], np.broadcast_to((f - i0)[:, None], q[i0].shape[:-1]))
    for i in np.nonzero(stops - starts > 1)[0]:
        block = q[path[starts[i]:stops[i], 1]]  # (k, J, 4)
        sgn = np.sign(np.sum(block * block[:1], axis=-1, keepdims=True))
        sgn[sgn == 0] = 1.0
        med = np.median(block * sgn, axis=0)
        out[i] = med / np.linalg.norm(med, axis=-1, keepdims=True)
    return out


@dataclass(frozen=True)
class BlendReport:
    """What :func:`blend_discontinuities` did.

    Attributes
    ----------
    frames: body frames ``i`` where the hand time jumps or stalls between ``i`` and ``i+1``.
    window: blend window, frames.
    jump_before, jump_after: largest frame-to-frame second difference (signal
        units per frame^2) over the blended windows, before and after.
    """

    frames: tuple[int, ...]
    window: int
    jump_before: float
    jump_after: float


def blend_discontinuities(values: np.ndarray, hand_time: np.ndarray, *, window: int = 7, jump: float = 1.5,
                          rotations: bool = False) -> tuple[np.ndarray, BlendReport]:
    """Blend the discontinuities that the median merge leaves (ch. 6.2).

    ``hand_time (n,)`` is the (median) hand frame used for each body frame.
    Where its increment differs from the local median increment (over
    ``window`` frames) by more than ``jump`` hand frames (the hand motion is
    skipped ahead or frozen there), the merged ``values (n, ...)`` are replaced,
    over ``window`` frames centred on the boundary, by
    ``(1 - w) x + w smooth(x)``: ``smooth`` a Gaussian of sigma ``window / 4``
    frames, ``w`` a raised cosine that is 1 at the boundary and 0 at the
    window's ends. ``rotations=True`` treats ``values`` as quaternions
    ``(n, J, 4)``: signs made continuous, blended, renormalised.
    """
    x = np.array(values, dtype=float, copy=True)
    t = np.asarray(hand_time, dtype=float)
    n = x.shape[0]
    if t.shape != (n,):
        raise AlignmentError(f"hand_time must have {n} entries, got {t.shape}")
    window = max(3, int(window) | 1)
    if rotations:
        x = make_continuous(x, axis=0)
    if n < 3:
        return x, BlendReport((), window, 0.0, 0.0)
    d = np.diff(t)
    local = median_filter(d, size=window, mode="nearest")
    frames = np.nonzero(np.abs(d - local) > jump)[0]
    if frames.size == 0:
        return x, BlendReport((), window, 0.0, 0.0)
    half = window // 2
    w = np.zeros(n)
    for i in frames:  # boundary between i and i+1
        k = np.arange(max(0, i - half), min(n, i + 2 + half))
        dist = np.abs(k - (i + 0.5))
        w[k] = np.maximum(w[k], 0.5 * (1 + np.cos(np.pi * np.clip(dist / (half + 1), 0, 1))))
    smooth = gaussian_filter1d(x, sigma=window / 4.0, axis=0, mode="nearest")
    shape = (n,) + (1,) * (x.ndim - 1)
    y = (1 - w.reshape(shape)) * x + w.reshape(shape) * smooth
    if rotations:
        y /= np.linalg.norm(y, axis=-1, keepdims=True)
    sel = w > 0

    def second(z):
        dd = np.zeros(n)
        dd[1:-1] = np.linalg.norm((z[2:] - 2 * z[1:-1] + z[:-2]).reshape(n - 2, -1), axis=1)
        return float(dd[sel].max())

    return y, BlendReport(tuple(int(i) for i in frames), window, second(x), second(y))
