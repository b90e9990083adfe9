"""The participant-facing app: ipywidgets, in Jupyter or served by Voila.

Screens: welcome -> consent -> participant information (ID, age, gender,
experience with computer animation and with gymnastics, as the flips paper
reported) -> instructions -> examples of correct motions -> trials (the video
plays; "Correct" / "Incorrect" by button or key) with progress and breaks ->
end with debrief. A session that already has data opens on a "welcome back"
screen and continues at the first unanswered trial.

Breaks are on by default (``DesignConfig.break_every``, every 30th test trial;
``mocomp study run --break-every N``, 0 = none): the break screen says how
long the suggested break is (``DesignConfig.break_s``, with a countdown when
the page's script runs) and how many trials are done, and the study resumes
when the participant clicks "Continue" (never by itself).

The end screen is the debrief (:class:`HarnessTexts` ``debrief``: what the
study was about; ``contact``, set by ``mocomp study run --contact`` or a
``--texts`` file; and the participant's code and session). It offers
"Withdraw my data": after a confirmation, :func:`study.session.withdraw_session`
marks the session withdrawn (``withdrawn.json``; nothing is deleted) and the
analysis leaves it out. A withdrawn session reopens on the "withdrawn" screen.

Every answer goes through :class:`study.controller.TrialController` (the same
code path the simulated observers use), which appends and ``fsync``-s it
before the next screen is built. Buttons are disabled as soon as a click
arrives and the controller ignores a second answer to the same trial, so
double clicks and key repeats cannot duplicate a row.

"Must watch first" (``DesignConfig.must_watch``, default on): on a trial the
response buttons and keys, and on an example the "Next" button, stay disabled
until the browser reports that the video of this presentation has played to
its end (the script forwards the video's ``ended`` event to the kernel, which
enables them, and ignores any earlier answer). The script announces itself
when the page loads; without it (a front end that does not run it) the rule
cannot be enforced, the buttons work at once and each row says so
(``must_watch`` = 0, ``watched_to_end`` empty). With ``loop_video`` the
script restarts the video at its end, so every play-through is reported.

Keys and browser timing come from a small script (installed once per page):
``C``/``I`` (configurable) press the visible response button, Space/Enter
the visible "Next"/"Continue" button; a capture-phase listener writes the
time from the video's ``playing`` event to the click (``client_rt_s``), the
time from the end of its first play-through to the click (``client_rt_end_s``) and
the input device into a hidden text widget just before the click reaches the
kernel. Without the script (e.g. a front end that does not run it) buttons
still work and ``client_rt_s`` stays empty.

``mocomp study run`` serves ``study/app.ipynb`` with Voila; the notebook calls
:func:`app_from_environment`, which reads the settings from the environment
variable ``MOCOMP_STUDY_CONFIG`` (JSON; see :func:`config_from_environment`).
"""
from __future__ import annotations

import base64
import html
import json
import os
import traceback
from dataclasses import dataclass, field, replace
from pathlib import Path

import ipywidgets as W

from mocomp.errors import MocompError, SessionLockedError

from .controller import TrialController, TrialView
from .design import DesignConfig
from .session import Session, utc_now, withdraw_session, withdrawal_record
from .stimulus_set import StimulusSet, load_manifest

ENV_CONFIG = "MOCOMP_STUDY_CONFIG"

_JS = r"""
(function () {
  if (window.__mocompHarness) { return; }
  window.__mocompHarness = true;
  var KC = "%KC%", KI = "%KI%";
  // Voila's beforeunload beacon (shut this page's kernel down) sends the _xsrf cookie's value, but the
  // page is streamed, so the server never sets that cookie and the beacon is refused (403). Set one
  // (double-submit: another site can neither read nor set it), so a closed or reloaded page frees the
  // session at once instead of after the server's idle-kernel cull.
  if (!/(^|;\s*)_xsrf=[^;]+/.test(document.cookie)) {
    var rnd = new Uint8Array(16), hex = "";
    window.crypto.getRandomValues(rnd);
    for (var j = 0; j < rnd.length; j++) { hex += ("0" + rnd[j].toString(16)).slice(-2); }
    document.cookie = "_xsrf=" + hex + "; path=/; SameSite=Strict";
  }
  var onset = null, endAt = null;
  function visible(el) { return el && el.offsetParent !== null && !el.disabled; }
  function first(sel) {
    var els = document.querySelectorAll(sel);
    for (var i = 0; i < els.length; i++) { if (visible(els[i])) { return els[i]; } }
    return null;
  }
  document.addEventListener("keydown", function (e) {
    if (e.repeat || e.altKey || e.ctrlKey || e.metaKey) { return; }
    var t = e.target;
    if (t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA" || t.tagName === "SELECT")) { return; }
    var k = (e.key || "").toLowerCase(), sel = null;
    if (k === KC) { sel = ".mocomp-btn-correct"; }
    else if (k === KI) { sel = ".mocomp-btn-incorrect"; }
    else if (k === " " || k === "enter") { sel = ".mocomp-btn-next"; }
    if (!sel) { return; }
    var b = first(sel);
    if (b) { e.preventDefault(); b.setAttribute("data-mocomp-input", "key"); b.click(); }
  }, true);
  document.addEventListener("playing", function (e) {
    if (e.target && e.target.tagName === "VIDEO") { onset = performance.now(); }
  }, true);
  document.addEventListener("loadedmetadata", function (e) {
    var v = e.target;
    if (v && v.tagName === "VIDEO") { v.muted = true; onset = null; endAt = null; var p = v.play(); if (p && p.catch) { p.catch(function () {}); } }
  }, true);
  function send(sel, obj) {
    var box = document.querySelector(sel + " input");
    if (!box) { return false; }
    box.value = JSON.stringify(obj);
    box.dispatchEvent(new Event("input", {bubbles: true}));
    return true;
  }
  function trialOf(el) {
    var box = el && el.closest ? el.closest("[class*='mocomp-trial-']") : null;
    var m = box ? /mocomp-trial-(\d+)/.exec(box.className) : null;
    return m ? parseInt(m[1], 10) : null;
  }
  // tell the kernel that this script runs (it then enforces "must watch first")
  var tries = 0, hello = setInterval(function () {
    if (send(".mocomp-media", {event: "ready", t: Date.now()}) || ++tries > 200) { clearInterval(hello); }
  }, 100);
  var ends = {};
  function play(v) { var p = v.play(); if (p && p.catch) { p.catch(function () {}); } }
  function reachedEnd(v) {  // once per play-through, from "ended" or (if that is lost) the last timeupdate
    if (v.__mocompAtEnd) { return; }
    v.__mocompAtEnd = true;
    if (endAt === null) { endAt = performance.now(); }
    var tr = trialOf(v);
    ends[tr] = (ends[tr] || 0) + 1;
    send(".mocomp-media", {event: "ended", trial: tr, n: ends[tr], t: Date.now()});
    var box = v.closest ? v.closest(".mocomp-loop") : null;
    if (box) { v.currentTime = 0; play(v); }
  }
  function isVideo(e) { return e.target && e.target.tagName === "VIDEO"; }
  document.addEventListener("ended", function (e) { if (isVideo(e)) { reachedEnd(e.target); } }, true);
  document.addEventListener("timeupdate", function (e) {
    var v = e.target;
    if (isVideo(e) && v.duration && isFinite(v.duration) && v.currentTime >= v.duration - 0.01) { reachedEnd(v); }
  }, true);
  document.addEventListener("seeked", function (e) { if (isVideo(e) && e.target.currentTime < 0.05) { e.target.__mocompAtEnd = false; } }, true);
  document.addEventListener("canplay", function (e) {  // autoplay that did not start: start it
    var v = e.target;
    if (isVideo(e) && v.paused && !v.ended && !v.__mocompAtEnd) { v.muted = true; play(v); }
  }, true);
  // break screen: count the suggested break down (cosmetic; the kernel never ends a break by itself)
  setInterval(function () {
    var els = document.querySelectorAll(".mocomp-countdown");
    for (var i = 0; i < els.length; i++) {
      var el = els[i], secs = parseFloat(el.getAttribute("data-seconds"));
      if (!el.__mocompStart) { el.__mocompStart = performance.now(); }
      var left = Math.max(0, Math.ceil(secs - (performance.now() - el.__mocompStart) / 1000));
      el.textContent = left > 0 ? (Math.floor(left / 60) + ":" + ("0" + (left % 60)).slice(-2) + " left")
                                : "you may continue whenever you are ready";
    }
  }, 250);
  document.addEventListener("error", function (e) {
    var v = e.target;
    if (v && v.tagName === "VIDEO") { send(".mocomp-media", {event: "error", trial: trialOf(v), t: Date.now()}); }
  }, true);
  document.addEventListener("click", function (e) {
    var b = e.target && e.target.closest ? e.target.closest(".mocomp-btn-correct, .mocomp-btn-incorrect") : null;
    if (!b) { return; }
    var box = document.querySelector(".mocomp-timing input");
    if (!box) { return; }
    var via = b.getAttribute("data-mocomp-input") || "button";
    b.removeAttribute("data-mocomp-input");
    var trial = null, els = document.querySelectorAll("[class*='mocomp-trial-']");
    for (var i = 0; i < els.length; i++) {
      var m = /mocomp-trial-(\d+)/.exec(els[i].className);
      if (m && els[i].offsetParent !== null) { trial = parseInt(m[1], 10); break; }
    }
    var now = performance.now();
    box.value = JSON.stringify({trial: trial, rt: onset === null ? null : (now - onset) / 1000,
                                rt_end: endAt === null ? null : (now - endAt) / 1000, input: via, t: Date.now()});
    box.dispatchEvent(new Event("input", {bubbles: true}));
  }, true);
})();
"""


@dataclass(frozen=True)
class HarnessTexts:
    """Everything the participant reads (HTML allowed). Defaults follow the paper's procedure."""

    title: str = "Motion perception study"
    welcome: str = ("<p>Thank you for taking part.</p><p>You will watch short animations of a person "
                    "performing a somersault and judge each one. The study takes about 15 minutes.</p>")
    consent: str = ("<p>Your answers and the information you give are stored under a participant code, "
                    "without your name. You may stop at any time without giving a reason. "
                    "Please confirm that you have read this and agree to take part.</p>")
    instructions: str = ("<p>You are about to see a sequence of motions. <b>Some of them are physically correct "
                         "and some are not.</b></p><p>First you will see a few <b>examples of correct "
                         "motions</b> as a reference. Then, for each motion, answer whether it looks "
                         "physically <b>correct</b> or <b>incorrect</b>. Each motion may appear more than "
                         "once. There are no time limits, but please answer after the motion has played.</p>")
    must_watch: str = ("<p>Each motion plays once; the answer buttons become active when it has played to its "
                       "end.</p>")
    example: str = "<p><b>Example {n} of {total}</b>: a physically correct motion.</p>"
    question: str = "<p>Is this motion physically correct?</p>"
    attention: str = ("<p style='color:#b00'><b>Attention check:</b> whatever you see, please press "
                      "<b>{expected}</b> for this one.</p>")
    break_text: str = ("<p><b>Time for a short break of about {break_len}</b> ({countdown}).</p>"
                       "<p>You have answered {done} of {total} motions; {remaining} to go. Rest your eyes, then "
                       "press <b>Continue</b> when you are ready: the study waits for you.</p>")
    welcome_back: str = "<p><b>Welcome back.</b> The study continues at trial {next} of {total}.</p>"
    end: str = "<p><b>Thank you!</b> All your answers are saved.</p>"
    debrief: str = ("<p><b>What this study was about.</b> Some of the somersaults you saw were physically "
                    "correct motion capture; others had been altered so that they break the laws of physics: the "
                    "body turned faster or slower in the air than its angular momentum allows (suddenly or "
                    "gradually), or it left the ground at a different angle than its flight path needs. We "
                    "measure how large such errors must be before people notice them, so that animation tools "
                    "know which errors matter. Whether you noticed an error or not, your answers help: there "
                    "are no right or wrong perceptions.</p>")
    contact: str = ""
    """Who to contact with questions or to withdraw later (``mocomp study run --contact``); HTML allowed."""
    no_contact: str = "<p>If you have any questions, please ask the experimenter now.</p>"
    contact_line: str = "<p><b>Questions, or withdrawing later:</b> {contact}</p>"
    code_line: str = ("<p>Your participant code is <b class='mocomp-participant-code'>{participant}</b> "
                      "(session {session}). Please quote it if you contact us, for example to withdraw your data "
                      "later. You may close this window now.</p>")
    withdraw_offer: str = ("<p>If you do not want your answers to be used, you can withdraw them now, without "
                           "giving a reason.</p>")
    withdraw_confirm: str = ("<p><b>Withdraw your data?</b> Your answers and the information you gave will be "
                             "marked as withdrawn and left out of every analysis. This cannot be undone from "
                             "this page.</p>")
    withdrawn: str = ("<p><b>Your data have been withdrawn.</b> Your answers are marked as withdrawn and will not "
                      "be used in any analysis. Your participant code was <b>{participant}</b> (session "
                      "{session}). You may close this window now.</p>")
    locked: str = ("<p style='color:#b00'><b>This session is already open in another window.</b></p>"
                   "<p>If you closed or reloaded a window of this study just now, its connection is released "
                   "within about {seconds} seconds: wait, then press <b>Try again</b>. Otherwise close the other "
                   "window first.</p>")
    declined: str = ("<p>You chose not to take part. No answers and no personal information were recorded: "
                     "only your participant code, the time of this decision and the trial order prepared for "
                     "the session. Thank you.</p>")


@dataclass(frozen=True)
class HarnessConfig:
    """Presentation settings of the app."""

    texts: HarnessTexts = field(default_factory=HarnessTexts)
    key_correct: str = "c"
    key_incorrect: str = "i"
    video_width: int = 640
    loop_video: bool = False
    show_progress: bool = True
    experience_levels: tuple = ("none", "a little", "some", "significant")
    lock_timeout_s: float = 15.0
    #: seconds after which the kernel of a closed or reloaded page has been shut down by the
    #: server (``mocomp study run --kernel-cull-s`` + its check interval); said on the "locked" screen
    release_after_s: float = 40.0


def _duration_text(seconds: float) -> str:
    """``90`` -> ``"1 minute 30 seconds"``, ``60`` -> ``"1 minute"``, ``45`` -> ``"45 seconds"``."""
    s = int(round(float(seconds)))
    m, r = divmod(s, 60)
    parts = [f"{m} minute{'s' if m != 1 else ''}"] if m else []
    if r or not m:
        parts.append(f"{r} second{'s' if r != 1 else ''}")
    return " ".join(parts)


def _video_bytes(path: Path) -> bytes:
    with open(path, "rb") as f:
        return f.read()


class StudyApp:
    """The ipywidgets app for one participant session (display ``app.widget``)."""

    def __init__(self, stimuli: StimulusSet | str | Path, data_dir: str | Path, participant_id: str, session_id: str,
                 *, design: DesignConfig | None = None, study_seed: int = 0, seed: int | None = None,
                 counterbalance_index: int | None = None, config: HarnessConfig | None = None):
        self.cfg = config or HarnessConfig()
        self.texts = self.cfg.texts
        self.participant_id, self.session_id = str(participant_id), str(session_id)
        self.controller: TrialController | None = None
        self.error: str | None = None
        self.screen_name = ""
        self._title = W.HTML(f"<h2 style='margin:4px 0'>{html.escape(self.texts.title)}</h2>")
        self._progress = W.IntProgress(value=0, min=0, max=1, layout=W.Layout(width="300px"))
        self._progress_label = W.Label("")
        self._header = W.HBox([self._progress, self._progress_label], layout=W.Layout(display="none"))
        self._body = W.VBox([], layout=W.Layout(min_height="360px"))
        self._timing = W.Text(value="", continuous_update=True, layout=W.Layout(display="none"))
        self._timing.add_class("mocomp-timing")
        self._media = W.Text(value="", continuous_update=True, layout=W.Layout(display="none"))
        self._media.add_class("mocomp-media")
        self._media.observe(self._on_media, names="value")
        self._client_ok = False  # the browser script has announced itself
        self._presenting: int | None = None  # trial_index of the video on screen
        self._ended: set[int] = set()  # presentations (trial indices) whose video has ended on this screen
        self._failed: set[int] = set()  # presentations whose video the browser could not play
        self._locked: list[W.Button] = []  # buttons waiting for the end of the video
        self._enforced_now = False  # "must watch first" enforced for the presentation on screen
        js = _JS.replace("%KC%", self.cfg.key_correct.lower()).replace("%KI%", self.cfg.key_incorrect.lower())
        b64 = base64.b64encode(js.encode()).decode()
        self._script = W.HTML(f'<img src="data:," alt="" style="display:none" onerror="eval(atob(\'{b64}\'))">')
        self.widget = W.VBox([self._title, self._header, self._body, self._timing, self._media, self._script])
        self.widget.add_class("mocomp-app")
        self._buttons: list[W.Button] = []
        self._video: W.Video | None = None
        self._token = 0
        self._screen_cls = ""
        self._open_args = dict(stimuli=stimuli, data_dir=data_dir, design=design, study_seed=study_seed, seed=seed,
                               counterbalance_index=counterbalance_index)
        self._open_session()

    def _open_session(self) -> None:
        """Open (or resume) the session; while another window's kernel holds it, say so and offer "Try again"."""
        a = self._open_args
        try:
            rec = withdrawal_record(Path(a["data_dir"]) / self.participant_id / self.session_id)
        except OSError:
            rec = None
        if rec is not None:  # e.g. the debrief page reloaded after withdrawing: nothing is opened or written
            self.error = None
            self._show_withdrawn()
            return
        try:
            st = a["stimuli"] if isinstance(a["stimuli"], StimulusSet) else load_manifest(a["stimuli"])
            sess = Session.open(a["data_dir"], self.participant_id, self.session_id, st, config=a["design"],
                                study_seed=a["study_seed"], seed=a["seed"],
                                counterbalance_index=a["counterbalance_index"], lock_timeout=self.cfg.lock_timeout_s)
        except SessionLockedError as e:
            self._show_locked(str(e))
            return
        except (MocompError, ValueError, FileNotFoundError) as e:
            self._show_error("The study could not start. Please call the experimenter.", str(e))
            return
        self.error = None
        self.controller = TrialController(sess)
        self._examples = self.controller.examples_to_show()
        if sess.state.resumed and (sess.n_answered > 0 or sess.participant_info() is not None):
            if sess.finished:
                self._show_end()
            else:
                self._show_welcome_back()
        else:
            self._show_welcome()

    # ----------------------------------------------------------- plumbing
    @property
    def session(self) -> Session | None:
        return None if self.controller is None else self.controller.session

    @property
    def must_watch(self) -> bool:
        """The design asks for "must watch first" (see the module docstring)."""
        if self.session is None:
            return False
        return bool(self.session.plan.meta.get("design", {}).get("must_watch", True))

    @property
    def enforcing(self) -> bool:
        """"Must watch first" is required and the browser script can report the video's end."""
        return self.must_watch and self._client_ok

    def _on_media(self, change) -> None:
        try:
            msg = json.loads(change["new"]) if change["new"] else None
        except ValueError:
            return
        if not isinstance(msg, dict):
            return
        ev = msg.get("event")
        if ev == "ready":
            if not self._client_ok:
                self._client_ok = True
                self.widget.add_class("mocomp-client-ready")  # (the browser test waits for this)
            return
        trial = msg.get("trial")
        if trial is None or trial != self._presenting:
            return  # a late event of an earlier screen
        if ev == "error" and trial not in self._failed:
            # the video cannot be shown: never leave the participant stuck; the row says it was not watched
            self._failed.add(int(trial))
            if self.session is not None and not self.session.closed:
                self.session.log_event("video_error", trial_index=trial)
            for b in self._locked:
                b.disabled = False
            self._locked = []
        if ev == "ended" and trial not in self._ended:
            self._ended.add(int(trial))
            for b in self._locked:
                b.disabled = False
            self._locked = []

    def _set(self, name: str, children: list) -> None:
        """Show a new screen; buttons of older screens stop working (stale or double clicks)."""
        old_video = self._video
        self._token += 1
        stack = list(children)
        while stack:
            w = stack.pop()
            if isinstance(w, W.Button):
                w._mocomp_token = self._token
            stack.extend(getattr(w, "children", ()))
        self.screen_name = name
        self._body.children = children
        if self._screen_cls:
            self._body.remove_class(self._screen_cls)
        self._screen_cls = f"mocomp-screen-{name}"
        self._body.add_class(self._screen_cls)
        if old_video is not None and old_video is not self._video:
            old_video.close()

    def _button(self, text: str, cls: str, style: str = "", handler=None, disabled: bool = False) -> W.Button:
        b = W.Button(description=text, button_style=style, disabled=disabled, layout=W.Layout(width="180px",
                                                                                              height="44px"))
        b.add_class(cls)
        if handler is not None:
            b.on_click(lambda btn: self._guard(handler, btn))
        return b

    def _guard(self, fn, button: W.Button | None = None) -> None:
        if button is not None and getattr(button, "_mocomp_token", None) != self._token:
            return  # a click on a screen that is no longer shown
        try:
            fn()
        except Exception as e:  # never show a traceback to a participant; keep it in the log
            tb = traceback.format_exc()
            if self.session is not None and not self.session.closed:
                try:
                    self.session.log_event("app_error", error=str(e), traceback=tb)
                except Exception:
                    pass
            self._show_error("Something went wrong. Please call the experimenter.", f"{type(e).__name__}: {e}")

    def _update_progress(self) -> None:
        if self.controller is None or not self.cfg.show_progress:
            return
        c = self.controller
        self._progress.max = max(c.total, 1)
        self._progress.value = c.n_answered
        self._progress_label.value = f"  {c.n_answered} of {c.total} answered"
        self._header.layout.display = "flex"

    # ------------------------------------------------------------ screens
    def _show_error(self, message: str, detail: str) -> None:
        self.error = detail
        self._set("error", [W.HTML(f"<p style='color:#b00'><b>{html.escape(message)}</b></p>"
                                   f"<pre style='font-size:80%;white-space:pre-wrap'>{html.escape(detail)}</pre>")])

    def _show_locked(self, detail: str) -> None:
        """The session is held by another window: one still open, or one just closed or reloaded whose
        kernel the server shuts down within ``release_after_s`` (the lock is never shared)."""
        self.error = detail
        secs = int(round(self.cfg.release_after_s))
        retry = self._button("Try again", "mocomp-btn-retry", "primary", self._open_session)
        self._set("error", [W.HTML(self.texts.locked.format(seconds=secs)), retry,
                            W.HTML(f"<pre style='font-size:80%;white-space:pre-wrap'>{html.escape(detail)}</pre>")])

    def _show_welcome(self) -> None:
        self._set("welcome", [W.HTML(self.texts.welcome),
                              self._button("Continue", "mocomp-btn-next", "primary", self._show_consent)])

    def _show_consent(self) -> None:
        agree = W.Checkbox(value=False, description="I have read the above and agree to take part", indent=False,
                           layout=W.Layout(width="auto"))
        agree.add_class("mocomp-consent-check")
        go = self._button("Continue", "mocomp-btn-consent", "primary", self._consent_given, disabled=True)
        agree.observe(lambda ch: setattr(go, "disabled", not ch["new"]), names="value")
        no = self._button("I do not agree", "mocomp-btn-decline", "", self._consent_declined)
        self._set("consent", [W.HTML(self.texts.consent), agree, W.HBox([go, no])])

    def _consent_given(self) -> None:
        self.session.log_event("consent_given")
        self._show_info()

    def _consent_declined(self) -> None:
        self.session.log_event("consent_declined")
        self.controller.finish()
        self._set("declined", [W.HTML(self.texts.declined)])

    def _show_info(self) -> None:
        lv = list(self.cfg.experience_levels)
        pid = W.Text(value=self.participant_id, description="Participant", disabled=True)
        age = W.Text(value="", description="Age", placeholder="years (optional)")
        age.add_class("mocomp-info-age")
        gender = W.Dropdown(options=["prefer not to say", "woman", "man", "another gender"],
                            value="prefer not to say", description="Gender")
        anim = W.Dropdown(options=lv, value=lv[0], description="Animation",
                          style={"description_width": "initial"})
        gym = W.Dropdown(options=lv, value=lv[0], description="Gymnastics",
                         style={"description_width": "initial"})
        msg = W.HTML("")

        def submit():
            a = age.value.strip()
            if a and (not a.isdigit() or not 10 <= int(a) <= 110):
                msg.value = "<span style='color:#b00'>Please enter your age in whole years (or leave it empty).</span>"
                return
            self.session.save_participant_info({
                "participant_id": self.participant_id, "age": int(a) if a else None, "gender": gender.value,
                "experience_animation": anim.value, "experience_gymnastics": gym.value})
            self._show_instructions()

        self._set("info", [W.HTML("<p>About you (experience: with computer animation, and with gymnastics or "
                                  "acrobatics):</p>"), pid, age, gender, anim, gym, msg,
                           self._button("Continue", "mocomp-btn-info", "primary", submit)])

    def _show_instructions(self) -> None:
        keys = (f"<p>Keys: <b>{self.cfg.key_correct.upper()}</b> = correct, "
                f"<b>{self.cfg.key_incorrect.upper()}</b> = incorrect; Space = continue.</p>")
        extra = self.texts.must_watch if self.must_watch else ""
        self._set("instructions", [W.HTML(self.texts.instructions + extra + keys),
                                   self._button("Start", "mocomp-btn-next", "primary", self._start)])

    def _start(self) -> None:
        self._example_i = 0
        self._next_example() if self._examples else self._next_trial()

    def _video_widget(self, view: TrialView, locked: list[W.Button] = ()) -> W.Widget:
        """The video of one presentation; with "must watch first" enforced, ``locked`` buttons
        start disabled and are enabled when the browser reports the video's end."""
        script_loops = self.cfg.loop_video and self._client_ok  # the script restarts it and reports each end
        v = W.Video(value=_video_bytes(view.video), format="mp4", autoplay=True,
                    loop=self.cfg.loop_video and not script_loops, controls=False, width=self.cfg.video_width)
        self._video = v
        self._presenting = view.trial_index
        self._ended = set()
        self._failed = set()
        self._locked = []
        # decided once per presentation: one shown before the script announced itself stays unenforced
        self._enforced_now = self.enforcing
        if self._enforced_now:
            for b in locked:
                b.disabled = True
            self._locked = list(locked)
        box = W.Box([v])
        box.add_class(f"mocomp-trial-{view.trial_index}")
        box.add_class("mocomp-stimulus")
        if script_loops:
            box.add_class("mocomp-loop")
        return box

    def _next_example(self) -> None:
        if self._example_i >= len(self._examples):
            self._next_trial()
            return
        view = self._examples[self._example_i]
        text = self.texts.example.format(n=self._example_i + 1, total=len(self._examples))

        def done():
            if self._enforced_now and view.trial_index not in self._ended | self._failed:
                self.session.log_event("example_skipped_before_video_end", trial_index=view.trial_index)
                return
            self.controller.example_viewed(view)
            self._example_i += 1
            self._next_example()

        nxt = self._button("Next", "mocomp-btn-next", "primary", done)
        self._set("example", [W.HTML(text), self._video_widget(view, [nxt]), nxt])

    def _show_welcome_back(self) -> None:
        c = self.controller
        cur = c.current()
        text = self.texts.welcome_back.format(next=cur.number, total=c.total)
        self._update_progress()
        nxt = self._start if c.n_answered == 0 else self._next_trial
        self._set("welcome_back", [W.HTML(text), self._button("Continue", "mocomp-btn-next", "primary", nxt)])

    def _show_break(self) -> None:
        self.controller.start_break()
        self._update_progress()

        def resume():
            self.controller.end_break()
            self._next_trial()

        c = self.controller
        secs = float(c.break_s)
        text = self.texts.break_text.format(
            break_len=_duration_text(secs), done=c.n_answered, total=c.total, remaining=c.total - c.n_answered,
            countdown=f"<span class='mocomp-countdown' data-seconds='{secs:g}'>{int(secs) // 60}:{int(secs) % 60:02d} "
                      "left</span>")
        self._set("break", [W.HTML(text), self._button("Continue", "mocomp-btn-next", "primary", resume)])

    def _next_trial(self) -> None:
        c = self.controller
        if c.current() is None:
            self._show_end()
            return
        if c.break_due():
            self._show_break()
            return
        view = c.current()
        prompt = self.texts.question
        if view.kind == "attention":
            prompt = self.texts.attention.format(expected=html.escape(view.expected_response.upper())) + prompt
        bc = self._button("Correct", "mocomp-btn-correct", "success")
        bi = self._button("Incorrect", "mocomp-btn-incorrect", "danger")
        self._buttons = [bc, bi]
        bc.on_click(lambda _b, i=view.trial_index: self._guard(lambda: self._answer("correct", i)))
        bi.on_click(lambda _b, i=view.trial_index: self._guard(lambda: self._answer("incorrect", i)))
        # (no token check here: a stale answer must reach the controller, which logs and ignores it)
        hint = W.HTML(f"<span style='color:#777'>keys: {self.cfg.key_correct.upper()} = correct, "
                      f"{self.cfg.key_incorrect.upper()} = incorrect</span>")
        self._update_progress()
        self._timing.value = ""
        video = self._video_widget(view, [bc, bi])
        self._set("trial", [W.HTML(prompt), video, W.HBox([bc, bi]), hint])
        c.show()

    def _answer(self, response: str, trial_index: int) -> None:
        c = self.controller
        if c is None or c.showing != trial_index:
            if c is not None:
                c.respond(response, input="button", trial_index=trial_index)  # logged as ignored
            return
        for b in self._buttons:
            b.disabled = True
        client_rt, client_rt_end, via = None, None, "button"
        try:
            t = json.loads(self._timing.value) if self._timing.value else None
        except ValueError:
            t = None
        if t and t.get("trial") == trial_index:
            via = "key" if t.get("input") == "key" else "button"
            client_rt = t.get("rt")
            client_rt_end = t.get("rt_end")
        self._timing.value = ""
        enforced = self._enforced_now and trial_index not in self._failed
        watched = (trial_index in self._ended) if self._client_ok else None
        row = c.respond(response, input=via, client_rt_s=client_rt, client_rt_end_s=client_rt_end,
                        trial_index=trial_index, must_watch=enforced, watched_to_end=watched)
        if row is None:
            if enforced and not watched:  # too early (logged): the buttons wait for the end of the video
                self._locked = list(self._buttons)
            return
        self._next_trial()

    def _show_end(self) -> None:
        """The debrief: thanks, what the study was about, contact, the participant's code, "Withdraw my data"."""
        c = self.controller
        self._update_progress()
        c.finish()
        t = self.texts
        contact = t.contact_line.format(contact=t.contact) if t.contact.strip() else t.no_contact
        code = t.code_line.format(participant=html.escape(self.participant_id), session=html.escape(self.session_id))
        wd = self._button("Withdraw my data", "mocomp-btn-withdraw", "", self._show_withdraw_confirm)
        self._set("end", [W.HTML(t.end + t.debrief + contact + code), W.HTML(t.withdraw_offer), wd])

    def _show_withdraw_confirm(self) -> None:
        yes = self._button("Yes, withdraw my data", "mocomp-btn-withdraw-confirm", "danger", self._withdraw)
        yes.layout.width = "220px"
        no = self._button("No, keep my data", "mocomp-btn-withdraw-cancel", "", self._show_end)
        self._set("withdraw_confirm", [W.HTML(self.texts.withdraw_confirm), W.HBox([yes, no])])

    def _withdraw(self) -> None:
        try:
            withdraw_session(self._open_args["data_dir"], self.participant_id, self.session_id, by="participant",
                             reason="withdrawn by the participant on the debrief screen",
                             lock_timeout=self.cfg.lock_timeout_s)
        except SessionLockedError as e:
            self._show_error("Your data could not be withdrawn here. Please tell the experimenter your "
                             f"participant code ({self.participant_id}); they will withdraw it.", str(e))
            return
        self._show_withdrawn()

    def _show_withdrawn(self) -> None:
        self._header.layout.display = "none"
        self._set("withdrawn", [W.HTML(self.texts.withdrawn.format(
            participant=html.escape(self.participant_id), session=html.escape(self.session_id)))])

    # ---------------------------------------------------------- notebook
    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)

    def close(self) -> None:
        """Release the session (the lock) without finishing; the session can be resumed later."""
        if self.controller is not None and not self.controller.session.closed:
            self.controller.finish()


def config_from_environment(env: dict | None = None) -> dict:
    """Settings from ``$MOCOMP_STUDY_CONFIG`` (a JSON object, or a path to a JSON file).

    Keys: ``manifest``, ``data_dir``, ``participant_id``, ``session_id``
    (required); ``design`` (a :class:`~study.design.DesignConfig` dict),
    ``study_seed``, ``seed``, ``counterbalance_index``, ``texts`` (a
    :class:`HarnessTexts` dict), ``key_correct``, ``key_incorrect``,
    ``video_width``.
    """
    env = os.environ if env is None else env
    raw = env.get(ENV_CONFIG)
    if not raw:
        raise ValueError(f"${ENV_CONFIG} is not set; start the app with `mocomp study run ...`")
    raw = raw.strip()
    cfg = json.loads(raw if raw.startswith("{") else Path(raw).read_text())
    missing = [k for k in ("manifest", "data_dir", "participant_id", "session_id") if not cfg.get(k)]
    if missing:
        raise ValueError(f"${ENV_CONFIG} lacks {', '.join(missing)}")
    return cfg


def app_from_config(cfg: dict) -> StudyApp:
    texts = HarnessTexts(**cfg.get("texts", {}))
    hc = HarnessConfig(texts=texts)
    extra = {k: cfg[k] for k in ("key_correct", "key_incorrect", "video_width", "loop_video", "lock_timeout_s",
                                 "release_after_s") if k in cfg}
    hc = replace(hc, **extra)
    design = DesignConfig.from_dict(cfg["design"]) if cfg.get("design") else None
    return StudyApp(cfg["manifest"], cfg["data_dir"], cfg["participant_id"], cfg["session_id"], design=design,
                    study_seed=int(cfg.get("study_seed", 0)), seed=cfg.get("seed"),
                    counterbalance_index=cfg.get("counterbalance_index"), config=hc)


def app_from_environment() -> StudyApp | W.Widget:
    """The app configured by ``$MOCOMP_STUDY_CONFIG``; a message widget if that is missing or wrong."""
    try:
        return app_from_config(config_from_environment())
    except (ValueError, OSError, TypeError) as e:
        return W.HTML(f"<p style='color:#b00'><b>The study is not configured:</b> {html.escape(str(e))}</p>")


__all__ = ["StudyApp", "HarnessConfig", "HarnessTexts", "app_from_environment", "app_from_config",
           "config_from_environment", "utc_now"]
