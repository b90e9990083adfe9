"""mocomp.impact.scene and .convert: both characters in one MuJoCo model, pose and velocity mapping."""
from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mocomp.core.rotations import quat_angle  # noqa: E402
from mocomp.impact.convert import motion_state, pose_to_qpos, qpos_to_pose  # noqa: E402
from mocomp.impact.scene import (FRICTION_ACTIVE, FRICTION_NAIVE, STEP, ImpactError, Scenario, build_scene,  # noqa: E402
                                 joint_limits, place_victim, strike_direction)
from mocomp.ops.align import headings  # noqa: E402
from mocomp.ops.synthetic import synthetic_walk  # noqa: E402


@pytest.fixture(scope="module")
def ase(real_data_dir):
    from mocomp.io import load

    v = load(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh")
    a = load(real_data_dir / "attacks" / "ase_rl_Atk_Kick.derived.bvh")
    return a, v


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration=1.0, fps=30.0).motion


def test_ase_scene_masses_step_friction_and_collision_groups(ase):
    from mocomp.body import ase_body

    a, v = ase
    sc = build_scene(a.skeleton, v.skeleton, attacker_motions=[a], victim_motions=[v], contact_body="right_foot")
    m = sc.model(FRICTION_NAIVE)
    body = ase_body(v.skeleton, props="ase")
    for lay in (sc.attacker, sc.victim):
        np.testing.assert_allclose(m.body_mass[lay.body_ids].sum(), body.total_mass, rtol=1e-9)
        assert len(lay.geom_ids) >= 17
    assert m.opt.timestep == pytest.approx(STEP)
    np.testing.assert_allclose(m.opt.gravity, [0, -9.81, 0])
    assert m.geom_friction[sc.floor_geom, 0] == FRICTION_NAIVE
    assert sc.model(FRICTION_ACTIVE).geom_friction[sc.floor_geom, 0] == FRICTION_ACTIVE
    # only the right foot strikes; no self-collision within a character; every geom meets the floor
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])) for g in sc.attacker.strike_geoms}
    assert names == {"a_right_foot"}
    ct, ca = m.geom_contype, m.geom_conaffinity
    for lay in (sc.attacker, sc.victim):
        g = lay.geom_ids
        assert not np.any((ct[g][:, None] & ca[g][None, :]) | (ca[g][:, None] & ct[g][None, :]))
        assert np.all((ct[g] & ca[sc.floor_geom]) | (ca[g] & ct[sc.floor_geom]))
    other = np.setdiff1d(sc.attacker.geom_ids, sc.attacker.strike_geoms)
    vg = sc.victim.geom_ids
    assert not np.any((ct[other][:, None] & ca[vg][None, :]) | (ca[other][:, None] & ct[vg][None, :]))
    s = sc.attacker.strike_geoms
    assert np.all((ct[s][:, None] & ca[vg][None, :]) | (ca[s][:, None] & ct[vg][None, :]))


def test_qpos_forward_kinematics_equals_motion_fk(ase):
    a, v = ase
    sc = build_scene(a.skeleton, v.skeleton)
    m = sc.model(1.0)
    d = mujoco.MjData(m)
    for k in (0, 40, 90):
        pose_to_qpos(d.qpos, sc.victim, v.root_positions[k], v.rotations[k])
        pose_to_qpos(d.qpos, sc.attacker, a.root_positions[k % a.n_frames], a.rotations[k % a.n_frames])
        mujoco.mj_kinematics(m, d)
        np.testing.assert_allclose(d.xpos[sc.victim.body_ids], v.positions[k], atol=1e-9)
        np.testing.assert_allclose(d.xpos[sc.attacker.body_ids], a.positions[k % a.n_frames], atol=1e-9)
        r, q = qpos_to_pose(d.qpos, sc.victim)
        np.testing.assert_allclose(r, v.root_positions[k])
        assert np.all(np.abs(np.sum(q * v.rotations[k], axis=1)) > 1 - 1e-12)


def test_state_velocities_integrate_to_the_next_frame(walk):
    """qvel from motion_state, integrated by MuJoCo over one frame, lands on the next frame's pose."""
    sc = build_scene(walk.skeleton, walk.skeleton)
    m = sc.model(1.0)
    d = mujoco.MjData(m)
    far = walk.translated([0, 0, 30])
    for k in (3, 12):
        t = k / walk.fps
        motion_state(walk, t, sc.victim, d.qpos, d.qvel)
        motion_state(far, t, sc.attacker, d.qpos, d.qvel)
        q = np.array(d.qpos)
        mujoco.mj_integratePos(m, q, d.qvel, walk.dt)
        r, rot = qpos_to_pose(q, sc.victim)
        np.testing.assert_allclose(r, walk.root_positions[k + 1], atol=1e-9)
        assert np.all(np.abs(np.sum(rot * walk.rotations[k + 1], axis=1)) > 1 - 1e-9)


def test_generic_skeleton_gets_bone_capsules_and_limits_from_the_captured_range(walk):
    sc = build_scene(walk.skeleton, walk.skeleton, victim_motions=[walk], margin_deg=10.0)
    ang = np.degrees(quat_angle(walk.rotations).max(axis=0))
    np.testing.assert_allclose(sc.limits_deg[1:], np.minimum(ang[1:] + 10.0, 180.0))
    m = sc.model(1.0)
    lim = np.degrees(m.jnt_range[m.body_jntadr[sc.victim.body_ids[1:]], 1])
    limited = m.jnt_limited[m.body_jntadr[sc.victim.body_ids[1:]]].astype(bool)
    np.testing.assert_allclose(lim[limited], sc.limits_deg[1:][limited], rtol=1e-9)
    assert "capsules" in sc.notes[-1]


def test_joint_limits_ignore_other_skeletons(walk, ase):
    _, v = ase
    lim = joint_limits([v, walk], walk.skeleton, margin_deg=0.0)
    np.testing.assert_allclose(lim[1:], np.degrees(quat_angle(walk.rotations).max(axis=0))[1:])


@pytest.mark.parametrize("facing", [0.0, 90.0, 180.0, -90.0])
@pytest.mark.parametrize("moving", [False, True])
def test_place_victim_faces_the_attacker_turned_by_facing(ase, real_data_dir, facing, moving):
    from mocomp.io import load

    a, v = ase
    if moving:
        v = load(real_data_dir / "walks" / "ase_rl_WalkForward01.derived.bvh")
    sc = Scenario(facing, contact_body="right_foot")
    pv = place_victim(a, v, sc)
    fwd, reach, ks = strike_direction(a, "right_foot")
    k = int(min(round(ks / a.fps * v.fps), v.n_frames - 1))      # the victim arrives when the strike does
    d = pv.root_positions[k] - a.root_positions[0]
    d[1] = 0
    assert np.linalg.norm(d) == pytest.approx(reach - sc.overlap, abs=1e-9)
    np.testing.assert_allclose(d / np.linalg.norm(d), fwd, atol=1e-9)
    h = headings(pv, [k])[0]
    look = np.array([np.cos(h), 0.0, -np.sin(h)])
    to_attacker = -fwd
    ang = np.degrees(np.arctan2(np.cross(to_attacker, look)[1], to_attacker @ look))
    assert ((ang - facing + 180) % 360 - 180) == pytest.approx(0.0, abs=1e-6)
    # rigid: the clip's own shape is unchanged
    np.testing.assert_allclose(np.diff(pv.root_positions[:, 1]), np.diff(v.root_positions[:, 1]), atol=1e-12)
    step = np.linalg.norm(np.diff(pv.root_positions[:, [0, 2]], axis=0), axis=1)
    np.testing.assert_allclose(step, np.linalg.norm(np.diff(v.root_positions[:, [0, 2]], axis=0), axis=1), atol=1e-12)


@pytest.mark.parametrize("bad", [180.5, -200.0, float("nan")])
def test_scenario_refuses_facing_outside_range(bad):
    with pytest.raises(ImpactError, match=r"\[-180, 180\]"):
        Scenario(bad)


def test_unknown_contact_body_is_named(ase):
    a, v = ase
    with pytest.raises(ImpactError, match="right_fist.*joints: pelvis"):
        build_scene(a.skeleton, v.skeleton, contact_body="right_fist")


def test_victim_bodies_match_ases_own_mujoco_model(ase, real_data_dir):
    """Peer check: the exported victim's body masses and centres of mass equal those MuJoCo computes
    from ASE's own MJCF (skeletons/ase_amp_humanoid_sword_shield.xml), in the BVH frames."""
    from mocomp.body.ase import MJCF_TO_BVH

    a, v = ase
    xml = (real_data_dir / "skeletons" / "ase_amp_humanoid_sword_shield.xml").read_text().replace('material="grid"', "")
    peer = mujoco.MjModel.from_xml_string(xml)
    sc = build_scene(a.skeleton, v.skeleton)
    m = sc.model(1.0)
    for name, b in zip(v.skeleton.names, sc.victim.body_ids):
        pb = mujoco.mj_name2id(peer, mujoco.mjtObj.mjOBJ_BODY, name)
        assert pb >= 0, name
        assert m.body_mass[b] == pytest.approx(peer.body_mass[pb], rel=1e-6), name
        np.testing.assert_allclose(m.body_ipos[b], MJCF_TO_BVH @ peer.body_ipos[pb], atol=1e-6, err_msg=name)
