"""Joining two different flights in mid-air (flips paper section 6, Fig. 4c; dissertation
section 5.6, Fig. 5.8: an aerial cartwheel joined with a forward flip).

"The same algorithm can be easily modified to join two different motions during the jump
phase. As long as the two motions have the same angular momentum direction, the
magnitudes can be adjusted by retiming" (section 5.2); "the motions are retimed so that
the angular momentums during the flight phase are equal in both of them" (section 6).

:func:`join_flights` takes the take-off (and first part of the flight) of motion ``A``
and the rest of the flight and the landing of motion ``B``:

1. **Align the L directions.** ``B`` is turned about the vertical so that the horizontal
   parts of the two flights' mean angular momenta point the same way. If the remaining
   angle (the difference of the L elevations) exceeds ``align_tol_deg``, the full
   alignment (shortest arc from ``L_B`` to ``L_A``) is applied too; it tilts ``B``'s
   landing by that angle, so it is refused above ``max_tilt_deg`` (:class:`~mocomp.errors.JoinError`
   with the measured directions). With ``upright=True`` the tilt is eased out over the
   landing phase (the ground can exert the torque; the feet on the ground are held by a root
   translation and leg IK, and what they still slide is reported).
2. **Match |L|** by uniform retiming (eq. 5.8): ``B`` is played ``|L_A| / |L_B|`` times
   faster (``match="takeoff"``), or ``A`` is retimed to ``B`` (``"landing"``), or both to the
   geometric mean (``"mean"``).
3. **Transition** by the Acrobatics-I frame search: the pair ``(f, g)``, ``f`` in ``A``'s
   flight and ``g`` in ``B``'s, minimising the similarity of App. A (eq. 5.12-5.13, frames
   aligned about L), plus a penalty on the alignment angle ``phi`` about ``L``. ``A``'s
   flight frames are turned about ``L`` by a ramp reaching ``phi`` at ``f`` (so the take-off
   and ``B``'s landing keep their orientation), joint angles are blended over a window
   around the seam and the root's remaining mismatch (perpendicular to ``L``) is split
   between the two sides. The choice is robust (see *The seam's tie rule* below).
4. **Retime and reposition the whole**: the joined flight goes through section 5.5's steps
   (:func:`~mocomp.edit.pipeline.three_steps`) with the target ``L_A``: the magnitude of L is
   restored across the transition by non-uniform retiming (step 1, the direction, only on
   request: section 5.2 adjusts transitions by retiming), then uniform retiming by ``k*``
   and COM repositioning onto the parabola (under 9.81 m/s^2 unless ``gravity`` says otherwise)
   from ``A``'s take-off, with an optional raised take-off (App. B; ``takeoff_height``) and the
   platform clearance of Fig. 5.10.
5. **Land on A's floor.** ``B``'s part is translated so that its COM continues ``A``'s at the
   seam, which moves ``B``'s floor with it (23-33 cm below ``A``'s for CMU 88_01 + 88_05, 7.6 cm
   for the synthetic back flip + side flip); the parabola is planned to end where ``B``'s landing
   touches the floor ``A`` took off from, and the landing is kept on it (:mod:`mocomp.edit.landing`).

**The seam's tie rule.** Where several pairs fit equally well the plain argmin of the cost is
ill-conditioned: joining a flight with a copy of itself makes every pair ``f = g`` of a held
tuck a perfect match (cost at rounding level, ~5e-7 after a 1e-7 relative perturbation), and the argmin
picked ``f = g`` = 183 for the synthetic back flip with itself and 144, 143, 155, 150, 146 when
both inputs were perturbed with five seeds (side flip 176 and 174-140; DeepMimic back flip 106
and 97-121; CMU 88_01 70 and 52-67); now 157, 156, 112 and 62 throughout. As in
:mod:`mocomp.flips.looping` (whose tolerances are shared), pairs whose cost is within
:data:`~mocomp.flips.looping.TIE_RTOL` (relative) plus :data:`~mocomp.flips.looping.TIE_ATOL`
(radians of mean weighted joint mismatch, times the sum of the eq. 5.13 weights) of the lowest
are tied, and among them, in order:

1. the smallest rotation about L ``|phi|`` (to within :data:`~mocomp.flips.looping.PHI_TOL`
   rad): the least twist to spread over the take-off part's flight;
2. the pair nearest the middle of both flights (the apex of the ballistic COM path:
   ``|2f - (a0 + a1 - 1)| + |2g - (b0 + b1 - 1)|`` smallest, with ``(a0, a1)`` and ``(b0, b1)``
   the retimed parts' flights), farthest from the take-off and landing poses, with the
   widest blend window;
3. the earliest ``f``, then the earliest ``g``.

Steps 2-3 compare integers. The retimed flights' frames are themselves taken with a
tolerance (:data:`FRAME_TOL`), so that the |L| matching's ``1 +- 1e-7`` speeds do not move
a flight's end by a frame (which moved the middle, step 2). ``seam["tied_pairs"]`` says how
many pairs tied. ``tests/test_edit_join.py`` perturbs the inputs by seeded 1e-7 noise.

**Limitation: the seam.** After step 1 the two flights' mean L point the same way, but at
the matched pair of frames the *bodies* are still oriented differently about an axis
perpendicular to L (a back flip turns about the body's left-right axis, a side flip about
its front-back axis: 62 deg on the synthetic back flip + side flip, 99 deg DeepMimic back
flip + side flip, 88 deg back flip + spin kick; the frame search's root weight cannot find
a better pair: x3-x30 leaves 60-97 deg). The crossfade removes that mismatch within the
blend window, which turns L away from its direction there: measured 0.62 rad (synthetic),
1.23 and 1.34 rad (DeepMimic), while the retiming keeps |L| within 7.4%, 28.8% (the DeepMimic
clips' own variation is 65%) and 4.7%. A wider window hardly helps (it is capped by the
flights' length: ``window_s=0.2`` gives 0.60 rad), and turning the take-off part's whole
flight towards the landing part's orientation (a smoothstep from take-off to the seam) was
worse (1.08, 1.83, 1.76 rad). Running step 1 over the joined flight
(``direction_step=True``) removes the direction error (< 1e-6 rad) but turns everything after
the seam, the landing too: 18, 85 and 129 deg, which the upright recovery cannot hide. The
COM velocity jumps at take-off and landing are measured on the output (one-frame velocities
either side; :func:`boundary_velocity_jumps`) and compared with the inputs' own; on the
DeepMimic clips step 3's parabola does not match the captured take-off (the clips' flights
are not ballistic: fitted gravity 7.8 m/s^2 for the back flip, 14.8 for the side flip), a
1.5 m/s vertical jump. :attr:`JoinResult.seam` carries these numbers and the bounds they
break (:data:`SEAM_LIMITS`, also in the notes). These are the model's numbers; ``mocomp join``
audits the frames it would write and refuses a join that the audit finds worse than its inputs
(``--force`` writes it anyway).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion
from ..core.rotations import make_continuous, quat_apply, quat_inverse, quat_multiply, shortest_arc
from ..errors import JoinError
from ..flips.looping import PHI_TOL, TIE_ATOL, TIE_RTOL, choose_tied
from .pipeline import RestoreResult, boundary_velocity_jumps, three_steps
from .restore import flight_momentum

__all__ = ["JoinPart", "JoinResult", "join_flights", "load_part", "boundary_velocity_jumps", "SEAM_LIMITS"]


def _fmt3(v):
    return "(" + ", ".join(f"{x:+.2f}" for x in v) + ")"


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _axis_quat(axis, angle):
    a = _unit(axis)
    h = 0.5 * np.asarray(angle, dtype=float)
    out = np.empty(np.shape(h) + (4,))
    out[..., :3] = np.sin(h)[..., None] * a
    out[..., 3] = np.cos(h)
    return out


def _ramp(d, window):
    """Raised cosine: 1 at distance 0, 0 from ``window + 1`` on."""
    x = np.clip(np.asarray(d, dtype=float) / (window + 1.0), 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * x))


def _elevation_deg(L):
    u = _unit(L)
    return float(np.degrees(np.arcsin(np.clip(u[1], -1, 1))))


def _azimuth_deg(L):
    return float(np.degrees(np.arctan2(L[0], L[2])))


#: bounds above which a join's seam evidence is flagged (:attr:`JoinResult.seam` ``["violations"]``):
#: direction error of L (rad) over the transition, beyond the take-off part's own variation;
#: relative |L| error (fraction, the paper's 20%: section 5.1) beyond the part's own; COM velocity
#: jump (m/s, any component) at take-off or landing beyond the input's own jump there.
SEAM_LIMITS = {"direction_rad": 0.1, "magnitude_frac": 0.2, "velocity_jump_m_s": 0.5}




@dataclass(frozen=True, eq=False)
class JoinPart:
    """One input of a join, as used.

    Attributes
    ----------
    name: where it came from.
    motion: the motion as used (resampled, aligned and retimed).
    flight: ``(start, stop)`` of its flight in ``motion``.
    L: ``(3,)`` kg m^2/s, mean angular momentum over the flight interior (after alignment/retiming).
    L_input: ``(3,)`` the same before alignment and retiming.
    rotation: ``(4,)`` quaternion applied to the whole motion (identity for the take-off part).
    speed: uniform retiming factor applied (eq. 5.8; 1 = none).
    notes: what was done to it.
    """

    name: str
    motion: Motion
    flight: tuple[int, int]
    L: np.ndarray
    L_input: np.ndarray
    rotation: np.ndarray
    speed: float
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class JoinResult:
    """A joined flight and its evidence.

    Attributes
    ----------
    motion: the final motion (after the three restoration steps).
    joined: the assembled motion before restoration.
    takeoff, landing: the two :class:`JoinPart`.
    body: the body model used (both motions share one skeleton).
    alignment: yaw (deg) about the vertical, residual angle after it, full-alignment tilt
        (deg), the L elevations/azimuths before.
    seam: ``f`` (take-off part frame), ``g`` (landing part frame), ``distance`` (eq. 5.13),
        ``mean_angle_deg``, ``phi_deg`` (rotation about L spread over the take-off part),
        ``pairs`` (candidates scored), ``tied_pairs`` (candidates tied on cost, decided by the
        module docstring's tie rule),
        ``window`` (frames), ``index`` (frame of the joined motion where ``B`` starts),
        ``root_mismatch_deg`` (body orientation difference perpendicular to L, removed by the
        blend), and the evidence on the output: ``direction_error_seam_rad`` (largest angle
        between L and the target over the blend window), ``direction_error_max_rad`` (whole
        flight), ``direction_error_seam_before_rad`` (before restoration),
        ``direction_error_own_rad`` (the take-off part's own variation), ``magnitude_error_*_frac``
        (fractions; x100 for %), ``velocity_jump_{takeoff,landing}_m_s`` (``(3,)`` COM velocity
        jumps, :func:`boundary_velocity_jumps`), ``..._own_m_s`` (the take-off input's at its
        take-off, the landing input's at its landing), ``..._excess_m_s`` (largest component of
        the difference) and ``violations`` (the :data:`SEAM_LIMITS` exceeded, in words).
    flight: ``(start, stop)`` of the joined flight before restoration.
    restore: the :class:`~mocomp.edit.RestoreResult` of the three steps (its ``stages`` are the
        per-frame errors; ``original`` is the take-off part's own flight).
    landing_tilt_deg: tilt of the final landing relative to the landing part's (yaw-aligned)
        landing, before the upright recovery; ``foot_slide`` (m) of the recovery when used.
    timings: seconds.
    """

    motion: Motion
    joined: Motion
    takeoff: JoinPart
    landing: JoinPart
    body: object
    alignment: dict
    seam: dict
    flight: tuple[int, int]
    restore: RestoreResult
    landing_tilt_deg: float
    foot_slide: float | None
    timings: dict
    notes: tuple[str, ...] = field(default=())

    def summary(self) -> str:
        al, s = self.alignment, self.seam
        lines = [
            f"join: take-off of {self.takeoff.name} (flight {self.takeoff.flight[0]}-{self.takeoff.flight[1] - 1}) + "
            f"landing of {self.landing.name} (flight {self.landing.flight[0]}-{self.landing.flight[1] - 1})",
            f"L_A elevation {al['elevation_takeoff_deg']:.1f} deg, L_B {al['elevation_landing_deg']:.1f} deg; "
            f"landing part turned {al['yaw_deg']:.1f} deg about the vertical, residual {al['residual_deg']:.1f} deg"
            + (f", fully aligned (tilt {al['tilt_deg']:.1f} deg)" if al["full"] else ""),
            f"|L|: {np.linalg.norm(self.takeoff.L_input):.2f} and {np.linalg.norm(self.landing.L_input):.2f} "
            f"kg m^2/s; retimed x{self.takeoff.speed:.3f} and x{self.landing.speed:.3f} to "
            f"{np.linalg.norm(self.takeoff.L):.2f}",
            f"seam: frame {s['f']} of the take-off part ~ frame {s['g']} of the landing part, mean joint-angle "
            f"mismatch {s['mean_angle_deg']:.1f} deg, phi {s['phi_deg']:.1f} deg about L, window {s['window']} frames, "
            f"root mismatch {s['root_mismatch_deg']:.1f} deg (perpendicular to L)",
            f"seam evidence (output): L direction error {s['direction_error_seam_rad']:.3f} rad at the seam "
            f"({s['direction_error_seam_before_rad']:.3f} before restoration; take-off part's own "
            f"{s['direction_error_own_rad']:.3f}), max |L| error {100 * s['magnitude_error_max_frac']:.1f}% "
            f"(own {100 * s['magnitude_error_own_frac']:.1f}%); COM velocity jump take-off "
            f"{_fmt3(s['velocity_jump_takeoff_m_s'])} (own {_fmt3(s['velocity_jump_takeoff_own_m_s'])}), landing "
            f"{_fmt3(s['velocity_jump_landing_m_s'])} (own {_fmt3(s['velocity_jump_landing_own_m_s'])}) m/s"
            + ("" if not s["violations"] else f"; {len(s['violations'])} bound(s) exceeded (see notes)"),
            f"landing tilt {self.landing_tilt_deg:.1f} deg"
            + (f" (eased out after touchdown; feet slide {100 * self.foot_slide:.1f} cm)" if self.foot_slide is not None
               else ""),
            self.restore.summary(),
        ]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def report(self, curves: bool = True) -> dict:
        d = {"takeoff": {"name": self.takeoff.name, "flight": list(self.takeoff.flight),
                         "L_input": self.takeoff.L_input.tolist(), "speed": self.takeoff.speed},
             "landing": {"name": self.landing.name, "flight": list(self.landing.flight),
                         "L_input": self.landing.L_input.tolist(), "speed": self.landing.speed,
                         "rotation": self.landing.rotation.tolist()},
             "alignment": self.alignment, "seam": self.seam, "joined_flight": list(self.flight),
             "landing_tilt_deg": self.landing_tilt_deg, "foot_slide_m": self.foot_slide,
             "timings_s": self.timings, "notes": list(self.notes), "restore": self.restore.report(curves)}
        return json.loads(json.dumps(d, default=float))


def _seam_evidence(res: RestoreResult, ce, mA2, flA2, mB2, flB2, seam: dict, notes: list) -> dict:
    """The transition's evidence: L's direction and magnitude errors over the blend window and
    the whole flight (output and before restoration), the COM velocity jumps at take-off and
    landing of the output against the inputs' own, and the bounds they break (:data:`SEAM_LIMITS`)."""
    fps = res.motion.fps
    lo, hi = (seam["index"] - 1 - seam["window"]) / fps, (seam["index"] + seam["window"]) / fps
    st = res.stages
    fin, ed, own = st["final"], st["edited"], st["original"]

    def in_seam(e, vals):
        m = (e.source_times >= lo) & (e.source_times <= hi)
        return float(np.max(vals[m])) if np.any(m) else 0.0

    comA = ce(mA2.root_positions, mA2.rotations)
    comB = ce(mB2.root_positions, mB2.rotations)
    comF = ce(res.motion.root_positions, res.motion.rotations)
    jt, jl = boundary_velocity_jumps(comF, res.flight_out, fps)
    jt_own = boundary_velocity_jumps(comA, flA2, fps)[0]
    jl_own = boundary_velocity_jumps(comB, flB2, fps)[1]
    ev = {
        "direction_error_seam_rad": in_seam(fin, fin.direction),
        "direction_error_max_rad": fin.max_direction,
        "direction_error_seam_before_rad": in_seam(ed, ed.direction),
        "direction_error_own_rad": own.max_direction,
        "magnitude_error_seam_frac": in_seam(fin, fin.magnitude),
        "magnitude_error_max_frac": fin.max_magnitude,
        "magnitude_error_own_frac": own.max_magnitude,
        "velocity_jump_takeoff_m_s": jt.tolist(), "velocity_jump_landing_m_s": jl.tolist(),
        "velocity_jump_takeoff_own_m_s": jt_own.tolist(), "velocity_jump_landing_own_m_s": jl_own.tolist(),
    }
    lim = SEAM_LIMITS
    viol = []
    if ev["direction_error_max_rad"] > own.max_direction + lim["direction_rad"]:
        viol.append(f"L direction error {ev['direction_error_max_rad']:.2f} rad (at the seam "
                    f"{ev['direction_error_seam_rad']:.2f} rad) exceeds the take-off part's own variation "
                    f"{own.max_direction:.2f} rad by more than {lim['direction_rad']:g} rad")
    if ev["magnitude_error_max_frac"] > max(own.max_magnitude, lim["magnitude_frac"]):
        viol.append(f"|L| error {100 * ev['magnitude_error_max_frac']:.1f}% exceeds "
                    f"{100 * max(own.max_magnitude, lim['magnitude_frac']):.0f}% (the part's own variation or 20%)")
    for where, j, j0 in (("take-off", jt, jt_own), ("landing", jl, jl_own)):
        if np.all(np.isfinite(j)) and np.all(np.isfinite(j0)):
            ex = float(np.max(np.abs(j - j0)))
            ev[f"velocity_jump_{'takeoff' if where == 'take-off' else 'landing'}_excess_m_s"] = ex
            if ex > lim["velocity_jump_m_s"]:
                viol.append(f"COM velocity jump at {where} ({', '.join(f'{v:+.2f}' for v in j)}) m/s differs from "
                            f"the input's own ({', '.join(f'{v:+.2f}' for v in j0)}) by {ex:.2f} m/s, "
                            f"more than {lim['velocity_jump_m_s']:g}")
    ev["violations"] = viol
    notes.extend(f"seam check: {v}" for v in viol)
    return ev


def load_part(source, fps: float | None = None, resample_fps: float = 120.0, min_fps: float = 50.0) -> tuple[Motion, str]:
    """A motion from a :class:`Motion`, a file path or a clip/example name; key-framed clips
    (below ``min_fps``, e.g. DeepMimic's 16 Hz keys) are spline-resampled to ``resample_fps``."""
    if isinstance(source, Motion):
        m, name = source, (source.source.path or "motion")
    else:
        from .. import datasets

        m, name = datasets.load(source, fps=fps), str(source)
    if m.fps < min_fps:
        from ..flips.preprocess import spline_resample

        m = spline_resample(m, resample_fps)
    return m, name


def _skeleton_difference(sa, sb, atol: float = 1e-4) -> str:
    """What differs between two skeletons, in words ('' when they are the same within ``atol`` m)."""
    if sa.names != sb.names:
        if sa.n_joints != sb.n_joints:
            only_a = [n for n in sa.names if n not in sb.names]
            only_b = [n for n in sb.names if n not in sa.names]
            return (f"{sa.n_joints} vs {sb.n_joints} joints (only in the first: {', '.join(only_a[:5]) or '-'}; "
                    f"only in the second: {', '.join(only_b[:5]) or '-'})")
        i = next(i for i, (x, y) in enumerate(zip(sa.names, sb.names)) if x != y)
        return f"joint names differ from joint {i} on ({sa.names[i]!r} vs {sb.names[i]!r})"
    if list(sa.parents) != list(sb.parents):
        i = next(i for i, (x, y) in enumerate(zip(sa.parents, sb.parents)) if x != y)
        return f"the hierarchy differs at joint {sa.names[i]!r}"
    la = np.linalg.norm(np.asarray(sa.offsets, dtype=float), axis=1)
    lb = np.linalg.norm(np.asarray(sb.offsets, dtype=float), axis=1)
    d = np.abs(np.asarray(sa.offsets, dtype=float) - np.asarray(sb.offsets, dtype=float)).max(axis=1)
    if d.max() <= atol:
        return ""
    root = np.asarray(sa.parents) < 0
    bad = np.flatnonzero((d > atol) & ~root)
    parts = []
    if bad.size:
        worst = bad[np.argsort(-np.abs(la[bad] - lb[bad]))][:3]
        lens = "; ".join(f"{sa.names[i]} {100 * la[i]:.1f} vs {100 * lb[i]:.1f} cm" for i in worst)
        parts.append(f"{bad.size} bone offsets differ by more than {1e3 * atol:g} mm (largest length differences: "
                     f"{lens}; largest offset difference {100 * d[bad].max():.1f} cm)")
    for i in np.flatnonzero((d > atol) & root):
        parts.append(f"the root offset of {sa.names[i]} differs by {100 * d[i]:.1f} cm")
    return f"same {sa.n_joints} joint names, but " + " and ".join(parts)


def _detect(motion, body, flight, name: str = "the clip", role: str | None = None):
    """``(flight, warning)``: the flight of ``motion`` (given, or detected), checked for plausible
    free flight (:mod:`mocomp.flips.plausibility`): a detected one that is not is refused
    (:class:`~mocomp.errors.ImplausibleFlightError`), a given one gets a warning (``None`` if fine)."""
    from ..flips.phases import detect_flights
    from ..flips.plausibility import check_detected, enforce_flight

    det = detect_flights(motion, body)
    if flight is not None:
        a, b = int(flight[0]), int(flight[1])
        if not (0 <= a < b <= motion.n_frames and b - a >= 6):
            raise JoinError(f"flight {flight} is not a usable flight of this {motion.n_frames}-frame motion "
                            "(need at least 6 airborne frames)")
    else:
        a, b = det.flight
    override = "flights=((start, stop), None)" if role == "takeoff" else "flights=(None, (start, stop))"
    warning = enforce_flight(check_detected(motion, body, (a, b), det), name, explicit=flight is not None,
                             override=override, source=role)
    return (a, b), warning


def _pick_seam(cost, phi, f, g, flight_a, flight_b, wsum: float) -> tuple[int, int]:
    """The seam's tie rule (see :func:`join_flights`) over candidate pairs ``(f, g)`` with costs
    ``cost`` (eq. 5.13 distance plus the ``|phi|`` penalty; ``inf`` where refused) and rotations
    about L ``phi`` (rad): ``(index of the chosen pair, number of pairs tied on cost)``."""
    tied = choose_tied(cost, wsum, TIE_RTOL, TIE_ATOL)
    n_tied = int(tied.size)
    ap = np.abs(phi[tied])
    tied = tied[ap <= ap.min() + PHI_TOL]
    off_apex = (np.abs(2 * f[tied] - (flight_a[0] + flight_a[1] - 1))
                + np.abs(2 * g[tied] - (flight_b[0] + flight_b[1] - 1)))
    key = np.lexsort((g[tied], f[tied], off_apex))
    return int(tied[key[0]]), n_tied


#: frames; a retimed frame whose source time is within this of a flight's first or last frame
#: counts as that frame (:func:`_retimed`), so a speed of ``1 +- 1e-7`` keeps the flight's frames
FRAME_TOL = 1e-3


def _retimed(motion: Motion, flight, speed: float):
    """``motion`` retimed by ``speed`` (eq. 5.8) and its flight's frames there: frame ``j`` shows
    source frame ``j speed``; the flight is the ``j`` with ``a - tol <= j speed <= b - 1 + tol``
    (``tol`` = :data:`FRAME_TOL`). Without the tolerance a speed of ``1 + 7e-8`` (|L| matched between
    a motion and a copy perturbed by 1e-7) dropped the last flight frame and ``1 - 5e-8`` the
    first, moving the seam's apex criterion by a frame."""
    if abs(speed - 1.0) < 1e-12:
        return motion, flight
    m = motion.retime(speed)
    a = int(np.ceil((flight[0] - FRAME_TOL) / speed))
    b = int(np.floor((flight[1] - 1 + FRAME_TOL) / speed)) + 1
    return m, (a, min(b, m.n_frames))


def _mean_L(body, motion, flight):
    L = flight_momentum(body, motion, flight)
    return np.nanmean(L[flight[0] + 1:flight[1] - 1], axis=0)


def join_flights(takeoff, landing, *, body=None, flights=(None, None), match: str = "takeoff",
                 full_alignment: bool = True, align_tol_deg: float = 3.0, max_tilt_deg: float = 45.0,
                 margin: float = 0.15, window_s: float = 0.1, phi_weight: float | None = None,
                 max_phi_deg: float = 120.0, max_root_mismatch_deg: float = 120.0, takeoff_height: float = 0.0, k_ratio: float | None = None,
                 k: float | None = None, upright: bool = True, recover_s: float = 0.3,
                 direction_step: bool = False, polish: bool = True, gravity="standard") -> JoinResult:
    """Join the take-off of ``takeoff`` with the landing of ``landing`` in mid-flight (section 6).

    Parameters
    ----------
    takeoff, landing: :class:`Motion`, file paths or clip names (same skeleton).
    body: body model (default: the take-off clip's prior -- DeepMimic's own masses for
        DeepMimic clips, de Leva's table otherwise; both motions share it).
    flights: ``(start, stop)`` flights of the two inputs (default: detected, section 4.1).
    match: which |L| both parts are retimed to: ``"takeoff"``, ``"landing"`` or ``"mean"``.
    full_alignment, align_tol_deg, max_tilt_deg: step 1 (see the module docstring).
    margin: fraction of each flight excluded at its ends from the frame search.
    window_s: seam blending half-window, seconds.
    phi_weight: weight of ``|phi|`` (rad) in the search (default: the similarity's root weight).
    max_phi_deg: largest rotation about L the seam may need.
    max_root_mismatch_deg: largest root orientation mismatch (perpendicular to L) at the seam.
    takeoff_height, k_ratio, k: step 3 (App. B height change, retiming; default ``k = k*``).
    upright: ease a landing tilt (full alignment, accumulated direction corrections) out over
        ``recover_s`` seconds after touchdown, about the ground point under the COM.
    direction_step: also run step 1 (direction of L, eq. 5.21) over the joined flight. Off by
        default, as in the paper: the aligned flights share L's direction, and "although during the
        transition the angular momentum will not be constant, we can adjust it by applying
        non-uniform motion retiming" (section 5.2); the transition's brief direction change is
        reported. Step 1 would turn the whole landing part to absorb it (a tilted landing).
    polish: final direction sweep when ``direction_step`` (see :func:`~mocomp.edit.restore_momentum`).
    gravity: the joined flight's gravity: ``"standard"`` (9.81 m/s^2, default), ``"clip"`` (the take-off
        part's fitted gravity) or m/s^2 (:func:`~mocomp.edit.linear.resolve_gravity`).

    The landing comes to rest on the floor ``takeoff`` took off from (:mod:`mocomp.edit.landing`).

    The transition pair is the lowest-cost one up to the documented tie rule (module docstring,
    *The seam's tie rule*: cost ties within ``TIE_RTOL``/``TIE_ATOL``, then the smallest ``|phi|``,
    then nearest both flights' middle, then the earliest frames).

    The seam's direction error and the take-off/landing velocity jumps are not removed (see
    the module docstring's *Limitation*); they are measured and reported in ``seam``, and the
    bounds they exceed are listed in ``seam["violations"]`` and the notes.
    """
    t0 = time.perf_counter()
    timings = {}
    notes: list[str] = []
    if match not in ("takeoff", "landing", "mean"):
        raise ValueError(f"match must be 'takeoff', 'landing' or 'mean', got {match!r}")
    mA, nameA = load_part(takeoff)
    mB, nameB = load_part(landing)
    why = _skeleton_difference(mA.skeleton, mB.skeleton)
    if why:
        raise JoinError(f"{nameA} and {nameB} have different skeletons: {why}; joining needs one body model "
                        "(the same joints and bone lengths): retarget one onto the other first")
    if mB.fps != mA.fps:
        mB = mB.resample(mA.fps)
        notes.append(f"{nameB} resampled to {mA.fps:g} Hz")
    if body is None:
        from ..flips.preprocess import clip_prior

        body = clip_prior(mA)
    flA, warnA = _detect(mA, body, flights[0], nameA, "takeoff")
    flB, warnB = _detect(mB, body, flights[1], nameB, "landing")
    notes += [w for w in (warnA, warnB) if w]
    LA0, LB0 = _mean_L(body, mA, flA), _mean_L(body, mB, flB)
    for nm, L in ((nameA, LA0), (nameB, LB0)):
        if not np.linalg.norm(L) > 1e-3:
            raise JoinError(f"{nm}'s flight has no angular momentum (|L| = {np.linalg.norm(L):.2e}); there is no "
                            "rotation to join")
    timings["load"] = time.perf_counter() - t0
    # ---------------------------------------------------------------- 1. align L directions
    t = time.perf_counter()
    hA, hB = np.array([LA0[0], LA0[2]]), np.array([LB0[0], LB0[2]])
    yaw = 0.0
    if np.linalg.norm(hA) > 0.1 * np.linalg.norm(LA0) and np.linalg.norm(hB) > 0.1 * np.linalg.norm(LB0):
        yaw = float(np.arctan2(LA0[0], LA0[2]) - np.arctan2(LB0[0], LB0[2]))
    q_yaw = _axis_quat([0.0, 1.0, 0.0], yaw)
    LB1 = quat_apply(q_yaw, LB0)
    resid = float(np.degrees(np.arccos(np.clip(_unit(LA0) @ _unit(LB1), -1, 1))))
    q_B = q_yaw
    tilt = 0.0
    full = False
    if resid > align_tol_deg:
        if not full_alignment or resid > max_tilt_deg:
            raise JoinError(
                f"the flights' angular momentum directions cannot be aligned: L of {nameA} points "
                f"{_elevation_deg(LA0):+.1f} deg above the horizontal (azimuth {_azimuth_deg(LA0):.0f} deg), L of "
                f"{nameB} {_elevation_deg(LB0):+.1f} deg (azimuth {_azimuth_deg(LB0):.0f} deg); after turning "
                f"{nameB} {np.degrees(yaw):.1f} deg about the vertical they still differ by {resid:.1f} deg, and the "
                + (f"full alignment would tilt its landing by that much (limit max_tilt_deg = {max_tilt_deg:g})"
                   if full_alignment else "full alignment is disabled")
                + "; join flights that rotate about similar axes (e.g. a back flip with a side flip)")
        q_full = shortest_arc(LB1, LA0)
        q_B = quat_multiply(q_full, q_yaw)
        tilt, full = resid, True
        notes.append(f"L directions differ by {resid:.1f} deg after the turn about the vertical: the landing part "
                     f"is tilted by that much to align them (full alignment)")
    from ..flips.reposition import ComEvaluator

    ce = ComEvaluator(body)
    comB = ce(mB.root_positions[flB[0]:flB[0] + 1], mB.rotations[flB[0]:flB[0] + 1])[0]
    mB_al = mB.rotated(q_B, center=comB)
    LB = quat_apply(q_B, LB0)
    timings["align"] = time.perf_counter() - t
    # ---------------------------------------------------------------- 2. match |L| by retiming
    t = time.perf_counter()
    nA, nB = float(np.linalg.norm(LA0)), float(np.linalg.norm(LB))
    target = {"takeoff": nA, "landing": nB, "mean": float(np.sqrt(nA * nB))}[match]
    sA, sB = target / nA, target / nB
    for nm, sp in ((nameA, sA), (nameB, sB)):
        if not 0.25 <= sp <= 4.0:
            raise JoinError(f"matching |L| would retime {nm} by x{sp:.2f} (|L| {nA:.1f} vs {nB:.1f} kg m^2/s); "
                            "beyond x0.25-x4 finite-difference momentum is unreliable (eq. 5.8): join flights of "
                            "comparable angular momentum or choose match='mean'")
        if not 0.5 <= sp <= 2.0:
            notes.append(f"{nm} is retimed by x{sp:.2f}: outside the x0.5-x2 range in which the paper found "
                         "retiming errors below 20% (section 5.1)")
    mA2, flA2 = _retimed(mA, flA, sA)
    mB2, flB2 = _retimed(mB_al, flB, sB)
    LA2, LB2 = _mean_L(body, mA2, flA2), _mean_L(body, mB2, flB2)
    u = _unit(LA2)
    timings["retime_parts"] = time.perf_counter() - t
    # ---------------------------------------------------------------- 3. frame search
    t = time.perf_counter()
    from ..flips.similarity import frame_distance, similarity_weights, twist_angle

    weights = similarity_weights(mA.skeleton)
    rA = make_continuous(np.asarray(mA2.rotations), axis=0)
    rB = make_continuous(np.asarray(mB2.rotations), axis=0)

    def window(fl):
        n = fl[1] - fl[0]
        mg = max(2, int(np.ceil(margin * n)))
        return np.arange(fl[0] + mg, fl[1] - 1 - mg)

    fA, gB = window(flA2), window(flB2)
    if fA.size == 0 or gB.size == 0:
        raise JoinError(f"the flights are too short to search for a transition ({flA2[1] - flA2[0]} and "
                        f"{flB2[1] - flB2[0]} frames after retiming)")
    FA, GB = np.meshgrid(fA, gB, indexing="ij")
    D, phi = frame_distance(rA[FA.ravel()], rB[GB.ravel()], u, weights)
    # phi: eq. 5.12's alignment angle (wrapped); the exact twist difference of the roots about L
    tw = twist_angle(quat_multiply(rB[GB.ravel(), 0], quat_inverse(rA[FA.ravel(), 0])), u)
    tw = (tw + np.pi) % (2 * np.pi) - np.pi
    pw = weights.root if phi_weight is None else float(phi_weight)
    cost = D + pw * np.abs(tw)
    ok = np.abs(tw) <= np.radians(max_phi_deg)
    if not np.any(ok):
        raise JoinError(f"no frame pair of the two flights is within {max_phi_deg:g} deg of rotation about L "
                        f"(closest {np.degrees(np.abs(tw).min()):.0f} deg)")
    cost = np.where(ok, cost, np.inf)
    wsum = weights.root + float(np.sum(weights.joints))
    k_best, n_tied = _pick_seam(cost, tw, FA.ravel(), GB.ravel(), flA2, flB2, wsum)
    f, g = int(FA.ravel()[k_best]), int(GB.ravel()[k_best])
    phi_f = float(tw[k_best])
    seam = {"f": f, "g": g, "distance": float(D[k_best]), "mean_angle_deg": float(np.degrees(D[k_best] / wsum)),
            "phi_deg": float(np.degrees(phi_f)), "pairs": int(D.size), "tied_pairs": n_tied}
    timings["search"] = time.perf_counter() - t
    # ---------------------------------------------------------------- assemble + blend
    t = time.perf_counter()
    a0 = flA2[0]
    rotA = np.array(rA[:f + 1])
    rpA = np.array(mA2.root_positions[:f + 1])
    # turn A's flight about L by a ramp reaching phi at f (about each frame's COM)
    lam = np.clip((np.arange(f + 1) - a0) / max(f - a0, 1), 0.0, 1.0)
    qr = _axis_quat(u, phi_f * lam)
    comA = ce(rpA, rotA)
    rotA[:, 0] = quat_multiply(qr, rotA[:, 0])
    rpA = comA + quat_apply(qr, rpA - comA)
    # B from g+1, translated so its COM continues A's with A's velocity at f
    comB2 = ce(mB2.root_positions, mB2.rotations)
    vA = (comA[f] - comA[f - 1]) * mA2.fps
    shift = comA[f] + vA / mA2.fps - comB2[g + 1]
    rotB = np.array(rB[g + 1:])
    rpB = np.array(mB2.root_positions[g + 1:]) + shift
    rot = np.concatenate([rotA, rotB])
    rp = np.concatenate([rpA, rpB])
    rot = make_continuous(rot, axis=0)
    landing_idx = f + (flB2[1] - 1 - g)
    fl_joined = (a0, landing_idx + 1)
    w = max(1, int(round(window_s * mA2.fps)))
    w = int(min(w, f - a0 - 2, flB2[1] - 3 - g))
    w = max(w, 1)
    seam["window"] = w
    seam["index"] = f + 1
    # cross-fade the matched pair (A_f ~ B_g) across the seam (joints and root, see .seams)
    from .seams import crossfade

    seam["root_mismatch_deg"] = crossfade(rot, rp, f, rotA[f], rB[g], w, ce)
    if seam["root_mismatch_deg"] > max_root_mismatch_deg:
        raise JoinError(
            f"at the best transition (frame {f} of {nameA} ~ frame {g} of {nameB}) the bodies are oriented "
            f"{seam['root_mismatch_deg']:.0f} deg apart about an axis perpendicular to L (limit "
            f"max_root_mismatch_deg = {max_root_mismatch_deg:g}): the two flights rotate the body in opposite "
            "senses (e.g. a forward and a backward somersault), so no smooth mid-air transition exists")
    joined = mA2.replace(root_positions=rp, rotations=rot)
    timings["assemble"] = time.perf_counter() - t
    # ---------------------------------------------------------------- 4. restore the whole
    t = time.perf_counter()
    from ..flips.mass import fit_ballistic

    fitA = fit_ballistic(ce(mA2.root_positions[flA2[0]:flA2[1]], mA2.rotations[flA2[0]:flA2[1]]), mA2.fps, flA2[0])
    # the intended landing: the joined motion's landing part without the full alignment's tilt,
    # resting on the floor A took off from (the landing part came with B's floor, moved by the
    # translation that continues A's COM at the seam: 23-33 cm below A's for CMU 88_01 + 88_05)
    from .landing import floor_level, lowest_heights

    q_untilt = quat_multiply(q_yaw, quat_inverse(q_B))
    floor_A = floor_level(lowest_heights(mA2, 0, max(flA2[0], 1)), mA2.fps)
    res = three_steps(body, joined, fl_joined, LA2, fitA, original=mA2, original_flight=flA2, k=k,
                      k_ratio=k_ratio, takeoff_height=takeoff_height, polish=polish, com_eval=ce,
                      direction=direction_step, upright_ref=joined, upright_pre=q_untilt,
                      recover_s=recover_s if upright else 0.0, landing_floor=floor_A, gravity=gravity,
                      stances="as-is")   # a join's seams are judged on their own (its take-off and landing
    # stances come from two clips; the audit refuses most joins anyway): the stance smoothing of edit and
    # twist is not applied here
    timings["restore"] = time.perf_counter() - t
    out = res.motion
    tilt_land = res.landing_tilt_deg
    slide = res.foot_slide
    seam.update(_seam_evidence(res, ce, mA2, flA2, mB2, flB2, seam, notes))
    timings["total"] = time.perf_counter() - t0
    partA = JoinPart(nameA, mA2, flA2, LA2, LA0, np.array([0.0, 0.0, 0.0, 1.0]), sA)
    partB = JoinPart(nameB, mB2, flB2, LB2, LB0, q_B, sB)
    alignment = {"yaw_deg": float(np.degrees(yaw)), "residual_deg": resid, "tilt_deg": tilt, "full": full,
                 "elevation_takeoff_deg": _elevation_deg(LA0), "elevation_landing_deg": _elevation_deg(LB0),
                 "azimuth_takeoff_deg": _azimuth_deg(LA0), "azimuth_landing_deg": _azimuth_deg(LB0),
                 "angle_after_deg": float(np.degrees(np.arccos(np.clip(_unit(LA2) @ _unit(LB2), -1, 1))))}
    return JoinResult(motion=out, joined=joined, takeoff=partA, landing=partB, body=body, alignment=alignment,
                      seam=seam, flight=fl_joined, restore=res, landing_tilt_deg=tilt_land, foot_slide=slide,
                      timings=timings, notes=tuple(notes))
