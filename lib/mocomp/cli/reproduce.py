"""``mocomp reproduce``: re-run every notebook and write one browsable report of the papers' figures and tables."""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from ._common import positive_float


def register(sub) -> None:
    p = sub.add_parser(
        "reproduce", help="run every notebook (papermill) and write a report: paper numbers beside ours",
        description="Execute every notebook in notebooks/ with papermill (a failing notebook does not stop the "
                    "others), export each to HTML and write REPORT_DIR/index.html: per paper and per figure or "
                    "table the figures, the paper's number beside ours, the difference, the tolerance and the "
                    "status (reproduced / differs / no paper value / failed), with the data, versions, commit "
                    "and run time; REPORT_DIR/results.json and results.csv hold every row. Exit status 1 when a "
                    "notebook failed or (--check-baseline) a row that reproduced no longer does; 0 otherwise.")
    p.add_argument("-o", "--out", required=True, metavar="REPORT_DIR", help="report folder (created)")
    data = p.add_mutually_exclusive_group()
    data.add_argument("--quick", action="store_true",
                      help="the embedded data alone (MOCOMP_DATA_DIR unset for the notebooks)")
    data.add_argument("--data", metavar="DIR", type=Path,
                      help="real-data folder for the notebooks (default: $MOCOMP_DATA_DIR; without either, "
                           "the same as --quick)")
    p.add_argument("--only", action="append", default=[], metavar="NAME",
                   help="run only this notebook (file name or stem; repeat for more)")
    p.add_argument("--notebooks", type=Path, default=None, metavar="DIR",
                   help="notebook folder (default: the source tree's notebooks/)")
    p.add_argument("--jobs", "-j", type=int, default=2,
                   help="notebooks executed at once, each in its own kernel (default 2)")
    p.add_argument("--timeout", type=positive_float, default=900.0,
                   help="seconds one cell may run before its notebook fails (default 900)")
    p.add_argument("--check-baseline", type=Path, default=None, metavar="FILE",
                   help="fail (exit 1) naming every row of FILE (e.g. docs/reproduce_baseline.json) that no "
                        "longer reproduces")
    p.add_argument("--write-baseline", type=Path, default=None, metavar="FILE",
                   help="record this run's reproduced rows in FILE (its section for this data mode)")
    p.add_argument("--no-progress", action="store_true", help="no progress output")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..reproduce.runner import ENV_VAR, reproduce
    from ..reproduce.report import summary

    if args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    if args.quick:
        data = None
    elif args.data is not None:
        data = args.data
    else:
        env = os.environ.get(ENV_VAR)
        data = Path(env) if env else None
    if data is not None and not data.is_dir():
        raise FileNotFoundError(f"{data}: data folder does not exist (--data or ${ENV_VAR})")
    t0 = time.perf_counter()
    out = reproduce(args.out, notebooks=args.notebooks, only=args.only, data=data, jobs=args.jobs,
                    timeout=args.timeout, progress=not args.no_progress, check_baseline=args.check_baseline,
                    write_baseline=args.write_baseline)
    s = summary(out["records"])
    rows = ", ".join(f"{n} {st}" for st, n in s["rows"].items())
    print(f"{s['notebooks']} notebook(s), {s['notebooks_failed']} failed; {s['rows_total']} rows: {rows}; "
          f"{time.perf_counter() - t0:.1f} s ({out['run']['mode']} mode)")
    for r in out["records"]:
        if r.status != "ok":
            print(f"mocomp reproduce: notebook failed: {r.name}: {r.error}", file=sys.stderr)
        elif r.results_error:
            print(f"mocomp reproduce: warning: {r.results_error}", file=sys.stderr)
    for reg in out["regressions"]:
        print(f"mocomp reproduce: regressed: {reg.line()}", file=sys.stderr)
    if args.check_baseline is not None and out["new"]:
        print(f"{len(out['new'])} reproduced row(s) not in {args.check_baseline} (record them with "
              f"--write-baseline)")
    print(f"report: {Path(args.out) / 'index.html'}")
    failed = s["notebooks_failed"] or s["notebooks_without_results"]
    return 1 if failed or out["regressions"] else 0
