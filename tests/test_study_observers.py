"""Simulated cohort: plan -> harness (controller) -> CSV -> analysis recovers the observers' parameters.

Observers: d'_s(x) = (x / threshold_s) ** slope_s per error type, criterion ``bias``,
``lapse`` rate (study.observers). Each simulated participant answers through
TrialController over a real Session (the code path of the app), writing the
same responses.csv that people produce.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from study.analysis import analyze, fit_psychometric_glms, load_responses
from study.design import DesignConfig
from study.observers import Observer, Psychometric, fit_observer_model, simulate_cohort
from study.placeholders import make_placeholder_set

TRUE = {("am_abrupt", "increase"): Psychometric(30, 2.0), ("am_abrupt", "decrease"): Psychometric(24, 1.5),
        ("am_smooth", "increase"): Psychometric(40, 2.5), ("am_smooth", "decrease"): Psychometric(45, 1.5),
        ("takeoff", "increase"): Psychometric(25, 2.0)}
OBSERVER = Observer(TRUE, bias=0.6, lapse=0.05)


@pytest.fixture(scope="module")
def cohort(tmp_path_factory):
    root = tmp_path_factory.mktemp("cohort")
    stim = make_placeholder_set(root / "stimuli", base_clips=("fwd", "bwd", "side"), n_frames=4)
    folders = simulate_cohort(stim, OBSERVER, root / "data", n=20, design=DesignConfig(n_attention=2), seed=7)
    return root, stim, folders


def test_observers_use_the_harness_path(cohort):
    root, stim, folders = cohort
    assert len(folders) == 20
    f = folders[0]
    assert (f / "plan.csv").exists() and (f / "plan.json").exists()
    rows = pd.read_csv(f / "responses.csv", keep_default_na=False)
    plan = pd.read_csv(f / "plan.csv", keep_default_na=False)
    assert list(rows["trial_index"]) == list(plan.loc[plan["kind"] != "example", "trial_index"])
    assert set(rows["input"]) == {"observer"}
    ev = (f / "events.jsonl").read_text()
    assert '"example_viewed"' in ev and '"finished"' in ev
    # each participant has its own plan (own seed)
    other = pd.read_csv(folders[1] / "plan.csv", keep_default_na=False)
    assert list(other["stimulus_id"]) != list(plan["stimulus_id"])


def test_analysis_recovers_observer_parameters(cohort, tmp_path):
    root, stim, _ = cohort
    res = analyze(root / "data", tmp_path / "report", n_boot=1000, seed=3, figures=False, mixed=False)
    # 1. full observer model: every generating parameter inside its 95% CI
    fit = fit_observer_model(res.data)
    for (p, d), ps in TRUE.items():
        s = f"{p}/{d}"
        assert fit.contains("threshold", ps.threshold, s), fit.params
        assert fit.contains("slope", ps.slope, s), fit.params
    assert fit.contains("bias", OBSERVER.bias)
    assert fit.contains("lapse", OBSERVER.lapse)
    # and the point estimates are close (not just wide intervals)
    for (p, d), ps in TRUE.items():
        assert fit.value("threshold", f"{p}/{d}") == pytest.approx(ps.threshold, rel=0.25)
    assert fit.value("bias") == pytest.approx(0.6, abs=0.2)
    # 2. condition d' (group-level, participant bootstrap) covers the d' the observer implies
    c = res.conditions[res.conditions["perturbation"] != "none"]
    expected = np.array([float(OBSERVER.expected_dprime(p, d, lv))
                         for p, d, lv in zip(c["perturbation"], c["direction"], c["level"])])
    inside = (c["dprime_ci_low"].to_numpy() <= expected) & (expected <= c["dprime_ci_high"].to_numpy())
    assert inside.mean() >= 0.85, c.assign(expected=expected)[["condition", "dprime", "dprime_ci_low",
                                                                "dprime_ci_high", "expected"]]
    # log-linear correction shrinks d' towards 0 but the estimate tracks the truth
    assert np.corrcoef(c["dprime"], expected)[0, 1] > 0.95
    # 3. mean ratings: the rated-correct rate of the controls is Phi(bias) (lapses halfway to 50%)
    ctl = res.conditions[res.conditions["perturbation"] == "none"]
    p_ctl = 100 * (1 - float(OBSERVER.p_incorrect("none", "none", 0)))
    assert ((ctl["pct_ci_low"] <= p_ctl) & (p_ctl <= ctl["pct_ci_high"])).all()
    # 4. per-participant d' (levels pooled) intervals cover the observer's pooled d' for most participants
    ps = res.participants_series
    lv = {k: stim.table.loc[(stim.table["perturbation"] == k[0]) & (stim.table["direction"] == k[1]),
                            "nominal_level"].unique() for k in TRUE}
    f0 = float(OBSERVER.p_incorrect("none", "none", 0))
    pooled = {f"{k[0]}/{k[1]}": np.mean([OBSERVER.p_incorrect(k[0], k[1], x) for x in lv[k]]) for k in TRUE}
    from scipy.stats import norm

    exp_pp = np.array([norm.ppf(pooled[c_]) - norm.ppf(f0) for c_ in ps["condition"]])
    cover = ((ps["ci_low"] <= exp_pp) & (exp_pp <= ps["ci_high"])).mean()
    assert cover >= 0.8


def test_probit_glm_recovers_a_linear_observer(tmp_path):
    """With slope (exponent) 1 and no lapses d'(x) = x / threshold: exactly the probit GLM."""
    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (10, 20, 30, 40)},
                                base_clips=tuple(f"c{i}" for i in range(6)), n_frames=4)
    obs = Observer({("takeoff", "increase"): Psychometric(threshold=25.0, slope=1.0)}, bias=0.4, lapse=0.0)
    simulate_cohort(stim, obs, tmp_path / "d", n=12, design=DesignConfig(groups={"takeoff": ("takeoff",)}),
                    seed=11)
    fit = fit_psychometric_glms(load_responses(tmp_path / "d")).iloc[0]
    assert fit["threshold_ci_low"] <= 25.0 <= fit["threshold_ci_high"]
    assert fit["threshold"] == pytest.approx(25.0, rel=0.2)
    assert -fit["intercept"] == pytest.approx(0.4, abs=2.5 * fit["intercept_se"])  # criterion


def test_observer_model_basics():
    ps = Psychometric(20, 2)
    assert ps.dprime(20) == pytest.approx(1.0) and ps.dprime(40) == pytest.approx(4.0) and ps.dprime(0) == 0
    o = Observer({("takeoff", "increase"): ps}, bias=0.5, lapse=0.1)
    from scipy.stats import norm

    assert float(o.p_incorrect("none", "none", 0)) == pytest.approx(0.05 + 0.9 * norm.cdf(-0.5))
    assert float(o.expected_dprime("takeoff", "increase", 0)) == 0
    assert float(o.true_dprime("am_smooth", "increase", 50)) == 0  # not listed: undetectable
    with pytest.raises(ValueError):
        Psychometric(0, 1)
    with pytest.raises(ValueError):
        Observer(lapse=1.0)
