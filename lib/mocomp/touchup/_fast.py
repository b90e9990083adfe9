"""Touch-up's hot paths without numpy's per-call overhead (issue 16's speed goal).

On a 100-frame clip a forward kinematics pass in numpy (:func:`mocomp.core.kinematics.forward_kinematics`)
is ~1200 array calls over 20-30 joints and costs 1-1.5 ms, the arithmetic a few microseconds; the
touch-up loop runs 3-4 of them per iteration (the motion for eq. 6-7, the feet and the support
polygon, its Gaussian-smoothed copy for eq. 4, the results of the footplant steps). Here they run
compiled (:func:`mocomp.core._compiled.forward_kinematics`: the same operations in the same order,
bit-identical results) and fill the motion's FK cache, so that the callees that ask ``motion.fk()``
(:func:`mocomp.ops.enforce_footplants`, :func:`mocomp.dynamics.com.center_of_mass`) find it done.

``COMPILED`` switches the compiled paths off (``MOCOMP_NO_NUMBA=1``, numba missing, or a test that
sets it to ``False``): every function then runs the numpy code it replaces, which is the reference
``tests/test_touchup_speed.py`` compares the compiled paths with.
"""
from __future__ import annotations

import numpy as np


from ..core import _compiled as _core_compiled

COMPILED = _core_compiled.AVAILABLE                     # the project's one numba switch (MOCOMP_NO_NUMBA)
if COMPILED:
    import numba

    from ..core._compiled import fk_pose
    from ..core._compiled import forward_kinematics as fk_nb
    from ..core._compiled import qexp, qlog, qmul, qrot

__all__ = ["COMPILED", "fk", "SegmentChains", "turn_sets", "gaussian_weights", "polygon_distance_and_target",
           "running_products"]


def gaussian_weights(sigma: float, truncate: float = 4.0) -> np.ndarray:
    """The weights :func:`scipy.ndimage.gaussian_filter1d` correlates with (radius
    ``int(truncate * sigma + 0.5)``, normalised to sum 1; symmetric)."""
    radius = int(truncate * float(sigma) + 0.5)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (float(sigma) * float(sigma)) * x ** 2)
    return phi / phi.sum()


def fk(motion):
    """``motion.fk()``, compiled when :data:`COMPILED` (and then cached on ``motion``)."""
    return motion.fk()                                  # core's FK: compiled once numba is loaded


if COMPILED:
    @numba.njit(cache=True, nogil=True)
    def _correlate_nearest(pad, w, out):
        """``out[i] = sum_k w[k] x[clip(i + k - r)]`` for symmetric ``w`` (radius ``r``) of the line
        ``x`` given padded with its end values (``pad`` ``(T + 2r,)``, ``mode="nearest"``), in the
        order of scipy's ``correlate1d`` for symmetric weights: ``x_i w_0 + sum_{j=r..1} (x_{i-j} +
        x_{i+j}) w_j``."""
        r = (w.shape[0] - 1) // 2
        n = out.shape[0]
        # tap by tap over the whole line (the inner loop runs over contiguous samples: vectorised), each
        # sample's sum still in scipy's order, so the same numbers as one sample at a time
        w0 = w[r]
        for i in range(n):
            out[i] = pad[i + r] * w0
        for j in range(r, 0, -1):
            wj = w[r + j]
            for i in range(n):
                out[i] += (pad[i + r - j] + pad[i + r + j]) * wj

    @numba.njit(cache=True, nogil=True)
    def _fill_pad(pad, r, T):
        """The ends of a padded line: ``r`` copies of its first and last samples."""
        for i in range(r):
            pad[i] = pad[r]
            pad[r + T + i] = pad[r + T - 1]

    @numba.njit(cache=True, nogil=True)
    def _central(x, t, out):
        """``np.gradient(x, t, axis=0, edge_order=1)`` of ``(T, S, 3)`` (numpy's non-uniform formula)."""
        T = x.shape[0]
        for s in range(x.shape[1]):
            for k in range(3):
                out[0, s, k] = (x[1, s, k] - x[0, s, k]) / (t[1] - t[0])
                out[T - 1, s, k] = (x[T - 1, s, k] - x[T - 2, s, k]) / (t[T - 1] - t[T - 2])
        for i in range(1, T - 1):
            dx1 = t[i] - t[i - 1]
            dx2 = t[i + 1] - t[i]
            a = -(dx2) / (dx1 * (dx1 + dx2))
            b = (dx2 - dx1) / (dx1 * dx2)
            c = dx1 / (dx2 * (dx1 + dx2))
            for s in range(x.shape[1]):
                for k in range(3):
                    out[i, s, k] = a * x[i - 1, s, k] + b * x[i, s, k] + c * x[i + 1, s, k]

    @numba.njit(cache=True, nogil=True)
    def _zmp_inputs_nb(root, rot, idx, parents, offsets, seg, local_coms, w, t):
        """Segment COMs ``(T, S, 3)`` of the Gaussian-smoothed chains ``idx`` of ``rot`` (``w``: the
        weights; one weight: no smoothing) and their second central difference on the times ``t``
        (:func:`_zmp_inputs_ws` with a workspace of its own)."""
        T = rot.shape[0]
        J = idx.shape[0]
        r = (w.shape[0] - 1) // 2
        return _zmp_inputs_ws(root, rot, idx, parents, offsets, seg, local_coms, w, t, np.empty((T, J, 4)),
                              np.empty((4, T + 2 * r)), np.empty((4, T)), np.empty((T, seg.shape[0], 3)))

    @numba.njit(cache=True, nogil=True)
    def _zmp_inputs_ws(root, rot, idx, parents, offsets, seg, local_coms, w, t, q, lines, outs, v):
        """:func:`_zmp_inputs_nb` on the caller's scratch arrays (``q (T, J, 4)``, ``lines (4, T + 2r)``,
        ``outs (4, T)``, ``v (T, S, 3)``; on 10,000 frames allocating and first touching them anew on
        every call, ~20 MB, was half the time). Per joint: the hemisphere-continuous components, each
        filtered (scipy's order, ``mode="nearest"``), renormalised."""
        T = rot.shape[0]
        J = idx.shape[0]
        smooth = w.shape[0] > 1
        r = (w.shape[0] - 1) // 2
        line = np.empty(T + 2 * r)
        out = np.empty(T)
        for j in range(J):
            jj = idx[j]
            sign = 1.0
            for f in range(T):
                if f > 0:
                    d = (rot[f, jj, 0] * rot[f - 1, jj, 0] + rot[f, jj, 1] * rot[f - 1, jj, 1]
                         + rot[f, jj, 2] * rot[f - 1, jj, 2] + rot[f, jj, 3] * rot[f - 1, jj, 3])
                    if d < 0.0:
                        sign = -sign
                for k in range(4):
                    if smooth:
                        lines[k, r + f] = rot[f, jj, k] * sign
                    else:
                        q[f, j, k] = rot[f, jj, k] * sign
            if smooth:
                for k in range(4):
                    _fill_pad(lines[k], r, T)
                    _correlate_nearest(lines[k], w, outs[k])
                for f in range(T):
                    n = np.sqrt(outs[0, f] * outs[0, f] + outs[1, f] * outs[1, f] + outs[2, f] * outs[2, f]
                                + outs[3, f] * outs[3, f])
                    for k in range(4):
                        q[f, j, k] = outs[k, f] / n
        rp = np.empty((T, 3))
        for k in range(3):
            if smooth:
                for f in range(T):
                    line[r + f] = root[f, k]
                _fill_pad(line, r, T)
                _correlate_nearest(line, w, out)
                for f in range(T):
                    rp[f, k] = out[f]
            else:
                for f in range(T):
                    rp[f, k] = root[f, k]
        # the chains' FK frame by frame into one pose's scratch (core's fk_pose, as its forward_kinematics
        # does per frame: the same numbers), the segment COMs read off it: no (T, J) arrays to allocate
        S = seg.shape[0]
        r = np.empty((T, S, 3))
        Gp = np.empty((J, 4))
        Pp = np.empty((J, 3))
        for f in range(T):
            fk_pose(parents, offsets, q, f, rp[f, 0], rp[f, 1], rp[f, 2], Gp, Pp)
            for s in range(S):
                j = seg[s]
                dx, dy, dz = qrot(Gp[j, 0], Gp[j, 1], Gp[j, 2], Gp[j, 3],
                                  local_coms[s, 0], local_coms[s, 1], local_coms[s, 2])
                r[f, s, 0] = Pp[j, 0] + dx
                r[f, s, 1] = Pp[j, 1] + dy
                r[f, s, 2] = Pp[j, 2] + dz
        a = np.empty_like(r)
        _central(r, t, v)
        _central(v, t, a)
        return r, a


if COMPILED:
    @numba.njit(cache=True, nogil=True)
    def _polygon_nb(p, pts, mask, rel_eps):
        """Per frame the signed distance of ``p`` ``(T, 2)`` to the convex hull of the masked
        ``pts`` ``(T, K, 2)`` and the nearest point of the segments between masked points: the
        arithmetic of :func:`mocomp.dynamics.zmp._signed_distance_frames` and
        :func:`mocomp.dynamics.zmp.nearest_on_polygon` (pairs in ``triu_indices`` order), one frame
        at a time."""
        T = p.shape[0]
        K = pts.shape[1]
        dist_out = np.full(T, np.nan)
        near_out = np.full((T, 2), np.nan)
        for f in range(T):
            px = p[f, 0]
            py = p[f, 1]
            fin = np.isfinite(px) and np.isfinite(py)
            anyk = False
            lo0 = np.inf
            lo1 = np.inf
            hi0 = -np.inf
            hi1 = -np.inf
            for k in range(K):
                if mask[f, k]:
                    anyk = True
                    lo0 = min(lo0, pts[f, k, 0])
                    hi0 = max(hi0, pts[f, k, 0])
                    lo1 = min(lo1, pts[f, k, 1])
                    hi1 = max(hi1, pts[f, k, 1])
            if not anyk:
                continue
            ext = max(hi0 - lo0, hi1 - lo1)
            eps = rel_eps * ext ** 2
            best = np.inf                        # nearest_on_polygon: NaN for a non-finite p
            nonflat = False
            inside = True
            d_all = np.inf
            d_edge = np.inf
            for i in range(K):
                for j in range(i, K):
                    if not (mask[f, i] and mask[f, j]):
                        continue
                    ax = pts[f, i, 0]
                    ay = pts[f, i, 1]
                    bx = pts[f, j, 0] - ax
                    by = pts[f, j, 1] - ay
                    den = bx * bx + by * by
                    qx = px - ax
                    qy = py - ay
                    tt = 0.0
                    if den > 0:
                        tt = min(max((qx * bx + qy * by) / den, 0.0), 1.0)
                    # the segment's nearest point, its distance as nearest_on_polygon computes it
                    nx = ax + tt * bx
                    ny = ay + tt * by
                    dn = np.sqrt((px - nx) * (px - nx) + (py - ny) * (py - ny))
                    if np.isfinite(dn) and dn < best:
                        best = dn
                        near_out[f, 0] = nx
                        near_out[f, 1] = ny
                    if not fin:
                        continue
                    # the signed distance's terms, as _signed_distance_frames computes them
                    ex = qx - tt * bx
                    ey = qy - tt * by
                    d = np.sqrt(ex * ex + ey * ey)
                    pos = False
                    neg = False
                    for k in range(K):
                        if mask[f, k]:
                            cr = bx * (pts[f, k, 1] - ay) - by * (pts[f, k, 0] - ax)
                            if cr > eps:
                                pos = True
                            elif cr < -eps:
                                neg = True
                    if pos or neg:
                        nonflat = True
                    if d < d_all:
                        d_all = d
                    if i < j and den > 0 and not (pos and neg):
                        if d < d_edge:
                            d_edge = d
                        side = 1.0 if pos else -1.0
                        if not ((bx * qy - by * qx) * side >= 0):
                            inside = False
            if not fin:
                continue
            if (not nonflat) or eps == 0:
                dist_out[f] = d_all
            elif inside:
                dist_out[f] = -d_edge
            else:
                dist_out[f] = d_edge
        return dist_out, near_out


if COMPILED:
    @numba.njit(cache=True, nogil=True)
    def _zmp_state_nb(root, rot, idx, parents, offsets, seg, local_coms, w, t, masses, y0, g, min_force, cpts, mask,
                      rel_eps, q, lines, outs, v):
        """:func:`mocomp.touchup.zmp.zmp_state` in one call: :func:`_zmp_inputs_nb`, eq. 4 on each frame's
        floor ``y0`` (:func:`mocomp.dynamics.zmp.zmp_of_point_masses` with the positions taken relative to
        it, sums in segment order), the polygon distance and eq. 7's target (:func:`_polygon_nb`).
        Returns ``(r, a, Z, distance, target)``."""
        r, a = _zmp_inputs_ws(root, rot, idx, parents, offsets, seg, local_coms, w, t, q, lines, outs, v)
        T = r.shape[0]
        S = r.shape[1]
        K = cpts.shape[1]
        Z = np.empty((T, 3))
        p2 = np.empty((T, 2))
        for f in range(T):
            den = 0.0
            nx = 0.0
            nx2 = 0.0
            nz = 0.0
            nz2 = 0.0
            for s in range(S):
                fy = a[f, s, 1] + g
                ry = (r[f, s, 1] - y0[f]) - 0.0
                den += masses[s] * fy
                nx += masses[s] * fy * r[f, s, 0]
                nx2 += masses[s] * a[f, s, 0] * ry
                nz += masses[s] * fy * r[f, s, 2]
                nz2 += masses[s] * a[f, s, 2] * ry
            if den >= min_force:
                Z[f, 0] = (nx - nx2) / den
                Z[f, 1] = 0.0 + y0[f]
                Z[f, 2] = (nz - nz2) / den
            else:
                Z[f, 0] = np.nan
                Z[f, 1] = np.nan
                Z[f, 2] = np.nan
            p2[f, 0] = Z[f, 0]
            p2[f, 1] = Z[f, 2]
        c2 = np.empty((T, K, 2))
        for f in range(T):
            for k in range(K):
                c2[f, k, 0] = cpts[f, k, 0]
                c2[f, k, 1] = cpts[f, k, 2]
        d, near = _polygon_nb(p2, c2, mask, rel_eps)
        tgt = Z.copy()
        for f in range(T):
            if np.isfinite(d[f]) and d[f] > 0:
                tgt[f, 0] = near[f, 0]
                tgt[f, 2] = near[f, 1]
        return r, a, Z, d, tgt


def polygon_distance_and_target(zmp: np.ndarray, contact_points: np.ndarray, mask: np.ndarray):
    """``(distance (T,), target (T, 3))``: the ZMP's signed distance to the support polygon
    (:func:`mocomp.dynamics.zmp.support_polygon_distance`) and, where it is outside, its nearest
    point of the polygon (:func:`mocomp.touchup.zmp.project_to_polygon`; the ZMP itself
    elsewhere). Compiled: one pass per frame, the same arithmetic."""
    from ..dynamics.zmp import nearest_on_polygon, support_polygon_distance

    mask = np.asarray(mask, bool)
    if COMPILED:
        c = np.asarray(contact_points, float)
        d, near = _polygon_nb(np.ascontiguousarray(zmp[:, [0, 2]], dtype=float),
                              np.ascontiguousarray(c[..., [0, 2]]), np.ascontiguousarray(mask), 1e-10)
    else:
        d = support_polygon_distance(zmp, contact_points, mask)
        near = None
    tgt = np.array(zmp)
    out = np.isfinite(d) & (np.nan_to_num(d) > 0)
    if out.any():
        pr = near[out] if near is not None else nearest_on_polygon(
            zmp[out][:, [0, 2]], np.asarray(contact_points)[out][..., [0, 2]], mask[out])
        tgt[out, 0], tgt[out, 2] = pr[:, 0], pr[:, 1]
    return d, tgt


class SegmentChains:
    """The joints on the kinematic chains of ``body``'s segment carriers (fixed for a touch-up
    run; the set-up of :func:`mocomp.audit.zmp.smoothed_segment_positions`, kept here once so that
    the compiled :meth:`positions_and_accelerations` gets its arrays without redoing it per call),
    and :meth:`positions`, which is the audit's function."""

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
        self.body = body
        self._idx64, self._seg64 = np.asarray(idx, np.int64), np.asarray(self.seg, np.int64)
        self._masses = np.ascontiguousarray(body.masses, dtype=float)
        self._weights, self._ws = {}, {}

    def positions_and_accelerations(self, motion, sigma: float | None) -> tuple[np.ndarray, np.ndarray]:
        """``(r, a)`` ``(T, S, 3)`` each: :meth:`positions` and their second central difference on
        the frame times (:func:`mocomp.dynamics.derivatives.second_difference`, ``edge_order=1``).
        Compiled: the hemisphere flips, the Gaussian (scipy's correlation order, ``mode="nearest"``),
        the renormalisation, the chains' FK, the segment COMs and the differences in one call,
        equal to the numpy path to rounding (~1e-15 m, ~1e-12 m/s^2)."""
        if not COMPILED:
            from ..dynamics.derivatives import second_difference

            r = self.positions(motion, sigma)
            return r, second_difference(r, motion.times)
        w = gaussian_weights(sigma) if sigma else np.ones(1)
        return _zmp_inputs_nb(np.ascontiguousarray(motion.root_positions, dtype=float),
                              np.ascontiguousarray(motion.rotations, dtype=float), np.asarray(self.idx, np.int64),
                              self.parents,
                              self.offsets, np.asarray(self.seg, np.int64), self.local_coms, w,
                              np.ascontiguousarray(motion.times, dtype=float))

    def zmp_state(self, motion, sigma: float | None, y0: np.ndarray, g: float, min_force: float,
                  contact_points: np.ndarray, mask: np.ndarray):
        """``(r, a, Z, distance, target)`` of :func:`mocomp.touchup.zmp.zmp_state` in one compiled call
        (:func:`_zmp_state_nb`; only when :data:`COMPILED`): equal to the numpy steps to rounding."""
        w = self._weights.get(sigma)
        if w is None:
            w = self._weights[sigma] = gaussian_weights(sigma) if sigma else np.ones(1)
        return _zmp_state_nb(np.ascontiguousarray(motion.root_positions, dtype=float),
                             np.ascontiguousarray(motion.rotations, dtype=float), self._idx64, self.parents,
                             self.offsets, self._seg64, self.local_coms, w,
                             np.ascontiguousarray(motion.times, dtype=float), self._masses,
                             np.ascontiguousarray(y0, dtype=float), float(g), float(min_force),
                             np.ascontiguousarray(contact_points, dtype=float), np.ascontiguousarray(mask, dtype=np.bool_),
                             1e-10, *self._workspace(motion.n_frames, w.shape[0]))

    def _workspace(self, T: int, taps: int):
        """The compiled ZMP state's scratch arrays for ``T`` frames and a ``taps``-sample Gaussian, kept
        between calls (a touch-up run asks for the same sizes 13-25 times)."""
        key = (T, taps)
        ws = self._ws.get(key)
        if ws is None:
            r = (taps - 1) // 2
            ws = self._ws[key] = (np.empty((T, self.idx.size, 4)), np.empty((4, T + 2 * r)), np.empty((4, T)),
                                  np.empty((T, len(self.seg), 3)))
        return ws

    def positions(self, motion, sigma: float | None) -> np.ndarray:
        """``(T, S, 3)`` m: the segment COMs of ``motion`` Gaussian-smoothed by ``sigma`` frames --
        :func:`mocomp.audit.zmp.smoothed_segment_positions` itself (the reference the compiled
        :meth:`positions_and_accelerations` is tested against; not a copy of it)."""
        from ..audit.zmp import smoothed_segment_positions

        return smoothed_segment_positions(self.body, motion, sigma)


if COMPILED:
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
            qx, qy, qz, qw = qexp(rotvec[t, 0], rotvec[t, 1], rotvec[t, 2])
            for j in range(J):
                if comp[j] >= 0:
                    Gn[j, 0], Gn[j, 1], Gn[j, 2], Gn[j, 3] = qmul(qx, qy, qz, qw, G[t, j, 0], G[t, j, 1], G[t, j, 2],
                                                                  G[t, j, 3])
                else:
                    for k in range(4):
                        Gn[j, k] = G[t, j, k]
            for k in range(3):
                out_root[t, k] = P[t, root, k]
            if comp[root] >= 0:                          # the root turned about its component's centre
                c = comp[root]
                dx, dy, dz = qrot(qx, qy, qz, qw, P[t, root, 0] - C[t, c, 0], P[t, root, 1] - C[t, c, 1],
                                  P[t, root, 2] - C[t, c, 2])
                out_root[t, 0] = C[t, c, 0] + dx
                out_root[t, 1] = C[t, c, 1] + dy
                out_root[t, 2] = C[t, c, 2] + dz
            for j in range(J):
                p = parents[j]
                if p < 0:
                    for k in range(4):
                        L[t, j, k] = Gn[j, k]
                    continue
                L[t, j, 0], L[t, j, 1], L[t, j, 2], L[t, j, 3] = qmul(-Gn[p, 0], -Gn[p, 1], -Gn[p, 2], Gn[p, 3],
                                                                      Gn[j, 0], Gn[j, 1], Gn[j, 2], Gn[j, 3])
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


if COMPILED:
    @numba.njit(cache=True, nogil=True)
    def _running_products_nb(inc):
        n = inc.shape[0] + 1
        acc = np.zeros((n, 4))
        acc[0, 3] = 1.0
        for i in range(1, n):
            acc[i, 0], acc[i, 1], acc[i, 2], acc[i, 3] = qmul(inc[i - 1, 0], inc[i - 1, 1], inc[i - 1, 2], inc[i - 1, 3],
                                                              acc[i - 1, 0], acc[i - 1, 1], acc[i - 1, 2], acc[i - 1, 3])
        return acc


def running_products(inc: np.ndarray) -> np.ndarray:
    """``(n + 1, 4)``: the identity, then ``inc[i - 1] acc[i - 1]`` for the ``(n, 4)`` per-frame
    increments ``inc`` (eq. 9's turns accumulated frame by frame from the take-off,
    :func:`mocomp.touchup.flight.flight_momentum_adjustment`). Compiled: one loop; the numpy path
    is :func:`mocomp.core.rotations.quat_multiply` frame by frame (the same products)."""
    inc = np.ascontiguousarray(inc, dtype=float)
    if COMPILED:
        return _running_products_nb(inc)
    from ..core.rotations import quat_multiply

    acc = np.zeros((inc.shape[0] + 1, 4))
    acc[0, 3] = 1.0
    for i in range(1, acc.shape[0]):
        acc[i] = quat_multiply(inc[i - 1], acc[i - 1])
    return acc


if COMPILED:
    from ..ops._kernels import _two_bone_ik_rows

    @numba.njit(cache=True, nogil=True)
    def _lift_legs_nb(P, G, rot, pts, held, up, touching, ks, chains, hps, tol, w, margin, lifted):
        """:func:`mocomp.touchup.iterate.lift_feet`'s per-leg loop (its numpy lines in order, frame by
        frame): ``rot`` changed in place on the legs' lifted frames, ``lifted (L, T)`` set."""
        T = P.shape[0]
        L = chains.shape[0]
        r = (w.shape[0] - 1) // 2
        down = np.empty(T)
        sm = np.empty(T)
        line = np.empty(T + 2 * r)
        dy = np.empty(T)
        need = np.empty(T)
        idx = np.empty(T, np.int64)
        tgt = np.empty((T, 3))
        end = np.empty((T, 4))
        axis = np.zeros((T, 3))
        out = np.empty((T, 3, 4))
        miss = np.empty(T)
        for i in range(T):
            axis[i, 0] = 1.0
        for li in range(L):
            ka, kt = ks[li, 0], ks[li, 1]
            a = chains[li, 2]
            low = False
            for t in range(T):
                dh = max(held[t, ka], held[t, kt])
                down[t] = min(dh, 0.0) if np.isfinite(dh) else 0.0
                if down[t] < -tol:
                    low = True
            if low and r > 0:
                for i in range(T + 2 * r):
                    line[i] = down[min(max(i - r, 0), T - 1)]
                _correlate_nearest(line, w, sm)
                for t in range(T):
                    down[t] = sm[t]
            n = 0
            for t in range(T):
                dh = max(held[t, ka], held[t, kt])
                du = max(up[t, ka], up[t, kt])
                v = max(max(down[t], dh if dh > 0 else -np.inf), du)
                if not np.isfinite(v):
                    v = down[t]
                nd = 0.0
                if touching[t, ka] and touching[t, kt]:
                    v = held[t, ka]
                    nd = held[t, kt] - v
                dy[t] = v
                need[t] = nd
                lifted[li, t] = abs(v) > tol or abs(nd) > tol
                if not lifted[li, t]:
                    continue
                Ax, Ay, Az = pts[t, ka, 0], pts[t, ka, 1], pts[t, ka, 2]
                vx, vy, vz = pts[t, kt, 0] - Ax, pts[t, kt, 1] - Ay, pts[t, kt, 2] - Az
                h = np.sqrt(vx * vx + vz * vz)
                nn = np.sqrt(vx * vx + vy * vy + vz * vz)
                beta = np.arctan2(vy, h)
                phi = np.arcsin(min(max((vy + nd) / max(nn, 1e-9), -1.0), 1.0)) - beta
                hh = max(h, 1e-9)
                qx, qy, qz, qw = qexp(-vz / hh * phi, 0.0 / hh * phi, vx / hh * phi)
                end[n, 0], end[n, 1], end[n, 2], end[n, 3] = qmul(qx, qy, qz, qw, G[t, a, 0], G[t, a, 1], G[t, a, 2],
                                                                  G[t, a, 3])
                ex, ey, ez = qrot(qx, qy, qz, qw, Ax - P[t, a, 0], Ay - P[t, a, 1], Az - P[t, a, 2])
                tgt[n, 0] = Ax - ex
                tgt[n, 1] = (Ay + v) - ey
                tgt[n, 2] = Az - ez
                idx[n] = t
                n += 1
            if n == 0:
                continue
            _two_bone_ik_rows(P, G, rot, idx[:n], hps[li], chains[li, 0], chains[li, 1], a, tgt[:n], end[:n],
                              axis[:n], 0.0, margin, out[:n], miss[:n])
            for i in range(n):
                t = idx[i]
                for c in range(3):
                    j = chains[li, c]
                    for k in range(4):
                        rot[t, j, k] = out[i, c, k]


if COMPILED:
    @numba.njit(cache=True, nogil=True)
    def _held_up_nb(pts, ref, rest, airborne, touching, held, up):
        """:func:`mocomp.touchup.iterate.lift_feet`'s ``held`` and ``up`` ``(T, K)``: a touching point's
        height still to go to its input height (``-inf`` elsewhere); a point's height below its floor (its
        resting level or input height, the lower; the input height in flight), ``-inf`` where none."""
        for t in range(pts.shape[0]):
            for k in range(pts.shape[1]):
                ry = ref[t, k, 1]
                fl = ry if airborne[t] else min(rest[k], ry)
                free = fl - pts[t, k, 1]
                held[t, k] = ry - pts[t, k, 1] if touching[t, k] else -np.inf
                up[t, k] = free if free > 0 else -np.inf


def lift_legs(P, G, rot, pts, reference_points, rest, airborne, touching, ks, chains, hps, tol, sigma, margin):
    """Compiled :func:`mocomp.touchup.iterate.lift_feet` from its ``held``/``up`` heights on
    (``rot`` changed in place); returns the lifted frames ``(L, T)`` bool."""
    T = P.shape[0]
    held, up = np.empty(pts.shape[:2]), np.empty(pts.shape[:2])
    _held_up_nb(np.ascontiguousarray(pts, dtype=float), np.ascontiguousarray(reference_points, dtype=float),
                np.ascontiguousarray(rest, dtype=float),
                np.zeros(T, np.bool_) if airborne is None else np.ascontiguousarray(airborne, dtype=np.bool_),
                np.ascontiguousarray(touching, dtype=np.bool_), held, up)
    lifted = np.zeros((len(chains), T), np.bool_)
    _lift_legs_nb(P, G, rot, np.ascontiguousarray(pts, dtype=float), held, up,
                  np.ascontiguousarray(touching, dtype=np.bool_),
                  np.asarray(ks, np.int64), np.asarray(chains, np.int64), np.asarray(hps, np.int64), float(tol),
                  gaussian_weights(sigma) if sigma and sigma > 0 else np.ones(1), float(margin), lifted)
    return lifted


if COMPILED:
    @numba.njit(cache=True, nogil=True)
    def _apply_hold_nb(cur, held, dref, w, use_w, half2, out):
        """``out``: ``cur`` displaced by ``(log(cur^-1 held) - dref) w`` (the map of ``cur`` to ``held``
        with joints turned by no more than the negligible angle left out, as
        :meth:`mocomp.ops.DisplacementMap.between`; then :func:`mocomp.ops.apply_displacement`), on
        the joints either map turns."""
        T, J = cur.shape[0], cur.shape[1]
        turned = np.zeros(J, np.bool_)
        for t in range(T):
            for j in range(J):
                if turned[j] or (cur[t, j, 0] == held[t, j, 0] and cur[t, j, 1] == held[t, j, 1]
                                 and cur[t, j, 2] == held[t, j, 2] and cur[t, j, 3] == held[t, j, 3]):
                    continue
                x, y, z, _ = qmul(-cur[t, j, 0], -cur[t, j, 1], -cur[t, j, 2], cur[t, j, 3],
                                  held[t, j, 0], held[t, j, 1], held[t, j, 2], held[t, j, 3])
                if x * x + y * y + z * z > half2:
                    turned[j] = True
        ref = np.zeros(J, np.bool_)
        for t in range(T):
            for j in range(J):
                if dref[t, j, 0] != 0.0 or dref[t, j, 1] != 0.0 or dref[t, j, 2] != 0.0:
                    ref[j] = True
        for j in range(J):
            if not (turned[j] or ref[j]):
                continue
            for t in range(T):
                v0, v1, v2 = 0.0, 0.0, 0.0
                if turned[j]:
                    x, y, z, ww = qmul(-cur[t, j, 0], -cur[t, j, 1], -cur[t, j, 2], cur[t, j, 3],
                                       held[t, j, 0], held[t, j, 1], held[t, j, 2], held[t, j, 3])
                    v0, v1, v2 = qlog(x, y, z, ww)
                v0 = v0 - dref[t, j, 0]
                v1 = v1 - dref[t, j, 1]
                v2 = v2 - dref[t, j, 2]
                if use_w:
                    v0 *= w[t]
                    v1 *= w[t]
                    v2 *= w[t]
                ex, ey, ez, ew = qexp(v0, v1, v2)
                out[t, j, 0], out[t, j, 1], out[t, j, 2], out[t, j, 3] = qmul(cur[t, j, 0], cur[t, j, 1], cur[t, j, 2],
                                                                              cur[t, j, 3], ex, ey, ez, ew)


def apply_hold(cur_rot, held_rot, dref_rot, weight, negligible: float) -> np.ndarray:
    """``(T, J, 4)``: the local rotations of touch-up's footplant step (:func:`mocomp.touchup.touchup`'s
    ``post``: the hold's map less the input's, weighted per frame by ``weight`` (``None``: 1), added)
    in one compiled call; equal to the maps' numpy/compiled steps to rounding."""
    cur = np.ascontiguousarray(cur_rot, dtype=float)
    out = cur.copy()
    half = np.sin(0.5 * negligible)
    _apply_hold_nb(cur, np.ascontiguousarray(held_rot, dtype=float), np.ascontiguousarray(dref_rot, dtype=float),
                   np.ones(1) if weight is None else np.ascontiguousarray(weight, dtype=float), weight is not None,
                   half * half, out)
    return out
