"""``mocomp study run`` (serve the participant app with Voila), ``mocomp study withdraw`` and
``mocomp study analyze``.

:func:`register_run`, :func:`register_withdraw` and :func:`register_analyze` add the
sub-commands to the ``study`` command's sub-parsers (``lib/mocomp/cli/study.py`` lists them).
"""
from __future__ import annotations

import argparse
import errno
import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

from mocomp.cli._common import float_in
from mocomp.errors import MocompError

__all__ = ["register_run", "register_withdraw", "register_analyze", "voila_command", "app_notebook", "cull_interval", "KERNEL_CULL_S",
           "HOST", "check_port_free", "free_port", "StudyServer", "ServerStopped"]

#: The only interface the participant app is served on.
HOST = "127.0.0.1"


def app_notebook() -> Path:
    """The packaged participant app notebook (``study/app.ipynb``)."""
    return Path(__file__).with_name("app.ipynb")


#: Default seconds after which the kernel of a closed or reloaded page is shut down (see voila_command).
KERNEL_CULL_S = 30


def cull_interval(cull_idle_s: int) -> int:
    """How often (s) the server looks for kernels to cull: a quarter of the idle timeout, 1-10 s."""
    return int(min(10, max(1, int(cull_idle_s) // 4)))


def voila_command(port: int, notebook: str | Path | None = None, *, python: str | None = None,
                  cull_idle_s: int = KERNEL_CULL_S) -> list[str]:
    """The Voila command line serving the app on 127.0.0.1:``port`` (no browser, no tracebacks shown).

    Each page has its own kernel, which holds the session lock while it lives.
    Voila's page asks the server to shut its kernel down on ``beforeunload``
    (a ``sendBeacon``), but browsers and extensions can drop that request; the
    kernel of a closed or reloaded page would then live on and keep the session
    locked. So the server also culls kernels that have *no page connected* and
    have been idle for ``cull_idle_s`` seconds (jupyter_server's
    ``MappingKernelManager.cull_idle_timeout``, checked every
    :func:`cull_interval` s; ``cull_connected=False``: the kernel of an open
    page is never culled, however long the participant takes). After at most
    ``cull_idle_s + cull_interval`` seconds the lock is free and the new
    page's "Try again" opens the session where it stopped; two windows never
    write at once (the lock is an exclusive ``flock``, held until the old
    kernel's process has exited).

    The server binds exactly ``port`` (``--Voila.port_retries=0``: if that port is
    taken it exits instead of moving to another one, so the printed address is
    always the served one) and requires a token (``--token``, Voila's
    ``auto_token`` flag: jupyter_server's ``IdentityProvider`` then takes the
    token from ``$JUPYTER_TOKEN``, which :class:`StudyServer` sets, so the
    secret never appears on a command line that ``ps`` shows). Requests without
    it are redirected to the login page and start no kernel; the page opened
    with ``?token=...`` gets a login cookie (named for the port, signed with a
    per-server secret), which its websocket and the ``beforeunload`` beacon
    (with its ``_xsrf`` field) carry.
    """
    nb = Path(notebook) if notebook is not None else app_notebook()
    cull = int(cull_idle_s)
    if cull < 1:
        raise ValueError(f"cull_idle_s must be >= 1 s, got {cull_idle_s}")
    port = int(port)
    if not 1 <= port <= 65535:
        raise ValueError(f"port must be 1-65535, got {port}")
    return [python or sys.executable, "-m", "voila", "--no-browser", f"--port={port}", "--Voila.port_retries=0",
            f"--Voila.ip={HOST}", "--token", "--show_tracebacks=False", "--theme=light",
            f"--MappingKernelManager.cull_idle_timeout={cull}",
            f"--MappingKernelManager.cull_interval={cull_interval(cull)}",
            "--MappingKernelManager.cull_connected=False", "--MappingKernelManager.cull_busy=False", str(nb)]


def check_port_free(port: int, host: str = HOST) -> None:
    """Refuse a port that is taken on ``host`` (bind a socket to it, as the server will).

    ``SO_REUSEADDR`` as tornado sets it, so a port only in ``TIME_WAIT`` counts as free
    while any socket bound or listening there (also on the wildcard address) counts as taken.
    """
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, int(port)))
        except OSError as e:
            why = "is already in use" if e.errno == errno.EADDRINUSE else f"cannot be used ({e.strerror})"
            raise MocompError(f"port {port} on {host} {why}: the study server would not be reachable at the "
                              f"address it prints; stop what uses it, or choose another --port (--port 0 picks a "
                              f"free one)") from None


def free_port(host: str = HOST) -> int:
    """A port that is free on ``host`` now (the kernel's choice for port 0)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


class ServerStopped(BaseException):
    """Raised in the main thread by SIGTERM/SIGINT/SIGHUP while :class:`StudyServer` serves."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = int(signum)


def _proc_start(pid: int) -> str | None:
    """The start time of process ``pid`` (field 22 of /proc/PID/stat), to tell a reused pid apart."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def _tree(pid: int) -> dict[int, str | None]:
    """``pid`` and all its descendants (kernels run in sessions of their own, so a process-group
    kill misses them), each with its start time: {pid: start}. psutil where installed, else /proc."""
    try:
        import psutil
    except ImportError:  # pragma: no cover - psutil comes with ipykernel
        psutil = None
    if psutil is not None:
        try:
            root = psutil.Process(pid)
            procs = [root] + root.children(recursive=True)
        except psutil.Error:
            return {}
        out = {}
        for p in procs:
            try:
                out[p.pid] = repr(p.create_time())
            except psutil.Error:
                pass
        return out
    children: dict[int, list[int]] = {}  # pragma: no cover
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int(Path(d, "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d.name))
    out, stack = {}, [pid]
    while stack:
        q = stack.pop()
        if (st := _proc_start(q)) is not None:
            out[q] = st
        stack.extend(children.get(q, []))
    return out


def _alive(pid: int, start: str | None) -> bool:
    """The process (pid with that start time) still runs and is not a zombie."""
    try:
        import psutil
    except ImportError:  # pragma: no cover
        psutil = None
    if psutil is not None:
        try:
            p = psutil.Process(pid)
            return repr(p.create_time()) == start and p.status() != psutil.STATUS_ZOMBIE
        except psutil.Error:
            return False
    st = _proc_start(pid)  # pragma: no cover
    if st is None or st != start:
        return False
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"


def _listening_ports(pids) -> set[int]:
    """TCP ports on which one of ``pids`` listens (psutil; empty set without it)."""
    try:
        import psutil
    except ImportError:  # pragma: no cover
        return set()
    ports = set()
    for pid in pids:
        try:
            conns = psutil.Process(pid).net_connections(kind="tcp")
        except psutil.Error:
            continue
        ports.update(c.laddr.port for c in conns if c.status == psutil.CONN_LISTEN)
    return ports


def _die_with_parent(parent: int):
    """``preexec_fn`` for the server: on Linux, ask the kernel to send the server SIGINT when
    ``mocomp study run`` dies, however it dies (``prctl(PR_SET_PDEATHSIG)``), so even a SIGKILL,
    which no handler sees, leaves no orphaned server (Voila stops on SIGINT and shuts its kernels
    down). A parent that died before the call is caught by comparing ``getppid``. Elsewhere: None."""
    if not sys.platform.startswith("linux"):
        return None

    def preexec() -> None:
        import ctypes

        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGINT), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):
            return
        if os.getppid() != parent:  # the parent is already gone
            os._exit(1)

    return preexec


class StudyServer:
    """The Voila server of one session, and every process it starts (its kernels).

    Started in a session of its own (``start_new_session``), so a Ctrl-C in the
    terminal reaches only ``mocomp study run``, which then stops the server
    itself. The process tree (the server and its kernels, which jupyter_client
    starts in sessions of their own) is recorded while it serves, and
    :meth:`stop` ends all of it on every exit path: first SIGINT to the server
    (Voila then shuts its kernels down, which release their session locks), then
    SIGTERM and finally SIGKILL to every recorded process that is still there.
    If ``mocomp study run`` is killed outright (SIGKILL), the kernel sends the server
    SIGINT (:func:`_die_with_parent`, Linux). Used as a context manager, with SIGTERM/SIGINT/SIGHUP turned into
    :class:`ServerStopped` while inside (so they unwind through ``finally``).
    """

    def __init__(self, cmd: list[str], env: dict, port: int, token: str, host: str = HOST, *,
                 grace_s: float = 15.0, term_s: float = 5.0):
        self.cmd, self.env, self.port, self.token, self.host = list(cmd), dict(env), int(port), token, host
        self.grace_s, self.term_s = float(grace_s), float(term_s)
        self.env["JUPYTER_TOKEN"] = token
        self.env.pop("JUPYTER_TOKEN_FILE", None)
        self.proc: subprocess.Popen | None = None
        self._known: dict[int, str | None] = {}
        self._old_handlers: dict[int, object] = {}

    @property
    def url(self) -> str:
        """The address to open: this server's port and its token."""
        return f"http://{self.host}:{self.port}/?token={self.token}"

    # -------------------------------------------------------------- lifecycle
    def __enter__(self) -> "StudyServer":
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
                self._old_handlers[sig] = signal.signal(sig, self._on_signal)
        try:
            self.start()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc) -> None:
        try:
            for sig in self._old_handlers:  # a second signal must not interrupt the shutdown
                signal.signal(sig, signal.SIG_IGN)
            self.stop()
        finally:
            for sig, h in self._old_handlers.items():
                signal.signal(sig, h)
            self._old_handlers = {}

    @staticmethod
    def _on_signal(signum, frame):
        raise ServerStopped(signum)

    def start(self) -> None:
        self.proc = subprocess.Popen(self.cmd, env=self.env, stdin=subprocess.DEVNULL, start_new_session=True,
                                     preexec_fn=_die_with_parent(os.getpid()))
        self._known = _tree(self.proc.pid)

    def _remember(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self._known.update(_tree(self.proc.pid))

    def wait_ready(self, timeout: float = 180.0) -> None:
        """Wait until the server listens on ``self.port`` (it must be that process tree listening
        there); refuse if it exits first or does not listen within ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while True:
            rc = self.proc.poll()
            if rc is not None:
                raise MocompError(f"the study server (Voila) exited with code {rc} before serving on "
                                  f"{self.host}:{self.port} (was the port taken meanwhile? its output is above)")
            self._remember()
            try:
                with socket.create_connection((self.host, self.port), timeout=1):
                    pass
            except OSError:
                pass
            else:
                ports = _listening_ports(self._known)
                if not ports or self.port in ports:  # (empty: psutil missing; the port was free before)
                    return
                raise MocompError(f"something else answers on {self.host}:{self.port}, while the study server "
                                  f"listens on {sorted(ports)}; refusing to print an address it does not serve")
            if time.monotonic() > deadline:
                raise MocompError(f"the study server did not listen on {self.host}:{self.port} within "
                                  f"{timeout:.0f} s")
            time.sleep(0.25)

    def wait(self) -> int:
        """Serve until the server exits on its own; its exit code."""
        while True:
            try:
                return self.proc.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                # kernels come and go with pages; one started less than 0.5 s before a server
                # crash is not recorded, but ipykernel ends itself when its parent changes
                self._remember()

    def stop(self) -> None:
        """End the server and every process it started (see the class docstring); idempotent.

        SIGINT, then up to ``grace_s`` for Voila to shut its kernels down; then SIGTERM to what is
        left, ``term_s`` later SIGKILL."""
        if self.proc is None:
            return
        self._remember()
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGINT)  # Voila: stop serving, shut every kernel down
                self.proc.wait(timeout=self.grace_s)
            except subprocess.TimeoutExpired:
                pass
        for sig, wait_s in ((signal.SIGTERM, self.term_s), (signal.SIGKILL, 5.0)):
            left = {p: st for p, st in self._known.items() if _alive(p, st)}
            if not left:
                break
            for p in left:
                try:
                    os.kill(p, sig)
                except (ProcessLookupError, PermissionError):
                    pass
            try:
                os.killpg(self.proc.pid, sig)  # anything else in the server's own group
            except (ProcessLookupError, PermissionError):
                pass
            deadline = time.monotonic() + wait_s
            while time.monotonic() < deadline and any(_alive(p, st) for p, st in left.items()):
                self.proc.poll()
                time.sleep(0.1)
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:  # pragma: no cover
            pass
        self.proc = None


def _session_args(p: argparse.ArgumentParser) -> None:
    """``--participant`` and ``--session``: the session folder DATA/<participant>/<session>/."""
    p.add_argument("--participant", required=True, help="participant id (letters, digits, _ . -)")
    p.add_argument("--session", required=True, help="session id, e.g. S1")


def register_run(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "run", help="serve the participant app (Voila on 127.0.0.1) for one participant session",
        description="Serve the perception-study app for one participant and session with Voila on "
                    "127.0.0.1 (open the printed address, which carries this session's access token, in a "
                    "browser; it is printed once the server listens on exactly that port). The plan is written to "
                    "DATA/<participant>/<session>/ before the first trial; re-running the same command "
                    "resumes the session where it stopped. Stop with Ctrl-C or SIGTERM (the server and its "
                    "kernels are shut down).")
    _session_args(p)
    p.add_argument("--manifest", required=True, help="stimulus manifest CSV (from `mocomp study render`)")
    p.add_argument("--data", required=True, metavar="DIR", help="folder for session data")
    p.add_argument("--port", type=int, default=8866,
                   help="port on 127.0.0.1 (default 8866; 0 = a free port); refused if it is taken")
    p.add_argument("--design", metavar="JSON", help="trial-design settings (JSON file, fields of study.design.DesignConfig)")
    p.add_argument("--study-seed", type=int, default=0, help="study seed; the participant seed derives from it and the id")
    p.add_argument("--seed", type=int, default=None, help="explicit participant seed (overrides --study-seed)")
    p.add_argument("--counterbalance-index", type=int, default=None,
                   help="participant number for counterbalance='latin'")
    p.add_argument("--break-every", type=int, default=None, metavar="N",
                   help="break screen before every N-th test trial (default 30, as DesignConfig; 0 = no breaks); "
                        "the participant resumes by clicking Continue")
    p.add_argument("--break-s", type=float_in(1, 3600, what="number of seconds"), default=None, metavar="S",
                   help="suggested break length said (and counted down) on the break screen (default 60)")
    p.add_argument("--contact", metavar="TEXT", default=None,
                   help="contact line of the debrief screen, e.g. 'Dr A. Researcher, a.researcher@uni.example, "
                        "+44 ...' (who to ask, and how to withdraw later); also settable as 'contact' in --texts")
    p.add_argument("--practice", type=int, default=None, help="number of practice trials")
    p.add_argument("--attention-checks", type=int, default=None, help="number of attention-check trials")
    p.add_argument("--no-must-watch", action="store_true",
                   help="allow answers before the video has played to its end (default: buttons and keys "
                        "stay disabled until it has, once per presentation)")
    p.add_argument("--texts", metavar="JSON", help="participant-facing texts (JSON file, fields of HarnessTexts)")
    p.add_argument("--lock-timeout", type=float_in(0, 3600, what="number of seconds"), default=None, metavar="S",
                   help="seconds a new window waits for a session held by another window (default 15)")
    p.add_argument("--kernel-cull-s", type=int, default=KERNEL_CULL_S, metavar="S",
                   help="shut down the kernel of a closed or reloaded page after S idle seconds without a "
                        f"page (frees the session for a new window; default {KERNEL_CULL_S})")
    p.add_argument("--print-config", action="store_true", help="print the app configuration and exit")
    p.set_defaults(func=run_run)
    return p


def _design_dict(args) -> dict | None:
    d = {}
    if args.design:
        d = json.loads(Path(args.design).read_text())
    if args.break_every is not None and args.break_every < 0:
        raise ValueError(f"--break-every must be >= 0 (0 = no breaks), got {args.break_every}")
    for key, val in (("break_every", args.break_every), ("break_s", getattr(args, "break_s", None)),
                     ("n_practice", args.practice),
                     ("n_attention", args.attention_checks), ("must_watch", False if args.no_must_watch else None)):
        if val is not None:
            d[key] = val
    if not d:
        return None
    from .design import DesignConfig

    DesignConfig.from_dict(d)  # validate now, not in the participant's browser
    return d


def _check_run_args(args, design: dict | None) -> None:
    """Refuse, before any server starts, what the app would only find in the participant's browser."""
    if (design or {}).get("counterbalance") == "latin" and args.counterbalance_index is None:
        raise ValueError(f"the design{' ' + repr(args.design) if args.design else ''} uses counterbalance='latin', "
                         "which needs --counterbalance-index N (the participant's number: row N of the "
                         "balanced Latin square of group orders)")
    import importlib.util

    if importlib.util.find_spec("voila") is None:
        from mocomp.errors import MocompError

        raise MocompError(f"`mocomp study run` serves the app with Voila, which is not importable from "
                          f"{sys.executable}: pip install 'mocomp[study]' (voila, ipykernel, jupyterlab-widgets)")


def run_run(args) -> int:
    from .session import _refuse_withdrawn, check_id
    from .stimulus_set import load_manifest

    check_id(args.participant, "participant id")
    check_id(args.session, "session id")
    _refuse_withdrawn(Path(args.data) / args.participant / args.session)
    manifest = Path(args.manifest).resolve()
    # fail here with a clear message, before starting a server (the app checks again at session start)
    load_manifest(manifest, verify_hashes=True)
    design = _design_dict(args)
    _check_run_args(args, design)
    data = Path(args.data).resolve()
    data.mkdir(parents=True, exist_ok=True)
    cfg = {"manifest": str(manifest), "data_dir": str(data), "participant_id": args.participant,
           "session_id": args.session, "study_seed": args.study_seed, "seed": args.seed,
           "counterbalance_index": args.counterbalance_index}
    if design:
        cfg["design"] = design
    if args.lock_timeout is not None:
        cfg["lock_timeout_s"] = args.lock_timeout
    if args.kernel_cull_s < 1:
        raise ValueError(f"--kernel-cull-s must be >= 1, got {args.kernel_cull_s}")
    cfg["release_after_s"] = args.kernel_cull_s + cull_interval(args.kernel_cull_s)
    if args.texts:
        cfg["texts"] = json.loads(Path(args.texts).read_text())
        if not isinstance(cfg["texts"], dict):
            raise ValueError(f"--texts {args.texts}: expected a JSON object of HarnessTexts fields")
    if args.contact is not None:
        cfg.setdefault("texts", {})["contact"] = args.contact
    from .harness import HarnessTexts

    try:
        texts = HarnessTexts(**cfg.get("texts", {}))  # refuse unknown fields now, not in the browser
    except TypeError as e:
        known = ", ".join(HarnessTexts.__dataclass_fields__)
        raise ValueError(f"--texts {args.texts}: {e} (fields: {known})") from None
    note = ("" if texts.contact.strip() else
            "mocomp study run: note: no --contact given: the debrief screen names no contact for questions or "
            "later withdrawal (it says to ask the experimenter)")
    if args.print_config:
        print(json.dumps(cfg, indent=2))
        return 0
    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port must be 0-65535, got {args.port}")
    port = free_port() if args.port == 0 else args.port
    check_port_free(port)  # refuse now, in one line; the server itself never moves to another port
    env = dict(os.environ)
    env["MOCOMP_STUDY_CONFIG"] = json.dumps(cfg)
    cmd = voila_command(port, cull_idle_s=args.kernel_cull_s)
    token = secrets.token_urlsafe(24)  # this session's; only the printed address carries it
    try:
        with StudyServer(cmd, env, port, token) as server:
            server.wait_ready()
            if note:
                print(note, file=sys.stderr, flush=True)
            print(f"participant {args.participant}, session {args.session}: open {server.url} "
                  f"(data -> {data / args.participant / args.session}); Ctrl-C stops the server", flush=True)
            rc = server.wait()
            if rc != 0:
                raise MocompError(f"the study server (Voila) on {HOST}:{port} exited with code {rc} (its output "
                                  "is above); the responses written so far are kept")
            return 0
    except ServerStopped as e:
        print(f"participant {args.participant}, session {args.session}: server on {HOST}:{port} stopped "
              f"({signal.Signals(e.signum).name}); the responses so far are saved, the same command resumes",
              file=sys.stderr, flush=True)
        return 128 + e.signum


def register_withdraw(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "withdraw", help="mark a participant's session withdrawn (kept, excluded from the analysis)",
        description="Mark DATA/<participant>/<session>/ withdrawn, as the app's debrief screen does: write "
                    "withdrawn.json (who, when, why) and log the event. Nothing is deleted or changed; "
                    "`mocomp study analyze` leaves the session out and lists it in its report, and `mocomp "
                    "study run` refuses to reopen it. A session open in a running app is refused (withdraw "
                    "from its debrief screen, or stop the server first).")
    _session_args(p)
    p.add_argument("--data", required=True, metavar="DIR", help="folder of session data (as given to `study run`)")
    p.add_argument("--reason", default="", help="optional note (e.g. 'asked by e-mail, 2026-05-01')")
    p.set_defaults(func=run_withdraw)
    return p


def run_withdraw(args) -> int:
    from .session import withdraw_session

    from mocomp.errors import SessionLockedError

    try:
        rec, newly = withdraw_session(args.data, args.participant, args.session, by="experimenter",
                                      reason=args.reason)
    except SessionLockedError as e:
        raise SessionLockedError(f"{e}; nothing was marked: withdraw on the app's debrief screen, or stop its "
                                 "`mocomp study run` and run this again") from None
    folder = Path(args.data) / args.participant / args.session
    if newly:
        print(f"{args.participant}/{args.session}: withdrawn ({rec['n_responses']} responses kept unchanged in "
              f"{folder / 'responses.csv'}, marked by {folder / 'withdrawn.json'}); `mocomp study analyze` "
              f"excludes the session and lists it")
    else:
        print(f"{args.participant}/{args.session}: already withdrawn ({rec.get('withdrawn_utc', '?')}, by "
              f"{rec.get('by', '?')}); nothing changed")
    return 0


def register_analyze(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "analyze", help="analyse every session CSV under a folder (ratings, d', psychometric, mixed model)",
        description="Read every responses.csv below RESPONSES_DIR (schema checked; sessions marked withdrawn are "
                    "left out unread and listed), and write tidy CSVs "
                    "(conditions.csv, trials.csv, participants_*.csv, psychometric.csv, observer_model.csv, "
                    "mixed_model.csv), "
                    "figures and report.md to REPORT_DIR.")
    p.add_argument("responses", metavar="RESPONSES_DIR")
    p.add_argument("-o", "--out", required=True, metavar="REPORT_DIR")
    p.add_argument("--correction", choices=("loglinear", "1/(2N)", "none"), default="loglinear",
                   help="d' correction for rates of 0 or 1 (default loglinear)")
    p.add_argument("--control", choices=("group", "pooled"), default="group",
                   help="false-alarm baseline: unperturbed motions of the same error group, or all of them")
    p.add_argument("--headline", choices=("pooled", "mean"), default="pooled",
                   help="group d' the report leads with and the d' figure shows: the pooled d' (counts pooled over "
                        "participants, as the paper's Table 2; default: with 2-4 trials per participant and "
                        "condition the correction shrinks individual d') or the mean of the per-participant d' "
                        "(Macmillan & Creelman's recommendation, for many trials per participant and condition); "
                        "conditions.csv has both, with CIs")
    p.add_argument("--level", choices=("nominal_level", "achieved_error"), default="nominal_level",
                   help="regressor of the psychometric fits")
    p.add_argument("--link", choices=("probit", "logit"), default="probit")
    p.add_argument("--n-boot", type=int, default=2000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--min-attention", type=float_in(0, 1, what="pass rate"), default=None, metavar="RATE",
                   help="exclude participants whose attention-check pass rate (0-1) is below this")
    p.add_argument("--allow-mixed-sets", action="store_true", help="accept sessions from different stimulus sets")
    p.add_argument("--observer-ci", choices=("profile", "bootstrap", "wald"), default="profile",
                   help="CIs of the observer-model fit (observer_model.csv; default profile likelihood)")
    p.add_argument("--no-observer-model", action="store_true",
                   help="skip the observer-model fit (threshold, slope, bias, lapse)")
    p.add_argument("--no-figures", action="store_true")
    p.set_defaults(func=run_analyze)
    return p


def run_analyze(args) -> int:
    from .analysis import analyze

    res = analyze(args.responses, args.out, level=args.level, control=args.control, correction=args.correction,
                  link=args.link, n_boot=args.n_boot, seed=args.seed, min_attention=args.min_attention,
                  allow_mixed_sets=args.allow_mixed_sets, figures=not args.no_figures,
                  observer_model=not args.no_observer_model, observer_ci=args.observer_ci, headline=args.headline)
    s = res.settings
    wd = f" ({len(s['withdrawn_sessions'])} withdrawn session(s) left out)" if s["withdrawn_sessions"] else ""
    print(f"{s['n_participants']} participants{wd}, {s['n_test_trials']} test trials, "
          f"{len(res.conditions)} condition rows, headline d' = {s['headline']} -> {Path(args.out) / 'report.md'}")
    return 0
