"""Root split about L and seam smoothing (dissertation eq. 5.14, section 5.4.2.2)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
from mocomp.flips.similarity import axis_quat
from mocomp.flips.smoothing import (apply_direction_offsets, apply_rotation_offsets, compose_root, ramp,
                                    root_reference, seam_corrections, shortest_arc, split_root)

AXIS = np.array([0.2, 0.1, -0.97])
AXIS = AXIS / np.linalg.norm(AXIS)


def same_rotation(a, b, atol=1e-9):
    return np.all(quat_angle(quat_multiply(a, quat_inverse(b))) < atol)


def test_split_compose_round_trip_with_and_without_reference():
    q = Rotation.random(300, random_state=3).as_quat()
    th, b = split_root(q, AXIS, unwrap=False)
    assert same_rotation(compose_root(th, b, AXIS), q, 1e-8)
    ref = root_reference(np.array([0.0, 0.0, 1.0]), AXIS)
    th2, b2 = split_root(q, AXIS, ref=ref, unwrap=False)
    np.testing.assert_allclose(b2, b, atol=1e-12)        # b does not depend on the reference
    assert same_rotation(compose_root(th2, b2, AXIS, ref), q, 1e-8)


def test_rotation_about_L_changes_only_theta():
    q = Rotation.random(100, random_state=4).as_quat()
    ref = root_reference(np.array([1.0, 0.0, 0.0]), AXIS)
    a = np.linspace(-7, 7, 100)
    q2 = quat_multiply(axis_quat(AXIS, a), q)
    th, b = split_root(q, AXIS, ref=ref, unwrap=False)
    th2, b2 = split_root(q2, AXIS, ref=ref, unwrap=False)
    np.testing.assert_allclose(b2, b, atol=1e-12)
    d = (th2 - th - a + np.pi) % (2 * np.pi) - np.pi
    np.testing.assert_allclose(d, 0.0, atol=1e-9)


def test_reference_removes_the_antiparallel_singularity():
    """A back flip about the body's -x axis with L along world +x: the plain split is
    singular (b = -L); with the flight's mean b as reference theta is smooth."""
    axis = np.array([1.0, 0.0, 0.0])
    turn = np.linspace(0, 2 * np.pi, 200)
    wob = 0.05 * np.sin(np.linspace(0, 20, 200))
    # body rotates about its own -x axis: q = R_x(-turn) with the body flipped 180 deg about y
    q = (Rotation.from_rotvec(np.outer(turn, [1, 0, 0])) * Rotation.from_rotvec([0, np.pi, 0])
         * Rotation.from_rotvec(np.outer(wob, [0, 0, 1]))).as_quat()
    th0, b = split_root(q, axis)
    assert np.allclose(b[:, 0], -1.0, atol=0.01)          # body-frame L is anti-parallel to world L
    ref = root_reference(b.mean(axis=0), axis)
    th, _ = split_root(q, axis, ref=ref)
    np.testing.assert_allclose(th - th[0], turn, atol=1e-2)
    assert np.max(np.abs(np.diff(th))) < 0.05


def test_shortest_arc_maps_u_to_v_with_no_twist():
    rng = np.random.default_rng(5)
    u = rng.normal(size=(50, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = rng.normal(size=(50, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    q = shortest_arc(u, v)
    np.testing.assert_allclose(Rotation.from_quat(q).apply(u), v, atol=1e-12)
    np.testing.assert_allclose(np.sum(q[:, :3] * v, axis=1), 0, atol=1e-12)
    q2 = shortest_arc(u[:1], -u[:1])                       # opposite: a deterministic half turn
    np.testing.assert_allclose(Rotation.from_quat(q2).apply(u[:1]), -u[:1], atol=1e-12)


def test_ramp_shape():
    w = 4
    r = ramp(np.arange(w + 2), w)
    assert r[0] == 1.0 and r[-1] == pytest.approx(0.0, abs=1e-15)
    assert np.all(np.diff(r) < 0)


@pytest.mark.parametrize("pair_at_left", [True, False])
def test_seam_corrections_meet_in_the_middle(pair_at_left):
    rng = np.random.default_rng(6)
    J, w = 5, 4
    left_ref = Rotation.random(J, random_state=7).as_quat()
    right_ref = (Rotation.from_quat(left_ref) * Rotation.from_rotvec(rng.normal(scale=0.2, size=(J, 3)))).as_quat()
    bl = np.array([1.0, 0.1, 0.0])
    br = np.array([1.0, -0.1, 0.05])
    L, R = seam_corrections(left_ref, right_ref, bl, br, w, pair_at_left)
    # at the pair's instant both sides are moved to the same (middle) pose
    full_l = quat_multiply(left_ref, L.joint_offset)
    full_r = quat_multiply(right_ref, R.joint_offset)
    assert same_rotation(full_l[1:], full_r[1:], 1e-9)
    bm_l = Rotation.from_quat(L.dir_offset).apply(bl / np.linalg.norm(bl))
    bm_r = Rotation.from_quat(R.dir_offset).apply(br / np.linalg.norm(br))
    np.testing.assert_allclose(bm_l, bm_r, atol=1e-12)
    # the weight at the pair's instant is 1 on the side that holds it
    if pair_at_left:
        assert L.weights[-1] == 1.0 and R.weights[0] < 1.0
    else:
        assert R.weights[0] == 1.0 and L.weights[-1] < 1.0
    # the ramp fades to 0 at w + 1 frames from the pair's instant
    holder, other = (L, R) if pair_at_left else (R, L)
    assert np.all(holder.weights > 0) and len(L.weights) == len(R.weights) == w + 1
    assert min(other.weights[0], other.weights[-1]) == pytest.approx(0.0, abs=1e-15)
    # applying to a block that starts at the reference gives the middle at full weight
    blk = np.repeat(left_ref[None], w + 1, axis=0)
    out = apply_rotation_offsets(blk, L)
    np.testing.assert_allclose(out[:, 0], blk[:, 0])          # the root is not touched here
    if pair_at_left:
        assert same_rotation(out[-1, 1:], quat_multiply(left_ref, L.joint_offset)[1:], 1e-9)
    bb = apply_direction_offsets(np.repeat(bl[None] / np.linalg.norm(bl), w + 1, axis=0), L)
    assert np.all(np.abs(np.linalg.norm(bb, axis=1) - 1) < 1e-12)


def test_identical_sides_are_left_unchanged():
    q = Rotation.random(6, random_state=8).as_quat()
    b = np.array([0.0, 0.0, 1.0])
    L, R = seam_corrections(q, q, b, b, 3, True)
    blk = Rotation.random(4 * 6, random_state=9).as_quat().reshape(4, 6, 4)
    assert same_rotation(apply_rotation_offsets(blk, L), blk, 1e-12)
    np.testing.assert_allclose(apply_direction_offsets(np.tile(b, (4, 1)), R), np.tile(b, (4, 1)), atol=1e-12)


def test_loop_seams_all_windows_at_once_equal_each_window_alone():
    """loop_seams evaluates every candidate window in one pass (the blocks laid end to end for L);
    each window's result equals the one-seam construction: seam_corrections, the offsets applied,
    the root recomposed (eq. 5.14), L of that block alone, the reference levels and eq. 5.22 speeds."""
    from mocomp.flips import prepare
    from mocomp.flips.smoothing import loop_seams, reference_levels, seam_speed
    from mocomp.core.rotations import quat_apply

    P = prepare("backflip")
    ws = P.seam_windows()
    assert len(ws) >= 3
    together = loop_seams(P, ws)
    m, n, phi = P.loop.m, P.loop.n, P.loop.phi
    L0, Lv = P.L_magnitude, np.asarray(P.momentum.angular)
    for w in ws:
        left, right, L_new, L_ref, sl, sr = together[w]
        sides = seam_corrections(P.rotations[n], P.rotations[m], P.bdir[n], P.bdir[m], w, pair_at_left=False)
        for frames, side, got in zip((np.arange(n - 1 - w, n), np.arange(m, m + w + 1)), sides, (left, right)):
            want = apply_rotation_offsets(P.rotations[frames], side)
            want[:, 0] = compose_root(P.theta[frames], apply_direction_offsets(P.bdir[frames], side), P.axis,
                                      P.root_ref)
            np.testing.assert_allclose(got, want, atol=1e-14)
        q_phi = axis_quat(P.axis, phi)
        R = np.concatenate([P.rotations[n - 3 - w:n - 1 - w], left, right, P.rotations[m + w + 1:m + w + 3]])
        R[w + 3:, 0] = quat_multiply(q_phi, R[w + 3:, 0])
        np.testing.assert_allclose(L_new, P.momentum_evaluator.angular(R, P.fps), rtol=0, atol=1e-12)
        mid = np.sqrt(L0[n] * L0[m])
        fl = reference_levels(np.ones(w + 2), L0[n], mid, ramp(np.arange(w + 2, 0, -1), w))
        fr = reference_levels(np.ones(w + 2), L0[m], mid, ramp(np.arange(0, w + 2), w))
        want_ref = np.concatenate([Lv[n - 2 - w:n] * fl[:, None],
                                   quat_apply(np.broadcast_to(q_phi, (w + 2, 4)), Lv[m:m + w + 2]) * fr[:, None]])
        np.testing.assert_allclose(L_ref, want_ref, rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(np.concatenate([sl, sr]), seam_speed(L_new, L_ref), rtol=1e-14)
        # and the same as computing this window alone
        alone = loop_seams(P, [w])[w]
        for a, b in zip(alone, together[w]):
            np.testing.assert_allclose(a, b, rtol=1e-14, atol=1e-14)
