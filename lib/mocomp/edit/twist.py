"""Twist jumps of any angle from one twist jump (dissertation section 5.6, Fig. 5.7: a 180 degree
twist jump turned into 210, 240 and 270 degree ones).

"Our method can be also applied to simpler, non-acrobatic motions, such as twist jumps.
Although in human twist jumps take-off poses can vary significantly with the achieved twist
rotation, small adjustments of the amount of rotation typically produce natural-looking
results ... In the generated motions the take-off, angular velocity and jump height increase
with the achieved degree of rotation." The Discussion (5.8) adds that extreme changes (a 45
degree twist made a 360 degree one) look unnatural.

:func:`twist_jump` uses the Acrobatics-I machinery with L about the vertical:

* **more rotation** -- the self-looping fragment ``f_m .. f_n`` of the flight (eq. 5.9, found
  in pre-processing with a smaller minimum angle) is repeated with its rotation about L
  (eq. 5.10-5.11, :func:`mocomp.flips.sequence.build_sequence` with ``extra_rotation``), the
  landing found by the second search;
* **less rotation** -- a fragment is cut out: flight frames ``m < n`` whose rotation about L
  differs by the deficit and whose poses match after turning ``f_n`` back by it (App. A
  similarity); the frames after ``n`` are turned back by that angle;
* seams are cross-faded (:mod:`mocomp.edit.seams`); the landing part is turned about the
  vertical (not about a slightly tilted L), so it lands upright, and the difference is spread
  over the flight frames before it;
* then the three steps of section 5.5 (:func:`mocomp.edit.pipeline.three_steps`): L's
  direction and magnitude are held at the original flight's over the new flight (a twist jump's
  |L| is small, so the seams' small tilt mismatches would swing its direction), and the
  whole motion is retimed uniformly by ``k*`` (App. B; ``k_ratio=1`` by default) for the new
  flight duration, and the COM repositioned on the parabola. A longer flight gives
  ``k* > 1``: the take-off is faster (vertical speed ``k* v0``), the jump higher
  (``(k* v0)^2 / 2g``) and the rotation faster (``|L|`` scales by ``k*``), as the paper says.

The reachable range: ``k*`` grows like the square root of the flight-duration ratio, and
uniform retiming by more than ~1.5x (or less than 1/1.5) distorts the take-off visibly
(section 5.1 bounds the retiming error for ``1/2 <= k <= 2``); :func:`reachable_range`
states the range for ``max_k`` and targets outside it raise
:class:`~mocomp.errors.TwistRangeError` with the numbers.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.rotations import quat_apply, quat_inverse, quat_multiply
from ..errors import PhysicsError, TwistRangeError
from .pipeline import RestoreResult, three_steps
from .seams import crossfade

__all__ = ["TwistResult", "twist_jump", "twist_series", "reachable_range", "prepare_twist"]


def _axis_quat(axis, angle):
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    h = 0.5 * np.asarray(angle, dtype=float)
    out = np.empty(np.shape(h) + (4,))
    out[..., :3] = np.sin(h)[..., None] * a
    out[..., 3] = np.cos(h)
    return out


@dataclass(frozen=True, eq=False)
class TwistResult:
    """A twist jump with a new amount of rotation, and its evidence.

    Attributes
    ----------
    motion: the new motion; original: the input as used.
    requested_deg, achieved_deg, original_deg: total rotation about L from the first to the
        last frame (degrees, unsigned).
    method: ``"repeat"`` (self-looping fragment repeated), ``"cut"`` (fragment removed) or
        ``"unchanged"``.
    frames: ``(T_seq,)`` source frame of each frame of the sequence before retiming.
    flight, flight_out: flight frames of the sequence (before retiming) and of the output.
    k, k_star: uniform retiming; takeoff_speed, takeoff_speed_original: vertical COM velocity
        at take-off (m/s); height, height_original: COM rise from take-off to apex (m);
        angular_speed, angular_speed_original: mean rotation rate about L over the flight
        (deg/s); L_magnitude, L_magnitude_original: mean |L| over the flight (kg m^2/s);
        flight_time, flight_time_original: s.
    restore: the :class:`~mocomp.edit.RestoreResult` of the three steps (per-frame errors).
    timings: seconds.
    """

    motion: object
    original: object
    requested_deg: float
    achieved_deg: float
    original_deg: float
    method: str
    frames: np.ndarray
    flight: tuple[int, int]
    flight_out: tuple[int, int]
    k: float
    k_star: float
    takeoff_speed: float
    takeoff_speed_original: float
    height: float
    height_original: float
    angular_speed: float
    angular_speed_original: float
    L_magnitude: float
    L_magnitude_original: float
    flight_time: float
    flight_time_original: float
    restore: RestoreResult | None
    timings: dict
    notes: tuple[str, ...] = field(default=())

    def summary(self) -> str:
        lines = [f"twist jump {self.original_deg:.0f} -> {self.achieved_deg:.1f} deg (requested "
                 f"{self.requested_deg:.1f}) by {self.method}; k = {self.k:.3f} (k* = {self.k_star:.3f})",
                 f"  take-off vertical speed {self.takeoff_speed_original:.2f} -> {self.takeoff_speed:.2f} m/s, "
                 f"height {self.height_original:.3f} -> {self.height:.3f} m, flight "
                 f"{self.flight_time_original:.3f} -> {self.flight_time:.3f} s",
                 f"  rotation rate {self.angular_speed_original:.0f} -> {self.angular_speed:.0f} deg/s, |L| "
                 f"{self.L_magnitude_original:.2f} -> {self.L_magnitude:.2f} kg m^2/s"]
        if self.restore is not None:
            f = self.restore.stages["final"]
            lines.append(f"  L over the new flight: direction error <= {f.max_direction:.1e} rad, |L| error <= "
                         f"{100 * f.max_magnitude:.1f}% (against k |L*|)")
            lines.append(f"  {self.restore.gravity_line()}")
            lines.append(f"  {self.restore.landing_line()}")
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def report(self, curves: bool = False) -> dict:
        d = {k: getattr(self, k) for k in ("requested_deg", "achieved_deg", "original_deg", "method", "k", "k_star",
                                           "takeoff_speed", "takeoff_speed_original", "height", "height_original",
                                           "angular_speed", "angular_speed_original", "L_magnitude",
                                           "L_magnitude_original", "flight_time", "flight_time_original")}
        d.update(flight=list(self.flight), flight_out=list(self.flight_out), timings_s=self.timings,
                 notes=list(self.notes), restore=None if self.restore is None else self.restore.report(curves))
        return json.loads(json.dumps(d, default=float))


def prepare_twist(source, body=None, min_angle_deg: float = 20.0, root_weight: float = 10.0,
                  flight: tuple[int, int] | None = None):
    """Pre-process a twist jump (:func:`mocomp.flips.prepare` without mass estimation, the
    self-loop search allowing small rotations per fragment); cached per clip. ``flight``:
    ``(start, stop)`` frames to use instead of the detected flight.

    The root's weight in the similarity (eq. 5.13) is raised from 2 to ``root_weight``: a twist
    jump turns about a near-vertical L with a small moment of inertia, so |L| is small, and a
    root tilt mismatch at a seam (blended about a horizontal axis, where the inertia is ~10x
    larger) would disturb L far more than in a somersault."""
    from ..flips.preprocess import prepare_cached

    opts = {"estimate": False, "loop_options": {"min_angle": float(np.radians(min_angle_deg))},
            "weight_overrides": {"root": float(root_weight)}}
    if body is not None:
        opts["body"] = body
    if flight is not None:
        opts["flight"] = (int(flight[0]), int(flight[1]))
    return prepare_cached(source, **opts)


def _flight_rotation(P) -> float:
    s, e = P.flight
    return float(P.theta[e - 1] - P.theta[s])


def reachable_range(P, max_k: float = 1.5) -> tuple[float, float]:
    """``(lo, hi)`` degrees of total rotation reachable from prepared clip ``P`` with
    ``1/max_k <= k* <= max_k``: ``k*`` ~ sqrt(flight-duration ratio) (App. B with the take-off
    and landing at one level) and the flight's rotation grows with its duration, so the
    flight's own rotation can be scaled by ``1/max_k^2 .. max_k^2``."""
    tot = abs(float(P.total_rotation))
    fl = abs(_flight_rotation(P))
    return float(np.degrees(tot - fl * (1 - 1 / max_k ** 2))), float(np.degrees(tot + fl * (max_k ** 2 - 1)))


def _cut_sequence(P, deficit: float, max_mean_angle: float = 15.0):
    """Frames ``m < n`` in the flight with ``theta(n) - theta(m) ~ deficit`` whose poses match once
    ``f_n`` is turned back by that angle (App. A); returns ``(m, n, angle, mean angle deg)``.

    The cost is the eq. 5.13 distance plus ``1e-3 |theta(n) - theta(m) - deficit|``. Its minimum is
    chosen robustly, with the tie rule of :mod:`mocomp.flips.looping`: pairs within
    :data:`~mocomp.flips.looping.TIE_RTOL` (relative) plus :data:`~mocomp.flips.looping.TIE_ATOL`
    (radians of mean joint mismatch, times the sum of the weights) of the lowest cost are tied,
    and among them, in order: the smallest angle remainder ``|theta(n) - theta(m) - deficit|``
    (to within :data:`~mocomp.flips.looping.PHI_TOL` rad; the least rotation left to spread over
    the flight), the cut centred nearest the middle of the flight (``|m + n - (s + e - 1)|``
    smallest: the apex, farthest from take-off and landing), the earliest ``m``. In a held pose
    at a constant rotation rate every pair the same number of frames apart matches exactly, and
    a plain argmin picked ``m`` = 65, 73, 113, 89, 87, 114 for a test motion and five seeded
    1e-7 perturbations of it (``tests/test_edit_twist.py``)."""
    from ..flips.looping import PHI_TOL, TIE_ATOL, TIE_RTOL, choose_tied
    from ..flips.similarity import frame_distance

    s, e = P.flight
    mg = max(2, int(np.ceil(0.1 * (e - s))))
    idx = np.arange(s + mg, e - 1 - mg)
    th = P.theta
    M, N = np.meshgrid(idx, idx, indexing="ij")
    M, N = M.ravel(), N.ravel()
    d = th[N] - th[M]
    rate = abs(th[e - 1] - th[s]) / max(e - 1 - s, 1)
    ok = (N > M) & (np.abs(d - deficit) <= max(1.5 * rate, np.radians(2.0)))
    if not np.any(ok):
        return None
    M, N, d = M[ok], N[ok], d[ok]
    D, _ = frame_distance(P.rotations[N], P.rotations[M], P.axis, P.weights, phi=-d)
    wsum = P.weights.root + float(np.sum(P.weights.joints))
    rem = np.abs(d - deficit)
    tied = choose_tied(D + 1e-3 * rem, wsum, TIE_RTOL, TIE_ATOL)
    tied = tied[rem[tied] <= rem[tied].min() + PHI_TOL]
    k = int(tied[np.lexsort((M[tied], np.abs(M[tied] + N[tied] - (s + e - 1))))[0]])
    return int(M[k]), int(N[k]), float(d[k]), float(np.degrees(D[k] / wsum))


def twist_jump(source, degrees: float, *, body=None, k_ratio: float | None = None, k: float | None = None,
               max_k: float = 1.5, window_s: float = 0.08, prepared=None, direction_step: bool = True,
               tol_deg: float = 1.0, max_rounds: int = 5, gravity="standard") -> TwistResult:
    """A twist jump turning ``degrees`` in all (from the first to the last frame), made from
    the twist jump ``source`` (a :class:`Motion`, file or clip name; see the module docstring).

    ``k_ratio`` (default 1: ``k = k*``, linear momentum continuous at take-off and landing) or
    ``k`` choose the uniform retiming; ``max_k`` bounds the reachable range
    (:func:`reachable_range`, and ``1/max_k <= k* <= max_k`` is checked on the result);
    ``window_s`` is the landing seam's blending half-window (loop seams blend over half a copy).
    ``direction_step`` runs step 1 (eq. 5.21) over the new flight: a twist jump's |L| is small
    (small inertia about the vertical), so the seams' brief tilt mismatches swing L's direction
    a lot unless it is restored. Step 1 turns the frames after each disturbance a little, which
    changes the total rotation by a few degrees, so the request is corrected and the jump rebuilt
    (secant steps, at most ``max_rounds``) until it is met within ``tol_deg``. ``gravity``: the new
    flight's, ``"standard"`` (9.81 m/s^2, default), ``"clip"`` (the input flight's fitted gravity) or
    m/s^2 (:func:`~mocomp.edit.linear.resolve_gravity`).
    """
    P = prepared if prepared is not None else prepare_twist(source, body)
    want = float(degrees)
    ask = want
    best = None
    tried = []                                   # (asked, achieved)
    lo_r, hi_r = reachable_range(P, max_k)
    for _ in range(max(1, int(max_rounds))):
        r = _twist_once(source, ask, k_ratio=k_ratio, k=k, max_k=max_k, window_s=window_s, prepared=P,
                        direction_step=direction_step, gravity=gravity)
        err = r.achieved_deg - want
        tried.append((ask, r.achieved_deg))
        if best is None or abs(err) < abs(best.achieved_deg - want):
            best = r
        if abs(err) <= tol_deg or r.method == "unchanged":
            break
        if len(tried) >= 2 and abs(tried[-1][1] - tried[-2][1]) > 1e-6:
            (x0, y0), (x1, y1) = tried[-2], tried[-1]
            slope = (y1 - y0) / (x1 - x0)
            nxt = x1 + (want - y1) / slope if slope > 0.2 else x1 - err
        else:
            nxt = ask - err
        ask = float(np.clip(nxt, lo_r - 10.0, hi_r + 10.0))
    if abs(best.achieved_deg - want) > tol_deg:
        best = _with_note(best, f"achieved {best.achieved_deg:.1f} deg for {want:g} requested after {max_rounds} rounds")
    import dataclasses

    best = dataclasses.replace(best, requested_deg=want)
    if not (1.0 / max_k - 1e-9 <= best.k_star <= max_k + 1e-9):
        raise TwistRangeError(
            f"{want:g} deg needs k* = {best.k_star:.3f} (App. B) for the {best.flight_time:.3f} s flight, outside "
            f"1/{max_k:g}..{max_k:g}: the take-off would change too much (sections 5.1, 5.8); the estimated reachable "
            f"range of this clip is {reachable_range(P, max_k)[0]:.0f}-{reachable_range(P, max_k)[1]:.0f} deg, "
            "choose a smaller change or raise max_k")
    return best


def _with_note(r, note):
    import dataclasses

    return dataclasses.replace(r, notes=r.notes + (note,))


def _twist_once(source, degrees: float, *, k_ratio=None, k=None, max_k: float = 1.5, window_s: float = 0.08,
                prepared=None, direction_step: bool = True, gravity="standard") -> TwistResult:
    """One build of :func:`twist_jump` for the angle ``degrees`` (no angle correction)."""
    t0 = time.perf_counter()
    timings = {}
    P = prepared
    timings["prepare"] = time.perf_counter() - t0
    body = P.body
    target = float(np.radians(degrees))
    if not np.isfinite(target) or target <= 0:
        raise TwistRangeError(f"the twist angle must be a positive number of degrees, got {degrees!r}")
    orig = abs(float(P.total_rotation))
    lo, hi = reachable_range(P, max_k)
    if not (np.radians(lo) - np.radians(10.0) <= target <= np.radians(hi) + np.radians(10.0)):
        raise TwistRangeError(
            f"{degrees:g} deg is outside the range reachable from this {np.degrees(orig):.0f} deg twist jump "
            f"({lo:.0f}-{hi:.0f} deg: its flight turns {np.degrees(abs(_flight_rotation(P))):.0f} deg in "
            f"{(P.flight[1] - 1 - P.flight[0]) / P.fps:.3f} s, and the take-off may be sped up or slowed down at most "
            f"x{max_k:g}, section 5.1/5.8); choose an angle in that range or raise max_k")
    extra = target - orig
    notes = list(P.notes)
    s, e = P.flight
    fps = P.fps
    from ..flips.reposition import ComEvaluator

    ce = ComEvaluator(body)
    up = np.array([0.0, 1.0, 0.0])
    t = time.perf_counter()
    if abs(np.degrees(extra)) < 2.0:
        method = "unchanged"
        frames = np.arange(P.motion.n_frames)
        seq_motion = P.motion
        fl_seq = (s, e)
    else:
        R = np.array(P.rotations)
        rp0 = np.asarray(P.motion.root_positions)
        if extra > 0:
            from ..flips.sequence import build_sequence

            if not P.loop.found:
                notes.append(P.loop.note)
            seq = build_sequence(P.rotations, P.theta, P.flight, P.loop, P.axis, P.weights, flips=None,
                                 extra_rotation=extra, omegas=P.omegas)
            frames, ext = seq.frames, np.array(seq.extra)
            takeoff, landing = seq.takeoff, seq.landing
            join_at = seq.landing_seam                       # last frame before F_E
            seams = [(a, P.loop.n, P.loop.m, (j + 1) * P.loop.phi) for j, a in enumerate(seq.loop_seams)]
            g = seq.join.g
            method = "repeat"
            ext_total = seq.extra_total
        else:
            cut = _cut_sequence(P, -extra)
            if cut is None:
                raise TwistRangeError(f"no pair of flight frames turns {np.degrees(-extra):.0f} deg apart: cannot "
                                      f"remove that much rotation from this {np.degrees(orig):.0f} deg twist jump")
            m, n, ang, mm = cut
            frames = np.concatenate([np.arange(0, m + 1), np.arange(n + 1, P.motion.n_frames)])
            ext = np.concatenate([np.zeros(m + 1), np.full(P.motion.n_frames - n - 1, -ang)])
            # spread the small remainder (requested minus cut angle) over the flight before the seam
            rem = extra + ang
            ramp_ = np.clip((np.arange(m + 1) - s) / max(m - s, 1), 0.0, 1.0)
            ext[:m + 1] += rem * ramp_
            ext[m + 1:] += rem
            takeoff, landing = s, e - 1 - (n - m)
            join_at, g = m, n
            seams = []
            method = "cut"
            ext_total = -ang + rem
            notes.append(f"cut frames {m + 1}-{n} ({np.degrees(ang):.1f} deg about L; pose mismatch {mm:.1f} deg)")
        rot = R[frames]
        rp = rp0[frames].astype(float).copy()
        # turn each frame about L through its COM (flight frames are repositioned later)
        q_ext = _axis_quat(P.axis, ext)
        com = ce(rp, rot)
        rot[:, 0] = quat_multiply(q_ext, rot[:, 0])
        rp = com + quat_apply(q_ext, rp - com)
        # landing part: about the vertical instead of the (tilted) L, so the landing is upright;
        # the difference is spread over the flight frames after the landing join
        from ..flips.similarity import twist_angle

        q_L = _axis_quat(P.axis, ext_total)
        q_y = _axis_quat(up, float(twist_angle(q_L, up)))
        C = quat_multiply(q_y, quat_inverse(q_L))
        j0 = join_at + 1
        lam = np.clip((np.arange(j0, frames.size) - j0 + 1) / max(landing - j0 + 1, 1), 0.0, 1.0)
        from ..core.motion import slerp

        ident = np.broadcast_to([0.0, 0.0, 0.0, 1.0], (lam.size, 4))
        qC = slerp(ident, np.broadcast_to(C, (lam.size, 4)), lam)
        com = ce(rp[j0:], rot[j0:])
        rot[j0:, 0] = quat_multiply(qC, rot[j0:, 0])
        rp[j0:] = com + quat_apply(qC, rp[j0:] - com)
        # the ground frames after the landing: one rigid block (as the landing frame)
        post = landing + 1
        if post < frames.size:
            c_l = ce(rp0[P.flight[1] - 1:P.flight[1]], R[P.flight[1] - 1:P.flight[1]])[0]
            q_post = quat_multiply(qC[-1], q_L)
            rp[post:] = quat_apply(q_post, rp0[frames[post:]] - c_l) + com[landing - j0]
            rot[post:, 0] = quat_multiply(q_post, R[frames[post:], 0])
        # seams: loop seams (f_n ~ R f_m) and the landing join
        w = max(1, int(round(window_s * fps)))
        w_loop = max(w, P.loop.period // 2)      # loop seams: spread over the whole copy
        for a, nn, mm_, turn in seams:
            left_ref = np.array(R[nn])
            left_ref[0] = quat_multiply(_axis_quat(P.axis, turn - P.loop.phi), left_ref[0])
            right_ref = np.array(R[mm_])
            right_ref[0] = quat_multiply(_axis_quat(P.axis, turn), right_ref[0])
            crossfade(rot, rp, a, left_ref, right_ref, max(1, min(w_loop, (P.loop.period - 2) // 2)), ce)
        left_ref = np.array(rot[join_at])
        right_ref = np.array(R[g])
        right_ref[0] = quat_multiply(q_ext[join_at + 1 if join_at + 1 < ext.size else -1], right_ref[0])
        crossfade(rot, rp, join_at, left_ref, right_ref, w, ce)
        seq_motion = P.motion.replace(root_positions=rp, rotations=rot)
        fl_seq = (int(takeoff), int(landing) + 1)
    timings["sequence"] = time.perf_counter() - t
    t = time.perf_counter()
    from .restore import flight_momentum

    L_orig = flight_momentum(body, P.motion, (s, e))
    L_const = np.nanmean(L_orig[s + 1:e - 1], axis=0)
    try:
        res = three_steps(body, seq_motion, fl_seq, L_const, P.fit, original=P.motion, original_flight=(s, e),
                          L_orig=L_orig, k=k, k_ratio=k_ratio, com_eval=ce, direction=direction_step,
                          upright_ref=seq_motion, gravity=gravity)
    except PhysicsError as exc:
        raise TwistRangeError(f"{degrees:g} deg: {exc}") from exc
    timings["restore"] = time.perf_counter() - t
    out = res.motion
    fa, fb = res.flight_out
    from ..flips.smoothing import split_root

    th_out, _ = split_root(np.asarray(out.rotations[:, 0]), P.axis, getattr(P, "root_ref", None))
    achieved = float(np.degrees(abs(th_out[-1] - th_out[0])))
    plan = res.linear.plan
    g_ = res.gravity                    # the new flight's (the input's apex height at the same g)
    v_new = plan.vy_takeoff_new
    v_old = P.fit.b_y
    fl_rot_new = abs(th_out[fb - 1] - th_out[fa])
    T_new = (fb - 1 - fa) / fps
    T_old = (e - 1 - s) / fps
    Lf = res.stages["final"].L
    timings["total"] = time.perf_counter() - t0
    return TwistResult(
        motion=out, original=P.motion, requested_deg=float(degrees), achieved_deg=achieved,
        original_deg=float(np.degrees(orig)), method=method, frames=frames, flight=fl_seq, flight_out=(fa, fb),
        k=plan.k, k_star=plan.k_star, takeoff_speed=float(v_new), takeoff_speed_original=float(v_old),
        height=float(v_new ** 2 / (2 * g_)), height_original=float(v_old ** 2 / (2 * g_)),
        angular_speed=float(np.degrees(fl_rot_new / T_new)),
        angular_speed_original=float(np.degrees(abs(_flight_rotation(P)) / T_old)),
        L_magnitude=float(np.mean(np.linalg.norm(Lf, axis=1))) if Lf.size else float("nan"),
        L_magnitude_original=float(np.linalg.norm(L_const)), flight_time=T_new, flight_time_original=T_old,
        restore=res, timings=timings, notes=tuple(notes))


def twist_series(source, degrees=(210.0, 240.0, 270.0), **kw) -> list[TwistResult]:
    """Fig. 5.7: one :class:`TwistResult` per angle, from one prepared clip."""
    P = kw.pop("prepared", None) or prepare_twist(source, kw.pop("body", None))
    return [twist_jump(source, d, prepared=P, **kw) for d in degrees]
