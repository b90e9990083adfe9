"""Forward kinematics: a hand-computed chain, and agreement with a per-joint scipy loop."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import EndSite, Motion, Skeleton, end_site_positions, forward_kinematics


def _q(axis: str, deg: float) -> np.ndarray:
    return Rotation.from_euler(axis, deg, degrees=True).as_quat()


def test_three_joint_chain_by_hand():
    """Root at (1,2,3) turned +90 deg about y; joint 1 (offset +y) turned +90 deg about z;
    joint 2 (offset +x) turned +90 deg about x; an end site at +z on joint 2.

    By hand: P1 = P0 + Ry(0,1,0) = (1,3,3); G1 = Ry Rz; G1 (1,0,0) = Ry (0,1,0) = (0,1,0), so
    P2 = (1,4,3); G2 = Ry Rz Rx; Rx (0,0,1) = (0,-1,0), Rz -> (1,0,0), Ry -> (0,0,-1), so the
    end site is at (1,4,2).
    """
    sk = Skeleton(("root", "a", "b"), [-1, 0, 1], [[0, 0, 0], [0, 1, 0], [1, 0, 0]],
                  end_sites=(EndSite(2, [0, 0, 1], "b_end"),))
    rot = np.stack([_q("y", 90), _q("z", 90), _q("x", 90)])[None]
    P, G = forward_kinematics(sk.parents, sk.offsets, np.array([[1.0, 2.0, 3.0]]), rot)
    np.testing.assert_allclose(P[0], [[1, 2, 3], [1, 3, 3], [1, 4, 3]], atol=1e-15)
    # G2 = Ry(90) * Rz(90) * Rx(90) (intrinsic Y-Z-X)
    expected_G2 = Rotation.from_euler("YZX", [90, 90, 90], degrees=True)
    assert (Rotation.from_quat(G[0, 2]) * expected_G2.inv()).magnitude() < 1e-12
    E = end_site_positions(sk.end_sites, P, G)
    np.testing.assert_allclose(E[0, 0], [1, 4, 2], atol=1e-15)
    m = Motion(sk, 30, [[1.0, 2.0, 3.0]], rot)
    np.testing.assert_allclose(m.end_site_positions(), E, atol=0)
    np.testing.assert_allclose(m.joint_positions("b"), [[1, 4, 3]], atol=1e-15)


def _branching_skeleton(rng):
    parents = [-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 9, 8, 11, 8, 13]
    return Skeleton([f"j{i}" for i in range(len(parents))], parents, rng.normal(size=(len(parents), 3)) * 0.2)


def test_fk_matches_naive_scipy_loop():
    rng = np.random.default_rng(5)
    sk = _branching_skeleton(rng)
    T, J = 50, sk.n_joints
    rot = Rotation.random(T * J, random_state=9).as_quat().reshape(T, J, 4)
    rp = rng.normal(size=(T, 3))
    P, G = forward_kinematics(sk.parents, sk.offsets, rp, rot)
    for t in range(0, T, 7):
        glob = [Rotation.from_quat(rot[t, 0])]
        pos = [rp[t]]
        for j in range(1, J):
            p = sk.parents[j]
            glob.append(glob[p] * Rotation.from_quat(rot[t, j]))
            pos.append(pos[p] + glob[p].apply(np.array(sk.offsets[j])))  # copy: scipy rejects read-only buffers
        np.testing.assert_allclose(P[t], np.array(pos), atol=1e-13)
        for j in range(J):
            assert (glob[j] * Rotation.from_quat(G[t, j]).inv()).magnitude() < 1e-12


def test_fk_identity_rotations_give_rest_pose_and_bone_lengths_are_kept():
    rng = np.random.default_rng(6)
    sk = _branching_skeleton(rng)
    T = 4
    ident = np.tile([0.0, 0.0, 0.0, 1.0], (T, sk.n_joints, 1))
    rp = np.tile(sk.offsets[0], (T, 1))
    P, _ = forward_kinematics(sk.parents, sk.offsets, rp, ident)
    np.testing.assert_allclose(P[2], sk.rest_positions(), atol=1e-15)
    rot = Rotation.random(T * sk.n_joints, random_state=3).as_quat().reshape(T, sk.n_joints, 4)
    P, _ = forward_kinematics(sk.parents, sk.offsets, rp, rot)
    lengths = np.linalg.norm(P[:, 1:] - P[:, sk.parents[1:]], axis=-1)
    np.testing.assert_allclose(lengths, np.broadcast_to(sk.bone_lengths()[1:], lengths.shape), atol=1e-14)


def test_fk_does_not_touch_inputs_and_motion_caches_read_only_results():
    rng = np.random.default_rng(1)
    sk = _branching_skeleton(rng)
    rot = Rotation.random(3 * sk.n_joints, random_state=1).as_quat().reshape(3, sk.n_joints, 4)
    rp = rng.normal(size=(3, 3))
    rot0, rp0 = rot.copy(), rp.copy()
    forward_kinematics(sk.parents, sk.offsets, rp, rot)
    np.testing.assert_array_equal(rot, rot0)
    np.testing.assert_array_equal(rp, rp0)
    m = Motion(sk, 10, rp, rot)
    assert m.positions is m.positions
    assert m.positions.flags.c_contiguous and m.global_rotations.flags.c_contiguous
    with pytest.raises(ValueError):
        m.positions[0, 0, 0] = 1.0
    P, G = m.fk()
    assert P is m.positions and G is m.global_rotations


def test_end_sites_none():
    sk = Skeleton(("r",), [-1], [[0, 0, 0]])
    m = Motion(sk, 10, np.zeros((5, 3)), np.tile([0, 0, 0, 1.0], (5, 1, 1)))
    assert m.end_site_positions().shape == (5, 0, 3)
