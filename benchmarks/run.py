#!/usr/bin/env python
"""Run every ``benchmarks/bench_*.py`` in one process and print ours-vs-peer ratios.

Each module exposes ``run(quick: bool) -> list[dict]``; each dict has the keys
``name``, ``ours_s`` (seconds), ``peer`` (the named peer, or None), ``peer_s``,
``ratio`` (``peer_s / ours_s``: how many times faster ours is), ``goal`` and
``note``. A goal is a condition on the row's own fields, ``"ours_s <= 0.05"`` or
``"ratio >= 10"`` (fields ``ours_s``, ``peer_s``, ``ratio``; operators ``<=``,
``<``, ``>=``, ``>``), or None. A row may carry ``passed`` to decide itself.

Usage::

    python benchmarks/run.py              # all benchmarks, full sizes
    python benchmarks/run.py --quick      # smaller sizes (CI smoke run)
    python benchmarks/run.py --only fk    # one module (name with or without bench_)
    python benchmarks/run.py --json out.json

Exit status: 0 when every goal passes, 1 when a goal fails or a module raises.
"""
from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import math
import os
import platform
import re
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
KEYS = ("name", "ours_s", "peer", "peer_s", "ratio", "goal", "note")
_GOAL = re.compile(r"^\s*(ours_s|peer_s|ratio)\s*(<=|>=|<|>)\s*([-+0-9.eE]+)\s*$")
_OPS = {"<=": lambda a, b: a <= b, ">=": lambda a, b: a >= b, "<": lambda a, b: a < b, ">": lambda a, b: a > b}


def discover(only: list[str] | None = None) -> list[Path]:
    """``bench_*.py`` files next to this script, sorted; ``only`` filters by name."""
    files = sorted(HERE.glob("bench_*.py"))
    if only:
        wanted = {o.removeprefix("bench_").removesuffix(".py") for o in only}
        unknown = wanted - {f.stem.removeprefix("bench_") for f in files}
        if unknown:
            names = ", ".join(f.stem.removeprefix("bench_") for f in files)
            raise SystemExit(f"run.py: error: no benchmark named {', '.join(sorted(unknown))} (have: {names})")
        files = [f for f in files if f.stem.removeprefix("bench_") in wanted]
    return files


def check_goal(row: dict) -> bool | None:
    """True/False when the row has a goal that can be evaluated, else None."""
    if "passed" in row and row["passed"] is not None:
        return bool(row["passed"])
    goal = row.get("goal")
    if not goal:
        return None
    m = _GOAL.match(str(goal))
    if not m:
        raise ValueError(f"benchmark {row.get('name')!r}: goal {goal!r} is not '<field> <op> <number>' "
                         "with field ours_s, peer_s or ratio")
    value = row.get(m.group(1))
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return False
    return _OPS[m.group(2)](float(value), float(m.group(3)))


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(f"_bench_{path.stem}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    if not callable(getattr(mod, "run", None)):
        raise TypeError(f"{path.name} has no run(quick) function")
    return mod


def run_all(files: list[Path], quick: bool, stream=sys.stdout) -> list[dict]:
    """Run the modules; a module that raises gives one row with ``error`` set."""
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    rows: list[dict] = []
    for f in files:
        module = f.stem.removeprefix("bench_")
        print(f"[{module}] running ...", file=stream, flush=True)
        t0 = time.perf_counter()
        try:
            out = _load(f).run(quick)
            for r in out:
                missing = [k for k in ("name", "ours_s") if k not in r]
                if missing:
                    raise ValueError(f"{f.name}: result row lacks {missing}: {r}")
                row = {k: r.get(k) for k in KEYS}
                row.update({k: v for k, v in r.items() if k not in KEYS})
                if row["ratio"] is None and row["peer_s"] is not None and row["ours_s"]:
                    row["ratio"] = row["peer_s"] / row["ours_s"]
                row["module"] = module
                row["passed"] = check_goal(row)
                rows.append(row)
        except Exception as e:  # report and carry on with the other modules
            rows.append({**{k: None for k in KEYS}, "name": module, "module": module, "passed": False,
                         "error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()})
        print(f"[{module}] done in {time.perf_counter() - t0:.1f} s", file=stream, flush=True)
    return rows


def _fmt_s(x) -> str:
    if x is None:
        return "-"
    if x < 1e-3:
        return f"{x * 1e6:.0f} us"
    if x < 1:
        return f"{x * 1e3:.1f} ms"
    return f"{x:.2f} s"


def format_table(rows: list[dict]) -> str:
    head = ["benchmark", "ours", "peer", "peer time", "ratio", "goal", "status"]
    body = []
    for r in rows:
        status = {True: "PASS", False: "FAIL", None: "-"}[r.get("passed")]
        if r.get("error"):
            status = "ERROR"
        ratio = r.get("ratio")
        body.append([str(r["name"]), _fmt_s(r.get("ours_s")), str(r.get("peer") or "-"), _fmt_s(r.get("peer_s")),
                     "-" if ratio is None else f"{ratio:.1f}x", str(r.get("goal") or "-"), status])
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
    line = "  ".join(h.ljust(w) for h, w in zip(head, widths))
    out = [line, "-" * len(line)]
    out += ["  ".join(c.ljust(w) for c, w in zip(b, widths)) for b in body]
    notes = [f"  {r['name']}: {r['note']}" for r in rows if r.get("note")]
    errors = [f"  {r['name']}: {r['error']}" for r in rows if r.get("error")]
    if notes:
        out += ["", "notes:"] + notes
    if errors:
        out += ["", "errors:"] + errors
    return "\n".join(out)


def host_speed(repeats: int = 5) -> dict:
    """Fixed reference workloads timed on this host (best of ``repeats``), so absolute times of
    different runs can be compared: hosts here differ (and a shared host slows down) by 2-3x,
    and our rows and their peers slow down together.

    ``python_loop_s``: a 2,000,000-step pure-Python integer loop; ``numpy_s``: 200 sine + sum
    passes over a 100,000-element float64 array (single-threaded elementwise numpy)."""
    import numpy

    def loop():
        s = 0
        for i in range(2_000_000):
            s += i
        return s

    a = numpy.linspace(0.0, 1.0, 100_000)

    def elementwise():
        t = 0.0
        for _ in range(200):
            t += float(numpy.sin(a).sum())
        return t

    out = {}
    for key, fn in (("python_loop_s", loop), ("numpy_s", elementwise)):
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - t0)
        out[key] = best
    return out


def machine_info(speed: bool = True) -> dict:
    import numpy

    info = {"python": platform.python_version(), "numpy": numpy.__version__, "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None}
    if speed:
        info["host_speed"] = host_speed()
    return info


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Time mocomp against named peers (ratios in one run).")
    ap.add_argument("--quick", action="store_true", help="smaller problem sizes (smoke run)")
    ap.add_argument("--only", action="append", metavar="NAME",
                    help="run only this benchmark module (e.g. fk or bench_fk); repeatable")
    ap.add_argument("--json", metavar="OUT", help="also write the results as JSON to OUT")
    args = ap.parse_args(argv)
    files = discover(args.only)
    if not files:
        print("run.py: no benchmarks found", file=sys.stderr)
        return 1
    rows = run_all(files, args.quick, stream=sys.stderr)
    print(format_table(rows))
    if args.json:
        doc = {"created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               "quick": args.quick, "machine": machine_info(),
               "results": [{k: v for k, v in r.items() if k != "traceback"} for r in rows]}
        Path(args.json).write_text(json.dumps(doc, indent=2, default=float) + "\n")
    return 0 if all(r.get("passed") is not False for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
