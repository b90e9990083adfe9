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


def test_ballistic_com_puts_a_lifted_hop_in_free_fall():
    """A synthetic walk raised 0.6 m (a smooth bump) over frames 20-40: the COM of the raised frames is
    moved onto the free-fall parabola between the supported frames around them (central-difference
    acceleration -g on every shifted frame), the rest untouched, the pose kept."""
    from mocomp.body import BodyModel
    from mocomp.dynamics.com import segment_positions
    from mocomp.impact.blend import ballistic_com, unsupported_frames
    from mocomp.ops.synthetic import synthetic_walk

    m = synthetic_walk(duration=2.0, fps=30.0).motion
    rp = np.array(m.root_positions)
    k = np.arange(m.n_frames)
    rp[:, 1] += np.where((k >= 20) & (k <= 40), 0.6 * np.sin(np.pi * (k - 20) / 20) ** 2, 0.0)
    hop = m.replace(root_positions=rp)
    floor = float(m.positions[..., 1].min())
    body = BodyModel.from_skeleton(m.skeleton, 70.0)
    air = unsupported_frames(hop, floor)
    assert air[25:36].all() and not air[:15].any()
    out, shift = ballistic_com(hop, body, floor)
    moved = np.abs(shift).max(axis=1) > 0
    assert moved[25:36].all() and not moved[:15].any() and not moved[46:].any()
    com = np.einsum("s,tsk->tk", body.masses, segment_positions(body, out)) / body.masses.sum()
    acc = np.diff(com[:, 1], 2) * m.fps ** 2                  # acc[i] is frame i + 1's
    idx = np.flatnonzero(moved)
    np.testing.assert_allclose(acc[idx - 1], -9.81, atol=1e-6)
    hor = np.diff(com[:, [0, 2]], 2, axis=0)
    np.testing.assert_allclose(hor[idx - 1], 0.0, atol=1e-9)  # straight, constant speed
    np.testing.assert_allclose(out.rotations, hop.rotations)


def test_run_victim_shield_charge_side_com_falls_freely_between_strike_and_reentry(real_data_dir, tmp_path):
    """Running victim, shield charge from its side: after the strike its fall toward the found clip left
    the floor (flight 2, frames 42-47) with the COM not in free fall (the final blend mixes two roots each
    falling on its own timeline): a gravity finding. With the COM put in free fall on those frames (root
    shifted <= 5 cm) the gravity finding goes; the angular-momentum findings of the blended pose stay
    (measured 2026-12-02, 56-run sweep: gravity findings after the strike 5 -> 3 runs, max shift 4.9 cm)."""
    from mocomp.audit import audit
    from mocomp.impact.pipeline import ImpactConfig, impact_response, load_library
    from mocomp.impact.scene import Scenario
    from mocomp.io import load, read_bvh, write_bvh

    d = real_data_dir
    run = load(d / "runs" / "ase_rl_RunForward.derived.bvh")
    charge = load(d / "attacks" / "ase_rl_Atk_ShieldCharge.derived.bvh")
    index = load_library(d / "reactions", run.skeleton, cache_dir=tmp_path / "idx")
    lib = [index.motion(c.path) for c in index.clips]
    found = {}
    for cb in (False, True):
        r = impact_response(charge, run, index, Scenario(-90.0), ImpactConfig(seed=0, com_ballistic=cb),
                            library_motions=lib)
        write_bvh(r.victim, tmp_path / f"v{cb}.bvh")
        e0, e1 = r.frames["external_force"]
        va = audit(read_bvh(tmp_path / f"v{cb}.bvh", scale=1.0), against=run, external_force_frames=[(e0, e1)])
        found[cb] = [x for x in va.violations if x.check == "gravity" and x.frames[1] > e1]
        if cb:
            assert 0 < r.evidence["ballistic_com"]["max_shift_m"] <= 0.06
            assert va.penetration.max_depth <= 0.01
            assert r.evidence["continuity_final"]["continuous"]
    assert found[False] and not found[True]
