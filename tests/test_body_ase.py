"""The ASE humanoid (sword-and-shield clips): segment mapping, prop masses, ASE's own bodies vs MuJoCo."""
import warnings

import numpy as np
import pytest

from conftest import real_files
from mocomp.body import BodyModel, ase_body, detect_convention
from mocomp.body.ase import ASE_BODY_POS, ASE_GEOMS, MJCF_TO_BVH, body_inertials
from mocomp.errors import MotionFormatError

ASE_CLIPS = real_files("*/ase_rl_*.bvh")
#: ASE's MJCF body masses (kg), as the data MANIFEST lists them (rounded there)
MANIFEST_MASSES = {"pelvis": 10.0, "torso": 12.0, "head": 3.9, "thigh": 4.5, "shin": 3.0, "foot": 1.0,
                   "upper_arm": 1.5, "lower_arm": 1.0, "hand": 0.5, "sword": 0.7, "shield": 2.1}


def _read(path):
    from mocomp.io import read_bvh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_bvh(path, scale="m")


@pytest.fixture(scope="module")
def ase_motion(real_data_dir):
    return _read(real_data_dir / "attacks" / "ase_rl_Atk_SlashDown.derived.bvh")


@pytest.fixture(scope="module")
def mj_model(real_data_dir):
    mujoco = pytest.importorskip("mujoco")
    xml = (real_data_dir / "skeletons" / "ase_amp_humanoid_sword_shield.xml").read_text()
    assert 'material="grid"' in xml  # the MANIFEST's fix: the floor's material is undefined
    return mujoco.MjModel.from_xml_string(xml.replace(' material="grid"', ""))


def test_ase_clips_are_all_found():
    assert len(ASE_CLIPS) == 24  # 11 reactions, 5 attacks, 4 combos, 1 run, 2 idle, 1 walk (data MANIFEST)


@pytest.mark.parametrize("path", ASE_CLIPS, ids=lambda p: p.name)
def test_ase_mapping_fits_every_clip(path, real_data_dir):
    sk = _read(path).skeleton
    assert detect_convention(sk).name == "ase"
    body = BodyModel.from_skeleton(sk, total_mass=70.0)
    assert body.total_mass == pytest.approx(70.0)
    assert set(body.massless_joints) == {"sword", "shield"}  # props massless by default, listed
    assert {sk.names[j] for j in body.segment_joint} == set(sk.names) - {"sword", "shield"}
    with_props = BodyModel.from_skeleton(sk, total_mass=70.0, props="ase")
    assert with_props.massless_joints == ()


def test_props_masses_sum_as_documented(ase_motion):
    sk = ase_motion.skeleton
    plain = BodyModel.from_skeleton(sk, 70.0)
    body = BodyModel.from_skeleton(sk, 70.0, props="ase")
    assert body.n_segments == plain.n_segments + 2
    sword, shield = body.masses[body.segment("sword")], body.masses[body.segment("shield")]
    # sword: hilt capsule (r 23 mm, 0.23 m, 300 kg/m^3) + blade box (0.68 x 0.02 x 0.07 m, 600 kg/m^3)
    hilt = 300.0 * (np.pi * 0.023 ** 2 * 0.23 + 4 / 3 * np.pi * 0.023 ** 3)
    assert sword == pytest.approx(hilt + 600.0 * 0.68 * 0.02 * 0.07, rel=1e-12)
    assert shield == pytest.approx(250.0 * np.pi * 0.3 ** 2 * 0.03, rel=1e-12)  # disc r 0.3 m, 30 mm
    assert sword == pytest.approx(0.7, abs=0.005) and shield == pytest.approx(2.1, abs=0.025)
    # the body keeps its 70 kg; the props come on top
    assert body.total_mass == pytest.approx(70.0 + sword + shield, rel=1e-12)
    np.testing.assert_allclose(body.masses[:plain.n_segments], plain.masses, rtol=1e-12)
    with pytest.raises(ValueError, match="props must be one of"):
        BodyModel.from_skeleton(sk, 70.0, props="heavy")


def test_props_shift_the_com_by_the_known_amount(ase_motion):
    from mocomp.dynamics.com import center_of_mass

    m = ase_motion
    plain = BodyModel.from_skeleton(m.skeleton, 70.0)
    body = BodyModel.from_skeleton(m.skeleton, 70.0, props="ase")
    c0, c1 = center_of_mass(plain, m), center_of_mass(body, m)
    # the prop COMs by hand: sword 0.74 m along the hand's x, its COM 0.41692 m back along x;
    # the shield 0.12 m down the forearm and 0.07 m to its -z side, COM 15 mm further out
    P, Q = m.positions, m.global_rotations
    from mocomp.core.rotations import quat_apply

    hand, arm = m.skeleton.find("right_hand"), m.skeleton.find("left_lower_arm")
    c_sword = P[:, hand] + quat_apply(Q[:, hand], np.broadcast_to([0.74 - 0.416920624, 0.0, 0.0], P[:, hand].shape))
    c_shield = P[:, arm] + quat_apply(Q[:, arm], np.broadcast_to([0.0, -0.12, -0.085], P[:, arm].shape))
    ms, msh = body.masses[body.segment("sword")], body.masses[body.segment("shield")]
    expected = (70.0 * c0 + ms * c_sword + msh * c_shield) / (70.0 + ms + msh)
    np.testing.assert_allclose(c1, expected, atol=1e-7)
    shift = np.linalg.norm(c1 - c0, axis=1)
    assert 0.005 < shift.max() < 0.05  # 2.8 kg held at arm's length moves a 70 kg body's COM by cm


def test_ase_inertials_equal_mujoco(mj_model):
    """Every body's mass, COM and inertia tensor from our transcription of the geoms equal
    what MuJoCo (as installed) computes from the MANIFEST's XML."""
    from scipy.spatial.transform import Rotation

    ours = body_inertials("mjcf")
    names = [mj_model.body(i).name for i in range(1, mj_model.nbody)]
    assert names == list(ASE_GEOMS)  # same bodies, same order as the skeleton's joints
    total = 0.0
    for i, n in enumerate(names, start=1):
        m, c, inertia = ours[n]
        assert m == pytest.approx(mj_model.body_mass[i], rel=1e-9), n
        np.testing.assert_allclose(c, mj_model.body_ipos[i], atol=1e-9, err_msg=n)
        q = mj_model.body_iquat[i]
        R = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()
        np.testing.assert_allclose(inertia, R @ np.diag(mj_model.body_inertia[i]) @ R.T, atol=1e-10, err_msg=n)
        np.testing.assert_allclose(mj_model.body_pos[i] if ASE_BODY_POS[n][0] else [0, 0, 0],
                                   ASE_BODY_POS[n][1], atol=1e-9, err_msg=n)
        total += m
        key = n.replace("right_", "").replace("left_", "")
        assert m == pytest.approx(MANIFEST_MASSES[key], abs=0.025), n
    assert total == pytest.approx(51.7, abs=0.02)


def test_ase_body_model_is_the_mjcf_in_bvh_frames(ase_motion, mj_model):
    sk = ase_motion.skeleton
    own = ase_body(sk, props="ase")
    assert own.segment_names == sk.names and own.massless_joints == ()
    np.testing.assert_allclose(own.masses, mj_model.body_mass[1:], rtol=1e-9)
    np.testing.assert_allclose(own.local_coms, mj_model.body_ipos[1:] @ MJCF_TO_BVH.T, atol=1e-9)
    # the clips' offsets are the MJCF body positions turned Y-up (MANIFEST: to 1.5e-8 m)
    np.testing.assert_allclose(sk.offsets[1:], mj_model.body_pos[2:] @ MJCF_TO_BVH.T, atol=1e-6)
    bare = ase_body(sk)
    assert set(bare.massless_joints) == {"sword", "shield"}
    assert bare.total_mass == pytest.approx(own.total_mass - own.masses[6] - own.masses[9], rel=1e-12)
    assert bare.total_mass == pytest.approx(48.9, abs=0.02)


def test_ase_body_refuses_other_skeletons(real_data_dir, ase_motion):
    cmu = _read(real_data_dir / "jumps" / "01_01.bvh").skeleton
    with pytest.raises(MotionFormatError, match="needs joint 'pelvis'"):
        ase_body(cmu)
    with pytest.raises(MotionFormatError, match="not ASE's humanoid or not in metres"):
        ase_body(ase_motion.skeleton.scaled(100.0))  # centimetres
    with pytest.raises(MotionFormatError, match="sword"):
        BodyModel.from_skeleton(cmu, 70.0, props="ase")
