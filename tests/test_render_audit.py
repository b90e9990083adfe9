"""Motions drawn with their audit (mocomp.plots.render_audit, issue #13 section 4).

Known answers from the synthetic back flip (its generator's flight, the audit's phases), a planted
defect (the body pushed 5 cm into the floor) found in the pixels, and the frame-range, camera and
output rules. Small images; speed goals live in benchmarks/bench_render.py.
"""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.audit import audit
from mocomp.plots import render_audit as ra
from mocomp.plots.render3d import RenderStyle
from mocomp.synth.registry import make_example

SMALL = RenderStyle(width=320, height=240)


def red_mask(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r > 150) & (g < 0.4 * r) & (b < 0.4 * r)


@pytest.fixture(scope="module")
def bf():
    return make_example("backflip")


@pytest.fixture(scope="module")
def bf_track(bf):
    return ra.audit_track(bf.motion, audit(bf.motion, bf.body, name="backflip"), name="backflip", style=SMALL)


@pytest.fixture(scope="module")
def sunk(bf):
    """The back flip with its whole body 5 cm below the floor over the landing hold (a planted defect)."""
    m = bf.motion
    a, b = bf.phases["hold"][0] + 3, bf.phases["hold"][1] - 3
    rp = np.array(m.root_positions)
    rp[a:b, 1] -= 0.05
    bad = m.replace(root_positions=rp)
    return bad, (a, b), ra.audit_track(bad, audit(bad, bf.body), name="sunk", style=SMALL)


# ------------------------------------------------------------------ phase poses
def test_filmstrip_poses_are_the_audits_takeoff_apex_and_landing(bf, bf_track):
    rep = bf_track.report
    (fa, fb), = rep.phases.flights
    # the audit's flight is inside the generator's (known answer) by the contact detector's height
    # tolerance: a toe counts as airborne a few frames after it leaves the floor
    ga, gb = bf.flight
    assert ga <= fa <= ga + 4 and gb - 4 <= fb <= gb
    poses = ra.phase_poses(rep)
    by = {p.label: p.frame for p in poses}
    com_y = np.asarray(rep.com.com)[:, 1]
    assert by["take-off 1"] == rep.phases.takeoffs[0] == fa
    assert by["landing 1"] == rep.phases.landings[0] == fb
    assert by["apex 1"] == fa + int(np.argmax(com_y[fa:fb]))
    assert by["start"] == 0 and by["end"] == rep.n_frames - 1
    frames = [p.frame for p in poses]
    assert frames == sorted(set(frames))
    inside = [f for f in frames if fa <= f < fb]
    assert len(inside) >= 4                                   # never one pose for a flight
    gaps = np.diff([fa] + inside + [fb]) / rep.fps
    assert gaps.max() <= 0.15 + 1.0 / rep.fps                 # max_gap_s between flight poses
    # not uniform in time: the flight is sampled far more densely than the ground
    assert len(inside) / (fb - fa) > 2 * (len(frames) - len(inside)) / (rep.n_frames - (fb - fa))


def test_phase_poses_stay_inside_the_frame_range_and_pick_the_crouch(bf_track):
    rep = bf_track.report
    (fa, fb), = rep.phases.flights
    poses = ra.phase_poses(rep, (fa - 30, fb - 10))
    assert all(fa - 30 <= p.frame < fb - 10 for p in poses)
    assert poses[0].label == "start" and poses[-1].label == "end"
    assert "landing 1" not in {p.label for p in poses}
    stance = [p for p in ra.phase_poses(rep) if p.label == "stance"]
    g0 = rep.phases.ground[0]
    com_y = np.asarray(rep.com.com)[:, 1]
    assert stance and stance[0].frame == g0[0] + int(np.argmin(com_y[g0[0]:g0[1]]))


def test_the_deepest_frame_below_the_floor_is_a_pose(sunk, bf_track):
    bad, (a, b), tr = sunk
    pen, = tr.report.by_check("floor_penetration")
    poses = ra.phase_poses(tr.report)
    # the body is pushed down in one step: the same frame is also a COM velocity jump
    assert ra.Pose(pen.peak_frame, "COM jump + below floor") in poses
    # the one-step push reads as one-frame airborne runs (the detector's speed test) at its ends: the
    # audit calls them spurious, not flights, so they get no take-off/landing poses that would hide it
    labels = {p.label for p in poses}
    for k, f in enumerate(tr.report.flights):
        if not f.is_flight:
            assert not {f"take-off {k + 1}", f"landing {k + 1}", f"apex {k + 1}"} & labels
    assert "below floor" not in {p.label for p in ra.phase_poses(bf_track.report)}   # clean: no such pose


def test_a_double_flip_shows_more_flight_poses(bf, bf_track):
    from mocomp.flips import multiflip, prepare

    res = multiflip(prepare(bf.motion, body=bf.body), flips=2)
    rep2 = audit(res.motion, bf.body)
    n1 = sum(p.label.startswith("flight") for p in ra.phase_poses(bf_track.report))
    n2 = sum(p.label.startswith("flight") for p in ra.phase_poses(rep2))
    assert n2 > n1 >= 2


# ------------------------------------------------------------------ planted defect, in the pixels
def test_penetrating_bones_are_those_the_audit_finds_below_the_floor(sunk):
    bad, (a, b), tr = sunk
    pen = tr.report.by_check("floor_penetration")
    assert len(pen) == 1 and pen[0].frames == (a, b)
    rows = np.flatnonzero(tr.penetrating.any(axis=1))
    np.testing.assert_array_equal(rows, np.arange(a, b))
    # the deepest bone is 5 cm below the floor, like the audit's lowest point
    np.testing.assert_allclose(tr.bone_depth[a:b].max(axis=1), tr.report.penetration.depth[a:b], atol=1e-9)
    # drawn with the audit's floor at the toe-capsule clearance
    assert tr.report.penetration.floor_y + tr.shift == pytest.approx(tr.floor_drawn, abs=1e-12)


def test_a_penetrating_foot_is_red_in_the_pixels_through_the_ground(sunk):
    bad, (a, b), tr = sunk
    f_bad, f_ok = (a + b) // 2, a - 12
    cams = ra.make_cameras("side", [tr], [(0, tr.n_frames)], SMALL.width / SMALL.height)
    with ra.AuditRenderer([tr], SMALL, cameras=cams) as r:
        out = {}
        for f in (f_bad, f_ok):
            scene = r.scene([f])                        # 3-D only: no 2-D depth mark, no text
            xy, ok = ra.project_points(r.projection(0), tr.lowest[f][None], SMALL.width, SMALL.height)
            x, y = np.round(xy[0]).astype(int)
            win = red_mask(scene)[max(0, y - 14):y + 15, max(0, x - 14):x + 15]
            out[f] = (int(win.sum()), int(red_mask(scene).sum()))
        annotated = r.frame([f_bad], title=False, findings=False)
    assert out[f_bad][0] >= 12, out                    # the sunken foot shows red through the ground
    assert out[f_ok][1] == 0, out                      # nothing red while the feet are on the floor
    # the annotated frame adds the depth mark and the time bar (violations red)
    assert red_mask(annotated[:SMALL.height]).sum() > out[f_bad][1]
    assert red_mask(annotated[SMALL.height:]).sum() > 0


def test_the_translucent_ground_shows_the_part_below_the_floor(sunk):
    """Through the translucent ground the sunken part of the foot adds (blended) red pixels that an
    opaque ground hides."""
    bad, (a, b), tr = sunk
    f = (a + b) // 2
    cams = ra.make_cameras("side", [tr], [(0, tr.n_frames)], SMALL.width / SMALL.height)
    counts = {}
    for op in (1.0, ra.OverlayStyle().ground_opacity):
        with ra.AuditRenderer([tr], SMALL, ra.OverlayStyle(ground_opacity=op), cams) as r:
            img = r.scene([f]).astype(int)
        red, g, b_ = img[..., 0], img[..., 1], img[..., 2]
        counts[op] = int(((red > 120) & (g < 0.6 * red) & (b_ < 0.6 * red)).sum())
    assert counts[ra.OverlayStyle().ground_opacity] > 1.15 * counts[1.0], counts


def test_contact_discs_follow_the_detectors_planted_frames(bf_track):
    tr = bf_track
    (fa, fb), = tr.report.phases.flights
    assert tr.planted[: fa - 5].any(axis=1).all() and not tr.planted[fa + 2:fb - 2].any()
    green = lambda img: (img[..., 1].astype(int) > 120) & (img[..., 0] < 60) & (img[..., 2] < 110)  # noqa: E731
    with ra.AuditRenderer([tr], SMALL) as r:
        stand, air = r.scene([5]), r.scene([(fa + fb) // 2])
    assert green(stand).sum() > 20 and green(air).sum() == 0


def test_projection_matches_the_rendered_com_mark(bf_track):
    """The 2-D marks sit where VTK draws the 3-D scene: a pixel of the body is where the COM projects."""
    tr = bf_track
    with ra.AuditRenderer([tr], SMALL) as r:
        f = 5
        scene = r.scene([f])
        (x, y), = ra.project_points(r.projection(0), tr.com[f][None], SMALL.width, SMALL.height)[0]
        sky = np.asarray(SMALL.background) * 255
    # the COM of a standing body lies inside its drawn trunk: not sky there, sky 60 px to the side
    px = scene[int(round(y)), int(round(x))].astype(float)
    assert np.abs(px - sky).max() > 40
    assert np.abs(scene[int(round(y)), min(int(round(x)) + 60, SMALL.width - 1)].astype(float) - sky).max() < 30


# ------------------------------------------------------------------ frames, cameras, outputs
@pytest.mark.parametrize("text,word", [("5:3", "at least 2 frames"), ("10:400", "has 323 frames (0-322)"),
                                       ("322:323", "at least 2 frames"), ("x:4", "'x' is not a frame number"),
                                       ("-1:4", "'-1' is not a frame number"), ("7", "must be A:B"),
                                       ("1:2:3", "must be A:B")])
def test_frame_range_errors_name_the_problem(text, word):
    with pytest.raises(ValueError, match=None) as e:
        ra.resolve_frames(text, 323, "backflip")
    assert word in str(e.value)


def test_frame_ranges_resolve():
    assert ra.resolve_frames(None, 10) == (0, 10)
    assert ra.resolve_frames("3:", 10) == (3, 10)
    assert ra.resolve_frames(":4", 10) == (0, 4)
    assert ra.resolve_frames((2, None), 10) == (2, 10)


def test_unknown_output_extension_is_named():
    with pytest.raises(ValueError, match=r"unknown output type '\.avi'"):
        ra.output_kind("x.avi")
    with pytest.raises(ValueError, match=r"\(no extension\)"):
        ra.output_kind("x")
    assert [ra.output_kind(f"a{e}") for e in (".mp4", ".GIF", ".png")] == ["video", "gif", "filmstrip"]


def test_cameras(bf, bf_track):
    tr = bf_track
    side, front = ra.view_directions(tr)
    L = np.sum([f.L_mean for f in tr.report.flights], axis=0) * [1, 0, 1]
    assert side @ (-L / np.linalg.norm(L)) == pytest.approx(1.0, abs=1e-9)   # along the somersault axis
    assert abs(side @ front) < 1e-9 and side[1] == front[1] == 0
    rng = [(0, tr.n_frames)]
    s, = ra.make_cameras("side", [tr], rng, 4 / 3)
    d = np.subtract(s.focal_point, s.position)
    assert (d / np.linalg.norm(d)) @ side > 0.98                     # 8 deg elevation
    fr, = ra.make_cameras("front", [tr], rng, 4 / 3)
    d = np.subtract(fr.focal_point, fr.position)
    assert (d / np.linalg.norm(d)) @ front > 0.98
    top, = ra.make_cameras("top", [tr], rng, 4 / 3)
    d = np.subtract(top.focal_point, top.position)
    assert d[1] / np.linalg.norm(d) == pytest.approx(-1.0)
    fol, = ra.make_cameras("follow", [tr], rng, 4 / 3)
    a, b = fol.at(0), fol.at(tr.n_frames - 1)
    shift = np.subtract(b.focal_point, a.focal_point)
    assert shift[1] == 0 and np.allclose(np.subtract(b.position, a.position), shift)
    travel = (tr.motion.root_positions[-1] - tr.motion.root_positions[0]) * [1, 0, 1]
    assert np.linalg.norm(shift - travel) < 0.1 * np.linalg.norm(travel) + 0.02
    with pytest.raises(ValueError, match="camera must be one of side, front, top, follow"):
        ra.make_cameras("orbit", [tr], rng, 4 / 3)


def test_side_by_side_timeline_holds_the_shorter_motion():
    from types import SimpleNamespace as NS

    a = NS(motion=NS(fps=120.0), n_frames=100)
    b = NS(motion=NS(fps=60.0), n_frames=30)
    fr, ended, fps = ra._timeline([a, b], [(0, 100), (0, 30)], 2)
    assert fps == 60.0 and len(fr) == 50
    np.testing.assert_array_equal(fr[:30, 1], np.arange(30))     # the same times at half the rate
    assert (fr[30:, 1] == 29).all() and ended[30:, 1].all() and not ended[:30, 1].any()


def test_video_gif_and_filmstrip_outputs(bf, tmp_path):
    import imageio.v3 as iio
    from PIL import Image

    m = bf.motion
    tiny = RenderStyle(width=96, height=72)
    v = ra.render_with_audit(m, tmp_path / "a.mp4", against=m[:200], frames="100:140", style=tiny)
    assert v.kind == "video" and v.stride == 2 and v.fps == 60.0 and v.n_frames == 20
    first = iio.imread(tmp_path / "a.mp4", index=0)
    assert first.shape == (72 + ra.OverlayStyle().bar_height, 2 * 96, 3)
    g = ra.render_with_audit(m, tmp_path / "a.gif", frames="100:140", style=tiny)
    assert g.stride == 5 and g.n_frames == 8
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 8 and im.info["duration"] in (41, 42, 40)
    s = ra.render_with_audit(m, tmp_path / "a.png", style=RenderStyle(width=160, height=120))
    img = iio.imread(tmp_path / "a.png")
    ov = ra.OverlayStyle()
    n = len(s.poses[0])
    assert img.shape[1] == n * 60 and img.shape[0] == ov.header_height + 80 + ov.caption_height + ov.bar_height


def test_lights_turn_with_the_camera(bf):
    """A motion turned 180 deg about the vertical is seen from the other side; with the lights turning
    with the camera (and the checker symmetric under the turn) the picture is the same, not the dark
    side of the body."""
    from mocomp.plots.render3d import rotate_about_y

    np.testing.assert_allclose(rotate_about_y([0.0, 0.0, -1.0], np.pi / 2), [-1.0, 0.0, 0.0], atol=1e-12)
    assert ra._camera_yaw(ra.Camera((0, 1, 5), (0, 1, 0))) == pytest.approx(0.0)
    assert ra._camera_yaw(ra.Camera((5, 1, 0), (0, 1, 0))) == pytest.approx(np.pi / 2)
    m = bf.motion
    turned = m.rotated([0.0, 1.0, 0.0, 0.0])
    imgs = []
    for mm in (m, turned):
        tr = ra.audit_track(mm, audit(mm, bf.body), style=SMALL)
        with ra.AuditRenderer([tr], SMALL) as r:
            imgs.append(r.scene([140]).astype(float))
    assert np.abs(imgs[0] - imgs[1]).mean() < 1.0


def test_real_88_01_landing_below_the_floor_is_drawn_red(real_data_dir):
    """CMU 88_01 (real capture): every frame the audit finds below the floor has a red bone, and no
    other frame; the filmstrip shows the flight by its take-off, apex and landing."""
    from mocomp import datasets

    m = datasets.load("88_01")
    tr = ra.audit_track(m, name="88_01", style=SMALL)
    rep = tr.report
    np.testing.assert_array_equal(tr.penetrating.any(axis=1), rep.penetration.depth > rep.thresholds.penetration)
    assert rep.by_check("floor_penetration")                 # the capture's own landing goes below its floor
    labels = {p.label: p.frame for p in ra.phase_poses(rep)}
    assert labels["take-off 1"] == rep.phases.takeoffs[0] and labels["landing 1"] == rep.phases.landings[0]
    a, b = rep.phases.flights[0]
    assert sum(a <= p.frame < b for p in ra.phase_poses(rep)) >= 4


# ------------------------------------------------------------------ expected findings (external force)
@pytest.fixture(scope="module")
def pushed(bf):
    """The back flip pushed: a 1 m/s horizontal velocity step in the landing hold, audited with and
    without the push declared as an external force."""
    m = bf.motion
    a = bf.phases["hold"][0] + 10
    rp = np.array(m.root_positions)
    rp[a:, 0] += 1.0 * (np.arange(m.n_frames - a) + 1) / m.fps
    p = m.replace(root_positions=rp)
    forced = audit(p, bf.body, external_force_frames=[(a - 2, a + 3)])
    return p, a, forced, audit(p, bf.body)


def _color_cols(img, col, tol=6):
    c = np.array(ra._rgb255(col))
    return np.flatnonzero(np.all(np.abs(img.astype(int) - c) <= tol, axis=-1).any(axis=0))


def test_expected_findings_have_their_own_colour_and_legend(pushed):
    p, a, forced, free = pushed
    assert forced.expected and not any(f.frames[0] - 12 <= a < f.frames[1] + 12 for f in forced.violations)
    assert any(f.frames[0] - 12 <= a < f.frames[1] + 12 for f in free.violations)
    st = ra.OverlayStyle()
    assert st.expected_color not in (st.advisory_color, st.penetration_color)
    e = forced.expected[0]
    assert ra.finding_color(e, st) == st.expected_color
    assert ra.finding_color(free.violations[0], st) == st.penetration_color
    bar_f = ra._TimeBar(ra.audit_track(p, forced, name="forced", style=SMALL), 640, st, (0, p.n_frames))
    bar_v = ra._TimeBar(ra.audit_track(p, free, name="free", style=SMALL), 640, st, (0, p.n_frames))
    z0, z1 = bar_f.rows[2], bar_f.rows[3]
    row_f = bar_f.image[z0:z1 + 1]
    cols = _color_cols(row_f, st.expected_color)
    # the expected finding is drawn violet over its frames
    lo, hi = bar_f.xf(e.frames[0]), max(bar_f.xf(e.frames[1]) - 1, bar_f.xf(e.frames[0]) + 1)
    assert np.any((cols >= lo) & (cols <= hi))
    # the legend (top strip) has the violet swatch only where there are expected findings
    assert _color_cols(bar_f.image[:z0 - 12], st.expected_color).size > 0
    assert _color_cols(bar_v.image[:z0 - 12], st.expected_color).size == 0
    assert _color_cols(bar_v.image[z0:z1 + 1], st.expected_color).size == 0
    assert "expected" in ra._verdict_text(forced)[0] and "expected" not in ra._verdict_text(free)[0]
