"""``mocomp batch COMMAND INPUT_DIR_OR_GLOB -o OUT_DIR [COMMAND options] [--workers N | --scheduler
tcp://HOST:PORT] [--resume]``: a command over every clip of a folder on Dask (:mod:`mocomp.batch`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _add_batch_options(p: argparse.ArgumentParser) -> None:
    from ._common import int_in

    p.add_argument("-o", "--out", metavar="OUT_DIR",
                   help="output folder: clips/<clip>/ (each clip's outputs, report.json, printed summary, row.json), "
                        "results.parquet and results.csv (one row per input file), batch.json")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int_in(0, 512), metavar="N",
                   help="worker processes of the local Dask cluster (default: one per core; 0: no cluster, one clip "
                        "after the other in this process, for debugging: a crash there ends the batch)")
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run on an existing Dask cluster (started with `dask scheduler` and `dask worker`; the "
                        "workers must see INPUT and OUT_DIR at the same paths: a shared filesystem)")
    p.add_argument("--resume", action="store_true",
                   help="keep the clips a previous run of the same batch completed (their row.json); run the rest")
    p.add_argument("--retry-failed", action="store_true",
                   help="with --resume: also re-run the clips that failed or crashed")
    p.add_argument("--output-type", metavar="EXT",
                   help="type of the main output where the command offers several (render: png (default, a phase "
                        "filmstrip), mp4, gif)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def register(sub) -> None:
    from ..batch import COMMANDS

    p = sub.add_parser(
        "batch", help="run a command over every clip of a folder on Dask (results.parquet, --resume)",
        allow_abbrev=False,
        usage="mocomp batch COMMAND INPUT_DIR_OR_GLOB -o OUT_DIR [COMMAND options] [--workers N | --scheduler "
              "tcp://HOST:PORT] [--resume [--retry-failed]] [--output-type EXT] [--no-progress]",
        description="Run a mocomp command over every clip of a folder (recursively) or glob with dask.distributed: "
                    "a local cluster of one worker process per core, or an existing cluster (--scheduler). The "
                    "command's own options follow the input (file options such as --plot take a file name, "
                    "written into each clip's folder). Every input file is one row of OUT_DIR/results.parquet "
                    "(and .csv): status ok / failed (the command's error) / crashed (its worker died) / "
                    "skipped (not a motion: .asf skeletons, C3D markers, DeepMimic character files, other "
                    "files, with the reason), the command's time and its report's key numbers. A failing or "
                    "crashing clip never stops the batch. Outputs are written atomically (a folder renamed "
                    "when complete), so --resume after a killed run redoes only the unfinished clips. "
                    "Commands: " + "; ".join(f"{n}: {s.help}" for n, s in COMMANDS.items()) + "; impact-index: "
                    "INPUT is the reaction library, every clip indexed into the cache on the workers, then merged "
                    "(OUT_DIR/index.json, results.parquet; resuming is the cache itself).",
        epilog="example: mocomp batch audit $MOCOMP_DATA_DIR -o audits --workers 2 --threshold penetration=0.03")
    p.add_argument("batch_command", choices=sorted([*COMMANDS, "impact-index"]), metavar="COMMAND",
                   help="the command to run: " + ", ".join(COMMANDS) + ", impact-index (the impact search's library "
                        "index: per-clip features and unique frames on the workers, into the content-addressed cache; "
                        "options as `mocomp impact-index`: --victim, --tolerance, --fps, --cache)")
    p.add_argument("input", metavar="INPUT_DIR_OR_GLOB",
                   help="a folder (every file below it), a glob ('data/flips/*.bvh', 'data/**/*.amc') or a file")
    _add_batch_options(p)
    p.__class__ = _batch_parser_class()  # options it does not know are the command's (its parser checks them)
    p.set_defaults(func=run)


def _batch_parser_class():
    from . import Parser

    class BatchParser(Parser):
        """The batch command's parser: the arguments it does not know are the command's options
        (``args.command_options``, in their order), not an error; its own options are checked at
        parse time wherever they stand."""

        def parse_known_args(self, args=None, namespace=None):
            ns, extras = super().parse_known_args(args, namespace)
            ns.command_options = list(getattr(ns, "command_options", None) or []) + list(extras)
            return ns, []

    return BatchParser


def _run_impact_index(args, options: list[str]) -> int:
    """``mocomp batch impact-index LIBRARY -o OUT [--victim FILE] [--tolerance T] [--fps HZ] [--cache DIR]``:
    the options are checked by ``mocomp impact-index``'s own parser."""
    import contextlib
    import io as _io

    from .. import io
    from ..batch.impact_index import build_index_batch
    from . import build_parser
    from .impact_index import _majority_skeleton

    if args.output_type is not None:
        raise ValueError("--output-type: impact-index writes the index cache (no output type to choose)")
    if args.retry_failed:
        raise ValueError("--retry-failed: impact-index re-reads every clip each run (the cache keeps the finished "
                         "ones), so there is nothing to retry")
    err = _io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            ns = build_parser().parse_args(["impact-index", args.input, *options])
    except SystemExit as e:
        if e.code:
            msg = err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else f"exit {e.code}"
            raise ValueError(f"options for impact-index: {msg.split(': error: ', 1)[-1]}") from None
        raise
    if ns.json:
        raise ValueError("--json: in a batch the index summary is OUT_DIR/index.json")
    skeleton = io.load(ns.victim).skeleton if ns.victim else _majority_skeleton(Path(args.input))
    res = build_index_batch(args.input, skeleton, cache_dir=ns.cache, tolerance=ns.tolerance, fps=ns.fps,
                            workers=args.workers, scheduler=args.scheduler, out_dir=args.out,
                            progress=not args.no_progress)
    print("\n".join(res.summary_lines()))
    return 0


def run(args) -> int:
    from ..batch import run_batch

    options = list(args.command_options)
    if args.out is None:
        raise ValueError("-o OUT_DIR is required")
    if args.batch_command == "impact-index":
        return _run_impact_index(args, options)
    if args.retry_failed and not args.resume:
        raise ValueError("--retry-failed goes with --resume")
    res = run_batch(args.batch_command, args.input, args.out, options, workers=args.workers,
                    scheduler=args.scheduler, resume=bool(args.resume), retry_failed=bool(args.retry_failed),
                    output_type=args.output_type, progress=not args.no_progress)
    for n in res.notes:
        print(f"note: {n}", file=sys.stderr)
    print("\n".join(res.summary_lines()))
    return 0
