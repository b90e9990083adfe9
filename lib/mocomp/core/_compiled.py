"""The compiled (numba) backend of the kinematics kernel, and the one switch that selects it.

Everything in :mod:`mocomp` that runs compiled goes through this module:

* :data:`AVAILABLE` -- True when numba imports and ``MOCOMP_NO_NUMBA`` is not set (to anything
  but ``""`` or ``"0"``). It is the only place the choice is made: callers with a numpy path
  (:func:`mocomp.core.kinematics.forward_kinematics`, :func:`mocomp.dynamics.momentum`, the
  multi-flip run-time stage, the BVH reader) take it when ``AVAILABLE`` is False.
* :func:`njit` -- ``numba.njit(cache=True, nogil=True, ...)`` for the method packages' compiled
  kernels (the DTW recurrence, the eq. 5.21 direction sweep, ...). Without numba it returns the
  function unchanged, so a kernel without a numpy twin still runs (interpreted: correct, slower).
* The inline helpers below (``@njit(inline="always")``: no call overhead inside a kernel) are the
  compiled twins of :mod:`mocomp.core.rotations` -- the numpy reference -- with the same
  operations in the same order, so both backends agree to the last bit where the operation count
  is the same (tested in ``tests/test_core_compiled.py``). Quaternions are scalar-last
  ``(x, y, z, w)`` passed as four floats and returned as tuples.
* :func:`fk_pose` / :func:`forward_kinematics` -- forward kinematics of one frame / of a clip,
  the compiled backend of :func:`mocomp.core.kinematics.forward_kinematics`.
* :func:`angular_velocity` -- angular velocities from sampled orientations, the compiled backend
  of :func:`mocomp.core.kinematics.angular_velocity` (order 2).

Importing this module imports numba (~0.3 s); :mod:`mocomp.core` imports it lazily, on the first
forward kinematics, so ``import mocomp`` does not pay for it. Compiled code is cached on disk
(``cache=True``).
"""
from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["AVAILABLE", "DISABLED", "njit", "qmul", "qrot", "point_velocity", "qangle", "qlog", "qexp", "qpow", "qmat", "slerp4", "qdelta", "centroid", "world_inertia", "spin", "fk_pose",
           "forward_kinematics", "angular_velocity"]

#: numba switched off by the environment (``MOCOMP_NO_NUMBA=1``): the numpy reference runs everywhere
DISABLED = os.environ.get("MOCOMP_NO_NUMBA", "").strip() not in ("", "0")

if DISABLED:
    numba = None
    AVAILABLE = False
else:
    try:
        import numba

        AVAILABLE = True
    except Exception:  # pragma: no cover - numba is a dependency; the library works without it
        numba = None
        AVAILABLE = False


def njit(*args, **options):
    """``numba.njit(cache=True, nogil=True, **options)``; without numba (or with
    ``MOCOMP_NO_NUMBA``) the plain Python function. Use as ``@njit`` or ``@njit(inline="always")``."""
    if AVAILABLE:
        opts = {"cache": True, "nogil": True}
        opts.update(options)
        if args and callable(args[0]):
            return numba.njit(**opts)(args[0])
        return numba.njit(*args, **opts)
    if args and callable(args[0]):
        return args[0]
    return lambda f: f


# ------------------------------------------------------------------ quaternion algebra
@njit(inline="always")
def qmul(ax, ay, az, aw, bx, by, bz, bw):
    """Hamilton product ``a b`` (apply ``b`` first); as :func:`mocomp.core.rotations.quat_multiply`."""
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@njit(inline="always")
def qrot(ux, uy, uz, w, vx, vy, vz):
    """``q v q^-1`` for a unit quaternion ``q = (u, w)``: ``v + w t + u x t``, ``t = 2 u x v``;
    as :func:`mocomp.core.rotations.quat_apply`. ``R(q)^T v`` is ``qrot(-ux, -uy, -uz, w, ...)``."""
    tx = 2.0 * (uy * vz - uz * vy)
    ty = 2.0 * (uz * vx - ux * vz)
    tz = 2.0 * (ux * vy - uy * vx)
    return (vx + w * tx + (uy * tz - uz * ty),
            vy + w * ty + (uz * tx - ux * tz),
            vz + w * tz + (ux * ty - uy * tx))


@njit(inline="always")
def qangle(x, y, z, w):
    """Rotation angle in ``[0, pi]`` of a unit quaternion (sign-independent): ``2 atan2(|u|, |w|)``;
    as :func:`mocomp.core.rotations.quat_angle`."""
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


@njit(inline="always")
def qlog(x, y, z, w):
    """Rotation vector of a unit quaternion, the short way; as :func:`mocomp.core.rotations.quat_log`."""
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    if s <= 1e-12:
        return 2.0 * x, 2.0 * y, 2.0 * z
    k = 2.0 * math.atan2(s, w) / s
    return k * x, k * y, k * z


@njit(inline="always")
def qexp(p0, p1, p2):
    """Unit quaternion of a rotation vector; as :func:`mocomp.core.rotations.quat_exp`."""
    a = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    if a <= 1e-12:
        k = 0.5
    else:
        k = math.sin(0.5 * a) / a
    return k * p0, k * p1, k * p2, math.cos(0.5 * a)


@njit(inline="always")
def qpow(x, y, z, w, t):
    """``q^t`` (slerp from the identity, the short way); as :func:`mocomp.core.rotations.quat_pow`."""
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    vn = math.sqrt(x * x + y * y + z * z)
    if vn <= 1e-12:
        return x * t, y * t, z * t, 1.0
    h = math.atan2(vn, w) * t
    sc = math.sin(h) / vn
    return x * sc, y * sc, z * sc, math.cos(h)


@njit(inline="always")
def qmat(x, y, z, w, R):
    """Rotation matrix of a unit quaternion into ``R (3, 3)``; as :func:`mocomp.core.rotations.quat_matrix`."""
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - z * w)
    R[0, 2] = 2 * (x * z + y * w)
    R[1, 0] = 2 * (x * y + z * w)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - x * w)
    R[2, 0] = 2 * (x * z - y * w)
    R[2, 1] = 2 * (y * z + x * w)
    R[2, 2] = 1 - 2 * (x * x + y * y)


@njit(inline="always")
def slerp4(ax, ay, az, aw, bx, by, bz, bw, t, cos_near):
    """Slerp ``a -> b`` at weight ``t`` (the short way), normalised; as
    :func:`mocomp.core.rotations.slerp`. Pairs with ``|a . b| >= cos_near`` (or ``sin(theta) <
    1e-9``) use the normalised linear interpolation (``cos_near > 1``: exact slerp whenever it is
    defined). Returns ``(x, y, z, w, nn)``, ``nn`` the squared norm before normalisation (finite
    and > 0 for a valid result)."""
    d = ax * bx + ay * by + az * bz + aw * bw
    s = 1.0
    if d < 0.0:
        d = -d
        s = -1.0
    if d > 1.0:
        d = 1.0
    w0 = 1.0 - t
    w1 = t
    if d < cos_near:
        th = math.acos(d)
        sn = math.sin(th)
        if sn >= 1e-9:
            w0 = math.sin((1.0 - t) * th) / sn
            w1 = math.sin(t * th) / sn
    w1 *= s
    x = w0 * ax + w1 * bx
    y = w0 * ay + w1 * by
    z = w0 * az + w1 * bz
    w = w0 * aw + w1 * bw
    nn = x * x + y * y + z * z + w * w
    n = math.sqrt(nn)
    return x / n, y / n, z / n, w / n, nn


@njit(inline="always")
def qdelta(Q, a, b, s):
    """``Log(Q[b, s] Q[a, s]^-1)``: the world rotation vector taking orientation ``a`` of segment
    (or joint) ``s`` to orientation ``b`` (``Q (T, S, 4)``), the short way; a finite-difference
    angular velocity is this over the time between them (as
    :func:`mocomp.core.kinematics.angular_velocity`)."""
    x, y, z, w = qmul(Q[b, s, 0], Q[b, s, 1], Q[b, s, 2], Q[b, s, 3], -Q[a, s, 0], -Q[a, s, 1], -Q[a, s, 2], Q[a, s, 3])
    return qlog(x, y, z, w)


# ------------------------------------------------------------------ rigid-body velocities
@njit(inline="always")
def point_velocity(vx, vy, vz, wx, wy, wz, dx, dy, dz):
    """``v + w x d``: the velocity of a point at offset ``d`` from an origin moving at ``v`` in a
    frame turning at ``w`` (all world axes); the compiled twin of
    :func:`mocomp.core.kinematics.point_velocities` (a child joint's origin, a segment's COM)."""
    return vx + (wy * dz - wz * dy), vy + (wz * dx - wx * dz), vz + (wx * dy - wy * dx)


# ------------------------------------------------------------------ segment sums
@njit(inline="always")
def centroid(m, X, f, M):
    """``sum_s m[s] X[f, s] / M`` (``X (T, S, 3)``): the whole-body COM of frame ``f`` from
    segment COMs (``M`` the total mass), or with ``M = 1`` and velocities the linear momentum
    (eq. 5.4); accumulated in segment order, then divided."""
    cx = 0.0
    cy = 0.0
    cz = 0.0
    for s in range(m.shape[0]):
        cx += m[s] * X[f, s, 0]
        cy += m[s] * X[f, s, 1]
        cz += m[s] * X[f, s, 2]
    return cx / M, cy / M, cz / M


@njit(inline="always")
def world_inertia(R, I_local, s, out):
    """``out = R I_local[s] R^T`` (3x3): segment ``s``'s inertia tensor in the world frame for
    its orientation matrix ``R`` (:func:`qmat`)."""
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for p in range(3):
                for r in range(3):
                    acc += R[i, p] * I_local[s, p, r] * R[j, r]
            out[i, j] = acc


@njit(inline="always")
def spin(x, y, z, w, I_local, s, wx, wy, wz):
    """``R I_local[s] R^T omega`` with ``R`` the unit quaternion ``(x, y, z, w)``: segment ``s``'s
    spin angular momentum (the first term of eq. 5.5) for the world angular velocity ``omega``,
    computed as ``R (I (R^T omega))`` with :func:`qrot` (no matrix)."""
    ux, uy, uz = qrot(-x, -y, -z, w, wx, wy, wz)
    ix = I_local[s, 0, 0] * ux + I_local[s, 0, 1] * uy + I_local[s, 0, 2] * uz
    iy = I_local[s, 1, 0] * ux + I_local[s, 1, 1] * uy + I_local[s, 1, 2] * uz
    iz = I_local[s, 2, 0] * ux + I_local[s, 2, 1] * uy + I_local[s, 2, 2] * uz
    return qrot(x, y, z, w, ix, iy, iz)


# ------------------------------------------------------------------ forward kinematics
@njit(inline="always")
def fk_pose(parents, offsets, rot, f, rx, ry, rz, G, P):
    """Forward kinematics of frame ``f`` of local rotations ``rot (T, J, 4)`` with the root at
    ``(rx, ry, rz)`` into ``G (J, 4)`` (world orientations) and ``P (J, 3)`` (world positions):
    ``G_j = G_parent(j) L_j``, ``P_j = P_parent(j) + G_parent(j) offset_j`` (parents precede
    children; the root's offset is not used). The operations of
    :func:`mocomp.core.kinematics.forward_kinematics`, in its order."""
    J = rot.shape[1]
    G[0, 0] = rot[f, 0, 0]
    G[0, 1] = rot[f, 0, 1]
    G[0, 2] = rot[f, 0, 2]
    G[0, 3] = rot[f, 0, 3]
    P[0, 0] = rx
    P[0, 1] = ry
    P[0, 2] = rz
    for j in range(1, J):
        p = parents[j]
        ax, ay, az, aw = G[p, 0], G[p, 1], G[p, 2], G[p, 3]
        G[j, 0], G[j, 1], G[j, 2], G[j, 3] = qmul(ax, ay, az, aw, rot[f, j, 0], rot[f, j, 1], rot[f, j, 2],
                                                  rot[f, j, 3])
        dx, dy, dz = qrot(ax, ay, az, aw, offsets[j, 0], offsets[j, 1], offsets[j, 2])
        P[j, 0] = P[p, 0] + dx
        P[j, 1] = P[p, 1] + dy
        P[j, 2] = P[p, 2] + dz


@njit
def forward_kinematics(parents, offsets, root_positions, rotations):
    """``(P (T, J, 3), G (T, J, 4))`` of a clip: :func:`fk_pose` per frame."""
    T, J = rotations.shape[0], rotations.shape[1]
    P = np.empty((T, J, 3))
    G = np.empty((T, J, 4))
    for f in range(T):
        fk_pose(parents, offsets, rotations, f, root_positions[f, 0], root_positions[f, 1], root_positions[f, 2],
                G[f], P[f])
    return P, G



# ------------------------------------------------------------------ velocities
@njit
def angular_velocity(q, t, body):
    """``(T, K, 3)`` angular velocities of orientations ``q (T, K, 4)`` at times ``t (T,)``: the
    order-2 formula of :func:`mocomp.core.kinematics.angular_velocity` (one-sided steps at the ends,
    the non-uniform central blend ``(h1 r_{i,i+1}/h2 + h2 r_{i-1,i}/h1) / (h1 + h2)`` inside), with
    ``r = Log(q_b q_a^-1)`` (world axes) or ``Log(q_a^-1 q_b)`` (``body``: the earlier orientation's
    own axes), in numpy's order of operations."""
    T, K = q.shape[0], q.shape[1]
    out = np.empty((T, K, 3))
    prev = np.empty(3)
    for k in range(K):
        for i in range(T - 1):
            ax, ay, az, aw = q[i, k, 0], q[i, k, 1], q[i, k, 2], q[i, k, 3]
            bx, by, bz, bw = q[i + 1, k, 0], q[i + 1, k, 1], q[i + 1, k, 2], q[i + 1, k, 3]
            if body:
                x, y, z, w = qmul(-ax, -ay, -az, aw, bx, by, bz, bw)
            else:
                x, y, z, w = qmul(bx, by, bz, bw, -ax, -ay, -az, aw)
            r0, r1, r2 = qlog(x, y, z, w)
            h2 = t[i + 1] - t[i]
            s0, s1, s2 = r0 / h2, r1 / h2, r2 / h2
            if i == 0:
                out[0, k, 0], out[0, k, 1], out[0, k, 2] = s0, s1, s2
            else:
                h1 = t[i] - t[i - 1]
                hs = h1 + h2
                out[i, k, 0] = (h1 * s0 + h2 * prev[0]) / hs
                out[i, k, 1] = (h1 * s1 + h2 * prev[1]) / hs
                out[i, k, 2] = (h1 * s2 + h2 * prev[2]) / hs
            prev[0], prev[1], prev[2] = s0, s1, s2
        out[T - 1, k, 0], out[T - 1, k, 1], out[T - 1, k, 2] = prev[0], prev[1], prev[2]
    return out
