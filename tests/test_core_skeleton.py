"""``mocomp.core.Skeleton`` on its own: constructor checks (each bad input a
MotionFormatError saying what is wrong), immutability, lookup errors, the height
estimate and bone lengths on a hand-measured skeleton, and the left/right mirror map."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mocomp.core import EndSite, RemovedRoot, Skeleton
from mocomp.errors import MotionFormatError

# A hand-made figure (metres): hips 0.9 m above the floor, ankles 0.1 m up, feet end sites
# on the floor 0.15 m forward, head end site at 1.75 m. Arms stretched sideways (T-pose).
NAMES = ("Hips", "Spine", "Head", "LeftArm", "LeftHand", "RightArm", "RightHand",
         "LeftUpLeg", "LeftFoot", "RightUpLeg", "RightFoot")
PARENTS = (-1, 0, 1, 1, 3, 1, 5, 0, 7, 0, 9)
OFFSETS = [[0, 0.9, 0], [0, 0.5, 0], [0, 0.2, 0], [0.2, 0, 0], [0.5, 0, 0], [-0.2, 0, 0], [-0.5, 0, 0],
           [0.1, 0, 0], [0, -0.8, 0], [-0.1, 0, 0], [0, -0.8, 0]]
ENDS = (EndSite(2, [0, 0.15, 0], "Head_end"), EndSite(8, [0, -0.1, 0.15], "LeftToe"),
        EndSite(10, [0, -0.1, 0.15], "RightToe"))


def figure(**kw) -> Skeleton:
    args = dict(names=NAMES, parents=PARENTS, offsets=OFFSETS, end_sites=ENDS)
    args.update(kw)
    return Skeleton(**args)


# ------------------------------------------------------------------ constructor checks
@pytest.mark.parametrize("kw, words", [
    (dict(names=(), parents=(), offsets=np.zeros((0, 3)), end_sites=()), "at least one joint"),
    (dict(parents=PARENTS[:-1]), "skeleton arrays disagree: 11 names, parents (10,)"),
    (dict(offsets=OFFSETS[:-1]), "offsets (10, 3)"),
    (dict(parents=(0,) + PARENTS[1:]), "joint 0 ('Hips') must be the root (parent -1), got parent 0"),
    (dict(parents=PARENTS[:3] + (5,) + PARENTS[4:]), "joint 3 ('LeftArm') has parent index 5; parents must precede"),
    (dict(parents=PARENTS[:3] + (-1,) + PARENTS[4:]), "joint 3 ('LeftArm') has parent index -1"),
    (dict(names=NAMES[:4] + ("Spine",) + NAMES[5:]), "duplicate joint name 'Spine' (joints 1 and 4)"),
    (dict(offsets=[[0, 0.9, 0], [0, np.nan, 0]] + OFFSETS[2:]), "joint 'Spine' has a non-finite offset"),
    (dict(offsets=[[0, 0.9, 0], [0, 0.5, np.inf]] + OFFSETS[2:]), "joint 'Spine' has a non-finite offset"),
    (dict(channels=[("Zrotation",)] * 10), "10 channel lists for 11 joints"),
    (dict(channels=[("Zrotation", "Wrotation")] * 11), "joint 'Hips' has unknown channel(s) ['Wrotation']"),
    (dict(channels=[("Zrotation", "Zrotation")] + [("Xrotation",)] * 10),
     "joint 'Hips' repeats a channel: ('Zrotation', 'Zrotation')"),
    (dict(end_sites=(EndSite(11, [0, 0.1, 0], "x"),)), "end site 'x' hangs from joint index 11, out of range"),
    (dict(end_sites=(EndSite(-1, [0, 0.1, 0], "x"),)), "end site 'x' hangs from joint index -1"),
    (dict(end_sites=(EndSite(2, [0, np.nan, 0], "Head_end"),)), "end site 'Head_end' has a non-finite offset"),
])
def test_constructor_rejects_bad_input_with_a_clear_message(kw, words):
    with pytest.raises(MotionFormatError) as e:
        figure(**kw)
    assert words in str(e.value), str(e.value)


def test_constructor_normalises_types_and_defaults():
    sk = figure(names=list(NAMES), parents=np.array(PARENTS, dtype=np.int32))
    assert sk.names == NAMES and isinstance(sk.names, tuple)
    assert sk.parents.dtype == np.int64 and sk.offsets.dtype == float and sk.offsets.shape == (11, 3)
    # default channel layout: 6 channels on the root, 3 rotations elsewhere (BVH's usual ZXY)
    assert sk.channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    assert set(sk.channels[1:]) == {("Zrotation", "Xrotation", "Yrotation")}
    assert sk.n_joints == len(sk) == 11 and sk.removed_root is None
    one = Skeleton(("Root",), [-1], [[0, 0, 0]])
    assert one.n_joints == 1 and one.height() == 0.0 and one.children(0) == []


# ------------------------------------------------------------------ immutability
def test_immutable_and_decoupled_from_the_inputs():
    parents = np.array(PARENTS)
    offsets = np.array(OFFSETS, dtype=float)
    sk = figure(parents=parents, offsets=offsets)
    offsets[1, 1] = 99.0  # the caller's arrays are copied
    parents[2] = 0
    assert sk.offsets[1, 1] == 0.5 and sk.parents[2] == 1
    with pytest.raises(ValueError, match="read-only"):
        sk.offsets[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        sk.parents[1] = 0
    with pytest.raises(ValueError, match="read-only"):
        sk.end_sites[0].offset[1] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        sk.names = ("x",) * 11
    with pytest.raises(dataclasses.FrozenInstanceError):
        sk.end_sites[0].parent = 0
    # derived copies are new objects; the original is untouched
    big = sk.scaled(2.0)
    assert big.offsets[1, 1] == 1.0 and sk.offsets[1, 1] == 0.5
    assert big.end_sites[0].offset[1] == pytest.approx(0.3) and sk.end_sites[0].offset[1] == 0.15


# ------------------------------------------------------------------ lookup
def test_index_find_contains_and_error_message():
    sk = figure()
    assert sk.index("RightFoot") == 10 and sk.find("RightFoot") == 10
    assert sk.find("Tail") is None and "Head" in sk and "Tail" not in sk
    with pytest.raises(KeyError) as e:
        sk.index("foot")
    msg = e.value.args[0]
    assert msg.startswith("no joint 'foot' in skeleton; similar: ")
    assert "LeftFoot" in msg and "RightFoot" in msg
    with pytest.raises(KeyError) as e:
        sk.index("Tail")
    assert e.value.args[0] == "no joint 'Tail' in skeleton; similar: none"


def test_children_and_chain():
    sk = figure()
    assert sk.children(0) == [1, 7, 9] and sk.children(1) == [2, 3, 5] and sk.children(4) == []
    assert sk.chain(4) == [0, 1, 3, 4] and sk.chain(0) == [0]


# ------------------------------------------------------------------ rest pose, height
def test_rest_positions_height_and_bone_lengths_known_answers():
    sk = figure()
    p = sk.rest_positions()
    np.testing.assert_allclose(p[sk.index("LeftHand")], [0.7, 1.4, 0])
    np.testing.assert_allclose(p[sk.index("RightFoot")], [-0.1, 0.1, 0])
    full = sk.rest_positions(include_end_sites=True)
    assert full.shape == (14, 3)
    np.testing.assert_allclose(full[11], [0, 1.75, 0], atol=1e-12)  # head end site
    np.testing.assert_allclose(full[12], [0.1, 0.0, 0.15], atol=1e-12)  # left toe on the floor
    # vertical extent, end sites included: floor (toes at 0) to the head end site (1.75)
    assert sk.height() == pytest.approx(1.75, abs=1e-12)
    assert figure(end_sites=()).height() == pytest.approx(1.6 - 0.1, abs=1e-12)  # head joint to ankles
    assert sk.scaled(0.5).height() == pytest.approx(0.875, abs=1e-12)
    np.testing.assert_allclose(sk.bone_lengths(), [0, 0.5, 0.2, 0.2, 0.5, 0.2, 0.5, 0.1, 0.8, 0.1, 0.8])


def test_equality_and_hash():
    a, b = figure(), figure()
    assert a == b and hash(a) == hash(b)
    assert a == a.with_channels([("Xrotation", "Yrotation", "Zrotation")] * 11)  # layout is not geometry
    moved = figure(offsets=[[0, 0.9, 0], [0, 0.51, 0]] + OFFSETS[2:])
    assert a != moved
    assert a != figure(names=NAMES[:-1] + ("RFoot",))


# ------------------------------------------------------------------ mirror map
def test_mirror_map_pairs_left_and_right():
    sk = figure()
    m = sk.mirror_map()
    pairs = {sk.names[j]: sk.names[k] for j, k in enumerate(m)}
    assert pairs["LeftArm"] == "RightArm" and pairs["RightHand"] == "LeftHand"
    assert pairs["LeftUpLeg"] == "RightUpLeg" and pairs["RightFoot"] == "LeftFoot"
    assert pairs["Hips"] == "Hips" and pairs["Spine"] == "Spine" and pairs["Head"] == "Head"
    np.testing.assert_array_equal(m[m], np.arange(sk.n_joints))  # an involution


@pytest.mark.parametrize("names, expect", [
    # CMU ASF: l/r prefixes; "lowerback" and "root" have no partner (no "rowerback")
    (("root", "lowerback", "lfemur", "rfemur", "lhumerus", "rhumerus"), (0, 1, 3, 2, 5, 4)),
    # Bandai / DeepMimic style suffixes
    (("Hips", "Spine", "UpLeg_L", "UpLeg_R", "Foot_l", "Foot_r"), (0, 1, 3, 2, 5, 4)),
    # lower-case words; a one-sided joint maps to itself
    (("pelvis", "left_hip", "right_hip", "left_extra"), (0, 2, 1, 3)),
])
def test_mirror_map_naming_conventions(names, expect):
    J = len(names)
    sk = Skeleton(names, [-1] + [0] * (J - 1), np.zeros((J, 3)))
    np.testing.assert_array_equal(sk.mirror_map(), expect)


# ------------------------------------------------------------------ removed root record
def test_removed_root_checks_and_scaling():
    rr = RemovedRoot("joint_Root", [0, 0, 0], ("Xposition", "Yposition", "Zposition", "Yrotation"),
                     [0.1, 0.0, 0.0, 90.0], [0, 0.9, 0])
    sk = figure(removed_root=rr)
    assert sk.removed_root is rr and sk == figure()  # equality: geometry only
    p, q = rr.transform()
    np.testing.assert_allclose(p, [0.1, 0, 0])
    np.testing.assert_allclose(q, [0, np.sqrt(0.5), 0, np.sqrt(0.5)], atol=1e-12)
    half = sk.scaled(0.5).removed_root
    np.testing.assert_allclose(half.values, [0.05, 0, 0, 90.0])  # lengths scale, angles do not
    np.testing.assert_allclose(half.child_offset, [0, 0.45, 0])
    assert sk.without_removed_root().removed_root is None
    with pytest.raises(MotionFormatError, match="'Hips' is also a joint"):
        figure(removed_root=dataclasses.replace(rr, name="Hips"))
    with pytest.raises(MotionFormatError, match="3 channel values for 4 channels"):
        RemovedRoot("R", [0, 0, 0], rr.channels, [0, 0, 0], [0, 0, 0])
    with pytest.raises(MotionFormatError, match="non-finite"):
        RemovedRoot("R", [0, np.nan, 0], rr.channels, [0, 0, 0, 0], [0, 0, 0])
