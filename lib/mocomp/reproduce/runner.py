"""Execute the notebooks (papermill), export them (nbconvert) and collect their rows.

:func:`reproduce` runs every notebook of a folder (or those named), each in its
own Jupyter kernel, in ``jobs`` parallel threads (each thread drives one kernel
process; the work runs in the kernels), with the data choice of the run:

* ``data=None`` (``--quick``): ``MOCOMP_DATA_DIR`` is removed from the kernels'
  environment, so each notebook uses the embedded data alone, and the papermill parameter
  ``QUICK = True`` is passed (``False`` otherwise): a notebook that declares it in its parameters
  cell may make its quick run cheaper in ways that leave its rows' numbers unchanged (fewer
  pixels, simpler filmstrips); the others ignore it;
* ``data=DIR``: ``MOCOMP_DATA_DIR=DIR`` for the kernels.

A notebook that raises does not stop the others: its record says ``failed``
with the error (exception, message, the cell that raised). Every executed
notebook (also a failed one, up to the failing cell) is saved, exported to
HTML, and its PNG outputs extracted for the report. Layout of REPORT_DIR::

    index.html                 the report (mocomp.reproduce.report)
    results.json, results.csv  every row of every notebook, + the run's metadata
    notebooks/NAME.ipynb       executed notebook
    notebooks/NAME.html        its HTML export
    notebooks/NAME.results.json  the rows the notebook wrote (its results_path)
    notebooks/NAME.kernel.log    the kernel process's own stdout/stderr
    figures/NAME/cellNNN_K.png   its PNG outputs
"""
from __future__ import annotations

import contextlib
import logging
import os
import platform
import re
import shutil
import subprocess
import sys
import threading
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from .figures import Figure, extract_figures
from .results import ResultRow, ResultsFileError, read_results

ENV_VAR = "MOCOMP_DATA_DIR"
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_ENV_LOCK = threading.Lock()


@dataclass
class NotebookRun:
    """What happened to one notebook."""

    name: str                      # file name, e.g. "multiflip.ipynb"
    status: str = "not run"        # "ok" | "failed"
    seconds: float = 0.0           # execution wall time (kernel start to last cell)
    export_seconds: float = 0.0    # HTML export and figure extraction
    error: str = ""                # one line: exception and message
    error_detail: str = ""         # the traceback (ANSI colours removed)
    failed_cell: int | None = None
    html: str = ""                 # paths relative to the report folder
    executed: str = ""
    results_file: str = ""
    rows: list[ResultRow] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    results_error: str = ""        # results file missing or malformed (notebook ran)
    kernel_log: str = ""           # the kernel process's own stdout/stderr (C-level messages, warnings)

    @property
    def stem(self) -> str:
        return Path(self.name).stem


def default_notebook_dir() -> Path:
    """``notebooks/`` of the source tree this package runs from, else of the working directory."""
    here = Path(__file__).resolve().parents[3] / "notebooks"
    return here if here.is_dir() else Path.cwd() / "notebooks"


def discover(folder: Path, only=()) -> list[Path]:
    """Every ``*.ipynb`` of ``folder`` in name order (or those named by ``only``: stem or file name)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"notebook folder {folder} does not exist")
    books = sorted(p for p in folder.glob("*.ipynb") if not p.name.startswith("."))
    if not books:
        raise FileNotFoundError(f"no notebooks (*.ipynb) in {folder}")
    if not only:
        return books
    by = {p.stem: p for p in books}
    chosen, unknown = [], []
    for n in only:
        key = Path(n).stem if n.endswith(".ipynb") else n
        (chosen.append(by[key]) if key in by else unknown.append(n))
    if unknown:
        raise ValueError(f"--only: no notebook named {', '.join(unknown)} in {folder} "
                         f"(have: {', '.join(sorted(by))})")
    return sorted(set(chosen))


def _git(root: Path, *args) -> str:
    try:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=20,
                              check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def environment_info(notebook_dir: Path) -> dict:
    """Versions used (python, numpy, scipy, mujoco, ...), the mocomp commit, host and load."""
    from importlib import metadata

    from .. import __version__

    versions = {"python": platform.python_version(), "mocomp": __version__}
    for dist in ("numpy", "scipy", "pandas", "matplotlib", "mujoco", "numba", "papermill", "nbconvert"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = "not installed"
    root = Path(notebook_dir).resolve().parent
    commit = _git(root, "rev-parse", "HEAD")
    dirty = bool(_git(root, "status", "--porcelain", "--untracked-files=no")) if commit else False
    return {"versions": versions, "git_commit": commit or "unknown (not a git checkout)",
            "git_dirty": dirty, "host": platform.node(), "platform": platform.platform(),
            "cpus": os.cpu_count(), "load_before": list(os.getloadavg())}


@contextlib.contextmanager
def kernel_environment(data: Path | None):
    """``MOCOMP_DATA_DIR`` as the run wants it, for the kernels started inside (restored after)."""
    # the inline backend even when the caller exports MPLBACKEND=Agg (CI does): under Agg a
    # kernel's plt.show() displays nothing, and the report takes the figures from the outputs
    want = {ENV_VAR: None if data is None else str(Path(data).resolve()),
            "MPLBACKEND": "module://matplotlib_inline.backend_inline"}
    with _ENV_LOCK:
        old = {k: os.environ.get(k) for k in want}
        _set_env(want)
    try:
        yield
    finally:
        with _ENV_LOCK:
            _set_env(old)


def _set_env(values: dict):
    for k, v in values.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def _error_of(exc: BaseException) -> tuple[str, str, int | None]:
    """(one line, detail, failing cell) of a papermill/nbclient exception."""
    ename = getattr(exc, "ename", None)
    if ename is not None:  # PapermillExecutionError: the kernel's exception
        line = f"{ename}: {getattr(exc, 'evalue', '')}".strip()
        detail = "\n".join(getattr(exc, "traceback", []) or [])
        cell = getattr(exc, "exec_count", None)
        return _ANSI.sub("", line), _ANSI.sub("", detail), cell
    line = f"{type(exc).__name__}: {exc}".splitlines()[0] if str(exc) else type(exc).__name__
    return _ANSI.sub("", line)[:500], _ANSI.sub("", "".join(traceback.format_exception(exc))), None


def _logged_kernel_manager(log_path: Path, handles: list):
    """An AsyncKernelManager whose kernel process writes its stdout/stderr to ``log_path``
    (kept out of the console: ipykernel's start-up warnings, library messages; the report
    links the file)."""
    from jupyter_client import AsyncKernelManager

    class LoggedKernelManager(AsyncKernelManager):
        async def _async_launch_kernel(self, kernel_cmd, **kw):
            fh = open(log_path, "ab")
            handles.append(fh)
            kw.setdefault("stdout", fh)
            kw.setdefault("stderr", fh)
            return await super()._async_launch_kernel(kernel_cmd, **kw)

    return LoggedKernelManager


def run_notebook(path: Path, report_dir: Path, *, timeout: float = 900.0, progress=None,
                 kernel_name: str = "python3", parameters: dict | None = None) -> NotebookRun:
    """Execute one notebook into ``report_dir`` (see the module docstring); never raises for the
    notebook's own failure (the record says ``failed``). ``parameters``: papermill parameters
    besides ``results_path`` (``QUICK`` in a ``--quick`` run)."""
    import nbformat
    import papermill as pm

    path = Path(path).resolve()
    report_dir = Path(report_dir).resolve()
    rec = NotebookRun(name=path.name)
    nb_dir = report_dir / "notebooks"
    nb_dir.mkdir(parents=True, exist_ok=True)
    executed = nb_dir / path.name
    results = nb_dir / f"{path.stem}.results.json"
    results.unlink(missing_ok=True)
    shutil.rmtree(report_dir / "figures" / path.stem, ignore_errors=True)  # no stale figures of an earlier run
    log = nb_dir / f"{path.stem}.kernel.log"
    log.unlink(missing_ok=True)
    rec.kernel_log = log.relative_to(report_dir).as_posix()
    handles: list = []
    rec.executed = executed.relative_to(report_dir).as_posix()
    rec.results_file = results.relative_to(report_dir).as_posix()
    t0 = time.perf_counter()
    try:
        pm.execute_notebook(str(path), str(executed), parameters={**(parameters or {}), "results_path": str(results)},
                            cwd=str(path.parent), kernel_name=kernel_name, execution_timeout=timeout,
                            progress_bar=progress if progress is not None else False, log_output=False,
                            report_mode=False, request_save_on_cell_execute=False,
                            kernel_manager_class=_logged_kernel_manager(log, handles))
        rec.status = "ok"
    except Exception as exc:  # the notebook's failure is a result, not a crash of the run
        rec.status = "failed"
        rec.error, rec.error_detail, cell = _error_of(exc)
        rec.failed_cell = cell
    finally:
        for fh in handles:
            fh.close()
    if not log.exists():
        rec.kernel_log = ""
    rec.seconds = time.perf_counter() - t0
    t1 = time.perf_counter()
    if executed.exists():
        try:
            nb = nbformat.read(executed, as_version=4)
            rec.figures = extract_figures(nb, path.name, report_dir / "figures" / path.stem, report_dir)
            rec.html = export_html(nb, nb_dir / f"{path.stem}.html").relative_to(report_dir).as_posix()
        except Exception as exc:  # an export problem is reported, the run goes on
            rec.results_error = f"HTML export failed: {type(exc).__name__}: {exc}"
    if results.exists():
        try:
            rec.rows = read_results(results)
        except (ResultsFileError, OSError) as exc:
            rec.results_error = str(exc)
    elif rec.status == "ok":
        rec.results_error = (f"{path.name} ran but wrote no results file (its last cell should call "
                             "write_results(rows, results_path, notebook=...))")
    rec.export_seconds = time.perf_counter() - t1
    return rec


def export_html(nb, out: Path) -> Path:
    """The executed notebook as a standalone HTML page (nbconvert, images embedded)."""
    from nbconvert import HTMLExporter

    body, _ = HTMLExporter().from_notebook_node(nb)
    out.write_text(body, encoding="utf-8")
    return out


class _Progress:
    """A tqdm bar per notebook (cells done / total) on a terminal; one line per finished
    notebook otherwise (CI logs)."""

    def __init__(self, books, enabled: bool, stream=None):
        self.stream = stream or sys.stderr
        self.bars = enabled and self.stream.isatty()
        self.enabled = enabled
        self.n = len(books)
        self.done = 0
        self.pos = {b.name: i for i, b in enumerate(books)}
        self.lock = threading.Lock()

    def bar_kwargs(self, name: str):
        if not self.bars:
            return None
        return {"desc": f"{Path(name).stem[:22]:22s}", "position": self.pos[name], "leave": True,
                "file": self.stream, "dynamic_ncols": True}

    def finished(self, rec: NotebookRun):
        with self.lock:
            self.done += 1
            if self.enabled and not self.bars:
                extra = f"  {rec.error}" if rec.status == "failed" else f"  {len(rec.rows)} rows"
                print(f"[{self.done}/{self.n}] {rec.status:6s} {rec.name}  {rec.seconds:.1f} s{extra}",
                      file=self.stream, flush=True)


def _history_file() -> Path:
    """Where the notebooks' last run times are kept between runs (``$XDG_CACHE_HOME/mocomp``)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mocomp" / "reproduce_times.json"


def _read_times(path: Path, key: str = "notebooks") -> dict:
    import json

    try:
        doc = json.loads(Path(path).read_text())
        if key == "notebooks":
            return {b["notebook"]: float(b["seconds"]) for b in doc["notebooks"]}
        return {k: float(v) for k, v in doc[key].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


#: notebook run times (s) for a first run on a machine (no previous report, no time cache: a fresh
#: clone in CI): the --quick run of 2026-12-02 with empty caches (numba compiling, examples
#: generated) at load 1.3-3.3. Only their order matters (longest first).
DEFAULT_SECONDS = {"momentum_errors.ipynb": 37.1, "perception_study.ipynb": 30.2, "impact_response.ipynb": 30.1,
                   "dtw_bands.ipynb": 23.1, "multiflip.ipynb": 22.1, "touchup.ipynb": 15.8,
                   "concatenation.ipynb": 15.0, "body_model.ipynb": 10.1, "perception_table2.ipynb": 9.1,
                   "editing_primitives.ipynb": 6.9, "mass_tables.ipynb": 6.7}


def _longest_first(books: list[Path], previous: Path, mode: str) -> list[Path]:
    """The notebooks, longest first by their last run times (the previous report in the same
    folder, else the time cache of this data mode, else :data:`DEFAULT_SECONDS`), so the parallel
    jobs end together; name order for notebooks never timed (they go first: unknown may be long).
    The report lists them by name."""
    secs = _read_times(previous) or _read_times(_history_file(), mode) or DEFAULT_SECONDS
    return sorted(books, key=lambda p: (-secs.get(p.name, float("inf")), p.name))


def _remember_times(records, mode: str) -> None:
    """Store this run's notebook times in the time cache (best effort: a read-only home is fine)."""
    import json

    path = _history_file()
    try:
        doc = json.loads(path.read_text()) if path.exists() else {}
        doc = doc if isinstance(doc, dict) else {}
        doc.setdefault(mode, {}).update({r.name: round(r.seconds, 2) for r in records})
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(doc, indent=1))
        tmp.replace(path)
    except (OSError, ValueError):
        pass


def reproduce(report_dir, *, notebooks: Path | None = None, only=(), data: Path | None = None,
              jobs: int = 2, timeout: float = 900.0, progress: bool = True, check_baseline: Path | None = None,
              write_baseline: Path | None = None) -> dict:
    """Run the notebooks and write the report; returns ``{"run": metadata, "records": [NotebookRun],
    "regressions": [Regression], "new": [keys]}``.

    ``data=None`` is ``--quick`` (embedded data alone); ``jobs`` notebooks run at once.
    ``check_baseline``: a baseline file (:mod:`mocomp.reproduce.baseline`) to check the rows
    against (read before anything runs, so a bad file fails at once); ``write_baseline``: the
    file to record this run's reproduced rows in.
    """
    from . import baseline as bl
    from .report import write_report

    base = bl.read_baseline(check_baseline) if check_baseline is not None else None

    folder = Path(notebooks) if notebooks is not None else default_notebook_dir()
    books = discover(folder, only)
    if data is not None and not Path(data).is_dir():
        raise FileNotFoundError(f"--data: {data} is not a folder")
    report_dir = Path(report_dir)
    if report_dir.exists() and not report_dir.is_dir():
        raise NotADirectoryError(f"-o: {report_dir} exists and is not a folder")
    report_dir.mkdir(parents=True, exist_ok=True)
    mode = "quick" if data is None else "data"
    books = _longest_first(books, report_dir / "results.json", mode)
    env = environment_info(folder)
    started = datetime.now(timezone.utc)
    t0 = time.perf_counter()
    prog = _Progress(books, progress)

    def one(p: Path) -> NotebookRun:
        rec = run_notebook(p, report_dir, timeout=timeout, progress=prog.bar_kwargs(p.name),
                           parameters={"QUICK": data is None})
        prog.finished(rec)
        return rec

    pm_log = logging.getLogger("papermill")  # "Passed unknown parameter", "Unable to parse line": noise here
    pm_level = pm_log.level
    pm_log.setLevel(logging.ERROR)
    with kernel_environment(data):
        if jobs <= 1 or len(books) == 1:
            records = [one(p) for p in books]
        else:
            with ThreadPoolExecutor(max_workers=jobs) as pool:
                records = list(pool.map(one, books))
    pm_log.setLevel(pm_level)
    _remember_times(records, mode)
    records.sort(key=lambda r: r.name)
    wall = time.perf_counter() - t0
    run = {
        "started": started.isoformat(timespec="seconds"),
        "seconds": wall,
        "mode": mode,
        "data": "embedded data only (--quick: MOCOMP_DATA_DIR unset for the notebooks)" if data is None
                else str(Path(data).resolve()),
        "notebook_dir": str(folder.resolve()),
        "jobs": jobs,
        "only": list(only),
        **env,
        "load_after": list(os.getloadavg()),
    }
    regressions, new = [], []
    if base is not None:
        regressions, new = bl.check_baseline(base, run["mode"], records, complete=not only)
        run["baseline"] = {"file": str(check_baseline), "regressions": [r.line() for r in regressions], "new": new}
    if write_baseline is not None:
        bl.write_baseline(write_baseline, run["mode"], records)
    write_report(report_dir, run, records)
    return {"run": run, "records": records, "regressions": regressions, "new": new}
