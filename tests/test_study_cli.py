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
            ("missing", "\n".join(",".join(x.split(",")[:9] + x.split(",")[10:]) for x in src.read_text().splitlines()),
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


def test_package_docstring_lists_every_module():
    from pathlib import Path

    import study

    mods = sorted(p.stem for p in Path(study.__file__).parent.glob("*.py") if p.stem != "__init__")
    missing = [m for m in mods if f":mod:`study.{m}`" not in study.__doc__]
    assert not missing, missing
