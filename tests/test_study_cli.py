"""``mocomp study run`` / ``mocomp study analyze`` through the real CLI entry point."""
from __future__ import annotations

import json

import pandas as pd

from mocomp.cli import main
from study.observers import Observer, Psychometric, simulate_cohort
from study.placeholders import make_placeholder_set


def test_study_commands(tmp_path, capsys):
    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20, 40)}, base_clips=("a", "b"),
                                n_frames=4)
    simulate_cohort(stim, Observer({("takeoff", "increase"): Psychometric(25, 2)}), tmp_path / "data", n=4)
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "rep"), "--n-boot", "50",
                 "--correction", "1/(2N)", "--no-figures"]) == 0
    c = pd.read_csv(tmp_path / "rep" / "conditions.csv")
    assert set(c["correction"]) == {"1/(2N)"} and len(c) == 3
    assert "4 participants" in capsys.readouterr().out
    # bad input: one line, exit 2
    assert main(["study", "analyze", str(tmp_path / "nope"), "-o", str(tmp_path / "r2")]) == 2
    assert "not found" in capsys.readouterr().err
    src = next((tmp_path / "data").rglob("responses.csv"))
    for name, text, msg in (
            ("missing", "\n".join(",".join(x.split(",")[:9] + x.split(",")[10:]) for x in src.read_text().splitlines()) + "\n",
             "missing column(s) stimulus_id"),
            ("dup", src.read_text() + src.read_text().splitlines()[3] + "\n", "duplicate trial"),
            ("empty", "", "empty CSV")):
        bad = tmp_path / name / "P" / "S" / "responses.csv"
        bad.parent.mkdir(parents=True)
        bad.write_text(text)
        assert main(["study", "analyze", str(tmp_path / name), "-o", str(tmp_path / "r3")]) == 2
        err = capsys.readouterr().err
        assert msg in err and str(bad) in err and len(err.strip().splitlines()) == 1, err
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d"), "--break-every", "3", "--print-config"]) == 0
    cfg = json.loads(capsys.readouterr().out)
    assert cfg["design"] == {"break_every": 3} and cfg["participant_id"] == "P1"
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d"), "--no-must-watch", "--print-config"]) == 0
    assert json.loads(capsys.readouterr().out)["design"] == {"must_watch": False}
    assert main(["study", "run", "--participant", "../P1", "--session", "S1", "--manifest", str(stim.path),
                 "--data", str(tmp_path / "d"), "--print-config"]) == 2
    assert "not valid" in capsys.readouterr().err
    assert main(["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(tmp_path / "m.csv"),
                 "--data", str(tmp_path / "d"), "--print-config"]) == 2


def test_run_and_analyze_refuse_bad_input_before_starting(tmp_path, capsys, monkeypatch):
    """Errors a participant's browser must never be the first to see: refused by the CLI, exit 2, one line."""
    import importlib.util

    import study.study_cli as sc

    def no_server(*a, **k):
        raise AssertionError("a server was started")

    stim = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20,)}, base_clips=("a",), n_frames=4)
    stim2 = make_placeholder_set(tmp_path / "s2", {("takeoff", "increase"): (20, 40)}, base_clips=("a", "b"),
                                 n_frames=4)
    monkeypatch.setattr(sc.subprocess, "Popen", no_server)
    run = ["study", "run", "--participant", "P1", "--session", "S1", "--manifest", str(stim.path),
           "--data", str(tmp_path / "d")]
    # counterbalance='latin' without the participant number
    design = tmp_path / "design.json"
    design.write_text(json.dumps({"counterbalance": "latin"}))
    assert main(run + ["--design", str(design)]) == 2
    err = capsys.readouterr().err
    assert "counterbalance='latin'" in err and "--counterbalance-index" in err and str(design) in err
    assert main(run + ["--design", str(design), "--counterbalance-index", "3", "--print-config"]) == 0
    assert json.loads(capsys.readouterr().out)["counterbalance_index"] == 3
    # voila not importable
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "voila" else real(name, *a))
    assert main(run) == 2
    err = capsys.readouterr().err
    assert "Voila" in err and "pip install" in err and len(err.strip().splitlines()) == 1
    monkeypatch.setattr(importlib.util, "find_spec", real)
    # a video changed after rendering
    vid = stim.video_path(stim.ids[0])
    vid.write_bytes(vid.read_bytes() + b"x")
    assert main(run + ["--print-config"]) == 2
    err = capsys.readouterr().err
    assert "manifest.csv:2 [sha256]" in err and vid.name in err
    # --level achieved_error on responses without that column names the file and the column
    simulate_cohort(stim2, Observer({("takeoff", "increase"): Psychometric(25, 2)}), tmp_path / "data", n=2)
    src = next((tmp_path / "data").rglob("responses.csv"))
    df = pd.read_csv(src, dtype=str, keep_default_na=False).drop(columns=["achieved_error"])
    df.to_csv(src, index=False)
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "r"), "--level",
                 "achieved_error", "--no-figures", "--n-boot", "20"]) == 2
    err = capsys.readouterr().err
    assert f"{src}:1 [achieved_error]: no column 'achieved_error'" in err and len(err.strip().splitlines()) == 1
    assert main(["study", "analyze", str(tmp_path / "data"), "-o", str(tmp_path / "r"), "--no-figures",
                 "--n-boot", "20"]) == 0  # nominal levels need no achieved_error


def test_package_docstring_lists_every_module():
    from pathlib import Path

    import study

    mods = sorted(p.stem for p in Path(study.__file__).parent.glob("*.py") if p.stem != "__init__")
    missing = [m for m in mods if f":mod:`study.{m}`" not in study.__doc__]
    assert not missing, missing
