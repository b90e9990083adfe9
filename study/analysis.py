"""Analysis of perception-study responses: ratings, d', psychometric and mixed models.

Pipeline (what ``mocomp study analyze RESPONSES_DIR -o REPORT_DIR`` runs, via
:func:`analyze`):

1. :func:`load_responses` reads every ``responses.csv`` below a folder and
   checks the schema: required columns, values, duplicate trials (the same
   participant/session/trial twice, within or across files), mixed stimulus
   sets. Zero-byte files are errors; header-only files (sessions with no
   answers, e.g. consent declined) are skipped and listed; a torn last line
   (no line end: a crash mid-write in a session never resumed) is left out
   with a warning naming the file and line, and listed in the report.
   Sessions marked withdrawn (``withdrawn.json`` beside ``responses.csv``,
   written by the app's debrief screen or ``mocomp study withdraw``) are not
   read at all; they are listed in the report (participant, session, when,
   by whom).
2. Only ``kind == "test"`` trials enter the statistics (examples, practice and
   attention checks do not); attention checks are summarised per participant.
3. :func:`condition_table`: per condition (error type x direction x level) the
   mean percentage rated correct (with Wilson 95 % CI) and d' against the
   unperturbed motions (see :mod:`study.sdt` for the convention, the
   corrections and the ceiling). The false-alarm rate comes from the
   unperturbed motions shown in the same error group (``control="group"``,
   the paper's Table 2 has one 0 % rating per group) or from all of them
   (``"pooled"``). Two group d' side by side, each with a participant-level
   (cluster) bootstrap CI: the *pooled* d' from counts pooled over participants
   (as the paper computed it from mean ratings), and the *mean of the
   per-participant d'* (Macmillan & Creelman 2005, *Detection Theory: A User's
   Guide*, 2nd ed., on group data: average the individual d', since pooling the rates of
   observers with different criteria biases d' towards 0). ``headline``
   (``mocomp study analyze --headline``) says which one the report, the d'
   figure and ``dprime_headline`` use. The default is the pooled d', because
   this study has few trials per participant and condition (2-4 with the
   paper's design), where the correction for rates of 0 and 1 caps and shrinks
   every individual d': in simulated cohorts of 20 (``tests/
   test_study_analysis.py::test_pooled_headline_is_the_better_estimate_at_this_design``;
   20 identical observers or criteria spread 0-1.2, 2 or 4 signal trials per
   participant and condition) the mean of the individual d' was 0.23-0.28
   too low on average and its 95 % CI covered the true d' in 60-70 % of the
   conditions, against -0.02 to -0.16 and 85-90 % for the pooled d'. Use
   ``"mean"`` when each participant sees each condition many times (or pool
   levels, ``participants_series.csv``).
4. :func:`participant_dprimes`: d' per participant, per condition and per
   error type (levels pooled), with a parametric bootstrap CI at the corrected
   rates (seeded; never zero-width when a cell's rate is 0 or 1, undefined
   without a correction; see that function).
5. :func:`fit_psychometric_glms`: per error type, a binomial GLM (probit or
   logit link, statsmodels) of P("incorrect") on the error level, the group's
   unperturbed motions at level 0, with participant-clustered (sandwich) SEs
   from 8 participants on. For the probit link the slope is d' per
   unit level (d'(x) = b x), so the *threshold* (level where d' = 1) is 1/b
   with a CI mapped from the Wald CI of b (unbounded when that CI contains 0).
6. :func:`fit_mixed_model`: per error group, a mixed-effects logistic model
   ``incorrect ~ condition`` (treatment contrasts against the unperturbed
   motions) with a random intercept per participant, fitted by maximum
   likelihood with adaptive Gauss-Hermite quadrature (:mod:`study.glmm`).
   statsmodels' ``BinomialBayesMixedGLM`` (variational Bayes; its N(0, 2^2)
   prior shrinks large effects) and a GEE (population-averaged) are reported
   beside it as cross-checks.
7. the observer model (:mod:`study.observer_fit`): per error type threshold
   and slope of d'(x) = (x / threshold) ** slope, a shared criterion and a
   lapse rate, by maximum likelihood with profile-likelihood CIs
   (``observer_model.csv``); the model the simulated observers answer with.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import norm

from mocomp.errors import StudyDataError

from .sdt import CORRECTIONS, dprime_ceiling, dprime_counts, wilson_interval
from .session import WITHDRAWN_FILE, withdrawal_record
from .stimulus_set import DIRECTIONS, PERTURBATIONS, condition_label

#: Columns the analysis needs in every responses CSV.
REQUIRED_COLUMNS = ("participant_id", "session_id", "stimulus_set_id", "trial_index", "kind", "group",
                    "stimulus_id", "perturbation", "direction", "nominal_level", "response")
SERIES = ["perturbation", "direction"]


@dataclass
class ResponseData:
    """All responses of a study, validated.

    ``trials``: every row of every file (typed), plus ``incorrect`` (0/1),
    ``source_file`` and ``source_line``. ``skipped``: (file, reason) for
    header-only files. ``stimulus_set_ids``: the set(s) the sessions used.
    ``dropped_lines``: (file, line, reason) for torn last lines left out (a
    crash in the middle of writing a row, in a session never resumed).
    ``mixed_files``: (file, participant ids) for files holding rows of more than
    one participant (analysed per participant, with a warning).
    ``sessions``: answered/planned trials per session (:func:`session_summary`);
    ``incomplete``: the sessions that stopped early.
    ``withdrawn``: sessions left out because the participant withdrew (one dict each:
    participant_id, session_id, file, withdrawn_utc, by, reason; see
    :func:`study.session.withdraw_session`).
    """

    trials: pd.DataFrame
    files: list[Path]
    skipped: list[tuple[str, str]] = field(default_factory=list)
    stimulus_set_ids: list[str] = field(default_factory=list)
    dropped_lines: list[tuple[str, int, str]] = field(default_factory=list)
    mixed_files: list[tuple[str, list[str]]] = field(default_factory=list)
    sessions: pd.DataFrame = field(default_factory=pd.DataFrame)
    withdrawn: list[dict] = field(default_factory=list)

    @property
    def incomplete(self) -> pd.DataFrame:
        """Sessions with fewer answers than planned (see :func:`session_summary`)."""
        if not len(self.sessions):
            return self.sessions
        return self.sessions[~self.sessions["complete"]]

    @property
    def test(self) -> pd.DataFrame:
        return self.trials[self.trials["kind"] == "test"]

    @property
    def attention(self) -> pd.DataFrame:
        return self.trials[self.trials["kind"] == "attention"]

    @property
    def participants(self) -> list[str]:
        return sorted(self.trials["participant_id"].unique())


class ResponseValueError(StudyDataError):
    """One bad value in a responses CSV: ``FILE:LINE: column COL: value 'X' is ...`` (one line).

    Attributes as :class:`~mocomp.errors.StudyDataError` (``path``, ``line``,
    ``column``, ``reason``) plus ``value`` (the text found in the file).
    """

    def __init__(self, path, line: int, column: str, value, problem: str):
        super().__init__(problem, path, line, column)
        self.value = value
        shown = str(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        self.args = (f"{path}:{line}: column {column}: value {shown!r} is {problem}",)


#: Distinct values per column up to which the reader interns the cells (see :func:`load_responses`).
_INTERN_MAX = 100_000
#: Largest trial_index accepted (a row of plan.csv; int32 range, as any plan is far smaller).
MAX_TRIAL_INDEX = 2**31 - 1
_ID_RE = r"^[A-Za-z0-9_.\-]{1,64}$"
_INT_RE = r"^\s*\+?[0-9]+(\.0*)?\s*$"  # non-negative integer text ("12", "12.0"); no exponent, no sign


def _decode_utf8(raw: bytes, path: Path) -> str:
    """The file as text; a byte that is not UTF-8 gives a one-line error naming line and column."""
    import csv

    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        head = raw[:raw.find(b"\n")].decode("utf-8", "replace") if b"\n" in raw else ""
        names = next(csv.reader([head])) if head else []
        line_start = raw.rfind(b"\n", 0, e.start) + 1
        before = raw[line_start:e.start].decode("utf-8", "replace")
        field_no = len(next(csv.reader([before + "x"]))) - 1 if before else 0
        col = names[field_no] if line > 1 and field_no < len(names) else f"{field_no + 1}"
        end = raw.find(b"\n", e.start)
        cell = raw[line_start:end if end >= 0 else len(raw)].decode("latin-1")
        cells = next(csv.reader([cell])) if cell else [""]
        value = cells[field_no] if field_no < len(cells) else cell
        raise ResponseValueError(path, line, col, value,
                                 f"not UTF-8 (byte 0x{raw[e.start]:02x}; responses files are UTF-8: re-save the "
                                 f"file as UTF-8, e.g. iconv -f latin1 -t utf-8)") from None


def _check_values(df: pd.DataFrame, require: tuple[str, ...]) -> None:
    """Every column of the data dictionary (study/DATA_DICTIONARY.md): types, ranges, allowed sets.

    Typed columns are converted in place (``trial_index`` int64; levels, times
    float64). The first bad value raises :class:`ResponseValueError`.

    All files are checked together, and each check runs on the *distinct* values of a
    column (``pd.factorize``; a study has few distinct levels, kinds, ids ...), mapped
    back to the rows: the cost is one hash pass per column, whatever the number of rows.
    """
    lines = df["source_line"].to_numpy()
    cache: dict[str, tuple[np.ndarray, pd.Series]] = {}

    def col_u(col):
        """(codes per row, distinct values as a str Series)."""
        if col not in cache:
            codes, uniq = pd.factorize(df[col].to_numpy(object))
            cache[col] = codes, pd.Series(np.asarray(uniq, object), dtype=object).astype(str)
        return cache[col]

    def rows_of(col, mask_u):
        codes, _ = col_u(col)
        return np.asarray(mask_u, bool)[codes]

    def bad(mask, col, problem):
        mask = np.asarray(mask, bool)
        if mask.any():
            i = int(np.flatnonzero(mask)[0])
            v = df[col].iloc[i]
            raise ResponseValueError(df["source_file"].iloc[i], int(lines[i]), col, v,
                                     problem(v) if callable(problem) else problem)

    def bad_u(col, mask_u, problem):
        if np.asarray(mask_u, bool).any():
            bad(rows_of(col, mask_u), col, problem)

    def number(col, *, empty_ok: bool, nonneg: bool, what: str = "a number"):
        codes, u = col_u(col)
        txt = u.str.strip()
        empty = (txt == "").to_numpy()
        num = pd.to_numeric(txt.where(~empty, np.nan), errors="coerce").to_numpy(float)
        if not empty_ok:
            bad_u(col, empty, f"empty ({col} must be {what})")
        bad_u(col, ~empty & np.isnan(num), f"not {what}")
        bad_u(col, ~empty & ~np.isfinite(num), f"not finite ({col} must be {what})")
        if nonneg:
            bad_u(col, ~empty & (num < 0), f"negative ({col} must be >= 0)")
        return num[codes]

    def in_set(col, allowed, problem):
        bad_u(col, ~col_u(col)[1].isin(allowed).to_numpy(), problem)

    for col in ("participant_id", "session_id", "stimulus_set_id", "stimulus_id"):
        bad_u(col, (col_u(col)[1].str.strip() == "").to_numpy(), "empty (every row needs one)")
    bad_u("participant_id", ~col_u("participant_id")[1].str.match(_ID_RE).to_numpy(bool),
          "not a participant code (letters, digits, _ . -, at most 64)")
    in_set("response", ("correct", "incorrect"), "not 'correct' or 'incorrect'")
    in_set("kind", ("practice", "test", "attention"), "not practice, test or attention")
    in_set("perturbation", PERTURBATIONS, f"not a known perturbation ({', '.join(PERTURBATIONS)})")
    in_set("direction", DIRECTIONS, f"not a known direction ({', '.join(DIRECTIONS)})")
    p_none = rows_of("perturbation", (col_u("perturbation")[1] == "none").to_numpy())
    d_none = rows_of("direction", (col_u("direction")[1] == "none").to_numpy())
    bad(p_none != d_none, "direction",
        "inconsistent with the perturbation (direction is 'none' exactly for unperturbed motions)")
    is_test = rows_of("kind", (col_u("kind")[1] == "test").to_numpy())
    bad(is_test & rows_of("group", (col_u("group")[1].str.strip() == "").to_numpy()), "group",
        "empty (every test trial belongs to an error group)")
    # trial_index: a non-negative integer (a plan row)
    codes, u = col_u("trial_index")
    bad_u("trial_index", ~u.str.match(_INT_RE).to_numpy(bool), "not a non-negative integer (a row of plan.csv)")
    num = pd.to_numeric(u.str.strip(), errors="coerce").to_numpy(float)
    bad_u("trial_index", num > MAX_TRIAL_INDEX, f"out of range (trial_index must be 0..{MAX_TRIAL_INDEX})")
    df["trial_index"] = num.astype(np.int64)[codes]
    # levels
    lv = number("nominal_level", empty_ok=False, nonneg=True, what="a finite number >= 0 (percent)")
    bad(p_none & (lv != 0), "nominal_level", "not 0 for an unperturbed motion (perturbation 'none')")
    df["nominal_level"] = lv
    if "achieved_error" in df.columns:
        df["achieved_error"] = number("achieved_error", empty_ok="achieved_error" not in require, nonneg=False,
                                      what="a finite number (percent)")
    for col in ("rt_s", "client_rt_s", "client_rt_end_s"):
        if col in df.columns:
            df[col] = number(col, empty_ok=col != "rt_s", nonneg=True, what="a finite time >= 0 in seconds")
    if "repetition" in df.columns:
        codes, u = col_u("repetition")
        rep = u.str.strip()
        bad_u("repetition", ((rep != "") & ~rep.str.match(_INT_RE).astype(bool)).to_numpy(),
              "not a non-negative integer (0, 1 or 2)")
        df["repetition"] = pd.to_numeric(rep.where(rep != "", np.nan), errors="coerce").to_numpy(float)[codes]
    for col, pat, what in (("seed", r"^[0-9]+$", "not a non-negative integer"),
                           ("plan_sha256", r"^[0-9a-f]{64}$", "not a SHA-256 (64 lower-case hex digits)")):
        if col in df.columns:
            t = col_u(col)[1].str.strip()
            bad_u(col, ((t != "") & ~t.str.match(pat).astype(bool)).to_numpy(), what)
    for col, allowed in (("expected_response", ("", "correct", "incorrect")), ("input", ("", "button", "key", "observer", "published")),
                         ("must_watch", ("", "0", "1")), ("watched_to_end", ("", "0", "1"))):
        if col in df.columns:
            in_set(col, allowed, f"not one of {', '.join(repr(a) for a in allowed)}")
    if "rated_correct" in df.columns:
        resp_c = rows_of("response", (col_u("response")[1] == "correct").to_numpy())
        rc = col_u("rated_correct")
        bad(np.where(resp_c, rows_of("rated_correct", (rc[1] != "1").to_numpy()),
                     rows_of("rated_correct", (rc[1] != "0").to_numpy())),
            "rated_correct", "inconsistent with the response column")
    if "condition" in df.columns:
        codes = [col_u(c)[0] for c in ("perturbation", "direction", "condition")]
        lc, lu = pd.factorize(lv)
        # one int64 key per row (mixed radix of the four codes): a 1-D factorize instead of np.unique(axis=0)
        radix = [int(c.max()) + 1 if len(c) else 1 for c in (codes[1], lc, codes[2])]
        flat = ((codes[0].astype(np.int64) * radix[0] + codes[1]) * radix[1] + lc) * radix[2] + codes[2]
        kc, kflat = pd.factorize(flat)
        kflat = np.asarray(kflat, np.int64)
        ku = np.stack([kflat // (radix[0] * radix[1] * radix[2]), kflat // (radix[1] * radix[2]) % radix[0],
                       kflat // radix[2] % radix[1], kflat % radix[2]], axis=1)
        pu, du, cu = (col_u(c)[1].to_numpy() for c in ("perturbation", "direction", "condition"))
        ok_u = np.array([cu[c] == "" or cu[c] == condition_label(pu[p], du[d_], lu[x]) for p, d_, x, c in ku], bool)
        bad(~ok_u[kc.ravel()], "condition", "inconsistent with perturbation/direction/nominal_level")
    for col in ("shown_utc", "responded_utc"):
        if col in df.columns:
            t = col_u(col)[1].str.strip()
            parsed = pd.to_datetime(t.where(t != "", None), utc=True, errors="coerce", format="ISO8601")
            bad_u(col, ((t != "").to_numpy() & parsed.isna().to_numpy()), "not a UTC ISO 8601 time")
    for col in require:
        if col not in ("nominal_level", "achieved_error"):
            number(col, empty_ok=False, nonneg=False)
        elif col == "achieved_error":
            bad(is_test & np.isnan(df[col].to_numpy(float)), col,
                "empty (needed as the level regressor: --level achieved_error)")


def _read_one(path: Path, dropped: list | None = None, require: tuple[str, ...] = ()):
    """Parse one responses file: (header, rows, physical line of each row), or None when header-only.

    Structural checks only (bytes, UTF-8, header, field counts); the values are checked
    once for all files together (:func:`_check_values`), so reading 10,000 files costs
    one csv parse each and no per-file DataFrame work.
    """
    import csv
    import io

    raw = path.read_bytes()
    if not raw:
        raise StudyDataError("empty CSV (no header, no rows)", path)
    if not raw.endswith(b"\n"):
        # a torn last line: a session crashed in the middle of writing a row and was never
        # resumed (Session.open would repair it). That answer was never acknowledged to the
        # participant, so it is left out (not counted), with a warning naming the line.
        cut = raw.rfind(b"\n") + 1
        line = raw[:cut].count(b"\n") + 1
        if cut == 0:
            raise StudyDataError("torn header (the file has no complete line)", path, line=1)
        frag = raw[cut:][:80].decode(errors="replace")
        msg = (f"{path}:{line}: torn last line (no line end: a write interrupted by a crash, session never "
               f"resumed) left out of the analysis: {frag!r}")
        warnings.warn(msg, stacklevel=3)
        if dropped is not None:
            dropped.append((str(path), line, "torn last line (incomplete row) left out"))
        raw = raw[:cut]
    text = _decode_utf8(raw, path)
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader)
    except StopIteration:
        raise StudyDataError("empty CSV (no header, no rows)", path) from None
    except csv.Error as e:
        raise StudyDataError(f"not a valid CSV: {e}", path, line=1) from None
    if not header or all(not h.strip() for h in header):
        raise StudyDataError("empty CSV (no header, no rows)", path)
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise StudyDataError(f"missing column(s) {', '.join(missing)} (required: {', '.join(REQUIRED_COLUMNS)})",
                             path, line=1)
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise StudyDataError(f"column(s) {', '.join(dup)} appear more than once in the header", path, line=1)
    for col in require:
        if col not in header:
            raise StudyDataError(f"no column {col!r} (needed as the level regressor: --level {col}); this file has "
                                 f"{', '.join(header)}; use --level nominal_level, or add the column", path,
                                 line=1, column=col)
    width = len(header)
    try:
        rows = list(reader)
    except csv.Error as e:
        raise StudyDataError(f"not a valid CSV: {e}", path, line=reader.line_num) from None
    if text.count("\n") == len(rows) + 1 and all(len(r) == width for r in rows):
        lines = range(2, len(rows) + 2)  # one physical line per record (the common case)
    else:  # blank lines, quoted line breaks or bad field counts: walk the records with their line numbers
        reader = csv.reader(io.StringIO(text, newline=""))
        next(reader)
        rows, lines = [], []
        for r in reader:
            if not r:  # a blank line
                continue
            if len(r) != width:
                raise StudyDataError(f"{len(r)} fields, the header has {width} (a comma too many or too few, or an "
                                     "unquoted comma in a value)", path, line=reader.line_num)
            rows.append(r)
            lines.append(reader.line_num)
    if not rows:
        return None
    return header, rows, lines


def load_responses(path: str | Path, *, allow_mixed_sets: bool = False, require: tuple[str, ...] = ()) -> ResponseData:
    """Read and check every ``responses.csv`` under ``path`` (or the one file ``path``).

    Raises :class:`~mocomp.errors.StudyDataError` naming the file, line and
    column for: no responses at all, zero-byte files, missing columns, bad
    values (:class:`ResponseValueError`, ``FILE:LINE: column COL: value 'X' is ...``),
    duplicate trials (a participant/session/trial answered twice, in
    one file or across files, e.g. a session folder copied twice) and sessions
    that used different stimulus sets (unless ``allow_mixed_sets``).
    ``require``: further columns every file must have, with a number in every
    test row (e.g. ``("achieved_error",)`` when it is the level regressor).
    A file holding rows of several participants is analysed participant by
    participant, with a warning naming the file and the ids (``mixed_files``).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"responses folder not found: {path}")
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*.csv")
                                                  if p.name == "responses.csv" or p.name.endswith(".responses.csv"))
    if not files:
        raise StudyDataError("no responses.csv found (expected DATA/<participant>/<session>/responses.csv)", path)
    files, withdrawn = _split_withdrawn(files)
    if not files:
        raise StudyDataError(f"every session here ({len(withdrawn)}) is withdrawn ({WITHDRAWN_FILE}): nothing to "
                             "analyse", path)
    skipped, dropped, mixed = [], [], []
    # per header: column chunks of each file, file names, row counts, line numbers. Each file's rows
    # are turned into columns at once and every cell is interned (one str object per distinct value
    # and column, like pandas' parser): a study has few distinct values per column, so the table costs
    # a pointer per cell instead of a str object (10,000 x 88 rows: 1.3 GB -> ~0.2 GB), and the
    # hashing/factorizing of the columns below compares pointers first.
    by_header: dict[tuple, dict] = {}
    for f in files:
        got = _read_one(f, dropped, tuple(require))
        if got is None:
            skipped.append((str(f), "header only: no responses"))
            continue
        header, rows, lines = got
        acc = by_header.get(tuple(header))
        if acc is None:
            acc = by_header[tuple(header)] = dict(cols=[[] for _ in header], seen=[{} for _ in header],
                                                  files=[], counts=[], lines=[])
        for j, col in enumerate(zip(*rows)):
            seen = acc["seen"][j]
            if seen is not None and len(seen) > _INTERN_MAX:
                seen = acc["seen"][j] = None  # a column of (nearly) unique values: interning saves nothing
            acc["cols"][j].append(col if seen is None else list(map(seen.setdefault, col, col)))
        acc["files"].append(str(f))
        acc["counts"].append(len(rows))
        acc["lines"].append(np.asarray(lines, np.int64))
        del rows, got
    frames = []
    for header, acc in by_header.items():
        total = sum(acc["counts"])
        data_cols = {}
        for name, chunks in zip(header, acc["cols"]):
            arr = np.empty(total, object)
            arr[:] = [v for ch in chunks for v in ch]
            data_cols[name] = arr
            chunks.clear()
        df = pd.DataFrame(data_cols, columns=list(header), dtype=object, copy=False)
        df["source_file"] = np.repeat(np.array(acc["files"], object), acc["counts"])
        df["source_line"] = np.concatenate(acc["lines"])
        frames.append(df)
    del by_header
    if frames:
        allr = pd.concat(frames, ignore_index=True) if len(frames) > 1 else frames[0]
        if len(frames) > 1:  # back to file order (files with other column orders were grouped apart)
            order = {str(f): i for i, f in enumerate(files)}
            allr = allr.iloc[np.lexsort((allr["source_line"].to_numpy(), allr["source_file"].map(order).to_numpy()))]
            allr = allr.reset_index(drop=True)
            for c in allr.columns:  # a column some files lack is empty there
                if c not in ("source_file", "source_line") and allr[c].isna().any():
                    allr[c] = allr[c].fillna("")
        _check_values(allr, tuple(require))
        if "expected_response" not in allr.columns:
            allr["expected_response"] = ""
        # decided: a file holding several participants (e.g. a merged export, or sessions appended to
        # one file) is analysed participant by participant, with a warning naming the file and the ids
        n_ids = allr.groupby("source_file", sort=False)["participant_id"].nunique()
        for f in n_ids.index[n_ids > 1]:
            ids = list(pd.unique(allr.loc[allr["source_file"] == f, "participant_id"]))
            shown = ", ".join(map(repr, ids[:10])) + (f", ... ({len(ids)} in all)" if len(ids) > 10 else "")
            warnings.warn(f"{f}: rows of {len(ids)} participants in one file ({shown}); each participant's "
                          "rows are analysed as that participant's own", stacklevel=2)
            mixed.append((str(f), [str(i) for i in ids]))
    if not frames:
        raise StudyDataError(f"all {len(files)} responses CSV(s) are empty (header only)", path)
    key = ["participant_id", "session_id", "trial_index"]
    dup = allr.duplicated(key, keep=False)
    if dup.any():
        d = allr[dup].sort_values(key + ["source_file", "source_line"])
        a, b = d.iloc[0], d.iloc[1]
        raise StudyDataError(
            f"duplicate trial: participant {a['participant_id']!r} session {a['session_id']!r} trial "
            f"{a['trial_index']} also at {b['source_file']}:{b['source_line']}", a["source_file"],
            int(a["source_line"]), "trial_index")
    sets = sorted(allr["stimulus_set_id"].unique())
    if len(sets) > 1 and not allow_mixed_sets:
        by = allr.groupby("stimulus_set_id")["source_file"].unique()
        desc = "; ".join(f"{s}: {len(v)} file(s), e.g. {v[0]}" for s, v in by.items())
        raise StudyDataError(f"responses come from {len(sets)} different stimulus sets ({desc}); analyse them "
                             "separately, or pass --allow-mixed-sets (allow_mixed_sets=True)", path, column="stimulus_set_id")
    allr["incorrect"] = (allr["response"] == "incorrect").astype(int)
    # one label per distinct (perturbation, direction, level), mapped back (not one call per row)
    gb = allr.groupby(["perturbation", "direction", "nominal_level"], sort=False)
    labels = np.array([condition_label(p, d, lv) for p, d, lv in gb.size().index], object)
    allr["condition"] = labels[gb.ngroup().to_numpy()]
    return ResponseData(trials=allr, files=files, skipped=skipped, stimulus_set_ids=sets, dropped_lines=dropped,
                        mixed_files=mixed, sessions=session_summary(allr), withdrawn=withdrawn)


def _split_withdrawn(files: list[Path]) -> tuple[list[Path], list[dict]]:
    """(files to read, withdrawn sessions): a session folder's ``responses.csv`` with a
    ``withdrawn.json`` beside it is left out unread (one ``stat`` per file)."""
    keep, out = [], []
    for f in files:
        rec = withdrawal_record(f.parent) if f.name == "responses.csv" else None
        if rec is None:
            keep.append(f)
            continue
        out.append(dict(participant_id=str(rec.get("participant_id", f.parent.parent.name)),
                        session_id=str(rec.get("session_id", f.parent.name)), file=str(f),
                        withdrawn_utc=str(rec.get("withdrawn_utc", "?")), by=str(rec.get("by", "?")),
                        reason=str(rec.get("reason", rec.get("unreadable", "")))))
    return keep, out


def _planned_trials(folder: Path) -> int | None:
    """Response trials planned for the session in ``folder`` (non-example rows of its plan.csv), or None."""
    plan = folder / "plan.csv"
    if not plan.is_file():
        return None
    try:
        kinds = pd.read_csv(plan, usecols=["kind"], dtype=str, keep_default_na=False)["kind"]
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError):
        return None  # an unreadable plan says nothing about the responses; the count is inferred instead
    return int((kinds != "example").sum())


def session_summary(trials: pd.DataFrame) -> pd.DataFrame:
    """Per session (participant, session, file): trials answered and planned, and whether it is complete.

    ``n_planned`` comes from the session's ``plan.csv`` (non-example rows) when it lies beside
    ``responses.csv`` (``planned_from="plan.csv"``), otherwise from the longest session of the same
    stimulus set (``"longest session"``). A session with fewer answers than planned (a participant who
    stopped early) is ``complete=False``; it is analysed like the others and listed in the report.
    """
    g = (trials.groupby(["participant_id", "session_id", "source_file", "stimulus_set_id"], sort=True)
         .size().rename("n_answered").reset_index())
    plans = {f: _planned_trials(Path(f).parent) for f in g["source_file"].unique()}
    g["n_planned"] = g["source_file"].map(plans)
    g["planned_from"] = np.where(g["n_planned"].isna(), "longest session", "plan.csv")
    longest = g.groupby("stimulus_set_id")["n_answered"].transform("max")
    g["n_planned"] = g["n_planned"].fillna(longest).astype(int)
    g["complete"] = g["n_answered"] >= g["n_planned"]
    return g[["participant_id", "session_id", "n_answered", "n_planned", "planned_from", "complete", "source_file"]]


# --------------------------------------------------------------------- tables
def _controls_for(test: pd.DataFrame, group: str, control: str) -> tuple[pd.DataFrame, str]:
    ctl = test[test["perturbation"] == "none"]
    if control == "group":
        g = ctl[ctl["group"] == group]
        if len(g):
            return g, "group"
    elif control != "pooled":
        raise ValueError(f"control must be 'group' or 'pooled', got {control!r}")
    if not len(ctl):
        raise StudyDataError("no test trials of unperturbed motions: d' needs them as the false-alarm baseline")
    return ctl, "pooled"


def _cells(test: pd.DataFrame, level: str) -> pd.DataFrame:
    """One row per (group, perturbation, direction, level) incl. each group's controls."""
    pert = test[test["perturbation"] != "none"]
    cells = (pert.groupby(["group", "perturbation", "direction", level], sort=True).size()
             .rename("n").reset_index().rename(columns={level: "level"}))
    return cells


def _participant_codes(test: pd.DataFrame) -> tuple[list[str], np.ndarray]:
    codes, uniq = pd.factorize(test["participant_id"], sort=True)
    return [str(u) for u in uniq], codes


def _count_matrix(sub: pd.DataFrame, codes: np.ndarray, keys: list[str], P: int):
    """Per-participant counts of ``sub`` in one grouped pass.

    Returns (cells, K, N): ``cells`` a DataFrame of the distinct ``keys`` (sorted),
    ``K``/``N`` (len(cells), P) arrays of "incorrect" answers / trials per cell and participant.
    """
    if keys:
        gb = sub.groupby(keys, sort=True)
        cell = gb.ngroup().to_numpy()
        cells = gb.size().index.to_frame(index=False)
    else:
        cell, cells = np.zeros(len(sub), np.int64), pd.DataFrame(index=[0])
    R = len(cells)
    flat = cell * P + codes
    K = np.bincount(flat, weights=sub["incorrect"].to_numpy(float), minlength=R * P).reshape(R, P)
    N = np.bincount(flat, minlength=R * P).astype(float).reshape(R, P)
    return cells, K, N


HEADLINES = ("mean", "pooled")


def participant_dprime_matrix(K: np.ndarray, N: np.ndarray, cr: np.ndarray, correction: str
                              ) -> tuple[np.ndarray, np.ndarray]:
    """Each participant's own d' of every row: ``(D, has)``, both (R, P).

    ``D[r, p]`` = z(H) - z(F) from participant p's "incorrect" answers and trials in row r
    (``K``, ``N``) and in its control row ``cr[r]``, corrected as ``correction``
    (:func:`study.sdt.dprime_counts`); ``has[r, p]``: p saw row r and its controls (else
    ``D`` is 0 there and p does not count for that row).
    """
    Kf, Nf = K[cr], N[cr]
    has = (N > 0) & (Nf > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        D = dprime_counts(np.where(has, K, 0.0), np.where(has, N, 1.0), np.where(has, Kf, 0.0),
                          np.where(has, Nf, 1.0), correction).dprime
    return np.where(has, D, 0.0), has


def mean_participant_dprime(K: np.ndarray, N: np.ndarray, cr: np.ndarray, correction: str
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean and SD over participants of their own d' (Macmillan & Creelman 2005, on group data), how
    many participants each row averages, and the mean of their ceilings (the largest the mean
    could be with their trial counts): ``(mean, sd, n, ceiling)`` per row (NaN where n == 0; an
    infinite individual d', possible only with ``correction="none"``, makes the mean infinite or NaN)."""
    D, has = participant_dprime_matrix(K, N, cr, correction)
    n = has.sum(1)
    ceil = dprime_ceiling(np.where(has, N, 1.0), np.where(has, N[cr], 1.0), correction)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, np.where(has, D, 0.0).sum(1) / np.maximum(n, 1), np.nan)
        dev = np.where(has, D - mean[:, None], 0.0)
        sd = np.where(n > 1, np.sqrt((dev ** 2).sum(1) / np.maximum(n - 1, 1)), np.nan)
        mceil = np.where(n > 0, np.where(has, ceil, 0.0).sum(1) / np.maximum(n, 1), np.nan)
    return mean, sd, n, mceil


def cluster_bootstrap_dprime(K: np.ndarray, N: np.ndarray, cr: np.ndarray, *, correction: str, n_boot: int,
                             seed: int, ci: float = 0.95, chunk: int = 256) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Participant (cluster) bootstrap of the pooled d' of every row.

    ``K``/``N`` (R, P): "incorrect" answers and trials of each row (condition or control)
    per participant; ``cr`` (R,): the control row of each row. Each resample draws P
    participants with replacement (multinomial weights ``W``, (B, P)) and pools *their own*
    counts and trials together, ``W @ K.T`` and ``W @ N.T``, so hits <= trials holds in every
    resample whatever the participants did (incomplete sessions, conditions some never
    saw). A resample in which no drawn participant saw a row (or its controls) leaves that
    row undefined in that resample; quantiles are over the defined ones. Vectorised over
    resamples in chunks of ``chunk`` (memory O(chunk x P)). Returns (ci_low, ci_high,
    n_defined) per row.
    """
    return _cluster_bootstrap(K, N, cr, correction=correction, n_boot=n_boot, seed=seed, ci=ci, chunk=chunk)[0]


def _quantiles(db: np.ndarray, ci: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = (1 - ci) / 2
    n_def = np.isfinite(db).sum(0) + np.isinf(db).sum(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        lo = np.nanquantile(db, a, axis=0)
        hi = np.nanquantile(db, 1 - a, axis=0)
    return lo, hi, n_def


def _cluster_bootstrap(K: np.ndarray, N: np.ndarray, cr: np.ndarray, *, correction: str, n_boot: int, seed: int,
                       ci: float = 0.95, chunk: int = 256, with_mean: bool = False):
    """The participant bootstrap of :func:`cluster_bootstrap_dprime` and, with ``with_mean``, of
    the mean of the per-participant d' (:func:`mean_participant_dprime`) on *the same*
    resamples: a resample's mean is ``sum_p W_p has_p D_p / sum_p W_p has_p`` (a participant
    drawn twice counts twice). Returns ``((lo, hi, n_def) pooled, (lo, hi, n_def) mean or None)``;
    a row whose individual d' are not all finite (``correction="none"``) has no mean CI (NaN).
    """
    R, P = K.shape
    rng = np.random.default_rng(seed)
    db = np.empty((n_boot, R))
    if with_mean:
        D, has = participant_dprime_matrix(K, N, cr, correction)
        fin = np.isfinite(D)
        Dm, Hm = np.where(has & fin, D, 0.0), has.astype(float)
        mean_ok = (fin | ~has).all(1)
        mb = np.empty((n_boot, R))
    for b0 in range(0, n_boot, chunk):
        b = min(chunk, n_boot - b0)
        W = rng.multinomial(P, np.full(P, 1.0 / P), size=b).astype(float)  # (b, P)
        Kb, Nb = W @ K.T, W @ N.T  # (b, R): counts and trials resampled together
        valid = (Nb > 0) & (Nb[:, cr] > 0)
        kh, nh = np.where(valid, Kb, 0.0), np.where(valid, Nb, 1.0)
        kf, nf = np.where(valid, Kb[:, cr], 0.0), np.where(valid, Nb[:, cr], 1.0)
        with np.errstate(divide="ignore"):
            d = dprime_counts(kh, nh, kf, nf, correction).dprime
        db[b0:b0 + b] = np.where(valid, d, np.nan)
        if with_mean:
            den = W @ Hm.T
            with np.errstate(invalid="ignore", divide="ignore"):
                mb[b0:b0 + b] = np.where((den > 0) & mean_ok, (W @ Dm.T) / den, np.nan)
    return _quantiles(db, ci), (_quantiles(mb, ci) if with_mean else None)


#: Columns of :func:`condition_table` (``conditions.csv``), in order.
CONDITION_COLUMNS = [
    "group", "perturbation", "direction", "level", "condition", "n_trials", "n_participants", "n_rated_correct",
    "n_incorrect", "pct_rated_correct", "pct_ci_low", "pct_ci_high", "hit_rate", "fa_rate", "n_control",
    "control_source", "dprime", "dprime_uncorrected", "correction", "ceiling", "at_ceiling", "dprime_ci_low",
    "dprime_ci_high", "n_boot", "n_boot_defined", "dprime_mean", "dprime_mean_ci_low", "dprime_mean_ci_high",
    "dprime_mean_sd", "n_participants_dprime", "dprime_mean_ceiling", "headline", "dprime_headline", "dprime_headline_ci_low",
    "dprime_headline_ci_high"]


def condition_table(data: ResponseData | pd.DataFrame, *, level: str = "nominal_level", control: str = "group",
                    correction: str = "loglinear", n_boot: int = 2000, seed: int = 0,
                    ci: float = 0.95, headline: str = "pooled") -> pd.DataFrame:
    """Mean % rated correct and d' per condition (tidy; one row per condition and per group's control).

    Columns: group, perturbation, direction, level, condition, n_trials,
    n_participants, n_rated_correct, pct_rated_correct, pct_ci_low/high
    (Wilson), hit_rate (P incorrect), fa_rate, n_control, control_source,
    dprime (corrected), dprime_uncorrected (the paper's z(r0) - z(r) from the
    pooled rates; +-inf at 0 or 1), correction, ceiling, at_ceiling,
    dprime_ci_low/high (participant bootstrap, percentile,
    :func:`cluster_bootstrap_dprime`), n_boot, n_boot_defined (resamples in which
    the row was defined: fewer than n_boot when few participants saw it);
    dprime_mean (the mean over participants of each one's own d', Macmillan &
    Creelman 2005; each participant's d' from their own hits in the
    row and false alarms in its control row, same correction),
    dprime_mean_ci_low/high (the same participant resamples as the pooled CI,
    :func:`_cluster_bootstrap`), dprime_mean_sd (SD across participants),
    n_participants_dprime (participants with trials in the row and its controls),
    dprime_mean_ceiling (mean of those participants' ceilings: the largest mean
    their trial counts allow under the correction);
    headline (``"mean"`` or ``"pooled"``: which of the two the report leads with)
    and dprime_headline/_ci_low/_ci_high (that one's values).

    The two answer different questions. The pooled d' is the sensitivity of the
    "average observer" built from pooled rates (the paper's Table 2); pooling
    observers with different criteria biases it towards 0. The mean of individual
    d' is the average sensitivity; with few trials per participant and cell, the
    correction for rates of 0 and 1 (and the ceiling it implies) pulls each
    individual d' towards 0, so the mean can lie below the pooled d' too.

    Cost is linear in the number of trials and participants: one grouped pass
    builds a (rows x participants) count matrix; the bootstrap is matrix products.
    """
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {CORRECTIONS}")
    if control not in ("group", "pooled"):
        raise ValueError(f"control must be 'group' or 'pooled', got {control!r}")
    if headline not in HEADLINES:
        raise ValueError(f"headline must be one of {HEADLINES}, got {headline!r}")
    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    if not len(test):
        raise StudyDataError("no test trials to analyse")
    parts, codes = _participant_codes(test)
    P = len(parts)
    is_none = (test["perturbation"] == "none").to_numpy()
    ctl, ctl_codes = test[is_none], codes[is_none]
    pert, pert_codes = test[~is_none], codes[~is_none]
    cg, Kg, Ng = _count_matrix(ctl, ctl_codes, ["group"], P) if len(ctl) else (pd.DataFrame(columns=["group"]),
                                                                                np.zeros((0, P)), np.zeros((0, P)))
    own = {g: i for i, g in enumerate(cg["group"])} if len(ctl) else {}
    _, Kp, Np = _count_matrix(ctl, ctl_codes, [], P) if len(ctl) else (None, None, None)
    cells, Kc, Nc = _count_matrix(pert, pert_codes, ["group", "perturbation", "direction", level], P)
    rows, K, N = [], [], []
    ctl_rows: dict[str, int] = {}
    for g in sorted(cells["group"].unique()):
        if control == "group" and g in own:
            key, src, kk, nn = g, "group", Kg[own[g]], Ng[own[g]]
        else:
            if Kp is None:
                raise StudyDataError("no test trials of unperturbed motions: d' needs them as the false-alarm baseline")
            key, src, kk, nn = "(pooled)", "pooled", Kp[0], Np[0]
        if key not in ctl_rows:
            ctl_rows[key] = len(rows)
            rows.append(dict(group=g if src == "group" else "(all)", perturbation="none", direction="none",
                             level=0.0, condition="none", control_row=len(rows), control_source=src))
            K.append(kk)
            N.append(nn)
        for i in np.flatnonzero((cells["group"] == g).to_numpy()):
            c = cells.iloc[i]
            rows.append(dict(group=g, perturbation=c["perturbation"], direction=c["direction"],
                             level=float(c[level]), condition=condition_label(c["perturbation"], c["direction"], c[level]),
                             control_row=ctl_rows[key], control_source=src))
            K.append(Kc[i])
            N.append(Nc[i])
    tab = pd.DataFrame(rows)
    K = np.array(K)
    N = np.array(N)
    k_tot, n_tot = K.sum(1), N.sum(1)
    tab["n_trials"] = n_tot.astype(int)
    tab["n_participants"] = (N > 0).sum(1)
    tab["n_incorrect"] = k_tot.astype(int)
    tab["n_rated_correct"] = (n_tot - k_tot).astype(int)
    tab["pct_rated_correct"] = 100 * (n_tot - k_tot) / n_tot
    lo, hi = wilson_interval(n_tot - k_tot, n_tot, ci)
    tab["pct_ci_low"], tab["pct_ci_high"] = 100 * lo, 100 * hi
    tab["hit_rate"] = k_tot / n_tot
    cr = tab["control_row"].to_numpy(int)
    tab["fa_rate"] = tab["hit_rate"].to_numpy()[cr]
    tab["n_control"] = n_tot[cr].astype(int)
    dp = dprime_counts(k_tot, n_tot, k_tot[cr], n_tot[cr], correction)
    with np.errstate(divide="ignore"):
        raw = norm.ppf(k_tot / n_tot) - norm.ppf(k_tot[cr] / n_tot[cr])
    is_ctl = tab["perturbation"].to_numpy() == "none"
    tab["dprime"] = np.where(is_ctl, 0.0, dp.dprime)
    tab["dprime_uncorrected"] = np.where(is_ctl, 0.0, raw)
    tab["correction"] = correction
    tab["ceiling"] = dp.ceiling
    tab["at_ceiling"] = np.where(is_ctl, False, dp.at_ceiling)
    (blo, bhi, n_def), (mlo, mhi, _) = _cluster_bootstrap(K, N, cr, correction=correction, n_boot=n_boot,
                                                          seed=seed, ci=ci, with_mean=True)
    tab["dprime_ci_low"] = np.where(is_ctl, np.nan, blo)
    tab["dprime_ci_high"] = np.where(is_ctl, np.nan, bhi)
    tab["n_boot"] = n_boot
    tab["n_boot_defined"] = n_def
    mean, sd, n_p, mceil = mean_participant_dprime(K, N, cr, correction)
    tab["dprime_mean"] = np.where(is_ctl, 0.0, mean)
    tab["dprime_mean_ci_low"] = np.where(is_ctl, np.nan, mlo)
    tab["dprime_mean_ci_high"] = np.where(is_ctl, np.nan, mhi)
    tab["dprime_mean_sd"] = np.where(is_ctl, np.nan, sd)
    tab["n_participants_dprime"] = n_p
    tab["dprime_mean_ceiling"] = mceil
    tab["headline"] = headline
    src = "dprime_mean" if headline == "mean" else "dprime"
    tab["dprime_headline"] = tab[src]
    tab["dprime_headline_ci_low"] = tab[src + "_ci_low"]
    tab["dprime_headline_ci_high"] = tab[src + "_ci_high"]
    return tab.drop(columns=["control_row"])[CONDITION_COLUMNS]


def participant_dprimes(data: ResponseData | pd.DataFrame, *, by: str = "condition", level: str = "nominal_level",
                        control: str = "group", correction: str = "loglinear", n_boot: int = 2000, seed: int = 0,
                        ci: float = 0.95) -> pd.DataFrame:
    """Per-participant d' with percentile bootstrap CIs.

    ``by="condition"``: one d' per participant and condition;
    ``by="series"``: per participant and error type (perturbation x direction),
    pooling the levels (more trials per cell, so tighter CIs).

    The interval is a parametric bootstrap of the *corrected* rates: the hits
    and false alarms are redrawn as binomial counts at the rates d' was
    computed from (log-linear ``(k + 0.5) / (n + 1)``, or ``1/(2N)`` at 0 and
    1), each draw corrected the same way, and the 2.5/97.5 % quantiles taken
    (seeded by ``seed``). Resampling the trials themselves (a draw at the
    *observed* rate) would give a zero-width interval whenever a participant
    answered all perturbed trials "incorrect" or no control "incorrect", which
    is common with a handful of trials per cell, and it under-covers (about 87 %
    for 6 signal and 12 control trials in our simulations, against 92-96 % for
    the corrected-rate bootstrap). With ``correction="none"`` a rate of 0 or 1
    makes d' infinite: its interval is undefined (NaN) and ``ci_note`` says so.
    ``ci_degenerate`` flags intervals of zero width (none with a correction).

    The interval is a function of the four counts (hits, signal trials, false
    alarms, control trials) only, so it is drawn once per distinct tuple of counts
    (a few hundred in a study, however many participants) and shared by every
    cell with those counts: the cost is linear in the participants, and cells with
    equal counts get equal intervals (no Monte-Carlo scatter between them).
    A participant without a single control trial in the baseline gets no row.
    """
    if by not in ("condition", "series"):
        raise ValueError("by must be 'condition' or 'series'")
    if control not in ("group", "pooled"):
        raise ValueError(f"control must be 'group' or 'pooled', got {control!r}")
    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    cols = ["participant_id", "group", "perturbation", "direction", "level", "n_signal", "hits", "n_control",
            "false_alarms", "control_source", "hit_rate", "fa_rate", "dprime", "ceiling", "correction", "ci_low",
            "ci_high", "ci_degenerate", "ci_note", "n_boot", "condition"]
    is_none = test["perturbation"] == "none"
    keys = ["participant_id", "group"] + SERIES + ([level] if by == "condition" else [])
    cells = test[~is_none].groupby(keys, sort=True)["incorrect"].agg(["sum", "size"]).reset_index()
    if not len(cells):
        return pd.DataFrame(columns=cols)
    ctl = test[is_none]
    own = ctl.groupby(["participant_id", "group"])["incorrect"].agg(["sum", "size"])
    pooled = ctl.groupby("participant_id")["incorrect"].agg(["sum", "size"])
    pid = cells["participant_id"]
    pk = pooled["sum"].reindex(pid).to_numpy(float)
    pn = pooled["size"].reindex(pid).to_numpy(float)
    if control == "group":
        idx = pd.MultiIndex.from_arrays([pid, cells["group"]])
        ok = own["sum"].reindex(idx).to_numpy(float)
        on = own["size"].reindex(idx).to_numpy(float)
        has = ~np.isnan(on)
        kf, nf = np.where(has, ok, pk), np.where(has, on, pn)
        src = np.where(has, "group", "pooled")
    else:
        kf, nf, src = pk, pn, np.full(len(cells), "pooled")
    keep = ~np.isnan(nf)  # participants with no control trial at all have no d'
    cells = cells[keep].reset_index(drop=True)
    kf, nf, src = kf[keep].astype(int), nf[keep].astype(int), src[keep]
    k, n = cells["sum"].to_numpy(int), cells["size"].to_numpy(int)
    d = dprime_counts(k, n, kf, nf, correction)
    # one parametric bootstrap per distinct (k, n, kf, nf)
    tup = np.stack([k, n, kf, nf], axis=1)
    uniq, inv = np.unique(tup, axis=0, return_inverse=True)
    inv = inv.ravel()
    du = dprime_counts(uniq[:, 0], uniq[:, 1], uniq[:, 2], uniq[:, 3], correction)
    rng = np.random.default_rng(seed)
    kb = rng.binomial(uniq[:, 1:2], np.asarray(du.hit_used)[:, None], size=(len(uniq), n_boot))
    fb = rng.binomial(uniq[:, 3:4], np.asarray(du.fa_used)[:, None], size=(len(uniq), n_boot))
    with np.errstate(divide="ignore", invalid="ignore"):  # no correction: draws of 0 or n give +-inf
        db = dprime_counts(kb, uniq[:, 1:2], fb, uniq[:, 3:4], correction).dprime
    a = (1 - ci) / 2
    # order statistics (no interpolation): draws can be +-inf without a correction
    qlo, qhi = np.quantile(db, [a, 1 - a], axis=1, method="inverted_cdf")
    lo, hi = qlo[inv], qhi[inv]
    note = np.full(len(cells), "", object)
    if correction == "none":
        und = (k == 0) | (k == n) | (kf == 0) | (kf == nf)
        lo, hi = np.where(und, np.nan, lo), np.where(und, np.nan, hi)
        note[und] = "undefined: a rate of 0 or 1 without a correction (d' is infinite)"
    with np.errstate(invalid="ignore"):
        degenerate = ~(hi - lo >= 1e-12)
    out = pd.DataFrame(dict(
        participant_id=cells["participant_id"], group=cells["group"], perturbation=cells["perturbation"],
        direction=cells["direction"], level=cells[level].astype(float) if by == "condition" else np.nan,
        n_signal=n, hits=k, n_control=nf, false_alarms=kf, control_source=src, hit_rate=k / n, fa_rate=kf / nf,
        dprime=np.asarray(d.dprime, float), ceiling=np.asarray(d.ceiling, float), correction=correction,
        ci_low=lo, ci_high=hi, ci_degenerate=degenerate, ci_note=note, n_boot=n_boot))
    if by == "condition":
        # one label per distinct (perturbation, direction, level), mapped back by group number
        gb = out.groupby(["perturbation", "direction", "level"], sort=False)
        labels = np.array([condition_label(p, d_, lv) for p, d_, lv in gb.size().index], object)
        out["condition"] = labels[gb.ngroup().to_numpy()]
    else:
        out["condition"] = out["perturbation"] + "/" + out["direction"]
    return out[cols]


def attention_summary(data: ResponseData) -> pd.DataFrame:
    """Per participant: attention checks passed / shown (empty frame if none were planned)."""
    a = data.attention
    if not len(a):
        return pd.DataFrame(columns=["participant_id", "n_checks", "n_passed", "pass_rate"])
    a = a.assign(passed=(a["response"] == a["expected_response"]).astype(int))
    s = a.groupby("participant_id")["passed"].agg(["size", "sum"]).reset_index()
    s.columns = ["participant_id", "n_checks", "n_passed"]
    s["pass_rate"] = s["n_passed"] / s["n_checks"]
    return s


# ------------------------------------------------------------------ models
def fit_psychometric_glms(data: ResponseData | pd.DataFrame, *, link: str = "probit", level: str = "nominal_level",
                          control: str = "group", ci: float = 0.95, se: str = "auto",
                          min_clusters: int = 8) -> pd.DataFrame:
    """Binomial GLM P("incorrect") = F(a + b x) per error type, x the error level (controls at 0).

    ``link``: ``"probit"`` (F = standard normal CDF; b is d' per unit level,
    a = z(false-alarm rate); threshold = 1/b is the level at d' = 1) or
    ``"logit"`` (b in log-odds per unit level; threshold = level where the
    odds of "incorrect" are e times those of the controls). Returned per
    series: intercept, slope, their SEs, CI of the slope, threshold with CI
    (from the slope's Wald CI; upper bound ``inf`` where that CI includes 0, both NaN
    when it lies below 0), the level
    where P = 0.5 (``pse``), deviance, df, and n.

    The GLM pools every participant's answers. ``se``: ``"cluster"`` gives
    cluster-robust (sandwich) standard errors with participants as clusters,
    honest when participants differ in criterion or sensitivity (the model
    SEs assume independent trials and are then too small); ``"model"`` the
    usual binomial SEs; ``"auto"`` (default) uses ``"cluster"`` with at least
    ``min_clusters`` participants (with fewer the sandwich is itself unreliable).
    The column ``se_type`` says which; the point estimates are the same.
    """
    import statsmodels.api as sm

    if link not in ("probit", "logit"):
        raise ValueError("link must be 'probit' or 'logit'")
    if se not in ("auto", "cluster", "model"):
        raise ValueError("se must be 'auto', 'cluster' or 'model'")
    if control not in ("group", "pooled"):
        raise ValueError(f"control must be 'group' or 'pooled', got {control!r}")
    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    if "participant_id" not in test.columns:
        test = test.assign(participant_id="(all)")
    n_parts = test["participant_id"].nunique()
    se_type = ("cluster" if n_parts >= min_clusters else "model") if se == "auto" else se
    if se_type == "cluster" and n_parts < 2:
        raise ValueError("cluster-robust SEs need at least 2 participants")
    zc = norm.ppf(0.5 + ci / 2)
    out = []
    # integer codes once for the whole table; each series then selects its rows and its group's
    # controls by integer comparisons and counts by bincount (no per-series copies of the table)
    pcodes, puniq = pd.factorize(test["participant_id"], sort=True)
    gcodes, guniq = pd.factorize(test["group"], sort=True)
    pcd, pun = pd.factorize(test["perturbation"], sort=True)
    dcd, dun = pd.factorize(test["direction"], sort=True)
    scodes, sflat = pd.factorize(pcd.astype(np.int64) * len(dun) + dcd, sort=True)  # sorted (perturbation, direction)
    suniq = [(pun[int(c) // len(dun)], dun[int(c) % len(dun)]) for c in sflat]
    xall = test[level].to_numpy(float)
    yall = test["incorrect"].to_numpy(float)
    none_rows = (test["perturbation"] == "none").to_numpy()
    P_all = len(puniq)
    for si, (p, dr) in enumerate(suniq):  # sorted by (perturbation, direction)
        if p == "none":
            continue
        if not none_rows.any():
            raise StudyDataError("no test trials of unperturbed motions: d' needs them as the false-alarm baseline")
        rows = np.flatnonzero(scodes == si)
        g_here = gcodes[rows[0]]
        ctl_rows = np.flatnonzero(none_rows & (gcodes == g_here)) if control == "group" else np.array([], int)
        if not len(ctl_rows):
            ctl_rows = np.flatnonzero(none_rows)
        x = np.r_[xall[rows], np.zeros(len(ctl_rows))]
        y = np.r_[yall[rows], yall[ctl_rows]]
        pc = np.r_[pcodes[rows], pcodes[ctl_rows]]
        xu, xi = np.unique(x, return_inverse=True)
        ksum = np.bincount(xi, weights=y, minlength=len(xu))
        ksize = np.bincount(xi, minlength=len(xu)).astype(float)
        endog = np.column_stack([ksum, ksize - ksum])
        X = sm.add_constant(xu)
        def fam():  # a fresh family per model (statsmodels' Binomial keeps the trial counts of its model)
            return sm.families.Binomial(link=sm.families.links.Probit() if link == "probit" else sm.families.links.Logit())

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = sm.GLM(endog, X, family=fam()).fit()
            cov = np.asarray(res.cov_params())
            if se_type == "cluster":  # same estimates from participant x level counts, sandwich by participant
                cu, cinv = np.unique(pc.astype(np.int64) * len(xu) + xi, return_inverse=True)  # sorted (participant, x)
                psum = np.bincount(cinv, weights=y, minlength=len(cu))
                psize = np.bincount(cinv, minlength=len(cu)).astype(float)
                rc = sm.GLM(np.column_stack([psum, psize - psum]),
                            sm.add_constant(xu[cu % len(xu)], has_constant="add"), family=fam()).fit(
                    start_params=res.params, cov_type="cluster",
                    cov_kwds={"groups": pd.factorize(cu // len(xu))[0]})
                cov = np.asarray(rc.cov_params())
        a, b = res.params
        sa, sb = np.sqrt(np.diag(cov))
        blo, bhi = b - zc * sb, b + zc * sb
        thr = 1.0 / b if b > 0 else np.nan
        if blo > 0:
            tlo, thi = 1.0 / bhi, 1.0 / blo
        elif bhi > 0:
            tlo, thi = 1.0 / bhi, np.inf
        else:
            tlo, thi = np.nan, np.nan
        out.append(dict(perturbation=p, direction=dr, group=guniq[g_here], link=link, level_column=level,
                        intercept=a, intercept_se=sa, slope=b, slope_se=sb, slope_ci_low=blo, slope_ci_high=bhi,
                        threshold=thr, threshold_ci_low=tlo, threshold_ci_high=thi,
                        pse=(-a / b if b != 0 else np.nan), deviance=res.deviance, df_resid=res.df_resid,
                        n_trials=int(ksize.sum()), n_levels=len(xu), converged=bool(res.converged),
                        cov_ab=float(cov[0, 1]), se_type=se_type,
                        n_participants=int(np.count_nonzero(np.bincount(pc, minlength=P_all)))))
    return pd.DataFrame(out)


def psychometric_curve(row: pd.Series | dict, x: np.ndarray, ci: float = 0.95) -> tuple[np.ndarray, ...]:
    """P("rated correct") along ``x`` for one :func:`fit_psychometric_glms` row, with a pointwise CI band."""
    x = np.asarray(x, float)
    eta = row["intercept"] + row["slope"] * x
    var = row["intercept_se"] ** 2 + x * x * row["slope_se"] ** 2 + 2 * x * row["cov_ab"]
    se = np.sqrt(np.maximum(var, 0))
    zc = norm.ppf(0.5 + ci / 2)
    F = norm.cdf if row["link"] == "probit" else (lambda e: 1 / (1 + np.exp(-e)))
    return 1 - F(eta), 1 - F(eta + zc * se), 1 - F(eta - zc * se)


class _Skipped(Exception):
    pass


def fit_mixed_model(data: ResponseData | pd.DataFrame, *, control: str = "group", n_nodes: int = 15,
                    cross_checks: bool = True, vb_max_participants: int = 200) -> pd.DataFrame:
    """Mixed-effects logistic model per error group, participant as a random effect.

    Model (per group g): logit P(incorrect) = b0 + b_c [condition c] + u_p,
    u_p ~ N(0, s^2) per participant; conditions coded as treatment contrasts
    against the group's unperturbed motions (so b_c is the log odds ratio of
    answering "incorrect", perturbed vs correct motion, for a typical
    participant). Fitted by maximum likelihood with adaptive Gauss-Hermite
    quadrature (:func:`study.glmm.fit_logit_glmm`; lme4's ``glmer`` with
    ``nAGQ=n_nodes``): ``estimate``, ``se``, ``z``, ``p``, ``ci_low/high``
    (Wald); the random-intercept row gives s with a CI from log s.

    Cross-checks (``cross_checks``): ``vb_mean``/``vb_sd`` from statsmodels'
    ``BinomialBayesMixedGLM.fit_vb`` (variational Bayes with its default priors,
    fixed effects N(0, 2^2): it shrinks large effects and its SDs are
    approximate), and ``gee_estimate``/``gee_se`` from a GEE (exchangeable
    within participant, robust SEs; statsmodels' ``GEE`` on the trial rows, computed
    from the (participant, condition) counts by :func:`study.glmm.fit_gee_exchangeable`,
    equal to it to rounding): population-averaged, hence smaller in
    magnitude than the conditional GLMM effects when s > 0. The variational-Bayes
    cross-check runs up to ``vb_max_participants`` participants only (statsmodels'
    ``fit_vb`` does not scale: 256 s without convergence at 1,000); ``cross_check_note``
    says when it was skipped. The GLMM and the GEE work on the (participant, condition)
    counts: linear in the participants, independent of the trials per cell.
    """
    from scipy.stats import norm as _norm

    from .glmm import fit_firth_logit, fit_gee_exchangeable, fit_logit_glmm, separated_columns

    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    # only the columns the models use (not a copy of every column per group)
    test = test[["participant_id", "group", "perturbation", "condition", "incorrect"]]
    out = []
    for g in sorted(test.loc[test["perturbation"] != "none", "group"].unique()):
        sub = test[(test["group"] == g) & (test["perturbation"] != "none")]
        ctl, src = _controls_for(test, g, control)
        d = pd.concat([sub, ctl], ignore_index=True)
        levels = ["none"] + sorted(set(d["condition"].unique()) - {"none"})
        d["cond"] = pd.Categorical(d["condition"], categories=levels)
        parts = sorted(d["participant_id"].unique())
        agg = d.groupby(["participant_id", "cond"], observed=True)["incorrect"].agg(["sum", "size"]).reset_index()
        X = np.zeros((len(agg), len(levels)))
        X[:, 0] = 1.0
        ci = agg["cond"].cat.codes.to_numpy()
        X[np.arange(len(agg)), ci] += np.where(ci > 0, 1.0, 0.0)
        gidx = agg["participant_id"].map({p: i for i, p in enumerate(parts)}).to_numpy()
        terms = ["Intercept"] + levels[1:]
        zc = _norm.ppf(0.975)
        sep = separated_columns(X, agg["sum"].to_numpy(), agg["size"].to_numpy())
        sep_note = ""
        method = (f"ML logistic GLMM, random intercept per participant, adaptive Gauss-Hermite "
                  f"(nAGQ={n_nodes})")
        if sep:
            # complete separation: the ML estimates of these terms are infinite (a huge number with a
            # NaN interval, "converged"). Fall back to Firth's penalised fit of the pooled counts.
            fr = fit_firth_logit(X, agg["sum"].to_numpy(), agg["size"].to_numpy(), names=terms)
            sep_note = ("separation: every answer in " + ", ".join(repr(levels[j]) for j in sep)
                        + " is the same, so the ML estimate is infinite; Firth bias-reduced logistic "
                        "regression (Jeffreys penalty, no random intercept) reported instead")
            warnings.warn(f"mixed model, group {g}: {sep_note}", stacklevel=2)
            est, se = fr.beta, fr.se
            sig, conv, llf = (np.nan, np.nan, np.nan), fr.converged, fr.pllf
            method = "Firth bias-reduced logistic regression (separation; participant effect not modelled)"
        elif len(parts) >= 2:
            r = fit_logit_glmm(X, agg["sum"].to_numpy(), agg["size"].to_numpy(), gidx, names=terms, n_nodes=n_nodes)
            est, se = r.beta, r.se
            if r.sigma < 1e-3 or not np.isfinite(r.log_sigma_se):  # at the boundary: no Wald CI on log s
                sig = (r.sigma, 0.0, np.nan)
            else:
                sig = (r.sigma, np.exp(np.log(r.sigma) - zc * r.log_sigma_se),
                       np.exp(np.log(r.sigma) + zc * r.log_sigma_se))
            conv, llf = r.converged, r.llf
        else:
            est = se = np.full(len(terms), np.nan)
            sig, conv, llf = (np.nan, np.nan, np.nan), False, np.nan
        rows_here = [dict(group=g, term=t, estimate=e, se=s_, z=e / s_, p=2 * _norm.sf(abs(e / s_)),
                          ci_low=e - zc * s_, ci_high=e + zc * s_) for t, e, s_ in zip(terms, est, se)]
        rows_here.append(dict(group=g, term="participant SD (random intercept)", estimate=sig[0], se=np.nan,
                              z=np.nan, p=np.nan, ci_low=sig[1], ci_high=sig[2]))
        for rr in rows_here:
            rr.update(vb_mean=np.nan, vb_sd=np.nan, gee_estimate=np.nan, gee_se=np.nan)
        vb_note = ""
        if cross_checks and len(parts) >= 2:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    from statsmodels.genmod.bayes_mixed_glm import BinomialBayesMixedGLM

                    if len(parts) > vb_max_participants:
                        raise _Skipped(f"not run: {len(parts)} participants > vb_max_participants="
                                       f"{vb_max_participants} (statsmodels' fit_vb grows faster than linearly: "
                                       "~256 s and no convergence at 1,000)")
                    import scipy.sparse as sp

                    # trial-level design built directly (no formula): fixed effects = treatment dummies,
                    # random effects = a *sparse* participant indicator (a dense one is trials x participants)
                    ccode = d["cond"].cat.codes.to_numpy()
                    Xt = np.zeros((len(d), len(levels)))
                    Xt[:, 0] = 1.0
                    Xt[np.arange(len(d)), ccode] += np.where(ccode > 0, 1.0, 0.0)
                    pcode = d["participant_id"].map({p: i for i, p in enumerate(parts)}).to_numpy()
                    yt = d["incorrect"].to_numpy(float)
                    Z = sp.csr_matrix((np.ones(len(d)), (np.arange(len(d)), pcode)), shape=(len(d), len(parts)))
                    m = BinomialBayesMixedGLM(yt, Xt, Z, np.zeros(len(parts), int), fep_names=terms,
                                              vcp_names=["participant"])
                    v = m.fit_vb()
                    vb = dict(zip(terms, zip(v.fe_mean, v.fe_sd)))
                    vb["participant SD (random intercept)"] = (float(np.exp(v.vcp_mean[0])), np.nan)
                except _Skipped as e:
                    vb, vb_note = {}, f"BinomialBayesMixedGLM {e}"
                except Exception as e:  # pragma: no cover - reported, not fatal
                    vb = {}
                    warnings.warn(f"BinomialBayesMixedGLM failed for group {g}: {e}")
                try:
                    # the GEE of the trial rows computed from the (participant, condition) counts:
                    # identical estimates and robust SEs (study.glmm.fit_gee_exchangeable), O(cells)
                    gee = fit_gee_exchangeable(X, agg["sum"].to_numpy(), agg["size"].to_numpy(), gidx, names=terms)
                    gp = dict(zip(terms, zip(gee.beta, gee.se)))
                except Exception as e:  # pragma: no cover
                    gp = {}
                    warnings.warn(f"GEE failed for group {g}: {e}")
            for rr in rows_here:
                if rr["term"] in vb:
                    rr["vb_mean"], rr["vb_sd"] = vb[rr["term"]]
                if rr["term"] in gp:
                    rr["gee_estimate"], rr["gee_se"] = gp[rr["term"]]
        for rr in rows_here:
            rr.update(n_trials=len(d), n_participants=len(parts), control_source=src, converged=conv, llf=llf,
                      cross_check_note=vb_note, separation=bool(sep), separation_note=sep_note, method=method)
        out.extend(rows_here)
    return pd.DataFrame(out)


def _term(name: str) -> str:
    if name.startswith("C(cond"):
        return name.split("[T.", 1)[1].rstrip("]")
    return name


# ------------------------------------------------------------------ report
@dataclass
class AnalysisResult:
    """Everything :func:`analyze` computed (tables are tidy DataFrames)."""

    data: ResponseData
    conditions: pd.DataFrame
    participants_condition: pd.DataFrame
    participants_series: pd.DataFrame
    psychometric: pd.DataFrame
    mixed: pd.DataFrame
    attention: pd.DataFrame
    settings: dict
    files: dict[str, Path] = field(default_factory=dict)
    observer_model: pd.DataFrame = field(default_factory=pd.DataFrame)


def analyze(responses: str | Path | ResponseData, out_dir: str | Path | None = None, *,
            level: str = "nominal_level", control: str = "group", correction: str = "loglinear",
            link: str = "probit", n_boot: int = 2000, seed: int = 0, min_attention: float | None = None,
            allow_mixed_sets: bool = False, figures: bool = True, mixed: bool = True,
            observer_model: bool = True, observer_ci: str = "profile", headline: str = "pooled") -> AnalysisResult:
    """Run the whole analysis; with ``out_dir``, write the tidy CSVs, figures and ``report.md``.

    ``min_attention``: exclude participants whose attention-check pass rate is
    below this (reported in the settings); None keeps everyone.
    ``headline``: which group d' the report leads with and the d' figure shows
    with its CI, ``"pooled"`` (from pooled counts, as the paper's Table 2;
    default, see the module docstring for why) or ``"mean"`` (of the
    per-participant d', Macmillan & Creelman's recommendation where each
    participant contributes many trials per condition); ``conditions.csv`` has
    both (:func:`condition_table`).
    Withdrawn sessions are never read; ``settings["withdrawn_sessions"]`` lists them.
    ``observer_model``: also fit the observer model (:func:`study.observer_fit.fit_observer_model`:
    per error type threshold and slope of d'(x) = (x / threshold) ** slope, a shared
    criterion ``bias`` and a ``lapse`` rate, by maximum likelihood with ``observer_ci``
    intervals, default profile likelihood), written to ``observer_model.csv``.
    Unlike the probit GLM (``psychometric.csv``: d' linear in the level, no lapses)
    it allows a non-linear d' and lapses. When the data cannot support it (e.g.
    levels <= 0 in the regressor), the reason is in ``settings["observer_model_note"]``.
    """
    if level not in ("nominal_level", "achieved_error"):
        raise ValueError(f"level must be 'nominal_level' or 'achieved_error', got {level!r}")
    if headline not in HEADLINES:
        raise ValueError(f"headline must be one of {HEADLINES}, got {headline!r}")
    if isinstance(responses, ResponseData):
        data = responses
        if level not in data.trials.columns or data.test[level].isna().any():
            raise StudyDataError(f"the responses have no (complete) column {level!r} for the level regressor",
                                 data.files[0] if data.files else None, column=level)
    else:
        data = load_responses(responses, allow_mixed_sets=allow_mixed_sets, require=(level,))
    att = attention_summary(data)
    excluded: list[str] = []
    if min_attention is not None and len(att):
        excluded = sorted(att.loc[att["pass_rate"] < min_attention, "participant_id"])
        if excluded:
            keep = ~data.trials["participant_id"].isin(excluded)
            data = replace(data, trials=data.trials[keep])
            if not len(data.test):
                raise StudyDataError(f"every participant failed the attention criterion {min_attention}")
    kw = dict(level=level, control=control, correction=correction)
    cond = condition_table(data, n_boot=n_boot, seed=seed, headline=headline, **kw)
    pc = participant_dprimes(data, by="condition", n_boot=n_boot, seed=seed, **kw)
    ps = participant_dprimes(data, by="series", n_boot=n_boot, seed=seed + 1, **kw)
    psy = fit_psychometric_glms(data, link=link, level=level, control=control)
    mm = fit_mixed_model(data, control=control) if mixed else pd.DataFrame()
    obs_tab, obs_note = pd.DataFrame(), ""
    if observer_model:
        from .observer_fit import fit_observer_model

        try:
            of = fit_observer_model(data, level=level, ci_method=observer_ci, seed=seed)
        except ValueError as e:
            obs_note = f"observer model not fitted: {e}"
        else:
            obs_tab = of.params.assign(level_column=level, converged=of.converged, loglike=of.loglike,
                                       deviance=of.deviance, df_resid=of.df_resid,
                                       n_participants=of.settings["n_participants"])
            if not of.converged:
                obs_note = "observer model: the optimiser did not report convergence"
    settings = dict(level_column=level, control=control, correction=correction, link=link, headline=headline,
                    n_boot=n_boot,
                    seed=seed, min_attention=min_attention, excluded_participants=excluded,
                    n_participants=len(data.participants), n_test_trials=int(len(data.test)),
                    stimulus_set_ids=data.stimulus_set_ids, n_files=len(data.files),
                    skipped_files=[f for f, _ in data.skipped],
                    dropped_lines=[f"{f}:{ln}: {why}" for f, ln, why in data.dropped_lines],
                    incomplete_sessions=[f"{r.participant_id}/{r.session_id}: {r.n_answered} of {r.n_planned} trials "
                                         f"(planned: {r.planned_from})" for r in data.incomplete.itertuples()],
                    mixed_participant_files=[f"{f}: {', '.join(ids)}" for f, ids in data.mixed_files],
                    withdrawn_sessions=[f"{w['participant_id']}/{w['session_id']}: withdrawn {w['withdrawn_utc']} by "
                                        f"{w['by']}" + (f" ({w['reason']})" if w["reason"] else "")
                                        for w in data.withdrawn],
                    observer_model=bool(observer_model), observer_ci=observer_ci, observer_model_note=obs_note)
    res = AnalysisResult(data=data, conditions=cond, participants_condition=pc, participants_series=ps,
                         psychometric=psy, mixed=mm, attention=att, settings=settings, observer_model=obs_tab)
    if out_dir is not None:
        write_report(res, out_dir, figures=figures)
    return res


def write_report(res: AnalysisResult, out_dir: str | Path, figures: bool = True) -> dict[str, Path]:
    """Write ``trials.csv`` (tidy trial-level data), ``conditions.csv``, ``participants_*.csv``,
    ``psychometric.csv``, ``observer_model.csv``, ``mixed_model.csv``, ``attention.csv``, ``settings.json``, figures and ``report.md``."""
    import json

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = {}

    def save(name, df):
        p = out / name
        df.to_csv(p, index=False)
        files[name] = p

    cols = [c for c in ["participant_id", "session_id", "trial_index", "kind", "group", "stimulus_id", "base_clip",
                        "perturbation", "direction", "nominal_level", "achieved_error", "condition", "repetition",
                        "expected_response", "response", "incorrect", "input", "must_watch", "watched_to_end", "rt_s",
                        "client_rt_s", "client_rt_end_s", "stimulus_set_id", "source_file", "source_line"]
            if c in res.data.trials.columns]
    save("trials.csv", res.data.trials[cols])
    save("conditions.csv", res.conditions)
    save("participants_condition.csv", res.participants_condition)
    save("participants_series.csv", res.participants_series)
    save("psychometric.csv", res.psychometric)
    save("mixed_model.csv", res.mixed)
    if res.settings.get("observer_model", True):
        save("observer_model.csv", res.observer_model)
    save("attention.csv", res.attention)
    (out / "settings.json").write_text(json.dumps(res.settings, indent=2, default=str))
    files["settings.json"] = out / "settings.json"
    if figures:
        from . import plots

        figdir = out / "figures"
        figdir.mkdir(exist_ok=True)
        for name, fn in (("ratings.png", plots.plot_ratings), ("dprime.png", plots.plot_dprime),
                         ("psychometric.png", plots.plot_psychometric),
                         ("participants.png", plots.plot_participants)):
            fig = fn(res)
            fig.savefig(figdir / name, dpi=110, bbox_inches="tight")
            plots.close(fig)
            files[f"figures/{name}"] = figdir / name
    (out / "report.md").write_text(report_markdown(res))
    files["report.md"] = out / "report.md"
    res.files = files
    return files


_HEADLINE_TEXT = {"mean": "the mean of the per-participant d' (Macmillan & Creelman's recommendation)",
                  "pooled": "the pooled d' (counts pooled over participants, as the paper's Table 2; the default: "
                            "with few trials per participant and condition the mean of the individual d' is "
                            "shrunk by the correction, see below)"}


def report_markdown(res: AnalysisResult) -> str:
    s = res.settings
    c = res.conditions
    head = s.get("headline", "pooled")
    heads = (["mean d' (headline)", "95% CI", "pooled d'", "95% CI"] if head == "mean"
             else ["pooled d' (headline)", "95% CI", "mean d'", "95% CI"])
    ceil = c.loc[c["perturbation"] != "none", "ceiling"]
    mceil = c.loc[c["perturbation"] != "none", "dprime_mean_ceiling"]
    lines = [
        "# Perception study: analysis report", "",
        f"- participants: {s['n_participants']} "
        + (f"({len(s['excluded_participants'])} excluded: attention-check pass rate below {s['min_attention']})"
           if s["min_attention"] is not None else "(no attention-check exclusion)")
        + f"; test trials: {s['n_test_trials']}; files: {s['n_files']}"
        + (f" ({len(s['skipped_files'])} header-only skipped)" if s["skipped_files"] else ""),
        *[f"- **left out**: {d}" for d in s.get("dropped_lines", [])],
        *([f"- **incomplete sessions** (stopped early; analysed with the trials they have): "
           f"{len(s['incomplete_sessions'])}"] + [f"  - {d}" for d in s["incomplete_sessions"]]
          if s.get("incomplete_sessions") else []),
        *[f"- **file with several participants** (each analysed as their own): {d}"
          for d in s.get("mixed_participant_files", [])],
        *([f"- **withdrawn sessions** (left out unread; data kept, marked by {WITHDRAWN_FILE}): "
           f"{len(s['withdrawn_sessions'])}"] + [f"  - {d}" for d in s["withdrawn_sessions"]]
          if s.get("withdrawn_sessions") else ["- withdrawn sessions: none"]),
        f"- stimulus set(s): {', '.join(s['stimulus_set_ids'])}",
        f"- d' = z(H) - z(F), H = P(\"incorrect\" | perturbed), F = P(\"incorrect\" | unperturbed, "
        f"{'same error group' if s['control'] == 'group' else 'all groups pooled'}); correction: "
        f"**{s['correction']}**; ceiling (largest attainable d') {ceil.min():.2f}-{ceil.max():.2f} "
        f"for these trial counts.",
        f"- **headline d': {_HEADLINE_TEXT[s.get('headline', 'pooled')]}**; the table gives both, the mean of "
        f"the per-participant d' (Macmillan & Creelman 2005: each participant's d' from their own "
        f"hits and false alarms, then averaged) and the pooled d' (from counts pooled over participants, as the "
        f"paper's Table 2); `--headline` chooses. With few trials per participant and condition the correction "
        f"caps each individual d' (mean of the individual ceilings {mceil.min():.2f}-{mceil.max():.2f} here, "
        f"`dprime_mean_ceiling`), so the mean saturates earlier than the pooled d'.",
        f"- CIs: {s['n_boot']} bootstrap resamples, seed {s['seed']}: participants resampled for both group d' "
        f"(the same resamples); "
        f"for individual d' binomial redraws at the corrected rates (so a rate of 0 or 1 still gets an "
        f"interval).",
        f"- psychometric: binomial GLM, {s['link']} link, regressor `{s['level_column']}`; SEs "
        + ("clustered by participant" if len(res.psychometric) and (res.psychometric["se_type"] == "cluster").all()
           else "binomial (fewer than 8 participants: no clustering)") + ".",
        "- mixed model: logistic GLMM, random intercept per participant, maximum likelihood by adaptive "
        "Gauss-Hermite quadrature (study.glmm; as lme4 glmer nAGQ); cross-checks: statsmodels "
        "BinomialBayesMixedGLM (variational Bayes) and GEE (exchangeable, robust SE) in mixed_model.csv.", "",
        "## Conditions", "",
        "| group | condition | n | % rated correct | " + " | ".join(heads) + " |", "|---|---|---|---|---|---|---|---|",
    ]
    for _, r in c.iterrows():
        if r["perturbation"] == "none":
            mean_c = pooled_c = ci_m = ci_p = ""
        else:
            ci_m = f"[{r['dprime_mean_ci_low']:.2f}, {r['dprime_mean_ci_high']:.2f}]"
            ci_p = f"[{r['dprime_ci_low']:.2f}, {r['dprime_ci_high']:.2f}]"
            mean_c = f"{r['dprime_mean']:.2f} (n={r['n_participants_dprime']})"
            pooled_c = f"{r['dprime']:.2f}{' (ceiling)' if r['at_ceiling'] else ''}"
        cells = [mean_c, ci_m, pooled_c, ci_p] if head == "mean" else [pooled_c, ci_p, mean_c, ci_m]
        if head and r["perturbation"] != "none":
            cells[0] = f"**{cells[0]}**"
        lines.append(f"| {r['group']} | {r['condition']} | {r['n_trials']} | {r['pct_rated_correct']:.1f} | "
                     + " | ".join(cells) + " |")
    lines += ["", "## Psychometric fits", "", "| error type | slope (d'/unit) | threshold (d'=1) | 95% CI |",
              "|---|---|---|---|"]
    for _, r in res.psychometric.iterrows():
        lines.append(f"| {r['perturbation']}/{r['direction']} | {r['slope']:.4f} ± {r['slope_se']:.4f} | "
                     f"{r['threshold']:.1f} | [{r['threshold_ci_low']:.1f}, {r['threshold_ci_high']:.1f}] |")
    if len(res.observer_model):
        lines += ["", "## Observer model (maximum likelihood; d'(x) = (x / threshold) ** slope, criterion bias, "
                  f"lapse rate; {s.get('observer_ci', 'profile')} 95% CIs)", "",
                  "| parameter | error type | estimate | 95% CI |", "|---|---|---|---|"]
        for _, r in res.observer_model.iterrows():
            lines.append(f"| {r['name']} | {r['series']} | {r['estimate']:.3g} | [{r['ci_low']:.3g}, {r['ci_high']:.3g}] |")
    if s.get("observer_model_note"):
        lines += ["", s["observer_model_note"]]
    if len(res.mixed):
        lines += ["", "## Mixed model (log odds ratio of \"incorrect\" against the group's unperturbed motions)", "",
                  "| group | term | estimate | 95% CI | p |", "|---|---|---|---|---|"]
        if "separation_note" in res.mixed.columns:
            for note in pd.unique(res.mixed.loc[res.mixed["separation"].astype(bool), "separation_note"]):
                lines += [f"**{note}.**", ""]
        for _, r in res.mixed.iterrows():
            lines.append(f"| {r['group']} | {r['term']} | {r['estimate']:.2f} | [{r['ci_low']:.2f}, {r['ci_high']:.2f}] | "
                         + ("" if pd.isna(r["p"]) else f"{r['p']:.3g}") + " |")
    if len(res.attention):
        lines += ["", f"Attention checks: mean pass rate {res.attention['pass_rate'].mean():.2f}."]
    lines += ["", "Files: conditions.csv (tidy, one row per condition), trials.csv, participants_*.csv, "
              "psychometric.csv, observer_model.csv, mixed_model.csv, attention.csv, figures/."]
    return "\n".join(lines) + "\n"
