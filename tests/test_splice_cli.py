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


def _spy(monkeypatch):
    """Record what the CLI hands to the loader and to splice_motions (both still run)."""
    import mocomp.datasets
    import mocomp.splice

    calls = {"load": [], "splice": []}
    real_load, real_splice = mocomp.datasets.load, mocomp.splice.splice_motions

    def load(name, **kw):
        calls["load"].append((name, kw))
        return real_load(name, **kw)

    def splice(body, hand, points=(), **kw):
        calls["splice"].append((points, kw))
        return real_splice(body, hand, points, **kw)

    monkeypatch.setattr(mocomp.datasets, "load", load)
    monkeypatch.setattr(mocomp.splice, "splice_motions", splice)
    return calls


def test_cli_defaults_are_the_library_defaults(files, monkeypatch, capsys):
    from mocomp.splice import SpliceConfig

    d, _ = files
    calls = _spy(monkeypatch)
    assert main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "out0.bvh")]) == 0
    (points, kw), = calls["splice"]
    assert kw["config"] == SpliceConfig() and kw["side"] == "right" and kw["layer"] == "arm" and list(points) == []
    assert [c[1] for c in calls["load"]] == [{"fps": None}, {"fps": None}]
    assert "pass 2 cost" in capsys.readouterr().out


def test_cli_options_reach_the_config_and_the_result(files, monkeypatch, capsys):
    """Every option arrives where it acts: the SpliceConfig / splice_motions
    arguments (spied), the loader's frame rates, and the evidence in the result
    (no pass 2 without refinement, both arms, the output's frame time)."""
    from mocomp.io import read_bvh

    d, pair = files
    calls = _spy(monkeypatch)
    rc = main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "out2.bvh"), "--side", "both",
               "--layer", "forearm", "--theta", "trunk", "--metric", "values", "--no-refine", "--phase-width", "25%",
               "--refine-width", "0.05", "--frame-map", "median", "--strict-points",
               "--body-fps", "60", "--hand-fps", "60", "--plot", str(d / "b.png")])
    assert rc == 0
    (points, kw), = calls["splice"]
    cfg = kw["config"]
    assert (cfg.theta, cfg.metric, cfg.refine, cfg.frame_map, cfg.strict_points) == ("trunk", "values", False, "median", True)
    assert cfg.phase_width == pytest.approx(0.25) and cfg.refine_width == pytest.approx(0.05)
    assert kw["side"] == "both" and kw["layer"] == "forearm"
    assert [c[1] for c in calls["load"]] == [{"fps": 60.0}, {"fps": 60.0}]
    out = capsys.readouterr().out
    assert "left arm" in out and "right arm" in out and "pass 2 cost" not in out
    assert f"body {pair.body.n_frames} frames at 60 fps, hand {pair.hand.n_frames} frames at 60 fps" in out
    assert read_bvh(d / "out2.bvh").fps == pytest.approx(60.0)
    assert "LowerArm_L" in out and "UpperArm_R" not in out.split("wrote")[-2]  # forearm layer: no upper arm


def test_cli_plot_both_arms_in_the_named_file(files, capsys):
    import matplotlib.image

    d, _ = files
    for side, png in (("right", "one.png"), ("both", "two.png")):
        assert main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "o.bvh"), "--side", side,
                     "--plot", str(d / png)]) == 0
    assert not list(d.glob("two_*.png")) and not list(d.glob("one_*.png"))
    h1 = matplotlib.image.imread(d / "one.png").shape[0]
    h2 = matplotlib.image.imread(d / "two.png").shape[0]
    assert h2 == pytest.approx(2 * h1, rel=0.02)  # one row of panels per arm
    assert f"wrote {d / 'two.png'} (right, left arms)" in capsys.readouterr().out


def test_cli_help_text(capsys):
    with pytest.raises(SystemExit) as e:
        main(["splice", "--help"])
    assert e.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "band of 30% of BODY's length" in text and "10% band" in text and "%%" not in text
    assert "reshapes the band" in text and "--strict-points" in text


def test_cli_strict_points(files, capsys):
    """A point far off the diagonal reshapes the band by default (and is
    honoured); with --strict-points it is an error naming the point and the band."""
    d, pair = files
    n, m = pair.body.n_frames, pair.hand.n_frames
    x = n // 4
    rho = 0.3 * n * np.hypot(n - 1, m - 1) / (n - 1)  # eq. 6.3, W = 30 % of n
    y = int(round(x * (m - 1) / (n - 1) + rho)) + 10  # 10 frames above the band
    args = ["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "s.bvh"), "--match", f"{x}:{y}"]
    assert main(args) == 0
    assert "residuals [0.0]" in capsys.readouterr().out
    assert main(args + ["--strict-points"]) == 2
    err = capsys.readouterr().err
    assert f"matching point 1 ({x}:{y}) is outside the band" in err and f"body frame {x} allows hand frames" in err


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


def test_splice_ends_with_the_audit_verdict(files, capsys):
    """Issue #13 section 2: the spliced body is audited against BODY; --no-audit skips it."""
    d, pair = files
    assert main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "oa.bvh")]) == 0
    cap = capsys.readouterr()
    last = cap.out.strip().splitlines()[-1]
    assert last.startswith("audit: ") and "input: " in last
    assert ("warning: the output" in cap.err) == ("new or worse: " in last)
    assert main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "ob.bvh"), "--no-audit"]) == 0
    assert not capsys.readouterr().out.strip().splitlines()[-1].startswith("audit:")


def test_cli_band_width_kind_and_report(files, capsys):
    import json

    d, pair = files
    rc = main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "bw.bvh"), "--band-width-kind", "full",
               "--report", str(d / "bw.json")])
    assert rc == 0
    out = capsys.readouterr().out
    assert "full-width reading" in out
    r = json.loads((d / "bw.json").read_text())
    arm = r["arms"]["right"]
    assert arm["band_width_kind"] == "full" and arm["pass1"]["band_fill"] < 0.6
    assert len(arm["hand_frame"]) == pair.body.n_frames and "quality" in arm
    assert r["audit"] is not None and "measured" in r["provenance"]
    rc = main(["splice", str(d / "body.bvh"), str(d / "hand.bvh"), "-o", str(d / "bw2.bvh"), "--report", str(d / "bw2.json"),
               "--no-audit"])
    assert json.loads((d / "bw2.json").read_text())["arms"]["right"]["pass1"]["band_fill"] > 0.6


def test_cli_help_documents_the_new_options(capsys):
    with pytest.raises(SystemExit):
        main(["splice", "--help"])
    h = " ".join(capsys.readouterr().out.split())
    for opt in ("--subsequence", "--map FILE.toml", "--band-width-kind {half,full}", "--report", "half-width W of eq. 6.3"):
        assert opt in h
