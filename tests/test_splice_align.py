"""Two-stage alignment (ch. 6.1-6.2) on ground truth with a known time warp."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.errors import AlignmentError
from mocomp.splice import HandMarkers, MatchPoint, SpliceConfig, align_hands, virtual_hand_markers
from mocomp.splice.align import compose_paths, remap_points
from mocomp.splice.synthetic import (ambiguous_pair, amplitude_profile, gesture_clip, make_splice_pair, synthetic_pair,
                                     time_warp)

from conftest import real_files


def _markers(pair):
    return virtual_hand_markers(pair.body, pair.side), virtual_hand_markers(pair.hand, pair.side)


def test_time_warp_and_amplitude_profile():
    s = time_warp(300, 200, 1, 0.5)
    assert s[0] == 0 and s[-1] == pytest.approx(199) and np.all(np.diff(s) > 0)
    rate = np.diff(s) / (199 / 299)
    assert rate.min() < 0.8 and rate.max() > 1.25  # non-uniform
    np.testing.assert_array_equal(s, time_warp(300, 200, 1, 0.5))  # seeded
    a = amplitude_profile(300, 2, 0.5, 1.5)
    assert a.min() == pytest.approx(0.5) and a.max() == pytest.approx(1.5)


def test_ground_truth_pair_is_what_it_says():
    pair = synthetic_pair(0, noise_deg=0.0, amplitude=(1.0, 1.0))
    sk = pair.body.skeleton
    hand_at_truth = pair.hand.sample(pair.truth / pair.hand.fps)
    j = sk.index("LowerArm_R")
    np.testing.assert_allclose(np.abs(np.sum(pair.body.rotations[:, j] * hand_at_truth.rotations[:, j], axis=1)), 1, atol=1e-9)
    legs = sk.index("UpperLeg_L")
    assert not np.allclose(pair.body.rotations[:, legs], pair.body.rotations[:1, legs])  # walking underneath


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_synthetic_pair_alignment_error(seed):
    """Acceptance on the data-free ground truth (procedural gestures on a
    procedural walk, warp 0.4-2.7x, amplitude 0.5-1.5x, 0.25 deg rotation
    noise = about 2.4 mm marker jitter, ten times the real clips'): mean
    error at most 2 frames at 30 Hz without user points. The taut frame map
    (least-distorting near-optimal alignment) beats the paper's literal
    row-median map, whose staircases inside phases and holds cost frames."""
    pair = synthetic_pair(seed)
    hb, hh = _markers(pair)
    e = align_hands(hb, hh).error(pair.truth)
    assert e["mean"] <= 2.0
    assert e["median"] <= 1.5
    literal = align_hands(hb, hh, frame_map="median").error(pair.truth)
    assert e["mean"] < literal["mean"]


def test_alignment_survives_heavy_noise():
    """Stress test: 1 degree of rotation noise (about 9 mm marker jitter, 40x
    the real clips). Before the taut frame map this gave 2.5 frames."""
    errs = []
    for seed in range(4):
        pair = synthetic_pair(seed, noise_deg=1.0)
        errs.append(align_hands(*_markers(pair)).error(pair.truth)["mean"])
    assert np.mean(errs) <= 2.0, errs


def test_marker_jitter_of_the_ground_truth_is_calibrated():
    """The default noise gives millimetre jitter (raw optical marker level),
    the noise-free pair none to speak of: the estimator sees what was put in."""
    from mocomp.splice.metrics import marker_jitter

    noisy = marker_jitter(virtual_hand_markers(synthetic_pair(0).body).positions)
    clean = marker_jitter(virtual_hand_markers(synthetic_pair(0, noise_deg=0.0).body).positions)
    assert 1.5e-3 < noisy < 3.5e-3
    assert clean < 2e-4


@pytest.mark.parametrize("amplitude,ratio", [((0.5, 1.5), 0.8), ((1.5, 2.5), 1.0)])
def test_sign_metric_beats_values_on_synthetic_ground_truth(amplitude, ratio):
    """Figure 6.4 on the data-free pairs: the first (phase-matching) pass with
    the signs of the derivatives is more accurate than with their values, for
    the issue's 0.5-1.5x amplitude change (by more than 20 %) and for a
    cramped hand capture (body 1.5-2.5x wider; a smaller edge on these slow
    procedural moves: 0.79 over these seeds, 6 of 8 seeds won; on the real
    wave clip it is 5x, see the real-data test). At 1 degree of noise the sign
    metric loses its edge (notebook)."""
    sign, value = [], []
    for seed in range(4):
        pair = synthetic_pair(seed, amplitude=amplitude)
        hb, hh = _markers(pair)
        sign.append(np.abs(align_hands(hb, hh, refine=False).stage1_map - pair.truth).mean())
        value.append(np.abs(align_hands(hb, hh, refine=False, metric="values").stage1_map - pair.truth).mean())
    assert np.mean(sign) < ratio * np.mean(value), (sign, value)


@pytest.mark.realdata
@pytest.mark.parametrize("path", real_files("hands/bandai2_*.bvh"), ids=lambda p: p.name)
def test_real_gesture_ground_truth_within_two_frames(path, real_data_dir):
    """Acceptance: a real gesture clip as the hand recording, spliced onto a
    real walk with a known warp, amplitude 0.5-1.5x and noise: mean alignment
    error <= 2 frames at 30 Hz, without user points."""
    from mocomp.io import read_bvh

    hand = read_bvh(path)
    walk = read_bvh(real_data_dir / "walks" / "bandai2_walk_normal_001.bvh")
    side = "left" if "left-hand" in path.name else "right"
    errs = []
    for seed in (0, 1):
        pair = make_splice_pair(hand, walk, seed, side=side)
        al = align_hands(*_markers(pair))
        errs.append(al.error(pair.truth)["mean"])
    assert max(errs) <= 2.0, errs


@pytest.mark.parametrize("seed", [1, 2])
def test_alignment_is_invariant_to_the_hand_recordings_heading(seed):
    """The hand recording turned about the vertical by 0, 70, 120 degrees, or
    turning 0 -> 120 degrees over the take: the first pass turns it back (eq.
    6.7 theta / trunk headings), and so must the second (eq. 6.9 compares
    world-frame vectors). Without the turn (``refine_theta="none"``, the
    behaviour before) the final error grew 0.8 -> 3.2 -> 4.4 (seed 1) and
    1.3 -> 8.2 -> 22.4 frames (seed 2), 7.9 / 12.3 when turning; now a
    constant turn stays within 0.1 frames of the unturned pair's error
    (0.88 / 0.90 / 0.88 and 1.21 / 1.22 / 1.21 with eq. 6.7) and the turning
    take within 2 frames (0.68 / 1.15)."""
    m = synthetic_pair(seed).hand.n_frames
    headings = (0.0, 70.0, 120.0, np.linspace(0.0, 120.0, m))
    for theta in ("window", "trunk"):
        errs = []
        for hd in headings:
            pair = synthetic_pair(seed, heading_deg=hd)
            errs.append(align_hands(*_markers(pair), theta=theta).error(pair.truth)["mean"])
        assert max(errs) <= 2.0, (theta, errs)
        assert max(errs[:3]) - min(errs[:3]) <= 0.1, (theta, errs)  # a constant turn changes (almost) nothing
    pair = synthetic_pair(seed, heading_deg=120.0)
    assert align_hands(*_markers(pair), refine_theta="none").error(pair.truth)["mean"] > 3.0  # the bug this guards


def test_turned_pair_is_what_it_says():
    """heading_deg turns only the hand recording: its arm markers relative to
    the shoulder are the unturned ones rotated by R_y(heading); truth and body unchanged."""
    a, b = synthetic_pair(0), synthetic_pair(0, heading_deg=70.0)
    np.testing.assert_array_equal(a.truth, b.truth)
    np.testing.assert_allclose(a.body.rotations, b.body.rotations)
    ha, hb = virtual_hand_markers(a.hand), virtual_hand_markers(b.hand)
    c, s = np.cos(np.radians(70)), np.sin(np.radians(70))
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    np.testing.assert_allclose(hb.relative, ha.relative @ R.T, atol=1e-9)
    np.testing.assert_allclose(np.unwrap(hb.trunk_heading - ha.trunk_heading), np.radians(70), atol=1e-9)
    with pytest.raises(AlignmentError, match="heading_deg"):
        synthetic_pair(0, heading_deg=np.zeros(3))


@pytest.mark.realdata
@pytest.mark.parametrize("path", real_files("hands/bandai2_*.bvh"), ids=lambda p: p.name)
def test_real_gesture_onto_turning_walk_within_two_frames(path, real_data_dir):
    """A real gesture spliced onto the Bandai walk that turns left (the
    body's heading changes while the hand capture faces one way): mean error
    <= 2 frames after both passes. Before the second pass turned the hand
    vectors into the body's heading, the wave gave 16.8 / 17.9 frames (first
    pass 0.9 / 0.6); now 0.9 / 0.6 (raise-up 1.8 / 1.6, the short clip)."""
    from mocomp.io import read_bvh

    hand = read_bvh(path)
    walk = read_bvh(real_data_dir / "walks" / "bandai2_walk-turn-left_normal_001.bvh")
    side = "left" if "left-hand" in path.name else "right"
    errs = []
    for seed in (0, 1):
        pair = make_splice_pair(hand, walk, seed, side=side)
        errs.append(align_hands(*_markers(pair)).error(pair.truth)["mean"])
    assert max(errs) <= 2.0, errs


@pytest.mark.realdata
def test_sign_metric_beats_values_when_amplitudes_differ(real_data_dir):
    """Figure 6.4: with amplitude differences the first (phase-matching) pass
    aligns better with the signs of the derivatives than with their values."""
    from mocomp.io import read_bvh

    hand = read_bvh(real_data_dir / "hands" / "bandai2_wave-right-hand_normal_001.bvh")
    walk = read_bvh(real_data_dir / "walks" / "bandai2_walk_normal_001.bvh")
    sign, value = [], []
    for seed in range(4):
        pair = make_splice_pair(hand, walk, seed, amplitude=(1.5, 2.5))  # cramped hand capture: body swings wider
        hb, hh = _markers(pair)
        sign.append(np.abs(align_hands(hb, hh, refine=False).hand_frame - pair.truth).mean())
        value.append(np.abs(align_hands(hb, hh, refine=False, metric="values").hand_frame - pair.truth).mean())
    assert np.mean(sign) < 0.5 * np.mean(value), (sign, value)


@pytest.mark.parametrize("seed", range(6))
def test_user_points_fix_the_ambiguous_case(seed):
    """Identical gesture cycles; the body leaves the last one out. Without
    points the alignment skips a wrong cycle; two matching points fix it."""
    pair = ambiguous_pair(seed)
    hb, hh = _markers(pair)
    auto = align_hands(hb, hh)
    fixed = align_hands(hb, hh, points=pair.points)
    assert auto.error(pair.truth)["mean"] > 5.0
    assert fixed.error(pair.truth)["mean"] <= 2.0
    np.testing.assert_array_equal(fixed.point_residuals(), 0.0)  # exact points are honoured after both passes
    for p in fixed.points:
        assert fixed.hand_frame[p.x] == pytest.approx(p.y, abs=1e-6)


def test_points_with_tolerance_are_honoured():
    pair = synthetic_pair(4)
    hb, hh = _markers(pair)
    x = pair.body.n_frames // 3
    y = int(pair.truth[x]) + 25  # deliberately off the truth
    al = align_hands(hb, hh, points=[MatchPoint(x, y, 3)])
    assert np.all(np.abs(al.matches(x) - y) <= 3)
    assert abs(al.hand_frame[x] - y) <= 3 + 1e-9
    assert al.points2 and al.points2[0].x == x


def test_remap_and_compose():
    map1 = np.array([0, 0, 1, 2, 4, 5, 5, 6, 8, 9.0])
    pts = remap_points((MatchPoint(3, 2, 0), MatchPoint(6, 5, 1)), map1, 10)
    assert pts[0] == MatchPoint(3, 3, 0)
    assert pts[1].y in (5, 6) and pts[1].tol >= 1
    with pytest.raises(AlignmentError, match="same warped frame"):
        remap_points((MatchPoint(5, 3, 0), MatchPoint(6, 4, 0)), np.array([0, 1, 2, 2.5, 2.8, 3, 6, 7, 8, 9]), 10)
    p1 = np.array([[0, 0], [1, 1], [1, 2], [2, 3]])
    p2 = np.array([[0, 0], [1, 0], [2, 1], [3, 2]])
    np.testing.assert_array_equal(compose_paths(p2, p1, 3), [[0, 0], [1, 0], [2, 1], [2, 2], [3, 3]])


@pytest.mark.parametrize("cfg", [dict(theta="trunk"), dict(theta="none"), dict(refine=False), dict(metric="values"),
                                 dict(refine_theta="window"), dict(refine_theta="none"), dict(refine_theta_span=0.0),
                                 dict(refine_step_cost=0.0), dict(frame_map="median"),
                                 dict(frame_map="median", refine=False), dict(tie_cells=0.0)])
def test_variants_run_and_stay_close(cfg):
    pair = synthetic_pair(1)
    al = align_hands(*_markers(pair), **cfg)
    assert al.error(pair.truth)["mean"] < 5.0
    assert (al.pass2 is None) == (cfg.get("refine") is False)


def test_bad_input():
    pair = synthetic_pair(0)
    hb, hh = _markers(pair)
    with pytest.raises(AlignmentError, match="frame rate"):
        align_hands(hb, HandMarkers(hh.positions, 60.0, hh.shoulder))
    with pytest.raises(AlignmentError, match="at least"):
        align_hands(hb, hh[:4])
    with pytest.raises(AlignmentError, match="trunk heading"):
        align_hands(hb, HandMarkers(hh.positions, hh.fps, hh.shoulder), theta="trunk")
    with pytest.raises(AlignmentError, match="positive fraction"):
        SpliceConfig(phase_width=0)
    with pytest.raises(ValueError, match="frame_map"):
        SpliceConfig(frame_map="mean")
    with pytest.raises(AlignmentError, match="tie_cells"):
        SpliceConfig(tie_cells=-0.1)
    with pytest.raises(ValueError, match="refine_theta"):
        SpliceConfig(refine_theta="heading")
    with pytest.raises(AlignmentError, match="refine_theta_span"):
        SpliceConfig(refine_theta_span=-1.0)
    with pytest.raises(AlignmentError, match="out of order"):
        align_hands(hb, hh, points=[(100, 50), (90, 60)])
    g = gesture_clip(0, 1)
    with pytest.raises(AlignmentError, match="arm joints"):
        make_splice_pair(g.motion, g.motion.replace(skeleton=_no_arm(g.motion.skeleton)), 0)


def _no_arm(sk):
    from mocomp.core import Skeleton

    names = tuple(n + "_x" if n == "Shoulder_R" else n for n in sk.names)
    return Skeleton(names, sk.parents, sk.offsets, sk.channels, sk.end_sites)
