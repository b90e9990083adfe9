"""Take-off and landing repair: ``k < k*`` made physical by reshaping the stance (beyond the paper).

At ``k = k*`` (App. B eq. B.5) the new flight leaves with the velocity the ``k``-retimed take-off
reaches; at any other ``k`` it cannot (:mod:`mocomp.flips.retime`): with the paper's ``k = 0.7 k*``
(section 5.3) the flight needs about twice the vertical take-off speed, and the COM velocity
jumps between two frames (CMU 88_01: 2.47 -> 5.81 m/s). The paper calls this imperceptible;
Newton does not allow it. :func:`repair_stance` removes the jump where it is made: over the last
ground frames before the take-off it adds a root displacement map ``d(t)`` (vertical, plus any
horizontal mismatch) with

    d(t_event) = 0,   d'(t_event) = dv,   d = d' = d'' = 0 where the window starts,

so the COM is accelerated smoothly from the retimed take-off's velocity to the new flight's
(and, mirrored, decelerated after the landing from the flight's arrival velocity to the retimed
landing's). Of all such maps it takes the one with the least displacement: it minimises

    J(d) = mean over the window of |d|^2  +  lambda D^6 mean |d'''|^2        (jerk-regularised)

(``D`` the window length, ``lambda`` = :data:`JERK_WEIGHT`: the jerk term keeps the ground force
smooth, as a minimum-jerk profile would [Flash & Hogan 1985]) subject to, at every output frame of
the window, the vertical ground reaction ``M (g + a_y)`` of the repaired COM between ``min_force``
(0.5, :data:`MIN_FORCE`; 0.1 where the stance needs it, which the measured ZMP then shows) and
``max_force`` body weights (the ground pushes, it cannot pull: ``a_y >= -g``; peak take-off
forces of standing back somersaults are 3-6 body weights and of running ones 8-13, and ``k = 0.7 k*``
asks for about twice the take-off speed, so ``max_force = 8`` (:data:`MAX_FORCE`), or the
stance's own peak where that is higher). ``a_y`` is the
retimed stance's own COM acceleration (Gaussian-smoothed over :data:`ACC_SMOOTH_S`) plus ``d''``.
``d`` is a clamped quintic B-spline on the window with knots every :data:`KNOT_SPACING_S` (so a
push can be as short as the stance needs, anywhere in it); the end conditions fix five of its
coefficients, and the least-squares problem with linear inequalities in the others is solved
exactly by Lawson & Hanson's reduction to one non-negative least squares (:func:`_lsi`). Gaining ``dv`` while ending where the take-off was forces a
deeper crouch first: even a bang-bang push (free fall, then the largest force) sinks
``dv^2 / (2 (max_force - 1) g)`` deeper, 13 cm for the 3.2 m/s the synthetic back flip needs at
``k = 0.7 k*``; the smooth map needs more.

The feet stay planted: every window frame's ankles are put back where the unrepaired frame had
them by the analytic two-bone leg IK of :mod:`mocomp.ops.ik` (:func:`~mocomp.ops.ik.two_bone_ik`;
the ankle keeps its world orientation, so the toes stay too). Folding the legs moves their mass
less than the root, so the root displacement is corrected until the whole-body COM (not the
root) follows ``d`` (a fixed-point iteration, :data:`COM_ITERATIONS`). Where a leg cannot reach,
a knee would have to fold further than the performer's own tightest fold anywhere in the clip
(the tuck) less :data:`KNEE_MARGIN`, or no push within the force bounds exists in the stance, :class:`StanceRepairError`
says so, naming the frames, the velocity to add and the force or depth it would take, instead of
writing such a motion.

What the repair leaves to measurement: the ZMP. A vertical displacement changes the ZMP of
touch-up paper eq. 4 through ``a_y`` (more push draws it toward the COM's ground projection,
less push lets the horizontal terms dominate); :func:`repair_stance` reports the largest ZMP
distance outside the support polygon over the window before and after (measured by
:mod:`mocomp.audit` on both motions, with the same body), and the physics report notes it when
the repair makes it worse.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..errors import PhysicsError

__all__ = ["StanceRepair", "StanceRepairError", "repair_stance", "stance_displacement", "TAKEOFF_CHOICES",
           "stance_window", "smooth_stance", "audit_com", "SMOOTH_MARGINS",
           "MAX_FORCE", "MIN_FORCE", "MIN_FORCE_FALLBACK", "MAX_WINDOW_S", "JERK_WEIGHT", "DEGREE", "KNOT_SPACING_S", "ACC_SMOOTH_S",
           "IK_TOLERANCE", "AIRBORNE_CLEARANCE", "KNEE_MARGIN", "KNEE_MIN"]

#: the values of ``multiflip(..., takeoff=...)`` / ``--takeoff``
TAKEOFF_CHOICES = ("smooth", "as-is", "repair")
#: body weights: the largest vertical ground reaction the repaired stance may need (or the stance's own
#: peak where that is higher). Standing take-offs of back somersaults peak at 3-6 body weights, running
#: ones (round-off, back handspring) at 8-13; the real CMU 88_01 flip's own push, smoothed over 20 ms,
#: peaks at 6.0 and the synthetic back flip's at 6.8. ``k = 0.7 k*`` asks for about twice the take-off
#: speed, so the bound is that of a running take-off.
MAX_FORCE = 8.0
#: body weights: the same bound at a landing (:func:`mocomp.edit.landing.match_landing_velocity`'s
#: :data:`~mocomp.edit.landing.LANDING_MAX_FORCE`: drop landings of gymnasts peak at 4-11 body weights)
LANDING_MAX_FORCE = 12.0
#: body weights: the smallest vertical ground reaction the repaired stance may have (the ground cannot
#: pull). Near zero the ZMP of eq. 4 is the ratio of two small numbers and runs far outside the support
#: polygon (synthetic side flip at 0.7 k*: 0.49 m before the repair, 2.87 m after with a 0.1 floor,
#: 0.42 m with 0.5); where no map keeps 0.5 (CMU 88_01's 0.3 s landing stance) the floor drops to
#: :data:`MIN_FORCE_FALLBACK` and the measured ZMP says what it costs
MIN_FORCE = 0.5
#: body weights: the floor used where :data:`MIN_FORCE` cannot be kept
MIN_FORCE_FALLBACK = 0.1
#: s: the longest stretch of the stance the displacement map may use
MAX_WINDOW_S = 0.8
#: the weight of the jerk term of J(d): at 1e-5 a 3.2 m/s push over 0.8 s sinks 21 cm with forces of
#: 0.5-3.8 body weights (1e-3: 34 cm, 0.6-2.7; 1e-7: 13 cm, the bang-bang limit, 0.1-5)
JERK_WEIGHT = 1e-5
#: degree of the B-spline d(t)
DEGREE = 5
#: s: the B-spline's knot spacing (at most; the window holds a whole number of intervals, at least 3)
KNOT_SPACING_S = 0.025
#: s: Gaussian smoothing (standard deviation) of the stance's own COM acceleration in the force bounds
ACC_SMOOTH_S = 0.02
#: m: the largest distance an ankle may be left from its planted position
IK_TOLERANCE = 0.005
#: root corrections so the COM (not the root) follows the displacement map
COM_ITERATIONS = 4


class StanceRepairError(PhysicsError):
    """The stance cannot take the velocity change within the force bounds or the legs' reach."""


@dataclass(frozen=True)
class StanceRepair:
    """What :func:`repair_stance` changed and measured (SI units).

    Attributes
    ----------
    event: ``"take-off"`` or ``"landing"``; event_time: s, output time of the event.
    frames: ``(start, stop)`` half-open output frames changed.
    dv: ``(3,)`` m/s, velocity added at the event (flight minus retimed stance).
    window: s, length of the stance the map may use (the map itself decays where it is not needed).
    dip: m, the most negative vertical displacement (a deeper crouch); rise: the most positive.
    horizontal: m, largest horizontal displacement of the root.
    peak_force, min_force: body weights, vertical ground reaction of the repaired COM over the
        window (smoothed acceleration); peak_force_before: the same before the repair.
    peak_extra_acceleration: m/s^2, largest ``|d''|``.
    ik_miss: m, largest distance an ankle is left from its planted position.
    zmp_outside_before, zmp_outside_after: m, largest ZMP distance outside the support polygon over
        the window frames (``nan`` where the audit measured none).
    """

    event: str
    event_time: float
    frames: tuple[int, int]
    dv: np.ndarray
    window: float
    dip: float
    rise: float
    horizontal: float
    peak_force: float
    min_force: float
    peak_force_before: float
    peak_extra_acceleration: float
    ik_miss: float
    zmp_outside_before: float = float("nan")
    zmp_outside_after: float = float("nan")

    def describe(self) -> str:
        a, b = self.frames
        dv = np.asarray(self.dv)
        return (f"{self.event} repaired over output frames {a}-{b - 1} ({(b - a)} frames): {np.linalg.norm(dv):.2f} m/s "
                f"added (vertical {dv[1]:+.2f}), crouch {100 * -self.dip:.1f} cm deeper at most, vertical ground force "
                f"{self.min_force:.2f}-{self.peak_force:.2f} body weights (before {self.peak_force_before:.2f}), "
                f"feet held within {1000 * self.ik_miss:.1f} mm; ZMP outside the support polygon at most "
                f"{_cm(self.zmp_outside_before)} before, {_cm(self.zmp_outside_after)} after")

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        d["dv"] = [float(x) for x in np.asarray(self.dv)]
        d["frames"] = list(self.frames)
        return d


def _cm(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.1f} cm"


def _knots(D: float, spacing: float = KNOT_SPACING_S, p: int = DEGREE) -> np.ndarray:
    """Clamped knot vector of degree ``p`` on ``[0, D]`` with uniform intervals of at most ``spacing``."""
    m = max(3, int(math.ceil(D / spacing - 1e-9)))
    return np.r_[np.zeros(p), np.linspace(0.0, D, m + 1), np.full(p, D)]


def _basis(tau: np.ndarray, knots: np.ndarray, deriv: int = 0, p: int = DEGREE) -> np.ndarray:
    """``(m, K)`` design matrix of the ``deriv``-th time derivative of the B-spline basis at ``tau`` (s)."""
    from scipy.interpolate import BSpline

    K = knots.size - p - 1
    spl = BSpline(knots, np.eye(K), p, extrapolate=False)
    if deriv:
        spl = spl.derivative(deriv)
    out = spl(np.clip(tau, 0.0, knots[-1]))
    return np.nan_to_num(np.asarray(out, dtype=float))


def _lsi(A: np.ndarray, b: np.ndarray, G: np.ndarray, h: np.ndarray):
    """``argmin |A x - b|`` subject to ``G x >= h`` (A of full column rank), or ``None`` when no ``x``
    meets the constraints: Lawson & Hanson's reduction (Solving Least Squares Problems, 1974, ch. 23):
    ``A = Q R``, ``z = R x - Q^T b`` turns it into least distance programming, ``min |z|`` with
    ``(G R^-1) z >= h - G R^-1 Q^T b``, solved exactly by one non-negative least squares
    (:func:`scipy.optimize.nnls`)."""
    from scipy.linalg import solve_triangular
    from scipy.optimize import nnls

    Q, R = np.linalg.qr(A)
    F = solve_triangular(R, G.T, trans="T").T          # G R^-1
    qb = Q.T @ b
    g = h - F @ qb
    scale = np.maximum(np.linalg.norm(F, axis=1), 1e-300)
    F, g = F / scale[:, None], g / scale              # row scaling leaves the feasible set unchanged
    n = F.shape[1]
    E = np.vstack([F.T, g[None, :]])
    e = np.zeros(n + 1)
    e[n] = 1.0
    u, _ = nnls(E, e, maxiter=50 * E.shape[1])
    r = E @ u - e
    if abs(r[n]) < 1e-12:
        return None
    z = -r[:n] / r[n]
    return solve_triangular(R, z + qb)


def stance_displacement(tau: np.ndarray, slope: float, D: float, lower=None, upper=None, *,
                        jerk_weight: float = JERK_WEIGHT, spacing: float = KNOT_SPACING_S, samples: int = 241,
                        d_lower=None, d_upper=None, lin_rows=None, acc_weight: float = 0.0):
    """One component of the displacement map, as a function of the time ``tau`` (s) from the
    event into the stance: ``d(0) = 0``, ``dd/dtau(0) = slope``, ``d = d' = d'' = 0`` at
    ``tau = D``, minimising ``J(d)`` (module docstring) with ``lower <= d''(tau) <= upper`` and
    ``d_lower <= d(tau) <= d_upper`` at the times ``tau`` (arrays like ``tau`` or ``None``). ``lin_rows``:
    ``(M, lo, hi)``, further linear bounds ``lo <= M d(tau) <= hi`` (``M`` of shape ``(m, len(tau))``:
    e.g. the audit's velocity-jump filters over the frames). ``slope=None`` leaves ``d'(0)`` free.
    Returns ``(d(tau), d''(tau), ok)``: ``ok`` is ``False`` when no map within the bounds exists (the
    least-violating one is returned)."""

    tau = np.asarray(tau, dtype=float)
    kn = _knots(D, spacing)
    K = kn.size - DEGREE - 1
    c_fixed = np.zeros(K)
    if slope is None:
        free = np.arange(1, K - 3)                      # c0 = 0 (d(0) = 0); the last three 0 (d, d', d'' at D)
    else:
        c_fixed[1] = slope * kn[DEGREE + 1] / DEGREE    # d'(0) = p (c1 - c0) / t_{p+1}
        free = np.arange(2, K - 3)
    q = np.linspace(0.0, D, samples)
    B0, B3 = _basis(q, kn), _basis(q, kn, 3)
    # J = mean (B0 c)^2 + lambda D^6 mean (B3 c)^2, c = c_fixed + E x
    blocks = [B0, math.sqrt(jerk_weight) * D ** 3 * B3]
    if acc_weight > 0:                                  # + acc_weight D^4 mean |d''|^2 (a gentler horizontal push)
        blocks.append(math.sqrt(acc_weight) * D ** 2 * _basis(q, kn, 2))
    A = np.vstack(blocks) / math.sqrt(samples)
    r0 = A @ c_fixed
    Af = A[:, free]
    H = Af.T @ Af
    f = Af.T @ r0
    x0 = np.linalg.lstsq(Af, -r0, rcond=None)[0]
    B2 = _basis(tau, kn, 2)
    cons = []
    ok = True
    rows = []
    Bd = _basis(tau, kn)
    cons_list = [(B2, lower, upper), (Bd, d_lower, d_upper)]
    if lin_rows is not None:
        cons_list.append((np.asarray(lin_rows[0], dtype=float) @ Bd, lin_rows[1], lin_rows[2]))
    for M_, lo, hi in cons_list:
        g0 = M_ @ c_fixed
        if lo is not None:
            rows.append((M_[:, free], g0 - np.asarray(lo, dtype=float)))
        if hi is not None:
            rows.append((-M_[:, free], np.asarray(hi, dtype=float) - g0))
    if rows:
        Gm = np.vstack([r[0] for r in rows])
        hv = np.concatenate([r[1] for r in rows])
        keep = np.isfinite(hv)
        Gm, hv = Gm[keep], hv[keep]
    if rows and hv.size:
        x = _lsi(Af, -r0, Gm, -hv)
        if x is None:                                   # no map meets the bounds: report the least-squares one
            ok, x = False, x0
    else:
        x = x0
    c = c_fixed.copy()
    c[free] = x
    d, a = Bd @ c, B2 @ c
    checks = [(a, lower, upper), (d, d_lower, d_upper)]
    if lin_rows is not None:
        checks.append((np.asarray(lin_rows[0], dtype=float) @ d, lin_rows[1], lin_rows[2]))
    for v, lo, hi in checks:   # judged in m/s^2, m and m/s, not scaled rows
        if lo is not None:
            lo = np.asarray(lo, dtype=float)
            ok &= bool(np.all(v >= lo - 1e-6 * (1.0 + np.abs(np.where(np.isfinite(lo), lo, 0.0)))))
        if hi is not None:
            hi = np.asarray(hi, dtype=float)
            ok &= bool(np.all(v <= hi + 1e-6 * (1.0 + np.abs(np.where(np.isfinite(hi), hi, 0.0)))))
    return d, a, ok


def _needed_force(tau, slope, D, a_own, g, min_force, max_force, d_lo=None, d_hi=None, n_free: int = 0) -> float:
    """The smallest upper force bound (body weights) for which a map exists (bisection), or inf; the
    first ``n_free`` samples carry no force bound."""
    free = np.arange(tau.size) < n_free
    lo_acc = np.where(free, -np.inf, g * (min_force - 1.0) - a_own)

    def hi_acc(f):
        return np.where(free, np.inf, g * (f - 1.0) - a_own)
    lo, hi = max_force, 4.0 * max_force
    kw = dict(d_lower=d_lo, d_upper=d_hi)
    if not stance_displacement(tau, slope, D, lo_acc, hi_acc(hi), **kw)[2]:
        return float("inf")
    for _ in range(10):
        mid = 0.5 * (lo + hi)
        if stance_displacement(tau, slope, D, lo_acc, hi_acc(mid), **kw)[2]:
            hi = mid
        else:
            lo = mid
    return hi


def _solve_map(tau, sign, dv, D, lo_acc, hi_acc, d_lo, d_hi, jerk_weight, frames, fps, event, a_own, g, min_force,
               max_force, fine, explain: bool = True, jump=None,
               free_slope: bool = False):
    """The three components of the displacement map (vertical: force bounds on the grid ``fine``,
    leg-room bounds on the frames ``tau``; ``jump``: linear bounds on the frames' displacement, see
    :func:`repair_stance`). Returns ``(disp (n, 3),
    acc (len(fine), 3))``."""
    disp = np.zeros((frames.size, 3))
    acc = np.zeros((fine.size, 3))
    both = np.concatenate([tau, fine])
    n = tau.size
    inf = np.full(fine.size, np.inf)
    for c in range(3):
        m_lo, m_hi = np.full(n, -np.inf), np.full(n, np.inf)
        rows = None
        if jump is not None:
            Mj = np.asarray(jump[0], dtype=float)
            rows = (np.c_[Mj, np.zeros((Mj.shape[0], fine.size))], np.asarray(jump[1], dtype=float)[:, c],
                    np.asarray(jump[2], dtype=float)[:, c])
        if abs(dv[c]) < 1e-9 and rows is None:
            continue
        slope = None if free_slope else sign * dv[c]
        if c == 1:
            d, a, ok = stance_displacement(both, slope, D, np.r_[m_lo, lo_acc],
                                           np.r_[m_hi, hi_acc], jerk_weight=jerk_weight,
                                           d_lower=np.r_[-d_lo, -inf], d_upper=np.r_[d_hi, inf], lin_rows=rows)
        elif rows is not None:
            d, a, ok = stance_displacement(both, slope, D, np.r_[m_lo, -inf], np.r_[m_hi, inf],
                                           jerk_weight=jerk_weight, lin_rows=rows,
                                           acc_weight=HORIZONTAL_ACC_WEIGHT)
        else:
            d, a, ok = stance_displacement(both, slope, D, jerk_weight=jerk_weight)
        if not ok and not explain:
            raise StanceRepairError(f"the {event} cannot be reshaped within the force bounds and the legs' room")
        if not ok:
            need = _needed_force(both, sign * dv[1], D, np.r_[np.zeros(n), a_own], g, min_force, max_force,
                                 np.r_[-d_lo, -inf], np.r_[d_hi, inf], n)
            a0, a1 = int(frames.min()), int(frames.max())
            need_text = ("no vertical ground force profile does it" if not np.isfinite(need) else
                         f"it would need a vertical ground force of {need:.1f} body weights")
            raise StanceRepairError(
                f"the {event} cannot be repaired: adding {dv[1]:+.2f} m/s vertically over output frames {a0}-{a1} "
                f"({frames.size / fps:.3f} s of stance) with the vertical ground force between {min_force:g} and "
                f"{max_force:.3g} body weights and the legs' room (the crouch may deepen by at most "
                f"{100 * float(np.max(d_lo)):.0f} cm before a knee folds tighter than anywhere else in the clip) is "
                f"impossible ({need_text}: a mean extra acceleration of "
                f"{abs(dv[1]) * fps / frames.size:.1f} m/s^2, and the crouch must come back up); use k nearer k* "
                f"(--k-ratio closer to 1) or --takeoff as-is")
        disp[:, c], acc[:, c] = d[:n], a[n:]
    return disp, acc


def stance_window(event: str, event_frame: float, stance, fps: float, max_window: float = MAX_WINDOW_S):
    """``(frames, tau, sign)``: the output frames of the stance ``[start, stop)`` next to the event at
    the fractional output frame ``event_frame`` that a displacement map may use (at most
    ``max_window`` s), their time from the event (s, positive into the stance) and the sign of
    ``dd/dtau`` for a velocity added at the event (``-1`` before a take-off, ``+1`` after a landing)."""
    s0, s1 = int(stance[0]), int(stance[1])
    if event == "take-off":
        frames = np.arange(max(s0, int(math.ceil(event_frame - max_window * fps))), min(s1, int(math.ceil(event_frame))))
        return frames, (event_frame - frames) / fps, -1.0
    frames = np.arange(max(s0, int(math.floor(event_frame)) + 1), min(s1, int(math.floor(event_frame + max_window * fps)) + 1))
    return frames, (frames - event_frame) / fps, 1.0


def repair_stance(motion: Motion, com_fn, event: str, event_frame: float, dv, stance: tuple[int, int], *,
                  g: float, max_force: float = MAX_FORCE, min_force: float = MIN_FORCE,
                  max_window: float = MAX_WINDOW_S, jerk_weight: float = JERK_WEIGHT, body=None,
                  measure_zmp: bool = True, explain: bool = True, jump=None,
                  free_slope: bool = False) -> tuple[Motion, StanceRepair]:
    """Add the velocity ``dv`` ``(3,)`` m/s to the stance next to an event, smoothly (module docstring).

    Parameters
    ----------
    motion: the motion to repair (not changed; a new one is returned).
    com_fn: ``com_fn(root_positions, rotations) -> (T, 3)`` whole-body COM (e.g. a
        :class:`~mocomp.flips.reposition.ComEvaluator`).
    event: ``"take-off"`` (the stance is before ``event_frame``) or ``"landing"`` (after it).
    event_frame: the event's output time in frames (fractional).
    dv: flight velocity minus the stance's at the event.
    stance: ``(start, stop)`` half-open output frames of the stance next to the event (the map
        uses at most ``max_window`` seconds of it, next to the event).
    g: m/s^2, the gravity of the force bounds; max_force, min_force: body weights.
    body: the :class:`~mocomp.body.BodyModel` for the ZMP measurement (``measure_zmp``).

    jump: ``(M, lo, hi)``: linear bounds ``lo <= M d <= hi`` (``lo``, ``hi`` of shape ``(m, 3)``, per
        component) on the displacement of the window frames (``M (m, n)``; :func:`smooth_stance` bounds
        the audit's velocity jumps with them); free_slope: leave ``d'`` at the event free.
    explain: on failure, work out the force a map would need for the message (a bisection; off in
        :func:`smooth_stance`, which tries several bounds).

    Raises :class:`StanceRepairError` when no map within the force bounds exists in the stance or
    the legs cannot keep the feet planted.
    """
    with _one_blas_thread():
        return _repair_stance(motion, com_fn, event, event_frame, dv, stance, g=g, max_force=max_force,
                              min_force=min_force, max_window=max_window, jerk_weight=jerk_weight, body=body,
                              measure_zmp=measure_zmp, explain=explain,
                              jump=jump, free_slope=free_slope)


_BLAS = None


def _one_blas_thread():
    """A context with the BLAS on one thread: the map's least-squares problems are small (a few hundred
    rows, ~35 unknowns), and a threaded BLAS on a loaded machine made each solve ~20x slower (145 ms
    against 7.6 ms per :func:`stance_displacement` at load 7 on 2 cores)."""
    global _BLAS
    try:
        if _BLAS is None:
            from threadpoolctl import ThreadpoolController

            _BLAS = ThreadpoolController()
        return _BLAS.limit(limits=1, user_api="blas")
    except Exception:  # noqa: BLE001 - no control over the BLAS: run as is
        import contextlib

        return contextlib.nullcontext()


def _repair_stance(motion: Motion, com_fn, event: str, event_frame: float, dv, stance: tuple[int, int], *,
                   g: float, max_force: float, min_force: float, max_window: float, jerk_weight: float, body,
                   measure_zmp: bool, explain: bool, jump, free_slope: bool):
    if event not in ("take-off", "landing"):
        raise ValueError(f"event must be 'take-off' or 'landing', got {event!r}")
    if not (np.isfinite(max_force) and np.isfinite(min_force) and 0.0 <= min_force < 1.0 < max_force):
        raise ValueError(f"need 0 <= min_force < 1 < max_force (body weights), got {min_force!r}, {max_force!r}")
    fps = float(motion.fps)
    dv = np.asarray(dv, dtype=float).reshape(3)
    frames, tau, sign = stance_window(event, event_frame, stance, fps, max_window)
    if frames.size < 4:
        raise StanceRepairError(
            f"the {event} stance has {frames.size} output frame(s) next to the event (frame {event_frame:.1f}): too short "
            f"to add {np.linalg.norm(dv):.2f} m/s; use k = k* (--k-ratio 1) or --takeoff as-is")
    D = float(tau.max()) + 1.0 / fps                    # the map reaches zero one frame beyond the window
    root = np.asarray(motion.root_positions, dtype=float)
    rot = np.asarray(motion.rotations, dtype=float)
    from ..core.kinematics import gaussian_smooth

    com = com_fn(root, rot)
    ay = np.gradient(np.gradient(gaussian_smooth(com[:, 1], ACC_SMOOTH_S * fps), 1.0 / fps), 1.0 / fps)
    a_own = ay[frames]
    lo_acc = g * (min_force - 1.0) - a_own
    max_force = max(float(max_force), float(np.max(1.0 + a_own / g)))
    hi_acc = g * (max_force - 1.0) - a_own
    down, up = _leg_room(motion, frames, event)
    # the force bounds hold on a grid twice as fine as the frames (between frames too)
    order = np.argsort(tau)
    fine = np.linspace(0.0, D, 2 * frames.size + 1)[1:]
    a_fine = np.interp(fine, tau[order], a_own[order])
    hi_fine = g * (max_force - 1.0) - a_fine
    gain = 1.0
    # the least vertical force: min_force, and only where the stance cannot do it so, MIN_FORCE_FALLBACK
    floors = (float(min_force),) + ((MIN_FORCE_FALLBACK,) if min_force > MIN_FORCE_FALLBACK else ())
    for attempt in range(3):
        for i, floor in enumerate(floors):
            lo_fine = g * (floor - 1.0) - a_fine
            try:
                disp, acc = _solve_map(tau, sign, dv, D, lo_fine, hi_fine, down / gain, up / gain, jerk_weight,
                                       frames, fps, event, a_fine, g, floor, max_force, fine, explain, jump,
                                       free_slope)
                break
            except StanceRepairError:
                if i == len(floors) - 1:
                    raise
        new_root, new_rot, miss, gain_seen = _apply_with_planted_feet(motion, com_fn, frames, disp, event,
                                                                      raise_errors=attempt == 2)
        if gain_seen is None:
            break
        gain = max(gain, gain_seen) * 1.05

    source = motion.source
    new = motion.replace(root_positions=new_root, rotations=new_rot, source=source)
    F_new = (g + a_fine + acc[:, 1]) / g                 # planned: the COM follows the map (fixed point above)
    F_old = (g + a_own) / g
    zb = za = float("nan")
    if measure_zmp:
        zb, za = _zmp_window(motion, new, body, frames)
    rep = StanceRepair(event=event, event_time=float(event_frame / fps), frames=(int(frames.min()), int(frames.max()) + 1),
                       dv=dv, window=float(D), dip=float(min(disp[:, 1].min(), 0.0)), rise=float(max(disp[:, 1].max(), 0.0)),
                       horizontal=float(np.max(np.linalg.norm(disp[:, [0, 2]], axis=1))), peak_force=float(F_new.max()),
                       min_force=float(F_new.min()), peak_force_before=float(F_old.max()),
                       peak_extra_acceleration=float(np.max(np.linalg.norm(acc, axis=1))), ik_miss=float(miss),
                       zmp_outside_before=zb, zmp_outside_after=za)
    return new, rep


#: m/s: the margins over the input's own event jump :func:`smooth_stance` tries in turn (the audit calls
#: an output worse than its input beyond a quarter of its 0.5 m/s threshold, 0.125)
SMOOTH_MARGINS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.35)
#: weight of the horizontal displacement's acceleration in the smoothing map's objective (``acc_weight D^4
#: mean |d''|^2`` beside ``mean |d|^2``): the horizontal push moves the ZMP of eq. 4 (touch-up paper). At 0
#: the synthetic back flip x2's ground frames with the ZMP outside the support polygon rose from 22 % to
#: 39 % (input 25 %), the side flip's from 18 % to 52 % (input 22 %); at 0.1 they are 23 % and 32 % with
#: the same velocity jumps (1: 23 % and 31 %, but the DeepMimic back flip x2 no longer fits its target)
HORIZONTAL_ACC_WEIGHT = 0.1
#: a velocity-jump row whose sensitivity to the stance's displacement is below this fraction of the
#: most sensitive row's is only kept from growing by :func:`smooth_stance` (its fits lie in the flight)
WEAK_ROW = 0.25


def _event_jump(com: np.ndarray, fps: float, event_frame: float) -> float:
    """The audit's largest COM velocity jump (m/s, :func:`mocomp.audit.com.velocity_jumps`) within its
    event window of the fractional output frame ``event_frame``."""
    from ..audit.com import velocity_jumps
    from ..audit.thresholds import AuditThresholds

    th = AuditThresholds()
    w = th.jump_frames(fps)
    ew = max(1, int(math.ceil(th.event_window * fps - 1e-9)))
    f = int(round(event_frame))
    lo, hi = max(0, f - ew - w), min(com.shape[0], f + ew + w + 1)
    if hi - lo < 1:
        return float("nan")
    j, _, _ = velocity_jumps(com[max(0, lo - w):min(com.shape[0], hi + w)], fps, w)
    m = np.linalg.norm(j, axis=1)[lo - max(0, lo - w):hi - max(0, lo - w)]
    m = m[np.isfinite(m)]
    return float(m.max()) if m.size else float("nan")


def _jump_rows(com: np.ndarray, fps: float, event_frame: float, frames: np.ndarray):
    """``(M, J0, at)``: the audit's COM velocity jumps (:func:`mocomp.audit.com.velocity_jumps`: right minus
    left one-sided quadratic-fit velocity) at every frame whose fits reach the event window of the
    fractional frame ``event_frame`` and a frame of ``frames`` (``at (m,)``, the frames), as ``J0 (m, 3)``
    (now) plus ``M (m, n) @ d`` for a displacement ``d (n, 3)`` of ``frames``."""
    from ..audit.com import endpoint_derivative_weights
    from ..audit.thresholds import AuditThresholds

    th = AuditThresholds()
    w = th.jump_frames(fps)
    ew = max(1, int(math.ceil(th.event_window * fps - 1e-9)))
    T = com.shape[0]
    wr, wl = endpoint_derivative_weights(w, 1.0 / fps)
    lo = max(w, int(math.floor(event_frame)) - ew - 2 * w)
    hi = min(T - w - 1, int(math.ceil(event_frame)) + ew + 2 * w)
    pos = {int(f): k for k, f in enumerate(frames)}
    M, J0, at = [], [], []
    for i in range(lo, hi + 1):
        row = np.zeros(frames.size)
        for j in range(w + 1):
            if i + j in pos:
                row[pos[i + j]] += wr[j]
            if i - w + j in pos:
                row[pos[i - w + j]] -= wl[j]
        if not np.any(row):
            continue
        M.append(row)
        J0.append(wr @ com[i:i + w + 1] - wl @ com[i - w:i + 1])
        at.append(i)
    if not M:
        return np.zeros((0, frames.size)), np.zeros((0, 3)), np.zeros(0, int)
    return np.asarray(M), np.asarray(J0), np.asarray(at)


def audit_com(motion: Motion):
    """``com_fn(root_positions, rotations) -> (T, 3)``: the whole-body COM with the body model
    :mod:`mocomp.audit` measures ``motion`` (and the outputs made from it) with
    (:func:`mocomp.audit.run.default_body`: a DeepMimic clip's own character, else de Leva's table),
    so :func:`smooth_stance` smooths the COM the audit measures, not a method's estimated one (the
    DeepMimic side flip x2: the landing smoothed to 0.29 m/s with the flip's estimated masses read
    0.58 with the character's)."""
    from ..audit.run import default_body
    from .reposition import ComEvaluator

    return ComEvaluator(default_body(motion))


def _region_jump(com: np.ndarray, fps: float, frames: np.ndarray) -> float:
    """The audit's largest COM velocity jump (m/s) at the frames whose one-sided fits reach ``frames``."""
    from ..audit.com import velocity_jumps
    from ..audit.thresholds import AuditThresholds

    w = AuditThresholds().jump_frames(fps)
    lo, hi = max(0, int(frames.min()) - 2 * w), min(com.shape[0], int(frames.max()) + 2 * w + 1)
    j, _, _ = velocity_jumps(com[lo:hi], fps, w)
    m = np.linalg.norm(j, axis=1)
    m = m[np.isfinite(m)]
    return float(m.max()) if m.size else 0.0


def smooth_stance(motion: Motion, com_fn, event: str, event_frame: float, stance, *, g: float, target_jump: float,
                  margins=SMOOTH_MARGINS, max_force: float = MAX_FORCE, min_force: float = MIN_FORCE,
                  max_window: float = MAX_WINDOW_S, body=None) -> tuple[Motion, dict]:
    """A longer push and a softer landing where a retiming made them harder (issue #13, beyond the paper).

    A flight retimed by ``k`` (App. B) leaves and arrives ``k`` times faster, and the stance next to
    it is played at rate ``k`` there (:class:`~mocomp.flips.retime.TimeWarp`), so the push's COM
    acceleration is ``k^2`` and its jerk ``k^3`` the captured ones, and the landing's impact ``k``
    times harder: measured from the frames, the COM velocity no longer joins the flight's smoothly
    (the audit's one-sided velocity fits, :mod:`mocomp.audit.com`: synthetic back flip at ``k* =
    1.40``, 0.22 -> 0.47 m/s at take-off, 0.66 -> 0.83 at landing). Here the stance next to the event
    gets a root displacement map ``d`` (:func:`repair_stance`: the jerk-regularised least-displacement
    map, ``d(event) = 0`` so the flight is met where it starts, the vertical ground force between
    ``min_force`` and ``max_force`` body weights, the feet held by leg IK within the knee limits)
    whose COM makes every velocity jump the audit measures within its event window at most
    ``target_jump`` (the input's own at that event) plus a margin, each component within its share
    (:func:`_jump_rows`: the jumps are linear in ``d``): the push starts earlier and lasts longer
    instead of ending harder, the landing gives way over more frames.

    The margins ``margins`` (m/s) are tried in turn until a map exists (then once more halfway back to
    the last one that did not fit); the map is kept only if it lowers the largest jump measured on
    the COM of the frames in the event window (:func:`_event_jump`). Returns ``(motion, info)``: ``info`` has ``event``, ``jump_before``,
    ``jump_after`` (m/s), ``target`` (m/s), ``margin`` (``None``: unchanged), ``repair``
    (:meth:`StanceRepair.to_dict` or ``None``) and ``error``.
    """
    fps = float(motion.fps)
    frames, tau, _ = stance_window(event, event_frame, stance, fps, max_window)
    info = {"event": event, "jump_before": float("nan"), "jump_after": float("nan"), "target": float(target_jump),
            "margin": None, "repair": None, "error": None}
    if frames.size < 4 or not np.isfinite(target_jump):
        info["error"] = f"the {event} stance has only {frames.size} frame(s) next to the event"
        return motion, info
    root = np.asarray(motion.root_positions, dtype=float)
    rot = np.asarray(motion.rotations, dtype=float)
    com = com_fn(root, rot)
    before = _event_jump(com, fps, event_frame)
    info["jump_before"] = info["jump_after"] = before
    if not np.isfinite(before) or before <= target_jump:
        return motion, info
    M, J0, _ = _jump_rows(com, fps, event_frame, frames)
    if not M.shape[0]:
        return motion, info
    share = np.sqrt(np.sum(J0 * J0, axis=0) / max(float(np.sum(J0 * J0)), 1e-12))
    share = np.maximum(share, 0.1)
    share /= np.linalg.norm(share)
    # each component gets at least 0.35 of the bound: a component the current jumps barely have can
    # still carry the flight side's own (the norm may then exceed the bound a little; the result is
    # kept only where the measured largest jump falls)
    share = np.maximum(share, 0.35)
    region = _region_jump(com, fps, frames)
    # rows the stance barely reaches (their fits lie mostly in the flight, which is not changed) may not
    # grow, but are not held to the target: a jump on the flight's side is out of the stance's reach
    sens = np.abs(M).sum(axis=1)
    weak = sens < WEAK_ROW * float(sens.max())

    def attempt(margin, min_force, split=True):
        B = float(target_jump) + float(margin)
        b = np.broadcast_to(B * share if split else np.full(3, B), J0.shape).copy()
        b[weak] = np.maximum(b[weak], np.abs(J0[weak]))
        try:
            new, rep = repair_stance(motion, com_fn, event, float(event_frame), np.zeros(3), stance, g=g,
                                     max_force=max_force, min_force=min_force, max_window=max_window, body=body,
                                     measure_zmp=False, explain=False, jump=(M, -b - J0, b - J0), free_slope=True)
        except StanceRepairError as e:
            info["error"] = info["error"] or str(e)
            return None
        c_new = com_fn(np.asarray(new.root_positions), np.asarray(new.rotations))
        after = _event_jump(c_new, fps, event_frame)
        if not (np.isfinite(after) and after < before - 1e-3):
            return None
        # nor may the changed frames' other jumps (beyond the event window) grow past the larger of
        # what they were and the event's new jump
        if _region_jump(c_new, fps, frames) > max(region, after) + 0.02:
            return None
        return after, new, rep, float(margin)

    # the least ground force: min_force (then the repair's own fallback, 0.1 body weights), and only where
    # no map exists so, none: the last frames before a take-off the method counts as ground may already
    # be airborne (the DeepMimic side flip's feet leave 3 frames before its detected take-off)
    for floor in (min_force, 0.0) if min_force > 0.0 else (min_force,):
        failed = None
        for margin in margins:
            got = attempt(margin, floor)
            if got is None:
                failed = margin
                continue
            if failed is not None:          # one bisection step between the last margin that did not fit and this
                mid = attempt(0.5 * (failed + margin), floor)
                if mid is not None and mid[0] < got[0]:
                    got = mid
            after, new, rep, m = got
            info.update(jump_after=after, margin=m, repair=rep.to_dict(), min_force=float(floor))
            return new, info
    # last: every component bounded alike, just below the largest jump now (a jump mostly on the flight's
    # side in a direction the current jumps barely have)
    got = attempt(before - 0.05 - float(target_jump), 0.0, split=False)
    if got is not None:
        after, new, rep, m = got
        info.update(jump_after=after, margin=m, repair=rep.to_dict(), min_force=0.0)
        return new, info
    return motion, info


#: rad: how much tighter than the performer's own tightest knee fold in the clip a repair may fold a
#: knee (the tightest fold is often the landing's own deepest crouch, which a harder arrival must
#: deepen: the DeepMimic back flip with straight legs needs 4.4 cm more there, refused at 0 deg)
KNEE_MARGIN = np.radians(10.0)
#: rad: the interior knee angle no repair folds past (deep squat ~ 40 deg)
KNEE_MIN = np.radians(40.0)


def _knee_limit(P: np.ndarray, chains) -> float:
    """The tightest interior knee angle a repair may reach: the clip's own tightest fold less
    :data:`KNEE_MARGIN`, never below :data:`KNEE_MIN` (nor above the clip's own)."""
    own = float(np.min(_knee_angles(P, chains)))
    return min(own, max(own - KNEE_MARGIN, KNEE_MIN))


def _knee_angles(P: np.ndarray, chains) -> np.ndarray:
    """``(T, C)`` interior knee angles (rad; pi = straight) of each leg chain."""
    out = []
    for h, k, a in chains:
        u, w = P[:, h] - P[:, k], P[:, a] - P[:, k]
        out.append(np.arctan2(np.linalg.norm(np.cross(u, w), axis=-1), np.sum(u * w, axis=-1)))
    return np.stack(out, axis=1)


def _leg_room(motion: Motion, frames: np.ndarray, event: str = "take-off") -> tuple[np.ndarray, np.ndarray]:
    """``(down, up)`` m per frame: how far the hips may sink (before a knee folds tighter than the
    performer's tightest fold anywhere in the clip) or rise (before a leg is straight) with the
    ankles where they are, the smaller over the legs (``inf`` without leg chains, and for a leg on
    the frames it is still in the air, :func:`_foot_down`)."""
    from ..ops.ik import leg_chains

    chains = leg_chains(motion.skeleton)
    n = frames.size
    if not chains:
        return np.full(n, np.inf), np.full(n, np.inf)
    P_all, _ = motion.fk()
    P_all = np.asarray(P_all)
    own = _knee_limit(P_all, chains)
    P = P_all[frames]
    down, up = np.full(n, np.inf), np.full(n, np.inf)
    sk = motion.skeleton
    for h, k, a in chains:
        # a leg whose own foot is still in the air (:func:`_foot_down`: before it first comes down at a
        # landing, after it left at a take-off) bounds no reach: the root may sink no lower than that
        # foot's height above its planted level. The DeepMimic side flip with straight legs lands on one
        # foot while the other, hip-high, still swings down: its zero reach refused every landing map
        # (smooth_stance 1.12 -> 0.52 m/s, input 0.30; now 0.29). Where the other foot is down the
        # airborne leg is still held by the IK (:func:`_apply_with_planted_feet`), which checks the
        # knee limit and the reach of what it does
        air = ~_foot_down(sk, P, a, event)
        below = [a] + [j for j in range(len(sk.parents)) if _descends(sk.parents, j, a)]
        hf = P[:, below, 1].min(axis=1)
        clear = hf - hf.min()
        l1 = np.linalg.norm(P[:, k] - P[:, h], axis=1)
        l2 = np.linalg.norm(P[:, a] - P[:, k], axis=1)
        r = P[:, h] - P[:, a]
        rho2 = np.sum(r * r, axis=1)
        lo2 = l1 * l1 + l2 * l2 - 2 * l1 * l2 * np.cos(own)
        hi2 = (l1 + l2 - 1e-3) ** 2
        hy = r[:, 1]
        # |r - delta e_y|^2 = rho2 - 2 delta hy + delta^2 reaches lo2 (sinking) / hi2 (rising)
        dn = hy - np.sqrt(np.maximum(hy * hy - (rho2 - lo2), 0.0))
        upv = -hy + np.sqrt(np.maximum(hy * hy + (hi2 - rho2), 0.0))
        dn, upv = np.where(air, clear, dn), np.where(air, np.inf, upv)
        down = np.minimum(down, np.maximum(dn, 0.0))
        up = np.minimum(up, np.maximum(upv, 0.0))
    return down, up


#: m: a foot whose lowest point is more than this above its lowest over the landing window is still in
#: the air (the body arrives between two frames: the first frames after the flight's planned end can
#: show the feet above the floor)
AIRBORNE_CLEARANCE = 0.02


def _foot_down(sk, P: np.ndarray, ankle: int, event: str) -> np.ndarray:
    """``(n,)`` bool: on a landing window (frames in time order), the frames from the one on which
    the leg ending at ``ankle`` first comes within :data:`AIRBORNE_CLEARANCE` of its lowest height
    over the window (ankle and the joints below it); on a take-off window, the frames up to the
    last one on which it is still that low. Frames before the first foot comes down (after the
    last one leaves) are airborne: the legs move rigidly with the root there (bending them in the
    air would change L, which only the ground may do; the audit saw |L| drop 8 % on such a frame of
    the front flip at 0.7 k* repaired), and they bound no displacement. The DeepMimic side flip's
    feet leave 3 frames (120 Hz) before the take-off its flight is planned from: held there, the
    leg IK's reach refused the map that makes the COM meet the flight (0.41 m/s jump, input 0.25)."""
    n = P.shape[0]
    if event not in ("landing", "take-off") or n == 0:
        return np.ones(n, bool)
    below = [ankle] + [j for j in range(len(sk.parents)) if _descends(sk.parents, j, ankle)]
    h = P[:, below, 1].min(axis=1)
    touch = np.flatnonzero(h <= h.min() + AIRBORNE_CLEARANCE)
    out = np.zeros(n, bool)
    if event == "landing":
        out[int(touch[0]):] = True
    else:
        out[:int(touch[-1]) + 1] = True
    return out


def _descends(parents, j: int, a: int) -> bool:
    p = int(parents[j])
    while p >= 0:
        if p == a:
            return True
        p = int(parents[p])
    return False


def _apply_with_planted_feet(motion: Motion, com_fn, frames: np.ndarray, disp: np.ndarray, event: str,
                             raise_errors: bool = True):
    """Root positions and rotations with the COM of ``frames`` displaced by ``disp`` and each leg's
    ankle held where it was (two-bone IK; the root corrected :data:`COM_ITERATIONS` times so the
    whole-body COM follows ``disp``). Returns ``(root, rotations, largest ankle miss, gain)``:
    ``gain`` is ``None`` when the legs did it, else the ratio of the root's sinking to the COM's (the
    leg-room bounds are divided by it for another try); with ``raise_errors`` a failure raises."""
    from ..ops.ik import leg_chains, two_bone_ik

    root = np.asarray(motion.root_positions, dtype=float)
    rot = np.asarray(motion.rotations, dtype=float)
    sk = motion.skeleton
    chains = leg_chains(sk)
    new_root, new_rot = root.copy(), rot.copy()
    com_old = com_fn(root[frames], rot[frames])
    P_old, _ = forward_kinematics(sk.parents, sk.offsets, root[frames], rot[frames])
    down_any = np.zeros(frames.size, bool)
    for ch in chains:
        down_any |= _foot_down(sk, P_old, ch[2], event)
    held = {tuple(ch): down_any for ch in chains}
    shift = disp.copy()
    miss = 0.0
    for _ in range(COM_ITERATIONS if chains else 1):
        new_root[frames] = root[frames] + shift
        block = rot[frames]
        miss = 0.0
        if chains:
            P_new, G_new = forward_kinematics(sk.parents, sk.offsets, new_root[frames], block)
            for chain in chains:
                on = held[tuple(chain)]
                if not on.any():
                    continue
                sub, m = two_bone_ik(P_new[on], G_new[on], block[on], sk.parents, chain, P_old[on, chain[2]])
                block = block.copy()
                block[on] = sub
                miss = max(miss, float(np.max(m)))
        new_rot[frames] = block
        shift += disp - (com_fn(new_root[frames], block) - com_old)
    if chains:
        P_all, _ = motion.fk()
        own = _knee_limit(np.asarray(P_all), chains)
        P_chk, _ = forward_kinematics(sk.parents, sk.offsets, new_root[frames], new_rot[frames])
        err = np.max([np.where(held[tuple(ch)], np.linalg.norm(P_chk[:, ch[2]] - P_old[:, ch[2]], axis=1), 0.0)
                      for ch in chains], axis=0)
        knee = np.min(_knee_angles(P_chk, chains), axis=1)
        bad = (err > IK_TOLERANCE) | (knee < own - 1e-6)
        if bad.any() and not raise_errors:
            sink = -(new_root[frames, 1] - root[frames, 1])
            want = -disp[:, 1]
            ok = want > 1e-3
            return new_root, new_rot, miss, float(np.max(sink[ok] / want[ok])) if ok.any() else 2.0
        if bad.any():
            fb = frames[bad]
            raise StanceRepairError(
                f"the {event} cannot be repaired with the feet planted: the crouch {100 * -disp[:, 1].min():.1f} cm "
                f"deeper folds a knee to {np.degrees(knee.min()):.0f} deg (the limit: the performer's tightest fold in "
                f"the clip less {np.degrees(KNEE_MARGIN):.0f} deg, {np.degrees(own):.0f} deg) or leaves an ankle up to {100 * err.max():.1f} cm from its planted "
                f"position, on output frames {int(fb.min())}-{int(fb.max())}; use k nearer k* (--k-ratio closer to 1) "
                f"or --takeoff as-is")
    return new_root, new_rot, miss, None


def _zmp_window(before: Motion, after: Motion, body, frames: np.ndarray) -> tuple[float, float]:
    """Largest ZMP distance outside the support polygon over ``frames`` of both motions, measured by
    :func:`mocomp.audit.audit` (with ``body``)."""
    from ..audit import audit

    out = []
    for m in (before, after):
        d = np.asarray(audit(m, body).zmp.distance)[frames]
        d = d[np.isfinite(d)]
        out.append(float(d.max()) if d.size else float("nan"))
    return out[0], out[1]


def smoothed_stance_note(info: dict, option: str) -> str | None:
    """The report line of one :func:`smooth_stance` result (``None`` when it changed nothing);
    ``option`` names how the user turns it on or off (e.g. "takeoff='smooth', --takeoff smooth")."""
    r = info.get("repair")
    if r is None:
        return None
    moved = (f"root moved up to {100 * r['horizontal']:.1f} cm horizontally, " if "horizontal" in r else "")
    return (f"{info['event']} stance smoothed ({option}; beyond the paper): largest COM velocity jump near it "
            f"{info['jump_before']:.2f} -> {info['jump_after']:.2f} m/s (the input's own {info['target']:.2f}) by a "
            f"longer push / softer give over output frames {r['frames'][0]}-{r['frames'][1] - 1}: crouch up to "
            f"{100 * -r['dip']:.1f} cm deeper, {moved}vertical ground force {r['min_force']:.2f}-"
            f"{r['peak_force']:.2f} body weights, feet held within {1000 * r['ik_miss']:.1f} mm")
