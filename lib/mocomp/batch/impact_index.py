"""The impact library index built on Dask: ``mocomp batch impact-index LIBRARY -o OUT_DIR``
(issue 20 section 2, issue 18).

The index of :mod:`mocomp.impact.index` (Zordan et al.'s reaction search, dissertation sec. 4.1:
per clip the 16 body parts' features and the unique frames of eq. 4.2) is per clip and
content-addressed: one ``.npz`` per clip in the cache folder, named by the SHA-256 of the clip's
bytes and of the index parameters. :func:`build_index_batch` maps the per-clip work (read, retarget
onto the victim, resample, features, unique frames; or read back when its cache file exists) over
the workers with :func:`mocomp.batch.map_items`, each worker writing its clip's cache file
atomically; the client then merges them with :func:`mocomp.impact.index.build_index` itself, which
reads every clip back from that cache. The merged index is therefore the in-process index (same
code, same files), and a later ``mocomp impact`` / ``build_index`` reads the cache the batch filled.

Each worker runs :func:`mocomp.impact.index.index_clip_file`, the per-clip step of
``build_index`` itself, so the cache keys are the same by construction. Should the merge still miss
a clip's cache file, it rebuilds that clip in the client (still the same index, just not in
parallel) and :attr:`IndexBatchResult.rebuilt` says which: the tests require it to be empty.
"""
from __future__ import annotations

import json
import os
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

__all__ = ["IndexItem", "IndexBatchResult", "index_clip", "build_index_batch", "COLUMNS"]

#: columns of the results table of ``mocomp batch impact-index``
COLUMNS = ("clip", "format", "command", "status", "error", "seconds", "worker", "frames", "index_frames",
           "unique", "cached", "key")


@dataclass(frozen=True)
class IndexItem:
    """One library file for a worker: its path, its name in the index, the victim's skeleton and
    the index parameters (picklable)."""

    path: str
    name: str
    skeleton: object
    tolerance: float
    fps: float
    cache: str


_BODIES: dict = {}


def index_clip(item: IndexItem) -> dict:
    """Index one clip into the cache (on a worker): read it back when its cache file exists, else
    build it (:mod:`mocomp.impact.index`) and write the cache file atomically. Returns its row;
    a clip the index refuses (unreadable, a skeleton that cannot be mapped) is a ``failed`` row with
    the index's reason, never an exception."""
    from ..errors import MocompError
    from ..impact import index as ix
    from ..impact.features import body_model_for
    from ..impact.retarget import RetargetError

    t0 = time.perf_counter()
    p = Path(item.path)
    row = {"clip": item.name, "command": "impact-index", "worker": f"{socket.gethostname()}:{os.getpid()}"}
    try:
        sig = ix._skeleton_signature(item.skeleton)
        body = _BODIES.get(sig)
        if body is None:
            body = _BODIES[sig] = body_model_for(item.skeleton)
        params = ix.index_parameters(item.skeleton, item.tolerance, item.fps)
        c = ix.index_clip_file(p, item.name, item.skeleton, body, params, Path(item.cache), item.tolerance,
                               item.fps)
        key = c.key
    except RetargetError as e:
        row.update(status="failed", error=str(e))
    except (MocompError, ValueError, OSError) as e:
        row.update(status="failed", error=f"{p}: cannot be read as a motion: {' '.join(str(e).split())}")
    else:
        row.update(status="ok", frames=c.native_frames, index_frames=c.n_frames, unique=int(c.unique.size),
                   cached=bool(c.cached), key=key)
    row["seconds"] = time.perf_counter() - t0
    return row


@dataclass
class IndexBatchResult:
    """What :func:`build_index_batch` did.

    index: the merged :class:`~mocomp.impact.index.LibraryIndex` (read back from the cache); ``None``
        when a clip crashed its worker (``crashed``): the merge runs ``build_index`` over the whole
        folder in this process, which would run that clip here too (move it out of the library).
    table: one row per file below the library (COLUMNS; files that are not library motions:
        ``skipped`` with the reason). rebuilt: clips the merge had to build in the client (should
        be none: see the module docstring). seconds: wall time; map_seconds: the mapped part.
    """

    index: object
    table: pd.DataFrame
    rebuilt: list = field(default_factory=list)
    seconds: float = 0.0
    map_seconds: float = 0.0
    workers: int = 0
    crashed: list = field(default_factory=list)

    def summary_lines(self) -> list[str]:
        ix, t = self.index, self.table
        c = {k: int(v) for k, v in t["status"].value_counts().items()}
        ok = t[t["status"] == "ok"]
        lines = [f"batch impact-index: {len(t)} files: {c.get('ok', 0)} clips indexed ({int(ok['cached'].sum())} from "
                 f"the cache), {c.get('failed', 0)} refused, {c.get('crashed', 0)} crashed, {c.get('skipped', 0)} "
                 f"skipped (not motions)",
                 (f"index: {len(ix.clips)} clips, {ix.n_frames} frames at {ix.fps:g} Hz, {ix.n_unique} unique "
                  f"(T = {ix.tolerance:g}); cache {ix.cache_dir}") if ix is not None else
                 (f"index not merged: {', '.join(self.crashed)} crashed its worker (the merge would run it in this "
                  "process); the other clips are in the cache"),
                 f"time: {self.seconds:.1f} s wall ({self.map_seconds:.1f} s mapped over "
                 + (f"{self.workers} worker(s))" if self.workers > 0 else
                    "this process)" if self.workers == 0 else "the cluster's workers)")]
        for r in t[t["status"].isin(("failed", "crashed"))].itertuples():
            lines.append(f"  {r.status} {r.clip}: {r.error}")
        if self.rebuilt:
            lines.append(f"  rebuilt in the client (no cache file from the workers): {', '.join(self.rebuilt)}")
        return lines


def build_index_batch(library_dir, skeleton, *, cache_dir=None, tolerance: float | None = None,
                      fps: float | None = None, workers: int | None = None, scheduler: str | None = None,
                      client=None, out_dir=None, progress: bool = True) -> IndexBatchResult:
    """Build the impact library index of ``library_dir`` for the victim's ``skeleton`` with the
    per-clip work mapped over Dask workers (see the module docstring); same arguments as
    :func:`mocomp.impact.index.build_index`, plus ``workers`` / ``scheduler`` / ``client`` as in
    :func:`mocomp.batch.map_items` (``workers=0``: in this process).

    out_dir: when given, ``results.parquet``/``results.csv`` (one row per file) and ``index.json``
    (the ``mocomp impact-index --json`` summary) are written there.
    Raises :class:`~mocomp.impact.index.LibraryError` as ``build_index`` does (no usable clip, not a
    directory). The cache folder must be shared with the workers (an existing cluster).
    """
    import numpy as np

    from ..impact import index as ix
    from .engine import map_items
    from .inputs import discover
    from .runner import _bar, _write_table

    t0 = time.perf_counter()
    tolerance = ix.DEFAULT_TOLERANCE if tolerance is None else float(tolerance)
    fps = ix.DEFAULT_FPS if fps is None else float(fps)
    if not (np.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"tolerance must be a finite number >= 0, got {tolerance!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps!r}")
    directory = Path(library_dir)
    files = ix.library_files(directory)  # LibraryError when not a directory
    cache = Path(cache_dir) if cache_dir is not None else ix.default_cache_dir()
    cache = Path(os.path.abspath(cache))
    names = {Path(os.path.abspath(p)): p.relative_to(directory).as_posix() for p in files}
    items = [IndexItem(str(Path(os.path.abspath(p))), names[Path(os.path.abspath(p))], skeleton, tolerance, fps,
                       str(cache)) for p in files]
    if out_dir is not None:
        o, d = Path(os.path.abspath(out_dir)), Path(os.path.abspath(directory))
        if o == d or d in o.parents:
            raise ValueError(f"output folder {out_dir} lies inside the library {directory}: its index.json would be "
                             "read as a library file; give a folder outside it")
    rows: dict[str, dict] = {}
    found = discover(directory)
    for f in found:
        if f.path not in names:
            rows[f.clip] = {"clip": f.clip, "format": f.format, "command": "impact-index", "status": "skipped",
                            "error": f.skip_reason or f"not a library motion file ({', '.join(ix._EXTENSIONS)})"}
    fmt = {f.clip: f.format for f in found}
    t_map = time.perf_counter()
    bar = _bar(len(items), "batch impact-index", progress)
    try:
        for o in map_items(index_clip, items, client=client, workers=workers, scheduler=scheduler,
                           name="batch-impact-index"):
            row = o.value if o.status == "ok" else {"clip": o.item.name, "command": "impact-index",
                                                    "status": o.status, "error": o.error}
            row["format"] = fmt.get(o.item.name)
            rows[o.item.name] = row
            bar.update(1)
    finally:
        bar.close()
    map_seconds = time.perf_counter() - t_map
    crashed = sorted(r["clip"] for r in rows.values() if r["status"] == "crashed")
    index, rebuilt = None, []
    if not crashed:
        # the merge: mocomp.impact.index itself, reading every clip back from the cache just filled
        index = ix.build_index(directory, skeleton, cache_dir=cache, tolerance=tolerance, progress=False, fps=fps)
        rebuilt = [c.name for c in index.clips if not c.cached]
    table = pd.DataFrame(list(rows.values()), columns=list(COLUMNS)).sort_values("clip", kind="stable")
    table = table.reset_index(drop=True)
    for c in ("seconds", "frames", "index_frames", "unique"):
        table[c] = pd.to_numeric(table[c], errors="coerce").astype(float)
    table["cached"] = table["cached"].map(lambda v: bool(v) if isinstance(v, (bool, np.bool_)) else None).astype(object)
    for c in ("clip", "format", "command", "status", "error", "worker", "key"):
        table[c] = table[c].map(lambda v: v if isinstance(v, str) and v else None).astype(object)
    if client is not None:
        n_workers = sum(client.nthreads().values())
    elif scheduler is not None:
        n_workers = -1  # an existing cluster's (not known here)
    else:
        from .engine import default_workers

        n_workers = default_workers() if workers is None else int(workers)
    res = IndexBatchResult(index, table, rebuilt, time.perf_counter() - t0, map_seconds, n_workers, crashed)
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        tt = table.copy()
        tt["cached"] = tt["cached"].map(lambda v: None if v is None else float(v)).astype(float)
        _write_table(tt, out)
    if out_dir is not None and index is not None:
        summary = {"library": str(directory), "tolerance": index.tolerance, "fps": index.fps, "cache": index.cache_dir,
                   "seconds": res.seconds, "clips": [
                       {"clip": c.name, "frames": c.native_frames, "index_frames": c.n_frames,
                        "unique": int(c.unique.size), "notes": list(c.notes)} for c in index.clips],
                   "refused": [{"path": p, "reason": r} for p, r in index.refused]}
        tmp = out / "index.json.partial"
        tmp.write_text(json.dumps(summary, indent=1) + "\n")
        os.replace(tmp, out / "index.json")
    if rebuilt:
        print(f"mocomp batch impact-index: warning: {len(rebuilt)} clip(s) rebuilt in the client: the merge found "
              "no cache file from the workers for them (was the cache folder shared with every worker?)",
              file=sys.stderr)
    return res
