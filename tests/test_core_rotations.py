"""Quaternion helpers of mocomp.core.rotations against scipy's Rotation (the reference)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from mocomp.core import slerp
from mocomp.core.rotations import (
    euler_sequence,
    euler_to_quat,
    make_continuous,
    quat_angle,
    quat_apply,
    quat_identity,
    quat_inverse,
    quat_multiply,
    swing_twist,
)

TAIT_BRYAN = ["".join(p) for p in itertools.permutations("XYZ")]
PROPER = [a + b + a for a in "XYZ" for b in "XYZ" if a != b]
ALL_12 = TAIT_BRYAN + PROPER


def same_rotation(q1, q2, atol=1e-12):
    """Quaternions equal up to sign, per element."""
    q1, q2 = np.broadcast_arrays(np.asarray(q1, float), np.asarray(q2, float))
    d = np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))
    return np.all(d < atol)


@pytest.fixture(scope="module")
def rots():
    return Rotation.random(500, random_state=7)


def test_multiply_matches_scipy(rots):
    a = rots.as_quat()
    b = Rotation.random(500, random_state=8).as_quat()
    ours = quat_multiply(a, b)
    ref = (Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()
    assert same_rotation(ours, ref)
    # not canonicalised: the Hamilton product of the given signs, so (-a) b = -(a b)
    np.testing.assert_allclose(quat_multiply(-a, b), -ours, atol=1e-15)


def test_multiply_broadcasts_and_is_not_commutative(rots):
    a = rots.as_quat()[:5]
    b = rots.as_quat()[5:12]
    out = quat_multiply(a[:, None], b[None, :])
    assert out.shape == (5, 7, 4)
    ref = (Rotation.from_quat(np.repeat(a, 7, 0)) * Rotation.from_quat(np.tile(b, (5, 1)))).as_quat()
    assert same_rotation(out.reshape(-1, 4), ref)
    assert not same_rotation(quat_multiply(a[0], b[0]), quat_multiply(b[0], a[0]), atol=1e-6)


def test_apply_matches_scipy(rots):
    v = np.random.default_rng(0).normal(size=(500, 3))
    np.testing.assert_allclose(quat_apply(rots.as_quat(), v), rots.apply(v), atol=1e-13)
    # one rotation, many vectors and many rotations, one vector
    np.testing.assert_allclose(quat_apply(rots.as_quat()[0], v), rots[0].apply(v), atol=1e-13)
    np.testing.assert_allclose(quat_apply(rots.as_quat(), v[0]), rots.apply(v[0]), atol=1e-13)
    # sign of the quaternion does not matter
    np.testing.assert_allclose(quat_apply(-rots.as_quat(), v), rots.apply(v), atol=1e-13)


def test_inverse_matches_scipy(rots):
    q = rots.as_quat()
    assert same_rotation(quat_inverse(q), rots.inv().as_quat())
    assert same_rotation(quat_multiply(q, quat_inverse(q)), quat_identity((500,)))
    q_copy = q.copy()
    quat_inverse(q)
    np.testing.assert_array_equal(q, q_copy)  # input untouched


def test_angle_matches_scipy(rots):
    q = rots.as_quat()
    np.testing.assert_allclose(quat_angle(q), rots.magnitude(), atol=1e-12)
    np.testing.assert_allclose(quat_angle(-q), rots.magnitude(), atol=1e-12)
    assert quat_angle(quat_identity()) == 0.0


@pytest.mark.parametrize("seq", ALL_12 + [s.lower() for s in ALL_12])
def test_euler_to_quat_all_sequences(seq):
    rng = np.random.default_rng([ord(c) for c in seq])  # deterministic per sequence
    ang = rng.uniform(-180, 180, size=(300, 3))
    if seq.upper() in PROPER:
        ang[:, 1] = rng.uniform(0, 180, size=300)
    else:
        ang[:, 1] = rng.uniform(-90, 90, size=300)
    # gimbal-ish rows: middle angle at (or a hair from) the singular value
    sing = 0.0 if seq.upper() in PROPER else 90.0
    ang[:6, 1] = [sing, -sing if sing else 180.0, sing - 1e-7, sing + 1e-9, sing, 180.0 if sing == 0 else -90.0]
    ours = euler_to_quat(seq, ang, degrees=True)
    ref = Rotation.from_euler(seq, ang, degrees=True).as_quat()
    assert same_rotation(ours, ref, atol=1e-12)
    # radians
    assert same_rotation(euler_to_quat(seq, np.deg2rad(ang), degrees=False), ref, atol=1e-12)


def test_euler_to_quat_fewer_axes_and_errors():
    ang = np.array([[30.0, -40.0], [170.0, 5.0]])
    assert same_rotation(euler_to_quat("ZX", ang), Rotation.from_euler("ZX", ang, degrees=True).as_quat())
    assert same_rotation(euler_to_quat("y", ang[:, :1]), Rotation.from_euler("y", ang[:, :1], degrees=True).as_quat())
    for bad in ("XXY", "XyZ", "ABC", "XYZX", ""):
        with pytest.raises(ValueError):
            euler_to_quat(bad, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="last angle axis"):
        euler_to_quat("XYZ", np.zeros((2, 2)))


def test_euler_sequence_from_bvh_channels():
    assert euler_sequence(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")) == "ZXY"
    assert euler_sequence(["Yrotation", "Xrotation", "Zrotation"]) == "YXZ"
    # BVH order is intrinsic: R = Rz Rx Ry for "Zrotation Xrotation Yrotation"
    z, x, y = 30.0, -50.0, 75.0
    Rz, Rx, Ry = (Rotation.from_euler(a, v, degrees=True) for a, v in (("z", z), ("x", x), ("y", y)))
    assert same_rotation(euler_to_quat("ZXY", [z, x, y]), (Rz * Rx * Ry).as_quat())


def test_swing_twist_reconstructs_and_twist_is_about_axis(rots):
    rng = np.random.default_rng(3)
    q = rots.as_quat()
    for axis in (np.array([0.0, 1.0, 0.0]), rng.normal(size=3), rng.normal(size=(500, 3))):
        swing, twist = swing_twist(q, axis)
        assert same_rotation(quat_multiply(swing, twist), q, atol=1e-12)
        a = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
        # twist's rotation axis is parallel to the axis: its vector part has no perpendicular part
        tv = twist[..., :3]
        perp = tv - np.sum(tv * a, axis=-1, keepdims=True) * a
        assert np.abs(perp).max() < 1e-12
        # swing's rotation axis is perpendicular to the axis
        assert np.abs(np.sum(swing[..., :3] * a, axis=-1)).max() < 1e-12
        # swing maps the axis exactly as q does (the twist leaves it fixed)
        np.testing.assert_allclose(quat_apply(swing, a), quat_apply(q, a), atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(twist, axis=-1), 1.0, atol=1e-12)


def test_swing_twist_known_answer_and_degenerate():
    # 40 deg about y, then 30 deg about x in the parent frame: q = Rx(30) Ry(40)
    q = (Rotation.from_euler("x", 30, degrees=True) * Rotation.from_euler("y", 40, degrees=True)).as_quat()
    swing, twist = swing_twist(q, [0, 1, 0])
    assert same_rotation(twist, Rotation.from_euler("y", 40, degrees=True).as_quat())
    assert same_rotation(swing, Rotation.from_euler("x", 30, degrees=True).as_quat())
    # 180 deg about an axis perpendicular to the twist axis: twist is the identity
    q180 = Rotation.from_rotvec([np.pi, 0, 0]).as_quat()
    swing, twist = swing_twist(q180, [0, 1, 0])
    assert same_rotation(twist, quat_identity())
    assert same_rotation(swing, q180)


def test_slerp_matches_scipy_slerp(rots):
    q0 = rots.as_quat()[:200]
    q1 = rots.as_quat()[200:400]
    t = np.random.default_rng(1).uniform(0, 1, 200)
    ours = slerp(q0, q1, t)
    ref = np.array([Slerp([0, 1], Rotation.from_quat([a, b]))([tt]).as_quat()[0] for a, b, tt in zip(q0, q1, t)])
    assert same_rotation(ours, ref, atol=1e-10)
    # ends: exact rotations; short way regardless of the sign of q1
    assert same_rotation(slerp(q0, q1, np.zeros(200)), q0)
    assert same_rotation(slerp(q0, q1, np.ones(200)), q1)
    assert same_rotation(slerp(q0, -q1, t), ours, atol=1e-12)


def test_slerp_constant_angular_speed_and_tiny_angles():
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q0 = Rotation.from_rotvec(0.2 * axis).as_quat()
    q1 = Rotation.from_rotvec(2.9 * axis).as_quat()
    t = np.linspace(0, 1, 11)
    out = slerp(q0[None], q1[None], t)
    np.testing.assert_allclose(Rotation.from_quat(out).as_rotvec(), np.outer(0.2 + 2.7 * t, axis), atol=1e-12)
    # nearly identical quaternions: no division blow-up, unit, between the two
    q2 = Rotation.from_rotvec(0.2 * axis + 1e-12).as_quat()
    mid = slerp(q0, q2, 0.5)
    assert np.all(np.isfinite(mid)) and abs(np.linalg.norm(mid) - 1) < 1e-15
    assert same_rotation(mid, q0, atol=1e-11)


def test_make_continuous_removes_sign_flips(rots):
    # a smooth path with random sign flips
    q = Rotation.from_rotvec(np.outer(np.linspace(0, 6, 400), [0, 1, 0])).as_quat()
    signs = np.where(np.random.default_rng(2).uniform(size=400) < 0.3, -1.0, 1.0)
    flipped = q * signs[:, None]
    fixed = make_continuous(flipped)
    assert same_rotation(fixed, q)
    assert np.all(np.sum(fixed[1:] * fixed[:-1], axis=-1) > 0)
    # first sample keeps its sign; other axes
    np.testing.assert_array_equal(fixed[0], flipped[0])
    stacked = np.stack([flipped, flipped], axis=1)  # (T, 2, 4), time on axis 0
    np.testing.assert_allclose(make_continuous(stacked, axis=0)[:, 1], fixed)
    np.testing.assert_allclose(make_continuous(np.swapaxes(stacked, 0, 1), axis=1)[1], fixed)


def test_quat_from_matrix_matches_scipy_and_inverts_quat_matrix(rots):
    """Random rotations plus the branch cases of Shepperd's method (identity, half turns about each
    axis, where w = 0 and one of x, y, z carries the square root) and a near-half-turn: the same
    rotation as scipy's from_matrix, w >= 0, unit norm, and quat_matrix of it gives R back."""
    from mocomp.core.rotations import quat_from_matrix, quat_matrix

    extra = Rotation.from_rotvec([[0, 0, 0], [np.pi, 0, 0], [0, np.pi, 0], [0, 0, np.pi], [2.0, -1.0, 0.5],
                                  [np.pi - 1e-9, 0, 0], [0, 3.1, 0.2]])
    R = np.concatenate([rots.as_matrix(), extra.as_matrix()]).reshape(-1, 3, 3)
    q = quat_from_matrix(R)
    assert q.shape == (len(R), 4)
    assert same_rotation(q, Rotation.from_matrix(R).as_quat(), atol=1e-12)
    assert np.all(q[:, 3] >= 0) and np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(quat_matrix(q), R, atol=1e-14)
    np.testing.assert_allclose(quat_from_matrix(R[None]), q[None], atol=0)
    with pytest.raises(ValueError, match=r"\(\.\.\., 3, 3\)"):
        quat_from_matrix(np.eye(4))


def test_axis_quat_and_twist_angle_against_scipy():
    """axis_quat(axis, a) is scipy's rotation by a about axis; twist_angle recovers a from
    axis_quat(axis, a) times any rotation about a perpendicular axis (the swing), either side."""
    from mocomp.core.rotations import axis_quat, twist_angle

    rng = np.random.default_rng(5)
    axis = rng.normal(size=3)
    u = axis / np.linalg.norm(axis)
    a = rng.uniform(-3.0, 3.0, size=50)
    q = axis_quat(3.0 * axis, a)                                   # the axis is normalised
    ref = Rotation.from_rotvec(a[:, None] * u).as_quat()
    np.testing.assert_allclose(q, ref * np.sign(ref[:, 3:] * q[:, 3:]), atol=1e-14)
    perp = np.cross(u, rng.normal(size=(50, 3)))
    swing = Rotation.from_rotvec(perp / np.linalg.norm(perp, axis=1, keepdims=True)
                                 * rng.uniform(0.0, 2.5, size=(50, 1))).as_quat()
    from mocomp.core.rotations import quat_multiply

    np.testing.assert_allclose(twist_angle(quat_multiply(q, swing), u), a, atol=1e-12)
    np.testing.assert_allclose(twist_angle(quat_multiply(swing, q), u), a, atol=1e-12)
