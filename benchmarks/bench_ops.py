"""Editing primitives (issue 15): footplant enforcement, a blend, a path edit.

Goals (issue 15, one run each): footplant enforcement on a 10 s clip at 120 Hz **under 30 ms**; a
1 s blend **under 5 ms**; pathedit of a 10 s clip **under 30 ms**.

Input: the real SFU walk ``walks/sfu_0008_Walking002.bvh`` (25 joints, 120 Hz), frames 0-1200
(10 s), when ``MOCOMP_DATA_DIR`` is set; otherwise the synthetic walk of
:mod:`mocomp.ops.synthetic` (31 joints, 120 Hz, 10 s) -- the note says which.

Rows (best of N wall time, garbage collector paused, a fresh Motion each run so no FK cache):

* ``footplant``: :func:`mocomp.ops.enforce_footplants` end to end with its defaults and
  ``audit=False`` -- contact detection and FK of the input, plant targets, the fades and the
  two-bone IK of both legs, the re-detection on the result (the FK it reads, filled in from the
  input's with only the legs recomputed) and the second pass (fades recomputed only on the stretches
  of a leg whose plants changed, IK only on frames whose correction changed). Not timed, because the
  caller did not ask for them: the evidence (slides, joint rates: computed on first use), the audits,
  the FK of the final result (computed on first use). Peer: :func:`mocomp.ops.ik.plant_feet`, the
  flight edits' simpler foot planting (ankles only, held where they touched down, compiled FK),
  given the same plants as weights -- it does no detection, no toe, no fades, no re-detection, so it
  is the floor of the IK work.
* ``blend 1 s``: :func:`mocomp.ops.blend` of frames of the clip into itself 4 s later with a
  120-frame (1 s) window, ``plant=False`` (alignment, slerp, velocity-integrated root, assembly);
  a second row with the feet planted (two detections and a footplant pass on the 1200-frame result)
  has no goal and says what the planting costs. Peer: ``Motion.sample`` of the window (the slerp of
  every joint and the root interpolation alone).
* ``pathedit``: :func:`mocomp.ops.path_edit` of the 10 s clip onto a 90 deg arc, feet re-planted
  (``audit=False``): the input's path, FK and contact detection, the moved motion (its FK the
  input's turned and shifted per frame) and a footplant enforcement as above on the input's plants.
  No peer; the goal ratio is the goal over ours.

Measured (2026-12-02, 2 cores shared with other jobs; ``benchmarks/run.py --only ops`` run
alternately on the code before the speed work (7a64b6e) and after, three runs each, best of 25 per
row; at 11:27 with load average 1.0-1.5, and at 11:24 with load 2.5-2.7):

=================================================  =============================  =============================
row (real SFU clip)                                before (7a64b6e)               after
=================================================  =============================  =============================
footplant, 10 s at 120 Hz (goal 30 ms)             29.3, 29.5, 50.6 (load 1-1.5)  35.0, 23.0, 23.0 (load 1-1.5)
                                                   47, 31 (load 2.5)              37, 23.5, 27 (load 2.5)
blend, 1 s window (goal 5 ms)                      1.9-2.9 ms                     1.8-2.8 ms
blend, 1 s window, feet planted (no goal)          32-44 ms (load 1-1.5)          27-33 ms (load 1-1.5)
pathedit, 10 s onto a 90 deg arc (goal 30 ms)      34.5, 36.1, 53.4 (load 1-1.5)  26.8, 27.1, 28.0 (load 1-1.5)
                                                   53, 35 (load 2.5)              43, 28, 32 (load 2.5)
=================================================  =============================  =============================

In one process, alternating the two versions call by call (best of 50, load 1.7-2.2): footplant
32-36 -> 26-28 ms, pathedit 40-44 -> 33-34 ms. At load 1-1.5 the footplant goal was met in 2 of 3
runs and the pathedit goal in 3 of 3; at load 2.5 only in some runs. Where the pathedit time goes
(~33 ms at load 2): the input's detection and FK (~5.5 ms), the moved FK (~2 ms), the first pass (~8 ms, IK ~3 ms of
it), the second (~7 ms: on this path-edited loop walk the re-detection adds a frame to nearly every
stance of the left foot, so most of that leg is solved again), the re-detection (~2.5 ms) and the
FK it reads (~2 ms). Results are the same as before the speed work to 1.3e-13 (rotations, slides,
plants; ``tests/test_ops_reference.py``). The peer is no match in scope (``plant_feet`` holds
ankles at their touch-down: no detection, no toes, no fades) and says what the bare IK costs.

Plants on the points' resting levels, the both-planted foot fitted to its targets and the extra
passes where the re-detection disagrees with the input's (2026-12-02, 13:58, load 6; old and new
switched call by call in one process, 12 calls each, min / median): footplant 61.4 / 74.0 ->
62.4 / 74.5 ms, pathedit 65.3 / 69.7 -> 65.0 / 71.4 ms, blend with feet planted 63.8 / 68.8 ->
67.6 / 71.7 ms (+4-6 %). The bench clip never starts the extra passes (its re-detection adds 0.4 % of
the planted frames); a raw CMU clip that does (131_02, 32 %) costs 2.8x its two passes. With the
heel-height easing and the toes moved with their heels (vectorised; 14:09, load 3.5, 12 calls each):
footplant 24.6 / 25.3 -> 25.9 / 28.3 ms (+5 % min), pathedit 27.3 / 28.9 -> 29.4 / 30.9 ms (+8 %),
blend with feet planted 27.0 / 27.8 -> 28.7 / 29.7 ms (+6 %).

Speed work for touch-up (2026-12-02 afternoon; before = ``lib/`` of 341bed2's ``mocomp.ops`` dropped into
today's tree, so only ``ops`` differs; the two run alternately, process by process): the displacement
maps log, smooth and apply only the joints they move (touch-up's targets differ by rounding on 28-30 of
31 joints: offsets within 1e-12 rad are dropped), long Gaussians by FFT, fused compiled log/exp kernels
(:mod:`mocomp.ops._kernels`), the legs' IK compiled. ``run.py --only ops``, three alternations at load
4.5-5 (best of 25 each): footplant 14.8, 15.9, 16.3 -> 14.2, 26.1, 15.6 ms; pathedit 16.6, 19.2, 37.0
-> 16.2, 33.6, 30.1 ms; blend 1.2 -> 1.1-1.4 ms -- the same within the noise (these 1,201-frame rows were
not the target; the clocked fades, ``leg_fade_clocks``, add no measurable time: 34.3 vs 35.6 ms min in
one process at load 5.6). Touch-up ``ground-default`` on the 10,001-frame synthetic walk, CPU best of 3:
2.11, 2.08 -> 0.80, 0.85 s (ops' share about 60 % -> 38 %).
"""
from __future__ import annotations

import os

import numpy as np

from timing import best_of, result


def clip():
    from mocomp.datasets import data_dir

    d = data_dir()
    if d is not None and (d / "walks" / "sfu_0008_Walking002.bvh").is_file():
        from mocomp import datasets

        return datasets.load("sfu_0008_Walking002")[:1201], "real SFU 0008_Walking002, frames 0-1200"
    from mocomp.ops.synthetic import synthetic_walk

    return synthetic_walk(duration=10.0, fps=120.0).motion, "synthetic walk (MOCOMP_DATA_DIR unset)"


def run(quick: bool) -> list[dict]:
    from mocomp.ops.ik import leg_chains, plant_feet
    from mocomp.ops import PathCurve, blend, enforce_footplants, foot_plants, motion_path, path_edit

    m, origin = clip()
    repeat = 5 if quick else 25
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rows = []
    fresh = lambda: m.replace()                                        # noqa: E731  (empty FK cache)
    enforce_footplants(fresh(), audit=False)                          # warm caches (effectors, imports)
    t_fp, r = best_of(lambda mm: enforce_footplants(mm, audit=False), repeat, fresh)
    pl = foot_plants(m)
    chains = leg_chains(m.skeleton)
    w = pl.labels[:, [0, 2]].astype(float)
    plant_feet(fresh(), 0, w, chains)
    t_peer, _ = best_of(lambda mm: plant_feet(mm, 0, w, chains), repeat, fresh)
    rows.append(result(f"footplant {m.skeleton.n_joints}j x {m.n_frames}f (10 s at 120 Hz)", t_fp,
                       "mocomp.ops.ik.plant_feet (ankles held, no detection/toes/fades)", t_peer,
                       goal="ours_s <= 0.03",
                       note=f"{origin}; slide within plants {r.slide_before.max() * 100:.2f} -> "
                            f"{r.slide_after.max() * 100:.2f} cm; {len(r.notes)} note(s); load average {load:.1f}"))
    N = int(round(m.fps))
    at = (int(3 * m.fps), int(7 * m.fps))
    blend(m, m, at, N, plant=False)
    t_b, rb = best_of(lambda mm: blend(mm, mm, at, N, plant=False), repeat * 2, fresh)
    ts = np.arange(at[0] - N // 2, at[0] - N // 2 + N) / m.fps
    t_s, _ = best_of(lambda mm: mm.sample(ts), repeat * 2, fresh)
    rows.append(result(f"blend 1 s window ({N} frames), {m.n_frames}f clips", t_b, "Motion.sample of the window", t_s,
                       goal="ours_s <= 0.005", note=f"{origin}; no foot planting"))
    t_bp, rbp = best_of(lambda mm: blend(mm, mm, at, N), max(3, repeat // 2), fresh)
    rows.append(result("blend 1 s window, feet planted", t_bp, note=f"{origin}; detection of both inputs + a footplant "
                       f"pass on the {rbp.motion.n_frames}-frame result"))
    path, s, psi = motion_path(m)
    arc = PathCurve.arc(float(s[-1]), np.radians(90), start=path[0], heading=float(psi[0]))
    path_edit(fresh(), arc)
    t_p, rp = best_of(lambda mm: path_edit(mm, arc), repeat, fresh)
    rows.append(result(f"pathedit {m.n_frames}f onto a 90 deg arc, feet re-planted", t_p, goal="ours_s <= 0.03",
                       note=f"{origin}; path {rp.path_length:.1f} m; slide after "
                            f"{rp.footplants.slide_after.max() * 100:.2f} cm"))
    return rows
