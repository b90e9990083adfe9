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
    assert main(["join", "backflip", "sideflip", "-o", str(out)]) == 0
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
