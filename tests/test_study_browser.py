"""End to end in a real browser: Debian's Chromium, driven by Playwright, against the
participant app served by Voila (``mocomp study run``) on 127.0.0.1.

1. A scripted participant completes a short session (consent, info, examples,
   trials by button and by key, a break, an attention check); the CSV holds
   exactly the expected rows, in plan order, with the scripted answers.
   "Must watch first" (the default): an answer key pressed while the video still
   plays does nothing; every row says the rule was enforced and the video had
   ended, and the browser's response time is never shorter than the video.
2. A second window on the same session is refused (session lock).
3. The server is killed (SIGKILL, kernel included) in the middle of a session,
   restarted, the page reopened: the app resumes at the first unanswered
   trial; afterwards no response is lost and none is duplicated, and the rows
   written before the crash are byte-for-byte unchanged.
4. A page reload mid-session whose kernel-shutdown beacon is lost (as with some
   browser extensions): the old kernel lives on, so the reloaded page is told the
   session is open elsewhere; the server culls the orphaned kernel and "Try
   again" resumes the session where it stopped, nothing lost or duplicated.
6. (with 1) Lab readiness: the break screen says how long the break is and counts
   it down, and stays until the participant clicks; the end screen is the debrief
   (purpose, the contact given by ``--contact``, the participant's code);
   "Withdraw my data" there (confirmed) writes ``withdrawn.json`` and changes no
   response, and the reopened page shows "withdrawn" and opens no session.
5. The page needs the token of the printed address: without it the browser lands
   on the login page and no kernel opens the session; with it, a plain reload's
   ``beforeunload`` beacon (which carries the login cookie and ``_xsrf``) shuts
   the old kernel down at once, so the reloaded page resumes without waiting
   for the culler.

Every page is opened at the address ``mocomp study run`` prints (its port and token).

Skips locally when Chromium (/usr/bin/chromium), Playwright or Voila is
missing; under CI=true it fails instead (``.ci/run`` installs Chromium).
"""
from __future__ import annotations

import csv
import io
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from _browser import chromium, need

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.timeout(420)]

CONTACT = "Dr Test Researcher, test@uni.example"
LEVELS = {("am_abrupt", "increase"): (25, 50), ("takeoff", "increase"): (20,)}
DESIGN = {"n_repeats": 2, "n_attention": 1, "break_every": 4}


@pytest.fixture(scope="module")
def browser():
    try:
        import voila  # noqa: F401
    except ImportError:
        need("voila", False)
    with chromium() as br:
        yield br


@pytest.fixture(scope="module")
def stimuli(tmp_path_factory):
    from study.placeholders import make_placeholder_set

    # 0.9 s videos: long enough to press a key while one still plays
    return make_placeholder_set(tmp_path_factory.mktemp("stimuli"), LEVELS, base_clips=("flip",), n_frames=9,
                                fps=10.0)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _descendants(pid: int) -> list[int]:
    """All descendant pids (from /proc), so that a kill takes the kernels too."""
    children: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        children.setdefault(ppid, []).append(int(d.name))
    out, stack = [], [pid]
    while stack:
        for c in children.get(stack.pop(), []):
            out.append(c)
            stack.append(c)
    return out


class Server:
    """``mocomp study run`` in its own process group, with its own Jupyter dirs."""

    def __init__(self, tmp: Path, stimuli, data: Path, participant: str, session: str = "S1",
                 extra: tuple[str, ...] = ()):
        self.tmp, self.data, self.port = tmp, data, _free_port()
        self.args = [sys.executable, "-m", "mocomp", "study", "run", "--participant", participant,
                     "--session", session, "--manifest", str(stimuli.path), "--data", str(data),
                     "--port", str(self.port), "--design", str(self._design_file()), "--lock-timeout", "3",
                     *extra]
        self.env = dict(os.environ)
        for k in ("DATA", "RUNTIME", "CONFIG"):
            d = tmp / f"jupyter_{k.lower()}"
            d.mkdir(exist_ok=True)
            self.env[f"JUPYTER_{k}_DIR"] = str(d)
        self.env["JUPYTER_PLATFORM_DIRS"] = "1"
        self.env.pop("MOCOMP_STUDY_CONFIG", None)
        self.proc: subprocess.Popen | None = None
        self.log = tmp / "server.log"

    def _design_file(self) -> Path:
        p = self.tmp / "design.json"
        p.write_text(json.dumps(DESIGN))
        return p

    def start(self, timeout: float = 90.0) -> str:
        """Start the server; the address it prints (port and this session's token)."""
        self.port = _free_port()
        self.args[self.args.index("--port") + 1] = str(self.port)
        offset = self.log.stat().st_size if self.log.exists() else 0
        logf = open(self.log, "a")
        self.proc = subprocess.Popen(self.args, env=self.env, stdout=logf, stderr=subprocess.STDOUT,
                                     start_new_session=True, cwd=self.tmp)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"server exited early ({self.proc.returncode}):\n{self.log.read_text()[-3000:]}")
            # the address is printed once the server listens on it
            m = re.search(r": open (http://127\.0\.0\.1:(\d+)/\?token=[A-Za-z0-9_-]{24,}) ",
                          self.log.read_bytes()[offset:].decode(errors="replace"))
            if m:
                assert int(m.group(2)) == self.port, m.group(1)  # the requested port, never another
                # a TCP connect only: a page request would start a kernel (and open the session)
                with socket.create_connection(("127.0.0.1", self.port), timeout=2):
                    return m.group(1)
            time.sleep(0.3)
        raise AssertionError(f"server did not print its address within {timeout} s:\n{self.log.read_text()[-3000:]}")

    def kill(self) -> None:
        """SIGKILL the server and every descendant (the kernels run in their own sessions)."""
        if self.proc is None:
            return
        pids = [self.proc.pid] + _descendants(self.proc.pid)
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self.proc.wait(timeout=30)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and any(Path(f"/proc/{p}").exists() and
                                                  "Z" not in _state(p) for p in pids):
            time.sleep(0.2)
        self.proc = None

    def stop(self) -> None:
        self.kill()


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return "Z"


def _rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return list(csv.DictReader(io.StringIO(path.read_text())))


def _wait_rows(path: Path, n: int, timeout: float = 20.0) -> list[dict]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        rows = _rows(path)
        if len(rows) >= n:
            return rows
        time.sleep(0.1)
    raise AssertionError(f"{path} has {len(_rows(path))} rows, expected {n}")


def _open(page, url):
    page.goto(url, timeout=90_000, wait_until="domcontentloaded")
    # the kernel has heard from the page's script ("must watch first" can be enforced)
    page.wait_for_selector(".mocomp-app.mocomp-client-ready", timeout=90_000)


def _intro(page, age="23"):
    page.click(".mocomp-screen-welcome .mocomp-btn-next")
    page.check(".mocomp-consent-check input")
    page.click(".mocomp-btn-consent:not([disabled])")
    page.fill(".mocomp-info-age input", age)
    page.click(".mocomp-btn-info")
    page.wait_for_selector(".mocomp-screen-instructions")
    page.keyboard.press("Space")  # Space = the visible "Start" button


def _examples(page):
    while True:
        page.wait_for_selector(".mocomp-screen-example, .mocomp-screen-trial, .mocomp-screen-break")
        if not page.query_selector(".mocomp-screen-example"):
            return
        idx = _current_trial(page)
        page.click(".mocomp-screen-example .mocomp-btn-next")
        page.wait_for_selector(f".mocomp-trial-{idx}", state="detached")


def _current_trial(page) -> int:
    return page.evaluate("""() => { for (const el of document.querySelectorAll("[class*='mocomp-trial-']")) {
        const m = /mocomp-trial-(\\d+)/.exec(el.className); if (m) return parseInt(m[1]); } return -1; }""")


def _answer_trials(page, n: int, answers: list, log: list, early: bool = False) -> None:
    """Answer ``n`` trials (taking breaks); answers[i] = (response, 'button'|'key').

    ``early``: on the first trial, press an answer key at once, while the video still
    plays ("must watch first": nothing may happen).
    """
    done = 0
    while done < n:
        page.wait_for_selector(".mocomp-screen-trial, .mocomp-screen-break, .mocomp-screen-end")
        if page.query_selector(".mocomp-screen-break"):
            if "break" not in log:  # the first break: it says how long, counts down, and waits for a click
                text = page.inner_text(".mocomp-screen-break")
                m = re.search(r"You have answered (\d+) of (\d+) motions; (\d+) to go", text)
                assert "break of about 1 minute" in text and m, text
                assert int(m.group(1)) + int(m.group(3)) == int(m.group(2)) and int(m.group(1)) % 4 == 0, text
                first = page.inner_text(".mocomp-countdown")
                assert re.fullmatch(r"[01]:\d\d left", first), first
                page.wait_for_timeout(1600)
                later = page.inner_text(".mocomp-countdown")
                assert re.fullmatch(r"0:\d\d left", later) and later != first, (first, later)
                assert page.query_selector(".mocomp-screen-break")  # still on break: only a click resumes
            page.click(".mocomp-screen-break .mocomp-btn-next")
            page.wait_for_selector(".mocomp-screen-break", state="detached")
            log.append("break")
            continue
        if page.query_selector(".mocomp-screen-end"):
            raise AssertionError("session ended early")
        if early and done == 0:
            idx = _current_trial(page)
            assert page.query_selector(".mocomp-screen-trial .mocomp-btn-correct[disabled]")  # locked at first
            page.keyboard.press("i")
            page.wait_for_timeout(150)
            assert _current_trial(page) == idx  # still the same trial: the key did nothing
        page.wait_for_selector(".mocomp-screen-trial .mocomp-btn-correct:not([disabled])")
        idx = _current_trial(page)
        attention = page.query_selector("text=Attention check") is not None
        resp, via = answers[len([x for x in log if x != "break"])]
        if attention:  # a diligent participant follows the instruction
            resp = "incorrect" if page.query_selector("text=please press INCORRECT") else "correct"
        if via == "key":
            page.keyboard.press("c" if resp == "correct" else "i")
        else:
            page.click(f".mocomp-btn-{resp}")
        page.wait_for_selector(f".mocomp-trial-{idx}", state="detached", timeout=30_000)
        log.append((idx, resp, via))
        done += 1


def _script(n):
    return [(("correct", "incorrect")[(i * 7) % 3 == 0], ("button", "key")[i % 2]) for i in range(n)]


def _plan_response_indices(folder: Path) -> list[int]:
    rows = _rows(folder / "plan.csv")
    return [int(r["trial_index"]) for r in rows if r["kind"] != "example"]


def test_complete_session_then_second_window_refused(browser, stimuli, tmp_path):
    data = tmp_path / "data"
    srv = Server(tmp_path, stimuli, data, "P01", extra=("--contact", CONTACT))
    try:
        url = srv.start()
        page = browser.new_page()
        _open(page, url)
        folder = data / "P01" / "S1"
        assert (folder / "plan.csv").exists()  # written before the first trial
        expected_idx = _plan_response_indices(folder)
        n = len(expected_idx)
        assert n == 11  # (3 + 2) stimuli x 2 showings + 1 attention check
        _intro(page)
        _examples(page)
        log: list = []
        _answer_trials(page, n, _script(n), log, early=True)
        page.wait_for_selector(".mocomp-screen-end")
        rows = _wait_rows(folder / "responses.csv", n)
        assert len(rows) == n
        assert [int(r["trial_index"]) for r in rows] == expected_idx
        answered = [x for x in log if x != "break"]
        assert [int(r["trial_index"]) for r in rows] == [a[0] for a in answered]
        assert [r["response"] for r in rows] == [a[1] for a in answered]
        assert [r["input"] for r in rows] == [a[2] for a in answered]
        assert log.count("break") == 2  # break_every=4 over 11 response trials
        rts = [float(r["rt_s"]) for r in rows]
        assert all(0 < t < 60 for t in rts)
        client = [float(r["client_rt_s"]) for r in rows if r["client_rt_s"] != ""]
        assert len(client) >= n - 2  # the browser's clock: video onset -> click
        # must watch first: enforced on every trial, and no answer before the end of the video
        assert {r["must_watch"] for r in rows} == {"1"} and {r["watched_to_end"] for r in rows} == {"1"}
        assert min(client) >= 0.9 - 0.1, client
        after_end = [float(r["client_rt_end_s"]) for r in rows if r["client_rt_end_s"] != ""]
        assert len(after_end) == len(client) and min(after_end) >= 0
        assert all(c - e >= 0.8 for c, e in zip(client, after_end))  # onset -> end covers the 0.9 s video
        att = [r for r in rows if r["kind"] == "attention"]
        assert len(att) == 1 and att[0]["response"] == att[0]["expected_response"]
        info = json.loads((folder / "participant.json").read_text())
        assert info["age"] == 23 and info["participant_id"] == "P01"
        ev = [json.loads(x)["event"] for x in (folder / "events.jsonl").read_text().splitlines()]
        assert ev[0] == "opened" and "consent_given" in ev and ev[-1] == "finished"

        # the end screen is the debrief: purpose, contact, the participant's code
        debrief = page.inner_text(".mocomp-screen-end")
        assert "What this study was about" in debrief and CONTACT in debrief
        assert page.inner_text(".mocomp-participant-code") == "P01" and "session S1" in debrief
        page.close()

        # a finished session reopens on the end screen and writes nothing
        page = browser.new_page()
        _open(page, url)
        page.wait_for_selector(".mocomp-screen-end")
        assert len(_rows(folder / "responses.csv")) == n
        # "Withdraw my data": confirmed, it marks the session; no response is changed or deleted
        rows_before = (folder / "responses.csv").read_bytes()
        page.click(".mocomp-btn-withdraw")
        page.wait_for_selector(".mocomp-screen-withdraw_confirm")
        page.click(".mocomp-btn-withdraw-cancel")  # changed their mind: back to the debrief
        page.wait_for_selector(".mocomp-screen-end")
        assert not (folder / "withdrawn.json").exists()
        page.click(".mocomp-btn-withdraw")
        page.click(".mocomp-btn-withdraw-confirm")
        page.wait_for_selector(".mocomp-screen-withdrawn")
        assert "Your data have been withdrawn" in page.inner_text(".mocomp-screen-withdrawn")
        rec = json.loads((folder / "withdrawn.json").read_text())
        assert rec["by"] == "participant" and rec["n_responses"] == n
        assert (folder / "responses.csv").read_bytes() == rows_before
        page.close()
        # reopened: the "withdrawn" screen, no session opened, nothing written
        page = browser.new_page()
        _open(page, url)
        page.wait_for_selector(".mocomp-screen-withdrawn")
        page.close()
        assert (folder / "responses.csv").read_bytes() == rows_before
        ev = [json.loads(x)["event"] for x in (folder / "events.jsonl").read_text().splitlines()]
        assert ev[-1] == "withdrawn" and ev.count("resumed") == 1  # the withdrawn page opened nothing
    finally:
        srv.stop()

    # two windows on one unfinished session: the second is refused
    srv2 = Server(tmp_path, stimuli, data, "P02")
    try:
        url = srv2.start()
        p1 = browser.new_page()
        _open(p1, url)
        _intro(p1)
        p2 = browser.new_page()
        _open(p2, url)
        p2.wait_for_selector(".mocomp-screen-error", timeout=60_000)
        assert "already open" in p2.inner_text(".mocomp-screen-error")
        p2.close()
        _examples(p1)
        _answer_trials(p1, 2, _script(2), [])
        assert len(_wait_rows(data / "P02" / "S1" / "responses.csv", 2)) == 2
        p1.close()
    finally:
        srv2.stop()


def test_kill_server_mid_session_and_resume(browser, stimuli, tmp_path):
    data = tmp_path / "data"
    folder = data / "P03" / "S1"
    srv = Server(tmp_path, stimuli, data, "P03")
    k = 5
    try:
        url = srv.start()
        page = browser.new_page()
        _open(page, url)
        expected_idx = _plan_response_indices(folder)
        n = len(expected_idx)
        script = _script(n)
        _intro(page)
        _examples(page)
        log: list = []
        _answer_trials(page, k, script, log)
        # the next trial is on screen, so the k-th answer is already on disk
        page.wait_for_selector(".mocomp-screen-trial .mocomp-btn-correct:not([disabled]), .mocomp-screen-break")
        before = (folder / "responses.csv").read_bytes()
        assert len(_rows(folder / "responses.csv")) == k
        srv.kill()  # crash: server and kernel die, the lock file stays behind
        assert json.loads((folder / "session.lock").read_text() or "{}").get("pid")
        page.close()

        url = srv.start()
        page = browser.new_page()
        _open(page, url)
        page.wait_for_selector(".mocomp-screen-welcome_back")
        assert f"trial {k + 1} of {n}" in page.inner_text(".mocomp-screen-welcome_back")
        page.click(".mocomp-screen-welcome_back .mocomp-btn-next")
        _answer_trials(page, n - k, script[k:], log2 := [])
        page.wait_for_selector(".mocomp-screen-end")
        rows = _wait_rows(folder / "responses.csv", n)
        after = (folder / "responses.csv").read_bytes()
        assert after.startswith(before)  # nothing before the crash was rewritten
        idx = [int(r["trial_index"]) for r in rows]
        assert idx == expected_idx  # nothing lost, nothing duplicated, same order
        assert len(set(idx)) == len(idx) == n
        answered = [x for x in log + log2 if x != "break"]
        assert [r["response"] for r in rows] == [a[1] for a in answered]
        ev = [json.loads(x) for x in (folder / "events.jsonl").read_text().splitlines()]
        names = [e["event"] for e in ev]
        assert "stale_lock_recovered" in names and "resumed" in names and names[-1] == "finished"
        assert {r["must_watch"] for r in rows} == {"1"}  # also after the restart
        resumed = next(e for e in ev if e["event"] == "resumed")
        assert resumed["n_answered"] == k
        page.close()
    finally:
        srv.stop()


def test_reload_with_lost_shutdown_beacon_resumes_after_the_orphan_is_culled(browser, stimuli, tmp_path):
    data = tmp_path / "data"
    folder = data / "P04" / "S1"
    cull = 4  # seconds (the default is 30); the server checks every second
    srv = Server(tmp_path, stimuli, data, "P04", extra=("--kernel-cull-s", str(cull)))
    k = 2
    try:
        url = srv.start()
        page = browser.new_page()
        _open(page, url)
        expected_idx = _plan_response_indices(folder)
        n = len(expected_idx)
        script = _script(n)
        _intro(page)
        _examples(page)
        log: list = []
        _answer_trials(page, k, script, log)
        page.wait_for_selector(".mocomp-screen-trial .mocomp-btn-correct:not([disabled]), .mocomp-screen-break")
        holder = json.loads((folder / "session.lock").read_text())["pid"]
        # the page's beforeunload beacon (voila/api/shutdown/<kernel>) never reaches the server
        page.evaluate("() => { navigator.sendBeacon = () => true; }")
        t0 = time.monotonic()
        page.reload(wait_until="domcontentloaded", timeout=90_000)
        page.wait_for_selector(".mocomp-screen-error, .mocomp-screen-welcome_back", timeout=90_000)
        if page.query_selector(".mocomp-screen-error"):
            # the new kernel came up before the orphan was culled: told so, and "Try again" works
            msg = page.inner_text(".mocomp-screen-error")
            assert "already open" in msg and f"within about {cull + 1} seconds" in msg
            assert len(_rows(folder / "responses.csv")) == k  # nothing written by either window meanwhile
            deadline = time.monotonic() + 60
            while True:
                page.click(".mocomp-btn-retry")
                try:
                    page.wait_for_selector(".mocomp-screen-welcome_back", timeout=6_000)
                    break
                except Exception:
                    assert time.monotonic() < deadline, "the orphaned kernel was never culled"
        waited = time.monotonic() - t0
        # it was the server's culler (the beacon never arrived) that shut the old kernel down
        log_text = srv.log.read_text()
        assert "Culling 'idle' kernel" in log_text and "with 0 connections" in log_text, log_text[-2000:]
        assert not Path(f"/proc/{holder}").exists() or _state(holder) == "Z"
        assert f"trial {k + 1} of {n}" in page.inner_text(".mocomp-screen-welcome_back")
        page.click(".mocomp-screen-welcome_back .mocomp-btn-next")
        _answer_trials(page, 1, script[k:], log2 := [])
        rows = _wait_rows(folder / "responses.csv", k + 1)
        idx = [int(r["trial_index"]) for r in rows]
        assert idx == expected_idx[:k + 1] and len(set(idx)) == k + 1  # nothing lost, nothing duplicated
        assert [r["response"] for r in rows] == [a[1] for a in log + log2 if a != "break"]
        ev = [json.loads(x) for x in (folder / "events.jsonl").read_text().splitlines()]
        names = [e["event"] for e in ev]
        assert names.count("opened") == 1 and names.count("resumed") == 1
        rec = next(e for e in ev if e["event"] == "stale_lock_recovered")
        assert rec["previous_holder"]["pid"] == holder
        assert waited < 60, waited
        page.close()
    finally:
        srv.stop()


def test_token_required_and_the_shutdown_beacon_works_with_it(browser, stimuli, tmp_path):
    data = tmp_path / "data"
    folder = data / "P05" / "S1"
    srv = Server(tmp_path, stimuli, data, "P05")  # default --kernel-cull-s 30
    k = 1
    try:
        url = srv.start()
        bare = url.split("?", 1)[0]
        for wrong in (bare, bare + "?token=x" + url.split("?token=", 1)[1][1:]):
            ctx = browser.new_context()  # no cookie of an earlier page
            p0 = ctx.new_page()
            p0.goto(wrong, timeout=60_000, wait_until="domcontentloaded")
            assert "/login" in p0.url and not p0.query_selector(".mocomp-app"), p0.url
            ctx.close()
        time.sleep(1.0)
        assert not (data / "P05").exists()  # no kernel ran the app: no session was opened
        page = browser.new_page()
        _open(page, url)
        expected_idx = _plan_response_indices(folder)
        script = _script(len(expected_idx))
        _intro(page)
        _examples(page)
        log: list = []
        _answer_trials(page, k, script, log)
        page.wait_for_selector(".mocomp-screen-trial .mocomp-btn-correct:not([disabled]), .mocomp-screen-break")
        holder = json.loads((folder / "session.lock").read_text())["pid"]
        t0 = time.monotonic()
        page.reload(wait_until="domcontentloaded", timeout=90_000)  # the beacon is sent as usual
        page.wait_for_selector(".mocomp-screen-error, .mocomp-screen-welcome_back", timeout=90_000)
        while not page.query_selector(".mocomp-screen-welcome_back"):  # the old kernel was still exiting
            assert time.monotonic() - t0 < 25, "the beacon did not shut the old kernel down"
            page.click(".mocomp-btn-retry")
            try:
                page.wait_for_selector(".mocomp-screen-welcome_back", timeout=3_000)
            except Exception:
                pass
        assert time.monotonic() - t0 < 25  # well before the culler (30 s idle) could have acted
        text = srv.log.read_text()
        assert "Kernel shutdown:" in text and "Culling 'idle' kernel" not in text, text[-2000:]
        assert "403 POST /voila/api/shutdown/" not in text, text[-2000:]  # the beacon was accepted
        assert not Path(f"/proc/{holder}").exists() or _state(holder) == "Z"
        assert f"trial {k + 1} of {len(expected_idx)}" in page.inner_text(".mocomp-screen-welcome_back")
        page.click(".mocomp-screen-welcome_back .mocomp-btn-next")
        _answer_trials(page, 1, script[k:], log2 := [])
        rows = _wait_rows(folder / "responses.csv", k + 1)
        assert [int(r["trial_index"]) for r in rows] == expected_idx[:k + 1]
        assert [r["response"] for r in rows] == [a[1] for a in log + log2 if a != "break"]
        page.close()
    finally:
        srv.stop()
