"""Table 2 of the flips paper (section 7): d' recomputed from the published mean ratings.

Pins how the paper computed its "sensitivity levels": d' = z(r0) - z(r) with r
the percentage rated correct and r0 the 0 % rating of the same group, no
correction. Every published value must be reproduced within the rounding of
the printed ratings and d', and with ONE unrounded control rating per group.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from study.paper import TABLE2_CONTROL_RATING, reproduce_table2, table2, write_table2_responses
from study.sdt import dprime_counts, dprime_from_ratings


def test_table2_has_every_published_cell():
    t = table2()
    assert len(t) == 19  # 15 angular-momentum cells (one not reported) + 4 take-off cells
    assert set(t["group"]) == {"angular_momentum", "takeoff"}
    assert t.groupby(["perturbation", "direction"]).size().to_dict() == {
        ("am_abrupt", "decrease"): 4, ("am_abrupt", "increase"): 4, ("am_smooth", "decrease"): 4,
        ("am_smooth", "increase"): 3, ("takeoff", "increase"): 4}


def test_known_cells_by_hand():
    # 72 % vs 41 %: z(.72) - z(.41) = 0.5828 + 0.2275 = 0.810 (published .81)
    assert dprime_from_ratings(72, 41) == pytest.approx(0.8104, abs=1e-3)
    assert dprime_from_ratings(72, 22) == pytest.approx(1.355, abs=1e-3)  # published 1.4
    assert dprime_from_ratings(63, 81) == pytest.approx(-0.546, abs=1e-3)  # published -.53
    assert dprime_from_ratings(63, 63) == 0.0


def test_every_published_dprime_reproduced_within_rounding():
    cells, groups = reproduce_table2()
    assert cells["consistent"].all(), cells.loc[~cells["consistent"]]
    # the printed ratings alone already give the printed d' to within 0.06
    assert np.abs(cells["deviation"]).max() < 0.06
    two = cells["decimals"] == 2
    assert np.abs(cells.loc[two, "deviation"]).max() < 0.025
    # and a single unrounded control rating per group explains all of its cells
    assert groups["consistent"].all()
    am = groups.set_index("group").loc["angular_momentum"]
    assert 71.5 <= am["control_lo"] < am["control_hi"] <= 72.5
    assert am["control_lo"] == pytest.approx(72.03, abs=0.01) and am["control_hi"] == pytest.approx(72.36, abs=0.01)


@pytest.mark.parametrize("name,formula", [
    ("sign flipped", lambda r0, r: -dprime_from_ratings(r0, r)),
    ("2AFC scaling z/sqrt2", lambda r0, r: dprime_from_ratings(r0, r) / np.sqrt(2)),
    ("logit instead of probit", lambda r0, r: np.log(r0 / (100 - r0)) - np.log(r / (100 - r))),
    ("against 50 % instead of the controls", lambda r0, r: -norm.ppf(np.asarray(r, float) / 100)),
])
def test_other_formulas_do_not_reproduce_table2(name, formula):
    cells, groups = reproduce_table2(formula)
    assert not groups["consistent"].all(), name


def test_counts_route_equals_ratings_route_without_correction():
    # d' from counts (hits = "incorrect" on perturbed) equals the ratings formula
    n = 76
    k_pert = np.array([45, 59, 17])  # "incorrect" answers
    k_ctl = 21
    d = dprime_counts(k_pert, n, k_ctl, n, "none").dprime
    r = 100 * (1 - k_pert / n)
    r0 = 100 * (1 - k_ctl / n)
    np.testing.assert_allclose(d, dprime_from_ratings(r0, r), atol=1e-12)
    assert TABLE2_CONTROL_RATING == {"angular_momentum": 72, "takeoff": 63}


def test_table2_through_mocomp_study_analyze(tmp_path, capsys):
    """Table-2-shaped responses through the CLI's condition table (not the ratings helper): with the
    paper's convention (no correction: no rate is 0 or 1) every published d' within rounding."""
    import pandas as pd

    from mocomp.cli import main

    from study.analysis import condition_table, load_responses

    write_table2_responses(tmp_path / "data")
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "rep"), "--correction", "none",
                 "--n-boot", "20", "--no-figures", "--no-observer-model"]) == 0
    assert "20 participants" in capsys.readouterr().out
    data = load_responses(tmp_path / "data")
    out = {"none": pd.read_csv(tmp_path / "rep" / "conditions.csv")}
    for corr in ("1/(2N)", "loglinear"):
        out[corr] = condition_table(data, correction=corr, n_boot=20)
    c = out["none"]
    ctl = c[c["perturbation"] == "none"].set_index("group")
    assert ctl["pct_rated_correct"].to_dict() == {"angular_momentum": 72.0, "takeoff": 63.0}
    assert set(ctl["n_trials"]) == {100} and (c["control_source"] == "group").all()
    pert = c[c["perturbation"] != "none"]
    t = table2().merge(pert, on=["group", "perturbation", "direction", "level"], how="left", validate="1:1")
    assert t["dprime"].notna().all() and len(t) == 19
    np.testing.assert_array_equal(t["pct_rated_correct"], t["rating"])
    np.testing.assert_allclose(t["dprime"], dprime_from_ratings(t["control_rating"], t["rating"]), atol=1e-12)
    dev = (t["dprime"] - t["dprime_published"]).abs()
    assert dev.max() < 0.06 and dev[t["decimals"] == 2].max() < 0.025, t[["perturbation", "direction", "level",
                                                                           "dprime", "dprime_published"]]
    # 1/(2N) only moves rates of 0 or 1 (none here): identical; log-linear shrinks every |d'| a little
    np.testing.assert_allclose(out["1/(2N)"]["dprime"], c["dprime"], atol=1e-12)
    ll = out["loglinear"][out["loglinear"]["perturbation"] != "none"]
    nz = pert["dprime"].abs() > 1e-9
    assert (ll["dprime"].abs()[nz].to_numpy() < pert["dprime"].abs()[nz].to_numpy()).all()
    assert (pert["dprime"].abs()[nz].to_numpy() - ll["dprime"].abs()[nz].to_numpy()).max() < 0.02
