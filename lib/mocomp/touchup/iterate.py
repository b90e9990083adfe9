"""The touch-up loop (Shin et al. 2003, sec. 3.1, Fig. 2, sec. 4.1): for every step of a schedule
and each of its iterations, compute the per-frame adjustments (ground: eq. 6-7; flight: the
ballistic COM, eq. 10), smooth them into a displacement map of the step's width, damp by ``rho``
and add (:func:`mocomp.ops.apply_hierarchy`), then hold the planted feet again
(:func:`mocomp.ops.enforce_footplants`, the input's plants: the leg correction of the step's result
less that of the motion before the step, so that the feet stay where the input had them). The ZMP distance outside the support
polygon and the flights' COM residuals are measured after every iteration.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_apply, quat_exp, quat_multiply
from ..dynamics.com import center_of_mass
from ..dynamics.momentum import momentum
from ..dynamics.constants import G_STANDARD
from ..ops import HierarchyStep, apply_hierarchy, ease, enforce_footplants
from ..ops.footplant import default_blend_frames, foot_points, footplant_plan
from . import _fast
from ._fast import SegmentChains, fk
from .flight import ballistic_targets, com_residual, flight_com_adjustment, flight_momentum_adjustment
from .ground import MAX_ANGLE, ground_adjustment
from .linksets import link_sets
from .schedule import schedule_from_spec
from .stages import Stages, stages
from .zmp import DEFAULT_SMOOTH_SIGMA, floor_levels, zmp_state

__all__ = ["TouchupResult", "touchup", "NEIGHBOURHOOD_S", "MIN_FLIGHT_S", "ground_weights", "lift_feet", "resting_levels",
           "ballistic_completion"]

#: s: ground frames this close to a flight are adjusted with it (the paper's 15 frames, 1/2 s)
NEIGHBOURHOOD_S = 0.5
#: s: the shortest ramp of the ground maps' weight next to a flight (:func:`ground_weights`)
MIN_RAMP_S = 0.1
#: ground frames whose ground-map weight (:func:`ground_weights`) is at most this get no per-frame
#: adjustment: the inner half of a flight's neighbourhood (take-off push, landing impact) stays out,
#: the outer half is adjusted and faded. With only weight-1 frames adjusted, a 120 Hz hop with 33
#: ground frames either side of its 34-frame flight had no ground frame adjusted at all (CMU 01_01
#: path-edited onto an arc: mean ZMP outside 11.1 -> 14.4 cm from the flight steps alone; 9.4 cm now)
GROUND_FRAMES_MIN_WEIGHT = 0.5
#: s: the Gaussian standard deviation (one frame at 30 fps) that eases :func:`lift_feet`'s lowering of touching points in and out
HOLD_SMOOTH_S = 1.0 / 30.0
#: s: flights shorter than this stay in the ground maps (:func:`ground_weights`; 3 frames at 30 fps)
MIN_FLIGHT_S = 0.1


@dataclass(frozen=True, eq=False)
class TouchupResult:
    """The touched-up ``motion``, its ``stages``, the ``schedule``, per iteration a record
    (``history``: step, iteration, mean/max ZMP distance outside, clamped frames, flight COM
    residuals, map magnitudes), the ``clamped`` frames per step, the wall time, and the ZMP's signed
    distance to the support polygon per ground frame before and after (``(T,)`` m, NaN elsewhere)."""

    motion: object
    input: object
    stages: Stages
    schedule: tuple
    history: tuple
    clamped: dict
    before: dict
    after: dict
    seconds: float
    distance_before: np.ndarray = None
    distance_after: np.ndarray = None
    capped: dict = None
    lifted: dict = None

    def to_dict(self) -> dict:
        return {"stages": self.stages.to_dict(), "schedule": [s.to_dict() for s in self.schedule],
                "planned": {"before": self.before, "after": self.after, "iterations": list(self.history),
                            "clamped_frames": {k: v for k, v in self.clamped.items()},
                            "capped_frames": dict(self.capped or {}),
                            "feet_lifted_frames": dict(self.lifted or {})},
                "seconds": self.seconds}


def _variation(L: np.ndarray) -> float:
    """(max - min) / mean of ``|L|`` over a flight's inner frames (the end frames' central
    differences reach into the ground frames; the audit drops them too)."""
    return float((L.max() - L.min()) / max(L.mean(), 1e-9))


def ground_weights(n_frames: int, flights, neighbourhood: int, min_ramp: int = 0, min_flight: int = 0) -> np.ndarray:
    """``(T,)``: per frame, how much the frame belongs to the ground stages; the ground steps
    compute per-frame adjustments only where it exceeds :data:`GROUND_FRAMES_MIN_WEIGHT` (the maps
    themselves, smoothed, act on every frame: see :func:`touchup`). It was the ground maps' weight
    (:func:`mocomp.ops.apply_hierarchy`'s ``weights``) until the fade was found to make the lean's
    angular accelerations at a hop's take-off and landing. 0 on a flight and on the frame either side; easing to 1 over the flight's
    neighbourhood (Fig. 4: those ground frames are the flight steps', their take-off push and
    landing impact stay out of the ground maps), but over no more frames than the flight lasts: a
    run's 1-3 frame flights (30 fps) would otherwise take every ground frame of the run out of the
    ground maps (0.5 s either side of flights 0.37 s apart), and the walk -> run blend's ZMP was left
    as it was (mean outside 8.1 -> 6.8 cm; 4.2 cm with the reach cut to the flights' lengths). The
    ramp is at least ``min_ramp`` frames (touch-up: :data:`MIN_RAMP_S`): cut to a 1-2 frame
    flight's length, the ground maps' weight stepped from 0 to 1 within two frames and the written
    blend's COM velocity jumped 1.8 and 6.1 m/s at the run's take-offs (audit violations the input
    does not have); with 3 frames (0.1 s at 30 fps) there is none. Flights shorter than
    ``min_flight`` frames (touch-up: :data:`MIN_FLIGHT_S`) are not taken out at all: the ground maps
    (kernels 1/3 s and wider) run smoothly through a run's 1-2 frame flights, whose parabola is
    then made by the flight steps; faded to 0 and back over 0.1 s around each of them, the
    blend's lean was switched off and on at every stride, and the angular accelerations that makes
    put the read-back ZMP 20-290 cm outside next to the flights (walk -> run blend: mean outside
    8.1 -> 5.1 cm faded, 1.7 cm not)."""
    w = np.ones(n_frames)
    for a, b in flights:
        if b - a < min_flight:
            continue
        w[a:b] = 0.0
        n = min(int(neighbourhood), max(b - a, int(min_ramp)))
        if n < 1:
            continue
        i = np.arange(1, n + 1)
        v = ease((i - 1) / n)                      # the frame next to a flight stays 0 too
        for f in (a - i, b - 1 + i):               # before and after the flight (never the same frame)
            ok = (f >= 0) & (f < n_frames)
            w[f[ok]] = np.minimum(w[f[ok]], v[ok])
    return w


def resting_levels(plants, reference_points: np.ndarray) -> np.ndarray:
    """``(4,)`` m: each foot point's resting level for :func:`lift_feet` -- the median of its
    plants' levels, its lowest height in ``reference_points`` ``(T, 4, 3)`` when never planted."""
    lv = np.asarray(plants.levels, float)
    rest = np.nanmin(reference_points[..., 1], axis=0)              # a point never planted: its lowest height
    for k in range(lv.shape[1]):                                    # np.nanmedian per column, without its overhead
        v = lv[:, k][np.isfinite(lv[:, k])]
        if v.size:
            rest[k] = np.median(v)
    return rest


def lift_feet(motion, plants, reference_points: np.ndarray, touching: np.ndarray, *, tol: float = 1e-3,
              rest: np.ndarray | None = None, airborne: np.ndarray | None = None):
    """``(motion, lifted frames per leg)``: each leg raised by two-bone IK
    (:func:`mocomp.ops.two_bone_ik`, the foot's orientation kept; with numba its compiled twin
    :func:`mocomp.ops._kernels.two_bone_ik_rows` on the clip's rows) on the frames where one of its
    foot points has been pushed down -- below its height in the input (``reference_points``
    ``(T, 4, 3)``) where it touches the ground there (``touching`` ``(T, 4)``), below its resting
    level elsewhere -- and lowered where a touching point has risen above its input height (a leg
    with a touching point is held at the input's height; the lifting of a free point below its
    resting level wins). The planted points are held by :func:`mocomp.ops.enforce_footplants`; a
    touching point that is not planted (a heel rolling in, a foot sliding through a blend window)
    is not, and a lean of the whole body about the ZMP's projection (the lower body in S2) swings
    it through the floor: on the walk -> run blend, 10 cm after the first step's 5 iterations.
    ``rest``: :func:`resting_levels` when the caller has it (fixed for a touch-up run).
    ``airborne`` ``(T,)`` bool: frames (the input's flights) whose foot points are held at least at
    their input height, so that a flight stays a flight."""
    from ..dynamics.derivatives import gaussian_smooth
    from ..ops import two_bone_ik
    from ..ops.displacement import _compiled
    from ..ops.ik import REACH_MARGIN

    compiled = _compiled()
    if compiled:
        from ..ops._kernels import two_bone_ik_rows

    P, G = fk(motion)
    pts = foot_points(P, G, plants)
    rest = resting_levels(plants, reference_points) if rest is None else rest
    touching = np.asarray(touching, bool)
    if compiled and _fast.COMPILED:                # the lines below in one compiled call (_fast.lift_legs)
        rot = np.array(motion.rotations)
        ks = [[plants.effectors.index(e) for e in (f"foot_{leg.side}", f"toe_{leg.side}")] for leg in plants.legs]
        up_legs = _fast.lift_legs(P, G, rot, pts, reference_points, rest, airborne, touching, ks,
                                  [leg.chain for leg in plants.legs],
                                  [int(motion.skeleton.parents[leg.chain[0]]) for leg in plants.legs], tol,
                                  HOLD_SMOOTH_S * motion.fps, REACH_MARGIN)
        lifted = {leg.side: np.flatnonzero(u).tolist() for leg, u in zip(plants.legs, up_legs) if u.any()}
        if not lifted:
            return motion, lifted
        return motion.replace_trusted(motion.root_positions, rot), lifted
    floor = np.minimum(rest[None], reference_points[..., 1])
    if airborne is not None:
        # in flight no foot point comes lower than it was: a lean carried through the flight
        # lowered the landing toe two frames early into the written motion's contact region, and
        # the read-back ZMP of those frames was 85-164 cm outside (CMU 01_01 hop on an arc)
        floor = np.where(np.asarray(airborne, bool)[:, None], reference_points[..., 1], floor)
    free = floor - pts[..., 1]
    # a touching point is held at its input height both ways (pulled down as well as up: the support
    # polygon touch-up balanced is the input's contact region, and a lean that swings the trailing
    # toe 2 cm up takes it out of the written motion's polygon -- on the walk -> run blend the
    # read-back ZMP was then 18-31 cm outside on frames touch-up had put inside); a free point only
    # pushed down is raised
    held = np.where(touching, reference_points[..., 1] - pts[..., 1], -np.inf)
    up = np.where(free > 0, free, -np.inf)
    rot = None
    lifted = {}
    for leg in plants.legs:
        ks = [plants.effectors.index(e) for e in (f"foot_{leg.side}", f"toe_{leg.side}")]
        dh, du = held[:, ks].max(axis=1), up[:, ks].max(axis=1)    # (T,) m; -inf: nothing to hold
        # the lowering eased in and out (Gaussian, HOLD_SMOOTH_S): a leg pulled down on the frames a
        # point touches and let go on the next jumped the written COM's velocity by 0.7 m/s
        down = np.where(np.isfinite(dh), np.minimum(dh, 0.0), 0.0)
        if (down < -tol).any():
            down = gaussian_smooth(down, HOLD_SMOOTH_S * motion.fps)
        dy = np.maximum(np.maximum(down, np.where(dh > 0, dh, -np.inf)), du)
        dy = np.where(np.isfinite(dy), dy, down)
        # both points touching: the ankle point to its input height and the foot pitched about it
        # so that the toe is at its input height too (a lean turns the foot with the lower body:
        # heel down, toe up, and the toe left the written motion's contact region)
        both = touching[:, ks].all(axis=1)
        dy = np.where(both, held[:, ks[0]], dy)
        need = np.where(both, held[:, ks[1]] - dy, 0.0)            # the toe's height still to go
        f = np.flatnonzero((np.abs(dy) > tol) | (np.abs(need) > tol))
        if not f.size:
            continue
        rot = np.array(motion.rotations) if rot is None else rot
        a = leg.chain[2]
        A = pts[f, ks[0]]
        v = pts[f, ks[1]] - A                                       # ankle point -> toe tip
        h = np.linalg.norm(v[:, [0, 2]], axis=1)
        n = np.linalg.norm(v, axis=1)
        beta = np.arctan2(v[:, 1], h)
        phi = np.arcsin(np.clip((v[:, 1] + need[f]) / np.maximum(n, 1e-9), -1.0, 1.0)) - beta
        axis = np.column_stack([-v[:, 2], np.zeros(f.size), v[:, 0]]) / np.maximum(h, 1e-9)[:, None]
        q = quat_exp(axis * phi[:, None])                           # v_h x up: pitch up for phi > 0
        end = quat_multiply(q, G[f, a])
        A_new = A + np.column_stack([np.zeros(f.size), dy[f], np.zeros(f.size)])
        tgt = A_new - quat_apply(q, A - P[f, a])                    # the ankle joint under the turned foot
        if compiled:                               # the same solve on the clip's rows (ops._kernels)
            r, _ = two_bone_ik_rows(P, G, rot, f, int(motion.skeleton.parents[leg.chain[0]]), leg.chain, tgt, end,
                                    (1.0, 0.0, 0.0), 0.0, REACH_MARGIN)
            rot[f[:, None], np.asarray(leg.chain)[None]] = r
        else:
            r, _ = two_bone_ik(P[f], G[f], rot[f], motion.skeleton.parents, leg.chain, tgt, end_rotation=end)
            rot[f] = r
        lifted[leg.side] = f.tolist()
    if rot is None:
        return motion, lifted
    return motion.replace_trusted(motion.root_positions, rot), lifted      # IK of unit quaternions


def ballistic_completion(body, motion, flights, g: float = G_STANDARD):
    """``(motion, largest shift m)``: the root of every flight frame translated by what the COM
    still lacks to be on the g parabola through the block's end points (sec. 3.4.2 with S1 empty,
    eq. 10's root translation, without the smoothing). The schedule's last flight step (all links
    in S2, rho = 1) asks for exactly this, but its map is smoothed 5 frames wide (sec. 4.1), which
    rounds the correction off at take-off and landing: the CMU 01_01 hop on an arc kept its COM
    1.8-2.0 mm off the parabola (the issue asks 1 mm). The end frames' correction is zero (the
    parabola goes through them), the ground frames are left alone, so the feet held by the steps
    stay where they are; the COM's velocity changes at take-off and landing by the residual's slope
    there (a few cm/s)."""
    if not flights:
        return motion, 0.0
    fk(motion)
    com = center_of_mass(body, motion)
    root = np.array(motion.root_positions, dtype=float)
    shift = 0.0
    for a, b in flights:
        if b - a < 3:
            continue
        d = ballistic_targets(com, a, b, motion.fps, g) - com[a:b]
        root[a:b] += d
        shift = max(shift, float(np.linalg.norm(d, axis=1).max()))
    return motion.replace_trusted(root, motion.rotations), shift


def _flight_records(body, motion, flights, g: float) -> list:
    if not flights:
        return []
    fk(motion)
    mom = momentum(body, motion)                   # its COM too (the same sum as center_of_mass, to rounding)
    com = mom.com
    L = np.linalg.norm(mom.angular, axis=1)
    return [{"frames": [a, b], "com_residual_m": com_residual(com, a, b, motion.fps, g),
             "L_variation": _variation(L[a + 1:b - 1] if b - a >= 5 else L[a:b])}
            for a, b in flights]


def touchup(motion, body=None, schedule=None, *, contacts=None, iterations: int | None = None,
            smooth_sigma: float | None = DEFAULT_SMOOTH_SIGMA, neighbourhood_s: float = NEIGHBOURHOOD_S,
            g: float = G_STANDARD, footplants: bool = True, polygon: str = "contact",
            max_angle_deg: float = float(np.degrees(MAX_ANGLE))) -> TouchupResult:
    """Touch up ``motion`` (module docstring).

    ``schedule``: a sequence of :class:`~mocomp.touchup.schedule.Step`, a preset name or a TOML
    path (default: ``ground-default`` then ``flight-default``); ``contacts``: plant overrides
    (:func:`mocomp.touchup.stages.stages`); ``iterations``: replaces every step's count;
    ``polygon``: the support polygon of the touching foot points (``"contact"``, the paper's
    contact region) or of the planted ones (``"planted"``, :meth:`Stages.polygon_mask`);
    ``max_angle_deg``: the cap of a ground adjustment's per-frame turn
    (:data:`mocomp.touchup.ground.MAX_ANGLE`; ``inf``: the paper's angles)."""
    from dataclasses import replace

    from ..audit import default_body
    from ..ops import DisplacementMap, apply_displacement
    from ..ops.displacement import NEGLIGIBLE_RAD, _compiled

    t0 = time.perf_counter()
    if not (np.isfinite(neighbourhood_s) and neighbourhood_s >= 0):
        raise ValueError(f"neighbourhood must be 0 or more seconds, got {neighbourhood_s!r}")
    body = default_body(motion) if body is None else body
    steps = tuple(schedule) if isinstance(schedule, (list, tuple)) else schedule_from_spec(schedule, motion.fps,
                                                                                             iterations)
    if iterations is not None and isinstance(schedule, (list, tuple)):
        steps = tuple(replace(s, iterations=int(iterations)) for s in steps)
    fk(motion)                                     # compiled, cached: the callees find it
    st = stages(motion, contacts)
    mask = st.polygon_mask(polygon)
    ground_y = floor_levels(st.plants.levels, float(np.nanmin(st.plants.levels)))
    sets = [link_sets(body, s.s1, s.s2, s.s3, where=s.where) for s in steps]
    foot_joints = {leg.ankle_point[0] for leg in st.plants.legs} | {leg.toe_point[0] for leg in st.plants.legs}
    feet = sorted(foot_joints)
    nb = int(round(neighbourhood_s * motion.fps))
    flights = st.flight_runs
    T = motion.n_frames

    ground_w = ground_weights(T, flights, nb, int(round(MIN_RAMP_S * motion.fps)), int(round(MIN_FLIGHT_S * motion.fps)))
    airborne = np.zeros(T, bool)                   # the flights a lean may not bring down (lift_feet)
    for a, b in flights:
        airborne[a:b] = b - a >= int(round(MIN_FLIGHT_S * motion.fps))
    in_air = np.zeros(T)
    for a, b in flights:                           # with the frame either side (a detector one frame off)
        in_air[max(a - 1, 0):b + 1] = 1.0

    cache: dict = {}
    chains = SegmentChains(body, motion.skeleton)
    rest = resting_levels(st.plants, st.contact_points)

    def zstate(cur):
        """The ZMP state of ``cur``, computed once per motion (the record of an iteration is the
        state the next iteration adjusts from)."""
        if cache.get("motion") is not cur:
            P, G = fk(cur)
            cache["motion"], cache["z"] = cur, zmp_state(body, cur, foot_points(P, G, st.plants), mask, ground_y,
                                                         smooth_sigma=smooth_sigma, g=g, chains=chains)
        return cache["z"]

    def measure(cur, with_flights: bool = True) -> dict:
        z = zstate(cur)
        out = z.summary(st.ground)
        out["_distance"] = np.where(st.ground, z.distance, np.nan)
        out["flights"] = _flight_records(body, cur, flights, g) if with_flights else None
        return out

    clamped: dict[int, list[int]] = {}
    capped: dict[int, list[int]] = {}
    lifted: dict[str, set] = {}
    history = []
    before = measure(motion)
    dist_before = before.pop("_distance")
    dist_after = dist_before
    state: dict = {}

    def adjust(cur, hstep):
        k = int(hstep.label)
        step, ls = steps[k], sets[k]
        state["prev"], state["k"] = cur, k
        if step.stage == "ground":
            z = zstate(cur)
            feet_in_s1 = any(ls.s1[j] for j in foot_joints)
            # frames near a flight are the flight steps' (Fig. 4): their take-off pushes and landing
            # impacts do not enter the ground maps
            adj = ground_adjustment(body, cur, ls, z, st.ground & z.outside() & (ground_w > GROUND_FRAMES_MIN_WEIGHT),
                                    feet_in_s1=feet_in_s1, g=g, max_angle=np.radians(max_angle_deg))
            clamped.setdefault(k, []).extend(np.flatnonzero(adj.clamped).tolist())
            capped.setdefault(k, []).extend(np.flatnonzero(adj.capped).tolist())
        else:
            fk(cur)
            mom = flight_momentum_adjustment(body, cur, ls, flights, neighbourhood=nb)
            cur = cur.replace_trusted(mom.root_positions, mom.rotations)
            fk(cur)
            # the root translation (S1 empty) stays inside the flights: continued into the
            # neighbourhood it moved the body against its planted feet through the push and the
            # landing (hop on an arc: planned mean ZMP outside 7.0 -> 8.6 cm in that step, and the
            # ballistic completion makes the flights exact anyway); a turn of S2 about the S1/S2
            # joint is continued (flight.flight_com_adjustment)
            adj = flight_com_adjustment(body, cur, ls, flights, center_of_mass(body, cur),
                                        neighbourhood=nb if ls.s1.any() else 0, g=g)
        # local rotations of rigid turns of unit quaternions: unit to rounding
        return cur.replace_trusted(adj.root_positions, adj.rotations)

    # the plants are the input's for every hold: their label work (gaps, runs, stacked labels) once
    fplan = footplant_plan(st.plants, default_blend_frames(motion.fps)) if footplants else None

    def hold(mm):
        fk(mm)
        return DisplacementMap.between(mm, enforce_footplants(mm, audit=False, passes=1, plan=fplan).motion)

    def post(cur):
        prev = state["prev"]
        moved = np.linalg.norm(fk(cur)[0][:, feet] - fk(prev)[0][:, feet], axis=-1).max(initial=0.0)
        if footplants and moved > 1e-6:
            # hold the feet against what this step moved, not against the plants' ideal: the IK
            # correction of the input (its own slides; computed once) is taken off, so touch-up
            # keeps the input's feet and an unedited clip is not cleaned up behind the user's back.
            # Steps that leave the legs alone (S1 holding the lower body) move no foot: no IK.
            if "d_ref" not in cache:
                cache["d_ref"] = hold(motion)
            d_ref = cache["d_ref"]
            # the plants' fade-out must not reach into a flight (its COM is on the parabola): the map
            # weighted directly (the map from ``cur`` to ``cur`` held is this map again, to rounding,
            # for turns below pi; the leg corrections are a few degrees)
            if _fast.COMPILED and _compiled():
                # the same steps in one compiled call (the hold leaves the root where it is: no root map)
                fk(cur)
                held = enforce_footplants(cur, audit=False, passes=1, plan=fplan).motion
                cur = cur.replace_trusted(cur.root_positions - d_ref.root * (1.0 - in_air[:, None] if flights else 1.0),
                                          _fast.apply_hold(cur.rotations, held.rotations, d_ref.rotations,
                                                           1.0 - in_air if flights else None, NEGLIGIBLE_RAD))
            else:
                d_cur = hold(cur)
                # differences of two finite maps, new arrays: wrapped without the constructor's copies and checks
                hold_map = DisplacementMap._trusted(d_cur.root - d_ref.root, d_cur.rotations - d_ref.rotations)
                cur = apply_displacement(cur, hold_map.weighted(1.0 - in_air) if flights else hold_map)
            cur, up = lift_feet(cur, st.plants, st.contact_points, st.touching, rest=rest, airborne=airborne)
            for side, fr in up.items():
                lifted.setdefault(side, set()).update(fr)
        k = state["k"]
        # the flights' COM and momentum records after flight steps (and the last iteration) only:
        # a ground step leaves the flights alone (its maps are weighted 0 there)
        last = len(history) + 1 == n_iterations
        rec = measure(cur, with_flights=steps[k].stage == "flight" or last)
        rec.update(step=k, iteration=sum(1 for h in history if h["step"] == k), label=steps[k].label())
        history.append(rec)
        return cur

    run = [k for k, s in enumerate(steps) if s.stage == "ground" or flights]
    n_iterations = sum(steps[k].iterations for k in run)
    hsteps = [HierarchyStep(steps[k].kernel_parameter(motion.fps), steps[k].rho, steps[k].kernel,
                            steps[k].iterations, str(k)) for k in run]
    # the ground maps act on every frame, the flights too: they are smooth (kernels 1/3 s and wider)
    # and the flight steps after them make the flights ballistic again. Faded to 0 toward a flight
    # (by ``ground_w``), the lean went over 0.27 s from its full size to nothing at a hop's
    # take-off and back at its landing; the angular accelerations that makes are not in eq. 6-7
    # (accelerations held fixed) and put the push and landing frames' ZMP 2x farther out (CMU 01_01
    # hop on an arc, ground steps alone: planned mean outside 11.95 -> 9.11 cm faded, 5.54 cm not).
    # ``ground_w`` still keeps the per-frame adjustments off the frames next to a flight.
    weights = [None for k in run]
    cur = motion
    if hsteps:
        res = apply_hierarchy(motion, adjust, hsteps, post, weights=weights)
        cur = res.motion
        for rec, (root_m, ang) in zip(history, res.magnitudes):
            rec.update(map_root_m=root_m, map_angle_rad=ang)
        if flights and any(steps[k].stage == "flight" for k in run):
            cur, shift = ballistic_completion(body, cur, flights, g)
            rec = measure(cur)
            rec.update(step=len(steps), iteration=0, label="flight: COM onto the parabola (root, unsmoothed)",
                       map_root_m=shift, map_angle_rad=0.0)
            history.append(rec)
    for rec in history:
        dist_after = rec.pop("_distance")
    after = history[-1] if history else before
    return TouchupResult(cur, motion, st, steps, tuple(history),
                         {steps[k].label(): sorted(set(v)) for k, v in clamped.items()},
                         before, {k: v for k, v in after.items() if k not in ("step", "iteration", "label")},
                         time.perf_counter() - t0, dist_before, dist_after,
                         {steps[k].label(): sorted(set(v)) for k, v in capped.items()},
                         {k: sorted(v) for k, v in lifted.items()})
