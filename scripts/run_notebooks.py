"""Execute every notebook in a folder end to end (CI), the way ``mocomp reproduce`` does.

A thin front end of :func:`mocomp.reproduce.runner.reproduce` (papermill, each
notebook's ``results_path`` pointed into the report folder, so nothing is
written next to the notebooks): the real data when ``MOCOMP_DATA_DIR`` is set,
the embedded data otherwise. The report goes to ``--out`` (a temporary folder,
removed, by default). Exit status 1 when a notebook fails or writes no results.
``mocomp reproduce -o DIR`` is the same run with the browsable report kept.

Usage: python scripts/run_notebooks.py notebooks [--timeout 900] [--jobs 2] [--out DIR]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path


def main() -> int:
    from mocomp.reproduce.runner import reproduce

    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("--timeout", type=float, default=900, help="seconds per cell")
    ap.add_argument("--jobs", type=int, default=2, help="notebooks at once (default 2)")
    ap.add_argument("--out", type=Path, default=None, help="keep the report here (default: a temporary folder)")
    args = ap.parse_args()
    data = os.environ.get("MOCOMP_DATA_DIR") or None
    with tempfile.TemporaryDirectory(prefix="run_notebooks_") as tmp:
        out = reproduce(args.out or tmp, notebooks=Path(args.folder), data=Path(data) if data else None,
                        jobs=args.jobs, timeout=args.timeout, progress=True)
    bad = [r for r in out["records"] if r.status != "ok" or r.results_error]
    for r in out["records"]:
        print(f"{'ok' if r not in bad else 'FAIL':5s} {r.name}  {r.seconds:.1f} s  {len(r.rows)} rows"
              + (f"\n{r.error_detail or r.error or r.results_error}" if r in bad else ""), flush=True)
    if bad:
        print(f"{len(bad)} notebook(s) failed: {[r.name for r in bad]}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
