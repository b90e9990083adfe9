"""The ipywidgets app without a browser: screens, clicks, double clicks, stale screens,
a simulated observer pressing the app's own buttons, resume, locks, configuration."""
from __future__ import annotations

import json

import ipywidgets as W
import numpy as np
import pandas as pd
import pytest

from study.design import DesignConfig
from study.harness import HarnessConfig, StudyApp, app_from_config, app_from_environment, config_from_environment
from study.observers import Observer, Psychometric
from study.placeholders import make_placeholder_set

LEVELS = {("am_abrupt", "increase"): (25, 50), ("takeoff", "increase"): (20,)}


@pytest.fixture(scope="module")
def stimuli(tmp_path_factory):
    return make_placeholder_set(tmp_path_factory.mktemp("stim"), LEVELS, base_clips=("a",), n_frames=4)


def _find(widget, cls):
    out, stack = [], [widget]
    while stack:
        w = stack.pop()
        if cls in getattr(w, "_dom_classes", ()):
            out.append(w)
        stack.extend(getattr(w, "children", ()))
    return out


def _click(app, cls):
    (b,) = _find(app.widget, cls)
    b.click()
    return b


def _through_intro(app, age="31"):
    assert app.screen_name == "welcome"
    _click(app, "mocomp-btn-next")
    assert app.screen_name == "consent"
    (cons,) = _find(app.widget, "mocomp-btn-consent")
    assert cons.disabled
    _find(app.widget, "mocomp-consent-check")[0].value = True
    assert not cons.disabled
    cons.click()
    assert app.screen_name == "info"
    _find(app.widget, "mocomp-info-age")[0].value = "abc"
    _click(app, "mocomp-btn-info")
    assert app.screen_name == "info"  # rejected, with a message
    _find(app.widget, "mocomp-info-age")[0].value = age
    _click(app, "mocomp-btn-info")
    assert app.screen_name == "instructions"
    _click(app, "mocomp-btn-next")
    while app.screen_name == "example":
        _click(app, "mocomp-btn-next")


def test_app_drives_a_whole_session_by_its_buttons(stimuli, tmp_path):
    """A simulated observer answers by clicking the app's buttons: the widget code path end to end."""
    app = StudyApp(stimuli, tmp_path, "P1", "S1", design=DesignConfig(break_every=4, n_attention=1))
    _through_intro(app)
    obs = Observer({("am_abrupt", "increase"): Psychometric(30, 2)}, bias=0.3)
    rng = np.random.default_rng(0)
    n_breaks, clicks = 0, []
    while app.screen_name != "end":
        if app.screen_name == "break":
            n_breaks += 1
            _click(app, "mocomp-btn-next")
            continue
        assert app.screen_name == "trial"
        view = app.controller.current()
        resp, _ = obs.respond(view, rng)
        b = _click(app, f"mocomp-btn-{resp}")
        b.click()  # a double click: ignored
        clicks.append((view.trial_index, resp))
    rows = pd.read_csv(tmp_path / "P1" / "S1" / "responses.csv", keep_default_na=False)
    assert list(zip(rows["trial_index"], rows["response"])) == clicks
    assert len(rows) == 11 and n_breaks == 2
    assert set(rows["input"]) == {"button"}
    att = rows[rows["kind"] == "attention"]
    assert (att["response"] == att["expected_response"]).all()
    info = json.loads((tmp_path / "P1" / "S1" / "participant.json").read_text())
    assert info["age"] == 31 and info["experience_gymnastics"] == "none"
    assert app.session.closed  # the lock is released at the end


def test_resume_stale_screens_and_locks(stimuli, tmp_path):
    app = StudyApp(stimuli, tmp_path, "P2", "S1")
    _through_intro(app)
    first = _find(app.widget, "mocomp-btn-correct")[0]
    first.click()
    second = _find(app.widget, "mocomp-btn-incorrect")[0]
    first.click()  # a click on the previous trial's button: ignored (logged)
    second.click()
    # a second app on the same session (another window) is refused
    other = StudyApp(stimuli, tmp_path, "P2", "S1", config=HarnessConfig(lock_timeout_s=0.2, release_after_s=7))
    assert other.screen_name == "error" and "already open" in other.error
    text = _find(other.widget, "mocomp-screen-error")[0].children[0].value
    assert "within about 7 seconds" in text and "Try again" in text
    _click(other, "mocomp-btn-retry")  # still held: still refused, nothing written
    assert other.screen_name == "error" and other.controller is None
    app.close()  # e.g. the page is closed (its kernel shut down); the session is not finished
    _click(other, "mocomp-btn-retry")  # the new window takes the session over where it stopped
    again = other
    assert again.screen_name == "welcome_back" and again.error is None
    assert "trial 3 of" in _find(again.widget, "mocomp-screen-welcome_back")[0].children[0].value
    _click(again, "mocomp-btn-next")
    assert again.screen_name == "trial" and again.controller.n_answered == 2
    again.close()
    rows = pd.read_csv(tmp_path / "P2" / "S1" / "responses.csv")
    assert list(rows["response"]) == ["correct", "incorrect"]
    ev = [json.loads(x)["event"] for x in (tmp_path / "P2" / "S1" / "events.jsonl").read_text().splitlines()]
    assert "response_ignored" in ev


def test_consent_declined(stimuli, tmp_path):
    app = StudyApp(stimuli, tmp_path, "P3", "S1")
    _click(app, "mocomp-btn-next")
    _click(app, "mocomp-btn-decline")
    assert app.screen_name == "declined"
    assert pd.read_csv(tmp_path / "P3" / "S1" / "responses.csv").empty
    assert not (tmp_path / "P3" / "S1" / "participant.json").exists()


def test_configuration_from_environment(stimuli, tmp_path):
    w = app_from_environment() if "MOCOMP_STUDY_CONFIG" not in __import__("os").environ else None
    if w is not None:
        assert isinstance(w, W.HTML) and "not configured" in w.value
    with pytest.raises(ValueError, match="lacks session_id"):
        config_from_environment({"MOCOMP_STUDY_CONFIG": json.dumps({"manifest": "m", "data_dir": "d",
                                                                    "participant_id": "p"})})
    cfg = {"manifest": str(stimuli.path), "data_dir": str(tmp_path), "participant_id": "P4", "session_id": "S9",
           "design": {"break_every": 3}, "key_correct": "f", "key_incorrect": "j",
           "texts": {"title": "Pilot"}}
    p = tmp_path / "cfg.json"
    p.write_text(json.dumps(cfg))
    app = app_from_config(config_from_environment({"MOCOMP_STUDY_CONFIG": str(p)}))
    assert app.cfg.key_correct == "f" and "Pilot" in app._title.value
    assert app.session.plan.meta["design"]["break_every"] == 3
    app.close()
    bad = StudyApp(tmp_path / "missing.csv", tmp_path, "P5", "S1")
    assert bad.screen_name == "error" and "not found" in bad.error


def _media(app, **msg):
    """What the browser script sends: the page is ready, a video ended, ..."""
    app._media.value = json.dumps({**msg, "t": len(app._media.value)})


def test_must_watch_first(stimuli, tmp_path):
    """With the browser script present, answers wait for the end of the video (per presentation)."""
    app = StudyApp(stimuli, tmp_path, "P6", "S1", design=DesignConfig(n_attention=0))
    assert app.must_watch and not app.enforcing  # default on, not yet enforceable (no script)
    _media(app, event="ready")
    assert app.enforcing
    _click(app, "mocomp-btn-next")
    _find(app.widget, "mocomp-consent-check")[0].value = True
    _click(app, "mocomp-btn-consent")
    _click(app, "mocomp-btn-info")
    _click(app, "mocomp-btn-next")
    # examples: "Next" is locked until the example's video ended
    while app.screen_name == "example":
        (nxt,) = _find(app.widget, "mocomp-btn-next")
        assert nxt.disabled
        idx = app._presenting
        nxt.click()  # (a forced click, e.g. a stale event): refused
        assert app.screen_name == "example" and app._presenting == idx
        _media(app, event="ended", trial=idx, n=1)
        assert not nxt.disabled
        nxt.click()
    folder = tmp_path / "P6" / "S1"
    n_rows = 0
    for k in range(3):
        assert app.screen_name == "trial"
        idx = app.controller.current().trial_index
        bc, bi = _find(app.widget, "mocomp-btn-correct")[0], _find(app.widget, "mocomp-btn-incorrect")[0]
        assert bc.disabled and bi.disabled
        bc.click()  # too early: nothing written, logged
        assert len(pd.read_csv(folder / "responses.csv")) == n_rows
        _media(app, event="ended", trial=idx - 1, n=1)  # an old screen's event: ignored
        assert bc.disabled
        _media(app, event="ended", trial=idx, n=1)
        assert not bc.disabled and not bi.disabled
        bi.click()
        n_rows += 1
        rows = pd.read_csv(folder / "responses.csv", keep_default_na=False)
        assert len(rows) == n_rows and rows["trial_index"].iloc[-1] == idx
    assert (rows["must_watch"] == 1).all() and (rows["watched_to_end"] == 1).all()
    ev = [json.loads(x)["event"] for x in (folder / "events.jsonl").read_text().splitlines()]
    assert ev.count("response_before_video_end") == 3 and "example_skipped_before_video_end" in ev
    assert app.session.plan.meta["design"]["must_watch"] is True
    app.close()
    # a page without the script cannot enforce it: answers go through and the rows say so
    again = StudyApp(stimuli, tmp_path, "P6", "S1")
    _click(again, "mocomp-btn-next")
    _click(again, "mocomp-btn-correct")
    # a presentation shown before the script announced itself stays unenforced (decided per presentation)
    _media(again, event="ready")
    assert again.enforcing and "mocomp-client-ready" in again.widget._dom_classes
    _click(again, "mocomp-btn-incorrect")
    again.close()
    rows = pd.read_csv(folder / "responses.csv", keep_default_na=False)
    assert list(rows["must_watch"].iloc[-2:]) == [0, 0]
    assert list(rows["watched_to_end"].astype(str).iloc[-2:]) == ["", "0"]
    # switched off in the design
    off = StudyApp(stimuli, tmp_path, "P7", "S1", design=DesignConfig(must_watch=False))
    _media(off, event="ready")
    assert not off.enforcing
    off.close()


def test_must_watch_video_error_never_blocks(stimuli, tmp_path):
    """A video the browser cannot play unlocks the answer; the row says it was not watched."""
    app = StudyApp(stimuli, tmp_path, "P8", "S1", design=DesignConfig(examples="none"))
    _media(app, event="ready")
    _click(app, "mocomp-btn-next")
    _find(app.widget, "mocomp-consent-check")[0].value = True
    _click(app, "mocomp-btn-consent")
    _click(app, "mocomp-btn-info")
    _click(app, "mocomp-btn-next")
    idx = app.controller.current().trial_index
    (bc,) = _find(app.widget, "mocomp-btn-correct")
    assert bc.disabled
    _media(app, event="error", trial=idx)
    assert not bc.disabled
    bc.click()
    app.close()
    folder = tmp_path / "P8" / "S1"
    row = pd.read_csv(folder / "responses.csv", keep_default_na=False).iloc[0]
    assert row["must_watch"] == 0 and row["watched_to_end"] == 0
    assert "video_error" in (folder / "events.jsonl").read_text()


def _text(app, screen):
    (box,) = _find(app.widget, f"mocomp-screen-{screen}")
    return " ".join(getattr(w, "value", "") for w in box.children if isinstance(w, W.HTML))


def _run_to_end(app, resp="correct"):
    n_breaks, texts = 0, []
    while app.screen_name != "end":
        if app.screen_name == "break":
            n_breaks += 1
            texts.append((_text(app, "break"), app.controller.n_answered))
            _click(app, "mocomp-btn-next")
            continue
        assert app.screen_name == "trial"
        view = app.controller.current()
        _click(app, f"mocomp-btn-{view.expected_response if view.kind == 'attention' else resp}")
    return n_breaks, texts


def test_break_screen_says_how_long_and_waits_for_a_click(stimuli, tmp_path):
    app = StudyApp(stimuli, tmp_path, "P7", "S1", design=DesignConfig(break_every=4, break_s=90))
    _through_intro(app)
    for _ in range(4):
        _click(app, "mocomp-btn-correct")
    assert app.screen_name == "break"
    text = _text(app, "break")
    assert "about 1 minute 30 seconds" in text and "answered 4 of 10" in text and "6 to go" in text
    assert "data-seconds='90'" in text  # the page's script counts it down
    # the break lasts until the participant clicks: no trial is shown, nothing is written meanwhile
    assert app.controller.showing is None and app.screen_name == "break"
    assert len(pd.read_csv(tmp_path / "P7" / "S1" / "responses.csv")) == 4
    _click(app, "mocomp-btn-next")
    assert app.screen_name == "trial"
    ev = [json.loads(x) for x in (tmp_path / "P7" / "S1" / "events.jsonl").read_text().splitlines()]
    started = [e for e in ev if e["event"] == "break_started"]
    assert started[0]["suggested_s"] == 90 and started[0]["n_answered"] == 4
    assert [e["event"] for e in ev][-1] == "break_ended"
    app.close()
    # by default: a break every 30 test trials, said to last about a minute
    dflt = StudyApp(stimuli, tmp_path, "P7", "S2")
    _through_intro(dflt)
    assert _run_to_end(dflt)[0] == 0  # this small set has 10 response trials, fewer than 30
    assert dflt.session.plan.meta["design"]["break_every"] == 30


def test_debrief_shows_purpose_contact_and_code_and_withdraws_on_request(stimuli, tmp_path):
    from study.harness import HarnessTexts

    contact = "Dr A. Researcher, a.researcher@uni.example"
    app = StudyApp(stimuli, tmp_path, "P8", "S1", config=HarnessConfig(texts=HarnessTexts(contact=contact)))
    _through_intro(app)
    _run_to_end(app)
    folder = tmp_path / "P8" / "S1"
    text = _text(app, "end")
    assert "What this study was about" in text and "angular momentum" in text
    assert contact in text and "mocomp-participant-code'>P8</b>" in text and "session S1" in text
    assert app.session.closed  # finished: every row written, the lock released before the debrief
    rows_before = (folder / "responses.csv").read_bytes()
    # "No, keep my data" goes back to the debrief and writes nothing
    _click(app, "mocomp-btn-withdraw")
    assert app.screen_name == "withdraw_confirm"
    _click(app, "mocomp-btn-withdraw-cancel")
    assert app.screen_name == "end" and not (folder / "withdrawn.json").exists()
    _click(app, "mocomp-btn-withdraw")
    _click(app, "mocomp-btn-withdraw-confirm")
    assert app.screen_name == "withdrawn" and "P8" in _text(app, "withdrawn")
    rec = json.loads((folder / "withdrawn.json").read_text())
    assert rec["by"] == "participant" and rec["n_responses"] == 10
    assert (folder / "responses.csv").read_bytes() == rows_before  # marked, not deleted
    # the page reloaded: it opens on the "withdrawn" screen, opens no session and writes nothing
    again = StudyApp(stimuli, tmp_path, "P8", "S1")
    assert again.screen_name == "withdrawn" and again.controller is None
    assert (folder / "responses.csv").read_bytes() == rows_before
    # without a contact the debrief says whom to ask
    app2 = StudyApp(stimuli, tmp_path, "P8", "S2")
    _through_intro(app2)
    _run_to_end(app2)
    assert "please ask the experimenter" in _text(app2, "end")


def test_contact_and_break_settings_from_the_run_configuration(stimuli, tmp_path):
    cfg = {"manifest": str(stimuli.path), "data_dir": str(tmp_path), "participant_id": "P9", "session_id": "S1",
           "design": {"break_every": 2, "break_s": 45}, "texts": {"contact": "lab@uni.example"}}
    app = app_from_config(cfg)
    assert app.texts.contact == "lab@uni.example"
    _through_intro(app)
    _click(app, "mocomp-btn-correct")
    _click(app, "mocomp-btn-correct")
    assert app.screen_name == "break" and "about 45 seconds" in _text(app, "break")
    app.close()
