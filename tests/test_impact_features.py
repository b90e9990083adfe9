"""mocomp.impact.features: the 16 body parts of the impact search (dissertation sec. 4.1, Table A.1)."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.dynamics.com import center_of_mass, segment_positions
from mocomp.impact.features import (BODY_PARTS, TABLE_A1, body_features, body_model_for, ground_frame_features,
                                    part_weights)
from mocomp.ops.align import yaw_quaternion
from mocomp.ops.synthetic import synthetic_walk


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration=1.5, fps=30.0).motion


def test_table_a1_weights_and_support_foot():
    wp, wr = part_weights()
    assert len(BODY_PARTS) == 16 and set(BODY_PARTS) == set(TABLE_A1)
    # Table A.1: trunk parts 1.0 / 0.10, upper arms and thighs 0.5 / 0.05, forearms and shanks 0.2 / 0.02,
    # head, hands, feet 0.1 / 0.01
    np.testing.assert_allclose(wp.sum(), 3 * 1.0 + 4 * 0.5 + 4 * 0.2 + 5 * 0.1, rtol=1e-12)
    np.testing.assert_allclose(wr, wp / 10, rtol=1e-12)
    wl, rl = part_weights("left")
    k = BODY_PARTS.index("foot_l")
    assert (wl[k], rl[k]) == (1.0, 0.10)
    assert wl[BODY_PARTS.index("foot_r")] == 0.1
    np.testing.assert_allclose(np.delete(wl, k), np.delete(wp, k))
    wb, _ = part_weights("both")
    assert wb[BODY_PARTS.index("foot_r")] == 1.0 == wb[k]
    with pytest.raises(ValueError, match="support foot"):
        part_weights("middle")
    assert TABLE_A1["lower_trunk"][0] == 8.70


def test_features_are_the_body_model_segments_and_com(walk):
    body = body_model_for(walk.skeleton)
    F = body_features(walk, body)
    order = [body.segment_names.index(b) for b in BODY_PARTS]
    np.testing.assert_allclose(F.positions, segment_positions(body, walk)[:, order], atol=1e-12)
    np.testing.assert_allclose(F.com, center_of_mass(body, walk), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(F.orientations, axis=-1), 1.0, atol=1e-12)
    assert F.positions.shape == (walk.n_frames, 16, 3) and F.fps == 30.0
    np.testing.assert_array_equal(F.ground[:, 1], 0.0)


def test_ground_frame_features_remove_yaw_and_shift_exactly(walk):
    yaw, shift = 1.1, np.array([2.0, 0.0, -3.5])
    moved = walk.rotated(yaw_quaternion(yaw)).translated(shift)
    A, B = body_features(walk), body_features(moved)
    np.testing.assert_allclose(np.angle(np.exp(1j * (B.heading - A.heading))), yaw, atol=1e-12)
    pa, oa = ground_frame_features(A.positions, A.orientations, A.ground, A.heading)
    pb, ob = ground_frame_features(B.positions, B.orientations, B.ground, B.heading)
    np.testing.assert_allclose(pb, pa, atol=1e-9)
    np.testing.assert_allclose(np.abs(np.sum(ob * oa, axis=-1)), 1.0, atol=1e-12)
    # one ground frame for a whole window (the window's first frame)
    pa0, _ = ground_frame_features(A.positions[5:15], A.orientations[5:15], A.ground[5], A.heading[5])
    pb0, _ = ground_frame_features(B.positions[5:15], B.orientations[5:15], B.ground[5], B.heading[5])
    np.testing.assert_allclose(pb0, pa0, atol=1e-9)
    assert not np.allclose(pa0[1:], pa[6:15], atol=1e-3)   # the root moves within the window


def test_velocities_known_answer(walk):
    """A still pose carried at a constant velocity and turning at a constant rate about +y."""
    T, fps = 31, 30.0
    t = np.arange(T) / fps
    v, omega = np.array([0.5, 0.0, 0.2]), 0.8
    rot = np.repeat(walk.rotations[:1], T, axis=0)
    still = walk.replace(root_positions=np.repeat(walk.root_positions[:1], T, axis=0), rotations=rot)
    moving = still.replace(root_positions=still.root_positions + v * t[:, None])
    F = body_features(moving)
    np.testing.assert_allclose(F.velocities, np.broadcast_to(v, F.velocities.shape), atol=1e-9)
    np.testing.assert_allclose(F.angular_velocities, 0.0, atol=1e-9)
    turning = still.rotated(yaw_quaternion(omega * t), center=still.root_positions[0])
    G = body_features(turning)
    np.testing.assert_allclose(G.angular_velocities, np.broadcast_to([0.0, omega, 0.0], G.angular_velocities.shape),
                               atol=1e-9)
    # linear velocity of a body turning about the vertical through the root: omega x r
    r = G.positions - still.root_positions[0]
    np.testing.assert_allclose(G.velocities[1:-1], np.cross([0.0, omega, 0.0], r)[1:-1], atol=5e-3 * omega)
