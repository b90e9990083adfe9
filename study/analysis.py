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
2. Only ``kind == "test"`` trials enter the statistics (examples, practice and
   attention checks do not); attention checks are summarised per participant.
3. :func:`condition_table`: per condition (error type x direction x level) the
   mean percentage rated correct (with Wilson 95 % CI) and d' against the
   unperturbed motions (see :mod:`study.sdt` for the convention, the
   corrections and the ceiling). The false-alarm rate comes from the
   unperturbed motions shown in the same error group (``control="group"``,
   the paper's Table 2 has one 0 % rating per group) or from all of them
   (``"pooled"``). The group d' is computed from counts pooled over
   participants (as the paper computed it from mean ratings), with a
   participant-level (cluster) bootstrap CI.
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
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import norm

from mocomp.errors import StudyDataError

from .sdt import CORRECTIONS, dprime_counts, wilson_interval
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
    """

    trials: pd.DataFrame
    files: list[Path]
    skipped: list[tuple[str, str]] = field(default_factory=list)
    stimulus_set_ids: list[str] = field(default_factory=list)
    dropped_lines: list[tuple[str, int, str]] = field(default_factory=list)

    @property
    def test(self) -> pd.DataFrame:
        return self.trials[self.trials["kind"] == "test"]

    @property
    def attention(self) -> pd.DataFrame:
        return self.trials[self.trials["kind"] == "attention"]

    @property
    def participants(self) -> list[str]:
        return sorted(self.trials["participant_id"].unique())


def _read_one(path: Path, dropped: list | None = None, require: tuple[str, ...] = ()) -> pd.DataFrame | None:
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
    try:
        df = pd.read_csv(io.BytesIO(raw), dtype=str, keep_default_na=False)
    except pd.errors.EmptyDataError:
        raise StudyDataError("empty CSV (no header, no rows)", path) from None
    except pd.errors.ParserError as e:
        raise StudyDataError(f"not a valid CSV: {e}", path) from None
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise StudyDataError(f"missing column(s) {', '.join(missing)} (required: {', '.join(REQUIRED_COLUMNS)})",
                             path, line=1)
    for col in require:
        if col not in df.columns:
            raise StudyDataError(f"no column {col!r} (needed as the level regressor: --level {col}); this file has "
                                 f"{', '.join(df.columns)}; use --level nominal_level, or add the column", path,
                                 line=1, column=col)
    if len(df) == 0:
        return None
    df["source_file"] = str(path)
    df["source_line"] = np.arange(len(df)) + 2

    def bad(mask, col, msg):
        if mask.any():
            i = int(np.flatnonzero(np.asarray(mask))[0])
            raise StudyDataError(msg(df[col].iloc[i]), path, int(df["source_line"].iloc[i]), col)

    for col in ("participant_id", "session_id", "stimulus_set_id", "stimulus_id"):
        bad(df[col].str.strip() == "", col, lambda v: "empty value")
    bad(~df["response"].isin(("correct", "incorrect")), "response",
        lambda v: f"{v!r} is not 'correct' or 'incorrect'")
    bad(~df["kind"].isin(("practice", "test", "attention")), "kind",
        lambda v: f"{v!r} is not practice, test or attention")
    bad(~df["perturbation"].isin(PERTURBATIONS), "perturbation", lambda v: f"unknown perturbation {v!r}")
    bad(~df["direction"].isin(DIRECTIONS), "direction", lambda v: f"unknown direction {v!r}")
    for col, kind in (("trial_index", "integer"), ("nominal_level", "number")):
        num = pd.to_numeric(df[col], errors="coerce")
        bad(num.isna(), col, lambda v: f"not a {kind}: {v!r}")
        df[col] = num
    bad(df["trial_index"] != np.floor(df["trial_index"]), "trial_index", lambda v: f"not an integer: {v!r}")
    df["trial_index"] = df["trial_index"].astype(int)
    if "rated_correct" in df.columns:
        rc = (df["response"] == "correct").astype(int).astype(str)
        bad(df["rated_correct"] != rc, "rated_correct", lambda v: f"{v!r} disagrees with the response column")
    for col in ("achieved_error", "rt_s", "client_rt_s", "client_rt_end_s", "repetition"):
        if col in df.columns:
            df[col] = pd.to_numeric(df[col].replace("", np.nan), errors="coerce")
    for col in require:
        if col != "nominal_level":
            num = pd.to_numeric(df[col], errors="coerce")
            bad(num.isna() & (df["kind"] == "test"), col, lambda v: f"not a number: {v!r} (needed as the level regressor)")
    if "expected_response" not in df.columns:
        df["expected_response"] = ""
    return df


def load_responses(path: str | Path, *, allow_mixed_sets: bool = False, require: tuple[str, ...] = ()) -> ResponseData:
    """Read and check every ``responses.csv`` under ``path`` (or the one file ``path``).

    Raises :class:`~mocomp.errors.StudyDataError` naming the file, line and
    column for: no responses at all, zero-byte files, missing columns, bad
    values, duplicate trials (a participant/session/trial answered twice, in
    one file or across files, e.g. a session folder copied twice) and sessions
    that used different stimulus sets (unless ``allow_mixed_sets``).
    ``require``: further columns every file must have, with a number in every
    test row (e.g. ``("achieved_error",)`` when it is the level regressor).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"responses folder not found: {path}")
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*.csv")
                                                  if p.name == "responses.csv" or p.name.endswith(".responses.csv"))
    if not files:
        raise StudyDataError("no responses.csv found (expected DATA/<participant>/<session>/responses.csv)", path)
    frames, skipped, dropped = [], [], []
    for f in files:
        df = _read_one(f, dropped, tuple(require))
        if df is None:
            skipped.append((str(f), "header only: no responses"))
        else:
            frames.append(df)
    if not frames:
        raise StudyDataError(f"all {len(files)} responses CSV(s) are empty (header only)", path)
    allr = pd.concat(frames, ignore_index=True)
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
    allr["condition"] = [condition_label(p, d, lv) for p, d, lv in
                         zip(allr["perturbation"], allr["direction"], allr["nominal_level"])]
    return ResponseData(trials=allr, files=files, skipped=skipped, stimulus_set_ids=sets, dropped_lines=dropped)


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


def condition_table(data: ResponseData | pd.DataFrame, *, level: str = "nominal_level", control: str = "group",
                    correction: str = "loglinear", n_boot: int = 2000, seed: int = 0,
                    ci: float = 0.95) -> pd.DataFrame:
    """Mean % rated correct and d' per condition (tidy; one row per condition and per group's control).

    Columns: group, perturbation, direction, level, condition, n_trials,
    n_participants, n_rated_correct, pct_rated_correct, pct_ci_low/high
    (Wilson), hit_rate (P incorrect), fa_rate, n_control, control_source,
    dprime (corrected), dprime_uncorrected (the paper's z(r0) - z(r) from the
    pooled rates; +-inf at 0 or 1), correction, ceiling, at_ceiling,
    dprime_ci_low/high (participant bootstrap, percentile).
    """
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {CORRECTIONS}")
    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    if not len(test):
        raise StudyDataError("no test trials to analyse")
    parts = sorted(test["participant_id"].unique())
    pidx = {p: i for i, p in enumerate(parts)}
    rows = []
    # per-participant counts for every row, for the cluster bootstrap
    K, N = [], []

    def counts(sub):
        k = np.zeros(len(parts))
        n = np.zeros(len(parts))
        g = sub.groupby("participant_id")["incorrect"].agg(["sum", "size"])
        for p, r in g.iterrows():
            k[pidx[p]] = r["sum"]
            n[pidx[p]] = r["size"]
        return k, n

    groups = sorted(test.loc[test["perturbation"] != "none", "group"].unique())
    ctl_rows = {}
    for g in groups:
        ctl, src = _controls_for(test, g, control)
        key = g if src == "group" else "(pooled)"
        if key not in ctl_rows:
            k, n = counts(ctl)
            ctl_rows[key] = len(rows)
            rows.append(dict(group=g if src == "group" else "(all)", perturbation="none", direction="none",
                             level=0.0, condition="none", n_trials=int(n.sum()),
                             n_participants=int((n > 0).sum()), n_incorrect=int(k.sum()), control_row=None,
                             control_source=src))
            K.append(k)
            N.append(n)
        cells = _cells(test[test["group"] == g], level)
        sub_all = test[test["group"] == g]
        for _, c in cells.iterrows():
            sub = sub_all[(sub_all["perturbation"] == c["perturbation"]) & (sub_all["direction"] == c["direction"])
                          & (sub_all[level] == c["level"])]
            k, n = counts(sub)
            rows.append(dict(group=g, perturbation=c["perturbation"], direction=c["direction"],
                             level=float(c["level"]),
                             condition=condition_label(c["perturbation"], c["direction"], c["level"]),
                             n_trials=int(n.sum()), n_participants=int((n > 0).sum()), n_incorrect=int(k.sum()),
                             control_row=ctl_rows[key], control_source=src))
            K.append(k)
            N.append(n)
    tab = pd.DataFrame(rows)
    K = np.array(K)
    N = np.array(N)
    k_tot, n_tot = K.sum(1), N.sum(1)
    tab["n_rated_correct"] = (n_tot - k_tot).astype(int)
    tab["pct_rated_correct"] = 100 * (n_tot - k_tot) / n_tot
    lo, hi = wilson_interval(n_tot - k_tot, n_tot, ci)
    tab["pct_ci_low"], tab["pct_ci_high"] = 100 * lo, 100 * hi
    tab["hit_rate"] = k_tot / n_tot
    cr = np.array([r if r is not None and not pd.isna(r) else i for i, r in enumerate(tab["control_row"])], int)
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
    # cluster bootstrap over participants
    rng = np.random.default_rng(seed)
    P = len(parts)
    W = rng.multinomial(P, np.full(P, 1.0 / P), size=n_boot).astype(float)  # (B, P)
    Kb, Nb = W @ K.T, W @ N.T  # (B, rows)
    valid = (Nb > 0) & (Nb[:, cr] > 0)
    Nb_safe = np.where(valid, Nb, 1.0)
    Kb_safe = np.where(valid, Kb, 0.0)
    db = dprime_counts(Kb_safe, Nb_safe, Kb_safe[:, cr], np.where(valid, Nb[:, cr], 1.0), correction).dprime
    db = np.where(valid, db, np.nan)
    a = (1 - ci) / 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tab["dprime_ci_low"] = np.where(is_ctl, np.nan, np.nanquantile(db, a, axis=0))
        tab["dprime_ci_high"] = np.where(is_ctl, np.nan, np.nanquantile(db, 1 - a, axis=0))
    tab["n_boot"] = n_boot
    return tab.drop(columns=["control_row"])[
        ["group", "perturbation", "direction", "level", "condition", "n_trials", "n_participants",
         "n_rated_correct", "n_incorrect", "pct_rated_correct", "pct_ci_low", "pct_ci_high", "hit_rate", "fa_rate",
         "n_control", "control_source", "dprime", "dprime_uncorrected", "correction", "ceiling", "at_ceiling",
         "dprime_ci_low", "dprime_ci_high", "n_boot"]]


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
    """
    if by not in ("condition", "series"):
        raise ValueError("by must be 'condition' or 'series'")
    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    rng = np.random.default_rng(seed)
    out = []
    for p, tp in test.groupby("participant_id", sort=True):
        pert = tp[tp["perturbation"] != "none"]
        keys = ["group"] + SERIES + ([level] if by == "condition" else [])
        for key, sub in pert.groupby(keys, sort=True):
            g = key[0]
            try:
                ctl, src = _controls_for(tp, g, control)
            except StudyDataError:
                continue
            k, n = int(sub["incorrect"].sum()), len(sub)
            kf, nf = int(ctl["incorrect"].sum()), len(ctl)
            d = dprime_counts(k, n, kf, nf, correction)
            kb = rng.binomial(n, float(d.hit_used), size=n_boot)
            fb = rng.binomial(nf, float(d.fa_used), size=n_boot)
            note = ""
            if correction == "none" and (k in (0, n) or kf in (0, nf)):
                lo = hi = np.nan
                note = "undefined: a rate of 0 or 1 without a correction (d' is infinite)"
            else:
                with np.errstate(divide="ignore", invalid="ignore"):  # no correction: draws of 0 or n give +-inf
                    db = dprime_counts(kb, n, fb, nf, correction).dprime
                a = (1 - ci) / 2
                # order statistics (no interpolation): draws can be +-inf without a correction
                lo, hi = np.quantile(db, [a, 1 - a], method="inverted_cdf")
            row = dict(participant_id=p, group=g, perturbation=key[1], direction=key[2],
                       level=float(key[3]) if by == "condition" else np.nan,
                       n_signal=n, hits=k, n_control=nf, false_alarms=kf, control_source=src,
                       hit_rate=k / n, fa_rate=kf / nf, dprime=float(d.dprime), ceiling=float(d.ceiling),
                       correction=correction, ci_low=lo, ci_high=hi, ci_degenerate=bool(hi - lo < 1e-12),
                       ci_note=note, n_boot=n_boot)
            row["condition"] = (condition_label(key[1], key[2], key[3]) if by == "condition"
                                else f"{key[1]}/{key[2]}")
            out.append(row)
    return pd.DataFrame(out)


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
def _series_data(test: pd.DataFrame, pert: str, direction: str, level: str, control: str) -> pd.DataFrame:
    sub = test[(test["perturbation"] == pert) & (test["direction"] == direction)]
    g = sub["group"].iloc[0]
    ctl, _ = _controls_for(test, g, control)
    d = pd.concat([sub.assign(x=sub[level].astype(float)), ctl.assign(x=0.0)])
    return d


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
    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    pert = test[test["perturbation"] != "none"]
    if "participant_id" not in test.columns:
        test = test.assign(participant_id="(all)")
    n_parts = test["participant_id"].nunique()
    se_type = ("cluster" if n_parts >= min_clusters else "model") if se == "auto" else se
    if se_type == "cluster" and n_parts < 2:
        raise ValueError("cluster-robust SEs need at least 2 participants")
    zc = norm.ppf(0.5 + ci / 2)
    out = []
    for (p, dr), _ in pert.groupby(SERIES, sort=True):
        d = _series_data(test, p, dr, level, control)
        agg = d.groupby("x")["incorrect"].agg(["sum", "size"]).reset_index()
        endog = np.column_stack([agg["sum"], agg["size"] - agg["sum"]])
        X = sm.add_constant(agg["x"].to_numpy(float))
        def fam():  # a fresh family per model (statsmodels' Binomial keeps the trial counts of its model)
            return sm.families.Binomial(link=sm.families.links.Probit() if link == "probit" else sm.families.links.Logit())

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = sm.GLM(endog, X, family=fam()).fit()
            cov = np.asarray(res.cov_params())
            if se_type == "cluster":  # same estimates from participant x level counts, sandwich by participant
                pa = d.groupby(["participant_id", "x"])["incorrect"].agg(["sum", "size"]).reset_index()
                rc = sm.GLM(np.column_stack([pa["sum"], pa["size"] - pa["sum"]]),
                            sm.add_constant(pa["x"].to_numpy(float), has_constant="add"), family=fam()).fit(
                    start_params=res.params, cov_type="cluster",
                    cov_kwds={"groups": pd.factorize(pa["participant_id"])[0]})
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
        out.append(dict(perturbation=p, direction=dr, group=d["group"].iloc[0], link=link, level_column=level,
                        intercept=a, intercept_se=sa, slope=b, slope_se=sb, slope_ci_low=blo, slope_ci_high=bhi,
                        threshold=thr, threshold_ci_low=tlo, threshold_ci_high=thi,
                        pse=(-a / b if b != 0 else np.nan), deviance=res.deviance, df_resid=res.df_resid,
                        n_trials=int(agg["size"].sum()), n_levels=len(agg), converged=bool(res.converged),
                        cov_ab=float(cov[0, 1]), se_type=se_type, n_participants=int(d["participant_id"].nunique())))
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


def fit_mixed_model(data: ResponseData | pd.DataFrame, *, control: str = "group", n_nodes: int = 15,
                    cross_checks: bool = True) -> pd.DataFrame:
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
    within participant, robust SEs): population-averaged, hence smaller in
    magnitude than the conditional GLMM effects when s > 0.
    """
    import statsmodels.api as sm
    from scipy.stats import norm as _norm

    from .glmm import fit_logit_glmm

    test = data.test if isinstance(data, ResponseData) else data[data["kind"] == "test"]
    out = []
    for g in sorted(test.loc[test["perturbation"] != "none", "group"].unique()):
        sub = test[(test["group"] == g) & (test["perturbation"] != "none")]
        ctl, src = _controls_for(test, g, control)
        d = pd.concat([sub, ctl]).copy()
        levels = ["none"] + sorted(set(d["condition"]) - {"none"})
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
        if len(parts) >= 2:
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
        if cross_checks and len(parts) >= 2:
            formula = "incorrect ~ C(cond, Treatment('none'))"
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    from statsmodels.genmod.bayes_mixed_glm import BinomialBayesMixedGLM

                    m = BinomialBayesMixedGLM.from_formula(formula, {"participant": "0 + C(participant_id)"}, d)
                    v = m.fit_vb()
                    vb = {_term(nm): (mu, sd) for nm, mu, sd in zip(m.fep_names, v.fe_mean, v.fe_sd)}
                    vb["participant SD (random intercept)"] = (float(np.exp(v.vcp_mean[0])), np.nan)
                except Exception as e:  # pragma: no cover - reported, not fatal
                    vb = {}
                    warnings.warn(f"BinomialBayesMixedGLM failed for group {g}: {e}")
                try:
                    gee = sm.GEE.from_formula(formula, groups="participant_id", data=d,
                                              family=sm.families.Binomial(),
                                              cov_struct=sm.cov_struct.Exchangeable()).fit()
                    gp = {_term(nm): (v_, s_) for nm, v_, s_ in zip(gee.params.index, gee.params.values, gee.bse.values)}
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
                      method=f"ML logistic GLMM, random intercept per participant, adaptive Gauss-Hermite "
                             f"(nAGQ={n_nodes})")
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
            observer_model: bool = True, observer_ci: str = "profile") -> AnalysisResult:
    """Run the whole analysis; with ``out_dir``, write the tidy CSVs, figures and ``report.md``.

    ``min_attention``: exclude participants whose attention-check pass rate is
    below this (reported in the settings); None keeps everyone.
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
            data = ResponseData(trials=data.trials[keep], files=data.files, skipped=data.skipped,
                                stimulus_set_ids=data.stimulus_set_ids, dropped_lines=data.dropped_lines)
            if not len(data.test):
                raise StudyDataError(f"every participant failed the attention criterion {min_attention}")
    kw = dict(level=level, control=control, correction=correction)
    cond = condition_table(data, n_boot=n_boot, seed=seed, **kw)
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
    settings = dict(level_column=level, control=control, correction=correction, link=link, n_boot=n_boot,
                    seed=seed, min_attention=min_attention, excluded_participants=excluded,
                    n_participants=len(data.participants), n_test_trials=int(len(data.test)),
                    stimulus_set_ids=data.stimulus_set_ids, n_files=len(data.files),
                    skipped_files=[f for f, _ in data.skipped],
                    dropped_lines=[f"{f}:{ln}: {why}" for f, ln, why in data.dropped_lines],
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


def report_markdown(res: AnalysisResult) -> str:
    s = res.settings
    c = res.conditions
    ceil = c.loc[c["perturbation"] != "none", "ceiling"]
    lines = [
        "# Perception study: analysis report", "",
        f"- participants: {s['n_participants']} "
        + (f"({len(s['excluded_participants'])} excluded: attention-check pass rate below {s['min_attention']})"
           if s["min_attention"] is not None else "(no attention-check exclusion)")
        + f"; test trials: {s['n_test_trials']}; files: {s['n_files']}"
        + (f" ({len(s['skipped_files'])} header-only skipped)" if s["skipped_files"] else ""),
        *[f"- **left out**: {d}" for d in s.get("dropped_lines", [])],
        f"- stimulus set(s): {', '.join(s['stimulus_set_ids'])}",
        f"- d' = z(H) - z(F), H = P(\"incorrect\" | perturbed), F = P(\"incorrect\" | unperturbed, "
        f"{'same error group' if s['control'] == 'group' else 'all groups pooled'}); correction: "
        f"**{s['correction']}**; ceiling (largest attainable d') {ceil.min():.2f}-{ceil.max():.2f} "
        f"for these trial counts.",
        f"- CIs: {s['n_boot']} bootstrap resamples, seed {s['seed']}: participants resampled for the group d'; "
        f"for individual d' binomial redraws at the corrected rates (so a rate of 0 or 1 still gets an "
        f"interval).",
        f"- psychometric: binomial GLM, {s['link']} link, regressor `{s['level_column']}`; SEs "
        + ("clustered by participant" if len(res.psychometric) and (res.psychometric["se_type"] == "cluster").all()
           else "binomial (fewer than 8 participants: no clustering)") + ".",
        "- mixed model: logistic GLMM, random intercept per participant, maximum likelihood by adaptive "
        "Gauss-Hermite quadrature (study.glmm; as lme4 glmer nAGQ); cross-checks: statsmodels "
        "BinomialBayesMixedGLM (variational Bayes) and GEE (exchangeable, robust SE) in mixed_model.csv.", "",
        "## Conditions", "",
        "| group | condition | n | % rated correct | d' | 95% CI |", "|---|---|---|---|---|---|",
    ]
    for _, r in c.iterrows():
        ci = "" if r["perturbation"] == "none" else f"[{r['dprime_ci_low']:.2f}, {r['dprime_ci_high']:.2f}]"
        lines.append(f"| {r['group']} | {r['condition']} | {r['n_trials']} | {r['pct_rated_correct']:.1f} | "
                     f"{r['dprime']:.2f}{' (ceiling)' if r['at_ceiling'] else ''} | {ci} |")
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
        for _, r in res.mixed.iterrows():
            lines.append(f"| {r['group']} | {r['term']} | {r['estimate']:.2f} | [{r['ci_low']:.2f}, {r['ci_high']:.2f}] | "
                         + ("" if pd.isna(r["p"]) else f"{r['p']:.3g}") + " |")
    if len(res.attention):
        lines += ["", f"Attention checks: mean pass rate {res.attention['pass_rate'].mean():.2f}."]
    lines += ["", "Files: conditions.csv (tidy, one row per condition), trials.csv, participants_*.csv, "
              "psychometric.csv, observer_model.csv, mixed_model.csv, attention.csv, figures/."]
    return "\n".join(lines) + "\n"
