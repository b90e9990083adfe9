"""The direction of L kept constant by all flight frames' corrections at once (a stacked
form of dissertation eq. 5.18-5.21; used by :func:`mocomp.edit.restore.correct_direction`
with ``method="smooth"``, the default).

**Why.** Eq. 5.21 fixes the rotation ``R_{f+1}`` of frame ``f+1`` so that ``L_f``,
computed from frames ``f-1, f, f+1`` (central differences), points along ``L*``; frame
after frame. ``L_f`` depends mostly on the *velocity* of the correction,
``(R_{f+1} - R_{f-1}) / 2h``, and only weakly on ``R_f`` (through the lever arms and
inertias at ``f``). The recurrence is therefore a leapfrog scheme: even and odd frames
form two nearly independent chains, and its parasitic mode (a ``(-1)^f`` alternation) is
neutrally stable. A fast limb motion excites it and nothing damps it: the corrections
jitter from frame to frame by up to tens of degrees (measured: the ``straight-legs``
preset with a 0.2 ease on the synthetic side flip, 49 deg of second difference;
``arms-twist`` with a 0.05 ease on the back flip, 12 deg) while every frame's direction
error is ~1e-7 rad. Where the mode is only weakly excited (``straight-legs`` with the
default 0.45 ease) its size is set by round-off: 0.3 to 8 deg of second difference
under 1e-9 rad changes of one input frame or a different summation order in a kernel,
while the joint solve stays at 0.30-0.36 deg.

**What.** Eq. 5.21 fixes two of each frame's three rotational degrees of freedom (a
rotation about ``L`` leaves its direction alone), and the recurrence's parasitic mode
barely changes ``L`` (it cancels in the central difference). So the corrections of the
whole flight, rotation vectors ``phi_g`` on frames ``f*+1 .. stop-1`` (frames up to the
first departure ``f*`` stay untouched, as in section 5.5.1), are found together:

1. the per-frame (Gauss-Newton) solution of eq. 5.21, low-passed frame to frame
   (Gaussian, ``sigma`` ~ 1.5 frames: removes the even/odd alternation, keeps the
   body's reaction to the limbs);
2. projected back onto the *same* constraints, ``unit(L_f(R_{f-1}, R_f, R_{f+1})) =
   unit(L*_f)`` on every flight frame ``f* .. stop-2``, by Newton steps that are the
   smallest in the metric ``|D2 dphi|^2 + w1 |D1 dphi|^2`` (second and first differences
   over the flight: the projection adds only smooth corrections and no drift). Each step
   linearises ``B_f^T unit(L_f)`` (``B_f``: two unit vectors orthogonal to the target)
   with the analytic block-tridiagonal Jacobian
   (:func:`mocomp.edit._kernels.momentum_blocks`) and solves one KKT system of the whole
   flight -- its unknowns ordered frame by frame, it is a band matrix (half-bandwidth 10),
   solved by LAPACK's banded LU (``dgbsv``, :func:`_kkt_layout`) -- backtracking on the
   summed direction error (zero on the target only, not on its antipode). 3-5 steps reach
   ~1e-10 rad.

Same constraints and tolerance as the paper's method; a different member of their
solution family. A full sequential-QP minimisation of ``|D2 phi|^2`` under the
constraints was tried and converges only linearly (the constraints' curvature, with
corrections far along the family's free directions, dominates; 10-80 iterations,
30-240 ms per flight) for similar roughness; the projection costs ~8.5 ms (synthetic side
flip, 4 Newton steps, on a host where a pure-Python 10M loop takes 1.4 s; the general sparse
LU, ``scipy.sparse.linalg.splu``, that the band solve replaced took ~21 ms there, the same
corrections to 2e-15).
If the projection does not reach the tolerance, the caller keeps the per-frame solution.

Measured (synthetic flips, roughness = largest second difference of the corrections,
per-frame -> joint; direction error after both < 1e-7 rad): side flip ``straight-legs``
default ease 8.3 -> 0.34 deg, ease 0.2 49.6 -> 1.0 deg; back flip ``arms-twist`` ease
0.05 12.2 -> 3.4 deg. The 3.4 deg left are the body's reaction to arms snapped out
within 3 frames: at 4x the frame rate the joint solution shows the same on the 120 Hz
grid (3.2 deg) while the per-frame one still jitters (11.2 deg).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dgbsv

__all__ = ["SmoothSolve", "smooth_corrections", "rotvecs_continuous", "second_difference_deg"]


@dataclass(frozen=True, eq=False)
class SmoothSolve:
    """Evidence of one stacked solve.

    corrections: ``(n, 4)`` quaternions (frame ``g`` of the flight slice rotated about its COM).
    converged: whether the constraints reached ``tol`` and the steps became negligible.
    iterations: SQP iterations; evaluations: L evaluations (Jacobian ones included).
    max_error: largest direction error (rad) at the returned corrections.
    objective_start, objective_end: ``sum |second difference of phi|^2`` (rad^2) of the
    per-frame corrections and of the returned ones.
    projection: rad, the second-difference norm of the projection's change to the low-passed start.
    """

    corrections: np.ndarray
    converged: bool
    iterations: int
    evaluations: int
    max_error: float
    objective_start: float
    objective_end: float
    projection: float = 0.0


def _skew(v: np.ndarray) -> np.ndarray:
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def _left_jacobian(phi: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` left Jacobian of SO(3): ``exp(phi + d) ~ exp(J d) exp(phi)``."""
    th = np.linalg.norm(phi, axis=-1)[:, None, None]
    K = _skew(phi)
    small = th < 1e-6
    ths = np.where(small, 1.0, th)
    c1 = np.where(small, 0.5, (1 - np.cos(ths)) / ths ** 2)
    c2 = np.where(small, 1.0 / 6.0, (ths - np.sin(ths)) / ths ** 3)
    return np.eye(3) + c1 * K + c2 * (K @ K)


def _exp(phi: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(phi, axis=-1, keepdims=True)
    k = np.where(a > 1e-12, np.sin(0.5 * a) / np.where(a > 1e-12, a, 1.0), 0.5)
    return np.concatenate([phi * k, np.cos(0.5 * a)], axis=-1)


def rotvecs_continuous(q: np.ndarray) -> np.ndarray:
    """Rotation vectors of a sequence of unit quaternions, continuous from row to row
    (angles may exceed pi rather than jump by 2 pi)."""
    q = np.array(q, dtype=float)
    for i in range(1, q.shape[0]):
        if q[i] @ q[i - 1] < 0:
            q[i] = -q[i]
    if q[0, 3] < 0:
        q = -q
    v = q[:, :3]
    s = np.linalg.norm(v, axis=1)
    ang = 2.0 * np.arctan2(s, q[:, 3])
    k = np.where(s > 1e-12, ang / np.where(s > 1e-12, s, 1.0), 2.0)
    return v * k[:, None]


def second_difference_deg(q: np.ndarray) -> np.ndarray:
    """``(n-3,)`` degrees: change of the per-frame increment ``q_{g+1} q_g^-1`` from frame to
    frame -- the roughness measure of :attr:`mocomp.edit.DirectionResult.roughness_deg`. The
    increments are core's rotation vectors (:func:`~mocomp.core.rotations.quat_log`, the short way)
    of the normalised relative rotations."""
    from ..core.rotations import quat_inverse, quat_log, quat_multiply

    if q.shape[0] < 4:
        return np.zeros(0)
    q = np.asarray(q, dtype=float)
    d = quat_multiply(q[1:], quat_inverse(q[:-1]))
    inc = quat_log(d / np.sqrt(np.einsum("...i,...i->...", d, d))[..., None])
    return np.degrees(np.linalg.norm(inc[2:] - 2 * inc[1:-1] + inc[:-2], axis=1))


def _basis(U: np.ndarray) -> np.ndarray:
    """``(n, 2, 3)``: two unit vectors orthogonal to each unit row of ``U``."""
    e = np.zeros_like(U)
    e[np.arange(U.shape[0]), np.argmin(np.abs(U), axis=1)] = 1.0
    b1 = np.cross(U, e)
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    b2 = np.cross(U, b1)
    return np.stack([b1, b2], axis=1)


def _second_diff_rows(P: np.ndarray, f0: int) -> np.ndarray:
    """``D @ x`` of :func:`smooth_corrections`' metric as rows: ``phi_{f-1} - 2 phi_f + phi_{f+1}``
    on frames ``f0 .. n-2`` of ``P (n, 3)`` (zero on frames ``<= f0``), flattened."""
    return (P[f0 - 1:-2] - 2 * P[f0:-1] + P[f0 + 1:]).ravel()


def _kkt_layout(n: int, f0: int, w1: float, w0: float):
    """The KKT system of :func:`smooth_corrections` as a band matrix.

    Unknowns in the natural order ``[dphi (3 nv), lambda (2 nc)]`` are permuted frame by
    frame (frame ``f``: its two multipliers, then its three rotation components), which makes
    the matrix banded (``L_f`` couples frames ``f-1 .. f+1``, the second-difference metric
    ``f-2 .. f+2``): half-bandwidths ~12 over ~5 n unknowns, solved by LAPACK's banded LU
    (``gbsv``, partial pivoting) in O(n) instead of a general sparse LU.

    Returns ``(perm, l, u, h_rows, h_cols, h_vals, ii, jj)``: ``perm[k]`` the band position of
    natural unknown ``k``; the metric ``H = D^T D + w1 D1^T D1 + (w0 + 1e-10 max diag D^T D) I``
    as band-position triplets (its entries are integers plus the diagonal shift, so exactly
    those of the sparse construction); ``ii``, ``jj`` the natural row (multiplier) and column
    (variable) of each constraint-Jacobian value in the order :func:`smooth_corrections` fills them.
    """
    free0 = f0 + 1
    nv, nc = n - free0, n - 1 - f0
    # frame-level metric: rows f0 .. n-2 of the second / first difference (columns: free frames,
    # at most three entries a row), accumulated as outer products of the rows -- integers, so
    # exact in any order (and no BLAS call: a dense matmul of this size costs milliseconds
    # on a loaded host)
    f = np.arange(f0, n - 1)
    cols = np.stack([f - 1, f, f + 1], axis=1) - free0                  # (nc, 3)
    c2 = np.where(cols >= 0, [1.0, -2.0, 1.0], 0.0)
    c1 = np.where(cols >= 0, [0.0, -1.0, 1.0], 0.0)
    cl = np.maximum(cols, 0)
    h2 = np.zeros((nv, nv))
    h1 = np.zeros((nv, nv))
    ri, rj = cl[:, :, None], cl[:, None, :]
    np.add.at(h2, (np.broadcast_to(ri, (nc, 3, 3)), np.broadcast_to(rj, (nc, 3, 3))), c2[:, :, None] * c2[:, None, :])
    np.add.at(h1, (np.broadcast_to(ri, (nc, 3, 3)), np.broadcast_to(rj, (nc, 3, 3))), c1[:, :, None] * c1[:, None, :])
    h = h2 + w1 * h1
    shift = w0 + 1e-10 * float(np.max(np.diag(h2)))
    gi, gj = np.nonzero(h)
    hv = h[gi, gj] + np.where(gi == gj, shift, 0.0)
    a3 = np.arange(3)
    h_rows = (3 * gi[:, None] + a3).ravel()
    h_cols = (3 * gj[:, None] + a3).ravel()
    h_vals = np.repeat(hv, 3)
    # band positions: frame f0 .. n-1 holds [lambda_f (if f <= n-2), dphi_f (if f >= f0+1)]
    fr = np.arange(f0, n)
    has_l, has_x = fr <= n - 2, fr >= free0
    size = 2 * has_l + 3 * has_x
    start = np.cumsum(size) - size
    px = (start + 2 * has_l)[has_x]
    pl = start[has_l]
    perm = np.concatenate([(px[:, None] + a3).ravel(), (pl[:, None] + np.arange(2)).ravel()])
    # constraint-Jacobian pattern (as smooth_corrections: L_f couples frames f-1, f, f+1)
    cons = np.arange(f0, n - 1)
    off = np.repeat([-1, 0, 1], nc)
    rows = np.tile(np.arange(nc), 3)
    g = cons[rows] + off
    keep = g >= free0
    blk_r, blk_g = rows[keep], g[keep]
    ii = np.broadcast_to(2 * blk_r[:, None, None] + np.arange(2)[None, :, None], (blk_r.size, 2, 3)).ravel()
    jj = np.broadcast_to(3 * (blk_g - free0)[:, None, None] + a3[None, None, :], (blk_r.size, 2, 3)).ravel()
    # half-bandwidths of the permuted matrix
    pr = np.concatenate([perm[h_rows], perm[3 * nv + ii], perm[jj]])
    pc = np.concatenate([perm[h_cols], perm[jj], perm[3 * nv + ii]])
    l = int(np.max(pr - pc))
    u = int(np.max(pc - pr))
    return perm, l, u, perm[h_rows], perm[h_cols], h_vals, ii, jj, shift


def smooth_corrections(m, I_local, X, Q, t, U, f0: int, init: np.ndarray, sigma: float = 1.5,
                       tol: float = 1e-7, max_iter: int = 20, w1: float = 1.0, w0: float = 0.0) -> SmoothSolve:
    """Smooth, then project back onto eq. 5.21's constraints (module docstring).

    ``X (n, S, 3)``, ``Q (n, S, 4)``: the uncorrected segment state of the flight slice;
    ``t (n,)`` s; ``U (n, 3)`` unit targets; ``f0``: the first departure (local index >= 1;
    frames ``<= f0`` stay uncorrected); ``init (n, 4)``: the per-frame corrections;
    ``sigma``: the Gaussian low-pass width in frames; ``tol``: direction error (rad) to reach;
    ``w1``, ``w0``: weights of the first differences and of the change itself in the
    projection's metric (the second differences have weight 1).
    """
    from scipy.ndimage import gaussian_filter1d

    from ._kernels import interior_momentum, momentum_blocks, rotate_frames

    n = X.shape[0]
    pivots = np.ascontiguousarray(np.einsum("s,tsk->tk", m, X) / m.sum())
    free = np.arange(f0 + 1, n)             # variables: frames f0+1 .. n-1
    cons = np.arange(f0, n - 1)             # constraints: L at frames f0 .. n-2
    nv, nc = free.size, cons.size
    Uc = U[cons]
    B = _basis(Uc)
    # the metric (second plus first differences over the flight) and the KKT band layout
    perm, lo, up, hr, hc, hv, ii, jj, _ = _kkt_layout(n, f0, w1, w0)
    N = 3 * nv + 2 * nc
    phi0 = rotvecs_continuous(init)
    phi0[:f0 + 1] = 0.0
    phi = gaussian_filter1d(phi0, sigma, axis=0, mode="nearest") if sigma > 0 else phi0.copy()
    phi[:f0 + 1] = 0.0
    ref = phi[free].ravel().copy()
    # sparsity of the constraint Jacobian: L_f couples frames f-1, f, f+1
    off = np.repeat([-1, 0, 1], nc)
    rows = np.tile(np.arange(nc), 3)
    g = cons[rows] + off
    keep = g >= free[0]
    blk_r, blk_k, blk_g = rows[keep], off[keep] + 1, g[keep]
    # band storage of the permuted symmetric KKT [[H, A^T], [A, 0]]
    pa, pj = perm[3 * nv + ii], perm[jj]
    # (LAPACK gbsv layout: lo extra rows on top for the LU's fill-in, then ab[lo + up + i - j, j])
    ab0 = np.zeros((2 * lo + up + 1, N))
    ab0[lo + up + hr - hc, hc] = hv
    a_r, a_c = lo + up + pa - pj, pj      # A entries (row: multiplier, column: variable)
    t_r, t_c = lo + up + pj - pa, pa      # their transposes
    evals = 0

    def state(ph):
        return rotate_frames(X, Q, pivots, np.ascontiguousarray(_exp(ph)))

    def errors(L):
        Lc = L[cons]
        return np.arctan2(np.linalg.norm(np.cross(Lc, Uc), axis=1), np.sum(Lc * Uc, axis=1))

    def residual(L):
        Lc = L[cons]
        return np.einsum("fij,fj->fi", B, Lc / np.linalg.norm(Lc, axis=1, keepdims=True)).ravel()

    Xc, Qc = state(phi)
    L = interior_momentum(m, I_local, Xc, Qc, t)
    evals += 1
    err = errors(L)
    it = 0
    while err.max() > tol and it < max_iter:
        it += 1
        L, Jm, J0, Jp = momentum_blocks(m, I_local, Xc, Qc, t, pivots)
        evals += 1
        Lc = L[cons]
        nL = np.linalg.norm(Lc, axis=1)
        lu = Lc / nL[:, None]
        G = np.einsum("fij,fjk->fik", B, (np.eye(3) - lu[:, :, None] * lu[:, None, :]) / nL[:, None, None])
        Jb = np.stack([Jm[cons], J0[cons], Jp[cons]])                 # (3, nc, 3, 3)
        vals = np.einsum("bij,bjk,bkl->bil", G[blk_r], Jb[blk_k, blk_r], _left_jacobian(phi[blk_g]))
        v = vals.ravel()
        ab = ab0.copy()
        ab[a_r, a_c] = v
        ab[t_r, t_c] = v
        rhs = np.zeros(N)
        rhs[perm[3 * nv:]] = -residual(L)
        x = phi[free].ravel()
        # Newton step onto the linearised constraints, smallest in the second-difference metric
        _, _, y, info = dgbsv(lo, up, ab, rhs, overwrite_ab=1, overwrite_b=1)
        if info != 0:                      # singular (info > 0) or bad argument
            break
        dx = y[perm[:3 * nv]]
        if not np.all(np.isfinite(dx)):
            break
        # backtrack on the summed direction error (angles: zero on the target only, not on its antipode)
        alpha, e0 = 1.0, float(err.sum())
        for _ in range(8):
            trial = phi.copy()
            trial[free] = (x + alpha * dx).reshape(nv, 3)
            Xt, Qt = state(trial)
            Lt = interior_momentum(m, I_local, Xt, Qt, t)
            evals += 1
            et = errors(Lt)
            if np.all(np.isfinite(et)) and et.sum() < e0:
                break
            alpha *= 0.5
        else:
            break
        phi, Xc, Qc, L, err = trial, Xt, Qt, Lt, et
    dphi = np.zeros_like(phi)
    dphi[free] = phi[free] - ref.reshape(nv, 3)
    change = _second_diff_rows(dphi, f0)
    return SmoothSolve(corrections=_exp(phi), converged=bool(err.max() <= tol), iterations=it,
                       evaluations=evals, max_error=float(err.max()) if err.size else 0.0,
                       objective_start=float(np.sum(_second_diff_rows(phi0, f0) ** 2)),
                       objective_end=float(np.sum(_second_diff_rows(phi, f0) ** 2)),
                       projection=float(np.sqrt(change @ change)))
