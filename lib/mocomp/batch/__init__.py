"""Batch work over a motion library on Dask (issue 20 section 2): ``mocomp batch COMMAND INPUT -o OUT``.

- :func:`run_batch` maps a ``mocomp`` command over every clip of a folder or glob (inputs:
  :mod:`mocomp.batch.inputs`; commands and the key numbers kept: :mod:`mocomp.batch.commands`;
  one clip on a worker, atomic outputs and the done-marker: :mod:`mocomp.batch.clip`) and writes
  ``results.parquet`` / ``results.csv`` with one row per input file.
- :func:`map_items` / :func:`open_client` (:mod:`mocomp.batch.engine`) are the mechanism itself:
  any module-level function over independent items, on a LocalCluster or an existing Dask
  cluster, each item's outcome (value, error, or the crash of its worker) reported, never a
  stopped run. ``mocomp study render`` renders its stimuli with it.

See docs/batch.md for running against an existing cluster.
"""
from .commands import COMMANDS, CommandSpec
from .engine import Outcome, default_workers, map_items, open_client
from .inputs import InputFile, discover
from .runner import BASE_COLUMNS, TIMING_COLUMNS, BatchResult, compare_tables, read_results, run_batch

__all__ = ["run_batch", "BatchResult", "compare_tables", "read_results", "BASE_COLUMNS", "TIMING_COLUMNS",
           "COMMANDS", "CommandSpec", "discover", "InputFile", "map_items", "open_client", "Outcome",
           "default_workers"]
