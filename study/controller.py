"""The trial controller: the one code path every response goes through.

The participant-facing app (:mod:`study.harness`) and the simulated observers
(:mod:`study.observers`) both drive a :class:`TrialController`; only the
source of the answer differs (a button/key in a browser, or an observer
model). The controller owns the order (from the plan on disk), the timing,
the break schedule and the write of every response (through
:meth:`study.session.Session.append_response`, which ``fsync``-s before it
returns); it ignores a second answer to the same trial (a double click), so a
response can neither be lost nor duplicated by the front end.

Response time ``rt_s`` is measured in the kernel, from :meth:`show` (the
trial screen being sent to the browser) to :meth:`respond` (the answer
arriving); it includes the video's loading time and the round trip to the
browser. The browser's own measurement, when available, is recorded as
``client_rt_s`` (see :mod:`study.harness`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from .session import Session, utc_now


@dataclass(frozen=True)
class TrialView:
    """What a front end needs to present one trial (or example)."""

    trial_index: int
    kind: str
    stimulus_id: str
    video: Path
    duration_s: float
    expected_response: str
    number: int
    """1-based position among the response trials (0 for examples)."""
    total: int
    """Number of response trials in the session."""
    meta: dict


class TrialController:
    """Step through a :class:`~study.session.Session`: examples, breaks, trials, end.

    Typical loop (what :func:`run_headless` and the app's callbacks do)::

        for ex in ctl.examples_to_show(): ctl.example_viewed(ex)
        while ctl.current() is not None:
            if ctl.break_due(): ctl.start_break(); ...; ctl.end_break()
            view = ctl.show()
            ctl.respond("correct", input="button")
        ctl.finish()
    """

    def __init__(self, session: Session, clock: Callable[[], float] = time.monotonic):
        self.session = session
        self.clock = clock
        self._shown: tuple[int, float, str] | None = None
        self._breaks_taken: set[int] = set()
        self._on_break_since: float | None = None
        self._finished = False
        if session.state.resumed and session.n_answered > 0:
            nxt = session.next_response_index()
            if nxt is not None:  # the welcome-back screen serves as the break due here
                self._breaks_taken.add(nxt)

    # ---------------------------------------------------------------- views
    def _view(self, trial_index: int) -> TrialView:
        t = self.session.trial(trial_index)
        s = self.session.stimuli
        number = 0
        if t["kind"] != "example":
            number = self.session._response_idx.index(int(trial_index)) + 1
        return TrialView(trial_index=int(trial_index), kind=t["kind"], stimulus_id=t["stimulus_id"],
                         video=s.video_path(t["stimulus_id"]), duration_s=float(s.table.at[t["stimulus_id"], "duration_s"]),
                         expected_response=t["expected_response"], number=number,
                         total=self.session.n_response_trials, meta=t)

    def examples_to_show(self) -> list[TrialView]:
        """Example trials, shown at the start of a session with no responses yet."""
        if self.session.n_answered > 0:
            return []
        ex = self.session.plan.trials[self.session.plan.trials["kind"] == "example"]
        return [self._view(int(i)) for i in ex["trial_index"]]

    def example_viewed(self, view: TrialView) -> None:
        self.session.log_event("example_viewed", trial_index=view.trial_index, stimulus_id=view.stimulus_id)

    # --------------------------------------------------------------- trials
    @property
    def n_answered(self) -> int:
        return self.session.n_answered

    @property
    def total(self) -> int:
        return self.session.n_response_trials

    def current(self) -> TrialView | None:
        """The next unanswered response trial (None when the session is complete)."""
        i = self.session.next_response_index()
        return None if i is None else self._view(i)

    def break_due(self) -> bool:
        i = self.session.next_response_index()
        if i is None or i in self._breaks_taken:
            return False
        return bool(self.session.trial(i)["break_before"])

    @property
    def break_s(self) -> float:
        """Suggested break length (s) from the plan's design (60 s for plans made before it was recorded)."""
        from .design import BREAK_S_DEFAULT

        return float(self.session.plan.meta.get("design", {}).get("break_s", BREAK_S_DEFAULT))

    def start_break(self) -> None:
        i = self.session.next_response_index()
        self._breaks_taken.add(i)
        self._on_break_since = self.clock()
        self.session.log_event("break_started", before_trial=i, n_answered=self.n_answered,
                               suggested_s=self.break_s)

    def end_break(self) -> None:
        dur = None if self._on_break_since is None else self.clock() - self._on_break_since
        self._on_break_since = None
        self.session.log_event("break_ended", duration_s=dur)

    def show(self) -> TrialView:
        """Mark the current trial as on screen now (starts the response clock)."""
        view = self.current()
        if view is None:
            raise ValueError("the session is complete; there is no trial to show")
        self._shown = (view.trial_index, self.clock(), utc_now())
        return view

    @property
    def showing(self) -> int | None:
        return None if self._shown is None else self._shown[0]

    def respond(self, response: str, *, input: str, rt_s: float | None = None,
                client_rt_s: float | None = None, trial_index: int | None = None, must_watch: bool = False,
                watched_to_end: bool | None = None, client_rt_end_s: float | None = None) -> dict | None:
        """Record the answer to the trial on screen; returns the written row.

        Returns None (and writes nothing) when no trial is on screen, or when
        ``trial_index`` is given and is not the trial on screen: the second
        click of a double click, or a stale event from an old screen; also when
        ``must_watch`` is enforced and the video has not ended yet
        (``watched_to_end`` false), logged as ``response_before_video_end``.
        """
        if self._shown is None or (trial_index is not None and int(trial_index) != self._shown[0]):
            self.session.log_event("response_ignored", response=response, input=input, trial_index=trial_index,
                                   showing=self.showing)
            return None
        idx, t0, shown_utc = self._shown
        if rt_s is None:
            rt_s = self.clock() - t0
        if must_watch and not watched_to_end:
            self.session.log_event("response_before_video_end", response=response, input=input,
                                   trial_index=idx)
            return None
        row = self.session.append_response(idx, response, input=input, rt_s=rt_s, shown_utc=shown_utc,
                                           client_rt_s=client_rt_s, must_watch=must_watch,
                                           watched_to_end=watched_to_end, client_rt_end_s=client_rt_end_s)
        self._shown = None
        return row

    def finish(self) -> None:
        if not self._finished:
            self._finished = True
            if self.session.finished:
                self.session.log_event("finished", n_answered=self.session.n_answered)
            else:
                self.session.log_event("closed_unfinished", n_answered=self.session.n_answered)
            self.session.close()


def run_headless(controller: TrialController, answer: Callable[[TrialView], tuple[str, float | None]],
                 *, input: str = "observer", progress: bool = False) -> int:
    """Run a whole session without a UI, asking ``answer(view) -> (response, rt_s)`` for each trial.

    Returns the number of responses written. This is the app's sequence of
    controller calls, minus the widgets.
    """
    for ex in controller.examples_to_show():
        controller.example_viewed(ex)
    n = 0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=controller.total, initial=controller.n_answered, desc="trials", leave=False)
    try:
        while controller.current() is not None:
            if controller.break_due():
                controller.start_break()
                controller.end_break()
            view = controller.show()
            resp, rt = answer(view)
            if controller.respond(resp, input=input, rt_s=rt) is not None:
                n += 1
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    controller.finish()
    return n
