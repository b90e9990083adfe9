"""The audit against an input and under declared external force: flights paired by time (spurious
one-frame airborne runs left out), forced airborne frames told apart from free flight, and pose
jumps found joint by joint against the input's own rates (issues 13, 15, 18)."""
from __future__ import annotations

import dataclasses
import json
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp import datasets
from mocomp.audit import AuditThresholds, audit, forced_mask, pair_flights, parse_frame_ranges
from mocomp.cli import main
from mocomp.errors import MotionFormatError
from mocomp.io import write_bvh
from mocomp.io.bvh import read_bvh
from mocomp.synth.registry import make_example


@pytest.fixture(scope="module")
def bf():
    return make_example("backflip")


def _lift_first_frame(m, dy=0.06):
    """A copy of ``m`` whose first frame is lifted ``dy``: a one-frame airborne run at frame 0, as CMU 90_08 has."""
    rp = np.array(m.root_positions)
    rp[0, 1] += dy
    return m.replace(root_positions=rp)


def _flight_rows(rep):
    return {k: (a, b) for k, _, _, a, b, _ in rep.comparison.rows if "flight" in k}


# ------------------------------------------------------------------ 1. flight pairing
def test_a_spurious_one_frame_airborne_run_is_reported_but_not_paired(bf):
    m = bf.motion
    sp = _lift_first_frame(m)
    rep = audit(sp, bf.body, against=m)
    assert rep.phases.flights[0] == (0, 1)                          # still in the phases and the report
    assert [f.kind for f in rep.flights] == ["spurious", "free"]
    assert rep.flights[0].fit is None and not rep.flights[0].is_flight
    pairing = rep.comparison.flight_pairing
    assert pairing.pairs == ((1, 0),) and pairing.spurious_this == (0,) and pairing.method == "order"
    rows = _flight_rows(rep)
    # the real flight (this motion's second airborne run) beside the original's first: identical values
    assert rows["flight2_g"][0] == pytest.approx(9.81, abs=1e-6)
    assert rows["flight2_g"][1] == pytest.approx(rows["flight2_g"][0], abs=1e-9)
    assert rows["flight2_L_direction_rad"][1] == pytest.approx(rows["flight2_L_direction_rad"][0], abs=1e-9)
    assert "flight1_g" not in rows and not any(k.startswith("against_") for k in rows)
    assert not any(k.startswith("flight") for k in rep.comparison.worse)
    # and the other way round: the original against the flickering copy
    back = audit(m, bf.body, against=sp)
    assert back.comparison.flight_pairing.pairs == ((0, 1),)
    assert _flight_rows(back)["flight1_g"][1] == pytest.approx(9.81, abs=1e-6)
    line = [x for x in rep.summary_lines() if x.strip().startswith("flight 1 (frames 0-0)")]
    assert line and "spurious" in line[0]
    d = rep.to_dict()
    assert d["flights"][0]["kind"] == "spurious"
    assert d["comparison"]["flight_pairing"]["pairs"] == [[2, 1]]


def test_spurious_threshold_is_frames_or_time():
    th = AuditThresholds()
    assert th.spurious_flight(1, 60.0) and th.spurious_flight(2, 30.0) and th.spurious_flight(3, 120.0)  # 25 ms
    assert not th.spurious_flight(4, 120.0) and not th.spurious_flight(3, 60.0)                         # 33, 50 ms
    assert not AuditThresholds(min_airborne_frames=1, min_airborne_time=0.0).spurious_flight(1, 120.0)


def _fake(flights, n_frames, fps, spurious=()):
    return SimpleNamespace(n_frames=n_frames, fps=fps, flights=tuple(
        SimpleNamespace(index=i, frames=f, kind="spurious" if i in spurious else "free") for i, f in enumerate(flights)))


def test_pairing_of_a_retimed_output_with_an_extra_hop_uses_overlap():
    """Input: hop, flip, hop at 120 Hz over 300 frames. Output retimed to 360 frames (flip 1.5x longer),
    one extra hop at its end and a one-frame flicker at frame 0: the flights pair by normalised time."""
    src = _fake([(40, 60), (120, 170), (220, 235)], 300, 120.0)
    out = _fake([(0, 1), (48, 72), (140, 215), (262, 280), (330, 345)], 360, 120.0, spurious=(0,))
    p = pair_flights(out, src)
    assert p.method == "overlap" and p.time_base == "normalised"
    assert p.pairs == ((1, 0), (2, 1), (3, 2))
    assert p.unpaired_this == (4,) and p.spurious_this == (0,)
    # equal counts after dropping the flicker: by order, even when the retimed flip moved
    out2 = _fake([(0, 1), (48, 72), (150, 230), (262, 280)], 360, 120.0, spurious=(0,))
    assert pair_flights(out2, src).pairs == ((1, 0), (2, 1), (3, 2))
    assert pair_flights(out2, src).method == "order"
    # nothing to pair
    assert pair_flights(_fake([], 300, 120.0), src).method == "none"


def test_unpaired_flight_of_the_input_is_listed_under_its_own_key(bf):
    m = bf.motion
    a, b = bf.flight
    grounded = m[:a - 20]                               # the stand and crouch only: no flight
    rep = audit(grounded, bf.body, against=m)
    rows = _flight_rows(rep)
    assert rows and all(k.startswith("against_flight1_") for k in rows)
    assert rows["against_flight1_g"][1] == pytest.approx(9.81, abs=1e-6) and np.isnan(rows["against_flight1_g"][0])


def test_real_90_08_pairs_its_side_flip_past_the_frame_0_flicker(real_data_dir):
    """CMU 90_08 has a one-frame airborne run at frame 0; a copy without its first frame has none.
    Index pairing set the copy's side flip beside the input's hop; paired by time they match."""
    src = datasets.load("90_08")
    rin = audit(src)
    assert rin.flights[0].frames == (0, 1) and rin.flights[0].kind == "spurious"
    for cut in (1, 3):                                       # same duration (seconds) and normalised time
        rep = audit(src[cut:], against=src)
        assert rep.flights[0].kind == "free"
        n = sum(f.kind != "spurious" for f in rin.flights)
        assert rep.comparison.flight_pairing.pairs == tuple((i, i + 1) for i in range(n))
        rows = _flight_rows(rep)
        for k in ("flight2_g", "flight2_L_direction_rad", "flight2_L_magnitude"):
            this, other = rows[k]
            assert this == pytest.approx(other, rel=0.05, abs=0.02), k       # the side flip beside itself
        assert rows["flight2_g"][0] == pytest.approx(rin.flights[2].fit.g, abs=0.5)
        assert not [k for k in rep.comparison.worse if "flight" in k]


# ------------------------------------------------------------------ 2. forced vs free flight
def _pushed(bf, p_off=10, n=8):
    """The back flip hit in flight: over frames [p, p + n) the root is jolted up 8 cm and 5 cm forward
    and turned 0.5 rad about the vertical, and back (a sin^2 bump); the rest of the flight is untouched."""
    m = bf.motion
    a, _ = bf.flight
    p = a + p_off
    bump = np.sin(np.pi * (np.arange(n) + 0.5) / n) ** 2
    rp = np.array(m.root_positions)
    rp[p:p + n, 1] += 0.08 * bump
    rp[p:p + n, 0] += 0.05 * bump
    rot = np.array(m.rotations)
    rot[p:p + n, 0] = (Rotation.from_rotvec(np.outer(0.5 * bump, [0, 1, 0])) * Rotation.from_quat(rot[p:p + n, 0])).as_quat()
    return m.replace(root_positions=rp, rotations=rot), (p, p + n)


def test_a_planted_push_is_a_violation_until_declared_then_expected(bf):
    pushed, (p, q) = _pushed(bf)
    free = audit(pushed, bf.body)
    checks = {f.check for f in free.violations}
    assert {"com_velocity_jump", "L_direction", "L_magnitude"} <= checks
    assert free.flights[0].kind == "free"

    rep = audit(pushed, bf.body, external_force_frames=slice(p, q))
    assert rep.verdict == "pass", [f.line() for f in rep.violations]
    assert rep.external_force is not None and rep.external_force.sum() == q - p
    fl = rep.flights[0]
    assert fl.kind == "forced" and fl.forced_frames == q - p
    assert fl.judged_frames == (q, fl.frames[1])                        # the free part after the hit
    assert fl.fit.g == pytest.approx(9.81, abs=1e-6) and fl.L_direction < 1e-6 and fl.L_judged
    exp = rep.expected
    assert exp and all(f.check in ("com_velocity_jump", "L_direction", "L_magnitude") for f in exp)
    assert all(f.frames[0] < q + rep.com.window and f.frames[1] > p - rep.com.window for f in exp)
    assert all("external force" in f.message for f in exp)
    assert rep.com.max_jump < 0.5                                        # the hit's jump is not the clip's
    to = [e for e in rep.com.events if e.kind == "take-off"][0]
    assert to.jump < 0.5
    d = rep.to_dict()
    assert d["external_force"]["frames"] == [[p, q]] and d["expected"] == len(exp)
    assert d["flights"][0]["kind"] == "forced" and d["flights"][0]["judged_frames"] == [q, fl.frames[1]]
    text = "\n".join(rep.summary_lines())
    assert "expected under external force" in text and "judged on its free part" in text
    # a penetration is never excused by a force
    rp = np.array(pushed.root_positions)
    rp[p:q, 1] -= 3.0
    sunk = audit(pushed.replace(root_positions=rp), bf.body, external_force_frames=slice(p, q))
    assert any(f.check == "floor_penetration" for f in sunk.violations)


def test_same_push_declared_in_every_accepted_form_gives_the_same_report(bf):
    pushed, (p, q) = _pushed(bf)
    T = pushed.n_frames
    mask = np.zeros(T, bool)
    mask[p:q] = True
    ref = audit(pushed, bf.body, external_force_frames=slice(p, q)).to_dict()
    for spec in ([(p, q)], np.arange(p, q), mask, f"{p}:{q}", [f"{p}:{q - 2}", f"{q - 2}:{q}"]):
        d = audit(pushed, bf.body, external_force_frames=spec).to_dict()
        d["seconds"] = ref["seconds"]
        assert d == ref


def test_a_flight_forced_throughout_is_not_judged(bf):
    pushed, _ = _pushed(bf)
    a, b = bf.flight
    rep = audit(pushed, bf.body, external_force_frames=slice(a - 5, b + 5))
    fl = rep.flights[0]
    assert fl.kind == "forced" and fl.fit is None and fl.judged_frames is None
    assert not [m for m in rep.measures() if m.key.startswith("flight")]
    assert not rep.violations


def test_external_force_frames_are_validated(bf):
    T = bf.motion.n_frames
    assert forced_mask(None, T) is None
    with pytest.raises(MotionFormatError, match="beyond"):
        forced_mask([(10, T + 5)], T, "victim.bvh")
    with pytest.raises(MotionFormatError, match="shape"):
        forced_mask(np.ones(T - 1, bool), T)
    with pytest.raises(MotionFormatError, match="outside"):
        forced_mask([T + 3], T)
    with pytest.raises(MotionFormatError, match="START:STOP"):
        parse_frame_ranges(["a:b"])
    with pytest.raises(MotionFormatError, match="START < STOP"):
        parse_frame_ranges(["9:3"])
    assert parse_frame_ranges(["3:5,7", "10:12"]) == [(3, 5), (7, 8), (10, 12)]


def test_cli_external_force(bf, tmp_path, capsys):
    pushed, (p, q) = _pushed(bf)
    f = tmp_path / "pushed.bvh"
    write_bvh(pushed, f)
    rj = tmp_path / "r.json"
    assert main(["audit", str(f), "--strict"]) == 1
    capsys.readouterr()
    assert main(["audit", str(f), "--strict", "--external-force", f"{p}:{q}", "--report", str(rj)]) == 0
    out = capsys.readouterr().out
    assert f"external force declared on frames {p}-{q - 1}" in out and "verdict: PASS" in out
    assert json.loads(rj.read_text())["external_force"]["frames"] == [[p, q]]
    assert main(["audit", str(f), "--external-force", "x:y"]) == 2
    assert "START:STOP" in capsys.readouterr().err


# ------------------------------------------------------------------ 3. pose jumps against the input
@pytest.fixture(scope="module")
def walk_copy(real_data_dir, tmp_path_factory):
    """CMU 131_01 (120 Hz; its RThumb flips by ~180 deg in a frame: 376 rad/s) and a copy of it
    written to BVH and read back."""
    src = datasets.load(real_data_dir / "walks" / "131_01.bvh")
    f = tmp_path_factory.mktemp("pose_jump") / "copy.bvh"
    write_bvh(src, f)
    return src, read_bvh(f, scale=1.0)


def _turned(m, joint, k, degrees=30.0):
    j = m.skeleton.index(joint)
    rot = np.array(m.rotations)
    rot[k:, j] = (Rotation.from_quat(rot[k:, j]) * Rotation.from_rotvec([0, 0, np.radians(degrees)])).as_quat()
    return m.replace(rotations=rot)


def test_unmodified_copy_of_a_real_clip_has_no_pose_jump(walk_copy):
    src, copy = walk_copy
    rep = audit(copy, against=src)
    assert rep.against.kinematics.joint_speed > 300                # the input's own glitch
    pj = rep.pose_jumps
    assert pj.mapping == "seconds" and len(pj.joints) == src.skeleton.n_joints
    assert pj.max_excess < 0.05 and pj.n_jumps == 0
    assert not rep.by_check("pose_jump")
    assert rep.measure("max_joint_speed_excess") == pytest.approx(pj.max_excess)
    assert "max_joint_speed_excess" not in rep.comparison.worse


def test_a_planted_30_degree_jump_of_one_joint_is_found(walk_copy):
    src, copy = walk_copy
    k = 400
    rep = audit(_turned(copy, "LeftElbow", k), against=src)
    # the whole-clip joint speed check cannot see it: the input's own glitch is far above 30 deg/frame
    assert rep.kinematics.joint_speed <= rep.against.kinematics.joint_speed
    found = rep.by_check("pose_jump")
    assert len(found) == 1
    f = found[0]
    assert f.where == "LeftElbow" and f.frames == (k - 1, k + 1) and f.peak_frame == k - 1
    rate = np.radians(30.0) * src.fps                                    # 62.8 rad/s
    own = rep.against.kinematics.rates[k - 1, src.skeleton.index("LeftElbow")]
    assert f.size == pytest.approx(rate - own, abs=3.0)                  # excess over the input's rate there
    assert f.severity == "advisory"                                      # default: a method may mean it
    assert rep.pose_jumps.n_jumps == 1 and rep.pose_jumps.joint == "LeftElbow"
    assert "max_joint_speed_excess" in rep.comparison.worse
    strict = audit(_turned(copy, "LeftElbow", k), against=src,
                   thresholds=AuditThresholds(pose_jump_is_violation=True))
    assert [x.check for x in strict.violations if x.check == "pose_jump"] == ["pose_jump"]
    d = rep.to_dict()
    assert d["pose_jumps"]["joint"] == "LeftElbow" and d["pose_jumps"]["n_jump_steps"] == 1


def test_pose_jump_reference_is_local_so_the_inputs_glitch_does_not_hide_a_jump(walk_copy):
    """The same 30-degree jump on the glitching joint itself (RThumb, 376 rad/s at one frame of the
    input) is found away from the glitch, while the copied glitch is not a finding."""
    src, copy = walk_copy
    j = src.skeleton.index("RThumb")
    g = int(np.argmax(audit(src).kinematics.rates[:, j]))
    k = g + 200
    rep = audit(_turned(copy, "RThumb", k), against=src)
    found = rep.by_check("pose_jump")
    assert [x.where for x in found] == ["RThumb"] and found[0].frames[0] == k - 1
    assert found[0].severity == "advisory"                              # the thumb carries no mass


def test_pose_jumps_of_a_uniformly_retimed_copy_are_matched_by_normalised_time(walk_copy):
    src, _ = walk_copy
    fast = src[:600].retime(1.25)
    rep = audit(fast, against=src[:600])
    assert rep.pose_jumps.mapping == "normalised"
    assert rep.pose_jumps.n_jumps == 0                 # played 1.25x faster, the reference is scaled with it
    jumped = audit(_turned(fast, "LeftElbow", 200), against=src[:600])
    assert [x.where for x in jumped.by_check("pose_jump")] == ["LeftElbow"]
    # an explicit frame map is used as given
    m = np.arange(fast.n_frames) * 1.25
    given = audit(fast, against=src[:600], against_frame_map=m)
    assert given.pose_jumps.mapping == "given" and given.pose_jumps.n_jumps == 0
    with pytest.raises(MotionFormatError, match="against_frame_map"):
        audit(fast, against=src[:600], against_frame_map=m[:-1])


def test_places_translate_to_the_inputs_flight_numbering(bf):
    """A command matches its output's violations with its input's by check and place
    (``mocomp.cli._common.new_violations``): the places are renamed through the pairing."""
    m = bf.motion
    rep = audit(_lift_first_frame(m), bf.body, against=m)
    cmp = rep.comparison
    assert cmp.place_in_other("take-off of flight 2") == "take-off of flight 1"
    assert cmp.place_in_other("flight 2") == "flight 1"
    assert cmp.place_in_other("landing of flight 1") == "landing of flight 1 (no partner)"
    assert cmp.place_in_other("toe_l") == "toe_l"
    from mocomp.cli._common import new_violations

    pushed, (p, q) = _pushed(bf)
    out = audit(_lift_first_frame(pushed), bf.body, against=pushed)
    # the push's L violations are the input's own, at its flight 1 = the output's flight 2
    assert {f.check for f in out.violations} >= {"L_direction", "L_magnitude"}
    assert not [f for f, _ in new_violations(out) if f.check.startswith("L_")]
