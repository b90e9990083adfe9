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
    assert d["k"] == pytest.approx(0.7 * d["k_star"])
    assert m.fps == pytest.approx(120.0) and m.n_frames > 300


def test_cli_explicit_k_and_height_change(tmp_path, capsys):
    out, rep = tmp_path / "t.bvh", tmp_path / "r.json"
    assert main(["flips", "backflip", "--flips", "3", "--k", "1.2", "--height-change", "-0.3", "-o", str(out),
                 "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["k"] == 1.2 and d["height_change"] == -0.3 and d["flips"] == 3


def test_cli_levels_shape_joint_flights_and_k_star(tmp_path):
    rep = tmp_path / "r.json"
    assert main(["flips", "backflip", "--k-ratio", "1", "--takeoff-height-change", "0.3", "--shape", "cuboid",
                 "--joint-flights", "--no-seam-retime", "-o", str(tmp_path / "t.bvh"), "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["takeoff_height_change"] == 0.3 and d["k"] == pytest.approx(d["k_star"])
    assert abs(d["p_jump_takeoff_rel"]) < 1e-9 and d["seam_retimed"] is False


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
