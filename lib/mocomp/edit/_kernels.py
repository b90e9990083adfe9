"""Compiled (numba) inner loop of the direction-of-L correction (dissertation eq. 5.18-5.21).

The loop over flight frames is a recurrence (the rotation found for frame
``f + 1`` changes the poses that ``L_{f+1}`` is computed from), so it runs
compiled. The arithmetic is exactly that of :func:`mocomp.dynamics.momentum`
with central differences (``order=2``): segment COM velocities by the
non-uniform central difference, world angular velocities blending the
backward and forward rotation vectors, ``L = sum_i R_i I_i R_i^T w_i +
m_i (c_i - COM) x v_i`` (eq. 5.5). :class:`mocomp.edit.restore._FrameMomentum`
is the same model in numpy (used by the BFGS variant and by the tests that pin
the two to each other).

Quaternion algebra and forward kinematics are the core kernel's
(:mod:`mocomp.core._compiled`: ``qmul``, ``qlog``, ``qexp``, ``qrot``, ``qmat``,
``slerp4`` inlined here); this module holds only the method's own loops. Without
numba (``MOCOMP_NO_NUMBA=1``) they run as plain Python: same results, slower.
"""
from __future__ import annotations

import math

import numpy as np

from ..core._compiled import centroid, njit, qdelta, qexp, qlog, qmat, qmul, qrot, slerp4, world_inertia

__all__ = ["direction_sweep", "interior_momentum", "rotate_frames", "momentum_blocks", "slerp_frames",
           "sampled_segments"]


@njit
def _angle(L, u):
    cx = L[1] * u[2] - L[2] * u[1]
    cy = L[2] * u[0] - L[0] * u[2]
    cz = L[0] * u[1] - L[1] * u[0]
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), L[0] * u[0] + L[1] * u[1] + L[2] * u[2])


@njit
def _frame_L(q, Iw, D, w_back, wf, C0, const, dt, R, out):
    """L at frame f when pose f+1 is rotated by ``q`` about its COM (eq. 5.21's L(R pose))."""
    qmat(q[0], q[1], q[2], q[3], R)
    # orbital part: axial(C0 R^T) / dt + const
    C = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            C[i, j] = C0[i, 0] * R[j, 0] + C0[i, 1] * R[j, 1] + C0[i, 2] * R[j, 2]
    out[0] = (C[1, 2] - C[2, 1]) / dt + const[0]
    out[1] = (C[2, 0] - C[0, 2]) / dt + const[1]
    out[2] = (C[0, 1] - C[1, 0]) / dt + const[2]
    S = D.shape[0]
    for s in range(S):
        a0, a1, a2, a3 = qmul(q[0], q[1], q[2], q[3], D[s, 0], D[s, 1], D[s, 2], D[s, 3])
        r0, r1, r2 = qlog(a0, a1, a2, a3)
        w0 = wf * r0 + w_back[s, 0]
        w1 = wf * r1 + w_back[s, 1]
        w2 = wf * r2 + w_back[s, 2]
        out[0] += Iw[s, 0, 0] * w0 + Iw[s, 0, 1] * w1 + Iw[s, 0, 2] * w2
        out[1] += Iw[s, 1, 0] * w0 + Iw[s, 1, 1] * w1 + Iw[s, 1, 2] * w2
        out[2] += Iw[s, 2, 0] * w0 + Iw[s, 2, 1] * w1 + Iw[s, 2, 2] * w2


@njit
def _rotate_frame(X, Q, pivot, f, q, R):
    """Rotate frame ``f``'s segment COMs about ``pivot`` and its orientations by ``q`` (in place)."""
    qmat(q[0], q[1], q[2], q[3], R)
    for s in range(X.shape[1]):
        d0 = X[f, s, 0] - pivot[0]
        d1 = X[f, s, 1] - pivot[1]
        d2 = X[f, s, 2] - pivot[2]
        X[f, s, 0] = pivot[0] + R[0, 0] * d0 + R[0, 1] * d1 + R[0, 2] * d2
        X[f, s, 1] = pivot[1] + R[1, 0] * d0 + R[1, 1] * d1 + R[1, 2] * d2
        X[f, s, 2] = pivot[2] + R[2, 0] * d0 + R[2, 1] * d1 + R[2, 2] * d2
        a0, a1, a2, a3 = qmul(q[0], q[1], q[2], q[3], Q[f, s, 0], Q[f, s, 1], Q[f, s, 2], Q[f, s, 3])
        Q[f, s, 0] = a0
        Q[f, s, 1] = a1
        Q[f, s, 2] = a2
        Q[f, s, 3] = a3


@njit
def direction_sweep(m, I_local, X, Q, t, U, a, b, tol, max_iter):
    """Eq. 5.18-5.21 over the flight ``[a, b)``: for ``f = a+1 .. b-2`` find the rotation of
    pose ``f+1`` about its COM that makes ``unit(L_f) = U[f]``, warm-started from the
    previous frame's rotation; Gauss-Newton on the unit-vector residual with an
    analytic Jacobian (minimum-norm step: rotations about ``L`` leave its direction
    alone) and step halving.

    ``X (T, S, 3)`` segment COMs and ``Q (T, S, 4)`` segment orientations are
    corrected in place. Returns ``(corr (T, 4), evaluations, first departure or -1,
    iterations (T,))``; ``corr[g]`` is the total rotation applied to frame ``g``
    about its COM (identity before the first departure; frames ``>= b`` get the last one).
    """
    T, S = X.shape[0], X.shape[1]
    M = 0.0
    for s in range(S):
        M += m[s]
    corr = np.zeros((T, 4))
    corr[:, 3] = 1.0
    iters = np.zeros(T, dtype=np.int64)
    pivots = np.zeros((T, 3))
    for f in range(T):
        for s in range(S):
            for k in range(3):
                pivots[f, k] += m[s] * X[f, s, k]
        for k in range(3):
            pivots[f, k] /= M
    cur = np.array([0.0, 0.0, 0.0, 1.0])
    R = np.empty((3, 3))
    Rf = np.empty((3, 3))
    Iw = np.empty((S, 3, 3))
    D = np.empty((S, 4))
    w_back = np.empty((S, 3))
    C0 = np.empty((3, 3))
    const = np.empty(3)
    ma = np.empty((S, 3))
    d = np.empty((S, 3))
    Iw_sum = np.empty((3, 3))
    L = np.empty(3)
    Ln = np.empty(3)
    u = np.empty(3)
    q = np.empty(4)
    qn = np.empty(4)
    ident = np.array([0.0, 0.0, 0.0, 1.0])
    evals = 0
    first = -1
    for f in range(a + 1, b - 1):
        if cur[3] < 1.0:
            _rotate_frame(X, Q, pivots[f + 1], f + 1, cur, R)
        h1 = t[f] - t[f - 1]
        h2 = t[f + 1] - t[f]
        dt = h1 + h2
        wf = h1 / dt / h2
        c1 = pivots[f + 1]
        for k in range(3):
            const[k] = 0.0
            for j in range(3):
                C0[k, j] = 0.0
                Iw_sum[k, j] = 0.0
        for s in range(S):
            for k in range(3):
                ma[s, k] = m[s] * (X[f, s, k] - pivots[f, k])
                d[s, k] = X[f + 1, s, k] - c1[k]
            # world inertia at f
            qmat(Q[f, s, 0], Q[f, s, 1], Q[f, s, 2], Q[f, s, 3], Rf)
            world_inertia(Rf, I_local, s, Iw[s])
            for i in range(3):
                for j in range(3):
                    Iw_sum[i, j] += Iw[s, i, j]
            # backward rotation vector q_f q_{f-1}^-1
            r0, r1, r2 = qdelta(Q, f - 1, f, s)
            w_back[s, 0] = h2 / dt * r0 / h1
            w_back[s, 1] = h2 / dt * r1 / h1
            w_back[s, 2] = h2 / dt * r2 / h1
            e0, e1, e2, e3 = qmul(Q[f + 1, s, 0], Q[f + 1, s, 1], Q[f + 1, s, 2], Q[f + 1, s, 3],
                                   -Q[f, s, 0], -Q[f, s, 1], -Q[f, s, 2], Q[f, s, 3])
            D[s, 0] = e0
            D[s, 1] = e1
            D[s, 2] = e2
            D[s, 3] = e3
            for i in range(3):
                for j in range(3):
                    C0[i, j] += ma[s, i] * d[s, j]
            v0 = c1[0] - X[f - 1, s, 0]
            v1 = c1[1] - X[f - 1, s, 1]
            v2 = c1[2] - X[f - 1, s, 2]
            const[0] += (ma[s, 1] * v2 - ma[s, 2] * v1) / dt
            const[1] += (ma[s, 2] * v0 - ma[s, 0] * v2) / dt
            const[2] += (ma[s, 0] * v1 - ma[s, 1] * v0) / dt
        for k in range(3):
            u[k] = U[f, k]
        _frame_L(ident, Iw, D, w_back, wf, C0, const, dt, R, L)
        evals += 1
        err = _angle(L, u)
        if err <= tol:
            for k in range(4):
                corr[f + 1, k] = cur[k]
            continue
        if first < 0:
            first = f
        for k in range(4):
            q[k] = ident[k]
        it = 0
        while it < max_iter:
            n = math.sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2])
            err_old = _angle(L, u)
            if err_old <= tol:
                break
            it += 1
            # Jacobian dL/dphi for q <- exp(phi) q: K/dt + wf * Iw_sum
            qmat(q[0], q[1], q[2], q[3], R)
            K = np.zeros((3, 3))
            ad = 0.0
            rd = np.empty((S, 3))
            for s in range(S):
                for i in range(3):
                    rd[s, i] = R[i, 0] * d[s, 0] + R[i, 1] * d[s, 1] + R[i, 2] * d[s, 2]
                ad += ma[s, 0] * rd[s, 0] + ma[s, 1] * rd[s, 1] + ma[s, 2] * rd[s, 2]
            for i in range(3):
                for j in range(3):
                    acc = 0.0
                    for s in range(S):
                        acc += rd[s, i] * ma[s, j]
                    K[i, j] = -acc
                K[i, i] += ad
            Jl = np.empty((3, 3))
            for i in range(3):
                for j in range(3):
                    Jl[i, j] = K[i, j] / dt + wf * Iw_sum[i, j]
            # J = (I - l l^T)/n @ Jl, residual e = L/n - u
            J = np.empty((3, 3))
            e = np.empty(3)
            for i in range(3):
                e[i] = L[i] / n - u[i]
                for j in range(3):
                    acc = 0.0
                    for k in range(3):
                        P = (1.0 if i == k else 0.0) - L[i] * L[k] / (n * n)
                        acc += P * Jl[k, j]
                    J[i, j] = acc / n
            JtJ = J.T @ J
            tr = JtJ[0, 0] + JtJ[1, 1] + JtJ[2, 2]
            for i in range(3):
                JtJ[i, i] += 1e-12 * tr
            step = -np.linalg.solve(JtJ, J.T @ e)
            accepted = False
            for _h in range(7):
                x0, x1, x2, x3 = qexp(step[0], step[1], step[2])
                a0, a1, a2, a3 = qmul(x0, x1, x2, x3, q[0], q[1], q[2], q[3])
                qn[0] = a0
                qn[1] = a1
                qn[2] = a2
                qn[3] = a3
                _frame_L(qn, Iw, D, w_back, wf, C0, const, dt, R, Ln)
                evals += 1
                if _angle(Ln, u) <= err_old:
                    accepted = True
                    break
                step *= 0.5
            for k in range(4):
                q[k] = qn[k]
            for k in range(3):
                L[k] = Ln[k]
            if not accepted:
                break
        iters[f + 1] = it
        nq = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        for k in range(4):
            q[k] /= nq
        _rotate_frame(X, Q, pivots[f + 1], f + 1, q, R)
        a0, a1, a2, a3 = qmul(q[0], q[1], q[2], q[3], cur[0], cur[1], cur[2], cur[3])
        nq = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3)
        cur[0] = a0 / nq
        cur[1] = a1 / nq
        cur[2] = a2 / nq
        cur[3] = a3 / nq
        for k in range(4):
            corr[f + 1, k] = cur[k]
    for g in range(b, T):
        for k in range(4):
            corr[g, k] = cur[k]
    return corr, evals, first, iters


@njit
def interior_momentum(m, I_local, X, Q, t):
    """``(n, 3)`` angular momentum about the COM (eq. 5.5) at frames ``1 .. n-2`` of segment COMs
    ``X (n, S, 3)`` and orientations ``Q (n, S, 4)`` at times ``t``; rows 0 and n-1 are NaN.

    Same discretisation as :func:`mocomp.dynamics.momentum` (``order=2``): non-uniform
    central differences of the segment COMs, angular velocities blending the backward and
    forward rotation vectors. The whole-body COM velocity cancels in ``L`` about the COM.
    """
    n, S = X.shape[0], X.shape[1]
    out = np.full((n, 3), np.nan)
    M = 0.0
    for s in range(S):
        M += m[s]
    Rf = np.empty((3, 3))
    for f in range(1, n - 1):
        h1 = t[f] - t[f - 1]
        h2 = t[f + 1] - t[f]
        dt = h1 + h2
        c0, c1, c2 = centroid(m, X, f, M)
        L0 = 0.0
        L1 = 0.0
        L2 = 0.0
        for s in range(S):
            r0, r1, r2 = qdelta(Q, f - 1, f, s)
            g0, g1, g2 = qdelta(Q, f, f + 1, s)
            w0 = (h1 * g0 / h2 + h2 * r0 / h1) / dt
            w1 = (h1 * g1 / h2 + h2 * r1 / h1) / dt
            w2 = (h1 * g2 / h2 + h2 * r2 / h1) / dt
            # R I R^T w = R (I (R^T w))
            qmat(Q[f, s, 0], Q[f, s, 1], Q[f, s, 2], Q[f, s, 3], Rf)
            u0 = Rf[0, 0] * w0 + Rf[1, 0] * w1 + Rf[2, 0] * w2
            u1 = Rf[0, 1] * w0 + Rf[1, 1] * w1 + Rf[2, 1] * w2
            u2 = Rf[0, 2] * w0 + Rf[1, 2] * w1 + Rf[2, 2] * w2
            v0 = I_local[s, 0, 0] * u0 + I_local[s, 0, 1] * u1 + I_local[s, 0, 2] * u2
            v1 = I_local[s, 1, 0] * u0 + I_local[s, 1, 1] * u1 + I_local[s, 1, 2] * u2
            v2 = I_local[s, 2, 0] * u0 + I_local[s, 2, 1] * u1 + I_local[s, 2, 2] * u2
            L0 += Rf[0, 0] * v0 + Rf[0, 1] * v1 + Rf[0, 2] * v2
            L1 += Rf[1, 0] * v0 + Rf[1, 1] * v1 + Rf[1, 2] * v2
            L2 += Rf[2, 0] * v0 + Rf[2, 1] * v1 + Rf[2, 2] * v2
            # orbital: m (x - c) x v, v by the non-uniform central difference
            p0 = X[f, s, 0] - c0
            p1 = X[f, s, 1] - c1
            p2 = X[f, s, 2] - c2
            a = h2 / (h1 * dt)
            bb = (h2 - h1) / (h1 * h2)
            c = h1 / (h2 * dt)
            q0 = -a * X[f - 1, s, 0] + bb * X[f, s, 0] + c * X[f + 1, s, 0]
            q1 = -a * X[f - 1, s, 1] + bb * X[f, s, 1] + c * X[f + 1, s, 1]
            q2 = -a * X[f - 1, s, 2] + bb * X[f, s, 2] + c * X[f + 1, s, 2]
            L0 += m[s] * (p1 * q2 - p2 * q1)
            L1 += m[s] * (p2 * q0 - p0 * q2)
            L2 += m[s] * (p0 * q1 - p1 * q0)
        out[f, 0] = L0
        out[f, 1] = L1
        out[f, 2] = L2
    return out


@njit
def slerp_frames(rot, i0, i1, alpha):
    """``(n, J, 4)`` local rotations at fractional frames: ``slerp(rot[i0], rot[i1], alpha)``
    per joint, exact copies where ``alpha == 0`` (as :meth:`mocomp.core.Motion.sample`)."""
    n = i0.shape[0]
    J = rot.shape[1]
    out = np.empty((n, J, 4))
    for k in range(n):
        a = alpha[k]
        for j in range(J):
            if a == 0.0:
                for c in range(4):
                    out[k, j, c] = rot[i0[k], j, c]
            else:
                a0, a1 = i0[k], i1[k]
                out[k, j, 0], out[k, j, 1], out[k, j, 2], out[k, j, 3], _ = slerp4(
                    rot[a0, j, 0], rot[a0, j, 1], rot[a0, j, 2], rot[a0, j, 3],
                    rot[a1, j, 0], rot[a1, j, 1], rot[a1, j, 2], rot[a1, j, 3], a, 2.0)
    return out


@njit
def sampled_segments(parents, offsets, root_pos, rot, i0, i1, alpha, seg_joint, local_coms):
    """Segment COMs ``(n, S, 3)`` and orientations ``(n, S, 4)`` of the motion sampled at
    fractional frames (root linear, joints slerped, then forward kinematics): the fused
    equivalent of ``segment_state(body, motion.sample(times))`` without the intermediate arrays."""
    n = i0.shape[0]
    J = rot.shape[1]
    S = seg_joint.shape[0]
    X = np.empty((n, S, 3))
    Q = np.empty((n, S, 4))
    G = np.empty((J, 4))
    P = np.empty((J, 3))
    loc = np.empty(4)
    for k in range(n):
        a = alpha[k]
        for j in range(J):
            if a == 0.0:
                for c in range(4):
                    loc[c] = rot[i0[k], j, c]
            else:
                a0, a1 = i0[k], i1[k]
                loc[0], loc[1], loc[2], loc[3], _ = slerp4(
                    rot[a0, j, 0], rot[a0, j, 1], rot[a0, j, 2], rot[a0, j, 3],
                    rot[a1, j, 0], rot[a1, j, 1], rot[a1, j, 2], rot[a1, j, 3], a, 2.0)
            p = parents[j]
            if p < 0:
                for c in range(4):
                    G[j, c] = loc[c]
                for c in range(3):
                    P[j, c] = (1.0 - a) * root_pos[i0[k], c] + a * root_pos[i1[k], c]
            else:
                g0, g1, g2, g3 = qmul(G[p, 0], G[p, 1], G[p, 2], G[p, 3], loc[0], loc[1], loc[2], loc[3])
                G[j, 0] = g0
                G[j, 1] = g1
                G[j, 2] = g2
                G[j, 3] = g3
                v = qrot(G[p, 0], G[p, 1], G[p, 2], G[p, 3], offsets[j, 0], offsets[j, 1], offsets[j, 2])
                for c in range(3):
                    P[j, c] = P[p, c] + v[c]
        for s in range(S):
            j = seg_joint[s]
            for c in range(4):
                Q[k, s, c] = G[j, c]
            v = qrot(G[j, 0], G[j, 1], G[j, 2], G[j, 3], local_coms[s, 0], local_coms[s, 1], local_coms[s, 2])
            for c in range(3):
                X[k, s, c] = P[j, c] + v[c]
    return X, Q


# ------------------------------------------------ joint direction solve (eq. 5.21 stacked)
@njit(inline="always")
def _jl_inv(r0, r1, r2, J):
    """Inverse left Jacobian of SO(3) at rotation vector ``r``: ``log(exp(d) exp(r)) ~ r + J d``."""
    th2 = r0 * r0 + r1 * r1 + r2 * r2
    th = math.sqrt(th2)
    if th < 1e-6:
        k = 1.0 / 12.0
    else:
        k = (1.0 - 0.5 * th * math.sin(th) / (1.0 - math.cos(th))) / th2
    # I - 1/2 [r]x + k [r]x^2, [r]x^2 = r r^T - th2 I
    J[0, 0] = 1.0 + k * (r0 * r0 - th2)
    J[1, 1] = 1.0 + k * (r1 * r1 - th2)
    J[2, 2] = 1.0 + k * (r2 * r2 - th2)
    J[0, 1] = 0.5 * r2 + k * r0 * r1
    J[1, 0] = -0.5 * r2 + k * r0 * r1
    J[0, 2] = -0.5 * r1 + k * r0 * r2
    J[2, 0] = 0.5 * r1 + k * r0 * r2
    J[1, 2] = 0.5 * r0 + k * r1 * r2
    J[2, 1] = -0.5 * r0 + k * r1 * r2


@njit
def rotate_frames(X, Q, pivots, corr):
    """Copies of ``X (n, S, 3)``, ``Q (n, S, 4)`` with frame ``g`` rotated by ``corr[g]`` about ``pivots[g]``."""
    Xc = X.copy()
    Qc = Q.copy()
    R = np.empty((3, 3))
    for g in range(X.shape[0]):
        if corr[g, 3] < 1.0:
            _rotate_frame(Xc, Qc, pivots[g], g, corr[g], R)
    return Xc, Qc


@njit
def momentum_blocks(m, I_local, X, Q, t, pivots):
    """``L (n, 3)`` (eq. 5.5, central differences, as :func:`interior_momentum`) and its
    derivatives with respect to a rotation of the whole pose at frames ``f-1``, ``f`` and
    ``f+1`` about that frame's COM (``Jm``, ``J0``, ``Jp``, each ``(n, 3, 3)``; left
    perturbations ``q_g <- exp(delta) q_g``), on frames ``1 .. n-2`` (rows 0 and n-1 zero).

    With ``a = x_f - c_f``, ``d_g = x_g - c_g`` and ``v = al d_{f-1} + be a + ga d_{f+1}``
    (the non-uniform central difference; the COM velocity cancels in L about the COM):
    ``Jp = sum ga m ((a.d+) I - d+ a^T) + wf Iw Jl^-1(r_fwd)``,
    ``Jm = sum al m ((a.d-) I - d- a^T) - wb Iw Jr^-1(r_back)``,
    ``J0 = sum m (a v^T - (a.v) I) + be m (|a|^2 I - a a^T) - [Iw w]x + Iw [w]x
    + Iw (wb Jl^-1(r_back) - wf Jr^-1(r_fwd))``; ``Jm + J0 + Jp = -[L]x`` (a rigid rotation of
    every frame rotates L).
    """
    n, S = X.shape[0], X.shape[1]
    L = np.zeros((n, 3))
    Jm = np.zeros((n, 3, 3))
    J0 = np.zeros((n, 3, 3))
    Jp = np.zeros((n, 3, 3))
    Rf = np.empty((3, 3))
    Iw = np.empty((3, 3))
    Jf = np.empty((3, 3))
    Jb = np.empty((3, 3))
    IJ = np.empty((3, 3))
    for f in range(1, n - 1):
        h1 = t[f] - t[f - 1]
        h2 = t[f + 1] - t[f]
        dt = h1 + h2
        al = -h2 / (h1 * dt)
        be = (h2 - h1) / (h1 * h2)
        ga = h1 / (h2 * dt)
        wf = h1 / (dt * h2)
        wb = h2 / (dt * h1)
        for s in range(S):
            ms = m[s]
            a0 = X[f, s, 0] - pivots[f, 0]
            a1 = X[f, s, 1] - pivots[f, 1]
            a2 = X[f, s, 2] - pivots[f, 2]
            p0 = X[f + 1, s, 0] - pivots[f + 1, 0]
            p1 = X[f + 1, s, 1] - pivots[f + 1, 1]
            p2 = X[f + 1, s, 2] - pivots[f + 1, 2]
            q0 = X[f - 1, s, 0] - pivots[f - 1, 0]
            q1 = X[f - 1, s, 1] - pivots[f - 1, 1]
            q2 = X[f - 1, s, 2] - pivots[f - 1, 2]
            v0 = al * q0 + be * a0 + ga * p0
            v1 = al * q1 + be * a1 + ga * p1
            v2 = al * q2 + be * a2 + ga * p2
            rb0, rb1, rb2 = qdelta(Q, f - 1, f, s)
            rf0, rf1, rf2 = qdelta(Q, f, f + 1, s)
            w0 = wf * rf0 + wb * rb0
            w1 = wf * rf1 + wb * rb1
            w2 = wf * rf2 + wb * rb2
            qmat(Q[f, s, 0], Q[f, s, 1], Q[f, s, 2], Q[f, s, 3], Rf)
            world_inertia(Rf, I_local, s, Iw)
            h0 = Iw[0, 0] * w0 + Iw[0, 1] * w1 + Iw[0, 2] * w2
            hh1 = Iw[1, 0] * w0 + Iw[1, 1] * w1 + Iw[1, 2] * w2
            hh2 = Iw[2, 0] * w0 + Iw[2, 1] * w1 + Iw[2, 2] * w2
            L[f, 0] += h0 + ms * (a1 * v2 - a2 * v1)
            L[f, 1] += hh1 + ms * (a2 * v0 - a0 * v2)
            L[f, 2] += hh2 + ms * (a0 * v1 - a1 * v0)
            av = (a0, a1, a2)
            pv = (p0, p1, p2)
            qv = (q0, q1, q2)
            vv = (v0, v1, v2)
            ww = (w0, w1, w2)
            ad_p = a0 * p0 + a1 * p1 + a2 * p2
            ad_m = a0 * q0 + a1 * q1 + a2 * q2
            aa = a0 * a0 + a1 * a1 + a2 * a2
            a_v = a0 * v0 + a1 * v1 + a2 * v2
            for i in range(3):
                for j in range(3):
                    dij = 1.0 if i == j else 0.0
                    Jp[f, i, j] += ga * ms * (ad_p * dij - pv[i] * av[j])
                    Jm[f, i, j] += al * ms * (ad_m * dij - qv[i] * av[j])
                    J0[f, i, j] += ms * (av[i] * vv[j] - a_v * dij) + be * ms * (aa * dij - av[i] * av[j])
            # - [Iw w]x + Iw [w]x
            hv = (h0, hh1, hh2)
            J0[f, 0, 1] += hv[2]
            J0[f, 0, 2] -= hv[1]
            J0[f, 1, 0] -= hv[2]
            J0[f, 1, 2] += hv[0]
            J0[f, 2, 0] += hv[1]
            J0[f, 2, 1] -= hv[0]
            for i in range(3):
                # (Iw [w]x)[i, j] = sum_k Iw[i, k] [w]x[k, j]
                J0[f, i, 0] += Iw[i, 1] * ww[2] - Iw[i, 2] * ww[1]
                J0[f, i, 1] += Iw[i, 2] * ww[0] - Iw[i, 0] * ww[2]
                J0[f, i, 2] += Iw[i, 0] * ww[1] - Iw[i, 1] * ww[0]
            _jl_inv(rf0, rf1, rf2, Jf)
            _jl_inv(rb0, rb1, rb2, Jb)
            for i in range(3):
                for j in range(3):
                    accf = 0.0
                    accfT = 0.0
                    accb = 0.0
                    accbT = 0.0
                    for k in range(3):
                        accf += Iw[i, k] * Jf[k, j]
                        accfT += Iw[i, k] * Jf[j, k]
                        accb += Iw[i, k] * Jb[k, j]
                        accbT += Iw[i, k] * Jb[j, k]
                    Jp[f, i, j] += wf * accf
                    Jm[f, i, j] -= wb * accbT
                    J0[f, i, j] += wb * accb - wf * accfT
    return L, Jm, J0, Jp

