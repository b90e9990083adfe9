"""The pre-processing stage, once per clip (flips paper section 4; dissertation section 5.3).

:func:`prepare` turns a single-flip clip into a :class:`PreparedFlip`: the motion as
used (frame-rate corrections and resampling applied), the detected flight, the
estimated mass distribution and inertias, momentum per frame, the angular
momentum direction, the root split about it, the similarity weights and the
self-looping fragment. Everything the run-time stage needs is precomputed and
cached here, so :func:`mocomp.flips.multiflip` only sequences, smooths, retimes
and repositions.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..body.model import BodyModel
from ..core.motion import Motion
from ..core.rotations import make_continuous
from ..errors import PhysicsError
from .looping import SelfLoop, find_self_loop
from .mass import FlightFit, MassEstimate, diagnose_gravity, estimate_masses, fit_ballistic
from .phases import FlightDetection, default_prior, detect_flights
from .reposition import ComEvaluator
from .similarity import SimilarityWeights, local_angular_velocities, similarity_weights
from .smoothing import AngularMomentumEvaluator, loop_seams, split_root_about

__all__ = ["PreparedFlip", "prepare", "prepare_cached", "clip_prior", "spline_resample", "flight_L_stats",
           "clip_timing"]


def spline_resample(motion: Motion, fps: float) -> Motion:
    """Resample sparse key frames smoothly: cubic spline through root positions and a C2
    rotation spline (``scipy.spatial.transform.RotationSpline``) per joint.

    Used for key-framed clips (DeepMimic's 16 Hz keys): slerp/linear resampling makes
    velocities piecewise constant, which breaks flight detection and momentum.
    """
    from scipy.interpolate import CubicSpline
    from scipy.spatial.transform import Rotation, RotationSpline

    t = motion.times
    n = int(np.floor(motion.duration * fps + 1e-9)) + 1
    tn = np.arange(n) / fps
    rp = CubicSpline(t, motion.root_positions, axis=0)(tn)
    rot = np.stack([RotationSpline(t, Rotation.from_quat(motion.rotations[:, j]))(tn).as_quat()
                    for j in range(motion.skeleton.n_joints)], axis=1)
    src = dataclasses.replace(motion.source, notes=motion.source.notes + (
        f"resampled from {motion.fps:g} Hz key frames to {fps:g} Hz with cubic / rotation splines",))
    return motion.replace(root_positions=rp, rotations=rot, fps=float(fps), source=src)


def clip_prior(motion: Motion, total_mass: float = 70.0, table: str = "de_leva_male",
               shape: str = "ellipsoid") -> BodyModel:
    """The prior mass distribution for a clip: the DeepMimic character's own masses for
    DeepMimic clips and for files whose skeleton is a known DeepMimic character's (e.g. a BVH the
    project wrote from one: :func:`mocomp.io.deepmimic.recognized_body`), else the table (de Leva
    1996 male by default)."""
    if motion.source.format == "deepmimic":
        from ..io.deepmimic import read_deepmimic_body

        for note in motion.source.notes:
            if note.startswith("character "):
                return read_deepmimic_body(note[len("character "):], motion.skeleton)
    body = _recognized(motion)
    if body is not None:
        return body
    return default_prior(motion.skeleton, total_mass=total_mass, table=table, shape=shape)


def _recognized(motion: Motion):
    """The DeepMimic character's body for a BVH file whose skeleton is a known character's (what the
    project writes from a DeepMimic clip); ``None`` for anything else, motions made in memory
    (synthetic, edited) included: they carry their body model with them."""
    if motion.source.format != "bvh":
        return None
    from ..io.deepmimic import recognized_body

    return recognized_body(motion.skeleton)


def _own_character(motion: Motion) -> bool:
    """The clip's character is known (a DeepMimic clip naming it, or a skeleton recognised as a
    DeepMimic character's): :func:`clip_prior` is its bodies' own masses."""
    if motion.source.format == "deepmimic":
        return any(n.startswith("character ") for n in motion.source.notes)
    return _recognized(motion) is not None


def flight_L_stats(L: np.ndarray, start: int, stop: int, margin: int = 1) -> dict:
    """``|L|`` over a flight's interior (``margin`` frames dropped at each end, where central
    differences straddle take-off/landing): ``mean``; ``variation``, the largest relative
    deviation from the mean; ``std``, the coefficient of variation; ``range``, peak to peak
    over the mean.

    What to expect: a ballistic flip sampled at 16 Hz key frames (synthetic, exact constant
    ``L``) comes out at 16 % / 5 % (variation / std) after spline resampling; CMU 88_01 at
    ~22 %. The DeepMimic back flip reports 62 % / 33 %, and that is the clip itself, not the
    pipeline: on its raw 16 Hz keys, with the character file's own masses (de Leva's: the same within 10 %),
    ``|L|`` falls from 57 to 22 kg m^2/s while both feet are > 0.3 m up (keys 14-18), because
    the body tucks (composite inertia about the somersault axis 5.1 -> 2.6 kg m^2) while the
    root keeps turning at ~8.5 rad/s, and the COM's horizontal speed drops from 1.5 to
    0.3-0.7 m/s (rms 30 mm off a straight line). Trimming the flight ends or swapping the mass
    table does not change this (tests/test_deepmimic_flight_physics.py)."""
    a, b = start + margin, stop - margin
    if b - a < 2:
        a, b = start, stop
    mag = np.linalg.norm(np.asarray(L)[a:b], axis=1)
    mean = float(mag.mean())
    ok = mean > 0
    return {"mean": mean, "variation": float(np.max(np.abs(mag - mean)) / mean) if ok else float("nan"),
            "std": float(mag.std() / mean) if ok else float("nan"),
            "range": float(np.ptp(mag) / mean) if ok else float("nan"), "frames": (a, b)}


@dataclass(frozen=True, eq=False)
class PreparedFlip:
    """A single-flip clip prepared for the run-time stage (all fields immutable).

    Attributes
    ----------
    motion: the clip as used (corrections, resampling applied; see ``notes``).
    name: where it came from.
    prior: the table model the masses started from; body: the estimated one.
    detection: all ballistic intervals (:class:`~mocomp.flips.phases.FlightDetection`).
    flight: ``(start, stop)`` half-open frames of the flight used.
    mass: the :class:`~mocomp.flips.mass.MassEstimate` (``None`` when estimation was skipped).
    mass_used: ``body`` carries ``mass``'s masses (``False`` when estimation was skipped or the
        estimate was set aside because it did not reduce the momentum deviation; see ``notes``).
    fit: ballistic COM trajectory of the flight with the body used (``a_x .. c_y``, gravity).
    momentum: :class:`~mocomp.dynamics.MomentumResult` with ``body`` (eq. 5.4-5.5).
    axis: ``(3,)`` unit direction of the mean angular momentum over the flight.
    L_stats: ``|L|`` over the flight interior (:func:`flight_L_stats`).
    rotations: ``(T, J, 4)`` sign-continuous local rotations.
    theta, bdir: root split about ``axis`` (eq. 5.14; :func:`~mocomp.flips.smoothing.split_root`)
        relative to the fixed offset ``root_ref``.
    omegas: ``(T, J, 3)`` local angular velocities when the similarity uses them, else ``None``.
    weights: eq. 5.13 weights; loop: the self-looping fragment (eq. 5.9).
    com_eval: fast exact COM for the estimated body; com: ``(T, 3)`` COM of ``motion``.
    smooth_sigma: momentum pre-smoothing (frames) used here and in the report.
    timings: seconds per pre-processing step.
    timing: :class:`~mocomp.flips.mass.TimingDiagnosis` over all the clip's flights (frame-rate check).
    """

    motion: Motion
    name: str
    prior: BodyModel
    body: BodyModel
    detection: FlightDetection
    flight: tuple[int, int]
    mass: MassEstimate | None
    fit: FlightFit
    momentum: object
    axis: np.ndarray
    L_stats: dict
    rotations: np.ndarray
    theta: np.ndarray
    bdir: np.ndarray
    root_ref: np.ndarray
    omegas: np.ndarray | None
    weights: SimilarityWeights
    loop: SelfLoop
    com_eval: ComEvaluator
    com: np.ndarray
    smooth_sigma: float | None
    timings: dict
    notes: tuple[str, ...] = ()
    _cache: dict = field(default_factory=dict, repr=False)
    timing: object = None
    mass_used: bool = False

    @property
    def fps(self) -> float:
        return self.motion.fps

    @property
    def total_rotation(self) -> float:
        """Radians of root rotation about ``axis`` from the first to the last frame."""
        return float(self.theta[-1] - self.theta[0])

    def default_window(self, retime: bool = True) -> int:
        """Seam smoothing half-window in frames (:meth:`best_window`): the smallest of about
        40 ms x 1 .. 8 (within the loop period) whose loop seam disturbs ``L`` least."""
        return self.best_window(retime)

    def _loop_seams(self, windows) -> None:
        """Compute (once) the loop seam of each half-window in ``windows`` that is not cached yet,
        all of them in one pass (:func:`~mocomp.flips.smoothing.loop_seams`)."""
        todo = [int(w) for w in dict.fromkeys(windows) if ("loop_seam", int(w)) not in self._cache]
        if not todo:
            return
        for w, (left, right, L_new, L_ref, sp_left, sp_right) in loop_seams(self, todo).items():
            self._cache[("loop_seam", w)] = (left, right)
            self._cache[("loop_seam_L", w)] = (L_new, L_ref)
            self._cache[("loop_seam_speed", w)] = (sp_left, sp_right)

    def loop_seam(self, window: int):
        """The loop seam correction ``f_{n-1} -> R(f_m)``, computed once and reused for every
        repetition (section 5.4.2.2): ``(left (w+1, J, 4), right (w+1, J, 4))`` smoothed
        rotations of source frames ``n-1-w .. n-1`` and ``m .. m+w``, the root recomposed
        from its own rotation about ``L`` and the smoothed perpendicular part (eq. 5.14), at
        zero extra rotation (a copy's rotation about ``L`` is applied on the left later);
        :func:`~mocomp.flips.smoothing.loop_seams`."""
        self._loop_seams([window])
        return self._cache[("loop_seam", int(window))]

    @property
    def L_magnitude(self) -> np.ndarray:
        """``(T,)`` ``|L|`` of the clip (estimated masses), frame by frame."""
        key = "L_magnitude"
        if key not in self._cache:
            mag = np.linalg.norm(np.asarray(self.momentum.angular), axis=1)
            mag.setflags(write=False)
            self._cache[key] = mag
        return self._cache[key]

    @property
    def momentum_evaluator(self) -> AngularMomentumEvaluator:
        """:class:`~mocomp.flips.smoothing.AngularMomentumEvaluator` of the estimated body (cached)."""
        key = "L_eval"
        if key not in self._cache:
            self._cache[key] = AngularMomentumEvaluator(self.body)
        return self._cache[key]

    def _loop_seam_momentum(self, window: int) -> tuple[np.ndarray, np.ndarray]:
        """``(L_new, L_ref)``, both ``(2w+4, 3)``: angular momentum of the smoothed loop seam at the
        sequence's own timing and the original's at those source frames (rotated with the copy),
        its level blended across the seam like the poses (:func:`~mocomp.flips.smoothing.loop_seams`)."""
        self._loop_seams([window])
        return self._cache[("loop_seam_L", int(window))]

    def loop_seam_speed(self, window: int) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 5.22 playback speeds across the loop seam ``f_{n-1} -> R(f_m)`` (section 5.4.2.2:
        "resulting changes in momentum can be adjusted by non-uniform retiming"), computed once
        and reused for every repetition like :meth:`loop_seam` (a rotation about ``L`` leaves
        ``|L|`` unchanged): ``(left (w+2,), right (w+2,))`` for the sequence frames showing source
        frames ``n-2-w .. n-1`` and ``m .. m+w+1`` (the smoothed window plus the neighbour whose
        central difference reaches into it). See :mod:`mocomp.flips.smoothing`."""
        self._loop_seams([window])
        return self._cache[("loop_seam_speed", int(window))]

    def seam_disturbance(self, window: int, retime: bool = True) -> float:
        """Largest change of the angular momentum vector the loop seam makes, over the flight's
        mean ``|L|``: ``max |s L_new - L_ref| / |L|`` over the seam frames, with ``s`` the eq. 5.22
        speeds when ``retime`` (which fix the magnitude, not the direction) else 1."""
        L_new, L_ref = self._loop_seam_momentum(int(window))
        s = np.ones(L_new.shape[0])
        if retime:
            left, right = self.loop_seam_speed(int(window))
            s = np.concatenate([left, right])
        dev = np.linalg.norm(s[:, None] * L_new - L_ref, axis=1)
        return float(dev.max() / max(self.L_stats["mean"], 1e-12))

    def seam_windows(self) -> list[int]:
        """Candidate seam half-windows: about 40 ms times 1, 1.5, 2, 3, 4, 6, 8, within the loop period."""
        w0 = max(1, int(round(0.04 * self.fps)))
        wmax = max(1, (self.loop.period - 2) // 2)
        return sorted({int(min(max(1, round(w0 * f)), wmax)) for f in (1, 1.5, 2, 3, 4, 6, 8)})

    def best_window(self, retime: bool = True) -> int:
        """The seam half-window that disturbs the angular momentum least (:meth:`seam_disturbance`
        over :meth:`seam_windows`), preferring the smallest within 10 % of the best: section 5.4.2.2
        smooths "over small windows"; how small is left open, and a twist jump's small ``|L|``
        needs wider ones than a somersault. Computed once per clip."""
        key = ("best_window", bool(retime))
        if key not in self._cache:
            ws = self.seam_windows()
            self._loop_seams(ws)                # every candidate window in one pass
            d = np.array([self.seam_disturbance(w, retime) for w in ws])
            ok = np.flatnonzero(d <= 1.1 * d.min() + 1e-3)
            self._cache[key] = int(ws[int(ok[0])])
        return self._cache[key]

    def summary(self) -> str:
        s, e = self.flight
        lines = [f"{self.name}: {self.motion.n_frames} frames at {self.fps:g} Hz; flight frames {s}-{e - 1} "
                 f"({(e - s) / self.fps:.3f} s), rotation about L in the clip {np.degrees(self.total_rotation):.0f} deg",
                 f"  gravity {self.fit.gravity:.2f} m/s^2 in this flight (s = {self.fit.scale:.2f}); timing over "
                 f"the clip's flights: "
                 + (self.timing.text if self.timing is not None else diagnose_gravity(self.fit.scale, self.fps)),
                 f"  |L| {self.L_stats['mean']:.2f} kg m^2/s over the flight, variation {100 * self.L_stats['variation']:.1f}%",
                 f"  self-loop m={self.loop.m} n={self.loop.n} phi={np.degrees(self.loop.phi):.0f} deg, "
                 f"mean mismatch {self.loop.mean_angle_deg:.1f} deg" + ("" if self.loop.found else " (fallback)")]
        if self.mass is not None:
            red = self.mass.reduction
            lines.append(f"  masses: linear-momentum deviation from the ballistic pattern "
                         f"{self.mass.prior_momentum_deviation:.3f} -> {self.mass.momentum_deviation:.3f} kg m/s "
                         + (f"({100 * red:.0f}% reduction)" if np.isfinite(red) else "(already ballistic with the prior)")
                         + ("" if self.mass_used else "; prior masses used"))
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)


def clip_timing(body: BodyModel, motion: Motion, flights, flight: tuple[int, int] | None = None,
                min_frames: int = 6, com_eval: ComEvaluator | None = None):
    """:func:`~mocomp.flips.mass.diagnose_timing` over every flight of a clip (``flights``, plus
    ``flight`` if it is not among them; flights under ``min_frames`` frames are skipped), the
    COM computed with ``body`` (by ``com_eval``, its :class:`~mocomp.flips.reposition.ComEvaluator`,
    when the caller has one): one flip gives a wide interval, several flights of the clip (hops
    before and after) narrow it."""
    from .mass import diagnose_timing, flight_turns

    fls = [(int(a), int(b)) for a, b in flights]
    if flight is not None and tuple(flight) not in fls:
        fls.append((int(flight[0]), int(flight[1])))
    fls = [f for f in fls if f[1] - f[0] >= min_frames] or fls
    com = (ComEvaluator(body) if com_eval is None else com_eval)(motion.root_positions, motion.rotations)
    fls = [f for f in sorted(fls) if f[1] - f[0] >= 4]
    fits = [fit_ballistic(com[a:b], motion.fps, a) for a, b in fls]
    return diagnose_timing(fits, motion.fps, motion.skeleton.height(), turns=flight_turns(motion, fls))


def _load(source, fps):
    if isinstance(source, Motion):
        m = source if fps is None else source.with_fps(fps)
        return m, (m.source.path or "motion")
    from .. import datasets

    return datasets.load(source, fps=fps), str(source)


def prepare(source, *, body: BodyModel | None = None, total_mass: float = 70.0, table: str = "de_leva_male",
            shape: str = "ellipsoid", fps: float | None = None, fix_timing: bool = False,
            min_fps: float = 50.0, resample_fps: float = 120.0, flight: tuple[int, int] | None = None,
            estimate: bool | str = "auto", joint_flights: bool = False, W: float = 1e-2,
            smooth_sigma: float | None = None, weight_overrides: dict | None = None,
            velocity_weight: float = 0.0, loop_options: dict | None = None,
            keep_prior_if_worse: bool = True) -> PreparedFlip:
    """Pre-process a single-flip clip (sections 4.1-4.3 and the self-looping search).

    Parameters
    ----------
    source: a :class:`Motion`, a file path, an embedded example name ("backflip") or a
        real clip name (``mocomp.datasets.load`` applies its known corrections).
    body: the prior body model (default: :func:`clip_prior` with ``total_mass``,
        ``table``, ``shape``).
    fps: frame rate to use instead of the file's.
    fix_timing: when the flight's gravity fit says the frame rate is mislabelled (e.g. a
        60 Hz capture stamped 120 Hz), relabel it and start over (the note says so);
        otherwise the clip is used as is and the diagnosis is reported.
    min_fps, resample_fps: clips below ``min_fps`` (key frames) are spline-resampled to
        ``resample_fps`` first.
    flight: force the flight frames ``(start, stop)`` instead of detecting them.
    estimate: estimate the masses (eq. 5.1-5.2); ``False`` keeps the prior; ``"auto"`` (default): estimate
        them unless the prior is the clip's own character (a DeepMimic clip names the character its
        motion was simulated with: its masses are known, and an estimate from its flight, which is
        not ballistic, is worse: its x2 flight planned with the estimated masses read 0.67 m/s COM
        velocity jumps with the character's (the audit's body), against the input's 0.33; planned with
        the character's, 0.58, and 0.45 with ``mocomp flips``'s stance smoothing). ``True`` estimates
        them anyway.
    joint_flights: estimate from every detected flight jointly (e.g. hops before the flip).
    W: regulariser of eq. 5.2 (see :mod:`mocomp.flips.mass`).
    keep_prior_if_worse: when the estimate does not reduce the linear-momentum deviation from
        the ballistic pattern relative to the prior (``mass.reduction <= 0``; CMU 90_08 at the
        default ``W``: -2.2 %), use the prior masses instead; ``mass`` still holds the estimate,
        ``mass_used`` is ``False`` and a note says so (it reaches the physics report's notes).
    smooth_sigma: Gaussian pre-smoothing (frames) for momentum; ``None`` = none.
    weight_overrides, velocity_weight: similarity weights (:func:`similarity_weights`).
    loop_options: keyword arguments for :func:`~mocomp.flips.looping.find_self_loop`.
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    motion, name = _load(source, fps)
    notes: list[str] = []
    if motion.fps < min_fps:
        notes.append(f"key frames at {motion.fps:g} Hz were spline-resampled to {resample_fps:g} Hz")
        motion = spline_resample(motion, resample_fps)
    timings["load"] = time.perf_counter() - t0
    for attempt in range(2):
        t = time.perf_counter()
        prior = clip_prior(motion, total_mass, table, shape) if body is None else body
        det = detect_flights(motion, prior)
        timings["phases"] = time.perf_counter() - t
        if flight is None:
            fl = det.flight
        else:
            fl = (int(flight[0]), int(flight[1]))
            if not (0 <= fl[0] < fl[1] <= motion.n_frames):
                raise ValueError(f"flight={flight} is outside the clip's {motion.n_frames} frames")
        t = time.perf_counter()
        if estimate not in (True, False, "auto"):
            raise ValueError(f"estimate must be True, False or 'auto', got {estimate!r}")
        known = body is None and _own_character(motion)
        if estimate is True or (estimate == "auto" and not known):
            flights = det.intervals if (joint_flights and det.flights) else [fl]
            if fl not in flights:
                flights = [fl] + list(flights)
            mass = estimate_masses(prior, motion, flights, W=W)
            est = mass.body
            fit = next(f for f in mass.fits if (f.start, f.stop) == fl)
            if keep_prior_if_worse and np.isfinite(mass.reduction) and not mass.reduction > 0:
                # eq. 5.1-5.2 did not make the flight more ballistic (e.g. CMU 90_08: -2.2 %): the
                # estimate is kept as evidence (``mass``), the prior is used
                est = prior
                fit = next(f for f in mass.prior_fits if (f.start, f.stop) == fl)
                mass_note = (f"mass estimate not used: it did not reduce the linear-momentum deviation from the "
                             f"ballistic pattern ({mass.prior_momentum_deviation:.3f} -> {mass.momentum_deviation:.3f} "
                             f"kg m/s, {100 * mass.reduction:+.1f}% reduction at W={W:g}), so the prior masses are "
                             "kept")
            else:
                mass_note = None
        else:
            mass, est, mass_note = None, prior, None
            if estimate == "auto" and known and attempt == 0:
                notes.append("masses: the DeepMimic character's own (known), not estimated from the flight "
                             "(estimate=True estimates them anyway)")
            from ..dynamics import center_of_mass

            fit = fit_ballistic(center_of_mass(prior, motion)[fl[0]:fl[1]], motion.fps, fl[0])
        com_eval = ComEvaluator(est)          # the fast exact COM of the body used, kept for the run time
        timing = clip_timing(est, motion, det.intervals, fl, com_eval=com_eval)
        timings["mass"] = time.perf_counter() - t
        if attempt == 0 and fix_timing and timing.suggested is not None:
            notes.append(f"frame rate relabelled {motion.fps:g} -> {timing.suggested:g} Hz: {timing.text}")
            motion = motion.with_fps(timing.suggested)
            continue
        break
    if not timing.consistent and not fix_timing:
        notes.append(timing.text)
    if mass_note is not None:
        notes.append(mass_note)
    t = time.perf_counter()
    from ..dynamics import momentum as compute_momentum

    mom = compute_momentum(est, motion, smooth_sigma=smooth_sigma)
    s, e = fl
    Ls = flight_L_stats(mom.angular, s, e)
    a, b = Ls["frames"]
    Lmean = mom.angular[a:b].mean(axis=0)
    if not np.linalg.norm(Lmean) > 1e-6:
        raise PhysicsError(f"the flight (frames {s}-{e - 1}) has no angular momentum: there is no somersault "
                           "axis to repeat rotation about; use a clip with a flip")
    axis = Lmean / np.linalg.norm(Lmean)
    timings["momentum"] = time.perf_counter() - t
    t = time.perf_counter()
    rot = make_continuous(np.asarray(motion.rotations), axis=0)
    theta, bdir, root_ref = split_root_about(rot[:, 0], axis, slice(s, e))
    weights = similarity_weights(motion.skeleton, weight_overrides, velocity_weight=velocity_weight)
    omegas = local_angular_velocities(rot, motion.fps) if velocity_weight > 0 else None
    loop = find_self_loop(rot, theta, fl, axis, weights, omegas, **(loop_options or {}))
    if not loop.found:
        notes.append(loop.note)
    timings["loop_search"] = time.perf_counter() - t
    t = time.perf_counter()
    from ._kernels import warmup

    warmup()                              # compiled run-time kernels loaded now, not on the first run
    timings["setup"] = time.perf_counter() - t
    for arr in (rot, theta, bdir, axis, root_ref):
        arr.setflags(write=False)
    prep = PreparedFlip(motion=motion, name=name, prior=prior, body=est, detection=det, flight=fl, mass=mass,
                        fit=fit, momentum=mom, axis=axis, L_stats=Ls, rotations=rot, theta=theta, bdir=bdir,
                        root_ref=root_ref, omegas=omegas, weights=weights, loop=loop, com_eval=com_eval, com=mom.com,
                        smooth_sigma=smooth_sigma, timings=timings, notes=tuple(notes), timing=timing,
                        mass_used=mass is not None and est is mass.body)
    t = time.perf_counter()
    for retime in (True, False):          # the seam window and its smoothing / eq. 5.22 speeds, once per clip
        w = prep.best_window(retime)
        prep.loop_seam(w)
        prep.loop_seam_speed(w)
    timings["seam_windows"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    return prep


_CACHE: dict = {}


def prepare_cached(source, **options) -> PreparedFlip:
    """:func:`prepare` memoised per clip: by name (or path and its modification time) and
    options; motions are keyed by identity. Results are immutable, so sharing is safe."""
    if isinstance(source, Motion):
        key = ("motion", id(source))
    else:
        p = Path(str(source))
        key = ("file", str(p.resolve()), p.stat().st_mtime) if p.is_file() else ("name", str(source))
    key = key + tuple(sorted((k, repr(v)) for k, v in options.items()))
    hit = _CACHE.get(key)
    if hit is not None and (key[0] != "motion" or hit[0] is source):
        return hit[1]
    prep = prepare(source, **options)
    _CACHE[key] = (source if isinstance(source, Motion) else None, prep)
    return prep
