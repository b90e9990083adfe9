"""Footplant enforcement: planted feet held still by analytic two-bone leg IK (issue 15, item 1).

Per leg the foot (ankle joint, toe joint and toe tip) moves as one rigid body; the toe joint's
local rotation is kept. On the frames of :class:`~mocomp.ops.plants.FootPlants`:

* ankle point planted: the foot is translated so the ankle point sits on its target
  (:func:`~mocomp.ops.plants.plant_targets`: mean position over the plant, on the support level);
  alone (the toe not yet down, or lifted), the foot also turns about it so the toe tip follows its
  fading correction from the toe's plant;
* ankle point and toe tip planted: additionally turned about the ankle point by the shortest arc
  that aims the toe tip at its target; the distance between the two points is fixed by the foot,
  so where it differs from the targets' distance (a heel rolling up while still counted planted)
  the foot is shifted along itself by half the difference (each point misses by half); the toe
  tip's target is made to fit the foot (:func:`consistent_toe_targets`);
* toe tip planted alone (heel off): the tip exactly on its target, the foot turned about it so
  that the ankle point follows its correction from the heel's plant as that fades (the heel rolls
  up about the toe).

The translation and the rotation vector of each foot are faded in and out over ``blend`` frames
around the planted frames (:func:`~mocomp.ops.easing.ramp_fill`), so no pose jumps; a fade waits
through the steps where the leg itself turns near the legs' fastest rate (:func:`leg_fade_clocks`) and
makes up on the slower steps around them, so the correction does not add to the input's peak joint
speed (issue 15: "no pose discontinuity above the input's own maximum joint speed"). The leg then
follows by :func:`~mocomp.ops.ik.two_bone_ik` (hip fixed, knee kept in the leg's plane; a nearly
straight leg, whose plane is noise, bends about its knee's hinge axis, :data:`BEND_PRIOR`). The reach
is soft: a target within :data:`SOFT_REACH` of the leg's full length is approached smoothly by
lifting the foot (horizontal hold kept), so the knee does not snap straight; the lifted frames and
the few that still cannot be reached (a target beyond the leg horizontally) are reported. Nothing
but the hip, knee and ankle local rotations changes; the root is never moved.

Around the plants: gaps of fewer than ``blend / 2`` frames between two plants of one point are
closed (two targets that close in time would make the foot jump); a direct switch from toe-only to
ankle-only frames (a foot rocking from toe to heel) is cross-faded over the blend frames; and the
contact detector is run again on the result, the frames it finds planted there are added and the
changed frames solved again (``passes``), so the audit, which uses the same detector, measures the
plants that were enforced. Where that re-detection disagrees widely with the input's (it adds more
than :data:`EXTRA_PASS_FRACTION` of the planted frames: raw CMU clips whose toes sink through the
floor), passes go on (``max_passes``) until the feet slide less than ``slide_goal`` within the
contacts the detector finds on the result, and the least sliding result is kept.

This is the footskate cleanup of Kovar, Schreiner & Gleicher (SCA 2002) with analytic IK in place
of their per-frame numerical solve, as the touch-up paper (Shin et al. 2003, sec. 3.1) uses it
after each displacement-map step.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_exp, quat_inverse, quat_log, quat_multiply
from ..dynamics.contacts import label_intervals
from . import displacement as _displacement
from .easing import RampPlan, ease, fade_clock
from .ik import REACH_MARGIN, _norm, hinge_axis, two_bone_ik
from .plants import FootPlants, foot_plants, plant_targets

__all__ = ["FootplantResult", "enforce_footplants", "plant_slides", "default_blend_frames", "foot_points",
           "consistent_toe_targets", "detected_slide", "FootplantPlan", "footplant_plan"]

#: m: a leg that misses its target by more than this is reported as unreachable on that frame
UNREACHABLE_TOL = 1e-3
#: m: with both points of a foot planted, the horizontal ankle-tip mismatch stays within this of its
#: run mean (:func:`bounded_foot_pitch`; shared by the two points: at most this much slide each);
#: ``None`` leaves the input's pitch as it is
PITCH_SLACK = 0.008
#: :func:`bounded_foot_pitch` keeps the mismatch within :data:`PITCH_SLACK` of zero (``True``: the foot
#: fits its two targets up to the slack, the rest of the misfit made heel height) or of its run mean
#: (``False``, as before: a constant misfit -- the two targets' heights set apart from the foot's own
#: pitch, as the resting levels of :func:`~mocomp.ops.plants.plant_targets` may -- stays, shared as a
#: slide of both points along the foot; CMU 131_02: 1.5 cm at each point)
PITCH_TO_ZERO = True
#: :func:`enforce_footplants`: a re-detection that adds more than this fraction of the planted frames
#: starts the extra passes (clean captures add under 1 %: SFU walk 0.4 %, SFU cartwheels 0.6 %, ASE
#: walk 0.3 %; raw CMU 131_01 7.5 %, 131_02 32 %)
EXTRA_PASS_FRACTION = 0.02
#: :func:`leg_fade_clocks`: fades slow down on the steps where a leg turns faster than ``1 - FADE_RATE_SLACK``
#: of the legs' fastest rate, down to :data:`FADE_CLOCK_FLOOR` at that rate (``None``: uniform fades, as before)
FADE_RATE_SLACK: float | None = 0.3
FADE_CLOCK_FLOOR = 0.0
#: fraction of the leg length over which the reach is softened (see :func:`_solve`)
SOFT_REACH = 0.02
#: weight of the knee's hinge axis (averaged over the clip in the thigh frame) against the leg's
#: plane normal in the IK: a leg straighter than about 3 deg bends about its hinge, not about noise
BEND_PRIOR = 0.05


#: m: :func:`enforce_footplants`' extra passes keep a result whose lowest body point reads deeper below the
#: audit's floor (:func:`_floor_depth`) than the input's by more than this only when every pass does
PENETRATION_SLACK = 0.005


def _floor_depth(motion: Motion) -> tuple[float, float]:
    """``(floor_y, depth)`` m: the audit's floor (:func:`mocomp.audit.contacts.floor_level`, the resting
    level of the lowest body point over the first ground stage's planted frames) and the largest depth
    of the lowest body point below it -- the audit's floor penetration, from the same functions."""
    from ..audit.contacts import floor_level, lowest_points, phases_of
    from ..dynamics.contacts import detect_contacts

    c = detect_contacts(motion)
    low, _, _ = lowest_points(motion)
    floor_y, _ = floor_level(low, c, phases_of(c, motion.n_frames))
    return floor_y, float(np.max(floor_y - low, initial=0.0))


def _deeper_than(motion: Motion, depth: float) -> bool:
    """The audit's floor penetration of ``motion`` exceeds ``depth`` by more than :data:`PENETRATION_SLACK`."""
    return _floor_depth(motion)[1] > depth + PENETRATION_SLACK


def default_blend_frames(fps: float) -> int:
    """Frames over which a correction fades in and out: 0.1 s, at least 2 frames."""
    return max(2, int(round(0.1 * fps)))


def foot_points(P: np.ndarray, G: np.ndarray, plants: FootPlants) -> np.ndarray:
    """``(T, 4, 3)`` world positions of the four foot points (``plants.effectors`` order); the four
    rotated in one :func:`~mocomp.core.rotations.quat_apply` (elementwise: the same numbers as one
    call per point), or with numba in one compiled loop (:func:`mocomp.ops._footplant_kernel.foot_points_rows`,
    core's ``qrot``: the same operations)."""
    pairs = [p for leg in plants.legs for p in (leg.ankle_point, leg.toe_point)]
    js = [int(j) for j, _ in pairs]
    offs = np.array([off for _, off in pairs], dtype=float)
    if _compiled_hold() and P.ndim == 3 and P.dtype == np.float64 and G.dtype == np.float64:
        from ._footplant_kernel import foot_points_rows   # the same products per point (core's qrot)

        return foot_points_rows(P, G, js, offs)
    return P[:, js] + quat_apply(G[:, js], offs)


def plant_slides(points: np.ndarray, plants: FootPlants) -> np.ndarray:
    """``(4,)`` m per foot point: the largest horizontal distance from where it was planted, over
    its planted runs (the audit's foot-slide measure, on these plants' frames)."""
    out = np.zeros(4)
    for k in range(4):
        for a, b in label_intervals(plants.labels[:, k]):
            p = points[a:b, k][:, [0, 2]]
            out[k] = max(out[k], float(np.linalg.norm(p - p[0], axis=1).max()))
    return out


def detected_slide(contacts, effectors) -> float:
    """m: the largest horizontal distance of a foot point from where it was planted, over the planted
    runs of a detector result (:func:`mocomp.dynamics.contacts.detect_contacts`) -- the audit's foot
    slide (:func:`mocomp.audit.contacts.contact_audits`) on these contacts, for ``effectors``."""
    out = 0.0
    for e in effectors:
        i = contacts.effectors.index(e)
        for a, b in label_intervals(contacts.labels[:, i]):
            p = contacts.positions[a:b, i][:, [0, 2]]
            out = max(out, float(np.linalg.norm(p - p[0], axis=1).max()))
    return out


@dataclass(frozen=True, eq=False)
class FootplantResult:
    """The motion with its feet planted, and the evidence.

    Attributes
    ----------
    motion: the result (same skeleton, frames, root as the input; leg rotations changed).
    plants: the :class:`~mocomp.ops.plants.FootPlants` enforced.
    targets: ``(T, 4, 3)`` m, where each planted point was held (NaN where not planted).
    blend_frames: frames of fade in/out around each plant.
    slide_before, slide_after: ``(4,)`` m, per foot point the largest slide within its plants
        (:func:`plant_slides`; planned: on the enforced plants' frames; properties computed on
        first use, like the joint speeds).
    unreachable: side -> list of half-open frame runs where the leg missed its target by more than
        :data:`UNREACHABLE_TOL` (reach clamped: the knee straight or folded).
    max_miss: m, largest miss over all frames and legs.
    changed_frames: frames on which any leg was solved.
    input: the motion the feet were planted on.
    joint_speed_before, joint_speed_after: rad/s, the largest joint rotation rate between frames
        (:func:`mocomp.audit.kinematics.step_rates`) of the input and the output (properties,
        computed on first use).
    audit_before, audit_after: :class:`~mocomp.audit.AuditReport` of the input and the output
        (measured; ``None`` with ``audit=False``).
    seconds: wall time of the enforcement (without the audits).
    """

    motion: Motion
    plants: FootPlants
    targets: np.ndarray
    blend_frames: int
    unreachable: dict
    max_miss: float
    changed_frames: int
    input: Motion
    audit_before: object | None = None
    audit_after: object | None = None
    seconds: float = 0.0
    notes: tuple[str, ...] = field(default=())
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def slide_before(self) -> np.ndarray:
        """``(4,)`` m, per foot point the largest slide within the enforced plants, on the input
        (:func:`plant_slides`; computed on first use)."""
        if "slide_before" not in self._cache:
            P, G = self.input.fk()
            self._cache["slide_before"] = plant_slides(foot_points(P, G, self.plants), self.plants)
        return self._cache["slide_before"]

    @property
    def slide_after(self) -> np.ndarray:
        """``(4,)`` m, the same on the output (planned: on the enforced plants' frames)."""
        if "slide_after" not in self._cache:
            P, G = self.motion.fk()
            self._cache["slide_after"] = plant_slides(foot_points(P, G, self.plants), self.plants)
        return self._cache["slide_after"]

    @property
    def joint_speed_before(self) -> float:
        """rad/s, the input's largest joint rotation rate between frames (computed on first use)."""
        if "before" not in self._cache:
            self._cache["before"] = _max_rate(self.input)
        return self._cache["before"]

    @property
    def joint_speed_after(self) -> float:
        """rad/s, the output's largest joint rotation rate between frames (a pose jump shows here)."""
        if "after" not in self._cache:
            self._cache["after"] = _max_rate(self.motion)
        return self._cache["after"]

    def measured_slide(self) -> tuple[float, float]:
        """``(before, after)`` m: the largest foot/toe slide the audit measures on the input and the
        output (its own contact detection on each)."""
        from .evidence import foot_slide

        if self.audit_before is None or self.audit_after is None:
            raise ValueError("run enforce_footplants(..., audit=True) for the measured slide")
        return foot_slide(self.audit_before), foot_slide(self.audit_after)

    def to_dict(self) -> dict:
        from .evidence import audit_numbers

        d = {"plants": self.plants.to_dict(), "blend_frames": self.blend_frames,
             "slide_before_m": dict(zip(self.plants.effectors, map(float, self.slide_before))),
             "slide_after_m": dict(zip(self.plants.effectors, map(float, self.slide_after))),
             "unreachable": {s: [list(r) for r in v] for s, v in self.unreachable.items()},
             "max_miss_m": self.max_miss, "changed_frames": self.changed_frames,
             "joint_speed_before_rad_s": self.joint_speed_before, "joint_speed_after_rad_s": self.joint_speed_after,
             "seconds": self.seconds, "notes": list(self.notes)}
        if self.audit_before is not None:
            d["measured"] = {"input": audit_numbers(self.audit_before), "output": audit_numbers(self.audit_after)}
        return d


def _max_rate(motion: Motion) -> float:
    from ..audit.kinematics import step_rates

    if motion.n_frames < 2:
        return 0.0
    return float(step_rates(motion)[0].max())


def consistent_toe_targets(targets: np.ndarray, pts: np.ndarray, plants: FootPlants) -> np.ndarray:
    """Toe-tip targets that fit the foot: for a toe plant that overlaps a plant of the same foot's
    ankle point, the tip's horizontal target is the ankle point's target plus the mean horizontal
    ankle-to-tip direction over the shared frames, at the mean ankle-to-tip horizontal distance. The
    mean of each point alone is not rigid when the foot turns during the plant (a path edit turns the
    body as it walks): the two means are then closer together than the foot is long."""
    out = np.array(targets)
    for li in range(len(plants.legs)):
        ka, kt = 2 * li, 2 * li + 1
        la, lt = plants.labels[:, ka], plants.labels[:, kt]
        run = np.cumsum(np.r_[lt[0], lt[1:] & ~lt[:-1]]) * lt         # toe run id per frame (0: not planted)
        sel = np.flatnonzero(lt & la)                                   # the shared frames, in order
        if sel.size == 0:
            continue
        rid = run[sel]
        nr = int(run.max()) + 1
        cnt = np.bincount(rid, minlength=nr)
        first = np.zeros(nr, dtype=int)
        r_u, i_u = np.unique(rid, return_index=True)
        first[r_u] = sel[i_u]
        _toe_from_ankle(out, targets, pts, ka, kt, run, sel, rid, nr, cnt, cnt > 0, first)
    return out

def bounded_foot_pitch(targets: np.ndarray, pts: np.ndarray, plants: FootPlants, slack: float,
                       fade: int = 0) -> np.ndarray:
    """Ankle-point target heights that keep a foot with both points planted nearly rigid on its
    horizontal targets. With both points held horizontally, the foot's horizontal length is fixed;
    the input's pitch (heel rising about the toe, toe rolling down after the heel strike) changes it,
    and what the two points cannot share without moving shows as a slide of both (the ASE walk: its
    horizontal length changes by 2.1 cm during one plant, so each point slid 1.05 cm). Per shared
    run, the horizontal mismatch ``h_target - h(t)`` is kept within ``slack`` of its run mean; the
    rest becomes height: the ankle point's target is lowered (or raised) to the pitch whose
    horizontal length fits (the heel rises less while the toe is planted, and the rest of its rise
    after its plant ends, over the fade). With :data:`PITCH_TO_ZERO` the mismatch is kept within
    ``slack`` of zero instead of its run mean: a misfit constant over the run (the ankle point's and the
    toe tip's targets put on resting levels that do not fit the foot's pitch) is turned into heel height
    too rather than shared by the two points; ``fade`` (frames, the enforcement's blend): the change of
    the ankle point's height is eased out over the planted frames around the shared ones
    (:func:`_fade_height_change`), so it does not jump where the toe lifts or lands."""
    out = np.array(targets)
    for li in range(len(plants.legs)):
        ka, kt = 2 * li, 2 * li + 1
        both = plants.labels[:, ka] & plants.labels[:, kt]
        if not both.any():
            continue
        sel = np.flatnonzero(both)
        first = np.flatnonzero(np.r_[True, np.diff(sel) > 1])
        cnt = np.diff(np.r_[first, sel.size])
        rid = np.repeat(np.arange(first.size), cnt)
        if not _pitch_heights(out, pts, ka, kt, sel, first, cnt, rid, slack):
            continue
        if fade > 0:
            _fade_height_change(out[:, ka, 1], targets[:, ka, 1], both, plants.labels[:, ka], fade)
    return out


def _toe_from_ankle(out, targets, pts, ka, kt, run, sel, rid, nr, cnt, has, first) -> None:
    """One foot's part of :func:`consistent_toe_targets`, in place on ``out``: per toe run (``run``,
    ids ``rid`` of the shared frames ``sel``, ``cnt`` of them, ``first`` shared frame), the toe tip's
    horizontal target is the ankle point's target at the run's first shared frame plus the mean
    ankle-to-tip direction at the mean horizontal distance."""
    d = (pts[sel, kt] - pts[sel, ka])[:, [0, 2]]
    L = np.bincount(rid, _norm(d), minlength=nr)
    u = np.stack([np.bincount(rid, d[:, c], minlength=nr) for c in range(2)], axis=1)
    L[has] /= cnt[has]
    u[has] /= cnt[has, None]
    n = _norm(u)
    ok = has & (n >= 1e-9)
    ok[0] = False
    if not ok.any():
        return
    f = np.flatnonzero(ok[run])
    r = run[f]
    scale = L[r] / n[r]
    out[f, kt, 0] = targets[first[r], ka, 0] + scale * u[r, 0]
    out[f, kt, 2] = targets[first[r], ka, 2] + scale * u[r, 1]


def _pitch_heights(out: np.ndarray, pts: np.ndarray, ka: int, kt: int, sel: np.ndarray, first: np.ndarray,
                   cnt: np.ndarray, rid: np.ndarray, slack: float) -> bool:
    """One foot's part of :func:`bounded_foot_pitch`, in place on ``out``: over the frames ``sel``
    where both its points (ankle ``ka``, toe tip ``kt``) are planted, grouped in runs (``first``,
    ``cnt``, ``rid``), the horizontal mismatch is kept within ``slack`` of zero (or of its run mean)
    and the rest becomes the ankle point's height. Returns whether any frame changed."""
    L3 = _norm(pts[sel, kt] - pts[sel, ka])                              # the foot's ankle-tip length
    dy = out[sel, ka, 1] - out[sel, kt, 1]
    h_t = _norm((out[sel, kt] - out[sel, ka])[:, [0, 2]])
    h = np.sqrt(np.maximum(L3 * L3 - dy * dy, 0.0))
    res = h_t - h
    ref = (np.add.reduceat(res, first) / cnt)[rid] if not PITCH_TO_ZERO else 0.0
    res_c = np.clip(res, ref - slack, ref + slack)
    change = res_c != res
    if not change.any():
        return False
    h_new = np.clip(h_t - res_c, 0.0, L3)
    dy_new = np.sign(dy) * np.sqrt(np.maximum(L3 * L3 - h_new * h_new, 0.0))
    f = sel[change]
    out[f, ka, 1] = out[f, kt, 1] + dy_new[change]
    return True


def _fade_height_change(y: np.ndarray, y0: np.ndarray, both: np.ndarray, planted: np.ndarray, fade: int) -> None:
    """In place: the change ``y - y0`` an ankle point's target height took on the frames ``both`` (its
    toe tip planted too) carried into the point's other planted frames of the same run, eased out over
    ``fade`` frames from the nearest such frame: where the toe lifts (or lands) while the heel stays
    planted, the heel's height does not jump back to its own target in one frame."""
    ch = np.where(both, y - y0, 0.0)
    if not np.any(ch):
        return
    sel, near, w = _height_fade_weights(both, planted, fade)
    y[sel] = y0[sel] + w * ch[near]


def _solve(motion: Motion, P, G, pts, plants: FootPlants, blend: int, height: str, tol: float,
           reach_margin: float, ease_kind: str, prev=None, hinges=None, clocks=None, plan=None):
    """One enforcement pass. Returns ``(rot, targets, state)`` with ``state`` per leg side:
    ``(delta (T, 3), rotvec (T, 3), miss (T,), lift (T,), solved (T,) bool, labels (T, 2))``. With ``prev`` (the
    ``(rot, state)`` of an earlier pass on the same motion) only the frames whose correction changed
    are solved again (the legs are independent and each frame's IK depends on its own correction).
    ``plan``: a :class:`FootplantPlan` of these ``plants``, ``blend``, ``height`` and ``ease_kind`` (the
    first pass's label work done once)."""
    from .ik import arc_quaternions

    T = motion.n_frames
    if hinges is None:
        hinges = [hinge_axis(P, G, leg.chain) for leg in plants.legs]
    if plan is not None and (prev is not None or plan.plants is not plants or plan.blend != blend
                             or plan.height != height or plan.ease_kind != ease_kind):
        plan = None
    if plan is not None:
        targets = plan.targets(pts)
        if _compiled_hold():
            return _solve_compiled(motion, P, G, pts, plan, targets, tol, reach_margin, hinges, clocks)
    else:
        targets = consistent_toe_targets(plant_targets(pts, plants, height), pts, plants)
        if height == "level" and PITCH_SLACK is not None:
            targets = bounded_foot_pitch(targets, pts, plants, PITCH_SLACK, blend if PITCH_TO_ZERO else 0)
    rot = np.array(motion.rotations) if prev is None else np.array(prev[0])
    state = {}
    jobs = []
    # the corrections of both legs at once, on segments of frames stacked one after the other with
    # ``reach`` unplanted frames between them: a fade reaches ``blend + 1`` frames and the toe-to-heel
    # cross-fade ``3 blend + 1`` from a planted frame, so nothing leaks from one segment into the next.
    # The first pass takes each leg whole; a later one only the stretches of a leg around the frames
    # whose plants changed (a stretch ends where the leg is unplanted for more than ``2 reach``
    # frames: beyond that its corrections are those of the earlier pass)
    nl = len(plants.legs)
    reach = 3 * blend + 2
    if plan is not None:
        labs, one_leg = None, plan.one_leg
    else:
        labs = [plants.labels[:, [2 * li, 2 * li + 1]] for li in range(nl)]
        one_leg = [bool(np.any(x[:, 1] & ~x[:, 0]) or np.any(x[:, 0] & ~x[:, 1])) for x in labs]
    segs = [] if plan is None else plan.segs
    for li, leg in enumerate(plants.legs if plan is None else ()):
        if prev is None:
            segs.append((li, 0, T))
            continue
        old = prev[1][leg.side][5]
        if np.array_equal(old, labs[li]):
            continue
        if one_leg[li] != bool(np.any(old[:, 1] & ~old[:, 0]) or np.any(old[:, 0] & ~old[:, 1])):
            segs.append((li, 0, T))                      # the fill of the rotation changes on the whole leg
            continue
        planted = np.flatnonzero(labs[li].any(axis=1))
        cut = np.flatnonzero(np.diff(planted) > 2 * reach)
        changed = np.r_[0, np.cumsum(np.any(labs[li] != old, axis=1))]
        for f0, f1 in zip(planted[np.r_[0, cut + 1]], planted[np.r_[cut, planted.size - 1]]):
            a, b = max(0, int(f0) - reach), min(T, int(f1) + 1 + reach)
            if changed[b] > changed[a]:
                segs.append((li, a, b))
    if plan is not None:
        rows, n = plan.rows, plan.n
    else:
        offs = np.cumsum([0] + [b - a + reach for _, a, b in segs])
        rows = [slice(int(o), int(o) + b - a) for o, (_, a, b) in zip(offs, segs)]
        n = int(offs[-1] - reach) if segs else 0

    def stack(k, x, fill=0.0):
        out = np.full((n,) + x.shape[2:], fill, dtype=x.dtype)
        for r, (li, a, b) in zip(rows, segs):
            out[r] = x[a:b, 2 * li + k]
        return out

    if plan is not None:
        la, lt, both = plan.la, plan.lt, plan.both
    else:
        la, lt = stack(0, plants.labels, False), stack(1, plants.labels, False)
        both = la & lt
    A, Tp = stack(0, pts), stack(1, pts)
    tA, tT = stack(0, targets, np.nan), stack(1, targets, np.nan)
    rv = np.zeros((n, 3))
    if both.any():
        q = arc_quaternions(Tp[both] - A[both], tT[both] - tA[both])
        rv[both] = quat_log(q)
    clock = None
    if clocks is not None and n > 1:
        ck = np.ones(n)
        for r, (li, a, b) in zip(rows, segs):
            ck[r] = clocks[a:b, li]
        clock = ck[:-1]
    plan_both, plan_a, plan_t, plan_any = RampPlan.many(np.column_stack([both, la, lt, la | lt]), blend, ease_kind,
                                                        clock=clock)
    rv = plan_both.fill(rv)
    Rq = quat_exp(rv)
    tip = A + quat_apply(Rq, Tp - A)                      # the toe tip after the foot turned about the ankle point
    # translation: the ankle point on its target while it is planted (with both points planted,
    # the aimed tip misses its target along the foot by the change of the ankle-tip distance
    # during the plant, and the foot shares that: half at the ankle point, half at the tip)
    d_a = np.zeros((n, 3))
    d_a[la] = tA[la] - A[la]
    if both.any():
        d_a[both] += 0.5 * (tT[both] - (tA[both] + tip[both] - A[both]))
    # toe tip planted alone (heel off): the tip exactly on its target, and the foot turned about
    # the tip so that the ankle point follows its fading correction from the heel's plant (the
    # heel rolls up about the toe; where the two targets disagree nothing jumps at heel-off)
    toe_only = lt & ~la if plan is None else plan.toe_only
    delta = np.where(la[:, None], d_a, 0.0)
    if toe_only.any():
        w_a = plan_a.fill(la.astype(float))
        da_fill = plan_a.fill(d_a)
        i = toe_only
        Tt = tT[i]
        a_cur = A[i] + Tt - tip[i]                               # ankle point with the tip on its target
        want = a_cur + da_fill[i] - w_a[i, None] * (Tt - tip[i])
        q_e = arc_quaternions(a_cur - Tt, want - Tt)
        R2 = quat_multiply(q_e, Rq[i])
        delta[i] = Tt - A[i] - quat_apply(R2, Tp[i] - A[i])
        rv[i] = quat_log(R2)
    # ankle point planted alone (before the toe lands, after it lifts): the ankle point exactly on
    # its target, the foot turned about it so that the toe tip follows its fading correction from
    # the toe's plant (symmetric to the above: a toe-only frame next to an ankle-only one is no jump)
    ankle_only = la & ~lt if plan is None else plan.ankle_only
    if ankle_only.any() and lt.any():
        w_t = plan_t.fill(lt.astype(float))                  # 0 on a leg whose toe is never planted
        ct_fill = plan_t.fill(np.where(lt[:, None], tT - Tp, 0.0))
        i = ankle_only & (w_t > 0)
        if i.any():
            a_new = tA[i]
            tip0 = a_new + quat_apply(Rq[i], Tp[i] - A[i])
            want = tip0 + ct_fill[i] + w_t[i, None] * (Tp[i] - tip0)
            R2 = quat_multiply(arc_quaternions(tip0 - a_new, want - a_new), Rq[i])
            rv[i] = quat_log(R2)
    if any(one_leg[li] for li, _, _ in segs):
        rv_f = plan_any.fill(rv)
        for r, (li, _, _) in zip(rows, segs):
            if one_leg[li]:
                rv[r] = rv_f[r]
    delta = plan_any.fill(delta)
    # a toe-only frame next to an ankle-only one (the foot rocks from toe to heel, as in a
    # cartwheel) holds two targets no rigid foot joins: cross-fade there over the blend frames
    if plan is not None:
        switches = plan.switches
    else:
        switches = []
        for r, (li, a, b) in zip(rows, segs):
            to, ao = toe_only[r], ankle_only[r]
            sw = np.flatnonzero((to[:-1] & ao[1:]) | (ao[:-1] & to[1:])) + 1
            if sw.size and blend > 0:
                t = np.arange(b - a)
                m = np.max(ease(1.0 - np.abs(t[:, None] - sw[None] + 0.5) / (blend + 1.0), ease_kind),
                           axis=1)[:, None]
                switches.append((r, m, max(blend / 2.0, 1.0)))
    for r, m, sig in switches:
        delta[r] = (1 - m) * delta[r] + m * gaussian_filter1d(delta[r], sig, axis=0, mode="nearest")
        rv[r] = (1 - m) * rv[r] + m * gaussian_filter1d(rv[r], sig, axis=0, mode="nearest")
    for li, leg in enumerate(plants.legs):
        ka, kt = 2 * li, 2 * li + 1
        mine = [(r, a, b) for r, (lj, a, b) in zip(rows, segs) if lj == li]
        if not mine:
            state[leg.side] = prev[1][leg.side]          # this leg's plants did not change: nor does its solve
            continue
        delta_l = np.zeros((T, 3)) if prev is None else np.array(prev[1][leg.side][0])
        rv_l = np.zeros((T, 3)) if prev is None else np.array(prev[1][leg.side][1])
        for r, a, b in mine:
            delta_l[a:b] = delta[r]
            rv_l[a:b] = rv[r]
        A_l = pts[:, ka]
        ja = leg.chain[2]
        Rq = quat_exp(rv_l)
        solve = (_norm(delta_l) > tol) | (_norm(rv_l) > tol)
        miss_all, lift_all = np.zeros(T), np.zeros(T)
        if prev is not None:
            d0, r0, miss_all, lift_all, solved0, _ = prev[1][leg.side]
            miss_all, lift_all = miss_all.copy(), lift_all.copy()
            redo = (np.abs(delta_l - d0).max(axis=1) > 1e-15) | (np.abs(rv_l - r0).max(axis=1) > 1e-15) | (solve != solved0)
            reset = redo & ~solve                        # corrected before, not now: back to the input's pose
            if reset.any():
                rot[np.ix_(reset, leg.chain)] = motion.rotations[np.ix_(reset, leg.chain)]
                miss_all[reset], lift_all[reset] = 0.0, 0.0
            idx = np.flatnonzero(redo & solve)
        else:
            idx = np.flatnonzero(solve)
        state[leg.side] = (delta_l, rv_l, miss_all, lift_all, solve, plants.labels[:, [ka, kt]])
        if idx.size == 0:
            continue
        tgt = A_l[idx] + delta_l[idx] + quat_apply(Rq[idx], P[idx, ja] - A_l[idx])   # the ankle joint, moved with the foot
        # soft reach: a target within ``soft`` of the leg's full length is brought in smoothly,
        # d' = d_s + soft (1 - exp(-(d - d_s) / soft)), by lifting the foot (the horizontal hold is
        # kept, the height yields), so the knee never snaps straight (its angle changes as
        # 1 / sin(knee) near full extension)
        h, k = leg.chain[0], leg.chain[1]
        H = P[idx, h]
        full = (_norm(P[idx, k] - H) + _norm(P[idx, ja] - P[idx, k])
                - 2.0 * reach_margin)
        soft = SOFT_REACH * full
        d_s = full - soft
        d = _norm(tgt - H)
        hor = _norm((tgt - H)[:, [0, 2]])
        d0 = _norm(P[idx, ja] - H)         # the input's own reach: never softened below it,
        want = np.where(d > d_s, np.maximum(d_s + soft * (1.0 - np.exp(-(d - d_s) / soft)),  # so a vanishing
                                            np.minimum(d, d0)), d)                         # correction is no jump
        far = (d > want) & (hor < want) & (tgt[:, 1] < H[:, 1])
        lift_all[idx] = 0.0
        if far.any():
            y = H[far, 1] - np.sqrt(want[far] ** 2 - hor[far] ** 2)
            lift_all[idx[far]] = y - tgt[far, 1]
            tgt[far, 1] = y
        jobs.append((leg.chain, idx, tgt, quat_multiply(Rq[idx], G[idx, ja]), hinges[li], miss_all))
    # both legs' IK in one vectorised call (the legs are independent: each frame's solve depends on its
    # own hip, knee and ankle only)
    if jobs:
        rot_legs, miss = _ik_legs(P, G, rot, motion.skeleton.parents, jobs, reach_margin)
        n0 = 0
        for (chain, idx, _, _, _, miss_all), r in zip(jobs, rot_legs):
            rot[np.ix_(idx, chain)] = r
            miss_all[idx] = miss[n0:n0 + idx.size]
            n0 += idx.size
    return rot, targets, state


def _compiled_hold() -> bool:
    """Whether the hold's compiled kernels run (:func:`mocomp.ops.displacement._compiled`: numba present,
    ``MOCOMP_NO_NUMBA`` unset, ``displacement.USE_COMPILED`` not ``False``)."""
    return _displacement._compiled()


def _solve_compiled(motion: Motion, P, G, pts, plan: "FootplantPlan", targets, tol, reach_margin, hinges, clocks):
    """:func:`_solve`'s first pass with a plan, compiled (:func:`mocomp.ops._footplant_kernel.solve_legs`):
    the same ``(rot, targets, state)``, equal to the numpy path to rounding."""
    from ._footplant_kernel import solve_legs

    k = plan.kernel_inputs(motion.skeleton.parents)
    rot = np.array(motion.rotations)
    delta, rv, miss, lift, solve = solve_legs(
        np.ascontiguousarray(P, dtype=np.float64), np.ascontiguousarray(G, dtype=np.float64), rot,
        np.ascontiguousarray(pts, dtype=np.float64), np.ascontiguousarray(targets, dtype=np.float64), k["labels"],
        k["chains"], k["parents"], np.ascontiguousarray(np.asarray(hinges, dtype=np.float64).reshape(-1, 3)), clocks,
        k["one_leg"], k["sw_mask"], k["has_sw"], k["sw_w"], plan.blend, k["kind"], tol, reach_margin, SOFT_REACH,
        BEND_PRIOR)
    state = {}
    for li, leg in enumerate(plan.plants.legs):
        state[leg.side] = (delta[li], rv[li], miss[li], lift[li], solve[li],
                           plan.plants.labels[:, [2 * li, 2 * li + 1]])
    return rot, targets, state


def _hinges_and_clocks(motion: Motion, P, G, plants: FootPlants):
    """``(hinges, clocks)``: :func:`~mocomp.ops.ik.hinge_axis` of each leg and :func:`leg_fade_clocks`
    (``None`` without :data:`FADE_RATE_SLACK`); compiled in one call when :func:`_compiled_hold`."""
    if _compiled_hold() and motion.n_frames >= 1:
        from ._footplant_kernel import hinges_and_clocks

        h, c = hinges_and_clocks(np.ascontiguousarray(P, dtype=np.float64), np.ascontiguousarray(G, dtype=np.float64),
                                 np.ascontiguousarray(motion.rotations, dtype=np.float64),
                                 [leg.chain for leg in plants.legs], FADE_RATE_SLACK, FADE_CLOCK_FLOOR)
        return list(h), c
    hinges = [hinge_axis(P, G, leg.chain) for leg in plants.legs]
    return hinges, (leg_fade_clocks(motion, plants) if FADE_RATE_SLACK is not None else None)


def leg_fade_clocks(motion: Motion, plants: FootPlants) -> np.ndarray:
    """``(T, legs)``: per frame ``t`` and leg, the clock of the fades on the step ``t -> t + 1``
    (:func:`~mocomp.ops.easing.fade_clock`; 1 on the last frame): the leg's fastest local joint rate
    (hip, knee, ankle) on that step against the fastest of all the legs' joints over the clip. A
    correction faded in where the leg already turns near that rate would add to it (ASE walk: the right
    foot's slap at touch-down, 8.48 rad/s, the clip's fastest joint, is in the fade-in of the next plant;
    faded in uniformly the output's foot turned at 9.04 rad/s there); with this clock the fade waits
    through that step and makes up on the steps before and after it."""
    T = motion.n_frames
    out = np.ones((T, len(plants.legs)))
    if T < 2:
        return out
    joints = sorted({int(j) for leg in plants.legs for j in leg.chain})
    q = motion.rotations[:, joints]
    d = quat_multiply(quat_inverse(q[:-1]), q[1:])
    ang = 2.0 * np.arctan2(_norm(d[..., :3]), np.abs(d[..., 3]))          # (T - 1, joints) rad per frame
    limit = float(ang.max())
    for li, leg in enumerate(plants.legs):
        out[:-1, li] = fade_clock(ang[:, [joints.index(int(j)) for j in leg.chain]].max(axis=1), limit,
                                  FADE_RATE_SLACK, FADE_CLOCK_FLOOR)
    return out


def _ik_legs(P, G, rot, parents, jobs, reach_margin):
    """:func:`~mocomp.ops.ik.two_bone_ik` of several legs in one call: each job ``(chain, frames,
    target, end rotation, hinge axis, _)`` is cut to a four-joint chain (the hip's parent, hip, knee,
    ankle) and the rows of all jobs are stacked. Returns the new local rotations ``(n, 3, 4)`` of each
    job's chain and the misses of all rows (job order). With numba (:func:`mocomp.ops.displacement._compiled`)
    each job runs through the compiled twin :func:`mocomp.ops._kernels.two_bone_ik_rows` on the clip's
    arrays directly (same operations; equal to this numpy path to rounding, ``tests/test_ops_ik.py``)."""
    from .displacement import _compiled

    if _compiled():
        from ._kernels import two_bone_ik_rows

        outs, misses = [], []
        for chain, idx, tgt, e, hinge, _ in jobs:
            o, mi = two_bone_ik_rows(P, G, rot, idx, int(parents[chain[0]]), chain, tgt, e, hinge, BEND_PRIOR,
                                     reach_margin)
            outs.append(o)
            misses.append(mi)
        return outs, np.concatenate(misses)
    Pm, Gm, Rm, tg, end, ax = [], [], [], [], [], []
    for chain, idx, tgt, e, hinge, _ in jobs:
        h = chain[0]
        hp = int(parents[h])
        cols = [hp if hp >= 0 else h, *chain]
        ix = (idx[:, None], np.asarray(cols)[None])
        p, g, r = P[ix], G[ix], rot[ix]
        if hp < 0:                                           # the hip is the root: no parent turn
            g[:, 0] = (0.0, 0.0, 0.0, 1.0)
        Pm.append(p); Gm.append(g); Rm.append(r); tg.append(tgt); end.append(e)
        ax.append(np.broadcast_to(hinge, (idx.size, 3)))
    out, miss = two_bone_ik(np.concatenate(Pm), np.concatenate(Gm), np.concatenate(Rm), _MINI_PARENTS, (1, 2, 3),
                            np.concatenate(tg), end_rotation=np.concatenate(end), reach_margin=reach_margin,
                            bend_axis=np.concatenate(ax), bend_prior=BEND_PRIOR)
    bounds = np.cumsum([0] + [j[1].size for j in jobs])
    return [out[a:b, 1:] for a, b in zip(bounds[:-1], bounds[1:])], miss


#: parents of the four-joint chain :func:`_ik_legs` solves on
_MINI_PARENTS = np.array([-1, 0, 1, 2])


def _with_leg_rotations(motion: Motion, P, G, rot, legs) -> Motion:
    """``motion`` with the local rotations ``rot``, which differ from its own on the legs' chains only,
    and its forward kinematics filled in (the re-detection pass reads the feet from it): ``P``, ``G``
    (the input's) except the joints below the hips on the frames where a leg changed, computed by
    :func:`~mocomp.core.kinematics.forward_kinematics` from the hips' common parent down (the same
    operations in the same order as a full FK: bit for bit equal)."""
    from ..core.kinematics import forward_kinematics
    from .ik import descends

    sk = motion.skeleton
    parents = sk.parents
    chains = np.array([leg.chain for leg in legs])
    chg = np.flatnonzero(np.any(rot[:, chains] != motion.rotations[:, chains], axis=(1, 2, 3)))
    hps = {int(parents[leg.chain[0]]) for leg in legs}
    if len(hps) != 1 or min(hps) < 0:
        return motion.replace_trusted(motion.root_positions, rot)   # hips on different parents: FK on first use
    hp = hps.pop()
    sub = [j for j in range(sk.n_joints) if any(descends(parents, j, leg.chain[0]) for leg in legs)]
    cols = np.array([hp] + sub)
    pos = {int(j): i for i, j in enumerate(cols)}
    par = np.array([pos.get(int(parents[j]), -1) for j in cols])
    P2, G2 = np.array(P), np.array(G)
    if chg.size:
        r = rot[chg[:, None], cols[None]]
        r[:, 0] = G[chg, hp]                            # the hips' parent as the chain's root
        Pm, Gm = forward_kinematics(par, sk.offsets[cols], P[chg, hp], r)
        P2[np.ix_(chg, sub)] = Pm[:, 1:]
        G2[np.ix_(chg, sub)] = Gm[:, 1:]
    return motion.replace_trusted(motion.root_positions, rot, fk=(P2, G2))

def _column_nanmedian(x: np.ndarray) -> np.ndarray:
    """``np.nanmedian(x, axis=0)`` of a ``(T, C)`` array, column by column (the median of each
    column's finite values; NaN for a column without any), without ``apply_along_axis``."""
    out = np.full(x.shape[1], np.nan)
    for c in range(x.shape[1]):
        v = x[:, c]
        v = v[~np.isnan(v)]
        if v.size:
            out[c] = np.median(v)
    return out


def _close_gaps(plants: FootPlants, max_gap: int) -> tuple[FootPlants, int]:
    """Plants of one foot point separated by fewer than ``max_gap`` unplanted frames joined into one
    (a point lifted for a few frames and put back is held throughout: two targets that close in time
    would make the foot jump between them). Points whose plants come from a CSV file are left as
    given. Returns the plants and the number of frames added."""
    import dataclasses

    lab = np.array(plants.labels)
    added = 0
    for k, e in enumerate(plants.effectors):
        if str(plants.source.get(e, "")).startswith("csv"):
            continue
        runs = label_intervals(lab[:, k])
        for (a0, b0), (a1, b1) in zip(runs, runs[1:]):
            if a1 - b0 < max_gap:
                lab[b0:a1, k] = True
                added += a1 - b0
    if not added:
        return plants, 0
    lev = np.array(plants.levels)
    fill = lab & np.isnan(lev)
    if fill.any():
        lev = np.where(fill, _column_nanmedian(np.where(plants.labels, lev, np.nan))[None], lev)
    return dataclasses.replace(plants, labels=lab, levels=lev), added


def enforce_footplants(motion: Motion, plants: FootPlants | None = None, *, contacts=None,
                       blend: int | None = None, height: str = "level", tol: float = 1e-6,
                       reach_margin: float = REACH_MARGIN, ease_kind: str = "smoothstep", passes: int = 2,
                       max_passes: int = 6, slide_goal: float | None = 0.01, audit: bool = True,
                       plan: "FootplantPlan | None" = None) -> FootplantResult:
    """Hold the planted feet of ``motion`` still (see the module docstring).

    Parameters
    ----------
    plants: the plants to enforce (default :func:`~mocomp.ops.plants.foot_plants` of the motion
        with ``contacts`` as overrides).
    contacts: overrides for the detector: a CSV path (``joint,start,stop``) or effector -> intervals.
    blend: frames of fade in/out (default :func:`default_blend_frames`, 0.1 s).
    height: how a planted point's height is set (:func:`~mocomp.ops.plants.plant_targets`):
        ``"level"`` (default: its lowest height in the plant on the support level, the heel roll
        kept), ``"hold"`` (on the support level throughout) or ``"keep"`` (its own height).
    tol: m / rad; frames whose correction is below this are not solved.
    passes: the contact detector is run again on the result and frames it finds planted that were
        not enforced are added, up to this many passes in all (a foot slowed by the fade-in is
        planted one frame earlier for the detector; the audit uses the same detector on the
        output). Effectors whose plants come from a CSV file are never extended.
    max_passes, slide_goal: when the last re-detection adds more than :data:`EXTRA_PASS_FRACTION` of the
        planted frames (the detector on the result disagrees with the input's: raw CMU toes sunk
        through the floor), passes go on, up to ``max_passes`` in all, until the feet slide at most
        ``slide_goal`` (m) within the plants the detector finds on the result
        (:func:`detected_slide`, the audit's measure), and the pass whose result slides least is
        kept: among the results (the first pass's included) whose audit floor penetration
        (:func:`_floor_depth`) is no deeper than the input's + :data:`PENETRATION_SLACK`; among all
        of them only when every one is deeper. ``slide_goal=None``: exactly ``passes`` passes.
    audit: also audit the input and the output (:func:`mocomp.audit.audit`), the measured evidence.
    plan: a :func:`footplant_plan` (in place of ``plants`` and ``blend``): the plants' label work
        (gaps closed, runs, stacked labels) done once for many motions, e.g. touch-up's iterations;
        ``height`` and ``ease_kind`` must be the plan's.

    Raises :class:`~mocomp.ops.plants.NoContactError` when no foot is ever planted.
    """
    import dataclasses

    from ..dynamics.contacts import detect_contacts

    t0 = time.perf_counter()
    if plan is not None:
        if plants is not None or contacts is not None or blend is not None:
            raise ValueError("give either a plan or plants/contacts/blend, not both")
        if plan.height != height or plan.ease_kind != ease_kind:
            raise ValueError(f"the plan is for height={plan.height!r}, ease_kind={plan.ease_kind!r}; got "
                             f"height={height!r}, ease_kind={ease_kind!r}")
        plants, blend = plan.input_plants, plan.blend
    if plants is None:
        plants = foot_plants(motion, contacts)
    elif contacts is not None:
        raise ValueError("give either plants or contacts overrides, not both")
    if plants.n_frames != motion.n_frames:
        raise ValueError(f"plants cover {plants.n_frames} frames, the motion has {motion.n_frames}")
    blend = default_blend_frames(motion.fps) if blend is None else int(blend)
    if blend < 0:
        raise ValueError(f"blend must be 0 or more frames, got {blend}")
    if passes < 1:
        raise ValueError(f"passes must be at least 1, got {passes}")
    if max_passes < 1:
        raise ValueError(f"max_passes must be at least 1, got {max_passes}")
    P, G = motion.fk()
    pts = foot_points(P, G, plants)
    notes = []
    plants, closed = (plan.plants, plan.closed) if plan is not None else _close_gaps(plants, max(1, blend // 2))
    if closed:
        notes.append(f"{closed} frame(s) of gaps shorter than {max(1, blend // 2)} frames between two plants of "
                     "one foot point counted as planted")
    prev = None
    hinges, clocks = _hinges_and_clocks(motion, P, G, plants)
    limit, best = passes, None
    for k in range(max(passes, max_passes)):
        rot, targets, state = _solve(motion, P, G, pts, plants, blend, height, tol, reach_margin, ease_kind, prev,
                                     hinges, clocks, plan)
        if k == limit - 1 and best is None:
            # the result: its FK is computed on first use (the evidence and the audits are lazy too)
            out = motion.replace_trusted(motion.root_positions, rot)
            break
        out = _with_leg_rotations(motion, P, G, rot, plants.legs)
        c = plants.contacts
        if c is None:
            again = detect_contacts(out)
        else:                                   # the feet only, on the floor the first detection found
            again = detect_contacts(out, effectors={e: (int(c.effector_joints[i]), c.effector_offsets[i])
                                                    for i, e in enumerate(c.effectors) if e in plants.effectors},
                                    ground_y=c.ground_y)
        if best is not None:                    # extra passes: keep the one the detector finds sliding least
            s = detected_slide(again, plants.effectors)
            worse = _deeper_than(out, pen_in)
            if (worse, s) < best[0]:
                best = ((worse, s), k, out, targets, state, plants)
            # the goal met: stop, unless this pass is deeper than the input and an earlier one was not
            if (s <= slide_goal and (not worse or best[0][0])) or k == limit - 1:
                break
        free = np.array([not str(plants.source[e]).startswith("csv") for e in plants.effectors])
        new = again.labels[:, [again.effectors.index(e) for e in plants.effectors]] & ~plants.labels & free[None]
        if not new.any():
            break
        notes.append(f"pass {k + 2}: {int(new.sum())} frame(s) the detector finds planted on the result added")
        if (slide_goal is not None and best is None and k == passes - 2 and max_passes > passes
                and new.sum() > EXTRA_PASS_FRACTION * plants.labels.sum()):
            # the detector on the result disagrees with the input's (CMU toes sunk through the floor):
            # more passes, each result measured by the detection the next pass needs anyway
            best, limit = ((True, np.inf), -1, None, None, None, None), max_passes
            # a pass may pitch a foot whose input slid under its merged plant (DeepMimic back flip: the
            # opening crouch's toes slide 11-14 cm, the heels re-detected beside them): the audit's floor
            # rises and the rest of the clip reads below it. Such a pass is kept only when every pass is
            # (PENETRATION_SLACK); this pass's result is a candidate too
            pen_in = _floor_depth(motion)[1]
            s = detected_slide(again, plants.effectors)
            best = ((_deeper_than(out, pen_in), s), k, out, targets, state, plants)
        lab = plants.labels | new
        # a point planted before: its median level; one planted only now: the level the detector found
        fill = _column_nanmedian(plants.levels)
        det = again.ground_y + again.levels[[again.effectors.index(e) for e in plants.effectors]]
        fill = np.where(np.isnan(fill), det, fill)
        lev = np.where(lab, np.where(np.isnan(plants.levels), fill[None], plants.levels), np.nan)
        plants = dataclasses.replace(plants, labels=lab, levels=lev)
        plants, _ = _close_gaps(plants, max(1, blend // 2))
        prev = (rot, state)
    if best is not None and best[2] is not None:
        (worse, sb), kb, out, targets, state, plants = best
        notes.append(f"the result of pass {kb + 1} kept: its feet slide least within the plants the detector finds "
                     f"on it ({sb * 100:.2f} cm)" + (
                         " of the passes not deeper below the audit's floor than the input" if not worse else
                         f"; every pass is deeper below the audit's floor than the input by more than "
                         f"{PENETRATION_SLACK * 100:g} cm"))
    unreachable, lifted, max_miss = {}, {}, 0.0
    changed = np.zeros(motion.n_frames, bool)
    for side, (_, _, miss, lift, solved, _) in state.items():
        far = miss > UNREACHABLE_TOL
        unreachable[side] = label_intervals(far) if far.any() else []
        if lift.max() > UNREACHABLE_TOL:
            lifted[side] = (label_intervals(lift > UNREACHABLE_TOL), float(lift.max()))
        max_miss = max(max_miss, float(miss.max()))
        changed |= solved
    seconds = time.perf_counter() - t0
    for side, (runs, amount) in lifted.items():
        if runs:
            notes.append(f"{side} foot lifted up to {amount * 1000:.1f} mm above its target height where the leg "
                         f"cannot reach it (frames " + ", ".join(f"{a}-{b - 1}" for a, b in runs[:6])
                         + (", ..." if len(runs) > 6 else "") + "); its horizontal position is held")
    if any(unreachable.values()):
        notes.append("unreachable: " + "; ".join(f"{s} leg frames " + ", ".join(f"{a}-{b - 1}" for a, b in v)
                                                   for s, v in unreachable.items() if v))
    res = FootplantResult(out, plants, targets, blend, unreachable, max_miss, int(changed.sum()), motion, seconds=seconds, notes=tuple(notes))
    if audit:
        from ..audit import audit as run_audit

        res = dataclasses.replace(res, audit_before=run_audit(motion, name="input"),
                                  audit_after=run_audit(out, name="footplants"))
    return res


class FootplantPlan:
    """What :func:`enforce_footplants` derives from the plants alone, computed once and reused on
    every motion those plants are enforced on (touch-up holds the input's plants after each of its
    5 + 5 + 2 iterations, Shin et al. 2003 sec. 3.1): the gaps closed (:func:`_close_gaps`), the
    planted runs of each point and their resting-level groups (:func:`~mocomp.ops.plants.plant_targets`
    with ``height="level"``), the toe runs paired with their heels' (``_toes_with_their_heels``), the
    shared runs of :func:`consistent_toe_targets` and :func:`bounded_foot_pitch` with the ease weights
    of its height fade (:func:`_fade_height_change`), and the first pass's stacked labels and
    toe-heel cross-fades (:func:`_solve`). :meth:`targets` gives the same numbers as those functions
    (the same operations on the same rows; ``tests/test_touchup_speed.py``). Build with
    :func:`footplant_plan`; pass as ``enforce_footplants(motion, plan=plan)``."""

    def __init__(self, plants: FootPlants, blend: int, height: str = "level", ease_kind: str = "smoothstep"):
        from .plants import ROBUST_LEVEL, TOE_HEEL_GAP

        if blend < 0:
            raise ValueError(f"blend must be 0 or more frames, got {blend}")
        self.input_plants = plants
        self.blend, self.height, self.ease_kind = int(blend), height, ease_kind
        plants, closed = _close_gaps(plants, max(1, self.blend // 2))
        self.plants, self.closed = plants, closed
        self.toe_heel_gap = TOE_HEEL_GAP
        lab = plants.labels
        T = plants.n_frames
        # plant_targets: per point, its planted rows, their runs and the resting-level groups
        self.points = []
        for k in range(4):
            sel = np.flatnonzero(lab[:, k])
            if sel.size == 0:
                self.points.append(None)
                continue
            first = np.flatnonzero(_r(True, np.diff(sel) > 1))
            cnt = np.diff(_r(first, sel.size))
            rid = np.repeat(np.arange(first.size), cnt)
            rest = None
            if height == "level" and ROBUST_LEVEL and plants.source.get(plants.effectors[k]) == "detector":
                level = plants.levels[sel[first], k]
                key = np.round(level, 3)
                rest = (np.array(level, dtype=float), [key == v for v in np.unique(key[np.isfinite(key)])])
            self.points.append((sel, first, cnt, rid, rest))
        # _toes_with_their_heels: per foot, each toe frame's heel run shift source
        self.toes = []
        if height == "level" and ROBUST_LEVEL:
            for ka, kt in ((0, 1), (2, 3)):
                if any(plants.source.get(plants.effectors[k]) != "detector" for k in (ka, kt)):
                    continue
                la, lt = lab[:, ka], lab[:, kt]
                if not (la & lt).any():
                    continue
                ra = np.cumsum(_r(la[0], la[1:] & ~la[:-1])) * la
                rt = np.cumsum(_r(lt[0], lt[1:] & ~lt[:-1])) * lt
                sh = np.flatnonzero(la & lt)
                pairs, first, cnt = np.unique(rt[sh] * (int(ra.max()) + 1) + ra[sh], return_index=True,
                                              return_counts=True)
                toe_run = pairs // (int(ra.max()) + 1)
                order = np.lexsort((first, -cnt, toe_run))
                keep = order[_r(True, toe_run[order][1:] != toe_run[order][:-1])]
                f = np.flatnonzero(lt)
                starts = _r(0, np.flatnonzero(np.diff(f) > 1) + 1)
                self.toes.append((ka, kt, int(rt.max()) + 1, toe_run[keep], sh[first[keep]], rt[f], f, starts,
                                  np.diff(_r(starts, f.size))))
        # consistent_toe_targets: per leg, the shared frames and the toe runs they belong to
        self.consistent = []
        for li in range(len(plants.legs)):
            ka, kt = 2 * li, 2 * li + 1
            la, lt = lab[:, ka], lab[:, kt]
            run = np.cumsum(_r(lt[0], lt[1:] & ~lt[:-1])) * lt
            sel = np.flatnonzero(lt & la)
            if sel.size == 0:
                continue
            rid = run[sel]
            nr = int(run.max()) + 1
            cnt = np.bincount(rid, minlength=nr)
            has = cnt > 0
            first = np.zeros(nr, dtype=int)
            r_u, i_u = np.unique(rid, return_index=True)
            first[r_u] = sel[i_u]
            self.consistent.append((ka, kt, run, sel, rid, nr, cnt, has, first))
        # bounded_foot_pitch: per leg, the runs of frames with both points planted, and the fade weights
        self.pitch = []
        fade = self.blend if PITCH_TO_ZERO else 0
        for li in range(len(plants.legs)):
            ka, kt = 2 * li, 2 * li + 1
            both = lab[:, ka] & lab[:, kt]
            if not both.any():
                continue
            sel = np.flatnonzero(both)
            first = np.flatnonzero(_r(True, np.diff(sel) > 1))
            cnt = np.diff(_r(first, sel.size))
            rid = np.repeat(np.arange(first.size), cnt)
            fw = _height_fade_weights(both, lab[:, ka], fade) if fade > 0 else None
            self.pitch.append((ka, kt, both, sel, first, cnt, rid, fw))
        # _solve's first pass: every leg whole, stacked with ``reach`` unplanted frames between them
        nl = len(plants.legs)
        reach = 3 * self.blend + 2
        labs = [lab[:, [2 * li, 2 * li + 1]] for li in range(nl)]
        self.one_leg = [bool(np.any(x[:, 1] & ~x[:, 0]) or np.any(x[:, 0] & ~x[:, 1])) for x in labs]
        self.segs = [(li, 0, T) for li in range(nl)]
        offs = np.cumsum([0] + [b - a + reach for _, a, b in self.segs])
        self.rows = [slice(int(o), int(o) + b - a) for o, (_, a, b) in zip(offs, self.segs)]
        self.n = n = int(offs[-1] - reach) if self.segs else 0
        la, lt = np.zeros(n, bool), np.zeros(n, bool)
        for r, (li, a, b) in zip(self.rows, self.segs):
            la[r], lt[r] = lab[a:b, 2 * li], lab[a:b, 2 * li + 1]
        self.la, self.lt, self.both = la, lt, la & lt
        self.toe_only, self.ankle_only = lt & ~la, la & ~lt
        self.switches = []
        for r, (li, a, b) in zip(self.rows, self.segs):
            to, ao = self.toe_only[r], self.ankle_only[r]
            sw = np.flatnonzero((to[:-1] & ao[1:]) | (ao[:-1] & to[1:])) + 1
            if sw.size and self.blend > 0:
                t = np.arange(b - a)
                m = np.max(ease(1.0 - np.abs(t[:, None] - sw[None] + 0.5) / (self.blend + 1.0), ease_kind),
                           axis=1)[:, None]
                self.switches.append((r, m, max(self.blend / 2.0, 1.0)))

    def kernel_inputs(self, parents) -> dict:
        """The plan as arrays for the compiled hold (:mod:`mocomp.ops._footplant_kernel`; made on first use):
        the labels, the legs' chains and hip parents, which legs get the ``plan_any`` fill of the foot turn,
        and per leg the toe-to-heel cross-fade weight (``sw_mask (L, T)``, ``has_sw``) with the Gaussian of
        its smoothing (``sw_w``). ``parents``: the skeleton's (the hips' parents; the plan is for one
        skeleton)."""
        k = getattr(self, "_kernel", None)
        if k is not None:
            return k
        from ._footplant_kernel import EASE_CODES
        from .displacement import _gaussian_kernel

        plants = self.plants
        L, T = len(plants.legs), plants.n_frames
        sw_mask, has_sw = np.zeros((L, T)), np.zeros(L, np.bool_)
        sig = max(self.blend / 2.0, 1.0)
        for r, m, sig in self.switches:
            li = self.segs[self.rows.index(r)][0]
            sw_mask[li] = m[:, 0]
            has_sw[li] = True
        k = {"labels": np.ascontiguousarray(plants.labels, dtype=np.bool_),
             "chains": np.array([leg.chain for leg in plants.legs], dtype=np.int64),
             "parents": np.array([int(parents[leg.chain[0]]) for leg in plants.legs], dtype=np.int64),
             "one_leg": np.array(self.one_leg, dtype=np.bool_), "sw_mask": sw_mask, "has_sw": has_sw,
             "sw_w": _gaussian_kernel(sig), "kind": EASE_CODES[self.ease_kind]}
        self._kernel = k
        return k

    def targets_inputs(self) -> dict:
        """The plan's runs as flat arrays for the compiled :meth:`targets`
        (:func:`mocomp.ops._footplant_kernel.plan_targets`; made on first use)."""
        k = getattr(self, "_targets_k", None)
        if k is not None:
            return k
        T = self.plants.n_frames
        rows, pt_off, first, cnt, run_off, group, level, rest = [], [0], [], [], [0], [], [], []
        n_groups = 0
        for pl in self.points:
            if pl is None:
                pt_off.append(pt_off[-1])
                run_off.append(run_off[-1])
                rest.append(False)
                continue
            sel, f, c, _, rs = pl
            first.extend((f + pt_off[-1]).tolist())
            cnt.extend(c.tolist())
            rows.extend(sel.tolist())
            pt_off.append(pt_off[-1] + sel.size)
            run_off.append(run_off[-1] + f.size)
            g = np.full(f.size, -1)
            if rs is not None:
                for m in rs[1]:
                    g[m] = n_groups
                    n_groups += 1
                level.extend(rs[0].tolist())
            else:
                level.extend([np.nan] * f.size)
            group.extend(g.tolist())
            rest.append(rs is not None)
        # _toes_with_their_heels: rows (toe_run, src), (rt_f, f), (starts, lens), each pair with its own offsets
        toe_k, toe_off, toe_nsh, parts = [], [[0, 0, 0]], [], [[], [], [], [], [], []]
        for ka, kt, nsh, toe_run, src, rt_f, f, starts, lens in self.toes:
            toe_k.append((ka, kt))
            toe_nsh.append(nsh)
            for i, a in enumerate((toe_run, src, rt_f, f, starts, lens)):
                parts[i].extend(np.asarray(a).tolist())
            toe_off.append([toe_off[-1][0] + len(toe_run), toe_off[-1][1] + len(f), toe_off[-1][2] + len(starts)])
        width = max([1] + [len(x) for x in parts])
        toe_arr = np.zeros((6, width), np.int64)
        for i, x in enumerate(parts):
            toe_arr[i, :len(x)] = x
        cons_k, cons_run, cons_sel, cons_rid, cons_off, cons_nr = [], [], [], [], [[0, 0]], []
        for ka, kt, run, sel, rid, nr, _, _, _ in self.consistent:
            cons_k.append((ka, kt))
            cons_run.extend(run.tolist())
            cons_sel.extend(sel.tolist())
            cons_rid.extend(rid.tolist())
            cons_nr.append(nr)
            cons_off.append([cons_off[-1][0] + sel.size, cons_off[-1][1] + T])
        pitch_k, pitch_both, pitch_sel, pitch_off, fsel, near, w, woff, has_fade = [], [], [], [0], [], [], [], [[0, 0]], []
        for ka, kt, both, sel, _, _, _, fw in self.pitch:
            pitch_k.append((ka, kt))
            pitch_both.append(both)
            pitch_sel.extend(sel.tolist())
            pitch_off.append(pitch_off[-1] + sel.size)
            if fw is not None:
                fs, nr_, ww = fw
                fsel.extend(np.flatnonzero(fs).tolist())
                near.extend(np.asarray(nr_).tolist())
                w.extend(np.asarray(ww, float).tolist())
            has_fade.append(fw is not None)
            woff.append([len(fsel), 0])
        i64 = lambda x, shape=None: np.array(x, dtype=np.int64).reshape(shape if shape else -1)   # noqa: E731
        k = {"pt_rows": i64(rows), "pt_off": i64(pt_off), "run_first": i64(first), "run_cnt": i64(cnt),
             "run_off": i64(run_off), "run_group": i64(group), "run_level": np.array(level, float),
             "pt_rest": np.array(rest, np.bool_), "n_groups": n_groups,
             "toe_k": i64(toe_k, (-1, 2)), "toe_arr": toe_arr, "toe_off": i64(toe_off, (-1, 3)),
             "toe_nsh": i64(toe_nsh), "gap": float(self.toe_heel_gap),
             "cons_k": i64(cons_k, (-1, 2)), "cons_run": i64(cons_run), "cons_sel": i64(cons_sel),
             "cons_rid": i64(cons_rid), "cons_off": i64(cons_off, (-1, 2)), "cons_nr": i64(cons_nr),
             "pitch_k": i64(pitch_k, (-1, 2)),
             "pitch_both": np.array(pitch_both, np.bool_).reshape(-1, T), "pitch_sel": i64(pitch_sel),
             "pitch_off": i64(pitch_off), "pitch_fsel": i64(fsel), "pitch_near": i64(near),
             "pitch_w": np.array(w, float), "pitch_woff": i64(woff, (-1, 2)),
             "pitch_has_fade": np.array(has_fade, np.bool_), "slack": float(PITCH_SLACK)}
        self._targets_k = k
        return k

    def targets(self, pts: np.ndarray) -> np.ndarray:
        """``(T, 4, 3)`` m: ``consistent_toe_targets(plant_targets(pts, plants, height), pts, plants)``,
        then :func:`bounded_foot_pitch` for ``height="level"`` (as :func:`_solve` sets them), with the
        runs planned. With numba (:func:`_compiled_hold`) the ``"level"`` targets run as one compiled call
        (:func:`mocomp.ops._footplant_kernel.plan_targets`, equal to this numpy code to rounding)."""
        from .plants import _resting_levels, plant_targets

        plants = self.plants
        if self.height == "level" and PITCH_SLACK is not None and PITCH_TO_ZERO and _compiled_hold():
            from ._footplant_kernel import plan_targets

            return plan_targets(np.ascontiguousarray(pts, dtype=np.float64),
                                np.ascontiguousarray(plants.levels, dtype=np.float64), self.targets_inputs())
        if self.height != "level":
            out = plant_targets(pts, plants, self.height)
        else:
            T = plants.n_frames
            out = np.full((T, 4, 3), np.nan)
            for k, pl in enumerate(self.points):
                if pl is None:
                    continue
                sel, first, cnt, rid, rest = pl
                p = pts[sel, k]
                mean = np.add.reduceat(p, first, axis=0) / cnt[:, None]
                out[sel, k] = mean[rid]
                y = p[:, 1]
                low = np.minimum.reduceat(y, first)
                if rest is not None:
                    lv = np.array(rest[0])
                    for g in rest[1]:
                        lv[g] = _median(low[g])
                    out[sel, k, 1] = y - low[rid] + lv[rid]
                else:
                    out[sel, k, 1] = y - low[rid] + plants.levels[sel, k]
            for ka, kt, nsh, toe_run, src, rt_f, f, starts, lens in self.toes:
                shift = np.full(nsh, np.nan)
                shift[toe_run] = out[src, ka, 1] - pts[src, ka, 1]
                s_t = shift[rt_f]
                own = np.repeat((out[f, kt, 1] - pts[f, kt, 1])[starts], lens)
                move = np.isfinite(s_t) & (np.abs(own - s_t) > self.toe_heel_gap)
                out[f[move], kt, 1] = pts[f[move], kt, 1] + s_t[move]
        targets = out
        out = np.array(targets)
        for ka, kt, run, sel, rid, nr, cnt, has, first in self.consistent:
            _toe_from_ankle(out, targets, pts, ka, kt, run, sel, rid, nr, cnt, has, first)
        if self.height != "level" or PITCH_SLACK is None:
            return out
        targets = out
        out = np.array(targets)
        slack = PITCH_SLACK
        for ka, kt, both, sel, first, cnt, rid, fw in self.pitch:
            if not _pitch_heights(out, pts, ka, kt, sel, first, cnt, rid, slack):
                continue
            if fw is not None:
                y, y0 = out[:, ka, 1], targets[:, ka, 1]
                ch = np.where(both, y - y0, 0.0)
                if np.any(ch):
                    fsel, near, w = fw
                    y[fsel] = y0[fsel] + w * ch[near]
        return out


def _r(*parts) -> np.ndarray:
    """``np.r_[parts]`` for 1-D arrays and scalars (the same array; without ``np.r_``'s ~8 us per call:
    the plan is built once per touch-up, with ~25 of them)."""
    return np.concatenate([np.atleast_1d(p) for p in parts])


def _median(x: np.ndarray) -> float:
    """``np.median`` of a 1-D array without NaNs (the middle value, or the mean of the two middle ones:
    the same number), without its per-call overhead."""
    s = np.sort(x)
    n = s.size
    return s[n // 2] if n % 2 else (s[n // 2 - 1] + s[n // 2]) / 2.0


def _height_fade_weights(both: np.ndarray, planted: np.ndarray, fade: int):
    """The label-only part of :func:`_fade_height_change`: ``(frames, nearest shared frame, weight)``."""
    T = both.size
    t = np.arange(T)
    run = np.cumsum(_r(planted[0], planted[1:] & ~planted[:-1])) * planted   # run id per frame (0: none)
    prev = np.maximum.accumulate(np.where(both, t, -1))                     # last shared frame at or before
    nxt = np.minimum.accumulate(np.where(both, t, T)[::-1])[::-1]            # first shared frame at or after
    ok_p = (prev >= 0) & (run[np.maximum(prev, 0)] == run)
    ok_n = (nxt < T) & (run[np.minimum(nxt, T - 1)] == run)
    dp = np.where(ok_p, t - prev, np.iinfo(np.int64).max)
    dn = np.where(ok_n, nxt - t, np.iinfo(np.int64).max)
    near = np.where(dp <= dn, np.maximum(prev, 0), np.minimum(nxt, T - 1))
    sel = planted & ~both & (ok_p | ok_n)
    d = np.minimum(dp, dn)[sel]
    w = ease(np.clip(1.0 - d / (fade + 1.0), 0.0, 1.0), "smoothstep")
    return sel, near[sel], w


def footplant_plan(plants: FootPlants, blend: int, *, height: str = "level",
                   ease_kind: str = "smoothstep") -> FootplantPlan:
    """:class:`FootplantPlan` of ``plants`` for :func:`enforce_footplants` with these ``blend`` frames,
    ``height`` and ``ease_kind`` (build once, enforce on many motions of the plants' frame count)."""
    from .plants import HEIGHT_MODES

    if height not in HEIGHT_MODES:
        raise ValueError(f"height must be one of {', '.join(HEIGHT_MODES)}, got {height!r}")
    return FootplantPlan(plants, int(blend), height, ease_kind)
