"""The compiled footplant hold (mocomp.ops._footplant_kernel, issue 16's speed goal) against the numpy
enforcement it replaces: the same held legs, corrections, misses, lifts and solved frames, to rounding,
on clips that exercise every branch (toe-only and ankle-only frames, a toe <-> heel switch, legs
whose points are always planted together, unreachable targets)."""
from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest
from _touchup_compare import assert_same_touchup
from _touchup_compare import quat_close as _quat_close

from mocomp.core.rotations import quat_multiply
from mocomp.ops import displacement as dm
from mocomp.ops import enforce_footplants
from mocomp.ops import footplant as fp
from mocomp.ops.footplant import default_blend_frames, footplant_plan
from mocomp.ops.plants import foot_plants
from mocomp.ops.synthetic import synthetic_walk

pytestmark = pytest.mark.skipif(not dm._compiled(), reason="numba switched off: nothing compiled to compare")

DATA = os.environ.get("MOCOMP_DATA_DIR")


def _turn_legs(m, plants, amount, seed):
    """``m`` with each hip and knee turned by a smooth per-frame rotation (the feet moved off their plants)."""
    rot = np.array(m.rotations)
    rng = np.random.default_rng(seed)
    for leg in plants.legs:
        for j in leg.chain[:2]:
            ang = amount * np.sin(np.linspace(0, 7, m.n_frames))[:, None] * rng.normal(size=3)
            half = 0.5 * np.linalg.norm(ang, axis=1, keepdims=True)
            q = np.concatenate([np.sin(half) * ang / np.maximum(2 * half, 1e-12), np.cos(half)], axis=1)
            rot[:, j] = quat_multiply(rot[:, j], q)
    return m.replace_trusted(m.root_positions, rot)


def _cases():
    walk = synthetic_walk(duration=3.0, fps=30.0).motion
    out = [("synthetic walk", walk, None)]
    pl = foot_plants(walk)
    lab = np.array(pl.labels)
    lab[:, 1], lab[:, 3] = lab[:, 0], lab[:, 2]                   # toe and heel always together: no one-leg fill
    out.append(("synthetic walk, feet flat", walk, dataclasses.replace(pl, labels=lab,
                                                                       levels=np.where(lab, np.nanmin(pl.levels), np.nan))))
    if DATA:
        from mocomp.io import read_bvh

        flip = read_bvh(os.path.join(DATA, "flips", "cmu_90_08_sideflip.bvh"))   # a toe <-> heel switch (left)
        out.append(("CMU 90_08 side flip", flip, None))
        wheel = read_bvh(os.path.join(DATA, "cartwheels", "sfu_0007_Cartwheel001.bvh")).slice(0, 400)
        out.append(("SFU cartwheel", wheel, None))
    return out


@pytest.mark.parametrize("case", range(4))
@pytest.mark.parametrize("amount", [0.0, 0.08, 0.6])
def test_compiled_hold_equals_numpy(case, amount, monkeypatch):
    cases = _cases()
    if case >= len(cases):
        pytest.skip("needs MOCOMP_DATA_DIR")
    name, m, plants = cases[case]
    plants = foot_plants(m) if plants is None else plants
    plan = footplant_plan(plants, default_blend_frames(m.fps))
    mm = _turn_legs(m, plants, amount, seed=case) if amount else m
    got = {}
    for compiled in (True, False):
        monkeypatch.setattr(dm, "USE_COMPILED", compiled)
        P, G = mm.fk()
        pts = fp.foot_points(P, G, plan.plants)
        hinges, clocks = fp._hinges_and_clocks(mm, P, G, plan.plants)
        rot, targets, state = fp._solve(mm, P, G, pts, plan.plants, plan.blend, "level", 1e-6, fp.REACH_MARGIN,
                                        "smoothstep", None, hinges, clocks, plan)
        res = enforce_footplants(mm, audit=False, passes=1, plan=plan)
        got[compiled] = (rot, targets, state, hinges, clocks, res)
    (rot, targets, state, hinges, clocks, res), (rot0, targets0, state0, hinges0, clocks0, res0) = got[True], got[False]
    np.testing.assert_allclose(np.array(hinges), np.array(hinges0), atol=1e-12, rtol=0)
    np.testing.assert_allclose(clocks, clocks0, atol=1e-12, rtol=0)
    np.testing.assert_array_equal(np.isnan(targets), np.isnan(targets0))
    assert _quat_close(rot, rot0) < 1e-10, name
    assert _quat_close(res.motion.rotations, res0.motion.rotations) < 1e-10, name
    assert res.changed_frames == res0.changed_frames and res.unreachable == res0.unreachable
    assert abs(res.max_miss - res0.max_miss) < 1e-10
    for side in state0:
        d, r, miss, lift, solved, lab = state[side]
        d0, r0, miss0, lift0, solved0, lab0 = state0[side]
        assert np.abs(d - d0).max() < 1e-10 and np.abs(r - r0).max() < 1e-10, (name, side)
        assert np.abs(miss - miss0).max() < 1e-10 and np.abs(lift - lift0).max() < 1e-10, (name, side)
        assert np.array_equal(solved, solved0) and np.array_equal(lab, lab0)
    # the hold did something on a moved motion (not a comparison of two untouched copies)
    if amount:
        assert _quat_close(rot0, mm.rotations) > 1e-3 and res0.changed_frames > 10
    if amount >= 0.6:
        assert res0.max_miss > 0 or any(state0[s][3].max() > 1e-4 for s in state0), "no reach limit met"


def test_compiled_hold_switch_branch_is_exercised():
    """The side flip's plan has a toe <-> heel switch on one leg, the flat-footed walk has no one-leg
    fill: the branches the comparisons above claim to cover are there."""
    cases = _cases()
    flat = footplant_plan(cases[1][2], 3).kernel_inputs(cases[1][1].skeleton.parents)
    assert not flat["one_leg"].any()
    if not DATA:
        pytest.skip("needs MOCOMP_DATA_DIR")
    _, flip, _ = cases[2]
    k = footplant_plan(foot_plants(flip), default_blend_frames(flip.fps)).kernel_inputs(flip.skeleton.parents)
    assert k["has_sw"].any() and k["sw_mask"].max() > 0.5


def test_touchup_all_compiled_equals_all_numpy(monkeypatch):
    """The whole touch-up with every compiled path (touch-up's ``_fast``: ZMP inputs, turns, the
    feet lift; ``mocomp.ops``: the hold kernel, the maps, the IK) against the numpy code alone, on
    the paper's examples the data allow, cut to the paper's frame counts: the touched-up motion
    and the per-iteration records agree to 1e-9."""
    from mocomp.audit import default_body
    from mocomp.touchup import _fast, touchup
    from mocomp.touchup.examples import PAPER_TIMINGS, paper_examples

    for name, e in paper_examples().items():
        m = e.motion.slice(0, min(PAPER_TIMINGS[name][0], e.motion.n_frames))
        body = default_body(m)
        fast = touchup(m, body, e.schedule)
        monkeypatch.setattr(_fast, "COMPILED", False)
        monkeypatch.setattr(dm, "USE_COMPILED", False)
        ref = touchup(m, body, e.schedule)
        monkeypatch.setattr(_fast, "COMPILED", True)
        monkeypatch.setattr(dm, "USE_COMPILED", None)
        assert_same_touchup(fast, ref, m, name)


@pytest.mark.parametrize("case", range(4))
def test_compiled_plan_targets_equal_numpy(case, monkeypatch):
    """:meth:`FootplantPlan.targets` compiled (mocomp.ops._footplant_kernel.plan_targets) against its numpy
    steps on foot points moved by 1 cm noise (the resting-level medians, the toe runs shifted with their
    heels, the toe tips set from the ankle points, the pitch bound and its fade all run on real clips)."""
    cases = _cases()
    if case >= len(cases):
        pytest.skip("needs MOCOMP_DATA_DIR")
    name, m, plants = cases[case]
    plan = footplant_plan(foot_plants(m) if plants is None else plants, default_blend_frames(m.fps))
    P, G = m.fk()
    pts = fp.foot_points(P, G, plan.plants) + np.random.default_rng(case).normal(scale=0.01, size=(m.n_frames, 4, 3))
    monkeypatch.setattr(dm, "USE_COMPILED", True)
    a = plan.targets(pts)
    monkeypatch.setattr(dm, "USE_COMPILED", False)
    b = plan.targets(pts)
    assert np.array_equal(np.isnan(a), np.isnan(b)) and np.isfinite(b).sum() > 100
    assert np.nanmax(np.abs(a - b)) < 1e-12, name
    # the targets are not the points themselves: the plan held something
    assert np.nanmax(np.abs(b - pts)) > 1e-3
