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
