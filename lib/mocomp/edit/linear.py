"""Step 3 of the restoration: linear momentum (dissertation section 5.5.3).

"The non-uniform retiming described in the previous section can cause changes
in the jump duration. To ensure proper momentum build-up and release, we retime
the motion uniformly, similarly as in Section 5.4.3. Next, we reposition the
character's center of mass (as in Section 5.4.4) so that it follows a correct
trajectory under gravity."

:func:`correct_linear` does exactly that with the Acrobatics-I machinery:
:func:`mocomp.flips.retime.plan_retime` chooses ``k`` (``k*`` of App. B eq. B.5
for the new flight duration, default ``0.7 k*`` as section 5.4.3; ``k`` and
``k*`` explained there, including how a ``k`` different from ``k*`` is
resolved), the whole motion is played ``k`` times faster, and every flight
frame is translated so its COM lies on the parabola of eq. 5.15/5.17
(:func:`mocomp.flips.reposition.flight_trajectory`, anchored at the take-off
COM); frames after the landing get eq. 5.16's offset. Translation does not
change angular momentum about the COM (section 5.4.1), so steps 1-2 survive;
uniform retiming multiplies it by ``k`` everywhere (eq. 5.8), take-off included.

**Take-off height and the platform** (App. B, Fig. 5.8 and 5.10). ``takeoff_height``
raises everything before the flight by that many metres (a dive from a
platform); the landing stays where it was, so ``dy`` (landing minus take-off
level) falls by the same amount and ``k*`` follows App. B. With a raised
take-off the body must not pass through the platform on the way down (Fig.
5.10: "guarantees that the character's body does not touch the platform during
the fall phase"): the platform is the half-space behind the take-off edge (the
most forward point of the body at take-off along the horizontal travel
direction) below the take-off level. If some joint would dip below the
platform top while still over it, the horizontal take-off speed along the
travel direction is raised by the smallest amount that clears it (bisection),
and that change is reported.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from ..dynamics.constants import GRAVITY_CHOICES  # noqa: F401  (re-exported)
from ..dynamics.constants import resolve_gravity as _resolve_gravity
from ..errors import PhysicsError
from ..flips.mass import FlightFit
from ..flips.reposition import ComEvaluator, FlightTrajectory, flight_trajectory
from ..flips.retime import EASE_S, RetimePlan, TimeWarp, ease_limits, plan_retime

__all__ = ["LinearResult", "PlatformCheck", "correct_linear", "resolve_gravity", "GRAVITY_CHOICES",
           "takeoff_velocity_of"]



def resolve_gravity(gravity, fit: FlightFit | None = None) -> tuple[float, str]:
    """``(g m/s^2, source)`` for the ``gravity`` option of the generated flights (issue #13 section 3):
    :func:`mocomp.dynamics.constants.resolve_gravity` with the input flight's fitted gravity
    (``fit.gravity``) as ``"clip"``; ``None`` is ``"standard"``. The fitted value stays in the
    reports as a diagnostic."""
    return _resolve_gravity("standard" if gravity is None else gravity, float("nan") if fit is None else float(fit.gravity))


@dataclass(frozen=True)
class PlatformCheck:
    """Clearance of the body over the take-off platform during the flight.

    Attributes
    ----------
    top: m, platform top (the take-off support level after the height change).
    edge: m, position of the platform edge along ``direction`` (horizontal unit vector).
    direction: ``(3,)`` horizontal travel direction.
    clearance: m, smallest height of any joint above the platform top while over it
        (``inf`` when no joint is over the platform during the flight).
    extra_speed: m/s, horizontal take-off speed added along ``direction`` to clear it.
    """

    top: float
    edge: float
    direction: np.ndarray
    clearance: float
    extra_speed: float


@dataclass(frozen=True, eq=False)
class LinearResult:
    """Step 3 (section 5.5.3) output and evidence.

    Attributes
    ----------
    motion: uniformly retimed and repositioned motion.
    flight: ``(start, stop)`` flight frames of the output.
    source_times: ``(T_out,)`` s, the input time each output frame shows (the flight at ``k`` times
        its own rate, the stances eased back to 1: :class:`~mocomp.flips.retime.TimeWarp`).
    plan: the :class:`~mocomp.flips.retime.RetimePlan` (``k``, ``k*``, velocity jumps).
    trajectory: the flight's COM parabola (:class:`~mocomp.flips.reposition.FlightTrajectory`,
        ``t`` in seconds from the take-off instant ``takeoff_time``).
    takeoff_time: s, take-off instant in the output (in general between two frames).
    com_residual: m, max distance of the output flight frames' COM from the parabola.
    takeoff_height: m, height change applied to the take-off (App. B).
    platform: :class:`PlatformCheck` or ``None``.
    seconds: wall time.
    gravity: m/s^2, the gravity the new flight falls with; gravity_source: ``"standard"``,
        ``"clip"`` or ``"given"`` (:func:`resolve_gravity`); gravity_fitted: m/s^2, the input
        flight's fitted gravity (a diagnostic of its frame rate and units).
    takeoff_velocity: ``(3,)`` m/s, the COM velocity the flight leaves with before the retiming
        (``k`` times it after); takeoff_velocity_source: ``"frames"`` (the captured push-off's) or
        ``"fit"`` (the ballistic fit's).
    """

    motion: Motion
    flight: tuple[int, int]
    source_times: np.ndarray
    plan: RetimePlan
    trajectory: FlightTrajectory
    takeoff_time: float
    com_residual: float
    takeoff_height: float
    platform: PlatformCheck | None
    seconds: float
    gravity: float = 9.81
    gravity_source: str = "standard"
    gravity_fitted: float = float("nan")
    takeoff_velocity: tuple = (float("nan"),) * 3
    takeoff_velocity_source: str = "fit"

    @property
    def k(self) -> float:
        return self.plan.k


#: s: the ground frames up to the take-off whose COM gives the captured take-off velocity (a
#: one-sided quadratic fit, as :mod:`mocomp.audit.com` measures velocity jumps)
TAKEOFF_WINDOW_S = 0.03
#: m/s: ``takeoff_velocity="auto"`` keeps the ballistic fit's take-off velocity unless the captured
#: push-off's differs from it by more than this (any component)
TAKEOFF_TOL = 0.3


def takeoff_velocity_of(motion: Motion, start: int, fit: FlightFit, ce, mode: str = "auto") -> tuple[np.ndarray, str]:
    """``((3,) m/s, source)``: the velocity a new flight starting at frame ``start`` of ``motion``
    leaves with (before the retiming by ``k``).

    ``"fit"``: the flight's ballistic fit ``(a_x, b_y, a_z)`` (the paper's). ``"frames"``: the
    captured push-off's, the derivative at ``start`` of a least-squares quadratic through the COM
    of frames ``start - w .. start`` (``w = max(2, round(0.03 s fps))``,
    :func:`mocomp.audit.com.endpoint_derivative_weights`: the audit's left-side velocity there),
    so the flight continues the push-off. ``"auto"`` (default): the fit's, unless the push-off's
    differs from it by more than :data:`TAKEOFF_TOL`: a flight that is not ballistic (the DeepMimic
    back flip leaves the ground at 2.1 m/s vertically, its fit says 0.8: a 1.4 m/s jump). On an
    exact flight the fit is exact and the push-off's quadratic is biased by the push-off's jerk
    (~0.1 m/s on the synthetic flips), and a detector's take-off a frame or two early or late
    moves a one-sided estimate but not the fit, hence the tolerance. With fewer than ``w`` frames
    before ``start`` the fit's."""
    fitted = np.array([fit.a_x, fit.b_y, fit.a_z], dtype=float)
    if mode not in ("auto", "fit", "frames"):
        raise ValueError(f"takeoff_velocity must be 'auto', 'fit' or 'frames', got {mode!r}")
    if mode == "fit":
        return fitted, "fit"
    from ..audit.com import endpoint_derivative_weights

    w = max(2, int(round(TAKEOFF_WINDOW_S * motion.fps)))
    a = int(start)
    if a < w:
        return fitted, "fit"
    c = ce(motion.root_positions[a - w:a + 1], motion.rotations[a - w:a + 1])
    _, left = endpoint_derivative_weights(w, 1.0 / motion.fps)
    pushed = left @ c
    if mode == "frames" or np.max(np.abs(pushed - fitted)) > TAKEOFF_TOL:
        return pushed, "frames"
    return fitted, "fit"


def _neighbour_flights(motion: Motion, ce, a: int, b: int) -> tuple[float, float]:
    """``(end of the previous flight, start of the next)`` in frames of ``motion`` around its flight
    ``[a, b)`` (:func:`mocomp.flips.phases.detect_flights` on the COM), or the clip's ends."""
    from ..flips.phases import detect_flights

    lo, hi = 0.0, float(motion.n_frames - 1)
    try:
        det = detect_flights(motion, com=ce(motion.root_positions, motion.rotations))
    except Exception:  # noqa: BLE001 - a clip the detector cannot read keeps the whole-clip easing
        return lo, hi
    for f in det.flights:
        s0, s1 = int(f.start), int(f.stop)
        if s1 <= a - 1:
            lo = max(lo, float(s1))
        elif s0 >= b + 1:
            hi = min(hi, float(s0))
    return lo, hi


def _lowest_and_forward(motion: Motion, frame: int, direction: np.ndarray) -> tuple[float, float]:
    from ..core.kinematics import end_site_positions
    Pf, Gf = motion.fk(frames=slice(frame, frame + 1))           # this frame only
    P = np.concatenate([Pf[0], end_site_positions(motion.skeleton.end_sites, Pf, Gf)[0]], axis=0) \
        if motion.skeleton.end_sites else Pf[0]
    return float(P[:, 1].min()), float((P @ direction).max())


def correct_linear(body, motion: Motion, flight, fit: FlightFit, *, k: float | None = None,
                   k_ratio: float | None = None, takeoff_height: float = 0.0, platform: bool | str = "auto",
                   clearance: float = 0.0, gravity="standard",
                   com_eval: ComEvaluator | None = None, landing_lift: float = 0.0,
                   takeoff_velocity: str = "auto", ease: float = EASE_S, stances=None) -> LinearResult:
    """Uniform retiming by ``k`` and COM repositioning over the flight (section 5.5.3).

    Parameters
    ----------
    body: body model of the motion (the one the COM is computed with).
    motion: the motion after steps 1-2 (its flight ``[start, stop)`` may be longer or
        shorter than the original's; frames before ``start`` are the original's).
    flight: ``(start, stop)`` of ``motion``'s flight.
    fit: the *original* flight's ballistic fit (:func:`mocomp.flips.mass.fit_ballistic`):
        take-off velocity ``(a_x, b_y, a_z)`` and duration (its gravity only with ``gravity="clip"``).
    gravity: the new flight's gravity, ``"standard"`` (9.81 m/s^2, default), ``"clip"`` (the
        fit's) or m/s^2 (:func:`resolve_gravity`).
    k, k_ratio: retiming factor, or its ratio to ``k*`` (default 0.7, section 5.4.3).
    takeoff_height: m, raise the take-off (all frames before the flight) by this much.
    platform: enforce clearance over the take-off platform: ``"auto"`` (when
        ``takeoff_height > 0``), ``True`` or ``False``.
    clearance: m, required margin above the platform top.
    com_eval: a prepared :class:`~mocomp.flips.reposition.ComEvaluator` for ``body``.
    takeoff_velocity: the velocity the new flight leaves with (before the retiming by ``k``):
        ``"auto"`` (default), ``"fit"`` (the paper's) or ``"frames"`` (the captured push-off's),
        :func:`takeoff_velocity_of`.
    landing_lift: m, raise the landing (the flight's last frame and every frame after it) by this
        much above where the input puts it: the parabola is planned for ``dy + landing_lift`` (App. B)
        and the frames after the flight follow. The pipeline uses it to make a landing pose that
        the corrections turned touch the floor it lands on (:func:`mocomp.edit.landing.landing_lift`).
    ease: s of source time over which the play rate eases from the flight's ``k`` back to 1 before the
        take-off and after the landing (:class:`~mocomp.flips.retime.TimeWarp`, default
        :data:`~mocomp.flips.retime.EASE_S`); ``0``: the whole motion uniformly by ``k`` (the paper's
        section 5.5.3, which plays every ground phase ``k`` times faster).
    stances: ``(first, last)`` source frames the easing stays within (the end of the clip's previous
        flight and the start of its next one: they keep their captured timing); default the whole clip.
    """
    t0 = time.perf_counter()
    a, b = int(flight[0]), int(flight[1])
    if not (0 <= a < b <= motion.n_frames and b - a >= 3):
        raise ValueError(f"flight [{a}, {b}) is not a flight of this {motion.n_frames}-frame motion")
    fps = motion.fps
    ce = com_eval if com_eval is not None else ComEvaluator(body)
    g, g_source = resolve_gravity(gravity, fit)
    h = float(takeoff_height)
    if not np.isfinite(h):
        raise ValueError(f"takeoff_height must be finite, got {takeoff_height!r}")
    com_in = ce(motion.root_positions[[a, b - 1]], motion.rotations[[a, b - 1]])
    c_take, c_land = com_in[0], com_in[1]
    T_seq = (b - 1 - a) / fps
    T0 = (fit.stop - 1 - fit.start) / fps
    v_take, v_source = takeoff_velocity_of(motion, a, fit, ce, takeoff_velocity)
    v0 = float(v_take[1])
    v_land = fit.b_y + 2.0 * fit.a_y * T0
    lift = float(landing_lift)
    if not np.isfinite(lift):
        raise ValueError(f"landing_lift must be finite, got {landing_lift!r}")
    dy = float(c_land[1] + lift - c_take[1] - h)
    try:
        plan = plan_retime(g, T_seq, v0, dy, v_land, k=k, k_ratio=k_ratio,
                           v_horizontal=float(np.hypot(v_take[0], v_take[2])))
    except PhysicsError as e:
        if h != 0.0:
            raise PhysicsError(f"{e} (take-off raised by {h:.3f} m, so the landing lies {dy:.3f} m above it)") from e
        raise
    kk = plan.k
    # the flight at k, the stances eased back to the captured rate (flips.retime.TimeWarp), the
    # clip's other flights (a hop after the landing) as captured; ease=0: uniform by k (the paper)
    end = (motion.n_frames - 1)
    lo, hi = _neighbour_flights(motion, ce, a, b) if stances is None else (float(stances[0]), float(stances[1]))
    r0, r1 = ease_limits(fps, float(a), float(b - 1), lo, hi, float(ease))
    warp = TimeWarp.build(kk, float(a), float(b - 1), float(end), r0, r1)
    src = np.minimum(warp.source_positions() / fps, motion.duration)
    from .restore import fast_sample

    out = fast_sample(motion, src)
    ta, tl = a / fps, (b - 1) / fps
    tau_a = warp.takeoff_output / fps
    eps = 1e-9
    ja = int(np.ceil(warp.takeoff_output - eps))
    jb = int(np.floor(warp.landing_output + eps))
    c0 = c_take + np.array([0.0, h, 0.0])
    traj = flight_trajectory(c0, float(v_take[0]), float(v_take[2]), -0.5 * g, kk, plan.vy_takeoff_new, plan.T_new)
    rp = np.array(out.root_positions)
    rot = out.rotations
    before = src < ta - eps
    rp[before, 1] += h
    fl = np.arange(ja, jb + 1)
    rel = ce.relative(rot[fl])                      # COM - root of each flight frame
    tt = fl / fps - tau_a
    pcheck = None
    vel = np.array(traj.velocity)
    use_platform = (h > 0) if platform == "auto" else bool(platform)
    if use_platform:
        vh = np.array([vel[0], 0.0, vel[2]])
        if np.linalg.norm(vh) < 1e-6:
            raise PhysicsError("the platform check needs a horizontal travel direction, but the take-off has no "
                               "horizontal velocity; give platform=False or a clip that leaves the platform")
        d = vh / np.linalg.norm(vh)
        low, edge = _lowest_and_forward(motion, a, d)
        top = low + h
        # joint positions relative to each flight frame's COM (translation-invariant)
        sk = out.skeleton
        from ..core.kinematics import end_site_positions
        Pj, Gj = out.fk(frames=slice(int(fl[0]), int(fl[-1]) + 1))
        if sk.end_sites:
            Pj = np.concatenate([Pj, end_site_positions(sk.end_sites, Pj, Gj)], axis=1)
        com_fl = rp[fl] + rel
        Prel = Pj - com_fl[:, None, :]

        def clear(extra):
            v = vel + extra * d
            c = c0 + tt[:, None] * v
            c[:, 1] += traj.a_y * tt * tt
            P = Prel + c[:, None, :]
            over = (P @ d) <= edge
            if not np.any(over):
                return np.inf
            return float(np.min(np.where(over, P[..., 1] - top, np.inf)))

        extra = 0.0
        cl = clear(0.0)
        if cl < clearance:
            hi = 0.5
            while clear(hi) < clearance:
                hi *= 2
                if hi > 20.0:
                    raise PhysicsError(
                        f"the body passes {-cl:.3f} m below the platform top ({h:.3f} m take-off) and even "
                        f"{hi:.0f} m/s more horizontal speed does not clear it; lower takeoff_height")
            lo = 0.0
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if clear(mid) >= clearance:
                    hi = mid
                else:
                    lo = mid
            extra = hi
            vel = vel + extra * d
            traj = FlightTrajectory(c0=traj.c0, velocity=vel, a_y=traj.a_y, T_new=traj.T_new)
            cl = clear(extra)
        pcheck = PlatformCheck(top=float(top), edge=float(edge), direction=d, clearance=float(cl),
                               extra_speed=float(extra))
    target = traj(tt)
    rp[fl] = target - rel
    after = src > tl + eps
    if np.any(after):
        c_land_new = traj(np.array([(tl - ta) / kk]))[0]
        rp[after] += c_land_new - c_land      # vertically: the lift (dy is planned with it)
    res = out.replace(root_positions=rp)
    com_out = ce(rp[fl], rot[fl])
    resid = float(np.max(np.linalg.norm(com_out - target, axis=1))) if fl.size else 0.0
    return LinearResult(motion=res, flight=(ja, jb + 1), source_times=src, plan=plan, trajectory=traj,
                        takeoff_time=float(tau_a), com_residual=resid, takeoff_height=h, platform=pcheck,
                        seconds=time.perf_counter() - t0, gravity=g, gravity_source=g_source,
                        gravity_fitted=float(fit.gravity), takeoff_velocity=tuple(float(x) for x in v_take),
                        takeoff_velocity_source=v_source)
