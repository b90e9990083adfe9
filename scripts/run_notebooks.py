"""Execute every notebook in a folder end to end (CI). Outputs are not saved.

Usage: python scripts/run_notebooks.py notebooks [--timeout 900]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("--timeout", type=int, default=900, help="seconds per cell")
    args = ap.parse_args()
    books = sorted(Path(args.folder).glob("*.ipynb"))
    if not books:
        print(f"no notebooks in {args.folder}", file=sys.stderr)
        return 1
    failed = []
    for nb_path in books:
        t0 = time.time()
        nb = nbformat.read(nb_path, as_version=4)
        client = NotebookClient(nb, timeout=args.timeout, kernel_name="python3",
                                resources={"metadata": {"path": str(nb_path.parent)}})
        try:
            client.execute()
            print(f"ok    {nb_path.name}  {time.time() - t0:.1f} s", flush=True)
        except Exception as e:  # report every failing notebook, then fail
            failed.append(nb_path.name)
            print(f"FAIL  {nb_path.name}  {time.time() - t0:.1f} s\n{e}", flush=True)
    if failed:
        print(f"{len(failed)} notebook(s) failed: {failed}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
