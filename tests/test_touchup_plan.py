"""Touch-up's per-run setup reused across its iterations (issue 16's speed goal): the footplant plan
(mocomp.ops.footplant.FootplantPlan, the plants' label work done once) gives the same targets and
the same held motion as the unplanned enforcement, and lift_feet's compiled leg IK equals its numpy
solve."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.ops import displacement as dm
from mocomp.ops import enforce_footplants
from mocomp.ops.footplant import (PITCH_SLACK, PITCH_TO_ZERO, bounded_foot_pitch, consistent_toe_targets,
                                  default_blend_frames, foot_points, footplant_plan)
from mocomp.ops.plants import foot_plants, plant_targets
from mocomp.ops.synthetic import synthetic_walk
from mocomp.touchup.iterate import lift_feet
from mocomp.touchup.stages import stages


@pytest.fixture(scope="module")
def walk():
    """A synthetic walk and a copy whose legs were turned a few degrees (the feet moved off their plants)."""
    m = synthetic_walk(duration=3.0, fps=30.0).motion
    rot = np.array(m.rotations)
    rng = np.random.default_rng(11)
    plants = foot_plants(m)
    for leg in plants.legs:
        for j in leg.chain[:2]:
            ang = 0.06 * np.sin(np.linspace(0, 7, m.n_frames))[:, None] * rng.normal(size=3)
            half = 0.5 * np.linalg.norm(ang, axis=1, keepdims=True)
            q = np.concatenate([np.sin(half) * ang / np.maximum(2 * half, 1e-12), np.cos(half)], axis=1)
            from mocomp.core.rotations import quat_multiply

            rot[:, j] = quat_multiply(rot[:, j], q)
    return m, m.replace_trusted(m.root_positions, rot), plants


def _unplanned_targets(pts, plants, height, blend):
    t = consistent_toe_targets(plant_targets(pts, plants, height), pts, plants)
    if height == "level" and PITCH_SLACK is not None:
        t = bounded_foot_pitch(t, pts, plants, PITCH_SLACK, blend if PITCH_TO_ZERO else 0)
    return t


@pytest.mark.parametrize("height", ["level", "hold", "keep"])
def test_plan_targets_equal_the_unplanned_ones(walk, height):
    m, moved, plants = walk
    blend = default_blend_frames(m.fps)
    plan = footplant_plan(plants, blend, height=height)
    for mm in (m, moved):                                  # one plan, two motions
        P, G = mm.fk()
        pts = foot_points(P, G, plan.plants)
        t0 = _unplanned_targets(pts, plan.plants, height, blend)
        t1 = plan.targets(pts)
        assert np.array_equal(np.isnan(t0), np.isnan(t1))
        assert np.nanmax(np.abs(t1 - t0)) < 1e-15
        assert np.isfinite(t1).any(axis=2).sum() > 0.3 * m.n_frames * 4     # most points planted somewhere


def test_plan_targets_with_given_labels_equal_the_unplanned_ones(walk):
    """Points not planted by the detector (given labels, gaps the closing fills) take the levels path."""
    m, moved, plants = walk
    lab = np.array(plants.labels)
    lab[10:14, 1] = False                                 # a 4-frame gap in a toe plant
    given = foot_plants(moved, labels=lab)
    blend = default_blend_frames(m.fps)
    plan = footplant_plan(given, blend)
    P, G = moved.fk()
    pts = foot_points(P, G, plan.plants)
    t0 = _unplanned_targets(pts, plan.plants, "level", blend)
    assert np.nanmax(np.abs(plan.targets(pts) - t0)) < 1e-15


@pytest.mark.parametrize("compiled", [False, True])
def test_enforce_with_a_plan_equals_enforce_with_plants(walk, monkeypatch, compiled):
    """Bit for bit on the numpy path; with numba the planned first pass runs the compiled hold
    (mocomp.ops._footplant_kernel), equal to rounding."""
    m, moved, plants = walk
    if compiled and not dm._compiled():
        pytest.skip("numba not available")
    monkeypatch.setattr(dm, "USE_COMPILED", compiled)
    plan = footplant_plan(plants, default_blend_frames(m.fps))
    for mm in (moved, m):
        a = enforce_footplants(mm, plants, audit=False, passes=1)
        b = enforce_footplants(mm, audit=False, passes=1, plan=plan)
        if compiled:
            assert np.abs(a.motion.rotations - b.motion.rotations).max() < 1e-12
            assert abs(a.max_miss - b.max_miss) < 1e-12
        else:
            assert np.array_equal(a.motion.rotations, b.motion.rotations)
            assert a.max_miss == b.max_miss
        assert a.changed_frames == b.changed_frames
        assert np.array_equal(np.isnan(a.targets), np.isnan(b.targets))
    # the enforcement did hold the moved feet: their legs changed
    held = enforce_footplants(moved, audit=False, passes=1, plan=plan)
    assert np.abs(held.motion.rotations - moved.rotations).max() > 1e-3 and held.changed_frames > 10


def test_plan_bad_combinations_are_errors(walk):
    m, _, plants = walk
    plan = footplant_plan(plants, 3)
    with pytest.raises(ValueError, match="plan or plants"):
        enforce_footplants(m, plants, plan=plan, audit=False)
    with pytest.raises(ValueError, match="height"):
        enforce_footplants(m, plan=plan, height="hold", audit=False)
    with pytest.raises(ValueError, match="height must be one of"):
        footplant_plan(plants, 3, height="floor")
    with pytest.raises(ValueError, match="blend"):
        footplant_plan(plants, -1)


@pytest.mark.skipif(not dm._compiled(), reason="numba switched off: nothing compiled to compare")
def test_lift_feet_compiled_ik_equals_numpy(walk, monkeypatch):
    m, moved, _ = walk
    st = stages(m)
    P, G = m.fk()
    ref = foot_points(P, G, st.plants)
    out = {}
    for flag in (True, False):
        monkeypatch.setattr(dm, "USE_COMPILED", flag)
        out[flag] = lift_feet(moved, st.plants, ref, st.touching)
    (a, la), (b, lb) = out[True], out[False]
    assert la == lb and sum(len(v) for v in la.values()) > 5            # frames were lifted/held
    assert np.abs(a.rotations - b.rotations).max() < 1e-12
    assert np.abs(a.rotations - moved.rotations).max() > 1e-3


def test_ground_weights_equal_their_frame_by_frame_definition():
    """The vectorised ramps of :func:`mocomp.touchup.iterate.ground_weights` against the definition
    written frame by frame (0 on a flight, eased to 1 over min(neighbourhood, max(flight, min_ramp))
    frames either side, the smaller weight where two ramps meet), on random flights."""
    from mocomp.ops import ease
    from mocomp.touchup.iterate import ground_weights

    def by_frame(T, flights, nb, min_ramp, min_flight):
        w = np.ones(T)
        for a, b in flights:
            if b - a < min_flight:
                continue
            w[a:b] = 0.0
            n = min(nb, max(b - a, min_ramp))
            for i in range(1, n + 1):
                for f in (a - i, b - 1 + i):
                    if 0 <= f < T:
                        w[f] = min(w[f], float(ease(np.array([(i - 1) / n]))[0]))
        return w

    rng = np.random.default_rng(0)
    partial = 0
    for _ in range(200):
        T = int(rng.integers(5, 150))
        k = int(rng.integers(0, 4))
        cuts = np.sort(rng.choice(T, size=2 * k, replace=False)) if 2 * k < T else np.zeros(0, int)
        flights = [(int(cuts[2 * j]), int(cuts[2 * j + 1])) for j in range(len(cuts) // 2)]
        args = (T, flights, int(rng.integers(0, 25)), int(rng.integers(0, 5)), int(rng.integers(0, 4)))
        w = ground_weights(*args)
        assert np.array_equal(w, by_frame(*args)), args
        partial += int(((w > 0) & (w < 1)).any())
    assert partial > 50                                    # ramps were exercised
