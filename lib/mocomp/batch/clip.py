"""One clip of a batch, run on a worker: the command's own entry point on that clip, its outputs
written atomically into the clip's folder, and the row of the results table.

Layout of ``OUT_DIR/clips/<clip>/`` (``<clip>`` is the input's relative path, e.g.
``flips/cmu_88_01_backflip.bvh/``)::

    output.bvh | render.png ...   what the command wrote (per command: mocomp.batch.commands)
    report.json                   the command's JSON report (audit, info --json, flips/edit/touchup --report)
    stdout.txt, stderr.txt        what it printed (its summary, warnings, the error line)
    traceback.txt                 when it raised an unexpected exception
    row.json                      the clip's row of the results table: the done-marker, written last

Everything is written into ``<clip>.partial-<id>/`` and that folder is renamed to ``<clip>/`` when
complete, so a killed batch leaves no half-written clip folder behind a name that looks done:
``--resume`` trusts a clip folder with its ``row.json`` and drops ``.partial-*`` folders.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import socket
import sys
import threading
import time
import traceback
import uuid
from dataclasses import dataclass
from pathlib import Path

from .commands import COMMANDS, command_argv, read_report

__all__ = ["ClipTask", "run_clip", "write_row_dir", "read_row", "CRASH_ENV", "ROW_FILE", "PARTIAL"]

ROW_FILE = "row.json"
PARTIAL = ".partial-"
#: test hook: a comma-separated list of file names; a worker about to run one of them dies of a
#: real SIGSEGV (as a segfaulting reader would), to test that a crash is one clip's failure
CRASH_ENV = "MOCOMP_BATCH_CRASH_ON"


@dataclass(frozen=True)
class ClipTask:
    """Everything a worker needs to run one clip (picklable; paths absolute, on a filesystem the
    workers share with the client)."""

    clip: str
    path: str
    format: str
    command: str
    options: tuple[str, ...]
    out_dir: str            # the clip's final folder
    output_type: str | None = None
    run: str = ""           # id of the batch run (stored in row.json, not in the table)


class _ThreadStream(io.TextIOBase):
    """``sys.stdout``/``sys.stderr`` stand-in that sends a thread's writes to its own buffer while
    it captures (a worker with several threads runs several clips at once), else to the stream."""

    def __init__(self, stream):
        self._stream = stream
        self._local = threading.local()

    def write(self, s):
        buf = getattr(self._local, "buf", None)
        return (buf if buf is not None else self._stream).write(s)

    def flush(self):
        buf = getattr(self._local, "buf", None)
        if buf is None:
            with contextlib.suppress(Exception):
                self._stream.flush()

    def isatty(self):
        return False if getattr(self._local, "buf", None) is not None else self._stream.isatty()

    def __getattr__(self, name):
        return getattr(self._stream, name)


_install_lock = threading.Lock()


@contextlib.contextmanager
def _captured():
    """Capture this thread's ``print``s to stdout and stderr: yields ``(out, err)`` StringIOs."""
    with _install_lock:
        for name in ("stdout", "stderr"):
            if not isinstance(getattr(sys, name), _ThreadStream):
                setattr(sys, name, _ThreadStream(getattr(sys, name)))
    out, err = io.StringIO(), io.StringIO()
    sys.stdout._local.buf, sys.stderr._local.buf = out, err
    try:
        yield out, err
    finally:
        sys.stdout._local.buf = sys.stderr._local.buf = None


def _maybe_crash(path: Path) -> None:
    names = {n.strip() for n in os.environ.get(CRASH_ENV, "").split(",") if n.strip()}
    if path.name in names:
        import faulthandler

        with open(path, "rb") as f:  # a reader that reads, then crashes
            f.read(1 << 16)
        time.sleep(0.5)
        faulthandler.disable()
        faulthandler._sigsegv()  # a real SIGSEGV, as from a reader's C extension


def _error_line(stderr: str, command: str) -> str | None:
    """The text of the command's last ``mocomp CMD: error: ...`` line."""
    for line in reversed(stderr.splitlines()):
        for prefix in (f"mocomp {command}: error: ", "mocomp: error: "):
            if line.startswith(prefix):
                return line[len(prefix):].strip()
    return None


def _json_safe(v):
    if isinstance(v, float) and v != v:
        return None
    return v


def read_row(clip_dir: Path) -> dict | None:
    """The row stored in a completed clip folder (``None`` when absent or unreadable: not done)."""
    try:
        d = json.loads((Path(clip_dir) / ROW_FILE).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(d, dict) or "status" not in d:
        return None
    return {k: (float("nan") if v is None and k not in _STR_KEYS else v) for k, v in d.items()}


_STR_KEYS = {"clip", "format", "command", "status", "error", "started_utc", "worker", "output", "report", "run"}


def write_row_dir(final: Path, row: dict, tmp: Path | None = None) -> Path:
    """Complete a clip folder: ``row.json`` written last into ``tmp`` (a new partial folder when
    ``None``), then ``tmp`` renamed to ``final`` (replacing an older ``final``)."""
    final = Path(final)
    if tmp is None:
        tmp = final.with_name(final.name + PARTIAL + uuid.uuid4().hex[:8])
        tmp.mkdir(parents=True)
    with open(tmp / ROW_FILE, "w") as f:
        json.dump({k: _json_safe(v) for k, v in row.items()}, f, indent=1)
        f.write("\n")
        f.flush()
        os.fsync(f.fileno())
    if final.exists():
        shutil.rmtree(final)
    try:
        os.rename(tmp, final)
    except OSError:
        if read_row(final) is None:  # pragma: no cover - a race with another batch on the same folder
            raise
        shutil.rmtree(tmp, ignore_errors=True)
    return final


def _relocate(text: str, tmp: Path, final: Path) -> str:
    return text.replace(str(tmp), str(final))


def base_row(task: ClipTask) -> dict:
    return {"clip": task.clip, "format": task.format, "command": task.command}


def run_clip(task: ClipTask) -> dict:
    """Run ``task.command`` on one clip (the command's ``mocomp`` entry point, as typed for that clip)
    and return its row; its files end up in ``task.out_dir`` (see the module docstring). A command
    that refuses the clip (exit status 2 and its error line) or raises is a ``failed`` row, never
    an exception."""
    from ..cli import main as cli_main

    spec = COMMANDS[task.command]
    final = Path(task.out_dir)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(final.name + PARTIAL + uuid.uuid4().hex[:8])
    tmp.mkdir()
    argv, files = command_argv(spec, Path(task.path), tmp, list(task.options), task.output_type)
    started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    tb = None
    rc = None
    t0 = time.perf_counter()
    with _captured() as (out, err):
        try:
            _maybe_crash(Path(task.path))
            rc = cli_main([task.command, *argv])
        except SystemExit as e:  # argparse refusing an option: its one line is on stderr
            rc = e.code if isinstance(e.code, int) else 2
        except Exception as e:  # noqa: BLE001 - a command's bug is this clip's failure
            tb = traceback.format_exc()
            print(f"mocomp {task.command}: error: {type(e).__name__}: {' '.join(str(e).split())}", file=sys.stderr)
    seconds = time.perf_counter() - t0
    stdout, stderr = _relocate(out.getvalue(), tmp, final), _relocate(err.getvalue(), tmp, final)
    (tmp / "stdout.txt").write_text(stdout)
    if stderr:
        (tmp / "stderr.txt").write_text(stderr)
    if tb is not None:
        (tmp / "traceback.txt").write_text(tb)
    report = None
    if spec.report_from_stdout and rc == 0:
        (tmp / "report.json").write_text(stdout)
    rep_path = tmp / "report.json"
    if rep_path.is_file():
        rep_path.write_text(_relocate(rep_path.read_text(), tmp, final))
        report = read_report(rep_path)
    ok = tb is None and rc in (0, 1)
    row = base_row(task)
    row.update({
        "status": "ok" if ok else "failed",
        "exit_code": rc,
        "error": None if ok else (_error_line(stderr, task.command) or f"exit status {rc}"),
        "warnings": sum(": warning:" in line for line in stderr.splitlines()),
        "output": files.get("output") if ok and (tmp / files.get("output", "\0")).is_file() else None,
        "report": "report.json" if report is not None else None,
        "seconds": seconds,
        "started_utc": started,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "run": task.run,
    })
    row.update(spec.columns(report, stdout) if ok else dict.fromkeys(spec.column_names))
    write_row_dir(final, row, tmp)
    return row
