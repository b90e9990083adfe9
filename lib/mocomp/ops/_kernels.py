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

import math

import numpy as np

from ..core._compiled import njit, qexp, qlog, qmul, qrot

__all__ = ["log_between", "displace", "turned_joints", "two_bone_ik_rows"]


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


# ------------------------------------------------------------------ two-bone leg IK (ops.footplant)
@njit(inline="always")
def _axis_angle(x, y, z, angle):
    n = math.sqrt(x * x + y * y + z * z)
    if n > 1e-12:
        s = math.sin(0.5 * angle)
        return x / n * s, y / n * s, z / n * s, math.cos(0.5 * angle)
    return 0.0, 0.0, 0.0, 1.0


@njit(inline="always")
def _arc(ux, uy, uz, vx, vy, vz):
    nu = math.sqrt(ux * ux + uy * uy + uz * uz)
    nv = math.sqrt(vx * vx + vy * vy + vz * vz)
    ux, uy, uz = ux / nu, uy / nu, uz / nu
    vx, vy, vz = vx / nv, vy / nv, vz / nv
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    w = 1.0 + ux * vx + uy * vy + uz * vz
    if w < 1e-12:                                        # antiparallel: 180 deg about a perpendicular
        cx, cy, cz = 0.0, uz, -uy                        # u x (1, 0, 0)
        if math.sqrt(cx * cx + cy * cy + cz * cz) < 1e-6:
            cx, cy, cz = -uz, 0.0, ux                    # u x (0, 1, 0)
        w = 0.0
    n = math.sqrt(cx * cx + cy * cy + cz * cz + w * w)
    return cx / n, cy / n, cz / n, w / n


@njit
def _two_bone_ik_rows(P, G, rot, frames, hp, h, k, a, tgt, end, axis, prior, margin, out, miss):
    """:func:`mocomp.ops.ik.two_bone_ik` (with ``bend_prior``, ``end_rotation`` and a per-row
    ``bend_axis``) on the rows ``frames`` of the clip's ``P``, ``G``, ``rot``: ``out (n, 3, 4)`` the new
    local rotations of hip, knee, ankle, ``miss (n,)``; ``hp`` the hip's parent (-1: the root)."""
    for i in range(frames.shape[0]):
        f = frames[i]
        Hx, Hy, Hz = P[f, h, 0], P[f, h, 1], P[f, h, 2]
        Kx, Ky, Kz = P[f, k, 0], P[f, k, 1], P[f, k, 2]
        Ax, Ay, Az = P[f, a, 0], P[f, a, 1], P[f, a, 2]
        Tx, Ty, Tz = tgt[i, 0], tgt[i, 1], tgt[i, 2]
        l1 = math.sqrt((Kx - Hx) ** 2 + (Ky - Hy) ** 2 + (Kz - Hz) ** 2)
        l2 = math.sqrt((Ax - Kx) ** 2 + (Ay - Ky) ** 2 + (Az - Kz) ** 2)
        d_want = math.sqrt((Tx - Hx) ** 2 + (Ty - Hy) ** 2 + (Tz - Hz) ** 2)
        d = min(max(d_want, abs(l1 - l2) + margin), l1 + l2 - margin)
        ux, uy, uz = Hx - Kx, Hy - Ky, Hz - Kz
        wx, wy, wz = Ax - Kx, Ay - Ky, Az - Kz
        nx, ny, nz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
        gx, gy, gz, gw = G[f, h, 0], G[f, h, 1], G[f, h, 2], G[f, h, 3]
        bx, by, bz = qrot(gx, gy, gz, gw, axis[i, 0], axis[i, 1], axis[i, 2])
        if prior > 0:
            s = prior * l1 * l2
            nx, ny, nz = nx + s * bx, ny + s * by, nz + s * bz
        if math.sqrt(nx * nx + ny * ny + nz * nz) < 1e-9:
            nx, ny, nz = bx, by, bz
        cx, cy, cz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        th0 = math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ux * wx + uy * wy + uz * wz)
        th1 = math.acos(min(max((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0), 1.0))
        if prior > 0:
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            ax, ay, az = nx / nn, ny / nn, nz / nn
            ua = ux * ax + uy * ay + uz * az
            wa = wx * ax + wy * ay + wz * az
            upx, upy, upz = ux - ua * ax, uy - ua * ay, uz - ua * az
            wpx, wpy, wpz = wx - wa * ax, wy - wa * ay, wz - wa * az
            nup = math.sqrt(upx * upx + upy * upy + upz * upz)
            nwp = math.sqrt(wpx * wpx + wpy * wpy + wpz * wpz)
            crx, cry, crz = wpy * upz - wpz * upy, wpz * upx - wpx * upz, wpx * upy - wpy * upx
            phi0 = math.atan2(crx * ax + cry * ay + crz * az, wpx * upx + wpy * upy + wpz * upz)
            c = min(max((l1 * l2 * math.cos(th1) - ua * wa) / max(nup * nwp, 1e-300), -1.0), 1.0)
            ac = math.acos(c)
            c1 = (phi0 - ac + math.pi) % (2 * math.pi) - math.pi
            c2 = (phi0 + ac + math.pi) % (2 * math.pi) - math.pi
            phi = c1 if abs(c1) <= abs(c2) else c2
            qx, qy, qz, qw = _axis_angle(ax, ay, az, phi)
        else:
            qx, qy, qz, qw = _axis_angle(nx, ny, nz, th0 - th1)
        rx, ry, rz = qrot(qx, qy, qz, qw, wx, wy, wz)
        A1x, A1y, A1z = Kx + rx, Ky + ry, Kz + rz
        hx, hy, hz, hw = _arc(A1x - Hx, A1y - Hy, A1z - Hz, Tx - Hx, Ty - Hy, Tz - Hz)
        Ghx, Ghy, Ghz, Ghw = qmul(hx, hy, hz, hw, gx, gy, gz, gw)
        t0, t1, t2, t3 = qmul(qx, qy, qz, qw, G[f, k, 0], G[f, k, 1], G[f, k, 2], G[f, k, 3])
        Gkx, Gky, Gkz, Gkw = qmul(hx, hy, hz, hw, t0, t1, t2, t3)
        if hp >= 0:
            px, py, pz, pw = G[f, hp, 0], G[f, hp, 1], G[f, hp, 2], G[f, hp, 3]
        else:
            px, py, pz, pw = 0.0, 0.0, 0.0, 1.0
        o = qmul(-px, -py, -pz, pw, Ghx, Ghy, Ghz, Ghw)
        out[i, 0, 0], out[i, 0, 1], out[i, 0, 2], out[i, 0, 3] = o[0], o[1], o[2], o[3]
        o = qmul(-Ghx, -Ghy, -Ghz, Ghw, Gkx, Gky, Gkz, Gkw)
        out[i, 1, 0], out[i, 1, 1], out[i, 1, 2], out[i, 1, 3] = o[0], o[1], o[2], o[3]
        o = qmul(-Gkx, -Gky, -Gkz, Gkw, end[i, 0], end[i, 1], end[i, 2], end[i, 3])
        out[i, 2, 0], out[i, 2, 1], out[i, 2, 2], out[i, 2, 3] = o[0], o[1], o[2], o[3]
        miss[i] = abs(d_want - d)


def two_bone_ik_rows(P, G, rot, frames, parent, chain, target, end_rotation, bend_axis, bend_prior, reach_margin):
    """Compiled :func:`mocomp.ops.ik.two_bone_ik` of one leg on the frames ``frames`` of the whole clip's
    ``P (T, J, 3)``, ``G (T, J, 4)`` (no gathering of the rows): returns the new local rotations of the
    hip, knee and ankle ``(n, 3, 4)`` and the misses ``(n,)``. ``target``, ``end_rotation``,
    ``bend_axis``: ``(n, 3)``, ``(n, 4)``, ``(n, 3)``; ``parent``: the hip's parent joint (-1: the root)."""
    n = len(frames)
    out = np.empty((n, 3, 4))
    miss = np.empty(n)
    h, k, a = (int(c) for c in chain)
    _two_bone_ik_rows(np.ascontiguousarray(P, dtype=np.float64), np.ascontiguousarray(G, dtype=np.float64), rot,
                      np.asarray(frames, dtype=np.int64), int(parent), h, k, a,
                      np.ascontiguousarray(target, dtype=np.float64), np.ascontiguousarray(end_rotation, dtype=np.float64),
                      np.ascontiguousarray(np.broadcast_to(bend_axis, (n, 3)), dtype=np.float64), float(bend_prior),
                      float(reach_margin), out, miss)
    return out, miss
