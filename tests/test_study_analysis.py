"""Analysis of responses: d' conventions and corrections, schema errors, condition tables,
bootstrap, psychometric GLM and the ML GLMM (against statsmodels as a peer)."""
from __future__ import annotations

import csv
import io
import shutil
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.special import expit
from scipy.stats import norm

from mocomp.errors import StudyDataError
from study.analysis import (analyze, condition_table, fit_mixed_model, fit_psychometric_glms, load_responses,
                            participant_dprimes)
from study.glmm import fit_logit_glmm
from study.sdt import adjusted_rate, dprime_ceiling, dprime_counts, wilson_interval
from study.session import RESPONSE_COLUMNS


# ------------------------------------------------------------------ d'
def test_dprime_known_values_and_corrections():
    d = dprime_counts(84134, 100000, 50000, 100000, "none")
    assert float(d.dprime) == pytest.approx(1.0, abs=1e-3)
    # log-linear (Hautus 1995): +0.5 / +1 in every cell
    assert adjusted_rate(3, 4, "loglinear") == pytest.approx(3.5 / 5)
    assert adjusted_rate(4, 4, "loglinear") == pytest.approx(4.5 / 5)
    # 1/(2N) (Macmillan & Kaplan 1985): only the extremes move
    assert adjusted_rate(3, 4, "1/(2N)") == pytest.approx(0.75)
    assert adjusted_rate(4, 4, "1/(2N)") == pytest.approx(1 - 1 / 8)
    assert adjusted_rate(0, 4, "1/(2N)") == pytest.approx(1 / 8)
    assert np.isinf(dprime_counts(4, 4, 1, 4, "none").dprime)
    # ceilings: perfect performance hits them exactly
    for corr in ("loglinear", "1/(2N)"):
        d = dprime_counts(8, 8, 0, 12, corr)
        assert float(d.dprime) == pytest.approx(float(dprime_ceiling(8, 12, corr)))
        assert bool(d.at_ceiling)
    assert float(dprime_ceiling(8, 12, "1/(2N)")) == pytest.approx(norm.ppf(1 - 1 / 16) - norm.ppf(1 / 24))
    assert float(dprime_ceiling(8, 12, "loglinear")) == pytest.approx(norm.ppf(8.5 / 9) - norm.ppf(0.5 / 13))
    with pytest.raises(ValueError):
        dprime_counts(1, 4, 1, 4, "bogus")
    with pytest.raises(ValueError):
        adjusted_rate(5, 4)


def test_wilson_interval_agrees_with_statsmodels():
    from statsmodels.stats.proportion import proportion_confint

    k, n = np.array([0, 3, 17, 40]), np.array([10, 10, 40, 40])
    lo, hi = wilson_interval(k, n)
    slo, shi = proportion_confint(k, n, method="wilson")
    np.testing.assert_allclose(lo, slo, atol=1e-12)
    np.testing.assert_allclose(hi, shi, atol=1e-12)
    # exact at the ends (rounding once left 7e-16 below a rate of 0, a negative error bar in plot_ratings)
    lo, hi = wilson_interval(np.array([0, 48]), np.array([48, 48]))
    assert lo[0] == 0.0 and hi[1] == 1.0 and lo[1] < 1 and hi[0] > 0


# ------------------------------------------------------------ fixtures
def _row(pid, sid, ti, pert, direction, level, resp, group, kind="test", set_id="SET1", expected=""):
    r = {c: "" for c in RESPONSE_COLUMNS}
    r.update(participant_id=pid, session_id=sid, stimulus_set_id=set_id, trial_index=ti, kind=kind, group=group,
             repetition=1, stimulus_id=f"{pert}_{direction}_{level}", perturbation=pert, direction=direction,
             nominal_level=level, achieved_error=level, response=resp, rated_correct=int(resp == "correct"),
             input="observer", rt_s=1.0, expected_response=expected)
    return r


def _write(path: Path, rows: list[dict], columns=RESPONSE_COLUMNS):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(columns), extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)


def _known_dataset(root: Path):
    """Two participants; known counts per cell.

    group A: controls 10 per participant, 3 "incorrect" each (FA 0.3);
             am_abrupt/increase/25: 10 per participant, 6 and 8 "incorrect".
    group T: controls 10, 1 and 3 incorrect; takeoff/increase/20: 10, all incorrect for P2.
    """
    spec = {"P1": dict(ctlA=3, a25=6, ctlT=1, t20=5), "P2": dict(ctlA=3, a25=8, ctlT=3, t20=10)}
    for pid, s in spec.items():
        rows, ti = [], 0
        for cell, (pert, d, lv, g) in dict(ctlA=("none", "none", 0, "angular_momentum"),
                                            a25=("am_abrupt", "increase", 25, "angular_momentum"),
                                            ctlT=("none", "none", 0, "takeoff"),
                                            t20=("takeoff", "increase", 20, "takeoff")).items():
            for i in range(10):
                rows.append(_row(pid, "S1", ti, pert, d, lv, "incorrect" if i < s[cell] else "correct", g))
                ti += 1
        rows.append(_row(pid, "S1", ti, "none", "none", 0, "incorrect", "", kind="attention", expected="incorrect"))
        _write(root / pid / "S1" / "responses.csv", rows)
    return spec


def test_condition_table_known_counts(tmp_path):
    _known_dataset(tmp_path)
    data = load_responses(tmp_path)
    tab = condition_table(data, correction="loglinear", n_boot=200, seed=1).set_index(["group", "condition"])
    a = tab.loc[("angular_momentum", "am_abrupt/increase/25")]
    assert a["n_trials"] == 20 and a["n_participants"] == 2
    assert a["pct_rated_correct"] == pytest.approx(30.0)  # 14 of 20 called incorrect
    assert a["hit_rate"] == pytest.approx(0.7) and a["fa_rate"] == pytest.approx(0.3)
    assert a["dprime"] == pytest.approx(norm.ppf(14.5 / 21) - norm.ppf(6.5 / 21))
    assert a["dprime_uncorrected"] == pytest.approx(norm.ppf(0.7) - norm.ppf(0.3))
    assert a["control_source"] == "group"
    t = tab.loc[("takeoff", "takeoff/increase/20")]
    assert t["fa_rate"] == pytest.approx(0.2)  # the take-off group's own controls
    assert t["dprime"] == pytest.approx(norm.ppf(15.5 / 21) - norm.ppf(4.5 / 21))
    # pooled controls: F = 10/40
    pooled = condition_table(data, control="pooled", correction="1/(2N)", n_boot=50).set_index("condition")
    assert pooled.loc["takeoff/increase/20", "fa_rate"] == pytest.approx(0.25)
    assert pooled.loc["takeoff/increase/20", "dprime"] == pytest.approx(norm.ppf(0.75) - norm.ppf(0.25))
    assert (pooled["control_source"] == "pooled").all()
    # the bootstrap is seeded and brackets the estimate
    tab2 = condition_table(data, n_boot=200, seed=1).set_index(["group", "condition"])
    assert tab2.loc[("angular_momentum", "am_abrupt/increase/25"), "dprime_ci_low"] == a["dprime_ci_low"]
    assert a["dprime_ci_low"] <= a["dprime"] <= a["dprime_ci_high"]


def test_participant_dprimes_known_counts(tmp_path):
    _known_dataset(tmp_path)
    pdp = participant_dprimes(load_responses(tmp_path), correction="1/(2N)", n_boot=300, seed=3)
    r = pdp.set_index(["participant_id", "condition"]).loc[("P2", "takeoff/increase/20")]
    assert r["hits"] == 10 and r["false_alarms"] == 3
    assert r["dprime"] == pytest.approx(norm.ppf(1 - 1 / 20) - norm.ppf(0.3))
    assert r["dprime"] == pytest.approx(r["ceiling"] - (norm.ppf(0.3) - norm.ppf(1 / 20)))
    r1 = pdp.set_index(["participant_id", "condition"]).loc[("P1", "am_abrupt/increase/25")]
    assert r1["ci_low"] < r1["dprime"] < r1["ci_high"] and not r1["ci_degenerate"]


def test_participant_dprime_interval_at_rates_of_zero_and_one(tmp_path):
    """A participant who calls every perturbed motion incorrect (P2, take-off 20 %) still gets an
    honest interval; without a correction the interval is undefined and says why."""
    _known_dataset(tmp_path)
    data = load_responses(tmp_path)
    r = participant_dprimes(data, n_boot=400, seed=1).set_index(["participant_id", "condition"])
    p2 = r.loc[("P2", "takeoff/increase/20")]
    assert p2["hit_rate"] == 1.0 and not p2["ci_degenerate"]
    assert p2["ci_low"] < p2["dprime"] <= p2["ci_high"] and p2["ci_high"] - p2["ci_low"] > 0.5
    none = participant_dprimes(data, n_boot=50, correction="none").set_index(["participant_id", "condition"])
    q = none.loc[("P2", "takeoff/increase/20")]
    assert np.isinf(q["dprime"]) and np.isnan(q["ci_low"]) and "undefined" in q["ci_note"]
    assert none.loc[("P1", "am_abrupt/increase/25"), "ci_note"] == ""


def test_participant_dprime_intervals_cover_the_truth():
    """400 simulated participants with 6 perturbed and 12 control trials each (many rates of 0
    or 1): the 95% intervals cover the true d' = 1 at about the nominal rate."""
    rng = np.random.default_rng(4)
    d_true, f = 1.0, 0.3
    h = norm.cdf(d_true + norm.ppf(f))
    rows = []
    for i in range(400):
        k, kf = rng.binomial(6, h), rng.binomial(12, f)
        for j in range(6):
            rows.append(("P%03d" % i, "takeoff", "increase", 20.0, int(j < k)))
        for j in range(12):
            rows.append(("P%03d" % i, "none", "none", 0.0, int(j < kf)))
    df = pd.DataFrame(rows, columns=["participant_id", "perturbation", "direction", "nominal_level", "incorrect"])
    df = df.assign(kind="test", group="takeoff")
    r = participant_dprimes(df, n_boot=400, seed=2)
    assert ((r["hits"] == 6) | (r["false_alarms"] == 0)).mean() > 0.1  # extremes are common here
    assert not r["ci_degenerate"].any()
    cover = ((r["ci_low"] <= d_true) & (d_true <= r["ci_high"])).mean()
    assert 0.91 <= cover <= 0.99, cover


def test_schema_errors_are_clear(tmp_path):
    _known_dataset(tmp_path)
    # missing column
    df = pd.read_csv(tmp_path / "P1" / "S1" / "responses.csv", dtype=str, keep_default_na=False)
    df.drop(columns=["response"]).to_csv(tmp_path / "m.csv", index=False)
    with pytest.raises(StudyDataError, match=r"m\.csv:1.*missing column\(s\) response"):
        load_responses(tmp_path / "m.csv")
    # empty file
    e = tmp_path / "e" / "responses.csv"
    e.parent.mkdir()
    e.write_text("")
    with pytest.raises(StudyDataError, match="empty CSV"):
        load_responses(e.parent)
    # header only: skipped, listed
    h = tmp_path / "h" / "P9" / "S1" / "responses.csv"
    _write(h, [])
    shutil.copytree(tmp_path / "P1", tmp_path / "h" / "P1")
    d = load_responses(tmp_path / "h")
    assert len(d.skipped) == 1 and d.participants == ["P1"]
    with pytest.raises(StudyDataError, match="all 1 responses CSV"):
        load_responses(h)
    # a bad value, with its line
    rows = list(csv.DictReader(io.StringIO((tmp_path / "P1" / "S1" / "responses.csv").read_text())))
    rows[4]["response"] = "maybe"
    _write(tmp_path / "v" / "responses.csv", rows)
    with pytest.raises(StudyDataError, match=r"responses\.csv:6: column response: value 'maybe' is "):
        load_responses(tmp_path / "v")
    # duplicate trial within a file
    rows = list(csv.DictReader(io.StringIO((tmp_path / "P1" / "S1" / "responses.csv").read_text())))
    _write(tmp_path / "d" / "responses.csv", rows + [rows[2]])
    with pytest.raises(StudyDataError, match="duplicate trial.*trial 2"):
        load_responses(tmp_path / "d")
    # the same session copied twice
    shutil.copytree(tmp_path / "P1", tmp_path / "c" / "a" / "P1")
    shutil.copytree(tmp_path / "P1", tmp_path / "c" / "b" / "P1")
    with pytest.raises(StudyDataError, match="duplicate trial"):
        load_responses(tmp_path / "c")
    # mixed stimulus sets
    rows = list(csv.DictReader(io.StringIO((tmp_path / "P2" / "S1" / "responses.csv").read_text())))
    for r in rows:
        r["stimulus_set_id"] = "OTHER"
    shutil.copytree(tmp_path / "P1", tmp_path / "mx" / "P1")
    _write(tmp_path / "mx" / "P2" / "S1" / "responses.csv", rows)
    with pytest.raises(StudyDataError, match="2 different stimulus sets"):
        load_responses(tmp_path / "mx")
    assert len(load_responses(tmp_path / "mx", allow_mixed_sets=True).stimulus_set_ids) == 2
    (tmp_path / "nothing").mkdir()
    with pytest.raises(StudyDataError, match="no responses.csv"):
        load_responses(tmp_path / "nothing")


def test_torn_last_line_is_left_out_with_file_and_line(tmp_path):
    """A session that crashed mid-write and was never resumed ends in a partial row (no line end):
    it was never acknowledged, so analyze leaves it out (warning naming file:line), never counts it."""
    _known_dataset(tmp_path / "ok")
    full = load_responses(tmp_path / "ok")
    src = (tmp_path / "ok" / "P1" / "S1" / "responses.csv").read_bytes()
    lines = src.splitlines(keepends=True)
    n_rows = len(lines) - 1
    shutil.copytree(tmp_path / "ok", tmp_path / "torn")
    f = tmp_path / "torn" / "P1" / "S1" / "responses.csv"
    # drop the last complete row, then append the first 60 bytes of it (a torn write)
    f.write_bytes(b"".join(lines[:-1]) + lines[-1][:60])
    with pytest.warns(UserWarning, match=rf"responses\.csv:{n_rows + 1}: torn last line"):
        d = load_responses(tmp_path / "torn")
    assert d.dropped_lines == [(str(f), n_rows + 1, "torn last line (incomplete row) left out")]
    p1 = d.trials[d.trials["participant_id"] == "P1"]
    assert len(p1) == n_rows - 1 == len(full.trials[full.trials["participant_id"] == "P1"]) - 1
    assert p1["source_line"].max() == n_rows
    with pytest.warns(UserWarning):
        res = analyze(tmp_path / "torn", tmp_path / "rep", n_boot=50, figures=False, mixed=False)
    assert res.settings["dropped_lines"] == [f"{f}:{n_rows + 1}: torn last line (incomplete row) left out"]
    assert "left out" in (tmp_path / "rep" / "report.md").read_text()
    assert len(res.data.trials) == len(full.trials) - 1
    # (the torn row was P1's attention check: it is not counted as passed or failed)
    assert res.attention.set_index("participant_id")["n_checks"].to_dict() == {"P2": 1}
    # a file with not even a complete header line
    g = tmp_path / "hdr" / "responses.csv"
    g.parent.mkdir()
    g.write_bytes(src[:30])
    with pytest.raises(StudyDataError, match=r"responses\.csv:1.*torn header"):
        load_responses(g)


def _probit_data(rng, slope=0.05, intercept=-0.6, levels=(10, 20, 30, 40), n=4000):
    rows, ti = [], 0
    for lv in (0,) + tuple(levels):
        k = rng.binomial(n, norm.cdf(intercept + slope * lv))
        for i in range(n):
            pert, d = ("none", "none") if lv == 0 else ("takeoff", "increase")
            rows.append(dict(participant_id="P1", kind="test", group="takeoff", perturbation=pert, direction=d,
                             nominal_level=float(lv), incorrect=int(i < k), condition=f"{pert}/{d}/{lv}"))
    return pd.DataFrame(rows)


def test_psychometric_glm_recovers_probit_model():
    df = _probit_data(np.random.default_rng(5))
    fit = fit_psychometric_glms(df, link="probit").iloc[0]
    assert fit["slope"] == pytest.approx(0.05, abs=3 * fit["slope_se"])
    assert fit["intercept"] == pytest.approx(-0.6, abs=3 * fit["intercept_se"])
    assert fit["threshold_ci_low"] <= 20.0 <= fit["threshold_ci_high"]  # d' = 1 at 1/0.05 = 20
    assert fit["threshold"] == pytest.approx(1 / fit["slope"])
    lg = fit_psychometric_glms(df, link="logit").iloc[0]
    assert lg["slope"] > fit["slope"]  # logit coefficients are ~1.6-1.8x probit ones
    assert 1.5 < lg["slope"] / fit["slope"] < 1.9


def test_glmm_agrees_with_glm_when_no_participant_variance_and_quadrature_converges():
    import statsmodels.api as sm

    rng = np.random.default_rng(2)
    P, C, m = 30, 4, 10
    beta = np.array([-1.0, 0.5, 1.5, 2.5])
    X = np.tile(np.eye(C), (P, 1))
    X[:, 0] = 1
    g = np.repeat(np.arange(P), C)
    # every participant gives exactly the same counts: zero between-participant variance, so the
    # ML random-intercept SD is on its boundary 0 and the GLMM reduces to the GLM (always checked)
    k = np.round(m * expit(X @ beta)).astype(int)
    n = np.full_like(k, m)
    r = fit_logit_glmm(X, k, n, g)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statsmodels' separation heuristic trips on the repeated rows
        glm = sm.GLM(np.column_stack([k, n - k]), X, family=sm.families.Binomial()).fit()
    assert r.converged and r.sigma < 1e-2
    np.testing.assert_allclose(r.beta, glm.params, atol=1e-4)
    np.testing.assert_allclose(r.se, glm.bse, rtol=1e-3)
    assert r.llf == pytest.approx(glm.llf, abs=1e-4)
    # participant variance present: recovered; the quadrature order does not matter
    u = rng.normal(0, 1.0, P)
    k2 = rng.binomial(m, expit(X @ beta + u[g]))
    a = fit_logit_glmm(X, k2, n, g, n_nodes=15)
    b = fit_logit_glmm(X, k2, n, g, n_nodes=30)
    np.testing.assert_allclose(a.beta, b.beta, atol=1e-4)
    assert a.llf == pytest.approx(b.llf, abs=1e-6)
    assert abs(np.log(a.sigma) - np.log(1.0)) < 2.5 * a.log_sigma_se
    assert np.all(np.abs(a.beta - beta) < 3 * a.se)
    glm2 = sm.GLM(np.column_stack([k2, n - k2]), X, family=sm.families.Binomial()).fit()
    # conditional effects exceed the marginal (GLM) ones when sigma > 0
    assert np.all(np.abs(a.beta[1:]) > np.abs(glm2.params[1:]))


def test_analyze_writes_report(tmp_path):
    _known_dataset(tmp_path / "data")
    res = analyze(tmp_path / "data", tmp_path / "report", n_boot=100, min_attention=0.5)
    for f in ("conditions.csv", "trials.csv", "participants_condition.csv", "participants_series.csv",
              "psychometric.csv", "mixed_model.csv", "attention.csv", "report.md", "settings.json",
              "figures/dprime.png", "figures/ratings.png", "figures/psychometric.png", "figures/participants.png"):
        assert (tmp_path / "report" / f).is_file(), f
    tidy = pd.read_csv(tmp_path / "report" / "conditions.csv")
    assert {"group", "perturbation", "direction", "level", "dprime", "correction", "ceiling"} <= set(tidy.columns)
    assert res.attention["pass_rate"].tolist() == [1.0, 1.0]
    assert "loglinear" in (tmp_path / "report" / "report.md").read_text()
    mm = fit_mixed_model(res.data, cross_checks=False)
    assert set(mm["group"]) == {"angular_momentum", "takeoff"}
    assert mm["method"].str.contains("Gauss-Hermite").all()


def test_psychometric_glm_cluster_robust_ses():
    """Participants who differ in criterion: the pooled GLM's binomial SEs are too small; the
    participant-clustered ones grow, the estimates stay. With identical participants both agree."""
    rng = np.random.default_rng(8)

    def cohort(spread):
        rows = []
        for i in range(20):
            c = rng.normal(0.5, spread)
            for lv in (0, 10, 20, 30, 40):
                p = norm.cdf(0.05 * lv - c)
                for _ in range(30):
                    rows.append(dict(participant_id=f"P{i}", kind="test", group="takeoff",
                                     perturbation="none" if lv == 0 else "takeoff",
                                     direction="none" if lv == 0 else "increase", nominal_level=float(lv),
                                     incorrect=int(rng.random() < p)))
        return pd.DataFrame(rows)

    het = cohort(0.8)
    cl = fit_psychometric_glms(het).iloc[0]
    md = fit_psychometric_glms(het, se="model").iloc[0]
    assert cl["se_type"] == "cluster" and md["se_type"] == "model"
    assert cl["slope"] == pytest.approx(md["slope"]) and cl["intercept"] == pytest.approx(md["intercept"])
    assert cl["intercept_se"] > 2 * md["intercept_se"]
    hom = cohort(0.0)
    r = fit_psychometric_glms(hom).iloc[0], fit_psychometric_glms(hom, se="model").iloc[0]
    assert r[0]["intercept_se"] == pytest.approx(r[1]["intercept_se"], rel=0.35)
    assert fit_psychometric_glms(het.assign(participant_id="P1")).iloc[0]["se_type"] == "model"  # one cluster


# ------------------------------------------- incomplete sessions, mixed files (issue 12, section 4)
def _rows_of(path: Path) -> list[dict]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def test_incomplete_session_is_analysed_and_listed(tmp_path):
    """A participant who stopped early (after the take-off controls, before the take-off
    condition): the participant bootstrap used to compare resampled control counts with
    the trials of a condition nobody drawn had seen ("counts must satisfy 0 <= k <= n")."""
    _known_dataset(tmp_path / "data")
    f = tmp_path / "data" / "P1" / "S1" / "responses.csv"
    rows = _rows_of(f)
    _write(f, rows[:30])  # ctlA, a25, ctlT done; t20 and the attention check never reached
    res = analyze(tmp_path / "data", tmp_path / "rep", n_boot=300, figures=False, observer_model=False)
    t = res.conditions.set_index("condition").loc["takeoff/increase/20"]
    assert t["n_participants"] == 1 and t["n_trials"] == 10
    # P2 alone is drawn in ~3/4 of the resamples; only those define the take-off condition
    assert 150 < t["n_boot_defined"] < 300
    assert np.isfinite(t["dprime_ci_low"]) and t["dprime_ci_low"] <= t["dprime"] <= t["dprime_ci_high"]
    inc = res.data.incomplete
    assert inc[["participant_id", "n_answered", "n_planned"]].values.tolist() == [["P1", 30, 41]]
    assert res.settings["incomplete_sessions"] == ["P1/S1: 30 of 41 trials (planned: longest session)"]
    assert "P1/S1: 30 of 41 trials" in (tmp_path / "rep" / "report.md").read_text()
    # with the session's plan.csv the planned count comes from it
    plan = pd.DataFrame(dict(trial_index=range(43), kind=["example"] * 2 + ["test"] * 40 + ["attention"]))
    plan.to_csv(f.parent / "plan.csv", index=False)
    d = load_responses(tmp_path / "data")
    assert d.incomplete[["n_planned", "planned_from"]].values.tolist() == [[41, "plan.csv"]]


def test_bootstrap_counts_never_exceed_trials_with_ragged_sessions():
    """Random cohorts of sessions stopped anywhere: every row's interval is computed (k <= n in
    every resample), and the point estimate agrees with the pooled counts."""
    rng = np.random.default_rng(3)
    for rep in range(5):
        rows = []
        for p in range(int(rng.integers(2, 7))):
            stop = int(rng.integers(1, 60))
            for ti in range(stop):
                cell = ti % 4
                pert, d, lv, g = [("none", "none", 0, "angular_momentum"), ("am_abrupt", "increase", 25, "angular_momentum"),
                                  ("none", "none", 0, "takeoff"), ("takeoff", "increase", 20, "takeoff")][cell]
                rows.append(dict(participant_id=f"P{p}", kind="test", group=g, perturbation=pert, direction=d,
                                 nominal_level=float(lv), incorrect=int(rng.random() < 0.5)))
        df = pd.DataFrame(rows)
        tab = condition_table(df, n_boot=200, seed=rep)
        pert = tab[tab["perturbation"] != "none"]
        assert (pert["n_boot_defined"] > 0).all()
        assert (pert["dprime_ci_low"] <= pert["dprime_ci_high"]).all()


def test_file_mixing_two_participants_is_split_with_a_warning(tmp_path):
    _known_dataset(tmp_path / "ok")
    both = _rows_of(tmp_path / "ok" / "P1" / "S1" / "responses.csv") + _rows_of(tmp_path / "ok" / "P2" / "S1" / "responses.csv")
    _write(tmp_path / "mixed" / "P1" / "S1" / "responses.csv", both)
    f = tmp_path / "mixed" / "P1" / "S1" / "responses.csv"
    with pytest.warns(UserWarning, match=rf"{f}: rows of 2 participants in one file \('P1', 'P2'\)"):
        res = analyze(tmp_path / "mixed", tmp_path / "rep", n_boot=100, figures=False, observer_model=False)
    ref = analyze(tmp_path / "ok", None, n_boot=100, figures=False, observer_model=False)
    assert res.data.participants == ["P1", "P2"]
    pd.testing.assert_frame_equal(res.conditions, ref.conditions)
    assert res.settings["mixed_participant_files"] == [f"{f}: P1, P2"]
    assert "P1, P2" in (tmp_path / "rep" / "report.md").read_text()


# ------------------------------------------------------ every bad value: one line, file:line:column
@pytest.mark.parametrize("col, value, problem", [
    ("nominal_level", "inf", "not finite"),
    ("nominal_level", "-5", "negative"),
    ("nominal_level", "abc", "not a finite number"),
    ("nominal_level", "", "empty"),
    ("trial_index", "1e30", "not a non-negative integer"),
    ("trial_index", "inf", "not a non-negative integer"),
    ("trial_index", "-3", "not a non-negative integer"),
    ("trial_index", "2.5", "not a non-negative integer"),
    ("trial_index", "99999999999", "out of range"),
    ("rt_s", "abc", "not a finite time"),
    ("rt_s", "nan", "not a finite time"),
    ("rt_s", "-0.2", "negative"),
    ("rt_s", "", "empty"),
    ("client_rt_s", "inf", "not finite"),
    ("achieved_error", "x", "not a finite number"),
    ("repetition", "-1", "not a non-negative integer"),
    ("kind", "tset", "not practice, test or attention"),
    ("direction", "sideways", "not a known direction"),
    ("response", "", "not 'correct' or 'incorrect'"),
    ("participant_id", "P 1", "not a participant code"),
    ("input", "mouse", "not one of"),
    ("condition", "takeoff/increase/99", "inconsistent"),
    ("rated_correct", "2", "inconsistent with the response"),
])
def test_every_bad_value_is_one_line_naming_file_line_column(tmp_path, col, value, problem):
    _known_dataset(tmp_path / "ok")
    rows = _rows_of(tmp_path / "ok" / "P2" / "S1" / "responses.csv")
    rows[15][col] = value  # an am_abrupt trial; file line 17
    f = tmp_path / "bad" / "responses.csv"
    _write(f, rows)
    with pytest.raises(StudyDataError) as ei:
        load_responses(f.parent)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(f"{f}:17: column {col}: value {value!r} is "), msg
    assert problem in msg, msg
    assert ei.value.line == 17 and ei.value.column == col and ei.value.path == str(f)
    # and the CLI prints it as its one error line, exit status 2
    from mocomp.cli import main

    assert main(["study", "analyze", str(f.parent), "-o", str(tmp_path / "r"), "--no-figures"]) == 2


def test_unperturbed_level_must_be_zero_and_direction_match(tmp_path):
    _known_dataset(tmp_path / "ok")
    rows = _rows_of(tmp_path / "ok" / "P1" / "S1" / "responses.csv")
    rows[0]["nominal_level"] = "5"  # a control (perturbation none)
    _write(tmp_path / "a" / "responses.csv", rows)
    with pytest.raises(StudyDataError, match=r"responses\.csv:2: column nominal_level: value '5' is not 0"):
        load_responses(tmp_path / "a")
    rows = _rows_of(tmp_path / "ok" / "P1" / "S1" / "responses.csv")
    rows[12]["direction"] = "none"  # a perturbed motion without direction
    _write(tmp_path / "b" / "responses.csv", rows)
    with pytest.raises(StudyDataError, match=r"responses\.csv:14: column direction: value 'none' is inconsistent"):
        load_responses(tmp_path / "b")


def test_latin1_byte_is_one_line_naming_file_line_column(tmp_path, capsys):
    _known_dataset(tmp_path / "ok")
    f = tmp_path / "ok" / "P1" / "S1" / "responses.csv"
    lines = f.read_bytes().split(b"\n")
    lines[5] = lines[5].replace(b"P1,S1", "Pé,S1".encode("latin-1"), 1)  # a Latin-1 e-acute in participant_id
    f.write_bytes(b"\n".join(lines))
    with pytest.raises(StudyDataError) as ei:
        load_responses(tmp_path / "ok")
    msg = str(ei.value)
    assert msg.startswith(f"{f}:6: column participant_id: value 'Pé' is not UTF-8 (byte 0xe9"), msg
    assert "\n" not in msg
    from mocomp.cli import main

    assert main(["study", "analyze", str(tmp_path / "ok"), "-o", str(tmp_path / "r"), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{f}:6: column participant_id" in err[0], err


def test_valid_optional_values_are_accepted(tmp_path):
    """Empty optional fields, '12.0' trial indices and harness-style times load; types are numeric."""
    _known_dataset(tmp_path / "ok")
    f = tmp_path / "ok" / "P1" / "S1" / "responses.csv"
    rows = _rows_of(f)
    rows[3].update(trial_index="3.0", client_rt_s="", shown_utc="2026-11-22T02:46:00.178+00:00", condition="none")
    _write(f, rows)
    d = load_responses(tmp_path / "ok")
    assert d.trials["trial_index"].dtype == np.int64 and d.trials["rt_s"].dtype == float
    assert d.trials.loc[3, "trial_index"] == 3


def test_glmm_is_linear_in_participants_and_keeps_its_estimates():
    """No participants x rows incidence matrix (was dense P x M: quadratic memory); the analytic
    (Fisher-identity) gradient reaches the same maximum from any start."""
    rng = np.random.default_rng(4)
    P, C = 40, 3
    g = np.repeat(np.arange(P), C)
    X = np.zeros((P * C, C))
    X[:, 0] = 1
    X[np.arange(P * C), np.tile(np.arange(C), P)] += np.tile(np.arange(C), P) > 0
    n = np.full(P * C, 12)
    k = rng.binomial(n, expit(X @ np.array([-0.5, 0.8, 1.6]) + rng.normal(0, 0.7, P)[g]))
    r = fit_logit_glmm(X, k, n, g)
    assert r.converged and np.all(np.isfinite(r.se))
    # re-fit from a far start: the same optimum
    r2 = fit_logit_glmm(X, k, n, g, start=np.r_[1.0, -1.0, 0.0, np.log(2.0)])
    np.testing.assert_allclose(r2.beta, r.beta, atol=2e-4)
    assert r2.llf == pytest.approx(r.llf, abs=1e-6)


# ------------------------------------------------------------------ separation -> Firth
def test_firth_solves_the_penalised_score_and_matches_ml_for_large_n():
    from study.glmm import fit_firth_logit

    rng = np.random.default_rng(9)
    X = np.column_stack([np.ones(6), np.r_[0, 0, 1, 1, 1, 1], np.r_[0, 0, 0, 0, 1, 1]])
    n = np.full(6, 5.0)
    k = np.array([1, 2, 5, 5, 3, 4], float)  # column 1's level: 10 of 10 -> separated for ML
    r = fit_firth_logit(X, k, n)
    assert r.converged and np.all(np.isfinite(r.beta)) and np.all(np.isfinite(r.se))
    # the modified score is zero at the solution (recomputed here from its definition)
    p = expit(X @ r.beta)
    w = n * p * (1 - p)
    inv = np.linalg.inv(X.T @ (w[:, None] * X))
    h = w * np.einsum("ij,jk,ik->i", X, inv, X)
    np.testing.assert_allclose(X.T @ (k - n * p + h * (0.5 - p)), 0, atol=1e-8)
    # one binomial cell: Firth's estimate is the logit of (k + 1/2) / (n + 1) (known closed form)
    one = fit_firth_logit(np.ones((1, 1)), np.array([7.0]), np.array([7.0]))
    assert one.beta[0] == pytest.approx(np.log(7.5 / 0.5), abs=1e-9)
    # no separation, large n: Firth ~ ML
    import statsmodels.api as sm

    Xb = np.column_stack([np.ones(4), np.r_[0, 1, 0, 1], np.r_[0, 0, 1, 1]])
    nb = np.full(4, 20000.0)
    kb = rng.binomial(20000, expit(Xb @ np.array([-0.4, 0.9, 0.3]))).astype(float)
    ml = sm.GLM(np.column_stack([kb, nb - kb]), Xb, family=sm.families.Binomial()).fit()
    np.testing.assert_allclose(fit_firth_logit(Xb, kb, nb).beta, ml.params, atol=2e-4)


def test_separated_condition_is_reported_and_fitted_by_firth(tmp_path):
    """A condition every participant called incorrect: the ML GLMM said a huge estimate with a NaN
    interval and converged=True; now the report says "separation" and the estimate is finite."""
    spec = {}
    for i in range(6):
        rows, ti = [], 0
        for lv, n_inc in ((0, 3), (25, 10)):  # the 25 % condition: 10 of 10 incorrect for everyone
            for j in range(10):
                rows.append(_row(f"P{i}", "S1", ti, "none" if lv == 0 else "am_abrupt",
                                 "none" if lv == 0 else "increase", lv,
                                 "incorrect" if j < (n_inc if lv else 3 + (i % 2)) else "correct",
                                 "angular_momentum"))
                ti += 1
        _write(tmp_path / "data" / f"P{i}" / "S1" / "responses.csv", rows)
        spec[i] = rows
    with pytest.warns(UserWarning, match="separation"):
        res = analyze(tmp_path / "data", tmp_path / "rep", n_boot=100, figures=False, observer_model=False)
    mm = res.mixed.set_index("term")
    r = mm.loc["am_abrupt/increase/25"]
    assert bool(r["separation"]) and "separation" in r["separation_note"]
    assert np.isfinite(r["estimate"]) and np.isfinite(r["ci_low"]) and np.isfinite(r["ci_high"])
    assert 2 < r["estimate"] < 8 and r["ci_low"] < r["estimate"] < r["ci_high"]
    assert "Firth" in r["method"]
    assert "separation" in (tmp_path / "rep" / "report.md").read_text()


# ------------------------------------------------------------------ aggregated = row-level (issue 12, scaling)
def _unbalanced_cohort(seed=11, P=30, C=4):
    """Bernoulli trial rows of a treatment-coded one-factor design with a random intercept;
    participants see different numbers of trials per condition and some conditions not at all."""
    rng = np.random.default_rng(seed)
    beta = np.array([-0.4, 0.5, 1.2, -0.8])[:C]
    u = rng.normal(0, 0.9, P)
    pid, cond = [], []
    for i in range(P):
        for c in range(C):
            if c and rng.random() < 0.15:
                continue  # a condition this participant never saw
            m = int(rng.integers(1, 9))
            pid += [i] * m
            cond += [c] * m
    pid, cond = np.array(pid), np.array(cond)
    y = (rng.random(len(pid)) < expit(beta[0] + np.where(cond > 0, beta[cond], 0) + u[pid])).astype(float)
    return pid, cond, y, C


def _design(cond, C):
    X = np.zeros((len(cond), C))
    X[:, 0] = 1
    X[np.arange(len(cond)), cond] += cond > 0
    return X


def _cells(pid, cond, y, C):
    key = pid * C + cond
    uk, inv = np.unique(key, return_inverse=True)
    return _design(uk % C, C), np.bincount(inv, weights=y), np.bincount(inv).astype(float), uk // C


def test_gee_from_cell_counts_equals_statsmodels_gee_on_the_trial_rows():
    """fit_gee_exchangeable on (participant, condition) counts = statsmodels GEE (exchangeable,
    robust SEs) on the Bernoulli rows, to 1e-8: estimates, SEs and the working correlation."""
    import statsmodels.api as sm

    from study.glmm import fit_gee_exchangeable

    pid, cond, y, C = _unbalanced_cohort()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = sm.GEE(y, _design(cond, C), groups=pid, family=sm.families.Binomial(),
                     cov_struct=sm.cov_struct.Exchangeable()).fit()
    X, k, n, g = _cells(pid, cond, y, C)
    perm = np.random.default_rng(0).permutation(len(k))  # row order does not matter
    r = fit_gee_exchangeable(X[perm], k[perm], n[perm], g[perm])
    assert r.converged
    assert abs(ref.model.cov_struct.dep_params) > 0.02  # the correlation term is exercised
    np.testing.assert_allclose(r.beta, ref.params, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(r.se, ref.bse, rtol=1e-8, atol=1e-10)
    assert r.rho == pytest.approx(ref.model.cov_struct.dep_params, rel=1e-8)


def test_glmm_on_cell_counts_equals_the_glmm_on_bernoulli_rows():
    """The marginal likelihood of Bernoulli rows with equal covariates is the binomial one of their
    counts (up to the constant sum log C(n, k)): fitting the counts (unbalanced, unsorted) and the
    trial rows themselves (n = 1 each) gives the same estimates and SEs to 1e-8."""
    pid, cond, y, C = _unbalanced_cohort(seed=5)
    X, k, n, g = _cells(pid, cond, y, C)
    perm = np.random.default_rng(1).permutation(len(k))
    a = fit_logit_glmm(X[perm], k[perm], n[perm], g[perm])
    b = fit_logit_glmm(_design(cond, C), y, np.ones(len(y)), pid, start=np.r_[a.beta, np.log(a.sigma)])
    assert a.converged and b.converged
    from scipy.special import gammaln

    const = float(np.sum(gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1)))
    assert a.llf == pytest.approx(b.llf + const, abs=1e-8)
    np.testing.assert_allclose(b.beta, a.beta, rtol=1e-6, atol=1e-6)  # two optimiser runs: their tolerance
    np.testing.assert_allclose(b.se, a.se, rtol=1e-4)  # Hessians by differences of the gradient


def test_loaded_table_holds_one_string_object_per_distinct_value(tmp_path):
    """The reader interns cells across files (10,000 x 88 rows: 1.3 GB of str objects -> pointers):
    the values are unchanged, equal values are one object, and the columns stay object dtype."""
    from study.observers import Observer, simulate_responses, write_responses
    from study.placeholders import make_placeholder_set

    stim = make_placeholder_set(tmp_path / "stim", n_frames=4)
    df = simulate_responses(stim, Observer({}, bias=0.5), n=6, seed=2)
    write_responses(df, tmp_path / "data")
    t = load_responses(tmp_path / "data").trials
    assert len(t) == len(df)
    for col in ("stimulus_set_id", "kind", "group", "stimulus_id", "perturbation", "response", "source_file"):
        assert col == "source_file" or t[col].dtype == object  # as before (source_file: pandas' str dtype)
        if t[col].dtype != object and getattr(t[col].dtype, "storage", None) == "pyarrow":
            # pandas' str dtype on Arrow storage (pyarrow installed): one buffer, no str object per
            # row to intern; to_numpy(object) would make fresh objects, so check the storage instead
            longest = int(t[col].str.len().max())
            per_row = t[col].memory_usage(deep=True, index=False) / len(t)
            assert per_row <= longest + 8, (col, per_row)  # a str object per row costs >= 49 + len bytes
            continue
        vals = t[col].to_numpy(object)
        assert len({id(v) for v in vals}) == len(set(vals)), col
    ref = df.sort_values(["participant_id", "trial_index"]).reset_index(drop=True)
    got = t.sort_values(["participant_id", "trial_index"]).reset_index(drop=True)
    for col in ("participant_id", "stimulus_id", "response", "condition"):
        assert (got[col].astype(str).to_numpy() == ref[col].astype(str).to_numpy()).all(), col


def test_columns_with_many_distinct_values_are_read_unchanged_without_interning(tmp_path, monkeypatch):
    """Past _INTERN_MAX distinct values a column keeps the parser's objects: same table either way."""
    import study.analysis as sa
    from study.observers import Observer, simulate_responses, write_responses
    from study.placeholders import make_placeholder_set

    stim = make_placeholder_set(tmp_path / "stim", n_frames=4)
    write_responses(simulate_responses(stim, Observer({}, bias=0.5), n=5, seed=3), tmp_path / "data")
    a = load_responses(tmp_path / "data").trials
    monkeypatch.setattr(sa, "_INTERN_MAX", 3)
    b = load_responses(tmp_path / "data").trials
    pd.testing.assert_frame_equal(a, b)
    assert len({id(v) for v in b["stimulus_id"]}) > len(set(b["stimulus_id"]))  # not interned past the cap


# ------------------------------------------- mean of per-participant d' (issue 19 item 6)
def _mean_dprime_dataset(root: Path):
    """One condition (am_abrupt/increase/25) and its group's controls, 4 + 4 trials each.

    hits/4 and false alarms/4: P1 4 and 0 (rates 1 and 0: the correction decides), P2 2 and 1,
    P3 3 and 2; P4 saw only controls (no d' of their own for the condition).
    """
    spec = {"P1": (4, 0), "P2": (2, 1), "P3": (3, 2), "P4": (None, 1)}
    for pid, (hits, fas) in spec.items():
        rows, ti = [], 0
        for i in range(4):
            rows.append(_row(pid, "S1", ti, "none", "none", 0, "incorrect" if i < fas else "correct",
                             "angular_momentum"))
            ti += 1
        for i in range(4 if hits is not None else 0):
            rows.append(_row(pid, "S1", ti, "am_abrupt", "increase", 25, "incorrect" if i < hits else "correct",
                             "angular_momentum"))
            ti += 1
        _write(root / pid / "S1" / "responses.csv", rows)


def test_mean_of_participant_dprimes_hand_computed(tmp_path):
    """Known counts per participant, d' worked out by hand from a z table.

    log-linear (Hautus 1995: (k + 0.5) / (n + 1)), n = 4 per cell:
      P1: H = 4.5/5 = 0.9, F = 0.5/5 = 0.1   d' = 2 z(0.9) = 2 x 1.2815515655 = 2.5631031311
      P2: H = 2.5/5 = 0.5, F = 1.5/5 = 0.3   d' = 0 - z(0.3) = 0.5244005127
      P3: H = 3.5/5 = 0.7, F = 2.5/5 = 0.5   d' = z(0.7) - 0 = 0.5244005127
      mean = 3.6119041565 / 3 = 1.2039680522; SD (n - 1) = sqrt(2.7708651 / 2) = 1.1770455
      pooled (P1-P3 hits 9/12; P1-P4 false alarms 4/16): z(9.5/13) - z(4.5/17)
    1/(2N) (Macmillan & Kaplan 1985: only 0 -> 1/(2n), 1 -> 1 - 1/(2n)):
      P1: H = 7/8, F = 1/8                   d' = 2 z(0.875) = 2 x 1.1503493804 = 2.3006987608
      P2: H = 0.5, F = 0.25                  d' = z(0.75) = 0.6744897502
      P3: H = 0.75, F = 0.5                  d' = 0.6744897502
      mean = 3.6496782612 / 3 = 1.2165594204
    """
    _mean_dprime_dataset(tmp_path)
    data = load_responses(tmp_path)
    key = ("angular_momentum", "am_abrupt/increase/25")
    ll = condition_table(data, correction="loglinear", n_boot=300, seed=4, headline="mean").set_index(
        ["group", "condition"]).loc[key]
    assert ll["dprime_mean"] == pytest.approx(1.2039680522, abs=1e-9)
    assert ll["dprime_mean_sd"] == pytest.approx(1.1770455, abs=1e-6)
    assert ll["n_participants_dprime"] == 3 and ll["n_participants"] == 3
    assert ll["dprime"] == pytest.approx(norm.ppf(9.5 / 13) - norm.ppf(4.5 / 17))  # pooled, unchanged
    assert ll["headline"] == "mean" and ll["dprime_headline"] == ll["dprime_mean"]
    assert (ll["dprime_headline_ci_low"], ll["dprime_headline_ci_high"]) == (ll["dprime_mean_ci_low"],
                                                                            ll["dprime_mean_ci_high"])
    assert ll["dprime_mean_ci_low"] <= ll["dprime_mean"] <= ll["dprime_mean_ci_high"]
    # a resample's mean lies between the smallest and the largest individual d'
    assert 0.5244005127 - 1e-9 <= ll["dprime_mean_ci_low"] and ll["dprime_mean_ci_high"] <= 2.5631031311 + 1e-9
    h2 = condition_table(data, correction="1/(2N)", n_boot=300, seed=4).set_index(["group", "condition"]).loc[key]
    assert h2["dprime_mean"] == pytest.approx(1.2165594204, abs=1e-9)
    # the same d' as participants_condition.csv gives each participant, averaged
    pc = participant_dprimes(data, correction="loglinear", n_boot=10)
    assert pc["dprime"].mean() == pytest.approx(ll["dprime_mean"], abs=1e-12)
    assert sorted(pc["dprime"].round(9)) == [0.524400513, 0.524400513, 2.563103131]
    pooled_head = condition_table(data, n_boot=50).set_index(["group", "condition"]).loc[key]  # the default
    assert pooled_head["headline"] == "pooled" and pooled_head["dprime_headline"] == pooled_head["dprime"]
    assert pooled_head["dprime_headline_ci_low"] == pooled_head["dprime_ci_low"]
    # each participant's ceiling: z(4.5/5) - z(0.5/5) = 2.5631031311 for 4 + 4 trials, all three alike
    assert ll["dprime_mean_ceiling"] == pytest.approx(2.5631031311, abs=1e-9)
    with pytest.raises(ValueError, match="headline"):
        condition_table(data, n_boot=10, headline="median")


def test_mean_dprime_bootstrap_is_the_participant_bootstrap_of_the_mean(tmp_path):
    """The vectorised interval equals a plain loop over the same participant resamples."""
    _mean_dprime_dataset(tmp_path)
    data = load_responses(tmp_path)
    n_boot, seed = 300, 7
    row = condition_table(data, n_boot=n_boot, seed=seed).set_index("condition").loc["am_abrupt/increase/25"]
    d_of = {"P1": 2 * norm.ppf(0.9), "P2": -norm.ppf(0.3), "P3": norm.ppf(0.7)}  # P4: no d'
    parts = ["P1", "P2", "P3", "P4"]
    rng = np.random.default_rng(seed)
    means = []
    for b0 in range(0, n_boot, 256):  # the same draws, in the same chunks, as the analysis
        W = rng.multinomial(4, np.full(4, 0.25), size=min(256, n_boot - b0))
        for w in W:
            drawn = [p for p, k in zip(parts, w) for _ in range(k) if p in d_of]
            means.append(np.mean([d_of[p] for p in drawn]) if drawn else np.nan)
    lo, hi = np.nanquantile(means, [0.025, 0.975])
    assert row["dprime_mean_ci_low"] == pytest.approx(lo, abs=1e-12)
    assert row["dprime_mean_ci_high"] == pytest.approx(hi, abs=1e-12)


def test_report_states_the_headline_and_lists_both_dprimes(tmp_path):
    _mean_dprime_dataset(tmp_path / "data")
    res = analyze(tmp_path / "data", tmp_path / "rep", n_boot=50, figures=False, mixed=False, observer_model=False,
                  headline="mean")
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "headline d': the mean of the per-participant d' (Macmillan & Creelman's recommendation)" in md
    assert "| mean d' (headline) | 95% CI | pooled d' | 95% CI |" in md
    r = res.conditions.set_index("condition").loc["am_abrupt/increase/25"]
    assert f"**{r['dprime_mean']:.2f} (n=3)**" in md and f"| {r['dprime']:.2f} |" in md
    assert res.settings["headline"] == "mean"
    res2 = analyze(tmp_path / "data", tmp_path / "rep2", n_boot=50, figures=True, mixed=False, observer_model=False)
    assert res2.settings["headline"] == "pooled"  # the default
    md2 = (tmp_path / "rep2" / "report.md").read_text()
    assert "headline d': the pooled d'" in md2 and "| pooled d' (headline) | 95% CI | mean d' | 95% CI |" in md2


def test_withdrawn_sessions_are_left_out_and_listed(tmp_path, capsys):
    from mocomp.cli import main
    from study.session import WITHDRAWN_FILE

    _known_dataset(tmp_path)
    full = analyze(tmp_path, None, n_boot=20, figures=False, mixed=False, observer_model=False)
    assert full.settings["n_participants"] == 2 and full.settings["withdrawn_sessions"] == []
    (tmp_path / "P2" / "S1" / WITHDRAWN_FILE).write_text(
        '{"participant_id": "P2", "session_id": "S1", "withdrawn_utc": "2026-12-01T10:00:00.000+00:00", '
        '"by": "participant", "reason": "debrief screen"}')
    res = analyze(tmp_path, tmp_path / "rep", n_boot=20, figures=False, mixed=False, observer_model=False)
    assert res.data.participants == ["P1"] and res.settings["n_participants"] == 1
    assert res.data.withdrawn[0]["participant_id"] == "P2" and res.data.withdrawn[0]["by"] == "participant"
    assert res.settings["withdrawn_sessions"] == ["P2/S1: withdrawn 2026-12-01T10:00:00.000+00:00 by participant "
                                                  "(debrief screen)"]
    a = res.conditions.set_index("condition").loc["am_abrupt/increase/25"]
    assert a["n_trials"] == 10 and a["hit_rate"] == pytest.approx(0.6)  # P1's 6 of 10 only
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "**withdrawn sessions** (left out unread" in md and "P2/S1: withdrawn" in md
    assert main(["study", "analyze", str(tmp_path), "-o", str(tmp_path / "rep3"), "--n-boot", "20",
                 "--no-figures", "--no-observer-model"]) == 0
    assert "1 participants (1 withdrawn session(s) left out)" in capsys.readouterr().out
    # a withdrawn session is not even read: a broken file there does not stop the analysis
    (tmp_path / "P2" / "S1" / "responses.csv").write_text("garbage\n")
    assert analyze(tmp_path, None, n_boot=20, figures=False, mixed=False, observer_model=False).settings[
        "n_participants"] == 1
    (tmp_path / "P1" / "S1" / WITHDRAWN_FILE).write_text("{}")
    with pytest.raises(StudyDataError, match="every session here \\(2\\) is withdrawn"):
        load_responses(tmp_path)


def test_pooled_headline_is_the_better_estimate_at_this_design(tmp_path):
    """Why the default headline is the pooled d': with the paper's design (each perturbed motion twice,
    one base: 2 signal trials per participant and condition) the correction shrinks and caps every
    individual d', so their mean is biased low and its CI misses the truth; the pooled d' is not.
    20 simulated observers with the same sensitivities and criteria spread over 0-1.2."""
    from study.design import DesignConfig
    from study.observers import Observer, Psychometric, simulate_cohort
    from study.placeholders import PAPER_LEVELS, make_placeholder_set

    true = {("am_abrupt", "increase"): Psychometric(36, 2.0), ("am_abrupt", "decrease"): Psychometric(30, 2.0),
            ("am_smooth", "increase"): Psychometric(48, 2.5), ("am_smooth", "decrease"): Psychometric(60, 2.0),
            ("takeoff", "increase"): Psychometric(33, 2.5)}
    stim = make_placeholder_set(tmp_path / "s", PAPER_LEVELS, base_clips=("backward",), n_frames=3)
    obs = [Observer(true, bias=b, lapse=0.0) for b in np.linspace(0.0, 1.2, 20)]
    simulate_cohort(stim, obs, tmp_path / "d", design=DesignConfig(), seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c = condition_table(load_responses(tmp_path / "d"), n_boot=400, seed=0)
    c = c[c["perturbation"] != "none"]
    d_true = np.array([float(obs[0].expected_dprime(p, d, x))
                       for p, d, x in zip(c["perturbation"], c["direction"], c["level"])])
    assert (c["n_trials"] == 40).all()  # 2 per participant and condition
    err_pooled, err_mean = np.mean(c["dprime"] - d_true), np.mean(c["dprime_mean"] - d_true)
    cover = {k: np.mean((c[k + "_ci_low"] <= d_true) & (d_true <= c[k + "_ci_high"])) for k in ("dprime", "dprime_mean")}
    assert abs(err_pooled) < 0.1 and err_mean < -0.2, (err_pooled, err_mean)
    assert cover["dprime"] >= 0.8 and cover["dprime_mean"] <= 0.7, cover
