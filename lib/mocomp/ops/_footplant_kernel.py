"""Compiled footplant hold (issue 16's speed goal): the first enforcement pass of
:func:`mocomp.ops.footplant._solve` with a :class:`~mocomp.ops.footplant.FootplantPlan` -- the foot
turns and translations, their fades (:meth:`mocomp.ops.easing.RampPlan.many` with the legs' fade
clocks), the toe-only / ankle-only turns, the toe-to-heel cross-fade, the soft reach and the leg IK --
as one numba call per hold, with the knees' hinge axes (:func:`mocomp.ops.ik.hinge_axis`) and the fade
clocks (:func:`mocomp.ops.footplant.leg_fade_clocks`) computed in a second one.

The numpy path stacks both legs' frames one after the other (with unplanted frames between them, so
nothing reaches from one leg into the other) and works on the stack; here each leg is its own
``T``-frame line, which is the same computation (the fades of a leg never reach past its own frames;
the cumulative fade clock differs only by the rounding of where its sum starts). The quaternion
algebra is core's inline helpers (:mod:`mocomp.core._compiled`: ``qmul``, ``qrot``, ``qlog``,
``qexp``, the compiled twins of :mod:`mocomp.core.rotations`), the shortest arc and the IK those of
:mod:`mocomp.ops._kernels`, so the result equals the numpy path's to rounding
(``tests/test_touchup_speed_hold.py``). Callers use it only when :func:`mocomp.ops.displacement._compiled`.
"""
from __future__ import annotations

import math

import numpy as np

from ..core._compiled import njit, qexp, qlog, qmul, qrot
from ._kernels import _arc, _two_bone_ik_rows

__all__ = ["EASE_CODES", "hinges_and_clocks", "solve_legs", "foot_points_rows", "plan_targets"]

#: :func:`mocomp.ops.easing.ease` kinds by the code the kernel takes
EASE_CODES = {"linear": 0, "smoothstep": 1, "smootherstep": 2, "cosine": 3}


@njit(inline="always")
def _ease(x, kind):
    """:func:`mocomp.ops.easing.ease` of one number (clipped to ``[0, 1]``)."""
    x = min(max(x, 0.0), 1.0)
    if kind == 0:
        return x
    if kind == 1:
        return x * x * (3.0 - 2.0 * x)
    if kind == 2:
        return x * x * x * (x * (6.0 * x - 15.0) + 10.0)
    return 0.5 - 0.5 * math.cos(math.pi * x)


@njit(inline="always")
def _at(C, i):
    """The cumulative clock at frame ``i``, continued with steps of 1 beyond the ends (``RampPlan.many``)."""
    T = C.shape[0]
    ic = min(max(i, 0), T - 1)
    return C[ic] + (i - ic)


@njit
def _ramp(defined, C, width, kind, prev_c, nxt_c, wp, wn):
    """The weights of :meth:`mocomp.ops.easing.RampPlan.many` with a clock (cumulative ``C (T,)``) for
    one column ``defined (T,)``; returns whether the plan is trivial (then only ``defined`` matters)."""
    T = defined.shape[0]
    n_def = 0
    for t in range(T):
        if defined[t]:
            n_def += 1
    if width <= 0 or n_def == 0 or n_def == T:
        return True
    p = -1
    for t in range(T):
        if defined[t]:
            p = t
        prev_c[t] = p
    q = T
    for t in range(T - 1, -1, -1):
        if defined[t]:
            q = t
        nxt_c[t] = q
    for t in range(T):
        p = prev_c[t]
        q = nxt_c[t]
        a = 0.0
        b = 0.0
        if p >= 0 and t - p <= width:
            span = _at(C, p + width + 1) - _at(C, p)
            g = (_at(C, t) - _at(C, p)) / span if span > 0 else (t - p) / (width + 1.0)
            a = _ease(1.0 - g, kind)
        if q < T and q - t <= width:
            span = _at(C, q) - _at(C, q - width - 1)
            g = (_at(C, q) - _at(C, t)) / span if span > 0 else (q - t) / (width + 1.0)
            b = _ease(1.0 - g, kind)
        s = max(1.0, a + b)
        wp[t] = a / s
        wn[t] = b / s
        prev_c[t] = min(max(p, 0), T - 1)
        nxt_c[t] = min(max(q, 0), T - 1)
    return False


@njit(inline="always")
def _fill_row(x, t, defined, trivial, prev_c, nxt_c, wp, wn, out, k):
    """Component ``k`` of :meth:`RampPlan.fill` at frame ``t`` of the ``(T, 3)`` values ``x``."""
    if defined[t]:
        out[t, k] = x[t, k]
    elif trivial:
        out[t, k] = 0.0
    else:
        out[t, k] = wp[t] * x[prev_c[t], k] + wn[t] * x[nxt_c[t], k]


@njit
def _fill(x, defined, trivial, prev_c, nxt_c, wp, wn, out):
    for t in range(x.shape[0]):
        for k in range(x.shape[1]):
            _fill_row(x, t, defined, trivial, prev_c, nxt_c, wp, wn, out, k)


@njit
def _smooth_mix(x, m, w, line, tmp):
    """In place: ``x = (1 - m) x + m gaussian_filter1d(x, axis=0, mode="nearest")`` with the
    symmetric weights ``w`` (``(T, 3)`` ``x``, ``(T,)`` ``m``)."""
    T = x.shape[0]
    r = (w.shape[0] - 1) // 2
    for k in range(x.shape[1]):
        for i in range(T + 2 * r):
            line[i] = x[min(max(i - r, 0), T - 1), k]
        for i in range(T):
            c = i + r
            acc = line[c] * w[r]
            for j in range(r, 0, -1):
                acc += (line[c - j] + line[c + j]) * w[r + j]
            tmp[i] = acc
        for i in range(T):
            x[i, k] = (1.0 - m[i]) * x[i, k] + m[i] * tmp[i]


@njit
def _hinges_and_clocks(P, G, rot, chains, slack, floor, use_clock, hinges, clocks):
    """:func:`mocomp.ops.ik.hinge_axis` of every leg into ``hinges (L, 3)`` and, with ``use_clock``,
    :func:`mocomp.ops.footplant.leg_fade_clocks` into ``clocks (T, L)`` (``rot (T, J, 4)`` local)."""
    T = P.shape[0]
    L = chains.shape[0]
    for li in range(L):
        h, k, a = chains[li, 0], chains[li, 1], chains[li, 2]
        sx = 0.0
        sy = 0.0
        sz = 0.0
        for f in range(T):
            ux, uy, uz = P[f, a, 0] - P[f, k, 0], P[f, a, 1] - P[f, k, 1], P[f, a, 2] - P[f, k, 2]
            vx, vy, vz = P[f, h, 0] - P[f, k, 0], P[f, h, 1] - P[f, k, 1], P[f, h, 2] - P[f, k, 2]
            nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            lx, ly, lz = qrot(-G[f, h, 0], -G[f, h, 1], -G[f, h, 2], G[f, h, 3], nx, ny, nz)
            sx += lx
            sy += ly
            sz += lz
        n = math.sqrt(sx * sx + sy * sy + sz * sz)
        if n > 1e-12:
            hinges[li, 0], hinges[li, 1], hinges[li, 2] = sx / n, sy / n, sz / n
        else:
            hinges[li, 0], hinges[li, 1], hinges[li, 2] = 1.0, 0.0, 0.0
    for f in range(T):
        for li in range(L):
            clocks[f, li] = 1.0
    if not use_clock or T < 2:
        return
    rate = np.zeros((T - 1, L))
    limit = 0.0
    for li in range(L):
        for c in range(3):
            j = chains[li, c]
            for f in range(T - 1):
                x, y, z, w = qmul(-rot[f, j, 0], -rot[f, j, 1], -rot[f, j, 2], rot[f, j, 3],
                                  rot[f + 1, j, 0], rot[f + 1, j, 1], rot[f + 1, j, 2], rot[f + 1, j, 3])
                ang = 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))
                if ang > rate[f, li]:
                    rate[f, li] = ang
                if ang > limit:
                    limit = ang
    if not limit > 0:
        return
    for li in range(L):
        for f in range(T - 1):
            clocks[f, li] = min(max((limit - rate[f, li]) / (slack * limit), floor), 1.0)


def hinges_and_clocks(P, G, rot, chains, slack, floor):
    """``(hinges (L, 3), clocks (T, L) or None)``: the knees' hinge axes and the legs' fade clocks
    (``slack`` ``None``: no clocks, as :data:`mocomp.ops.footplant.FADE_RATE_SLACK`)."""
    T = P.shape[0]
    chains = np.asarray(chains, dtype=np.int64)
    hinges = np.empty((chains.shape[0], 3))
    clocks = np.empty((T, chains.shape[0]))
    _hinges_and_clocks(P, G, rot, chains, 0.5 if slack is None else float(slack), float(floor), slack is not None,
                       hinges, clocks)
    return hinges, (clocks if slack is not None else None)


@njit
def _foot_points(P, G, js, offs, out):
    T = P.shape[0]
    for f in range(T):
        for k in range(js.shape[0]):
            j = js[k]
            dx, dy, dz = qrot(G[f, j, 0], G[f, j, 1], G[f, j, 2], G[f, j, 3], offs[k, 0], offs[k, 1], offs[k, 2])
            out[f, k, 0] = P[f, j, 0] + dx
            out[f, k, 1] = P[f, j, 1] + dy
            out[f, k, 2] = P[f, j, 2] + dz


def foot_points_rows(P, G, js, offs):
    """``(T, K, 3)``: ``P[:, js] + quat_apply(G[:, js], offs)`` (:func:`mocomp.ops.footplant.foot_points`)."""
    out = np.empty((P.shape[0], len(js), 3))
    _foot_points(P, G, np.asarray(js, dtype=np.int64), np.asarray(offs, dtype=np.float64), out)
    return out


@njit
def _solve_legs(P, G, rot, pts, targets, labels, chains, parents, hinges, clocks, one_leg, sw_mask, has_sw, sw_w,
                width, kind, tol, margin, soft_reach, prior, delta_o, rv_o, miss_o, lift_o, solve_o):
    """The first pass of :func:`mocomp.ops.footplant._solve` with a plan, leg by leg (module docstring):
    ``rot`` changed in place on the solved frames, per leg ``delta_o``, ``rv_o`` ``(L, T, 3)``,
    ``miss_o``, ``lift_o`` ``(L, T)`` and ``solve_o`` ``(L, T)`` filled."""
    T = P.shape[0]
    L = chains.shape[0]
    la = np.empty(T, np.bool_)
    lt = np.empty(T, np.bool_)
    both = np.empty(T, np.bool_)
    anyp = np.empty(T, np.bool_)
    C = np.zeros(T)
    prev_c = np.empty((4, T), np.int64)
    nxt_c = np.empty((4, T), np.int64)
    wp = np.zeros((4, T))
    wn = np.zeros((4, T))
    triv = np.empty(4, np.bool_)
    rv = np.zeros((T, 3))
    rq = np.empty((T, 4))
    delta = np.zeros((T, 3))
    d_a = np.zeros((T, 3))
    tip = np.empty((T, 3))
    tmp = np.empty((T, 3))
    tmp2 = np.empty((T, 3))
    wcol = np.empty((T, 3))
    r = (sw_w.shape[0] - 1) // 2
    line = np.empty(T + 2 * r)
    line_out = np.empty(T)
    idx = np.empty(T, np.int64)
    tgt = np.empty((T, 3))
    end = np.empty((T, 4))
    axis = np.empty((T, 3))
    out = np.empty((T, 3, 4))
    miss = np.empty(T)
    for li in range(L):
        ka = 2 * li
        kt = 2 * li + 1
        h, kn, ja = chains[li, 0], chains[li, 1], chains[li, 2]
        for t in range(T):
            la[t] = labels[t, ka]
            lt[t] = labels[t, kt]
            both[t] = la[t] and lt[t]
            anyp[t] = la[t] or lt[t]
        C[0] = 0.0
        for t in range(1, T):
            C[t] = C[t - 1] + clocks[t - 1, li]
        triv[0] = _ramp(both, C, width, kind, prev_c[0], nxt_c[0], wp[0], wn[0])
        triv[1] = _ramp(la, C, width, kind, prev_c[1], nxt_c[1], wp[1], wn[1])
        triv[2] = _ramp(lt, C, width, kind, prev_c[2], nxt_c[2], wp[2], wn[2])
        triv[3] = _ramp(anyp, C, width, kind, prev_c[3], nxt_c[3], wp[3], wn[3])
        # the foot turned about the ankle point to aim the toe tip (both planted), faded
        for t in range(T):
            rv[t, 0] = 0.0
            rv[t, 1] = 0.0
            rv[t, 2] = 0.0
            if both[t]:
                q = _arc(pts[t, kt, 0] - pts[t, ka, 0], pts[t, kt, 1] - pts[t, ka, 1], pts[t, kt, 2] - pts[t, ka, 2],
                         targets[t, kt, 0] - targets[t, ka, 0], targets[t, kt, 1] - targets[t, ka, 1],
                         targets[t, kt, 2] - targets[t, ka, 2])
                rv[t, 0], rv[t, 1], rv[t, 2] = qlog(q[0], q[1], q[2], q[3])
        _fill(rv, both, triv[0], prev_c[0], nxt_c[0], wp[0], wn[0], tmp)
        has_lt = False
        for t in range(T):
            rv[t, 0], rv[t, 1], rv[t, 2] = tmp[t, 0], tmp[t, 1], tmp[t, 2]
            rq[t, 0], rq[t, 1], rq[t, 2], rq[t, 3] = qexp(rv[t, 0], rv[t, 1], rv[t, 2])
            vx = pts[t, kt, 0] - pts[t, ka, 0]
            vy = pts[t, kt, 1] - pts[t, ka, 1]
            vz = pts[t, kt, 2] - pts[t, ka, 2]
            ex, ey, ez = qrot(rq[t, 0], rq[t, 1], rq[t, 2], rq[t, 3], vx, vy, vz)
            tip[t, 0] = pts[t, ka, 0] + ex
            tip[t, 1] = pts[t, ka, 1] + ey
            tip[t, 2] = pts[t, ka, 2] + ez
            # the ankle point on its target; with both planted half the along-foot misfit each
            for c in range(3):
                d_a[t, c] = 0.0
                if la[t]:
                    d_a[t, c] = targets[t, ka, c] - pts[t, ka, c]
                if both[t]:
                    d_a[t, c] += 0.5 * (targets[t, kt, c] - (targets[t, ka, c] + tip[t, c] - pts[t, ka, c]))
                delta[t, c] = d_a[t, c] if la[t] else 0.0
            if lt[t]:
                has_lt = True
        # toe tip planted alone: the tip on its target, the foot turned about it after the heel's correction
        _fill(d_a, la, triv[1], prev_c[1], nxt_c[1], wp[1], wn[1], tmp)          # da_fill
        for t in range(T):
            for c in range(3):
                wcol[t, c] = 1.0 if la[t] else 0.0
        _fill(wcol, la, triv[1], prev_c[1], nxt_c[1], wp[1], wn[1], tmp2)        # w_a (column 0)
        for t in range(T):
            if not (lt[t] and not la[t]):
                continue
            Ax, Ay, Az = pts[t, ka, 0], pts[t, ka, 1], pts[t, ka, 2]
            Tx, Ty, Tz = targets[t, kt, 0], targets[t, kt, 1], targets[t, kt, 2]
            acx, acy, acz = Ax + Tx - tip[t, 0], Ay + Ty - tip[t, 1], Az + Tz - tip[t, 2]
            w_a = tmp2[t, 0]
            wx = acx + tmp[t, 0] - w_a * (Tx - tip[t, 0])
            wy = acy + tmp[t, 1] - w_a * (Ty - tip[t, 1])
            wz = acz + tmp[t, 2] - w_a * (Tz - tip[t, 2])
            q = _arc(acx - Tx, acy - Ty, acz - Tz, wx - Tx, wy - Ty, wz - Tz)
            x, y, z, w = qmul(q[0], q[1], q[2], q[3], rq[t, 0], rq[t, 1], rq[t, 2], rq[t, 3])
            ex, ey, ez = qrot(x, y, z, w, pts[t, kt, 0] - Ax, pts[t, kt, 1] - Ay, pts[t, kt, 2] - Az)
            delta[t, 0] = Tx - Ax - ex
            delta[t, 1] = Ty - Ay - ey
            delta[t, 2] = Tz - Az - ez
            rv[t, 0], rv[t, 1], rv[t, 2] = qlog(x, y, z, w)
        # ankle point planted alone: the foot turned about it after the toe's correction
        if has_lt:
            for t in range(T):
                for c in range(3):
                    wcol[t, c] = 1.0 if lt[t] else 0.0
                    d_a[t, c] = targets[t, kt, c] - pts[t, kt, c] if lt[t] else 0.0
            _fill(wcol, lt, triv[2], prev_c[2], nxt_c[2], wp[2], wn[2], tmp2)    # w_t
            _fill(d_a, lt, triv[2], prev_c[2], nxt_c[2], wp[2], wn[2], tmp)      # ct_fill
            for t in range(T):
                w_t = tmp2[t, 0]
                if not (la[t] and not lt[t] and w_t > 0):
                    continue
                anx, any_, anz = targets[t, ka, 0], targets[t, ka, 1], targets[t, ka, 2]
                ex, ey, ez = qrot(rq[t, 0], rq[t, 1], rq[t, 2], rq[t, 3], pts[t, kt, 0] - pts[t, ka, 0],
                                  pts[t, kt, 1] - pts[t, ka, 1], pts[t, kt, 2] - pts[t, ka, 2])
                t0x, t0y, t0z = anx + ex, any_ + ey, anz + ez
                wx = t0x + tmp[t, 0] + w_t * (pts[t, kt, 0] - t0x)
                wy = t0y + tmp[t, 1] + w_t * (pts[t, kt, 1] - t0y)
                wz = t0z + tmp[t, 2] + w_t * (pts[t, kt, 2] - t0z)
                q = _arc(t0x - anx, t0y - any_, t0z - anz, wx - anx, wy - any_, wz - anz)
                x, y, z, w = qmul(q[0], q[1], q[2], q[3], rq[t, 0], rq[t, 1], rq[t, 2], rq[t, 3])
                rv[t, 0], rv[t, 1], rv[t, 2] = qlog(x, y, z, w)
        if one_leg[li]:
            _fill(rv, anyp, triv[3], prev_c[3], nxt_c[3], wp[3], wn[3], tmp)
            for t in range(T):
                for c in range(3):
                    rv[t, c] = tmp[t, c]
        _fill(delta, anyp, triv[3], prev_c[3], nxt_c[3], wp[3], wn[3], tmp)
        for t in range(T):
            for c in range(3):
                delta[t, c] = tmp[t, c]
        if has_sw[li]:                       # toe <-> heel switches: cross-faded to the smoothed corrections
            _smooth_mix(delta, sw_mask[li], sw_w, line, line_out)
            _smooth_mix(rv, sw_mask[li], sw_w, line, line_out)
        # the leg: the ankle joint moved with the foot, the soft reach, the IK
        n = 0
        for t in range(T):
            for c in range(3):
                delta_o[li, t, c] = delta[t, c]
                rv_o[li, t, c] = rv[t, c]
            nd = math.sqrt(delta[t, 0] * delta[t, 0] + delta[t, 1] * delta[t, 1] + delta[t, 2] * delta[t, 2])
            nr = math.sqrt(rv[t, 0] * rv[t, 0] + rv[t, 1] * rv[t, 1] + rv[t, 2] * rv[t, 2])
            s = nd > tol or nr > tol
            solve_o[li, t] = s
            miss_o[li, t] = 0.0
            lift_o[li, t] = 0.0
            if not s:
                continue
            x, y, z, w = qexp(rv[t, 0], rv[t, 1], rv[t, 2])
            Ax, Ay, Az = pts[t, ka, 0], pts[t, ka, 1], pts[t, ka, 2]
            ex, ey, ez = qrot(x, y, z, w, P[t, ja, 0] - Ax, P[t, ja, 1] - Ay, P[t, ja, 2] - Az)
            gx = Ax + delta[t, 0] + ex
            gy = Ay + delta[t, 1] + ey
            gz = Az + delta[t, 2] + ez
            Hx, Hy, Hz = P[t, h, 0], P[t, h, 1], P[t, h, 2]
            l1 = math.sqrt((P[t, kn, 0] - Hx) ** 2 + (P[t, kn, 1] - Hy) ** 2 + (P[t, kn, 2] - Hz) ** 2)
            l2 = math.sqrt((P[t, ja, 0] - P[t, kn, 0]) ** 2 + (P[t, ja, 1] - P[t, kn, 1]) ** 2
                           + (P[t, ja, 2] - P[t, kn, 2]) ** 2)
            full = l1 + l2 - 2.0 * margin
            soft = soft_reach * full
            d_s = full - soft
            d = math.sqrt((gx - Hx) ** 2 + (gy - Hy) ** 2 + (gz - Hz) ** 2)
            hor = math.sqrt((gx - Hx) ** 2 + (gz - Hz) ** 2)
            d0 = math.sqrt((P[t, ja, 0] - Hx) ** 2 + (P[t, ja, 1] - Hy) ** 2 + (P[t, ja, 2] - Hz) ** 2)
            want = d
            if d > d_s:
                want = max(d_s + soft * (1.0 - math.exp(-(d - d_s) / soft)), min(d, d0))
            if d > want and hor < want and gy < Hy:
                yy = Hy - math.sqrt(want * want - hor * hor)
                lift_o[li, t] = yy - gy
                gy = yy
            idx[n] = t
            tgt[n, 0], tgt[n, 1], tgt[n, 2] = gx, gy, gz
            end[n, 0], end[n, 1], end[n, 2], end[n, 3] = qmul(x, y, z, w, G[t, ja, 0], G[t, ja, 1], G[t, ja, 2],
                                                              G[t, ja, 3])
            axis[n, 0], axis[n, 1], axis[n, 2] = hinges[li, 0], hinges[li, 1], hinges[li, 2]
            n += 1
        if n == 0:
            continue
        _two_bone_ik_rows(P, G, rot, idx[:n], parents[li], h, kn, ja, tgt[:n], end[:n], axis[:n], prior, margin,
                          out[:n], miss[:n])
        for i in range(n):
            t = idx[i]
            miss_o[li, t] = miss[i]
            for c in range(3):
                j = chains[li, c]
                for k in range(4):
                    rot[t, j, k] = out[i, c, k]


def solve_legs(P, G, rot, pts, targets, labels, chains, parents, hinges, clocks, one_leg, sw_mask, has_sw, sw_w,
               width, kind, tol, margin, soft_reach, prior):
    """Run :func:`_solve_legs` (``rot`` changed in place); returns ``(delta, rv, miss, lift, solve)``,
    each with the legs first."""
    T, L = P.shape[0], len(chains)
    delta = np.empty((L, T, 3))
    rv = np.empty((L, T, 3))
    miss = np.empty((L, T))
    lift = np.empty((L, T))
    solve = np.empty((L, T), np.bool_)
    _solve_legs(P, G, rot, pts, targets, np.ascontiguousarray(labels), np.asarray(chains, dtype=np.int64),
                np.asarray(parents, dtype=np.int64), hinges,
                np.ones((T, L)) if clocks is None else np.ascontiguousarray(clocks, dtype=np.float64),
                np.asarray(one_leg, dtype=np.bool_), sw_mask, has_sw, sw_w, int(width), int(kind), float(tol),
                float(margin), float(soft_reach), float(prior), delta, rv, miss, lift, solve)
    return delta, rv, miss, lift, solve


# ------------------------------------------------------------------ the plan's targets (FootplantPlan.targets)
@njit
def _plan_targets(pts, levels, pt_rows, pt_off, run_first, run_cnt, run_off, run_group, run_level, pt_rest, n_groups,
                  toe_k, toe_arr, toe_off, toe_nsh, gap, cons_k, cons_run, cons_sel, cons_rid, cons_off, cons_nr,
                  pitch_k, pitch_both, pitch_sel, pitch_off, pitch_fsel, pitch_near, pitch_w, pitch_woff, pitch_has_fade,
                  slack, out):
    """:meth:`mocomp.ops.footplant.FootplantPlan.targets` for ``height="level"`` with
    :data:`~mocomp.ops.footplant.PITCH_TO_ZERO` (its numpy steps in order, on the plan's runs flattened
    into arrays by :meth:`~mocomp.ops.footplant.FootplantPlan.targets_inputs`): ``out (T, 4, 3)`` filled
    (NaN where not planted)."""
    T = pts.shape[0]
    for t in range(T):
        for k in range(4):
            for c in range(3):
                out[t, k, c] = np.nan
    # plant_targets: per run the mean position, the height put on the run's resting level
    n_runs = run_first.shape[0]
    low = np.empty(n_runs)
    lv = np.empty(n_runs)
    for k in range(4):
        for r in range(run_off[k], run_off[k + 1]):
            a = run_first[r]
            n = run_cnt[r]
            sx = 0.0
            sy = 0.0
            sz = 0.0
            lo = np.inf
            for i in range(a, a + n):
                t = pt_rows[i]
                sx += pts[t, k, 0]
                sy += pts[t, k, 1]
                sz += pts[t, k, 2]
                lo = min(lo, pts[t, k, 1])
            low[r] = lo
            lv[r] = run_level[r]
            for i in range(a, a + n):
                t = pt_rows[i]
                out[t, k, 0] = sx / n
                out[t, k, 1] = sy / n
                out[t, k, 2] = sz / n
    for g in range(n_groups):                    # runs on one support level share the median of their lows
        cnt = 0
        for r in range(n_runs):
            if run_group[r] == g:
                cnt += 1
        vals = np.empty(cnt)
        cnt = 0
        for r in range(n_runs):
            if run_group[r] == g:
                vals[cnt] = low[r]
                cnt += 1
        s = np.sort(vals)
        med = s[cnt // 2] if cnt % 2 else (s[cnt // 2 - 1] + s[cnt // 2]) / 2.0
        for r in range(n_runs):
            if run_group[r] == g:
                lv[r] = med
    for k in range(4):
        for r in range(run_off[k], run_off[k + 1]):
            a = run_first[r]
            for i in range(a, a + run_cnt[r]):
                t = pt_rows[i]
                base = lv[r] if pt_rest[k] else levels[t, k]
                out[t, k, 1] = pts[t, k, 1] - low[r] + base
    # _toes_with_their_heels: a toe run shifted with its heel's run where the two shifts differ
    for e in range(toe_k.shape[0]):
        ka, kt = toe_k[e, 0], toe_k[e, 1]
        o = toe_off[e]
        n_tr = toe_off[e + 1, 0] - o[0]
        n_st = toe_off[e + 1, 2] - o[2]
        shift = np.full(toe_nsh[e], np.nan)
        for i in range(n_tr):
            src = toe_arr[1, o[0] + i]
            shift[toe_arr[0, o[0] + i]] = out[src, ka, 1] - pts[src, ka, 1]
        for b in range(n_st):
            s0 = toe_arr[4, o[2] + b]                  # block start in the toe frames, its length
            ln = toe_arr[5, o[2] + b]
            t0 = toe_arr[3, o[1] + s0]
            own = out[t0, kt, 1] - pts[t0, kt, 1]
            for i in range(s0, s0 + ln):
                t = toe_arr[3, o[1] + i]
                s_t = shift[toe_arr[2, o[1] + i]]
                if np.isfinite(s_t) and abs(own - s_t) > gap:
                    out[t, kt, 1] = pts[t, kt, 1] + s_t
    # consistent_toe_targets: the toe tip's horizontal target from the ankle point's along the mean foot direction
    for e in range(cons_k.shape[0]):
        ka, kt = cons_k[e, 0], cons_k[e, 1]
        nr = cons_nr[e]
        Ls = np.zeros(nr)
        ux = np.zeros(nr)
        uz = np.zeros(nr)
        cnt = np.zeros(nr, np.int64)
        first = np.zeros(nr, np.int64)
        seen = np.zeros(nr, np.bool_)
        for i in range(cons_off[e, 0], cons_off[e + 1, 0]):
            t = cons_sel[i]
            r = cons_rid[i]
            dx = pts[t, kt, 0] - pts[t, ka, 0]
            dz = pts[t, kt, 2] - pts[t, ka, 2]
            Ls[r] += math.sqrt(dx * dx + dz * dz)
            ux[r] += dx
            uz[r] += dz
            cnt[r] += 1
            if not seen[r]:
                seen[r] = True
                first[r] = t
        ok = np.zeros(nr, np.bool_)
        nn = np.zeros(nr)
        for r in range(nr):
            if cnt[r] > 0:
                Ls[r] /= cnt[r]
                ux[r] /= cnt[r]
                uz[r] /= cnt[r]
            nn[r] = math.sqrt(ux[r] * ux[r] + uz[r] * uz[r])
            ok[r] = cnt[r] > 0 and nn[r] >= 1e-9 and r > 0
        ax = np.empty(nr)
        az = np.empty(nr)
        for r in range(nr):
            if ok[r]:
                ax[r] = out[first[r], ka, 0]
                az[r] = out[first[r], ka, 2]
        for t in range(T):
            r = cons_run[cons_off[e, 1] + t]
            if ok[r]:
                scale = Ls[r] / nn[r]
                out[t, kt, 0] = ax[r] + scale * ux[r]
                out[t, kt, 2] = az[r] + scale * uz[r]
    # bounded_foot_pitch: the foot's horizontal misfit kept within the slack, the rest made heel height
    y0 = np.empty(T)
    for e in range(pitch_k.shape[0]):
        ka, kt = pitch_k[e, 0], pitch_k[e, 1]
        a, b = pitch_off[e], pitch_off[e + 1]
        n = b - a
        res = np.empty(n)
        L3 = np.empty(n)
        h_t = np.empty(n)
        dyv = np.empty(n)
        for i in range(n):
            t = pitch_sel[a + i]
            L3[i] = math.sqrt((pts[t, kt, 0] - pts[t, ka, 0]) ** 2 + (pts[t, kt, 1] - pts[t, ka, 1]) ** 2
                              + (pts[t, kt, 2] - pts[t, ka, 2]) ** 2)
            dyv[i] = out[t, ka, 1] - out[t, kt, 1]
            h_t[i] = math.sqrt((out[t, kt, 0] - out[t, ka, 0]) ** 2 + (out[t, kt, 2] - out[t, ka, 2]) ** 2)
            res[i] = h_t[i] - math.sqrt(max(L3[i] * L3[i] - dyv[i] * dyv[i], 0.0))
        for t in range(T):
            y0[t] = out[t, ka, 1]
        changed = False
        for i in range(n):
            rc = min(max(res[i], -slack), slack)          # PITCH_TO_ZERO: within the slack of zero
            if rc == res[i]:
                continue
            changed = True
            t = pitch_sel[a + i]
            h_new = min(max(h_t[i] - rc, 0.0), L3[i])
            sg = 1.0 if dyv[i] > 0 else (-1.0 if dyv[i] < 0 else 0.0)
            out[t, ka, 1] = out[t, kt, 1] + sg * math.sqrt(max(L3[i] * L3[i] - h_new * h_new, 0.0))
        if not changed or not pitch_has_fade[e]:
            continue
        anych = False
        for t in range(T):
            if pitch_both[e, t] and out[t, ka, 1] - y0[t] != 0.0:
                anych = True
        if not anych:
            continue
        for i in range(pitch_woff[e, 0], pitch_woff[e + 1, 0]):
            t = pitch_fsel[i]
            nr_ = pitch_near[i]
            ch = out[nr_, ka, 1] - y0[nr_] if pitch_both[e, nr_] else 0.0
            out[t, ka, 1] = y0[t] + pitch_w[i] * ch


def plan_targets(pts, levels, k):
    """Run :func:`_plan_targets` with the plan's arrays ``k`` (:meth:`FootplantPlan.targets_inputs`)."""
    out = np.empty(pts.shape)
    _plan_targets(pts, levels, k["pt_rows"], k["pt_off"], k["run_first"], k["run_cnt"], k["run_off"], k["run_group"],
                  k["run_level"], k["pt_rest"], k["n_groups"], k["toe_k"], k["toe_arr"], k["toe_off"], k["toe_nsh"],
                  k["gap"], k["cons_k"], k["cons_run"], k["cons_sel"], k["cons_rid"], k["cons_off"], k["cons_nr"],
                  k["pitch_k"], k["pitch_both"], k["pitch_sel"], k["pitch_off"], k["pitch_fsel"], k["pitch_near"],
                  k["pitch_w"], k["pitch_woff"], k["pitch_has_fade"], k["slack"], out)
    return out
