"""``mocomp touchup``: the command line contract, its report (planned values + the audit of the
written file) and its errors."""
import json

import numpy as np
import pytest

from _cli import exit_code
from mocomp.cli import main
from mocomp.io import read_bvh, write_bvh
from mocomp.ops.synthetic import synthetic_walk




@pytest.fixture(scope="module")
def walk_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("tu")
    p = d / "walk.bvh"
    write_bvh(synthetic_walk(duration=1.5, fps=60).motion, p)
    return p


def test_cli_writes_motion_report_plot(walk_file, tmp_path, capsys):
    out, rep, png = tmp_path / "o.bvh", tmp_path / "r.json", tmp_path / "z.png"
    rc = main(["touchup", str(walk_file), "-o", str(out), "--schedule", "ground-default", "--iterations", "2",
               "--report", str(rep), "--plot", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "stages:" in text and "step 3.2 [ground: S1=rest, S2=arms" in text
    assert text.strip().splitlines()[-1].startswith("audit: ")
    d = json.loads(rep.read_text())
    assert set(d) >= {"touchup", "audit", "provenance", "masses"}
    pl = d["touchup"]["planned"]
    assert len(pl["iterations"]) == 6 and pl["after"]["mean_outside_m"] < pl["before"]["mean_outside_m"]
    assert png.stat().st_size > 10_000
    m = read_bvh(out, scale=1.0)
    assert m.n_frames == 91
    assert d["audit"] is not None and d["provenance"]["measured"] == "audit"


def test_cli_masses_file(walk_file, tmp_path, capsys):
    from mocomp.audit import default_body

    body = default_body(read_bvh(walk_file, scale=1.0))
    mf = tmp_path / "m.json"
    mf.write_text(json.dumps({n: float(v) * 1.1 for n, v in zip(body.segment_names, body.masses)}))
    rep = tmp_path / "r.json"
    assert main(["touchup", str(walk_file), "-o", str(tmp_path / "o.bvh"), "--masses", str(mf), "--no-audit",
                 "--schedule", "ground-default", "--report", str(rep)]) == 0
    assert np.isclose(sum(json.loads(rep.read_text())["masses"].values()), 1.1 * body.total_mass)
    bad = dict(json.loads(mf.read_text()))
    bad.pop("head")
    mf.write_text(json.dumps(bad))
    assert exit_code(["touchup", str(walk_file), "-o", str(tmp_path / "o.bvh"), "--masses", str(mf)]) == 2
    assert "missing segment(s) head" in capsys.readouterr().err


def test_cli_polygon_and_cap(walk_file, tmp_path, capsys):
    rep = tmp_path / "r.json"
    assert main(["touchup", str(walk_file), "-o", str(tmp_path / "o.bvh"), "--no-audit", "--schedule", "ground-default",
                 "--polygon", "planted", "--max-angle", "1", "--report", str(rep)]) == 0
    text = capsys.readouterr().out
    d = json.loads(rep.read_text())
    assert d["polygon"] == "planted"
    capped = d["touchup"]["planned"]["capped_frames"]
    assert "capped frames" in text and sum(len(v) for v in capped.values()) > 0


@pytest.mark.parametrize("args, msg", [
    (["--max-angle", "-3"], "--max-angle: must be a angle in degrees above 0 and at most 180"),
    (["--polygon", "hull"], "--polygon"),
    (["--schedule", "sideways"], "unknown schedule 'sideways'"),
    (["--iterations", "0"], "--iterations"),
    (["--contacts", "nope.csv"], "contact file nope.csv does not exist"),
])
def test_cli_errors(walk_file, tmp_path, capsys, args, msg):
    assert exit_code(["touchup", str(walk_file), "-o", str(tmp_path / "o.bvh")] + args) == 2
    err = capsys.readouterr().err
    assert err.startswith("mocomp touchup: error:") and msg in err


def test_cli_bad_schedule_field_and_contradicting_contacts(walk_file, tmp_path, capsys):
    s = tmp_path / "s.toml"
    s.write_text('[[step]]\nstage = "ground"\ns2 = "upper"\nsigma = -4\n')
    assert exit_code(["touchup", str(walk_file), "-o", str(tmp_path / "o.bvh"), "--schedule", str(s)]) == 2
    assert "step 1: sigma must be 0 or more frames" in capsys.readouterr().err
    c = tmp_path / "c.csv"
    c.write_text("joint,start,stop\nfoot_l,0,91\n")
    assert exit_code(["touchup", str(walk_file), "-o", str(tmp_path / "o.bvh"), "--contacts", str(c)]) == 2
    assert "foot_l is labelled planted on frames 0-90 but moves" in capsys.readouterr().err


def test_mass_fit_lowers_eq5_within_bounds(real_data_dir):
    """Sec. 3.2: fitted on a real unedited walk, eq. 5's objective falls, the total mass is kept and
    every mass stays within the factor of the table; touch-up of that walk with the fitted masses
    changes its joints less than with the table's (the paper's argument for fitted masses)."""
    from mocomp import datasets
    from mocomp.audit import default_body
    from mocomp.touchup import touchup
    from mocomp.touchup.masses import fit_masses

    m = datasets.load(real_data_dir / "walks" / "bandai2_walk_normal_001.bvh")
    b = default_body(m)
    f = fit_masses(b, m)
    assert f.after < 0.9 * f.before
    assert np.isclose(f.body.total_mass, b.total_mass)
    ratio = f.body.masses / b.masses
    assert ratio.max() / ratio.min() <= 4.0 + 1e-9          # shares within 2x of the table, then the total restored
    assert ratio.max() / ratio.min() > 1.5                  # and the fit moved them

    def change(body):
        out = touchup(m, body, "ground-default").motion
        return np.degrees(2 * np.arccos(np.abs(np.einsum("tjk,tjk->tj", m.rotations, out.rotations)).clip(0, 1))).mean()

    assert change(f.body) < change(b)
