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


def test_cli_observer_model_recovers_the_cohort(cohort, tmp_path, capsys):
    """`mocomp study analyze` writes observer_model.csv: every generating parameter of the
    simulated cohort (thresholds, slopes, bias, lapse) inside its 95% CI, estimates close."""
    from mocomp.cli import main

    root, _, _ = cohort
    assert main(["study", "analyze", str(root / "data"), "-o", str(tmp_path / "cli"), "--n-boot", "200",
                 "--no-figures"]) == 0
    tab = pd.read_csv(tmp_path / "cli" / "observer_model.csv", keep_default_na=False, na_values=[""])
    tab["series"] = tab["series"].fillna("")
    got = {(r["name"], r["series"]): r for _, r in tab.iterrows()}
    truth = {("bias", ""): OBSERVER.bias, ("lapse", ""): OBSERVER.lapse}
    for (p, d), ps in TRUE.items():
        truth[("threshold", f"{p}/{d}")] = ps.threshold
        truth[("slope", f"{p}/{d}")] = ps.slope
    assert set(got) == set(truth) and len(tab) == 12
    for key, v in truth.items():
        r = got[key]
        assert r["ci_low"] <= v <= r["ci_high"], (key, v, r[["estimate", "ci_low", "ci_high"]].tolist())
        assert r["ci_low"] <= r["estimate"] <= r["ci_high"]
    for (p, d), ps in TRUE.items():  # and the point estimates are close (not just wide intervals)
        assert got[("threshold", f"{p}/{d}")]["estimate"] == pytest.approx(ps.threshold, rel=0.25)
    assert got[("bias", "")]["estimate"] == pytest.approx(0.6, abs=0.2)
    assert set(tab["ci_method"]) == {"profile"} and tab["converged"].all()
    assert "## Observer model" in (tmp_path / "cli" / "report.md").read_text()
    # the same numbers as the library call
    fit = fit_observer_model(load_responses(root / "data"))
    np.testing.assert_allclose(tab["estimate"], fit.params["estimate"], rtol=1e-6)


def test_analysis_recovers_observer_parameters(cohort, tmp_path):
    root, stim, _ = cohort
    res = analyze(root / "data", tmp_path / "report", n_boot=1000, seed=3, figures=False, mixed=False,
                  observer_model=False)
    assert not (tmp_path / "report" / "observer_model.csv").exists()
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


def _binomial_cohort(rng, observer, levels, n_per_cell):
    """Test trials drawn straight from the observer model (no harness): for calibration studies."""
    rows = []
    for g, perts in (("angular_momentum", ("am_abrupt", "am_smooth")), ("takeoff", ("takeoff",))):
        cells = [("none", "none", 0.0)] + [(p, d, float(x)) for (p, d), xs in levels.items() if p in perts for x in xs]
        for p, d, x in cells:
            k = rng.binomial(n_per_cell, float(observer.p_incorrect(p, d, x)))
            rows.append(pd.DataFrame(dict(kind="test", group=g, perturbation=p, direction=d, nominal_level=x,
                                          incorrect=(np.arange(n_per_cell) < k).astype(int))))
    return pd.concat(rows, ignore_index=True)


def test_observer_fit_intervals_are_calibrated():
    """Coverage of the profile-likelihood 95% CIs over 16 simulated cohorts (12 parameters each).

    The cohort of ``cohort`` above (20 participants x 3 clips x 2 showings = 120 trials per
    cell). Wald intervals of the same fit covered ~76% here (whole fits lost to a lapse on
    its boundary); the profile intervals cover ~95% (measured: 0.958 over 100 cohorts).
    """
    from study.placeholders import PAPER_LEVELS

    hits = []
    for seed in range(16):
        df = _binomial_cohort(np.random.default_rng(seed), OBSERVER, PAPER_LEVELS, 120)
        fit = fit_observer_model(df)
        assert fit.converged
        assert (fit.params["ci_low"] <= fit.params["estimate"]).all()
        assert (fit.params["estimate"] <= fit.params["ci_high"]).all()
        for (p, d), ps in TRUE.items():
            hits += [fit.contains("threshold", ps.threshold, f"{p}/{d}"), fit.contains("slope", ps.slope, f"{p}/{d}")]
        hits += [fit.contains("bias", OBSERVER.bias), fit.contains("lapse", OBSERVER.lapse)]
        lap = fit.params.set_index("name").loc["lapse"]
        if lap["estimate"] < 1e-6:  # on its boundary: the interval starts there
            assert lap["ci_low"] == 0.0
    coverage = np.mean(hits)
    assert 0.90 <= coverage <= 0.99, coverage


def test_observer_fit_bootstrap_and_wald_options(cohort):
    root, _, _ = cohort
    data = load_responses(root / "data")
    prof = fit_observer_model(data)
    boot = fit_observer_model(data, ci_method="bootstrap", n_boot=40, seed=1)
    again = fit_observer_model(data, ci_method="bootstrap", n_boot=40, seed=1)
    pd.testing.assert_frame_equal(boot.params, again.params)  # seeded
    assert boot.settings["n_boot"] == 40 and boot.settings["failed_resamples"] <= 2
    np.testing.assert_allclose(boot.params["estimate"], prof.params["estimate"])  # same point estimates
    assert (boot.params["ci_method"] == "bootstrap").all()
    wald = fit_observer_model(data, ci_method="wald")
    # where the likelihood is nearly quadratic (thresholds), Wald and profile agree closely
    t = prof.params["name"] == "threshold"
    np.testing.assert_allclose(np.log(wald.params.loc[t, "ci_high"]), np.log(prof.params.loc[t, "ci_high"]),
                               atol=0.08)
    with pytest.raises(ValueError, match="ci_method"):
        fit_observer_model(data, ci_method="bayes")
    # one criterion per error group (the generating bias is shared: both intervals hold it)
    grp = fit_observer_model(data, criterion="group").params
    b = grp[grp["name"] == "bias"]
    assert list(b["series"]) == ["angular_momentum", "takeoff"]
    assert ((b["ci_low"] <= OBSERVER.bias) & (OBSERVER.bias <= b["ci_high"])).all()


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
