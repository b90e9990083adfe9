"""``mocomp study run`` / ``mocomp study analyze`` through the real CLI entry point."""
from __future__ import annotations

import json

import pandas as pd

from mocomp.cli import main
from study.observers import Observer, Psychometric, simulate_cohort
from study.placeholders import make_placeholder_set


def test_study_commands(tmp_path, capsys):
    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20, 40)}, base_clips=("a", "b"),
                                n_frames=4)
    simulate_cohort(stim, Observer({("takeoff", "increase"): Psychometric(25, 2)}), tmp_path / "data", n=4)
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "rep"), "--n-boot", "50",
                 "--correction", "1/(2N)", "--no-figures"]) == 0
    c = pd.read_csv(tmp_path / "rep" / "conditions.csv")
    assert set(c["correction"]) == {"1/(2N)"} and len(c) == 3
    assert "4 participants" in capsys.readouterr().out
    # bad input: one line, exit 2
    assert main(["study", "analyze", str(tmp_path / "nope"), "-o", str(tmp_path / "r2")]) == 2
    assert "not found" in capsys.readouterr().err
    src = next((tmp_path / "data").rglob("responses.csv"))
    for name, text, msg in (
            ("missing", "\n".join(",".join(x.split(",")[:9] + x.split(",")[10:]) for x in src.read_text().splitlines()) + "\n",
             "missing column(s) stimulus_id"),
            ("dup", src.read_text() + src.read_text().splitlines()[3] + "\n", "duplicate trial"),
            ("empty", "", "empty CSV")):
        bad = tmp_path / name / "P" / "S" / "responses.csv"
        bad.parent.mkdir(parents=True)
        bad.write_text(text)
        assert main(["study", "analyze", str(tmp_path / name), "-o", str(tmp_path / "r3")]) == 2
        err = capsys.readouterr().err
        assert msg in err and str(bad) in err and len(err.strip().splitlines()) == 1, err
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d"), "--break-every", "3", "--print-config"]) == 0
    cfg = json.loads(capsys.readouterr().out)
    assert cfg["design"] == {"break_every": 3} and cfg["participant_id"] == "P1"
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d"), "--no-must-watch", "--print-config"]) == 0
    assert json.loads(capsys.readouterr().out)["design"] == {"must_watch": False}
    assert main(["study", "run", "--participant", "../P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d"), "--print-config"]) == 2
    assert "not valid" in capsys.readouterr().err
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(tmp_path / "m.csv"),
                 "--data", str(tmp_path / "d"), "--print-config"]) == 2


def test_run_and_analyze_refuse_bad_input_before_starting(tmp_path, capsys, monkeypatch):
    """Errors a participant's browser must never be the first to see: refused by the CLI, exit 2, one line."""
    import importlib.util

    import study.study_cli as sc

    def no_server(*a, **k):
        raise AssertionError("a server was started")

    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20,)}, base_clips=("a",), n_frames=4)
    stim2 = make_placeholder_set(tmp_path / "s2", {("takeoff", "increase"): (20, 40)}, base_clips=("a", "b"),
                                 n_frames=4)
    monkeypatch.setattr(sc.subprocess, "Popen", no_server)
    run = ["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
           "--data", str(tmp_path / "d")]
    # counterbalance='latin' without the participant number
    design = tmp_path / "design.json"
    design.write_text(json.dumps({"counterbalance": "latin"}))
    assert main(run + ["--design", str(design)]) == 2
    err = capsys.readouterr().err
    assert "counterbalance='latin'" in err and "--counterbalance-index" in err and str(design) in err
    assert main(run + ["--design", str(design), "--counterbalance-index", "3", "--print-config"]) == 0
    assert json.loads(capsys.readouterr().out)["counterbalance_index"] == 3
    # voila not importable
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "voila" else real(name, *a))
    assert main(run) == 2
    err = capsys.readouterr().err
    assert "Voila" in err and "pip install" in err and len(err.strip().splitlines()) == 1
    monkeypatch.setattr(importlib.util, "find_spec", real)
    # a video changed after rendering
    vid = stim.video_path(stim.ids[0])
    vid.write_bytes(vid.read_bytes() + b"x")
    assert main(run + ["--print-config"]) == 2
    err = capsys.readouterr().err
    assert "manifest.csv:2 [sha256]" in err and vid.name in err
    # --level achieved_error on responses without that column names the file and the column
    simulate_cohort(stim2, Observer({("takeoff", "increase"): Psychometric(25, 2)}), tmp_path / "data", n=2)
    src = next((tmp_path / "data").rglob("responses.csv"))
    df = pd.read_csv(src, dtype=str, keep_default_na=False).drop(columns=["achieved_error"])
    df.to_csv(src, index=False)
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "r"), "--level",
                 "achieved_error", "--no-figures", "--n-boot", "20"]) == 2
    err = capsys.readouterr().err
    assert f"{src}:1 [achieved_error]: no column 'achieved_error'" in err and len(err.strip().splitlines()) == 1
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "r"), "--no-figures",
                 "--n-boot", "20"]) == 0  # nominal levels need no achieved_error


def test_package_docstring_lists_every_module():
    from pathlib import Path

    import study

    mods = sorted(p.stem for p in Path(study.__file__).parent.glob("*.py") if p.stem != "__init__")
    missing = [m for m in mods if f":mod:`study.{m}`" not in study.__doc__]
    assert not missing, missing


# ------------------------------------------------------------------ the server of `mocomp study run`
import os  # noqa: E402
import signal  # noqa: E402
import socket  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")


def _need_voila():
    import importlib.util

    if importlib.util.find_spec("voila") is None:
        if IN_CI:
            pytest.fail("CI=true but voila is not installed (the study-server tests must run in CI)")
        pytest.skip("voila not installed")


def _occupied(host="127.0.0.1"):
    s = socket.socket()
    s.bind((host, 0))
    s.listen(1)
    return s


def _run_args(stim, data, *extra):
    return ["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
            "--data", str(data), *extra]


def test_run_refuses_a_taken_port_and_never_starts_a_server(tmp_path, capsys, monkeypatch):
    """The printed address must be the served one: a taken port is refused in one line naming it."""
    import study.study_cli as sc

    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20,)}, base_clips=("a",), n_frames=4)

    def no_server(*a, **k):
        raise AssertionError("a server was started")

    monkeypatch.setattr(sc.subprocess, "Popen", no_server)
    for host in ("127.0.0.1", "0.0.0.0"):  # also a listener on every interface
        with _occupied(host) as s:
            port = s.getsockname()[1]
            assert main(_run_args(stim, tmp_path / "d", "--port", str(port))) == 2
            err = capsys.readouterr().err
            assert f"port {port} on 127.0.0.1 is already in use" in err and "--port 0" in err, err
            assert len(err.strip().splitlines()) == 1
    with socket.socket() as s:  # bound, not listening: the server could not bind it either
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        assert main(_run_args(stim, tmp_path / "d", "--port", str(port))) == 2
        assert f"port {port} on 127.0.0.1 is already in use" in capsys.readouterr().err
    for bad in ("-1", "65536"):
        assert main(_run_args(stim, tmp_path / "d", "--port", bad)) == 2
        assert "--port must be 0-65535" in capsys.readouterr().err
    # a whitespace-padded id is refused, not opened as P1
    assert main(["study", "run", "--participant", " P1 ", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert "participant id ' P1 ' is not valid" in err and "whitespace" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "d" / "P1").exists()


def test_port_zero_and_voila_command():
    from study.study_cli import check_port_free, free_port, voila_command

    p = free_port()
    check_port_free(p)  # free: no error
    cmd = voila_command(p)
    assert f"--port={p}" in cmd and "--Voila.port_retries=0" in cmd and "--Voila.ip=127.0.0.1" in cmd
    assert "--token" in cmd and not any("token=" in c.lower() for c in cmd)  # the secret is not on the command line
    with pytest.raises(ValueError, match="port must be 1-65535"):
        voila_command(0)


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_voila_exits_instead_of_moving_to_another_port(tmp_path):
    """The server side of the rule (for a port taken between the check and the bind)."""
    _need_voila()
    from study.study_cli import _listening_ports, _tree, voila_command

    env = dict(os.environ, JUPYTER_TOKEN="t" * 32, JUPYTER_PLATFORM_DIRS="1")
    for k in ("DATA", "RUNTIME", "CONFIG"):
        env[f"JUPYTER_{k}_DIR"] = str(tmp_path / k)
    with _occupied() as s:
        port = s.getsockname()[1]
        proc = subprocess.Popen(voila_command(port), env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                start_new_session=True)
        try:
            seen = set()
            deadline = time.monotonic() + 150
            while proc.poll() is None and time.monotonic() < deadline:
                seen |= _listening_ports(_tree(proc.pid))
                time.sleep(0.2)
            assert proc.poll() is not None, "Voila kept running although its port was taken"
            out = proc.stdout.read().decode(errors="replace")
            assert proc.returncode != 0 and not seen, (seen, out[-2000:])
            assert "no available port" in out, out[-2000:]
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


def _get(port, path):
    import http.client

    c = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    try:
        c.request("GET", path)
        r = c.getresponse()
        return r.status, r.getheader("Location") or "", r.read().decode(errors="replace")
    finally:
        c.close()


def _events(folder):
    return [json.loads(x)["event"] for x in (folder / "events.jsonl").read_text().splitlines()]


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_served_address_token_and_shutdown_on_signal(tmp_path, sig):
    """`mocomp study run --port 0`: it listens on exactly the printed port; without the printed token a
    request is sent to the login page and starts no kernel; with it the app opens the session. SIGTERM or
    SIGINT to `mocomp study run` ends the server and its kernel (no orphan, the port and the session lock
    are free again) and leaves the rows written so far untouched."""
    _need_voila()
    import psutil

    from mocomp.errors import SessionLockedError
    from study.controller import TrialController
    from study.session import Session
    from study.study_cli import _tree, check_port_free

    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20, 40)}, base_clips=("a",),
                                n_frames=4)
    data = tmp_path / "data"
    folder = data / "P1" / "S1"
    sess = Session.open(data, "P1", "S1", stim)
    ctl = TrialController(sess)
    for _ in range(2):
        ctl.show()
        assert ctl.respond("correct", input="test") is not None
    sess.close()
    before = (folder / "responses.csv").read_bytes()
    n_events = len(_events(folder))

    env = dict(os.environ, JUPYTER_PLATFORM_DIRS="1")
    for k in ("DATA", "RUNTIME", "CONFIG"):
        env[f"JUPYTER_{k}_DIR"] = str(tmp_path / k)
    env.pop("MOCOMP_STUDY_CONFIG", None)
    env.pop("JUPYTER_TOKEN", None)
    log = tmp_path / "out.log"
    with open(log, "w") as f:
        proc = subprocess.Popen([sys.executable, "-m", "mocomp", *_run_args(stim, data, "--port", "0",
                                                                           "--lock-timeout", "2")],
                                env=env, stdout=f, stderr=subprocess.STDOUT, start_new_session=True, cwd=tmp_path)
    tree: dict = {}
    try:
        deadline = time.monotonic() + 180
        url = None
        while url is None:
            assert proc.poll() is None, log.read_text()[-3000:]
            assert time.monotonic() < deadline, log.read_text()[-3000:]
            for line in log.read_text().splitlines():
                if ": open http://" in line:
                    url = line.split(": open ", 1)[1].split()[0]
            time.sleep(0.2)
        assert url.startswith("http://127.0.0.1:") and "?token=" in url
        port = int(url.split(":")[2].split("/")[0])
        token = url.split("?token=", 1)[1]
        assert port > 0 and len(token) >= 24
        # the printed port is the one a process of this server listens on (and only it)
        tree = _tree(proc.pid)
        listeners = {c.pid for c in psutil.net_connections(kind="tcp")
                     if c.status == psutil.CONN_LISTEN and c.laddr.port == port}
        assert listeners and listeners <= set(tree), (listeners, tree)
        # no token, a wrong one: sent to the login page, no kernel, the session is not touched
        for path in ("/", "/?token=wrong", "/?token=" + token[:-1]):
            status, loc, body = _get(port, path)
            assert status in (302, 403) and (status == 403 or "/login" in loc), (path, status, loc)
            assert "mocomp" not in body
        time.sleep(1.0)
        assert len(_events(folder)) == n_events
        # with the token: the page, whose kernel resumes the session and holds its lock
        status, _, body = _get(port, "/?token=" + token)
        assert status == 200 and "voila" in body.lower()
        deadline = time.monotonic() + 60
        while "resumed" not in _events(folder):
            assert time.monotonic() < deadline, _events(folder)
            time.sleep(0.2)
        with pytest.raises(SessionLockedError):
            Session.open(data, "P1", "S1", stim, lock_timeout=0.5)
        tree = _tree(proc.pid)
        assert len(tree) >= 3  # mocomp, voila, the page's kernel

        os.kill(proc.pid, sig)  # to `mocomp study run` only, as `kill PID` or a terminal's Ctrl-C does
        rc = proc.wait(timeout=90)
        assert rc == 128 + sig, log.read_text()[-3000:]
        deadline = time.monotonic() + 15
        while True:
            alive = [p for p in tree if psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE]
            if not alive or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        assert not alive, [psutil.Process(p).cmdline() for p in alive]
        check_port_free(port)  # the port is free again
        assert "stopped (" + signal.Signals(sig).name + ")" in log.read_text()
        assert (folder / "responses.csv").read_bytes() == before  # the rows so far, unchanged
        sess = Session.open(data, "P1", "S1", stim, lock_timeout=5)  # the kernel released the lock
        assert sess.state.n_answered == 2
        sess.close()
    finally:
        for p in [proc.pid, *tree]:
            try:
                os.kill(p, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        proc.wait(timeout=30)


_FAKE_SERVER = r"""
import os, signal, subprocess, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)  # a server that does not stop on SIGINT
kid = subprocess.Popen([sys.executable, "-c",
    "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); time.sleep(600)"],
    start_new_session=True)  # like a kernel: a session of its own, survives a group kill
open(sys.argv[1], "w").write(str(kid.pid))
if sys.argv[2] == "crash":
    time.sleep(1.5)
    os._exit(3)
time.sleep(600)
"""


def _wait_file(p: Path, timeout=30) -> int:
    deadline = time.monotonic() + timeout
    while not (p.exists() and p.read_text()):
        assert time.monotonic() < deadline
        time.sleep(0.05)
    return int(p.read_text())


def _gone(pid: int) -> bool:
    import psutil

    try:
        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


@pytest.mark.timeout(120)
def test_server_tree_is_ended_on_every_exit_path(tmp_path):
    """StudyServer ends the server and processes it started in sessions of their own (kernels):
    after an exception while serving, and after the server crashed and left its child behind."""
    from study.study_cli import StudyServer

    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)}
    # an exception while serving (a server ignoring SIGINT, a child ignoring SIGTERM: SIGKILL ends them)
    pidf = tmp_path / "kid1"
    with pytest.raises(RuntimeError, match="boom"):
        with StudyServer([sys.executable, "-c", _FAKE_SERVER, str(pidf), "serve"], dict(os.environ), 1, "t",
                         grace_s=1, term_s=1) as s:
            kid = _wait_file(pidf)
            server_pid = s.proc.pid
            s._remember()
            raise RuntimeError("boom")
    assert _gone(server_pid) and _gone(kid)
    assert s.proc is None
    # the server crashes on its own and its child is re-parented: still ended
    pidf = tmp_path / "kid2"
    with StudyServer([sys.executable, "-c", _FAKE_SERVER, str(pidf), "crash"], dict(os.environ), 1, "t",
                     grace_s=1, term_s=1) as s:
        kid = _wait_file(pidf)
        assert s.wait() == 3
        assert not _gone(kid)  # orphaned, until the server object ends it
    assert _gone(kid)
    # the caller's signal handlers are back
    assert {sig: signal.getsignal(sig) for sig in handlers} == handlers


_KILLED_PARENT = r"""
import os, sys, time
from study.study_cli import StudyServer
s = StudyServer([sys.executable, "-c", "import time; time.sleep(600)"], dict(os.environ), 1, "t")
s.start()
print(s.proc.pid, flush=True)
time.sleep(600)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="parent-death signal is Linux-only")
@pytest.mark.timeout(60)
def test_server_dies_with_a_parent_killed_by_sigkill(tmp_path):
    """SIGKILL to `mocomp study run` reaches no handler: the kernel's parent-death signal
    (SIGINT) still ends the server it started, instead of leaving it orphaned on its port."""
    parent = subprocess.Popen([sys.executable, "-c", _KILLED_PARENT], stdout=subprocess.PIPE, text=True)
    try:
        server = int(parent.stdout.readline())
        assert not _gone(server)
        parent.kill()
        parent.wait(timeout=10)
        deadline = time.monotonic() + 30  # a loaded 2-core CI host (a reproduce run beside the tests) took > 10 s once
        while not _gone(server) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _gone(server)
    finally:
        parent.kill()
        try:
            os.kill(server, signal.SIGKILL)
        except (ProcessLookupError, PermissionError, UnboundLocalError):
            pass


def test_withdraw_command_and_run_refuses_a_withdrawn_session(tmp_path, capsys):
    """`mocomp study withdraw` marks a session (nothing deleted), says so, is idempotent; bad input is
    one line, exit 2; `study run` then refuses the session before starting anything."""
    from study.controller import TrialController, run_headless
    from study.session import Session

    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20,)}, base_clips=("a",), n_frames=4)
    data = tmp_path / "d"
    with Session.open(data, "P1", "S1", stim) as s:
        ctl = TrialController(s)
        for _ in range(2):
            ctl.show()
            ctl.respond("correct", input="test")
        folder = s.folder
    rows = (folder / "responses.csv").read_bytes()
    wd = ["study", "withdraw", "--participant", "P1", "--session", "S1", "--data", str(data)]
    assert main(wd + ["--reason", "asked by e-mail"]) == 0
    out = capsys.readouterr().out
    assert "P1/S1: withdrawn (2 responses kept unchanged" in out and "excludes the session" in out
    rec = json.loads((folder / "withdrawn.json").read_text())
    assert rec["by"] == "experimenter" and rec["reason"] == "asked by e-mail"
    assert (folder / "responses.csv").read_bytes() == rows
    assert main(wd) == 0
    assert "already withdrawn" in capsys.readouterr().out
    assert json.loads((folder / "withdrawn.json").read_text()) == rec
    # run refuses it (before any server; one line, exit 2)
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(data), "--print-config"]) == 2
    err = capsys.readouterr().err
    assert "was withdrawn" in err and len(err.strip().splitlines()) == 1
    # bad input
    assert main(["study", "withdraw", "--participant", "P7", "--session", "S1", "--data", str(data)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mocomp study: error: ") and "no session P7/S1" in err
    assert len(err.strip().splitlines()) == 1
    # a session open in a running app is refused, not marked
    with Session.open(data, "P2", "S1", stim) as s2:
        assert main(["study", "withdraw", "--participant", "P2", "--session", "S1", "--data", str(data)]) == 2
        err = capsys.readouterr().err
        assert "already open" in err and "nothing was marked" in err and len(err.strip().splitlines()) == 1
        assert not (s2.folder / "withdrawn.json").exists()
        run_headless(TrialController(s2), lambda v: ("correct", 0.5))  # the session goes on normally
    assert main(["study", "withdraw", "--participant", "P2", "--session", "S1", "--data", str(data)]) == 0
    assert "P2/S1: withdrawn (4 responses" in capsys.readouterr().out  # all 4 trials of the plan


def test_run_options_for_breaks_and_contact(tmp_path, capsys):
    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20,)}, base_clips=("a",), n_frames=4)
    base = ["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
            "--data", str(tmp_path / "d"), "--print-config"]
    assert main(base + ["--break-every", "0", "--break-s", "90", "--contact", "lab@uni.example"]) == 0
    cfg = json.loads(capsys.readouterr().out)
    assert cfg["design"] == {"break_every": 0, "break_s": 90.0} and cfg["texts"] == {"contact": "lab@uni.example"}
    from study.design import DesignConfig

    assert DesignConfig.from_dict(cfg["design"]).break_every is None  # 0 = no breaks
    texts = tmp_path / "texts.json"
    texts.write_text(json.dumps({"contact": "from the file", "title": "Pilot"}))
    assert main(base + ["--texts", str(texts), "--contact", "from the command line"]) == 0
    assert json.loads(capsys.readouterr().out)["texts"] == {"contact": "from the command line", "title": "Pilot"}
    texts.write_text(json.dumps({"contakt": "typo"}))
    assert main(base + ["--texts", str(texts)]) == 2
    err = capsys.readouterr().err
    assert "contakt" in err and "fields: title" in err and len(err.strip().splitlines()) == 1
    assert main(base + ["--break-every", "-1"]) == 2
    assert "--break-every must be >= 0" in capsys.readouterr().err
