"""The splice measures its own quality (issue #19 item 7): frozen or reversed
hand, warp slope, eq. 6.9 residual; warnings with frames; verified suggestions."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from mocomp.errors import AlignmentError
from mocomp.splice import splice_motions
from mocomp.splice.pipeline import _merge_arm, _spliced_hand, arm_layer_joints
from mocomp.splice.quality import QualityThresholds, dominant_period, measure_quality
from mocomp.splice.synthetic import synthetic_pair
from mocomp.splice.warpmap import rasterize_map


@pytest.fixture(scope="module")
def spliced():
    pair = synthetic_pair(3)
    return pair, splice_motions(pair.body, pair.hand, suggest=False)


def _measure_with_map(pair, res, f):
    """Splice again with the frame map ``f`` forced (merge + blend as the pipeline does) and measure."""
    al = res.alignments["right"]
    a2 = replace(al, hand_frame=np.asarray(f, float), path=rasterize_map(f, al.m))
    idx = arm_layer_joints(pair.body.skeleton, "right")
    rot, _ = _merge_arm(pair.body, pair.hand, a2, idx, idx, 7, 1.5)
    return measure_quality(a2, _spliced_hand(rot, pair.body, "right", None, a2))


def test_true_map_has_no_problem_stretches(spliced):
    pair, res = spliced
    q = _measure_with_map(pair, res, pair.truth)
    assert q.stretches == ()
    assert q.ok and q.frozen_frames == 0
    assert np.median(q.residual_deg) < 5.0  # eq. 6.9 at the truth: the noise only (amplitude leaves the wrist alone)


def test_a_stalled_map_is_reported_frozen_at_its_frames(spliced):
    pair, res = spliced
    f = pair.truth.copy()
    a, b = 112, 150  # the hand recording moves fast at truth[112]
    f[a:b] = f[a]
    q = _measure_with_map(pair, res, f)
    fr = q.of_kind("frozen")
    assert len(fr) == 1, [s.describe() for s in q.stretches]
    # the jump back to the truth at b is blended over the 7-frame window, so the stall ends a few frames early
    assert abs(fr[0].start - a) <= 3 and abs(fr[0].stop - b) <= 5
    sl = q.of_kind("slope")
    assert sl and min(s.start for s in sl) <= a + 3 and min(s.value for s in sl) < 0.05
    assert q.map_stall_frames >= b - a - 1
    w = q.warnings()
    assert any(f"body frames {fr[0].start}-{fr[0].stop - 1}" in x and "frozen" in x for x in w)


def test_a_hand_moving_against_the_body_is_reported_reversed(spliced):
    pair, res = spliced
    al = res.alignments["right"]
    rel = np.array(al.body_features.rel[:, 3])
    a, b = 60, 100  # the spliced hand replays this stretch backwards
    rel[a:b] = rel[a:b][::-1]
    q = measure_quality(al, rel)
    rv = q.of_kind("reversed")
    assert len(rv) == 1 and a - 4 <= rv[0].start and rv[0].stop <= b + 4 and rv[0].value < -0.5
    assert rv[0].frames >= 0.4 * (b - a)  # the windowed cosine is diluted where the reversed stretch meets its ends
    assert not measure_quality(al, al.body_features.rel[:, 3]).of_kind("reversed")


def test_slope_range_and_residual_thresholds_are_applied(spliced):
    pair, res = spliced
    f = pair.truth.copy()
    n = len(f)
    q_shift = _measure_with_map(pair, res, np.clip(f + 6, 0, res.alignments["right"].m - 1))
    q_true = _measure_with_map(pair, res, f)
    assert np.median(q_shift.residual_deg) > 2 * np.median(q_true.residual_deg)
    al = res.alignments["right"]
    strict = measure_quality(al, _spliced_hand(np.array(res.motion.rotations), pair.body, "right", None, al),
                             thresholds=QualityThresholds(slope_range=(0.9, 1.1), residual_deg=1.0))
    assert strict.of_kind("slope") and strict.of_kind("residual")
    assert all(0 <= s.start < s.stop <= n for s in strict.stretches)
    with pytest.raises(AlignmentError, match="slope_range"):
        QualityThresholds(slope_range=(1.2, 3.0))


def test_dominant_period_of_a_sine():
    fps = 30.0
    t = np.arange(300) / fps
    assert dominant_period(np.abs(np.sin(2 * np.pi * 1.25 * t)), fps) == pytest.approx(0.4, abs=1 / fps)
    assert dominant_period(np.ones(100), fps) is None


def test_report_and_summary_carry_the_quality(spliced):
    pair, res = spliced
    d = res.to_dict()
    json.dumps(d)
    q = d["arms"]["right"]["quality"]
    assert set(q) >= {"stretches", "frozen_frames", "thresholds", "median_residual_deg", "suggestion", "map_stall_frames"}
    assert "quality:" in res.summary()


# ------------------------------------------------------------------ real data: the wave pair
@pytest.fixture(scope="module")
def wave(real_data_dir):
    from mocomp import datasets

    d = real_data_dir / "hands"
    return (datasets.load(d / "bandai2_wave-both-hands_normal_001.bvh"),
            datasets.load(d / "bandai2_wave-right-hand_normal_001.bvh"))


@pytest.mark.realdata
def test_wave_freeze_is_warned_with_its_frames_and_a_verified_suggestion(wave):
    body, hand = wave
    res = splice_motions(body, hand)
    q = res.quality["right"]
    fr = q.of_kind("frozen")
    # the issue: 47 frames (37-83) frozen with the taut map
    assert fr and fr[0].frames >= 40 and 34 <= fr[0].start <= 40 and 80 <= fr[0].stop - 1 <= 86
    assert q.map_stall_frames >= 45
    assert any("frozen" in w and f"{fr[0].start}-{fr[0].stop - 1}" in w for w in res.warnings())
    sug = q.suggestion
    assert sug is not None and len(sug.new_points) == 2 and all(p.tol > 0 for p in sug.new_points)
    assert sug.frozen_before == q.frozen_frames and sug.frozen_after <= 4
    # verify the suggestion independently: splice again with the points
    again = splice_motions(body, hand, sug.points, suggest=False)
    q2 = again.quality["right"]
    assert q2.frozen_frames == sug.frozen_after
    assert q2.map_stall_frames <= 12 < q.map_stall_frames


@pytest.mark.realdata
def test_paper_literal_median_map_freeze_is_warned_too(wave):
    body, hand = wave
    q = splice_motions(body, hand, frame_map="median", suggest=False).quality["right"]
    assert q.frozen_frames >= 45  # the issue: 54 frames with the paper's row medians


@pytest.mark.realdata
def test_cli_warns_on_stderr_and_reports(real_data_dir, tmp_path, capsys):
    from mocomp.cli import main

    d = real_data_dir / "hands"
    rc = main(["splice", str(d / "bandai2_wave-both-hands_normal_001.bvh"), str(d / "bandai2_wave-right-hand_normal_001.bvh"),
               "-o", str(tmp_path / "o.bvh"), "--report", str(tmp_path / "r.json"), "--plot", str(tmp_path / "p.png"),
               "--no-audit"])
    assert rc == 0
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.startswith("mocomp splice: warning: right arm: hand frozen")]
    assert lines and "body frames" in lines[0]
    assert "mocomp splice: warning: right arm: two tolerant matching points would cut the freeze: --match" in err
    r = json.loads((tmp_path / "r.json").read_text())
    q = r["arms"]["right"]["quality"]
    assert q["frozen_frames"] >= 40 and q["suggestion"]["frozen_after"] <= 4
    assert r["warnings"] and (tmp_path / "p.png").stat().st_size > 20_000


@pytest.mark.realdata
def test_suggestion_keeps_the_users_points(wave):
    body, hand = wave
    res = splice_motions(body, hand, ["160:150~4"])
    sug = res.quality["right"].suggestion
    assert sug is not None and "160:150~4" in [str(p) for p in sug.points]
    xs = [p.x for p in sug.points]
    assert xs == sorted(xs) and len(sug.points) == 3
    assert sug.frozen_after < sug.frozen_before
