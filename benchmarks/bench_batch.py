"""``mocomp batch audit`` on Dask (issue 20 section 2): throughput with 1 and 2 workers, and the
overhead per clip against a plain loop.

Input: every file of the shared data folder (``MOCOMP_DATA_DIR``; 91 files, 80 motions: BVH,
ASF/AMC, DeepMimic; the 11 others are skipped rows) in full mode, its ``reactions/`` and
``skeletons/`` folders (15 motions, 5 skipped files; links in a temporary folder) in ``--quick``
mode. Without the data folder: 16 BVH files written from the embedded examples.

Rows (``ours_s`` is one wall-clock run, not a best-of: a batch is long and its first clips pay the
workers' imports once, as in real use):

- ``batch audit, 1 worker``: :func:`mocomp.batch.run_batch` from the first submission to the last
  row (``BatchResult.run_seconds``: the local cluster's start, ~5-20 s on this host, is in the
  note, not in the time); the note gives clips/s.
- ``batch audit, 2 workers``: the same on two worker processes; peer = the 1-worker row, so
  ``ratio`` is the speed-up. Goal ``ratio >= 1.6`` (near-linear on 2 cores, issue 20). On a host
  whose 2 cores are shared with other jobs the second worker competes with them: the note gives
  the load average before and after, read the row with it.
- ``batch overhead per clip``: (1-worker batch time - plain loop time) / clips; peer = the plain
  loop's time per clip: ``mocomp.cli.main(["audit", CLIP, "--report", R])`` in one process, one
  clip after the other, output discarded (what a researcher's for-loop does). The batch adds the
  task round trip, the captured output and the per-clip files (report, stdout, row.json, the
  atomic rename), and each worker process pays the first call of the audit's code once (the
  loop's process too). Goal ``ours_s <= 0.05`` s per clip.
- ``batch overhead per clip without Dask``: the same with ``workers=0`` (the batch's per-clip work
  in this process, no cluster), separating the batch's file handling from Dask's.

The plain loop and the ``workers=0`` batch run before and after the two Dask runs (the best of the
two is used), so that a change of the host's load touches every variant.

Measured (2026-12-02, full mode, 80 clips, load average 6-7 on the 2 cores: 8 helpers' jobs beside
it): plain loop 11.5 s (0.14 s/clip), workers=0 9.1 s, 1 worker 27.2 s (command time 17.3 s of it),
2 workers 50.1 s (command time 59.3 s: the audits ran 3.4x slower with the second worker competing
with the host's other jobs), so speed-up 0.54 (FAIL) and overhead 0.20 s/clip (FAIL). An earlier run
at load 8-11: 1 worker 103 s, 2 workers 93 s, plain loop 40.5 s. See docs/batch.md.
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
        runs, loops, inproc = {}, [], []
        k = 0

        def batch(w):
            nonlocal k
            k += 1
            t0 = time.perf_counter()
            res = run_batch("audit", src, tmp / f"out{k}", workers=w, progress=False)
            return res, time.perf_counter() - t0

        # alternated, so that the host's changing load touches every variant alike
        loops.append(_plain_loop(files))
        inproc.append(batch(0)[0].run_seconds)
        for w in (1, 2):
            runs[w] = batch(w)
        loops.append(_plain_loop(files))
        inproc.append(batch(0)[0].run_seconds)
        load1 = os.getloadavg()
        load = f"load average {load0[0]:.1f} before, {load1[0]:.1f} after (2 cores)"
        t_loop, t_in = min(loops), min(inproc)
        r1 = runs[1][0]
        for w, (res, wall) in runs.items():
            c = res.counts()
            rows.append(result(
                f"batch audit, {w} worker{'s' if w > 1 else ''}, {n} clips", res.run_seconds,
                peer="batch audit, 1 worker" if w == 2 else None, peer_s=r1.run_seconds if w == 2 else None,
                goal="ratio >= 1.6" if w == 2 else None,
                note=f"{n / res.run_seconds:.2f} clips/s; {c.get('ok', 0)} ok, {c.get('failed', 0)} failed, "
                     f"{c.get('skipped', 0)} skipped; wall with the cluster's start {wall:.1f} s; command time "
                     f"summed over clips {res.table['seconds'].sum():.1f} s; input: {what}; {load}"))
        rows.append(result(
            "batch overhead per clip (1 worker vs plain loop)", (r1.run_seconds - t_loop) / n,
            peer="plain loop of mocomp.cli.main audit, per clip", peer_s=t_loop / n, goal="ours_s <= 0.05",
            note=f"plain loop {' / '.join(f'{x:.1f}' for x in loops)} s for {n} clips (best used), batch on 1 "
                 f"worker {r1.run_seconds:.1f} s, batch in this process (workers=0) "
                 f"{' / '.join(f'{x:.1f}' for x in inproc)} s; {load}"))
        rows.append(result(
            "batch overhead per clip without Dask (workers=0 vs plain loop)", (t_in - t_loop) / n,
            peer="plain loop of mocomp.cli.main audit, per clip", peer_s=t_loop / n,
            note="the batch's own per-clip work: captured output, report/stdout/row.json files, the folder "
                 f"renamed, the row read back; {load}"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    for r in run("--quick" in sys.argv):
        print(r)
