"""Crash-safe session storage: plan before the first trial, append+fsync, resume in the same
order, never overwrite, torn-line repair, and the session lock (other process, stale, foreign host)."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from mocomp.errors import SessionLockedError, StudyDataError
from study.controller import TrialController, run_headless
from study.design import DesignConfig
from study.placeholders import make_placeholder_set
from study.session import RESPONSE_COLUMNS, Session, SessionLock

LEVELS = {("am_abrupt", "increase"): (25, 50), ("takeoff", "increase"): (20,)}


@pytest.fixture(scope="module")
def stimuli(tmp_path_factory):
    return make_placeholder_set(tmp_path_factory.mktemp("stim"), LEVELS, base_clips=("a", "b"), n_frames=4)


def _answer_n(sess, n, resp="correct"):
    ctl = TrialController(sess)
    for _ in range(n):
        ctl.show()
        assert ctl.respond(resp, input="test") is not None
    return ctl


def test_create_resume_same_order(stimuli, tmp_path):
    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        folder = s.folder
        assert (folder / "plan.csv").exists() and (folder / "plan.json").exists()
        meta = json.loads((folder / "plan.json").read_text())
        assert meta["plan_sha256"] == s.plan.sha256 and meta["stimulus_set_id"] == stimuli.set_id
        plan_idx = list(s.plan.response_trials["trial_index"])
        assert (folder / "responses.csv").read_text().strip() == ",".join(RESPONSE_COLUMNS)
        ctl = _answer_n(s, 3)
        # a second answer to the same trial (double click) is ignored, not written
        ctl.show()
        assert ctl.respond("incorrect", input="test") is not None
        assert ctl.respond("incorrect", input="test") is None
        assert ctl.respond("correct", input="test", trial_index=plan_idx[0]) is None
    with Session.open(tmp_path, "P1", "S1", stimuli) as s2:
        assert s2.state.resumed and s2.state.n_answered == 4
        assert s2.next_response_index() == plan_idx[4]
        run_headless(TrialController(s2), lambda v: ("incorrect", 0.5))
        rows = s2.responses()
    assert [int(i) for i in rows["trial_index"]] == plan_idx
    assert list(rows["response"][:3]) == ["correct"] * 3 and rows["response"].iloc[3] == "incorrect"
    ev = [json.loads(x)["event"] for x in (folder / "events.jsonl").read_text().splitlines()]
    assert ev.count("opened") == 1 and ev.count("resumed") == 1 and ev[-1] == "finished"
    assert "response_ignored" in ev


def test_refuses_a_different_plan_or_stimulus_set(stimuli, tmp_path):
    Session.open(tmp_path, "P1", "S1", stimuli, config=DesignConfig(break_every=5)).close()
    with pytest.raises(ValueError, match="seed"):
        Session.open(tmp_path, "P1", "S1", stimuli, seed=123)
    with pytest.raises(ValueError, match="different design"):
        Session.open(tmp_path, "P1", "S1", stimuli, config=DesignConfig(break_every=6))
    other = make_placeholder_set(tmp_path / "other", LEVELS, base_clips=("a",), n_frames=4, seed=9)
    with pytest.raises(StudyDataError, match="stimulus set"):
        Session.open(tmp_path, "P1", "S1", other)
    # the refused opens did not touch anything and released the lock
    Session.open(tmp_path, "P1", "S1", stimuli).close()
    # the plan on disk is protected by its hash
    plan = tmp_path / "P1" / "S1" / "plan.csv"
    plan.write_text(plan.read_text().replace("test", "tset", 1))
    with pytest.raises(StudyDataError, match="plan_sha256"):
        Session.open(tmp_path, "P1", "S1", stimuli)
    for bad in ("../x", "a/b", "", ".hidden", "x" * 65):
        with pytest.raises(ValueError, match="not valid"):
            Session.open(tmp_path, bad, "S1", stimuli)


def test_corrupt_responses_are_reported_with_line(stimuli, tmp_path):
    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        _answer_n(s, 3)
        path = s.responses_path
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines + [lines[2]]))  # trial of line 3 appended again
    with pytest.raises(StudyDataError, match=r"responses\.csv:5 \[trial_index\]: duplicate trial_index"):
        Session.open(tmp_path, "P1", "S1", stimuli)


def test_a_session_written_with_other_columns_is_refused_untouched(stimuli, tmp_path):
    """A session from another version of the package (a column fewer) is named, not rewritten."""
    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        _answer_n(s, 2)
        path = s.responses_path
    lines = path.read_text().splitlines(keepends=True)
    drop = RESPONSE_COLUMNS.index("client_rt_end_s")
    old = ["".join(",".join(f for i, f in enumerate(ln.rstrip("\r\n").split(",")) if i != drop) + "\n")
           for ln in lines]
    path.write_text("".join(old))
    before = path.read_bytes()
    with pytest.raises(StudyDataError, match=r"responses\.csv:1: header differs .*missing client_rt_end_s\)"):
        Session.open(tmp_path, "P1", "S1", stimuli)
    assert path.read_bytes() == before


def test_torn_last_line_is_backed_up_and_repaired(stimuli, tmp_path):
    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        _answer_n(s, 2)
        path = s.responses_path
    full = path.read_bytes()
    path.write_bytes(full + b"P1,S1,abc,def,12")  # a crash in the middle of a write
    with Session.open(tmp_path, "P1", "S1", stimuli) as s2:
        assert s2.state.repaired_torn_line and s2.n_answered == 2
        _answer_n(s2, 1)
    backups = list(path.parent.glob("responses.csv.torn-*"))
    assert len(backups) == 1 and backups[0].read_bytes() == full + b"P1,S1,abc,def,12"
    assert path.read_bytes().startswith(full) and len(s2.responses()) == 3


def test_participant_info_never_overwritten(stimuli, tmp_path):
    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        s.save_participant_info({"age": 22})
    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        assert s.save_participant_info({"age": 99})["age"] == 22
        assert s.participant_info()["age"] == 22
        assert s.events()[-1]["event"] == "participant_info_not_overwritten"


_HOLDER = """
import sys, time
from study.stimulus_set import load_manifest
from study.session import Session
s = Session.open(sys.argv[1], "P1", "S1", load_manifest(sys.argv[2]))
print("locked", flush=True)
time.sleep(120)
"""


def test_lock_other_process_then_stale_after_crash(stimuli, tmp_path):
    env = dict(os.environ)
    proc = subprocess.Popen([sys.executable, "-c", _HOLDER, str(tmp_path), str(stimuli.path)],
                            stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout.readline().strip() == "locked"
        with pytest.raises(SessionLockedError, match=f"pid {proc.pid}"):
            Session.open(tmp_path, "P1", "S1", stimuli, lock_timeout=0.5)
    finally:
        proc.send_signal(signal.SIGKILL)  # a crash: no clean release
        proc.wait(timeout=10)
    lock = tmp_path / "P1" / "S1" / "session.lock"
    assert json.loads(lock.read_text())["pid"] == proc.pid  # left behind
    with Session.open(tmp_path, "P1", "S1", stimuli, lock_timeout=0.5) as s:
        ev = s.events()
        stale = [e for e in ev if e["event"] == "stale_lock_recovered"]
        assert stale and stale[0]["previous_holder"]["pid"] == proc.pid
        # the same process cannot open it twice either
        t0 = time.monotonic()
        with pytest.raises(SessionLockedError, match="this process"):
            Session.open(tmp_path, "P1", "S1", stimuli, lock_timeout=5)
        assert time.monotonic() - t0 < 1
    assert lock.read_text() == ""  # released cleanly


def test_lock_from_another_host(tmp_path):
    folder = tmp_path / "P1" / "S1"
    folder.mkdir(parents=True)
    lock = folder / "session.lock"
    lock.write_text(json.dumps({"pid": 1, "host": "elsewhere-" + socket.gethostname(), "since": "x"}))
    with pytest.raises(SessionLockedError, match="host elsewhere"):
        SessionLock(folder, stale_after_s=60).acquire(timeout=0)
    old = time.time() - 3600
    os.utime(lock, (old, old))  # heartbeat an hour old: stale
    lk = SessionLock(folder, stale_after_s=60).acquire(timeout=0)
    assert lk.took_over["host"].startswith("elsewhere")
    lk.release()


def test_resume_refuses_a_different_counterbalance_index(stimuli, tmp_path):
    cfg = DesignConfig(counterbalance="latin")
    with Session.open(tmp_path, "P1", "S1", stimuli, config=cfg, counterbalance_index=1) as s:
        order = s.plan.meta["group_order"]
        _answer_n(s, 2)
    for other in (0, 3, None):  # 3 = 1 mod 2 gives the same Latin row, but it is not what was planned
        with pytest.raises(ValueError, match="counterbalance index 1"):
            Session.open(tmp_path, "P1", "S1", stimuli, config=cfg, counterbalance_index=other)
    with Session.open(tmp_path, "P1", "S1", stimuli, config=cfg, counterbalance_index=1) as s:
        assert s.state.n_answered == 2 and s.plan.meta["group_order"] == order


def test_videos_are_verified_before_a_session_starts_or_resumes(tmp_path):
    stim = make_placeholder_set(tmp_path / "stim", LEVELS, base_clips=("a",), n_frames=4)
    Session.open(tmp_path / "d", "P1", "S1", stim).close()
    vid = stim.video_path(stim.ids[2])
    good = vid.read_bytes()
    vid.write_bytes(good[:-3] + b"xyz")  # same size, different content
    line = stim.ids.index(stim.ids[2]) + 2
    for pid in ("P1", "P2"):  # resume and a new session are both refused
        with pytest.raises(StudyDataError, match=rf"manifest\.csv:{line} \[sha256\].*{vid.name}.*differs"):
            Session.open(tmp_path / "d", pid, "S1", stim)
    assert not (tmp_path / "d" / "P2" / "S1" / "plan.csv").exists()
    assert sum(1 for e in (tmp_path / "d" / "P1" / "S1" / "events.jsonl").read_text().splitlines()) == 1
    vid.unlink()
    with pytest.raises(StudyDataError, match=rf"\[file\].*{vid.name}.*does not exist"):
        Session.open(tmp_path / "d", "P1", "S1", stim)
    vid.write_bytes(good)
    Session.open(tmp_path / "d", "P1", "S1", stim).close()


@pytest.mark.parametrize("bad", [" P01 ", "P01 ", " P01", "P01\n", "\tP01", "P 01", "P01/x", "../P01", "", "-P01",
                                 "P" * 65])
def test_ids_are_used_as_given_never_normalised(stimuli, tmp_path, bad):
    """``" P01 "`` is refused (one line naming the id), never opened as P01's session."""
    from study.session import check_id

    Session.open(tmp_path / "d", "P01", "S1", stimuli).close()
    before = sorted(p.relative_to(tmp_path) for p in (tmp_path / "d").rglob("*"))
    events = (tmp_path / "d" / "P01" / "S1" / "events.jsonl").read_text()
    for what, args in (("participant id", (bad, "S1")), ("session id", ("P01", bad))):
        with pytest.raises(StudyDataError) as ei:
            Session.open(tmp_path / "d", *args, stimuli)
        msg = str(ei.value)
        assert msg.startswith(f"{what} {bad!r} is not valid") and "\n" not in msg.replace(repr(bad), ""), msg
        if bad != bad.strip():
            assert "whitespace" in msg
        with pytest.raises(ValueError):  # also a ValueError, as before
            check_id(bad, what)
    # nothing opened, created or logged
    assert sorted(p.relative_to(tmp_path) for p in (tmp_path / "d").rglob("*")) == before
    assert (tmp_path / "d" / "P01" / "S1" / "events.jsonl").read_text() == events


def test_valid_ids_are_returned_unchanged():
    from study.session import check_id

    for good in ("P01", "p.1_a-b", "7", "A" * 64):
        assert check_id(good, "participant id") == good


def test_withdrawal_marks_the_session_and_never_deletes(stimuli, tmp_path):
    """Issue 19 item 5: 'withdraw my data' writes withdrawn.json once, changes no other file,
    and the session can no longer be opened or written to."""
    from study.session import WITHDRAWN_FILE, withdraw_session, withdrawal_record

    with Session.open(tmp_path, "P1", "S1", stimuli) as s:
        _answer_n(s, 3)
        s.save_participant_info({"participant_id": "P1", "age": 30})
        folder = s.folder
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.name not in ("events.jsonl", "session.lock")}
    assert withdrawal_record(folder) is None
    rec, newly = withdraw_session(tmp_path, "P1", "S1", by="experimenter", reason="asked by e-mail")
    assert newly and rec["by"] == "experimenter" and rec["reason"] == "asked by e-mail"
    assert rec["n_responses"] == 3 and rec["participant_id"] == "P1" and rec["session_id"] == "S1"
    import hashlib

    assert rec["responses_sha256"] == hashlib.sha256(before["responses.csv"]).hexdigest()
    assert json.loads((folder / WITHDRAWN_FILE).read_text()) == rec == withdrawal_record(folder)
    after = {p.name: p.read_bytes() for p in folder.iterdir() if p.name not in ("events.jsonl", "session.lock")}
    assert after.pop(WITHDRAWN_FILE) and after == before  # nothing deleted, nothing changed
    ev = [json.loads(x) for x in (folder / "events.jsonl").read_text().splitlines()]
    assert ev[-1]["event"] == "withdrawn" and ev[-1]["by"] == "experimenter" and ev[-1]["n_responses"] == 3
    # a second withdrawal keeps the first record
    rec2, newly2 = withdraw_session(tmp_path, "P1", "S1", by="participant")
    assert not newly2 and rec2 == rec
    # the session is closed for good: no resume, no further rows
    with pytest.raises(StudyDataError, match="withdrawn"):
        Session.open(tmp_path, "P1", "S1", stimuli)
    assert (folder / "responses.csv").read_bytes() == before["responses.csv"]
    # not a session / bad ids / bad 'by'
    with pytest.raises(StudyDataError, match="no session P9/S1"):
        withdraw_session(tmp_path, "P9", "S1", by="experimenter")
    with pytest.raises(ValueError, match="not valid"):
        withdraw_session(tmp_path, "../P1", "S1", by="experimenter")
    with pytest.raises(ValueError, match="by must be"):
        withdraw_session(tmp_path, "P1", "S1", by="someone")


def test_withdrawal_of_a_session_open_elsewhere_is_refused(stimuli, tmp_path):
    """A session still held by a running app is never marked under its feet; once released it can be."""
    from study.session import withdraw_session, withdrawal_record

    s = Session.open(tmp_path, "P2", "S1", stimuli)
    try:
        _answer_n(s, 1)
        with pytest.raises(SessionLockedError):
            withdraw_session(tmp_path, "P2", "S1", by="experimenter", lock_timeout=0.2)
        assert withdrawal_record(s.folder) is None
        _answer_n(s, 1)  # the open session goes on writing normally
    finally:
        s.close()
    rec, newly = withdraw_session(tmp_path, "P2", "S1", by="experimenter")
    assert newly and rec["n_responses"] == 2
