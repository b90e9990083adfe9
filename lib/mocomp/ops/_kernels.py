"""Compiled kernels of the displacement maps (:mod:`mocomp.ops.displacement`): the log map of
``q_base^-1 q_target`` and the product ``q exp(v)`` over the frames and the joints a map moves, fused
into one loop each (the numpy path makes a temporary per quaternion component and product term: at
10,000 frames x 25 joints that is most of a touch-up step's time).

They use core's inline helpers (:mod:`mocomp.core._compiled`: ``qmul``, ``qlog``, ``qexp``, the
compiled twins of :mod:`mocomp.core.rotations`, same operations in the same order), so they give the
numpy path's numbers to rounding (the compiled sin/cos/atan2 may differ in the last bit); :mod:`mocomp.ops.displacement` calls them only when
:data:`mocomp.core._compiled.AVAILABLE` (numba present, ``MOCOMP_NO_NUMBA`` unset) and runs its numpy
path otherwise (``tests/test_ops_displacement_weights.py`` compares the two).
"""
from __future__ import annotations

import numpy as np

from ..core._compiled import njit, qexp, qlog, qmul

__all__ = ["log_between", "displace", "turned_joints"]


@njit
def _turned(a, b, half2, flags):
    T, J = a.shape[0], a.shape[1]
    for t in range(T):
        for j in range(J):
            if flags[j] or (a[t, j, 0] == b[t, j, 0] and a[t, j, 1] == b[t, j, 1] and a[t, j, 2] == b[t, j, 2]
                            and a[t, j, 3] == b[t, j, 3]):
                continue                 # (equal: exactly no turn; the compiled product may fuse to ~1e-18)
            x, y, z, w = qmul(-a[t, j, 0], -a[t, j, 1], -a[t, j, 2], a[t, j, 3],
                              b[t, j, 0], b[t, j, 1], b[t, j, 2], b[t, j, 3])
            if x * x + y * y + z * z > half2:
                flags[j] = True


@njit
def _log_between(a, b, cols, out):
    T = a.shape[0]
    for t in range(T):
        for i in range(cols.shape[0]):
            j = cols[i]
            x, y, z, w = qmul(-a[t, j, 0], -a[t, j, 1], -a[t, j, 2], a[t, j, 3],
                              b[t, j, 0], b[t, j, 1], b[t, j, 2], b[t, j, 3])
            p0, p1, p2 = qlog(x, y, z, w)
            out[t, j, 0] = p0
            out[t, j, 1] = p1
            out[t, j, 2] = p2


@njit
def _displace(rot, v, cols, out):
    T = rot.shape[0]
    for t in range(T):
        for i in range(cols.shape[0]):
            j = cols[i]
            ex, ey, ez, ew = qexp(v[t, j, 0], v[t, j, 1], v[t, j, 2])
            x, y, z, w = qmul(rot[t, j, 0], rot[t, j, 1], rot[t, j, 2], rot[t, j, 3], ex, ey, ez, ew)
            out[t, j, 0] = x
            out[t, j, 1] = y
            out[t, j, 2] = z
            out[t, j, 3] = w


def turned_joints(a: np.ndarray, b: np.ndarray, negligible: float) -> np.ndarray:
    """Indices of the joints ``j`` where ``q_b`` differs from ``q_a`` (``(T, J, 4)``) by more than
    ``negligible`` rad on some frame: the vector part ``u`` of ``q_a^-1 q_b`` has ``|u| = sin(angle / 2)``,
    so a joint is kept where ``|u| > sin(negligible / 2)`` (any non-zero ``u`` for ``negligible = 0``; an
    unchanged joint's ``u`` is exactly zero in floating point)."""
    flags = np.zeros(a.shape[1], dtype=np.bool_)
    half = np.sin(0.5 * negligible)
    _turned(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64), half * half, flags)
    return np.flatnonzero(flags)


def log_between(a: np.ndarray, b: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``(T, J, 3)``: ``quat_log(quat_multiply(quat_inverse(a), b))`` on the joints ``cols``, zero on
    the others (``a``, ``b`` ``(T, J, 4)``)."""
    out = np.zeros(a.shape[:-1] + (3,))
    _log_between(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64),
                 np.asarray(cols, dtype=np.int64), out)
    return out


def displace(rot: np.ndarray, v: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``(T, J, 4)``: ``rot`` with ``quat_multiply(rot, quat_exp(v))`` on the joints ``cols`` (a copy)."""
    rot = np.ascontiguousarray(rot, dtype=np.float64)
    out = rot.copy()
    _displace(rot, np.ascontiguousarray(v, dtype=np.float64), np.asarray(cols, dtype=np.int64), out)
    return out
