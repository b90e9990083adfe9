"""Per flight: ballistic fit of the COM, angular momentum spread, take-off angle.

**Ballistic fit.** The COM height over the flight's frames is fitted by least
squares with ``y(t) = c2 tau^2 + c1 tau + c0`` (``tau = t - t_mid``); the fitted
gravity is ``g = -2 c2`` with the 95 % (``confidence``) t-interval
``g +- t_{n-3} 2 se(c2)``, ``se`` from the residual variance ``RSS / (n - 3)``
and ``(X^T X)^-1``. The audit never takes a gravity fitted to the clip as
truth: the finding is raised when 9.81 m/s^2 lies outside the interval widened by
``g_tolerance``; the residual of the free fit and that of the best parabola
with ``g = 9.81`` (``y + 9.81/2 tau^2 = c1 tau + c0``) are both reported. The
horizontal COM is fitted by a line (constant velocity in free flight).
Take-off velocity: the fit's derivative at the first airborne frame; the
take-off angle is its angle from the vertical.

**Angular momentum** about the COM (eq. 5.5, flips paper section 4.3, with the
body model's segments; central differences on the frame times, order 2, no
smoothing) on the flight's frames, one frame dropped at each end (their central
differences straddle the take-off or landing). The paper's error measures
(flips paper section 7, dissertation section 5.7: the direction and the
magnitude of L): *direction spread*, the largest angle between ``L(t)`` and the
mean ``L`` over the flight, and *magnitude variation*, the largest
``| |L(t)| - mean |L| | / mean |L|``. Neither is judged when ``mean |L|`` is
below ``L_min`` (a straight jump has no meaningful L direction).

**Kinds of airborne run.** ``"free"``: judged on all its frames. ``"spurious"``: shorter than
``min_airborne_frames`` frames or ``min_airborne_time`` (a contact-detector flicker; see
:class:`~mocomp.audit.AuditThresholds`): listed, never measured, never paired in comparisons.
``"forced"``: some of its frames lie under a declared external force (:mod:`mocomp.audit.force`):
the fit and the L measures use only its longest free part (``judged_frames``), or none when that is
shorter than ``min_flight_frames``.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import stats

from ..dynamics.contacts import label_intervals
from ..dynamics.derivatives import angular_velocity, central_difference
from ..dynamics.momentum import assemble_momentum, momentum
from .findings import Finding
from .thresholds import G_STANDARD

__all__ = ["BallisticFit", "FlightAudit", "fit_ballistic", "L_spread", "flight_audits"]


@dataclass(frozen=True)
class BallisticFit:
    """Least-squares parabola of the COM height over a flight.

    Attributes
    ----------
    g: m/s^2, fitted gravity ``-2 c2``; g_low, g_high: its ``confidence`` t-interval.
    g_se: m/s^2, standard error; dof: ``n - 3``.
    rms: m, RMS residual of the free fit; rms_standard: m, RMS residual of the best
        parabola with ``g = 9.81``.
    coef: ``(c2, c1, c0)`` in ``tau = t - t_mid``; t_mid: s.
    """

    g: float
    g_low: float
    g_high: float
    g_se: float
    dof: int
    rms: float
    rms_standard: float
    coef: tuple[float, float, float]
    t_mid: float


@lru_cache(maxsize=256)
def _t_quantile(p: float, dof: int) -> float:
    """Student's t quantile (scipy's ``stats.t.ppf``, ~0.2 ms a call: cached, flights share dofs)."""
    return float(stats.t.ppf(p, dof))


def fit_ballistic(t: np.ndarray, y: np.ndarray, confidence: float = 0.95) -> BallisticFit:
    """Fit ``y(t)`` (at least 4 samples; an interval needs ``n - 3 >= 1``)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = t.size
    if n < 4:
        raise ValueError(f"a ballistic fit with an interval needs at least 4 frames, got {n}")
    tm = float(t.mean())
    tau = t - tm
    X = np.column_stack([tau ** 2, tau, np.ones(n)])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    dof = n - 3
    s2 = float(r @ r) / dof
    cov = s2 * np.linalg.inv(X.T @ X)
    se = 2.0 * float(np.sqrt(max(cov[0, 0], 0.0)))
    g = -2.0 * float(coef[0])
    tc = _t_quantile(0.5 + confidence / 2.0, dof)
    ys = y + 0.5 * G_STANDARD * tau ** 2
    X2 = X[:, 1:]
    c2, *_ = np.linalg.lstsq(X2, ys, rcond=None)
    r2 = ys - X2 @ c2
    return BallisticFit(g, g - tc * se, g + tc * se, se, dof, float(np.sqrt(np.mean(r ** 2))),
                        float(np.sqrt(np.mean(r2 ** 2))), (float(coef[0]), float(coef[1]), float(coef[2])), tm)


def L_spread(L: np.ndarray) -> tuple[float, float, float, np.ndarray]:
    """``(direction spread rad, magnitude variation, mean |L|, mean L)`` of ``L`` ``(n, 3)``."""
    Lm = L.mean(axis=0)
    n = np.linalg.norm(L, axis=1)
    ang = np.arctan2(np.linalg.norm(np.cross(L, Lm), axis=1), L @ Lm)
    mean_n = float(n.mean())
    var = float(np.max(np.abs(n - mean_n)) / mean_n) if mean_n > 0 else float("nan")
    return float(ang.max()), var, mean_n, Lm


@dataclass(frozen=True)
class FlightAudit:
    """One airborne run.

    Attributes
    ----------
    index: 0-based; frames: half-open ``(start, stop)``; duration: s (``(stop - start) / fps``).
    fit: :class:`BallisticFit` (``None`` when shorter than ``min_flight_frames``).
    takeoff_velocity: ``(3,)`` m/s from the fits at the first frame (``None`` without a fit).
    takeoff_angle: rad from the vertical; takeoff_speed: m/s.
    rise: m, COM apex height above the first airborne frame's COM height (from the fit).
    L_mean: ``(3,)`` kg m^2/s; L_direction: rad; L_magnitude: relative; L_abs: mean |L|.
    L_judged: mean |L| >= ``L_min``.
    horizontal_rms: m, RMS residual of the linear fits of x and z.
    kind: ``"free"``, ``"forced"`` (some frames under a declared external force) or ``"spurious"``
        (too short to be a flight; see the module docstring).
    forced_frames: how many of its frames are under the declared external force.
    judged_frames: half-open ``(start, stop)`` the fit and L measures were taken on (``frames`` for a
        free flight, the longest free part of a forced one), ``None`` when not measured.
    """

    index: int
    frames: tuple[int, int]
    duration: float
    fit: BallisticFit | None
    takeoff_velocity: np.ndarray | None
    takeoff_angle: float
    takeoff_speed: float
    rise: float
    L_mean: np.ndarray | None
    L_direction: float
    L_magnitude: float
    L_abs: float
    L_judged: bool
    horizontal_rms: float
    kind: str = "free"
    forced_frames: int = 0
    judged_frames: tuple[int, int] | None = None

    @property
    def is_flight(self) -> bool:
        """Not spurious: a flight for the ballistic / L measures and for pairing in comparisons."""
        return self.kind != "spurious"

    def to_dict(self) -> dict:
        f = self.fit
        nan = float("nan")
        return {
            "index": self.index, "frames": list(self.frames), "duration_s": self.duration,
            "g_fit": f.g if f else nan, "g_low": f.g_low if f else nan, "g_high": f.g_high if f else nan,
            "residual_rms_m": f.rms if f else nan, "residual_rms_g9.81_m": f.rms_standard if f else nan,
            "takeoff_velocity": None if self.takeoff_velocity is None else [float(v) for v in self.takeoff_velocity],
            "takeoff_angle_deg": float(np.degrees(self.takeoff_angle)), "takeoff_speed": self.takeoff_speed,
            "com_rise_m": self.rise,
            "L_mean": None if self.L_mean is None else [float(v) for v in self.L_mean],
            "L_direction_rad": self.L_direction, "L_magnitude_rel": self.L_magnitude, "L_abs_mean": self.L_abs,
            "L_judged": self.L_judged, "horizontal_rms_m": self.horizontal_rms,
            "kind": self.kind, "forced_frames": self.forced_frames,
            "judged_frames": None if self.judged_frames is None else list(self.judged_frames),
        }


def flight_L(body, times, seg_pos, seg_rot) -> np.ndarray:
    """``(n, 3)`` L about the COM (eq. 5.5) of a frame range from its segment COMs and orientations
    (central differences on those frames only): what :func:`mocomp.dynamics.momentum` gives for the
    range sliced as a motion of its own, without its forward kinematics again."""
    vel = central_difference(seg_pos, times)
    omega = angular_velocity(seg_rot, times)
    return assemble_momentum(body, times, seg_pos, seg_rot, vel, omega, velocity_mode="finite_difference").angular


def flight_audits(body, motion, com: np.ndarray, phases, thresholds, seg_pos=None,
                  seg_rot=None, forced: np.ndarray | None = None) -> tuple[tuple[FlightAudit, ...], list]:
    """Per airborne run of ``phases.flights``, a :class:`FlightAudit`, and the gravity / L findings.
    ``forced``: ``(T,)`` bool, frames under a declared external force (see the module docstring)."""
    t = motion.times
    out, findings = [], []
    nan = float("nan")
    for k, (a, b) in enumerate(phases.flights):
        n = b - a
        nf = int(forced[a:b].sum()) if forced is not None else 0
        if thresholds.spurious_flight(n, motion.fps):
            kind, judged = "spurious", None
        elif nf:
            kind = "forced"
            free = label_intervals(~forced[a:b])
            judged = None
            if free:
                s0, s1 = max(free, key=lambda r: (r[1] - r[0], r[0]))
                if s1 - s0 >= thresholds.min_flight_frames:
                    judged = (a + s0, a + s1)
        else:
            kind, judged = "free", ((a, b) if n >= thresholds.min_flight_frames else None)
        if judged is None:
            out.append(FlightAudit(k, (a, b), n / motion.fps, None, None, nan, nan, nan, None, nan, nan, nan, False,
                                   nan, kind, nf, None))
            continue
        fa_, fb_ = judged
        nj = fb_ - fa_
        tt, cy = t[fa_:fb_], com[fa_:fb_]
        fit = fit_ballistic(tt, cy[:, 1], thresholds.confidence)
        tau0 = tt[0] - fit.t_mid
        vy = 2 * fit.coef[0] * tau0 + fit.coef[1]
        hx = np.polyfit(tt, cy[:, 0], 1)
        hz = np.polyfit(tt, cy[:, 2], 1)
        hres = np.concatenate([cy[:, 0] - np.polyval(hx, tt), cy[:, 2] - np.polyval(hz, tt)])
        v0 = np.array([hx[0], vy, hz[0]])
        angle = float(np.arctan2(np.hypot(v0[0], v0[2]), v0[1]))
        c2, c1, c0 = fit.coef
        y0 = c2 * tau0 ** 2 + c1 * tau0 + c0
        apex = c0 - c1 ** 2 / (4 * c2) if c2 < 0 else float(np.max(cy[:, 1]))
        if seg_pos is None:
            Lf = momentum(body, motion[fa_:fb_]).angular
        else:
            Lf = flight_L(body, tt, seg_pos[fa_:fb_], seg_rot[fa_:fb_])
        L = Lf[1:-1] if nj >= 5 else Lf
        spread, var, Labs, Lm = L_spread(L)
        judged_L = Labs >= thresholds.L_min
        fa = FlightAudit(k, (a, b), n / motion.fps, fit, v0, angle, float(np.linalg.norm(v0)), float(apex - y0), Lm,
                         spread, var, Labs, bool(judged_L), float(np.sqrt(np.mean(hres ** 2))), kind, nf, judged)
        out.append(fa)
        where = f"flight {k + 1}"
        part = "" if kind == "free" else f"on its free part (frames {fa_}-{fb_ - 1}, outside the declared external force): "
        tol = thresholds.g_tolerance
        if not (fit.g_low - tol <= G_STANDARD <= fit.g_high + tol):
            dist = max(fit.g_low - tol - G_STANDARD, G_STANDARD - fit.g_high - tol)
            findings.append(Finding(
                "gravity", "violation", (fa_, fb_), (fa_ + fb_) // 2, fit.g, tol, "g_tolerance", "m/s^2", where,
                f"{part}COM falls with g = {fit.g:.2f} m/s^2 ({thresholds.confidence:.0%} interval {fit.g_low:.2f}-"
                f"{fit.g_high:.2f}; 9.81 lies {dist:.2f} beyond it plus the {tol:g} m/s^2 tolerance); residual "
                f"{fit.rms * 1000:.1f} mm free, {fit.rms_standard * 1000:.1f} mm with g = 9.81"))
        if judged_L:
            off = fa_ + 1 if nj >= 5 else fa_
            nL = np.linalg.norm(L, axis=1)
            ang = np.arctan2(np.linalg.norm(np.cross(L, Lm), axis=1), L @ Lm)
            if spread > thresholds.L_direction:
                findings.append(Finding(
                    "L_direction", "violation", (fa_, fb_), off + int(np.argmax(ang)), spread, thresholds.L_direction,
                    "L_direction", "rad", where,
                    f"{part}L direction strays {np.degrees(spread):.1f} deg from its mean (|L| {Labs:.1f} kg m^2/s); "
                    f"limit {np.degrees(thresholds.L_direction):.1f} deg"))
            if var > thresholds.L_magnitude:
                findings.append(Finding(
                    "L_magnitude", "violation", (fa_, fb_), off + int(np.argmax(np.abs(nL - Labs))), var,
                    thresholds.L_magnitude, "L_magnitude", "relative", where,
                    f"{part}|L| varies by {var:.1%} of its mean {Labs:.1f} kg m^2/s; limit {thresholds.L_magnitude:.0%}"))
    return tuple(out), findings
