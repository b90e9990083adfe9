"""Landings that come to rest on the floor they land on (issue #13 section 3).

The restoration (:func:`mocomp.edit.pipeline.three_steps`) places the flight on a gravity
parabola and moves every frame after it rigidly with the landing's centre of mass (step 3,
section 5.5.3). That keeps the COM continuous but says nothing about the floor, and the audit
of the written frames found the feet below it (6.8 cm on the synthetic back flip with
``arms-twist``, 23-33 cm for the join CMU 88_01 + 88_05). The causes, measured:

* **The flight ended before the feet reached the floor.** The flight detector ends a flight a
  few frames early (the synthetic back flip's at 1.9 cm above the floor, the DeepMimic side
  flip's 56 cm above it, 11 frames early); the frames in between were treated as ground, so
  step 1's corrections were frozen there (a twist stopped in mid-air: the audit's L spread of
  0.46 rad) and the upright recovery turned the body while it was still falling.
* **A landing pose that the corrections turned.** Step 1 turns every frame after the edit (that
  is how asymmetric arms make a twist, Fig. 5.10) and a join turns its landing part to align L.
  A body turned by ``theta`` about its COM carries its feet up by about ``H (1 - cos theta)``
  (``H`` the COM height above the feet), so it reaches the floor later and lower than planned.
* **The upright recovery pivoted at the lowest joint**, which for a turned body is not on the
  floor: easing a 22.5 deg tilt out about it put the resting feet 6.8 cm below the floor.
* **A join's landing part on its own floor**: translated so that its COM continues the take-off
  part's at the seam, its floor came along (7.6 cm below the take-off floor for back flip + side
  flip, 23-33 cm for CMU 88_01 + 88_05).

The remedies, applied by the pipeline and measured on frames:

1. :func:`landing_reference`: the landing as intended (the edited motion, or a join's landing
   part without its alignment tilt): its floor (:func:`floor_level`), its touchdown
   (:func:`touchdown_index`: the first frame at or after the detected flight's end where its
   lowest body point reaches that floor) and, from two frames before it on, every body point and
   the ankles' world orientations. The pipeline runs the flight on to this touchdown.
2. :func:`level_feet`: before the touchdown the feet turn to be as level as the intended
   landing's (a turned body lands on flat feet, prepared in the air, instead of rolling flat on
   the floor).
3. :func:`landing_lift`: how much step 3 must raise (or lower) the landing so that the corrected
   pose touches the target floor at the touchdown with the reference's clearance; the parabola
   is planned for that height (App. B's ``dy``), so the flight stays ballistic up to the contact.
4. :func:`rest_on_floor`: from the touchdown on, a vertical root translation that gives the
   lowest body point the reference's clearance where the reference rests on its floor (held
   where it does not, low-passed so a capture's glitch does not bounce the body), and two-bone
   leg IK (:func:`mocomp.ops.ik.two_bone_ik`) that makes each planted foot move as the
   reference's does from where its contact began (on a landing the corrections did not turn,
   the feet already do and nothing changes).

:func:`check_landing` measures the result on the output frames (:class:`LandingCheck`): the
resting level of the lowest body point against the target floor and the deepest point below
it, against :data:`REST_TOL` (1 cm).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kinematics import end_site_positions, forward_kinematics
from ..core.motion import Motion, slerp
from ..core.rotations import quat_apply, quat_inverse, quat_multiply, swing_twist
from ..ops.ik import descends, leg_chains, run_starts, two_bone_ik

__all__ = ["TOUCH_TOL", "REST_TOL", "LANDING_VELOCITY_CHOICES", "ARRIVAL_TOL", "LANDING_MAX_FORCE", "stance_velocity", "stance_stop",
           "match_landing_velocity", "arrival_velocity", "own_landing_jump", "LandingReference", "LandingCheck", "lowest_heights", "floor_level",
           "landing_reference", "landing_lift", "foot_points", "touchdown_index", "level_feet", "rest_on_floor", "check_landing"]

#: m: the lowest body point within this of the floor touches it (the touchdown frame) ...
TOUCH_TOL = 0.01
#: m: ... and so does it within this of the floor where it stops descending (:func:`touchdown_index`;
#: the contact detector's height tolerance)
TOUCH_NEAR = 0.05
#: m: a landing rests on its floor when its resting level is within this of it, and no body point
#: goes deeper below it than the reference landing's own deepest point plus this
REST_TOL = 0.01
#: m: clearance of the reference's lowest point below which it rests on the floor (weight 1), and
#: above which it does not (weight 0; smoothstep between)
REST_BAND = (0.02, 0.05)
#: m: a foot whose lowest point is within ``FOOT_BAND[0]`` of its own lowest height after touchdown
#: in the reference is planted there (weight 1), above ``FOOT_BAND[1]`` it is not
FOOT_BAND = (0.02, 0.05)
#: m: the output's foot is on the floor (weight 1) within ``OUT_BAND[0]`` of the reference's foot
#: clearance above it, off it above ``OUT_BAND[1]``
OUT_BAND = (0.01, 0.05)
#: s: the feet are turned level over at least this long before the touchdown (:func:`level_feet`)
LEVEL_MIN_S = 0.1
#: rad/s: ... and no faster than this
LEVEL_RATE = float(np.radians(300.0))
#: s: Gaussian width of the low-pass on the vertical root shift of :func:`rest_on_floor`
SHIFT_SMOOTH_S = 0.03
#: s: a plant's leg IK weight falls from 1 to 0 no faster than over this long (:func:`_plant_targets`)
PLANT_RAMP_S = 0.2
#: a planted leg is stretched to at most this fraction of its length (hip-knee plus knee-ankle)
REACH = 0.995
#: m: over this much need the root's drop eases in (:func:`_reach_drop`)
REACH_SOFT = 0.003


def _points(skeleton, root_positions, rotations) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(points (n, J + E, 3), P (n, J, 3), G (n, J, 4))``: joints and end sites (core FK)."""
    P, G = forward_kinematics(skeleton.parents, skeleton.offsets, root_positions, rotations)
    if skeleton.end_sites:
        return np.concatenate([P, end_site_positions(skeleton.end_sites, P, G)], axis=1), P, G
    return P, P, G


def lowest_heights(motion: Motion, start: int = 0, stop: int | None = None) -> np.ndarray:
    """``(n,)`` m: the lowest height of every joint and end site in frames ``start..stop`` (the
    point :mod:`mocomp.audit` measures floor penetration with)."""
    stop = motion.n_frames if stop is None else stop
    pts, _, _ = _points(motion.skeleton, motion.root_positions[start:stop], motion.rotations[start:stop])
    return pts[..., 1].min(axis=1)


def floor_level(low: np.ndarray, fps: float, near: float = 0.03, speed: float = 0.4) -> float:
    """The level (m) a stretch of ground frames rests on, from the lowest body point's heights
    ``low (n,)``: over the frames where it moves vertically slower than ``speed`` m/s (the contact
    detector's speed; a capture glitch that drops a point 9 cm for a frame is fast), the median of
    those within ``near`` m above their 10th percentile (the resting frames, not a hop or the
    push-off). CMU 90_08's landing: 0.5 cm (the minimum-based estimate read -4.8 cm, one glitch)."""
    low = np.asarray(low, dtype=float)
    if low.size == 0:
        raise ValueError("floor_level needs at least one frame")
    if low.size < 3:
        return float(np.median(low))
    slow = np.abs(np.gradient(low)) * fps < speed
    cand = low[slow] if slow.sum() >= 2 else low
    anchor = float(np.percentile(cand, 10))
    return float(np.median(cand[cand <= anchor + near]))


def _weights(clear: np.ndarray, band) -> np.ndarray:
    """Smoothstep: 1 at or below ``band[0]``, 0 at or above ``band[1]``."""
    x = np.clip((band[1] - np.asarray(clear, dtype=float)) / (band[1] - band[0]), 0.0, 1.0)
    return x * x * (3 - 2 * x)


@dataclass(frozen=True, eq=False)
class LandingReference:
    """The intended landing, from the frame where its flight ends (see the module docstring).

    Attributes
    ----------
    floor: m, the level its lowest body point rests on after the flight (:func:`floor_level`).
    touchdown: frame (of the reference motion) where the lowest body point reaches ``floor``, at
        or after the flight's end (:func:`touchdown_index`).
    start: the first frame of the arrays, ``touchdown - 2`` (so that an output frame showing a
        time just before the touchdown reads the clearance it really has).
    times: ``(n,)`` s, times of the frames ``start..`` of the reference motion.
    clearance: ``(n,)`` m, height of the lowest body point above ``floor`` on those frames
        (:attr:`touchdown_clearance` at the touchdown).
    points: ``(n, J + E, 3)`` m, every joint and end site (joints first, as :func:`lowest_heights`).
    ankle_orientation: ``(n, C, 4)`` world orientations of the ankles.
    chains: ``(hip, knee, ankle)`` joint indices of the legs (:func:`mocomp.ops.ik.leg_chains`).
    foot_points: per leg, the indices (in ``points``) of its foot points: the ankle, the joints
        below it and their end sites.
    own_depth: m, the reference's own deepest point below ``floor`` from the touchdown on (>= 0).
    """

    floor: float
    touchdown: int
    start: int
    times: np.ndarray
    clearance: np.ndarray
    points: np.ndarray
    ankle_orientation: np.ndarray
    chains: tuple
    foot_points: tuple
    own_depth: float

    @property
    def touchdown_clearance(self) -> float:
        """m, the lowest body point's height above ``floor`` at the touchdown frame."""
        return float(self.clearance[self.touchdown - self.start])

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(clearance (n,), points (n, J + E, 3), ankle_orientation (n, C, 4))`` at the times ``t``
        (s; linear interpolation, orientations by slerp), clamped to the reference's frames."""
        t = np.clip(np.asarray(t, dtype=float), self.times[0], self.times[-1])
        if self.times.size < 2:
            i0, i1, a = np.zeros(t.size, int), np.zeros(t.size, int), np.zeros(t.size)
        else:
            x = (t - self.times[0]) / (self.times[1] - self.times[0])
            i0 = np.clip(np.floor(x).astype(int), 0, self.times.size - 2)
            i1, a = i0 + 1, np.clip(x - i0, 0.0, 1.0)
        clear = (1 - a) * self.clearance[i0] + a * self.clearance[i1]
        pts = (1 - a)[:, None, None] * self.points[i0] + a[:, None, None] * self.points[i1]
        q0, q1 = self.ankle_orientation[i0], self.ankle_orientation[i1]
        return clear, pts, slerp(q0, q1, np.broadcast_to(a[:, None], q0.shape[:-1]))


def touchdown_index(low: np.ndarray, floor: float) -> int:
    """Index of the first frame of ``low (n,)`` (the lowest body point's heights from the flight's
    end on) where it reaches the floor at ``floor``: within :data:`TOUCH_TOL` of it, or within
    :data:`TOUCH_NEAR` of it where it stops descending (a capture's foot lands a little above the
    level it later rests on: the DeepMimic side flip's at 1.1 cm, which then rises to 4.2 cm and
    settles 13 frames later). The first of the two; the minimum frame when neither occurs."""
    low = np.asarray(low, dtype=float)
    near = np.flatnonzero(low <= floor + TOUCH_TOL)
    stop = np.flatnonzero((low[:-1] <= floor + TOUCH_NEAR) & (low[1:] >= low[:-1]))
    cands = [int(x[0]) for x in (near, stop) if x.size]
    return min(cands) if cands else int(np.argmin(low))


def landing_reference(motion: Motion, flight_stop: int) -> LandingReference | None:
    """The :class:`LandingReference` of ``motion`` whose flight ends before frame ``flight_stop``
    (``None`` when no frame follows the flight)."""
    b = int(flight_stop)
    if b >= motion.n_frames:
        return None
    sk = motion.skeleton
    pts, P, G = _points(sk, motion.root_positions[b:], motion.rotations[b:])
    low = pts[..., 1].min(axis=1)
    floor = floor_level(low, motion.fps)
    td = b + touchdown_index(low, floor)
    # the arrays start two frames before the touchdown, so that an output frame showing a time just
    # before it (retimed frames fall between the input's; the first after a retimed flight can show
    # a time up to a frame before its end) reads the clearance it really has
    s0 = max(0, td - 2)
    pts, P, G = _points(sk, motion.root_positions[s0:], motion.rotations[s0:])
    clear = pts[..., 1].min(axis=1) - floor
    chains = tuple(leg_chains(sk))
    return LandingReference(floor=floor, touchdown=td, start=s0, times=np.asarray(motion.times[s0:], dtype=float),
                            clearance=clear, points=pts, ankle_orientation=np.array(G[:, [c[2] for c in chains]]),
                            chains=chains, foot_points=foot_points(sk, chains),
                            own_depth=float(max(0.0, -clear[td - s0:].min())))


def foot_points(skeleton, chains) -> tuple[np.ndarray, ...]:
    """Per leg ``(hip, knee, ankle)``: indices of the ankle, the joints below it and their end sites
    among the joints and end sites (joints first, the order of :func:`lowest_heights`)."""
    par = skeleton.parents
    out = []
    for chain in chains:
        below = [j for j in range(skeleton.n_joints) if descends(par, j, chain[2])]
        sites = [skeleton.n_joints + i for i, e in enumerate(skeleton.end_sites) if e.parent in below]
        out.append(np.array(below + sites, dtype=int))
    return tuple(out)



def landing_lift(motion: Motion, frame: int, floor: float, clearance: float) -> float:
    """m to raise ``motion`` (from ``frame`` on) so that its lowest body point at ``frame`` is
    ``clearance`` above ``floor``: what step 3 adds to the landing COM's planned height."""
    low = lowest_heights(motion, frame, frame + 1)[0]
    return float(floor + clearance - low)


def _held(w: np.ndarray, err: np.ndarray) -> np.ndarray:
    """``s_i = w_i err_i + (1 - w_i) s_{i-1}``, ``s_{-1} = 0``: follow ``err`` where ``w`` is 1, hold
    the last value where it is 0 (the scalar recurrence of :func:`mocomp.edit.seams._held_shift`)."""
    s = np.empty_like(err)
    prev = 0.0
    for i, (wi, ei) in enumerate(zip(w.tolist(), err.tolist())):
        prev = wi * ei + (1.0 - wi) * prev
        s[i] = prev
    return s


def _shift_to_clearance(sk, rp, rot, first, floor, clear, w_rest, fps: float) -> float:
    """Vertical root shift (in place on ``rp``) of frames ``first..`` giving the lowest body point
    the clearance ``clear`` above ``floor`` where ``w_rest`` is 1 (held elsewhere), low-passed
    (a 5-frame median, then a Gaussian of :data:`SHIFT_SMOOTH_S`): the shift corrects where the
    body stands, not a capture's glitches (CMU 90_08 drops a point 9 cm for one frame after its
    landing; followed frame by frame that bounced the whole body, a 4 m/s COM jump); returns the
    largest shift (m)."""
    from scipy.ndimage import gaussian_filter1d, median_filter

    pts, _, _ = _points(sk, rp[first:], rot[first:])
    low = pts[..., 1].min(axis=1)
    s = _held(w_rest, floor + clear - low)
    if s.size >= 3:
        s = gaussian_filter1d(median_filter(s, size=min(5, s.size), mode="nearest"), SHIFT_SMOOTH_S * fps,
                              mode="nearest")
    # from 0 at ``first`` (the touchdown, where step 3 put the body on the floor: the smoothing must
    # not carry later corrections back onto the frame that joins the flight's parabola)
    x = np.clip(np.arange(s.size) / max(2.0 * SHIFT_SMOOTH_S * fps, 1.0), 0.0, 1.0)
    s = s * (x * x * (3 - 2 * x))
    rp[first:, 1] += s
    return float(np.max(np.abs(s))) if s.size else 0.0


def _level(G_now: np.ndarray, G_ref: np.ndarray) -> np.ndarray:
    """``G_now`` turned so that the direction that is vertical in ``G_ref``'s frame is vertical
    again (the foot as level as in the reference; the smallest turn)."""
    up = np.array([0.0, 1.0, 0.0])
    up_now = quat_apply(G_now, quat_apply(quat_inverse(G_ref), up))
    u = up_now / np.linalg.norm(up_now, axis=-1, keepdims=True)
    q = np.concatenate([np.cross(u, up), 1.0 + u[..., 1:2]], axis=-1)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(n > 1e-9, q / np.where(n > 1e-9, n, 1.0), np.array([1.0, 0.0, 0.0, 0.0]))
    return quat_multiply(q, G_now)


def _heading(G: np.ndarray) -> np.ndarray:
    """The turn about the world vertical in ``G = heading * rest`` (``rest`` with no such turn)."""
    _, tw = swing_twist(quat_inverse(G), np.array([0.0, 1.0, 0.0]))
    return quat_inverse(tw)


def level_feet(motion: Motion, reference: Motion, touchdown: int, chains=None, earliest: int = 0,
               min_s: float = LEVEL_MIN_S, rate: float = LEVEL_RATE) -> tuple[Motion, int]:
    """The feet of ``motion`` (the ankles' world orientations) turned to be as level as the same
    frames of ``reference`` (the intended landing, on the same frame times), keeping their heading,
    by a weight rising (smoothstep) to 1 at ``touchdown`` and 1 after. A body that the corrections
    turned lands on flat feet, prepared in the air as a gymnast does, instead of touching down on
    a toe and rolling flat on the floor (a heel travelling ``l (1 - cos theta)``: 1.1-1.5 cm on the
    synthetic back flip with ``arms-twist``). The turn starts ``max(min_s, angle / rate)`` seconds
    before the touchdown (``angle`` the largest turn a foot needs there; not before ``earliest``):
    the feet are light (~1.5 % of the body each) but a fast turn of a large angle still moves L
    (the synthetic side flip with ``straight-legs`` lands 105 deg off the vertical: turned within
    0.1 s the feet changed |L| by 8 %, within 0.35 s by 1.4 %), which the later steps then retime.
    Only the ankles' local rotations change. Returns ``(motion, first frame changed)``."""
    td = int(touchdown)
    sk = motion.skeleton
    chains = leg_chains(sk) if chains is None else list(chains)
    if not chains or td >= motion.n_frames:
        return motion, motion.n_frames
    ank = [c[2] for c in chains]
    _, _, G1 = _points(sk, motion.root_positions[td:td + 1], motion.rotations[td:td + 1])
    _, _, Gr1 = _points(sk, reference.root_positions[td:td + 1], reference.rotations[td:td + 1])
    turn = np.max(2 * np.arccos(np.clip(np.abs(np.sum(_level(G1[0, ank], Gr1[0, ank]) * G1[0, ank], axis=-1)),
                                        0.0, 1.0)))
    start = max(int(earliest), td - int(round(max(min_s, turn / rate) * motion.fps)), 0)
    _, _, G = _points(sk, motion.root_positions[start:], motion.rotations[start:])
    _, _, Gr = _points(sk, reference.root_positions[start:], reference.rotations[start:])
    span = max(td - start, 1)
    x = np.clip((np.arange(motion.n_frames - start) + 1) / span, 0.0, 1.0)
    w = x * x * (3 - 2 * x)
    rot = np.array(motion.rotations)
    for a in ank:
        p = int(sk.parents[a])
        Ga = slerp(G[:, a], _level(G[:, a], Gr[:, a]), w)
        rot[start:, a] = quat_multiply(quat_inverse(G[:, p]), Ga)
    return motion.replace(rotations=rot), start


def _plant_targets(sk, rp, rot, first, floor, ref_floor, ref_pts, ank_ori, chains, feet, ramp: float = 1.0):
    """The planted feet's IK targets of frames ``first..`` (see :func:`_plant`): per leg
    ``(chain, weight (n,), ankle target (n, 3), ankle world orientation (n, 4))``, and the FK
    ``(P, G)`` they were computed on. ``ref_pts (n, J + E, 3)``: the reference's points at the
    frames' source times, ``ref_floor`` its floor; ``ank_ori (n, C, 4)`` its ankles; ``ramp``: frames
    a plant's IK weight takes at least to fall from 1 to 0 (:data:`PLANT_RAMP_S`).
    Per leg the tuple ends with the IK's blend weight ``w_ik``, continuous where runs begin and end."""
    pts, P, G = _points(sk, rp[first:], rot[first:])
    rows = np.arange(pts.shape[0])
    out = []
    for c, chain in enumerate(chains):
        a = chain[2]
        fp = feet[c]
        ref_c = ref_pts[:, fp, 1].min(axis=1) - ref_floor                        # reference foot clearance
        w = (_weights(ref_c - ref_c.min(), FOOT_BAND)
             * _weights(pts[:, fp, 1].min(axis=1) - floor - np.maximum(ref_c, 0.0), OUT_BAND))
        st = run_starts((w >= 0.5)[:, None])[:, 0]
        w = np.where(st >= 0, w, 0.0)
        s0 = np.maximum(st, 0)
        # the IK's blend weight: 0 where a contact run begins or ends. It rises with the run's weight
        # above 0.5 (a plant switched on at w = 0.5 stepped the leg within one frame) and falls no
        # faster than 1 / ramp per frame, starting earlier where the run's weight falls faster: released
        # as the weight fell (0.93 -> 0.52 within 5 frames), a foot held 6 cm from the unplanted pose
        # moved at 1.4 m/s, and with it the COM (a 0.55 m/s COM velocity jump on the DeepMimic side flip
        # with arms-twist, above any of the input's). Not limited where it rises: a foot held later
        # slides first (1.0 cm on the synthetic back flip with arms-twist against 0.7)
        y = np.clip(2.0 * w - 1.0, 0.0, 1.0)
        w_ik = _release_limited(np.where(st >= 0, y * y * (3 - 2 * y), 0.0), 1.0 / max(float(ramp), 1.0))
        pc = fp[np.argmin(pts[s0[:, None], fp[None, :], 1], axis=1)]            # contact point of each run
        # the reference's own foot motion since the contact began, turned by the heading difference
        # between the output's foot and the reference's there (yaw only), from where it began
        Y = quat_multiply(_heading(G[s0, a]), quat_inverse(_heading(ank_ori[s0, c])))
        held = pts[s0, pc] + quat_apply(Y, ref_pts[rows, pc] - ref_pts[s0, pc])
        held[:, 1] = floor + ref_pts[rows, pc, 1] - ref_floor
        G_t = quat_multiply(Y, ank_ori[:, c])                                     # as level as the reference's
        local = quat_apply(quat_inverse(G[:, a]), pts[rows, pc] - P[:, a])     # contact point in the foot's frame
        Ga = slerp(G[:, a], G_t, w_ik)
        cur = P[:, a]
        out.append((chain, w, cur + w_ik[:, None] * (held - quat_apply(Ga, local) - cur), Ga, w_ik))
    return out, P, G


def _release_limited(w: np.ndarray, rate: float) -> np.ndarray:
    """``w`` lowered where needed so that it falls by at most ``rate`` per frame (rises unchanged):
    ``out_i = min_{j >= i} (w_j + (j - i) rate)``."""
    out = np.array(w, dtype=float)
    for i in range(out.size - 2, -1, -1):
        out[i] = min(out[i], out[i + 1] + rate)
    return out


def _reach_drop(sk, P, targets, ref_pts, reach: float = REACH) -> np.ndarray:
    """``(n,)`` m to lower the root so that every planted leg reaches its ankle target with at most
    ``reach`` of its length, or as far as the reference's leg is stretched then (``ref_pts``; a
    straight leg cannot push the hip up any further); eased in, so that the root comes down
    instead of kinking (a leg clamped straight by the IK
    bent the COM path by 0.15 m/s): 0 where no leg needs it, quadratic over the first
    :data:`REACH_SOFT`, then the need less half of that."""
    need = np.full(P.shape[0], -np.inf)
    for (h, k, a), w, tgt, _, _ in targets:
        r = np.maximum(reach * (np.linalg.norm(sk.offsets[k]) + np.linalg.norm(sk.offsets[a])),
                       np.linalg.norm(ref_pts[:, a] - ref_pts[:, h], axis=1))
        H = P[:, h]
        dxz = np.hypot(H[:, 0] - tgt[:, 0], H[:, 2] - tgt[:, 2])
        dy = (H[:, 1] - tgt[:, 1]) - np.sqrt(np.maximum(r * r - dxz * dxz, 0.0))
        need = np.maximum(need, np.where(w >= 0.5, dy, -np.inf))
    e = REACH_SOFT
    need = np.where(np.isfinite(need), need, 0.0)
    # C1: 0 where no leg needs it, x^2 / 2e over the first e, then x - e/2
    return np.where(need <= 0.0, 0.0, np.where(need < e, need * need / (2 * e), need - 0.5 * e))


def _plant(sk, rp, rot, first, floor, ref_floor, ref_pts, ank_ori, chains, feet,
           tol: float = 1e-4, ramp: float = 1.0) -> tuple[int, float, float]:
    """Leg IK of frames ``first..`` (in place on ``rot``, and ``rp`` lowered where a leg cannot
    reach) for the planted feet. A foot is planted where the reference's is (its lowest point
    within :data:`FOOT_BAND` of its own lowest after touchdown) *and* the output's is near the
    floor (:data:`OUT_BAND`): a foot of a turned body that reaches the floor later than the
    reference's lands when it gets there, not pulled down. Where a contact begins, the foot's
    lowest point ``c`` is the contact point; from there it moves as the reference's does (turned by
    the heading difference of the two feet then: a planted reference foot holds it still, a pivot
    on the ball of the foot is kept) at the reference's height above the floor, and the foot
    turns as the reference's (its tilt; the heading relative to the contact's start), about ``c``.
    For a landing that the corrections did not turn the output's feet already do this, and the IK
    leaves them alone; where the body turns back upright over the feet it holds them. Hip and knee
    by two-bone IK place the ankle. Where a planted leg would need more than :data:`REACH` of its
    length, the root comes down (:func:`_reach_drop`). Returns ``(IK solves, largest miss m,
    largest drop m)``."""
    if not chains:
        return 0, 0.0, 0.0
    targets, P, G = _plant_targets(sk, rp, rot, first, floor, ref_floor, ref_pts, ank_ori, chains, feet, ramp)
    drop = _reach_drop(sk, P, targets, ref_pts)
    if np.max(drop, initial=0.0) > 1e-6:
        rp[first:, 1] -= drop
        targets, P, G = _plant_targets(sk, rp, rot, first, floor, ref_floor, ref_pts, ank_ori, chains, feet, ramp)
    solves, miss = 0, 0.0
    for chain, _, tgt, Ga, w in targets:
        a = chain[2]
        cur = P[:, a]
        ang = 2 * np.arccos(np.clip(np.abs(np.sum(Ga * G[:, a], axis=-1)), 0.0, 1.0))
        idx = np.flatnonzero((w > 1e-9) & ((np.linalg.norm(tgt - cur, axis=1) > tol) | (ang > 1e-4)))
        if idx.size:
            Gi = np.array(G[idx])
            Gi[:, a] = Ga[idx]
            f = first + idx
            rot[f], m = two_bone_ik(P[idx], Gi, rot[f], sk.parents, chain, tgt[idx])
            solves += idx.size
            miss = max(miss, float(np.max(m)))
    return solves, miss, float(np.max(drop, initial=0.0))


def rest_on_floor(motion: Motion, first: int, floor: float, ref: LandingReference,
                  source_times) -> tuple[Motion, dict]:
    """Frames ``first..`` of ``motion`` (which show the reference's times ``source_times``) put
    on the floor at height ``floor`` as the reference rests on its own (module docstring, item 3):
    vertical root shift, leg IK of the planted feet, and the shift again (the IK can move the
    lowest point). Returns the motion and ``{"shift_max_m", "ik_solves", "ik_miss_m"}``."""
    first = int(first)
    if first >= motion.n_frames:
        return motion, {"shift_max_m": 0.0, "ik_solves": 0, "ik_miss_m": 0.0}
    sk = motion.skeleton
    clear, ref_pts, ori = ref.at(np.asarray(source_times, dtype=float))
    w_rest = _weights(clear, REST_BAND)
    rp = np.array(motion.root_positions)
    rot = np.array(motion.rotations)
    s1 = _shift_to_clearance(sk, rp, rot, first, floor, clear, w_rest, motion.fps)
    solves, miss, drop = _plant(sk, rp, rot, first, floor, ref.floor, ref_pts, ori, list(ref.chains), ref.foot_points,
                                ramp=PLANT_RAMP_S * motion.fps)
    s2 = _shift_to_clearance(sk, rp, rot, first, floor, clear, w_rest, motion.fps)
    return motion.replace(root_positions=rp, rotations=rot), {
        "shift_max_m": max(s1, s2, drop), "ik_solves": int(solves), "ik_miss_m": miss}


@dataclass(frozen=True)
class LandingCheck:
    """Where the output's landing rests, measured on its frames from the touchdown on.

    Attributes
    ----------
    floor: m, the floor it should rest on (the input's landing floor; a join's take-off floor).
    rest_level: m, the resting level of its lowest body point (:func:`floor_level`).
    offset: m, ``rest_level - floor`` (negative: below the floor).
    depth: m, the deepest any body point goes below ``floor`` after touchdown;
        reference_depth: the reference landing's own deepest (m, >= 0).
    touchdown: output frame of the touchdown; lift: m, the height change step 3 planned for it;
        shift_max: m, the largest vertical root shift of :func:`rest_on_floor`; ik_solves;
        ik_miss: m, the largest distance an ankle stayed from its target (out of reach).
    ok: ``|offset| <= REST_TOL`` and ``depth <= reference_depth + REST_TOL``.
    """

    floor: float
    rest_level: float
    offset: float
    depth: float
    reference_depth: float
    touchdown: int
    lift: float
    shift_max: float
    ik_solves: int
    ik_miss: float
    ok: bool

    def as_dict(self) -> dict:
        return {"floor_m": self.floor, "rest_level_m": self.rest_level, "offset_m": self.offset,
                "depth_below_floor_m": self.depth, "reference_depth_m": self.reference_depth,
                "touchdown_frame": self.touchdown, "planned_lift_m": self.lift, "shift_max_m": self.shift_max,
                "ik_solves": self.ik_solves, "ik_miss_m": self.ik_miss, "tolerance_m": REST_TOL, "ok": self.ok}

    def describe(self) -> str:
        where = "above" if self.offset > 0 else "below"
        return (f"the landing rests {100 * abs(self.offset):.1f} cm {where} the floor it lands on "
                f"(y = {self.floor:.3f} m; deepest point {100 * self.depth:.1f} cm below it, the intended "
                f"landing's own {100 * self.reference_depth:.1f} cm; tolerance {100 * REST_TOL:g} cm)")


def check_landing(motion: Motion, first: int, floor: float, ref: LandingReference, lift: float = 0.0,
                  settle: dict | None = None) -> LandingCheck:
    """:class:`LandingCheck` of ``motion``'s frames ``first..`` against ``floor``."""
    low = lowest_heights(motion, int(first))
    rest = floor_level(low, motion.fps)
    depth = float(max(0.0, floor - low.min()))
    off = rest - floor
    s = settle or {}
    ok = abs(off) <= REST_TOL and depth <= ref.own_depth + REST_TOL
    return LandingCheck(floor=float(floor), rest_level=float(rest), offset=float(off), depth=depth,
                        reference_depth=ref.own_depth, touchdown=int(first), lift=float(lift),
                        shift_max=float(s.get("shift_max_m", 0.0)), ik_solves=int(s.get("ik_solves", 0)),
                        ik_miss=float(s.get("ik_miss_m", 0.0)), ok=bool(ok))


#: the values of ``landing_velocity`` (:func:`match_landing_velocity`, ``mocomp edit --landing``)
LANDING_VELOCITY_CHOICES = ("auto", "repair", "as-is")
#: m/s: ``landing_velocity="auto"`` repairs the landing stance when the flight's arrival velocity
#: differs from the stance's by more than this (any component; the take-off's
#: :data:`mocomp.edit.linear.TAKEOFF_TOL`)
ARRIVAL_TOL = 0.3
#: body weights: the largest vertical ground reaction the repaired landing stance may need (or the
#: stance's own peak where that is higher). Landings take more than take-offs: drop landings of
#: gymnasts peak at roughly 4-11 body weights (McNitt-Gray 1993) and somersault landings above
#: 10; :data:`mocomp.flips.takeoff.MAX_FORCE` (8, a running take-off) would refuse the DeepMimic
#: back flip with straight legs, which needs 8.5
LANDING_MAX_FORCE = 12.0
#: shares of the velocity difference tried in turn where the stance cannot take all of it (the
#: legs' room: the DeepMimic back flip with straight legs would fold a knee 1 deg tighter than the
#: performer does anywhere in the clip): part of a jump removed is better than none
PARTIAL_SHARES = (1.0, 0.5)
#: s: the stance frames after the event whose COM gives the stance's velocity there (a quadratic
#: least-squares fit, as :mod:`mocomp.audit.com` measures velocity jumps)
ARRIVAL_WINDOW_S = 0.03


def stance_velocity(com: np.ndarray, event_frame: float, fps: float, window_s: float = ARRIVAL_WINDOW_S) -> np.ndarray:
    """``(3,)`` m/s: the velocity, at the fractional frame ``event_frame``, of a least-squares
    quadratic through the COM ``com (T, 3)`` of the ``max(3, round(window_s fps) + 1)`` frames after it
    (the landing stance's own velocity where the flight meets it)."""
    first = int(np.floor(event_frame)) + 1
    n = max(3, int(round(window_s * fps)) + 1)
    c = np.asarray(com, dtype=float)[first:first + n]
    if c.shape[0] < 3:
        return np.full(3, np.nan)
    t = (np.arange(first, first + c.shape[0]) - event_frame) / fps
    return np.polyfit(t, c, 2)[1]


def stance_stop(motion: Motion, first: int, floor: float, near: float = TOUCH_NEAR) -> int:
    """The frame after the landing stance that begins at ``first``: the first frame after the body
    reached the floor where its lowest point rises more than ``near`` above ``floor`` again (the next
    hop of a clip with several flights), or the end of the motion."""
    low = lowest_heights(motion, int(first))
    on = np.flatnonzero(low <= floor + near)
    if not on.size:
        return motion.n_frames
    up = np.flatnonzero(low[on[0]:] > floor + near)
    return int(first + on[0] + up[0]) if up.size else motion.n_frames


def arrival_velocity(com: np.ndarray, event_frame: int, fps: float, window_s: float = ARRIVAL_WINDOW_S) -> np.ndarray:
    """``(3,)`` m/s: the velocity at frame ``event_frame`` of a least-squares quadratic through the
    COM ``com (T, 3)`` of the ``max(3, round(window_s fps) + 1)`` frames up to it (a flight's arrival)."""
    e = int(event_frame)
    n = max(3, int(round(window_s * fps)) + 1)
    c = np.asarray(com, dtype=float)[max(0, e - n + 1):e + 1]
    if c.shape[0] < 3:
        return np.full(3, np.nan)
    t = (np.arange(e - c.shape[0] + 1, e + 1) - e) / fps
    return np.polyfit(t, c, 2)[1]


def own_landing_jump(com: np.ndarray, last_flight_frame: int, fps: float) -> np.ndarray:
    """``(3,)`` m/s: the input's own velocity change where its flight (last frame
    ``last_flight_frame``) meets its landing stance, :func:`arrival_velocity` minus
    :func:`stance_velocity` (the impact a capture or the synthetic generator has; the repair keeps it)."""
    e = int(last_flight_frame)
    return arrival_velocity(com, e, fps) - stance_velocity(com, float(e), fps)


def match_landing_velocity(motion: Motion, com_fn, event_frame: float, arrival, floor: float, *, g: float,
                           mode: str = "auto", tol: float = ARRIVAL_TOL, max_force: float = LANDING_MAX_FORCE,
                           jerk_weight: float | None = None, own_jump=None, body=None):
    """The landing stance of ``motion`` (frames after the fractional output frame ``event_frame``,
    where the flight's parabola ends with the velocity ``arrival (3,)`` m/s) decelerated smoothly from
    the flight's arrival velocity to its own, beyond the paper.

    Step 3 (dissertation / flips paper section 5.5.3) retimes the whole motion by ``k`` and moves
    the frames after the flight rigidly (eq. 5.16), so the stance keeps ``k`` times its captured
    velocity while the parabola arrives with its own: continuous only when the input flight is
    ballistic with the chosen gravity and take-off velocity. On the DeepMimic back and side flips
    (fitted g 7.6 and 13.0, a push-off the fit misses by 1.4 m/s) the audit measured COM velocity
    jumps of 0.9-1.25 m/s at the landing, against 0.3-0.4 for the input. As ``multiflip(...,
    takeoff="repair")`` does for a ``k < k*`` landing (section 5.3's jump), the difference is added
    to the stance by :func:`mocomp.flips.takeoff.repair_stance`: a jerk-regularised root displacement
    map with ``d(event) = 0`` and ``d'(event) = arrival - stance velocity``, vertical ground force
    within bounds (at most ``max_force`` body weights, :data:`LANDING_MAX_FORCE`), feet held by leg IK.

    ``own_jump (3,)`` m/s: the velocity change the input's own landing has there (its impact, already
    scaled by ``k``; :func:`own_landing_jump`): the stance is brought to ``arrival - own_jump``, so the
    output's landing is no more abrupt than the input's, and a flight that arrives as the input's did
    (an exact synthetic flight, an unedited clip) is left alone.

    ``mode``: ``"as-is"`` (the paper's: nothing changes), ``"repair"`` (whenever the difference
    exceeds 1 mm/s), ``"auto"`` (default: when any component exceeds ``tol``). Returns ``(motion,
    info)``, ``info`` a dict: ``mode``, ``arrival_m_s``, ``stance_m_s`` (before), ``own_jump_m_s``,
    ``difference_m_s`` (``arrival - own_jump - stance``),
    ``repaired`` (bool), ``repair`` (:meth:`~mocomp.flips.takeoff.StanceRepair.to_dict` or None),
    ``share`` (the part of the difference added: the first of :data:`PARTIAL_SHARES` the stance takes),
    ``note`` (why not repaired, when it should have been; ``None`` otherwise)."""
    if mode not in LANDING_VELOCITY_CHOICES:
        raise ValueError(f"landing_velocity must be one of {', '.join(LANDING_VELOCITY_CHOICES)}, got {mode!r}")
    from ..flips.takeoff import StanceRepairError, repair_stance

    arrival = np.asarray(arrival, dtype=float).reshape(3)
    first = int(np.floor(event_frame)) + 1
    info = {"mode": mode, "arrival_m_s": arrival.tolist(), "stance_m_s": None, "difference_m_s": None,
            "repaired": False, "repair": None, "note": None}
    if mode == "as-is" or first >= motion.n_frames:
        return motion, info
    stop = stance_stop(motion, first, floor)
    com = com_fn(np.asarray(motion.root_positions[:stop], dtype=float), np.asarray(motion.rotations[:stop], dtype=float))
    v = stance_velocity(com, event_frame, motion.fps)
    if not np.all(np.isfinite(v)):
        return motion, info
    own = np.zeros(3) if own_jump is None else np.nan_to_num(np.asarray(own_jump, dtype=float).reshape(3))
    dv = arrival - own - v
    info.update(stance_m_s=v.tolist(), difference_m_s=dv.tolist(), own_jump_m_s=own.tolist())
    need = float(np.max(np.abs(dv))) > (tol if mode == "auto" else 1e-3)
    if not need:
        return motion, info
    opts = {} if jerk_weight is None else {"jerk_weight": jerk_weight}
    first_error = None
    for share in PARTIAL_SHARES:
        try:
            new, rep = repair_stance(motion, com_fn, "landing", float(event_frame), share * dv, (first, stop), g=g,
                                     body=body, max_force=max_force, measure_zmp=False, **opts)
        except StanceRepairError as e:
            first_error = first_error or str(e)
            continue
        info.update(repaired=True, repair=rep.to_dict(), share=share)
        if share < 1.0:
            info["note"] = (f"the landing stance took {100 * share:.0f}% of the velocity difference "
                            f"({', '.join(f'{x:+.2f}' for x in dv)}) m/s between the flight's arrival and the stance; "
                            f"the whole would not fit ({first_error}); the COM velocity jumps by the rest at the landing")
        return new, info
    info["note"] = (f"the flight arrives at ({', '.join(f'{x:+.2f}' for x in arrival)}) m/s, the landing stance "
                    f"moves at ({', '.join(f'{x:+.2f}' for x in v)}): not repaired ({first_error}); the COM velocity "
                    "jumps at the landing")
    return motion, info
