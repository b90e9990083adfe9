"""``mocomp edit``, ``mocomp join``, ``mocomp twist`` (issue 5, interfaces)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mocomp.cli import main
from mocomp.io import read_bvh


def test_edit_writes_bvh_report_and_plot(tmp_path, capsys):
    out, rep, png = tmp_path / "e.bvh", tmp_path / "r.json", tmp_path / "e.png"
    rc = main(["edit", "backflip", "--preset", "arms-twist", "-o", str(out), "--report", str(rep),
               "--plot", str(png)])
    assert rc == 0
    m = read_bvh(out)
    assert m.skeleton.n_joints == 31 and m.n_frames > 250
    d = json.loads(rep.read_text())
    assert d["max_errors"]["direction"]["direction_rad"] < 0.01
    assert d["max_errors"]["magnitude"]["magnitude_frac"] < 0.05
    assert d["max_errors"]["magnitude"]["magnitude_percent"] == 100 * d["max_errors"]["magnitude"]["magnitude_frac"]
    assert "max |L| err (%)" in capsys.readouterr().out
    assert png.stat().st_size > 10_000
    assert "after step" not in capsys.readouterr().err


def test_edit_bad_inputs(tmp_path, capsys):
    assert main(["edit", "backflip", "--preset", "arms-twist", "-o", str(tmp_path / "x.txt")]) == 2
    assert ".bvh" in capsys.readouterr().err
    assert main(["edit", "backflip", "--preset", "arms-twist", "--flight", "120", "125",
                 "-o", str(tmp_path / "x.bvh")]) == 2
    err = capsys.readouterr().err
    assert "too short" in err and "flight" in err


def test_join_and_its_refusal(tmp_path, capsys):
    out = tmp_path / "j.bvh"
    assert main(["join", "backflip", "sideflip", "-o", str(out), "--force"]) == 0
    assert read_bvh(out).n_frames > 200
    assert main(["join", "backflip", "twist180", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "cannot be aligned" in err and "deg" in err


def test_twist_and_out_of_range(tmp_path, capsys):
    out, rep = tmp_path / "t.bvh", tmp_path / "t.json"
    assert main(["twist", "twist180", "--degrees", "240", "-o", str(out), "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert abs(d["achieved_deg"] - 240) < 1.5 and d["takeoff_speed"] > d["takeoff_speed_original"]
    assert np.isfinite(read_bvh(out).root_positions).all()
    assert main(["twist", "twist180", "--degrees", "720", "-o", str(out)]) == 2
    assert "outside the range reachable" in capsys.readouterr().err


def _arm_angles(motion, f):
    """Upper arm vs the trunk axis (deg), left and right."""
    j = {n: i for i, n in enumerate(motion.skeleton.names)}
    P = motion.positions[f]
    up = P[j["Neck"]] - P[j["Hips"]]
    out = []
    for s in ("Left", "Right"):
        a = P[j[s + "ForeArm"]] - P[j[s + "Arm"]]
        out.append(float(np.degrees(np.arccos(a @ up / np.linalg.norm(a) / np.linalg.norm(up)))))
    return out


def test_edit_method_bfgs_and_up_side_reach_the_computation(tmp_path, capsys):
    out, ed, rep = tmp_path / "e.bvh", tmp_path / "ed.bvh", tmp_path / "r.json"
    assert main(["edit", "backflip", "--preset", "arms-twist", "--method", "bfgs", "--up-side", "r",
                 "-o", str(out), "--edited", str(ed), "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["direction"]["method"] == "bfgs"
    assert d["direction"]["evaluations"] > 10 * (d["flight"][1] - d["flight"][0])   # BFGS iterates per frame
    assert d["max_errors"]["direction"]["direction_rad"] < 1e-6
    assert d["reference"] == "constant"           # 'auto' on an exact synthetic flight
    # --up-side r: the right arm goes up along the trunk, the left out to the side (mid edit)
    edited = read_bvh(ed)
    lft, rgt = _arm_angles(edited, (d["flight"][0] + d["flight"][1]) // 2)
    assert rgt < 10.0 and abs(lft - 90.0) < 5.0


def test_edit_reference_original_and_takeoff_height_reach_the_computation(tmp_path, capsys):
    from mocomp import datasets

    out, rep = tmp_path / "e.bvh", tmp_path / "r.json"
    assert main(["edit", "backflip", "--preset", "straight-legs", "--reference", "original",
                 "--takeoff-height", "0.5", "-o", str(out), "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["reference"] == "original"
    assert d["takeoff_height_m"] == 0.5
    assert d["platform"] is not None and d["platform"]["clearance"] >= -1e-9
    assert d["retime"]["dy"] < -0.4                       # the landing now lies 0.5 m below the take-off
    assert "target original" in capsys.readouterr().out
    m = read_bvh(out)
    src = datasets.load_example("backflip").motion
    assert abs(m.root_positions[0, 1] - src.root_positions[0, 1] - 0.5) < 1e-4


def test_edit_real_clip_default_target_starts_at_the_edit(tmp_path, capsys, real_data_dir):
    """CLI default --reference auto on a capture: the original's own L(f), so step 1's first departure
    is the frame before the first edited one and the output's take-off part is the capture's."""
    rep = tmp_path / "r.json"
    assert main(["edit", "cmu_88_01_backflip", "--preset", "arms-twist", "-o", str(tmp_path / "e.bvh"),
                 "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["reference"] == "original"
    assert d["direction"]["first_departure"] == d["edit_frames"][0] - 1
    assert d["foot_slide_own_m"] > 0.05 and d["foot_slide_m"] < d["foot_slide_own_m"] + 0.02
    assert "reference='auto'" in capsys.readouterr().out


def test_join_help_states_the_seam_limitation(capsys):
    with pytest.raises(SystemExit):
        main(["join", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "Limitation" in out and "--direction-step" in out and "velocity jumps" in out


# ------------------------------------------------------------- plausibility of the flight
def _parabola_fit(duration_s: float, g: float, fps: float = 120.0, start: int = 10):
    """The ballistic fit of an exact COM parabola lasting ``duration_s`` (take-off frame to last
    airborne frame) under gravity ``g``."""
    from mocomp.flips.mass import fit_ballistic

    n = int(round(duration_s * fps)) + 1
    t = np.arange(n) / fps
    com = np.column_stack([0.5 * t, 1.0 + 2.0 * t - 0.5 * g * t * t, 0.0 * t])
    return fit_ballistic(com, fps, start)


def test_flight_check_rules_on_exact_parabolas():
    """Known answers: the duration rule at 0.25 s, the flight's own gravity interval (floor sd 0.08 in
    log s, 95 %: x/÷ 1.17) against 7.00-13.73 m/s^2, the clip's combined gravity against the same band."""
    from mocomp.flips.mass import G, diagnose_timing
    from mocomp.flips.plausibility import GRAVITY_BAND, MIN_FLIGHT_S, check_flight

    assert GRAVITY_BAND == pytest.approx((G / 1.4, G * 1.4)) and MIN_FLIGHT_S == 0.25
    ok = check_flight(_parabola_fit(0.4, 9.81), 120.0)
    assert ok.ok and ok.duration == pytest.approx(0.4) and ok.gravity == pytest.approx(9.81, rel=1e-9)
    short = check_flight(_parabola_fit(0.2, 9.81), 120.0)
    assert not short.ok and len(short.problems) == 1 and "0.200 s, shorter than the 0.25 s" in short.problems[0]
    assert check_flight(_parabola_fit(0.25, 9.81), 120.0).ok                     # the minimum itself passes
    lo = check_flight(_parabola_fit(0.4, 5.0), 120.0)                            # 5.0 x 1.17 = 5.85 < 7.00
    assert not lo.ok and "gravity 5.00 m/s^2" in lo.problems[0] and "7.00-13.73" in lo.problems[0]
    assert lo.gravity_interval[1] == pytest.approx(5.0 * np.exp(1.959964 * 0.08), rel=1e-4)
    edge = _parabola_fit(0.4, 6.5)                                               # interval reaches 7.6
    assert check_flight(edge, 120.0).ok
    clip = check_flight(edge, 120.0, diagnose_timing([edge], 120.0))             # ... but the clip's 6.5 does not
    assert not clip.ok and "the clip's 1 flight combined gives gravity 6.50" in clip.problems[0]
    hi = check_flight(_parabola_fit(0.4, 4 * 9.81), 120.0, diagnose_timing([_parabola_fit(0.4, 4 * 9.81)], 120.0))
    assert not hi.ok and hi.suggested_fps == 60.0                                # a 60 Hz capture labelled 120 Hz
    assert "reload it at 60 Hz (fps=60)" in hi.describe()


def test_flight_check_on_a_synthetic_jump_at_a_wrong_frame_rate():
    """The synthetic jump (exact g = 9.81) passes; labelled 60 Hz instead of 120 Hz its flight lasts
    twice as long and its gravity is a quarter: refused, pointing at 120 Hz."""
    from mocomp import datasets
    from mocomp.flips.plausibility import check_detected
    from mocomp.flips.preprocess import clip_prior
    from mocomp.flips.phases import detect_flights

    m = datasets.load("jump")
    body = clip_prior(m)
    det = detect_flights(m, body)
    c = check_detected(m, body, det.flight, det)
    assert c.ok and c.gravity == pytest.approx(9.81, rel=2e-3) and c.clip_gravity == pytest.approx(9.81, rel=2e-3)
    slow = m.with_fps(60.0)
    c2 = check_detected(slow, body, det.flight)
    assert not c2.ok and c2.gravity == pytest.approx(9.81 / 4, rel=2e-3) and c2.suggested_fps == 120.0
    assert c2.duration == pytest.approx(2 * c.duration)


def test_edit_explicit_short_flight_is_used_with_a_one_line_warning(tmp_path, capsys):
    out = tmp_path / "e.bvh"
    assert main(["edit", "backflip", "--preset", "straight-legs", "--flight", "130", "155", "-o", str(out)]) == 0
    cap = capsys.readouterr()
    warn = [ln for ln in cap.err.splitlines() if "warning" in ln]
    assert warn[0].startswith("mocomp edit: warning: backflip: the given flight, frames 130-154")
    assert "0.200 s, shorter than the 0.25 s minimum" in warn[0] and "used anyway" in warn[0]
    assert out.exists()
    # the edit of a flight that is not one is worse than its input: the audit of the output says so, one line
    # (the body is airborne until frame 199, so the restoration runs the flight on to the touchdown there)
    assert len(warn) == 2 and warn[1].startswith(f"mocomp edit: warning: the output {out} has ")
    assert "new or worse than its input" in warn[1] and cap.out.splitlines()[-1].startswith("audit: FAIL")
    assert "until the body reaches the floor (frame 199)" in cap.out


def test_edit_detected_synthetic_flight_passes_without_warning(tmp_path, capsys):
    assert main(["edit", "jump", "--preset", "straight-legs", "-o", str(tmp_path / "e.bvh")]) == 0
    assert "warning" not in capsys.readouterr().err


def test_walk_131_01_is_refused_by_edit(tmp_path, capsys, real_data_dir):
    """CMU 131_01 (a walk): the detector's 0.200 s 'flight' (frames 321-345, COM gravity 4.50 m/s^2)
    used to be edited into a 34 m/s knee and a 0.6 m foot slide with exit 0."""
    out = tmp_path / "w.bvh"
    assert main(["edit", "131_01", "--preset", "straight-legs", "-o", str(out)]) == 2
    assert not out.exists()
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mocomp edit: error: 131_01: the detected flight, frames "
                                                   "321-345 (0.200 s at 120 Hz), is not plausible free flight")
    for part in ("shorter than the 0.25 s minimum", "gravity 4.50 m/s^2", "outside the accepted 7.00-13.73 m/s^2",
                 "Refused", "(--flight START STOP)"):
        assert part in lines[0], part


def test_join_refuses_a_walk_naming_its_option(tmp_path, capsys, real_data_dir):
    out = tmp_path / "j.bvh"
    assert main(["join", "131_01", "131_02", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "131_01: the detected flight, frames 321-345" in err
    assert "(--takeoff-flight START STOP)" in err and "flights=(" not in err and not out.exists()


def test_flips_refuses_a_clip_at_a_wrong_frame_rate_and_says_how_to_fix_it(tmp_path, capsys, real_data_dir):
    """MASS back flip: 120 Hz header, really ~50 Hz (MANIFEST): gravity ~59 m/s^2 at the header rate."""
    out = tmp_path / "f.bvh"
    assert main(["flips", "mass_backflip", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "frames 45-75" in err and "outside the accepted 7.00-13.73" in err
    assert "(--fix-timing, or --fps 50)" in err and not out.exists()


REAL_FLIGHTS = ["cmu_88_01_backflip", "cmu_88_05_cartwheel_backflip", "cmu_90_08_sideflip", "deepmimic_backflip",
                "deepmimic_sideflip", "deepmimic_spinkick", "deepmimic_jump", "cmu_83_58_hopturn270", "131_03",
                "01_01"]


@pytest.mark.parametrize("name", REAL_FLIGHTS)
def test_every_real_flight_of_the_data_passes_the_check(name, real_data_dir):
    """With the prior masses (edit, twist, join) and with the estimated ones (flips), after the
    loaders' frame-rate corrections; the DeepMimic side flip's own fit (14.8 / 13.0 m/s^2) lies above
    the band but its interval reaches into it (its clip's flights combined: 10.9)."""
    from mocomp.flips.plausibility import check_prepared
    from mocomp.flips.preprocess import prepare_cached

    for estimate in (False, True):
        P = prepare_cached(name, estimate=estimate, loop_options={"min_angle": 0.0})
        c = check_prepared(P)
        assert c.ok, c.describe(name)
        assert 7.0 < c.clip_gravity < 11.5 and c.duration >= 0.25


@pytest.mark.parametrize("name,rule", [("131_01", ("shorter", "parabola", "combined")), ("131_02", ("shorter",)),
                                       ("sfu_0005_Jogging001", ("shorter",)),
                                       ("mass_backflip", ("parabola", "combined"))])
def test_walks_runs_and_a_mislabelled_clip_are_refused(name, rule, real_data_dir):
    from mocomp.flips.plausibility import check_prepared
    from mocomp.flips.preprocess import prepare_cached

    P = prepare_cached(name, estimate=False, loop_options={"min_angle": 0.0})
    c = check_prepared(P)
    assert len(c.problems) == len(rule)
    for problem, word in zip(c.problems, rule):
        assert word in problem
    if name == "mass_backflip":       # at 50 Hz it is a flight
        assert check_prepared(prepare_cached(name, fps=50.0, estimate=False)).ok


# ---------------------------------------------------------------- issue #13 section 2: the audit of the output
def _verdict(cap):
    last = cap.out.strip().splitlines()[-1]
    assert last.startswith("audit: PASS, ") or last.startswith("audit: FAIL, "), last
    return last


@pytest.mark.parametrize("argv", [
    ["edit", "backflip", "--preset", "arms-twist"],
    ["twist", "twist180", "--degrees", "240"],
    ["join", "backflip", "sideflip", "--force"],
])
def test_commands_end_with_the_audit_verdict(tmp_path, capsys, argv):
    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    assert main(argv + ["-o", str(out), "--report", str(rep)]) == 0
    cap = capsys.readouterr()
    last = _verdict(cap)
    d = json.loads(rep.read_text())
    a = d["audit"]
    assert a["verdict"] in ("pass", "fail") and a["verdict"].upper() in last
    assert a["violations"] == len([f for f in a["findings"] if f["severity"] == "violation"])
    assert a["name"] == str(out) and a["n_frames"] == read_bvh(out).n_frames
    assert d["provenance"]["measured"] == "audit"
    # a warning line exactly when the output has violations its input(s) lack, naming them
    warn = [ln for ln in cap.err.splitlines() if ln.startswith(f"mocomp {argv[0]}: warning: the output")]
    assert bool(warn) == bool(a["new_violations"])
    for f in a["new_violations"]:
        assert f"{f['check']} at {f['where']}" in warn[0] and f["severity"] == "violation"
    if argv[0] == "join":
        assert [o["name"] for o in a["other_inputs"]] == ["sideflip"] and "sideflip: " in last


def test_edit_no_audit(tmp_path, capsys):
    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    assert main(["edit", "backflip", "--preset", "arms-twist", "-o", str(out), "--report", str(rep),
                 "--no-audit"]) == 0
    cap = capsys.readouterr()
    assert not any(ln.startswith("audit:") for ln in cap.out.splitlines())
    assert json.loads(rep.read_text())["audit"] is None
