"""The synthetic performer's skeleton: CMU/cgspeed names and hierarchy, proportions, rest pose."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.body import BodyModel
from mocomp.io import read_bvh
from mocomp.io.bvh import format_bvh, parse_bvh
from mocomp.core import Motion
from mocomp.synth.skeleton import JOINT_NAMES, synthetic_skeleton


def test_31_cmu_joints_in_cgspeed_order():
    sk = synthetic_skeleton(1.75)
    assert sk.n_joints == 31
    assert sk.names[:6] == ("Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase")
    for name in ("RightToeBase", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head", "LeftShoulder",
                 "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase", "LeftHandIndex1", "LThumb", "RThumb",
                 "RightHandIndex1"):
        assert name in sk
    assert sk.names[sk.parents[sk.index("LThumb")]] == "LeftHand"
    assert sk.names[sk.parents[sk.index("Neck")]] == "Spine1"
    assert sk.names[sk.parents[sk.index("RightShoulder")]] == "Spine1"
    # cgspeed zero-length carrier joints
    for name in ("LHipJoint", "LowerBack", "Neck", "LeftShoulder", "LeftFingerBase", "LThumb"):
        assert np.allclose(sk.offsets[sk.index(name)], 0)
    assert {e.name for e in sk.end_sites} == {"LeftToeBase_end", "RightToeBase_end", "Head_end",
                                              "LeftHandIndex1_end", "LThumb_end", "RightHandIndex1_end",
                                              "RThumb_end"}


def test_matches_real_cgspeed_hierarchy(real_data_dir):
    real = read_bvh(real_data_dir / "flips" / "cmu_88_01_backflip.bvh", scale="cmu", fps=60.0)
    sk = synthetic_skeleton(1.75)
    assert real.skeleton.names == sk.names
    assert np.array_equal(real.skeleton.parents, sk.parents)
    assert len(real.skeleton.end_sites) == len(sk.end_sites)


@pytest.mark.parametrize("H", [1.5, 1.75, 2.0])
def test_stands_on_the_floor_and_scales_with_height(H):
    sk = synthetic_skeleton(H)
    p = sk.rest_positions(include_end_sites=True)
    head_end = p[sk.n_joints + [e.name for e in sk.end_sites].index("Head_end")]
    assert head_end[1] == pytest.approx(H, abs=1e-12)         # vertex at H
    assert p[:, 1].min() == pytest.approx(0.008 * H, abs=1e-12)  # toe tips just above the sole
    assert sk.height() == pytest.approx(0.992 * H, abs=1e-12)
    assert np.allclose(synthetic_skeleton(H).offsets, synthetic_skeleton(1.0).offsets * H)
    # facing +z, left on +x, legs vertical
    assert p[sk.index("LeftUpLeg"), 0] > 0 and p[sk.index("RightUpLeg"), 0] < 0
    assert p[sk.index("LeftToeBase"), 2] > p[sk.index("LeftFoot"), 2]
    assert np.allclose(p[sk.index("LeftUpLeg"), [0, 2]], p[sk.index("LeftFoot"), [0, 2]])


def test_left_right_mirror_symmetric():
    sk = synthetic_skeleton(1.75)
    mm = sk.mirror_map()
    assert sk.names[mm[sk.index("LHipJoint")]] == "RHipJoint"
    assert sk.names[mm[sk.index("LThumb")]] == "RThumb"
    assert np.allclose(sk.offsets[mm] * [-1, 1, 1], sk.offsets)


def test_invalid_height():
    with pytest.raises(ValueError, match="height"):
        synthetic_skeleton(0.1)
    with pytest.raises(ValueError):
        synthetic_skeleton(float("nan"))


def test_body_model_maps_every_mass_bearing_bone():
    sk = synthetic_skeleton(1.75)
    body = BodyModel.from_skeleton(sk, 70.0)
    assert body.total_mass == pytest.approx(70.0)
    assert body.n_segments == 16
    assert set(body.massless_joints) == {"LHipJoint", "RHipJoint", "LeftToeBase", "RightToeBase", "Spine1", "Neck",
                                         "Neck1", "LeftShoulder", "RightShoulder", "LeftFingerBase",
                                         "RightFingerBase", "LeftHandIndex1", "RightHandIndex1", "LThumb", "RThumb"}
    # standing with the arms down, the whole-body COM sits at 55-58 % of stature, as for real adults
    from mocomp.dynamics import center_of_mass
    from mocomp.synth.poses import pose
    from mocomp.core.rotations import quat_exp as exp_quat

    stand = Motion(sk, 120.0, sk.offsets[:1], exp_quat(pose(sk))[None])
    com = center_of_mass(body, stand)[0]
    assert 0.55 * 1.75 < com[1] < 0.58 * 1.75
    assert abs(com[0]) < 1e-12


def test_bvh_round_trip():
    sk = synthetic_skeleton(1.8)
    rng = np.random.default_rng(0)
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_rotvec(rng.normal(0, 0.3, (4 * 31, 3))).as_quat().reshape(4, 31, 4)
    m = Motion(sk, 120.0, np.array([[0, 1.0, 0]] * 4) + rng.normal(0, 0.1, (4, 3)), rot)
    back = parse_bvh(format_bvh(m), scale=1.0)
    assert back.skeleton.names == JOINT_NAMES
    assert np.allclose(back.skeleton.offsets, sk.offsets, atol=1e-5)
    assert np.allclose(back.positions, m.positions, atol=1e-4)
