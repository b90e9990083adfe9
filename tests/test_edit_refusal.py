"""``mocomp edit`` refuses an edit whose corrections turn the landing off any standing pose (issue 13:
"a join or edit that cannot do so says so"): the synthetic side flip with straight legs lands 107 deg
off the vertical and easing it upright moved the COM at 12.4 m/s between frames."""
from __future__ import annotations

import json

from mocomp.audit import audit
from mocomp.cli import main
from mocomp.datasets import load_example
from mocomp.io.bvh import read_bvh


def test_edit_that_lands_on_its_side_is_refused_with_the_audits_findings(tmp_path, capsys):
    out = tmp_path / "e.bvh"
    assert main(["edit", "sideflip", "--preset", "straight-legs", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mocomp edit: error: the straight-legs edit turns the landing")
    assert "deg off the vertical" in err[0] and "com_velocity_jump" in err[0] and "--force" in err[0]
    assert not out.exists() and not list(tmp_path.glob(".*.bvh"))          # nothing left behind
    # --force writes it, and the audit of the written frames shows why it was refused
    rep = tmp_path / "r.json"
    assert main(["edit", "sideflip", "--preset", "straight-legs", "-o", str(out), "--force", "--report", str(rep)]) == 0
    d = json.loads(rep.read_text())
    assert d["audit"]["comparison"]["rows"] and d["audit"]["verdict"] == "fail"
    r = audit(read_bvh(out, scale=1.0), against=load_example("sideflip").motion)
    assert r.measure("max_com_jump_mps") > 2.0 and r.against.measure("max_com_jump_mps") < 0.5


def test_an_edit_that_lands_upright_is_not_refused(tmp_path):
    assert main(["edit", "sideflip", "--preset", "arms-twist", "-o", str(tmp_path / "e.bvh")]) == 0
