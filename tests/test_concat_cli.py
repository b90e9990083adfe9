"""``mocomp concat`` (issue 17): the command line contract, its report (planned values + the audit
of the written file) and one-line errors."""
from __future__ import annotations

import json

import pytest

from mocomp.cli import main
from mocomp.io.bvh import read_bvh


def test_concat_two_flips_writes_report_and_audit(tmp_path, capsys):
    out, rep, png = tmp_path / "o.bvh", tmp_path / "r.json", tmp_path / "L.png"
    assert main(["concat", "backflip", "backflip", "-o", str(out), "--report", str(rep), "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert "rule: forward (auto:" in text and "planned timing (eq. 3-7" in text and "runner-up" in text
    assert text.strip().splitlines()[-1].startswith("audit: ")
    d = json.loads(rep.read_text())
    j = d["joints"][0]
    assert j["rule"]["rule"] == "forward"
    assert set(j["timing"]["optimum"]) == {"T", "f_T", "F", "F_dm", "F_inertia", "F_time"}
    o = j["timing"]["optimum"]
    assert o["F"] == pytest.approx(o["F_dm"] + o["F_inertia"] + o["F_time"])
    assert 0 < j["time_scaling"]["s"] < 1
    assert d["audit"] is not None and "planned" in d["provenance"]["planned"]
    m = read_bvh(out, scale=1.0)
    assert m.n_frames == d["output"]["frames"]
    assert d["output"]["duration_s"] < d["output"]["inputs_back_to_back_s"]
    assert png.stat().st_size > 10000


def test_concat_given_phases_and_rule(tmp_path, capsys):
    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    assert main(["concat", "backflip", "backflip", "--rule", "forward", "--phases", "A:90,200", "B:90,200",
                 "-o", str(out), "--report", str(rep), "--no-audit"]) == 0
    j = json.loads(rep.read_text())["joints"][0]
    assert j["phases"]["A"]["main"] == [90, 200] and j["phases"]["A"]["borders"] == "given"
    assert j["rule"]["why"].startswith("given:")
    assert j["blendable_periods"]["A"][0] >= 145 and j["blendable_periods"]["B"][1] <= 145


def test_concat_chain_of_three(tmp_path, capsys):
    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    assert main(["concat", "backflip", "backflip", "backflip", "-o", str(out), "--report", str(rep),
                 "--no-audit"]) == 0
    d = json.loads(rep.read_text())
    assert len(d["joints"]) == 2
    # the second joint's A main phase is the second flip's, placed at its offset in the chain
    j1, j2 = d["joints"]
    sh = j1["timing"]["T"] + j1["time_scaling"]["window_frames_after"] - j1["blend_window"]["frames"]
    assert j2["phases"]["A"]["main"][1] == j1["phases"]["B"]["main"][1] + sh
    assert read_bvh(out, scale=1.0).n_frames == d["output"]["frames"]


@pytest.mark.parametrize("argv, msg", [
    (["backflip"], "give at least two motions"),
    (["backflip", "backflip", "--phases", "C:1,5"], "there are only motions A-B"),
    (["backflip", "backflip", "--phases", "A:10,5000"], "has only 323 frames"),
    (["backflip", "backflip", "--rule", "forward,reverse"], "--rule lists 2 rules for 1 joint"),
    (["backflip", "backflip", "--max-f", "1e-6"], "too different to be blended"),
    (["backflip", "backflip", "sideflip"], "joint 2 (the chain so far -> sideflip): auto rule: after the eq. 2 "
                                           "alignment"),
    (["backflip@3", "backflip"], "backflip@3: the clip holds 1 strike(s)"),
    (["backflip@0", "backflip"], "strikes are numbered from 1"),
    (["backflip@9:5", "backflip"], "need START < STOP"),
    (["backflip@10:5000", "backflip"], "the clip has only 323 frames"),
    (["backflip", "backflip", "--fps", "C:60"], "--fps C:60: there are only motions A-B"),
])
def test_concat_bad_input_one_line(tmp_path, capsys, argv, msg):
    assert _code(["concat", *argv, "-o", str(tmp_path / "o.bvh")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mocomp concat: error:") and msg in err[0]


def test_concat_bad_phases_syntax(tmp_path, capsys):
    assert _code(["concat", "backflip", "backflip", "--phases", "A:9", "-o", str(tmp_path / "o.bvh")]) == 2
    assert "is not MOTION:START,STOP" in capsys.readouterr().err


def _code(argv) -> int:
    """The exit status: argument errors exit through SystemExit, checks after parsing return 2."""
    try:
        return main(argv)
    except SystemExit as e:
        return int(e.code)


def test_concat_baseline_motion_graph(tmp_path, capsys):
    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    assert main(["concat", "backflip", "backflip", "--baseline", "motion-graph", "-o", str(out), "--report", str(rep),
                 "--no-audit"]) == 0
    d = json.loads(rep.read_text())["baseline"]
    mg = tmp_path / "o.motion-graph.bvh"
    assert read_bvh(mg, scale=1.0).n_frames / 120.0 == pytest.approx(d["motion_graph_s"])
    assert d["ours_s"] < d["motion_graph_s"]
    lv = d["lowest_L_between_main_phases"]
    assert lv["ours"][0] > 0.3 * lv["main_level"][0] > lv["motion_graph"][0]
    assert "lowest |L| between the main phases (measured)" in capsys.readouterr().out


def test_concat_single_strikes_cut_from_takes(tmp_path, capsys, real_data_dir):
    """FILE@K: the K-th strike of a take; a chain of three (kick, slash cut from a combo, slash down)."""
    d = real_data_dir
    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    args = [f"{d}/attacks/ase_rl_Atk_Kick.derived.bvh@1", f"{d}/combos/ase_rl_Atk_2xCombo01.derived.bvh@1",
            f"{d}/attacks/ase_rl_Atk_SlashDown.derived.bvh@5:60"]
    assert main(["concat", *args, "-o", str(out), "--report", str(rep), "--no-audit"]) == 0
    text = capsys.readouterr().out
    assert "A: " in text and "strike 1 of 2: frames 10-41, toe_r" in text
    assert "B: " in text and "strike 1 of 2: frames 5-42, hand_r" in text
    assert "C: " in text and "frames 5-59" in text
    assert len(json.loads(rep.read_text())["joints"]) == 2


def test_concat_summary_reports_measured_feet_and_labels_planned(tmp_path, capsys):
    """The summary's foot slide is what mocomp.audit measures on the file written, read back (the
    planned one, ops.enforce_footplants on its own plants, is labelled planned): the printed and
    reported values equal an audit of the file run here."""
    from mocomp import datasets
    from mocomp.audit import audit
    from mocomp.ops.evidence import foot_slide

    out, rep = tmp_path / "o.bvh", tmp_path / "r.json"
    assert main(["concat", "backflip", "backflip", "-o", str(out), "--report", str(rep)]) == 0
    text = capsys.readouterr().out
    assert "planned feet (ops.enforce_footplants" in text and "\n  feet: largest slide" not in text
    line = next(s for s in text.splitlines() if s.startswith("measured on "))
    d = json.loads(rep.read_text())
    m = d["measured"]
    flip = datasets.load("backflip")
    ref = audit(read_bvh(out, scale=1.0), against=flip)
    assert m["max_foot_slide_m"] == pytest.approx(foot_slide(ref), abs=1e-9)
    assert m["inputs_max_foot_slide_m"][0] == pytest.approx(foot_slide(audit(flip)), abs=1e-9)
    assert m["max_penetration_m"] == pytest.approx(ref.measure("max_penetration_m"), abs=1e-9)
    assert f"largest foot slide within the contacts it finds {m['max_foot_slide_m'] * 100:.2f} cm" in line
    (j,) = m["joints"]
    assert j["output_window"] == d["joints"][0]["time_scaling"]["output_window"]
    assert j["max_foot_slide_m"] <= m["max_foot_slide_m"]
    assert text.strip().splitlines()[-1].startswith("audit: ")
