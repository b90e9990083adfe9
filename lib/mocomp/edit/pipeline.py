"""The whole restoration after an in-flight edit (dissertation section 5.5, flips paper 5.5).

:func:`restore_momentum` runs the three steps on an edited motion and keeps the
evidence the paper plots:

1. direction of L (eq. 5.18-5.21, :func:`~mocomp.edit.restore.correct_direction`);
2. magnitude of L by non-uniform retiming (eq. 5.22, :func:`~mocomp.edit.restore.correct_magnitude`);
3. uniform retiming and COM repositioning (section 5.5.3, :func:`~mocomp.edit.linear.correct_linear`).

For each stage (the unedited original, the edit, after each step) the
per-frame direction error (radians) and magnitude error (fraction) of ``L``
over the flight are recorded against the target (Figures 3 / 5.4 / 5.5);
after step 3 the target is ``k`` times the original one, since uniform
retiming scales momentum by ``k`` (eq. 5.8).

The default target (``reference="auto"``) is the constant ``L*`` on exact flights and the
original's own ``L(f)`` on captured ones, so that step 1 starts where the edit starts
(``f*`` of eq. 5.18-5.21) and the frames before the edit stay untouched.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_multiply
from ..dynamics.com import check_compatible
from ..flips.mass import FlightFit, fit_ballistic
from ..flips.reposition import ComEvaluator
from ..flips.takeoff import smoothed_stance_note
from .layers import EditRangeError
from .linear import LinearResult, correct_linear
from .restore import (DirectionResult, MagnitudeResult, correct_direction, correct_magnitude, direction_error,
                      flight_momentum, magnitude_error, validate_flight)

__all__ = ["StageErrors", "RestoreResult", "restore_momentum", "three_steps", "changed_frames", "STAGES",
           "boundary_velocity_jumps"]

#: deg/s: the upright recovery after a turned landing eases the tilt out no faster than this
RECOVER_RATE = 90.0
#: deg: a landing turned further than this off the vertical cannot end standing (noted)
MAX_STANDING_TILT = 45.0

#: m/s^2: ``landing_velocity="auto"`` treats an input flight whose fitted gravity is further than this
#: from the output's (or whose push-off the fit misses, :func:`mocomp.edit.linear.takeoff_velocity_of`)
#: as not ballistic, and matches its landing stance to the new flight's arrival
NONBALLISTIC_G_TOL = 1.0

#: evidence stages in order
STAGES = ("original", "edited", "direction", "magnitude", "final")

#: ``reference="auto"``: largest own direction variation (rad) of the original flight's ``L``
#: for which the constant target ``L*`` is used (the acceptance bound on step 1's error)
AUTO_REFERENCE_TOL = 0.01


@dataclass(frozen=True, eq=False)
class StageErrors:
    """Per-frame momentum errors over one stage's flight (interior frames).

    Attributes
    ----------
    stage: one of :data:`STAGES`.
    frames: ``(n,)`` frame indices in that stage's motion.
    times: ``(n,)`` s since that stage's take-off.
    phase: ``(n,)`` fraction of that stage's flight (0 = take-off, 1 = landing).
    source_times: ``(n,)`` s, the time in the *original* motion each frame shows.
    L: ``(n, 3)`` kg m^2/s; target: ``(n, 3)`` the target it is compared with.
    direction: ``(n,)`` rad, angle between ``L`` and the target.
    magnitude: ``(n,)`` relative magnitude error (fraction; x100 for %).
    """

    stage: str
    frames: np.ndarray
    times: np.ndarray
    phase: np.ndarray
    source_times: np.ndarray
    L: np.ndarray
    target: np.ndarray
    direction: np.ndarray
    magnitude: np.ndarray

    @property
    def max_direction(self) -> float:
        return float(np.max(self.direction)) if self.direction.size else 0.0

    @property
    def max_magnitude(self) -> float:
        return float(np.max(self.magnitude)) if self.magnitude.size else 0.0

    @property
    def rms_magnitude(self) -> float:
        return float(np.sqrt(np.mean(self.magnitude ** 2))) if self.magnitude.size else 0.0

    def as_dict(self) -> dict:
        return {"stage": self.stage, "frames": self.frames.tolist(), "time_s": self.times.tolist(),
                "phase": self.phase.tolist(), "source_time_s": self.source_times.tolist(),
                "direction_error_rad": self.direction.tolist(), "magnitude_error_frac": self.magnitude.tolist(),
                "max_direction_error_rad": self.max_direction, "max_magnitude_error_frac": self.max_magnitude,
                "max_magnitude_error_percent": 100.0 * self.max_magnitude}


@dataclass(frozen=True, eq=False)
class RestoreResult:
    """Output and evidence of :func:`restore_momentum`.

    Attributes
    ----------
    motion: the restored motion.
    original, edited: the inputs.
    body: the body model used.
    flight: ``(start, stop)`` of the original/edited flight; flight_out: of the output.
    reference: ``"constant"`` (target ``L*``, dissertation eq. 5.19/5.22) or ``"original"``
        (the original's own ``L(f)``, conference paper section 5.5); ``"auto"`` resolved to one of them.
    L_star: ``(3,)`` kg m^2/s, the constant target (the original flight's mean ``L`` unless given).
    fit: the original flight's ballistic COM fit (take-off velocity, gravity).
    edit_frames: ``(first, last)`` frames the edit changed (``None``: nothing changed).
    direction, magnitude, linear: the three steps' results.
    stages: :class:`StageErrors` per stage (:data:`STAGES`); ``final`` is the output.
    timings: seconds per step (``direction``, ``magnitude``, ``linear``, ``polish``, ``evidence``, ``total``).
    polish: the final direction sweep over the output flight (``None`` if disabled).
    landing_tilt_deg: how far the corrections turned the landing off the vertical (degrees);
    foot_slide: m, the largest horizontal travel of a foot on the ground from the touchdown on, when
        a tilt was eased back (feet pinned by root translation and leg IK,
        :func:`mocomp.edit.seams.recover_upright` and :mod:`mocomp.edit.landing`), measured on the
        output frames as :func:`_own_slide` (``None``: no recovery); foot_slide_own: m, the same measure on the input's own frames after
        its flight (captured landings slide too: 10.5 cm on CMU 88_01), for comparison.
    landing: :class:`~mocomp.edit.landing.LandingCheck`, where the output's landing rests against the
        floor it lands on, measured on its frames from the touchdown on (``None``: no frame after
        the flight).
    velocity_jumps: measured COM velocity jumps (m/s, :func:`boundary_velocity_jumps`) across the
        output's take-off and landing (``takeoff_m_s``, ``landing_m_s``) and the original's
        (``..._own_m_s``); the retime plan's ``vy_*_jump`` are the model's (fitted parabola vs
        ``k`` times its own take-off/landing velocity), these are what the frames show.
    arrival: what ``landing_velocity`` did (:func:`mocomp.edit.landing.match_landing_velocity`'s
        info: the flight's arrival velocity, the stance's before, whether and how it was repaired;
        ``None`` with ``"as-is"`` or no frame after the flight).
    """

    motion: Motion
    original: Motion
    edited: Motion
    body: object
    flight: tuple[int, int]
    flight_out: tuple[int, int]
    reference: str
    L_star: np.ndarray
    fit: FlightFit
    edit_frames: tuple[int, int] | None
    direction: DirectionResult
    magnitude: MagnitudeResult
    linear: LinearResult
    stages: dict
    timings: dict
    notes: tuple[str, ...] = field(default=())
    polish: DirectionResult | None = None
    landing_tilt_deg: float = 0.0
    foot_slide: float | None = None
    foot_slide_own: float | None = None
    velocity_jumps: dict | None = None
    landing: "LandingCheck | None" = None
    arrival: dict | None = None

    @property
    def k(self) -> float:
        return self.linear.plan.k

    @property
    def gravity(self) -> float:
        """m/s^2, the gravity the output flight falls with (``fit.gravity`` is the input's fitted one)."""
        return self.linear.gravity

    @property
    def k_star(self) -> float:
        return self.linear.plan.k_star

    def flight_duration(self, which: str = "final") -> float:
        """Seconds from the take-off frame to the last airborne frame."""
        fps = self.motion.fps
        if which == "final":
            a, b = self.flight_out
        elif which == "magnitude":
            a, b = self.magnitude.flight
        else:
            a, b = self.flight
        return (b - 1 - a) / fps

    def summary(self) -> str:
        s = self.stages
        lines = [f"edit frames {self.edit_frames}, flight {self.flight[0]}-{self.flight[1] - 1} "
                 f"({self.flight_duration('original'):.3f} s) -> {self.flight_out[0]}-{self.flight_out[1] - 1} "
                 f"({self.flight_duration():.3f} s); target {self.reference} |L*| = {np.linalg.norm(self.L_star):.2f}",
                 "stage       max dir err (rad)   max |L| err (%)   rms |L| err (%)"]
        for name in STAGES:
            e = s[name]
            lines.append(f"{name:<11} {e.max_direction:>17.2e}   {100 * e.max_magnitude:>15.2f}   "
                         f"{100 * e.rms_magnitude:>15.2f}")
        p = self.linear.plan
        lines.append(self.gravity_line())
        lines.append(f"k = {p.k:.3f} (k* = {p.k_star:.3f}), take-off vy jump {p.vy_takeoff_jump:+.3f} m/s, "
                     f"landing vy jump {p.vy_landing_jump:+.3f} m/s; COM parabola residual "
                     f"{self.linear.com_residual:.1e} m")
        if self.linear.platform is not None:
            pc = self.linear.platform
            lines.append(f"platform top {pc.top:.3f} m: clearance {pc.clearance:.3f} m, extra horizontal speed "
                         f"{pc.extra_speed:.3f} m/s")
        if self.polish is not None:
            ang = np.degrees(np.max(2 * np.arccos(np.clip(np.abs(self.polish.corrections[:, 3]), 0, 1))))
            lines.append(f"final direction sweep: largest rotation {ang:.2f} deg")
        if self.foot_slide is not None:
            lines.append(f"landing tilt {self.landing_tilt_deg:.1f} deg eased out after touchdown (feet slide "
                         f"{100 * self.foot_slide:.1f} cm"
                         + ("" if self.foot_slide_own is None
                            else f"; the input's own {100 * self.foot_slide_own:.1f} cm")
                         + ")")
        if self.landing is not None:
            lines.append(self.landing_line())
        lines.append("time: " + ", ".join(f"{k} {1e3 * v:.1f} ms" for k, v in self.timings.items()))
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def gravity_line(self) -> str:
        return (f"gravity {self.gravity:.2f} m/s^2 ({self.linear.gravity_source}; the input flight's fitted "
                f"{self.fit.gravity:.2f} m/s^2, a diagnostic)")

    def landing_line(self) -> str:
        """One line on where the landing rests (:attr:`landing`)."""
        lc = self.landing
        if lc is None:
            return "landing: no frame after the flight"
        return (f"landing: rests {100 * lc.offset:+.1f} cm from the floor it lands on (y = {lc.floor:.3f} m), "
                f"deepest point {100 * lc.depth:.1f} cm below it (intended landing's own "
                f"{100 * lc.reference_depth:.1f} cm); touchdown frame {lc.touchdown}, planned lift "
                f"{100 * lc.lift:+.1f} cm, root height corrected by up to {100 * lc.shift_max:.1f} cm"
                + ("" if lc.ok else " -- NOT on the floor (see note)"))

    def report(self, curves: bool = True) -> dict:
        """A JSON-serialisable report (numbers, and the per-frame curves when ``curves``).
        Direction errors are in radians (``*_rad``), relative magnitude errors of ``|L|`` as
        fractions (``*_frac``; ``*_percent`` where a percentage is given too)."""
        p = self.linear.plan
        d = {
            "flight": list(self.flight), "flight_out": list(self.flight_out),
            "flight_duration_s": {"original": self.flight_duration("original"),
                                  "after_magnitude": self.flight_duration("magnitude"),
                                  "final": self.flight_duration()},
            "fps": self.motion.fps, "edit_frames": None if self.edit_frames is None else list(self.edit_frames),
            "reference": self.reference, "L_star": self.L_star.tolist(),
            "gravity_m_s2": self.gravity, "gravity_source": self.linear.gravity_source,
            "gravity_fitted_m_s2": self.fit.gravity,
            "takeoff_velocity": list(self.linear.takeoff_velocity),
            "takeoff_velocity_source": self.linear.takeoff_velocity_source,
            "takeoff_velocity_fitted": [self.fit.a_x, self.fit.b_y, self.fit.a_z],
            "direction": {"method": self.direction.method, "first_departure": self.direction.first_departure,
                          "evaluations": self.direction.evaluations,
                          "roughness_deg": self.direction.roughness_deg,
                          "per_frame_roughness_deg": self.direction.per_frame_roughness_deg,
                          "max_correction_deg": float(np.degrees(np.max(2 * np.arccos(np.clip(
                              np.abs(self.direction.corrections[:, 3]), 0, 1)))))},
            "retime": {"k": p.k, "k_star": p.k_star, "k_ratio": p.k_ratio, "T_seq": p.T_seq, "T_new": p.T_new,
                       "v0": p.v0, "dy": p.dy, "vy_takeoff_new": p.vy_takeoff_new,
                       "vy_takeoff_jump": p.vy_takeoff_jump, "vy_landing_jump": p.vy_landing_jump, "note": p.note},
            "polish_max_rotation_deg": None if self.polish is None else float(np.degrees(np.max(
                2 * np.arccos(np.clip(np.abs(self.polish.corrections[:, 3]), 0, 1))))),
            "landing_tilt_deg": self.landing_tilt_deg, "foot_slide_m": self.foot_slide,
            "foot_slide_own_m": self.foot_slide_own, "velocity_jumps_measured": self.velocity_jumps,
            "landing": None if self.landing is None else self.landing.as_dict(),
            "landing_velocity": self.arrival,
            "com_parabola_residual_m": self.linear.com_residual,
            "takeoff_height_m": self.linear.takeoff_height,
            "platform": None if self.linear.platform is None else {
                "top": self.linear.platform.top, "clearance": self.linear.platform.clearance,
                "extra_speed": self.linear.platform.extra_speed},
            # relative |L| errors as fractions (x100 for %; the summary prints %)
            "max_errors": {n: {"direction_rad": e.max_direction, "magnitude_frac": e.max_magnitude,
                               "magnitude_percent": 100.0 * e.max_magnitude,
                               "rms_magnitude_frac": e.rms_magnitude} for n, e in self.stages.items()},
            "timings_s": dict(self.timings), "notes": list(self.notes),
        }
        if curves:
            d["curves"] = {n: e.as_dict() for n, e in self.stages.items()}
        return d

    def write_report(self, path, curves: bool = True) -> None:
        with open(path, "w") as fh:
            json.dump(self.report(curves), fh, indent=1)


def boundary_velocity_jumps(com: np.ndarray, flight, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """``(take-off, landing)`` COM velocity jumps (m/s, ``(3,)`` each) of a motion with COM
    trajectory ``com (T, 3)`` and flight ``(start, stop)``: one-frame velocities on the airborne
    side minus those on the ground side (take-off ``(c[a+1]-c[a]) - (c[a-1]-c[a-2])``, landing
    ``(c[b+1]-c[b]) - (c[b-1]-c[b-2])``, times ``fps``). A smooth ballistic take-off gives about
    ``-2 g / fps`` vertically; compare with the input's own value. NaN where the frames do not exist."""
    a, b = int(flight[0]), int(flight[1])
    c = np.asarray(com, dtype=float)
    T = c.shape[0]
    nan = np.full(3, np.nan)
    take = (c[a + 1] - c[a] - (c[a - 1] - c[a - 2])) * fps if a >= 2 and a + 1 < T else nan
    land = (c[b + 1] - c[b] - (c[b - 1] - c[b - 2])) * fps if b + 1 < T and b >= 2 else nan
    return take, land


def _root_orientation_at(motion: Motion, t: float) -> np.ndarray:
    """``motion.sample([t]).rotations[0, 0]`` (the root's slerped orientation at time ``t``, the
    frame's own on a frame time) without sampling every joint into a new motion."""
    from ..core.motion import slerp
    from .restore import _frame_weights

    i0, i1, a = _frame_weights(motion, [t])
    if a[0] == 0.0:
        return np.array(motion.rotations[i0[0], 0])
    return slerp(motion.rotations[i0[0], 0], motion.rotations[i1[0], 0], a[0])


def _own_slide(motion: Motion, stop: int, contact=(0.05, 0.12)) -> float | None:
    """:func:`mocomp.edit.seams.stance_slide` of ``motion``'s foot joints from frame ``stop`` on
    (its landing as given), ``None`` when there are no foot joints or frames."""
    from .seams import _contact_weights, stance_slide

    feet = [j for j, nm in enumerate(motion.skeleton.names) if any(k in nm.lower() for k in ("toe", "foot", "ankle"))]
    if not feet or stop >= motion.n_frames - 1:
        return None
    pos = motion.fk(frames=slice(stop, None))[0][:, feet]
    return stance_slide(pos, _contact_weights(pos[..., 1], contact))


def changed_frames(original: Motion, edited: Motion, atol: float = 1e-9) -> np.ndarray:
    """Indices of frames whose root position or any joint rotation differs (quaternion sign ignored)."""
    if original.skeleton.names != edited.skeleton.names or original.n_frames != edited.n_frames:
        raise EditRangeError(f"the edited motion ({edited.n_frames} frames, {edited.skeleton.n_joints} joints) "
                             f"does not match the original ({original.n_frames} frames, "
                             f"{original.skeleton.n_joints} joints): an edit must keep the frames and skeleton")
    dp = np.abs(edited.root_positions - original.root_positions).max(axis=1)
    qa, qb = edited.rotations, original.rotations
    dq = np.minimum(np.linalg.norm(qa - qb, axis=-1), np.linalg.norm(qa + qb, axis=-1)).max(axis=1)
    return np.flatnonzero((dp > atol) | (dq > atol))


def _stage(name, body, motion, flight, src_of_frame, target_fn, scale=1.0, L=None):
    a, b = flight
    frames = np.arange(a + 1, b - 1)
    if L is None:
        L = flight_momentum(body, motion, flight)
    L = L[frames]
    src = src_of_frame(frames)
    tgt = scale * target_fn(src)
    fps = motion.fps
    dur = max((b - 1 - a) / fps, 1e-12)
    t = (frames - a) / fps
    return StageErrors(stage=name, frames=frames, times=t, phase=t / dur, source_times=src, L=L, target=tgt,
                       direction=direction_error(L, tgt) if frames.size else np.zeros(0),
                       magnitude=magnitude_error(L, tgt) if frames.size else np.zeros(0))


def restore_momentum(body, original: Motion, edited: Motion, flight, *, k_ratio: float | None = None,
                     k: float | None = None, reference: str = "auto", L_star=None,
                     method: str = "smooth", takeoff_height: float = 0.0, platform: bool | str = "auto",
                     clearance: float = 0.0, gravity="standard", takeoff_velocity: str = "auto", oversample: int = 8,
                     tol: float = 1e-7, fit: FlightFit | None = None, polish: bool = True,
                     upright: bool = True, recover_s: float = 0.3,
                     auto_tol: float = AUTO_REFERENCE_TOL, landing_velocity: str = "auto",
                     stances: str = "smooth") -> RestoreResult:
    """Restore momentum conservation of an in-flight edit (section 5.5, all three steps).

    Parameters
    ----------
    body: body model (segment masses and inertias) of the skeleton.
    original: the unedited motion; edited: the same frames after the animator's edit
        (e.g. :func:`mocomp.edit.apply_preset`); the edit must change only frames strictly
        inside the flight (``start+1 .. stop-2``), else :class:`EditRangeError`.
    flight: ``(start, stop)`` half-open frames of the ballistic phase.
    k_ratio, k: step 3's uniform retiming factor, or its ratio to ``k*`` (App. B eq. B.5 for the
        restored flight's duration). Default ``k_ratio = 1``: section 5.5.3 retimes "to ensure
        proper momentum build-up and release", i.e. linear momentum continuous at take-off and
        landing, which is ``k = k*``; the flight then lasts ``sqrt(T_seq T)`` (longer, higher,
        slower rotation for a straight-leg edit, as Fig. 5.9 shows). ``k_ratio = 0.7`` is
        section 5.4.3's aesthetic choice for multi-flips ("higher jumps with slower rotations");
        it leaves vertical velocity jumps at take-off and landing (reported).
    reference: ``"constant"``: the target is the constant ``L*`` (eq. 5.19, 5.22), the original
        flight's mean ``L`` unless ``L_star`` is given; ``"original"``: the original's own ``L(f)``
        frame by frame (conference paper's ``ratio = |L_modif(f)| / |L(f)|``); ``"auto"`` (default):
        ``"constant"`` when ``L_star`` is given or the original flight's own direction of ``L``
        stays within ``auto_tol`` rad of its mean (exact or synthetic flights), else ``"original"``
        (the resolved choice is :attr:`RestoreResult.reference`, with a note).

        Why: section 5.5 / eq. 5.18-5.21 start step 1 at the first frame ``f*`` where the
        *edited* ``L`` departs from ``L*``, i.e. where the edit begins. On captured flights
        ``L`` is not constant (measured own direction variation: 0.05 rad CMU 88_01, 0.40 rad
        CMU 90_08, 0.12 rad DeepMimic back flip), so against a constant ``L*`` the unedited
        frames already "depart" and step 1 starts at the first flight frame, before the edit:
        an *unedited* clip was turned by up to 10 deg (88_01), 37 deg (90_08) and 26 deg
        (DeepMimic back flip), its landing tilted up to 31 deg. Against the original's own
        ``L(f)`` the unedited frames match their target exactly, so ``f*`` is the frame before
        the first edited one (``L_f`` reads pose ``f+1``), the corrections are the identity and
        step 2's ratio is 1 before the edit, and an unedited clip passes through unturned.
    auto_tol: ``reference="auto"``'s threshold (rad) on the original's own direction variation
        (default 0.01, the acceptance bound on step 1's error).
    method: step 1's solver, ``"smooth"`` (default: per-frame sweep, then all frames' corrections
        smoothed jointly under the same constraints), ``"gauss-newton"`` (the per-frame sweep
        alone) or ``"bfgs"`` (the paper's); see :func:`~mocomp.edit.restore.correct_direction`.
    takeoff_height, platform, clearance: step 3 options (:func:`~mocomp.edit.linear.correct_linear`).
    gravity: the gravity the restored flight falls with: ``"standard"`` (9.81 m/s^2, default),
        ``"clip"`` (the input flight's fitted gravity, the paper's choice) or m/s^2
        (:func:`~mocomp.edit.linear.resolve_gravity`); the fitted value stays in the report.
    takeoff_velocity: the velocity the flight leaves with: ``"auto"`` (default: the ballistic fit's,
        unless the captured push-off reaches a different one, a flight that is not ballistic: then the
        push-off's, so the flight continues it), ``"fit"`` (the paper's) or ``"frames"``
        (:func:`~mocomp.edit.linear.takeoff_velocity_of`).
    oversample: step 2's fine grid (x the frame rate).
    tol: step 1's direction tolerance (rad).
    fit: the original flight's ballistic fit, if already computed.
    polish: after step 3, sweep step 1 once more over the output flight (targets at the
        frames' source times): the in-between poses that steps 2-3 interpolate move the
        finite-difference ``L`` off its direction by about the data's own frame-to-frame
        noise. The rotations are about each frame's COM, so the parabola stays exact; the
        frames after the landing turn with the last one, each about its own COM.
    upright, recover_s: step 1 turns every frame after the edit, the landing too (that is how
        asymmetric arms make a twist, Fig. 5.10). A standing landing tilted that way is eased back
        to the original's vertical over ``recover_s`` seconds after touchdown (about the ground
        point under the COM; a torque from the ground, not part of the ballistic correction; the
        feet's slide is reported). The turn about the vertical is kept.
    landing_velocity: how the landing stance meets the flight's arrival velocity (beyond the paper;
        :func:`mocomp.edit.landing.match_landing_velocity`). ``"as-is"``: the paper's section 5.5.3
        (dissertation 5.5.3, flips paper 5.5): the frames after the flight are retimed by ``k`` and
        moved rigidly (eq. 5.16), which is continuous only where the input flight is ballistic with
        the chosen gravity and take-off velocity. ``"auto"`` (default): on an input flight that is
        not ballistic (fitted gravity more than :data:`NONBALLISTIC_G_TOL` from the output's, or a
        push-off the fit misses), where the parabola's
        arrival velocity differs from the retimed stance's by more than 0.3 m/s (any component;
        the DeepMimic back and side flips: 0.9-1.25 m/s measured jumps at landing against the
        input's 0.3-0.4), the stance is reshaped by :func:`mocomp.flips.takeoff.repair_stance`
        (as ``multiflip(..., takeoff="repair")`` does at a ``k < k*`` landing): the COM decelerated
        smoothly from the arrival velocity to the stance's own, less the input landing's own impact
        (``k`` times its velocity change there), feet held by leg IK, ground force
        bounded; a stance that cannot take it is left as is with a note. ``"repair"``: whenever
        they differ.
    stances: ``"smooth"`` (default, beyond the paper): the stance before the take-off and after the
        landing get a longer push and a softer give where the retiming by ``k`` made the COM velocity's
        join with the flight rougher than the input's (:func:`mocomp.flips.takeoff.smooth_stance`);
        ``"as-is"``: the paper's.
    """
    t_all = time.perf_counter()
    if k is None and k_ratio is None:
        k_ratio = 1.0
    if reference not in ("auto", "constant", "original"):
        raise ValueError(f"reference must be 'auto', 'constant' or 'original', got {reference!r}")
    if reference == "original" and L_star is not None:
        raise ValueError("L_star is a constant target; it cannot be combined with reference='original'")
    check_compatible(body, original)
    check_compatible(body, edited)
    if edited.fps != original.fps:
        raise EditRangeError(f"the edited motion is at {edited.fps:g} Hz, the original at {original.fps:g} Hz")
    a, b = validate_flight(original, flight)
    changed = changed_frames(original, edited)
    edit_frames = (int(changed[0]), int(changed[-1])) if changed.size else None
    if changed.size and (changed[0] < a + 1 or changed[-1] > b - 2):
        raise EditRangeError(
            f"the edit changes frames {changed[0]}-{changed[-1]}, but the flight is frames {a}-{b - 1}: edits "
            f"must lie strictly inside it (frames {a + 1}-{b - 2}), so that L at take-off stays the original's "
            "(eq. 5.19) and the landing is untouched; move or shorten the edit")
    ce = ComEvaluator(body)
    fps = original.fps
    if fit is None:
        fit = fit_ballistic(ce(original.root_positions[a:b], original.rotations[a:b]), fps, a)
    L_orig = flight_momentum(body, original, (a, b))
    Lmean = np.nanmean(L_orig[a + 1:b - 1], axis=0)
    L_const = Lmean if L_star is None else np.asarray(L_star, dtype=float)
    if L_const.shape != (3,) or not np.linalg.norm(L_const) > 0:
        raise ValueError(f"L_star must be a non-zero 3-vector, got {L_star!r}")
    notes = []
    if reference == "auto":
        own = direction_error(L_orig[a + 1:b - 1], Lmean)
        own_max = float(np.max(own)) if own.size else 0.0
        if L_star is not None or own_max <= auto_tol:
            reference = "constant"
        else:
            reference = "original"
            notes.append(f"target: the original's own L(f) frame by frame (reference='auto': its direction varies "
                         f"by up to {own_max:.3f} rad over the flight, above {auto_tol:g} rad; a constant L* "
                         "would turn the frames before the edit)")
    if edit_frames is None:
        notes.append("the edited motion equals the original: nothing to restore but the uniform retiming")
    return three_steps(body, edited, (a, b), L_const, fit, original=original, original_flight=(a, b),
                       L_orig=L_orig, reference=reference, method=method, tol=tol, oversample=oversample, k=k,
                       k_ratio=k_ratio, takeoff_height=takeoff_height, platform=platform, clearance=clearance,
                       gravity=gravity, takeoff_velocity=takeoff_velocity, polish=polish, notes=notes,
                       edit_frames=edit_frames, com_eval=ce,
                       t_start=t_all, upright_ref=edited if upright else None,
                       recover_s=recover_s, landing_velocity=landing_velocity, stances=stances)


def _smooth_stances(final: Motion, ce, lin, mg, original: Motion, original_flight, b_detected: int):
    """:func:`mocomp.flips.takeoff.smooth_stance` on the output's stance before the take-off and after the
    landing (bounded by the clip's other flights, which keep their timing): the audit's COM velocity
    jumps near each event brought within the input's own there (``original`` over ``original_flight``).
    Step 3 plays the flight ``k`` times faster and eases the stances back to the captured rate
    (:class:`~mocomp.flips.retime.TimeWarp`), so the push ends with ``k^2`` times its captured
    acceleration and the landing's impact is ``k`` times harder; the map makes the push longer and
    the give deeper instead. Returns ``(motion, infos)``."""
    from ..flips.takeoff import LANDING_MAX_FORCE, _event_jump, audit_com, smooth_stance
    from .linear import _neighbour_flights

    fps = final.fps
    cs = audit_com(original)                        # the COM the audit measures (the input's body model)
    comO = cs(original.root_positions, original.rotations)
    a0, b0 = int(original_flight[0]), int(original_flight[1])
    lo, hi = _neighbour_flights(mg.motion, ce, int(mg.flight[0]), int(mg.flight[1]))
    src = np.asarray(lin.source_times, dtype=float) * fps          # mg frames shown by each output frame
    tj = lin.trajectory
    ev_to = lin.takeoff_time * fps
    ev_ld = (lin.takeoff_time + tj.T_new) * fps
    n = final.n_frames
    fr = np.arange(n)
    before = fr[(fr < ev_to) & (src >= lo)]
    after = fr[(fr > ev_ld) & (src <= hi)]
    infos = []
    g = lin.gravity
    if before.size >= 4:
        final, info = smooth_stance(final, cs, "take-off", float(ev_to), (int(before[0]), int(before[-1]) + 1), g=g,
                                    target_jump=_event_jump(comO, original.fps, a0 - 0.5))
        infos.append(info)
    if after.size >= 4:
        final, info = smooth_stance(final, cs, "landing", float(ev_ld), (int(after[0]), int(after[-1]) + 1), g=g,
                                    max_force=LANDING_MAX_FORCE,
                                    target_jump=_event_jump(comO, original.fps, b0 - 0.5))
        infos.append(info)
    return final, tuple(infos)


def three_steps(body, edited: Motion, flight, L_const, fit: FlightFit, *, original: Motion,
                original_flight, L_orig=None, reference: str = "constant", method: str = "smooth",
                tol: float = 1e-7, oversample: int = 8, k=None, k_ratio=None, takeoff_height: float = 0.0,
                platform="auto", clearance: float = 0.0, gravity="standard", takeoff_velocity: str = "auto",
                polish: bool = True, notes=(),
                edit_frames=None, com_eval=None, t_start=None, direction: bool = True,
                upright_ref: Motion | None = None, upright_pre=None, recover_s: float = 0.3,
                landing_floor: float | None = None, settle: bool = True,
                landing_velocity: str = "auto", stances: str = "smooth") -> RestoreResult:
    """Steps 1-3 (and the final direction sweep) on ``edited``'s flight with the constant target
    ``L_const`` (or, with ``reference="original"``, ``original``'s per-frame ``L_orig`` on the same
    frames); ``fit`` gives the take-off velocity for step 3 (and its gravity with ``gravity="clip"``). The ``original`` stage of
    the evidence is ``original`` over ``original_flight`` against ``L_const`` (its own variation).
    ``direction=False`` skips step 1 and the final sweep (joins: section 5.2 adjusts a transition's
    momentum by retiming only). ``upright_ref``: a motion on ``edited``'s frame times whose root
    orientation (pre-multiplied by ``upright_pre``, if given) is the intended one; where the
    corrections turned the output's landing off its vertical, the tilt is eased back over
    ``recover_s`` seconds after touchdown (:func:`mocomp.edit.seams.recover_upright`).

    The landing comes to rest on the floor it lands on (:mod:`mocomp.edit.landing`): the intended
    landing is ``upright_ref`` (turned by ``upright_pre``; ``edited`` without ``upright_ref``), its
    floor the level it rests on after the flight, or ``landing_floor`` (m, in ``edited``'s
    coordinates: a join lands on its take-off floor). Step 3 plans the parabola so that the
    corrected pose touches that floor at the intended touchdown, the upright recovery starts
    there and turns the body over the point it touches, and with ``settle`` the frames from the
    touchdown on get the intended landing's clearance above the floor (root height, leg IK,
    levelled planted feet). :attr:`RestoreResult.landing` measures the result; a landing that
    does not rest within 1 cm of the floor gets a note. ``landing_velocity`` (see
    :func:`restore_momentum`) then matches the landing stance to the flight's arrival velocity.
    ``stances="smooth"`` (default; ``"as-is"``: the paper's) then gives the stances next to the take-off and
    the landing a longer push and a softer give where the retiming made the COM velocity's join with
    the flight rougher than the input's (:func:`_smooth_stances`). Used by :func:`restore_momentum`,
    :func:`mocomp.edit.join.join_flights` and :func:`mocomp.edit.twist.twist_jump`."""
    t_all = time.perf_counter() if t_start is None else t_start
    if k is None and k_ratio is None:
        k_ratio = 1.0
    a, b = int(flight[0]), int(flight[1])
    notes = list(notes)
    timings = {}
    ce = com_eval if com_eval is not None else ComEvaluator(body)
    L_const = np.asarray(L_const, dtype=float)
    if L_orig is None:
        L_orig = flight_momentum(body, original, original_flight)
    # the intended landing and its floor (mocomp.edit.landing), and the flight up to its touchdown
    from .landing import landing_lift, landing_reference

    if upright_ref is None:
        land_motion = edited
    else:
        land_motion = upright_ref if upright_pre is None else upright_ref.rotated(np.asarray(upright_pre, dtype=float))
    land_ref = landing_reference(land_motion, b)
    b_detected = b
    if land_ref is not None and land_ref.touchdown > b:
        notes.append(f"the flight (frames {a}-{b - 1}) goes on for {land_ref.touchdown - b} more frame(s) until the "
                     f"body reaches the floor (frame {land_ref.touchdown}): they are restored with it (frozen "
                     "corrections there stopped a twist in mid-air)")
        b = land_ref.touchdown
        if reference != "constant":     # the per-frame target over the whole airborne phase (same frames)
            L_orig = flight_momentum(body, original, (a, b))
    # step 1
    t = time.perf_counter()
    target1 = L_const if reference == "constant" else L_orig
    if direction:
        d = correct_direction(body, edited, (a, b), L_star=target1, method=method, tol=tol)
    else:   # step 1 skipped: identity corrections, the evidence still measured
        L_e = flight_momentum(body, edited, (a, b))
        U = np.broadcast_to(target1, L_e.shape) if np.ndim(target1) == 1 else target1
        err = direction_error(np.nan_to_num(L_e), U)
        err[~np.all(np.isfinite(L_e), axis=1)] = np.nan
        d = DirectionResult(motion=edited, corrections=np.tile([0.0, 0.0, 0.0, 1.0], (edited.n_frames, 1)),
                            error_before=err, error_after=err, L_before=L_e, L_after=L_e,
                            L_star=np.asarray(target1, dtype=float), first_departure=None, method="none",
                            evaluations=0, seconds=0.0, flight=(a, b))
    timings["direction"] = time.perf_counter() - t
    if d.roughness_deg > 5.0 and d.smoothing is not None and d.smoothing.converged:
        notes.append(f"the direction corrections change fast (second difference up to {d.roughness_deg:.1f} deg, "
                     f"{d.per_frame_roughness_deg:.1f} deg frame by frame before the joint smoothing): the body's "
                     "reaction to limbs moving within a few frames; ease the edit in and out more slowly")
    elif d.roughness_deg > 5.0:
        notes.append(f"the direction corrections jitter from frame to frame (second difference up to "
                     f"{d.roughness_deg:.1f} deg): eq. 5.21's two-step recurrence oscillates when limbs move fast "
                     "relative to the frame rate; use method='smooth' (the joint solve), ease the edit in and out "
                     "more slowly or resample the clip to a higher frame rate")
    floor_target, lift = None, 0.0
    m1, L1 = d.motion, d.L_after
    if land_ref is not None:
        floor_target = land_ref.floor if landing_floor is None else float(landing_floor)
        td = land_ref.touchdown
        if settle:      # feet as level as the intended landing's by the touchdown (prepared in the air)
            from .landing import level_feet

            m1, lev_start = level_feet(d.motion, land_motion, td, land_ref.chains, earliest=(a + b) // 2)
            if lev_start < b:
                L1 = None                                   # flight frames changed: step 2 measures L again
        lift = landing_lift(m1, td, floor_target, land_ref.touchdown_clearance)
    # step 2
    t = time.perf_counter()
    if reference == "constant":
        mg = correct_magnitude(body, m1, (a, b), L_star=L_const, oversample=oversample, L_before=L1)
    else:
        mg = correct_magnitude(body, m1, (a, b), oversample=oversample, reference=original, L_before=L1)
    timings["magnitude"] = time.perf_counter() - t
    # step 3
    t = time.perf_counter()
    lin = correct_linear(body, mg.motion, mg.flight, fit, k=k, k_ratio=k_ratio, takeoff_height=takeoff_height,
                         platform=platform, clearance=clearance, gravity=gravity, com_eval=ce, landing_lift=lift,
                         takeoff_velocity=takeoff_velocity)
    timings["linear"] = time.perf_counter() - t
    # evidence
    t = time.perf_counter()
    frame_t = edited.times
    if reference == "constant":
        def dir_target(src):
            return np.broadcast_to(L_const, (np.size(src), 3))

        def mag_target(src):
            return dir_target(src)
    else:
        good = np.all(np.isfinite(L_orig), axis=1)
        tt, LL = frame_t[good], L_orig[good]

        def dir_target(src):
            return np.column_stack([np.interp(src, tt, LL[:, i]) for i in range(3)])

        mag_LL = np.linalg.norm(LL, axis=1)

        def mag_target(src):
            # direction and magnitude from the frame-rate original, the discretisation the stages'
            # L are measured with (step 2's fine-grid |L| of slerped in-between poses has a
            # sawtooth of up to +-8% within each frame interval where limbs move fast; read at
            # fractional source times it would show as a spurious error)
            v = dir_target(src)
            v = v / np.linalg.norm(v, axis=1, keepdims=True)
            return v * np.interp(src, tt, mag_LL)[:, None]

    ident = lambda f: frame_t[f]  # noqa: E731
    stages = {
        # the clip's own variation: the unedited flight against its own constant target
        "original": _stage("original", body, original, tuple(original_flight), lambda f: original.times[f],
                           lambda src: np.broadcast_to(L_const, (np.size(src), 3)), L=L_orig),
        "edited": _stage("edited", body, edited, (a, b), ident, dir_target, L=d.L_before),
        "direction": _stage("direction", body, d.motion, (a, b), ident, dir_target, L=d.L_after),
    }
    src2 = mg.source_times
    stages["magnitude"] = _stage("magnitude", body, mg.motion, mg.flight, lambda f: src2[f], mag_target,
                                 L=mg.L_after)
    t2 = mg.motion.times

    def src3(f):
        return np.interp(lin.source_times[f], t2, src2)

    final = lin.motion
    polish_res = None
    if polish and direction:
        # Resampling at in-between times (steps 2 and 3) moves the finite-difference L off its
        # direction by about the capture's own frame-to-frame noise; one more sweep of step 1
        # over the output flight (targets at the source times) removes that. Rotations about
        # each frame's COM leave the COM parabola of step 3 exact.
        tp = time.perf_counter()
        fr = np.arange(lin.motion.n_frames)
        tgt = np.full((lin.motion.n_frames, 3), np.nan)
        fa, fb = lin.flight
        tgt[fa + 1:fb - 1] = dir_target(src3(fr[fa + 1:fb - 1]))
        tgt[:fa + 1] = tgt[fa + 1]
        tgt[fb - 1:] = tgt[fb - 2]
        polish_res = correct_direction(body, lin.motion, lin.flight, L_star=tgt, method="gauss-newton", tol=tol)
        final = polish_res.motion
        timings["polish"] = time.perf_counter() - tp
        t += timings["polish"]
    stages["final"] = _stage("final", body, final, lin.flight, src3, mag_target, scale=lin.plan.k,
                             L=None if polish_res is None else polish_res.L_after)
    timings["evidence"] = time.perf_counter() - t
    tilt, slide, slide_own = 0.0, None, None
    # the output frame of the touchdown: the first after the flight (which runs until the body reaches the floor)
    td_out = lin.flight[1]
    if upright_ref is not None:
        from .seams import landing_tilt, recover_upright

        fl_last = lin.flight[1] - 1
        q_ref = _root_orientation_at(upright_ref, float(np.clip(src3(np.array([fl_last]))[0], 0.0,
                                                                  upright_ref.duration)))
        if upright_pre is not None:
            q_ref = quat_multiply(np.asarray(upright_pre, dtype=float), q_ref)
        tilt, up_now = landing_tilt(q_ref, final.rotations[fl_last, 0])
        if tilt > 1.0 and recover_s > 0 and td_out < final.n_frames:
            tr = time.perf_counter()
            # no faster than RECOVER_RATE: a 56 deg tilt (CMU 90_08 + straight-legs) eased out within
            # 0.3 s swung the COM by 0.75 m in 0.3 s (4 m/s velocity jumps on the ground)
            recover_s = max(recover_s, tilt / RECOVER_RATE)
            pivot = None
            if floor_target is not None:    # under the COM on the floor (not at the lowest joint, which
                # for a turned body is above the floor or below it: 6.8 cm on the synthetic back flip)
                c = ce(final.root_positions[td_out:td_out + 1], final.rotations[td_out:td_out + 1])[0]
                pivot = np.array([c[0], floor_target, c[2]])
            final, slide = recover_upright(final, td_out, up_now, recover_s, ce, pivot=pivot)
            timings["upright"] = time.perf_counter() - tr
            slide_own = _own_slide(upright_ref, b_detected)
            if tilt > MAX_STANDING_TILT:
                notes.append(f"the corrections turned the landing {tilt:.0f} deg off the vertical (more than "
                             f"{MAX_STANDING_TILT:g} deg): no standing landing follows from that; easing it upright "
                             "needs a torque from the ground no landing gives (see the audit's COM velocity jumps and "
                             "ZMP) -- a smaller edit, or a landing that rolls out, would be physical")
    landing, info, arrival_info = None, None, None
    if land_ref is not None and td_out < final.n_frames:
        from .landing import rest_on_floor

        tr = time.perf_counter()
        fr = np.arange(td_out, final.n_frames)
        if settle:
            final, info = rest_on_floor(final, td_out, floor_target, land_ref, src3(fr))
        timings["landing"] = time.perf_counter() - tr
    # "auto" repairs the landings of flights that are not ballistic with the chosen gravity (the fit's g
    # off it, or a push-off the fit misses): an exact flight's arrival already meets its stance as the
    # input's did, and the repair's cost (20-40 ms) stays off it
    ballistic = lin.takeoff_velocity_source == "fit" and abs(fit.gravity - lin.gravity) <= NONBALLISTIC_G_TOL
    if (landing_velocity == "repair" or (landing_velocity == "auto" and not ballistic)) \
            and floor_target is not None and td_out < final.n_frames:
        from .landing import match_landing_velocity, own_landing_jump

        tr = time.perf_counter()
        tj = lin.trajectory
        arrival = np.array(tj.velocity, dtype=float)
        arrival[1] += 2.0 * tj.a_y * tj.T_new
        # the parabola ends at the input's last flight frame, shown at output frame (b - 1) / k
        ev = (lin.takeoff_time + tj.T_new) * final.fps
        # the intended landing's own velocity change there (its impact), k times in the retimed output
        c_own = ce(land_motion.root_positions, land_motion.rotations)
        own = lin.plan.k * own_landing_jump(c_own, b - 1, land_motion.fps)
        final, arrival_info = match_landing_velocity(
            final, ce, ev, arrival, floor_target, g=lin.gravity, mode=landing_velocity, own_jump=own, body=body)
        if arrival_info["repaired"]:
            r = arrival_info["repair"]
            notes.append(f"landing stance repaired (landing_velocity={landing_velocity!r}; beyond the paper, whose "
                         f"step 3 moves it rigidly): the flight arrives at "
                         f"({', '.join(f'{x:+.2f}' for x in arrival)}) m/s, the stance moved at "
                         f"({', '.join(f'{x:+.2f}' for x in arrival_info['stance_m_s'])}); over output frames "
                         f"{r['frames'][0]}-{r['frames'][1] - 1} the crouch deepens by up to {100 * -r['dip']:.1f} cm, "
                         f"vertical ground force {r['min_force']:.2f}-{r['peak_force']:.2f} body weights, feet held "
                         f"within {1000 * r['ik_miss']:.1f} mm")
        elif arrival_info["note"]:
            notes.append(arrival_info["note"])
        timings["arrival"] = time.perf_counter() - tr
    stance_info = ()
    if stances == "smooth":
        tr = time.perf_counter()
        final, stance_info = _smooth_stances(final, ce, lin, mg, original, original_flight, b_detected)
        timings["stances"] = time.perf_counter() - tr
        notes += [n for n in (smoothed_stance_note(sm, "stances='smooth'") for sm in stance_info) if n]
    elif stances != "as-is":
        raise ValueError(f"stances must be 'smooth' or 'as-is', got {stances!r}")
    if land_ref is not None and td_out < final.n_frames:
        from .landing import check_landing

        tr = time.perf_counter()
        landing = check_landing(final, td_out, floor_target, land_ref, lift, info)
        timings["landing"] = timings.get("landing", 0.0) + time.perf_counter() - tr
    if slide is not None:
        # the feet's slide on the frames written (after the floor contact was restored), the measure
        # of the input's own landing contacts (foot_slide_own)
        slide = _own_slide(final, td_out) or 0.0
        notes.append(f"the corrections turned the landing {tilt:.1f} deg off the vertical; it is eased back "
                     f"upright over {recover_s:.2g} s after touchdown (a torque from the ground), the feet on "
                     f"the ground held by root translation and leg IK (largest slide {100 * slide:.1f} cm"
                     + ("" if slide_own is None else
                        f"; the input's own feet travel {100 * slide_own:.1f} cm during its landing contacts")
                     + ")")
        if not landing.ok:
            notes.append(f"landing: {landing.describe()}")
    comF = ce(final.root_positions, final.rotations)
    comO = ce(original.root_positions, original.rotations)
    jt, jl = boundary_velocity_jumps(comF, lin.flight, final.fps)
    jt0, jl0 = boundary_velocity_jumps(comO, original_flight, original.fps)
    vjumps = {"takeoff_m_s": jt.tolist(), "landing_m_s": jl.tolist(), "takeoff_own_m_s": jt0.tolist(),
              "landing_own_m_s": jl0.tolist()}
    ex = np.abs(jt - jt0)
    if np.all(np.isfinite(ex)) and ex.max() > 0.5:
        notes.append(f"the COM velocity jumps by ({', '.join(f'{v:+.2f}' for v in jt)}) m/s across the take-off, "
                     f"the input by ({', '.join(f'{v:+.2f}' for v in jt0)}): the input flight's ballistic fit "
                     f"(gravity {fit.gravity:.2f} m/s^2, take-off velocity ({fit.a_x:+.2f}, {fit.b_y:+.2f}, "
                     f"{fit.a_z:+.2f}) m/s) does not meet its captured take-off, so step 3's parabola starts off the "
                     "ground phase's velocity")
    timings["total"] = time.perf_counter() - t_all
    if lin.plan.note:
        notes.append(lin.plan.note)
    return RestoreResult(motion=final, original=original, edited=edited, body=body, flight=(a, b),
                         flight_out=lin.flight, reference=reference, L_star=L_const, fit=fit,
                         edit_frames=edit_frames, direction=d, magnitude=mg, linear=lin, stages=stages,
                         timings=timings, notes=tuple(notes), polish=polish_res, landing_tilt_deg=tilt,
                         foot_slide=slide, foot_slide_own=slide_own, velocity_jumps=vjumps, landing=landing,
                         arrival=arrival_info)
