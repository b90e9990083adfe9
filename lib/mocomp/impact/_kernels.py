"""Compiled (numba) window distances of the impact search (eq. 4.1, Appendix A).

:func:`window_distances_nb` computes, for candidate windows starting at library rows ``starts``,

    D = sum_f w_f sum_b ( w_p,b |(p_b - g_s) - R_y(psi_s) q_b,f| + w_theta,b 2 acos |<o_b, q_y(psi_s) Q_b,f>| )

i.e. eq. 4.1 between the query window (aligned at its first frame: ``qp``, ``qo``) and the library
window aligned at its own first frame (root ground point ``g_s``, heading ``psi_s``): comparing
``R_y(-psi)(p - g)`` with ``q`` equals comparing ``p - g`` with ``R_y(psi) q``, and
``<q_y(-psi) o, Q> = <o, q_y(psi) Q> = cos(psi/2) <o, Q> + sin(psi/2) <o, Y Q>`` with ``Y`` the pure
quaternion ``(0, 1, 0, 0)`` (``yq = Y Q`` is precomputed), so nothing is rotated per candidate.

Early abandoning: the frames are summed in window order and a window stops as soon as its partial
sum exceeds the threshold (all terms are >= 0); with ``margin >= 0`` the threshold also follows the
best complete window found so far plus ``margin``. Abandoned windows get ``inf``.

The numpy version (:meth:`mocomp.impact.search._Query.terms`) is the reference
(``tests/test_impact_search.py`` compares them) and the fallback when numba cannot be imported.
"""
from __future__ import annotations

import numpy as np

try:
    import numba

    AVAILABLE = True
except Exception:  # pragma: no cover - numba is a project dependency
    AVAILABLE = False

__all__ = ["AVAILABLE", "window_distances_nb", "rest_bounds_nb"]


if AVAILABLE:
    @numba.njit(cache=True, nogil=True)
    def window_distances_nb(P, O, G, H, starts, frames, qp, qo, yq, w, wp, wr, f_start, acc0, term0,
                            Cl, Cq, threshold, margin, out):
        """Fill ``out (K,)`` with the window distances (``inf`` when abandoned); return the number
        of frame pairs compared.

        Frames ``frames[f_start:]`` are computed, after ``acc0 (K,)`` accumulated over the earlier
        ones (``term0 (K,)``: the unweighted term of frame ``f_start - 1``). ``Cl (N,)`` and ``Cq (F,)``
        are prefix sums of the library's and the query's frame-to-frame distances (``< 0`` entries
        of ``Cq``: no bound). ``margin < 0``: fixed ``threshold``."""
        K = starts.shape[0]
        F = frames.shape[0]
        B = wp.shape[0]
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
            psi = H[s]
            c = np.cos(psi)
            sn = np.sin(psi)
            ch = np.cos(0.5 * psi)
            sh = np.sin(0.5 * psi)
            g0 = G[s, 0]
            g1 = G[s, 1]
            g2 = G[s, 2]
            for f in range(f_start, F):
                r = s + frames[f]
                term = 0.0
                for b in range(B):
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
                    term += wp[b] * np.sqrt(dx * dx + dy * dy + dz * dz) + wr[b] * 2.0 * np.arccos(dot)
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
        """Lower bound of ``sum_{j > f} w_j d_j`` from ``d_f = term``: the frame distance is a metric
        invariant under the windows' rigid alignment, so ``d_j >= d_f - (steps of the query and of
        the library window between frames f and j)``."""
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
