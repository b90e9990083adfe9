"""Similarity measure of the flips method (dissertation eq. 5.12-5.13, flips paper App. A)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import Skeleton
from mocomp.flips.similarity import (DEFAULT_CLASS_WEIGHTS, alignment_angle, axis_quat, classify_joint,
                                     frame_distance, local_angular_velocities, similarity_weights, twist_angle)

from _flips_data import skeleton, spinning_motion

CMU = ("Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "LowerBack", "Spine", "Spine1",
       "Neck", "Head", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand")
MAX3DS = ("Hips", "LeftHip", "LeftKnee", "LeftAnkle", "Chest", "Chest2", "LeftCollar", "LeftShoulder",
          "LeftElbow", "LeftWrist", "Neck", "Head")
DEEPMIMIC = ("root", "chest", "neck", "right_hip", "right_knee", "right_ankle", "right_shoulder", "right_elbow",
             "right_wrist")
ASF = ("root", "lhipjoint", "lfemur", "ltibia", "lfoot", "lowerback", "upperback", "thorax", "lclavicle",
       "lhumerus", "lradius", "lwrist")


@pytest.mark.parametrize("names, expected", [
    (CMU, {"LeftUpLeg": "thigh", "LeftLeg": "knee", "LeftShoulder": "other", "LeftArm": "shoulder",
           "LeftForeArm": "elbow", "Spine": "trunk", "LowerBack": "trunk", "LHipJoint": "other", "Head": "other"}),
    (MAX3DS, {"LeftHip": "thigh", "LeftKnee": "knee", "LeftCollar": "other", "LeftShoulder": "shoulder",
              "LeftElbow": "elbow", "Chest": "trunk"}),
    (DEEPMIMIC, {"right_hip": "thigh", "right_knee": "knee", "right_shoulder": "shoulder", "right_elbow": "elbow",
                 "chest": "trunk", "neck": "other"}),
    (ASF, {"lfemur": "thigh", "ltibia": "knee", "lhumerus": "shoulder", "lradius": "elbow", "lclavicle": "other",
           "lhipjoint": "other", "upperback": "trunk", "thorax": "trunk"}),
])
def test_joint_classes_follow_naming_conventions(names, expected):
    for name, cls in expected.items():
        assert classify_joint(name, names) == cls, name
    assert classify_joint(names[0], names, is_root=True) == "root"


def test_weights_are_the_papers_and_overridable():
    sk = skeleton()
    w = similarity_weights(sk)
    assert w.root == 2.0
    assert w.joints[sk.index("LeftUpLeg")] == 0.7 and w.joints[sk.index("LeftLeg")] == 0.5
    assert w.joints[sk.index("LeftArm")] == 0.3 and w.joints[sk.index("LeftForeArm")] == 0.1
    assert w.joints[sk.index("Spine")] == 0.7 and w.joints[sk.index("Head")] == 0.0
    assert w.joints[0] == 0.0
    w2 = similarity_weights(sk, overrides={"Head": 0.2, "root": 1.0})
    assert w2.joints[sk.index("Head")] == 0.2 and w2.root == 1.0
    with pytest.raises(KeyError):
        similarity_weights(sk, overrides={"NoSuchJoint": 1.0})
    with pytest.raises(ValueError):
        similarity_weights(sk, overrides={"Spine": -1.0})
    assert set(w.table()["class"]) <= set(DEFAULT_CLASS_WEIGHTS)


def test_twist_and_alignment_angle_known_answers():
    axis = np.array([0.3, -0.2, 0.9])
    axis /= np.linalg.norm(axis)
    rng = np.random.default_rng(1)
    q1 = Rotation.random(50, random_state=2).as_quat()
    phi = rng.uniform(-3.0, 3.0, 50)
    q2 = Rotation.from_rotvec(phi[:, None] * axis).as_quat()
    # a pure rotation about the axis has that twist
    np.testing.assert_allclose(twist_angle(q2, axis), phi, atol=1e-12)
    # eq. 5.12: q2 = R(phi) q1 exactly -> phi recovered, D's root term vanishes
    q2b = (Rotation.from_rotvec(phi[:, None] * axis) * Rotation.from_quat(q1)).as_quat()
    np.testing.assert_allclose(alignment_angle(q1, q2b, axis), phi, atol=1e-10)
    # sign of the quaternion does not matter
    np.testing.assert_allclose(alignment_angle(-q1, q2b, axis), phi, atol=1e-10)


def test_distance_is_zero_for_a_frame_rotated_about_L_and_sums_weighted_angles():
    m = spinning_motion()
    sk = m.skeleton
    w = similarity_weights(sk)
    axis = np.array([1.0, 0, 0])
    f1 = np.array(m.rotations[80])
    f2 = f1.copy()
    f2[0] = (Rotation.from_rotvec([1.1, 0, 0]) * Rotation.from_quat(f1[0])).as_quat()
    D, phi = frame_distance(f1, f2, axis, w)
    assert D == pytest.approx(0.0, abs=1e-9) and phi == pytest.approx(1.1, abs=1e-9)
    # bend the left knee by 0.2 rad and tilt the root by 0.1 rad about z (perpendicular to L)
    f3 = f2.copy()
    kn = sk.index("LeftLeg")
    f3[kn] = (Rotation.from_quat(f3[kn]) * Rotation.from_rotvec([0.2, 0, 0])).as_quat()
    f3[0] = (Rotation.from_rotvec([0, 0, 0.1]) * Rotation.from_quat(f3[0])).as_quat()
    D3, _ = frame_distance(f1, f3, axis, w)
    # the root tilt about z changes the twist about x only at second order
    assert D3 == pytest.approx(0.5 * 0.2 + 2.0 * 0.1, rel=2e-2)
    # vectorised over pairs
    Ds, _ = frame_distance(np.stack([f1, f1]), np.stack([f2, f3]), axis, w)
    np.testing.assert_allclose(Ds, [D, D3])


def test_velocity_term_of_the_conference_variant():
    m = spinning_motion()
    axis = np.array([1.0, 0, 0])
    om = local_angular_velocities(m.rotations, m.fps)
    # root spins at 2 pi * 1.2 rad/s about +x inside the flight
    np.testing.assert_allclose(om[80, 0], [2 * np.pi * 1.2, 0, 0], atol=1e-6)
    w0 = similarity_weights(m.skeleton)
    wv = similarity_weights(m.skeleton, velocity_weight=0.1)
    D0, _ = frame_distance(m.rotations[70], m.rotations[82], axis, w0)
    Dv, _ = frame_distance(m.rotations[70], m.rotations[82], axis, wv, om[70], om[82])
    assert Dv > D0
    with pytest.raises(ValueError):
        frame_distance(m.rotations[70], m.rotations[82], axis, wv)


def test_axis_quat_matches_scipy():
    axis = np.array([0.0, 0.6, 0.8])
    q = axis_quat(axis, np.array([0.3, -2.0]))
    np.testing.assert_allclose(q, Rotation.from_rotvec(np.outer([0.3, -2.0], axis)).as_quat(), atol=1e-12)


def test_velocity_variant_in_the_loop_search_thresholds_the_pose_part():
    """With the conference paper's angular-velocity term the pairs are ranked by the full
    distance, but "similar" (eq. 5.9's threshold, degrees) is judged on the pose part."""
    from mocomp.flips import prepare

    from _flips_data import synthetic

    m = synthetic("sideflip").motion
    P0 = prepare(m)
    Pv = prepare(m, velocity_weight=0.05)
    assert Pv.loop.found and Pv.omegas is not None
    D_pose, _ = frame_distance(Pv.rotations[Pv.loop.m], Pv.rotations[Pv.loop.n], Pv.axis,
                               similarity_weights(m.skeleton))
    wsum = Pv.weights.root + Pv.weights.joints.sum()
    assert Pv.loop.mean_angle_deg == pytest.approx(np.degrees(D_pose / wsum))
    assert Pv.loop.distance > D_pose                       # the velocity term is in the ranking distance
    assert abs(Pv.loop.period - P0.loop.period) <= 6
