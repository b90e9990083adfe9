"""Impact response (issue 18, dissertation ch. 4).

Row ``impact response``: one full response -- naive simulation, search, the active simulation
with its targets, the final blend (:attr:`mocomp.impact.pipeline.ImpactResult.response_cpu_seconds`)
-- of the kick ``attacks/ase_rl_Atk_Kick`` on the standing victim ``idle/ase_rl_Idle_Ready``
(contact body ``right_foot``), facing 0, 90, 180 and -90 deg in turn, with the shared reaction
library (``reactions/``, 14 clips, index built once before timing). The figure is the **median CPU
time** (``time.process_time``) over the runs, robust to this shared machine's preemption (as the
flips rows); the note gives the median wall time, the per-stage medians and the first-contact,
repair and attacker stages left out of the response. Goal (issue 18): **under 2 s**. Peer: the
paper's "approximately one minute each (without graphics)" (sec. 4.4, 2007), quoted, not rerun.
Without ``MOCOMP_DATA_DIR`` the row is skipped (the method needs the ASE clips and the library).

Measured (2026-12-02, load ~11 on 2 cores, quick, 4 runs, the match time searched too: 8 query
windows per response; servos at 50/60 rad/s): median CPU 0.77 s (naive simulation 463 ms, search
15 ms, active simulation 228 ms, blend 33 ms; targets 21 ms); median wall of the whole call 2.9 s at
that load. Goal met. Re-run 2026-12-02 16:08 after the strike limit, the attacker separation and the
re-entry repairs (load 9.4-10.2, quick): median CPU 0.32 s (naive 188 ms, search 5 ms, active 101 ms,
blend 15 ms; repairs 25 ms and attacker 24 ms outside the response); search 16.2 vs 169.4 ms CPU over the
23 queries, 10.4x, same best 23/23, 74 k vs 822 k frame pairs (11.1x).

Search and index rows (the search half, :mod:`mocomp.impact.index` / :mod:`mocomp.impact.search`):

* ``impact search, unique frames`` -- the search of :func:`mocomp.impact.search.search` (unique
  frames, eq. 4.2, then the refinement; early abandoning and the triangle-inequality bound) beside
  the **exhaustive** search (``exhaustive=True``: every window of every clip compared in full with
  the same compiled eq. 4.1 kernel) on the same queries. Goal from issue 18: **at least 10x faster,
  with the same best match**. ``ours_s``/``peer_s`` are the sums over the queries of each query's
  least **CPU time** (``time.process_time``, best of N) of one ``search`` call (query features
  included; the query motion's forward kinematics is cached by the core after the first call, for
  both searches alike); the row passes only when the ratio is >= 10 *and* every query got the
  exhaustive best. The note gives the frame pairs
  compared (the machine-independent measure), the agreement and the matching-only ratio.
* ``impact search, matching only`` -- the same calls, the comparison part alone
  (``stats["seconds_matching"]``, least wall time: the query window's features, identical for both
  searches, left out).
* ``impact index build, N frames`` -- :func:`mocomp.impact.index.build_index` without the cache
  (load, retarget, features, unique frames) on the library repeated 1, 2 and 4 times (copies in a
  temporary folder): the build must be linear in library frames (the row passes when the time per
  frame at 4x is within 1.5x of the 1x time per frame); plus the cached reload of the 1x library.

Queries: with ``MOCOMP_DATA_DIR`` the shared reaction library (``reactions/``: 14 clips, 1739
frames at 30 Hz) and 23 queries of 0.9 s (the paper searches 0.1-1.0 s after the impact): the
three victims (standing, walking, running) at 4 starts each and 11 windows cut from library clips,
turned and shifted at random (as ``tests/test_impact_search.py``). Without it: a synthetic library
(walks, jump, back flip, twist) and synthetic walk queries.

Measured before (2026-12-02, load ~7, ``--quick``): same best in 23/23, 11.0x fewer frame pairs,
CPU per query 3.5 vs 15.3 ms, **4.4x**: every search paid ~1.5 ms of Python control flow that
pruning does not shrink. Now (the whole search one compiled call, each window bounded first without ``acos`` and finished
exactly only if it survives, :mod:`mocomp.impact._kernels`; full mode): same best in 23/23, 74 k
frame pairs vs 822 k (11.1x fewer; 7.6 k of them exact), CPU per query 0.85 vs 10.94 ms, **12.9x**
at load 4.1; 1.49 vs 16.27 ms, **10.9x** at load 5.7-6.0 (the victim queries, absent from the
library, cost the most; the windows cut from library clips little). The goal is met with a thin
margin under heavy load: on this 1739-frame library the exhaustive search is only ~35 k windows.
Index build 242 / 232 us per frame at 1x / 2x (linear); cached reload of the 14 clips 66 ms.

The paper (Majkowska 2007, sec. 4.4) quotes about one minute per response, 70 % of it in the search
of a 110-clip library, on 2007 hardware: quoted in the notes, not comparable.
"""
from __future__ import annotations

import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from timing import best_of, result

FACINGS = (0.0, 90.0, 180.0, -90.0)


def _response_row(quick: bool) -> dict | None:
    from mocomp.datasets import data_dir
    from mocomp.impact.pipeline import impact_response, load_library
    from mocomp.impact.scene import Scenario
    from mocomp.io import load

    d = data_dir()
    if d is None:
        return None
    a = load(d / "attacks" / "ase_rl_Atk_Kick.derived.bvh")
    v = load(d / "idle" / "ase_rl_Idle_Ready.derived.bvh")
    index = load_library(d / "reactions", v.skeleton)
    lib = [index.motion(c.path) for c in index.clips]
    runs = FACINGS if quick else FACINGS * 2
    cpu, wall, stages = [], [], {}
    for f in runs:
        w0 = time.perf_counter()
        r = impact_response(a, v, index, Scenario(f, contact_body="right_foot"), library_motions=lib)
        wall.append(time.perf_counter() - w0)
        cpu.append(r.response_cpu_seconds)
        for k, t in r.cpu.items():
            stages.setdefault(k, []).append(t)
    med = statistics.median(cpu)
    st = ", ".join(f"{k} {statistics.median(t) * 1000:.0f} ms" for k, t in stages.items())
    return result(f"impact response (kick -> idle, {len(runs)} runs, facings 0/90/180/-90)", med,
                  "paper (sec. 4.4, 2007): about one minute each", 60.0, "ours_s <= 2.0",
                  f"median CPU s of naive sim + search + active sim + blend; median wall of the whole call "
                  f"{statistics.median(wall):.2f} s; per-stage CPU medians: {st}; library {len(index.clips)} clips, "
                  f"{index.n_frames} frames")


def _library():
    """(library dir, victim skeleton, queries [(motion, start)], description)."""
    from mocomp.datasets import data_dir

    d = data_dir()
    if d is not None and (d / "reactions").is_dir():
        from mocomp.impact.index import build_index
        from mocomp.io import load
        from mocomp.ops.align import yaw_quaternion

        victims = [load(d / f) for f in ("idle/ase_rl_Idle_Ready.derived.bvh", "walks/ase_rl_WalkForward01.derived.bvh",
                                         "runs/ase_rl_RunForward.derived.bvh")]
        idx = build_index(d / "reactions", victims[0].skeleton, progress=False)
        rng = np.random.default_rng(18)
        queries = [(m, int(s)) for m in victims for s in np.linspace(0, m.n_frames - 28, 4).astype(int)]
        for c in idx.clips[:11]:
            m = idx.motion(c.path).rotated(yaw_quaternion(rng.uniform(-np.pi, np.pi)))
            queries.append((m.translated([rng.uniform(-2, 2), 0.0, rng.uniform(-2, 2)]),
                            int(rng.integers(0, c.n_frames - 27))))
        return d / "reactions", victims[0].skeleton, queries, "shared reaction library (14 clips)"
    import mocomp.datasets as datasets
    from mocomp.io import write_bvh
    from mocomp.ops.synthetic import synthetic_walk

    lib = Path(tempfile.mkdtemp(prefix="bench_impact_lib_"))
    write_bvh(synthetic_walk(duration=4.0, fps=30.0).motion, lib / "walk.bvh")
    write_bvh(synthetic_walk(duration=3.0, fps=30.0, speed=1.2, stride_time=1.0).motion, lib / "fast_walk.bvh")
    for name in ("jump", "backflip", "twist180"):
        write_bvh(datasets.load_example(name).motion.resample(30.0), lib / f"{name}.bvh")
    q = synthetic_walk(duration=4.0, fps=30.0, speed=0.9).motion
    return lib, q.skeleton, [(q, s) for s in range(0, 90, 8)], "synthetic library (5 clips, no MOCOMP_DATA_DIR)"


def _search_rows(quick: bool) -> list[dict]:
    from mocomp.impact.index import build_index
    from mocomp.impact.search import search

    lib, skeleton, queries, what = _library()
    cache = Path(tempfile.mkdtemp(prefix="bench_impact_cache_"))
    rows = []
    try:
        idx = build_index(lib, skeleton, cache_dir=cache, progress=False)
        repeat = 3 if quick else 7
        L = 27
        ours = peer = ours_m = peer_m = 0.0
        pairs = pairs_ex = same = exact = 0
        ours_x = pairs_x = ru_fast = ru_exact = 0
        search(idx, *_window(queries[0], L))                       # compile / load the kernels
        search(idx, *_window(queries[0], L), exhaustive=True)
        load0 = os.getloadavg()[0]
        for q in queries:
            args = _window(q, L)
            t_u, a = _best_cpu(lambda: search(idx, *args), repeat)
            t_e, b = _best_cpu(lambda: search(idx, *args, exhaustive=True), repeat)
            ours += t_u
            peer += t_e
            ours_m += _best_matching(lambda: search(idx, *args), repeat)
            peer_m += _best_matching(lambda: search(idx, *args, exhaustive=True), repeat)
            pairs += a.stats["frames_compared"]
            exact += a.stats["frames_exact"]
            pairs_ex += b.stats["frames_compared"]
            same += (a.clip, a.frame) == (b.clip, b.frame)
            # the optional exact runner-up (search(runner_up="exact")) against the default and the exhaustive
            t_x, x = _best_cpu(lambda: search(idx, *args, runner_up="exact"), repeat)
            ours_x += t_x
            pairs_x += x.stats["frames_compared"] + x.stats["frames_runner_up"]
            rb = (b.runner_up.clip, b.runner_up.frame) if b.runner_up is not None else None
            ru_fast += ((a.runner_up.clip, a.runner_up.frame) if a.runner_up is not None else None) == rb
            ru_exact += ((x.runner_up.clip, x.runner_up.frame) if x.runner_up is not None else None) == rb
        n = len(queries)
        agree = same == n
        note = (f"{what}, {idx.n_frames} frames, {idx.n_unique} unique (T = {idx.tolerance:g}); {n} queries of {L} "
                f"frames; same best as exhaustive in {same}/{n}; frame pairs compared {pairs} vs {pairs_ex} "
                f"({pairs_ex / pairs:.1f}x fewer; of them {exact} exact, the rest dropped on the bound stage); "
                f"per query {ours / n * 1e3:.2f} vs {peer / n * 1e3:.2f} ms CPU; load {load0:.1f}-{os.getloadavg()[0]:.1f}")
        row = result(f"impact search, unique frames, {n} queries x {L} frames", ours,
                     "exhaustive search (same kernel, every window)", peer, "ratio >= 10", note)
        row["passed"] = bool(agree and row["ratio"] >= 10)
        rows.append(row)
        rows.append(result(f"impact search, matching only, {n} queries", ours_m,
                           "exhaustive search, matching only", peer_m, None,
                           "stats['seconds_matching']: the query window's features (the same for both) left out"))
        rows.append(result(f"impact search, runner_up='exact', {n} queries", ours_x,
                           "exhaustive search (same kernel, every window)", peer, None,
                           f"exhaustive runner-up in {ru_exact}/{n} (default 'fast': {ru_fast}/{n}); frame pairs "
                           f"{pairs_x} vs {pairs_ex} ({pairs_ex / max(pairs_x, 1):.2f}x fewer); optional, the default "
                           f"keeps the unique-frame pruning for the runner-up too"))
        # ------------------------------------------------------------ index build: linear in frames
        files = [p for p in sorted(Path(lib).rglob("*")) if p.is_file()]
        per_frame = []
        for k in ((1, 2) if quick else (1, 2, 4)):
            tmp = Path(tempfile.mkdtemp(prefix="bench_impact_rep_"))
            try:
                chars = Path(lib).parent / "skeletons"            # DeepMimic character files, one level up
                if chars.is_dir():
                    (tmp / "skeletons").mkdir()
                    for f in chars.glob("*character*.txt"):
                        shutil.copy(f, tmp / "skeletons" / f.name)
                for i in range(k):
                    for f in files:
                        (tmp / f"copy{i}").mkdir(exist_ok=True)
                        shutil.copy(f, tmp / f"copy{i}" / f.name)
                t, built = best_of(lambda _: build_index(tmp, skeleton, progress=False, use_cache=False),
                                   repeat=1 if quick else 3)
                per_frame.append(t / built.n_frames)
                r = result(f"impact index build, {built.n_frames} frames ({k}x library, no cache)", t, None, None,
                           None, f"{t / built.n_frames * 1e6:.0f} us/frame; {built.n_unique} unique frames")
                if k > 1:
                    r["passed"] = bool(per_frame[-1] <= 1.5 * per_frame[0])
                    r["goal"] = "time per frame within 1.5x of the 1x library's (linear)"
                rows.append(r)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        t, c = best_of(lambda _: build_index(lib, skeleton, cache_dir=cache, progress=False), repeat=repeat)
        rows.append(result(f"impact index reload from cache, {c.n_frames} frames", t, None, None, None,
                           "hash every clip's bytes, read the per-clip .npz files"))
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        if "bench_impact_lib_" in str(lib):
            shutil.rmtree(lib, ignore_errors=True)
    return rows


def _window(q, L):
    m, s = q
    return m, s, s + L


def _best_cpu(fn, repeat: int):
    """Least CPU time (``time.process_time``) of ``fn()`` over ``repeat`` calls, and its result: on
    this shared 2-core machine the wall time of a 20 ms call is inflated 2-3x by preemption."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def _best_matching(fn, repeat: int) -> float:
    return min(fn().stats["seconds_matching"] for _ in range(repeat))


def run(quick: bool = False) -> list[dict]:
    rows = []
    row = _response_row(quick)
    if row is not None:
        rows.append(row)
    return rows + _search_rows(quick)
