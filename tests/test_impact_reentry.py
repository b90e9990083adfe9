"""The final blend's target frame re-chosen against the active simulation's state (ImpactConfig
reentry_radius / reentry_by; beyond the paper, which blends onto the searched frame)."""
import numpy as np
import pytest

from mocomp.impact.search import reentry_frame_costs
from mocomp.ops.synthetic import synthetic_walk


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration=2.0, fps=30.0).motion


def test_frame_costs_are_zero_on_the_state_itself_and_grow_away_from_it(walk):
    state = walk.slice(0, 21)                                # its last frame is frame 20
    fr, c = reentry_frame_costs(state, walk, 22, 4)
    np.testing.assert_array_equal(fr, np.arange(18, 27))
    assert c[fr == 20][0] == pytest.approx(0.0, abs=1e-6)
    assert int(fr[np.argmin(c)]) == 20 and np.all(c >= 0)
    assert c[fr == 26][0] > c[fr == 22][0] > 0.0             # further along the gait, further away
    # the radius is clipped at the clip's ends
    fr, _ = reentry_frame_costs(state, walk, 1, 3)
    np.testing.assert_array_equal(fr, np.arange(0, 5))


def test_frame_costs_see_the_height(walk):
    """Only the ground point and heading are removed: a state lifted 10 cm is 10 cm from its own frame
    in every body part (cost = 0.1 m x the sum of Table A.1's position weights)."""
    from mocomp.impact.features import body_features, part_weights
    from mocomp.impact.search import support_foot_of

    state = walk.slice(20, 21)
    up = state.replace(root_positions=np.array(state.root_positions) + [0.0, 0.1, 0.0])
    fr, c = reentry_frame_costs(up, walk, 20, 0)
    f = body_features(up, velocities=False)
    wp, _ = part_weights(support_foot_of(f.com[0], f.positions[0]))
    assert c[0] == pytest.approx(0.1 * wp.sum(), rel=1e-6)


def test_bad_radius_and_config_refused(walk):
    from mocomp.impact.pipeline import ImpactConfig

    with pytest.raises(ValueError, match="radius"):
        reentry_frame_costs(walk.slice(0, 2), walk, 5, -1)
    with pytest.raises(ValueError, match="reentry_radius"):
        ImpactConfig(reentry_radius=-2)
    with pytest.raises(ValueError, match="reentry_by"):
        ImpactConfig(reentry_by="height")


@pytest.fixture(scope="module")
def walk_charge_back(real_data_dir, tmp_path_factory):
    """The shield charge into the walking victim's back: the active pass ends 21 cm below the searched
    frame of the found clip (ASE Fall_SpinRight), the naive one 10 cm (measured 2026-12-02)."""
    from mocomp.impact.pipeline import ImpactConfig, impact_response, load_library
    from mocomp.impact.scene import Scenario
    from mocomp.io import load

    d = real_data_dir
    victim = load(d / "walks" / "ase_rl_WalkForward01.derived.bvh")
    attacker = load(d / "attacks" / "ase_rl_Atk_ShieldCharge.derived.bvh")
    index = load_library(d / "reactions", victim.skeleton, cache_dir=tmp_path_factory.mktemp("idx"))
    lib = [index.motion(c.path) for c in index.clips]
    runs = {}
    for name, cfg in {"paper": ImpactConfig(seed=0),
                      "height": ImpactConfig(seed=0, reentry_radius=3, reentry_by="root_height"),
                      "eq41": ImpactConfig(seed=0, reentry_radius=3)}.items():
        runs[name] = impact_response(attacker, victim, index, Scenario(180.0, None, None), cfg, library_motions=lib)
    return runs, index


def test_rechosen_frame_lowers_the_root_correction(walk_charge_back):
    runs, index = walk_charge_back
    p, h, e = runs["paper"], runs["height"], runs["eq41"]
    assert p.evidence["reentry_refine"] is None
    assert p.search.clip == h.search.clip and p.search.frame == h.search.frame     # the same search
    ref = h.evidence["reentry_refine"]
    assert ref["by"] == "root_height" and abs(ref["clip_frame_chosen"] - ref["clip_frame_searched"]) <= 3
    # measured: -0.213 m (paper) -> +0.020 m (root_height), eq4.1 in between; the horizontal part stays 0
    assert abs(p.blend_active.root_error_vertical_m) > 0.15
    assert abs(h.blend_active.root_error_vertical_m) < 0.05
    assert abs(e.blend_active.root_error_vertical_m) <= abs(p.blend_active.root_error_vertical_m) + 1e-9
    for r in (p, h, e):
        assert r.blend_active.root_error_horizontal_m < 1e-3
        # still far below blending from the naive pass in the joints (measured 12.5 / 16.5 vs 32.4 deg)
        assert r.blend_active.joint_error_deg < 0.7 * r.blend_naive.joint_error_deg
    # the blend still lands exactly on the (shifted) clip frame, whose root height the chosen one is
    native = index.motion(h.search.clip)
    last = h.blend_active.motion
    np.testing.assert_allclose(last.rotations[-1], h.found.rotations[-1], atol=1e-9)
    assert h.found.root_positions[-1, 1] == pytest.approx(native.root_positions[ref["clip_frame_chosen"], 1], abs=1e-6)
    assert h.frames["found_clip_frame_at_reentry"] == ref["clip_frame_chosen"]


def test_cli_reentry_radius(real_data_dir, tmp_path, capsys):
    from mocomp.cli import main

    d = real_data_dir
    rc = main(["impact", "--attacker", str(d / "attacks" / "ase_rl_Atk_ShieldCharge.derived.bvh"),
               "--victim", str(d / "walks" / "ase_rl_WalkForward01.derived.bvh"), "--facing", "180",
               "--reentry-radius", "3", "--cache", str(tmp_path / "c"), "-o", str(tmp_path / "o"), "--no-audit"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "re-entry frame re-chosen by root_height (beyond the paper)" in out
    line = next(x for x in out.splitlines() if x.startswith("final-blend correction"))
    assert abs(float(line.split("vertical ")[1].split(" m")[0])) < 0.05          # measured +0.020 m
