"""``mocomp batch audit`` on Dask (issue 20 section 2): throughput with 1 and 2 workers, and the
overhead per clip against a plain loop.

Input: every file of the shared data folder (``MOCOMP_DATA_DIR``; 91 files, 80 motions: BVH,
ASF/AMC, DeepMimic; the 11 others are skipped rows) in full mode, its ``reactions/`` and
``skeletons/`` folders (15 motions, 5 skipped files; links in a temporary folder) in ``--quick``
mode. Without the data folder: 16 BVH files written from the embedded examples.

Rows (each Dask variant runs twice, interleaved with the others, the best run used; a batch is
long and its first clips would pay the workers' imports, which the warm-up at the cluster's start
takes instead):

- ``batch audit, 1 worker``: :func:`mocomp.batch.run_batch` from the first submission to the last
  row (``BatchResult.run_seconds``: the cluster up and warm; its start, run in a background thread
  while the inputs are classified, is the last row); the note gives clips/s.
- ``batch audit, 2 workers``: the same on two worker processes; peer = the 1-worker row, so
  ``ratio`` is the speed-up. Goal ``ratio >= 1.6`` (near-linear on 2 cores, issue 20). On a host
  whose 2 cores are shared with other jobs the second worker competes with them: the note gives
  the load average before and after, read the row with it.
- ``batch audit, 2 workers, adaptive chunks vs one clip per task``: the A/B of chunking, the two
  alternated in this process.
- ``batch overhead per clip``: (1-worker batch time - plain loop time) / clips; peer = the plain
  loop's time per clip: ``mocomp.cli.main(["audit", CLIP, "--report", R])`` in one process, one
  clip after the other, output discarded (what a researcher's for-loop does). Goal ``ours_s <=
  0.05`` s per clip.
- ``batch overhead per clip without Dask``: the same with ``workers=0`` (the batch's per-clip work
  in this process, no cluster), separating the batch's file handling from Dask's.
- ``batch fixed cost``: the first local cluster's start and warm-up (forkserver start and its one
  import of mocomp included; later clusters in the same process reuse the forkserver); the note
  gives the whole 1-worker batch, start included, against the plain loop, per clip.

The plain loop and the ``workers=0`` batch run in each round too, so that a change of the host's
load touches every variant.

Measured (2026-12-02, full mode, 80 clips, load average 1.3-1.5 on the 2 cores; other helpers'
jobs idle at that moment): 1 worker 2.89 s, 2 workers 1.59 s: speed-up 1.82 (PASS); overhead
10.3 ms per clip over the plain loop's 25.8 ms (PASS); adaptive chunks 1.59 s vs one clip per task
1.88 s (2 workers, interleaved); first cluster start + warm-up 2.4 s, later ones 0.1-0.3 s. Before
this change (same host, load 1.3-1.6, one clip per task, spawned workers, the start inside the
timed run): 1 worker 6.15 s, 2 workers 6.42 s (1.0x), overhead 52.6 ms per clip. At load 4.5-7.4
the same benchmark gave 1 worker 5.55 s, 2 workers 9.23 s (0.6x: the audits' own time summed over
clips went from 5.0 s to 16.4 s with the second worker, i.e. it got no second core). See
docs/batch.md.
"""
from __future__ import annotations

import contextlib
import io
import os
import tempfile
import time
from pathlib import Path


def _inputs(tmp: Path, quick: bool) -> tuple[Path, str]:
    d = os.environ.get("MOCOMP_DATA_DIR")
    if d and Path(d).is_dir():
        root = Path(d)
        if not quick:
            return root, f"the shared data folder {root}"
        src = tmp / "in"
        for pat in ("reactions/*", "skeletons/*"):
            for p in sorted(root.glob(pat)):
                q = src / p.relative_to(root)
                q.parent.mkdir(parents=True, exist_ok=True)
                q.symlink_to(p)
        return src, f"{root}/reactions + skeletons (links)"
    from mocomp import datasets
    from mocomp.io import write_bvh

    src = tmp / "synth"
    src.mkdir()
    names = sorted(datasets.examples())
    for i in range(16):
        name = names[i % len(names)]
        write_bvh(datasets.load(name), src / f"{name}_{i:02d}.bvh")
    return src, "16 BVH files of the embedded examples"


def _plain_loop(files) -> float:
    from mocomp.cli import build_parser, main

    build_parser()  # imports, as the batch's workers do before their first clip
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        for i, f in enumerate(files):
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                main(["audit", str(f.path), "--report", str(Path(d) / f"r{i}.json")])
        return time.perf_counter() - t0


def run(quick: bool) -> list[dict]:
    from mocomp.batch import discover, run_batch
    from timing import result

    rows = []
    with tempfile.TemporaryDirectory() as tmpd:
        tmp = Path(tmpd)
        src, what = _inputs(tmp, quick)
        files = [f for f in discover(src) if f.is_motion]
        n = len(files)
        load0 = os.getloadavg()
        runs: dict = {}
        loops, inproc = [], []
        k = 0

        def batch(w, chunk=None):
            nonlocal k
            k += 1
            t0 = time.perf_counter()
            res = run_batch("audit", src, tmp / f"out{k}", workers=w, progress=False, chunk=chunk)
            return res, time.perf_counter() - t0

        # interleaved, twice, so that the host's changing load touches every variant alike; the best
        # of the two rounds is used for each
        variants = (("1", 1, None), ("2", 2, None), ("2/one clip per task", 2, 1))
        for _ in range(1 if quick else 2):
            loops.append(_plain_loop(files))
            inproc.append(batch(0)[0].run_seconds)
            for label, w, chunk in variants:
                runs.setdefault(label, []).append(batch(w, chunk))
        load1 = os.getloadavg()
        load = f"load average {load0[0]:.1f} before, {load1[0]:.1f} after (2 cores)"
        t_loop, t_in = min(loops), min(inproc)
        best = {label: min(v, key=lambda rw: rw[0].run_seconds) for label, v in runs.items()}

        def times(label):
            return " / ".join(f"{r.run_seconds:.1f}" for r, _ in runs[label])

        r1 = best["1"][0]
        for label in ("1", "2"):
            res, wall = best[label]
            c = res.counts()
            w = int(label)
            rows.append(result(
                f"batch audit, {w} worker{'s' if w > 1 else ''}, {n} clips", res.run_seconds,
                peer="batch audit, 1 worker" if w == 2 else None, peer_s=r1.run_seconds if w == 2 else None,
                goal="ratio >= 1.6" if w == 2 else None,
                note=f"{n / res.run_seconds:.2f} clips/s once the cluster is up (runs {times(label)} s, best used); "
                     f"{c.get('ok', 0)} ok, {c.get('failed', 0)} failed, {c.get('skipped', 0)} skipped; adaptive "
                     f"chunks; the cluster's start and warm-up {res.start_seconds:.1f} s ran beside the input "
                     f"classification ({res.start_waited:.1f} s waited for), whole batch wall {wall:.1f} s; command "
                     f"time summed over clips {res.table['seconds'].sum():.1f} s; input: {what}; {load}"))
        one, _ = best["2/one clip per task"]
        rows.append(result(
            "batch audit, 2 workers, adaptive chunks vs one clip per task", best["2"][0].run_seconds,
            peer="one clip per task (chunk=1)", peer_s=one.run_seconds,
            note=f"interleaved in this process: adaptive {times('2')} s, one clip per task {times('2/one clip per task')} "
                 f"s; {load}"))
        rows.append(result(
            "batch overhead per clip (1 worker vs plain loop)", (r1.run_seconds - t_loop) / n,
            peer="plain loop of mocomp.cli.main audit, per clip", peer_s=t_loop / n, goal="ours_s <= 0.05",
            note=f"plain loop {' / '.join(f'{x:.1f}' for x in loops)} s for {n} clips (best used), batch on 1 "
                 f"worker {times('1')} s (best used; from the first submission, the cluster up and warm), batch in "
                 f"this process (workers=0) {' / '.join(f'{x:.1f}' for x in inproc)} s; {load}"))
        rows.append(result(
            "batch overhead per clip without Dask (workers=0 vs plain loop)", (t_in - t_loop) / n,
            peer="plain loop of mocomp.cli.main audit, per clip", peer_s=t_loop / n,
            note="the batch's own per-clip work: captured output, report/stdout/row.json files, the folder "
                 f"renamed, the row read back; {load}"))
        order = sorted((r for v in runs.values() for r in v), key=lambda rw: rw[0].started)
        starts = [r.start_seconds for r, _ in order]
        waited = [r.start_waited for r, _ in order]
        r1w = min(runs["1"], key=lambda rw: rw[0].run_seconds)[1]
        rows.append(result(
            "batch fixed cost: local cluster start + workers' warm-up, first cluster of the process", starts[0],
            note=f"the first includes the forkserver's start and its one import + warm-up of mocomp; in a background "
                 f"thread beside the inputs' classification; starts in run order {' / '.join(f'{x:.1f}' for x in starts)}"
                 f" s, of which the batch waited {' / '.join(f'{x:.1f}' for x in waited)} s; the whole 1-worker batch "
                 f"(start, classification, tables included) {r1w:.1f} s against the plain loop's {t_loop:.1f} s: "
                 f"{1e3 * (r1w - t_loop) / n:.0f} ms per clip; {load}"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    for r in run("--quick" in sys.argv):
        print(r)
