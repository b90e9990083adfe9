"""Body height: measured when the clip stands upright, from the bone lengths when it never does."""
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import real_files
from mocomp import datasets
from mocomp.body.height import UPRIGHT_FRACTION, estimate_height, skeleton_stature, standing_height
from mocomp.core import Motion, Skeleton
from mocomp.synth.skeleton import synthetic_skeleton

ASE_CLIPS = real_files("*/ase_rl_*.bvh")
#: ASE's humanoid standing straight, from its MJCF: sole 0.05 m below the ankle, shin 0.40987,
#: thigh 0.421546, pelvis -> torso 0.236151, torso -> head joint 0.223894, head sphere top
#: 0.175 + 0.095 m above the head joint
ASE_STATURE = 0.05 + 0.40987 + 0.421546 + 0.236151 + 0.223894 + 0.175 + 0.095


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return datasets.load(name)


def _standing(sk: Skeleton, n: int = 10, knee_deg: float = 0.0, hip_deg: float = 0.0) -> Motion:
    """The rest pose (upright for the synthetic skeleton), optionally with bent knees and hips."""
    q = np.zeros((n, sk.n_joints, 4))
    q[..., 3] = 1.0
    for side in ("Left", "Right"):
        q[:, sk.find(f"{side}Leg")] = Rotation.from_euler("x", knee_deg, degrees=True).as_quat()
        q[:, sk.find(f"{side}UpLeg")] = Rotation.from_euler("x", -hip_deg, degrees=True).as_quat()
    root = np.tile([0.0, 1.0, 0.0], (n, 1))
    return Motion(sk, 30.0, root, q)


def test_upright_synthetic_body_is_measured():
    sk = synthetic_skeleton(1.75)
    e = estimate_height(_standing(sk))
    assert e.basis == "motion" and e.convention == "cmu_bvh"
    # straight: head top to toe tip equals the bone chain exactly
    assert e.value == pytest.approx(sk.height(), abs=1e-9)
    assert e.chain == pytest.approx(sk.height(), abs=1e-9) and e.ratio == pytest.approx(1.0, abs=1e-9)


def test_crouching_synthetic_body_gets_the_skeleton_stature():
    sk = synthetic_skeleton(1.75)
    crouch = _standing(sk, knee_deg=70.0, hip_deg=60.0)
    e = estimate_height(crouch)
    assert e.motion_extent < UPRIGHT_FRACTION * e.chain  # a deep crouch never stands upright
    assert e.basis == "skeleton" and e.value == pytest.approx(skeleton_stature(sk), abs=1e-12)
    assert e.value == pytest.approx(sk.height(), abs=1e-9)
    # the old estimate (all joints, motion only) takes the crouch for the height
    from mocomp.io.units import standing_height as joint_extent

    assert joint_extent(crouch) < 0.9 * sk.height()
    # slightly bent knees (10 degrees) still count as standing
    assert estimate_height(_standing(sk, knee_deg=10.0)).basis == "motion"


def test_unmapped_skeleton_keeps_the_joint_extent():
    sk = Skeleton(("root", "a", "b"), np.array([-1, 0, 1]), np.array([[0, 0, 0], [0, 0.5, 0], [0, 0.5, 0]]))
    m = Motion(sk, 30.0, np.zeros((3, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (3, 3, 1)))
    e = estimate_height(m)
    assert e.basis == "joints" and e.chain is None and e.value == pytest.approx(1.0)


@pytest.mark.parametrize("path", ASE_CLIPS, ids=lambda p: p.name)
def test_every_ase_clip_has_the_ase_humanoid_height(path, real_data_dir):
    m = _load(path.relative_to(real_data_dir).as_posix())
    e = estimate_height(m)
    assert e.convention == "ase"
    assert e.chain == pytest.approx(ASE_STATURE, abs=1e-6)  # the skeleton's stature is the MJCF's
    # same skeleton, same height within a few cm, whether measured (upright clips) or not
    assert abs(e.value - ASE_STATURE) < 0.045, e.reason


def test_crouching_shield_charge(real_data_dir):
    from mocomp.io.units import standing_height as joint_extent

    m = _load("ase_rl_Atk_ShieldCharge.derived")
    assert joint_extent(m) == pytest.approx(1.195, abs=0.005)  # the old estimate: implausibly short
    e = estimate_height(m)
    assert e.basis == "skeleton" and e.ratio < 0.92
    assert standing_height(m) == pytest.approx(ASE_STATURE, abs=1e-6)


#: today's (joint-extent) estimates of upright clips whose head is their highest point, and the
#: new ones: they agree within 3.5 cm (the new one measures head top to foot, not all joints)
PINNED = {
    "01_01": 1.569, "01_01.amc": 1.684, "HDM_dg_06-03_03_120": 1.722, "88_01": 1.388, "90_08": 1.538,
    "83_58": 1.359, "sfu_0008_Walking002": 1.567, "sfu_0005_Jogging001": 1.578, "131_01": 1.408,
    "141_16": 1.364, "sfu_0005_JumpRope001": 1.618, "cmu_91_59_stumble": 1.354,
}


@pytest.mark.parametrize("name, old", PINNED.items())
def test_upright_clips_keep_their_height(name, old, real_data_dir):
    from mocomp.io.units import standing_height as joint_extent

    m = _load(name)
    assert joint_extent(m) == pytest.approx(old, abs=0.001)  # the pinned value is today's
    e = estimate_height(m)
    assert e.basis == "motion"
    assert abs(e.value - old) < 0.035, (name, e.value)


@pytest.mark.parametrize("name", ["mass_backflip", "mass_cart", "sfu_0017_WushuKicks001",
                                  "bandai2_wave-left-hand_normal_001"])
def test_raised_arms_no_longer_inflate_the_height(name, real_data_dir):
    """The joint extent counts hands held overhead (2.31 m for the MASS back flip); the new
    estimate stays within 4 % of the skeleton's stature."""
    from mocomp.io.units import standing_height as joint_extent

    m = _load(name)
    e = estimate_height(m)
    assert joint_extent(m) > e.value + 0.1
    assert abs(e.value / e.chain - 1.0) < 0.04


def test_one_skeleton_one_height_deepmimic(real_data_dir):
    """Every DeepMimic clip shares one humanoid: heights agree within 6 cm (joint extent: 26 cm)."""
    vals = [estimate_height(_load(p.stem)).value for p in real_files("*/deepmimic_*.txt")
            if p.parent.name != "skeletons"]
    assert len(vals) >= 15 and max(vals) - min(vals) < 0.06
