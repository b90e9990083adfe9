"""Compiled (numba) window distances and the compiled unique-frame search (eq. 4.1-4.2, Appendix A).

:func:`window_distances_nb` computes, for candidate windows starting at library rows ``starts``,

    D = sum_f w_f sum_b ( w_p,b |(p_b - g_s) - R_y(psi_s) q_b,f| + w_theta,b 2 acos |<o_b, q_y(psi_s) Q_b,f>| )

i.e. eq. 4.1 between the query window (aligned at its first frame: ``qp``, ``qo``) and the library
window aligned at its own first frame (root ground point ``g_s``, heading ``psi_s``): comparing
``R_y(-psi)(p - g)`` with ``q`` equals comparing ``p - g`` with ``R_y(psi) q``, and
``<q_y(-psi) o, Q> = <o, q_y(psi) Q> = cos(psi/2) <o, Q> + sin(psi/2) <o, Y Q>`` with ``Y`` the pure
quaternion ``(0, 1, 0, 0)`` (``yq = Y Q`` is precomputed), so nothing is rotated per candidate.
It is the exhaustive search's kernel (every frame of every window, no abandoning) and the
reference the compiled search is tested against.

:func:`search_nb` is the whole unique-frame search of :func:`mocomp.impact.search.search` in one
compiled call (the unique-frame pass, the choice of the regions, their refinement, the
runner-up); per window it runs two stages, both exact with respect to the window's fate:

1. a **lower bound** of every frame term, with the geodesic angle ``2 acos|d|`` replaced by the
   chord bound ``2 sqrt(2 (1 - |d|)) = 4 sin(theta/4) <= theta`` (no ``acos``: a square root,
   ~10x cheaper, within ``theta^2/96`` of the angle), summed in window order; the window is dropped
   as soon as the bound's partial sum, or that sum plus the triangle-inequality bound of the rest
   (:func:`_rest_bound`), exceeds the threshold;
2. for a window that survives, the **exact** terms (the same arithmetic as
   :func:`window_distances_nb`, so its distance is bit-identical to the exhaustive one's), dropped
   as soon as the exact partial sum plus the stage-1 bounds of the remaining frames exceeds the
   threshold.

A window whose distance is within the threshold is therefore never dropped (the comparisons carry
a relative slack of 1e-10 against rounding of the bound), and no window above it is kept.

Without numba (``MOCOMP_NO_NUMBA=1`` or numba missing) the search runs its numpy reference
(:meth:`mocomp.impact.search._Query.terms` and the Python control flow of
:mod:`mocomp.impact.search`); ``tests/test_impact_search.py`` compares the two.
"""
from __future__ import annotations

import os

import numpy as np

try:                                                   # the project's one numba switch, when present
    from ..core._compiled import AVAILABLE
except ImportError:                                    # pragma: no cover - older core
    AVAILABLE = os.environ.get("MOCOMP_NO_NUMBA", "").strip() in ("", "0")
    if AVAILABLE:
        try:
            import numba  # noqa: F401
        except Exception:
            AVAILABLE = False

if AVAILABLE:
    import numba

__all__ = ["AVAILABLE", "window_distances_nb", "rest_bounds_nb", "search_nb", "query_nb", "steps_nb", "trig_nb", "SLACK"]

#: relative slack of the bound comparisons (rounding of the chord bound near theta = 0)
SLACK = 1e-10


if AVAILABLE:
    @numba.njit(cache=True, nogil=True, inline="always")
    def _frame_term(P, O, r, qp, qo, yq, f, wp, wr, g0, g1, g2, c, sn, ch, sh, exact):
        """Eq. 4.1's term of library row ``r`` against query frame ``f`` (unweighted by ``w_f``);
        ``exact=False``: the chord lower bound of the angles."""
        term = 0.0
        for b in range(wp.shape[0]):
            qx = qp[f, b, 0]
            qz = qp[f, b, 2]
            dx = P[r, b, 0] - g0 - (c * qx + sn * qz)
            dy = P[r, b, 1] - g1 - qp[f, b, 1]
            dz = P[r, b, 2] - g2 - (c * qz - sn * qx)
            d1 = (O[r, b, 0] * qo[f, b, 0] + O[r, b, 1] * qo[f, b, 1] + O[r, b, 2] * qo[f, b, 2]
                  + O[r, b, 3] * qo[f, b, 3])
            d2 = (O[r, b, 0] * yq[f, b, 0] + O[r, b, 1] * yq[f, b, 1] + O[r, b, 2] * yq[f, b, 2]
                  + O[r, b, 3] * yq[f, b, 3])
            dot = abs(ch * d1 + sh * d2)
            if dot > 1.0:
                dot = 1.0
            if exact:
                term += wp[b] * np.sqrt(dx * dx + dy * dy + dz * dz) + wr[b] * 2.0 * np.arccos(dot)
            else:
                term += wp[b] * np.sqrt(dx * dx + dy * dy + dz * dz) + wr[b] * 2.0 * np.sqrt(2.0 - 2.0 * dot)
        return term

    @numba.njit(cache=True, nogil=True)
    def window_distances_nb(P, O, G, T, starts, frames, qp, qo, yq, w, wp, wr, f_start, acc0, term0,
                            Cl, Cq, threshold, margin, out):
        """Fill ``out (K,)`` with the window distances (``inf`` when abandoned); return the number
        of frame pairs compared.

        Frames ``frames[f_start:]`` are computed, after ``acc0 (K,)`` accumulated over the earlier
        ones (``term0 (K,)``: the unweighted term of frame ``f_start - 1``). ``Cl (N,)`` and ``Cq (F,)``
        are prefix sums of the library's and the query's frame-to-frame distances (empty: no bound).
        Early abandoning when the partial sum exceeds the threshold (all terms are >= 0); with
        ``margin >= 0`` the threshold follows the best complete window + ``margin``."""
        K = starts.shape[0]
        F = frames.shape[0]
        thr = threshold
        compared = 0
        use_bound = Cq.shape[0] == F
        for k in range(K):
            s = starts[k]
            acc = acc0[k]
            abandoned = acc > thr
            if not abandoned and use_bound and f_start > 0:
                abandoned = acc + _rest_bound(term0[k], f_start - 1, s, frames, w, Cl, Cq) > thr
            if abandoned:
                out[k] = np.inf
                continue
            c, sn, ch, sh = T[s, 0], T[s, 1], T[s, 2], T[s, 3]
            for f in range(f_start, F):
                term = _frame_term(P, O, s + frames[f], qp, qo, yq, f, wp, wr, G[s, 0], G[s, 1], G[s, 2],
                                   c, sn, ch, sh, True)
                acc += w[f] * term
                compared += 1
                if acc > thr:
                    abandoned = True
                    break
                if use_bound and f + 1 < F and acc + _rest_bound(term, f, s, frames, w, Cl, Cq) > thr:
                    abandoned = True
                    break
            if abandoned:
                out[k] = np.inf
            else:
                out[k] = acc
                if margin >= 0.0 and acc + margin < thr:
                    thr = acc + margin
        return compared

    @numba.njit(cache=True, nogil=True, inline="always")
    def _rest_bound(term, f, s, frames, w, Cl, Cq):
        """Lower bound of ``sum_{j > f} w_j d_j`` from a lower bound ``term`` of ``d_f``: the frame
        distance is a metric invariant under the windows' rigid alignment, so ``d_j >= d_f - (steps
        of the query and of the library window between frames f and j)``."""
        out = 0.0
        base_l = Cl[s + frames[f]]
        base_q = Cq[f]
        for j in range(f + 1, frames.shape[0]):
            lb = term - (Cl[s + frames[j]] - base_l) - (Cq[j] - base_q)
            if lb <= 0.0:
                break
            out += w[j] * lb
        return out

    @numba.njit(cache=True, nogil=True)
    def rest_bounds_nb(starts, first, frames, w, Cl, Cq, out):
        """``out[k]``: the bound of :func:`_rest_bound` from each window's first-frame term."""
        for k in range(starts.shape[0]):
            out[k] = _rest_bound(first[k], 0, starts[k], frames, w, Cl, Cq)

    # -------------------------------------------------------------- the compiled search
    @numba.njit(cache=True, nogil=True)
    def _window(P, O, G, T, s, frames, qp, qo, yq, w, wp, wr, Cl, Cq, first_lb, thr, lbf, suf, cnt, ws, low):
        """Two-stage distance of the window at library row ``s`` (module docstring): the exact
        distance, or ``inf`` when it exceeds ``thr``. ``first_lb[s]`` holds its first-frame bound.
        ``cnt[0]`` += bound terms, ``cnt[1]`` += exact terms."""
        F = frames.shape[0]
        thr_s = thr + SLACK * abs(thr)
        c, sn, ch, sh = T[s, 0], T[s, 1], T[s, 2], T[s, 3]
        g0, g1, g2 = G[s, 0], G[s, 1], G[s, 2]
        lb = 0.0
        for f in range(F):
            if f == 0:
                t = first_lb[s]
            else:
                t = _frame_term(P, O, s + frames[f], qp, qo, yq, f, wp, wr, g0, g1, g2, c, sn, ch, sh, False)
                cnt[0] += 1
            lbf[f] = w[f] * t
            lb += lbf[f]
            if lb > thr_s:
                low[s] = thr
                return np.inf
            # the rest's bound is at most t * sum_{j > f} w_j: computed only when it could abandon
            if f + 1 < F and lb + t * ws[f + 1] > thr_s and lb + _rest_bound(t, f, s, frames, w, Cl, Cq) > thr_s:
                low[s] = thr
                return np.inf
        suf[F] = 0.0
        for f in range(F - 1, -1, -1):
            suf[f] = suf[f + 1] + lbf[f]
        acc = 0.0
        for f in range(F):
            term = _frame_term(P, O, s + frames[f], qp, qo, yq, f, wp, wr, g0, g1, g2, c, sn, ch, sh, True)
            acc += w[f] * term
            cnt[1] += 1
            if acc + suf[f + 1] > thr_s:
                low[s] = thr
                return np.inf
        if acc > thr:
            low[s] = thr
            return np.inf
        return acc

    @numba.njit(cache=True, nogil=True)
    def _evaluate(P, O, G, T, rows, frames, qp, qo, yq, w, wp, wr, Cl, Cq, threshold, margin, D, first_lb,
                  lbf, suf, cnt, ws, low):
        """Record in ``D`` the distance of every window at ``rows`` not computed yet (``D`` NaN) that is
        at most ``threshold`` and, with ``margin >= 0``, at most the best complete one + ``margin``;
        best-first by the first-frame bound plus the bound of the rest, so the threshold is tight early."""
        n = 0
        for r in rows:
            if np.isnan(D[r]) and low[r] < threshold:
                n += 1
        todo = np.empty(n, np.int64)
        key = np.empty(n)
        n = 0
        for r in rows:                                 # windows dropped before against a threshold at or
            if np.isnan(D[r]) and low[r] < threshold:  # below this one are known to exceed it: skipped
                if np.isnan(first_lb[r]):
                    first_lb[r] = _frame_term(P, O, r + frames[0], qp, qo, yq, 0, wp, wr, G[r, 0], G[r, 1], G[r, 2],
                                              T[r, 0], T[r, 1], T[r, 2], T[r, 3], False)
                    cnt[0] += 1
                todo[n] = r
                key[n] = w[0] * first_lb[r] + _rest_bound(first_lb[r], 0, r, frames, w, Cl, Cq)
                n += 1
        order = np.argsort(key, kind="mergesort")
        thr = threshold
        for k in order:
            if key[k] > thr + SLACK * abs(thr):        # this one and all after it fail at their first frame
                break
            r = todo[k]
            if low[r] >= thr:
                continue
            d = _window(P, O, G, T, r, frames, qp, qo, yq, w, wp, wr, Cl, Cq, first_lb, thr, lbf, suf, cnt, ws, low)
            if d < np.inf:
                D[r] = d
                if margin >= 0.0 and d + margin < thr:
                    thr = d + margin

    @numba.njit(cache=True, nogil=True)
    def _interval(row, row_clip, cstart, nvalid, U, Uoff, mark):
        """Mark every valid window start strictly between the unique frames neighbouring ``row``."""
        ci = row_clip[row]
        s0 = cstart[ci]
        nv = nvalid[ci]
        u = U[Uoff[ci]:Uoff[ci + 1]]
        f = row - s0
        k = np.searchsorted(u, f)
        lo = u[k - 1] + 1 if k > 0 else 0
        hi = u[k + 1] - 1 if k + 1 < u.shape[0] else nv - 1
        if hi > nv - 1:
            hi = nv - 1
        for j in range(lo, hi + 1):
            mark[s0 + j] = True

    @numba.njit(cache=True, nogil=True)
    def _far(rows, best, row_clip, L):
        """The ``rows`` in another clip than row ``best`` or at least ``L`` rows from it."""
        out = np.empty(rows.shape[0], np.int64)
        n = 0
        for r in rows:
            if row_clip[r] != row_clip[best] or abs(r - best) >= L:
                out[n] = r
                n += 1
        return out[:n]

    @numba.njit(cache=True, nogil=True)
    def _best_rows(D, row_clip, L):
        """``(best, runner-up)`` rows of the computed windows (``D`` not NaN): the least distance (first
        row on ties), and the least among the windows in another clip or at least ``L`` rows away
        (``-1``: none)."""
        best = -1
        for r in range(D.shape[0]):
            if not np.isnan(D[r]) and (best < 0 or D[r] < D[best]):
                best = r
        ru = -1
        if best >= 0:
            for r in range(D.shape[0]):
                if not np.isnan(D[r]) and (row_clip[r] != row_clip[best] or abs(r - best) >= L):
                    if ru < 0 or D[r] < D[ru]:
                        ru = r
        return best, ru

    @numba.njit(cache=True, nogil=True)
    def _refine(P, O, G, T, cand, frames, qp, qo, yq, w, wp, wr, Cl, Cq, margin, max_regions, D, first_lb, lbf,
                suf, cnt, ws, low, row_clip, cstart, nvalid, U, Uoff):
        """Sec. 4.1's search over the unique-frame windows ``cand``: every one within ``margin`` of the
        best of them exactly, then every window between the neighbouring unique frames of those (at
        most ``max_regions``, best first) within the best one's distance. Returns the regions refined."""
        n = cand.shape[0]
        _evaluate(P, O, G, T, cand, frames, qp, qo, yq, w, wp, wr, Cl, Cq, np.inf, margin, D, first_lb, lbf, suf,
                  cnt, ws, low)
        best_u = np.inf
        for r in cand:
            if D[r] < best_u:
                best_u = D[r]
        ev = np.empty(n, np.int64)
        m = 0
        for r in cand:
            if D[r] <= best_u + margin:
                ev[m] = r
                m += 1
        ev = ev[:m]
        dv = np.empty(m)
        for k in range(m):
            dv[k] = D[ev[k]]
        regions = ev[np.argsort(dv, kind="mergesort")][:max_regions]
        mark = np.zeros(D.shape[0], np.bool_)
        for r in regions:
            _interval(r, row_clip, cstart, nvalid, U, Uoff, mark)
        rows = np.flatnonzero(mark)
        _evaluate(P, O, G, T, rows, frames, qp, qo, yq, w, wp, wr, Cl, Cq, best_u, 0.0, D, first_lb, lbf, suf,
                  cnt, ws, low)
        return regions.shape[0]

    @numba.njit(cache=True, nogil=True)
    def search_nb(P, O, G, T, Cl, row_clip, cstart, nvalid, U, Uoff, cand, frames, qp, qo, yq, w, wp, wr, Cq,
                  L, margin, max_regions, D, first_lb, out):
        """The unique-frame search of :func:`mocomp.impact.search.search` (phases 1-3 of its code),
        compiled. ``cand``: the unique-frame rows (and each clip's last valid start); ``U``/``Uoff``:
        every clip's unique frames (clip-local numbers) and their offsets; ``D``/``first_lb (N,)``
        NaN-filled, filled in. ``out (6,) int64``: best row, runner-up row (-1: none), bound terms,
        exact terms, windows touched, regions refined."""
        N = P.shape[0]
        F = frames.shape[0]
        lbf = np.empty(F)
        suf = np.empty(F + 1)
        cnt = np.zeros(2, np.int64)
        low = np.full(N, -1.0)                         # per row: its distance exceeds this (abandoned)
        ws = np.zeros(F + 1)                           # suffix sums of the window weights
        for f in range(F - 1, -1, -1):
            ws[f] = ws[f + 1] + w[f]
        # 1.-2. the best: the unique-frame windows, then the intervals of the best of them
        nreg = _refine(P, O, G, T, cand, frames, qp, qo, yq, w, wp, wr, Cl, Cq, margin, max_regions, D, first_lb,
                       lbf, suf, cnt, ws, low, row_clip, cstart, nvalid, U, Uoff)
        # 3. the runner-up: the best computed window far from the best (another clip or at least L rows
        #    away); if there is none, the far unique-frame windows are computed first; then the interval
        #    around it is refined
        best, ru = _best_rows(D, row_clip, L)
        if ru < 0:
            _evaluate(P, O, G, T, _far(cand, best, row_clip, L), frames, qp, qo, yq, w, wp, wr, Cl, Cq, np.inf, 0.0, D, first_lb, lbf,
                      suf, cnt, ws, low)
            best, ru = _best_rows(D, row_clip, L)
        if ru >= 0:
            mark = np.zeros(N, np.bool_)
            _interval(ru, row_clip, cstart, nvalid, U, Uoff, mark)
            _evaluate(P, O, G, T, _far(np.flatnonzero(mark), best, row_clip, L), frames, qp, qo, yq, w, wp, wr, Cl, Cq, D[ru], -1.0, D, first_lb, lbf,
                      suf, cnt, ws, low)
            best, ru = _best_rows(D, row_clip, L)
        touched = 0
        for r in range(N):
            if not np.isnan(first_lb[r]):
                touched += 1
        out[0] = best
        out[1] = ru
        out[2] = cnt[0]
        out[3] = cnt[1]
        out[4] = touched
        out[5] = nreg

    @numba.njit(cache=True, nogil=True)
    def trig_nb(H, T):
        """``T (N, 4)``: ``cos psi, sin psi, cos psi/2, sin psi/2`` of the library headings ``H (N,)`` (once
        per index, shared by both searches so their distances agree to the bit)."""
        for r in range(H.shape[0]):
            T[r, 0] = np.cos(H[r])
            T[r, 1] = np.sin(H[r])
            T[r, 2] = np.cos(0.5 * H[r])
            T[r, 3] = np.sin(0.5 * H[r])

    # -------------------------------------------------------------- the query window
    @numba.njit(cache=True, nogil=True)
    def query_nb(Pw, Gw, joints, coms, g0x, g0z, heading, pos, qp, qo, yq):
        """The query window's body parts from its joints' world positions ``Pw (L, J, 3)`` and rotations
        ``Gw (L, J, 4)``: ``pos = P_j + R(G_j) c`` (segment COMs, world), and aligned at the first frame
        (:func:`mocomp.impact.features.ground_frame_features`): ``qp = R_y(-h)(pos - g)``,
        ``qo = q_y(-h) G_j``, and ``yq = Y qo`` (``Y = (0, 1, 0, 0)``: the signed permutation
        ``(z, w, -x, -y)``). Scalar-last quaternions; fills the output arrays."""
        c = np.cos(heading)
        s = np.sin(heading)
        ay = np.sin(-0.5 * heading)
        aw = np.cos(-0.5 * heading)
        for i in range(Pw.shape[0]):
            for b in range(joints.shape[0]):
                j = joints[b]
                ux, uy, uz, ww = Gw[i, j, 0], Gw[i, j, 1], Gw[i, j, 2], Gw[i, j, 3]
                vx, vy, vz = coms[b, 0], coms[b, 1], coms[b, 2]
                tx = 2.0 * (uy * vz - uz * vy)            # q v q^-1 = v + w t + u x t, t = 2 u x v
                ty = 2.0 * (uz * vx - ux * vz)
                tz = 2.0 * (ux * vy - uy * vx)
                px = Pw[i, j, 0] + vx + ww * tx + (uy * tz - uz * ty)
                py = Pw[i, j, 1] + vy + ww * ty + (uz * tx - ux * tz)
                pz = Pw[i, j, 2] + vz + ww * tz + (ux * ty - uy * tx)
                pos[i, b, 0], pos[i, b, 1], pos[i, b, 2] = px, py, pz
                dx = px - g0x
                dz = pz - g0z
                qp[i, b, 0] = c * dx - s * dz
                qp[i, b, 1] = py
                qp[i, b, 2] = s * dx + c * dz
                ox = aw * ux + ay * uz                    # (0, ay, 0, aw) (x) (ux, uy, uz, ww)
                oy = aw * uy + ay * ww
                oz = aw * uz - ay * ux
                ow = aw * ww - ay * uy
                qo[i, b, 0], qo[i, b, 1], qo[i, b, 2], qo[i, b, 3] = ox, oy, oz, ow
                yq[i, b, 0], yq[i, b, 1], yq[i, b, 2], yq[i, b, 3] = oz, ow, -ox, -oy

    @numba.njit(cache=True, nogil=True)
    def steps_nb(qp, qo, wp, wr, F, out):
        """``out (F,)``: prefix sums of the frame-to-frame distances of the aligned query window
        (:func:`mocomp.impact.index.frame_distances` between frames ``f`` and ``f + 1``), ``out[0] = 0``."""
        out[0] = 0.0
        for f in range(1, F):
            term = 0.0
            for b in range(wp.shape[0]):
                dx = qp[f, b, 0] - qp[f - 1, b, 0]
                dy = qp[f, b, 1] - qp[f - 1, b, 1]
                dz = qp[f, b, 2] - qp[f - 1, b, 2]
                dot = abs(qo[f, b, 0] * qo[f - 1, b, 0] + qo[f, b, 1] * qo[f - 1, b, 1]
                          + qo[f, b, 2] * qo[f - 1, b, 2] + qo[f, b, 3] * qo[f - 1, b, 3])
                if dot > 1.0:
                    dot = 1.0
                term += wp[b] * np.sqrt(dx * dx + dy * dy + dz * dz) + wr[b] * 2.0 * np.arccos(dot)
            out[f] = out[f - 1] + term
