"""Compiled (numba) versions of the run-time stage's per-frame loops.

* :func:`slerp_rows_nb` / :func:`slerp_gather_nb` -- the retiming interpolation of
  :func:`mocomp.core.rotations.slerp` with ``nlerp_below`` (normalised lerp for neighbours closer than
  ``nlerp_below``, exact slerp otherwise); the gather variant reads rows ``i0`` and ``i0 + 1``
  in place and reports that every output is a finite unit quaternion (so the new ``Motion``
  need not be validated again);
* :func:`com_relative_nb` -- :meth:`mocomp.flips.reposition.ComEvaluator.relative`, the
  mass-weighted forward kinematics collapsed to one vector per joint;
* :func:`landing_search_nb` -- the candidate pairs of :func:`mocomp.flips.sequence.find_landing`
  and their eq. 5.12-5.13 distances (no (G, U) arrays built; the choice is made by the caller);
  :func:`frame_distance_nb`;
* :func:`landing_seam_nb` -- the landing seam smoothing (eq. 5.14) of
  :func:`mocomp.flips.multiflip.multiflip`; :func:`turn_roots_nb` -- each frame's rotation about ``L``;
  :func:`reposition_nb` -- the root positions of the retimed frames (interpolation, and on the
  flight the parabola minus the COM offset, eq. 5.15/5.17).

They give the numpy versions' results to rounding (tested, most bit for bit); they exist because
the numpy versions are dominated by per-call overhead on small arrays (a few thousand
quaternions, or a single frame's 31 joints). Their quaternion algebra is the core kernel's
inline helpers (:mod:`mocomp.core._compiled`: ``qmul``, ``qrot``, ``qpow``, ``qangle``,
``slerp4``); only the method's own loops live here. Compiled code is cached on disk
(``cache=True``) and loaded by :func:`warmup` during pre-processing. ``AVAILABLE`` (numba
importable and ``MOCOMP_NO_NUMBA`` unset, decided in :mod:`mocomp.core._compiled`) False: the
run-time stage takes its numpy paths (the retiming slerp, the root turn, the COM evaluator,
the landing search), and the landing-seam kernels, which have no numpy twin outside the tests,
run as plain Python on their few frames.
"""
from __future__ import annotations

import math

import numpy as np

from ..core._compiled import AVAILABLE, njit, qangle, qmul, qpow, qrot, slerp4

__all__ = ["AVAILABLE", "writable", "slerp_rows_nb", "com_relative_nb", "frame_distance_nb", "slerp_gather_nb",
           "landing_search_nb", "landing_seam_nb",
           "turn_roots_nb", "reposition_nb", "warmup"]

@njit(inline="always")
def _slerp1(q0, n0, q1, n1, j, t, cos_near, out, n):
    """Row ``n`` joint ``j`` of the retiming slerp: ``q0[n0, j] -> q1[n1, j]`` at weight ``t``
    into ``out[n, j]`` (core's :func:`~mocomp.core._compiled.slerp4`, normalised lerp for pairs
    closer than ``cos_near``); returns the squared norm before normalisation (finite and > 0 for
    a valid unit result)."""
    out[n, j, 0], out[n, j, 1], out[n, j, 2], out[n, j, 3], nn = slerp4(
        q0[n0, j, 0], q0[n0, j, 1], q0[n0, j, 2], q0[n0, j, 3],
        q1[n1, j, 0], q1[n1, j, 1], q1[n1, j, 2], q1[n1, j, 3], t, cos_near)
    return nn


@njit
def _slerp_rows(q0, q1, a, cos_near, out):
    N, J, _ = q0.shape
    for n in range(N):
        t = a[n]
        for j in range(J):
            _slerp1(q0, n, q1, n, j, t, cos_near, out, n)
    return out

@njit
def _slerp_gather(rot, i0, a, cos_near, out):
    """``out[n] = slerp(rot[i0[n]], rot[i0[n] + 1], a[n])`` without gathering the two rows first;
    returns whether every result is a finite unit quaternion (its pre-normalisation norm finite
    and positive), so the caller need not check again."""
    N = i0.shape[0]
    J = rot.shape[1]
    ok = True
    for n in range(N):
        t = a[n]
        k = i0[n]
        for j in range(J):
            nn = _slerp1(rot, k, rot, k + 1, j, t, cos_near, out, n)
            if not (nn > 0.0 and nn < math.inf):
                ok = False
    return ok

@njit
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
                G[i, 0], G[i, 1], G[i, 2], G[i, 3] = qmul(G[p, 0], G[p, 1], G[p, 2], G[p, 3], q[t, jj, 0],
                                                          q[t, jj, 1], q[t, jj, 2], q[t, jj, 3])
            dx, dy, dz = qrot(G[i, 0], G[i, 1], G[i, 2], G[i, 3], u[i, 0], u[i, 1], u[i, 2])
            sx += dx
            sy += dy
            sz += dz
        out[t, 0] = sx
        out[t, 1] = sy
        out[t, 2] = sz
    return out


@njit
def _reposition(rp_seq, i0, al, tw, f0, f1, w_to, div, c0, vel, a_y, rot_out, joints, parent, u, out):
    """Root positions of the retimed frames: linear interpolation of the sequence's root
    positions ``rp_seq`` at ``i0 + al``, then on output frames ``f0 .. f1-1`` the position that
    puts the COM on the eq. 5.15/5.17 parabola (``c0 + t vel``, ``+ a_y t^2`` vertically, at
    ``t = (tw - w_to) / div``) minus the COM offset of ``rot_out``; the same operations in the
    same order as the numpy version in :func:`mocomp.flips.multiflip.multiflip`. Returns whether
    every position is finite."""
    N = i0.shape[0]
    for n in range(N):
        k = i0[n]
        t = al[n]
        for c in range(3):
            a = rp_seq[k, c]
            out[n, c] = a + t * (rp_seq[k + 1, c] - a)
    rel = _com_relative(rot_out[f0:f1], joints, parent, u, np.empty((f1 - f0, 3)))
    for n in range(f0, f1):
        t = (tw[n] - w_to) / div
        x = c0[0] + t * vel[0]
        y = c0[1] + t * vel[1]
        z = c0[2] + t * vel[2]
        y += a_y * t * t
        r = n - f0
        out[n, 0] = x - rel[r, 0]
        out[n, 1] = y - rel[r, 1]
        out[n, 2] = z - rel[r, 2]
    ok = True
    for n in range(N):
        for c in range(3):
            v = out[n, c]
            if not (v - v == 0.0):
                ok = False
    return ok


def reposition_nb(rp_seq, i0, al, tw, f0, f1, w_to, div, traj, rot_out, com_eval):
    """Compiled root positions of the run-time stage (see ``_reposition``): ``(out (N, 3), finite)``."""
    out = np.empty((i0.shape[0], 3))
    ok = _reposition(rp_seq, i0, al, tw, int(f0), int(f1), float(w_to), float(div), writable(traj.c0),
                     writable(traj.velocity), float(traj.a_y), rot_out, com_eval._joints64, com_eval._parent_pos,
                     com_eval._u, out)
    return out, bool(ok)


@njit
def _seam_block(blk, wts, left, off_l, off_r, arc_l, arc_r, theta, axis, ref):
    n, J, _ = blk.shape
    Lx, Ly, Lz = axis[0], axis[1], axis[2]
    for i in range(n):
        t = wts[i]
        off = off_l if left[i] else off_r
        for j in range(1, J):
            px, py, pz, pw = qpow(off[j, 0], off[j, 1], off[j, 2], off[j, 3], t)
            x, y, z, w = qmul(blk[i, j, 0], blk[i, j, 1], blk[i, j, 2], blk[i, j, 3], px, py, pz, pw)
            blk[i, j, 0], blk[i, j, 1], blk[i, j, 2], blk[i, j, 3] = x, y, z, w
        # root: b = q^-1 L (body frame), rotated by arc^t, recomposed q = q_L(theta) arc(ref b -> L) ref
        qx, qy, qz, qw = blk[i, 0, 0], blk[i, 0, 1], blk[i, 0, 2], blk[i, 0, 3]
        bx, by, bz = qrot(-qx, -qy, -qz, qw, Lx, Ly, Lz)
        arc = arc_l if left[i] else arc_r
        ax_, ay_, az_, aw_ = qpow(arc[0], arc[1], arc[2], arc[3], t)
        bx, by, bz = qrot(ax_, ay_, az_, aw_, bx, by, bz)
        nb = 1.0 / math.sqrt(bx * bx + by * by + bz * bz)
        bx, by, bz = qrot(ref[0], ref[1], ref[2], ref[3], bx * nb, by * nb, bz * nb)
        # shortest arc from (bx, by, bz) to L
        sx, sy, sz = by * Lz - bz * Ly, bz * Lx - bx * Lz, bx * Ly - by * Lx
        sw = 1.0 + bx * Lx + by * Ly + bz * Lz
        sn = math.sqrt(sx * sx + sy * sy + sz * sz + sw * sw)
        sx, sy, sz, sw = sx / sn, sy / sn, sz / sn, sw / sn
        h = 0.5 * theta[i]
        c, s_ = math.cos(h), math.sin(h)
        x, y, z, w = qmul(s_ * Lx, s_ * Ly, s_ * Lz, c, sx, sy, sz, sw)
        x, y, z, w = qmul(x, y, z, w, ref[0], ref[1], ref[2], ref[3])
        blk[i, 0, 0], blk[i, 0, 1], blk[i, 0, 2], blk[i, 0, 3] = x, y, z, w
    return blk


@njit(inline="always")
def _arc(ux, uy, uz, vx, vy, vz):
    """Shortest-arc quaternion from unit ``u`` to unit ``v`` (:func:`~mocomp.flips.smoothing.shortest_arc`)
    and its norm before normalisation (``< 1e-9``: opposite vectors, not handled here)."""
    x, y, z = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    w = 1.0 + (ux * vx + uy * vy + uz * vz)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    return x / n, y / n, z / n, w / n, n

@njit
def _landing_seam(rot, a, la, rb, w, qr, br, axis, theta, src, ref):
    """The landing seam of :func:`mocomp.flips.multiflip.multiflip` in place on ``rot`` (frames
    ``la .. rb-1``, seam after ``a``; ``qr``/``br`` the pose and body-frame ``L`` of ``g``): the
    half-way pose ``mid = slerp(rot[a], qr, 1/2)``, the per-joint offsets to it, the root
    swing arcs to the middle direction, the raised-cosine ramp, then :func:`_seam_block`.
    Returns False, leaving ``rot`` untouched, when a swing arc is degenerate (opposite
    directions), so the caller can take the numpy path that handles it."""
    J = rot.shape[1]
    off_l = np.empty((J, 4))
    off_r = np.empty((J, 4))
    for j in range(J):
        lx, ly, lz, lw = rot[a, j, 0], rot[a, j, 1], rot[a, j, 2], rot[a, j, 3]
        rx, ry, rz, rw = qr[j, 0], qr[j, 1], qr[j, 2], qr[j, 3]
        sg = -1.0 if lx * rx + ly * ry + lz * rz + lw * rw < 0.0 else 1.0
        mx, my, mz, mw = lx + sg * rx, ly + sg * ry, lz + sg * rz, lw + sg * rw
        mn = math.sqrt(mx * mx + my * my + mz * mz + mw * mw)
        mx, my, mz, mw = mx / mn, my / mn, mz / mn, mw / mn
        off_l[j, 0], off_l[j, 1], off_l[j, 2], off_l[j, 3] = qmul(-lx, -ly, -lz, lw, mx, my, mz, mw)
        off_r[j, 0], off_r[j, 1], off_r[j, 2], off_r[j, 3] = qmul(-rx, -ry, -rz, rw, mx, my, mz, mw)
    # b_l = q_root(a)^-1 L, b_m the normalised mean of b_l and b_r
    blx, bly, blz = qrot(-rot[a, 0, 0], -rot[a, 0, 1], -rot[a, 0, 2], rot[a, 0, 3], axis[0], axis[1], axis[2])
    bmx, bmy, bmz = blx + br[0], bly + br[1], blz + br[2]
    bn = math.sqrt(bmx * bmx + bmy * bmy + bmz * bmz)
    bmx, bmy, bmz = bmx / bn, bmy / bn, bmz / bn
    arc_l = np.empty(4)
    arc_r = np.empty(4)
    arc_l[0], arc_l[1], arc_l[2], arc_l[3], nl = _arc(blx, bly, blz, bmx, bmy, bmz)
    arc_r[0], arc_r[1], arc_r[2], arc_r[3], nr = _arc(br[0], br[1], br[2], bmx, bmy, bmz)
    if not (nl >= 1e-9 and nr >= 1e-9):
        return False
    n = rb - la
    wts = np.empty(n)
    left = np.empty(n, dtype=np.bool_)
    th = np.empty(n)
    for i in range(n):
        d = abs(la + i - a) / (w + 1.0)
        wts[i] = 0.5 * (1.0 + math.cos(math.pi * min(max(d, 0.0), 1.0)))
        left[i] = la + i <= a
        th[i] = theta[src[la + i]]
    _seam_block(rot[la:rb], wts, left, off_l, off_r, arc_l, arc_r, th, axis, ref)
    return True

@njit
def _turn_roots(rot, extra, axis):
    """``rot[:, 0] = q_L(extra) rot[:, 0]`` in place: each frame's rotation about the unit ``axis``."""
    ax, ay, az = axis[0], axis[1], axis[2]
    for i in range(rot.shape[0]):
        h = 0.5 * extra[i]
        s_ = math.sin(h)
        c = math.cos(h)
        x, y, z, w = qmul(s_ * ax, s_ * ay, s_ * az, c, rot[i, 0, 0], rot[i, 0, 1], rot[i, 0, 2], rot[i, 0, 3])
        rot[i, 0, 0], rot[i, 0, 1], rot[i, 0, 2], rot[i, 0, 3] = x, y, z, w
    return rot


def landing_seam_nb(rot, a, la, rb, w, qr, br, axis, theta, src, ref) -> bool:
    """In-place landing-seam smoothing of the gathered sequence rotations ``rot`` (see
    :func:`mocomp.flips.multiflip.multiflip`); False (``rot`` untouched) for a degenerate swing arc."""
    c = writable

    return bool(_landing_seam(rot, int(a), int(la), int(rb), int(w), c(qr), c(br), c(axis), c(theta),
                              c(src, np.int64), c(ref)))


def turn_roots_nb(rot, extra, axis) -> np.ndarray:
    """In place ``rot[:, 0] = axis_quat(axis, extra) * rot[:, 0]`` (``axis`` normalised here)."""
    return _turn_roots(rot, writable(extra), _unit_axis(axis))


def writable(x, dtype=np.float64):
    """``x`` itself when it already is a writable C-contiguous ``dtype`` array (the kernels only read
    it), else such a copy: one compiled signature per kernel (no read-only variants)."""
    if isinstance(x, np.ndarray) and x.dtype == dtype and x.flags.c_contiguous and x.flags.writeable:
        return x
    return np.array(x, dtype=dtype, copy=True, order="C")


_WEIGHTS_CACHE: dict = {}


def _joint_weights(weights) -> tuple[np.ndarray, np.ndarray]:
    """``(nz, wj)``: joints with a non-zero eq. 5.13 weight and those weights, for a
    :class:`~mocomp.flips.similarity.SimilarityWeights`; the last few are kept, keyed by the
    weights object and checked against its current joint weights (cheap next to rebuilding)."""
    jw = np.asarray(weights.joints)
    got = _WEIGHTS_CACHE.get(id(weights))
    if got is not None and got[0] is weights and (got[1] is jw if not jw.flags.writeable else
                                                  np.array_equal(got[1], jw)):
        return got[2], got[3]
    nz = np.flatnonzero(jw).astype(np.int64)
    wj = np.ascontiguousarray(jw[nz], dtype=np.float64)
    if len(_WEIGHTS_CACHE) > 8:
        _WEIGHTS_CACHE.clear()
    _WEIGHTS_CACHE[id(weights)] = (weights, jw if not jw.flags.writeable else jw.copy(), nz, wj)
    return nz, wj


_AXIS_CACHE: list = [None, None]


def _unit_axis(axis) -> np.ndarray:
    """``axis / |axis|`` as a C-contiguous float64 array; for a read-only array (a prepared clip's
    ``L`` direction, which cannot change) the last result is reused while the same array comes in."""
    if _AXIS_CACHE[0] is axis:
        return _AXIS_CACHE[1]
    a = np.asarray(axis, dtype=np.float64)
    u = np.ascontiguousarray(a / np.linalg.norm(a))
    if isinstance(axis, np.ndarray) and not axis.flags.writeable:
        _AXIS_CACHE[0], _AXIS_CACHE[1] = axis, u
    return u


@njit(inline="always")
def _pair_distance(r1, p1, r2, p2, ax, ay, az, wr, nz, wj):
    """Eq. 5.12-5.13 between frame ``r1[p1]`` and frame ``r2[p2]``: ``(D, phi)``."""
    # eq. 5.12: twist about the axis of q_r2 q_r1^-1, wrapped to (-pi, pi]
    x, y, z, w = qmul(r2[p2, 0, 0], r2[p2, 0, 1], r2[p2, 0, 2], r2[p2, 0, 3],
                       -r1[p1, 0, 0], -r1[p1, 0, 1], -r1[p1, 0, 2], r1[p1, 0, 3])
    phi = 2.0 * math.atan2(x * ax + y * ay + z * az, w)
    phi = (phi + math.pi) % (2.0 * math.pi) - math.pi
    h = 0.5 * phi
    c, s_ = math.cos(h), math.sin(h)
    # aligned root q_phi q_r1, then the angle of q_r2 aligned^-1
    bx, by, bz, bw = qmul(s_ * ax, s_ * ay, s_ * az, c, r1[p1, 0, 0], r1[p1, 0, 1], r1[p1, 0, 2], r1[p1, 0, 3])
    x, y, z, w = qmul(r2[p2, 0, 0], r2[p2, 0, 1], r2[p2, 0, 2], r2[p2, 0, 3], -bx, -by, -bz, bw)
    d = wr * qangle(x, y, z, w)
    # eq. 5.13: weighted joint-angle differences
    for k in range(nz.shape[0]):
        j = nz[k]
        x, y, z, w = qmul(r2[p2, j, 0], r2[p2, j, 1], r2[p2, j, 2], r2[p2, j, 3],
                           -r1[p1, j, 0], -r1[p1, j, 1], -r1[p1, j, 2], r1[p1, j, 3])
        d += wj[k] * qangle(x, y, z, w)
    return d, phi

@njit
def _frame_distance(r1, r2, axis, wr, nz, wj, out_d, out_phi):
    N = r1.shape[0]
    ax, ay, az = axis[0], axis[1], axis[2]
    for p in range(N):
        d, phi = _pair_distance(r1, p, r2, p, ax, ay, az, wr, nz, wj)
        out_d[p] = d
        out_phi[p] = phi
    return out_d

@njit
def _landing_search(rot, theta, m, period, n_u, phi, g0, g1, extra_total, max_delta, axis, wr, nz, wj):
    """The candidate pairs of :func:`mocomp.flips.sequence.find_landing` without the (G, U)
    arrays: over ``g`` in ``g0 .. g1-1`` (outer) and ``u`` in ``0 .. n_u-1`` (inner, source
    frame ``m + u % period``, copy ``u // period`` turned by ``copy * phi``), the pairs whose
    rotation about ``L`` is within ``max_delta`` of ``theta[g] + extra_total``, with their
    eq. 5.13 distance. Returns ``(u, g, D, mismatch)`` arrays (empty: none); the caller
    chooses among them."""
    ax, ay, az = axis[0], axis[1], axis[2]
    th_u = np.empty(n_u)                       # rotation about L of each unrolled frame
    for u in range(n_u):
        cp = u // period
        th_u[u] = theta[m + u - cp * period] + cp * phi
    n_pairs = 0
    for g in range(g0, g1):
        want = theta[g] + extra_total
        for u in range(n_u):
            if abs(th_u[u] - want) <= max_delta:
                n_pairs += 1
    us = np.empty(n_pairs, dtype=np.int64)
    gs = np.empty(n_pairs, dtype=np.int64)
    ds = np.empty(n_pairs)
    diffs = np.empty(n_pairs)
    k = 0
    for g in range(g0, g1):
        want = theta[g] + extra_total
        for u in range(n_u):
            diff = th_u[u] - want
            if abs(diff) <= max_delta:
                f = m + u % period
                d, _ = _pair_distance(rot, f, rot, g, ax, ay, az, wr, nz, wj)
                us[k], gs[k], ds[k], diffs[k] = u, g, d, diff
                k += 1
    return us, gs, ds, diffs


def landing_search_nb(rotations: np.ndarray, theta: np.ndarray, m: int, period: int, n_u: int, phi: float,
                      g0: int, g1: int, extra_total: float, max_delta: float, axis: np.ndarray, weights):
    """Compiled landing-search candidates (see ``_landing_search``): ``(u, g, D, mismatch)``, the
    same pairs and distances as the array version in :func:`mocomp.flips.sequence.find_landing`
    (tested)."""
    nz, wj = _joint_weights(weights)
    a = _unit_axis(axis)
    return _landing_search(np.ascontiguousarray(rotations, dtype=np.float64),
                           np.ascontiguousarray(theta, dtype=np.float64), int(m), int(period), int(n_u),
                           float(phi), int(g0), int(g1), float(extra_total), float(max_delta), a,
                           float(weights.root), nz, wj)


def frame_distance_nb(rot1: np.ndarray, rot2: np.ndarray, axis: np.ndarray, weights) -> tuple[np.ndarray, np.ndarray]:
    """Compiled :func:`mocomp.flips.similarity.frame_distance` for ``(N, J, 4)`` frame pairs without the
    velocity term: ``(D (N,), phi (N,))`` (same results to rounding, tested)."""
    r1, r2 = writable(rot1), writable(rot2)
    nz = np.flatnonzero(weights.joints).astype(np.int64)
    wj = np.ascontiguousarray(weights.joints[nz], dtype=np.float64)
    a = np.asarray(axis, dtype=np.float64)
    a = np.ascontiguousarray(a / np.linalg.norm(a))
    N = r1.shape[0]
    phi = np.empty(N)
    D = _frame_distance(r1, r2, a, float(weights.root), nz, wj, np.empty(N), phi)
    return D, phi


def slerp_rows_nb(q0: np.ndarray, q1: np.ndarray, a: np.ndarray, nlerp_below: float = 0.1) -> np.ndarray:
    q0, q1 = writable(q0), writable(q1)
    return _slerp_rows(q0, q1, np.ascontiguousarray(a, dtype=np.float64), math.cos(nlerp_below),
                       np.empty_like(q0))


def slerp_gather_nb(rot: np.ndarray, i0: np.ndarray, a: np.ndarray, nlerp_below: float = 0.1
                    ) -> tuple[np.ndarray, bool]:
    """:func:`slerp_rows_nb` of ``rot[i0]`` and ``rot[i0 + 1]`` with weights ``a`` (the retiming
    interpolation), reading the rows in place: ``(out (N, J, 4), ok)``, ``ok`` telling that every
    output is a finite unit quaternion (to rounding: each row is normalised)."""
    rot = writable(rot)
    i0 = np.ascontiguousarray(i0, dtype=np.int64)
    if i0.size and (i0.min() < 0 or i0.max() + 1 >= rot.shape[0]):
        raise IndexError(f"slerp rows {i0.min()}..{i0.max() + 1} outside 0..{rot.shape[0] - 1}")
    out = np.empty((i0.shape[0],) + rot.shape[1:])
    ok = _slerp_gather(rot, i0, np.ascontiguousarray(a, dtype=np.float64), math.cos(nlerp_below), out)
    return out, bool(ok)


def com_relative_nb(q: np.ndarray, joints: np.ndarray, parent: np.ndarray, u: np.ndarray) -> np.ndarray:
    q = writable(q)
    return _com_relative(q, joints, parent, u, np.empty((q.shape[0], 3)))


_WARM = False


def warmup() -> None:
    """Load (or compile, the first time on a machine) the kernels, so that the first
    run-time call is not charged for it; :func:`mocomp.flips.prepare` calls this."""
    global _WARM
    if not AVAILABLE or _WARM:
        return
    q = np.zeros((2, 2, 4))
    q[..., 3] = 1.0
    slerp_rows_nb(q, q, np.zeros(2))
    slerp_gather_nb(q, np.zeros(1, dtype=np.int64), np.zeros(1))
    com_relative_nb(q, np.arange(2, dtype=np.int64), np.zeros(2, dtype=np.int64), np.zeros((2, 3)))
    _frame_distance(q, q, np.array([1.0, 0.0, 0.0]), 1.0, np.arange(2, dtype=np.int64), np.ones(2), np.empty(2),
                    np.empty(2))
    landing_seam_nb(q.copy(), 0, 0, 2, 1, q[0], np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.zeros(2),
                    np.arange(2), q[0, 0])
    turn_roots_nb(q.copy(), np.zeros(2), np.array([1.0, 0.0, 0.0]))
    _reposition(np.zeros((2, 3)), np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros(1), 0, 1, 0.0, 1.0,
                np.zeros(3), np.zeros(3), 0.0, q.copy(), np.arange(2, dtype=np.int64), np.zeros(2, dtype=np.int64),
                np.zeros((2, 3)), np.empty((1, 3)))
    ro = q.copy()
    ro.setflags(write=False)                          # the prepared clip's arrays are read-only
    th = np.zeros(2)
    th.setflags(write=False)
    _landing_search(ro, th, 0, 1, 1, 1.0, 1, 2, 0.0, 1.0, np.array([1.0, 0.0, 0.0]), 1.0,
                    np.arange(2, dtype=np.int64), np.ones(2))
    from .smoothing import _angular_nb, _landing_speed_nb

    def ro(x):                              # the body's evaluator arrays are read-only
        x = np.array(x)
        x.setflags(write=False)
        return x

    _landing_speed_nb(np.concatenate([q, q[:1]]), 0, 3, ro(np.array([-1, 0], dtype=np.int64)), ro(np.zeros((2, 3))),
                      ro(np.arange(2, dtype=np.int64)), ro(np.zeros((2, 3))), ro(np.ones(2)),
                      ro(np.tile(np.eye(3), (2, 1, 1))), 1.0, np.zeros(3, dtype=np.int64), np.zeros(3),
                      np.array([1.0, 0.0, 0.0]), np.zeros((3, 3)), 1, 1, 1.0, 1.0, 1.0, 0.5, 2.0)
    _angular_nb(np.concatenate([q, q[:1]]), np.array([-1, 0], dtype=np.int64), np.zeros((2, 3)),
                np.arange(2, dtype=np.int64), np.zeros((2, 3)), np.ones(2), np.tile(np.eye(3), (2, 1, 1)), 1.0,
                np.empty((1, 3)))
    _WARM = True
