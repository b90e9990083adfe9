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


def test_plant_targets_known_answer_release_and_dip():
    """The ankle's horizontal target ``p + w (anchor - p)``: anchored on the first frame of each run of
    weight >= 0.5, held by the weight on the frames of weight above 0 around it, and moved linearly from
    one run's anchor to the next through a dip that does not reach 0."""
    from mocomp.ops.ik import plant_targets

    pos = np.zeros((9, 1, 2))
    pos[:, 0, 0] = np.arange(9.0)                     # the ankle moves 1 m per frame along x
    w = np.array([0.0, 0.25, 0.5, 1.0, 0.25, 0.5, 1.0, 0.25, 0.0])[:, None]
    got = plant_targets(pos, w)[:, 0, 0]
    # anchors: frame 1 -> run 1 (frame 2, x=2); 2, 3 -> 2; dip frame 4 halfway from run 1's last
    # frame (3) to run 2's first (5): anchor 2 + (4 - 3) / (5 - 3) * (5 - 2) = 3.5; 5, 6, 7 -> 5
    anchor = np.array([0.0, 2.0, 2.0, 2.0, 3.5, 5.0, 5.0, 5.0, 8.0])
    np.testing.assert_allclose(got, pos[:, 0, 0] + w[:, 0] * (anchor - pos[:, 0, 0]), atol=1e-12)
    # no weight at all, or below 0.5 only: the position itself
    np.testing.assert_array_equal(plant_targets(pos, np.full((9, 1), 0.4)), pos)


def _old_plant_rotations(parents, rotations, P, G, start, weights, chains, tol=1e-3):
    """The former rule (the anchor weighted only while w >= 0.5, dropped below): the release jumps."""
    from mocomp.ops.ik import run_starts

    rot = np.array(rotations)
    starts = run_starts(np.asarray(weights) >= 0.5)
    for c, chain in enumerate(chains):
        a = chain[2]
        tgt = np.array(P[:, a])
        on = starts[:, c] >= 0
        plant = tgt[np.maximum(starts[:, c], 0)][:, [0, 2]]
        tgt[:, [0, 2]] += np.where(on, weights[:, c], 0.0)[:, None] * (plant - tgt[:, [0, 2]])
        idx = np.flatnonzero(np.linalg.norm(tgt - P[:, a], axis=1) > tol)
        if idx.size:
            rot[start + idx], _ = two_bone_ik(P[idx], G[idx], rot[start + idx], parents, chain, tgt[idx])
    return rot, 0


def _step_excess(motion, out) -> np.ndarray:
    """``(T-1, J)`` m: how much further each joint moves between two frames in ``out`` than in ``motion``."""
    d0 = np.linalg.norm(np.diff(motion.positions, axis=0), axis=-1)
    return np.linalg.norm(np.diff(out.positions, axis=0), axis=-1) - d0


def test_plant_feet_lets_go_without_a_jump(monkeypatch):
    """The standing end of the back flip drifting 5 cm sideways: the left foot held for 30 frames and
    let go over 24 (its weight falling through 0.5 at frame 42), the right one held, lifted to weight
    0.3 and put down again over 10 frames. Measured: where the left weight falls through 0.5 no joint of
    the left leg moves more than 0.8 mm per frame further than in the input (the correction shrinks by
    1/24 per frame, the excess grows smoothly 0.5 -> 1.1 mm over frames 36-47), no joint anywhere more
    than 8.3 mm (the right leg's dip: 0.14 of 3.5 cm per frame); the former rule, which dropped the
    hold where the weight fell below 0.5, moved the left leg 12.5 mm in that one frame."""
    import mocomp.ops.ik as ik
    from mocomp.ops.ik import descends

    m = example("backflip").motion[240:323]
    n = m.n_frames
    rp = np.array(m.root_positions)
    rp[:, 0] += np.linspace(0.0, 0.05, n)
    drift = m.replace(root_positions=rp)
    chains = leg_chains(m.skeleton)
    w = np.zeros((n, 2))
    w[:30, 0] = 1.0
    w[30:54, 0] = np.linspace(1.0, 0.0, 25)[1:]
    w[:, 1] = 1.0
    w[58:68, 1] = np.r_[np.linspace(1.0, 0.3, 6)[1:], np.linspace(0.3, 1.0, 6)[:-1]]
    out, solves = plant_feet(drift, 0, w, chains)
    assert solves > 0
    cross = (w[:-1, 0] >= 0.5) & (w[1:, 0] < 0.5)
    assert cross.sum() == 1
    left = [j for j in range(m.skeleton.n_joints) if descends(m.skeleton.parents, j, chains[0][0])]
    ex = _step_excess(drift, out)
    assert ex[cross][:, left].max() < 0.0015 and ex.max() < 0.01
    ank = [c[2] for c in chains]
    A, A0 = out.positions[:, ank], drift.positions[:, ank]
    # held while the weight is 1 (left: frames 0-29 at frame 0's place; right: until the dip)
    assert np.abs(A[:30, 0, [0, 2]] - A0[0, 0, [0, 2]]).max() < 1e-3
    assert np.abs(A[:58, 1, [0, 2]] - A0[0, 1, [0, 2]]).max() < 1e-3
    # let go: the left leg is the input's once its weight is 0
    np.testing.assert_array_equal(out.rotations[54:, list(chains[0])], drift.rotations[54:, list(chains[0])])
    monkeypatch.setattr(ik, "plant_rotations", _old_plant_rotations)
    old, _ = ik.plant_feet(drift, 0, w, chains)
    assert _step_excess(drift, old)[cross][:, left].max() > 0.01


def test_plant_feet_lets_go_without_a_jump_on_a_real_walk(real_data_dir, monkeypatch):
    """SFU walk (120 Hz, 5 s) drifting 0.1 m/s sideways; each ankle's weight 1 within 1.5 cm of its low,
    0 above 4 cm, and let go no faster than over 0.2 s (as the flight edits do). The ankle joint rolls
    forward with the heel while still that low, so the holds pull it back by up to 15 cm: a stress test.
    Where a weight falls through 0.5 (8 releases) no joint moves more than 1.1 cm per frame further than
    in the input (measured), no more than on the other frames (2.0 cm: the weight changing within a
    hold); the former rule jumped by 14.8 cm there."""
    import mocomp.ops.ik as ik

    m = datasets.load("sfu_0008_Walking002")[:600]
    rp = np.array(m.root_positions)
    rp[:, 2] += 0.1 * np.arange(m.n_frames) / m.fps
    drift = m.replace(root_positions=rp)
    chains = leg_chains(m.skeleton)
    ank = [c[2] for c in chains]
    y = drift.positions[:, ank, 1]
    x = np.clip((y.min(axis=0) + 0.04 - y) / 0.025, 0.0, 1.0)
    w = x * x * (3 - 2 * x)
    for i in range(w.shape[0] - 2, -1, -1):                   # released over 0.2 s at least
        w[i] = np.minimum(w[i], w[i + 1] + 1.0 / 24)
    cross = ((w[:-1] >= 0.5) & (w[1:] < 0.5)).any(axis=1)
    assert cross.sum() >= 6
    out, solves = plant_feet(drift, 0, w, chains)
    assert solves > 100
    ex = _step_excess(drift, out)
    assert ex[cross].max() < 0.015
    assert ex[cross].max() <= ex[~cross].max()
    monkeypatch.setattr(ik, "plant_rotations", _old_plant_rotations)
    old, _ = ik.plant_feet(drift, 0, w, chains)
    assert _step_excess(drift, old)[cross].max() > 0.1


def test_compiled_leg_ik_equals_the_numpy_two_bone_ik(monkeypatch):
    """ops._kernels.two_bone_ik_rows (the footplant's compiled leg IK) against ops.ik.two_bone_ik on random
    targets around the feet, with the hinge prior, a given foot orientation and targets out of reach."""
    import mocomp.ops.displacement as dm
    from mocomp.core._compiled import AVAILABLE
    from mocomp.core.rotations import quat_exp
    from mocomp.ops.footplant import BEND_PRIOR, _ik_legs
    from mocomp.ops.ik import hinge_axis

    if not AVAILABLE:
        pytest.skip("numba not available")
    m = example("backflip").motion
    P, G = m.fk()
    rng = np.random.default_rng(11)
    jobs = []
    for chain in leg_chains(m.skeleton):
        idx = np.sort(rng.choice(m.n_frames, 120, replace=False))
        tgt = P[idx, chain[2]] + rng.normal(scale=0.08, size=(idx.size, 3))
        tgt[:5] += [0.0, -2.0, 0.0]                             # out of reach
        end = quat_multiply(quat_exp(rng.normal(scale=0.2, size=(idx.size, 3))), G[idx, chain[2]])
        jobs.append((chain, idx, tgt, end, hinge_axis(P, G, chain), None))
    got = {}
    for flag in (True, False):
        monkeypatch.setattr(dm, "USE_COMPILED", flag)
        got[flag] = _ik_legs(P, G, m.rotations, m.skeleton.parents, jobs, 1e-6)
    for a, b in zip(got[True][0], got[False][0]):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[True][1], got[False][1], rtol=0, atol=1e-12)
    assert got[True][1][:5].min() > 0.5 and BEND_PRIOR > 0
