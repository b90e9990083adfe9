"""``mocomp impact``: the end-to-end response on real clips, its report, the audits of both written
files, and its errors (issue 18)."""
from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")

from _cli import exit_code  # noqa: E402
from mocomp.cli import main  # noqa: E402
from mocomp.io import read_bvh, write_bvh  # noqa: E402




@pytest.fixture(scope="module")
def clips(real_data_dir):
    return {"kick": str(real_data_dir / "attacks" / "ase_rl_Atk_Kick.derived.bvh"),
            "idle": str(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh"),
            "library": str(real_data_dir / "reactions")}


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return str(tmp_path_factory.mktemp("impact_cache"))


@pytest.fixture(scope="module")
def kicked(clips, cache, tmp_path_factory):
    """One full response: kick -> standing victim, face to face."""
    d = tmp_path_factory.mktemp("impact_out")
    rep = d / "r.json"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["impact", "--attacker", clips["kick"], "--victim", clips["idle"], "--contact-body", "right_foot",
                   "--library", clips["library"], "--cache", cache, "-o", str(d / "out"), "--report", str(rep)])
    return rc, d, json.loads(rep.read_text()), buf.getvalue()


def test_writes_both_characters_report_and_audits(kicked):
    rc, d, rep, text = kicked
    assert rc == 0
    v, a = read_bvh(d / "out" / "victim.bvh", scale=1.0), read_bvh(d / "out" / "attacker.bvh", scale=1.0)
    assert v.n_frames == rep["frames"]["output_frames"] and a.n_frames > 30
    assert (d / "out" / "filmstrip.png").stat().st_size > 5_000
    for key in ("impact_time_s", "contact_bodies", "impulse_Ns", "search", "pruning", "active_tracking_error_deg",
                "final_blend_correction", "timings_s", "mujoco_warnings", "audit"):
        assert key in rep, key
    assert "right_foot" in rep["contact_bodies"] and rep["impulse_norm_Ns"] > 10
    s = rep["search"]
    assert s["clip"].endswith((".bvh", ".txt")) and s["frame"] >= 0 and "runner_up" in s
    p = rep["pruning"]
    assert 0 < p["frames_compared"] < p["frames_exhaustive"]
    assert set(rep["audit"]) == {"victim", "attacker"}
    lines = text.strip().splitlines()
    assert lines[-2].startswith("victim audit: ") and lines[-1].startswith("attacker audit: ")


def test_acceptance_continuity_floor_and_feet(kicked):
    """No jump at re-entry beyond the found clip's own; the audit of the written victim: no floor
    penetration over 1 cm, no foot slide over the audit's limit after re-entry."""
    _, _, rep, _ = kicked
    c = rep["evidence"]["continuity_final"]
    # measured 2026-12-02: root 0.6 cm (clip max 5.2 cm); joints 17.60 deg against the clip's 17.58 (the
    # linear blend gave 18.3: its error rate on top of the clip's own fast get-up; the eased weights enter
    # the clip with its own velocity, the rest is the simulation's velocity at weight 1 - w(n-1))
    assert c["reentry_root_step_m"] <= c["clip_max_root_step_m"]
    assert c["reentry_joint_step_deg"] <= c["clip_max_joint_step_deg"] + 0.05
    assert rep["evidence"]["blend_weights"] in ("linear", "smoothstep", "smootherstep")
    assert c["rewind_root_step_m"] <= c["clip_max_root_step_m"]
    au = rep["audit"]["victim"]
    assert au["measures"]["max_penetration_m"] <= 0.01
    re = rep["frames"]["reentry"]
    slides = [f for f in au["findings"] if f["check"] == "foot_slide" and f["frames"][1] >= re]
    assert not slides
    fb = rep["final_blend_correction"]
    act, nai = fb["from_active (planned)"], fb["from_naive (planned, for comparison)"]
    assert act["joint_error_at_reentry_deg"] < nai["joint_error_at_reentry_deg"]


def test_same_seed_same_output(kicked, clips, cache, tmp_path):
    _, d, rep, _ = kicked
    rc = main(["impact", "--attacker", clips["kick"], "--victim", clips["idle"], "--contact-body", "right_foot",
               "--library", clips["library"], "--cache", cache, "-o", str(tmp_path / "o"), "--no-audit"])
    assert rc == 0
    a = read_bvh(d / "out" / "victim.bvh", scale=1.0)
    b = read_bvh(tmp_path / "o" / "victim.bvh", scale=1.0)
    np.testing.assert_allclose(a.root_positions, b.root_positions, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.rotations, b.rotations, rtol=0, atol=1e-9)


@pytest.mark.parametrize("facing", ["200", "-180.5", "nan"])
def test_facing_outside_range_is_refused(facing, tmp_path, capsys):
    rc = exit_code(["impact", "--attacker", "a.bvh", "--victim", "v.bvh", "--facing", facing, "-o", str(tmp_path)])
    assert rc == 2
    err = capsys.readouterr().err
    assert "mocomp impact: error: argument --facing" in err and ("180" in err or "finite" in err)


def test_no_contact_says_closest_distance_and_when(clips, cache, tmp_path, capsys):
    rc = exit_code(["impact", "--attacker", clips["kick"], "--victim", clips["idle"], "--contact-body", "right_foot",
              "--offset", "4,0", "--library", clips["library"], "--cache", cache, "-o", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "no contact" in err and "closest" in err and " s)" in err
    assert len(err.strip().splitlines()) == 1


def test_victim_on_the_ground_is_refused(clips, cache, tmp_path, capsys):
    low = tmp_path / "lying.bvh"
    write_bvh(read_bvh(clips["idle"], scale=1.0).translated([0, -0.45, 0]), low)
    rc = exit_code(["impact", "--attacker", clips["kick"], "--victim", str(low), "--contact-body", "right_foot",
              "--library", clips["library"], "--cache", cache, "-o", str(tmp_path / "o")])
    assert rc == 2
    assert "already on the ground" in capsys.readouterr().err


def test_library_without_a_usable_clip_is_refused(clips, cache, tmp_path, capsys):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "broken.bvh").write_text("HIERARCHY\nROOT x\n{\n")
    rc = exit_code(["impact", "--attacker", clips["kick"], "--victim", clips["idle"], "--library", str(lib),
              "--cache", cache, "-o", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "no clip usable for the victim's skeleton" in err and "broken.bvh" in err


def test_unknown_contact_body_is_named(clips, cache, tmp_path, capsys):
    rc = exit_code(["impact", "--attacker", clips["kick"], "--victim", clips["idle"], "--contact-body", "fist",
              "--library", clips["library"], "--cache", cache, "-o", str(tmp_path / "o")])
    assert rc == 2
    assert "contact body 'fist'" in capsys.readouterr().err


def test_strike_frames_declared_as_external_force_in_the_audit(kicked):
    """The strike's frames go to the audit as under external force: no gravity / L finding touching them
    is a violation (they are 'expected'), and the strike ends within its limits."""
    _, _, rep, _ = kicked
    a, b = rep["frames"]["external_force"]
    assert rep["frames"]["rewind"] <= a < b <= rep["frames"]["reentry"] + 1
    assert rep["impulse_norm_Ns"] <= 60.0 * 1.15
    # the kick's foot stays on the victim 0.37 s unlimited: the strike ends at 0.25 s
    assert rep["contact_end_s"] - rep["impact_time_s"] <= 0.25 + 1e-3
    assert rep["strike_end"] is not None and rep["strike_end"]["after_impact_s"] <= 0.25 + 1e-3
    for f in rep["audit"]["victim"]["findings"]:
        if f["check"] in ("gravity", "L_direction", "L_magnitude") and f["frames"][0] < b and f["frames"][1] > a:
            assert f["severity"] != "violation", f
