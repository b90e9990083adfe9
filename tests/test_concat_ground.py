"""Issue 17's "feet slide at most 1 cm in support and never penetrate": the body lifted out of the floor
(mocomp.ops.ground_contact) and the concatenation's grounding, measured with mocomp.audit on the BVH
written and read back."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from mocomp import datasets
from mocomp.audit import audit
from mocomp.concat import concatenate, momentum_track
from mocomp.io import write_bvh
from mocomp.io.bvh import read_bvh
from mocomp.ops.evidence import foot_slide
from mocomp.ops.ground_contact import floor_depth, lift_out_of_floor


def _sunk(m, frames, dy):
    rp = np.array(m.root_positions)
    rp[frames, 1] -= dy
    return m.replace(root_positions=rp)


def test_lift_restores_a_sunk_landing_exactly():
    # the synthetic back flip (flight 122-196 at 120 fps) with its landing stance pushed 3 cm into the floor
    m = datasets.load("backflip")
    f = np.arange(230, m.n_frames)
    sunk = _sunk(m, f, 0.03)
    fd0 = floor_depth(m)
    assert fd0.max_depth < 2e-3
    assert floor_depth(sunk).max_depth == pytest.approx(0.03 + fd0.depth[f].min(), abs=2e-3)
    r = lift_out_of_floor(sunk)
    assert r.depth_after <= 1e-4 and r.passes == 1
    # the sunk frames come back up by the 3 cm less the original's clearance there, nothing moves sideways
    assert np.allclose(r.lift[f], np.maximum(0.03 - (m.root_positions[f, 1] * 0 + (fd0.lowest[f] - fd0.floor_y)), 0.0),
                       atol=2e-3)
    assert r.lift[f].max() == pytest.approx(0.03, abs=2e-3)
    assert np.array_equal(r.motion.root_positions[:, [0, 2]], sunk.root_positions[:, [0, 2]])
    assert np.array_equal(r.motion.rotations, sunk.rotations)
    assert np.all(r.lift[:200] == 0.0)                      # the take-off stance and the flight untouched
    # the angular momentum about the COM is unchanged away from the lift's edges (a vertical translation)
    L0, L1 = momentum_track(sunk).L, momentum_track(r.motion).L
    inner = slice(240, m.n_frames - 10)
    assert np.abs(L1[inner] - L0[inner]).max() < 1e-6 * max(1.0, np.abs(L0).max())


def test_lift_is_linear_over_a_flight():
    # a point sunk on the frames just after the landing, lifted with a smoothed lift: inside the flight
    # (122-196) the lift is linear in time, so the flight's vertical acceleration is the input's
    m = datasets.load("backflip")
    sunk = _sunk(m, np.arange(197, 215), 0.02)
    r = lift_out_of_floor(sunk, smooth=0.1)
    d2 = np.diff(r.lift[122:197], 2)
    assert r.lift[190:197].max() > 0.0                      # the smoothing reaches into the flight
    assert np.abs(d2).max() < 1e-12
    assert r.depth_after <= 1e-4
    rough = lift_out_of_floor(sunk, smooth=0.1, ballistic=False)
    assert np.abs(np.diff(rough.lift[122:197], 2)).max() > 1e-5


def test_lift_argument_errors():
    m = datasets.load("backflip")
    with pytest.raises(ValueError, match="passes"):
        lift_out_of_floor(m, passes=0)
    with pytest.raises(ValueError, match="tol"):
        lift_out_of_floor(m, tol=-1.0)


def _read_back(m, tmp_path, name):
    p = tmp_path / f"{name}.bvh"
    write_bvh(m, str(p))
    return read_bvh(str(p), scale=1.0)


@pytest.mark.parametrize("rel, fps", [("flips/deepmimic_backflip.txt", None), ("flips/cmu_88_01_backflip.bvh", 60),
                                      ("flips/deepmimic_sideflip.txt", None)])
def test_flip_pairs_slide_and_penetration_read_back(real_data_dir, tmp_path, rel, fps):
    # the inputs sink 3.6 (DeepMimic back flip), 10.9 (CMU 88_01: raw toes) and 7.6 cm (DeepMimic side flip)
    # below the level they took off from; the concatenation's grounding: <= 1 cm slide, <= 0.5 cm depth
    kw = {"fps": fps} if fps else {}
    m = datasets.load(str(real_data_dir / rel), **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = concatenate(m, m)
        raw = concatenate(m, m, ground=False)
    out = _read_back(r.motion, tmp_path, "ours")
    rep, before = audit(out, against=m), audit(_read_back(raw.motion, tmp_path, "raw"), against=m)
    assert foot_slide(rep) <= 0.01
    assert rep.measure("max_penetration_m") <= 0.005
    assert before.measure("max_penetration_m") > 0.03       # what the grounding removed
    assert r.ground["lifted"] and r.ground["depth_m"] <= 0.005 and r.ground["slide_m"] <= 0.01
    assert "ground_contact" in r.to_dict()
    # the grounding moves the body up only: |L| between the main phases is kept (0.65 / 0.94 / 0.78)
    lo = momentum_track(out).magnitude[r.phases[0].t_m:r.phases[1].t_m + r.frame_shift + 1].min()
    lo0 = momentum_track(raw.motion).magnitude[r.phases[0].t_m:r.phases[1].t_m + r.frame_shift + 1].min()
    assert lo == pytest.approx(lo0, rel=0.05)


def test_keep_floor_leaves_the_floor_where_it_was():
    # the take-off stance (the floor's own stage) sunk 2 cm on a few of its frames: spread over that stage
    # the smoothed lift raises the median the floor is; keep_floor lifts that stage frame by frame
    m = datasets.load("backflip")
    sunk = _sunk(m, np.arange(40, 60), 0.02)
    f0 = floor_depth(sunk).floor_y
    kept = lift_out_of_floor(sunk, smooth=0.1, keep_floor=True)
    spread = lift_out_of_floor(sunk, smooth=0.1)
    assert kept.floor_y == pytest.approx(f0, abs=1e-4) and kept.depth_after <= 1e-4
    # spread, the floor rises (1.4 -> 2.6 cm) and chases the lift: 0.58 cm left after the two passes
    assert spread.floor_y > f0 + 1e-3 and 1e-4 < spread.depth_after < 0.5 * spread.depth_before


def _wushu(d):
    from mocomp.concat import find_actions

    w = datasets.load(str(d / "kicks_punches/sfu_0017_WushuKicks001.bvh"))
    acts = find_actions(w)
    rk = next(x for x in acts if x.effector == "toe_r")
    lk = next(x for x in acts if x.effector == "toe_l")
    return rk.cut(w), lk.cut(w)


@pytest.mark.parametrize("pair", ["sie punches", "wushu constrained", "sfu cartwheels"])
def test_other_pairs_slide_and_penetration_read_back(real_data_dir, tmp_path, pair):
    # measured: slide 0.60 / 0.46 / 0.25 cm, penetration 0.42 / 0.41 / 0.14 cm (inputs 0.91 / 1.92 / 2.25 cm)
    kw = {}
    if pair == "sie punches":
        a = datasets.load(str(real_data_dir / "kicks_punches/deepmimic_sie_humanoid3d_punch_forward00.txt"))
        b = datasets.load(str(real_data_dir / "kicks_punches/deepmimic_sie_humanoid3d_punch_forward02.txt"))
    elif pair == "wushu constrained":
        (a, b), kw = _wushu(real_data_dir), {"on_facing": "constrain"}
    else:
        cw = datasets.load(str(real_data_dir / "cartwheels/sfu_0007_Cartwheel001.bvh"))
        f = lambda s: int(round(s * cw.fps))                                   # noqa: E731
        a, b = cw[f(2.2):f(4.85)], cw[f(10.9):f(13.8)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = concatenate(a, b, **kw)
    rep = audit(_read_back(r.motion, tmp_path, "ours"), against=a)
    assert foot_slide(rep) <= 0.01
    assert rep.measure("max_penetration_m") <= 0.005
    assert not [f for f in rep.violations if f.check == "floor_penetration"]
