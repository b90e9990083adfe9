"""Issue #13: the stances next to a retimed flight get a longer push and a softer give
(``mocomp.flips.takeoff.smooth_stance``; ``multiflip(takeoff="smooth")``, ``mocomp flips --takeoff
smooth`` and ``edit``'s ``stances="smooth"``, the defaults of the commands). Measured as the commands
are: the BVH written and read back, audited by :mod:`mocomp.audit` against the input."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from mocomp.audit import audit
from mocomp.audit.com import velocity_jumps
from mocomp.audit.report import WORSE_FRACTION
from mocomp.audit.thresholds import AuditThresholds
from mocomp.flips import multiflip, prepare
from mocomp.flips.takeoff import _event_jump, _jump_rows, smooth_stance
from mocomp.io.bvh import read_bvh, write_bvh

#: m/s: "worse than the input" in the audit's comparison (a quarter of the 0.5 m/s jump threshold)
MARGIN = WORSE_FRACTION * AuditThresholds().jump_min
ACCEPTANCE = ("max_penetration_m", "max_foot_slide_m", "max_com_jump_mps", "takeoff_jump_mps", "landing_jump_mps")


@pytest.fixture(scope="module")
def backflip():
    return prepare("backflip")


def _rows(motion, against, tmp_path: Path, name: str) -> dict:
    path = tmp_path / f"{name}.bvh"
    write_bvh(motion, path)
    rep = audit(read_bvh(path), against=against)
    return {r[0]: r for r in rep.comparison.rows}


def test_synthetic_backflip_x2_takeoff_and_landing_as_the_input(backflip, tmp_path):
    """At k* = 1.40 the take-off played k times faster pushed with ~2x the captured acceleration: the
    audit read 0.47 m/s at take-off against the input's 0.22 and 0.83 at landing against 0.66. Smoothed,
    both are within a quarter of the threshold of the input's, and nothing else got worse."""
    smooth = multiflip(backflip, 2, takeoff="smooth")
    asis = multiflip(backflip, 2, takeoff="as-is")
    assert smooth.plan.k == pytest.approx(asis.plan.k) and smooth.plan.k > 1.3
    rs = _rows(smooth.motion, backflip.motion, tmp_path, "smooth")
    ra = _rows(asis.motion, backflip.motion, tmp_path, "asis")
    for key in ("takeoff_jump_mps", "landing_jump_mps"):
        _, _, _, out, inp, _ = rs[key]
        assert out <= inp + MARGIN / 2, (key, out, inp)
    # the defect the smoothing removes is there without it (the take-off at least)
    assert ra["takeoff_jump_mps"][3] > ra["takeoff_jump_mps"][4] + MARGIN
    for key in ACCEPTANCE:
        assert not rs[key][5], (key, rs[key])
    # the flight itself is the same parabola: only stance frames moved
    a, b = smooth.flight
    assert np.allclose(smooth.motion.root_positions[a + 1:b - 1], asis.motion.root_positions[a + 1:b - 1], atol=1e-9)
    rep = [i for i in smooth.report.notes if "stance smoothed" in i]
    assert len(rep) == 2 and "take-off" in rep[0] and "landing" in rep[1]


def test_smooth_stance_keeps_the_feet_and_bounds_the_force(backflip):
    """The map moves the root and bends the legs; the planted feet stay where they were (within the
    IK tolerance) and the vertical ground force stays within the bounds."""
    asis = multiflip(backflip, 2, takeoff="as-is")
    smooth = multiflip(backflip, 2, takeoff="smooth")
    P0, _ = asis.motion.fk()
    P1, _ = smooth.motion.fk()
    from mocomp.ops.ik import leg_chains
    from mocomp.dynamics import momentum

    a0 = int(np.floor(smooth.warp.takeoff_output)) - 1
    moved = np.linalg.norm(smooth.motion.root_positions[:a0] - asis.motion.root_positions[:a0], axis=1)
    assert moved.max() > 0.005                       # the push was reshaped ...
    for h, k, ank in leg_chains(backflip.motion.skeleton):
        assert np.max(np.linalg.norm(P1[:a0, ank] - P0[:a0, ank], axis=1)) < 0.006   # ... on planted feet
    # vertical ground force M (g + a_y) of the reshaped push, from the COM of the frames: within 0-8 body
    # weights (the ground pushes, never pulls; MAX_FORCE), smoothed over 20 ms as the repair bounds it
    from mocomp.dynamics.derivatives import gaussian_smooth

    com = momentum(backflip.body, smooth.motion).com
    dt = 1.0 / backflip.fps
    ay = np.gradient(np.gradient(gaussian_smooth(com[:, 1], 0.02 * backflip.fps), dt), dt)
    force = 1.0 + ay[10:a0 - 3] / 9.81
    assert force.min() > -0.05 and force.max() < 8.5


def test_jump_rows_are_the_audits_jumps(backflip):
    """``_jump_rows`` writes the audit's velocity jumps as ``J0 + M d``: checked against
    :func:`mocomp.audit.com.velocity_jumps` of the displaced COM (an independent computation)."""
    com = np.asarray(backflip.com, dtype=float)
    fps = backflip.fps
    s = backflip.flight[0]
    frames = np.arange(s - 40, s)
    M, J0, idx = _jump_rows(com, fps, s - 0.5, frames)
    assert idx.size == J0.shape[0] > 10
    rng = np.random.default_rng(3)
    d = rng.normal(scale=0.01, size=(frames.size, 3))
    moved = com.copy()
    moved[frames] += d
    w = AuditThresholds().jump_frames(fps)
    j_all, _, _ = velocity_jumps(moved, fps, w)
    j0_all, _, _ = velocity_jumps(com, fps, w)
    assert np.allclose(j0_all[idx], J0, atol=1e-12)
    assert np.allclose(j_all[idx], J0 + M @ d, atol=1e-9)


def test_smooth_stance_leaves_a_stance_that_is_already_smooth(backflip):
    """An event whose measured jump is within the target is not touched (the same motion back)."""
    m = backflip.motion
    s = backflip.flight[0]
    jump = _event_jump(np.asarray(backflip.com), backflip.fps, s - 0.5)
    out, info = smooth_stance(m, backflip.com_eval, "take-off", s - 0.5, (0, s), g=9.81, target_jump=jump + 0.01)
    assert out is m and info["repair"] is None and info["jump_before"] == pytest.approx(jump)


def _data(*parts) -> Path:
    root = os.environ.get("MOCOMP_DATA_DIR")
    p = Path(root, *parts) if root else None
    if p is None or not p.exists():
        pytest.skip("real data not available (MOCOMP_DATA_DIR)")
    return p


def test_edit_deepmimic_backflip_straight_legs_lands_as_the_input(tmp_path):
    """Real clip, through the command: ``mocomp edit deepmimic_backflip --preset straight-legs`` landed
    with a COM velocity jump of 0.56 m/s against the input's 0.37 (the audit called it worse); with the
    stances smoothed (the default) it is within a quarter of the threshold of the input's, and the
    paper's ``--stances as-is`` still shows the harder landing."""
    from mocomp.cli import main

    clip = _data("flips", "deepmimic_backflip.txt")
    got = {}
    for mode in ("smooth", "as-is"):
        out, rep = tmp_path / f"{mode}.bvh", tmp_path / f"{mode}.json"
        assert main(["edit", str(clip), "--preset", "straight-legs", "--stances", mode, "-o", str(out),
                     "--report", str(rep)]) == 0
        rows = {r["key"]: r for r in json.loads(rep.read_text())["audit"]["comparison"]["rows"]}
        got[mode] = rows
    land = got["smooth"]["landing_jump_mps"]
    assert land["this"] <= land["against"] + MARGIN and not land["worse"]
    assert got["as-is"]["landing_jump_mps"]["this"] > land["this"] + 0.1
    for key in ACCEPTANCE:
        assert not got["smooth"][key]["worse"], (key, got["smooth"][key])


def test_deepmimic_clip_is_planned_with_its_own_characters_masses(tmp_path):
    """A DeepMimic clip names its character: ``prepare`` uses its masses (known) instead of estimating
    them from the flight (``estimate="auto"``). The flight's parabola is then the COM the audit
    measures: the back flip x2's largest jump away from its landings, 0.67 m/s with the estimated masses
    against the input's 0.33, falls to ~0.45 (within the audit's quarter-threshold of the input's)."""
    from mocomp.audit.run import default_body

    clip = _data("flips", "deepmimic_backflip.txt")
    P = prepare(str(clip))
    char = default_body(P.motion)
    assert P.mass is None and any("character's own" in n for n in P.notes)
    np.testing.assert_allclose(P.body.masses, char.masses, rtol=1e-12)
    Q = prepare(str(clip), estimate=True)
    assert Q.mass is not None and not np.allclose(Q.body.masses, char.masses)
    rows = {}
    for label, prep in (("own", P), ("estimated", Q)):
        rows[label] = _rows(multiflip(prep, 2, takeoff="smooth").motion, P.motion, tmp_path, label)
    own, est = rows["own"]["max_com_jump_mps"], rows["estimated"]["max_com_jump_mps"]
    assert own[3] <= own[4] + MARGIN + 0.05
    assert est[3] > own[3] + 0.1


def test_deepmimic_sideflip_x2_takeoff_frames_already_airborne_meet_the_flight(tmp_path):
    """Real clip, through the command: the DeepMimic side flip's feet leave 3 frames (120 Hz) before the
    take-off its new flight is planned from. Holding the ankles on those frames bounded the map by the
    legs' reach, and the COM met the flight with a 0.41 m/s jump (frame 110; input 0.25 away from the
    landings). Now the legs move rigidly with the root there (as on a landing's airborne frames): the
    jump falls to ~0.15, nothing gets worse on penetration / slide / jumps."""
    from mocomp.cli import main

    clip = _data("flips", "deepmimic_sideflip.txt")
    out, rep = tmp_path / "sf.bvh", tmp_path / "sf.json"
    assert main(["flips", str(clip), "--flips", "2", "-o", str(out), "--report", str(rep)]) == 0
    rows = {r["key"]: r for r in json.loads(rep.read_text())["audit"]["comparison"]["rows"]}
    mj = rows["max_com_jump_mps"]
    assert mj["this"] <= mj["against"], mj                       # 0.15 against 0.25 (was 0.41)
    assert rows["takeoff_jump_mps"]["this"] <= rows["takeoff_jump_mps"]["against"] + MARGIN / 2
    for key in ACCEPTANCE:
        assert not rows[key]["worse"], (key, rows[key])


def test_takeoff_airborne_frames_follow_the_last_foot_down():
    """``_foot_down`` on a take-off window: frames up to the last one with the foot within the clearance
    of its lowest are held, later ones are airborne (mirror of the landing rule); the leg room there
    lets the root sink no lower than the foot's height above its planted level."""
    from mocomp.flips.takeoff import AIRBORNE_CLEARANCE, _foot_down

    class Sk:
        parents = np.array([-1, 0])
    n = 8
    P = np.zeros((n, 2, 3))
    P[:, 1, 1] = [0.0, 0.001, 0.0, 0.005, 0.01, 0.03, 0.06, 0.1]     # a toe leaving the floor
    got = _foot_down(Sk, P, 1, "take-off")
    last = int(np.flatnonzero(P[:, 1, 1] <= AIRBORNE_CLEARANCE)[-1])
    assert got.tolist() == [True] * (last + 1) + [False] * (n - last - 1)
    land = _foot_down(Sk, P[::-1], 1, "landing")
    assert land.tolist() == got[::-1].tolist()


def test_edit_deepmimic_sideflip_straight_legs_one_foot_landing_is_smoothed(tmp_path):
    """Real clip, through the command: the DeepMimic side flip with straight legs lands on one foot while
    the other, hip-high, still swings down. That leg's reach (zero: its ankle level with its hip) bounded
    the landing map on the first stance frame, so no map existed and the landing jumped 0.52 m/s against
    the input's 0.30 (counted twice: the hop 5 frames later shares the frame). The leg room now counts
    only legs whose own foot is down: the jump is within the input's, penetration and slide not worse."""
    from mocomp.cli import main

    clip = _data("flips", "deepmimic_sideflip.txt")
    out, rep = tmp_path / "e.bvh", tmp_path / "e.json"
    assert main(["edit", str(clip), "--preset", "straight-legs", "-o", str(out), "--report", str(rep)]) == 0
    rows = {r["key"]: r for r in json.loads(rep.read_text())["audit"]["comparison"]["rows"]}
    for key in ("landing_jump_mps", "takeoff_jump_mps"):
        assert rows[key]["this"] <= rows[key]["against"] + MARGIN / 2, (key, rows[key])   # 0.29 vs 0.30 (was 0.52)
    for key in ACCEPTANCE:
        assert not rows[key]["worse"], (key, rows[key])


def test_leg_room_ignores_a_leg_still_in_the_air():
    """``_leg_room`` on a landing window (known answer): the left foot planted with the knee bent, the
    right one still hip-high on the first frames (its ankle level with its hip: no room to sink). Those
    frames' room is the left leg's (positive), not the airborne leg's zero; once the right foot is down
    (within the clearance of its lowest) both legs bound it."""
    from types import SimpleNamespace

    from mocomp.flips.takeoff import _leg_room

    names = ["root", "lhip", "lknee", "lankle", "rhip", "rknee", "rankle"]
    sk = SimpleNamespace(names=names, parents=np.array([-1, 0, 1, 2, 0, 4, 5]))
    n = 12
    P = np.zeros((n, 7, 3))
    P[:, 0] = [0.0, 0.95, 0.0]
    P[:, 1] = [-0.1, 0.9, 0.0]
    P[:, 2] = [-0.1, 0.5, 0.15]                 # bent left knee (thigh 0.427, shin 0.477)
    P[:, 3] = [-0.1, 0.05, 0.0]
    P[:, 4] = [0.1, 0.9, 0.0]
    ry = np.r_[np.full(5, 0.9), np.linspace(0.9, 0.05, 5)[1:], np.full(n - 9, 0.05)]
    P[:, 6, 0], P[:, 6, 1], P[:, 6, 2] = 0.1, ry, 0.4 * (ry > 0.06)
    P[:, 5] = 0.5 * (P[:, 4] + P[:, 6]) + np.array([0.0, 0.0, 0.1])
    # the clip's tightest knee elsewhere: a deep crouch frame appended (the limit is taken over the clip)
    crouch = P[-1].copy()
    crouch[2] = [-0.1, 0.45, 0.44]
    P_all = np.concatenate([P, crouch[None]])
    motion = SimpleNamespace(skeleton=sk, fk=lambda: (P_all, None))
    frames = np.arange(n)
    down, up = _leg_room(motion, frames, "landing")
    left_only = _leg_room(SimpleNamespace(skeleton=SimpleNamespace(names=names[:4] + ["a", "b", "c"],
                                                                   parents=sk.parents), fk=lambda: (P_all, None)),
                          frames, "landing")[0]
    assert np.all(down[:5] > 0.05)                               # not the airborne leg's zero
    np.testing.assert_allclose(down[:5], left_only[:5], rtol=1e-12)
    assert np.all(down[9:] <= left_only[9:] + 1e-12)             # both legs bound once the right foot is down
