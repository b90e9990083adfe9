"""Every registered ``mocomp`` command (and sub-command): ``--help`` works, and bad input
prints exactly one line naming the problem and exits with status 2 (issue 2, section 5).

The commands are discovered from the parser, so a command added to
``COMMAND_MODULES`` is covered without editing this file: each positional
argument gets a corrupt BVH file (or, for an output, a path in ``tmp_path``) and
each required option a plausible value; commands without a file argument get an
explicit bad value in ``NO_FILE_CASES``.
"""
from __future__ import annotations

import argparse

import pytest

from mocomp.cli import COMMAND_MODULES, build_parser, main

BAD_BVH = ("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n}\n"
           "MOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0\n0 zero 0\n")

#: commands that take no input file: argv (after the command) with a bad value
NO_FILE_CASES = {"demo": ["--flips", "0", "-o", "{tmp}/demo"],
                 "batch": ["audit", "{tmp}/no-such-folder", "-o", "{tmp}/out_batch"],  # a bad clip is a row
                 "impact": ["--attacker", "{tmp}/bad.bvh", "--victim", "{tmp}/bad.bvh", "-o", "{tmp}/impact"],
                 "reproduce": ["--check-baseline", "{tmp}/bad.bvh", "-o", "{tmp}/out_report"],
                 # (keyed by the whole command path where one sub-command takes no file)
                 "study withdraw": ["--participant", "P1", "--session", "S1", "--data", "{tmp}/no-such-data"]}


def _sub_actions(parser: argparse.ArgumentParser):
    return [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]


def _leaves(parser, prefix=()):
    """(command path, leaf parser) for every runnable (sub-)command."""
    subs = _sub_actions(parser)
    if not subs:
        yield prefix, parser
        return
    for action in subs:
        for name, p in action.choices.items():
            yield from _leaves(p, prefix + (name,))


LEAVES = dict(_leaves(build_parser()))


def test_every_command_module_is_registered_and_discovered():
    tops = {path[0] for path in LEAVES}
    assert tops == {m.replace("_", "-") for m in COMMAND_MODULES}   # module impact_index: command impact-index
    assert {"info", "convert", "plot", "demo"} <= tops


@pytest.mark.parametrize("path", sorted(LEAVES), ids=" ".join)
def test_help(path, capsys):
    with pytest.raises(SystemExit) as e:
        main([*path, "--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: mocomp {' '.join(path)}")
    # the help describes the command, not just its usage line
    assert len(out.splitlines()) > 4


def _suffix(action) -> str:
    """File suffix an output option asks for (from its metavar or help), '' for a folder."""
    text = f"{action.metavar or ''} {action.help or ''}".lower()
    for suffix in (".bvh", ".png", ".json"):
        if suffix in text:
            return suffix
    return ""


def _bad_argv(path, parser, tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text(BAD_BVH)
    for key in (" ".join(path), path[0]):
        if key in NO_FILE_CASES:
            return [*path, *(a.format(tmp=tmp_path) for a in NO_FILE_CASES[key])], None
    argv, used_file = list(path), False
    for a in parser._actions:
        if isinstance(a, (argparse._HelpAction, argparse._VersionAction)):
            continue
        is_out = any(s in (a.dest or "").lower() for s in ("out", "output")) or a.metavar in ("OUT", "OUT.bvh")
        if not a.option_strings:  # positional
            n = a.nargs if isinstance(a.nargs, int) else 1
            if is_out:
                argv += [str(tmp_path / "out.bvh")] * n
            else:
                argv += [str(bad)] * n
                used_file = True
        elif a.required:
            if a.choices:
                value = [str(next(iter(a.choices)))]
            elif is_out:
                value = [str(tmp_path / ("out" + _suffix(a)))]
            elif "manifest" in a.dest or "spec" in a.dest:
                value, used_file = [str(bad)], True
            elif "data" in a.dest:
                value = [str(tmp_path / "data")]
            else:
                value = ["1"]
            argv += [a.option_strings[-1], *value]
    assert used_file, f"mocomp {' '.join(path)} takes no file: add a bad-input case to NO_FILE_CASES"
    return argv, bad


@pytest.mark.parametrize("path", sorted(LEAVES), ids=" ".join)
def test_bad_input_prints_one_line_and_exits_2(path, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("MOCOMP_DATA_DIR", raising=False)
    argv, bad = _bad_argv(path, LEAVES[path], tmp_path)
    assert main(argv) == 2, argv
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    assert lines[0].startswith(f"mocomp {path[0]}") and ": error: " in lines[0], lines[0]
    if bad is not None:
        assert bad.name in lines[0], lines[0]          # names the file
    # nothing was written for a failed command
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith("out")]


@pytest.mark.parametrize("path", sorted(LEAVES), ids=" ".join)
def test_argument_errors_print_one_line_and_exit_2(path, capsys):
    """An argparse error (a missing required argument or an unknown option) is one line
    ``mocomp CMD: error: ... (see mocomp CMD --help)``, not the usage block, for every (sub-)command."""
    prog = "mocomp " + " ".join(path)
    for extra in (["--no-such-option-xyz"], []):
        argv = [*path, *extra]
        required = [a for a in LEAVES[path]._actions if a.required or not a.option_strings]
        if not extra and not required:
            continue  # nothing can be missing
        with pytest.raises(SystemExit) as e:
            main(argv)
        assert e.value.code == 2, argv
        cap = capsys.readouterr()
        lines = cap.err.splitlines()
        assert cap.out == "" and len(lines) == 1, (argv, cap.err)
        assert lines[0].startswith(f"{prog}: error: "), lines[0]
        assert lines[0].endswith(f" (see {prog} --help)"), lines[0]
        if not required:
            assert "unrecognized arguments: --no-such-option-xyz" in lines[0], lines[0]


@pytest.mark.parametrize("path", sorted(LEAVES), ids=" ".join)
def test_every_parser_reports_errors_in_one_line(path):
    """Each (sub-)command's parser is the one-line-error class, so argument errors found by the
    command itself (``parser.error`` from a type check) are one line too."""
    from mocomp.cli import Parser

    assert isinstance(LEAVES[path], Parser)


# ------------------------------------------------------------------ numeric option values
def _numeric_options(parser):
    """Options whose type function turns "2" into a number: the float and int options (and unit/
    number mixes such as --scale). Discovered from the parser, so a new option is covered."""
    out = []
    for a in parser._actions:
        if not a.option_strings or a.type is None or a.choices:
            continue
        try:
            v = a.type("2")
        except Exception:  # noqa: BLE001 - not a numeric option (paths, B:H matching points, ...)
            continue
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out.append(a)
    return out


def _complete_argv(path, parser, tmp_path):
    """argv that parses: every positional and required option given a plausible value."""
    argv = list(path)
    for a in parser._actions:
        if isinstance(a, (argparse._HelpAction, argparse._VersionAction)):
            continue
        n = a.nargs if isinstance(a.nargs, int) else 1
        if not a.option_strings:
            argv += [str(next(iter(a.choices))) if a.choices else str(tmp_path / "in.bvh")] * n
        elif a.required:
            value = str(next(iter(a.choices))) if a.choices else ("1" if a.type is not None else
                                                                  str(tmp_path / "out.bvh"))
            argv += [a.option_strings[-1], *[value] * n]
    return argv


NUMERIC = [(path, a.option_strings[-1]) for path in sorted(LEAVES) for a in _numeric_options(LEAVES[path])]

#: options of the study sub-commands (study/study_cli.py, study/render_cli.py, edited by others:
#: issue #12) that still accept nan/inf; strict, so fixing one makes its entry fail here until removed
STUDY_ACCEPTS_NONFINITE: set = set()   # none left: every numeric option of every command refuses nan/inf


def test_numeric_options_are_discovered():
    found = {(p[0], o) for p, o in NUMERIC}
    assert {("flips", "--height-change"), ("flips", "--k"), ("edit", "--k"), ("edit", "--fps"),
            ("convert", "--scale"), ("twist", "--degrees"), ("join", "--max-tilt"), ("splice", "--phase-width"),
            ("plot", "--dpi")} <= found


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN", "-Infinity"])
@pytest.mark.parametrize("path,option", NUMERIC, ids=[" ".join(p) + " " + o for p, o in NUMERIC])
def test_numeric_options_reject_nonfinite_values_at_parse_time(path, option, value, tmp_path, capsys, request):
    """nan/inf never reach a command: argparse stops with exit 2 and one line naming the option
    (the value given as --opt=VALUE, so -inf is not taken for an option)."""
    if (" ".join(path), option) in STUDY_ACCEPTS_NONFINITE:
        request.applymarker(pytest.mark.xfail(strict=True, reason="study CLI accepts non-finite values"))
    parser = build_parser()
    action = next(a for a in LEAVES[path]._actions if option in a.option_strings)
    n = action.nargs if isinstance(action.nargs, int) else 1
    base = _complete_argv(path, LEAVES[path], tmp_path)
    good = base + ([f"{option}=2"] if n == 1 else [option, *["2"] * n])
    parser.parse_args(good)                                 # the argv is otherwise complete
    capsys.readouterr()
    bad = base + ([f"{option}={value}"] if n == 1 else [option, *[value] * n])
    with pytest.raises(SystemExit) as e:
        parser.parse_args(bad)
    assert e.value.code == 2
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert cap.out == "" and len(lines) == 1, cap.err
    assert lines[0].startswith(f"mocomp {' '.join(path)}: error: argument ") and option in lines[0], lines[0]


@pytest.mark.parametrize("argv, message", [
    (["edit", "backflip", "--preset", "arms-twist", "-o", "x.bvh", "--k-ratio=-1"], "--k-ratio: must be a positive"),
    (["edit", "backflip", "--preset", "arms-twist", "-o", "x.bvh", "--fps", "0"], "--fps: frame rate must be positive"),
    (["flips", "backflip", "-o", "x.bvh", "--fps=-120"], "--fps: frame rate must be positive"),
    (["flips", "backflip", "-o", "x.bvh", "--total-mass", "0"], "--total-mass: must be a positive"),
    (["twist", "twist180", "--degrees", "200", "-o", "x.bvh", "--max-k", "1"], "--max-k: must be a number above 1"),
    (["join", "backflip", "sideflip", "-o", "x.bvh", "--max-tilt", "181"], "--max-tilt: must be a number at least 0 "
                                                                          "and at most 180"),
    (["convert", "backflip", "x.bvh", "--scale=-1"], "--scale: scale must be a positive number"),
    (["splice", "a", "b", "-o", "x.bvh", "--phase-width", "0"], "--phase-width: band width must be a positive"),
    (["study", "analyze", "r.csv", "-o", "out", "--min-attention", "1.5"], "--min-attention: must be a pass rate at "
                                                                         "least 0 and at most 1"),
    (["study", "run", "--participant", "P01", "--session", "S1", "--manifest", "m.json", "--data", "d",
      "--lock-timeout=-1"], "--lock-timeout: must be a number of "
                                                                             "seconds at least 0"),
])
def test_out_of_range_option_values_are_refused_at_parse_time(argv, message, capsys):
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert message in err and err.count("\n") == 0, err
