"""Editing primitives (issue 15): known answers on synthetic motions, invariants, bad input."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from mocomp import datasets
from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
from mocomp.ops import (CurveError, DisplacementMap, HierarchyStep, NoContactError, PathCurve, align, apply_displacement,
                        apply_hierarchy, blend, enforce_footplants, foot_plants, path_edit, read_contacts_csv, slope,
                        two_bone_ik)
from mocomp.ops.ik import leg_chains
from mocomp.ops.synthetic import synthetic_walk


@functools.lru_cache(maxsize=None)
def walk():
    return synthetic_walk(duration=4.0, fps=120.0)


def _frozen_copy(m):
    return np.array(m.root_positions), np.array(m.rotations)


def _unchanged(m, copy):
    np.testing.assert_array_equal(m.root_positions, copy[0])
    np.testing.assert_array_equal(m.rotations, copy[1])


# ------------------------------------------------------------------ IK
def test_two_bone_ik_reaches_reachable_targets_to_1e9_and_keeps_bone_lengths():
    m = walk().motion[::7]
    P, G = m.fk()
    for chain in leg_chains(m.skeleton):
        h, k, a = chain
        rng = np.random.default_rng(3)
        # targets within reach: pulled 8 % toward the hip, then moved up to 5 cm
        tgt = P[:, h] + 0.92 * (P[:, a] - P[:, h]) + rng.uniform(-0.05, 0.05, (m.n_frames, 3))
        rot, miss = two_bone_ik(P, G, m.rotations, m.skeleton.parents, chain, tgt)
        out = m.replace(rotations=rot)
        assert np.abs(out.positions[:, a] - tgt).max() < 1e-9
        assert miss.max() < 1e-12
        for j in (k, a):
            p = m.skeleton.parents[j]
            np.testing.assert_allclose(np.linalg.norm(out.positions[:, j] - out.positions[:, p], axis=1),
                                       np.linalg.norm(P[:, j] - P[:, p], axis=1), atol=1e-12)
        np.testing.assert_allclose(out.positions[:, h], P[:, h], atol=1e-12)
        # the knee stays on the side it was (its plane normal keeps its sense)
        n0 = np.cross(P[:, a] - P[:, k], P[:, h] - P[:, k])
        n1 = np.cross(out.positions[:, a] - out.positions[:, k], out.positions[:, h] - out.positions[:, k])
        assert np.all(np.sum(n0 * n1, axis=1) > 0)
        # the ankle keeps its world orientation
        assert np.abs(np.abs(np.sum(out.global_rotations[:, a] * G[:, a], axis=1)) - 1).max() < 1e-12


def test_two_bone_ik_out_of_reach_reports_the_miss():
    m = walk().motion[40:41]
    P, G = m.fk()
    h, k, a = chain = leg_chains(m.skeleton)[0]
    far = P[0, h] + np.array([0.0, -2.0, 0.0])
    rot, miss = two_bone_ik(P[0], G[0], m.rotations[0], m.skeleton.parents, chain, far)
    reach = np.linalg.norm(P[0, k] - P[0, h]) + np.linalg.norm(P[0, a] - P[0, k])
    assert miss == pytest.approx(2.0 - reach, abs=1e-5)


# ------------------------------------------------------------------ footplants
def test_footplant_holds_a_drifting_walk_and_changes_only_the_legs():
    """The synthetic walk (toe joints exactly still in stance) with the whole body drifting 4 cm
    sideways per second: the planted points slide ~4-8 cm before, under 1 cm after (audit)."""
    sw = walk()
    m = sw.motion
    rp = np.array(m.root_positions)
    rp[:, 0] += 0.04 * m.times
    drift = m.replace(root_positions=rp)
    copy = _frozen_copy(drift)
    r = enforce_footplants(drift)
    _unchanged(drift, copy)
    before, after = r.measured_slide()
    assert before > 0.02 and after < 0.01
    assert r.slide_after.max() < 0.006
    np.testing.assert_array_equal(r.motion.root_positions, drift.root_positions)
    legs = {j for c in leg_chains(m.skeleton) for j in c}
    others = [j for j in range(m.skeleton.n_joints) if j not in legs]
    np.testing.assert_array_equal(r.motion.rotations[:, others], drift.rotations[:, others])
    assert r.joint_speed_after <= r.joint_speed_before * 1.05
    assert r.max_miss < 1e-3


def test_footplant_without_contacts_is_a_clear_error():
    m = datasets.load_example("backflip").motion
    flying = m.translated((0.0, 3.0, 0.0))[120:200]
    with pytest.raises(NoContactError, match="no foot is planted"):
        enforce_footplants(flying.replace(root_positions=flying.root_positions + np.linspace(0, 5, 80)[:, None]
                                          * np.array([0, 1.0, 0])), audit=False)


def test_contacts_csv_overrides_and_errors(tmp_path):
    m = walk().motion
    f = tmp_path / "c.csv"
    f.write_text("joint,start,stop\nLeftFoot,10,40\ntoe_r,0,30\n")
    ov = read_contacts_csv(f, m.skeleton, m.n_frames)
    assert ov == {"foot_l": [(10, 40)], "toe_r": [(0, 30)]}
    pl = foot_plants(m, f)
    assert pl.intervals["foot_l"] == [(10, 40)] and pl.source["foot_l"].startswith("csv")
    for text, msg in (("joint,start,stop\nNose,1,2\n", "c.csv:2: joint 'Nose'"),
                      ("joint,start,stop\nfoot_l,5,x\n", "c.csv:2: stop 'x'"),
                      ("joint,start,stop\nfoot_l,5,9999\n", "c.csv:2: interval"),
                      ("start,stop\n", "c.csv:1: the first row")):
        f.write_text(text)
        with pytest.raises(ValueError, match=msg.replace("(", r"\(")):
            read_contacts_csv(f, m.skeleton, m.n_frames)


# ------------------------------------------------------------------ displacement maps
def test_displacement_constant_offset_reproduced_exactly_by_both_kernels():
    m = walk().motion[:200]
    J = m.skeleton.n_joints
    rv = np.zeros((J, 3))
    rv[3] = [0.2, -0.1, 0.05]
    d = DisplacementMap.constant(m.n_frames, J, root=(0.1, -0.02, 0.3), rotations=rv)
    for kernel in ("gaussian", "bspline"):
        s = d.smoothed(12, kernel)
        np.testing.assert_allclose(s.root, d.root, atol=1e-12)
        np.testing.assert_allclose(s.rotations, d.rotations, atol=1e-12)
    out = apply_displacement(m, d.smoothed(12, "bspline"))
    np.testing.assert_allclose(out.root_positions - m.root_positions, np.tile([0.1, -0.02, 0.3], (200, 1)), atol=1e-12)
    ang = quat_angle(quat_multiply(quat_inverse(m.rotations[:, 3]), out.rotations[:, 3]))
    np.testing.assert_allclose(ang, np.linalg.norm(rv[3]), atol=1e-12)


def test_displacement_between_roundtrips_and_damping_scales():
    m = walk().motion[:120]
    other = slope(m, 7.0).motion
    d = DisplacementMap.between(m, other)
    back = apply_displacement(m, d)
    np.testing.assert_allclose(back.positions, other.positions, atol=1e-9)
    half = d.scaled(0.5)
    assert half.magnitude()[1] == pytest.approx(0.5 * d.magnitude()[1])
    # a Gaussian smooths a step: the jump per frame falls
    step = np.zeros((100, 3))
    step[50:] = 1.0
    dm = DisplacementMap(step, np.zeros((100, 2, 3))).smoothed(5)
    assert np.abs(np.diff(dm.root[:, 0])).max() < 0.1


def test_hierarchy_applies_each_level_with_its_damping():
    m = walk().motion[:120]
    target = m.translated((0.2, 0.0, 0.0))
    sched = [HierarchyStep(10, 0.5), HierarchyStep(5, 0.5, "bspline", iterations=2)]
    r = apply_hierarchy(m, lambda cur, step: target.replace(rotations=cur.rotations) if False else
                        cur.translated(target.root_positions[0] - cur.root_positions[0]), sched)
    # each application closes half of the remaining 0.2 m: 0.1, 0.05, 0.025 left after 3 maps
    assert len(r.maps) == 3
    np.testing.assert_allclose(r.motion.root_positions[:, 0] - m.root_positions[:, 0], 0.2 * (1 - 0.5 ** 3), atol=1e-12)
    with pytest.raises(ValueError, match="rho"):
        HierarchyStep(10, -0.1)
    with pytest.raises(ValueError, match="sigma"):
        HierarchyStep(-1, 0.5)


# ------------------------------------------------------------------ alignment and blend
def test_align_recovers_a_known_turn_and_shift():
    m = walk().motion
    q = np.array([0.0, np.sin(np.radians(35) / 2), 0.0, np.cos(np.radians(35) / 2)])
    moved = m.rotated(q, center=(1.0, 0.0, 2.0)).translated((3.0, 0.0, -1.0))
    t = align(m, moved, 100, 100)
    assert np.degrees(t.yaw) == pytest.approx(-35.0, abs=1e-9)
    np.testing.assert_allclose(t.apply(moved).root_positions, m.root_positions, atol=1e-9)
    t2 = align(m, moved, 100, 100, by="feet")
    back = t2.apply(moved)
    np.testing.assert_allclose(back.positions, m.positions, atol=1e-9)


def test_blend_of_a_motion_with_itself_is_the_identity():
    m = walk().motion
    copy = _frozen_copy(m)
    r = blend(m, m, (200, 200), 30, plant=False)
    _unchanged(m, copy)
    assert r.motion.n_frames == m.n_frames
    np.testing.assert_allclose(r.motion.root_positions, m.root_positions, atol=1e-12)
    assert quat_angle(quat_multiply(quat_inverse(r.motion.rotations), m.rotations)).max() < 1e-7
    r2 = blend(m, m, (200, 200), 30)          # the exact plants stay where they were
    assert np.abs(r2.motion.positions - m.positions).max() < 0.01


def test_blend_window_errors():
    m = walk().motion
    with pytest.raises(ValueError, match="at least 2 frames"):
        blend(m, m, (100, 100), 1)
    with pytest.raises(ValueError, match="longer than A"):
        blend(m[:50], m, (25, 100), 80)
    with pytest.raises(ValueError, match="window of at most"):
        blend(m, m, (3, 100), 20)
    with pytest.raises(ValueError, match="outside"):
        blend(m, m, (100, 5000), 10)


def test_blend_between_two_walks_turned_apart_has_no_root_jump_and_planted_feet():
    sw = walk().motion
    q = np.array([0.0, np.sin(np.radians(40) / 2), 0.0, np.cos(np.radians(40) / 2)])
    b = sw.rotated(q).translated((5.0, 0.0, 3.0))
    r = blend(sw, b, (200, 332), 40, audit=True)       # 132 frames = one stride: same pelvis yaw
    assert abs(np.degrees(r.transform.yaw) + 40) < 1e-6
    steps = np.linalg.norm(np.diff(r.motion.root_positions, axis=0), axis=1)
    assert steps.max() < 1.5 * np.linalg.norm(np.diff(sw.root_positions, axis=0), axis=1).max()
    assert r.footplants.measured_slide()[1] < 0.01


# ------------------------------------------------------------------ path and slope
def test_pathedit_onto_a_straight_line_is_a_rigid_move_and_arcs_turn():
    m0 = walk().motion
    rp = np.array(m0.root_positions)
    rp[:, 0] = 0.0                                   # no sway: the smoothed path is exactly straight
    m = m0.replace(root_positions=rp)
    copy = _frozen_copy(m)
    from mocomp.ops import motion_path

    path, s, psi = motion_path(m)
    line = PathCurve(np.array([[2.0, 1.0], [2.0 + 10.0, 1.0]]))    # along +x from (2, 1)
    r = path_edit(m, line, plant=False)
    _unchanged(m, copy)
    # the straight walk along +z becomes a walk along +x: positions turned by +90 deg about y and moved
    P0, P1 = m.positions, r.motion.positions
    rel0 = P0 - np.array([path[0, 0], 0, path[0, 1]])
    rel1 = P1 - np.array([2.0, 0, 1.0])
    np.testing.assert_allclose(rel1[..., 0], rel0[..., 2], atol=1e-9)
    np.testing.assert_allclose(rel1[..., 2], -rel0[..., 0], atol=1e-9)
    np.testing.assert_allclose(rel1[..., 1], rel0[..., 1], atol=1e-12)
    m = m0
    path, s, psi = motion_path(m)
    arc = PathCurve.arc(float(s[-1]), np.radians(90))
    r2 = path_edit(m, arc, audit=True)
    assert np.degrees(r2.turn) == pytest.approx(90.0, abs=3.0)
    assert r2.footplants.measured_slide()[1] < 0.01
    np.testing.assert_allclose(r2.step_after.mean(), r2.step_before.mean(), rtol=0.05)


def test_curves_with_cusps_and_bad_points_are_refused():
    with pytest.raises(CurveError, match="cusp at point 2"):
        PathCurve.parse("0,0;1,0;0,0.01", "polyline")
    with pytest.raises(CurveError, match="cusp"):
        PathCurve.parse("0,0;1,0;0,0")
    with pytest.raises(CurveError, match="point 2"):
        PathCurve.parse("0,0;1;2,2")
    with pytest.raises(CurveError, match="coincide"):
        PathCurve.parse("0,0;0,0;1,1")
    with pytest.raises(CurveError, match="at least 2"):
        PathCurve.parse("0,0")
    c = PathCurve.parse("0,0;0,1;1,2;", "polyline")                # a 45 deg corner is fine
    assert c.length == pytest.approx(1 + np.sqrt(2), abs=1e-9)


def test_slope_zero_is_identity_and_ten_degrees_climbs():
    m = walk().motion
    copy = _frozen_copy(m)
    assert slope(m, 0.0).motion is m
    r = slope(m, 10.0)
    _unchanged(m, copy)
    travel = np.linalg.norm((m.root_positions[-1] - m.root_positions[0])[[0, 2]])
    assert np.degrees(np.arctan2(r.climb, travel)) == pytest.approx(10.0, abs=0.5)
    # heights above the tilted floor equal the heights above the flat floor
    np.testing.assert_allclose(r.heights_above_floor(r.motion.positions), m.positions[..., 1] - r.floor_y, atol=1e-9)
    with pytest.raises(ValueError, match="between -90 and 90"):
        slope(m, 95.0)
    with pytest.raises(ValueError, match="horizontal"):
        slope(m, 5.0, axis=(0, 1, 0))


def test_second_pass_resolves_only_changed_frames_exactly():
    """The re-detection pass re-solves only frames whose correction changed: its result equals one
    full pass on the final plants."""
    sw = walk().motion
    rp = np.array(sw.root_positions)
    rp[:, 0] += 0.04 * sw.times
    m = sw.replace(root_positions=rp)
    r2 = enforce_footplants(m, audit=False, passes=2)
    r1 = enforce_footplants(m, r2.plants, audit=False, passes=1)
    np.testing.assert_allclose(r2.motion.rotations, r1.motion.rotations, atol=1e-12)


def test_hinge_prior_bends_a_straight_leg_about_its_knee_axis():
    """A straight leg has no bending plane; with the hinge prior it bends about the knee's axis
    measured on the bent frames, and the target is still reached."""
    from mocomp.ops.ik import hinge_axis

    m = walk().motion
    P, G = m.fk()
    chain = leg_chains(m.skeleton)[0]
    ax = hinge_axis(P, G, chain)
    h, k, a = chain
    i = int(np.argmin(np.linalg.norm(np.cross(P[:, a] - P[:, k], P[:, h] - P[:, k]), axis=1)))    # straightest
    tgt = P[i, h] + 0.9 * (P[i, a] - P[i, h])
    rot, miss = two_bone_ik(P[i], G[i], m.rotations[i], m.skeleton.parents, chain, tgt, bend_axis=ax, bend_prior=0.05)
    out = m[i].replace(rotations=rot[None])
    assert np.linalg.norm(out.positions[0, a] - tgt) < 1e-9
    n = np.cross(out.positions[0, a] - out.positions[0, k], out.positions[0, h] - out.positions[0, k])
    from mocomp.core.rotations import quat_apply

    world_ax = quat_apply(out.global_rotations[0, h], ax)
    assert abs(np.dot(n / np.linalg.norm(n), world_ax)) > 0.95


def test_blend_time_warp_moves_the_cadence_from_a_to_b():
    """A walk (stride 1.1 s) into a brisker one (stride 0.786 s): the step periods are measured from
    the plants, and through the window the frames of A advance faster and those of B slower than 1
    per output frame at the start and 1 at the end for B."""
    a = walk().motion
    b = synthetic_walk(duration=4.0, fps=120.0, speed=1.4, stride_time=1.1 / 1.4).motion
    r = blend(a, b, (240, 200), 60, time_warp=True, plant=False)
    pa, pb = r.time_warp
    assert pa == pytest.approx(0.55 * 120, abs=2) and pb == pytest.approx(1.1 / 1.4 / 2 * 120, abs=2)
    da, db = np.diff(r.a_frames), np.diff(r.b_frames)
    assert da[0] == pytest.approx(1.0, abs=0.02) and da[-1] == pytest.approx(pa / pb, rel=0.03)
    assert db[0] == pytest.approx(pb / pa, rel=0.03) and db[-1] == pytest.approx(1.0, abs=0.02)
    assert np.linalg.norm(np.diff(r.motion.root_positions, axis=0), axis=1).max() < 1.4 * 1.5 / 120


def test_second_pass_plants_a_point_the_given_labels_never_planted():
    """Given labels that never plant the left toe point: the detector's second pass finds it planted
    on the result; its level must come from the detector (the given plants have no level for it;
    a column median of nothing gave NaN targets and NaN leg rotations)."""
    m = walk().motion
    pl = foot_plants(m)
    lab = np.array(pl.labels)
    k = pl.effectors.index("toe_l")
    lab[:, k] = False
    given = foot_plants(m, labels=lab, require=False)
    r = enforce_footplants(m, given, audit=False, passes=2)
    assert any(n.startswith("pass 2") for n in r.notes)
    assert np.isfinite(r.motion.rotations).all()
    assert r.plants.labels[:, k].any() and np.isfinite(r.plants.levels[r.plants.labels[:, k], k]).all()


def test_blend_with_a_given_ground_transform():
    """A caller's transform replaces the alignment: the default one given explicitly reproduces the
    default blend exactly; another (B turned 30 deg more about its own pivot) makes the rest of B that
    transform of B (up to the horizontal shift of the velocity integration) and the window's first
    frame still A's; a wrong type is refused."""
    from mocomp.ops import GroundTransform, headings
    from mocomp.ops.align import yaw_quaternion

    m = walk().motion
    turned = m.rotated(yaw_quaternion(np.radians(50.0)))
    r0 = blend(m, turned, (200, 150), 20, plant=False)
    r1 = blend(m, turned, (200, 150), 20, plant=False, transform=r0.transform)
    np.testing.assert_array_equal(r1.motion.rotations, r0.motion.rotations)
    np.testing.assert_array_equal(r1.motion.root_positions, r0.motion.root_positions)
    tf = GroundTransform(r0.transform.yaw + np.radians(30.0), r0.transform.pivot, r0.transform.shift)
    r2 = blend(m, turned, (200, 150), 20, plant=False, transform=tf)
    assert r2.transform == tf
    b2 = tf.apply(turned)
    stop, off = r2.window[1], int(round(r2.b_offset))
    rest = slice(stop, r2.motion.n_frames)
    np.testing.assert_allclose(r2.motion.rotations[rest], b2.rotations[stop - off:], atol=1e-12)
    np.testing.assert_allclose(r2.motion.root_positions[rest] - r2.shift, b2.root_positions[stop - off:],
                               atol=1e-9)
    assert headings(r2.motion, [stop])[0] == pytest.approx(headings(r0.motion, [stop])[0] + np.radians(30.0),
                                                           abs=1e-6)
    with pytest.raises(TypeError, match="GroundTransform"):
        blend(m, turned, (200, 150), 20, plant=False, transform=(0.1, (0, 0, 0), (0, 0, 0)))


def test_plants_go_on_the_resting_level_not_on_a_sunk_frame():
    """Three plants of one point resting at 2 cm, 3 cm and 2.5 cm above a detector level of 0 (the
    1st percentile of a clip whose point sank through the floor elsewhere): with the resting levels
    each plant's lowest frame goes on their median, 2.5 cm (the plants move by -0.5, +0.5 and 0 cm);
    on the detector's level (ROBUST_LEVEL off) each would drop by 2-3 cm. Runs on another detector
    level keep their own median."""
    import dataclasses

    import mocomp.ops.plants as pl
    from mocomp.ops.plants import plant_targets

    T = 60
    lab = np.zeros((T, 4), bool)
    runs = [(0, 10, 0.02), (20, 30, 0.03), (40, 50, 0.025)]
    pts = np.zeros((T, 4, 3))
    pts[:, :, 1] = 0.2
    for a, b, y in runs:
        lab[a:b, 0] = True
        pts[a:b, 0, 1] = y + 0.001 * np.arange(b - a)          # the heel rolls up 1 mm a frame
    lab[52:58, 2] = True                                       # another point on a box 0.3 m up
    pts[52:58, 2, 1] = 0.31
    lev = np.where(lab, 0.0, np.nan)
    lev[52:58, 2] = 0.3
    walk = synthetic_walk(duration=0.5, fps=120.0).motion
    plants = dataclasses.replace(pl.foot_plants(walk), labels=lab, levels=lev)
    y = plant_targets(pts, plants)[..., 1]
    for a, b, _ in runs:
        np.testing.assert_allclose(y[a:b, 0], 0.025 + 0.001 * np.arange(b - a), atol=1e-12)
    np.testing.assert_allclose(y[52:58, 2], 0.31, atol=1e-12)
    try:
        pl.ROBUST_LEVEL = False
        y0 = plant_targets(pts, plants)[..., 1]
    finally:
        pl.ROBUST_LEVEL = True
    np.testing.assert_allclose(y0[20:30, 0], 0.001 * np.arange(10), atol=1e-12)
    # given plants (a blend's labels, a CSV file) keep their level: the percentile of their own planted frames
    given = dataclasses.replace(plants, source={e: "given" for e in plants.effectors})
    np.testing.assert_allclose(plant_targets(pts, given)[..., 1], y0, atol=1e-12)


def test_detected_slide_is_the_audits_foot_slide():
    """ops.footplant.detected_slide on a detection of a motion equals the audit's largest foot slide
    (the measure the extra passes are chosen by), here on a drifting synthetic walk (a few mm) and
    on its enforced result."""
    from mocomp.audit import audit
    from mocomp.dynamics.contacts import detect_contacts
    from mocomp.ops.evidence import foot_slide
    from mocomp.ops.footplant import detected_slide

    m = walk().motion
    rp = np.array(m.root_positions)
    rp[:, 0] += 0.04 * m.times                                 # the body drifts 4 cm/s sideways
    m = m.replace(root_positions=rp)
    for x in (m, enforce_footplants(m, audit=False).motion):
        want = foot_slide(audit(x))
        assert want > 0
        assert abs(detected_slide(detect_contacts(x), ("foot_l", "toe_l", "foot_r", "toe_r")) - want) < 1e-12


def test_a_toe_plant_moves_with_its_heels_plant():
    """Ankle point planted on frames 0-20 resting at 5 cm and on 40-50 at 0 cm (its resting level, the
    median of the two lows, is 2.5 cm: the first plant moves by -2.5 cm); the toe tip planted on
    frames 10-30, its only plant (on its own resting level it would not move: 2.5 cm apart from the
    heel's shift, more than TOE_HEEL_GAP): it moves by the heel's -2.5 cm over its whole run (the foot
    keeps its pitch). With a second toe plant 4 cm lower its own shift is -2 cm, within TOE_HEEL_GAP of
    the heel's: it keeps its own."""
    import dataclasses

    import mocomp.ops.plants as pl
    from mocomp.ops.plants import plant_targets

    T = 60
    lab = np.zeros((T, 4), bool)
    lab[0:20, 0] = lab[40:50, 0] = True
    lab[10:30, 1] = True
    pts = np.full((T, 4, 3), 0.2)
    pts[0:20, 0, 1], pts[40:50, 0, 1] = 0.05, 0.0
    pts[10:30, 1, 1] = -0.04 + 0.001 * np.arange(20)
    walk = synthetic_walk(duration=0.5, fps=120.0).motion
    plants = dataclasses.replace(pl.foot_plants(walk), labels=lab, levels=np.where(lab, 0.0, np.nan))
    y = plant_targets(pts, plants)[..., 1]
    np.testing.assert_allclose(y[0:20, 0], 0.025, atol=1e-12)
    np.testing.assert_allclose(y[10:30, 1], pts[10:30, 1, 1] - 0.025, atol=1e-12)
    lab[52:55, 1] = True
    pts[52:55, 1, 1] = -0.08
    y = plant_targets(pts, dataclasses.replace(plants, labels=lab, levels=np.where(lab, 0.0, np.nan)))[..., 1]
    np.testing.assert_allclose(y[10:30, 1], pts[10:30, 1, 1] - 0.02, atol=1e-12)


def test_clocked_ramp_waits_on_a_stopped_step_and_still_ends_on_time():
    """RampPlan.many with a clock: all ones is the plain ramp; a step of clock 0 leaves the weight where it
    was across that step, and the fade still reaches 0 within ``width + 1`` steps of the defined frame."""
    from mocomp.ops.easing import RampPlan, fade_clock

    T, width = 20, 4
    d = np.zeros((T, 1), bool)
    d[10:] = True                                   # a plant from frame 10: fade-in over frames 6-9
    vals = np.ones(T)
    plain = RampPlan.many(d, width)[0].fill(vals)
    np.testing.assert_allclose(RampPlan.many(d, width, clock=np.ones(T - 1))[0].fill(vals), plain, atol=1e-15)
    ck = np.ones(T - 1)
    ck[7] = 0.0                                     # the step 7 -> 8 stopped
    w = RampPlan.many(d, width, clock=ck)[0].fill(vals)
    assert w[7] == w[8] and 0.0 < w[7] < 1.0
    np.testing.assert_array_equal(w[:6], 0.0)       # nothing before the fade's first frame
    assert np.all(np.diff(w[5:11]) >= 0)            # still rising to the plant
    # the clock from rates: 1 below half the limit, 0 at it
    np.testing.assert_allclose(fade_clock(np.array([0.0, 0.4, 0.75, 1.0, 2.0]), 1.0), [1.0, 1.0, 0.5, 0.0, 0.0])
