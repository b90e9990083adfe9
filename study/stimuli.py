"""The stimuli of a study: base motions, their perturbations and the measured errors.

Pipeline per base motion (``[[base]]`` of a specification, :mod:`study.spec`):

1. **Load** it: ``example:NAME`` (the project's synthetic, physically exact flips:
   motion, body model and flight come with it), ``clip:NAME`` (a real clip by
   name through ``mocomp.datasets.load``, which applies the known frame-rate and
   T-pose corrections), ``data:REL/PATH`` (a BVH under ``$MOCOMP_DATA_DIR``, with
   ``fps``/``first_frame`` from the spec) or ``file:PATH``.
2. **Find the flight**: the longest airborne interval (``mocomp.dynamics``
   contact detection) unless the example states it.
3. **Normalise** (the paper: "the same camera configuration and the same
   take-off position"): keep ``pre_s`` seconds before take-off and ``post_s``
   after landing; rotate about the vertical so the flight's mean angular
   momentum points along +z (the camera looks along -z, so every somersault
   is seen side-on and turns counter-clockwise on screen: back flips face +x,
   front flips face -x, both travel towards -x); move the take-off COM to x = z = 0;
   shift vertically so the lowest joint of the standing phase sits one toe-capsule
   radius above the ground (feet on the floor in the rendering).
   Then **made ballistic** (``[flight] base_correction = "ballistic"``, default;
   :func:`make_ballistic`): the flight COM put on a g = 9.81 parabola by the edit pipeline's
   COM repositioning, the correction's size recorded, a base needing more than
   ``max_correction_m`` refused.
4. **Perturb**: angular-momentum errors rotation-only (``[flight] am_mode = "rotation"``,
   default; :func:`study.perturb.rotate_flight`: COM, flight time, take-off and landing kept,
   the orientation about L retimed) or paper-literal (``"retime"``;
   :func:`study.perturb.rebuild_flight`: retimed flights, COM parabola re-fitted, landing
   translated); take-off errors by :func:`study.perturb.rebuild_flight`, their levels in
   percent of horizontal speed or degrees of take-off angle (``takeoff_levels``); the
   unperturbed control is the (corrected) capture itself (``[flight] com = "capture"``,
   default) or its exact-ballistic version (``"ballistic"``).
5. **Measure** each stimulus with the project's dynamics (:func:`measure_stimulus`):
   the achieved relative angular-momentum error, the change of the take-off
   velocity along the jump direction and of the take-off angle, the velocity
   jumps at take-off and landing, the flight time and apex height; and every cue the audit
   measures on the stimulus' frames (``cue_*``, :func:`_motion_cues`).
6. **Audit** each stimulus (:func:`audit_stimulus`): :func:`mocomp.audit.audit` of the
   motion it renders against its unperturbed source (the normalised base motion),
   with the base's body model; the verdict and counts go into the manifest
   (:data:`AUDIT_COLUMNS`). A perturbed stimulus is meant to break physics, so its
   new violations (e.g. ``L_magnitude`` for an angular-momentum error, a COM
   velocity jump for a take-off error) are the perturbation seen by an independent
   measurement; an unperturbed stimulus should have none.

The achieved error (manifest column ``achieved_error``, percent, positive in the
nominal direction) is, for angular-momentum stimuli, the ratio
``|L(t)| / |L_control(s(t))|`` (``s(t)``: the original time shown at ``t``, so the
capture's own variation of ``|L|`` cancels), taken at its peak: the median over
the flight after the switch (abrupt) or the value at landing of a straight-line
fit over the flight (smooth). For take-off stimuli it is the relative change of
the mean horizontal COM velocity over the flight along the jump direction. For controls it is the angular-momentum measure (about 0).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mocomp.core.motion import Motion
from mocomp.core.rotations import quat_multiply
from mocomp.errors import DataNotFoundError, NoFlightPhaseError, PhysicsError, StudyDataError

from .perturb import FlightRebuild, rebuild_flight, rotate_flight, signed_level
from .spec import BaseSpec, StudySpec

__all__ = ["BaseMotion", "Stimulus", "BuiltStimuli", "load_base", "normalize_base", "make_stimulus",
           "measure_stimulus", "build_stimuli", "stimulus_id", "AUDIT_COLUMNS", "audit_base", "audit_stimulus"]


# ------------------------------------------------------------ dynamics adapter
def _center_of_mass(body, motion: Motion) -> np.ndarray:
    """``(T, 3)`` whole-body COM (:func:`mocomp.dynamics.center_of_mass`)."""
    from mocomp.dynamics import center_of_mass

    return np.asarray(center_of_mass(body, motion), dtype=float)


def _angular_momentum(body, motion: Motion) -> np.ndarray:
    """``(T, 3)`` angular momentum about the COM (:func:`mocomp.dynamics.momentum`, eq. 5.5)."""
    from mocomp.dynamics import momentum

    return np.asarray(momentum(body, motion).angular, dtype=float)


def _inertia(body, motion: Motion) -> np.ndarray:
    """``(T, 3, 3)`` whole-body inertia about the COM (:func:`mocomp.dynamics.composite_inertia`)."""
    from mocomp.dynamics import composite_inertia

    return np.asarray(composite_inertia(body, motion), dtype=float)


def _airborne_intervals(motion: Motion, body, contact_height: float) -> list[tuple[int, int]]:
    """Half-open airborne frame ranges (:func:`mocomp.dynamics.detect_contacts`, feet/toes/hands).

    Height only (the speed test is switched off): during push-off and landing the
    feet move fast while still on the ground, and a speed test would stretch the
    flight over ground frames (on CMU 88_01: frames 45-85 instead of 46-80, and a
    4 m/s jump between the fitted parabola and the landing).
    """
    from mocomp.dynamics import airborne_intervals, detect_contacts

    c = detect_contacts(motion, height_tol=contact_height, speed_tol=1e6)
    return [(int(a), int(b)) for a, b in airborne_intervals(c, min_frames=3)
            if a > 0 and b < motion.n_frames]


# ------------------------------------------------------------------ the bases
@dataclass(frozen=True, eq=False)
class BaseMotion:
    """A normalised base motion (see the module docstring, steps 1-3).

    Attributes
    ----------
    id: base id from the spec; ``source``: where it came from.
    motion: trimmed, rotated, translated motion.
    body: the :class:`~mocomp.body.BodyModel` used for its dynamics.
    flight: ``(a, b)`` half-open airborne frames of ``motion``.
    info: evidence of the loading/normalisation (JSON-able): frame rate, source
        frames kept, rotation applied, floor shift, flight length, ...
    """

    id: str
    source: str
    motion: Motion
    body: object
    flight: tuple[int, int]
    info: dict = field(default_factory=dict)


def _load_source(b: BaseSpec, spec: StudySpec):
    """``(motion, body or None, flight or None, notes)`` for a base's ``source``."""
    kind, _, name = b.source.partition(":")
    notes: list[str] = []
    if kind == "example":
        from mocomp import datasets

        if name not in datasets.examples():
            # a missing example is a wrong spec (or an incomplete install), never "missing data"
            raise StudyDataError(f"base {b.id!r}: no embedded example {name!r}; available: "
                                 f"{', '.join(sorted(datasets.examples())) or 'none registered'}",
                                 spec.path, column="base.source")
        res = datasets.load_example(name)
        motion = res.motion
        body = getattr(res, "body", None)
        flight = getattr(res, "flight", None)
        if b.fps is not None:
            motion = motion.with_fps(b.fps)
        return motion, body, (None if flight is None else (int(flight[0]), int(flight[1]))), notes
    if kind == "clip":
        from mocomp import datasets

        kw = {}
        if b.fps is not None:
            kw["fps"] = b.fps
        if b.scale is not None:
            kw["scale"] = b.scale
        res = datasets.load(name, **kw)
        motion = getattr(res, "motion", res)
        return motion, getattr(res, "body", None), None, notes
    if kind == "data":
        from mocomp.datasets import data_dir

        root = data_dir(required=True)
        path = root / name
    else:  # file
        path = Path(name)
        if not path.is_absolute() and spec.path is not None:
            path = spec.path.parent / path
    if not path.is_file():
        raise DataNotFoundError(f"base {b.id!r}: file {path} does not exist")
    if path.suffix.lower() != ".bvh":
        raise StudyDataError(f"base {b.id!r}: cannot read {path.suffix!r} files here; use a BVH file or "
                             "a 'clip:NAME' source", spec.path, column="base.source")
    from mocomp.io import read_bvh

    motion = read_bvh(path, scale="auto" if b.scale is None else b.scale, fps=b.fps)
    return motion, None, None, notes


def _rotation_about_y(angle: float) -> np.ndarray:
    return np.array([0.0, np.sin(angle / 2.0), 0.0, np.cos(angle / 2.0)])


def normalize_base(motion: Motion, body, flight: tuple[int, int], *, pre_s: float, post_s: float,
                   floor_clearance: float) -> tuple[Motion, tuple[int, int], dict]:
    """Trim, rotate and translate a base motion (module docstring, step 3).

    Returns ``(motion, flight, info)``; ``floor_clearance`` is the height (m) at
    which the lowest joint of the standing phase is put (the toe capsule radius).
    """
    a, b = flight
    fps = motion.fps
    s0 = max(0, a - int(round(pre_s * fps)))
    s1 = min(motion.n_frames, b + int(round(post_s * fps)))
    m = motion[s0:s1]
    a, b = a - s0, b - s0
    if a < 2 or b > m.n_frames - 2:
        raise NoFlightPhaseError(f"the flight [{a + s0}, {b + s0}) needs ground frames on both sides "
                                 f"(clip has {motion.n_frames} frames)")
    L = _angular_momentum(body, m)[a + 1:b - 1]
    Lm = L.mean(axis=0)
    Lh = np.hypot(Lm[0], Lm[2])
    if Lh < 0.5 * np.linalg.norm(Lm) or np.linalg.norm(Lm) < 1e-6:
        raise PhysicsError(f"the flight's angular momentum {Lm.round(3).tolist()} is not a somersault about a "
                           "horizontal axis (the study's side view needs one)")
    # rotate about y so that (Lx, Lz) -> (0, +|Lh|): angle phi with R_y(phi) applied to the vector
    phi = np.arctan2(Lm[0], Lm[2])  # R_y(phi) maps (sin phi, 0, cos phi) -> (0, 0, 1)
    q = _rotation_about_y(-phi)
    m = m.rotated(q)
    com = _center_of_mass(body, m)
    low = np.minimum(m.positions[..., 1].min(axis=1),
                     m.end_site_positions()[..., 1].min(axis=1) if m.skeleton.end_sites else np.inf)
    stand = low[:a]
    floor = float(np.percentile(stand, 10))
    shift = np.array([-com[a, 0], floor_clearance - floor, -com[a, 2]])
    m = m.translated(shift)
    info = {"frames_kept": [int(s0), int(s1)], "fps": float(fps), "flight": [int(a), int(b)],
            "flight_s": (b - 1 - a) / fps, "rotation_about_y_deg": float(np.degrees(-phi)),
            "translation_m": shift.round(6).tolist(), "L_mean_before": Lm.round(4).tolist()}
    return m, (int(a), int(b)), info


def make_ballistic(motion: Motion, body, flight: tuple[int, int], *, max_correction: float, base_id: str = "",
                   spec_path=None) -> tuple[Motion, tuple[int, int], dict]:
    """Put a base's flight COM on a g = 9.81 m/s^2 parabola before it is perturbed (issue 19 item 2).

    The edit pipeline's COM repositioning (:func:`mocomp.edit.linear.correct_linear`, dissertation
    section 5.5.3 / flips paper section 5.4.4) with ``k = 1`` (no retiming: the flight keeps its
    frames and duration), ``gravity = G_STANDARD`` (:data:`mocomp.dynamics.constants.G_STANDARD`) and
    the ballistic fit's take-off velocity (``takeoff_velocity="fit"``, the paper's; the captured
    push-off's moves CMU 88_05's landing 0.44 m): every flight frame is translated so its COM lies
    on the parabola through the take-off COM that lands at the captured landing height; frames after
    the landing get the landing's offset (horizontal only). The correction's size is the largest
    COM displacement over the whole motion (``ballistic_correction_m``; flight frames and the
    landing phase's shift are also given). A base that needs more than ``max_correction`` m is
    refused (:class:`~mocomp.errors.StudyDataError` naming the base and ``flight.max_correction_m``).
    Measured (60 Hz CMU clips): 88_01 0.164 m, 88_05 back flip 0.135 m, 90_08 side flip 0.036 m;
    the synthetic flips < 1e-6 m. The default bound (0.2 m, ``study.spec``) refuses the same clips read
    at their headers' wrong 120 Hz (g fits 44-49 m/s^2; corrections 0.27-0.48 m).
    """
    from mocomp.dynamics.constants import G_STANDARD
    from mocomp.edit.linear import correct_linear
    from mocomp.flips.mass import fit_ballistic

    a, b = flight
    C = _center_of_mass(body, motion)
    fit = fit_ballistic(C[a:b], motion.fps, a)
    res = correct_linear(body, motion, flight, fit, k=1.0, gravity=G_STANDARD, takeoff_velocity="fit")
    out = res.motion
    if out.n_frames != motion.n_frames or tuple(res.flight) != (a, b):
        raise PhysicsError(f"base {base_id!r}: the ballistic correction changed the frames "
                           f"({motion.n_frames} -> {out.n_frames}, flight {flight} -> {res.flight})")
    d = np.linalg.norm(_center_of_mass(body, out) - C, axis=1)
    size = float(d.max())
    info = {"ballistic_correction": "correct_linear(k=1, g=9.81, takeoff_velocity='fit')",
            "ballistic_correction_m": size, "ballistic_correction_flight_m": float(d[a:b].max()),
            "ballistic_landing_shift_m": float(d[b:].max()) if b < len(d) else 0.0,
            "g_fit_before_correction": float(fit.gravity), "ballistic_correction_max_m": float(max_correction)}
    if size > max_correction:
        raise StudyDataError(
            f"base {base_id!r}: making its flight ballistic (g = 9.81 m/s^2) moves its COM by {size:.3f} m "
            f"(flight fits g = {fit.gravity:.2f} m/s^2), more than the bound {max_correction:g} m; check its "
            "frame rate and units, or raise flight.max_correction_m", spec_path, column="flight.max_correction_m")
    return out, (a, b), info


def load_base(b: BaseSpec, spec: StudySpec) -> BaseMotion:
    """Load and normalise one base motion (module docstring, steps 1-3)."""
    from mocomp.body import BodyModel
    from mocomp.plots.render3d import RADIUS_FRACTION

    motion, body, flight, notes = _load_source(b, spec)
    first = b.first_frame
    last = motion.n_frames - 1 if b.last_frame == -1 else b.last_frame
    if not (0 <= first < last < motion.n_frames):
        raise StudyDataError(f"base {b.id!r}: frames [{first}, {last}] are outside the clip's "
                             f"{motion.n_frames} frames", spec.path, column="base.first_frame")
    motion = motion[first:last + 1]
    if body is None:
        body = BodyModel.from_skeleton(motion.skeleton)
    if flight is not None:
        flight = (flight[0] - first, flight[1] - first)
        how = "given by the example"
    else:
        iv = _airborne_intervals(motion, body, spec.contact_height)
        if not iv:
            raise NoFlightPhaseError(f"base {b.id!r} ({b.source}): no airborne frames found "
                                     f"(contact height {spec.contact_height} m)")
        flight = max(iv, key=lambda ab: ab[1] - ab[0])
        how = f"longest of {len(iv)} airborne interval(s)"
    clearance = RADIUS_FRACTION["toe"] * motion.skeleton.height()
    m, fl, info = normalize_base(motion, body, flight, pre_s=spec.pre_s, post_s=spec.post_s,
                                 floor_clearance=clearance)
    if spec.base_correction == "ballistic":
        m, fl, corr = make_ballistic(m, body, fl, max_correction=spec.max_correction_m, base_id=b.id,
                                     spec_path=spec.path)
        info.update(corr)
    info.update({"source": b.source, "first_frame": first, "flight_detection": how,
                 "loaded_frames": motion.n_frames, "unit_scale": motion.source.unit_scale,
                 "notes": list(motion.source.notes) + notes, "body_table": getattr(body, "table", ""),
                 "body_mass_kg": float(getattr(body, "total_mass", float("nan")))})
    return BaseMotion(b.id, b.source, m, body, fl, info)


# --------------------------------------------------------------- the stimuli
def stimulus_id(base_id: str, perturbation: str, direction: str, level_pct: float) -> str:
    """``<base>__none`` or ``<base>__<perturbation>_<direction>_<level>`` (level in percent, ``%g``)."""
    if perturbation == "none":
        return f"{base_id}__none"
    return f"{base_id}__{perturbation}_{direction}_{level_pct:g}"


@dataclass(frozen=True, eq=False)
class Stimulus:
    """One stimulus: the perturbed motion, what was asked and what was achieved.

    ``nominal_level`` is in percent (0 for the control; degrees for take-off stimuli of a spec with
    ``takeoff_levels = "angle"``); ``measures`` holds the manifest's measured columns
    (:func:`measure_stimulus`); ``audit`` the :class:`~mocomp.audit.AuditReport` of its motion.
    """

    stimulus_id: str
    base_clip: str
    base_source: str
    perturbation: str
    direction: str
    nominal_level: float
    rebuild: FlightRebuild
    measures: dict
    audit: object = None

    @property
    def motion(self) -> Motion:
        return self.rebuild.motion


_Y3 = np.array([0.0, 1.0, 0.0])


def _flight_velocity(com: np.ndarray, fps: float, a: int, b: int, gravity: float) -> np.ndarray:
    """Take-off velocity of the ballistic flight through the COM at the first (``a``) and
    last (``b - 1``) airborne frames: ``(c_b - c_a) / T + g T / 2 y``.

    Its horizontal part is the mean horizontal COM velocity over the flight; for
    an exactly ballistic COM it is the take-off velocity itself.
    """
    T = (b - 1 - a) / fps
    return (com[b - 1] - com[a]) / T + 0.5 * gravity * T * np.array([0.0, 1.0, 0.0])


def _motion_cues(motion: Motion, body, flight: tuple[int, int], report=None, L: np.ndarray | None = None) -> dict:
    """The perceptual cues of one motion's flight, measured on its frames: with :func:`mocomp.audit.audit`
    (``report``; computed when ``None``) the flight time, the COM apex above take-off, the COM
    velocity jumps at take-off and landing and the take-off angle (degrees from the vertical), of the
    audit's flight that overlaps ``flight`` most; with :mod:`mocomp.dynamics` the whole-body rotation
    speed ``|I^-1 L|`` (rad/s, inertia and L about the COM) averaged over the first (``rot_first``)
    and last (``rot_last``) two inner flight frames."""
    a, b = flight
    Lm = _angular_momentum(body, motion) if L is None else L
    I = _inertia(body, motion[a + 1:b - 1])
    w = np.linalg.norm(np.linalg.solve(I, Lm[a + 1:b - 1][..., None])[..., 0], axis=1)
    out = {"cue_flight_s": np.nan, "cue_apex_m": np.nan, "cue_takeoff_jump_ms": np.nan,
           "cue_landing_jump_ms": np.nan, "cue_takeoff_angle_deg": np.nan,
           "rot_first": float(w[:2].mean()), "rot_last": float(w[-2:].mean())}
    rep = _audit_or_none(motion, body) if report is None else report
    if rep is None:  # a skeleton the audit cannot measure (e.g. no contact points): audit cues NaN
        return out
    best, ov = None, 0
    for f in rep.flights:
        o = min(b, f.frames[1]) - max(a, f.frames[0])
        if o > ov and f.fit is not None:
            best, ov = f, o
    if best is None:
        raise NoFlightPhaseError(f"the audit finds no flight overlapping frames [{a}, {b})")
    jumps = {e.kind: e.jump for e in rep.com.events if e.flight == best.index}
    out.update({"cue_flight_s": float(best.duration), "cue_apex_m": float(best.rise),
                "cue_takeoff_jump_ms": float(jumps.get("take-off", np.nan)),
                "cue_landing_jump_ms": float(jumps.get("landing", np.nan)),
                "cue_takeoff_angle_deg": float(np.degrees(best.takeoff_angle))})
    return out


def _audit_or_none(motion: Motion, body, name: str | None = None):
    """:func:`mocomp.audit.audit` of ``motion``, or ``None`` when the audit cannot measure its skeleton."""
    from mocomp.audit import audit
    from mocomp.errors import MocompError

    try:
        return audit(motion, body, name=name)
    except MocompError:
        return None


def measure_stimulus(rb: FlightRebuild, control: FlightRebuild, body, *, L_control: np.ndarray | None = None,
                     com: np.ndarray | None = None, com_control: np.ndarray | None = None,
                     stimulus_audit=None, control_audit=None, control_cues: dict | None = None,
                     takeoff_levels: str = "velocity") -> dict:
    """The achieved errors and the evidence of one stimulus (module docstring).

    Returns a dict with ``achieved_error`` (percent, in the nominal direction),
    ``achieved_signed_pct``, ``L_error_pct`` (signed peak relative change of
    ``|L|``), ``velocity_error_pct`` (signed relative change of the take-off
    velocity along the jump direction), ``takeoff_angle_deg``,
    ``takeoff_angle_change_deg``, ``takeoff_speed_ms``, ``speed_ratio``,
    ``flight_s``, ``base_flight_s``, ``apex_m`` (COM rise above take-off),
    ``landing_shift_m``, ``takeoff_dv_ms`` / ``landing_dv_ms`` (COM velocity jump
    between the ground phase and the flight parabola) and
    ``takeoff_dv_added_ms`` / ``landing_dv_added_ms`` (the part of those jumps the
    perturbation adds: the change of the ideal flight's velocity at take-off and at
    touchdown against the control; the ground phases are the control's, so this is
    the discontinuity a participant sees on top of the capture's own), ``landing_rate``
    (retiming rate at the last airborne frame: the body's rotation slows by this
    factor at touchdown), ``L_direction_change_deg`` (largest angle between ``L`` and the control's
    ``L`` at the same original time), ``com_capture_dev_m`` (how far the base
    flight's COM is from a ballistic parabola). Velocities are those of the
    ballistic flight through the stimulus' COM at its first and last airborne
    frames (:func:`_flight_velocity`).

    The ``cue_*`` entries are the cues a participant may see besides the nominal error, each
    measured on the stimulus' frames with :func:`mocomp.audit.audit` (``stimulus_audit``, computed
    when ``None``) and :mod:`mocomp.dynamics` (:func:`_motion_cues`), never taken from the
    perturbation's plan: ``cue_flight_s`` / ``cue_flight_change_s``, ``cue_apex_m`` /
    ``cue_apex_change_m`` (COM rise of the audit's ballistic fit), ``cue_takeoff_jump_ms`` /
    ``cue_landing_jump_ms`` (the audit's COM velocity jumps there), ``cue_takeoff_angle_deg`` /
    ``cue_takeoff_angle_change_deg`` (the audit's take-off angle from the vertical, and its change
    against the control's), ``cue_L_change_pct`` (= ``L_error_pct``), ``cue_takeoff_rotation_ratio``
    / ``cue_landing_rotation_ratio`` (whole-body rotation speed ``|I^-1 L|`` over the first / last
    two inner flight frames against the control's: the change a participant sees where the flight
    meets the ground phases), ``cue_landing_rotation_speed_rads`` and ``cue_com_change_m`` (largest
    COM distance from the control's, rotation-only stimuli). With ``takeoff_levels="angle"`` a
    take-off stimulus' ``achieved_error`` is ``cue_takeoff_angle_change_deg`` (degrees).

    Rotation-only stimuli (``rb.am_mode == "rotation"``): ``L_error_pct`` is the change of ``|L|``
    the nominal level names (:mod:`study.perturb`): the median ratio to the control after the
    abrupt switch over that before it, or the landing over the take-off value of the fitted line.
    """
    m = rb.motion
    fps = m.fps
    fa, fb = rb.flight
    if L_control is None:
        L_control = _angular_momentum(body, control.motion)
    L = _angular_momentum(body, m)
    # inner flight frames: central differences do not straddle take-off or landing
    idx = np.arange(fa + 1, fb - 1)
    if idx.size < 3:
        raise NoFlightPhaseError(f"flight of {fb - fa} frames is too short to measure")
    s = rb.original_time[idx]
    # the control's L at the same original time, from its own inner flight frames only
    # (its first/last airborne frames straddle take-off/landing); held constant beyond them
    ca, cb = control.flight
    cin = np.arange(ca + 1, cb - 1)
    tc = control.original_time[cin]
    Lc_at = np.stack([np.interp(s, tc, L_control[cin, k]) for k in range(3)], axis=1)
    ratio = np.linalg.norm(L[idx], axis=1) / np.linalg.norm(Lc_at, axis=1)
    u = (idx - fa) / fps
    Tn = rb.warp.new_T
    rotation = rb.am_mode == "rotation"
    if rb.kind == "am_abrupt":
        keep = np.abs(u - rb.warp.switch_u) > 1.5 / fps
        post = keep & (u > rb.warp.switch_u)
        pre = keep & (u < rb.warp.switch_u)
        if post.sum() < 2 or (rotation and pre.sum() < 2):
            raise NoFlightPhaseError("too few flight frames around the abrupt switch to measure the error")
        # rotation-only: the change across the switch; retimed: after the switch against the control
        L_err = float(np.median(ratio[post]) / (np.median(ratio[pre]) if rotation else 1.0) - 1.0)
    else:
        A = np.stack([np.ones_like(u), u / Tn], axis=1)
        (c0, c1), *_ = np.linalg.lstsq(A, ratio, rcond=None)
        # rotation-only: landing over take-off of the fitted line; retimed: at landing against the control
        L_err = float((c0 + c1) / (c0 if rotation else 1.0) - 1.0)
    cosang = np.sum(L[idx] * Lc_at, axis=1) / (np.linalg.norm(L[idx], axis=1) * np.linalg.norm(Lc_at, axis=1))
    L_dir = float(np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0))).max())

    C = _center_of_mass(body, m) if com is None else com
    Cc = _center_of_mass(body, control.motion) if com_control is None else com_control
    g = rb.gravity
    v = _flight_velocity(C, fps, fa, fb, g)
    vc = _flight_velocity(Cc, fps, *control.flight, g)
    h = control.jump_direction
    vh, vch = float(v @ h), float(vc @ h)
    v_err = (vh / vch - 1.0) if abs(vch) > 1e-6 else float("nan")
    ang = lambda w: float(np.degrees(np.arctan2(w[1], np.hypot(w[0], w[2]))))  # noqa: E731
    v_before = (C[fa - 1] - C[fa - 2]) * fps
    v_after = (C[fb + 1] - C[fb]) * fps if fb + 1 < m.n_frames else C[fb] * np.nan
    v_land = v - g * Tn * np.array([0.0, 1.0, 0.0])
    y0 = C[fa, 1]
    if rb.kind == "takeoff":
        signed = v_err
    else:
        signed = L_err
    sign = -1.0 if rb.error < 0 else 1.0
    cues = _motion_cues(m, body, rb.flight, stimulus_audit, L=L)
    ccues = _motion_cues(control.motion, body, control.flight, control_audit, L=L_control) \
        if control_cues is None else control_cues
    angle_change = cues["cue_takeoff_angle_deg"] - ccues["cue_takeoff_angle_deg"]
    if rb.kind == "takeoff" and takeoff_levels == "angle":
        signed = angle_change / 100.0  # degrees, reported as "percent" x 100 below
    out_cues = {
        "cue_flight_s": cues["cue_flight_s"], "cue_flight_change_s": cues["cue_flight_s"] - ccues["cue_flight_s"],
        "cue_apex_m": cues["cue_apex_m"], "cue_apex_change_m": cues["cue_apex_m"] - ccues["cue_apex_m"],
        "cue_takeoff_jump_ms": cues["cue_takeoff_jump_ms"], "cue_landing_jump_ms": cues["cue_landing_jump_ms"],
        "cue_takeoff_angle_deg": cues["cue_takeoff_angle_deg"], "cue_takeoff_angle_change_deg": angle_change,
        "cue_L_change_pct": 100.0 * L_err,
        "cue_takeoff_rotation_ratio": cues["rot_first"] / ccues["rot_first"],
        "cue_landing_rotation_ratio": cues["rot_last"] / ccues["rot_last"],
        "cue_landing_rotation_speed_rads": cues["rot_last"],
        "cue_com_change_m": float(np.linalg.norm(C[:min(len(C), len(Cc))] - Cc[:min(len(C), len(Cc))],
                                                 axis=1).max()) if rb.am_mode == "rotation" else float("nan"),
    }
    return out_cues | {
        "achieved_error": 100.0 * sign * signed,
        "achieved_signed_pct": 100.0 * signed,
        "L_error_pct": 100.0 * L_err,
        "velocity_error_pct": 100.0 * v_err,
        "takeoff_angle_deg": ang(v),
        "takeoff_angle_change_deg": ang(v) - ang(vc),
        "takeoff_speed_ms": float(np.linalg.norm(v)),
        "speed_ratio": float(np.linalg.norm(v) / np.linalg.norm(vc)),
        "flight_s": float(Tn),
        "base_flight_s": float(rb.warp.T),
        "apex_m": float(C[fa:fb, 1].max() - y0),
        "landing_shift_m": float(np.linalg.norm(rb.landing_shift)),
        "takeoff_dv_ms": float(np.linalg.norm(v - v_before)),
        "landing_dv_ms": float(np.linalg.norm(v_after - v_land)),
        "takeoff_dv_added_ms": float(np.linalg.norm(rb.velocity - control.velocity)),
        "landing_dv_added_ms": float(np.linalg.norm((rb.velocity - g * Tn * _Y3) -
                                                    (control.velocity - g * control.warp.new_T * _Y3))),
        "landing_rate": float(rb.rate[rb.flight[1] - 1]),
        "L_direction_change_deg": L_dir,
        "com_capture_dev_m": float(rb.capture_deviation),
    }


def takeoff_error_for_angle(v0: np.ndarray, direction: str, degrees: float) -> float:
    """The relative change ``e`` of the horizontal take-off speed that turns the take-off angle
    (from the vertical, as :mod:`mocomp.audit` measures it) by ``degrees`` (``+`` increase: flatter):
    ``tan(alpha0 +- d) / tan(alpha0) - 1`` with ``alpha0 = atan(|v_h| / v_y)``; the vertical speed
    and the flight time are kept (:mod:`study.perturb`, step 3)."""
    vh, vy = float(np.hypot(v0[0], v0[2])), float(v0[1])
    if vy <= 0:
        raise PhysicsError(f"the take-off velocity does not rise (v_y = {vy:.3f} m/s)")
    a0 = np.arctan2(vh, vy)
    a1 = a0 + np.radians(signed_level(direction, degrees))
    if not (0.0 < a1 < np.radians(89.0)):
        raise PhysicsError(f"a take-off angle of {np.degrees(a0):.1f} deg from the vertical cannot change by "
                           f"{signed_level(direction, degrees):+g} deg (result must lie in (0, 89) deg)")
    return float(np.tan(a1) / np.tan(a0) - 1.0)


def make_stimulus(base: BaseMotion, perturbation: str, direction: str, level_pct: float, *,
                  gravity: float = 9.81, switch_fraction: float = 0.5, com_mode: str = "capture",
                  control: FlightRebuild | None = None, L_control: np.ndarray | None = None,
                  am_mode: str = "rotation", takeoff_levels: str = "velocity",
                  control_audit=None, control_cues: dict | None = None) -> Stimulus:
    """Build, audit and measure one stimulus of ``base`` (``level_pct`` in percent; degrees for a
    take-off stimulus with ``takeoff_levels="angle"``); ``am_mode``: ``"rotation"``
    (:func:`study.perturb.rotate_flight`) or ``"retime"`` (:func:`study.perturb.rebuild_flight`)."""
    com = lambda mm: _center_of_mass(base.body, mm)  # noqa: E731
    if perturbation == "takeoff" and takeoff_levels == "angle":
        e = 0.0
    else:
        e = signed_level(direction, level_pct / 100.0)
    if control is None:
        control = rebuild_flight(base.motion, base.flight, com, kind="none", gravity=gravity, com_mode=com_mode)
    if perturbation == "takeoff" and takeoff_levels == "angle":
        e = takeoff_error_for_angle(control.base_velocity, direction, level_pct)
    if perturbation == "none":
        rb = control
    elif perturbation.startswith("am_") and am_mode == "rotation":
        rb = rotate_flight(base.motion, base.flight, com, lambda mm: _angular_momentum(base.body, mm),
                           lambda mm: _inertia(base.body, mm), kind=perturbation, error=e, gravity=gravity,
                           switch_fraction=switch_fraction)
    else:
        rb = rebuild_flight(base.motion, base.flight, com, kind=perturbation, error=e, gravity=gravity,
                            switch_fraction=switch_fraction, com_mode=com_mode)
    sid = stimulus_id(base.id, perturbation, direction, level_pct)
    rep = _audit_or_none(rb.motion, base.body, name=sid)
    if perturbation == "none":
        control_audit = rep
    meas = measure_stimulus(rb, control, base.body, L_control=L_control, stimulus_audit=rep,
                            control_audit=control_audit, control_cues=control_cues, takeoff_levels=takeoff_levels)
    meas["am_mode"] = am_mode if perturbation.startswith("am_") else ""
    meas["level_unit"] = "deg" if (perturbation == "takeoff" and takeoff_levels == "angle") else "percent"
    meas["imposed_velocity_change_pct"] = 100.0 * e if perturbation == "takeoff" else float("nan")
    return Stimulus(sid, base.id, base.source, perturbation, direction, float(level_pct), rb, meas, rep)


#: manifest columns written from the audit of each stimulus (study/DATA_DICTIONARY.md, "manifest.csv")
AUDIT_COLUMNS: tuple[str, ...] = (
    "audit_verdict", "audit_violations", "audit_advisories", "audit_new_violations", "audit_checks",
    "audit_new_checks", "audit_source_verdict", "audit_source_violations",
)


def audit_base(base: BaseMotion):
    """:func:`mocomp.audit.audit` of a base motion (the unperturbed source of its stimuli)."""
    from mocomp.audit import audit

    return audit(base.motion, base.body, name=f"base {base.id}")


def _check_counts(findings) -> str:
    counts: dict[str, int] = {}
    for f in findings:
        counts[f.check] = counts.get(f.check, 0) + 1
    return ";".join(f"{k}:{v}" for k, v in sorted(counts.items()))


def audit_stimulus(stimulus: "Stimulus", base: BaseMotion, base_report=None) -> tuple[object, dict]:
    """Audit the motion a stimulus renders against its unperturbed source (``base.motion``).

    Returns ``(report, columns)``: the :class:`~mocomp.audit.AuditReport` (with ``against`` the
    source's) and the manifest's :data:`AUDIT_COLUMNS`: ``audit_verdict`` (``pass``/``fail``),
    ``audit_violations``, ``audit_advisories``, ``audit_new_violations`` (violations the source
    lacks at that check and place, or has smaller by more than a quarter of the threshold:
    :func:`mocomp.cli._common.new_violations`, the rule every command's verdict uses),
    ``audit_checks`` / ``audit_new_checks`` (``check:count`` pairs joined by ``;``, empty when
    none) and the source's ``audit_source_verdict`` / ``audit_source_violations``.
    """
    import dataclasses

    from mocomp.audit import audit
    from mocomp.cli._common import new_violations

    src = base_report if base_report is not None else audit_base(base)
    rep = stimulus.audit if stimulus.audit is not None else audit(stimulus.motion, base.body,
                                                                  name=stimulus.stimulus_id)
    rep = dataclasses.replace(rep, against=src, comparison=rep.compare(src))
    new = [f for f, _ in new_violations(rep)]
    return rep, {
        "audit_verdict": rep.verdict, "audit_violations": len(rep.violations),
        "audit_advisories": len(rep.advisories), "audit_new_violations": len(new),
        "audit_checks": _check_counts(rep.violations), "audit_new_checks": _check_counts(new),
        "audit_source_verdict": src.verdict, "audit_source_violations": len(src.violations),
    }


@dataclass
class BuiltStimuli:
    """Every stimulus of a spec, plus notes (skipped bases) and per-base evidence."""

    stimuli: list[Stimulus]
    bases: list[BaseMotion]
    notes: list[str]
    base_info: dict
    skipped_bases: list[str] = field(default_factory=list)


def build_stimuli(spec: StudySpec, *, skip_missing_data: bool = False, progress: bool = False) -> BuiltStimuli:
    """Load every base of ``spec`` and make all its stimuli (controls first).

    A base whose data are missing (e.g. a ``clip:`` source with ``MOCOMP_DATA_DIR``
    unset) is an error naming the base and ``MOCOMP_DATA_DIR``, unless
    ``skip_missing_data`` or the base says ``required = false``: then it is left
    out and listed in ``skipped_bases`` and ``notes``.
    """
    from tqdm.auto import tqdm

    notes: list[str] = []
    bases: list[BaseMotion] = []
    skipped: list[str] = []
    for b in spec.bases:
        try:
            bases.append(load_base(b, spec))
        except DataNotFoundError as e:
            if b.required and not skip_missing_data:
                raise DataNotFoundError(
                    f"base {b.id!r} ({b.source}) of {spec.path or 'the specification'}: its data are missing ({e}); "
                    "set MOCOMP_DATA_DIR to the folder of capture clips (e.g. ../shared/data/mocap), or pass "
                    "--skip-missing-data (skip_missing_data=True) to render the other bases only "
                    "(the skipped bases are then listed in render_info.json)") from None
            skipped.append(b.id)
            notes.append(f"base {b.id!r} skipped ({'--skip-missing-data' if b.required else 'required = false'}): {e}")
    out: list[Stimulus] = []
    design = [d for d in spec.design() if d[0] in {bm.id for bm in bases}]
    by_id = {bm.id: bm for bm in bases}
    controls: dict[str, tuple[FlightRebuild, np.ndarray]] = {}
    for bid, p, d, lv in tqdm(design, desc="stimuli", unit="stim", disable=not progress, leave=False):
        base = by_id[bid]
        if bid not in controls:
            com = lambda mm, body=base.body: _center_of_mass(body, mm)  # noqa: E731
            ctl = rebuild_flight(base.motion, base.flight, com, kind="none", gravity=spec.gravity,
                                 com_mode=spec.com_mode)
            Lc = _angular_momentum(base.body, ctl.motion)
            rep_c = _audit_or_none(ctl.motion, base.body, name=stimulus_id(bid, "none", "none", 0))
            controls[bid] = (ctl, Lc, rep_c, _motion_cues(ctl.motion, base.body, ctl.flight, rep_c, L=Lc))
        ctl, Lc, rep_c, cues_c = controls[bid]
        try:
            out.append(make_stimulus(base, p, d, lv, gravity=spec.gravity, switch_fraction=spec.switch_fraction,
                                     com_mode=spec.com_mode, control=ctl, L_control=Lc, am_mode=spec.am_mode,
                                     takeoff_levels=spec.takeoff_levels, control_audit=rep_c,
                                     control_cues=cues_c))
        except PhysicsError as e:
            raise PhysicsError(f"stimulus {stimulus_id(bid, p, d, lv)}: {e}") from None
    info = {bm.id: bm.info for bm in bases}
    return BuiltStimuli(out, bases, notes, info, skipped)
