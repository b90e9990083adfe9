"""Merging and smoothing (ch. 6.2) and the splice end to end: skeleton
clips (BVH) and optical markers (the HDM05 C3D)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.errors import AlignmentError
from mocomp.splice import splice_markers, splice_motions
from mocomp.splice.merge import blend_discontinuities, median_frames, median_rotations
from mocomp.splice.pipeline import arm_layer_joints
from mocomp.splice.synthetic import make_marker_pair, synthetic_pair


def test_median_frames_known_answer():
    vals = np.array([[0.0], [10.0], [1.0], [5.0], [7.0]])
    path = np.array([[0, 0], [1, 1], [1, 2], [1, 3], [2, 4]])
    np.testing.assert_array_equal(median_frames(vals, path, 3), [[0.0], [5.0], [7.0]])
    with pytest.raises(AlignmentError, match="every body frame"):
        median_frames(vals, np.array([[0, 0], [2, 4]]), 3)


def test_median_rotations_middle_of_a_monotone_run_and_sign_invariant():
    angles = np.radians([0, 10, 20, 30, 40])
    q = Rotation.from_rotvec(np.outer(angles, [0, 0, 1])).as_quat()[:, None, :]
    q[3] *= -1  # same rotation, other hemisphere
    path = np.array([[0, 0], [0, 1], [0, 2], [0, 3], [0, 4], [1, 4]])
    out = median_rotations(q, path, 2)
    assert Rotation.from_quat(out[0, 0]).magnitude() == pytest.approx(np.radians(20), abs=1e-9)
    np.testing.assert_allclose(np.abs(out[1, 0] @ q[4, 0]), 1.0)


def test_blending_removes_a_jump_and_leaves_the_rest():
    t = np.linspace(0, 2 * np.pi, 100)
    x = np.stack([np.sin(t), np.cos(t)], axis=1)
    hand_time = np.arange(100.0)
    hand_time[50:] += 6  # the hand motion skips 6 frames between body frames 49 and 50
    xj = x.copy()
    xj[50:] = np.stack([np.sin(t[50:] + 0.4), np.cos(t[50:] + 0.4)], axis=1)
    y, rep = blend_discontinuities(xj, hand_time, window=9)
    assert rep.frames == (49,)
    assert rep.jump_after < 0.5 * rep.jump_before
    np.testing.assert_array_equal(y[:40], xj[:40])  # untouched outside the window
    np.testing.assert_array_equal(y[60:], xj[60:])
    y2, rep2 = blend_discontinuities(x, np.arange(100.0), window=9)
    assert rep2.frames == () and np.array_equal(y2, x)


@pytest.fixture(scope="module")
def pair():
    return synthetic_pair(2)


def test_splice_motions_drives_the_arm_from_the_hand_clip(pair):
    res = splice_motions(pair.body, pair.hand)
    out, body, hand = res.motion, pair.body, pair.hand
    al = res.alignments["right"]
    sk = body.skeleton
    arm = arm_layer_joints(sk, "right")
    assert [sk.names[j] for j in arm] == ["Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R"]
    others = [j for j in range(sk.n_joints) if j not in arm]
    np.testing.assert_array_equal(out.rotations[:, others], body.rotations[:, others])  # the body's own motion
    np.testing.assert_array_equal(out.root_positions, body.root_positions)
    # where a body frame has exactly one hand frame and no blending nearby, the arm is
    # the hand clip at the (fractional) frame the map gives: slerp between its neighbours
    starts = np.searchsorted(al.path[:, 0], np.arange(al.n))
    stops = np.searchsorted(al.path[:, 0], np.arange(al.n), side="right")
    near = np.zeros(al.n, bool)
    for f in res.blends["right"].frames:
        near[max(0, f - 5):f + 6] = True
    single = np.nonzero((stops - starts == 1) & ~near)[0]
    assert len(single) > 0.3 * al.n
    j = hand.skeleton.index("LowerArm_R")
    at_map = hand.sample(al.hand_frame[single] / hand.fps).rotations[:, j]
    d = np.abs(np.sum(out.rotations[single, j] * at_map, axis=1))
    np.testing.assert_allclose(d, 1.0, atol=1e-9)
    # ... and where several hand frames match, the component-wise median of their rotations
    multi = np.nonzero((stops - starts >= 3) & ~near)[0]
    assert len(multi) > 0
    for i in multi[:5]:
        block = hand.rotations[al.path[starts[i]:stops[i], 1], j]
        block = block * np.sign(block @ block[0])[:, None]
        med = np.median(block, axis=0)
        np.testing.assert_allclose(np.abs(out.rotations[i, j] @ (med / np.linalg.norm(med))), 1.0, atol=1e-12)
    # the spliced arm follows the hand clip at the true frames: small angle error vs the (unscaled) truth
    truth_rot = hand.sample(pair.truth / hand.fps).rotations[:, j]
    ang = 2 * np.degrees(np.arccos(np.clip(np.abs(np.sum(out.rotations[:, j] * truth_rot, axis=1)), 0, 1)))
    assert np.median(ang) < 3.0
    assert "right arm" in res.summary()
    assert set(res.timings) >= {"align", "merge", "total"}


def _roughness(motion):
    """Mean |second difference| of the wrist relative to the shoulder (m/frame^2)."""
    y = motion.joint_positions("Hand_R") - motion.joint_positions("UpperArm_R")
    return float(np.mean(np.linalg.norm(np.diff(y, 2, axis=0), axis=1)))


def test_spliced_arm_is_as_smooth_as_the_performance(pair):
    """Section 3: the merged arm must not stutter. With the taut frame map the
    wrist's frame-to-frame acceleration is that of the hand clip played at the
    true frames (within 30 %); the paper-literal row-median map repeats and
    skips frames and stays far rougher even after blending its discontinuities."""
    truth = _roughness(pair.hand.sample(pair.truth / pair.hand.fps))
    taut = _roughness(splice_motions(pair.body, pair.hand).motion)
    literal = splice_motions(pair.body, pair.hand, frame_map="median")
    assert taut < 1.3 * truth
    assert _roughness(literal.motion) > 1.5 * taut
    assert len(literal.blends["right"].frames) > 0


def test_splice_layers_both_arms_and_resampling(pair):
    res = splice_motions(pair.body, pair.hand, side="both", layer="hand")
    assert set(res.alignments) == {"right", "left"}
    assert res.joints["right"] == ("Hand_R",) and res.joints["left"] == ("Hand_L",)
    hand60 = pair.hand.resample(60.0)
    res2 = splice_motions(pair.body, hand60, [(150, 2 * int(pair.truth[150]), 4)])
    assert res2.hand_resampled == (60.0, 30.0)
    assert res2.alignments["right"].points[0].y == int(pair.truth[150])
    assert np.all(np.abs(res2.alignments["right"].matches(150) - int(pair.truth[150])) <= 2)


def test_splice_bad_input(pair):
    from mocomp.core import Skeleton

    sk = pair.hand.skeleton
    names = tuple("Wrist_R" if n == "Hand_R" else n for n in sk.names)
    other = pair.hand.replace(skeleton=Skeleton(names, sk.parents, sk.offsets, sk.channels, sk.end_sites))
    with pytest.raises(Exception, match="arm joints|lacks the joints"):
        splice_motions(pair.body, other)
    with pytest.raises(ValueError, match="side"):
        splice_motions(pair.body, pair.hand, side="middle")
    with pytest.raises(ValueError, match="layer"):
        splice_motions(pair.body, pair.hand, layer="leg")
    with pytest.raises(AlignmentError, match="outside the matrix"):
        splice_motions(pair.body, pair.hand, [(5, 100000)])


@pytest.mark.realdata
def test_real_walk_with_wave_bvh_roundtrip(real_data_dir, tmp_path):
    """A real gesture clip spliced onto a real walk, written and read back as BVH."""
    from mocomp.io import read_bvh, write_bvh

    walk = read_bvh(real_data_dir / "walks" / "bandai2_walk_normal_001.bvh")
    wave = read_bvh(real_data_dir / "hands" / "bandai2_wave-right-hand_normal_001.bvh")
    res = splice_motions(walk, wave)
    out = tmp_path / "walk_wave.bvh"
    write_bvh(res.motion, out)
    back = read_bvh(out, scale="m")
    assert back.n_frames == walk.n_frames
    np.testing.assert_allclose(back.positions, res.motion.positions, atol=1e-5)
    hand_y = res.motion.joint_positions("Hand_R")[:, 1] - res.motion.joint_positions("Head")[:, 1]
    walk_y = walk.joint_positions("Hand_R")[:, 1] - walk.joint_positions("Head")[:, 1]
    assert np.mean(hand_y > 0) > 0.3 > np.mean(walk_y > 0)  # now the hand is raised above the head often: waving


@pytest.mark.realdata
def test_hdm05_c3d_marker_path_end_to_end(real_data_dir):
    """The optical-marker path on the HDM05 C3D (Plug-in-Gait wrist/forearm/
    finger markers, 120 Hz): a warped, amplitude-changed copy with 2 mm noise
    as the body recording, the original as the hand recording."""
    from mocomp.io.c3d import read_c3d

    m = read_c3d(real_data_dir / "hands" / "HDM_dg_06-03_03_120.c3d")
    errs = []
    for seed in (0, 1):
        p = make_marker_pair(m, seed)
        res = splice_markers(p.body, p.hand)
        al = res.alignments["right"]
        assert al.hand_features.n_frames == m.n_frames and res.markers.positions.shape == p.body.positions.shape
        errs.append(al.error(p.truth)["mean"])
        # the spliced wrist markers sit at the body's shoulder + the hand recording's arm: close to the truth
        idx = [p.body.names.index(n) for n in res.joints["right"]]
        sh = p.body.names.index("Daniel:RSHO")
        truth_rel = np.stack([np.interp(p.truth, np.arange(m.n_frames), m.positions[:, k, c] - m.positions[:, sh, c])
                              for k in idx for c in range(3)], axis=1).reshape(-1, len(idx), 3)
        got_rel = res.markers.positions[:, idx] - p.body.positions[:, sh][:, None]
        assert np.median(np.linalg.norm(got_rel - truth_rel, axis=2)) < 0.03
    assert max(errs) < 3.0, errs  # frames at 120 Hz (25 ms)


_ARM = ("RWRA", "RWRB", "RFRM", "RFIN", "RSHO")


def _arm_only(m, names, positions=None, source="subset"):
    from mocomp.io.markers import Markers

    idx = [m.names.index("Daniel:" + n) for n in names]
    P = np.nan_to_num(m.positions[:, idx]) if positions is None else positions
    return Markers(tuple(names), P, m.fps, m.mask[:, idx], source=source)


@pytest.mark.realdata
def test_marker_splice_theta_window_is_clamped_at_the_ends(real_data_dir):
    """No trunk heading (no waist or left shoulder marker): the arm layer
    turns the hand recording by eq. 6.7 between matched frames. The body is
    the same arm turned 40 degrees about the vertical; every frame, the
    first and last two included (which used to get theta = 0, 0.16 m
    off), comes back to the body's own markers within 1.5 cm."""
    from mocomp.io.c3d import read_c3d
    from mocomp.splice import hand_markers_from_markers

    m = read_c3d(real_data_dir / "hands" / "HDM_dg_06-03_03_120.c3d")
    hand = _arm_only(m, _ARM)
    assert hand_markers_from_markers(hand).trunk_heading is None
    c, s = np.cos(np.radians(40)), np.sin(np.radians(40))
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    body = _arm_only(m, _ARM, np.nan_to_num(hand.positions) @ R.T, "turned")
    res = splice_markers(body, hand)
    err = np.linalg.norm(res.markers.positions[:, :4] - body.positions[:, :4], axis=2).max(axis=1)
    assert err.max() < 0.015, err
    assert err[[0, 1, -2, -1]].max() < 0.01


@pytest.mark.realdata
def test_hand_only_capture_drives_the_hand_marker_in_the_forearm_frame(real_data_dir):
    """A hand-only capture (the four arm markers, no shoulder, the body
    static): the hand marker is carried in the forearm's frame onto the
    body's forearm (layer 'hand'); the body's wrist and forearm markers stay.
    Against the truth (the hand recording's FIN in its forearm frame at the
    true frames, put on the body's forearm) the spliced FIN is within 1.2 /
    1.5 mm (median) here; layer='arm' explains why it cannot be used."""
    from mocomp.io.c3d import read_c3d
    from mocomp.splice import hand_markers_from_markers
    from mocomp.splice.markers import forearm_frame

    m = read_c3d(real_data_dir / "hands" / "HDM_dg_06-03_03_120.c3d")
    ks = [m.names.index("Daniel:" + n) for n in _ARM]
    rel = np.nan_to_num(m.positions[:, ks[:4]]) - np.nan_to_num(m.positions[:, ks[4]])[:, None] + [0.0, 1.2, 0.3]
    hand_only = _arm_only(m, _ARM[:4], rel, "hand-only")
    hh = hand_markers_from_markers(hand_only)
    assert hh.shoulder is None and any("no shoulder marker" in n for n in hh.notes)
    ch, Rh = forearm_frame(hh.positions)
    local = np.einsum("tji,tj->ti", Rh, hh.positions[:, 3] - ch)
    for seed in (0, 1):
        p = make_marker_pair(m, seed)
        res = splice_markers(p.body, hand_only)
        assert res.joints["right"] == ("Daniel:RFIN",) and "hand layer" in res.markers.notes[-1]
        assert res.alignments["right"].error(p.truth)["mean"] < 2.0  # frames at 120 Hz
        hb = hand_markers_from_markers(p.body)
        cb, Rb = forearm_frame(hb.positions)
        want = cb + np.einsum("tij,tj->ti", Rb, np.stack([np.interp(p.truth, np.arange(m.n_frames), local[:, k]) for k in range(3)], 1))
        fin = p.body.names.index("Daniel:RFIN")
        assert np.nanmedian(np.linalg.norm(res.markers.positions[:, fin] - want, axis=1)) < 0.003
        others = [p.body.names.index("Daniel:" + n) for n in _ARM[:3]]
        np.testing.assert_array_equal(res.markers.positions[:, others], p.body.positions[:, others])
    with pytest.raises(AlignmentError, match=r"layer='arm' .* need a right shoulder marker; the hand recording \(hand-only\) has none. Use layer='hand'"):
        splice_markers(p.body, hand_only, layer="arm")
    with pytest.raises(ValueError, match="layer"):
        splice_markers(p.body, hand_only, layer="elbow")


def test_forearm_frame_known_answer_and_degenerate_frame():
    from mocomp.splice.markers import forearm_frame

    P = np.array([[[0.0, 0.02, 0.0], [0.0, -0.02, 0.0], [-0.1, 0.0, 0.0], [0.05, 0.0, 0.01]]] * 3)
    c, R = forearm_frame(P)
    np.testing.assert_allclose(c, 0.0, atol=1e-15)
    np.testing.assert_allclose(R[0], [[-1, 0, 0], [0, 1, 0], [0, 0, -1]], atol=1e-15)  # e1 -x, e2 +y, e3 = e1 x e2
    Q = P.copy()
    Q[2, 0], Q[2, 1] = [-0.05, 0.0, 0.0], [0.05, 0.0, 0.0]  # wrist axis along the forearm
    with pytest.raises(AlignmentError, match="frame 2: the wrist markers' axis"):
        forearm_frame(Q)
