"""Crash-safe storage of one participant's session, and its lock.

Layout of a session folder ``DATA/<participant_id>/<session_id>/``::

    plan.csv          the trial plan (written before the first trial, never changed)
    plan.json         how it was made (seed, design, stimulus set, plan_sha256)
    participant.json  participant information and consent time (written once)
    responses.csv     one row per answered trial (see DATA_DICTIONARY.md)
    events.jsonl      append-only log: opened, resumed, breaks, stale locks, finished, withdrawn
    session.lock      holder of the session (PID, host, time), see SessionLock
    withdrawn.json    only if the participant withdrew (see withdraw_session): who, when, why

Guarantees:

* **Nothing lost.** Every response is written with one ``write`` to a file
  opened in append mode, then ``fsync``-ed, before :meth:`Session.append_response`
  returns; the harness shows the next trial only after that.
* **Never overwritten.** Files are created with ``O_EXCL`` (or by an atomic
  link of a fully written temporary file); responses are only ever appended.
  The one repair is of a *torn* last line (a crash in the middle of a write
  that was therefore never acknowledged): the file is first copied to
  ``responses.csv.torn-<time>`` and then the fragment is truncated, and the
  repair is logged.
* **Resume in the same order.** Re-opening the session reads the plan from disk
  and continues at the first response trial without a row; existing rows are
  checked against the plan (order, stimulus) and any mismatch is an error.
* **One writer.** :class:`SessionLock` holds an exclusive ``flock`` on
  ``session.lock`` for the session's lifetime; a second window (any process
  on this host) gets :class:`~mocomp.errors.SessionLockedError`. The kernel
  drops a ``flock`` when its holder dies, so a lock left by a crashed process
  is recognised as stale and taken over (logged). For a holder on another
  host (a shared network drive, where ``flock`` may not be honoured) the lock
  counts as live until its heartbeat is older than ``stale_after_s``.
  A reloaded or closed page whose kernel lives on (its shutdown request lost)
  still holds the lock: ``mocomp study run`` has the server cull such kernels
  (no page connected, idle ``--kernel-cull-s`` seconds; see
  :func:`study.study_cli.voila_command`), after which the new page's "Try
  again" takes the session over; it is never shared.
* **Withdrawal marks, never deletes.** :func:`withdraw_session` (the app's
  debrief screen, or ``mocomp study withdraw``) writes ``withdrawn.json`` once
  (``O_EXCL``-style atomic create) under the session lock and logs the event;
  every file stays as it was. A withdrawn session cannot be opened again
  (:meth:`Session.open` refuses it), and ``mocomp study analyze`` leaves it out
  and lists it in its report. Deleting the files, where an ethics protocol
  requires it, is a deliberate step of the experimenter, never done here.
"""
from __future__ import annotations

import csv
import errno
import fcntl
import io
import json
import os
import re
import shutil
import socket
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd

from mocomp.errors import SessionLockedError, StudyDataError

from .design import DesignConfig, Plan, make_plan, participant_seed
from .stimulus_set import StimulusSet

#: Columns of ``responses.csv`` in order (documented in DATA_DICTIONARY.md).
RESPONSE_COLUMNS: tuple[str, ...] = (
    "participant_id", "session_id", "stimulus_set_id", "plan_sha256", "seed", "trial_index", "kind",
    "group", "repetition", "stimulus_id", "condition", "perturbation", "direction", "nominal_level",
    "achieved_error", "base_clip", "expected_response", "response", "rated_correct", "input", "must_watch",
    "watched_to_end", "rt_s", "client_rt_s", "client_rt_end_s", "shown_utc", "responded_utc",
)


def _header_mismatch(header: list[str]) -> str:
    """What differs between a session file's header and :data:`RESPONSE_COLUMNS`, and what to do."""
    missing = [c for c in RESPONSE_COLUMNS if c not in header]
    extra = [c for c in header if c not in RESPONSE_COLUMNS]
    parts = []
    if missing:
        parts.append("missing " + ", ".join(missing))
    if extra:
        parts.append("unknown " + ", ".join(extra))
    if not parts:
        parts.append("same columns in another order")
    return (f"header differs from this version's columns ({'; '.join(parts)}): the session was written by "
            f"another version of the study package or edited by hand; nothing is written to it: resume it with "
            f"the version that wrote it, or start a new session ID (see DATA_DICTIONARY.md for the columns)")


RESPONSES = ("correct", "incorrect")
_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


def check_id(value: str, what: str) -> str:
    """Participant and session ids become folder names: letters, digits, ``_.-``, at most 64.

    The id is checked as given, never normalised: ``" P01 "`` or ``"P01\\n"`` is refused (a
    :class:`~mocomp.errors.StudyDataError`, also a ``ValueError``), not opened as ``P01``, so a
    mistyped id can never land in (or resume) another participant's folder.
    """
    value = str(value)
    if value != value.strip():
        raise StudyDataError(f"{what} {value!r} is not valid: it has leading or trailing whitespace "
                             "(ids are used exactly as given; remove it)")
    if not _ID_RE.fullmatch(value):
        raise StudyDataError(f"{what} {value!r} is not valid: use 1-64 letters, digits, '_', '.', '-' "
                             "(starting with a letter or digit)")
    return value


def utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _write_new(path: Path, data: bytes) -> None:
    """Create ``path`` with ``data`` atomically; FileExistsError if it exists (never overwrites)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)
    try:
        os.link(tmp, path)  # atomic; fails if path exists
    finally:
        os.unlink(tmp)
    _fsync_dir(path.parent)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class SessionLock:
    """Exclusive lock on a session folder (see the module docstring).

    Use :meth:`acquire` (retries up to ``timeout`` seconds, e.g. while the
    kernel of a just-reloaded page shuts down) and :meth:`release`;
    :meth:`heartbeat` refreshes the time stamp other hosts judge staleness by.
    """

    _held_here: dict[str, "SessionLock"] = {}

    def __init__(self, folder: str | Path, stale_after_s: float = 1800.0):
        self.path = Path(folder) / "session.lock"
        self.stale_after_s = float(stale_after_s)
        self._fd: int | None = None
        self.took_over: dict | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def holder(self) -> dict:
        try:
            txt = self.path.read_text()
            return json.loads(txt) if txt.strip() else {}
        except (OSError, ValueError):
            return {}

    def _try_once(self) -> None:
        key = str(self.path.resolve())
        if key in SessionLock._held_here:
            raise SessionLockedError(f"session {self.path.parent} is already open in this process "
                                     "(close the other app/session first)")
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            os.close(fd)
            if e.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                h = self.holder()
                raise SessionLockedError(
                    f"session {self.path.parent} is open in another window or process "
                    f"(pid {h.get('pid', '?')} on {h.get('host', '?')} since {h.get('since', '?')})") from None
            raise
        try:
            prev = {}
            raw = os.read(fd, 65536)
            if raw.strip():
                try:
                    prev = json.loads(raw)
                except ValueError:
                    prev = {"unparsable": raw[:200].decode(errors="replace")}
            host = socket.gethostname()
            if prev and prev.get("host") not in (None, host):
                age = time.time() - os.fstat(fd).st_mtime
                if age < self.stale_after_s:
                    raise SessionLockedError(
                        f"session {self.path.parent} is held by pid {prev.get('pid')} on host {prev.get('host')} "
                        f"(heartbeat {age:.0f} s ago; it counts as stale after {self.stale_after_s:.0f} s)")
            self.took_over = prev or None  # a holder that died without releasing (flock was free)
            info = {"pid": os.getpid(), "host": host, "since": utc_now()}
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps(info).encode(), 0)
            os.fsync(fd)
        except BaseException:
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
            raise
        self._fd = fd
        SessionLock._held_here[key] = self

    def acquire(self, timeout: float = 10.0, poll: float = 0.25) -> "SessionLock":
        self.path.parent.mkdir(parents=True, exist_ok=True)
        deadline = time.monotonic() + float(timeout)
        while True:
            try:
                self._try_once()
                return self
            except SessionLockedError:
                if time.monotonic() >= deadline or str(self.path.resolve()) in SessionLock._held_here:
                    raise
                time.sleep(poll)

    def heartbeat(self) -> None:
        if self._fd is not None:
            os.utime(self.path)

    def release(self) -> None:
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        SessionLock._held_here.pop(str(self.path.resolve()), None)
        try:
            os.ftruncate(fd, 0)
            os.fsync(fd)
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)

    def __del__(self):  # pragma: no cover - safety net for abandoned objects
        try:
            self.release()
        except Exception:
            pass


def _append_event(folder: Path, event: str, **data) -> None:
    """Append one JSON line to ``folder/events.jsonl`` and ``fsync`` it."""
    rec = json.dumps({"utc": utc_now(), "event": event, **data}, default=str) + "\n"
    fd = os.open(Path(folder) / "events.jsonl", os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    try:
        os.write(fd, rec.encode())
        os.fsync(fd)
    finally:
        os.close(fd)


#: The file that marks a session withdrawn (see :func:`withdraw_session`).
WITHDRAWN_FILE = "withdrawn.json"
WITHDRAWN_BY = ("participant", "experimenter")


def withdrawal_record(folder: str | Path) -> dict | None:
    """The withdrawal record of a session folder (``withdrawn.json``), or None if not withdrawn.

    An unreadable record still means "withdrawn" (the file's existence is the mark): its
    content is then ``{"unreadable": <reason>}``.
    """
    p = Path(folder) / WITHDRAWN_FILE
    if not p.exists():
        return None
    try:
        rec = json.loads(p.read_text())
        return rec if isinstance(rec, dict) else {"unreadable": "not a JSON object"}
    except (OSError, ValueError) as e:
        return {"unreadable": str(e)}


def _refuse_withdrawn(folder: Path) -> None:
    rec = withdrawal_record(folder)
    if rec is not None:
        raise StudyDataError(f"this session was withdrawn ({rec.get('withdrawn_utc', '?')}, by "
                             f"{rec.get('by', '?')}); its data are kept, marked withdrawn, and excluded from the "
                             "analysis; nothing more is written to it (start a new session id only with the "
                             "participant's renewed consent)", folder / WITHDRAWN_FILE)


def withdraw_session(data_dir: str | Path, participant_id: str, session_id: str, *, by: str,
                     reason: str = "", lock_timeout: float = 2.0) -> tuple[dict, bool]:
    """Mark a session withdrawn: write ``withdrawn.json`` (once) and log ``withdrawn`` in ``events.jsonl``.

    Nothing is deleted or changed: ``responses.csv``, ``participant.json`` and the plan stay
    byte for byte; the mark makes :meth:`Session.open` refuse the session and
    ``mocomp study analyze`` leave it out (listing it). ``by``: ``"participant"`` (the app's
    debrief screen) or ``"experimenter"`` (``mocomp study withdraw``).

    The session lock is taken first, so a session open in a running app (another window or
    process) is refused (:class:`~mocomp.errors.SessionLockedError`) rather than marked
    while it may still be written to. Returns ``(record, newly)``: ``newly`` is False when
    the session was already withdrawn (the first record is kept and returned).
    Raises :class:`~mocomp.errors.StudyDataError` when the folder is not a session
    (no ``plan.json``).
    """
    pid = check_id(participant_id, "participant id")
    sid = check_id(session_id, "session id")
    if by not in WITHDRAWN_BY:
        raise ValueError(f"by must be one of {WITHDRAWN_BY}, got {by!r}")
    folder = Path(data_dir) / pid / sid
    if not (folder / "plan.json").is_file():
        raise StudyDataError(f"no session {pid}/{sid} here (no plan.json in {folder}); check --data, "
                             "--participant and --session", folder)
    old = withdrawal_record(folder)
    if old is not None:
        return old, False
    lock = SessionLock(folder).acquire(timeout=lock_timeout)
    try:
        old = withdrawal_record(folder)
        if old is not None:
            return old, False
        resp = folder / "responses.csv"
        raw = resp.read_bytes() if resp.exists() else b""
        import hashlib

        n_rows = max(raw.count(b"\n") - 1, 0)
        rec = {"participant_id": pid, "session_id": sid, "withdrawn_utc": utc_now(), "by": by,
               "reason": str(reason), "n_responses": n_rows,
               "responses_sha256": hashlib.sha256(raw).hexdigest() if raw else None,
               "note": "data kept unchanged, excluded from the analysis (mocomp study analyze lists this session)"}
        try:
            _write_new(folder / WITHDRAWN_FILE, json.dumps(rec, indent=2, sort_keys=True).encode())
        except FileExistsError:
            return withdrawal_record(folder), False
        _append_event(folder, "withdrawn", by=by, reason=rec["reason"], n_responses=n_rows)
        return rec, True
    finally:
        lock.release()


def _format_row(values: list) -> bytes:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(values)
    return buf.getvalue().encode()


@dataclass
class ResumeState:
    """What :meth:`Session.open` found: rows already on disk, and repairs made."""

    resumed: bool
    n_answered: int
    repaired_torn_line: bool = False


class Session:
    """One participant's session folder, opened for writing (holds the lock).

    Create or resume with :meth:`open`; always :meth:`close` (or use ``with``).
    """

    def __init__(self, folder: Path, plan: Plan, stimuli: StimulusSet, lock: SessionLock, state: ResumeState,
                 participant_id: str, session_id: str):
        self.folder = folder
        self.plan = plan
        self.stimuli = stimuli
        self.lock = lock
        self.state = state
        self.participant_id = participant_id
        self.session_id = session_id
        self._response_idx = [int(i) for i in plan.response_trials["trial_index"]]
        self._answered: list[int] = []
        self._fd: int | None = None

    # ------------------------------------------------------------------ open
    @classmethod
    def open(cls, data_dir: str | Path, participant_id: str, session_id: str, stimuli: StimulusSet, *,
             config: DesignConfig | None = None, seed: int | None = None, study_seed: int = 0,
             counterbalance_index: int | None = None, lock_timeout: float = 10.0,
             stale_after_s: float = 1800.0, verify_videos: bool = True) -> "Session":
        """Create a new session (plan written to disk first) or resume an existing one.

        ``seed`` defaults to :func:`~study.design.participant_seed` ``(study_seed, participant_id)``.
        On resume the plan on disk is used; a different stimulus set, seed,
        design or counterbalance index is refused (use a new session id) rather
        than silently ignored. ``verify_videos``: first recompute the SHA-256 of
        every video and compare it with the manifest
        (:meth:`~study.stimulus_set.StimulusSet.verify_videos`), so no session
        starts on a changed or missing file.
        """
        pid = check_id(participant_id, "participant id")
        sid = check_id(session_id, "session id")
        folder = Path(data_dir) / pid / sid
        _refuse_withdrawn(folder)
        if verify_videos:
            stimuli.verify_videos()
        folder.mkdir(parents=True, exist_ok=True)
        lock = SessionLock(folder, stale_after_s=stale_after_s).acquire(timeout=lock_timeout)
        try:
            _refuse_withdrawn(folder)  # (withdrawn while this call waited for the lock)
            sess = cls._open_locked(folder, pid, sid, stimuli, config, seed, study_seed, counterbalance_index, lock)
        except BaseException:
            lock.release()
            raise
        if lock.took_over:
            sess.log_event("stale_lock_recovered", previous_holder=lock.took_over)
        sess.log_event("resumed" if sess.state.resumed else "opened", n_answered=sess.state.n_answered,
                       pid=os.getpid(), host=socket.gethostname())
        return sess

    @classmethod
    def _open_locked(cls, folder, pid, sid, stimuli, config, seed, study_seed, cb_index, lock):
        plan_csv, plan_json = folder / "plan.csv", folder / "plan.json"
        if seed is None:
            seed = participant_seed(study_seed, pid)
        if not plan_json.exists():
            if (folder / "responses.csv").exists():
                raise StudyDataError("responses exist but the plan is missing; refusing to re-plan", folder)
            if plan_csv.exists():  # crashed between writing plan.csv and plan.json: never committed
                plan_csv.rename(folder / f"plan.csv.incomplete-{int(time.time())}")
            plan = make_plan(stimuli, config, participant_id=pid, seed=seed, counterbalance_index=cb_index)
            plan.meta["session_id"] = sid
            _write_new(plan_csv, plan.to_csv_bytes())
            _write_new(plan_json, plan.meta_json().encode())
            sess = cls(folder, plan, stimuli, lock, ResumeState(False, 0), pid, sid)
            sess._create_responses_file()
            return sess
        meta = json.loads(plan_json.read_text())
        csv_bytes = plan_csv.read_bytes()
        plan = Plan.from_files(csv_bytes, meta)
        import hashlib

        if hashlib.sha256(csv_bytes).hexdigest() != meta.get("plan_sha256"):
            raise StudyDataError("plan.csv does not match the plan_sha256 recorded in plan.json "
                                 "(the plan was edited after the session started)", plan_csv)
        if meta.get("stimulus_set_id") != stimuli.set_id:
            raise StudyDataError(f"this session was planned with stimulus set {meta.get('stimulus_set_id')} "
                                 f"but the manifest {stimuli.path} is set {stimuli.set_id}; "
                                 "use the original manifest or a new session id", plan_json)
        if meta.get("participant_id") != pid:
            raise StudyDataError(f"plan belongs to participant {meta.get('participant_id')!r}, not {pid!r}", plan_json)
        if int(meta.get("seed")) != int(seed):
            raise ValueError(f"session {folder} was planned with seed {meta.get('seed')}, not {seed}; "
                             "use a new session id for a new plan")
        cb_planned = meta.get("counterbalance_index")
        if (None if cb_index is None else int(cb_index)) != (None if cb_planned is None else int(cb_planned)):
            raise ValueError(f"session {folder} was planned with counterbalance index {cb_planned}, not {cb_index}; "
                             "resume it with the same --counterbalance-index, or use a new session id")
        if config is not None and config.to_dict() != DesignConfig.from_dict(meta.get("design") or {}).to_dict():
            raise ValueError(f"session {folder} was planned with a different design; "
                             "use a new session id for a new design")
        sess = cls(folder, plan, stimuli, lock, ResumeState(True, 0), pid, sid)
        if not (folder / "responses.csv").exists():
            sess._create_responses_file()
        else:
            sess._load_existing_responses()
        sess.state.n_answered = len(sess._answered)
        return sess

    # ------------------------------------------------------------- responses
    @property
    def responses_path(self) -> Path:
        return self.folder / "responses.csv"

    def _create_responses_file(self) -> None:
        fd = os.open(self.responses_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
        os.write(fd, _format_row(list(RESPONSE_COLUMNS)))
        os.fsync(fd)
        _fsync_dir(self.folder)
        self._fd = fd

    def _load_existing_responses(self) -> None:
        path = self.responses_path
        raw = path.read_bytes()
        if raw and not raw.endswith(b"\n"):
            cut = raw.rfind(b"\n") + 1
            backup = path.with_name(f"responses.csv.torn-{datetime.now(timezone.utc):%Y%m%dT%H%M%S%f}")
            shutil.copy2(path, backup)
            _fsync_dir(self.folder)
            with open(path, "r+b") as f:
                f.truncate(cut)
                f.flush()
                os.fsync(f.fileno())
            self.state.repaired_torn_line = True
            self.log_event("torn_line_repaired", backup=backup.name, fragment=raw[cut:][:500].decode(errors="replace"))
            raw = raw[:cut]
        text = raw.decode()
        if not text:
            raise StudyDataError("responses.csv is empty (no header)", path)
        rows = list(csv.reader(io.StringIO(text)))
        if tuple(rows[0]) != RESPONSE_COLUMNS:
            raise StudyDataError(_header_mismatch(rows[0]), path, 1)
        ti = RESPONSE_COLUMNS.index("trial_index")
        st = RESPONSE_COLUMNS.index("stimulus_id")
        plan_stim = dict(zip(self.plan.trials["trial_index"].astype(int), self.plan.trials["stimulus_id"]))
        for k, r in enumerate(rows[1:]):
            line = k + 2
            if len(r) != len(RESPONSE_COLUMNS):
                raise StudyDataError(f"{len(r)} fields, expected {len(RESPONSE_COLUMNS)}", path, line)
            if k >= len(self._response_idx):
                raise StudyDataError("more responses than response trials in the plan", path, line)
            want = self._response_idx[k]
            try:
                got = int(r[ti])
            except ValueError:
                raise StudyDataError(f"not an integer: {r[ti]!r}", path, line, "trial_index") from None
            if got != want:
                what = "duplicate" if got in self._answered else "out-of-order"
                raise StudyDataError(f"{what} trial_index {got}; the plan's next response trial is {want}",
                                     path, line, "trial_index")
            if r[st] != plan_stim[got]:
                raise StudyDataError(f"stimulus {r[st]!r} but the plan shows {plan_stim[got]!r} at trial {got}",
                                     path, line, "stimulus_id")
            self._answered.append(got)
        self._fd = os.open(path, os.O_WRONLY | os.O_APPEND)

    @property
    def n_answered(self) -> int:
        return len(self._answered)

    @property
    def n_response_trials(self) -> int:
        return len(self._response_idx)

    @property
    def finished(self) -> bool:
        return self.n_answered >= self.n_response_trials

    def next_response_index(self) -> int | None:
        """Plan ``trial_index`` of the first unanswered response trial (None when done)."""
        return None if self.finished else self._response_idx[self.n_answered]

    def trial(self, trial_index: int) -> dict:
        return self.plan.trials.iloc[int(trial_index)].to_dict()

    def append_response(self, trial_index: int, response: str, *, input: str, rt_s: float,
                        shown_utc: str, client_rt_s: float | None = None, must_watch: bool = False,
                        watched_to_end: bool | None = None, client_rt_end_s: float | None = None) -> dict:
        """Append one response row and ``fsync`` it; returns the row as written.

        ``must_watch``: the answer was locked until the video had ended (enforced);
        ``watched_to_end``: the front end reported the end of the video before the
        answer (None: unknown, e.g. a simulated observer or no browser script).

        Only the next unanswered response trial may be answered (anything else
        is a programming error, raised as ValueError, and nothing is written).
        """
        if self._fd is None:
            raise ValueError("session is closed")
        want = self.next_response_index()
        if want is None or int(trial_index) != want:
            raise ValueError(f"trial {trial_index} is not the next unanswered trial ({want})")
        if response not in RESPONSES:
            raise ValueError(f"response must be one of {RESPONSES}, got {response!r}")
        if must_watch and not watched_to_end:
            raise ValueError(f"trial {trial_index}: an enforced must-watch answer needs the video to have ended")
        t = self.trial(trial_index)
        srow = self.stimuli.row(t["stimulus_id"])
        row = dict(participant_id=self.participant_id, session_id=self.session_id,
                   stimulus_set_id=self.plan.meta["stimulus_set_id"], plan_sha256=self.plan.sha256,
                   seed=self.plan.meta["seed"], trial_index=int(trial_index), kind=t["kind"], group=t["group"],
                   repetition=int(t["repetition"]), stimulus_id=t["stimulus_id"], condition=t["condition"],
                   perturbation=t["perturbation"], direction=t["direction"],
                   nominal_level=float(t["nominal_level"]), achieved_error=float(srow["achieved_error"]),
                   base_clip=t["base_clip"], expected_response=t["expected_response"], response=response,
                   rated_correct=int(response == "correct"), input=str(input), must_watch=int(bool(must_watch)),
                   watched_to_end="" if watched_to_end is None else int(bool(watched_to_end)),
                   rt_s=round(float(rt_s), 4),
                   client_rt_s="" if client_rt_s is None else round(float(client_rt_s), 4),
                   client_rt_end_s="" if client_rt_end_s is None else round(float(client_rt_end_s), 4),
                   shown_utc=shown_utc, responded_utc=utc_now())
        data = _format_row([row[c] for c in RESPONSE_COLUMNS])
        n = os.write(self._fd, data)
        if n != len(data):  # pragma: no cover - a short write on a local disk means the disk is full
            raise OSError(f"short write to {self.responses_path} ({n} of {len(data)} bytes)")
        os.fsync(self._fd)
        self._answered.append(int(trial_index))
        self.lock.heartbeat()
        return row

    def responses(self) -> pd.DataFrame:
        """The responses on disk (a fresh read)."""
        return pd.read_csv(self.responses_path, keep_default_na=False, dtype=str)

    # -------------------------------------------------------- info and events
    def participant_info(self) -> dict | None:
        p = self.folder / "participant.json"
        return json.loads(p.read_text()) if p.exists() else None

    def save_participant_info(self, info: dict) -> dict:
        """Write ``participant.json`` once; on a resumed session the first record stays and is returned."""
        existing = self.participant_info()
        if existing is not None:
            if {k: v for k, v in existing.items() if k != "saved_utc"} != dict(info):
                self.log_event("participant_info_not_overwritten", new=dict(info))
            return existing
        rec = {**dict(info), "saved_utc": utc_now()}
        try:
            _write_new(self.folder / "participant.json", json.dumps(rec, indent=2, sort_keys=True).encode())
        except FileExistsError:
            return self.participant_info()
        return rec

    def log_event(self, event: str, **data) -> None:
        _append_event(self.folder, event, **data)

    def events(self) -> list[dict]:
        p = self.folder / "events.jsonl"
        return [json.loads(x) for x in p.read_text().splitlines() if x.strip()] if p.exists() else []

    # ------------------------------------------------------------------ close
    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        self.lock.release()

    @property
    def closed(self) -> bool:
        return self._fd is None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
