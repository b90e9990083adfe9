"""Self-looping search (flips paper section 5.2, dissertation eq. 5.9).

Find flight frames ``f_m``, ``f_n`` and an angle ``phi`` with
``R(f_m, L, phi) ~ f_n``: frame ``m`` rotated by ``phi`` about the angular
momentum direction is similar (App. A, eq. 5.12-5.13) to frame ``n``. The
fragment ``F_B = f_m .. f_n`` can then be repeated, each copy rotated by a
further ``phi``, to add rotation while keeping ``L`` constant (eq. 5.7).

Choice among similar pairs: every pair of flight frames (away from take-off and
landing) whose rotation about ``L`` is at least ``min_angle`` is scored by
``D(m, n) / phi``, the seam discontinuity per radian of rotation gained: a
multi-flip needs about ``extra / phi`` seams, so this minimises the total seam
discontinuity for a given extra rotation.

Ties (a robust choice): pairs whose cost is within :data:`TIE_RTOL` (relative) plus
:data:`TIE_ATOL` (mean joint mismatch, radians per radian of ``phi``) of the lowest are
equally good, and the choice among them does not follow the cost's rounding noise. Without
this the choice is ill-conditioned wherever several pairs are (near-)perfect loops: in a held
tuck all poses coincide up to the rotation about ``L``, every pair's ``D`` is rounding noise
(~1e-17, ~1e-8 after a 1e-7 relative perturbation of the input) and the pick jumped between
hosts and seeds (synthetic back flip: ``m`` 141-144 and periods 24-29 frames over five
seeded 1e-7 perturbations). Among the tied pairs the rule is, in order:

1. the largest ``phi`` (to within :data:`PHI_TOL` rad): the fewest seams for the extra
   rotation, which is what ``D / phi`` itself prefers between pairs of equal ``D``;
2. the pair centred nearest the middle of the flight (the apex of the ballistic COM path:
   ``|m + n - (start + stop - 1)|`` smallest), farthest from take-off and landing poses;
3. the earliest ``m``.

Steps 2-3 compare integers, so a perturbation well below the tolerances cannot change the
result (``tests/test_flips_tolerances.py`` perturbs the input by seeded 1e-7 noise).

A pair "exists" when its mean
weighted joint-angle difference is below ``max_mean_angle`` degrees; otherwise
the best pair is still returned with ``found=False`` and the caller falls back
(section 5.2: "the transition between any two chosen frames ... automatically by
smoothing", its momentum adjusted "by applying non-uniform motion retiming as described
in Section 5.5"; :mod:`mocomp.flips.smoothing`), and says so.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import PhysicsError
from .similarity import SimilarityWeights, frame_distance

__all__ = ["SelfLoop", "find_self_loop", "TIE_RTOL", "TIE_ATOL", "PHI_TOL", "choose_tied"]

#: relative tolerance within which two candidate costs are tied (the loop's ``D / phi`` and the
#: landing join's ``D``)
TIE_RTOL = 1e-4
#: absolute tolerance of a tie, in radians of mean weighted joint mismatch (``D / sum(weights)``;
#: per radian of ``phi`` for the loop cost): ~1.7e-4 degrees, far below anything visible and
#: ~100x above the cost noise of a 1e-7 relative perturbation of the input (~2e-8)
TIE_ATOL = 3e-6
#: radians; loop angles closer than this count as equal for the largest-``phi`` rule (one frame
#: of a flip turns ~0.05-0.1 rad; rounding and 1e-7 input noise move ``phi`` by ~1e-7)
PHI_TOL = 1e-4


@dataclass(frozen=True)
class SelfLoop:
    """Result of the self-looping search (eq. 5.9).

    Attributes
    ----------
    m, n: the loop frames (absolute frame indices, ``m < n``); ``F_B = f_m .. f_n``.
    phi: radians, rotation about ``L`` gained per repetition, ``theta(n) - theta(m)``
        (the root twist about ``L``, so the rotation stays exactly continuous).
    phi_aligned: radians, eq. 5.12's alignment angle for the pair (unwrapped next to ``phi``).
    distance: eq. 5.13 distance ``D(R(f_m, phi), f_n)`` (weighted radians; with the conference
        paper's angular-velocity term when the weights have one).
    mean_angle_deg: the pose part of ``distance`` divided by the sum of weights, in degrees (a
        readable "average joint-angle mismatch"; the similarity threshold applies to it).
    found: ``True`` when a pair met the similarity threshold; ``False`` means the
        fallback of section 5.2 (join the best pair by wider smoothing).
    n_pairs: number of pairs scored.
    candidates: ``(k, 5)`` the best few pairs ``[m, n, phi, D, cost]`` (evidence): the chosen
        pair first, then the others by increasing cost (tied pairs may precede it in cost).
    seconds: time the search took.
    note: plain-words remark (e.g. why the fallback was used).
    """

    m: int
    n: int
    phi: float
    phi_aligned: float
    distance: float
    mean_angle_deg: float
    found: bool
    n_pairs: int
    candidates: np.ndarray = field(repr=False)
    seconds: float = 0.0
    note: str = ""

    @property
    def period(self) -> int:
        """Frames per repetition (``n - m``)."""
        return self.n - self.m


def choose_tied(cost: np.ndarray, scale: float, rtol: float = TIE_RTOL, atol: float = TIE_ATOL) -> np.ndarray:
    """Indices of the candidates tied with the lowest ``cost``: ``cost <= min (1 + rtol) + atol scale``
    (``scale`` converts ``atol``, radians of mean joint mismatch, to the cost's units, e.g. the
    sum of the eq. 5.13 weights). Non-finite costs are never tied."""
    c = np.asarray(cost, dtype=float)
    fin = np.isfinite(c)
    if not np.any(fin):
        return np.zeros(0, dtype=np.int64)
    best = float(np.min(c[fin]))
    return np.flatnonzero(fin & (c <= best * (1.0 + rtol) + atol * scale))


def _pick_loop(cost, phi, mi, ni, pool, wsum, mid2):
    """The tie rule of the module docstring over candidates ``pool``: index of the chosen pair."""
    tied = pool[choose_tied(cost[pool], wsum)]
    tied = tied[phi[tied] >= phi[tied].max() - PHI_TOL]
    key = np.lexsort((mi[tied], np.abs(mi[tied] + ni[tied] - mid2)))
    return int(tied[key[0]])


def find_self_loop(rotations: np.ndarray, theta: np.ndarray, flight: tuple[int, int], axis: np.ndarray,
                   weights: SimilarityWeights, omegas: np.ndarray | None = None,
                   margin: float = 0.1, min_margin_frames: int = 2, min_angle: float = np.deg2rad(60.0),
                   max_angle: float = 2 * np.pi, max_mean_angle: float = 12.0,
                   keep: int = 10) -> SelfLoop:
    """Eq. 5.9 search over the flight ``[start, stop)`` of a clip.

    Parameters
    ----------
    rotations: ``(T, J, 4)`` local rotations (root = world orientation).
    theta: ``(T,)`` unwrapped root rotation about ``axis`` (:func:`~mocomp.flips.smoothing.split_root`).
    flight: half-open frame range of the ballistic phase.
    axis: unit angular-momentum direction ``L``.
    weights: eq. 5.13 weights (with ``velocity_weight > 0`` pass ``omegas (T, J, 3)``).
    margin: fraction of the flight excluded at each end (take-off/landing poses are
        not loop material); at least ``min_margin_frames`` frames.
    min_angle, max_angle: radians, allowed rotation per repetition.
    max_mean_angle: degrees; threshold on ``D / sum(weights)`` for a pair to count as self-looping.
    """
    t0 = time.perf_counter()
    s, e = int(flight[0]), int(flight[1])
    nflight = e - s
    mg = max(int(np.ceil(margin * nflight)), int(min_margin_frames))
    lo, hi = s + mg, e - 1 - mg          # candidate frames lo..hi inclusive
    if hi - lo < 2:
        raise PhysicsError(
            f"the flight (frames {s}-{e - 1}, {nflight} frames) is too short for a self-looping search "
            f"after excluding {mg} frames at each end; need a longer ballistic phase (or a higher frame rate)")
    idx = np.arange(lo, hi + 1)
    th = np.asarray(theta, dtype=float)
    dth = th[idx][None, :] - th[idx][:, None]                 # theta(n) - theta(m), rows m, cols n
    iu, ju = np.triu_indices(idx.size, k=1)
    phi = dth[iu, ju]
    ok = (phi >= min_angle) & (phi <= max_angle)
    total = float(th[hi] - th[lo])
    if not np.any(ok):
        raise PhysicsError(
            f"the flight rotates only {np.degrees(total):.0f} deg about L between frames {lo} and {hi}; "
            f"a self-looping fragment needs at least {np.degrees(min_angle):.0f} deg: this clip is not a flip "
            "(for small rotations such as twist jumps lower min_angle, e.g. prepare(..., loop_options="
            "{'min_angle': radians}))")
    mi, ni = idx[iu[ok]], idx[ju[ok]]
    phi = phi[ok]
    rot = np.asarray(rotations, dtype=float)
    om1 = om2 = None
    if weights.velocity_weight > 0:
        if omegas is None:
            raise ValueError("velocity_weight > 0 needs per-frame angular velocities (omegas)")
        om1, om2 = omegas[mi], omegas[ni]
    D, phi_al = frame_distance(rot[mi], rot[ni], axis, weights, om1, om2)
    # eq. 5.12's angle is defined mod 2 pi: unwrap it next to the twist difference
    phi_al = phi + ((phi_al - phi + np.pi) % (2 * np.pi) - np.pi)
    cost = D / phi
    wsum = weights.root + float(np.sum(weights.joints))
    if weights.velocity_weight > 0:
        # the threshold is on the pose mismatch (degrees); the velocity term only ranks the pairs
        import dataclasses

        D_pose, _ = frame_distance(rot[mi], rot[ni], axis, dataclasses.replace(weights, velocity_weight=0.0))
    else:
        D_pose = D
    mean_deg = np.degrees(D_pose / wsum)
    good = mean_deg <= max_mean_angle
    found = bool(np.any(good))
    pool = np.flatnonzero(good) if found else np.arange(D.size)
    best = _pick_loop(cost, phi, mi, ni, pool, wsum, s + e - 1)
    order = pool[np.argsort(cost[pool], kind="stable")]
    order = np.concatenate([[best], order[order != best]])[:keep]     # the chosen pair first
    cands = np.column_stack([mi[order], ni[order], phi[order], D[order], cost[order]])
    note = ""
    if not found:
        note = (f"no self-looping pair: the most similar pair (frames {mi[best]}, {ni[best]}, "
                f"{np.degrees(phi[best]):.0f} deg apart) differs by {mean_deg[best]:.1f} deg on average "
                f"(threshold {max_mean_angle:.1f}); falling back to section 5.2: the copies are joined "
                "automatically by smoothing, and the change of |L| across those transitions is adjusted by "
                "non-uniform retiming (eq. 5.22)")
    return SelfLoop(m=int(mi[best]), n=int(ni[best]), phi=float(phi[best]), phi_aligned=float(phi_al[best]),
                    distance=float(D[best]), mean_angle_deg=float(mean_deg[best]), found=found,
                    n_pairs=int(D.size), candidates=cands, seconds=time.perf_counter() - t0, note=note)
