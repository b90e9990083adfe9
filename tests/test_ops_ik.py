"""Two-bone leg IK and foot planting after a landing (issue 5, joins: the upright recovery
after touchdown must not slide the feet on the ground)."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from mocomp import datasets
from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
from mocomp.edit import seams
from mocomp.edit.join import join_flights
from mocomp.ops.ik import leg_chains, plant_feet, two_bone_ik
from mocomp.edit.seams import stance_slide


@functools.lru_cache(maxsize=None)
def example(name):
    return datasets.load_example(name)


def test_leg_chains_are_hip_knee_ankle():
    sk = example("backflip").motion.skeleton
    names = [tuple(sk.names[j] for j in c) for c in leg_chains(sk)]
    assert names == [("LeftUpLeg", "LeftLeg", "LeftFoot"), ("RightUpLeg", "RightLeg", "RightFoot")]


def test_two_bone_ik_reaches_the_target_and_keeps_the_foot_orientation():
    m = example("backflip").motion[250:262]          # standing after the landing, slightly bent knees
    P, G = m.fk()
    chain = leg_chains(m.skeleton)[0]
    h, k, a = chain
    rng = np.random.default_rng(7)
    tgt = P[:, a] + rng.uniform(-0.06, 0.06, (m.n_frames, 3))
    rot, miss = two_bone_ik(P, G, m.rotations, m.skeleton.parents, chain, tgt)
    out = m.replace(rotations=rot)
    np.testing.assert_allclose(out.positions[:, a], tgt, atol=1e-6)
    assert np.all(miss < 1e-5)
    # the foot's world orientation and every joint outside hip/knee/ankle are unchanged
    np.testing.assert_allclose(np.abs(np.sum(out.global_rotations[:, a] * G[:, a], axis=-1)), 1.0, atol=1e-9)
    others = [j for j in range(m.skeleton.n_joints) if j not in chain]
    np.testing.assert_array_equal(rot[:, others], m.rotations[:, others])
    # the bones keep their lengths (FK) and the hip stays put
    np.testing.assert_allclose(out.positions[:, h], P[:, h], atol=1e-12)


def test_two_bone_ik_out_of_reach_stops_on_the_line_to_the_target():
    m = example("backflip").motion[255:256]
    P, G = m.fk()
    h, k, a = chain = leg_chains(m.skeleton)[1]
    reach = np.linalg.norm(P[0, k] - P[0, h]) + np.linalg.norm(P[0, a] - P[0, k])
    far = P[0, h] + np.array([0.0, -1.0, 0.3]) * 2.0
    rot, miss = two_bone_ik(P[0], G[0], m.rotations[0], m.skeleton.parents, chain, far)
    pa = m.replace(rotations=rot[None]).positions[0, a]
    assert miss == pytest.approx(np.linalg.norm(far - P[0, h]) - reach, abs=1e-5)
    d = pa - P[0, h]
    np.testing.assert_allclose(d / np.linalg.norm(d), (far - P[0, h]) / np.linalg.norm(far - P[0, h]), atol=1e-6)


def test_plant_feet_holds_a_sliding_stance_foot():
    """The standing end of the back flip with the whole body drifting 6 cm sideways over 12
    frames: with both feet planted the ankles stay within a millimetre; the knees take it up."""
    m = example("backflip").motion[250:262]
    rp = np.array(m.root_positions)
    rp[:, 0] += np.linspace(0.0, 0.06, m.n_frames)
    drift = m.replace(root_positions=rp)
    chains = leg_chains(m.skeleton)
    ank = [c[2] for c in chains]
    w = np.ones((m.n_frames, len(chains)))
    assert stance_slide(drift.positions[:, ank], w) > 0.059
    out, solves = plant_feet(drift, 0, w, chains)
    assert solves == 2 * (m.n_frames - 1)          # the first frame is the plant itself
    assert stance_slide(out.positions[:, ank], w) < 1e-3
    # the root still drifts (the legs, not the body, absorb it)
    np.testing.assert_array_equal(out.root_positions, drift.root_positions)


def test_plant_feet_refuses_overlapping_chains():
    m = example("backflip").motion[250:255]
    h, k, a = leg_chains(m.skeleton)[0]
    with pytest.raises(ValueError, match="overlap"):
        plant_feet(m, 0, np.ones((5, 2)), [(h, k, a), (k, a, a + 1)])


def test_deepmimic_join_recovery_no_longer_slides_the_stance_foot(real_data_dir, monkeypatch):
    """Back flip + spin kick (full alignment, 37.5 deg of landing tilt eased out after touchdown):
    the recovery alone drags the landing foot 15 cm across the floor (measured 15.4 cm); pinned
    (root translation and leg IK in the recovery, then the landing put on the floor with the feet
    held, :mod:`mocomp.edit.landing`) the audit of the output finds the landing contacts sliding
    about a centimetre (measured 1.0 cm; the back flip's own landing slides 12.9 cm)."""
    from mocomp.audit import audit
    from mocomp.edit import landing

    r = join_flights("deepmimic_backflip", "deepmimic_spinkick")
    assert r.restore.landing_tilt_deg > 30.0
    td = r.restore.landing.touchdown
    rep = audit(r.motion)
    after = [c.slide for c in rep.contacts if c.frames[0] >= td - 2 and not c.effector.startswith("hand")]
    assert after and max(after) < 0.015
    assert r.foot_slide is not None and r.foot_slide < r.restore.foot_slide_own
    monkeypatch.setattr(seams, "recover_upright", functools.partial(seams.recover_upright, pin_feet=False))
    monkeypatch.setattr(landing, "rest_on_floor", lambda m, first, floor, ref, src: (m, {}))
    r0 = join_flights("deepmimic_backflip", "deepmimic_spinkick")
    assert r0.foot_slide > 0.10
    # same landing otherwise: the pinning moves the root horizontally by centimetres, not more (and
    # vertically by what puts the landing back on the floor: up to 9 cm, the recovery's pivot lowers it)
    n = min(r.motion.n_frames, r0.motion.n_frames)
    assert np.abs(r.motion.root_positions[:n, [0, 2]] - r0.motion.root_positions[:n, [0, 2]]).max() < 0.05
    assert r.restore.landing.ok
    ang = np.degrees(quat_angle(quat_multiply(r.motion.rotations[:n, 0], quat_inverse(r0.motion.rotations[:n, 0]))))
    assert ang.max() < 1e-6


def test_run_starts_and_stance_slide_on_known_runs():
    from mocomp.ops.ik import run_starts

    on = np.array([[0, 1], [1, 1], [1, 0], [0, 1], [1, 1]], dtype=bool)
    np.testing.assert_array_equal(run_starts(on), [[-1, 0], [1, 0], [1, -1], [-1, 3], [4, 3]])
    # a joint moving 1 cm per frame: within its contact runs it travels at most 1 and 1 cm
    pos = np.zeros((5, 2, 3))
    pos[:, :, 0] = 0.01 * np.arange(5)[:, None]
    assert stance_slide(pos, on.astype(float)) == pytest.approx(0.01)
    assert stance_slide(pos, np.zeros((5, 2))) == 0.0
