"""Lean quaternion kernels for the run-time stage (scalar-last, broadcasting on leading axes).

Same results as :mod:`mocomp.core.rotations` / :func:`mocomp.core.motion.slerp` (tested in
``tests/test_flips_runtime.py``) with fewer temporaries and no axis juggling: the run-time
stage calls them on small arrays where numpy's per-call overhead dominates.
"""
from __future__ import annotations

import numpy as np


def qmul(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Hamilton product ``a * b``."""
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    if out is None:
        out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    x = aw * bx + ax * bw + ay * bz - az * by
    y = aw * by - ax * bz + ay * bw + az * bx
    z = aw * bz + ax * by - ay * bx + az * bw
    w = aw * bw - ax * bx - ay * by - az * bz
    out[..., 0], out[..., 1], out[..., 2], out[..., 3] = x, y, z, w
    return out


def qconj(q: np.ndarray) -> np.ndarray:
    out = q.copy()
    out[..., :3] *= -1.0
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` on the last axis (numpy's ``cross`` has a large per-call overhead)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = ay * bz - az * by
    out[..., 1] = az * bx - ax * bz
    out[..., 2] = ax * by - ay * bx
    return out


def qapply(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by ``q (..., 4)``."""
    u = q[..., :3]
    t = cross(u, v)
    t *= 2.0
    return v + q[..., 3:4] * t + cross(u, t)


def qangle(q: np.ndarray) -> np.ndarray:
    """Rotation angle in ``[0, pi]`` (sign-independent)."""
    return 2.0 * np.arctan2(np.sqrt(np.einsum("...i,...i->...", q[..., :3], q[..., :3])), np.abs(q[..., 3]))


def qpow(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``q^w`` (slerp from the identity) for unit ``q (..., 4)`` and weights ``w`` (leading shape)."""
    s = np.where(q[..., 3:4] < 0.0, -1.0, 1.0)
    q = q * s
    vn = np.linalg.norm(q[..., :3], axis=-1)
    half = np.arctan2(vn, q[..., 3])
    wh = w * half
    scale = np.divide(np.sin(wh), vn, out=np.asarray(w, dtype=float) * np.ones_like(vn), where=vn > 1e-12)
    out = np.empty(np.broadcast_shapes(q.shape, np.shape(w) + (1,)))
    out[..., :3] = q[..., :3] * scale[..., None]
    out[..., 3] = np.cos(wh)
    return out


def slerp_rows(q0: np.ndarray, q1: np.ndarray, a: np.ndarray, nlerp_below: float = 0.1) -> np.ndarray:
    """Slerp of ``(N, J, 4)`` rows with one weight per row ``a (N,)`` (short way).

    Pairs closer than ``nlerp_below`` radians (half the rotation angle between them, i.e.
    0.2 rad of rotation) use normalised linear interpolation, which differs from slerp by at
    most ``theta^3 / 12`` (< 1e-4 rad there; tested) and needs no trigonometric functions;
    farther pairs use the exact slerp formula. Neighbouring frames of a 60-120 Hz capture
    are almost always in the first case.
    """
    dot = np.einsum("nji,nji->nj", q0, q1)
    sgn = np.sign(dot)
    sgn[sgn == 0.0] = 1.0
    a2 = a[:, None]
    out = q0 * (1.0 - a2)[..., None]
    out += q1 * (a2 * sgn)[..., None]
    far = np.abs(dot) < np.cos(nlerp_below)
    if far.any():
        n, j = np.nonzero(far)
        th = np.arccos(np.minimum(np.abs(dot[n, j]), 1.0))
        inv = 1.0 / np.sin(th)
        af = a[n]
        out[n, j] = (q0[n, j] * (np.sin((1.0 - af) * th) * inv)[:, None]
                     + q1[n, j] * (np.sin(af * th) * inv * sgn[n, j])[:, None])
    out /= np.sqrt(np.einsum("nji,nji->nj", out, out))[..., None]
    return out
