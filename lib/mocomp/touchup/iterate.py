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

from ..dynamics.com import center_of_mass
from ..dynamics.momentum import momentum
from ..dynamics.constants import G_STANDARD
from ..ops import HierarchyStep, apply_hierarchy, enforce_footplants
from ..ops.footplant import foot_points
from .flight import com_residual, flight_com_adjustment, flight_momentum_adjustment
from .ground import ground_adjustment
from .linksets import link_sets
from .schedule import schedule_from_spec
from .stages import Stages, stages
from .zmp import DEFAULT_SMOOTH_SIGMA, floor_levels, zmp_state

__all__ = ["TouchupResult", "touchup", "NEIGHBOURHOOD_S"]

#: s: ground frames this close to a flight are adjusted with it (the paper's 15 frames, 1/2 s)
NEIGHBOURHOOD_S = 0.5


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

    def to_dict(self) -> dict:
        return {"stages": self.stages.to_dict(), "schedule": [s.to_dict() for s in self.schedule],
                "planned": {"before": self.before, "after": self.after, "iterations": list(self.history),
                            "clamped_frames": {k: v for k, v in self.clamped.items()}},
                "seconds": self.seconds}


def _variation(L: np.ndarray) -> float:
    """(max - min) / mean of ``|L|`` over a flight's inner frames (the end frames' central
    differences reach into the ground frames; the audit drops them too)."""
    return float((L.max() - L.min()) / max(L.mean(), 1e-9))


def _measure(body, motion, st: Stages, ground_y: float, smooth_sigma, g: float) -> dict:
    P, G = motion.fk()
    pts = foot_points(P, G, st.plants)
    z = zmp_state(body, motion, pts, st.contact_mask, ground_y, smooth_sigma=smooth_sigma, g=g)
    out = z.summary(st.ground)
    out["_distance"] = np.where(st.ground, z.distance, np.nan)
    com = center_of_mass(body, motion)
    L = np.linalg.norm(momentum(body, motion).angular, axis=1)
    out["flights"] = [{"frames": [a, b], "com_residual_m": com_residual(com, a, b, motion.fps, g),
                       "L_variation": _variation(L[a + 1:b - 1] if b - a >= 5 else L[a:b])}
                      for a, b in st.flight_runs]
    return out


def touchup(motion, body=None, schedule=None, *, contacts=None, iterations: int | None = None,
            smooth_sigma: float | None = DEFAULT_SMOOTH_SIGMA, neighbourhood_s: float = NEIGHBOURHOOD_S,
            g: float = G_STANDARD, footplants: bool = True) -> TouchupResult:
    """Touch up ``motion`` (module docstring).

    ``schedule``: a sequence of :class:`~mocomp.touchup.schedule.Step`, a preset name or a TOML
    path (default: ``ground-default`` then ``flight-default``); ``contacts``: plant overrides
    (:func:`mocomp.touchup.stages.stages`); ``iterations``: replaces every step's count."""
    from ..audit import default_body

    t0 = time.perf_counter()
    if not (np.isfinite(neighbourhood_s) and neighbourhood_s >= 0):
        raise ValueError(f"neighbourhood must be 0 or more seconds, got {neighbourhood_s!r}")
    body = default_body(motion) if body is None else body
    steps = tuple(schedule) if isinstance(schedule, (list, tuple)) else schedule_from_spec(schedule, motion.fps,
                                                                                             iterations)
    if iterations is not None and isinstance(schedule, (list, tuple)):
        from dataclasses import replace

        steps = tuple(replace(s, iterations=int(iterations)) for s in steps)
    st = stages(motion, contacts)
    ground_y = floor_levels(st.plants.levels, float(np.nanmin(st.plants.levels)))
    sets = [link_sets(body, s.s1, s.s2, s.s3, where=s.where) for s in steps]
    foot_joints = {leg.ankle_point[0] for leg in st.plants.legs} | {leg.toe_point[0] for leg in st.plants.legs}
    nb = int(round(neighbourhood_s * motion.fps))
    flights = st.flight_runs
    ground_mask = st.ground
    clamped: dict[int, list[int]] = {}
    history = []
    before = _measure(body, motion, st, ground_y, smooth_sigma, g)
    dist_before = before.pop("_distance")
    dist_after = dist_before

    # ground maps leave the flights, and the ground frames within the neighbourhood of a flight
    # (adjusted with it, Fig. 4), alone: 0 there, easing to 1 over the neighbourhood
    from ..ops import DisplacementMap, apply_displacement, ease

    ground_w = np.ones(motion.n_frames)
    for a, b in flights:
        ground_w[a:b] = 0.0
        for i in range(1, nb + 1):                 # the frame next to a flight stays 0 too
            v = float(ease(np.array([(i - 1) / nb]))[0])
            for f in (a - i, b - 1 + i):
                if 0 <= f < motion.n_frames:
                    ground_w[f] = min(ground_w[f], v)
    state = {}

    def adjust(cur, hstep):
        k = int(hstep.label)
        step, ls = steps[k], sets[k]
        state["prev"], state["stage"] = cur, step.stage
        if step.stage == "ground":
            P, G = cur.fk()
            z = zmp_state(body, cur, foot_points(P, G, st.plants), st.contact_mask, ground_y,
                          smooth_sigma=smooth_sigma, g=g)
            feet_in_s1 = any(ls.s1[j] for j in foot_joints)
            # frames near a flight are the flight steps' (Fig. 4): their take-off pushes and landing
            # impacts do not enter the ground maps
            adj = ground_adjustment(body, cur, ls, z, ground_mask & z.outside() & (ground_w >= 1.0),
                                    feet_in_s1=feet_in_s1, g=g)
            clamped.setdefault(k, []).extend(np.flatnonzero(adj.clamped).tolist())
        else:
            if not flights:
                return cur
            mom = flight_momentum_adjustment(body, cur, ls, flights, neighbourhood=nb)
            cur = cur.replace(root_positions=mom.root_positions, rotations=mom.rotations)
            adj = flight_com_adjustment(body, cur, ls, flights, center_of_mass(body, cur), neighbourhood=nb, g=g)
        return cur.replace(root_positions=adj.root_positions, rotations=adj.rotations)

    in_air = np.zeros(motion.n_frames)
    for a, b in flights:                           # with the frame either side (a detector one frame off)
        in_air[max(a - 1, 0):b + 1] = 1.0

    def weighted(base, moved, w):
        d = DisplacementMap.between(base, moved)
        return apply_displacement(base, DisplacementMap(d.root * w[:, None], d.rotations * w[:, None, None]))

    def post(cur):
        if state["stage"] == "ground" and flights:
            cur = weighted(state["prev"], cur, ground_w)
        moved = DisplacementMap.between(state["prev"], cur).magnitude()
        if not footplants or max(moved) < 1e-9:      # a step that changed nothing needs no plants held
            return cur
        # hold the feet against what this step moved, not against the plants' ideal: the IK
        # correction of the previous motion (the input's own slides) is taken off, so touch-up
        # keeps the input's feet and an unedited clip is not cleaned up behind the user's back
        hold = lambda mm: DisplacementMap.between(mm, enforce_footplants(mm, st.plants, audit=False,  # noqa: E731
                                                                          passes=1).motion)
        d_cur, d_prev = hold(cur), hold(state["prev"])
        held = apply_displacement(cur, DisplacementMap(d_cur.root - d_prev.root, d_cur.rotations - d_prev.rotations))
        # the plants' fade-out must not reach into a flight (its COM is on the parabola)
        return weighted(cur, held, 1.0 - in_air) if flights else held

    hsteps = [HierarchyStep(s.sigma_frames(motion.fps), s.rho, s.kernel, s.iterations, str(k))
              for k, s in enumerate(steps)]
    cur = motion
    for k, hs in enumerate(hsteps):
        if steps[k].stage == "flight" and not flights:
            continue
        for it in range(hs.iterations):
            res = apply_hierarchy(cur, adjust, [HierarchyStep(hs.sigma, hs.rho, hs.kernel, 1, hs.label)], post)
            cur = res.motion
            rec = _measure(body, cur, st, ground_y, smooth_sigma, g)
            dist_after = rec.pop("_distance")
            rec.update(step=k, iteration=it, label=steps[k].label(), map_root_m=res.magnitudes[0][0],
                       map_angle_rad=res.magnitudes[0][1])
            history.append(rec)
    after = history[-1] if history else before
    return TouchupResult(cur, motion, st, steps, tuple(history),
                         {steps[k].label(): sorted(set(v)) for k, v in clamped.items()},
                         before, {k: v for k, v in after.items() if k not in ("step", "iteration", "label")},
                         time.perf_counter() - t0, dist_before, dist_after)
