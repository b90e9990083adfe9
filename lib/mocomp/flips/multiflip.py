"""The run-time stage: a multi-flip jump from a prepared single flip (flips paper section 5;
dissertation section 5.4), with a physics report.

:func:`multiflip` runs, each stage timed:

1. **sequence** -- eq. 5.10-5.11 and the landing search (:mod:`.sequence`), from the
   cached self-looping fragment;
2. **smooth** -- root rotation about ``L`` plus the rotated copies' extra turn, the
   loop seam correction computed once in pre-processing and pasted at every seam,
   the landing seam (eq. 5.14, :mod:`.smoothing`); then the eq. 5.22 playback speeds
   across the seams (section 5.4.2.2's non-uniform retiming, :mod:`.smoothing`: the loop
   seam's cached per clip, the landing seam's from the angular momentum of its frames);
3. **retime** -- one factor ``k`` for take-off, flight and landing (App. B, :mod:`.retime`)
   on the seam-warped time; slerp of every joint at the retimed instants;
4. **reposition** -- flight frames translated so the exact COM (estimated masses) follows
   eq. 5.15/5.17; landing frames offset by eq. 5.16 (:mod:`.reposition`);
5. **assemble** -- the new :class:`~mocomp.core.Motion`.

The self-looping search belongs to pre-processing (cached per clip); its time is
reported separately, as is the time of the physics evaluation (momentum of the
new motion), which is evidence, not part of the method.
"""
from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion
from ..core.rotations import axis_quat, quat_angle, quat_apply, quat_inverse, quat_multiply, slerp, twist_angle
from ..dynamics.constants import G_STANDARD
from ..errors import PhysicsError
from .preprocess import PreparedFlip, flight_L_stats
from .reposition import FlightTrajectory, event_velocity, flight_trajectory
from .retime import EASE_S, RetimePlan, TimeWarp, ease_limits, plan_retime, resolve_gravity, sample_positions
from .takeoff import TAKEOFF_CHOICES, smoothed_stance_note
from .sequence import Sequence, build_sequence
from ._kernels import AVAILABLE as KERNELS
from ._kernels import landing_seam_nb, reposition_nb, slerp_gather_nb, turn_roots_nb, writable
from .smoothing import (SPEED_BOUNDS, _landing_speed_nb, compose_root, ramp, seam_speed, split_root, warp_time,
                        warped_positions)

__all__ = ["PhysicsReport", "MultiFlipResult", "multiflip", "landing_change_for_k"]

RUNTIME_STAGES = ("sequence", "smooth", "retime", "reposition", "assemble")


@dataclass(frozen=True)
class PhysicsReport:
    """What a researcher needs to judge a generated multi-flip (angles in degrees).

    Rotation: ``requested_rotation`` (``360 x flips``), ``requested_extra`` (the rotation added to
    the input's, ``360 x (flips - 1)``, or the ``extra_rotation`` given), ``target_rotation`` (the input's own
    rotation about L plus ``360 x (flips - 1)``, so it lands as the input did),
    ``original_rotation``, ``achieved_rotation`` (root rotation about L, first to last
    frame, of the new motion), ``rotation_error`` (achieved - target).
    Sequencing: ``r`` (the paper's count), ``copies_used``, ``phi`` (per repetition),
    ``phi_S``, ``phi_E``, frames ``m, n`` (loop), ``f`` (source frame), ``f_copy``, ``g``,
    ``loop_distance``, ``loop_mean_angle``, ``landing_distance``, ``join_twist``
    (rotation mismatch at the landing join, spread over the flight), ``loop_found``.
    Timing: ``k``, ``k_star``, ``k_ratio``; flight durations (s) ``T_original``,
    ``T_sequenced``, ``T_new``; ``gravity`` (m/s^2, what the new flight falls with),
    ``gravity_source`` (``"standard"``, ``"clip"`` or ``"given"``), ``gravity_fitted`` (m/s^2, the
    input flight's ballistic fit: a diagnostic of its frame rate, units and masses), ``gravity_scale``
    (``gravity_fitted / 9.81``).
    Angular momentum (kg m^2/s, estimated masses, flight interior): ``L_original``,
    ``L_new`` (mean |L|), ``L_variation_original``, ``L_variation_new`` (max relative
    deviation of |L| from its mean), ``L_std_original``, ``L_std_new`` (coefficient of
    variation), ``L_range_original``, ``L_range_new`` (peak to peak over the mean),
    ``L_direction_change`` (angle between the mean L directions, after removing the
    rotation applied).
    COM: ``com_residual_rms``, ``com_residual_max`` (m, new flight COM about its own
    ballistic fit), ``com_target_error`` (m, max distance to eq. 5.15/5.17).
    Every value here is the model's plan; the frames written are measured by :mod:`mocomp.audit`
    (the CLI prints both, the audit as the physics of the output).
    Take-off: ``takeoff`` (``"as-is"`` or ``"repair"``), ``takeoff_velocity`` (``"measured"``: the
    flight continues the input's take-off velocity; ``"fit"``: the flight fit's intercepts, eq. 5.15),
    ``velocity_jump_takeoff`` / ``velocity_jump_landing`` (``(3,)`` m/s, planned COM velocity jumps,
    new flight minus the retimed stance, before any repair), ``repairs`` (the
    :class:`~mocomp.flips.takeoff.StanceRepair` of each repaired event, as dicts),
    ``takeoff_angle_original``, ``takeoff_angle_new``, ``takeoff_angle_change``
    (elevation of the COM velocity). Planned linear momentum jumps (kg m/s, vertical, after any
    repair: 0 where the stance was repaired): ``p_jump_takeoff``,
    ``p_jump_landing``, and relative to ``M k |v|``, the momentum of the ``k``-retimed ground
    phase at take-off (the basis of the take-off note too; :mod:`mocomp.flips.retime`):
    ``p_jump_takeoff_rel``, ``p_jump_landing_rel``. Landing: ``landing_orientation_error`` (final root orientation
    vs the original's final one). ``height_change`` (m, landing level change),
    ``takeoff_height_change`` (m), ``dy`` (m, landing minus take-off COM level of the new motion).
    ``times_ms``: per stage, ``runtime_total`` (sum of run-time stages),
    ``loop_search`` (pre-processing, cached), ``preprocess_total``, ``evaluate``.
    Seams: ``seam_retimed`` (eq. 5.22 non-uniform retiming across the seams, section
    5.4.2.2), ``seam_speed_min``/``seam_speed_max`` (the playback-speed range it used; 1 = none).
    ``L_profile_deviation_max``/``_rms``: ``|L|`` of each new flight frame relative to ``k`` times the
    original's ``|L|`` at the source frame it shows, minus 1 (0 = the edit left the momentum
    profile as captured; seams, joins and the interpolation of retiming show up here).
    """

    flips: int | None
    requested_rotation: float | None
    target_rotation: float
    original_rotation: float
    achieved_rotation: float
    rotation_error: float
    r: int
    copies_used: int
    phi: float
    phi_S: float
    phi_E: float
    m: int
    n: int
    f: int
    f_copy: int
    g: int
    loop_distance: float
    loop_mean_angle: float
    landing_distance: float
    join_twist: float
    loop_found: bool
    k: float
    k_star: float
    k_ratio: float
    T_original: float
    T_sequenced: float
    T_new: float
    gravity: float
    gravity_scale: float
    L_original: float
    L_new: float
    L_variation_original: float
    L_variation_new: float
    L_std_original: float
    L_std_new: float
    L_range_original: float
    L_range_new: float
    L_direction_change: float
    com_residual_rms: float
    com_residual_max: float
    com_target_error: float
    takeoff_angle_original: float
    takeoff_angle_new: float
    takeoff_angle_change: float
    p_jump_takeoff: float
    p_jump_landing: float
    p_jump_takeoff_rel: float
    p_jump_landing_rel: float
    landing_orientation_error: float
    height_change: float
    dy: float
    times_ms: dict
    notes: tuple[str, ...] = ()
    seam_retimed: bool = False
    seam_speed_min: float = 1.0
    seam_speed_max: float = 1.0
    L_profile_deviation_max: float = float("nan")
    L_profile_deviation_rms: float = float("nan")
    takeoff_height_change: float = 0.0
    requested_extra: float | None = None
    gravity_fitted: float = float("nan")
    gravity_source: str = "clip"
    takeoff: str = "as-is"
    takeoff_velocity: str = "fit"
    velocity_jump_takeoff: tuple = (0.0, 0.0, 0.0)
    velocity_jump_landing: tuple = (0.0, 0.0, 0.0)
    repairs: tuple = ()

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["notes"] = list(self.notes)
        return d

    def to_json(self, path=None, indent: int = 2) -> str:
        def clean(v):
            if isinstance(v, float) and not np.isfinite(v):
                return None
            if isinstance(v, (np.floating, np.integer)):
                return v.item()
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            return v

        text = json.dumps(clean(self.to_dict()), indent=indent)
        if path is not None:
            from pathlib import Path

            Path(path).write_text(text + "\n")
        return text

    def __str__(self) -> str:
        t = self.times_ms
        req = f"{self.requested_rotation:.0f}" if self.requested_rotation is not None else "-"
        req += " deg" + (f" ({self.requested_extra:.0f} extra)" if self.requested_extra is not None else "")
        lines = [
            f"rotation about L: requested {req}, target {self.target_rotation:.1f}, achieved "
            f"{self.achieved_rotation:.1f} (error {self.rotation_error:+.2f}); original {self.original_rotation:.1f}",
            f"sequencing: loop m={self.m} n={self.n} phi={self.phi:.1f} deg ({'self-looping' if self.loop_found else 'FALLBACK'}"
            f", mean mismatch {self.loop_mean_angle:.1f} deg), r={self.r}, copies used {self.copies_used}, "
            f"landing join f={self.f} (copy {self.f_copy}) ~ g={self.g} (D={self.landing_distance:.3f}, "
            f"twist {self.join_twist:+.2f} deg spread)",
            f"retiming: k={self.k:.3f}, k*={self.k_star:.3f} (k/k*={self.k_ratio:.2f}); flight "
            f"{self.T_original:.3f} s -> {self.T_sequenced:.3f} s sequenced -> {self.T_new:.3f} s; new flight falls with "
            f"g = {self.gravity:.2f} m/s^2 ({self.gravity_source}); the input's flight fits {self.gravity_fitted:.2f} "
            f"(s={self.gravity_scale:.2f}, a diagnostic)",
            f"angular momentum |L|: {self.L_original:.2f} -> {self.L_new:.2f} kg m^2/s; variation over the flight "
            f"{100 * self.L_variation_original:.1f}% -> {100 * self.L_variation_new:.1f}% of the mean at most (std "
            f"{100 * self.L_std_original:.1f}% -> {100 * self.L_std_new:.1f}%, peak to peak {100 * self.L_range_original:.1f}%"
            f" -> {100 * self.L_range_new:.1f}%), direction change "
            f"{self.L_direction_change:.1f} deg; against k x the original's |L| at the frames shown: max "
            f"{100 * self.L_profile_deviation_max:.1f}%, rms {100 * self.L_profile_deviation_rms:.1f}%",
            f"COM: residual about a ballistic fit rms {1e3 * self.com_residual_rms:.3f} mm, max "
            f"{1e3 * self.com_residual_max:.3f} mm; max distance to eq. 5.15/5.17 {1e3 * self.com_target_error:.2e} mm",
            f"take-off ({self.takeoff}, flight from the {self.takeoff_velocity} take-off velocity): angle "
            f"{self.takeoff_angle_original:.1f} -> {self.takeoff_angle_new:.1f} deg (change "
            f"{self.takeoff_angle_change:+.1f}); planned COM velocity jump {_vec(self.velocity_jump_takeoff)} m/s at "
            f"take-off, {_vec(self.velocity_jump_landing)} at landing"
            + ("; repaired in the stance, so the planned linear momentum jump is " if self.repairs else
               "; planned linear momentum jump ")
            + f"{self.p_jump_takeoff:+.2f} kg m/s ({100 * self.p_jump_takeoff_rel:+.1f}%) at take-off, "
            f"{self.p_jump_landing:+.2f} ({100 * self.p_jump_landing_rel:+.1f}%) at landing",
            f"landing: final root orientation differs from the original's by {self.landing_orientation_error:.2f} deg; "
            f"height change {self.height_change:+.3f} m at landing, {self.takeoff_height_change:+.3f} m at take-off "
            f"(landing {self.dy:+.3f} m from the take-off level)",
            "times (ms): " + ", ".join(f"{k} {v:.3f}" for k, v in t.items()),
        ]
        if self.seam_retimed:
            lines.insert(3, f"seams: |L| kept at the original's by non-uniform retiming (eq. 5.22), playback speed "
                            f"{self.seam_speed_min:.2f}-{self.seam_speed_max:.2f}x over the seam windows")
        for r in self.repairs:
            lines.append("repair: " + _repair_text(r))
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


def _vec(v) -> str:
    v = np.asarray(v, dtype=float)
    return f"{np.linalg.norm(v):.2f} (vertical {v[1]:+.2f})"


def _repair_text(d: dict) -> str:
    from .takeoff import StanceRepair

    fields = {k: d[k] for k in StanceRepair.__dataclass_fields__}
    fields["frames"] = tuple(fields["frames"])
    return StanceRepair(**fields).describe()


@dataclass(frozen=True, eq=False)
class MultiFlipResult:
    """A generated multi-flip and its evidence.

    Attributes
    ----------
    motion: the new :class:`Motion` (same skeleton and frame rate as the input).
    original: the input as used (``prepared.motion``).
    prepared: the :class:`PreparedFlip`.
    sequence: the frame plan (:class:`~mocomp.flips.sequence.Sequence`).
    plan: the retiming decision (:class:`~mocomp.flips.retime.RetimePlan`).
    trajectory: the new flight's COM trajectory (:class:`FlightTrajectory`).
    seq_positions: ``(T_new,)`` position in the sequence shown by each output frame.
    flight: ``(start, stop)`` output frames on the new flight.
    report: the :class:`PhysicsReport` (``None`` when ``evaluate=False``).
    timings: seconds per run-time stage.
    seq_times: ``(T_new,)`` warped sequence time (in original frames) of each output frame (the
        retiming acts on warped time, see :mod:`mocomp.flips.smoothing`): ``i k`` when uniform, else
        :attr:`warp`'s source positions (the flight at ``k``, the stances eased to 1).
    takeoff_time: warped sequence time of the take-off frame (output time: :attr:`takeoff_seconds`).
    warp: the :class:`~mocomp.flips.retime.TimeWarp` used (``ease=0``: rate ``k`` everywhere).
    landing: what ``landing="auto"`` did (:func:`mocomp.edit.landing.match_landing_velocity`'s info), or
        ``None`` where it did not apply (a ballistic input flight, ``landing="as-is"``, ``takeoff="repair"``).
    speed: ``(T*,)`` eq. 5.22 playback speed per sequence frame (``None`` without seam retiming).
    repairs: the :class:`~mocomp.flips.takeoff.StanceRepair` of each repaired event
        (``takeoff="repair"``; empty otherwise).
    """

    motion: Motion
    original: Motion
    prepared: PreparedFlip
    sequence: Sequence
    plan: RetimePlan
    trajectory: FlightTrajectory
    seq_positions: np.ndarray
    flight: tuple[int, int]
    report: PhysicsReport | None
    timings: dict
    momentum: object = field(default=None, repr=False)
    seq_times: np.ndarray | None = field(default=None, repr=False)
    takeoff_time: float | None = None
    speed: np.ndarray | None = field(default=None, repr=False)
    repairs: tuple = ()
    warp: object = field(default=None, repr=False)
    landing: dict | None = field(default=None, repr=False)

    @property
    def takeoff_seconds(self) -> float:
        """Output time (s) of the take-off (:attr:`warp`'s; ``takeoff_time / (k fps)`` when uniform)."""
        if self.warp is not None:
            return float(self.warp.takeoff_output) / self.prepared.fps
        t = self.sequence.takeoff if self.takeoff_time is None else self.takeoff_time
        return float(t) / (self.plan.k * self.prepared.fps)

    @property
    def runtime_seconds(self) -> float:
        return float(sum(self.timings[s] for s in RUNTIME_STAGES))


def multiflip(prepared: PreparedFlip, flips: int | None = 2, *, k: float | None = None,
              k_ratio: float | None = None, height_change: float = 0.0, extra_rotation: float | None = None,
              window: int | None = None, evaluate: bool = True, max_delta: float | None = None,
              seam_retime: bool = True, takeoff_height_change: float = 0.0, gravity="standard",
              takeoff: str = "as-is", takeoff_velocity: str = "measured",
              repair_options: dict | None = None, ease: float = EASE_S, landing: str = "auto") -> MultiFlipResult:
    """Turn a prepared single flip into a ``flips``-somersault jump (section 5).

    Parameters
    ----------
    prepared: from :func:`~mocomp.flips.prepare`.
    flips: total somersaults (>= 2); or give ``extra_rotation`` (radians about ``L``) instead.
    k: explicit retiming factor (``> 1`` faster); default ``k_ratio * k*`` with ``k_ratio = 1``:
        ``k = k*`` (App. B eq. B.5), the one factor whose flight leaves with the velocity the
        retimed take-off reaches. ``k_ratio = 0.7`` is the paper's aesthetic choice (section 5.3,
        "higher jumps with slower rotations"): its flight needs about twice the vertical take-off
        speed, so the COM velocity jumps at take-off and landing (the note states the planned jump,
        the audit of the written frames measures it), unless ``takeoff="repair"``. Give one of
        ``k`` and ``k_ratio``.
    gravity: what the new flight falls with: ``"standard"`` (default; 9.81 m/s^2,
        :data:`~mocomp.dynamics.constants.G_STANDARD`, after the loaders' known frame-rate
        corrections), ``"clip"`` (the gravity fitted to the input's flight, the behaviour before
        issue #13: 11.8 m/s^2 on CMU 88_01, 7.6 on the DeepMimic back flip) or a number in m/s^2
        (:func:`~mocomp.flips.retime.resolve_gravity`). The fitted gravity stays in the report
        (``gravity_fitted``), with a note when it is implausible for the frame rate.
    takeoff: ``"as-is"`` (default: the paper's method; at ``k != k*`` the velocity jumps) or
        ``"repair"`` (beyond the paper, :mod:`mocomp.flips.takeoff`): the last ground frames before
        take-off and the first after landing are reshaped by a root displacement map, the feet held
        planted by the leg IK, so the COM reaches the new flight's velocity within the stance
        (``repair_options``: keyword arguments of :func:`~mocomp.flips.takeoff.repair_stance`, e.g.
        ``max_force``). Raises :class:`~mocomp.flips.takeoff.StanceRepairError` naming the frames and
        the force or depth needed when the stance cannot do it.
    takeoff_velocity: ``"measured"`` (default): the new flight leaves with ``k`` times the COM
        velocity the input has at its take-off frame (a local quadratic fit over
        :data:`~mocomp.flips.reposition.EVENT_HALF_WIDTH_S` either side), so it continues the
        retimed take-off; ``"fit"``: eq. 5.15/5.17 as printed, the intercepts of the ballistic fit
        of the input's flight. The two agree on a ballistic input (synthetic back flip: 3.13 m/s both);
        on a non-ballistic one they do not (DeepMimic back flip: 1.74 m/s measured, 0.80 fitted, which
        made the COM velocity jump from 3.3 to 1.3 m/s at take-off at ``k = k*``).
    height_change: m, landing level change (negative = land lower, e.g. off a platform);
        App. B: the landing may rise above the take-off by less than ``v0 T``.
    takeoff_height_change: m, take-off level change (App. B's ``y_start^new``: the ground phase
        before the flight and the parabola's ``c_y`` move by it; positive = take off from higher up,
        e.g. a platform). ``dy^new = dy + height_change - takeoff_height_change`` enters k*.
        :func:`landing_change_for_k` gives the landing change for which ``k* = k`` (App. B: with
        ``k = 1`` no retiming is needed).
    window: seam smoothing half-window in frames (default ``prepared.default_window()``).
    evaluate: compute the physics report (momentum of the new motion; timed separately).
    max_delta: radians, largest rotation mismatch accepted at the landing join.
    seam_retime: non-uniform retiming across the seams (eq. 5.22 as section 5.4.2.2 prescribes for
        dissimilar adjoining frames; :mod:`mocomp.flips.smoothing`): frames whose ``|L|`` the seam
        smoothing changed are played faster or slower so ``|L|`` follows the original's. ``False``
        gives the plain uniform retiming by ``k``.
    ease: s of source time over which the play rate eases from the flight's ``k`` back to 1 in the
        stance before the take-off and after the landing (:class:`~mocomp.flips.retime.TimeWarp`;
        default :data:`~mocomp.flips.retime.EASE_S`, not beyond the clip's neighbouring flights,
        which keep their captured timing). ``0``: the paper's uniform retiming of the whole clip by
        ``k`` (every ground phase ``k`` times faster, its velocity jumps ``k`` times larger).
    landing: ``"auto"`` (default): when the input flight is not ballistic (its measured take-off
        velocity more than :data:`~mocomp.edit.linear.TAKEOFF_TOL` from its ballistic fit's, or its
        fitted gravity more than :data:`~mocomp.edit.pipeline.NONBALLISTIC_G_TOL` from the new
        flight's), the landing stance is decelerated from the parabola's arrival velocity as ``mocomp
        edit`` does (:func:`mocomp.edit.landing.match_landing_velocity`, keeping the input's own
        landing impact, ``k`` times; beyond the paper); ``"as-is"``: the paper's. Not applied with
        ``takeoff="repair"``, which repairs the landing itself.
    """
    P = prepared
    fps = P.fps
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    seq = build_sequence(P.rotations, P.theta, P.flight, P.loop, P.axis, P.weights, flips=flips,
                         extra_rotation=extra_rotation, omegas=P.omegas, max_delta=max_delta)
    t1 = time.perf_counter()
    timings["sequence"] = t1 - t0
    # ---------------------------------------------------------------- smooth
    src = seq.frames
    nseq = src.size
    rot = np.take(P.rotations, src, axis=0)                 # (nseq, J, 4) gathered copy, zero extra rotation
    w = P.default_window(seam_retime) if window is None else int(window)
    hi_u = seq.landing_seam + 1                             # repetitions end here (exclusive)
    if seq.loop_seams:
        left_blk, right_blk = P.loop_seam(w)
        for a in seq.loop_seams:
            rot[a - w:a + 1] = left_blk
            hi = min(a + 2 + w, hi_u)
            rot[a + 1:hi] = right_blk[:hi - a - 1]
    # landing seam f -> g+1 (pair f ~ g at f's instant): half the mismatch on each side with the
    # raised-cosine ramp (section 5.4.2.2); the root's part perpendicular to L only (eq. 5.14)
    a, g = seq.landing_seam, seq.join.g
    la, rb = max(a - w, 0), min(a + 2 + w, nseq)
    if not landing_seam_nb(rot, a, la, rb, w, P.rotations[g], P.bdir[g], P.axis, P.theta, src, P.root_ref):
        raise PhysicsError(f"{P.name}: landing seam after sequence frame {a}: the directions of L in the body "
                           f"frames of the two seam poses (frames {int(src[a])} and {g}) are opposite; no "
                           f"swing arc blends them. Choose another landing (a different number of flips or k).")
    # each frame's rotation about L (copies j*phi, landing extra, spread join correction), on the left
    if KERNELS:
        turn_roots_nb(rot, seq.extra, P.axis)
    else:
        rot[:, 0] = quat_multiply(axis_quat(P.axis, seq.extra), rot[:, 0])
    q_land = None
    if not _whole_turns(seq.extra_total):
        # an extra rotation that is not whole turns (e.g. a twist jump turned further): the ground
        # phase after the landing is turned about the vertical, not about a tilted L, so it stays
        # upright; the difference C = R_y R_L^-1 is spread linearly over the whole flight (a constant
        # extra angular velocity, the smallest one that does it: L stays constant in flight but tilts;
        # spread over the frames after the landing join only it tripled |L| there)
        q_L = axis_quat(P.axis, seq.extra_total)
        up = np.array([0.0, 1.0, 0.0])
        q_land = axis_quat(up, float(twist_angle(q_L, up)))
        C = quat_multiply(q_land, quat_inverse(q_L))
        j0, j1 = seq.takeoff, seq.landing
        lam = np.clip((np.arange(j0, nseq) - j0) / max(j1 - j0, 1), 0.0, 1.0)
        ident = np.zeros(4)
        ident[3] = 1.0
        rot[j0:, 0] = quat_multiply(slerp(np.broadcast_to(ident, (lam.size, 4)), np.broadcast_to(C, (lam.size, 4)),
                                          lam), rot[j0:, 0])
    upright_tilt = float(np.degrees(quat_angle(C))) if q_land is not None else 0.0
    speed = _seam_speeds(P, seq, rot, w, hi_u, la, rb) if seam_retime else None
    t2 = time.perf_counter()
    timings["smooth"] = t2 - t1
    # ---------------------------------------------------------------- retime
    fit = P.fit
    s, e = P.flight
    T0 = (e - 1 - s) / fps
    if speed is None:
        W = None
        W_to = float(seq.takeoff)
        T_seq = (seq.landing - seq.takeoff) / fps
    else:
        W = warp_time(speed)
        W_to = float(W[seq.takeoff])
        T_seq = float(W[seq.landing] - W_to) / fps
    com0 = P.com[s]
    com_land = P.com[e - 1]
    h0 = float(takeoff_height_change)
    dy = float(com_land[1] - com0[1] + height_change - h0)
    g_used, g_source = resolve_gravity(gravity, fit.gravity)
    if takeoff not in TAKEOFF_CHOICES:
        raise ValueError(f"takeoff must be one of {', '.join(TAKEOFF_CHOICES)}, got {takeoff!r}")
    if takeoff_velocity == "measured":
        v_to = event_velocity(P.com, s, fps)
        v_ld = event_velocity(P.com, e - 1, fps)
    elif takeoff_velocity == "fit":
        v_to = np.array([fit.a_x, fit.b_y, fit.a_z])
        v_ld = np.array([fit.a_x, fit.b_y + 2.0 * fit.a_y * T0, fit.a_z])
    else:
        raise ValueError(f"takeoff_velocity must be 'measured' or 'fit', got {takeoff_velocity!r}")
    v0, v_land = float(v_to[1]), float(v_ld[1])
    try:
        plan = plan_retime(g_used, T_seq, v0, dy, v_land, k=k, k_ratio=k_ratio,
                           v_horizontal=float(np.hypot(v_to[0], v_to[2])))
    except PhysicsError as exc:
        if "radicand" not in str(exc):
            raise
        own = dy - height_change + h0
        limit = v0 * T_seq - own + h0
        raise PhysicsError(
            f"impossible height change (landing {height_change:+.3f} m, take-off {h0:+.3f} m) for a {flips}-flip from "
            f"this clip: k* (App. B) needs the landing less than v0*T = {v0 * T_seq:.3f} m above the take-off "
            f"(v0 = {v0:.3f} m/s, sequenced flight T = {T_seq:.3f} s); the clip already lands {own:+.3f} m from "
            f"its take-off level, so use --height-change below {limit:.3f} m (or raise the take-off with "
            f"--takeoff-height-change, or give an explicit --k)") from None
    kk = plan.k
    W_land = float(seq.landing) if W is None else float(W[seq.landing])
    if ease:
        # the flight at k, the stances eased back to the captured rate (retime.TimeWarp), other
        # flights of the clip (hops before or after) played as captured
        Wt = np.arange(nseq, dtype=float) if W is None else W
        s, e = P.flight
        others = [(int(f.start), int(f.stop)) for f in P.detection.flights if (int(f.start), int(f.stop)) != (s, e)]
        prev_end = max([b for a, b in others if b <= s], default=0)
        next_start = min([a for a, b in others if a >= e], default=P.motion.n_frames)
        pre = np.flatnonzero((np.arange(nseq) < seq.takeoff) & (src >= prev_end))
        post_ = np.flatnonzero((np.arange(nseq) > seq.landing) & (src < next_start))
        lo = float(Wt[pre[0]]) if pre.size else W_to
        hi = float(Wt[post_[-1]]) if post_.size else W_land
        r0, r1 = ease_limits(fps, W_to, W_land, lo, hi, float(ease))
        warp = TimeWarp.build(kk, W_to, W_land, float(Wt[-1]), r0, r1)
        tw = warp.source_positions()
        tau = tw if W is None else np.interp(tw, W, np.arange(nseq, dtype=float))
    else:
        warp = TimeWarp.build(kk, W_to, W_land, float(nseq - 1) if W is None else float(W[-1]), 0.0, 0.0)
        if W is None:
            tau = sample_positions(nseq, kk)
            tw = tau
        else:
            tw, tau = warped_positions(W, kk)
    u_to, u_land = warp.takeoff_output, warp.landing_output
    i0 = np.minimum(np.floor(tau).astype(int), nseq - 2)
    al = tau - i0
    if KERNELS:
        rot_out, unit = slerp_gather_nb(rot, i0, al)
    else:
        rot_out, unit = slerp(rot[i0], rot[i0 + 1], al[:, None], nlerp_below=0.1), False
    t3 = time.perf_counter()
    timings["retime"] = t3 - t2
    # ------------------------------------------------------------- reposition
    rp_seq = np.take(P.motion.root_positions, src, axis=0)
    if h0:                                                          # App. B: the take-off level y_start^new
        com0 = com0 + np.array([0.0, h0, 0.0])
        rp_seq[:seq.takeoff + 1, 1] += h0
    traj = flight_trajectory(com0, float(v_to[0]), float(v_to[2]), -0.5 * g_used, kk, plan.vy_takeoff_new, plan.T_new)
    post = seq.landing + 1
    end = traj.end
    if q_land is None:
        rp_seq[post:] += end - com_land                              # eq. 5.16 (offset incl. height)
    else:                                                           # turned about the vertical
        rp_seq[post:] = quat_apply(q_land, rp_seq[post:] - com_land) + end
    # the last flight frame where the parabola ends, so output frames between it and the first
    # ground frame interpolate between two repositioned roots
    rp_seq[seq.landing] = end - P.com_eval.relative(rot[seq.landing:seq.landing + 1])[0]
    fl = np.flatnonzero((tau >= seq.takeoff - 1e-9) & (tau <= seq.landing + 1e-9))
    f0, f1 = int(fl[0]), int(fl[-1]) + 1
    if fl.size != f1 - f0:                                          # tau is non-decreasing: cannot happen
        raise AssertionError("retimed flight frames are not contiguous")
    if KERNELS:                                                     # the same operations, compiled
        root_out, finite = reposition_nb(rp_seq, i0, al, writable(tw, np.float64), f0, f1, W_to, kk * fps, traj,
                                         rot_out, P.com_eval)
    else:
        r0 = np.take(rp_seq, i0, axis=0)
        root_out = r0 + al[:, None] * (np.take(rp_seq, i0 + 1, axis=0) - r0)
        tf = (tw[f0:f1] - W_to) / (kk * fps)
        root_out[f0:f1] = traj(tf) - P.com_eval.relative(rot_out[f0:f1])  # a view, no gather
        finite = bool(np.isfinite(root_out).all())
    t4 = time.perf_counter()
    timings["reposition"] = t4 - t3
    # --------------------------------------------------------------- assemble
    source = _generated_source(P, f"multi-flip ({flips if flips else 'extra rotation'}) by mocomp.flips from "
                                  f"{P.name}: k={kk:.3f}")
    if unit and finite:
        new = _fresh_motion(P.motion, root_out, rot_out, source)
    else:                                                           # Motion's own checks (and its errors)
        new = P.motion.replace(root_positions=root_out, rotations=rot_out, source=source)
    t5 = time.perf_counter()
    timings["assemble"] = t5 - t4
    flight_out = (f0, f1)
    repairs: tuple = ()
    if landing not in ("auto", "as-is"):
        raise ValueError(f"landing must be 'auto' or 'as-is', got {landing!r}")
    if takeoff == "repair":
        new, repairs = _repair(P, seq, new, traj, kk, tau, u_to, u_land, v_to, v_ld, q_land, g_used, repair_options)
        timings["repair"] = time.perf_counter() - t5
    landing_info = None
    smoothed: tuple = ()
    if landing == "auto" and takeoff != "repair" and not _ballistic(P, v_to, g_used):
        t6 = time.perf_counter()
        new, landing_info = _match_landing(P, new, traj, kk, u_land, g_used)
        timings["landing"] = time.perf_counter() - t6
    if takeoff == "smooth":
        t6 = time.perf_counter()
        new, smoothed = _smooth(P, seq, new, traj, kk, tau, u_to, u_land, q_land, g_used, landing == "auto")
        timings["stances"] = time.perf_counter() - t6
    report, mom = None, None
    if evaluate:
        report, mom = _evaluate(P, seq, plan, traj, new, flight_out, timings, height_change, dy, flips,
                                extra_rotation, W_to, speed, tau, w, h0, upright_tilt,
                                gravity_info=(g_used, g_source, fit.gravity), takeoff=takeoff, repairs=repairs,
                                takeoff_velocity=takeoff_velocity, v_to=v_to, v_ld=v_ld, W_land=W_land, q_land=q_land,
                                u_to=u_to, landing_info=landing_info, smoothed=smoothed)
    return MultiFlipResult(motion=new, original=P.motion, prepared=P, sequence=seq, plan=plan, trajectory=traj,
                           seq_positions=tau, flight=flight_out, report=report, timings=timings, momentum=mom,
                           seq_times=tw, takeoff_time=W_to, speed=speed, repairs=repairs, warp=warp,
                           landing=landing_info)


def _ballistic(P: PreparedFlip, v_to: np.ndarray, g: float) -> bool:
    """The input flight meets its stances as a ballistic flight of gravity ``g`` would: its measured
    take-off velocity within :data:`~mocomp.edit.linear.TAKEOFF_TOL` of its ballistic fit's (any
    component) and its fitted gravity within :data:`~mocomp.edit.pipeline.NONBALLISTIC_G_TOL` of ``g``
    (the synthetic flips: yes; the DeepMimic back flip: 1.74 m/s measured, 0.80 fitted, no)."""
    from ..edit.linear import TAKEOFF_TOL
    from ..edit.pipeline import NONBALLISTIC_G_TOL

    fit = P.fit
    fitted = np.array([fit.a_x, fit.b_y, fit.a_z], dtype=float)
    return bool(np.max(np.abs(np.asarray(v_to, dtype=float) - fitted)) <= TAKEOFF_TOL
                and abs(float(fit.gravity) - float(g)) <= NONBALLISTIC_G_TOL)


def _match_landing(P: PreparedFlip, new: Motion, traj: FlightTrajectory, k: float, u_land: float, g: float):
    """``landing="auto"``: :func:`mocomp.edit.landing.match_landing_velocity` on the landing stance
    (the parabola's arrival velocity, the input's own landing impact ``k`` times, the floor the
    output lands on). Returns ``(motion, info)``."""
    from ..edit.landing import floor_level, lowest_heights, match_landing_velocity, own_landing_jump

    arrival = np.array(traj.velocity, dtype=float)
    arrival[1] += 2.0 * traj.a_y * traj.T_new
    first = int(np.floor(u_land)) + 1
    if first >= new.n_frames:
        return new, None
    floor = floor_level(lowest_heights(new, first), new.fps)
    com_in = P.com_eval(P.motion.root_positions, P.motion.rotations)
    own = k * own_landing_jump(com_in, P.flight[1] - 1, P.fps)
    return match_landing_velocity(new, P.com_eval, float(u_land), arrival, floor, g=g, mode="auto", own_jump=own,
                                  body=P.body)


def event_jumps(traj: FlightTrajectory, k: float, v_to: np.ndarray, v_ld: np.ndarray, q_land=None):
    """Planned COM velocity jumps ``(3,)`` m/s at take-off and landing: the new flight's velocity
    minus the ``k``-retimed stance's (``k v_to`` before take-off; ``k v_ld`` after landing, turned by
    ``q_land`` when the landing phase is turned about the vertical)."""
    up = traj.velocity - k * np.asarray(v_to, dtype=float)
    v_end = np.array(traj.velocity, dtype=float)
    v_end[1] += 2.0 * traj.a_y * traj.T_new
    ground = k * np.asarray(v_ld, dtype=float)
    if q_land is not None:
        ground = quat_apply(q_land, ground)
    return up, v_end - ground


def _stances(P, seq, tau):
    """``(before, after)``: the output frames of the stance before the take-off and after the landing,
    bounded by the clip's other flights (``tau``: the sequence position of every output frame)."""
    src = seq.frames[np.clip(np.rint(tau).astype(int), 0, seq.n_frames - 1)]
    s, e = P.flight
    others = [(int(f.start), int(f.stop)) for f in P.detection.flights if (int(f.start), int(f.stop)) != (s, e)]
    prev_end = max([b for a, b in others if b <= s], default=0)
    next_start = min([a for a, b in others if a >= e], default=P.motion.n_frames)
    before = np.flatnonzero((tau < seq.takeoff) & (src >= prev_end))
    after = np.flatnonzero((tau > seq.landing) & (src < next_start))
    return before, after


def _smooth(P, seq, new, traj, kk, tau, u_to, u_land, q_land, g, land: bool):
    """``takeoff="smooth"`` (default; beyond the paper): :func:`~mocomp.flips.takeoff.smooth_stance` on the
    stance before the take-off and, with ``land``, after the landing: the frames next to the event
    get the captured push's (impact's) acceleration instead of ``k^2`` times it, the velocity that
    leaves out made up by a longer push (a deeper give); at the landing the stance also takes the
    part of the arrival velocity the input's own impact does not remove (the flight arrives ``k``
    times faster; a non-ballistic input's parabola arrives with yet another velocity). Returns
    ``(motion, infos)``."""
    from .takeoff import LANDING_MAX_FORCE, _event_jump, audit_com, smooth_stance

    before, after = _stances(P, seq, tau)
    s, e = P.flight
    key = "runtime:audit_com"
    got = P._cache.get(key)
    if got is None or got[0] is not P.motion:               # per clip: the audit's body, the input's COM with it
        ce = audit_com(P.motion)
        got = (P.motion, ce, ce(np.asarray(P.motion.root_positions), np.asarray(P.motion.rotations)))
        P._cache[key] = got
    _, ce, com_in = got
    infos = []
    if before.size >= 4:
        new, info = smooth_stance(new, ce, "take-off", float(u_to), (int(before[0]), int(before[-1]) + 1),
                                  g=g, body=P.body, target_jump=_event_jump(com_in, P.fps, s - 0.5))
        infos.append(info)
    if land and after.size >= 4:
        new, info = smooth_stance(new, ce, "landing", float(u_land), (int(after[0]), int(after[-1]) + 1),
                                  g=g, body=P.body, max_force=LANDING_MAX_FORCE,
                                  target_jump=_event_jump(com_in, P.fps, e - 0.5))
        infos.append(info)
    return new, tuple(infos)


def _repair(P, seq, new, traj, kk, tau, u_to, u_land, v_to, v_ld, q_land, g, options):
    """``takeoff="repair"``: :func:`~mocomp.flips.takeoff.repair_stance` at take-off and landing
    (stances bounded by the clip's other flights)."""
    from .takeoff import repair_stance

    opts = dict(options or {})
    up, down = event_jumps(traj, kk, v_to, v_ld, q_land)
    before, after = _stances(P, seq, tau)
    repairs = []
    for event, jump, frames, t_ev in (("take-off", up, before, u_to), ("landing", down, after, u_land)):
        if float(np.linalg.norm(jump)) < 1e-3 or frames.size == 0:
            continue
        new, rep = repair_stance(new, P.com_eval, event, t_ev, jump, (int(frames[0]), int(frames[-1]) + 1), g=g,
                                 body=P.body, **opts)
        repairs.append(rep)
    return new, tuple(repairs)


def landing_change_for_k(prepared: PreparedFlip, flips: int | None = 2, k: float = 1.0, *,
                         takeoff_height_change: float = 0.0, **options) -> float:
    """App. B: the landing-level change (m, for ``height_change``) that makes ``k* = k``, from
    ``k*^2 = (g T / 2) / (v0 - dy / T)``: ``dy = T (v0 - g T / (2 k^2))``. With ``k = 1`` "we can
    even eliminate the need for retiming by appropriately changing the take-off and landing
    levels": the multi-flip keeps the original's speed and lands that much lower (a platform).
    ``options`` are :func:`multiflip`'s (sequencing and seam retiming fix ``T``)."""
    if not (np.isfinite(k) and k > 0):
        raise ValueError(f"k must be positive, got {k!r}")
    res = multiflip(prepared, flips, k=1.0, evaluate=False, takeoff_height_change=takeoff_height_change, **options)
    T, v0, g = res.plan.T_seq, res.plan.v0, res.plan.g
    return float(T * (v0 - g * T / (2.0 * k * k)) - res.plan.dy)


def _seam_speeds(P: PreparedFlip, seq: Sequence, rot: np.ndarray, w: int, hi_u: int, la: int, rb: int) -> np.ndarray:
    """``(nseq,)`` eq. 5.22 playback speeds (1 away from seams): the loop seam's profile, computed
    once per clip (:meth:`PreparedFlip.loop_seam_speed`), pasted at every loop seam; the landing
    seam's from the ``|L|`` of its smoothed frames (``rot``, final rotations at the sequence's
    timing) against the original's (:mod:`mocomp.flips.smoothing`)."""
    nseq = rot.shape[0]
    speed = np.ones(nseq)
    if seq.loop_seams:
        sl, sr = P.loop_seam_speed(w)
        for a in seq.loop_seams:
            lo = a - w - 1
            speed[max(lo, 0):a + 1] = sl[max(-lo, 0):]
            hi = min(a + 3 + w, hi_u)
            if hi > a + 1:
                speed[a + 1:hi] = sr[:hi - a - 1]
    # landing seam: frames la .. rb-1 were smoothed; their neighbours' central differences reach in
    lo, hi = max(la - 2, 0), min(rb + 2, nseq)
    if hi - lo >= 3:
        a, f, g = seq.landing_seam, seq.join.f, seq.join.g
        L0 = P.L_magnitude
        lev_l, lev_r = float(L0[f]), float(L0[g])
        mid = float(np.sqrt(lev_l * lev_r))
        if KERNELS:                                                 # compiled, the same steps as below
            E = P.momentum_evaluator
            ax_unit, L_ang = _landing_speed_constants(P)
            speed[lo + 1:hi - 1] = _landing_speed_nb(
                rot, lo, hi, E.parents, E.offsets, E.seg_joint, E.local_coms, E.masses, E.inertias, float(P.fps),
                writable(seq.frames, np.int64), writable(seq.extra, np.float64), ax_unit,
                L_ang, int(a), int(w), lev_l, lev_r, mid, *SPEED_BOUNDS)
            return speed
        L_new = P.momentum_evaluator.angular(rot[lo:hi], P.fps)
        idx = np.arange(lo + 1, hi - 1)
        src = seq.frames[idx]
        left = idx <= a
        # the original's L at the frames shown, turned with them about L, its level blended across the seam
        ref = quat_apply(axis_quat(P.axis, seq.extra[idx]), np.asarray(P.momentum.angular)[src])
        if lev_l > 0 and lev_r > 0:
            ref *= (np.where(left, mid / lev_l, mid / lev_r) ** ramp(np.abs(idx - a), w))[:, None]
        speed[idx] = seam_speed(L_new, ref)
    return speed


def _landing_speed_constants(P: PreparedFlip) -> tuple[np.ndarray, np.ndarray]:
    """Per-clip inputs of the compiled landing-seam speeds, made once and kept in the prepared
    clip's cache (they depend only on ``P``): the unit axis of ``L`` and a writable copy of the
    clip's angular momentum (the kernel reads it; the prepared arrays are read-only)."""
    key = "runtime:landing_speed_constants"
    got = P._cache.get(key)
    if got is None or got[0] is not P.momentum:
        ax = np.asarray(P.axis, dtype=float)
        got = (P.momentum, ax / np.linalg.norm(ax), np.array(P.momentum.angular, dtype=float))
        P._cache[key] = got
    return got[1], got[2]


def _generated_source(P: PreparedFlip, note: str):
    """``P.motion.source`` marked ``generated`` with ``note`` appended (the new motion's
    :class:`~mocomp.core.motion.SourceInfo`, frozen); the last one made is kept in the prepared
    clip's cache, since repeated run-time calls with the same ``k`` make the same one."""
    key = "runtime:source"
    base = P.motion.source
    got = P._cache.get(key)
    if got is not None and got[0] is base and got[1] == note:
        return got[2]
    source = dataclasses.replace(base, format="generated", notes=base.notes + (note,))
    P._cache[key] = (base, note, source)
    return source


def _fresh_motion(template: Motion, root_positions: np.ndarray, rotations: np.ndarray, source) -> Motion:
    """``template.replace(root_positions=..., rotations=..., source=...)`` without :class:`Motion`'s
    defensive copy and validation (:meth:`Motion.replace_trusted`): the run-time stage made the
    arrays with the right shapes, checked the root positions finite, and the compiled slerp
    normalised every rotation and reported it finite and non-zero. The result equals the checked
    construction (tested)."""
    return template.replace_trusted(root_positions, rotations, source)


def _whole_turns(angle: float) -> bool:
    return abs(np.remainder(angle + np.pi, 2 * np.pi) - np.pi) < 1e-9


def _tail(side, n):
    return dataclasses.replace(side, weights=side.weights[-n:])


def _head(side, n):
    return dataclasses.replace(side, weights=side.weights[:n])


def _ballistic_residual(com: np.ndarray, fps: float) -> tuple[float, float]:
    from .mass import fit_ballistic

    f = fit_ballistic(com, fps)
    return f.rms, f.max


def _evaluate(P: PreparedFlip, seq: Sequence, plan: RetimePlan, traj: FlightTrajectory, new: Motion,
              flight_out: tuple[int, int], timings: dict, height_change: float, dy: float, flips, extra_rotation,
              W_to: float | None = None, speeds: np.ndarray | None = None, tau: np.ndarray | None = None,
              window: int | None = None, takeoff_height_change: float = 0.0, upright_tilt: float = 0.0, *,
              gravity_info=None, takeoff: str = "as-is", repairs=(), takeoff_velocity: str = "fit", v_to=None,
              v_ld=None, W_land=None, q_land=None, u_to=None, landing_info=None, smoothed=()):
    from ..dynamics import momentum as compute_momentum

    t = time.perf_counter()
    fps = P.fps
    mom = compute_momentum(P.body, new, smooth_sigma=P.smooth_sigma)
    a, b = flight_out
    Lo, Ln = P.L_stats, flight_L_stats(mom.angular, a, b)
    # mean L direction of the new flight, compared after undoing nothing (rotation about L keeps L)
    ia, ib = Ln["frames"]
    Ld = mom.angular[ia:ib].mean(axis=0)
    dir_change = float(np.degrees(np.arccos(np.clip(Ld @ P.axis / max(np.linalg.norm(Ld), 1e-12), -1, 1))))
    # |L| against the original's at the source frame shown, times k (how far the editing moved it)
    if tau is None:
        tau = np.minimum(np.arange(new.n_frames) * plan.k, seq.n_frames - 1.0)
    ii = np.arange(ia, ib)
    src = seq.frames[np.clip(np.rint(tau[ii]).astype(int), 0, seq.n_frames - 1)]
    prof = np.linalg.norm(mom.angular[ii], axis=1) / (plan.k * P.L_magnitude[src]) - 1.0
    com = mom.com[a:b]
    rms, mx = _ballistic_residual(com, fps)
    W_to = float(seq.takeoff) if W_to is None else W_to
    u_to = W_to / plan.k if u_to is None else float(u_to)         # output frame of the take-off
    tt = (np.arange(a, b) - u_to) / fps
    target_err = float(np.max(np.linalg.norm(com - traj(tt), axis=1)))
    theta_new, _ = split_root(new.rotations[:, 0], P.axis, ref=P.root_ref)
    achieved = float(theta_new[-1] - theta_new[0])
    orig = P.total_rotation
    fit = P.fit
    if v_to is None:
        v_to = np.array([fit.a_x, fit.b_y, fit.a_z])
    if v_ld is None:
        v_ld = np.array([fit.a_x, fit.b_y + 2.0 * fit.a_y * (P.flight[1] - 1 - P.flight[0]) / fps, fit.a_z])
    vh = np.hypot(v_to[0], v_to[2])
    ang0 = float(np.degrees(np.arctan2(v_to[1], vh)))
    ang1 = float(np.degrees(np.arctan2(plan.vy_takeoff_new, plan.k * vh)))
    M = P.body.total_mass
    jump_up, jump_down = event_jumps(traj, plan.k, v_to, v_ld, q_land)
    repaired = {r.event for r in repairs}
    g_used, g_source, g_fit = gravity_info if gravity_info is not None else (plan.g, "clip", fit.gravity)
    q_end = new.rotations[-1, 0]
    q_ref = P.motion.rotations[-1, 0]
    land_err = float(np.degrees(quat_angle(quat_multiply(q_end, quat_inverse(q_ref)))))
    timings["evaluate"] = time.perf_counter() - t
    times = {k: 1e3 * v for k, v in timings.items()}
    times["runtime_total"] = 1e3 * sum(timings[s] for s in RUNTIME_STAGES)
    times["loop_search"] = 1e3 * P.timings.get("loop_search", float("nan"))
    times["preprocess_total"] = 1e3 * P.timings.get("total", float("nan"))
    notes = list(seq.notes) + list(P.notes)
    if plan.note:
        notes.append(plan.note if not repaired else
                     plan.note.split(": the linear momentum jumps")[0] + ": the jump is removed in the stance "
                     "(takeoff='repair', see the repair lines)")
    notes += _gravity_notes(P, g_used, g_source, g_fit)
    if landing_info is not None and landing_info.get("repaired"):
        r = landing_info["repair"]
        notes.append(f"the input flight is not ballistic, so the landing stance was decelerated from the new "
                     f"flight's arrival ({', '.join(f'{x:+.2f}' for x in landing_info['arrival_m_s'])}) m/s, keeping "
                     f"the input's own landing impact (landing='auto', --landing auto; beyond the paper): output "
                     f"frames {r['frames'][0]}-{r['frames'][1] - 1}, crouch up to {100 * -r['dip']:.1f} cm deeper, "
                     f"vertical ground force {r['min_force']:.2f}-{r['peak_force']:.2f} body weights")
    elif landing_info is not None and landing_info.get("note"):
        notes.append(landing_info["note"])
    notes += [n for n in (smoothed_stance_note(sm, "takeoff='smooth', --takeoff smooth") for sm in smoothed) if n]
    for r in repairs:
        if np.isfinite(r.zmp_outside_after) and r.zmp_outside_after > max(r.zmp_outside_before, 0.0) + 0.02:
            notes.append(f"the {r.event} repair moves the ZMP up to {100 * r.zmp_outside_after:.1f} cm outside the "
                         f"support polygon (before {100 * max(r.zmp_outside_before, 0.0):.1f} cm) over output frames "
                         f"{r.frames[0]}-{r.frames[1] - 1}")
    if upright_tilt > 0.05:
        notes.append(f"the extra rotation is not whole turns and L is {np.degrees(np.arccos(min(abs(P.axis[1]), 1.0))):.1f} "
                     f"deg from the vertical: to land upright the body is turned a further {upright_tilt:.1f} deg, "
                     "spread evenly over the flight, which tilts L (see the direction change)")
    if not P.loop.found:
        notes = [n for n in notes if n != P.loop.note]
        notes.append(f"fallback (section 5.2): {P.loop.note.split(';')[0]}; the copies were joined automatically by "
                     f"smoothing ({window} frames each side)"
                     + (" and |L| across the joins was adjusted by non-uniform retiming (eq. 5.22)"
                        if speeds is not None else "; seam retiming is off, so |L| is not constant across the joins"))
    req = 360.0 * flips if extra_rotation is None else None
    req_extra = 360.0 * (flips - 1) if extra_rotation is None else float(np.degrees(extra_rotation))
    rep = PhysicsReport(
        flips=int(flips) if extra_rotation is None else None, requested_rotation=req, requested_extra=req_extra,
        target_rotation=float(np.degrees(seq.target)), original_rotation=float(np.degrees(orig)),
        achieved_rotation=float(np.degrees(achieved)), rotation_error=float(np.degrees(achieved - seq.target)),
        r=seq.r, copies_used=int(seq.join.copy + 1), phi=float(np.degrees(P.loop.phi)),
        phi_S=float(np.degrees(seq.phi_S)), phi_E=float(np.degrees(seq.phi_E)), m=P.loop.m, n=P.loop.n,
        f=seq.join.f, f_copy=seq.join.copy, g=seq.join.g, loop_distance=P.loop.distance,
        loop_mean_angle=P.loop.mean_angle_deg, landing_distance=seq.join.distance,
        join_twist=float(np.degrees(seq.join.delta)), loop_found=P.loop.found,
        k=plan.k, k_star=plan.k_star, k_ratio=plan.k_ratio, T_original=(P.flight[1] - 1 - P.flight[0]) / fps,
        T_sequenced=plan.T_seq, T_new=plan.T_new, gravity=plan.g, gravity_scale=float(g_fit) / G_STANDARD,
        L_original=Lo["mean"], L_new=Ln["mean"], L_variation_original=Lo["variation"],
        L_variation_new=Ln["variation"], L_std_original=Lo["std"], L_std_new=Ln["std"],
        L_range_original=Lo["range"], L_range_new=Ln["range"],
        L_direction_change=dir_change, com_residual_rms=rms, com_residual_max=mx, com_target_error=target_err,
        takeoff_angle_original=ang0, takeoff_angle_new=ang1, takeoff_angle_change=ang1 - ang0,
        p_jump_takeoff=0.0 if "take-off" in repaired else M * plan.vy_takeoff_jump,
        p_jump_landing=0.0 if "landing" in repaired else M * plan.vy_landing_jump,
        p_jump_takeoff_rel=0.0 if "take-off" in repaired else plan.p_jump_takeoff_rel,
        p_jump_landing_rel=0.0 if "landing" in repaired else plan.p_jump_landing_rel,
        gravity_fitted=float(g_fit), gravity_source=str(g_source), takeoff=str(takeoff),
        takeoff_velocity=str(takeoff_velocity), velocity_jump_takeoff=tuple(float(x) for x in jump_up),
        velocity_jump_landing=tuple(float(x) for x in jump_down), repairs=tuple(r.to_dict() for r in repairs),
        landing_orientation_error=land_err, height_change=float(height_change), dy=dy, times_ms=times,
        notes=tuple(notes), seam_retimed=speeds is not None,
        L_profile_deviation_max=float(np.max(np.abs(prof))), L_profile_deviation_rms=float(np.sqrt(np.mean(prof ** 2))),
        takeoff_height_change=float(takeoff_height_change),
        seam_speed_min=float(speeds.min()) if speeds is not None else 1.0,
        seam_speed_max=float(speeds.max()) if speeds is not None else 1.0)
    return rep, mom


def _gravity_notes(P: PreparedFlip, g_used: float, source: str, g_fit: float) -> list[str]:
    """Notes on the input's fitted gravity: implausible for its frame rate (the likely error named,
    :func:`~mocomp.flips.mass.diagnose_gravity` and the clip's :class:`~mocomp.flips.mass.TimingDiagnosis`),
    or just different from the gravity the new flight falls with."""
    from .mass import diagnose_gravity

    notes = []
    timing = P.timing
    s = float(g_fit) / G_STANDARD
    flight_text = diagnose_gravity(s, P.fps)
    if timing is not None and not timing.consistent:
        notes.append(f"the input's fitted gravity is implausible: {timing.text}; the new flight falls with "
                     f"{g_used:.2f} m/s^2 ({source}) but the ground phases keep the clip's timing")
    elif not 0.7 <= s <= 1.45:
        notes.append(f"the input's flight is implausible: {flight_text}; the new flight falls with {g_used:.2f} "
                     f"m/s^2 ({source})")
    elif abs(g_fit / g_used - 1.0) > 0.05:
        clip = f"; the clip's flights combined give {timing.scale * G_STANDARD:.2f} m/s^2" if timing is not None else ""
        notes.append(f"the input's flight fits gravity {g_fit:.2f} m/s^2 (within the usual error of one rotating "
                     f"flight{clip}); the new flight falls with {g_used:.2f} m/s^2 ({source}"
                     + ("; gravity='clip', --gravity clip, keeps the fitted value)" if source == "standard" else ")"))
    return notes
