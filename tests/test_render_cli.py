"""``mocomp render`` and every writing command's ``--render FILE`` (issue #13 section 4)."""
from __future__ import annotations

import argparse

import numpy as np
import pytest

from mocomp.cli import build_parser, main

TINY = ["--size", "96x72"]


def _leaf(name: str) -> argparse.ArgumentParser:
    """The parser of command ``name`` (a module name: ``impact_index`` is ``mocomp impact-index``)."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name.replace("_", "-")]


def _one_error_line(capsys, command: str) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"mocomp {command}: error: "), err
    return err[0]


# ------------------------------------------------------------------ mocomp render
@pytest.mark.parametrize("camera", ["side", "front", "top", "follow"])
def test_render_each_camera(tmp_path, capsys, camera):
    from PIL import Image

    out = tmp_path / f"{camera}.gif"
    assert main(["render", "backflip", "-o", str(out), "--frames", "150:170", "--camera", camera, *TINY]) == 0
    text = capsys.readouterr().out
    assert f"camera {camera}" in text and "audit of backflip: PASS" in text
    with Image.open(out) as im:
        assert im.n_frames == 4 and im.size == (96, 72 + 56)


def test_render_cameras_differ(tmp_path):
    from PIL import Image

    imgs = {}
    for cam in ("side", "top"):
        out = tmp_path / f"{cam}.gif"
        assert main(["render", "backflip", "-o", str(out), "--frames", "150:152", "--camera", cam, *TINY]) == 0
        with Image.open(out) as im:
            imgs[cam] = np.asarray(im.convert("RGB"), float)[:72]
    assert np.abs(imgs["side"] - imgs["top"]).mean() > 10


def test_render_against_side_by_side_mp4(tmp_path, capsys):
    import imageio.v3 as iio

    out = tmp_path / "pair.mp4"
    assert main(["render", "backflip", "--against", "frontflip", "-o", str(out), "--frames", "0:20", *TINY]) == 0
    text = capsys.readouterr().out
    assert "audit of backflip" in text and "audit of frontflip" in text and "10 frames at 60 fps" in text
    assert iio.imread(out, index=0).shape == (72 + 56, 2 * 96, 3)


def test_render_filmstrip_png(tmp_path, capsys):
    import imageio.v3 as iio

    out = tmp_path / "strip.png"
    assert main(["render", "backflip", "-o", str(out), "--size", "160x120"]) == 0
    text = capsys.readouterr().out
    assert "take-off 1 (f " in text and "apex 1 (f " in text and "landing 1 (f " in text
    assert iio.imread(out).shape[1] % 60 == 0


@pytest.mark.parametrize("argv,word", [
    (["-o", "{tmp}/x.avi"], "unknown output type '.avi'"),
    (["-o", "{tmp}/x"], "unknown output type '(no extension)'"),
    (["-o", "{tmp}/missing/x.png"], "does not exist"),
    (["-o", "{tmp}/x.png", "--frames", "100:400"], "backflip has 323 frames (0-322), so the stop frame can be at most 323"),
    (["-o", "{tmp}/x.png", "--frames", "9:10"], "at least 2 frames"),
    (["-o", "{tmp}/x.png", "--frames", "a:9"], "'a' is not a frame number"),
    (["-o", "{tmp}/x.png", "--camera", "orbit"], "invalid choice: 'orbit'"),
    (["-o", "{tmp}/x.png", "--size", "641x480"], "even numbers"),
])
def test_render_bad_arguments_one_line(tmp_path, capsys, argv, word):
    argv = [a.format(tmp=tmp_path) for a in argv]
    try:
        rc = main(["render", "backflip", *argv])
    except SystemExit as e:
        rc = e.code
    assert rc == 2
    line = _one_error_line(capsys, "render")
    assert word in line, line
    assert not list(tmp_path.glob("x*"))


def test_render_bad_motion_names_the_file(tmp_path, capsys):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n}\n")
    assert main(["render", str(bad), "-o", str(tmp_path / "x.png")]) == 2
    assert "bad.bvh" in _one_error_line(capsys, "render")


# ------------------------------------------------------------------ --render on every writing command
WRITERS = ("flips", "edit", "join", "twist", "splice", "demo")


def test_every_audited_command_has_render():
    """--render comes with add_audit_arg: every command with --no-audit has it, with the same checks."""
    from mocomp.cli import COMMAND_MODULES

    audited = []
    for name in COMMAND_MODULES:
        if name in ("study",):
            continue
        opts = {o for a in _leaf(name)._actions for o in a.option_strings}
        if "--no-audit" in opts:
            audited.append(name)
            assert "--render" in opts, name
    assert set(WRITERS) <= set(audited)


@pytest.mark.parametrize("command", WRITERS)
def test_render_option_refuses_an_unknown_type_before_the_command_runs(tmp_path, capsys, command):
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args([command, "--render", str(tmp_path / "r.avi")])
    assert e.value.code == 2
    assert "unknown output type '.avi'" in _one_error_line(capsys, command)


@pytest.fixture(scope="module")
def splice_files(tmp_path_factory):
    from mocomp.io import write_bvh
    from mocomp.splice.synthetic import synthetic_pair

    d = tmp_path_factory.mktemp("splice")
    pair = synthetic_pair(3)
    write_bvh(pair.body, d / "body.bvh")
    write_bvh(pair.hand, d / "hand.bvh")
    return d


def _argv(command, tmp_path, splice_files):
    out = str(tmp_path / "o.bvh")
    # join refuses a physically invalid join unless forced (issue #13 section 3), where that is built
    force = ["--force"] if "--force" in {o for a in _leaf("join")._actions for o in a.option_strings} else []
    return {"flips": ["flips", "backflip", "--flips", "2", "-o", out],
            "edit": ["edit", "backflip", "--preset", "arms-twist", "-o", out],
            "join": ["join", "backflip", "sideflip", "-o", out, *force],
            "twist": ["twist", "twist180", "--degrees", "240", "-o", out],
            "splice": ["splice", str(splice_files / "body.bvh"), str(splice_files / "hand.bvh"), "-o", out],
            "demo": ["demo", "-o", str(tmp_path / "demo")]}[command]


@pytest.mark.parametrize("command", WRITERS)
def test_render_option_draws_the_output_beside_its_input(tmp_path, capsys, splice_files, command):
    import imageio.v3 as iio

    target = tmp_path / "r.png"
    assert main(_argv(command, tmp_path, splice_files) + ["--render", str(target)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith("audit: ")                          # the verdict stays the last line
    assert lines[-2].startswith(f"wrote {target} (filmstrip") and " | " in lines[-2]   # two rows: output | input
    img = iio.imread(target)
    assert img.shape[0] > 2 * 300 and img.dtype == np.uint8


@pytest.mark.parametrize("command", ["edit", "demo"])
def test_render_option_without_audit_draws_the_output_alone(tmp_path, capsys, splice_files, command):
    from PIL import Image

    target = tmp_path / "r.gif"
    assert main(_argv(command, tmp_path, splice_files) + ["--no-audit", "--render", str(target)]) == 0
    out = capsys.readouterr().out
    assert f"wrote {target} (gif, 640x536" in out and not any(ln.startswith("audit:") for ln in out.splitlines())
    with Image.open(target) as im:
        assert im.size == (640, 536) and im.n_frames > 10
