"""Mass distribution from flight phases (flips paper section 4.2, dissertation eq. 5.1-5.2).

During a flight the centre of mass moves on a line in x and z and a parabola in
y. The segment masses ``m_i`` and the trajectory parameters are found together
by one linear least-squares problem (eq. 5.1),

    min  sum_t || sum_i (m_i / M) pos_i(t) - COM(t) ||^2,
    COM(t) = [a_x t + b_x, a_y t^2 + b_y t + c_y, a_z t + b_z],

subject to ``sum_i m_i = M``, ``m_i >= 0`` and equal left/right limb masses, plus
the regulariser ``W sum_i (m_i - m_i^0)^2`` toward the table prior (eq. 5.2).

Implementation: for fixed masses the optimal trajectory parameters are a linear
projection, so they are eliminated exactly (the residual is the part of the
mass-weighted segment trajectories outside the span of ``{1, t}`` in x, z and
``{1, t, t^2}`` in y). What is left is a bounded linear least-squares problem in
the symmetric mass fractions; the sum constraint is eliminated through the
heaviest group and the bounds are handled by ``scipy.optimize.lsq_linear``.
To make ``W`` dimensionless the position residual is divided by the number of
equations and the standing height squared, and the masses are fractions of M::

    J(f) = |r(f)|^2 / (N_eq h^2) + W |f - f0|^2.

A change of the distribution by ``|df|`` is accepted only if it lowers the
relative mean-square residual by more than ``W |df|^2``. The default ``W = 1e-2`` was
set on real flips, where the COM's departure from a parabola is dominated by capture
and model error (tens of mm) rather than by the masses: with the earlier ``W = 3e-4``
(tuned on synthetic flips with 0.3-1 degree jitter) the CMU back flip 88_01 gave the
head 27 % of the body mass and the arms and pelvis none -- the overfitting eq. 5.2 is
there to prevent ("large shifts in mass distribution, which resulted in only small
improvements"). Regularisation path on the six real single flips (largest change of one
segment, in points of %; reduction of the linear-momentum deviation; MASS read at 60 Hz, the
rate its gravity implies; the 16 Hz DeepMimic keys spline-resampled to 120 Hz)::

    W        88_01        88_05        90_08         MASS         DeepMimic back / side
    3e-4     20.5, 31 %   4.3, 42 %    1.5, -1.2 %   9.7, 19 %    15.4, 52 % / 5.9, 31 %
    3e-3      9.5, 26 %   3.5, 41 %    0.3, -3.8 %   6.1, 19 %     4.8, 38 % / 3.1, 24 %
    1e-2      4.5, 18 %   2.5, 39 %    0.2, -2.2 %   3.3, 17 %     3.0, 22 % / 2.2, 16 %
    3e-2      2.1, 13 %   1.5, 34 %    0.1, -1.0 %   1.8, 14 %     1.2,  9 % / 1.2,  9 %

(the dissertation's Table C.1 moves one segment by at most 2.6 points and reports a 30 %
reduction.)
On the side flip 90_08 no ``W`` helps: its COM is already close to ballistic with the prior
(eq. 5.1's residual falls by 1 %) and the estimate makes the momentum slightly *less*
ballistic, so :func:`mocomp.flips.prepare` keeps the prior there (``keep_prior_if_worse``,
with a note in the result and the physics report).

The bound ``m_i >= 0`` is active on most real flips: at the default ``W`` the estimate gives
0 kg to the forearms, hands and feet of 88_01 and MASS, to the hands and feet of 88_05 and to
the ankles of the DeepMimic side flip (their contribution to the COM is small, so eq. 5.1 buys
a little residual with them). ``min_fraction`` replaces the bound by ``m_i >= min_fraction *
m_i^0``; it is off by default (the dissertation's constraint). Measured at ``W = 1e-2``, the
reduction with ``min_fraction`` 0 / 0.25 / 0.5 is 18.3 / 16.8 / 15.1 % (88_01), 39.2 / 38.7 /
37.9 % (88_05), 17.2 / 15.5 / 13.5 % (MASS), 21.5 / 21.5 / 19.1 % and 16.5 / 15.6 / 14.5 %
(DeepMimic back / side); the synthetic tall-performer estimates (true masses >= 0.88 of the
prior) are unchanged.

Estimated on the flip and evaluated on the clip's other flights, the
reduction does not carry over reliably at any ``W`` (it ranges from -85 % to +22 % per
clip), so the flip's own gain is not evidence of better masses by itself; nor does an independent
physical check favour them: the constancy of ``|L|`` over the flight (which eq. 5.1 does not
use) is better with the estimate than with the prior on 2 of the 6 real flips (88_05,
DeepMimic back flip) and worse on 4, at every ``W``. On synthetic
"tall performer" flips (true masses known) the estimate lands closer to the truth than
the prior for every ``W`` above, with and without 0.3-1 degree jitter (closer for
smaller ``W``); without noise and ``W = 0`` the fit is exact. Capture noise enters eq. 5.1 as noise in
the regressors (the segment positions), so the segment trajectories are lightly
smoothed first (``smooth``; a Gaussian maps a parabola to a parabola). Several
flights of one performer share the masses and each has its own trajectory
parameters (:func:`estimate_masses` with a list of flights).

The gravity scale ``s = 2 |a_y| / g`` (``a_y`` is negative in a y-up world; the
printed formula ``s = 2 a_y / g`` uses its magnitude) reveals unit errors and
mislabelled frame rates; :func:`diagnose_gravity` says so in plain words.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from ..body.model import BodyModel
from ..errors import NoFlightPhaseError

__all__ = ["G", "FlightFit", "MassEstimate", "fit_ballistic", "estimate_masses", "diagnose_gravity",
           "diagnose_timing", "TimingDiagnosis", "FLIGHT_LOG_SCALE_SD", "ROTATION_LOG_SCALE_SD", "flight_turns",
           "momentum_deviation",
           "FlightTooShortError", "COMMON_RATES"]

#: standard gravity, m/s^2
G = 9.80665
#: capture rates a mislabelled clip is snapped to when the gravity fit implies another rate
COMMON_RATES = (24.0, 25.0, 30.0, 50.0, 60.0, 100.0, 120.0, 240.0)


class FlightTooShortError(NoFlightPhaseError):
    """A flight phase has too few frames to estimate a mass distribution."""


@dataclass(frozen=True)
class FlightFit:
    """Ballistic COM trajectory of one flight (eq. 5.1), ``t`` in seconds from ``start``.

    Attributes
    ----------
    start, stop: half-open frame range.
    a_x, b_x, a_z, b_z: m/s and m, horizontal lines.
    a_y, b_y, c_y: m/s^2, m/s, m, vertical parabola ``a_y t^2 + b_y t + c_y``.
    gravity: m/s^2, ``-2 a_y`` (the clip's own gravity).
    scale: ``gravity / G`` (1 when frame rate and units are right).
    rms, max: m, residual of the COM about the fitted trajectory.
    scale_se: standard error of ``scale`` from the least-squares fit alone (white residuals;
        the real uncertainty of capture data is larger, see :func:`diagnose_timing`).
    """

    start: int
    stop: int
    a_x: float
    b_x: float
    a_y: float
    b_y: float
    c_y: float
    a_z: float
    b_z: float
    gravity: float
    scale: float
    rms: float
    max: float
    scale_se: float = float("nan")

    @property
    def n_frames(self) -> int:
        return self.stop - self.start

    def com(self, t: np.ndarray) -> np.ndarray:
        """``(n, 3)`` fitted COM at times ``t`` (s from take-off)."""
        t = np.asarray(t, dtype=float)
        return np.column_stack([self.a_x * t + self.b_x, self.a_y * t * t + self.b_y * t + self.c_y,
                                self.a_z * t + self.b_z])

    def velocity(self, t: float) -> np.ndarray:
        return np.array([self.a_x, 2 * self.a_y * t + self.b_y, self.a_z])


def _design(t: np.ndarray, quadratic: bool) -> np.ndarray:
    return np.column_stack([np.ones_like(t), t, t * t] if quadratic else [np.ones_like(t), t])


def fit_ballistic(com: np.ndarray, fps: float, start: int = 0) -> FlightFit:
    """Least-squares ballistic trajectory through ``com (n, 3)`` sampled at ``fps`` (frames
    ``start .. start + n - 1``)."""
    com = np.asarray(com, dtype=float)
    n = com.shape[0]
    if n < 4:
        raise FlightTooShortError(f"a ballistic fit needs at least 4 frames, got {n}")
    t = np.arange(n) / fps
    A1, A2 = _design(t, False), _design(t, True)
    bx, ax = np.linalg.lstsq(A1, com[:, 0], rcond=None)[0]
    bz, az = np.linalg.lstsq(A1, com[:, 2], rcond=None)[0]
    cy, by, ay = np.linalg.lstsq(A2, com[:, 1], rcond=None)[0]
    fit = np.column_stack([ax * t + bx, ay * t * t + by * t + cy, az * t + bz])
    r = np.linalg.norm(com - fit, axis=1)
    g = -2.0 * ay
    ry = com[:, 1] - fit[:, 1]
    se = float("nan")
    if n > 3:
        cov = np.linalg.inv(A2.T @ A2) * (float(ry @ ry) / (n - 3))
        se = 2.0 * float(np.sqrt(max(cov[2, 2], 0.0))) / G
    return FlightFit(int(start), int(start + n), float(ax), float(bx), float(ay), float(by), float(cy),
                     float(az), float(bz), float(g), float(g / G), float(np.sqrt(np.mean(r * r))), float(r.max()),
                     se)


def _projector_complement(n: int, fps: float, quadratic: bool) -> np.ndarray:
    """``I - A (A^T A)^-1 A^T`` for the time design of one axis."""
    A = _design(np.arange(n) / fps, quadratic)
    Q, _ = np.linalg.qr(A)
    return np.eye(n) - Q @ Q.T


def momentum_deviation(com: np.ndarray, fps: float, total_mass: float) -> float:
    """RMS deviation (kg m/s) of the linear momentum ``p = M dCOM/dt`` from its ballistic
    pattern (constant in x and z, linear in y) over a flight, on the interior frames
    (central differences)."""
    com = np.asarray(com, dtype=float)
    if com.shape[0] < 5:
        return float("nan")
    v = (com[2:] - com[:-2]) * (fps / 2.0)
    n = v.shape[0]
    t = np.arange(n) / fps
    dev = []
    for axis in range(3):
        A = _design(t, axis == 1)[:, :2] if axis == 1 else np.ones((n, 1))
        coef = np.linalg.lstsq(A, v[:, axis], rcond=None)[0]
        dev.append(v[:, axis] - A @ coef)
    d = np.linalg.norm(np.column_stack(dev), axis=1)
    return float(total_mass * np.sqrt(np.mean(d * d)))


def diagnose_gravity(scale: float, fps: float, height: float | None = None) -> str:
    """Plain-words reading of the gravity scale ``s`` of a flight fit at frame rate ``fps``."""
    s = float(scale)
    g = s * G
    if not np.isfinite(s) or s <= 0:
        return (f"the fitted vertical motion is not a downward parabola (gravity {g:.2f} m/s^2): the interval "
                "is probably not a flight phase")
    if 0.7 <= s <= 1.45:
        return (f"fitted gravity {g:.2f} m/s^2 (s = {s:.2f}) is consistent with 9.81 m/s^2: frame rate "
                f"({fps:g} Hz) and length units look right")
    implied = fps / np.sqrt(s)
    nearest = min(COMMON_RATES, key=lambda r: abs(np.log(r / implied)))
    units_ok = height is None or 1.2 <= height <= 2.2
    if units_ok and (s > 2.0 or s < 0.5) and abs(np.log(nearest / implied)) < np.log(1.25):
        speed = "fast" if s > 1 else "slow"
        return (f"fitted gravity is {g:.1f} m/s^2 (s = {s:.2f}) at the stated {fps:g} Hz: the motion runs "
                f"{np.sqrt(s) if s > 1 else 1 / np.sqrt(s):.2f}x too {speed}, so the clip was most likely captured "
                f"at about {implied:.0f} Hz (nearest common rate {nearest:g} Hz) but labelled {fps:g} Hz; reload "
                f"it with fps={nearest:g} (CLI: --fps {nearest:g})")
    if not units_ok:
        return (f"fitted gravity is {g:.1f} m/s^2 (s = {s:.2f}) and the skeleton is {height:.2f} m tall: the "
                f"length unit is probably wrong (lengths look {s:.3g}x too large); reload with the right scale")
    return (f"fitted gravity {g:.2f} m/s^2 (s = {s:.2f}) is off by more than the fit's usual error but does "
            f"not match a clean frame-rate or unit error (implied rate {implied:.0f} Hz); the flight may be short, "
            "noisy or coarsely sampled, or the mass distribution poor")


#: systematic uncertainty of one flight's gravity scale (standard deviation of ``log s``): a
#: floor, plus a part growing with the body's rotation during the flight (in turns of the root's
#: orientation path), ``sd^2 = FLIGHT_LOG_SCALE_SD^2 + (ROTATION_LOG_SCALE_SD * turns)^2``.
#: Maximum-likelihood fit to 68 flights of 13 real clips at their known capture rates (CMU
#: 88_01, 88_05, 90_08 at 60 Hz; 83_58, 01_01, 131_03, SFU two-foot jumps, jump rope and wushu
#: kicks at 120 Hz; DeepMimic flips, jump and spin kick): hops stay within ~0.03 of 0, while
#: flips' flights (fast inverted rotation, where an approximate segment COM is least reliable),
#: very short flights and key-framed clips reach 0.27-0.45; 5.9 % of the flights fall outside
#: their 95 % interval under this model.
FLIGHT_LOG_SCALE_SD = 0.08
ROTATION_LOG_SCALE_SD = 0.44


@dataclass(frozen=True)
class TimingDiagnosis:
    """What the flights' fitted gravity says about the frame rate (and units), in plain words.

    Gravity fitted in flight scales as ``length unit / time^2``: at a stated rate ``fps`` a
    gravity scale ``s = g_fit / 9.81`` means the true capture rate is ``fps / sqrt(s)`` (units
    right). Each flight's ``log s`` is given its least-squares error plus a systematic error
    that grows with the rotation in the flight (:data:`FLIGHT_LOG_SCALE_SD`,
    :data:`ROTATION_LOG_SCALE_SD`: a hop before a flip says more about the frame rate than the
    flip itself); flights are combined by a random-effects mean (DerSimonian-Laird: flights that
    disagree beyond their errors widen the interval).

    Attributes
    ----------
    fps: the stated frame rate (Hz).
    scale, scale_interval: combined ``s`` and its ``level`` interval.
    implied_fps, implied_interval: ``fps / sqrt(s)`` and its interval (Hz).
    candidates: common capture rates (:data:`COMMON_RATES`) inside the interval, nearest first.
    consistent: the stated rate is inside the interval.
    suggested: the rate to reload with (nearest candidate) when the stated rate is not
        consistent and the units look right, else ``None``.
    per_flight: ``(start, stop, s, sd of log s)`` per flight.
    tau: between-flight standard deviation of ``log s`` beyond the per-flight errors.
    units_ok: the skeleton height is plausible for metres (or unknown).
    level: the interval's coverage.
    text: the plain-words diagnosis.
    """

    fps: float
    scale: float
    scale_interval: tuple[float, float]
    implied_fps: float
    implied_interval: tuple[float, float]
    candidates: tuple[float, ...]
    consistent: bool
    suggested: float | None
    per_flight: tuple[tuple[int, int, float, float], ...]
    tau: float
    units_ok: bool
    level: float
    text: str

    def __str__(self) -> str:
        return self.text


def flight_turns(motion, flights) -> np.ndarray:
    """Per flight ``(start, stop)``, the length of the root orientation's path in turns (the sum
    of frame-to-frame rotation angles over 2 pi)."""
    from ..core.rotations import quat_angle, quat_inverse, quat_multiply

    q = np.asarray(motion.rotations[:, 0])
    step = quat_angle(quat_multiply(q[1:], quat_inverse(q[:-1])))       # frame f -> f + 1, whole clip at once
    return np.asarray([float(np.sum(step[int(a):max(int(b) - 1, int(a))])) / (2 * np.pi) for a, b in flights])


def _rates(values) -> str:
    v = [f"{r:g}" for r in values]
    return v[0] if len(v) == 1 else ", ".join(v[:-1]) + " or " + v[-1]


def diagnose_timing(fits, fps: float, height: float | None = None, level: float = 0.95, turns=None,
                    flight_sd: float = FLIGHT_LOG_SCALE_SD,
                    rotation_sd: float = ROTATION_LOG_SCALE_SD) -> TimingDiagnosis:
    """Combine the gravity fits of one or more flights of a clip (:class:`FlightFit`) into a
    :class:`TimingDiagnosis` (see there). ``height``: the skeleton's standing height in metres
    (a wrong length unit shows as an implausible height rather than a frame-rate error);
    ``turns``: per flight, the root's rotation during it in turns (:func:`flight_turns`; 0 if
    not given)."""
    from scipy.stats import norm

    turns = np.zeros(len(fits)) if turns is None else np.asarray(turns, dtype=float)
    keep = [i for i, f in enumerate(fits) if np.isfinite(f.scale) and f.scale > 0]
    fits = [fits[i] for i in keep]
    turns = turns[keep] if len(keep) else np.zeros(0)
    units_ok = height is None or 1.2 <= height <= 2.2
    z = float(norm.ppf(0.5 + level / 2))
    if not fits:
        text = ("no flight has a downward parabola: the intervals are probably not flight phases, so the frame "
                "rate cannot be checked from gravity")
        nan = float("nan")
        return TimingDiagnosis(float(fps), nan, (nan, nan), nan, (nan, nan), (), False, None, (), nan, units_ok,
                               level, text)
    y = np.log([f.scale for f in fits])
    se = np.array([f.scale_se / f.scale if np.isfinite(f.scale_se) else 0.0 for f in fits])
    var = se ** 2 + flight_sd ** 2 + (rotation_sd * turns) ** 2
    w = 1.0 / var
    mean = float(np.sum(w * y) / np.sum(w))
    tau2 = 0.0
    if y.size > 1:
        Q = float(np.sum(w * (y - mean) ** 2))
        tau2 = max(0.0, (Q - (y.size - 1)) / float(np.sum(w) - np.sum(w * w) / np.sum(w)))
    ws = 1.0 / (var + tau2)
    mean = float(np.sum(ws * y) / np.sum(ws))
    sd = float(np.sqrt(1.0 / np.sum(ws)))
    s = float(np.exp(mean))
    s_lo, s_hi = float(np.exp(mean - z * sd)), float(np.exp(mean + z * sd))
    implied = float(fps / np.sqrt(s))
    f_lo, f_hi = float(fps / np.sqrt(s_hi)), float(fps / np.sqrt(s_lo))
    cands = tuple(sorted((r for r in COMMON_RATES if f_lo <= r <= f_hi), key=lambda r: abs(np.log(r / implied))))
    consistent = bool(s_lo <= 1.0 <= s_hi)
    per = tuple((int(f.start), int(f.stop), float(f.scale), float(np.sqrt(v))) for f, v in zip(fits, var + tau2))
    n = len(fits)
    what = f"{n} flight{'s' if n > 1 else ''}"
    pct = f"{100 * level:.0f}%"
    g = s * G
    suggested = None
    if consistent:
        others = [r for r in cands if abs(np.log(r / fps)) > 1e-6]
        text = (f"fitted gravity {g:.2f} m/s^2 (s = {s:.2f}, {pct} interval {s_lo:.2f}-{s_hi:.2f} from {what}) is "
                f"consistent with 9.81 m/s^2: the stated frame rate ({fps:g} Hz) and length units look right")
        if others:
            text += (f"; the flights cannot rule out {_rates(others)} Hz (implied {implied:.0f} Hz, {pct} interval "
                     f"{f_lo:.0f}-{f_hi:.0f} Hz)")
    elif not units_ok:
        text = (f"fitted gravity is {g:.1f} m/s^2 (s = {s:.2f}) and the skeleton is {height:.2f} m tall: the "
                f"length unit is probably wrong (lengths look {s:.3g}x too large); reload with the right scale")
    else:
        speed = "fast" if s > 1 else "slow"
        fac = np.sqrt(s) if s > 1 else 1 / np.sqrt(s)
        text = (f"fitted gravity is {g:.1f} m/s^2 (s = {s:.2f}, {pct} interval {s_lo:.2f}-{s_hi:.2f} from {what}) "
                f"at the stated {fps:g} Hz: the motion runs {fac:.2f}x too {speed}, so the clip was captured at "
                f"about {implied:.0f} Hz ({pct} interval {f_lo:.0f}-{f_hi:.0f} Hz) but labelled {fps:g} Hz")
        if cands:
            suggested = float(cands[0])
            if len(cands) == 1:
                text += f"; the one common capture rate in that interval is {suggested:g} Hz"
            else:
                text += (f"; the common capture rates {_rates(sorted(cands))} Hz are "
                         f"{'both' if len(cands) == 2 else 'all'} consistent with the flights "
                         f"(they cannot tell them apart), {suggested:g} Hz is the nearest")
            text += f": reload it with fps={suggested:g} (CLI: --fps {suggested:g})"
        else:
            text += ("; no common capture rate lies in that interval, so the flight may be short, noisy or coarsely "
                     "sampled, or the mass distribution poor")
    return TimingDiagnosis(float(fps), s, (s_lo, s_hi), implied, (f_lo, f_hi), cands, consistent, suggested, per,
                           float(np.sqrt(tau2)), units_ok, float(level), text)


@dataclass(frozen=True)
class MassEstimate:
    """Result of eq. 5.1-5.2 with its evidence.

    Attributes
    ----------
    body: new :class:`BodyModel` with the estimated masses and recomputed inertias.
    prior: the table model it started from (``m^0``).
    groups: symmetric segment groups (one mass each).
    fits: per flight, the trajectory fitted with the estimated masses.
    prior_fits: the same with the prior masses.
    W: regulariser weight (dimensionless, see module docstring).
    residual_rms, prior_residual_rms: m, COM residual about the fitted trajectories.
    momentum_deviation, prior_momentum_deviation: kg m/s, RMS deviation of linear
        momentum from its ballistic pattern (mean over flights).
    reduction: ``1 - momentum_deviation / prior_momentum_deviation`` (the paper: 0.30).
    gravity_scale: ``s`` combined over the flights (:func:`diagnose_timing`); diagnosis: plain
        words about it; timing: the :class:`TimingDiagnosis` behind them.
    seconds: time taken.
    """

    body: BodyModel
    prior: BodyModel
    groups: tuple[tuple[int, ...], ...]
    fits: tuple[FlightFit, ...]
    prior_fits: tuple[FlightFit, ...]
    W: float
    residual_rms: float
    prior_residual_rms: float
    momentum_deviation: float
    prior_momentum_deviation: float
    reduction: float
    gravity_scale: float
    diagnosis: str
    seconds: float = 0.0
    notes: tuple[str, ...] = field(default=())
    timing: TimingDiagnosis | None = None

    @property
    def masses(self) -> np.ndarray:
        return self.body.masses

    def table(self, truth: np.ndarray | None = None):
        """Dissertation Table C.1 layout: per segment, initial and optimized mass in % of the
        total (and the true % when ``truth`` masses are given), plus the change in points."""
        import pandas as pd

        M = self.body.total_mass
        df = pd.DataFrame({
            "segment": self.body.segment_names,
            "joint": [self.body.skeleton.names[j] for j in self.body.segment_joint],
            "initial_%": 100 * self.prior.masses / self.prior.total_mass,
            "optimized_%": 100 * self.body.masses / M,
        })
        if truth is not None:
            truth = np.asarray(truth, dtype=float)
            df["true_%"] = 100 * truth / truth.sum()
            df["initial_error_%"] = df["initial_%"] - df["true_%"]
            df["optimized_error_%"] = df["optimized_%"] - df["true_%"]
        else:
            df["change_%"] = df["optimized_%"] - df["initial_%"]
        return df

    def error_vs(self, truth: np.ndarray) -> tuple[float, float]:
        """RMS per-segment mass error (kg) of (estimate, prior) against ``truth``, with the
        prior scaled to the truth's total mass."""
        truth = np.asarray(truth, dtype=float)
        est = self.body.masses * truth.sum() / self.body.total_mass
        pri = self.prior.masses * truth.sum() / self.prior.total_mass
        return float(np.sqrt(np.mean((est - truth) ** 2))), float(np.sqrt(np.mean((pri - truth) ** 2)))


def estimate_masses(prior: BodyModel, motion, flights, W: float = 1e-2, symmetric: bool = True,
                    min_frames: int = 8, smooth: float = 2.0,
                    segment_positions: np.ndarray | None = None, min_fraction: float = 0.0) -> MassEstimate:
    """Eq. 5.1-5.2 over one flight ``(start, stop)`` or several (a list): shared masses,
    per-flight trajectories.

    Parameters
    ----------
    prior: the table model (``m^0``, local COMs, shapes); its total mass is kept.
    motion: the :class:`~mocomp.core.Motion` (the prior's skeleton).
    flights: ``(start, stop)`` half-open frame range, or a list of them.
    W: regulariser weight (dimensionless; see the module docstring). 0 = eq. 5.1 alone.
    symmetric: one mass per left/right pair (:func:`mocomp.body.symmetry.symmetric_groups`).
    min_frames: fewer airborne frames than this in every flight raises
        :class:`FlightTooShortError`.
    smooth: Gaussian sigma (frames at 120 Hz, scaled with the frame rate) applied to the
        segment trajectories before the fit, with ``ceil(2 sigma)`` frames dropped at each
        end of a flight (the kernel reaches into the ground phases there). Capture noise
        in the segment positions is noise in the regressors of eq. 5.1 and biases the
        masses; a Gaussian maps a parabola to a parabola, so the ballistic model is kept.
        0 disables it. Reported fits and momentum deviations use the raw trajectories.
    segment_positions: precomputed ``(T, S, 3)`` segment COMs (else computed).
    min_fraction: lower bound ``m_i >= min_fraction * m_i^0`` in place of eq. 5.2's ``m_i >= 0``
        (0, the default, is the dissertation's bound; in ``[0, 1)``). See the module docstring
        for what it does on the real flips.
    """
    from ..body.inertia import inertia_for_masses
    from ..body.symmetry import symmetric_groups
    from ..dynamics import segment_positions as seg_pos

    t0 = time.perf_counter()
    if not 0.0 <= float(min_fraction) < 1.0:
        raise ValueError(f"min_fraction={min_fraction!r}: the lower bound m_i >= min_fraction * m_i^0 needs "
                         "0 <= min_fraction < 1 (0 = eq. 5.2's m_i >= 0)")
    if isinstance(flights, tuple) and len(flights) == 2 and np.isscalar(flights[0]):
        flights = [flights]
    flights = [(int(a), int(b)) for a, b in flights]
    if not flights:
        raise NoFlightPhaseError("mass estimation needs at least one flight phase")
    fps = motion.fps
    short = [f for f in flights if f[1] - f[0] < min_frames]
    usable = [f for f in flights if f[1] - f[0] >= min_frames]
    if not usable:
        a, b = max(flights, key=lambda f: f[1] - f[0])
        raise FlightTooShortError(
            f"the longest flight (frames {a}-{b - 1}) has {b - a} frames ({(b - a) / fps:.3f} s at {fps:g} Hz); "
            f"estimating masses needs at least {min_frames} airborne frames: use a clip with a longer flight, "
            "resample it to a higher frame rate, or skip estimation and keep the table prior")
    notes = [f"flight {a}-{b - 1} ({b - a} frames) is too short and was not used" for a, b in short]
    pos = seg_pos(prior, motion) if segment_positions is None else np.asarray(segment_positions)
    M = prior.total_mass
    f0 = prior.masses / M
    S = f0.size
    groups = symmetric_groups(prior) if symmetric else [[i] for i in range(S)]
    Gm = np.zeros((S, len(groups)))
    for gi, g in enumerate(groups):
        Gm[g, gi] = 1.0
    h = float(motion.skeleton.height()) if hasattr(motion.skeleton, "height") else 1.7
    sig = smooth * fps / 120.0 if smooth else 0.0
    if sig >= 0.3:
        from scipy.ndimage import gaussian_filter1d

        spos = gaussian_filter1d(pos, sig, axis=0, mode="nearest")
        drop = int(np.ceil(2 * sig))
    else:
        spos, drop = pos, 0
    blocks = []
    n_eq = 0
    for a, b in usable:
        d = drop if b - a - 2 * drop >= min_frames else 0
        a, b = a + d, b - d
        P = spos[a:b]                       # (n, S, 3)
        n = b - a
        for axis in range(3):
            C = _projector_complement(n, fps, axis == 1)
            blocks.append(C @ P[:, :, axis])
        n_eq += 3 * n
    A = np.vstack(blocks) / (np.sqrt(n_eq) * h)          # residual r = A f (already projected)
    K = np.vstack([A @ Gm, np.sqrt(W) * Gm])
    y = np.concatenate([np.zeros(A.shape[0]), np.sqrt(W) * f0])
    sizes = Gm.sum(axis=0)
    # eliminate the sum constraint through the group with the largest prior mass
    mu0 = (Gm.T @ f0) / sizes
    kk = int(np.argmax(mu0 * sizes))
    free = [i for i in range(len(groups)) if i != kk]
    # mu_k = (1 - sum_{free} n_i mu_i) / n_k
    E = np.zeros((len(groups), len(free)))
    e0 = np.zeros(len(groups))
    for c, i in enumerate(free):
        E[i, c] = 1.0
        E[kk, c] = -sizes[i] / sizes[kk]
    e0[kk] = 1.0 / sizes[kk]
    lb = float(min_fraction) * mu0
    sol = lsq_linear(K @ E, y - K @ e0, bounds=(lb[free], np.inf) if min_fraction > 0 else (0.0, np.inf),
                     method="bvls", tol=1e-12)
    mu = E @ sol.x + e0
    if mu[kk] < lb[kk]:  # pathological: the eliminated group is below its bound; solve with SLSQP instead
        from scipy.optimize import minimize

        H = K.T @ K
        c = K.T @ y
        res = minimize(lambda x: x @ H @ x - 2 * c @ x, mu0, jac=lambda x: 2 * (H @ x - c), method="SLSQP",
                       bounds=[(float(b), None) for b in lb],
                       constraints=[{"type": "eq", "fun": lambda x: sizes @ x - 1.0, "jac": lambda x: sizes}],
                       options={"ftol": 1e-14, "maxiter": 500})
        mu = np.maximum(res.x, lb)
        mu /= sizes @ mu
        notes.append("the constrained solve used SLSQP (the eliminated group hit its bound)")
    f = Gm @ mu
    masses = f * M
    body = prior.with_masses(masses, inertia_for_masses(prior, masses))
    com_est = np.einsum("s,tsk->tk", f, pos)
    com_pri = np.einsum("s,tsk->tk", f0, pos)
    fits = tuple(fit_ballistic(com_est[a:b], fps, a) for a, b in usable)
    pfits = tuple(fit_ballistic(com_pri[a:b], fps, a) for a, b in usable)
    dev = float(np.mean([momentum_deviation(com_est[a:b], fps, M) for a, b in usable]))
    pdev = float(np.mean([momentum_deviation(com_pri[a:b], fps, M) for a, b in usable]))

    def _rms(fs):
        w = np.array([ft.n_frames for ft in fs], dtype=float)
        return float(np.sqrt(np.sum(w * np.array([ft.rms for ft in fs]) ** 2) / w.sum()))

    timing = diagnose_timing(fits, fps, h, turns=flight_turns(motion, usable))
    scale = timing.scale if np.isfinite(timing.scale) else float(np.median([ft.scale for ft in fits]))
    diag = timing.text
    return MassEstimate(body=body, prior=prior, groups=tuple(tuple(g) for g in groups), fits=fits, prior_fits=pfits,
                        W=float(W), residual_rms=_rms(fits), prior_residual_rms=_rms(pfits),
                        momentum_deviation=dev, prior_momentum_deviation=pdev,
                        reduction=float(1.0 - dev / pdev) if pdev > 1e-9 * M else float("nan"),
                        gravity_scale=scale, diagnosis=diag, seconds=time.perf_counter() - t0, notes=tuple(notes),
                        timing=timing)
