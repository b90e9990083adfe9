"""``run_batch``: a command over every clip of a folder on Dask, with resume, the results table
and a summary (``mocomp batch``)."""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import shutil
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from .clip import PARTIAL, ROW_FILE, ClipTask, base_row, read_row, run_clip, write_row_dir
from .commands import COMMANDS, command_argv
from .engine import ClientStarter, map_items
from .inputs import InputFile, discover

__all__ = ["BatchResult", "run_batch", "BASE_COLUMNS", "TIMING_COLUMNS", "compare_tables", "read_results"]

#: columns of every results table, before the command's own (mocomp.batch.commands)
BASE_COLUMNS = ("clip", "format", "command", "status", "exit_code", "error", "warnings", "output", "report",
                "seconds", "started_utc", "worker")
#: columns that differ between two runs of the same batch (left out by :func:`compare_tables`)
TIMING_COLUMNS = ("seconds", "started_utc", "worker")
CONFIG_FILE = "batch.json"


@dataclass
class BatchResult:
    """What :func:`run_batch` did.

    table: the results table (one row per input file, sorted by clip; also ``results.parquet`` and
        ``results.csv`` in ``out_dir``).
    ran: clips run now; resumed: clips whose completed folder was reused (``--resume``).
    seconds: wall time of the whole batch; run_seconds: from the first submission to the last row
        (the cluster up and warm).
    start_seconds: the local cluster's start and the workers' warm-up (in a background thread, beside
        the inputs' classification; NaN when no cluster was started); start_waited: the part of it the
        batch waited for, after its own preparation.
    workers: worker threads of the cluster (0: none was needed).
    started: when the batch started (``time.time()``).
    """

    table: pd.DataFrame
    out_dir: Path
    ran: int = 0
    resumed: int = 0
    seconds: float = 0.0
    run_seconds: float = 0.0
    workers: int = 0
    start_seconds: float = float("nan")
    start_waited: float = 0.0
    started: float = 0.0
    notes: list[str] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {k: int(v) for k, v in self.table["status"].value_counts().items()}

    def summary_lines(self, max_errors: int = 10) -> list[str]:
        t = self.table
        c = self.counts()
        n_motion = len(t) - c.get("skipped", 0)
        cmd = t["command"].iloc[0] if len(t) else "?"
        rate = (self.ran / self.run_seconds) if self.run_seconds > 0 and self.ran else float("nan")
        lines = [f"batch {cmd}: {len(t)} files, {n_motion} clips: {c.get('ok', 0)} ok, {c.get('failed', 0)} failed, "
                 f"{c.get('crashed', 0)} crashed; {c.get('skipped', 0)} skipped (not motions); "
                 f"{self.ran} run now, {self.resumed} resumed"]
        lines.append(f"time: {self.seconds:.1f} s wall ({self.run_seconds:.1f} s running"
                     + (f", {rate:.2f} clips/s " + (f"on {self.workers} worker(s)" if self.workers else "in this process")
                        if math.isfinite(rate) else "")
                     + (f"; command time per clip median {t['seconds'].median():.2f} s, "
                        f"max {t['seconds'].max():.2f} s ({t.loc[t['seconds'].idxmax(), 'clip']})"
                        if t["seconds"].notna().any() else "") + ")"
                     + (f"; cluster start and warm-up {self.start_seconds:.1f} s, beside the inputs' "
                        f"classification ({self.start_waited:.1f} s waited for)"
                        if math.isfinite(self.start_seconds) else ""))
        for col in ("verdict", "out_verdict"):
            if col in t.columns and t[col].notna().any():
                v = t[col].dropna().value_counts()
                lines.append(f"{col.replace('_', ' ')}: " + ", ".join(f"{k} {n}" for k, n in v.items()))
        bad = t[t["status"].isin(("failed", "crashed"))]
        for r in bad.head(max_errors).itertuples():
            lines.append(f"  {r.status} {r.clip}: {r.error}")
        if len(bad) > max_errors:
            lines.append(f"  ... {len(bad) - max_errors} more (see results.csv)")
        lines.append(f"results: {self.out_dir / 'results.parquet'}, {self.out_dir / 'results.csv'}; per clip: "
                     f"{self.out_dir / 'clips'}/<clip>/")
        return lines


def _skip_row(f: InputFile, command: str) -> dict:
    return {"clip": f.clip, "format": f.format, "command": command, "status": "skipped", "error": f.skip_reason}


def _validate(command: str, options: list[str], output_type: str | None) -> None:
    """Parse the command line of a clip with the command's own parser: bad options fail before any
    clip runs (``ValueError`` with the command's one-line message)."""
    from ..cli import build_parser

    spec = COMMANDS[command]
    if output_type is not None and output_type not in spec.output_types:
        allowed = ", ".join(spec.output_types) or "none (its output type is fixed)"
        raise ValueError(f"--output-type {output_type}: {command} writes {allowed}")
    import tempfile

    err = io.StringIO()
    with tempfile.TemporaryDirectory() as d, contextlib.redirect_stderr(err):
        argv, _ = command_argv(spec, Path(d) / "CLIP.bvh", Path(d), list(options), output_type)
        try:
            ns = build_parser().parse_args([command, *argv])
        except SystemExit as e:
            if e.code:
                msg = err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else f"exit {e.code}"
                raise ValueError(f"options for {command}: {msg.split(': error: ', 1)[-1]}") from None
            raise
    if getattr(ns, "threshold", None):  # checked by the commands when they run: check it once here
        from ..audit import AuditThresholds

        try:
            AuditThresholds.from_strings(ns.threshold)
        except (ValueError, KeyError) as e:
            raise ValueError(f"options for {command}: {' '.join(str(e).strip(chr(34)).split())}") from None


def _config(command, options, output_type) -> dict:
    return {"command": command, "options": list(options), "output_type": output_type}


def _check_config(out: Path, cfg: dict, resume: bool) -> None:
    path = out / CONFIG_FILE
    if resume and path.is_file():
        try:
            old = json.loads(path.read_text())
        except ValueError:
            old = None
        if isinstance(old, dict) and {k: old.get(k) for k in cfg} != cfg:
            raise ValueError(f"--resume: {out} holds a batch of {old.get('command')} {' '.join(old.get('options') or [])}"
                             f" (output type {old.get('output_type')}), not of {cfg['command']} "
                             f"{' '.join(cfg['options'])}; use another -o folder or drop --resume")
    tmp = path.with_name(path.name + PARTIAL)
    tmp.write_text(json.dumps(cfg, indent=1) + "\n")
    os.replace(tmp, path)


def _drop_partials(clips_dir: Path) -> int:
    n = 0
    if clips_dir.is_dir():
        for p in sorted(clips_dir.rglob(f"*{PARTIAL}*"), reverse=True):
            if p.is_dir():
                shutil.rmtree(p, ignore_errors=True)
                n += 1
    return n


def _clip_dir(out: Path, clip: str) -> Path:
    return out / "clips" / Path(*clip.split("/"))


#: text columns of every table (the others are numbers; a command's text columns are those its
#: ``columns(None, "")`` does not give as a float)
_TEXT_COLUMNS = ("clip", "format", "command", "status", "error", "output", "report", "started_utc", "worker")


def _table(rows: list[dict], command: str) -> pd.DataFrame:
    """The results table: a fixed schema per command (text columns object with ``None``, the others
    float with NaN), rows sorted by clip."""
    spec = COMMANDS[command]
    own = spec.columns(None, "")
    cols = list(BASE_COLUMNS) + [c for c in spec.column_names if c not in BASE_COLUMNS]
    text = set(_TEXT_COLUMNS) | {c for c, v in own.items() if not isinstance(v, float)}
    df = pd.DataFrame(rows, columns=cols)  # the private key "run" (which run wrote a row) is left out
    df = df.sort_values("clip", kind="stable").reset_index(drop=True)
    for c in df.columns:
        if c in text:
            df[c] = df[c].map(lambda v: v if isinstance(v, str) and v != "" else None).astype(object)
        else:
            df[c] = pd.to_numeric(df[c], errors="coerce").astype(float)
    return df


def _write_table(df: pd.DataFrame, out: Path) -> None:
    for name, write in (("results.parquet", lambda p: df.to_parquet(p, index=False)),
                        ("results.csv", lambda p: df.to_csv(p, index=False, float_format="%.9g"))):
        tmp = out / (name + PARTIAL)
        write(tmp)
        os.replace(tmp, out / name)


def _warm_up() -> None:
    """Import the commands on a worker and make the first call of the reader and the audit (which
    every command runs on its input or output) on an embedded example clip, so that no clip's time
    holds the imports or first calls (~0.5 s). (Not a worker plugin: a plugin's setup runs while a
    restarted worker starts, and a clip that crashes that worker then, while its nanny is still
    starting it, leaves the nanny without restarting it.)"""
    import tempfile

    from .. import datasets
    from ..cli import build_parser, main
    from ..io import write_bvh

    build_parser()
    with tempfile.TemporaryDirectory(prefix="mocomp-batch-warm-") as d:
        clip = Path(d) / "warm.bvh"
        write_bvh(datasets.load("jump"), clip)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            main(["audit", str(clip), "--report", str(Path(d) / "warm.json")])


def _completed(task: ClipTask) -> bool:
    """Whether ``task``'s clip folder is complete, written by this run."""
    row = read_row(Path(task.out_dir))
    return row is not None and row.get("run") == task.run


def read_results(out_dir) -> pd.DataFrame:
    """The results table of a batch folder (``results.parquet``)."""
    return pd.read_parquet(Path(out_dir) / "results.parquet")


def _bar(total: int, desc: str, enabled: bool):
    from tqdm.auto import tqdm

    tty = sys.stderr.isatty()
    return tqdm(total=total, desc=desc, unit="clip", disable=not enabled, file=sys.stderr,
                mininterval=0.5 if tty else 30.0, dynamic_ncols=tty)


def run_batch(command: str, source, out_dir, options=(), *, workers: int | None = None,
              scheduler: str | None = None, resume: bool = False, retry_failed: bool = False,
              output_type: str | None = None, progress: bool = True, client=None,
              chunk: int | None = None) -> BatchResult:
    """Run ``mocomp COMMAND`` on every clip of ``source`` (folder, glob or file), on Dask.

    options: the command's own options, as on its command line (file options take file names).
    workers / scheduler / client: a LocalCluster of that many single-threaded worker processes
        (default: one per core; 0: no cluster, the clips run one after the other in this process,
        where a crash ends the batch), an existing cluster's scheduler address, or an open Client.
    resume: keep every clip whose folder is complete (its ``row.json``); ``retry_failed`` also
        re-runs those that failed or crashed.
    chunk: clips per Dask task (default: adaptive, :func:`mocomp.batch.engine.chunk_sizes`; the
        clips are submitted largest file first).
    A local cluster is started in the background as soon as the command line is checked, while the
    inputs are classified (its start and the workers' warm-up: ``BatchResult.start_seconds``).
    Writes ``out_dir/clips/<clip>/``, ``results.parquet``, ``results.csv`` and ``batch.json``;
    returns a :class:`BatchResult`. A clip that fails or crashes its worker is a row; the batch
    always finishes.
    """
    t_start = time.perf_counter()
    started = time.time()
    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; batch runs: {', '.join(COMMANDS)}")
    options = [str(o) for o in options]
    _validate(command, options, output_type)
    out = Path(out_dir).expanduser()
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"output folder {out} is a file, not a directory")
    in_process = client is None and scheduler is None and workers == 0
    starter = None
    if client is None and not in_process and _may_exist(source):
        # the cluster's workers start and import while the inputs are classified and finished clips
        # read back; closed below when no clip is left to run
        starter = ClientStarter(workers, scheduler, setup=_warm_up)
    try:
        res = _run(command, source, out, options, output_type, resume, retry_failed, progress, client, starter,
                   in_process, t_start, chunk)
        res.started = started
        return res
    finally:
        if starter is not None:
            starter.close()


def _may_exist(source) -> bool:
    import glob as _glob

    text = os.fspath(source)
    return Path(text).expanduser().exists() or _glob.has_magic(text)


def _by_size(tasks: list[ClipTask]) -> list[ClipTask]:
    """Largest input first (a clip's command time grows with its frames): the chunks that end the
    batch hold the small clips, so the workers finish together."""
    def size(t):
        try:
            return os.path.getsize(t.path)
        except OSError:
            return 0
    return sorted(tasks, key=lambda t: (-size(t), t.clip))


def _run(command, source, out, options, output_type, resume, retry_failed, progress, client, starter,
         in_process, t_start, chunk) -> BatchResult:
    files = discover(source, exclude=out)
    out.mkdir(parents=True, exist_ok=True)
    _check_config(out, _config(command, options, output_type), resume)
    res = BatchResult(pd.DataFrame(), out)
    dropped = _drop_partials(out / "clips")
    if dropped:
        res.notes.append(f"removed {dropped} incomplete clip folder(s) of an interrupted run")

    rows: dict[str, dict] = {}
    tasks: list[ClipTask] = []
    run_id = uuid.uuid4().hex[:12]
    for f in files:
        if not f.is_motion:
            rows[f.clip] = _skip_row(f, command)
            continue
        d = _clip_dir(out, f.clip)
        old = read_row(d) if resume else None
        if old is not None and old.get("command") == command and (not retry_failed or old["status"] == "ok"):
            rows[f.clip] = old
            res.resumed += 1
            continue
        tasks.append(ClipTask(f.clip, str(f.path), f.format, command, tuple(options), str(d), output_type, run_id))

    if tasks:
        c = client
        if starter is not None:
            c = starter.get()
            res.start_seconds, res.start_waited = starter.start_seconds, starter.waited_seconds
        elif c is not None:
            c.run(_warm_up)  # imports on every worker before the first clip (a restarted one: in its first)
        if c is not None:
            res.workers = sum(c.nthreads().values())
        bar = _bar(len(tasks), f"batch {command}", progress)
        n_bad = 0
        t_run = time.perf_counter()
        try:
            for o in map_items(run_clip, _by_size(tasks), client=c, workers=0 if in_process else None,
                               name=f"batch-{command}", fetch=False, done=_completed, stall_seconds=120.0,
                               chunk=chunk):
                task = o.item
                final = Path(task.out_dir)
                done = read_row(final)  # the row the worker wrote (run_clip's result stays on the worker)
                if done is not None and done.get("run") == task.run:
                    row = done
                else:  # the task did not complete its folder: the worker died, or run_clip broke
                    row = base_row(task)
                    row.update({"status": o.status if o.status != "ok" else "failed", "run": task.run,
                                "error": o.error or "the clip's task ended without writing its row.json"})
                    for p in final.parent.glob(final.name + PARTIAL + "*"):
                        shutil.rmtree(p, ignore_errors=True)
                    write_row_dir(final, row)
                rows[task.clip] = row
                n_bad += row["status"] != "ok"
                res.ran += 1
                bar.set_postfix_str(f"{n_bad} failed" if n_bad else "", refresh=False)
                bar.update(1)
        finally:
            bar.close()
        res.run_seconds = time.perf_counter() - t_run
    res.table = _table(list(rows.values()), command)
    _write_table(res.table, out)
    res.seconds = time.perf_counter() - t_start
    return res


def compare_tables(a: pd.DataFrame, b: pd.DataFrame, *, rtol: float = 1e-9, atol: float = 1e-12,
                   ignore=TIMING_COLUMNS) -> list[str]:
    """Differences between two results tables (rows matched by clip), timings ignored: a list of
    ``clip: column: a vs b`` lines, empty when the tables agree (numbers within ``rtol``/``atol``,
    NaN equal to NaN and to a missing value)."""
    import numpy as np

    diffs = []
    cols_a, cols_b = [c for c in a.columns if c not in ignore], [c for c in b.columns if c not in ignore]
    if cols_a != cols_b:
        diffs.append(f"columns differ: {sorted(set(cols_a) ^ set(cols_b))}")
    ia, ib = a.set_index("clip"), b.set_index("clip")
    if set(ia.index) != set(ib.index):
        diffs.append(f"clips differ: {sorted(set(ia.index) ^ set(ib.index))}")
    for clip in sorted(set(ia.index) & set(ib.index)):
        for c in [c for c in cols_a if c in cols_b and c != "clip"]:
            va, vb = ia.at[clip, c], ib.at[clip, c]
            na, nb = va is None or (isinstance(va, float) and math.isnan(va)), \
                vb is None or (isinstance(vb, float) and math.isnan(vb))
            if na and nb:
                continue
            if isinstance(va, (int, float, np.number)) and isinstance(vb, (int, float, np.number)) and not (na or nb):
                if not np.isclose(float(va), float(vb), rtol=rtol, atol=atol):
                    diffs.append(f"{clip}: {c}: {va!r} vs {vb!r}")
            elif va != vb:
                diffs.append(f"{clip}: {c}: {va!r} vs {vb!r}")
    return diffs
