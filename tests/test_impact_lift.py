"""Issue 18: the floor lift adds no vertical acceleration while the body is unsupported
(:func:`mocomp.impact.blend.floor_lift` ``ballistic``), measured on the written, read-back BVH."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.impact.blend import linear_over


def test_linear_over_known_answer():
    v = np.array([0.0, 0.0, 1.0, 5.0, 2.0, 4.0, 6.0, 3.0, 9.0, 9.5])
    m = np.array([0, 0, 1, 1, 0, 0, 0, 1, 1, 1], bool)
    out = linear_over(v, m)
    # frames 1..4: the line from v[1] = 0 to v[4] = 2; frames 6..: held at v[6] (the run ends the array)
    np.testing.assert_allclose(out, [0.0, 0.0, 2 / 3, 4 / 3, 2.0, 4.0, 6.0, 6.0, 6.0, 6.0])
    assert np.all(np.abs(np.diff(out, 2)[m[1:-1]]) < 1e-12)      # no acceleration on a masked frame
    # frames before start are never touched, the line anchored at start - 1
    out2 = linear_over(v, np.ones(10, bool), start=4)
    np.testing.assert_allclose(out2[:4], v[:4])
    np.testing.assert_allclose(out2[3:], v[3])
    with_gap = linear_over(v, m, start=3)
    np.testing.assert_allclose(with_gap[:3], v[:3])
    np.testing.assert_allclose(with_gap[2:5], [1.0, 1.5, 2.0])


pytest.importorskip("mujoco")


@pytest.mark.parametrize("ballistic", [False, True])
def test_walk_victim_shield_charge_side_no_gravity_finding_after_the_strike(real_data_dir, tmp_path, ballistic):
    """Walking victim, shield charge from its side (facing -90): the lift (up to ~0.2 m: the found fall
    sinks while lying) eased in over the segment while the body fell on its hip with no foot down, so the
    written COM fell at 3-6 m/s^2, then 13.7: the audit's gravity and L findings in flight 1 (frames 41-49).
    With the lift straight over the unsupported frames: none outside the strike's frames (measured
    2026-12-02 over the 56-run sweep: walk victims with findings 2 -> 0, run 6 -> 6, idle 0 -> 0).
    The eased lift is run too, so that the test shows the finding it guards against."""
    from mocomp.audit import audit
    from mocomp.impact.pipeline import ImpactConfig, impact_response, load_library
    from mocomp.impact.scene import Scenario
    from mocomp.io import load, read_bvh, write_bvh

    d = real_data_dir
    walk = load(d / "walks" / "ase_rl_WalkForward01.derived.bvh")
    charge = load(d / "attacks" / "ase_rl_Atk_ShieldCharge.derived.bvh")
    index = load_library(d / "reactions", walk.skeleton, cache_dir=tmp_path / "idx")
    lib = [index.motion(c.path) for c in index.clips]
    r = impact_response(charge, walk, index, Scenario(-90.0), ImpactConfig(seed=0, lift_ballistic=ballistic),
                        library_motions=lib)
    write_bvh(r.victim, tmp_path / "v.bvh")
    v = read_bvh(tmp_path / "v.bvh", scale=1.0)
    e0, e1 = r.frames["external_force"]
    va = audit(v, against=walk, external_force_frames=[(e0, e1)])
    after = [x for x in va.violations if x.check in ("gravity", "L_direction", "L_magnitude") and x.frames[1] > e1]
    lift = r.evidence["floor_lift"]
    assert lift["max_lift_m"] > 0.1                              # the lift is there in both
    if not ballistic:
        assert any(x.check == "gravity" for x in after)          # the finding the ballistic lift removes
        return
    assert not after, [(x.check, x.where, x.frames) for x in after]
    assert va.penetration.max_depth <= 0.01
    assert r.evidence["continuity_final"]["continuous"]
    assert not [x for x in va.violations if "slide" in x.check and x.frames[0] >= r.frames["reentry"]]
