"""The whole impact response (dissertation ch. 4): contact, naive simulation, search, active
simulation, final blend, the attacker's response -- with evidence and per-stage timings.

:func:`impact_response` runs, on the victim clip's frame rate and timeline (the attack clip sampled
on it):

0. a long attack clip (over ``max_attack``, 5 s) cut to the window of its fastest strike
   (:func:`~mocomp.impact.scene.strike_window`);
1. **placement** (:func:`~mocomp.impact.scene.place_victim`; backed off 10 cm at a time while the
   characters touch at the first frame) and the scene
   (:func:`~mocomp.impact.scene.build_scene`; victim joint limits from the victim clip and the
   library's clips);
2. **first contact** at the capture rate and the **rewind** to the last frame before it
   (:func:`~mocomp.impact.simulate.find_first_contact`);
3. the **naive simulation** (friction 1.0) from the rewind frame to 1.0 s after the impact; the strike
   ends after 0.25 s of contact or 60 N s (``max_contact``, ``max_impulse``; both passes);
4. the **search** (:func:`mocomp.impact.search.search`) of the naive frames from 0.1 s after the
   impact (pushed later while the contact lasts, up to 0.25 s; App. A) to 1.0 s;
5. the **active simulation** (friction 0.5) toward the found clip, aligned by the search's root
   transform (its window's first frame on the query's ``start``), the blend of the targets eased
   in after a reaction delay (0.1-0.2 s, drawn from ``seed`` unless given);
6. the **final blend** of the active segment onto the found clip at the re-entry frame (the last
   frame of the search window), the found clip playing on after it; the same blend from the naive
   segment is measured for comparison (the correction the active simulation saves);
7. repairs of the output (tried again with eased blend weights, then with the plants freed around the
   re-entry, while the re-entry steps past the found clip's own largest step): the root lifted where a joint would be below the floor
   (:func:`~mocomp.impact.blend.floor_lift`; the ASE falls sink while lying), the planted feet held
   (:func:`mocomp.ops.enforce_footplants`), and a second lift for what the plants' levels sank
   (vertical only, so the plants stay put in the ground plane);
8. the **attacker**: its clip, the simulated contact for a few frames, a blend back
   (:mod:`~mocomp.impact.attacker`), its root pushed out of the victim's body where the blend back
   would step through it (:func:`~mocomp.impact.attacker.separate`).

The physics of the output is judged by :mod:`mocomp.audit` on the written frames (the CLI); the
result carries the planned numbers (labelled so) and the continuity measured on its own frames.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.motion import Motion, concatenate
from .scene import FRICTION_ACTIVE, FRICTION_NAIVE, ImpactError, Scenario, TouchAtStartError

__all__ = ["ImpactConfig", "ImpactResult", "impact_response", "load_library"]


@dataclass(frozen=True)
class ImpactConfig:
    """Parameters of the response (App. A values by default).

    window: s after the impact, the search window (0.1, 1.0); max_push: s, the latest the window's
    start is pushed while the contact lasts (0.25). delay: s, the reaction delay before the active
    control starts (None: drawn uniformly from ``delay_range`` with ``seed``). friction_naive,
    friction_active: the floor's (1.0, 0.5). gains: :class:`~mocomp.impact.simulate.ServoGains`.
    plant: hold the planted feet of the output; lift: lift the output above the floor.
    lift_ballistic: the lift adds no vertical acceleration on frames where the body is unsupported
    (:func:`~mocomp.impact.blend.floor_lift` ``ballistic``; False: the lift eases in regardless).
    com_ballistic: the output's root translated on the free-fall frames between the strike's end and
    the re-entry so that the COM falls freely there (:func:`~mocomp.impact.blend.ballistic_com`).
    attacker_follow, attacker_blend: s (:func:`~mocomp.impact.attacker.attacker_response`).
    compare_naive: also measure the final-blend correction from the naive simulation.
    exhaustive_search: the exhaustive search instead of the unique-frame one (the reference).
    runner_up: the search's runner-up, ``"fast"`` (default) or ``"exact"``
    (:func:`~mocomp.impact.search.search`; benchmark, 23 queries: ``"exact"`` gives the exhaustive
    runner-up in 23/23 at 2.4x less CPU than the exhaustive search, ``"fast"`` in 16/23 at 11.6x less).
    realign: align the found clip onto the active simulation for the final blend, by the search's
    rule (root heading and ground point at the window's first frame); the search aligned it onto the
    naive simulation. False keeps the search's alignment.
    reentry: ``"match_start"`` (default): the match time is searched as well -- one query window of
    ``match_window`` s per candidate start (every ``start_step`` frames) from ``window[0]`` (pushed
    while the contact lasts, and at least ``delay + min_active`` s after the impact so the active
    control has time to act) to ``window[1]``; the transition ends at the best window's first frame,
    where eq. A.1 weighs the match most. ``"window_end"``: one query window over the whole search
    window, the transition ending at its last frame (weighted 0 by eq. A.1).
    max_contact, max_impulse: s, N s: the strike ends (the attacker's striking bodies stop touching the
    victim) once its contact has lasted 0.25 s (App. A's longest push of the search window) or its
    impulse reached 60 N s (a strong kick: the ASE kick on the standing victim gives 52 N s), in
    both passes; None: no limit (a clip ending inside the victim then pushes for a second, 840 N s).
    max_attack, strike_lead: s: an attack clip longer than ``max_attack`` (a 13 s take) is cut to
    its strike window (:func:`~mocomp.impact.scene.strike_window`: ``strike_lead`` s before its fastest
    strike, the rest of ``max_attack`` after it) before the placement; the outputs are on that
    window's timeline (``evidence["attack_window"]`` gives its frames in the clip). None: never cut.
    min_overlap: m: with the default placement (no ``Scenario.offset``), when the characters touch at
    the first frame the victim is placed 10 cm farther (the scenario's overlap less 0.1 m) until they
    do not, down to this overlap (``evidence["placement"]``).
    strike_early: s: a long take cut to its strike (``max_attack``) is placed for that strike
    (:func:`~mocomp.impact.scene.strike_at`: its fastest joint's reach at the fastest frame); while the
    first contact comes more than ``strike_early`` s before that frame (the wind-up touching the victim),
    the victim is placed 10 cm farther, down to ``min_overlap``; if the strike then misses, the last
    placement that touched is kept (``evidence["placement"]["contact_before_strike"]``).
    separate: keep the attacker's body out of the victim's after the strike
    (:func:`~mocomp.impact.attacker.separate`). separate_max_speed, separate_max_shift: m/s, m: the
    bounds of that push (1.5 m/s, about a step back; 0.8 m), None: unbounded (a running victim falling
    through the attacker's place pushed it 1.6 m at 3.7 m/s, its feet gliding); what the bounds leave is
    reported (``evidence["attacker"]["separation"]["residual_overlap_m"]``).
    blend_weights: the final blend's weights (:func:`~mocomp.impact.blend.final_blend`): ``"linear"``
    (the paper's), ``"smoothstep"``, ``"smootherstep"``, or ``"auto"`` (default: linear unless the
    repaired output's step into or out of the re-entry frame exceeds the found clip's own largest
    frame-to-frame step, then smoothstep, then smootherstep, the first that is continuous or else the
    smallest step; when the step comes from the plants alone, the leg joints are freed of the plants
    within a fade of the re-entry and rate-limited there). ``evidence["repairs_tried"]`` lists the tries.
    reentry_radius: frames (output rate) either side of the searched clip frame at the re-entry among which
    the final blend's target frame is re-chosen against the *active* simulation's state there (eq. 4.1's
    frame term, height kept: :func:`~mocomp.impact.search.reentry_frame_costs`); the clip's timeline after
    the re-entry shifts with it. The search matched the naive pass, whose pelvis height the active pass
    (friction 0.5, servos toward the clip, the root unactuated) does not keep. ``reentry_by``: ``"eq4.1"``
    (the frame term) or ``"root_height"`` (the clip frame whose pelvis height is nearest the simulation's).
    56-run sweep (3 victims x 5 attacks x 4 facings), root error at re-entry mean (median) and runs better
    than blending from the naive pass: radius 0 (the paper) 0.069 (0.039) m, 31/56; 3 by eq4.1 0.037
    (0.026) m, 37/56; 3 by root_height 0.022 (0.012) m, 43/56; joint error at re-entry 8.4 / 9.9 / 10.1 deg
    (naive 23.2; better than naive 54 / 50 / 52 of 56); root_height r=3 and the paper alike, written BVH audited:
    re-entry continuous 55/56, no foot slide after the re-entry, no penetration over 1 cm. 0 (default) blends onto the searched frame exactly
    (the paper's final blend); the choice is ``evidence["reentry_refine"]``. Beyond the paper.
    """

    window: tuple[float, float] = (0.1, 1.0)
    max_push: float = 0.25
    delay: float | None = None
    delay_range: tuple[float, float] = (0.1, 0.2)
    seed: int = 0
    friction_naive: float = FRICTION_NAIVE
    friction_active: float = FRICTION_ACTIVE
    gains: object = None
    plant: bool = True
    lift: bool = True
    lift_ballistic: bool = True
    com_ballistic: bool = True
    attacker_follow: float = 0.1
    attacker_blend: float = 0.3
    compare_naive: bool = True
    exhaustive_search: bool = False
    runner_up: str = "fast"
    realign: bool = True
    reentry: str = "match_start"
    match_window: float = 0.4
    min_active: float = 0.2
    start_step: int = 1
    blend_weights: str = "auto"
    max_attack: float | None = 5.0
    min_overlap: float = -0.35
    strike_early: float = 0.25
    strike_lead: float = 1.5
    separate: bool = True
    separate_max_speed: float | None = 1.5
    separate_max_shift: float | None = 0.8
    max_contact: float | None = 0.25
    max_impulse: float | None = 60.0
    reentry_radius: int = 0
    reentry_by: str = "eq4.1"

    def __post_init__(self):
        a, b = self.window
        if not (0 <= a < b):
            raise ValueError(f"window must satisfy 0 <= start < stop seconds, got {self.window}")
        lo, hi = self.delay_range
        if not (0 <= lo <= hi):
            raise ValueError(f"delay_range must satisfy 0 <= low <= high, got {self.delay_range}")
        if self.max_attack is not None and not (self.max_attack > self.strike_lead > 0):
            raise ValueError(f"need max_attack > strike_lead > 0 s, got {self.max_attack!r}, {self.strike_lead!r}")
        if self.blend_weights not in ("auto", "linear", "smoothstep", "smootherstep"):
            raise ValueError(f"blend_weights must be 'auto', 'linear', 'smoothstep' or 'smootherstep', "
                             f"got {self.blend_weights!r}")
        if self.runner_up not in ("fast", "exact"):
            raise ValueError(f"runner_up must be 'fast' or 'exact', got {self.runner_up!r}")
        if not (isinstance(self.reentry_radius, (int, np.integer)) and self.reentry_radius >= 0):
            raise ValueError(f"reentry_radius must be an integer >= 0 (frames), got {self.reentry_radius!r}")
        if self.reentry_by not in ("eq4.1", "root_height"):
            raise ValueError(f"reentry_by must be 'eq4.1' or 'root_height', got {self.reentry_by!r}")
        if self.reentry not in ("match_start", "window_end"):
            raise ValueError(f"reentry must be 'match_start' or 'window_end', got {self.reentry!r}")
        if not (0 < self.match_window < b):
            raise ValueError(f"match_window must lie in (0, {b}) s, got {self.match_window}")
        for name in ("max_contact", "max_impulse"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number or None, got {v!r}")
        if self.delay is not None and not (0 <= self.delay < b):
            raise ValueError(f"delay must lie in [0, {b}) s, got {self.delay}")


@dataclass(frozen=True)
class ImpactResult:
    """The response and its evidence.

    victim, attacker: the output motions (victim clip timeline; the victim continues with the
    found clip after re-entry). first_contact: :class:`~mocomp.impact.simulate.FirstContact`.
    naive, active: :class:`~mocomp.impact.simulate.PassResult`. search: the search's result.
    found: the found clip aligned on the victim timeline over the simulated frames.
    blend_active, blend_naive: :class:`~mocomp.impact.blend.BlendOutcome` (the latter only measured).
    frames: key frame numbers of the victim output (rewind, impact, window start/stop, re-entry).
    delay: s. timings: wall s per stage; cpu: CPU s per stage (this process). evidence: continuity,
    repairs, attacker numbers.
    """

    victim: Motion
    attacker: Motion
    scenario: Scenario
    first_contact: object
    naive: object
    active: object
    search: object
    found: Motion
    blend_active: object
    blend_naive: object
    frames: dict
    delay: float
    timings: dict
    evidence: dict
    notes: tuple[str, ...] = field(default=())
    cpu: dict = field(default_factory=dict)

    RESPONSE_STAGES = ("naive_simulation", "search", "targets", "active_simulation", "final_blend")

    @property
    def response_seconds(self) -> float:
        """Wall time of the response proper (naive sim, search, active sim with its targets, blend)."""
        return float(sum(self.timings[k] for k in self.RESPONSE_STAGES))

    @property
    def response_cpu_seconds(self) -> float:
        """CPU time (this process) of the same stages: the machine's load does not inflate it."""
        return float(sum(self.cpu[k] for k in self.RESPONSE_STAGES))

    def to_dict(self) -> dict:
        fc = self.first_contact
        bn = None if self.blend_naive is None else self.blend_naive.to_dict()
        return {
            "scenario": {"facing_deg": self.scenario.facing_deg, "offset_m": self.scenario.offset,
                         "contact_body": self.scenario.contact_body},
            "impact_time_s": self.naive.impact_time, "first_contact_frame": fc.frame, "rewind_frame": fc.rewind_frame,
            "contact_bodies": sorted({p for pair in self.naive.pairs for p in pair}),
            "contact_pairs": [list(p) for p in self.naive.pairs],
            "contact_end_s": self.naive.contact_end,
            "impulse_Ns": self.naive.impulse.tolist(), "impulse_norm_Ns": float(np.linalg.norm(self.naive.impulse)),
            "strike_end": self.naive.strike_end,
            "search": self.search.to_dict(),
            "pruning": {**{k: self.search.stats.get(k) for k in ("windows_compared", "windows_exhaustive",
                                                                  "unique_windows")},
                        **{k: self.evidence["search"][k] for k in ("query_windows", "frames_compared",
                                                                   "frames_exhaustive", "pruning_factor")}},
            "frames": self.frames, "reaction_delay_s": self.delay,
            "naive_simulation": self.naive.to_dict(), "active_simulation": self.active.to_dict(),
            "active_tracking_error_deg": {"mean": float(np.degrees(self.active.tracking_error_rad.mean())),
                                          "max": float(np.degrees(self.active.tracking_error_rad.max()))},
            "final_blend_correction": {"from_active (planned)": self.blend_active.to_dict(),
                                       "from_naive (planned, for comparison)": bn},
            "mujoco_warnings": {"naive": self.naive.warnings, "active": self.active.warnings},
            "timings_s": self.timings, "cpu_s": self.cpu, "response_s": self.response_seconds,
            "response_cpu_s": self.response_cpu_seconds,
            "evidence": self.evidence, "notes": list(self.notes),
        }


def load_library(library_dir, skeleton, *, cache_dir=None, progress: bool = False):
    """The library index for the victim's skeleton (:func:`mocomp.impact.index.build_index`), with a
    clear error when no clip can serve that skeleton."""
    from .index import LibraryError, build_index

    try:
        index = build_index(library_dir, skeleton, cache_dir=cache_dir, progress=progress)
    except LibraryError as e:
        raise ImpactError(f"library {library_dir}: no clip usable for the victim's skeleton "
                          f"({skeleton.n_joints} joints: {', '.join(skeleton.names[:6])}, ...): {e}") from e
    if not index.clips:
        raise ImpactError(f"library {library_dir}: no clip usable for the victim's skeleton")
    return index


def _on_timeline(attacker: Motion, fps: float, n: int) -> Motion:
    """The attack clip sampled at ``fps`` for ``n`` frames (its last pose held after its end)."""
    t = np.arange(n) / fps
    return attacker.sample(np.clip(t, 0.0, attacker.duration), fps=fps)


def _reach_limit_motions(index, limit: int = 64):
    """Library clips (on the victim's skeleton) whose captured range widens the victim's joint limits."""
    out = []
    for c in index.clips[:limit]:
        try:
            out.append(index.motion(c.path))
        except Exception:                            # a clip that changed is skipped here, refused later
            continue
    return out


def impact_response(attacker: Motion, victim: Motion, index, scenario: Scenario = Scenario(),
                    config: ImpactConfig = ImpactConfig(), *, library_motions=None) -> ImpactResult:
    """The whole response (module docstring). ``index``: the library index for the victim's skeleton
    (:func:`load_library`); ``library_motions``: its clips as motions (for the joint limits; read
    from the index when None)."""
    from .attacker import attacker_response
    from .blend import (ballistic_com, final_blend, floor_lift, frame_steps, keep_before, limit_plant_steps, plant_feet,
                        props_above_floor, wrist_props)
    from .scene import build_scene, place_victim
    from .search import search
    from .simulate import ServoGains, blend_targets, clip_targets, find_first_contact, naive_targets, simulate

    timings, cpu = {}, {}
    t, c = time.perf_counter(), time.process_time()
    if index.skeleton != victim.skeleton:
        raise ImpactError("the library index was built for another skeleton than the victim's")
    gains = config.gains if config.gains is not None else ServoGains()
    fps = victim.fps
    attack_window = None
    if config.max_attack is not None and attacker.duration > config.max_attack:
        # a long take (walking about, several strikes): the window around its fastest strike is the attack
        from .scene import strike_window

        a_, b_, peak_ = strike_window(attacker, scenario.contact_body, lead=config.strike_lead,
                                      tail=config.max_attack - config.strike_lead)
        attack_window = {"start": a_, "stop": b_, "strike_frame": peak_, "clip_frames": attacker.n_frames}
        attacker = attacker.slice(a_, b_)
    # a long take cut to its strike is placed for that strike (its fastest joint's reach there): the farthest
    # reach of the window came from the wind-up, and the victim was touched 1.3 s before the slash
    k_place = None if attack_window is None else attack_window["strike_frame"] - attack_window["start"]
    placed = place_victim(attacker, victim, scenario, strike_frame=k_place)
    need = int(np.ceil((config.window[1] + 0.5) * fps))
    # the attack on the victim's frames, long enough to be looked up during the burst
    att = _on_timeline(attacker, fps, max(victim.n_frames, int(np.floor(attacker.duration * fps + 1e-9)) + 1))
    lib = _reach_limit_motions(index) if library_motions is None else list(library_motions)
    from .scene import default_impact_body

    scene = build_scene(attacker.skeleton, victim.skeleton, attacker_body=default_impact_body(attacker),
                        victim_body=default_impact_body(victim), attacker_motions=[attacker],
                        victim_motions=[victim] + lib, contact_body=scenario.contact_body)
    timings["setup"], cpu["setup"] = time.perf_counter() - t, time.process_time() - c

    t, c = time.perf_counter(), time.process_time()
    placement = {"overlap_m": scenario.overlap if scenario.offset is None else None, "tries": 1}
    t_strike = None if k_place is None else k_place / attacker.fps
    if t_strike is not None:
        placement["strike_time_s"] = t_strike
    early = None                                      # (placed, fc, overlap) of a try that touched before the strike
    while True:
        vk = placed.slice(0, min(placed.n_frames, att.n_frames))
        try:
            fc = find_first_contact(scene, att.slice(0, vk.n_frames), vk)
            if (t_strike is not None and scenario.offset is None and fc.time < t_strike - config.strike_early
                    and placement["overlap_m"] - 0.1 >= config.min_overlap - 1e-9):
                # the wind-up touches the victim (a Bandai slash's forearms on the victim's guard 1.3 s before
                # the slash): back off for the strike, keeping this try should the strike then miss
                early = (placed, fc, placement["overlap_m"])
                placement["overlap_m"] = round(placement["overlap_m"] - 0.1, 6)
                placement["tries"] += 1
                placed = place_victim(attacker, victim, replace(scenario, overlap=placement["overlap_m"]),
                                      strike_frame=k_place)
                continue
            break
        except TouchAtStartError:
            # the default placement (the strike's reach minus the overlap) can put a short strike's
            # victim inside the attacker's guard (a sword slash reaching 0.73 m): back off 10 cm at a time
            if scenario.offset is not None or placement["overlap_m"] - 0.1 < config.min_overlap - 1e-9:
                raise
            placement["overlap_m"] = round(placement["overlap_m"] - 0.1, 6)
            placement["tries"] += 1
            placed = place_victim(attacker, victim, replace(scenario, overlap=placement["overlap_m"]),
                                  strike_frame=k_place)
        except ImpactError:
            if early is None:
                raise
            # backed off past the strike's reach: the last placement that touched is kept
            placed, fc, placement["overlap_m"] = early
            placement["contact_before_strike"] = True
            break
    if t_strike is not None:
        placement["contact_time_s"] = fc.time
    timings["first_contact"], cpu["first_contact"] = time.perf_counter() - t, time.process_time() - c
    # the victim clip held at its end beyond, so the burst has targets
    t0 = fc.rewind_frame / fps
    t_naive_end = fc.time + config.window[1] + 1.0 / fps

    t, c = time.perf_counter(), time.process_time()
    naive = simulate(scene, att, placed, t0, t_naive_end, victim_targets=naive_targets(placed, t0, t_naive_end),
                     friction=config.friction_naive, gains=gains, max_contact=config.max_contact,
                     max_impulse=config.max_impulse)
    timings["naive_simulation"], cpu["naive_simulation"] = time.perf_counter() - t, time.process_time() - c
    if naive.impact_time is None:
        raise ImpactError(f"the kinematic pass found contact at frame {fc.frame} ({fc.time:.3f} s), but the "
                          "simulated attacker never touched the victim (a grazing contact): move the victim "
                          "closer (--offset)")
    t_imp = naive.impact_time
    push = 0.0 if naive.contact_end is None else min(max(naive.contact_end - t_imp, 0.0), config.max_push)
    rng = np.random.default_rng(config.seed)
    delay = float(config.delay) if config.delay is not None else float(rng.uniform(*config.delay_range))

    t, c = time.perf_counter(), time.process_time()
    n_q = naive.victim.n_frames
    if config.reentry == "window_end":
        # one query window over the whole search window; the transition ends at its last frame
        s_time = t_imp + max(config.window[0], push)
        start = int(np.ceil((s_time - t0) * fps - 1e-9))
        stop = min(int(np.floor((t_imp + config.window[1] - t0) * fps + 1e-9)) + 1, n_q)
        if stop - start < 2:
            raise ImpactError(f"the search window {s_time:.3f}-{t_imp + config.window[1]:.3f} s holds fewer than 2 "
                              f"frames at {fps:g} fps")
        res = search(index, naive.victim, start, stop, exhaustive=config.exhaustive_search, runner_up=config.runner_up)
        reentry, starts = stop - 1, [start]
        fcmp, fexh = res.stats.get("frames_compared", 0), res.stats.get("frames_exhaustive", 0)
    else:
        # the match time is searched too (App. A: "a match ... in the window 0.1-1.0 s"): one query window of
        # match_window s per candidate start; the transition ends at the best window's first frame, where
        # eq. A.1 weighs the match most
        L = max(2, int(round(config.match_window * fps)))
        s_lo = t_imp + max(config.window[0], push, delay + config.min_active)
        first = int(np.ceil((s_lo - t0) * fps - 1e-9))
        last = min(int(np.floor((t_imp + config.window[1] - t0) * fps + 1e-9)) + 1, n_q) - L
        if last < first:
            raise ImpactError(f"no room for a {config.match_window:g} s match window between {s_lo - t_imp:.3f} s "
                              f"and {config.window[1]:g} s after the impact")
        starts = list(range(first, last + 1, max(1, int(config.start_step))))
        res, start, fcmp, fexh = None, first, 0, 0
        for s0 in starts:
            r_ = search(index, naive.victim, s0, s0 + L, exhaustive=config.exhaustive_search,
                        runner_up=config.runner_up)
            fcmp += r_.stats.get("frames_compared", 0)
            fexh += r_.stats.get("frames_exhaustive", 0)
            if res is None or r_.distance < res.distance:
                res, start = r_, s0
        stop = start + L
        reentry = start
    search_stats = {"query_windows": len(starts), "query_starts": [int(x) for x in starts],
                    "frames_compared": int(fcmp), "frames_exhaustive": int(fexh),
                    "pruning_factor": float(fexh / fcmp) if fcmp else None}
    timings["search"], cpu["search"] = time.perf_counter() - t, time.process_time() - c

    t, c = time.perf_counter(), time.process_time()
    clip = res.root_transform.apply(index.motion(res.clip))
    # the found clip on the victim timeline: clip frame res.frame at query frame `start`
    n_seg = reentry + 1
    times_q = np.arange(n_seg) / fps                   # query time (0 = rewind frame)
    tc = res.frame / clip.fps + (times_q - start / fps)
    if tc[-1] > clip.duration + 1e-9:
        raise ImpactError(f"the found clip {res.clip} ends before the re-entry frame")
    found_seg = clip.sample(np.clip(tc, 0.0, clip.duration), fps=fps)
    t_react = t_imp + delay
    t_re = t0 + reentry / fps
    qa = clip_targets(placed, t0 + times_q)
    targets = blend_targets(qa, np.array(found_seg.rotations), t0 + times_q, t_react, t_re)
    timings["targets"], cpu["targets"] = time.perf_counter() - t, time.process_time() - c
    t, c = time.perf_counter(), time.process_time()
    active = simulate(scene, att, placed, t0, t_re, victim_targets=targets, friction=config.friction_active,
                      gains=gains, max_contact=config.max_contact, max_impulse=config.max_impulse)
    timings["active_simulation"], cpu["active_simulation"] = time.perf_counter() - t, time.process_time() - c

    t, c = time.perf_counter(), time.process_time()
    seg = active.victim.slice(0, n_seg)
    refine = None
    if config.reentry_radius > 0:
        # beyond the paper: the search matched the naive simulation; the found clip's frame at the re-entry is
        # re-chosen within reentry_radius frames by eq. 4.1's frame term against the active simulation's state
        # there (height kept), and the clip's timeline shifted by the difference
        from .search import reentry_frame_costs

        native = index.motion(res.clip)
        f_re = tc[-1] * native.fps
        f0 = int(round(f_re))
        r_nat = max(1, int(round(config.reentry_radius * native.fps / fps)))
        fr, costs = reentry_frame_costs(seg, native, f0, r_nat)
        if config.reentry_by == "root_height":
            costs = np.abs(np.asarray(native.root_positions)[fr, 1] - float(seg.root_positions[-1, 1]))
        # the shifted timeline must keep the clip's frames at and after the re-entry inside the clip
        ok = fr + (f_re - f0) <= native.n_frames - 1 + 1e-9
        # a whole number of output frames (a 60 Hz clip shifted by an odd frame would be realigned a half frame
        # off its blend target: 1 cm of horizontal root error)
        sh = (fr - f0) * fps / native.fps
        ok &= np.abs(sh - np.round(sh)) <= 0.05
        k = int(np.argmin(np.where(ok, costs, np.inf)))
        shift = float(fr[k] - f0) / native.fps
        i0 = int(np.flatnonzero(fr == f0)[0])
        refine = {"by": config.reentry_by, "radius_frames": r_nat, "clip_frame_searched": f0, "clip_frame_chosen": int(fr[k]),
                  "shift_s": shift, "cost_searched": float(costs[i0]), "cost_chosen": float(costs[k])}
        tc = tc + shift
    if config.realign:
        # the search aligned the clip's root at its window start onto the naive simulation's; the final
        # blend aligns it the same way (root heading and ground point, sec. 4.1) onto the active one
        from ..ops.align import align

        native = index.motion(res.clip)
        same = abs(native.fps - fps) <= 1e-6
        f_start = tc[start] * native.fps
        g = align(seg, native if same else native.resample(fps), start,
                  int(round(f_start)) if same else int(round(f_start / native.fps * fps)))
        clip_a = g.apply(native)
        found_a = clip_a.sample(np.clip(tc, 0.0, clip_a.duration), fps=fps)
    else:
        clip_a = clip
        found_a = found_seg if refine is None else clip.sample(np.clip(tc, 0.0, clip.duration), fps=fps)
    bn = final_blend(naive.victim.slice(0, n_seg), found_seg) if config.compare_naive else None
    clip = clip_a
    # the output: the victim clip up to the rewind frame, the blended segment, the found clip after
    before = placed.slice(0, fc.rewind_frame) if fc.rewind_frame > 0 else None
    t_after = tc[-1] + (np.arange(reentry + 1, 10 ** 6) - reentry) / fps
    t_after = t_after[t_after <= clip.duration + 1e-9]
    after = clip.sample(t_after, fps=fps).replace(source=placed.source) if t_after.size else None

    def assemble(blended):
        return concatenate(([before] if before is not None else []) + [blended.motion.replace(source=placed.source)]
                           + ([after] if after is not None else []))

    weights = "linear" if config.blend_weights == "auto" else config.blend_weights
    ba = final_blend(seg, found_a, weights=weights)
    out = assemble(ba)
    timings["final_blend"], cpu["final_blend"] = time.perf_counter() - t, time.process_time() - c

    t, c = time.perf_counter(), time.process_time()
    evidence = {"search": search_stats, "attack_window": attack_window, "placement": placement,
                "reentry_refine": refine}
    re_frame = fc.rewind_frame + reentry
    # the found clip's own steps on the output's sampling grid (its frames after the re-entry are sampled
    # at the output's rate and phase; another phase gives other largest steps, 0.1 deg apart on a fast get-up)
    phase = (tc[0]) % (1.0 / fps)
    clip_steps = clip.sample(np.arange(phase, clip.duration + 1e-9, 1.0 / fps), fps=fps) \
        if abs(clip.fps - fps) > 1e-6 or phase > 1e-9 else clip
    cq_max = float(frame_steps(clip_steps)[1].max())
    floor_y = _planted_floor(placed.slice(0, max(fc.rewind_frame + 1, 2)))
    # the input before the rewind frame is left as it is; the lift eases in over the simulated segment
    # the sword does not lift the body (a lying fall drove it 39 cm into the floor: the lifted body floated
    # 24 cm above it); the wrist turns it out of the floor instead
    props = wrist_props(out.skeleton)
    lift_kw = dict(tolerance=0.002, start=fc.rewind_frame, ramp_frames=max(reentry, 1), exclude=props,
                   ballistic=config.lift_ballistic)

    # the strike's last frame (its force acts up to it; the audit's external_force_frames end)
    c_end = naive.contact_end if active.contact_end is None else max(naive.contact_end, active.contact_end)
    strike_end = fc.rewind_frame + int(np.ceil((c_end - t0) * fps - 1e-9)) + 1
    vbody = default_impact_body(placed) if config.com_ballistic else None

    def repair(out, seam_free: bool = False):
        """The lift, the plants (their fades rate-limited; with ``seam_free`` the leg joints are free of
        the plants within the plants' fade of the re-entry), the second lift; returns (out, evidence)."""
        ev = {"continuity": _continuity(out, clip_steps, re_frame, fc.rewind_frame, frame_steps)}
        lift = np.zeros(out.n_frames)
        if config.lift:
            out, lift = floor_lift(out, floor_y, **lift_kw)
        if config.plant:
            from ..ops import NoContactError

            try:
                fp = plant_feet(out)
                free = None
                if seam_free:
                    free = np.zeros(out.n_frames, bool)
                    free[max(re_frame - fp.blend_frames, 0):re_frame + fp.blend_frames + 1] = True
                lifted = out
                out, limited = limit_plant_steps(out, fp.motion, fp.plants, cq_max, free=free)
                # the input before the rewind frame stays as captured (the plants' change eases in after it)
                out, restored = keep_before(out, lifted, fc.rewind_frame, fp.blend_frames)
                ev["footplant"] = {"plants": {e: len(v) for e, v in fp.plants.intervals.items()}
                                   if hasattr(fp.plants, "intervals") else None,
                                   "max_miss_m": float(fp.max_miss), "changed_frames": int(fp.changed_frames),
                                   "frames_fade_slowed": limited, "input_frames_restored": restored, "seam_free_frames": int(free.sum()) if seam_free else 0}
            except NoContactError as e:               # no plant at all (a victim airborne throughout)
                ev["footplant"] = {"skipped": str(e)}
        if config.lift:
            # the plants set planted heights on their support level, which can sink a few mm below the floor
            # again: a second, vertical-only lift (the plants stay put in the ground plane)
            out, lift2 = floor_lift(out, floor_y, **lift_kw)
            lift = lift + lift2
            out, turn = props_above_floor(out, floor_y, props, tolerance=0.002, start=fc.rewind_frame)
            ev["props_turned"] = {"frames": int((turn > 0).sum()), "max_deg": float(np.degrees(turn.max()))}
        if config.com_ballistic:
            # the blended root is a weighted mean of two roots each falling on its own timeline: the COM
            # put in free fall on the unsupported frames between the strike's end and the re-entry
            out, shift = ballistic_com(out, vbody, floor_y, start=strike_end - 1, stop=re_frame + 1)
            lift3 = np.zeros(out.n_frames)
            if config.lift:
                out, lift3 = floor_lift(out, floor_y, **lift_kw)
                lift = lift + lift3
            sn = np.linalg.norm(shift, axis=1)
            ev["ballistic_com"] = {"frames_shifted": int((sn > 0).sum()), "max_shift_m": float(sn.max()),
                                   "max_vertical_shift_m": float(np.abs(shift[:, 1]).max()),
                                   "lift_after_m": float(lift3.max())}
        if config.lift:
            ev["floor_lift"] = {"floor_y_m": floor_y, "frames_lifted": int((lift > 0).sum()),
                                "max_lift_m": float(lift.max()), "lift_at_reentry_m": float(lift[re_frame]),
                                "after_plants_max_m": float(lift2.max())}
        ev["continuity_final"] = _continuity(out, clip_steps, re_frame, fc.rewind_frame, frame_steps)
        return out, ev

    final, ev = repair(out)
    tried = [weights]
    for eased in ("smoothstep", "smootherstep"):
        if config.blend_weights != "auto" or ev["continuity_final"]["continuous"]:
            break
        # the paper's linear weights step past the found clip's own largest step at the re-entry: the eased
        # weights enter the clip with its own velocity (smootherstep: and its acceleration)
        ba2 = final_blend(seg, found_a, weights=eased)
        f2, ev2 = repair(assemble(ba2))
        tried.append(eased)
        if ev2["continuity_final"]["reentry_joint_step_deg"] < ev["continuity_final"]["reentry_joint_step_deg"]:
            ba, out, final, ev, weights = ba2, assemble(ba2), f2, ev2, eased
    if config.plant and not ev["continuity_final"]["continuous"] and ev["continuity"]["continuous"]:
        # the plants made the step (a foot held by its toe across the seam while the blended foot slides):
        # the leg joints are freed of the plants around the re-entry, their steps limited there
        f3, ev3 = repair(out, seam_free=True)
        tried.append(weights + "+seam_free")
        if ev3["continuity_final"]["reentry_joint_step_deg"] < ev["continuity_final"]["reentry_joint_step_deg"]:
            final, ev = f3, ev3
    out = final
    evidence.update(ev, blend_weights=weights, repairs_tried=tried)
    timings["repairs"], cpu["repairs"] = time.perf_counter() - t, time.process_time() - c

    t, c = time.perf_counter(), time.process_time()
    ar = attacker_response(att.slice(0, int(np.floor(attacker.duration * fps + 1e-9)) + 1), active.attacker,
                           fc.rewind_frame, active.impact_time if active.impact_time is not None else t_imp,
                           active.contact_end, follow=config.attacker_follow, blend=config.attacker_blend)
    evidence["attacker"] = ar.to_dict()
    att_out = ar.motion
    if config.lift:                                   # the simulated feet sink into the soft floor contact
        att_out, alift = floor_lift(att_out, _floor_level(att.slice(0, max(fc.rewind_frame + 1, 2))),
                                    tolerance=0.002)
        evidence["attacker"].update(frames_lifted=int((alift > 0).sum()), max_lift_m=float(alift.max()))
    if config.separate:
        # after the strike the attacker blends back to its clip, which knows nothing of the victim's
        # reaction: its body is kept out of the victim's (root pushed horizontally, smoothly)
        from .attacker import separate

        from .attacker import body_gap

        s0 = fc.rewind_frame + ar.follow_frames
        pushed, sep = separate(att_out, out, start=s0, max_speed=config.separate_max_speed,
                               max_shift=config.separate_max_shift)
        held = pushed
        floor_a = _floor_level(att.slice(0, max(fc.rewind_frame + 1, 2)))
        if sep["frames_shifted"] and config.plant:
            # the push slides the feet: the plants of the unpushed attacker are held on the pushed one
            from ..ops import NoContactError, enforce_footplants
            from ..ops.plants import foot_plants

            try:
                planted = enforce_footplants(pushed, plants=foot_plants(att_out), audit=False).motion
                if config.lift:                       # the plants' support level, as for the victim
                    planted, _ = floor_lift(planted, floor_a, tolerance=0.002)
                g_, _ = body_gap(planted, out)
                # a foot held where the push has carried the body away from can put a leg back into the
                # victim (a 1.6 m push): then the feet slide instead
                if g_.size <= s0 or g_[s0:].min() >= min(sep["min_gap_after_m"], 0.0) - 0.025:
                    held, sep["feet_planted"] = planted, True
                else:
                    sep["feet_planted"] = False
                    sep["plants_undone"] = f"holding the feet put the attacker {-100 * g_[s0:].min():.1f} cm into the victim"
            except NoContactError:
                sep["feet_planted"] = False
        if sep["frames_shifted"]:
            g_, _ = body_gap(held, out)
            sep["min_gap_final_m"] = float(g_[s0:].min()) if g_.size > s0 else None
        att_out = held
        evidence["attacker"]["separation"] = sep
    timings["attacker"], cpu["attacker"] = time.perf_counter() - t, time.process_time() - c
    frames = {"rewind": fc.rewind_frame, "first_contact": fc.frame,
              "impact": fc.rewind_frame + int(round((t_imp - t0) * fps)),
              "window_start": fc.rewind_frame + start, "window_stop": fc.rewind_frame + stop,
              "reentry": re_frame, "found_clip_frame_at_reentry": int(round(tc[-1] * clip.fps)),
              "output_frames": out.n_frames}
    # the frames the strike's force acts on both characters (half-open; for the audit's external_force_frames)
    frames["external_force"] = [frames["impact"], strike_end]
    notes = scene.notes + naive.notes
    return ImpactResult(out, att_out, scenario, fc, naive, active, res, found_a, ba, bn, frames, delay,
                        timings, evidence, notes, cpu)


def _floor_level(victim: Motion) -> float:
    """m: the floor the clip stands on before the impact -- the median height of its lowest joint or end
    site over those frames (the audit measures penetration from the first ground stage the same way)."""
    P = victim.positions[..., 1].min(axis=1)
    E = victim.end_site_positions()
    if E.size:
        P = np.minimum(P, E[..., 1].min(axis=1))
    return float(np.median(P))


def _planted_floor(victim: Motion) -> float:
    """m: the floor the victim stands on before the impact as :mod:`mocomp.audit` measures it (the
    median height of the lowest body point over the planted frames of the first ground stage), else
    (fewer than the audit's 5 frames) :func:`_floor_level`. A running victim's flight frames raised the
    median of every frame 1 cm above it (0.0738 vs 0.0633 m): the lift then held the output's later
    frames there, the audit's floor of the output rose with them and the input's own footfalls read as
    penetration (1.42 cm at frame 13, run + kick from behind)."""
    from ..audit import audit
    from ..audit.run import MIN_FRAMES

    if victim.n_frames >= MIN_FRAMES:
        try:
            return float(audit(victim).penetration.floor_y)
        except Exception:                             # no ground stage the audit can name: the plain median
            pass
    return _floor_level(victim)


def _continuity(out: Motion, clip: Motion, re_frame: int, rewind: int, frame_steps) -> dict:
    """Frame-to-frame root and joint steps at the rewind and re-entry seams (into and out of the
    seam frame) against the found clip's own largest steps at the output's frame rate."""
    dr, dq = frame_steps(out)
    cr, cq = frame_steps(clip)

    def around(k):                                   # the steps into and out of frame k
        lo, hi = max(k - 1, 0), min(k + 1, len(dr))
        return float(dr[lo:hi].max()), float(np.degrees(dq[lo:hi].max()))

    r_re, q_re = around(re_frame)
    r_rw, q_rw = around(rewind)
    return {"reentry_root_step_m": r_re, "reentry_joint_step_deg": q_re,
            "rewind_root_step_m": r_rw, "rewind_joint_step_deg": q_rw,
            "clip_max_root_step_m": float(cr.max()), "clip_max_joint_step_deg": float(np.degrees(cq.max())),
            "segment_max_root_step_m": float(dr[rewind:re_frame].max()) if re_frame > rewind else 0.0,
            "segment_max_joint_step_deg": float(np.degrees(dq[rewind:re_frame].max())) if re_frame > rewind else 0.0,
            "continuous": bool(r_re <= cr.max() + 1e-9 and q_re <= np.degrees(cq.max()) + 1e-9)}
