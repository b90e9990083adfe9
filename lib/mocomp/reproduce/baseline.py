"""The committed list of rows that reproduce, and the check that none stops reproducing (CI).

A baseline file (``docs/reproduce_baseline.json``) holds, per data mode of a run
(``quick``: embedded data alone; ``data``: with the real-data folder) and per
notebook, the keys (``paper | item | quantity``) of the rows that were
``reproduced``. :func:`check_baseline` returns every key of a checked notebook
that is no longer reproduced (it differs, failed, has no paper value any more,
is missing, or its notebook failed or disappeared), so CI fails naming each.
Rows that reproduce but are not in the baseline are reported as new (not an
error): ``mocomp reproduce --write-baseline FILE`` records them.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from .results import ResultRow, ResultsFileError

SCHEMA = 1
MODES = ("quick", "data")


def row_key(row: ResultRow) -> str:
    """The identity of a row across runs: ``paper | item | quantity``."""
    return f"{row.paper} | {row.item} | {row.quantity}"


@dataclass(frozen=True)
class Regression:
    key: str
    notebook: str
    now: str        # the row's status now, "missing", "notebook failed" or "notebook missing"
    detail: str     # ours/paper/tolerance, or the notebook's error

    def line(self) -> str:
        return f"{self.key} ({self.notebook}): was reproduced, now {self.now}" + (
            f": {self.detail}" if self.detail else "")


def read_baseline(path) -> dict:
    """Read a baseline file; a malformed one raises :class:`ResultsFileError` naming the file."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ResultsFileError(f"{path}:{e.lineno}: not valid JSON ({e.msg})") from None
    modes = doc.get("modes") if isinstance(doc, dict) else None
    if not isinstance(modes, dict) or not set(modes) <= set(MODES):
        raise ResultsFileError(f"{path}: expected {{'modes': {{'quick' | 'data': {{notebook: [keys]}}}}}}")
    for mode, books in modes.items():
        if not isinstance(books, dict) or not all(
                isinstance(v, list) and all(isinstance(k, str) for k in v) for v in books.values()):
            raise ResultsFileError(f"{path}: modes.{mode} must map notebook names to lists of row keys")
    return doc


def _describe(row: ResultRow) -> str:
    def f(v):
        return "None" if v is None else f"{v:.6g}"
    return f"ours {f(row.ours)}, paper {f(row.paper_value)}, tolerance {row.tolerance:g} {row.unit}".rstrip()


def check_baseline(baseline: dict, mode: str, records, complete: bool) -> tuple[list[Regression], list[str]]:
    """(regressions, new reproduced keys) of a run against ``baseline`` (from :func:`read_baseline`).

    ``records``: the run's :class:`~mocomp.reproduce.runner.NotebookRun` s. ``complete``:
    the run covered the whole folder (no ``--only``), so a baseline notebook absent from
    it has disappeared (a regression); otherwise only the notebooks run are checked.
    """
    expected = baseline.get("modes", {}).get(mode, {})
    by_name = {r.name: r for r in records}
    regressions, new = [], []
    for nb, keys in sorted(expected.items()):
        rec = by_name.get(nb)
        if rec is None:
            if complete:
                regressions += [Regression(k, nb, "notebook missing", f"{nb} is not in the notebook folder")
                                for k in keys]
            continue
        rows = {row_key(r): r for r in rec.rows}
        for k in keys:
            row = rows.get(k)
            if rec.status != "ok" and row is None:
                regressions.append(Regression(k, nb, "notebook failed", rec.error))
            elif row is None:
                regressions.append(Regression(k, nb, "missing", "the notebook no longer writes this row"
                                              + (f" ({rec.results_error})" if rec.results_error else "")))
            elif row.status != "reproduced":
                regressions.append(Regression(k, nb, row.status, _describe(row)))
    for rec in records:
        known = set(expected.get(rec.name, []))
        new += [row_key(r) for r in rec.rows if r.status == "reproduced" and row_key(r) not in known]
    return regressions, new


def write_baseline(path, mode: str, records) -> Path:
    """Record the reproduced rows of the notebooks that ran to the end in ``mode``'s section
    of ``path`` (other modes and notebooks, and failed notebooks' entries, are kept)."""
    path = Path(path)
    doc = read_baseline(path) if path.exists() else {
        "schema": SCHEMA,
        "about": "rows that reproduce (paper | item | quantity), per data mode and notebook; "
                 "mocomp reproduce --check-baseline fails when one stops reproducing. "
                 "Update with mocomp reproduce --write-baseline.",
        "modes": {}}
    section = doc["modes"].setdefault(mode, {})
    for rec in records:
        if rec.status == "ok" and not rec.results_error:
            section[rec.name] = sorted({row_key(r) for r in rec.rows if r.status == "reproduced"})
    doc["modes"] = {m: dict(sorted(doc["modes"][m].items())) for m in MODES if m in doc["modes"]}
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    tmp.replace(path)
    return path
