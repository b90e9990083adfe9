"""Compiled (numba) versions of the run-time stage's two per-frame loops.

* :func:`slerp_rows_nb` -- the retiming interpolation of :func:`mocomp.flips._quat.slerp_rows`
  (normalised lerp for neighbours closer than ``nlerp_below``, exact slerp otherwise);
* :func:`com_relative_nb` -- :meth:`mocomp.flips.reposition.ComEvaluator.relative`, the
  mass-weighted forward kinematics collapsed to one vector per joint.

Both give the numpy versions' results to rounding (tested); they exist because the numpy
versions are dominated by per-call overhead on arrays of a few thousand quaternions. Numba
is a project dependency (also used by :mod:`mocomp.splice`); compiled code is cached on
disk (``cache=True``). ``AVAILABLE`` is False when numba cannot be imported and the
numpy versions are used instead.
"""
from __future__ import annotations

import math

import numpy as np

try:
    import numba

    AVAILABLE = True
except Exception:  # pragma: no cover - numba is a dependency; keep the library importable without it
    AVAILABLE = False

__all__ = ["AVAILABLE", "slerp_rows_nb", "com_relative_nb"]

if AVAILABLE:
    @numba.njit(cache=True, nogil=True)
    def _slerp_rows(q0, q1, a, cos_near, out):
        N, J, _ = q0.shape
        for n in range(N):
            t = a[n]
            for j in range(J):
                d = q0[n, j, 0] * q1[n, j, 0] + q0[n, j, 1] * q1[n, j, 1] + q0[n, j, 2] * q1[n, j, 2] \
                    + q0[n, j, 3] * q1[n, j, 3]
                s = 1.0
                if d < 0.0:
                    d = -d
                    s = -1.0
                if d >= cos_near:
                    w0 = 1.0 - t
                    w1 = t * s
                else:
                    if d > 1.0:
                        d = 1.0
                    th = math.acos(d)
                    inv = 1.0 / math.sin(th)
                    w0 = math.sin((1.0 - t) * th) * inv
                    w1 = math.sin(t * th) * inv * s
                x = w0 * q0[n, j, 0] + w1 * q1[n, j, 0]
                y = w0 * q0[n, j, 1] + w1 * q1[n, j, 1]
                z = w0 * q0[n, j, 2] + w1 * q1[n, j, 2]
                w = w0 * q0[n, j, 3] + w1 * q1[n, j, 3]
                r = 1.0 / math.sqrt(x * x + y * y + z * z + w * w)
                out[n, j, 0] = x * r
                out[n, j, 1] = y * r
                out[n, j, 2] = z * r
                out[n, j, 3] = w * r
        return out

    @numba.njit(cache=True, nogil=True)
    def _com_relative(q, joints, parent, u, out):
        T = q.shape[0]
        n = joints.shape[0]
        G = np.empty((n, 4))
        for t in range(T):
            r = joints[0]
            G[0, 0] = q[t, r, 0]
            G[0, 1] = q[t, r, 1]
            G[0, 2] = q[t, r, 2]
            G[0, 3] = q[t, r, 3]
            sx = 0.0
            sy = 0.0
            sz = 0.0
            for i in range(n):
                if i > 0:
                    p = parent[i]
                    jj = joints[i]
                    ax, ay, az, aw = G[p, 0], G[p, 1], G[p, 2], G[p, 3]
                    bx, by, bz, bw = q[t, jj, 0], q[t, jj, 1], q[t, jj, 2], q[t, jj, 3]
                    G[i, 0] = aw * bx + ax * bw + ay * bz - az * by
                    G[i, 1] = aw * by - ax * bz + ay * bw + az * bx
                    G[i, 2] = aw * bz + ax * by - ay * bx + az * bw
                    G[i, 3] = aw * bw - ax * bx - ay * by - az * bz
                ux, uy, uz, w = G[i, 0], G[i, 1], G[i, 2], G[i, 3]
                vx, vy, vz = u[i, 0], u[i, 1], u[i, 2]
                tx = 2.0 * (uy * vz - uz * vy)
                ty = 2.0 * (uz * vx - ux * vz)
                tz = 2.0 * (ux * vy - uy * vx)
                sx += vx + w * tx + uy * tz - uz * ty
                sy += vy + w * ty + uz * tx - ux * tz
                sz += vz + w * tz + ux * ty - uy * tx
            out[t, 0] = sx
            out[t, 1] = sy
            out[t, 2] = sz
        return out


def slerp_rows_nb(q0: np.ndarray, q1: np.ndarray, a: np.ndarray, nlerp_below: float = 0.1) -> np.ndarray:
    q0 = np.ascontiguousarray(q0, dtype=np.float64)
    q1 = np.ascontiguousarray(q1, dtype=np.float64)
    return _slerp_rows(q0, q1, np.ascontiguousarray(a, dtype=np.float64), math.cos(nlerp_below),
                       np.empty_like(q0))


def com_relative_nb(q: np.ndarray, joints: np.ndarray, parent: np.ndarray, u: np.ndarray) -> np.ndarray:
    q = np.ascontiguousarray(q, dtype=np.float64)
    return _com_relative(q, joints, parent, u, np.empty((q.shape[0], 3)))
