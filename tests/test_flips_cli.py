"""``mocomp flips`` and ``mocomp.flips.demo``."""
import json

import numpy as np
import pytest

from mocomp.cli import main
from mocomp.io.bvh import read_bvh


def test_cli_double_flip_writes_bvh_and_report(tmp_path, capsys):
    out, rep = tmp_path / "double.bvh", tmp_path / "report.json"
    assert main(["flips", "backflip", "--flips", "2", "-o", str(out), "--report", str(rep)]) == 0
    text = capsys.readouterr().out
    assert "rotation about L: requested 720 deg" in text and "wrote" in text
    m = read_bvh(out, scale=1.0)
    d = json.loads(rep.read_text())
    assert d["flips"] == 2 and abs(d["achieved_rotation"] - 720) < 10
    assert d["k"] == pytest.approx(d["k_star"])          # the default since issue #13: k = k*
    assert d["gravity"] == 9.81 and d["gravity_source"] == "standard" and d["takeoff"] == "smooth"
    assert m.fps == pytest.approx(120.0) and m.n_frames > 250


def test_cli_explicit_k_and_height_change(tmp_path, capsys):
    out, rep = tmp_path / "t.bvh", tmp_path / "r.json"
    assert main(["flips", "backflip", "--flips", "3", "--k", "1.2", "--height-change", "-0.3", "-o", str(out),
                 "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["k"] == 1.2 and d["height_change"] == -0.3 and d["flips"] == 3


@pytest.fixture
def prepared_by_cli(monkeypatch):
    """The :class:`PreparedFlip` of each ``mocomp flips`` run (``prepare`` wrapped where the CLI
    imports it)."""
    import mocomp.flips as flips_pkg

    seen = []
    real = flips_pkg.prepare

    def spy(*args, **kwargs):
        seen.append(real(*args, **kwargs))
        return seen[-1]

    monkeypatch.setattr(flips_pkg, "prepare", spy)
    return seen


def test_cli_levels_shape_and_k_star(tmp_path, prepared_by_cli):
    rep = tmp_path / "r.json"
    assert main(["flips", "backflip", "--k-ratio", "1", "--takeoff-height-change", "0.3", "--shape", "cuboid",
                 "--no-seam-retime", "-o", str(tmp_path / "t.bvh"), "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["takeoff_height_change"] == 0.3 and d["k"] == pytest.approx(d["k_star"])
    assert abs(d["p_jump_takeoff_rel"]) < 1e-9 and d["seam_retimed"] is False
    # --shape cuboid reaches the body model: same masses' prior, other inertias (dissertation eq. 5.3)
    assert main(["flips", "backflip", "--no-seam-retime", "-o", str(tmp_path / "e.bvh")]) == 0
    cub, ell = prepared_by_cli
    assert cub.prior.shape == "cuboid" and ell.prior.shape == "ellipsoid"
    np.testing.assert_allclose(cub.prior.masses, ell.prior.masses)
    diff = np.abs(cub.prior.inertias - ell.prior.inertias).max(axis=(1, 2)) / np.abs(ell.prior.inertias).max(axis=(1, 2))
    assert np.all(diff > 0.1), diff


@pytest.mark.realdata
def test_cli_joint_flights_uses_every_flight(real_data_dir, tmp_path, prepared_by_cli):
    """CMU 88_01 has the flip (frames 47-78) and a hop (95-108): --joint-flights fits both."""
    for extra in ([], ["--joint-flights"]):
        assert main(["flips", "cmu_88_01_backflip", *extra, "-o", str(tmp_path / "t.bvh")]) == 0
    one, joint = prepared_by_cli
    assert [(f.start, f.stop) for f in one.mass.fits] == [(47, 79)]
    assert [(f.start, f.stop) for f in joint.mass.fits] == [(47, 79), (95, 109)]
    assert joint.flight == one.flight == (47, 79)
    assert np.abs(joint.body.masses - one.body.masses).max() > 0.05       # kg: the hop moved the estimate


@pytest.mark.parametrize("argv, message", [
    (["flips", "backflip", "--flight", "150", "155"], "skip estimation and keep the table prior (--no-mass-estimate)"),
    (["flips", "jump"], "this clip is not a flip (for a twist jump use mocomp twist)"),
])
def test_cli_hints_name_cli_options(tmp_path, capsys, argv, message):
    assert main(argv + ["-o", str(tmp_path / "x.bvh")]) == 2
    err = capsys.readouterr().err
    assert message in err and "prepare(" not in err and "min_angle" not in err


def test_cli_no_flight_hint_names_the_flight_option(tmp_path, capsys):
    from mocomp.errors import NoFlightPhaseError
    from mocomp.flips import prepare
    from mocomp.io.bvh import write_bvh

    from _flips_data import synthetic

    m = synthetic("backflip").motion
    still = m.replace(root_positions=np.repeat(m.root_positions[:1], 120, axis=0),
                      rotations=np.repeat(m.rotations[:1], 120, axis=0))
    path = write_bvh(still, tmp_path / "still.bvh")
    with pytest.raises(NoFlightPhaseError, match=r"flight=\(start, stop\)"):       # the Python API's wording
        prepare(str(path))
    assert main(["flips", str(path), "-o", str(tmp_path / "x.bvh")]) == 2
    err = capsys.readouterr().err
    assert "no flight phase found" in err and "(--flight START STOP)" in err and "flight=(" not in err


@pytest.mark.parametrize("argv, message", [
    (["flips", "backflip", "--flips", "1"], "at least 2"),
    (["flips", "backflip", "--height-change", "6"], "--height-change below"),
    (["flips", "no_such_clip_xyz"], "no_such_clip_xyz"),
    (["flips", "jump"], "not a flip"),
    (["flips", "backflip", "--k", "-1"], "--k must be a positive"),
])
def test_cli_bad_input_is_one_clear_line(tmp_path, capsys, argv, message):
    assert main(argv + ["-o", str(tmp_path / "x.bvh")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and err.count("\n") == 0
    assert not (tmp_path / "x.bvh").exists()


def test_cli_k_and_k_ratio_exclusive(tmp_path):
    with pytest.raises(SystemExit):
        main(["flips", "backflip", "--k", "1.1", "--k-ratio", "0.7", "-o", str(tmp_path / "x.bvh")])


def test_demo_writes_everything(tmp_path, capsys):
    from mocomp.flips import demo

    d = demo(tmp_path / "demo", renderer="matplotlib")
    for key in ("bvh", "original_bvh", "filmstrip", "momentum", "report"):
        assert d["paths"][key].exists() and d["paths"][key].stat().st_size > 1000
    assert d["filmstrip_renderer"] == "matplotlib"
    rep = json.loads(d["paths"]["report"].read_text())
    assert rep["flips"] == 2 and rep["landing_orientation_error"] < 1.0
    assert "angular momentum" in capsys.readouterr().out
    m = read_bvh(d["paths"]["bvh"], scale=1.0)
    np.testing.assert_allclose(m.root_positions, d["result"].motion.root_positions, atol=1e-6)


def test_demo_cli_flips_count(tmp_path, capsys):
    """``mocomp demo --flips 3`` makes a triple flip (its stance cannot take the 0.7 k* repair, about
    9.6 body weights: the demo says so and uses k = k*); ``--flips 1`` is refused before any work;
    an explicit ``--takeoff repair`` that cannot be done is an error, not replaced."""
    out = tmp_path / "d"
    assert main(["demo", "--flips", "3", "-o", str(out)]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["flips"] == 3 and abs(rep["achieved_rotation"] - 1080) < 10
    assert rep["k"] == pytest.approx(rep["k_star"])
    assert "note: the take-off cannot be repaired" in capsys.readouterr().out
    assert (out / "backflip_x3.bvh").stat().st_size > 1000
    assert main(["demo", "--flips", "3", "--takeoff", "repair", "-o", str(tmp_path / "r")]) == 2
    assert "the take-off cannot be repaired" in capsys.readouterr().err
    assert main(["demo", "--flips", "1", "-o", str(tmp_path / "one")]) == 2
    err = capsys.readouterr().err.strip()
    assert "--flips must be at least 2" in err and err.count("\n") == 0
    assert not (tmp_path / "one").exists()
    from mocomp.flips import demo

    with pytest.raises(ValueError, match=">= 2"):
        demo(tmp_path / "two", flips=1)
    assert not (tmp_path / "two").exists()


# ---------------------------------------------------------------- issue #13 section 2: the audit of the output
def _audit_run(tmp_path, capsys, *extra):
    out, rep = tmp_path / "x2.bvh", tmp_path / "r.json"
    assert main(["flips", "backflip", "-o", str(out), "--report", str(rep), *extra]) == 0
    cap = capsys.readouterr()
    return out, json.loads(rep.read_text()), cap


def test_flips_k07_output_is_audited_worse_than_input(tmp_path, capsys):
    """Planted case: k = 0.7 k* keeps the flight's duration while the take-off is retimed, so the COM
    velocity jumps at take-off (the model's own note says +104%); the audit of the written frames
    must find it, the input (the exact synthetic single flip) has no violation."""
    out, d, cap = _audit_run(tmp_path, capsys, "--k-ratio", "0.7", "--takeoff", "as-is")
    last = cap.out.strip().splitlines()[-1]
    assert last.startswith("audit: FAIL, ") and "input: PASS, 0 violation(s)" in last
    assert "new or worse: com_velocity_jump" in last
    warn = [ln for ln in cap.err.splitlines() if "warning" in ln]
    assert len(warn) == 1 and warn[0].startswith(f"mocomp flips: warning: the output {out} has ")
    assert "com_velocity_jump at take-off of flight 1" in warn[0]
    a = d["audit"]
    new = {}
    for f in a["new_violations"]:                        # the largest finding at each place
        if (f["check"], f["where"]) not in new or f["size"] > new[(f["check"], f["where"])]["size"]:
            new[(f["check"], f["where"])] = f
    assert a["verdict"] == "fail" and a["violations"] >= 1
    jump = new[("com_velocity_jump", "take-off of flight 1")]
    assert jump["input_size"] is None and jump["size"] > 2.0 and jump["size"] > jump["threshold"]
    assert a["comparison"]["against_verdict"] == "pass" and "takeoff_jump_mps" in a["comparison"]["worse"]
    # measured take-off jump: the flight leaves at ~6.3 m/s vertically, the retimed take-off reaches ~3 m/s
    assert a["measures"]["takeoff_jump_mps"] > 2.0
    # the model's planned values stay under their keys, labelled by the provenance key
    assert "achieved_rotation" in d and d["provenance"]["measured"] == "audit" and "planned" in d["provenance"]["planned"]
    assert "planned (the method's model values" in cap.out


def test_flips_k1_output_adds_no_com_jump(tmp_path, capsys):
    """Clean case: k = k* keeps the take-off continuous; the audit finds no physics violation the
    input lacks. (It does flag the kinematic rate check point_speed: the doubled rotation in the
    flight moves a fingertip at 26.8 m/s against the 25 m/s limit; reported, not tuned away.)"""
    out, d, cap = _audit_run(tmp_path, capsys, "--k-ratio", "1")
    last = cap.out.strip().splitlines()[-1]
    assert last.startswith("audit: ") and "com_velocity_jump" not in last
    assert "com_velocity_jump" not in cap.err
    a = d["audit"]
    physics = {"floor_penetration", "foot_slide", "com_velocity_jump", "gravity", "L_direction", "L_magnitude",
               "bone_length"}
    assert not {f["check"] for f in a["new_violations"]} & physics
    assert a["measures"]["takeoff_jump_mps"] < 0.5          # below the take-off jump threshold (jump_min)


def test_flips_audit_is_of_the_written_frames(tmp_path, capsys):
    """The audit in the report is the audit of the BVH read back, against the prepared input."""
    from mocomp.audit import audit
    from mocomp.flips import prepare

    out, d, _ = _audit_run(tmp_path, capsys, "--k-ratio", "0.7")
    direct = audit(read_bvh(out), against=prepare("backflip").motion)
    for k, v in direct.to_dict()["measures"].items():
        got = d["audit"]["measures"][k]
        assert (v is None and got is None) or got == pytest.approx(v, rel=1e-6, abs=1e-9), k
    assert d["audit"]["violations"] == len(direct.violations)


def test_flips_no_audit(tmp_path, capsys):
    out, d, cap = _audit_run(tmp_path, capsys, "--no-audit")
    assert not any(ln.startswith("audit:") for ln in cap.out.splitlines()) and "warning" not in cap.err
    assert d["audit"] is None and d["provenance"]["measured"] is None
    assert cap.out.strip().splitlines()[-1] == f"wrote {tmp_path / 'r.json'}"


def test_demo_cli_ends_with_the_audit_verdict(tmp_path, capsys):
    """The demo makes the double flip at the paper's k = 0.7 k* with the take-off and landing stances
    repaired: the audit of the frames written passes, with no COM velocity jump at take-off or landing
    (as-is, the same k jumps by about 3 m/s: ``test_flips_takeoff``)."""
    assert main(["demo", "-o", str(tmp_path)]) == 0
    cap = capsys.readouterr()
    last = cap.out.strip().splitlines()[-1]
    assert last.startswith("audit: PASS, 0 violation(s)"), last
    assert "warning" not in cap.err
    d = json.loads((tmp_path / "report.json").read_text())
    assert d["audit"]["verdict"] == "pass" and "flips" in d
    assert d["k"] == pytest.approx(0.7 * d["k_star"])
    m = d["audit"]["measures"]
    assert m["takeoff_jump_mps"] < 0.5 and m["landing_jump_mps"] < 0.8


def test_demo_cli_at_k_star_as_is(tmp_path, capsys):
    """``--k-ratio 1 --takeoff as-is`` is multiflip's own default: continuous at k = k*; what the audit
    still finds is the fingertip of the synthetic arm swing, k* = 1.40 times its 19.4 m/s (26.9 m/s,
    limit 25): the uniform retiming of the take-off, frame for frame k times the input's speed."""
    assert main(["demo", "-o", str(tmp_path), "--k-ratio", "1", "--takeoff", "as-is"]) == 0
    cap = capsys.readouterr()
    last = cap.out.strip().splitlines()[-1]
    assert last.startswith("audit: FAIL, 1 violation(s) (point_speed 1)")
    assert "com_velocity_jump" not in cap.err and "point_speed at LeftHandIndex1" in cap.err
    d = json.loads((tmp_path / "report.json").read_text())
    assert d["k"] == pytest.approx(d["k_star"]) and d["audit"]["measures"]["takeoff_jump_mps"] < 0.5


def test_flips_real_clip_worse_takeoff_is_warned(tmp_path, capsys, real_data_dir):
    """CMU 88_01 has a take-off COM jump of its own (0.63 m/s); k = 0.7 k* makes it 2.8 m/s. Counting
    violations per check would call that 'no new violation' (the input has four COM jumps, the output
    one); matched by place, the larger one is reported as worse than the input's."""
    out, rep = tmp_path / "x2.bvh", tmp_path / "r.json"
    assert main(["flips", "88_01", "-o", str(out), "--report", str(rep), "--k-ratio", "0.7", "--takeoff", "as-is"]) == 0
    cap = capsys.readouterr()
    new = {(f["check"], f["where"]): f for f in json.loads(rep.read_text())["audit"]["new_violations"]}
    jump = new[("com_velocity_jump", "take-off of flight 1")]
    # the planned step is 2.9 m/s; where it falls between two frames splits it over both (1.26 + 0.96
    # with the stances eased, 1.77 + 0.75 uniformly)
    assert jump["input_size"] == pytest.approx(0.63, abs=0.1) and jump["size"] > 1.0
    assert "com_velocity_jump at take-off of flight 1" in cap.err and "; input 0.6" in cap.err
    assert ("foot_slide", "foot_r") not in new          # the input's own slide, unchanged by the method
