"""Multi-flip synthesis speed (flips paper section 6 / dissertation section 5.6 "Running time").

Rows
----
* ``flips run-time, N flips`` (N = 2, 3, 4): one call of ``mocomp.flips.multiflip(prepared,
  N, evaluate=False)`` on the embedded synthetic back flip (120 fps, 31 joints, 323 frames):
  the landing search and sequencing, seam smoothing, the eq. 5.22 seam retiming (angular
  momentum of the landing seam's frames; the loop seam's speeds are cached per clip), retiming
  (slerp of every joint of every output frame), repositioning (exact COM of every flight frame)
  and building the new ``Motion``. **Not included**: the self-looping search (eq. 5.9), cached
  per clip by ``prepare`` (its own row below) together with the loop seam's smoothing, speeds
  and window choice, and the physics report (``evaluate=True``: momentum of the new motion,
  evidence rather than method). The figure is the median CPU time
  (``time.process_time``) over the repeats, which is robust to the preemption of this shared
  2-core machine; the repeats of 2, 3 and 4 flips are interleaved, so a burst of load slows
  all three alike; the note gives the median wall time and the per-stage medians.
  Peer: the paper's **published** 2007 timings (3.69, 4.60, 5.09 ms on 2007 hardware), quoted
  as reference numbers -- not re-run here. Goal for the double flip: under 1 ms.

  Measured (2026-12-01; this host is 2-3x slower than a week before, when the row read 0.49 ms,
  and shared with a CI simulation, so single runs swing by +-30 %). Before/after the run-time
  overhead work (commits 4b0dedb, 296a2cb, b286739; outputs bit for bit as before on
  that host, checked then by hashes since replaced by the portable tolerance tests of
  ``tests/test_flips_tolerances.py``), 2 flips, CPU time:
  old and new code run *at the same time* in two processes (same load; 3 x 1500 calls each, two
  repetitions): median 0.70-1.06 ms (median 0.79) before, 0.58-0.78 ms (median 0.64) after;
  fastest call 0.64-0.66 -> 0.50-0.52 ms, i.e. about 20 % less. Full ``benchmarks/run.py
  --only flips`` runs alternated old/new: the row's median was 0.70-1.19 ms (median of 8 runs
  1.03) before and 0.66-0.97 ms (3 runs) after, 3 and 4 flips likewise, growth ratio 1.11-1.14
  both. What was removed: the fancy-index gathers (``np.take``), per-call copies of arrays the
  kernels only read, per-call rebuilding of per-clip kernel inputs (unit ``L`` axis, joint
  weights, angular momentum), the sequence's concatenations, and the repositioning's numpy
  steps (now one compiled kernel). What is left (cProfile, 1000 calls): the kernels' own
  arithmetic is about 330 us of a ~0.55 ms quiet call (retiming slerp ~170 us for 405 x 31
  quaternions, COM of the flight frames ~50, landing search ~40, landing-seam speeds ~40), so a
  further large cut needs fewer floating-point operations there, which would change the bits.
* ``flips run-time growth``: time per output frame of 4 flips over that of 2 flips (near-linear
  growth: at most 1.3).
* ``flips self-loop search``: the cached eq. 5.9 search of that clip.
* ``flips pre-processing, 10 s clip``: ``mocomp.flips.prepare`` on a 10 s, 120 fps clip (the
  synthetic back flip with standing still before and after): flight detection, mass
  estimation (eq. 5.1-5.2) with the frame-rate check over all flights, inertias, momentum of
  every frame (eq. 5.4-5.5), the root split, the self-loop search and the seam windows. Peer: the published "about 3 s" (paper; the dissertation says about
  2 s). Goal: under 100 ms. **A warm-process figure**: median CPU time of repeated calls in
  this process, after a first untimed call (and after the run-time rows above), so imports,
  numba's compilation or cache load (``mocomp.flips._kernels.warmup``), the embedded example's
  generation and first-touch memory are not in it.
* ``flips pre-processing, 10 s clip, cold process``: the same ``prepare`` call as the first one
  in a fresh Python subprocess, wall time (``time.perf_counter``) of that one call: it includes
  numba loading its on-disk cache of the compiled kernels (or compiling them, when the cache is
  missing or stale -- the note says which it found before the run) and every first-call cost;
  the top-level imports and building the clip are timed separately in the note. No goal (the goal above
  is for the warm figure); a single sample, so expect more jitter than the medians.
"""
from __future__ import annotations

import gc
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from timing import result

PAPER_RUNTIME_MS = {2: 3.69, 3: 4.60, 4: 5.09}
PAPER_PREPROCESS_S = 3.0


def _times(fn, repeat: int, warm: bool = True) -> tuple[list[float], list[float]]:
    cpu, wall = [], []
    if warm:
        fn()
    for _ in range(repeat):
        gc_was = gc.isenabled()
        gc.disable()
        try:
            c0, w0 = time.process_time(), time.perf_counter()
            fn()
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        finally:
            if gc_was:
                gc.enable()
    return cpu, wall


def ten_second_clip(motion, seconds: float = 10.0):
    """The clip padded with its first and last poses (standing still) to ``seconds``."""
    from mocomp.core.motion import concatenate

    n = int(round(seconds * motion.fps)) - motion.n_frames
    a = n // 2
    head = motion[0:1]
    tail = motion[motion.n_frames - 1:]
    pad_a = head.replace(root_positions=np.repeat(head.root_positions, a, 0),
                         rotations=np.repeat(head.rotations, a, 0))
    pad_b = tail.replace(root_positions=np.repeat(tail.root_positions, n - a, 0),
                         rotations=np.repeat(tail.rotations, n - a, 0))
    return concatenate([pad_a, motion, pad_b])


_COLD = r"""
import json, sys, time
t0 = time.perf_counter()
sys.path.insert(0, {bench_dir!r})
from bench_flips import ten_second_clip
from mocomp import datasets
from mocomp.flips import prepare
t1 = time.perf_counter()
long = ten_second_clip(datasets.load("backflip"))
t2 = time.perf_counter()
c = time.process_time()
P = prepare(long)
t3 = time.perf_counter()
print(json.dumps({{"imports": t1 - t0, "clip": t2 - t1, "prepare": t3 - t2, "cpu": time.process_time() - c,
                   "steps": P.timings}}))
"""


def numba_cache_state() -> str:
    """Whether the flips kernels' numba cache files exist next to their sources."""
    import mocomp.flips as fl

    cache = Path(fl.__file__).parent / "__pycache__"
    n = len(list(cache.glob("*.nbi"))) if cache.is_dir() else 0
    return f"{n} numba cache index files found in {cache.name}/ before the run" if n else \
        "no numba cache found before the run (the kernels were compiled in it)"


def cold_prepare() -> tuple[dict, str]:
    """Time the first ``prepare`` of the 10 s clip in a fresh subprocess (see the module docstring)."""
    state = numba_cache_state()
    code = _COLD.format(bench_dir=str(Path(__file__).resolve().parent))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ), timeout=600)
    return json.loads(out.stdout.strip().splitlines()[-1]), state


def run(quick: bool = False) -> list[dict]:
    from mocomp import datasets
    from mocomp.flips import multiflip, prepare

    repeat = 30 if quick else 200
    motion = datasets.load("backflip")
    P = prepare(motion)
    rows = []
    per_frame = {}
    counts = (2, 3, 4)
    outs = {n: multiflip(P, n, evaluate=False) for n in counts}
    stage = {n: {k: [] for k in outs[n].timings} for n in counts}
    cpu = {n: [] for n in counts}
    wall = {n: [] for n in counts}

    def call(n):
        r = multiflip(P, n, evaluate=False)
        for k, v in r.timings.items():
            stage[n][k].append(v)

    # Interleaved rounds (2, 3, 4, 2, 3, 4, ...): a burst of load on this shared machine then
    # slows every flip count alike instead of one row, which keeps the growth ratio honest.
    for _ in range(repeat):
        for n in counts:
            c, w = _times(lambda: call(n), 1, warm=False)
            cpu[n] += c
            wall[n] += w
    for n in counts:
        out = outs[n]
        ours = statistics.median(cpu[n])
        per_frame[n] = ours / out.motion.n_frames
        stages = ", ".join(f"{k} {1e3 * statistics.median(v):.3f}" for k, v in stage[n].items())
        rows.append(result(
            f"flips run-time, {n} flips", ours, peer="paper 2007 (published, not re-run)",
            peer_s=PAPER_RUNTIME_MS[n] / 1e3, goal="ours_s <= 0.001" if n == 2 else None,
            note=(f"embedded synthetic back flip, 120 fps, 31 joints, {motion.n_frames} -> {out.motion.n_frames} "
                  f"frames; median CPU {1e3 * ours:.3f} ms, wall median {1e3 * statistics.median(wall[n]):.3f} / "
                  f"min {1e3 * min(wall[n]):.3f} ms over {repeat} (2/3/4 flips interleaved); stages (wall ms): "
                  f"{stages}; includes the eq. 5.22 seam retiming; excludes the cached self-loop search / loop "
                  f"seam and the physics report")))
    growth = per_frame[4] / per_frame[2]
    row = result("flips run-time growth (per output frame, 4 vs 2 flips)", per_frame[4],
                 note=f"time per output frame: 2 flips {1e6 * per_frame[2]:.2f} us, 4 flips "
                      f"{1e6 * per_frame[4]:.2f} us; ratio {growth:.2f} (goal <= 1.3: near-linear)")
    row["passed"] = bool(growth <= 1.3)
    row["goal"] = "per-frame time ratio <= 1.3"
    rows.append(row)
    rows.append(result("flips self-loop search (cached per clip)", P.loop.seconds,
                       note=f"{P.loop.n_pairs} frame pairs scored (eq. 5.9, D/phi criterion); part of prepare()"))
    long = ten_second_clip(motion)
    cpu, wall = _times(lambda: prepare(long), 3 if quick else 7)
    ours = statistics.median(cpu)
    Q = prepare(long)
    steps = ", ".join(f"{k} {1e3 * v:.1f}" for k, v in Q.timings.items())
    rows.append(result(
        "flips pre-processing, 10 s clip", ours, peer="paper 2007 (published, not re-run)",
        peer_s=PAPER_PREPROCESS_S, goal="ours_s <= 0.1",
        note=(f"warm process (after a first untimed call; no imports, numba cache load or compilation): "
              f"{long.n_frames} frames at 120 fps (synthetic back flip padded with standing still); median CPU "
              f"{1e3 * ours:.1f} ms, wall median {1e3 * statistics.median(wall):.1f} ms; steps (ms, last run): "
              f"{steps}")))
    cold, state = cold_prepare()
    csteps = ", ".join(f"{k} {1e3 * v:.1f}" for k, v in cold["steps"].items())
    rows.append(result(
        "flips pre-processing, 10 s clip, cold process", cold["prepare"],
        note=(f"first prepare() in a fresh subprocess, wall time of that call (CPU {1e3 * cold['cpu']:.0f} ms): "
              f"includes numba's cache load or compilation, the modules prepare() imports lazily (scipy.optimize, ...) and "
              f"first-call costs; {state}; not included: the top-level imports "
              f"{1e3 * cold['imports']:.0f} ms, building the clip (embedded example generation) "
              f"{1e3 * cold['clip']:.0f} ms; steps (ms): {csteps}")))
    return rows


if __name__ == "__main__":
    for r in run(quick=True):
        print(r)
