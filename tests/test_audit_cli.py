"""``mocomp audit``: summary, JSON report, plot, --against, thresholds, one-line errors (exit 2)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mocomp.cli import main
from mocomp.io import write_bvh
from mocomp.synth.registry import make_example


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The embedded back flip as BVH, and a copy whose last 30 frames sink 6 cm into the floor."""
    d = tmp_path_factory.mktemp("audit_cli")
    r = make_example("backflip")
    m = r.motion
    orig = d / "backflip.bvh"
    write_bvh(m, orig)
    rp = np.array(m.root_positions)
    rp[-30:, 1] -= 0.06
    sunk = d / "sunk.bvh"
    write_bvh(m.replace(root_positions=rp), sunk)
    return orig, sunk, m.n_frames


def test_audit_example_writes_report_and_plot(tmp_path, capsys):
    rj, png = tmp_path / "r.json", tmp_path / "audit.png"
    assert main(["audit", "backflip", "--report", str(rj), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "verdict: PASS" in out and "flight 1" in out and "g = 9.81" in out
    d = json.loads(rj.read_text())
    assert d["verdict"] == "pass" and d["violations"] == 0
    assert d["flights"][0]["g_fit"] == pytest.approx(9.81, abs=1e-6)
    assert png.stat().st_size > 20_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_audit_finds_the_sunken_landing_against_the_original(files, tmp_path, capsys):
    orig, sunk, T = files
    rj = tmp_path / "r.json"
    assert main(["audit", str(sunk), "--against", str(orig), "--report", str(rj)]) == 0
    out = capsys.readouterr().out
    assert "verdict: FAIL" in out and "floor_penetration" in out and "WORSE" in out
    d = json.loads(rj.read_text())
    pen = [f for f in d["findings"] if f["check"] == "floor_penetration"]
    assert len(pen) == 1 and pen[0]["frames"] == [T - 30, T]
    assert pen[0]["size"] == pytest.approx(0.06, abs=1e-4)          # BVH text keeps ~1e-6 m
    assert "max_penetration_m" in d["comparison"]["worse"]
    assert d["comparison"]["against_verdict"] == "pass"
    # the 6 cm drop in one frame is also a COM velocity jump (down, then stop)
    assert {f["check"] for f in d["findings"] if f["severity"] == "violation"} >= {"com_velocity_jump"}
    # --strict turns the failed verdict into exit 1; thresholds above the defects pass it
    assert main(["audit", str(sunk), "--strict"]) == 1
    assert main(["audit", str(orig), "--strict"]) == 0
    assert main(["audit", str(sunk), "--strict", "--threshold", "penetration=0.07", "--threshold", "jump_min=6",
                 "--threshold", "root_speed=8"]) == 0


@pytest.mark.parametrize("argv, words", [
    (["audit", "no_such_clip_xyz"], "no_such_clip_xyz"),
    (["audit", "backflip", "--threshold", "nope=1"], "unknown threshold 'nope'"),
    (["audit", "backflip", "--threshold", "penetration=-1"], "penetration must be positive"),
    (["audit", "backflip", "--threshold", "penetration"], "NAME=VALUE"),
    (["audit", "backflip", "--plot", "x.gif"], "unknown image type"),
    (["audit", "backflip", "--max-findings", "-1"], "--max-findings"),
])
def test_bad_input_is_one_line_and_exit_2(argv, words, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(argv)
    except SystemExit as e:                      # argument errors stop in argparse
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mocomp audit: error:") and words in err[0]


def test_unreadable_and_missing_outputs(files, tmp_path, capsys):
    orig, _, _ = files
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n")
    assert main(["audit", str(bad)]) == 2
    assert "bad.bvh" in capsys.readouterr().err
    assert main(["audit", str(orig), "--report", str(tmp_path / "missing" / "r.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["audit", str(orig), "--plot", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err


def test_against_uses_the_same_loading(files, capsys):
    orig, _, _ = files
    assert main(["audit", str(orig), "--against", str(orig)]) == 0
    out = capsys.readouterr().out
    assert "worse than the original on 0 measure(s)" in out


def test_real_clip_by_name(real_data_dir, capsys):
    assert main(["audit", "88_01", "--max-findings", "3"]) == 0
    out = capsys.readouterr().out
    assert "flight 1" in out and "verdict:" in out
