"""The edit presets' effect on the body (issue 5, section 1; dissertation Figs. 5.9-5.10):
measured on joint positions, at the middle of the edited span where the layers hold full weight."""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from mocomp import datasets
from mocomp.edit import apply_preset


@lru_cache(maxsize=None)
def clip(name):
    if name.startswith("cmu_"):
        from mocomp.flips.preprocess import prepare_cached

        p = prepare_cached(name, estimate=False)
        return p.motion, p.flight
    r = datasets.load_example(name)
    return r.motion, r.flight


def _angle(u, v):
    u = u / np.linalg.norm(u)
    v = v / np.linalg.norm(v)
    return float(np.degrees(np.arccos(np.clip(u @ v, -1.0, 1.0))))


def body_angles(motion, f):
    """Knee and elbow flexion (0 = straight), upper arm and thigh against the trunk axis (deg);
    the lateral direction from the right shoulder to the left one."""
    j = {n: i for i, n in enumerate(motion.skeleton.names)}
    P = motion.positions[f]
    up = P[j["Neck"]] - P[j["Hips"]]
    lat = P[j["LeftArm"]] - P[j["RightArm"]]
    out = {"lateral": lat}
    for s in ("Left", "Right"):
        out[f"knee_{s}"] = _angle(P[j[s + "Leg"]] - P[j[s + "UpLeg"]], P[j[s + "Foot"]] - P[j[s + "Leg"]])
        out[f"thigh_{s}"] = _angle(P[j[s + "Leg"]] - P[j[s + "UpLeg"]], -up)
        arm = P[j[s + "ForeArm"]] - P[j[s + "Arm"]]
        out[f"upper_arm_{s}"] = _angle(arm, up)
        out[f"arm_lat_{s}"] = _angle(arm, lat if s == "Left" else -lat)
        out[f"elbow_{s}"] = _angle(arm, P[j[s + "Hand"]] - P[j[s + "ForeArm"]])
    return out



@pytest.mark.parametrize("name", ["backflip", "sideflip", "cmu_88_01_backflip"])
def test_straight_legs_straightens_tucked_knees_along_the_trunk(name, request):
    if name.startswith("cmu_"):
        request.getfixturevalue("real_data_dir")
    m, fl = clip(name)
    ed, plan = apply_preset(m, fl, "straight-legs")
    f = (plan.start + plan.stop) // 2
    b0, b1 = body_angles(m, f), body_angles(ed, f)
    for s in ("Left", "Right"):
        assert b0[f"knee_{s}"] > 120.0                  # tucked: ~130 deg (synthetic), 125-126 (CMU 88_01)
        assert b1[f"knee_{s}"] < 1.0                    # straight
        assert b0[f"thigh_{s}"] > 130.0                 # thighs folded up against the chest ...
        assert b1[f"thigh_{s}"] < 25.0                  # ... now along the trunk (18-21 deg from neck-hips)
        assert b1[f"upper_arm_{s}"] == pytest.approx(b0[f"upper_arm_{s}"], abs=1e-6)   # arms untouched
    # outside the edited span nothing changes
    np.testing.assert_array_equal(ed.rotations[:plan.start], m.rotations[:plan.start])
    np.testing.assert_array_equal(ed.rotations[plan.stop:], m.rotations[plan.stop:])


@pytest.mark.parametrize("up_side", ["l", "r"])
@pytest.mark.parametrize("name", ["backflip", "cmu_88_01_backflip"])
def test_arms_twist_raises_one_arm_along_the_trunk_and_the_other_sideways(name, up_side, request):
    if name.startswith("cmu_"):
        request.getfixturevalue("real_data_dir")
    m, fl = clip(name)
    ed, plan = apply_preset(m, fl, "arms-twist", up_side=up_side)
    f = (plan.start + plan.stop) // 2
    b0, b1 = body_angles(m, f), body_angles(ed, f)
    up, side = ("Left", "Right") if up_side == "l" else ("Right", "Left")
    assert b1[f"upper_arm_{up}"] < 10.0                 # above the head, along the trunk axis (3.8-5.5)
    assert abs(b1[f"upper_arm_{side}"] - 90.0) < 5.0     # out to the side ...
    assert b1[f"arm_lat_{side}"] < 10.0                 # ... along the shoulder line, outwards
    assert b1[f"elbow_{up}"] < 1.0 and b1[f"elbow_{side}"] < 1.0
    assert b0[f"elbow_{up}"] > 50.0                     # the input's arms were bent
    for s in ("Left", "Right"):
        assert b1[f"knee_{s}"] == pytest.approx(b0[f"knee_{s}"], abs=1e-6)   # legs untouched


def test_arms_out_extends_both_arms_sideways_symmetrically():
    m, fl = clip("backflip")
    ed, plan = apply_preset(m, fl, "arms-out")
    f = (plan.start + plan.stop) // 2
    b1 = body_angles(ed, f)
    for s in ("Left", "Right"):
        assert abs(b1[f"upper_arm_{s}"] - 90.0) < 5.0 and b1[f"arm_lat_{s}"] < 10.0 and b1[f"elbow_{s}"] < 1.0
    # both arms out changes |L| (inertia) but, symmetric, not its direction (Fig. 5.9's kind of edit)
    from mocomp.edit import restore_momentum

    r = datasets.load_example("backflip")
    res = restore_momentum(r.body, r.motion, ed, r.flight, L_star=r.L0)
    assert res.stages["edited"].max_magnitude > 0.1
    assert res.stages["edited"].max_direction < 1e-3
    assert res.stages["final"].max_magnitude < 0.05


def test_unknown_preset_and_side_are_refused():
    m, fl = clip("backflip")
    with pytest.raises(ValueError, match="unknown edit preset 'pike'"):
        apply_preset(m, fl, "pike")
    with pytest.raises(ValueError, match="up_side must be 'l' or 'r'"):
        apply_preset(m, fl, "arms-twist", up_side="x")
