"""A BVH the project wrote from a DeepMimic clip reads back with the DeepMimic character's body model.

The BVH writer lists joints depth first (DeepMimic lists them by ID, e.g. ``right_hip`` before
``right_shoulder``), and a BVH names no character; :func:`mocomp.io.deepmimic.match_character`
recognises the character by its joints (name and parent, any order) and bone offsets (0.1 mm), and
:func:`mocomp.audit.default_body` uses it. A skeleton that merely resembles the character (one bone
5 mm longer, a joint renamed or re-parented) keeps the generic table model, and says why."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.audit import audit, default_body
from mocomp.body import BodyModel
from mocomp.core.skeleton import Skeleton
from mocomp.dynamics import momentum
from mocomp.dynamics.com import segment_positions
from mocomp.io import read_bvh, write_bvh
from mocomp.io.deepmimic import match_character, read_deepmimic, read_deepmimic_character, recognized_body


def _round_trip(motion, tmp_path, name="out.bvh"):
    p = tmp_path / name
    write_bvh(motion, p)
    return read_bvh(p)


def _by_name(body):
    """segment name -> (mass, joint name, local COM)"""
    return {s: (float(m), body.skeleton.names[j], tuple(np.round(c, 9)))
            for s, m, j, c in zip(body.segment_names, body.masses, body.segment_joint, body.local_coms)}


def _check_same_body_and_L(m, r, b0, b1):
    assert b1.total_mass == pytest.approx(b0.total_mass, abs=1e-12)
    assert _by_name(b1) == _by_name(b0)  # masses and COMs per segment, carried by the joint of the same name
    for s in b0.segment_names:  # inertias too
        np.testing.assert_allclose(b1.inertias[b1.segment(s)], b0.inertias[b0.segment(s)], atol=1e-12)
    # world segment COMs over the frames agree (the joint order differs, the positions do not)
    p0, p1 = segment_positions(b0, m), segment_positions(b1, r)
    idx = [b1.segment(s) for s in b0.segment_names]
    np.testing.assert_allclose(p1[:, idx], p0, atol=1e-6)
    L0 = np.linalg.norm(momentum(b0, m).angular, axis=1)
    L1 = np.linalg.norm(momentum(b1, r).angular, axis=1)
    assert np.max(np.abs(L1 - L0)) <= 0.01 * L0.max()
    return L0, L1


# ------------------------------------------------------------------ real DeepMimic clips
@pytest.mark.realdata
@pytest.mark.parametrize("clip", ["flips/deepmimic_backflip.txt",
                                  "kicks_punches/deepmimic_sie_humanoid3d_punch_forward00.txt"])
def test_deepmimic_bvh_reads_back_with_the_characters_body(real_data_dir, tmp_path, clip):
    m = read_deepmimic(real_data_dir / clip)
    r = _round_trip(m, tmp_path)
    # the writer lists joints depth first: not DeepMimic's ID order, the same joints and parents by name
    assert r.skeleton.names != m.skeleton.names and set(r.skeleton.names) == set(m.skeleton.names)
    assert r.source.format == "bvh" and not any(n.startswith("character ") for n in r.source.notes)
    b0, b1 = default_body(m), default_body(r)
    assert b0.total_mass == pytest.approx(45.0)
    assert "recognised as DeepMimic character deepmimic_humanoid3d_character.txt" in b1.notes[0]
    L0, L1 = _check_same_body_and_L(m, r, b0, b1)
    # the generic model this replaces measures |L| >= 15 % higher (the issue's ~18 %)
    Lg = np.linalg.norm(momentum(BodyModel.from_skeleton(r.skeleton, total_mass=70.0), r).angular, axis=1)
    assert Lg.max() > 1.15 * L0.max()
    # the audit says which model and why
    rep = audit(r)
    assert "DeepMimic character file" in rep.body and "recognised" in rep.body
    assert rep.total_mass == pytest.approx(45.0)


@pytest.mark.realdata
def test_cmu_bvh_keeps_the_generic_model(real_data_dir):
    m = read_bvh(real_data_dir / "flips" / "cmu_88_01_backflip.bvh", fps=60)
    char, why = match_character(m.skeleton)
    assert char is None and "joints differ" in why
    b = default_body(m)
    assert b.total_mass == pytest.approx(70.0) and "de Leva" in b.table
    assert "recognised" not in audit(m).body


@pytest.mark.realdata
def test_resembling_skeleton_is_refused(real_data_dir, tmp_path):
    """Same names and parents, one bone 5 mm longer (another performer, a rescaled rig): no match."""
    m = read_deepmimic(real_data_dir / "flips" / "deepmimic_backflip.txt")
    sk = m.skeleton
    off = np.array(sk.offsets)
    k = sk.names.index("left_knee")
    off[k, 1] -= 0.005
    other = dataclasses.replace(m, skeleton=Skeleton(sk.names, sk.parents, off, sk.channels, sk.end_sites))
    r = _round_trip(other, tmp_path)
    char, why = match_character(r.skeleton)
    assert char is None and "differs by 5 mm" in why
    assert "de Leva" in default_body(r).table and default_body(r).total_mass == pytest.approx(70.0)
    # scaled by 1 %: every bone differs by millimetres
    r2 = _round_trip(dataclasses.replace(m, skeleton=sk.scaled(1.01), root_positions=m.root_positions * 1.01),
                     tmp_path, "scaled.bvh")
    assert match_character(r2.skeleton)[0] is None


# ------------------------------------------------------------------ a small character (no data needed)
def _joint(i, name, jtype, parent, x=0.0, y=0.0, z=0.0):
    return {"ID": i, "Name": name, "Type": jtype, "Parent": parent, "AttachX": x, "AttachY": y, "AttachZ": z,
            "AttachThetaX": 0, "AttachThetaY": 0, "AttachThetaZ": 0}


def _body(i, name, shape, mass, y=0.0, p=(0.1, 0.1, 0.1)):
    return {"ID": i, "Name": name, "Shape": shape, "Mass": mass, "AttachX": 0.0, "AttachY": y, "AttachZ": 0.0,
            "AttachThetaX": 0, "AttachThetaY": 0, "AttachThetaZ": 0, "Param0": p[0], "Param1": p[1], "Param2": p[2]}


def _character(tmp_path, name="character.txt", spine_mass=20.0, knee_y=-0.45):
    """root -> hip -> knee -> foot and root -> spine -> head, numbered hip 1, spine 2, knee 3, head 4,
    foot 5: not a depth-first order (like DeepMimic's humanoid, whose right_hip, ID 3, precedes
    right_shoulder, ID 6, a child of chest, ID 1)."""
    joints = [_joint(0, "root", "none", -1), _joint(1, "hip", "spherical", 0, z=0.1, y=-0.05),
              _joint(2, "spine", "spherical", 0, y=0.3), _joint(3, "knee", "revolute", 1, y=knee_y),
              _joint(4, "head", "spherical", 2, y=0.4), _joint(5, "foot", "spherical", 3, y=-0.45)]
    bodies = [_body(0, "root", "sphere", 10, y=0.05, p=(0.3, 0, 0)), _body(1, "hip", "capsule", 8, y=-0.22,
                                                                           p=(0.12, 0.3, 0)),
              _body(2, "spine", "box", spine_mass, y=0.2, p=(0.3, 0.4, 0.2)),
              _body(3, "knee", "cylinder", 4, y=-0.22, p=(0.1, 0.35, 0)),
              _body(4, "head", "sphere", 5, y=0.15, p=(0.2, 0, 0)), _body(5, "foot", "box", 1, y=-0.03,
                                                                          p=(0.2, 0.06, 0.1))]
    f = tmp_path / name
    f.write_text(json.dumps({"Skeleton": {"Joints": joints}, "BodyDefs": bodies}))
    return f


def _motion_file(tmp_path, T=40):
    frames = []
    for k in range(T):
        t = k / 30
        q = Rotation.from_rotvec([[0.3 * np.sin(2 * t + j), 0.2 * np.cos(3 * t + j), 0.1 * j * t]
                                  for j in range(5)]).as_quat()[:, [3, 0, 1, 2]]
        # root pos, root quat, hip, spine, knee angle, head, foot (ID order)
        frames.append([1 / 30, 0.1 * t, 1.0 + 0.05 * np.sin(4 * t), 0.0, *q[0], *q[1], *q[2],
                       0.8 * np.sin(t), *q[3], *q[4]])
    f = tmp_path / "clip.txt"
    f.write_text(json.dumps({"Loop": "none", "Frames": frames}))
    return f


def test_small_character_round_trip_and_refusals(tmp_path):
    ch_file = _character(tmp_path)
    char = read_deepmimic_character(ch_file)
    m = read_deepmimic(_motion_file(tmp_path), character=char, height_check=False)
    r = _round_trip(m, tmp_path)
    assert r.skeleton.names != m.skeleton.names  # depth first: root, hip, knee, foot, spine, head
    assert r.skeleton.names == ("root", "hip", "knee", "foot", "spine", "head")
    c, why = match_character(r.skeleton, [char])
    assert c is char and "6 joints by name and parent" in why
    b0 = default_body(m)
    b1 = recognized_body(r.skeleton, [char])
    _check_same_body_and_L(m, r, b0, b1)
    assert b1.total_mass == pytest.approx(48.0)
    # same joints, knee bone 2 mm shorter: no match, the reason names the difference
    other = read_deepmimic_character(_character(tmp_path, "other.txt", knee_y=-0.448))
    c, why = match_character(r.skeleton, [other])
    assert c is None and "differs by 2 mm" in why
    # a joint renamed, a joint re-parented: no match
    sk = r.skeleton
    renamed = Skeleton(tuple("toe" if n == "foot" else n for n in sk.names), sk.parents, sk.offsets, sk.channels)
    assert "joints differ" in match_character(renamed, [char])[1]
    par = np.array(sk.parents)
    par[sk.names.index("head")] = sk.names.index("root")
    assert "hangs from" in match_character(Skeleton(sk.names, par, sk.offsets, sk.channels), [char])[1]
    # two characters with this skeleton but different masses: ambiguous, none chosen
    heavy = read_deepmimic_character(_character(tmp_path, "heavy.txt", spine_mass=30.0))
    c, why = match_character(r.skeleton, [char, heavy])
    assert c is None and "ambiguous" in why
    # ... but two copies of the same character are fine
    twin = read_deepmimic_character(_character(tmp_path, "twin.txt"))
    assert match_character(r.skeleton, [char, twin])[0] is char


# ------------------------------------------------------------------ joint order
def test_reorder_joints_restores_the_written_order(tmp_path):
    """The BVH writer lists joints depth first (the format's column order); reorder_joints puts a
    read-back motion in the original order: names, parents, offsets, channels, end sites and every
    joint's rotation and world position equal the in-memory motion's."""
    from mocomp.errors import MotionFormatError
    from mocomp.io.bvh import reorder_joints

    char = read_deepmimic_character(_character(tmp_path))
    m = read_deepmimic(_motion_file(tmp_path), character=char, height_check=False)
    r = _round_trip(m, tmp_path)
    back = reorder_joints(r, m.skeleton.names)
    assert back.skeleton.names == m.skeleton.names
    np.testing.assert_array_equal(back.skeleton.parents, m.skeleton.parents)
    np.testing.assert_allclose(back.skeleton.offsets, m.skeleton.offsets, atol=1e-10)
    assert back.skeleton.channels == m.skeleton.channels
    assert [(e.parent, e.name) for e in back.skeleton.end_sites] == [(e.parent, e.name) for e in m.skeleton.end_sites]
    dots = np.abs(np.einsum("tjk,tjk->tj", back.rotations, m.rotations))
    assert dots.min() > 1 - 1e-12
    np.testing.assert_allclose(back.fk()[0], m.fk()[0], atol=1e-7)
    assert reorder_joints(back, back.skeleton.names) is back
    # a child before its parent, or a joint missing: clear errors
    bad = list(m.skeleton.names)
    bad[1], bad[3] = bad[3], bad[1]  # knee (child of hip) before hip
    with pytest.raises(MotionFormatError, match="comes before its parent"):
        reorder_joints(r, bad)
    with pytest.raises(MotionFormatError, match="missing"):
        reorder_joints(r, m.skeleton.names[:-1])


@pytest.mark.realdata
def test_deepmimic_order_restored_after_round_trip(real_data_dir, tmp_path):
    from mocomp.io.bvh import reorder_joints

    m = read_deepmimic(real_data_dir / "flips" / "deepmimic_backflip.txt")
    back = reorder_joints(_round_trip(m, tmp_path), m.skeleton.names)
    assert back.skeleton.names == m.skeleton.names
    np.testing.assert_allclose(back.fk()[0], m.fk()[0], atol=1e-6)
    b0, b1 = default_body(m), default_body(back)
    np.testing.assert_array_equal(b1.segment_joint, b0.segment_joint)
    np.testing.assert_allclose(b1.masses, b0.masses)
