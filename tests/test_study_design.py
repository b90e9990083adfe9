"""Trial design (flips paper section 7, Procedure): examples of correct motions first, test
motions random within error groups, groups interleaved, every motion twice; seeds,
counterbalancing, practice, attention checks, breaks."""
from __future__ import annotations

from itertools import permutations

import numpy as np
import pytest

from study.design import DesignConfig, balanced_latin_square, make_plan, participant_seed
from study.placeholders import make_placeholder_set


@pytest.fixture(scope="module")
def stimuli(tmp_path_factory):
    return make_placeholder_set(tmp_path_factory.mktemp("stim"), n_frames=4)


def _test(plan):
    return plan.trials[plan.trials["kind"] == "test"]


def test_paper_procedure(stimuli):
    plan = make_plan(stimuli, participant_id="P1", seed=11)
    t = plan.trials
    ex = t[t["kind"] == "example"]
    # examples first: every unperturbed motion once, and only those
    assert list(t["kind"].iloc[:len(ex)]) == ["example"] * len(ex)
    assert sorted(ex["stimulus_id"]) == sorted(stimuli.unperturbed)
    test = _test(plan)
    # every test motion twice per group it belongs to; controls shown in each group (Table 2's 0 % columns)
    counts = test.groupby(["group", "stimulus_id"]).size()
    assert set(counts) == {2}
    am = test[test["group"] == "angular_momentum"]
    assert set(am["perturbation"]) == {"none", "am_abrupt", "am_smooth"}
    assert set(test.loc[test["group"] == "takeoff", "perturbation"]) == {"none", "takeoff"}
    assert len(test) == 2 * (2 * (1 + 16) + 2 * (1 + 4))
    # two passes, each containing every (group, stimulus) once
    for rep in (1, 2):
        p = test[test["repetition"] == rep]
        assert not p.duplicated(["group", "stimulus_id"]).any()
    assert (np.diff(test["repetition"].to_numpy()) >= 0).all()
    # never the same motion twice in a row
    s = test["stimulus_id"].to_numpy()
    assert not (s[1:] == s[:-1]).any()
    # groups interleaved: within each pass both groups are spread over the whole pass
    p1 = test[test["repetition"] == 1].reset_index(drop=True)
    pos = p1.index[p1["group"] == "takeoff"].to_numpy()
    assert pos.min() < len(p1) * 0.2 and pos.max() > len(p1) * 0.8
    assert np.diff(pos).max() <= 2 * len(p1) / len(pos)
    assert plan.meta["seed"] == 11 and plan.meta["stimulus_set_id"] == stimuli.set_id


def test_deterministic_per_seed_and_random_within_groups(stimuli):
    a = make_plan(stimuli, participant_id="P1", seed=5)
    b = make_plan(stimuli, participant_id="P1", seed=5)
    c = make_plan(stimuli, participant_id="P1", seed=6)
    assert a.to_csv_bytes() == b.to_csv_bytes() and a.sha256 == b.sha256
    assert a.to_csv_bytes() != c.to_csv_bytes()
    # the group sequence (interleaving pattern) is fixed by the design; the order within groups is random
    assert list(_test(a)["group"]) == list(_test(c)["group"])
    assert list(_test(a)["stimulus_id"]) != list(_test(c)["stimulus_id"])
    # order within a group is close to uniformly random: first-shown stimulus of the take-off group over seeds
    firsts = [(_test(make_plan(stimuli, participant_id="P", seed=s)).query("group == 'takeoff'")
               ["stimulus_id"].iloc[0]) for s in range(200)]
    _, n = np.unique(firsts, return_counts=True)
    assert len(n) == 10 and n.min() >= 5  # 10 take-off-group stimuli, each first about 20 times
    assert participant_seed(0, "P1") == participant_seed(0, "P1") != participant_seed(0, "P2")
    assert participant_seed(1, "P1") != participant_seed(0, "P1")


def test_blocked_mixed_and_counterbalanced(stimuli):
    cfg = DesignConfig(interleave="blocked", counterbalance="latin")
    orders = [make_plan(stimuli, cfg, participant_id="P", seed=1, counterbalance_index=i).meta["group_order"]
              for i in range(4)]
    assert orders[0] != orders[1] and orders[0] == orders[2]
    plan = make_plan(stimuli, cfg, participant_id="P", seed=1, counterbalance_index=1)
    g = _test(plan)[_test(plan)["repetition"] == 1]["group"].tolist()
    first = plan.meta["group_order"][0]
    assert g[: g.count(first)] == [first] * g.count(first)  # blocked: one group after the other
    with pytest.raises(ValueError, match="counterbalance_index"):
        make_plan(stimuli, cfg, participant_id="P", seed=1)
    mixed = make_plan(stimuli, DesignConfig(repeat_mode="mixed"), participant_id="P", seed=3)
    t = _test(mixed)
    assert set(t.groupby(["group", "stimulus_id"]).size()) == {2}
    s = t["stimulus_id"].to_numpy()
    assert not (s[1:] == s[:-1]).any()
    own = make_plan(stimuli, DesignConfig(controls="own_group"), participant_id="P", seed=3)
    assert set(_test(own).loc[_test(own)["perturbation"] == "none", "group"]) == {"control"}


def test_counterbalanced_orders_differ_with_the_default_interleave(stimuli):
    """Under interleave='proportional' (default) the group order is a phase: the first group of the
    order leads each pass, and reversing the order moves the group at many positions, not only ties."""
    cfg = DesignConfig(counterbalance="latin")
    assert cfg.interleave == "proportional"
    plans = [make_plan(stimuli, cfg, participant_id="P", seed=1, counterbalance_index=i) for i in (0, 1)]
    orders = [p.meta["group_order"] for p in plans]
    assert orders == [["angular_momentum", "takeoff"], ["takeoff", "angular_momentum"]]
    seqs = [_test(p)["group"].to_numpy() for p in plans]
    for plan, order, g in zip(plans, orders, seqs):
        rep = _test(plan)["repetition"].to_numpy()
        for r in (1, 2):  # each pass starts with the first group of this participant's order
            assert g[rep == r][0] == order[0]
    n_small = int((seqs[0] == "takeoff").sum())  # 2 passes x (2 controls + 8) = 20
    changed = int((seqs[0] != seqs[1]).sum())
    # every take-off trial changes place (the most that can change is 2 x 20 of the 88)
    assert len(seqs[0]) == 88 and n_small == 20 and changed == 2 * n_small
    # still proportional: the take-off group spread over each whole pass in both orders
    for plan in plans:
        p1 = _test(plan)[_test(plan)["repetition"] == 1].reset_index(drop=True)
        pos = p1.index[p1["group"] == "takeoff"].to_numpy()
        assert pos.min() <= 3 and pos.max() >= len(p1) - 4 and np.diff(pos).max() <= 2 * len(p1) / len(pos)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_balanced_latin_square(n):
    sq = balanced_latin_square(n)
    assert sq.shape == ((n if n % 2 == 0 else 2 * n), n)
    for row in sq:
        assert sorted(row) == list(range(n))
    for col in sq.T:
        assert np.bincount(col, minlength=n).min() == sq.shape[0] // n
    # carry-over balance: every ordered pair adjacent equally often
    pairs = {p: 0 for p in permutations(range(n), 2)}
    for row in sq:
        for a, b in zip(row[:-1], row[1:]):
            pairs[(a, b)] += 1
    assert len(set(pairs.values())) == 1


def test_practice_attention_breaks(stimuli):
    cfg = DesignConfig(n_practice=3, n_attention=4, break_every=15)
    plan = make_plan(stimuli, cfg, participant_id="P", seed=2)
    t = plan.trials
    kinds = t["kind"].tolist()
    n_ex = kinds.count("example")
    assert kinds[n_ex:n_ex + 3] == ["practice"] * 3
    att = t[t["kind"] == "attention"]
    assert len(att) == 4 and sorted(att["expected_response"]) == ["correct", "correct", "incorrect", "incorrect"]
    assert (att["perturbation"] == "none").all()
    # spread: one per quarter of the test phase
    phase = t[t["kind"].isin(["test", "attention"])].reset_index(drop=True)
    q = np.flatnonzero(phase["kind"] == "attention") // (len(phase) / 4)
    assert sorted(q.astype(int)) == [0, 1, 2, 3]
    br = np.flatnonzero(t["break_before"])
    first_test = kinds.index("test") if kinds.index("test") < kinds.index("attention") else kinds.index("attention")
    assert list(br - first_test) == list(range(15, len(phase), 15))


def test_design_errors(stimuli):
    with pytest.raises(ValueError, match="no design group"):
        make_plan(stimuli, DesignConfig(groups={"am": ("am_abrupt", "am_smooth")}), participant_id="P", seed=1)
    with pytest.raises(ValueError, match="perturbed"):
        make_plan(stimuli, DesignConfig(examples=(stimuli.perturbed[0],)), participant_id="P", seed=1)
    with pytest.raises(ValueError, match="n_repeats"):
        DesignConfig(n_repeats=0)
    with pytest.raises(ValueError, match="unknown field"):
        DesignConfig.from_dict({"n_repeat": 2})
    cfg = DesignConfig(break_every=7, examples=("flip__none",))
    assert DesignConfig.from_dict(cfg.to_dict()) == cfg


def test_breaks_are_on_by_default_and_can_be_changed_or_disabled(stimuli):
    """Issue 19 item 5: a break before every 30th test-phase trial unless the design says otherwise."""
    from study.design import BREAK_EVERY_DEFAULT, BREAK_S_DEFAULT

    assert DesignConfig().break_every == BREAK_EVERY_DEFAULT == 30 and DesignConfig().break_s == BREAK_S_DEFAULT == 60
    plan = make_plan(stimuli, participant_id="P", seed=5)
    t = plan.trials
    phase = t[t["kind"].isin(["test", "attention"])]
    assert len(phase) > 60  # the default placeholder set is long enough for two breaks
    pos = np.flatnonzero(phase["break_before"].to_numpy())
    assert list(pos) == list(range(30, len(phase), 30))
    assert not t.loc[t["kind"] == "example", "break_before"].any()
    assert plan.meta["design"]["break_every"] == 30 and plan.meta["design"]["break_s"] == 60
    for off in (0, None):
        cfg = DesignConfig(break_every=off)
        assert cfg.break_every is None
        assert not make_plan(stimuli, cfg, participant_id="P", seed=5).trials["break_before"].any()
    assert DesignConfig.from_dict({"break_every": 0}) == DesignConfig(break_every=None)
    for bad in (-1, 2.5, True):
        with pytest.raises(ValueError, match="break_every"):
            DesignConfig(break_every=bad)
    for bad in (0, -5, 3601, float("nan")):
        with pytest.raises(ValueError, match="break_s"):
            DesignConfig(break_s=bad)
    # plans written before break_s existed: their design dict lacks it and reads as the default
    old = {k: v for k, v in DesignConfig(break_every=None).to_dict().items() if k != "break_s"}
    assert DesignConfig.from_dict(old).break_s == 60 and DesignConfig.from_dict(old).break_every is None
