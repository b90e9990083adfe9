"""Soft reach of the leg IK (mocomp.ops.ik): a planted foot that the pelvis glides past gives a
continuous knee angle (no snap straight), and the frames out of reach are reported."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.core.kinematics import forward_kinematics
from mocomp.ops.ik import (SOFT_REACH, UNREACHABLE_TOL, leg_chains, plant_rotations, soft_distance,
                           two_bone_ik)
from mocomp.ops.synthetic import synthetic_walk


def test_soft_distance_is_c1_below_full_and_identity_below_the_soft_zone():
    full, s = 0.9, 0.02
    d = np.linspace(0.5, 1.3, 8001)
    out = soft_distance(d, full, s)
    np.testing.assert_array_equal(out[d <= full - s], d[d <= full - s])
    assert np.all(out < full) and np.all(np.diff(out) > 0)
    slope = np.gradient(out, d)
    assert np.abs(np.diff(slope)).max() < 5e-3                 # no kink: C1 (slope 1 -> 0 smoothly)
    assert soft_distance(full + 10 * s, full, s) == pytest.approx(full - s * np.exp(-11), abs=1e-12)
    # never below the chain's own distance (a vanishing correction is reached exactly)
    assert soft_distance(0.895, full, s, floor=0.895) == pytest.approx(0.895)
    np.testing.assert_array_equal(soft_distance(d, full, 0.0), d)


def _glide(n=200, travel=0.8):
    """One planted leg of a standing pose whose pelvis glides ``travel`` m forward at constant speed."""
    m = synthetic_walk(duration=1.0).motion
    sk = m.skeleton
    chains = leg_chains(sk)
    rp = np.repeat(m.root_positions[:1], n, 0)
    rp[:, 0] += np.linspace(0.0, travel, n)
    rot = np.repeat(m.rotations[:1], n, 0)
    P, G = forward_kinematics(sk.parents, sk.offsets, rp, rot)
    w = np.zeros((n, len(chains)))
    w[:, 0] = 1.0
    return sk, chains, rp, rot, P, G, w


def _knee_angles(sk, chain, rp, rot):
    P, _ = forward_kinematics(sk.parents, sk.offsets, rp, rot)
    h, k, a = chain
    u, v = P[:, h] - P[:, k], P[:, a] - P[:, k]
    c = np.einsum("ij,ij->i", u, v) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
    return np.degrees(np.arccos(np.clip(c, -1, 1))), P


def test_target_moving_beyond_reach_gives_a_continuous_knee():
    sk, chains, rp, rot, P, G, w = _glide()
    hard, _ = plant_rotations(sk.parents, rot, P, G, 0, w, chains, soft_reach=0.0)
    soft, solves, reach = plant_rotations(sk.parents, rot, P, G, 0, w, chains, return_reach=True)
    ang_h, _ = _knee_angles(sk, chains[0], rp, hard)
    ang_s, Ps = _knee_angles(sk, chains[0], rp, soft)
    step_h, step_s = np.abs(np.diff(ang_h)), np.abs(np.diff(ang_s))
    # measured: hard clamp 4.7 deg in one frame just before the knee locks (then 0): a snap;
    # soft 0.46 deg at most, changing gradually
    assert step_h.max() > 3.0
    assert step_s.max() < 0.2 * step_h.max()
    assert np.abs(np.diff(step_s)).max() < 0.1                  # the knee's rate itself has no jump
    assert ang_s.max() < 180.0 and ang_s[-1] > ang_s[0] + 25.0    # it does straighten, toward 180
    # the planted ankle is held where reachable; the frames out of reach are reported, in one run to the end
    (runs,), (leg1,) = reach.unreachable[:1], reach.unreachable[1:]
    assert leg1 == [] and len(runs) == 1 and runs[0][1] == len(rp)
    a = chains[0][2]
    tgt = np.array(P[:, a])
    tgt[:, [0, 2]] = P[0, a, [0, 2]]                                # held in the ground plane, its own height
    slide = np.linalg.norm(Ps[:, a] - tgt, axis=1)
    assert slide[:runs[0][0]].max() <= UNREACHABLE_TOL + 1e-9
    assert slide[runs[0][0]] > UNREACHABLE_TOL
    assert reach.max_miss[0] == pytest.approx(slide.max(), abs=0.02) and "out of reach" in reach.summary()


def test_soft_reach_leaves_reachable_targets_and_the_identity_alone():
    sk, chains, rp, rot, P, G, w = _glide(n=50, travel=0.05)
    r, n = plant_rotations(sk.parents, rot, P, G, 0, w, chains)
    _, P2 = _knee_angles(sk, chains[0], rp, r)
    a = chains[0][2]
    np.testing.assert_allclose(P2[:, a, [0, 2]], np.repeat(P[:1, a, [0, 2]], 50, 0), atol=2e-3)
    # a target at the ankle's own place is reached exactly, even with the leg in the soft zone
    h = chains[0][0]
    full = float(np.linalg.norm(P[0, chains[0][1]] - P[0, h]) + np.linalg.norm(P[0, a] - P[0, chains[0][1]]))
    out, miss = two_bone_ik(P[:1], G[:1], rot[:1], sk.parents, chains[0], P[:1, a], soft_reach=0.5 * full)
    assert miss[0] < 1e-9
    with pytest.raises(ValueError, match="soft_reach"):
        plant_rotations(sk.parents, rot, P, G, 0, w, chains, soft_reach=0.7)
    assert SOFT_REACH == 0.02
