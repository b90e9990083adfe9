"""mocomp.impact.simulate: first contact, rewind, the servo passes (eq. 4.3), errors, determinism."""
from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from mocomp.impact.scene import ImpactError, Scenario, build_scene, place_victim  # noqa: E402
from mocomp.impact.simulate import (ServoGains, blend_targets, ease_in_out, find_first_contact,  # noqa: E402
                                    naive_targets, on_ground, simulate)
from mocomp.ops.synthetic import synthetic_walk  # noqa: E402


@pytest.fixture(scope="module")
def kick(real_data_dir):
    from mocomp.io import load

    v = load(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh")
    a = load(real_data_dir / "attacks" / "ase_rl_Atk_Kick.derived.bvh")
    pv = place_victim(a, v, Scenario(0.0, contact_body="right_foot"))
    aa = a.sample(np.clip(np.arange(pv.n_frames) / pv.fps, 0, a.duration), fps=pv.fps)
    sc = build_scene(a.skeleton, v.skeleton, attacker_motions=[a], victim_motions=[v], contact_body="right_foot")
    return sc, aa, pv


def _held(motion, k, n, lift=0.0):
    """Frame k held for n frames, raised by ``lift`` m."""
    m = motion.slice(k, k + 1)
    from mocomp.core.motion import concatenate

    return concatenate([m] * n).translated([0, lift, 0])


def test_free_fall_of_a_held_pose_follows_gravity():
    """In the air with its pose held, the victim's root falls as g t^2 / 2 (servo forces are internal)."""
    w = synthetic_walk(duration=1.0, fps=30.0).motion
    v = _held(w, 0, 20, lift=3.0)
    a = _held(w, 0, 20).translated([0, 0, 40])
    sc = build_scene(w.skeleton, w.skeleton)
    t_end = 0.4
    res = simulate(sc, a, v, 0.0, t_end, victim_targets=naive_targets(v, 0.0, t_end), friction=1.0)
    t = np.arange(res.victim.n_frames) / v.fps
    drop = v.root_positions[0, 1] - res.victim.root_positions[:, 1]
    np.testing.assert_allclose(drop, 0.5 * 9.81 * t ** 2, atol=0.01)
    assert res.impact_time is None and res.warnings == {}
    assert np.degrees(res.tracking_error_rad.max()) < 2.0


def test_servos_pull_a_limb_to_its_target_critically_damped():
    """Eq. 4.3 with k_v = 2 sqrt(k_p): the joint error decays without overshooting past the target."""
    from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply

    w = synthetic_walk(duration=1.0, fps=30.0).motion
    v = _held(w, 0, 40, lift=3.0)
    a = _held(w, 0, 40).translated([0, 0, 40])
    target = np.array(_held(w, 15, 40).rotations)             # another walk pose
    sc = build_scene(w.skeleton, w.skeleton)
    # 0.6 s: in the air throughout (a 3 m drop takes 0.78 s)
    res = simulate(sc, a, v, 0.0, 0.6, victim_targets=target, friction=1.0, gains=ServoGains(omega_victim=30.0))
    err = quat_angle(quat_multiply(quat_inverse(res.victim.rotations[:, 1:]), target[:res.victim.n_frames, 1:]))
    e0 = err[0].mean()
    assert e0 > np.radians(3)
    assert err[-1].mean() < 0.25 * e0
    assert np.all(np.diff(err.mean(axis=1)[:6]) < 0)         # decreasing at first


def test_first_contact_rewind_and_the_kick_pushes_the_victim_away(kick):
    sc, aa, pv = kick
    fc = find_first_contact(sc, aa, pv)
    assert fc.rewind_frame == fc.frame - 1 and fc.frame > 0
    assert any(p[0] == "right_foot" for p in fc.pairs)
    t0 = fc.rewind_frame / pv.fps
    t1 = t0 + 0.4
    res = simulate(sc, aa, pv, t0, t1, victim_targets=naive_targets(pv, t0, t1), friction=1.0)
    assert res.impact_time is not None and t0 <= res.impact_time <= fc.time + 1.0 / pv.fps
    assert res.contact_end >= res.impact_time
    push = pv.root_positions[fc.rewind_frame] - aa.root_positions[fc.rewind_frame]
    push[1] = 0
    assert res.impulse @ push / np.linalg.norm(push) > 10.0           # N s, along attacker -> victim
    moved = res.victim.root_positions[-1] - pv.root_positions[fc.rewind_frame + res.victim.n_frames - 1]
    assert moved @ push > 0                                            # knocked back relative to its clip
    assert res.warnings == {}
    # the start is the mocap frame itself
    np.testing.assert_allclose(res.victim.root_positions[0], pv.root_positions[fc.rewind_frame], atol=1e-12)


def test_passes_are_deterministic(kick):
    sc, aa, pv = kick
    fc = find_first_contact(sc, aa, pv)
    t0 = fc.rewind_frame / pv.fps
    runs = [simulate(sc, aa, pv, t0, t0 + 0.3, victim_targets=naive_targets(pv, t0, t0 + 0.3), friction=0.5)
            for _ in range(2)]
    np.testing.assert_allclose(runs[0].victim.root_positions, runs[1].victim.root_positions, rtol=0, atol=0)
    np.testing.assert_allclose(runs[0].victim.rotations, runs[1].victim.rotations, rtol=0, atol=0)
    np.testing.assert_allclose(runs[0].impulse, runs[1].impulse, rtol=0, atol=0)


def test_no_contact_names_the_closest_distance_and_when(kick):
    sc, aa, pv = kick
    far = pv.translated([3.0, 0, 0]) if True else pv
    with pytest.raises(ImpactError, match=r"no contact.*closest \d+\.\d+ m at frame \d+ \(\d+\.\d+ s\)"):
        find_first_contact(sc, aa, far)


def test_victim_on_the_ground_is_refused(kick):
    sc, aa, pv = kick
    lying, h, thr = on_ground(pv, 0)
    assert not lying and h > thr
    low = pv.translated([0, -0.5, 0])
    assert on_ground(low, 0)[0]
    fc = find_first_contact(sc, aa, pv)
    # lowered so that its head and chest are at the kick's height: still touched, but lying
    with pytest.raises(ImpactError, match="already on the ground"):
        find_first_contact(sc, aa, pv.translated([0, -0.45, 0]))
    assert fc.frame > 0


def test_blend_targets_ease_from_attacked_to_found():
    w = synthetic_walk(duration=1.0, fps=30.0).motion
    qa, qf = np.array(w.rotations[:10]), np.array(w.rotations[10:20])
    t = np.arange(10) / 30.0
    out = blend_targets(qa, qf, t, t[2], t[8])
    assert np.allclose(np.abs(np.sum(out[:3] * qa[:3], axis=-1)), 1.0)
    assert np.allclose(np.abs(np.sum(out[8:] * qf[8:], axis=-1)), 1.0)
    np.testing.assert_allclose(ease_in_out([0.0, 0.5, 1.0]), [0.0, 0.5, 1.0])


# ------------------------------------------------------------------ the whole response (mocomp.impact.pipeline)
@pytest.fixture(scope="module")
def response_inputs(real_data_dir, tmp_path_factory):
    from mocomp.impact.pipeline import load_library
    from mocomp.io import load

    v = load(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh")
    a = load(real_data_dir / "attacks" / "ase_rl_Atk_Kick.derived.bvh")
    index = load_library(real_data_dir / "reactions", v.skeleton, cache_dir=tmp_path_factory.mktemp("idx"))
    return a, v, index, [index.motion(c.path) for c in index.clips]


def test_response_lands_exactly_on_the_found_clip_at_reentry(response_inputs):
    from mocomp.impact.pipeline import ImpactConfig, impact_response

    a, v, index, lib = response_inputs
    raw = ImpactConfig(plant=False, lift=False)
    r = impact_response(a, v, index, Scenario(0.0, contact_body="right_foot"), raw, library_motions=lib)
    re = r.frames["reentry"]
    np.testing.assert_allclose(r.victim.root_positions[re], r.found.root_positions[-1], atol=1e-9)
    assert np.all(np.abs(np.sum(r.victim.rotations[re] * r.found.rotations[-1], axis=1)) > 1 - 1e-9)
    # the output starts as the victim's clip (placed) up to the rewind frame
    rw = r.frames["rewind"]
    assert r.naive.impact_time <= r.first_contact.time + 1e-9
    assert r.frames["reentry"] - r.frames["impact"] >= round((r.delay + 0.2) * v.fps) - 1
    # the match-time search ends the transition where the match is weighted most: a small root error,
    # much smaller than re-entering at the end of one 0.1-1.0 s window (measured 0.07 vs 0.31 m)
    end = impact_response(a, v, index, Scenario(0.0, contact_body="right_foot"),
                          ImpactConfig(plant=False, lift=False, reentry="window_end"), library_motions=lib)
    assert r.blend_active.root_error_m < 0.5 * end.blend_active.root_error_m
    assert r.evidence["search"]["query_windows"] > 1 and end.evidence["search"]["query_windows"] == 1
    assert rw == end.frames["rewind"]


def test_facing_sweep_gives_different_reactions_and_active_beats_naive(response_inputs):
    from mocomp.impact.pipeline import impact_response

    a, v, index, lib = response_inputs
    runs = {f: impact_response(a, v, index, Scenario(f, contact_body="right_foot"), library_motions=lib)
            for f in (0.0, 90.0, 180.0)}
    found = {(r.search.clip, r.search.frame) for r in runs.values()}
    assert len(found) == 3                                    # front, side, back: three reactions
    for r in runs.values():
        assert r.blend_active.joint_error_deg < r.blend_naive.joint_error_deg
        assert r.naive.warnings == {} and r.active.warnings == {}


def test_response_seed_draws_the_delay_deterministically(response_inputs):
    from mocomp.impact.pipeline import ImpactConfig, impact_response

    a, v, index, lib = response_inputs
    sc = Scenario(0.0, contact_body="right_foot")
    r1 = impact_response(a, v, index, sc, ImpactConfig(seed=3), library_motions=lib)
    r2 = impact_response(a, v, index, sc, ImpactConfig(seed=3), library_motions=lib)
    r3 = impact_response(a, v, index, sc, ImpactConfig(seed=4), library_motions=lib)
    assert 0.1 <= r1.delay <= 0.2 and r1.delay == r2.delay != r3.delay
    np.testing.assert_allclose(r1.victim.rotations, r2.victim.rotations, rtol=0, atol=0)
    np.testing.assert_allclose(r1.attacker.root_positions, r2.attacker.root_positions, rtol=0, atol=0)


def test_impact_config_refuses_bad_values():
    from mocomp.impact.pipeline import ImpactConfig

    with pytest.raises(ValueError, match="reentry"):
        ImpactConfig(reentry="end")
    with pytest.raises(ValueError, match="window"):
        ImpactConfig(window=(1.0, 0.1))
    with pytest.raises(ValueError, match="match_window"):
        ImpactConfig(match_window=2.0)
