"""``mocomp edit``, ``mocomp join``, ``mocomp twist`` (issue 5, interfaces)."""
from __future__ import annotations

import json

import numpy as np

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
