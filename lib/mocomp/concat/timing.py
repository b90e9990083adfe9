"""The optimal timing of the blend (Shum et al. 2009, eq. 3-7), over the whole (T, f) table at once.

Motion 2 starts ``T`` frames after motion 1. For every ``T`` whose blendable periods overlap:

* ``f_T = argmin_f ||L1(f) - L2(f - T)||^2`` over ``f`` in period 1 with ``f - T`` in period 2 (eq. 5);
* ``F_dm = ||L1(f_T) - L2(f_T - T)||^2`` (eq. 4);
* ``F_inertia = sum_j m_j (r1_j(f_T) . (r2_j(f_T - T) - r1_j(f_T)))^2`` (eq. 6, as printed: the dot
  product of the first motion's moment arm with the change of arm, squared, weighted by mass);
* ``F_time = ||L1(f_T) - L1(f_start)||^2``, ``f_start`` the first frame of period 1 (eq. 7);
* ``F = F_dm + F_inertia + F_time`` (eq. 3), the minimising ``T`` chosen.

The paper scans ``T`` and ``f`` by brute force (O(n^2) in "tens of seconds"). Here the table
``D[f, g] = |L1(f)|^2 + |L2(g)|^2 - 2 L1(f) . L2(g)`` is one matrix product (the cross-correlation
of the two trajectories over the two periods); its diagonals ``f - g = T`` are gathered into a
``(n_T, n1)`` band and reduced by one ``argmin``. The units of the terms differ ((kg m^2/s)^2 and
kg m^4): the paper adds them as they are; ``weights`` scales each.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .phases import ConcatError, MomentumTrack

__all__ = ["TimingTable", "timing_table", "optimal_timing"]


@dataclass(frozen=True, eq=False)
class TimingTable:
    """Eq. 3-7 for every offset. ``T``: ``(K,)`` frames; ``f_T``: ``(K,)`` frames of motion 1;
    ``F_dm``, ``F_inertia``, ``F_time``, ``F``: ``(K,)``; ``period1``, ``period2``: the half-open
    blendable periods scanned; ``allowed``: ``(K,)`` bool, the offsets a further condition admits
    (:meth:`where`; all by default): :attr:`best` and :meth:`runner_up` choose among them."""

    T: np.ndarray
    f_T: np.ndarray
    F_dm: np.ndarray
    F_inertia: np.ndarray
    F_time: np.ndarray
    F: np.ndarray
    period1: tuple[int, int]
    period2: tuple[int, int]
    allowed: np.ndarray | None = None

    def _F(self) -> np.ndarray:
        return self.F if self.allowed is None else np.where(self.allowed, self.F, np.inf)

    def where(self, allowed) -> "TimingTable":
        """The table with only ``allowed`` offsets eligible (the others stay listed)."""
        import dataclasses

        return dataclasses.replace(self, allowed=np.asarray(allowed, dtype=bool))

    @property
    def best(self) -> int:
        return int(np.argmin(self._F()))

    def row(self, k: int) -> dict:
        return {"T": int(self.T[k]), "f_T": int(self.f_T[k]), "F": float(self.F[k]), "F_dm": float(self.F_dm[k]),
                "F_inertia": float(self.F_inertia[k]), "F_time": float(self.F_time[k])}

    def runner_up(self) -> int | None:
        """The best offset that is not the optimum nor adjacent to it (a distinct timing), if any."""
        k0 = self.best
        F = self._F()
        far = (np.abs(self.T - self.T[k0]) > 1) & np.isfinite(F)
        if not far.any():
            return None
        idx = np.flatnonzero(far)
        return int(idx[np.argmin(F[idx])])


def timing_table(t1: MomentumTrack, t2: MomentumTrack, period1: tuple[int, int], period2: tuple[int, int],
                 weights=(1.0, 1.0, 1.0), min_T: int | None = None) -> TimingTable:
    """Eq. 3-7 for every offset ``T`` at which the periods overlap (see the module docstring); ``t2``
    must already be turned by the alignment (eq. 2). ``min_T``: only offsets ``T >= min_T`` are kept
    (:func:`mocomp.concat.concatenate` uses it to keep the two main phases apart)."""
    a0, a1 = (int(x) for x in period1)
    b0, b1 = (int(x) for x in period2)
    if not (0 <= a0 < a1 <= t1.n_frames and 0 <= b0 < b1 <= t2.n_frames):
        raise ConcatError(f"blendable periods A {a0}-{a1} / B {b0}-{b1} are empty or outside the motions "
                          f"({t1.n_frames} and {t2.n_frames} frames)")
    L1, L2 = t1.L[a0:a1], t2.L[b0:b1]
    n1, n2 = len(L1), len(L2)
    D = (L1 * L1).sum(1)[:, None] + (L2 * L2).sum(1)[None, :] - 2.0 * (L1 @ L2.T)      # (n1, n2)
    # T = (a0 + i) - (b0 + j); band row k = i - j + (n2 - 1), k = 0 .. n1 + n2 - 2
    K = n1 + n2 - 1
    i = np.arange(n1)
    j = i[None, :] - (np.arange(K)[:, None] - (n2 - 1))                              # (K, n1)
    valid = (j >= 0) & (j < n2)
    band = np.where(valid, D[i[None, :], np.clip(j, 0, n2 - 1)], np.inf)
    # eq. 5; ties (to the round-off of the expansion) go to the earliest frame, as eq. 7 prefers
    tol = 1e-9 * max(float((L1 * L1).sum(1).max()), float((L2 * L2).sum(1).max()), 1e-300)
    fi = np.argmax(band <= band.min(axis=1, keepdims=True) + tol, axis=1)             # (K,)
    F_dm = np.maximum(band[np.arange(K), fi], 0.0)
    T = a0 - b0 + np.arange(K) - (n2 - 1)
    f_T = a0 + fi
    if min_T is not None:
        keep = T >= int(min_T)
        if not keep.any():
            raise ConcatError(f"no offset T >= {int(min_T)} lets the blendable periods A {a0}-{a1} and B {b0}-{b1} "
                              f"overlap (the largest is {int(T.max())})")
        T, f_T, F_dm = T[keep], f_T[keep], F_dm[keep]
    g = f_T - T
    r1 = t1.arms[f_T]
    r2 = t2.arms[g]
    F_in = np.einsum("s,ks->k", t1.masses, np.einsum("ksc,ksc->ks", r1, r2 - r1) ** 2)
    F_time = ((t1.L[f_T] - t1.L[a0]) ** 2).sum(1)
    w = np.asarray(weights, dtype=float)
    F = w[0] * F_dm + w[1] * F_in + w[2] * F_time
    return TimingTable(T, f_T, F_dm, F_in, F_time, F, (a0, a1), (b0, b1))


def optimal_timing(t1: MomentumTrack, t2: MomentumTrack, period1, period2, *, max_F: float | None = None,
                   weights=(1.0, 1.0, 1.0), min_T: int | None = None) -> TimingTable:
    """:func:`timing_table`, raising :class:`ConcatError` with the measured value when the optimum's
    ``F`` exceeds ``max_F`` (the two motions are too different to be blended)."""
    tab = timing_table(t1, t2, period1, period2, weights, min_T)
    k = tab.best
    if max_F is not None and tab.F[k] > max_F:
        r = tab.row(k)
        raise ConcatError(f"the motions are too different to be blended: the best timing T={r['T']} (f_T={r['f_T']}) "
                          f"has F = {r['F']:.4g} (F_dm {r['F_dm']:.4g}, F_inertia {r['F_inertia']:.4g}, "
                          f"F_time {r['F_time']:.4g}) above the threshold {max_F:.4g}")
    return tab
