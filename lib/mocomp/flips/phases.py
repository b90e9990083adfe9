"""Ballistic phase detection (flips paper section 4.1, dissertation section 5.3.1).

1. **Constraint method** (Liu & Popovic 2002): frames where at least one end
   effector (feet, toes, hands) is nearly still are candidates for the borders of
   a ballistic phase; no ground level is assumed (multi-level scenes work; an
   effector resting at its own lowest level also counts as planted). The runs of
   frames with *no* planted effector are the candidate flights.
2. **Linear-momentum pattern** (computed with an average mass distribution, de
   Leva's table by default, as the paper does before masses are estimated). In
   flight the vertical momentum falls on a line (slope ``-M g``) and the
   horizontal momentum is constant; at take-off it first dips and then rises
   sharply (push-off), at landing it drops sharply and then recovers. So within
   each candidate (widened by ``border_window``) the take-off is placed at a peak
   of the vertical COM velocity (the end of the sudden rise) and the landing at a
   later trough (where the sudden drop begins), such that the velocity between
   them falls on one line (R^2 >= ``min_r2``, slope ``-g s`` with ``s`` in
   ``gravity_range``); the longest such span wins. The borders are then moved in to
   where the vertical acceleration (3-point second difference of the COM, which
   does not reach across a border) has dropped below ``-g/2``: the peak and the
   trough are where the ground force equals the weight, mid-push.
   A limb that stays put for a few frames in mid-air (e.g. the feet at the apex of
   a straight hop) splits a flight into candidates; they are merged when the
   vertical velocity keeps falling on one line across the gap.
3. The longest ballistic interval is "the" flight; all are returned (several
   flights of one performer feed joint mass estimation).

Validated on every synthetic jump (borders within 2 frames of the truth at 120 Hz)
and on every real flip, twist and jump clip of the data set (``tests/test_flips_phases.py``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..body.model import BodyModel
from ..errors import NoFlightPhaseError
from .mass import G, FlightFit, fit_ballistic

__all__ = ["FlightDetection", "detect_flights", "default_prior"]


def default_prior(skeleton, total_mass: float = 70.0, table: str = "de_leva_male",
                  shape: str = "ellipsoid") -> BodyModel:
    """The average mass distribution used before any estimate (de Leva 1996 male by default)."""
    return BodyModel.from_skeleton(skeleton, total_mass=total_mass, table=table, shape=shape)


@dataclass(frozen=True)
class FlightDetection:
    """Ballistic intervals of a clip.

    Attributes
    ----------
    flights: refined ballistic intervals as :class:`FlightFit` (prior masses), in time order.
    longest: index into ``flights`` of the longest one (``None`` if none).
    candidates: ``(start, stop)`` runs with no still effector (before merging/refinement).
    support: ``(T,)`` bool, at least one effector still.
    effectors: effector names; still_speed: m/s threshold used.
    com: ``(T, 3)`` COM with the prior masses.
    rejected: ``(start, stop, reason)`` candidates that were not ballistic.
    """

    flights: tuple[FlightFit, ...]
    longest: int | None
    candidates: tuple[tuple[int, int], ...]
    support: np.ndarray = field(repr=False)
    effectors: tuple[str, ...] = ()
    still_speed: float = 0.0
    com: np.ndarray = field(default=None, repr=False)
    rejected: tuple[tuple[int, int, str], ...] = ()
    fps: float = 0.0

    @property
    def flight(self) -> tuple[int, int]:
        """``(start, stop)`` of the longest flight; raises :class:`NoFlightPhaseError` if none."""
        if self.longest is None:
            raise NoFlightPhaseError(self.explain())
        f = self.flights[self.longest]
        return f.start, f.stop

    @property
    def intervals(self) -> list[tuple[int, int]]:
        return [(f.start, f.stop) for f in self.flights]

    def explain(self) -> str:
        n = len(self.candidates)
        if not self.flights:
            why = "; ".join(f"{a}-{b - 1}: {r}" for a, b, r in self.rejected[:4])
            return (f"no flight phase found: {n} interval(s) had no still hand or foot"
                    + (f", none ballistic ({why})" if why else "")
                    + "; check that the clip contains a jump, its frame rate (very low rates: resample first) "
                      "and units, or give the flight frames explicitly (flight=(start, stop))")
        return f"{len(self.flights)} flight(s); longest frames {self.flight[0]}-{self.flight[1] - 1}"


def _ballistic_span(vy: np.ndarray, y: np.ndarray, lo: int, hi: int, fps: float, min_n: int,
                    gravity_range: tuple[float, float], min_r2: float) -> tuple[int, int] | None:
    """Longest ``[i, j + 1)`` in ``[lo, hi)`` where ``i`` is a peak of the vertical COM velocity
    (end of the push), ``j`` a later trough (start of the landing) and the velocity falls on a
    line in between (slope ``-g s`` with ``s`` in ``gravity_range``, R^2 >= ``min_r2``)."""
    v = vy[lo:hi]
    n = v.size
    if n < min_n:
        return None
    left = np.r_[-np.inf, v[:-1]]
    right = np.r_[v[1:], -np.inf]
    peaks = np.flatnonzero((v >= left) & (v >= right))
    left = np.r_[np.inf, v[:-1]]
    right = np.r_[v[1:], np.inf]
    troughs = np.flatnonzero((v <= left) & (v <= right))
    t = np.arange(n) / fps
    best = None
    for i in peaks:
        for j in troughs[troughs >= i + min_n - 1][::-1]:
            if best is not None and j - i <= best[1] - best[0]:
                break
            tt, vv = t[i:j + 1], v[i:j + 1]
            slope, icpt = np.polyfit(tt, vv, 1)
            ss = float(np.sum((vv - vv.mean()) ** 2))
            r2 = 1.0 - float(np.sum((vv - (slope * tt + icpt)) ** 2)) / ss if ss > 0 else 0.0
            if r2 >= min_r2 and gravity_range[0] <= -slope / G <= gravity_range[1]:
                best = (int(i), int(j))
                break
    if best is None:
        return None
    i, j = best
    # tighten to the frames where the ground force has (nearly) vanished: vertical
    # acceleration below -g/2 (the peak/trough are where it equals g, mid-push)
    g_est = -np.polyfit(t[i:j + 1], v[i:j + 1], 1)[0]
    yy = y[lo:hi]
    acc = np.full(n, np.inf)
    acc[1:-1] = (yy[2:] - 2.0 * yy[1:-1] + yy[:-2]) * fps * fps      # 3-point: no smearing past a border
    free = np.flatnonzero(acc[i:j + 1] < -0.5 * g_est)
    if free.size >= min_n:
        i, j = i + int(free[0]), i + int(free[-1])
    return lo + i, lo + j + 1


def detect_flights(motion, prior: BodyModel | None = None, still_speed: float = 0.3, smooth_sigma: float = 1.0,
                   min_flight: float = 0.08, max_gap: float = 0.15, border_window: float = 0.1,
                   v_tol: float = 0.3, min_r2: float = 0.8, rest_height: float = 0.03,
                   gravity_range: tuple[float, float] = (0.35, 40.0), effectors=None,
                   com: np.ndarray | None = None, agree_factor: float | None = 1.6) -> FlightDetection:
    """Ballistic intervals of ``motion`` (section 4.1).

    Parameters
    ----------
    prior: average mass distribution for the COM (default :func:`default_prior`).
    still_speed: m/s; an effector slower than this is "not moving significantly".
    rest_height: m; an effector this close to its own resting level in the clip (2nd
        percentile of its height) also counts as planted (slow-moving feet on a flat floor;
        on a multi-level scene the stillness test still applies).
    smooth_sigma: Gaussian smoothing (in frames at 120 Hz; scaled with the frame rate) of
        effector positions and of the COM before differentiating.
    min_flight: s; shorter ballistic intervals are ignored.
    max_gap: s; candidates separated by at most this many "still" frames are merged when
        the vertical COM velocity keeps falling on one line across both and the gap
        (residual RMS at most ``v_tol / 2`` m/s, gap frames within ``v_tol``).
    border_window: s; each candidate is widened by this much on both sides before its
        borders are placed: take-off at a peak of the vertical COM velocity (the end of
        the push: "slight drop, then sudden rise"), landing at a later trough (where the
        sudden drop starts), the velocity between them falling on one line (ballistic:
        slope ``-g``, R^2 >= ``min_r2``); the longest such span wins.
    gravity_range: accepted fitted-gravity scale ``s`` (a wider range than plausible
        capture errors, so mislabelled clips are still found and diagnosed later).
    effectors: ``{name: (joint name or index, local offset (3,))}``; default feet, toes and
        hands (:func:`mocomp.dynamics.contacts.default_effectors`).
    com: precomputed ``(T, 3)`` COM (skips ``prior``).
    agree_factor: with three or more flights, a flight whose fitted gravity differs from the
        clip's frame-weighted median by more than this factor is rejected (the flights of one clip
        share its frame rate and units, so a gravity far off means the interval is not free
        flight); ``None`` keeps every flight.
    """
    from ..core.kinematics import central_difference, gaussian_smooth
    from ..dynamics import center_of_mass
    from ..dynamics.contacts import default_effectors, effector_positions, label_intervals

    fps = motion.fps
    T = motion.n_frames
    if com is None:
        prior = default_prior(motion.skeleton) if prior is None else prior
        com = center_of_mass(prior, motion)
    eff = default_effectors(motion.skeleton) if effectors is None else {
        n: (motion.skeleton.index(j) if isinstance(j, str) else int(j), np.asarray(o, dtype=float))
        for n, (j, o) in effectors.items()}
    names = tuple(eff)
    joints = np.array([eff[n][0] for n in names])
    offs = np.array([eff[n][1] for n in names])
    pos = effector_positions(motion, joints, offs)
    if smooth_sigma and smooth_sigma * fps / 120.0 > 0.2:
        pos = gaussian_smooth(pos, smooth_sigma * fps / 120.0, axis=0)
    speed = np.linalg.norm(central_difference(pos, fps), axis=-1)
    height = pos[..., 1] - np.percentile(pos[..., 1], 2.0, axis=0)
    support = ((speed < still_speed) | (height < rest_height)).any(axis=1)
    cands = [(a, b) for a, b in label_intervals(~support) if b - a >= 2]
    sig = smooth_sigma * fps / 120.0
    cs = gaussian_smooth(com, sig, axis=0) if sig >= 0.75 else np.asarray(com)
    vy = central_difference(cs, fps)[:, 1]
    gap = int(round(max_gap * fps))
    W = max(3, int(round(border_window * fps)))
    min_n = max(int(np.ceil(min_flight * fps)), 4)
    # merge candidates split by a limb that pauses in mid-air: the vertical momentum keeps
    # falling on one line across the gap (no take-off/landing pattern inside it)
    merged: list[tuple[int, int]] = []
    for a, b in cands:
        if merged and 0 < a - merged[-1][1] <= gap:
            pa, pb = merged[-1]
            idx = np.r_[pa:pb, a:b]
            coef = np.polyfit(idx / fps, vy[idx], 1)
            res = vy[idx] - np.polyval(coef, idx / fps)
            gi = np.arange(pb, a)
            if (coef[0] < 0 and float(np.sqrt(np.mean(res ** 2))) <= 0.5 * v_tol
                    and np.max(np.abs(vy[gi] - np.polyval(coef, gi / fps))) <= v_tol):
                merged[-1] = (pa, b)
                continue
        merged.append((a, b))
    flights, rejected = [], []
    for a, b in merged:
        seg = _ballistic_span(vy, cs[:, 1], max(0, a - W), min(T, b + W), fps, min_n, gravity_range, min_r2)
        if seg is None:
            rejected.append((a, b, "no take-off peak / landing trough pair with a ballistic momentum "
                                   "pattern in between"))
            continue
        s0, s1 = seg
        fit = fit_ballistic(com[s0:s1], fps, s0)
        if not (gravity_range[0] <= fit.scale <= gravity_range[1]):
            rejected.append((s0, s1, f"COM not ballistic (fitted gravity {fit.gravity:.2f} m/s^2)"))
            continue
        if flights and s0 < flights[-1].stop:
            if s1 - s0 > flights[-1].n_frames:
                flights[-1] = fit
            continue
        flights.append(fit)
    order = np.argsort([f.start for f in flights])
    flights = [flights[i] for i in order]
    if len(flights) >= 3 and agree_factor:
        # one clip has one frame rate and one length unit, so its flights share one gravity:
        # a flight whose fitted gravity is off the clip's (frame-weighted median) by more than
        # ``agree_factor`` is not free flight (a roll, a slide, a hand-supported phase)
        ls = np.log([f.scale for f in flights])
        wts = np.array([f.n_frames for f in flights], dtype=float)
        o = np.argsort(ls)
        c = np.cumsum(wts[o])
        ref = float(ls[o][np.searchsorted(c, 0.5 * c[-1])])
        keep = []
        for f, v in zip(flights, ls):
            if abs(v - ref) > np.log(agree_factor):
                rejected.append((f.start, f.stop, f"fitted gravity {f.gravity:.2f} m/s^2 disagrees with the clip's other "
                                                  f"flights ({G * np.exp(ref):.2f} m/s^2) by more than {agree_factor:g}x"))
            else:
                keep.append(f)
        flights = keep
    longest = int(np.argmax([f.n_frames for f in flights])) if flights else None
    return FlightDetection(flights=tuple(flights), longest=longest, candidates=tuple(cands), support=support,
                           effectors=names, still_speed=float(still_speed), com=com, rejected=tuple(rejected),
                           fps=float(fps))
