"""``mocomp splice BODY HAND -o OUT.bvh [--match ...] [--plot ...]``."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.cli import main
from mocomp.io import read_bvh, write_bvh
from mocomp.splice.synthetic import synthetic_pair


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("splice")
    pair = synthetic_pair(3)
    write_bvh(pair.body, d / "body.bvh")
    write_bvh(pair.hand, d / "hand.bvh")
    return d, pair


def test_cli_writes_spliced_bvh_and_plot(files, capsys):
    d, pair = files
    x = pair.body.n_frames // 2
    y = int(round(pair.truth[x]))
    rc = main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "out.bvh"),
               "--match", f"{x}:{y}", "--match", f"{x + 40}:{int(pair.truth[x + 40])}~3", "--plot", str(d / "bands.png")])
    assert rc == 0
    out = capsys.readouterr().out
    assert "right arm" in out and f"{x}:{y}" in out and "residuals [0.0," in out
    m = read_bvh(d / "out.bvh", scale="m")
    assert m.n_frames == pair.body.n_frames and m.skeleton.names == pair.body.skeleton.names
    assert (d / "bands.png").stat().st_size > 10_000
    legs = m.skeleton.index("UpperLeg_R")
    np.testing.assert_allclose(np.abs(np.sum(m.rotations[:, legs] * pair.body.rotations[:, legs], axis=1)), 1, atol=1e-6)


def test_cli_options(files, capsys):
    d, _ = files
    rc = main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "out2.bvh"), "--side", "both",
               "--layer", "forearm", "--theta", "trunk", "--no-refine", "--phase-width", "25%", "--plot", str(d / "b.png"),
               "--frame-map", "median"])
    assert rc == 0
    assert (d / "b_right.png").exists() and (d / "b_left.png").exists()
    assert "left arm" in capsys.readouterr().out


@pytest.mark.parametrize("args,msg", [
    (["--match", "50:20", "--match", "40:30"], "out of order"),
    (["--match", "5:99999"], "outside the matrix"),
])
def test_cli_bad_points_exit_2(files, capsys, args, msg):
    d, _ = files
    rc = main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "x.bvh"), *args])
    assert rc == 2
    err = capsys.readouterr().err
    assert msg in err and err.count("\n") == 1


def test_cli_argument_errors(files, capsys):
    d, _ = files
    with pytest.raises(SystemExit) as e:
        main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "x.bvh"), "--match", "12x"])
    assert e.value.code == 2
    assert "BODY_FRAME:HAND_FRAME" in capsys.readouterr().err
    assert main(["splice", str(d / "body.bvh"), str(d / "nope.bvh"), "-o", str(d / "x.bvh")]) == 2
    assert main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "x.txt")]) == 2
    assert main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "no" / "x.bvh")]) == 2
