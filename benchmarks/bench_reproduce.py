"""``mocomp reproduce``: the whole report (every notebook of ``notebooks/``) end to end.

Issue 20 (section 1). Each row is one ``mocomp reproduce`` command in a fresh
subprocess (its wall time, imports and kernel starts included): the notebooks
run in parallel Jupyter kernels (``--jobs 2``), each exported to HTML, the
figures extracted and the index written. Goals (issue 20): ``--quick`` (the
embedded data alone) under 2 minutes, the run on the shared real data
(``MOCOMP_DATA_DIR``) under 10 minutes, on this 2-core machine. The note gives
the notebooks' own times (longest first), the row counts per status and the
load average before and after: the machine is shared, and a notebook's time
grows with the load (perception_study renders 21 stimuli; momentum_errors and
multiflip render filmstrips). Peer: none.

``--quick`` (of the benchmark runner): one notebook (perception_table2) with
``mocomp reproduce --quick``, no goal: a smoke run of the command.

Measured (2026-12-02): ``mocomp reproduce --quick`` on all 11 notebooks, warm caches, load 1.5-1.8:
46.8 s (notebooks' own times summed 84 s), baseline check passing; with empty caches (a fresh
export of the tree, ``NUMBA_CACHE_DIR``/``MOCOMP_CACHE_DIR``/``XDG_CACHE_HOME`` empty, so numba
compiles and the examples are generated) 108.8 s at load 1.3-3.3 (summed 206 s; momentum_errors
37 s of which 16.5 s is its first restoration's compilation). Quick mode of the two longest
notebooks (``QUICK``: momentum_errors' filmstrips drawn with matplotlib and its straight-leg
restorations reused; perception_study's stimuli at 320x240, 15 fps, 200 bootstrap draws),
before/after alternated with ``--jobs 1``: momentum_errors 21.1/13.9/13.3 s -> 10.5/10.6/10.9 s,
perception_study 49.3/29.2/30.3 s -> 20.8/16.2/20.2 s (load 5.9 -> 1.8 over the six pairs), the
rows unchanged (within 1e-5 relative).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from timing import result

ROOT = Path(__file__).resolve().parents[1]


def _reproduce(args: list[str]) -> tuple[float, dict, list[float], list[float]]:
    env = {k: v for k, v in os.environ.items() if k != "MOCOMP_DATA_DIR"}
    with tempfile.TemporaryDirectory() as tmp:
        load0 = list(os.getloadavg())
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "mocomp", "reproduce", "-o", tmp, "--no-progress", *args],
                             capture_output=True, text=True, cwd=ROOT, env=env, timeout=3600)
        dt = time.perf_counter() - t0
        load1 = list(os.getloadavg())
        if not (Path(tmp) / "results.json").exists():
            raise RuntimeError(f"mocomp reproduce {' '.join(args)} wrote no report: {out.stderr[-2000:]}")
        doc = json.loads((Path(tmp) / "results.json").read_text())
    return dt, doc, load0, load1


def _note(doc: dict, load0, load1) -> str:
    s = doc["summary"]
    books = sorted(doc["notebooks"], key=lambda b: -b["seconds"])
    times = ", ".join(f"{b['notebook'].removesuffix('.ipynb')} {b['seconds']:.0f} s" for b in books[:4])
    return (f"{s['notebooks']} notebooks ({s['notebooks_failed']} failed), {s['rows_total']} rows ("
            + ", ".join(f"{n} {k}" for k, n in s["rows"].items()) + f"); longest: {times}; "
            f"load {load0[0]:.1f} before, {load1[0]:.1f} after, on {os.cpu_count()} CPUs")


def run(quick: bool) -> list[dict]:
    rows = []
    if quick:
        dt, doc, l0, l1 = _reproduce(["--quick", "--only", "perception_table2"])
        return [result("reproduce --quick, perception_table2 only", dt, note=_note(doc, l0, l1))]
    dt, doc, l0, l1 = _reproduce(["--quick", "--jobs", "2"])
    row = result("reproduce --quick (every notebook, embedded data, 2 kernels)", dt, goal="ours_s <= 120",
                 note=_note(doc, l0, l1))
    rows.append(row)
    data = os.environ.get("MOCOMP_DATA_DIR")
    if data:
        dt, doc, l0, l1 = _reproduce(["--data", data, "--jobs", "2"])
        rows.append(result("reproduce on the shared real data (every notebook, 2 kernels)", dt, goal="ours_s <= 600",
                           note=_note(doc, l0, l1)))
    return rows
