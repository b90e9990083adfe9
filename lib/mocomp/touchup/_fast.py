"""Touch-up's hot paths without numpy's per-call overhead (issue 16's speed goal).

On a 100-frame clip a forward kinematics pass in numpy (:func:`mocomp.core.kinematics.forward_kinematics`)
is ~1200 array calls over 20-30 joints and costs 1-1.5 ms, the arithmetic a few microseconds; the
touch-up loop runs 3-4 of them per iteration (the motion for eq. 6-7, the feet and the support
polygon, its Gaussian-smoothed copy for eq. 4, the results of the footplant steps). Here they run
compiled (:func:`mocomp.edit._kernels.forward_kinematics`: the same operations in the same order,
bit-identical results) and fill the motion's FK cache, so that the callees that ask ``motion.fk()``
(:func:`mocomp.ops.enforce_footplants`, :func:`mocomp.dynamics.com.center_of_mass`) find it done.

``COMPILED`` switches the compiled paths off (``MOCOMP_NO_NUMBA=1``, numba missing, or a test that
sets it to ``False``): every function then runs the numpy code it replaces, which is the reference
``tests/test_touchup_speed.py`` compares the compiled paths with.
"""
from __future__ import annotations

import os

import numpy as np

from ..audit.zmp import smooth_quaternions_fast
from ..core.kinematics import forward_kinematics
from ..core.rotations import quat_apply
from ..dynamics.derivatives import gaussian_smooth

COMPILED = os.environ.get("MOCOMP_NO_NUMBA", "").strip() in ("", "0")
if COMPILED:
    try:
        from ..edit._kernels import motion_fk
    except Exception:                                   # pragma: no cover - numba missing or broken
        COMPILED = False

__all__ = ["COMPILED", "fk", "SegmentChains"]


def fk(motion):
    """``motion.fk()``, compiled when :data:`COMPILED` (and then cached on ``motion``)."""
    if COMPILED:
        return motion_fk(motion)
    return motion.fk()


class SegmentChains:
    """The joints on the kinematic chains of ``body``'s segment carriers (fixed for a touch-up
    run), and :meth:`positions`: :func:`mocomp.audit.zmp.smoothed_segment_positions` on them."""

    def __init__(self, body, skeleton):
        need = np.zeros(skeleton.n_joints, bool)
        for c in set(int(j) for j in body.segment_joint):
            need[skeleton.chain(c)] = True
        idx = np.flatnonzero(need)                     # ascending: parents still precede children
        remap = np.full(skeleton.n_joints, -1)
        remap[idx] = np.arange(idx.size)
        par = np.asarray(skeleton.parents)[idx]
        self.idx = idx
        self.parents = np.where(par < 0, -1, remap[par]).astype(np.int64)
        self.offsets = np.ascontiguousarray(skeleton.offsets[idx], dtype=float)
        self.seg = remap[np.asarray(body.segment_joint)]
        self.local_coms = np.asarray(body.local_coms, float)

    def positions(self, motion, sigma: float | None) -> np.ndarray:
        """``(T, S, 3)`` m: the segment COMs of ``motion`` Gaussian-smoothed by ``sigma`` frames
        (:func:`mocomp.audit.zmp.smoothed_segment_positions`, the same arithmetic)."""
        root = gaussian_smooth(motion.root_positions, sigma, axis=0) if sigma else motion.root_positions
        rot = smooth_quaternions_fast(motion.rotations[:, self.idx], sigma) if sigma else motion.rotations[:, self.idx]
        if COMPILED:
            from ..edit._kernels import forward_kinematics as fk_nb

            P, Gr = fk_nb(self.parents, self.offsets, np.ascontiguousarray(root, dtype=float),
                          np.ascontiguousarray(rot, dtype=float))
        else:
            P, Gr = forward_kinematics(self.parents, self.offsets, root, rot)
        j = self.seg
        return P[:, j] + quat_apply(Gr[:, j], self.local_coms[None])


if COMPILED:
    import numba

    @numba.njit(cache=True, nogil=True)
    def _turn_local_nb(P, G, parents, comp, root, rotvec, C):
        """Per frame: S2 turned by ``rotvec`` ``(T, 3)`` about its components' centres ``C``
        ``(T, J, 3)`` (read at each S2 joint's pivot); returns the root's new position ``(T, 3)``
        and every joint's local rotation ``(T, J, 4)`` (``G_parent^-1 G_j`` of the turned global
        orientations). The turn is the axis-angle's unit quaternion and its matrix (Rodrigues)."""
        T = P.shape[0]
        J = P.shape[1]
        out_root = np.empty((T, 3))
        L = np.empty((T, J, 4))
        Gn = np.empty((J, 4))
        for t in range(T):
            rx = rotvec[t, 0]
            ry = rotvec[t, 1]
            rz = rotvec[t, 2]
            th = np.sqrt(rx * rx + ry * ry + rz * rz)
            if th > 0.0:
                s = np.sin(0.5 * th) / th
            else:
                s = 0.5
            qx = rx * s
            qy = ry * s
            qz = rz * s
            qw = np.cos(0.5 * th)
            for j in range(J):
                if comp[j] >= 0:
                    bx = G[t, j, 0]
                    by = G[t, j, 1]
                    bz = G[t, j, 2]
                    bw = G[t, j, 3]
                    Gn[j, 0] = qw * bx + qx * bw + qy * bz - qz * by
                    Gn[j, 1] = qw * by - qx * bz + qy * bw + qz * bx
                    Gn[j, 2] = qw * bz + qx * by - qy * bx + qz * bw
                    Gn[j, 3] = qw * bw - qx * bx - qy * by - qz * bz
                else:
                    for k in range(4):
                        Gn[j, k] = G[t, j, k]
            for k in range(3):
                out_root[t, k] = P[t, root, k]
            if comp[root] >= 0:                          # the root turned about its component's centre
                c = comp[root]
                vx = P[t, root, 0] - C[t, c, 0]
                vy = P[t, root, 1] - C[t, c, 1]
                vz = P[t, root, 2] - C[t, c, 2]
                tx = 2.0 * (qy * vz - qz * vy)
                ty = 2.0 * (qz * vx - qx * vz)
                tz = 2.0 * (qx * vy - qy * vx)
                out_root[t, 0] = C[t, c, 0] + vx + qw * tx + (qy * tz - qz * ty)
                out_root[t, 1] = C[t, c, 1] + vy + qw * ty + (qz * tx - qx * tz)
                out_root[t, 2] = C[t, c, 2] + vz + qw * tz + (qx * ty - qy * tx)
            for j in range(J):
                p = parents[j]
                if p < 0:
                    for k in range(4):
                        L[t, j, k] = Gn[j, k]
                    continue
                ax = -Gn[p, 0]
                ay = -Gn[p, 1]
                az = -Gn[p, 2]
                aw = Gn[p, 3]
                bx = Gn[j, 0]
                by = Gn[j, 1]
                bz = Gn[j, 2]
                bw = Gn[j, 3]
                L[t, j, 0] = aw * bx + ax * bw + ay * bz - az * by
                L[t, j, 1] = aw * by - ax * bz + ay * bw + az * bx
                L[t, j, 2] = aw * bz + ax * by - ay * bx + az * bw
                L[t, j, 3] = aw * bw - ax * bx - ay * by - az * bz
        return out_root, L


def turn_sets(P: np.ndarray, G: np.ndarray, sets, rotvec: np.ndarray, centre: np.ndarray):
    """``(root positions (T, 3), local rotations (T, J, 4))`` after S2 turned by ``rotvec``
    ``(T, 3)`` rad about ``centre`` ``(T, J, 3)`` (:func:`mocomp.touchup.linksets.rotate_sets`, then
    :func:`~mocomp.touchup.linksets.local_from_global`; S3's and S1's orientations are kept, so
    only the root's position and the rotations are needed). Compiled: one pass per frame; the
    numpy path builds the matrices with scipy (agreement to rounding, ~1e-15)."""
    root = int(np.flatnonzero(sets.parents < 0)[0])
    if COMPILED:
        return _turn_local_nb(np.ascontiguousarray(P, dtype=float), np.ascontiguousarray(G, dtype=float),
                              np.asarray(sets.parents, np.int64), np.asarray(sets.component, np.int64), root,
                              np.ascontiguousarray(rotvec, dtype=float), np.ascontiguousarray(centre, dtype=float))
    from scipy.spatial.transform import Rotation

    from .linksets import local_from_global, rotate_sets

    Pn, Gn = rotate_sets(P, G, sets, Rotation.from_rotvec(rotvec).as_matrix(), centre)
    return Pn[:, root], local_from_global(Gn, sets.parents)
