"""The ``mocomp`` command line: info, convert, plot (in-process via main() and as a subprocess)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from mocomp import datasets
from mocomp.cli import main
from mocomp.core import EndSite, Motion, Skeleton
from mocomp.datasets.examples import EXAMPLES, Example
from mocomp.io import UnitWarning, read_bvh, write_bvh
from mocomp.io.summary import joint_speeds, summarize
from mocomp.plots.motion import main_direction, motion_overview

COMMANDS = ("info", "convert", "plot")


def walker(T: int = 121, fps: float = 120.0) -> Motion:
    """A rigid 1.7 m figure (identity rotations) gliding 2 m along +x in 1 s at hip height 1.0 m."""
    names = ("Hips", "Spine", "Head", "LeftUpLeg", "LeftFoot", "RightUpLeg", "RightFoot")
    off = [[0, 0, 0], [0, 0.3, 0], [0, 0.3, 0], [0.1, -0.05, 0], [0, -0.85, 0], [-0.1, -0.05, 0], [0, -0.85, 0]]
    sk = Skeleton(names, [-1, 0, 1, 0, 3, 0, 5], off, end_sites=(EndSite(2, [0, 0.2, 0], "Head_end"),))
    t = np.arange(T) / fps
    root = np.column_stack([2.0 * t, np.full(T, 1.0), np.zeros(T)])
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (T, len(names), 1))
    return Motion(sk, fps, root, rot)


@pytest.fixture
def walker_bvh(tmp_path) -> Path:
    return write_bvh(walker(), tmp_path / "walker.bvh")


def run_cli(*argv, env_data=None):
    """Run ``python -m mocomp`` in a subprocess; returns (code, stdout, stderr)."""
    env = dict(os.environ)
    env.pop("MOCOMP_DATA_DIR", None)
    if env_data:
        env["MOCOMP_DATA_DIR"] = str(env_data)
    p = subprocess.run([sys.executable, "-m", "mocomp", *map(str, argv)], capture_output=True, text=True, env=env,
                       timeout=120)
    return p.returncode, p.stdout, p.stderr


# ------------------------------------------------------------------ help
@pytest.mark.parametrize("cmd", COMMANDS)
def test_help_in_process(cmd, capsys):
    with pytest.raises(SystemExit) as e:
        main([cmd, "--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert f"usage: mocomp {cmd}" in out and "FILE_OR_NAME" in out and "--scale" in out and "--fps" in out


def test_help_subprocess():
    code, out, _ = run_cli("--help")
    assert code == 0 and all(c in out for c in COMMANDS)
    code, out, _ = run_cli("plot", "--help")
    assert code == 0 and "--output" in out and "heat map" in out


# ------------------------------------------------------------------ info
def test_info_known_answers(walker_bvh, capsys):
    assert main(["info", str(walker_bvh), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["n_joints"] == 7 and d["root"] == "Hips" and d["n_frames"] == 121
    assert d["fps"] == 120.0 and d["header_fps"] == pytest.approx(120.0)
    assert d["duration"] == pytest.approx(1.0)
    assert d["unit_scale"] == 1.0 and "m" in d["unit_reason"]
    assert d["standing_height"] == pytest.approx(1.7, abs=1e-6)  # feet at 0.1 m, head end at 1.8 m
    assert d["rest_height"] == pytest.approx(1.7, abs=1e-6)
    assert d["root_path_length"] == pytest.approx(2.0, abs=1e-6)
    assert d["root_displacement"] == pytest.approx(2.0, abs=1e-6)
    assert d["root_height_range"] == pytest.approx([1.0, 1.0], abs=1e-6)
    assert d["peak_joint_speed"] == pytest.approx(2.0, abs=1e-5)  # every joint glides at 2 m/s
    assert main(["info", str(walker_bvh)]) == 0
    text = capsys.readouterr().out
    for key in ("joints", "frames", "fps", "duration", "unit scale", "height", "root travel"):
        assert key in text
    assert "2.000 m along the ground" in text and "1.700 m standing" in text and "(as the header)" in text


def test_info_overrides(walker_bvh, capsys):
    with pytest.warns(UnitWarning, match="standing height 0.017 m"):  # the implausible unit is flagged
        assert main(["info", str(walker_bvh), "--json", "--fps", "60", "--scale", "cm"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["fps"] == 60.0 and d["header_fps"] == pytest.approx(120.0) and d["duration"] == pytest.approx(2.0)
    assert d["unit_scale"] == 0.01 and d["standing_height"] == pytest.approx(0.017, abs=1e-8)
    assert d["peak_joint_speed"] == pytest.approx(0.01, abs=1e-7)  # 2 cm in 2 s
    assert main(["info", str(walker_bvh), "--fps", "60"]) == 0
    assert "(header says 120)" in capsys.readouterr().out


def test_info_on_example_name(monkeypatch, capsys):
    monkeypatch.setitem(EXAMPLES, "cli_test_walker", Example(
        "cli_test_walker", "glides", lambda: types.SimpleNamespace(motion=walker(), truth=None)))
    datasets._make_example.cache_clear()
    try:
        assert main(["info", "cli_test_walker", "--json"]) == 0
        d = json.loads(capsys.readouterr().out)
        assert d["n_frames"] == 121 and d["source"] == "cli_test_walker"
        assert main(["info", "cli_test_walker", "--fps", "30"]) == 2
        assert "generated example" in capsys.readouterr().err
    finally:
        datasets._make_example.cache_clear()


def test_info_fps_wording_per_source(monkeypatch, capsys):
    """A generated motion has no header: info says so (not "(as the header)"), in text and JSON."""
    monkeypatch.setitem(EXAMPLES, "cli_test_walker", Example(
        "cli_test_walker", "glides", lambda: types.SimpleNamespace(motion=walker().replace(
            source=datasets.load("backflip").source), truth=None)))
    datasets._make_example.cache_clear()
    try:
        assert main(["info", "cli_test_walker"]) == 0
        text = capsys.readouterr().out
        assert "fps          120 (generated at this rate)" in text and "header" not in text
        assert main(["info", "cli_test_walker", "--json"]) == 0
        d = json.loads(capsys.readouterr().out)
        assert d["header_fps"] is None and d["fps_basis"] == "generated at this rate"
    finally:
        datasets._make_example.cache_clear()


@pytest.mark.parametrize("fmt, fps, header, words", [
    ("bvh", 120.0, 120.0, "as the header"),
    ("bvh", 60.0, 120.0, "header says 120"),
    ("synthetic", 120.0, 120.0, "generated at this rate"),
    ("synthetic", 120.0, None, "generated at this rate"),
    ("synthetic", 60.0, 120.0, "generated at 120 fps"),
    ("deepmimic", 16.0, 16.0, "from the key-frame times"),
    ("deepmimic", 30.0, 16.0, "key frames at 16 fps"),
    ("deepmimic", 30.0, None, "single key frame: no timing in the file"),
    ("asf/amc", 120.0, None, "the file states none"),
    ("unknown", 50.0, None, ""),
])
def test_fps_basis_words(fmt, fps, header, words):
    from mocomp.io.summary import fps_basis

    assert fps_basis(fmt, fps, header) == words


@pytest.mark.parametrize("name, line", [
    ("deepmimic_backflip", "fps          16 (from the key-frame times)"),
    ("01_01.amc", "fps          120 (the file states none)"),
    ("88_01", "fps          60 (header says 120)"),
])
def test_info_fps_wording_real(name, line, real_data_dir, capsys):
    assert main(["info", name]) == 0
    assert line in capsys.readouterr().out.splitlines()


def test_summary_matches_library(walker_bvh):
    m = read_bvh(walker_bvh)
    s = summarize(m)
    np.testing.assert_allclose(joint_speeds(m), 2.0, atol=1e-6)
    assert s.to_dict()["joint_names"][0] == "Hips"
    one = summarize(m[:1])
    assert one.peak_joint_speed == 0.0 and one.root_path_length == 0.0


# ------------------------------------------------------------------ convert
def test_convert_scale_fps_and_round_trip(walker_bvh, tmp_path, capsys):
    out = tmp_path / "out_cm.bvh"
    assert main(["convert", str(walker_bvh), str(out), "--out-scale", "cm", "--fps", "60"]) == 0
    assert "wrote" in capsys.readouterr().out
    text = out.read_text()
    assert "Frame Time: 0.016666666666666666\n" in text  # exact: reads back as 60.0
    assert "OFFSET 0.00000000000 30.00000000000 0.00000000000" in text  # Spine 0.3 m written in cm
    back = read_bvh(out, scale="cm")
    assert back.fps == 60.0
    np.testing.assert_allclose(back.positions, walker().positions, atol=1e-6)
    out2 = tmp_path / "out_num.bvh"
    assert main(["convert", str(walker_bvh), str(out2), "--out-scale", "0.0254", "--precision", "10"]) == 0
    np.testing.assert_allclose(read_bvh(out2, scale="inch").positions, walker().positions, atol=1e-8)


def test_convert_input_scale(walker_bvh, tmp_path):
    """--scale reinterprets the input's unit: a metres file read as cm shrinks 100 times."""
    out = tmp_path / "small.bvh"
    with pytest.warns(UnitWarning):
        assert main(["convert", str(walker_bvh), str(out), "--scale", "cm"]) == 0
    back = read_bvh(out, scale="m", height_check=False)
    np.testing.assert_allclose(back.positions, walker().positions * 0.01, atol=1e-8)


def test_convert_errors(walker_bvh, tmp_path, capsys):
    assert main(["convert", str(walker_bvh), str(tmp_path / "x.txt")]) == 2
    assert "must be a .bvh file" in capsys.readouterr().err
    assert main(["convert", str(walker_bvh), str(tmp_path / "no" / "dir" / "x.bvh")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["convert", str(walker_bvh), str(tmp_path / "x.bvh"), "--out-scale", "auto"]) == 2
    with pytest.raises(SystemExit) as e:
        main(["convert", str(walker_bvh), str(tmp_path / "x.bvh"), "--out-scale", "-3"])
    assert e.value.code == 2


def test_convert_real_clip_applies_corrections(real_data_dir, tmp_path, capsys):
    out = tmp_path / "bf.bvh"
    assert main(["convert", "88_01", str(out)]) == 0
    back = read_bvh(out, scale="m")
    ref = datasets.load("88_01")
    assert back.fps == pytest.approx(60.0) and back.n_frames == 202
    np.testing.assert_allclose(back.positions, ref.positions, atol=1e-6)


@pytest.mark.parametrize("name", ["01_01.amc", "deepmimic_backflip"])
def test_convert_other_formats_to_bvh(name, real_data_dir, tmp_path, capsys):
    out = tmp_path / "c.bvh"
    assert main(["convert", name, str(out), "--out-scale", "cm"]) == 0
    ref = datasets.load(name)
    back = read_bvh(out, scale="cm")
    assert back.n_frames == ref.n_frames and back.fps == pytest.approx(ref.fps)
    # BVH lists joints depth-first, so DeepMimic's order changes: compare by name
    idx = [back.skeleton.index(n) for n in ref.skeleton.names]
    np.testing.assert_allclose(back.positions[:, idx], ref.positions, atol=1e-6)


# ------------------------------------------------------------------ plot
def test_plot_writes_png(walker_bvh, tmp_path, capsys):
    out = tmp_path / "p.png"
    assert main(["plot", str(walker_bvh), "-o", str(out), "--dpi", "50"]) == 0
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    assert main(["plot", str(walker_bvh), "-o", str(tmp_path / "p.xyz")]) == 2
    assert "unknown image type" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["plot", str(walker_bvh)])  # -o is required
    assert e.value.code == 2


def test_plot_functions():
    m = walker()
    fig = motion_overview(m, title="w")
    titles = [a.get_title() for a in fig.axes]
    assert "root, top view" in titles and "root, side view" in titles
    assert any(t.startswith("joint speed (peak 2.00 m/s") for t in titles)
    # the side view runs along the travel direction: +x here
    np.testing.assert_allclose(main_direction(m.root_positions[:, [0, 2]]), [1.0, 0.0], atol=1e-12)
    back = m.root_positions[::-1, [0, 2]]
    np.testing.assert_allclose(main_direction(back), [-1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(main_direction(np.zeros((5, 2))), [1.0, 0.0])
    motion_overview(m[:1])  # one frame: no crash, zero speeds


# ------------------------------------------------------------------ bad input
def test_bad_input_one_line_exit_2_subprocess(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n}\n"
                   "MOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0\n0 zero 0\n")
    code, out, err = run_cli("info", bad)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mocomp info: error:") and "bad.bvh" in lines[0]
    code, out, err = run_cli("info", tmp_path / "missing.bvh")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "no such file" in err
    code, _, err = run_cli("plot", "no_such_clip_name", "-o", tmp_path / "x.png")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "MOCOMP_DATA_DIR" in err


def test_bad_input_exit_2_in_process(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("MOCOMP_DATA_DIR", raising=False)
    empty = tmp_path / "empty.bvh"
    empty.write_text("")
    for argv in (["info", str(empty)], ["info", "nonexistent_clip"], ["convert", str(empty), str(tmp_path / "o.bvh")],
                 ["plot", str(tmp_path / "nope.bvh"), "-o", str(tmp_path / "o.png")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"mocomp {argv[0]}: error:"), err
    cases = {("info",): ("mocomp info", "the following arguments are required: FILE_OR_NAME"),
             ("info", "x", "--fps", "-1"): ("mocomp info", "argument --fps: frame rate must be positive, got -1"),
             ("info", "x", "--scale", "furlong"): ("mocomp info", "argument --scale: 'furlong' is neither a number"),
             ("info", "x", "--bogus"): ("mocomp info", "unrecognized arguments: --bogus"),
             ("nosuchcommand",): ("mocomp", "argument COMMAND: invalid choice: 'nosuchcommand'")}
    for argv, (prog, what) in cases.items():
        with pytest.raises(SystemExit) as e:
            main(list(argv))
        assert e.value.code == 2
        cap = capsys.readouterr()
        lines = cap.err.splitlines()
        assert cap.out == "" and len(lines) == 1, cap.err  # no usage block: one line
        assert lines[0].startswith(f"{prog}: error: {what}"), lines[0]
        assert lines[0].endswith(f"(see {prog} --help)"), lines[0]


def test_argparse_error_one_line_subprocess():
    code, out, err = run_cli("info", "x", "--fps", "-1")
    assert code == 2 and out == ""
    assert err.splitlines() == ["mocomp info: error: argument --fps: frame rate must be positive, got -1 "
                                "(see mocomp info --help)"]


# ------------------------------------------------------------------ unwritable outputs
@pytest.fixture
def bad_outputs(tmp_path):
    """(label, path, text the error must contain) for outputs that cannot be written."""
    (tmp_path / "D.bvh").mkdir()
    (tmp_path / "d.png").mkdir()
    (tmp_path / "afile").write_text("x")
    return tmp_path


@pytest.mark.parametrize("cmd,name,expect", [
    ("convert", "D.bvh", "output {p} is a directory, not a file"),
    ("convert", "afile/x.bvh", "output folder {parent} is a file, not a directory"),
    ("convert", "none/x.bvh", "output folder {parent} does not exist"),
    ("plot", "d.png", "output {p} is a directory, not a file"),
    ("plot", "afile/x.png", "output folder {parent} is a file, not a directory"),
    ("plot", "none/x.png", "output folder {parent} does not exist"),
])
def test_unwritable_output_one_line_exit_2(cmd, name, expect, walker_bvh, bad_outputs, capsys):
    p = bad_outputs / name
    argv = [cmd, str(walker_bvh), str(p)] if cmd == "convert" else [cmd, str(walker_bvh), "-o", str(p)]
    assert main(argv) == 2
    cap = capsys.readouterr()
    assert cap.err.splitlines() == [f"mocomp {cmd}: error: " + expect.format(p=p, parent=p.parent)]
    assert not (bad_outputs / "afile").is_dir() and (bad_outputs / "afile").read_text() == "x"


@pytest.mark.parametrize("cmd,suffix", [("convert", ".bvh"), ("plot", ".png")])
def test_read_only_output_one_line_exit_2(cmd, suffix, walker_bvh, tmp_path, capsys, monkeypatch):
    """A read-only output file (and folder): checked with os.access, so faked here (root may write anything)."""
    import mocomp.cli._common as common

    ro = tmp_path / ("ro" + suffix)
    ro.write_text("keep")
    monkeypatch.setattr(common.os, "access", lambda path, mode: False)
    for out, expect in ((ro, f"output {ro} is read-only"),
                        (tmp_path / ("new" + suffix), f"output folder {tmp_path} is not writable")):
        argv = [cmd, str(walker_bvh), str(out)] if cmd == "convert" else [cmd, str(walker_bvh), "-o", str(out)]
        assert main(argv) == 2
        assert capsys.readouterr().err.splitlines() == [f"mocomp {cmd}: error: {expect}"]
    assert ro.read_text() == "keep"


@pytest.mark.parametrize("exc,expect", [
    (IsADirectoryError(21, "Is a directory", "/x/D.bvh"), "/x/D.bvh: is a directory"),
    (PermissionError(13, "Permission denied", "/x/ro.bvh"), "/x/ro.bvh: permission denied"),
    (NotADirectoryError(20, "Not a directory", "/x/afile/o.png"), "/x/afile/o.png: not a directory"),
    (OSError(28, "No space left on device"), "no space left on device"),
    (FileExistsError(17, "File exists", "/a", None, "/b"), "/a -> /b: file exists"),
    (FileNotFoundError("output folder /q does not exist"), "output folder /q does not exist"),
])
def test_any_os_error_of_a_command_is_one_line_exit_2(exc, expect, monkeypatch, capsys):
    """The generic mechanism: whatever command raises an OSError (e.g. flips writing into a folder),
    main() prints one line naming the path and what is wrong, and exits 2 (no traceback)."""
    import mocomp.cli.info as info

    def boom(args):
        raise exc

    monkeypatch.setattr(info, "run", boom)  # registered by build_parser() inside main()
    assert main(["info", "whatever"]) == 2
    assert capsys.readouterr().err.splitlines() == [f"mocomp info: error: {expect}"]


def test_unwritable_output_of_another_command_is_one_line(tmp_path, capsys):
    """The generic mechanism on a real command that does no output check of its own:
    ``mocomp demo -o FILE`` (a file where the output folder should be)."""
    f = tmp_path / "afile"
    f.write_text("x")
    assert main(["demo", "-o", str(f)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("mocomp demo: error: ") and str(f) in lines[0], lines
    assert f.read_text() == "x"


def test_closed_stdout_is_not_an_error(tmp_path):
    """``mocomp info ... | head -1``: the reader closing the pipe ends the command quietly."""
    src = write_bvh(walker(), tmp_path / "w.bvh")
    env = dict(os.environ)
    env.pop("MOCOMP_DATA_DIR", None)
    p = subprocess.Popen([sys.executable, "-m", "mocomp", "info", str(src), "--json"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env=env)
    p.stdout.close()  # nobody reads: the first write fails with EPIPE
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 1
    assert err == "", err


def test_unwritable_output_subprocess(tmp_path):
    (tmp_path / "D.bvh").mkdir()
    src = write_bvh(walker(), tmp_path / "w.bvh")
    code, out, err = run_cli("convert", src, tmp_path / "D.bvh")
    assert code == 2 and out == "" and "Traceback" not in err
    assert err.splitlines() == [f"mocomp convert: error: output {tmp_path / 'D.bvh'} is a directory, not a file"]


def test_new_violations_matched_by_check_and_place():
    """``new_violations``: an output violation is new when no input has the same check at the same
    place, worse when the input's is smaller by more than a quarter of the threshold."""
    from types import SimpleNamespace as NS

    from mocomp.cli._common import new_violations

    def f(check, where, size, threshold=1.0):
        return NS(check=check, where=where, size=size, threshold=threshold)

    def rep(*fs, against=None):
        return NS(violations=tuple(fs), against=against)

    a = rep(f("com_velocity_jump", "take-off of flight 1", 0.6), f("foot_slide", "foot_r", 0.07, 0.03))
    b = rep(f("com_velocity_jump", "take-off of flight 1", 2.9))
    o1, o2, o3, o4 = (f("com_velocity_jump", "take-off of flight 1", 2.8), f("foot_slide", "foot_r", 0.0705, 0.03),
                      f("foot_slide", "foot_l", 0.05, 0.03), f("com_velocity_jump", "take-off of flight 1", 0.8))
    out = rep(o1, o2, o3, o4, against=a)
    got = new_violations(out)
    assert [x for x, _ in got] == [o1, o3] and got[0][1] is a.violations[0] and got[1][1] is None
    # a further input with a larger take-off jump at the same place: not worse than the worst input
    assert [x for x, _ in new_violations(out, [b])] == [o3]
    assert new_violations(rep(against=a)) == ()
