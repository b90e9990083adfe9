"""Joint pairing for the splice (issue #19 item 8): --map FILE.toml, the body
model's naming conventions, and a clear list of unpaired joints."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.cli import main
from mocomp.core.skeleton import Skeleton
from mocomp.errors import AlignmentError, MotionFormatError
from mocomp.io import read_bvh
from mocomp.splice import splice_motions
from mocomp.splice.jointmap import convention_aliases, load_joint_map, pair_joints
from mocomp.splice.markers import find_arm_joints
from mocomp.splice.pipeline import arm_layer_joints
from mocomp.splice.synthetic import synthetic_pair


def _renamed(motion, renames: dict):
    sk = motion.skeleton
    names = tuple(renames.get(n, n) for n in sk.names)
    ends = sk.end_sites
    sk2 = Skeleton(names, sk.parents, sk.offsets, None, ends)
    return motion.replace(skeleton=sk2)


@pytest.fixture(scope="module")
def pair():
    return synthetic_pair(3)


def test_same_names_pair_with_themselves(pair):
    sk = pair.body.skeleton
    idx = arm_layer_joints(sk, "right")
    arm = find_arm_joints(sk, "right")
    pr = pair_joints(sk, sk, idx, arm, arm)
    assert pr == {sk.names[j]: sk.names[j] for j in idx}


ARM_R = '[arm.hand.right]\nclavicle = "Shoulder_R"\nupper = "UpperArm_R"\nforearm = "LowerArm_R"\nhand = "{hand}"\n'


def test_unpaired_joint_error_lists_both_sides(pair, tmp_path):
    hand = _renamed(pair.hand, {"Hand_R": "Wrist_Right"})
    with pytest.raises(MotionFormatError, match="cannot find the right arm joints"):
        splice_motions(pair.body, hand, suggest=False, quality=False)
    f = tmp_path / "arm.toml"
    f.write_text(ARM_R.format(hand="Wrist_Right"))  # the hand recording's arm chain named: it pairs by role
    res = splice_motions(pair.body, hand, joint_map=f, suggest=False, quality=False)
    assert res.pairs["right"]["Hand_R"] == "Wrist_Right"
    # ... but an extra finger joint under the hand has no counterpart
    sk = pair.body.skeleton
    names = sk.names + ("Index_R",)
    parents = np.concatenate([sk.parents, [sk.index("Hand_R")]])
    offsets = np.vstack([sk.offsets, [[-0.05, 0, 0]]])
    body2 = pair.body.replace(skeleton=Skeleton(names, parents, offsets, None, sk.end_sites),
                              rotations=np.concatenate([pair.body.rotations, pair.body.rotations[:, :1] * 0 + [0, 0, 0, 1]], axis=1))
    with pytest.raises(AlignmentError, match=r"\['Index_R'\].*--map FILE.toml.*Index_R = "):
        splice_motions(body2, pair.hand, suggest=False, quality=False)


def test_map_file_pairs_and_keeps(pair, tmp_path):
    hand = _renamed(pair.hand, {"Hand_R": "RightPalm"})
    f = tmp_path / "map.toml"
    f.write_text('[joints]\nHand_R = "RightPalm"\n' + ARM_R.format(hand="RightPalm"))
    res = splice_motions(pair.body, hand, joint_map=f, suggest=False, quality=False)
    assert res.pairs["right"]["Hand_R"] == "RightPalm"
    # with the map, the wrist rotation comes from the hand recording's renamed joint
    ref = splice_motions(pair.body, pair.hand, suggest=False, quality=False)
    np.testing.assert_allclose(res.motion.rotations, ref.motion.rotations, atol=1e-12)
    f.write_text('[joints]\nkeep = ["Hand_R"]\n')
    kept = splice_motions(pair.body, pair.hand, joint_map=f, suggest=False, quality=False)
    j = pair.body.skeleton.index("Hand_R")
    np.testing.assert_allclose(kept.motion.rotations[:, j], pair.body.rotations[:, j])
    assert "Hand_R" not in kept.joints["right"]


@pytest.mark.parametrize("text, match", [
    ("[joints\n", "not valid TOML"),
    ('[joints]\nHand_R = 3\n', "must be a hand-recording joint name"),
    ('[bones]\nx = "y"\n', "unknown table"),
    ('[arm.body.middle]\nupper = "a"\n', "side must be"),
    ('[arm.body.right]\nupper = "a"\n', "needs upper, forearm, hand"),
])
def test_bad_map_files_name_the_file_and_key(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(MotionFormatError, match=match) as e:
        load_joint_map(f)
    assert "bad.toml" in str(e.value)


def test_map_naming_a_missing_joint_is_refused(pair, tmp_path):
    f = tmp_path / "map.toml"
    f.write_text('[joints]\nHand_R = "NoSuchJoint"\n')
    with pytest.raises(AlignmentError, match="NoSuchJoint"):
        splice_motions(pair.body, pair.hand, joint_map=f, suggest=False, quality=False)


def test_convention_aliases_know_the_cmu_finger_names():
    groups = convention_aliases()
    assert any({"RFingers", "RightHandIndex1"} <= g for g in groups)


# ------------------------------------------------------------------ real data: CMU 01_01 <- CMU 141_16
@pytest.mark.realdata
def test_cmu_to_cmu_with_different_finger_names(real_data_dir, tmp_path, capsys):
    from mocomp import datasets

    body = datasets.load(real_data_dir / "jumps" / "01_01.bvh")
    hand = datasets.load(real_data_dir / "hands" / "cmu_141_16_wave.bvh")
    assert "RFingers" in body.skeleton and "RFingers" not in hand.skeleton and "RightHandIndex1" in hand.skeleton
    res = splice_motions(body, hand, subsequence=True, suggest=False)
    assert res.pairs["right"]["RFingers"] == "RightHandIndex1"  # by the body model's naming conventions
    assert res.pairs["right"]["RightHand"] == "RightHand"
    # an explicit map gives the same pairing; the CLI writes the splice
    m = tmp_path / "cmu.toml"
    m.write_text('[joints]\nRFingers = "RightHandIndex1"\nLFingers = "LeftHandIndex1"\n')
    rc = main(["splice", str(real_data_dir / "jumps" / "01_01.bvh"), str(real_data_dir / "hands" / "cmu_141_16_wave.bvh"),
               "-o", str(tmp_path / "o.bvh"), "--map", str(m), "--subsequence", "--no-audit"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "RFingers <- RightHandIndex1" in out
    w = read_bvh(tmp_path / "o.bvh", scale="m")
    assert w.n_frames == body.n_frames and w.skeleton.names == body.skeleton.names
