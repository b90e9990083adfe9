"""The physics audit (mocomp.audit): planted defects are found with their frames and sizes, clean
synthetic motions pass, numbers agree with independent numpy computations, every real clip audits."""
from __future__ import annotations

import dataclasses
import json
import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import real_files
from mocomp import datasets
from mocomp.audit import AuditConfigError, AuditThresholds, audit
from mocomp.audit.com import velocity_jumps
from mocomp.audit.flights import L_spread, fit_ballistic
from mocomp.audit.kinematics import bone_length_deviation
from mocomp.errors import MotionFormatError
from mocomp.synth.registry import make_example

EXAMPLES = ["backflip", "frontflip", "sideflip", "jump", "twist180", "twist360"]


@pytest.fixture(scope="module")
def bf():
    return make_example("backflip")


@pytest.fixture(scope="module")
def bf_report(bf):
    return audit(bf.motion, bf.body, name="backflip")


def lowest_by_numpy(motion):
    """The lowest y of every joint and end site per frame, from the raw FK arrays."""
    P, G = motion.fk()
    ys = [P[..., 1]]
    for e in motion.skeleton.end_sites:
        off = Rotation.from_quat(np.array(G[:, e.parent])).apply(np.array(e.offset))
        ys.append((P[:, e.parent] + off)[:, 1:2])
    return np.concatenate(ys, axis=1).min(axis=1)


# ------------------------------------------------------------------ clean motions pass
@pytest.mark.parametrize("name", EXAMPLES)
def test_clean_synthetic_examples_pass_with_the_true_flight_and_g(name):
    r = make_example(name)
    rep = audit(r.motion, r.body, name=name)
    assert rep.verdict == "pass", [f.line() for f in rep.violations]
    assert rep.violations == ()
    assert len(rep.phases.flights) == 1
    a, b = rep.phases.flights[0]
    assert r.flight[0] <= a and b <= r.flight[1] and (b - a) >= 0.85 * (r.flight[1] - r.flight[0])
    fit = rep.flights[0].fit
    assert fit.g == pytest.approx(r.g, abs=1e-6)           # the COM is an exact parabola in flight
    assert fit.rms < 1e-9 and fit.rms_standard < 1e-9
    assert rep.penetration.max_depth < 1e-9
    assert rep.kinematics.bone_length < 1e-9
    # the take-off velocity and angle agree with the generator's exact COM parabola
    v = r.com_velocity_target([r.motion.times[a]])[0]
    np.testing.assert_allclose(rep.flights[0].takeoff_velocity, v, atol=1e-6)
    assert rep.flights[0].takeoff_angle == pytest.approx(math.atan2(math.hypot(v[0], v[2]), v[1]), abs=1e-6)


def test_flight_L_from_the_clip_fk_equals_momentum_of_the_sliced_flight(bf):
    from mocomp.audit.flights import flight_L
    from mocomp.dynamics import momentum, segment_positions

    m, body = bf.motion, bf.body
    a, b = bf.flight
    pos = segment_positions(body, m)
    rot = np.asarray(m.global_rotations[:, body.segment_joint])
    np.testing.assert_allclose(flight_L(body, m.times[a:b], pos[a:b], rot[a:b]),
                               momentum(body, m[a:b]).angular, rtol=1e-12, atol=1e-12)


def test_synthetic_flight_L_measures_are_small_and_judged(bf_report, bf):
    f = bf_report.flights[0]
    assert f.L_judged
    assert f.L_magnitude < 0.01 and f.L_direction < 1e-3
    np.testing.assert_allclose(f.L_mean, bf.L0, rtol=0.01)


# ------------------------------------------------------------------ planted defects
def test_foot_pushed_5cm_into_the_floor_is_found_on_those_frames(bf):
    m = bf.motion
    a, b = bf.phases["hold"][0] + 3, bf.phases["hold"][1] - 3
    rp = np.array(m.root_positions)
    rp[a:b, 1] -= 0.05
    bad = m.replace(root_positions=rp)
    rep = audit(bad, bf.body)
    pen = rep.by_check("floor_penetration")
    assert len(pen) == 1 and pen[0].is_violation
    assert pen[0].frames == (a, b)
    assert pen[0].size == pytest.approx(0.05, abs=1e-9)
    # independent: raw FK minima against the floor of the first stand frames
    low = lowest_by_numpy(bad)
    floor = np.median(low[:bf.phases["stand"][1]])
    assert rep.penetration.floor_y == pytest.approx(floor, abs=1e-12)
    np.testing.assert_allclose(rep.penetration.depth, np.maximum(0, floor - low), atol=1e-12)
    assert rep.verdict == "fail"
    # a threshold above the defect removes the finding
    rep2 = audit(bad, bf.body, thresholds=AuditThresholds(penetration=0.06))
    assert rep2.by_check("floor_penetration") == ()


def test_1mps_com_velocity_step_is_found_at_its_frame(bf):
    m = bf.motion
    k = 160                                                  # mid-flight
    rp = np.array(m.root_positions)
    t = m.times
    rp[k:, 0] += (t[k:] - t[k]) * 1.0                         # +1 m/s in x from frame k on
    bad = m.replace(root_positions=rp)
    rep = audit(bad, bf.body)
    jumps = rep.by_check("com_velocity_jump")
    at = [f for f in jumps if f.frames[0] <= k < f.frames[1]]
    assert len(at) == 1
    assert at[0].peak_frame == k
    assert at[0].size == pytest.approx(1.0, abs=0.02)
    assert at[0].where == "in flight 1"
    np.testing.assert_allclose(rep.com.jump[k], [1.0, 0.0, 0.0], atol=0.02)
    # independent: numpy.polyfit of the COM on each side, differentiated at t_k
    w = rep.com.window
    c = rep.com.com
    left = [np.polyval(np.polyder(np.polyfit(t[k - w:k + 1], c[k - w:k + 1, i], 2)), t[k]) for i in range(3)]
    right = [np.polyval(np.polyder(np.polyfit(t[k:k + w + 1], c[k:k + w + 1, i], 2)), t[k]) for i in range(3)]
    np.testing.assert_allclose(rep.com.jump[k], np.subtract(right, left), atol=1e-8)
    assert rep.verdict == "fail"


def test_non_ballistic_flight_with_g6_is_fitted_and_flagged(bf):
    m = bf.motion
    a, b = bf.flight
    t = m.times
    ta, tb = t[a], t[b - 1]
    rp = np.array(m.root_positions)
    s = slice(a, b)
    rp[s, 1] -= (9.81 - 6.0) / 2 * (t[s] - ta) * (tb - t[s])   # COM curvature -9.81 + 3.81 = -6
    bad = m.replace(root_positions=rp)
    rep = audit(bad, bf.body)
    assert len(rep.flights) == 1
    f = rep.flights[0]
    assert f.fit.g == pytest.approx(6.0, abs=1e-6)
    assert not f.fit.g_low <= 9.81 <= f.fit.g_high
    g = rep.by_check("gravity")
    assert len(g) == 1 and g[0].is_violation and g[0].size == pytest.approx(6.0, abs=1e-6)
    # independent: numpy.polyfit of the COM height over the audited flight frames
    fa, fb = f.frames
    c2 = np.polyfit(t[fa:fb], rep.com.com[fa:fb, 1], 2)[0]
    assert f.fit.g == pytest.approx(-2 * c2, abs=1e-8)
    assert f.fit.rms_standard > 0.01 > f.fit.rms


def test_a_joint_flipped_for_one_frame_is_a_joint_speed_spike(bf):
    m = bf.motion
    j = m.skeleton.index("LeftUpLeg")
    rot = np.array(m.rotations)
    k = 50
    rot[k, j] = (Rotation.from_rotvec([np.pi * 0.9, 0, 0]) * Rotation.from_quat(rot[k, j])).as_quat()
    rep = audit(m.replace(rotations=rot), bf.body)
    sp = [f for f in rep.by_check("joint_speed") if f.where == "LeftUpLeg"]
    assert len(sp) == 1 and sp[0].is_violation
    assert sp[0].frames == (k - 1, k + 2)
    assert sp[0].size == pytest.approx(np.pi * 0.9 * m.fps, rel=0.05)


def test_against_the_original_flags_the_worse_measure(bf):
    m = bf.motion
    a, b = bf.phases["hold"]
    rp = np.array(m.root_positions)
    rp[a:b, 1] -= 0.05
    rep = audit(m.replace(root_positions=rp), bf.body, against=m, against_body=bf.body, name="edit",
                against_name="backflip")
    cmp = rep.comparison
    assert cmp is not None and rep.against is not None
    assert "max_penetration_m" in cmp.worse
    row = {r[0]: r for r in cmp.rows}["max_penetration_m"]
    assert row[3] == pytest.approx(0.05, abs=1e-9) and row[4] < 1e-9
    assert "flight1_g" not in cmp.worse
    assert any("WORSE" in line for line in cmp.summary_lines())
    json.dumps(rep.to_dict())                                  # JSON-ready, NaN as null


# ------------------------------------------------------------------ measures on known answers
def test_velocity_jumps_of_a_parabola_vanish_and_a_step_is_exact():
    fps = 100.0
    t = np.arange(50) / fps
    x = np.stack([0.3 * t, -4.905 * t ** 2 + 2 * t, 0 * t], axis=1)
    j, vl, vr = velocity_jumps(x, fps, 3)
    assert np.nanmax(np.abs(j)) < 1e-9
    np.testing.assert_allclose(vr[3:-3, 1], -9.81 * t[3:-3] + 2, atol=1e-9)
    y = x.copy()
    y[20:, 2] += 0.5 * (t[20:] - t[20])
    j, _, _ = velocity_jumps(y, fps, 3)
    assert j[20, 2] == pytest.approx(0.5, abs=1e-9)
    assert np.isnan(j[:3]).all() and np.isnan(j[-3:]).all()


def test_ballistic_fit_matches_numpy_and_its_interval_covers_the_truth():
    rng = np.random.default_rng(4)
    t = np.arange(40) / 60.0
    hits = 0
    for _ in range(200):
        y = 1.0 + 3 * t - 4.905 * t ** 2 + rng.normal(0, 0.005, t.size)
        f = fit_ballistic(t, y, 0.95)
        assert f.g == pytest.approx(-2 * np.polyfit(t, y, 2)[0], abs=1e-9)
        hits += f.g_low <= 9.81 <= f.g_high
    assert 0.90 <= hits / 200 <= 0.99                          # a 95 % interval
    with pytest.raises(ValueError):
        fit_ballistic(t[:3], t[:3])


def test_L_spread_known_angles():
    ang = np.radians([0.0, 3.0, -3.0])
    L = 20 * np.stack([np.zeros(3), np.sin(ang), np.cos(ang)], axis=1)
    L[1] *= 1.1
    spread, var, mean_abs, Lm = L_spread(L)
    np.testing.assert_allclose(Lm, L.mean(axis=0))
    u = Lm / np.linalg.norm(Lm)
    expect = np.arccos(np.clip((L / np.linalg.norm(L, axis=1)[:, None]) @ u, -1, 1)).max()
    assert spread == pytest.approx(expect, abs=1e-9)
    assert np.radians(3.0) < spread < np.radians(3.3)
    assert mean_abs == pytest.approx(20 * 3.1 / 3)
    assert var == pytest.approx((22 - mean_abs) / mean_abs)


def test_bone_length_deviation_finds_a_stretched_bone(bf):
    m = bf.motion
    P = np.array(m.fk()[0])
    sk = m.skeleton
    rest = np.linalg.norm(sk.offsets, axis=1)
    assert bone_length_deviation(P, sk.parents, rest).max() < 1e-12
    j = sk.index("LeftHand")
    P[10:12, j] += 0.01 * (P[10:12, j] - P[10:12, sk.parents[j]]) / rest[j]
    d = bone_length_deviation(P, sk.parents, rest)
    assert d[10:12, j] == pytest.approx(0.01, abs=1e-12)
    assert np.count_nonzero(d > 1e-9) == 2 + 2 * len(sk.children(j))


def test_standing_still_keeps_the_zmp_inside_the_feet(bf_report, bf):
    d = bf_report.zmp.distance[5:bf.phases["stand"][1] - 5]
    assert np.isfinite(d).all() and (d <= 0).all()


# ------------------------------------------------------------------ thresholds and errors
def test_thresholds_are_validated_and_parsed():
    th = AuditThresholds.from_strings(["penetration=0.03", "floor_y=0.0", "zmp_is_violation=true"])
    assert th.penetration == 0.03 and th.floor_y == 0.0 and th.zmp_is_violation
    assert AuditThresholds.from_strings(["floor_y=none"]).floor_y is None
    for bad, word in ((["nope=1"], "unknown threshold 'nope'"), (["penetration"], "NAME=VALUE"),
                      (["penetration=abc"], "not a number"), (["penetration=-1"], "penetration must be positive"),
                      (["jump_window=1"], "jump_window"), (["min_flight_frames=3"], "min_flight_frames"),
                      (["confidence=1"], "confidence"), (["penetration=nan"], "finite")):
        with pytest.raises(AuditConfigError, match=word):
            AuditThresholds.from_strings(bad)
    with pytest.raises(AuditConfigError, match="floor_y"):
        AuditThresholds(floor_y=float("inf"))
    assert dataclasses.replace(AuditThresholds(), jump_window=4).jump_frames(120) == 4
    assert AuditThresholds().jump_frames(120) == 4 and AuditThresholds().jump_frames(30) == 2


def test_bad_input_raises_the_projects_errors(bf):
    with pytest.raises(MotionFormatError, match="at least 5 frames"):
        audit(bf.motion[:4], bf.body, name="short")
    other = make_example("jump")
    with pytest.raises(MotionFormatError):
        audit(bf.motion, other.body.scaled_to(50.0).__class__.from_skeleton(
            bf.motion.skeleton.scaled(1.1)))
    with pytest.raises(TypeError):
        audit(bf.motion, bf.body, thresholds={"penetration": 0.1})


def test_explicit_floor_is_used(bf):
    rep = audit(bf.motion, bf.body, thresholds=AuditThresholds(floor_y=0.05))
    assert rep.penetration.floor_y == 0.05
    assert rep.penetration.max_depth == pytest.approx(0.05 - 0.014, abs=1e-6)
    assert rep.by_check("floor_penetration")


def test_summary_and_dict(bf_report):
    lines = bf_report.summary_lines()
    assert lines[-1].startswith("verdict: PASS")
    d = bf_report.to_dict()
    assert d["verdict"] == "pass" and d["flights"][0]["g_fit"] == pytest.approx(9.81, abs=1e-6)
    assert json.loads(json.dumps(d))["measures"]["max_penetration_m"] < 1e-9


# ------------------------------------------------------------------ fast forms pinned (issue #13 speed)
def _motions_for_pinning(bf):
    out = [(bf.motion, bf.body)]
    if datasets.data_dir():
        from mocomp.audit import default_body

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = datasets.load("01_01")[:400]
        out.append((m, default_body(m)))
    return out


@pytest.mark.parametrize("sigma", [2.0, 0.7, 0.0])
def test_audit_zmp_equals_the_dynamics_zmp_of_the_smoothed_motion(bf, sigma):
    """The audit's ZMP (segment chains only, no smoothed Motion built) is dynamics.zmp on
    smooth_motion, and its polygon distance (never-touching points dropped) is the distance
    with every contact point."""
    from mocomp.audit.contacts import phases_of
    from mocomp.audit.zmp import smoothed_segment_positions, zmp_audit, zmp_from_segments
    from mocomp.dynamics import segment_positions
    from mocomp.dynamics.contacts import detect_contacts
    from mocomp.dynamics.derivatives import smooth_motion
    from mocomp.dynamics.zmp import support_polygon_distance, zmp

    for m, body in _motions_for_pinning(bf):
        sm = smooth_motion(m, sigma)
        ref_r = segment_positions(body, sm)
        r = smoothed_segment_positions(body, m, sigma)
        np.testing.assert_allclose(r, ref_r, rtol=0, atol=1e-12)
        ref = zmp(body, m, ground_y=0.01, smooth_sigma=sigma or None)
        z = zmp_from_segments(body, r, m.times, 0.01)
        np.testing.assert_array_equal(np.isnan(z), np.isnan(ref.zmp))
        assert np.isfinite(z).sum() > m.n_frames            # the ZMP is defined on ground frames
        np.testing.assert_allclose(z, ref.zmp, rtol=0, atol=1e-9)
        c = detect_contacts(m)
        th = AuditThresholds(zmp_smooth_sigma=sigma)
        floor_y = float(c.ground_y)
        za, _ = zmp_audit(body, m, c, floor_y, phases_of(c, m.n_frames), th)
        pts, lab = c.contact_points()
        d = support_polygon_distance(zmp(body, m, ground_y=floor_y, smooth_sigma=sigma or None), pts, lab)
        np.testing.assert_array_equal(np.isnan(za.distance), np.isnan(d))
        assert np.isfinite(d).any()
        np.testing.assert_allclose(za.distance, d, rtol=0, atol=1e-9)


def test_fast_quaternion_smoothing_equals_smooth_quaternions_across_sign_flips():
    from mocomp.audit.zmp import smooth_quaternions_fast
    from mocomp.dynamics.derivatives import smooth_quaternions

    rng = np.random.default_rng(7)
    rv = np.cumsum(rng.normal(scale=0.05, size=(300, 5, 3)), axis=0)
    q = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(300, 5, 4)
    q[rng.random((300, 5)) < 0.2] *= -1.0                    # random hemisphere flips
    for sigma in (0.5, 2.0, 5.0):
        ref = smooth_quaternions(q, sigma)
        fast = smooth_quaternions_fast(q, sigma)
        assert fast.shape == ref.shape
        np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-14)
        np.testing.assert_allclose(np.linalg.norm(fast, axis=-1), 1.0, atol=1e-14)


def test_step_rates_equal_the_quaternion_product_form_and_known_angles(bf):
    from mocomp.audit.kinematics import step_rates, step_rates_reference

    m = bf.motion
    rot = np.array(m.rotations)
    rot[10:, 3] *= -1.0                                      # q and -q: the same rotation, no rate
    rot[40, 5] = Rotation.from_rotvec([0.0, np.pi, 0.0]).as_quat()   # 180 deg turn in a frame
    m2 = m.replace(rotations=rot)
    np.testing.assert_allclose(step_rates(m2)[0], step_rates_reference(m2), rtol=1e-12, atol=1e-9)
    q = Rotation.from_rotvec(np.outer(np.arange(6) * 0.1, [0.0, 0.0, 1.0])).as_quat()   # 0.1 rad per frame
    qq = np.repeat(q[:, None], m.skeleton.n_joints, axis=1)
    qq[::2] *= -1.0
    m3 = m[:6].replace(rotations=qq)
    np.testing.assert_allclose(step_rates(m3)[0], 0.1 * m.fps, rtol=1e-12)


# ------------------------------------------------------------------ real clips
REAL = [p for p in real_files("**/*") if p in set(datasets.real_clips())] if datasets.data_dir() else []


@pytest.mark.parametrize("path", REAL, ids=lambda p: p.name)
def test_every_real_clip_audits_without_crashing(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(path)
    rep = audit(m, name=path.name)
    assert rep.verdict in ("pass", "fail")
    assert np.isfinite(rep.penetration.floor_y)
    for f in rep.findings:
        assert f.size > f.threshold or f.check == "gravity"
    json.dumps(rep.to_dict())


def test_real_cmu_hops_fall_with_standard_gravity(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = audit(datasets.load("01_01"), name="01_01")
    fits = [f.fit for f in rep.flights if f.fit is not None and f.duration > 0.2]
    assert len(fits) >= 8
    assert all(9.0 < f.g < 11.0 for f in fits)
    assert not rep.by_check("gravity")


def test_real_88_01_backflip_flight_is_measured_with_its_own_g(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = audit(datasets.load("88_01"), name="88_01")
    f = max(rep.flights, key=lambda f: f.frames[1] - f.frames[0])
    assert f.L_judged and 20 < f.L_abs < 60
    assert 11.0 < f.fit.g < 14.0                               # the per-flight fit (11.8): flagged
    assert rep.by_check("gravity")


def test_command_output_of_a_deepmimic_clip_is_audited_with_the_clips_own_body(real_data_dir, tmp_path):
    """Issue 13: a command's BVH output of a DeepMimic clip no longer names the character, and was
    audited with a generic 70 kg de Leva body while its input used the clip's own 45 kg character;
    with the input's skeleton (joints in the BVH writer's order) the input's body is used."""
    from mocomp.audit.run import default_body, same_skeleton
    from mocomp.io.bvh import read_bvh, write_bvh

    src = datasets.load(str(real_data_dir / "flips" / "deepmimic_backflip.txt"))
    out = read_bvh(write_bvh(src, tmp_path / "o.bvh"), scale=1.0)
    assert tuple(out.skeleton.names) != tuple(src.skeleton.names)       # reordered by the writer
    assert same_skeleton(out.skeleton, src.skeleton)
    alone = audit(out)
    # nothing names the character, but the skeleton is exactly the character's (joints by name and
    # parent, bone offsets within 0.1 mm: mocomp.io.deepmimic.match_character): its 45 kg body, and why
    assert alone.total_mass == pytest.approx(45.0) and "recognised as DeepMimic character" in alone.body
    rep = audit(out, against=src)
    body = default_body(src)
    assert rep.total_mass == pytest.approx(body.total_mass) and rep.against.total_mass == rep.total_mass
    assert abs(rep.total_mass - 70.0) > 5.0
    # the same frames with the same body: the COM measures agree with the input's
    assert rep.measure("max_com_jump_mps") == pytest.approx(rep.against.measure("max_com_jump_mps"), abs=1e-3)
    # a different skeleton keeps the default
    bf = make_example("backflip").motion
    assert not same_skeleton(bf.skeleton, src.skeleton)
    assert audit(bf, against=src).total_mass == pytest.approx(70.0)
