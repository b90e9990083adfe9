"""Edit layers and presets (issue 5, section 1)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import Motion, Skeleton
from mocomp.core.rotations import quat_apply
from mocomp.edit.layers import AimLayer, EditRangeError, OffsetLayer, TargetLayer, apply_layers, ease_weights


def test_ease_weights_shape_and_continuity():
    w = ease_weights(100, 20, 80, 10)
    assert np.all(w[:20] == 0) and np.all(w[80:] == 0)
    assert np.all(w[30:70] == 1)
    assert np.all(np.diff(w[19:31]) > 0) and np.all(np.diff(w[69:81]) < 0)
    # smoothstep: first step is small (zero slope at the join), symmetric ramps
    assert w[20] < 0.03
    assert np.allclose(w[20:30], w[70:80][::-1])


def test_ease_weights_rejects_outside_range():
    with pytest.raises(EditRangeError, match="outside"):
        ease_weights(50, 40, 60, 5)


def _chain(T=40):
    sk = Skeleton(("root", "a", "b"), [-1, 0, 1], [[0, 1, 0], [0, -0.5, 0], [0, -0.5, 0]])
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (T, 3, 1))
    return Motion(sk, 30.0, np.zeros((T, 3)), rot)


def test_offset_layer_adds_local_rotation_with_full_weight_inside():
    m = _chain()
    out = OffsetLayer(5, 35, 5, joint="a", rotvec=(0.0, 0.0, np.pi / 2)).apply(m)
    got = Rotation.from_quat(out.rotations[20, 1])
    assert np.allclose(got.as_rotvec(), [0, 0, np.pi / 2], atol=1e-12)
    assert np.allclose(out.rotations[0], m.rotations[0])
    assert m.rotations[20, 1, 3] == 1.0  # input untouched


def test_target_layer_reaches_target():
    m = _chain()
    tgt = Rotation.from_euler("x", 40, degrees=True).as_quat()
    out = TargetLayer(0, 40, 8, joint="b", target=tuple(tgt)).apply(m)
    assert Rotation.from_quat(out.rotations[20, 2]).approx_equal(Rotation.from_quat(tgt), atol=1e-12)


def test_aim_layer_points_bone_along_reference_direction():
    m = _chain()
    # reference: the root, rotated 30 degrees about z over the whole clip
    q = Rotation.from_euler("z", 30, degrees=True).as_quat()
    rot = np.array(m.rotations)
    rot[:, 0] = q
    m = m.replace(rotations=rot)
    out = AimLayer(0, 40, 5, joint="a", child="b", reference="root", direction=(1.0, 0.0, 0.0)).apply(m)
    P = out.positions
    bone = P[20, 2] - P[20, 1]
    want = quat_apply(q, np.array([1.0, 0.0, 0.0]))
    assert np.allclose(bone / np.linalg.norm(bone), want, atol=1e-9)
    assert np.allclose(out.positions[:, 0], m.positions[:, 0])  # the parent does not move


def test_apply_layers_composes_in_order():
    m = _chain()
    l1 = OffsetLayer(0, 40, 0, joint="a", rotvec=(0.3, 0, 0))
    l2 = OffsetLayer(0, 40, 0, joint="a", rotvec=(0, 0.4, 0))
    out = apply_layers(m, [l1, l2])
    want = Rotation.from_rotvec([0.3, 0, 0]) * Rotation.from_rotvec([0, 0.4, 0])
    assert Rotation.from_quat(out.rotations[10, 1]).approx_equal(want, atol=1e-12)
