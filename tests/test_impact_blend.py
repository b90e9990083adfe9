"""mocomp.impact.blend and .attacker: the final blend (sec. 4.2), floor lift, attacker blend-back."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
from mocomp.impact.attacker import attacker_response
from mocomp.impact.blend import correction, final_blend, floor_lift, frame_steps
from mocomp.ops.synthetic import synthetic_walk


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(duration=2.0, fps=30.0).motion


def _perturbed(m, seed=1, deg=20.0, shift=(0.3, -0.1, 0.2)):
    rng = np.random.default_rng(seed)
    J = m.skeleton.n_joints
    d = Rotation.from_rotvec(np.radians(deg) * rng.normal(size=(J, 3)) / np.sqrt(3)).as_quat()
    rot = quat_multiply(m.rotations, np.broadcast_to(d, m.rotations.shape))
    return m.replace(root_positions=m.root_positions + np.asarray(shift), rotations=rot)


def test_final_blend_starts_on_sim_ends_on_clip_and_spreads_root_error_linearly(walk):
    sim = _perturbed(walk)
    out = final_blend(sim, walk)
    m = out.motion
    np.testing.assert_allclose(m.root_positions[0], sim.root_positions[0], atol=1e-12)
    np.testing.assert_allclose(m.root_positions[-1], walk.root_positions[-1], atol=1e-12)
    assert np.allclose(np.abs(np.einsum("jk,jk->j", m.rotations[0], sim.rotations[0])), 1.0, atol=1e-12)
    assert np.allclose(np.abs(np.einsum("jk,jk->j", m.rotations[-1], walk.rotations[-1])), 1.0, atol=1e-12)
    n = m.n_frames - 1
    w = np.arange(n + 1)[:, None] / n
    e = walk.root_positions[-1] - sim.root_positions[-1]
    np.testing.assert_allclose(m.root_positions, (1 - w) * sim.root_positions + w * walk.root_positions, atol=1e-12)
    end = final_blend(sim, walk, root="end_error").motion
    np.testing.assert_allclose(end.root_positions - sim.root_positions, w * e, atol=1e-12)
    # at the seam the interpolated root moves with the clip plus the error rate, not with the simulation
    v_clip = walk.root_positions[-1] - walk.root_positions[-2]
    v_out = m.root_positions[-1] - m.root_positions[-2]
    assert np.linalg.norm(v_out - v_clip) <= np.linalg.norm(walk.root_positions - sim.root_positions, axis=1)[-2] / n + 1e-12
    # joints: the slerp weight i/n -> the angle to the sim is i/n of the sim-clip angle
    a_total = quat_angle(quat_multiply(quat_inverse(sim.rotations), walk.rotations))
    a_moved = quat_angle(quat_multiply(quat_inverse(sim.rotations), m.rotations))
    np.testing.assert_allclose(a_moved, np.arange(n + 1)[:, None] / n * a_total, atol=1e-9)
    assert out.root_error_m == pytest.approx(np.linalg.norm(e))
    assert out.joint_error_deg == pytest.approx(np.degrees(a_total[-1]).mean())


def test_correction_is_zero_on_the_clip_itself_and_grows_with_the_error(walk):
    c0 = correction(walk, walk)
    assert c0["root_error_m"] == pytest.approx(0.0, abs=1e-12) and c0["mean_correction_deg"] < 1e-5
    c1 = correction(_perturbed(walk, deg=10), walk)
    c2 = correction(_perturbed(walk, deg=30), walk)
    assert 0 < c1["mean_correction_deg"] < c2["mean_correction_deg"]


def test_final_blend_refuses_mismatched_frames(walk):
    with pytest.raises(ValueError, match="same frames"):
        final_blend(walk.slice(0, 10), walk)
    with pytest.raises(ValueError, match="interpolate"):
        final_blend(walk, walk, root="linear")


def test_floor_lift_raises_only_sunk_frames_and_smoothly(walk):
    n = walk.n_frames
    def lowest(m):
        return np.minimum(m.positions[..., 1].min(axis=1), m.end_site_positions()[..., 1].min(axis=1))

    low0 = lowest(walk)
    floor = float(low0.min())
    sink = np.zeros(n)
    sink[25:31] = 0.15                                   # a stretch sunk 15 cm (like the ASE falls)
    sunk = walk.replace(root_positions=walk.root_positions - sink[:, None] * np.array([0, 1, 0]))
    out, lift = floor_lift(sunk, floor, tolerance=0.005)
    low = lowest(out)
    assert np.all(low >= floor - 0.005 - 1e-9)
    assert lift[25:31].min() >= 0.15 - (floor - low0[25:31]).max() - 0.005 - 1e-9
    assert np.all(lift[:3] == 0) and np.all(lift[-3:] == 0)
    dr, _ = frame_steps(out)
    assert np.abs(np.diff(lift)).max() < 0.15                # no single-frame jump of the full 15 cm
    untouched, none = floor_lift(walk.translated([0, 1.0, 0]), floor)
    assert not none.any() and untouched.n_frames == n


def test_frame_steps_measures_root_and_joint_steps(walk):
    dr, dq = frame_steps(walk)
    np.testing.assert_allclose(dr, np.linalg.norm(np.diff(walk.root_positions, axis=0), axis=1))
    assert dq.shape == (walk.n_frames - 1,) and np.all(dq >= 0)


def test_attacker_follows_the_simulation_then_returns_to_its_clip(walk):
    fps = walk.fps
    rewind = 5
    sim = _perturbed(walk.slice(rewind), deg=15, shift=(0.1, 0.0, 0.05))
    res = attacker_response(walk, sim, rewind, impact_time=(rewind + 0.5) / fps, contact_end=(rewind + 2) / fps,
                            follow=0.1, max_follow=0.3, blend=0.2)
    out = res.motion
    assert out.n_frames == walk.n_frames
    np.testing.assert_allclose(out.root_positions[:rewind], walk.root_positions[:rewind])
    nf = res.follow_frames
    assert nf >= 2                                             # at least until the contact ended
    np.testing.assert_allclose(out.root_positions[rewind:rewind + nf + 1], sim.root_positions[:nf + 1])
    after = rewind + nf + res.blend_frames + 1
    np.testing.assert_allclose(out.root_positions[after:], walk.root_positions[after:], atol=1e-12)
    ang = quat_angle(quat_multiply(quat_inverse(out.rotations[after:]), walk.rotations[after:]))
    assert ang.max() < 1e-6
    # the blend back is gradual: no step larger than the offset it removes spread over the blend frames
    dr, _ = frame_steps(out)
    d0 = np.linalg.norm(sim.root_positions[nf] - walk.root_positions[rewind + nf])
    assert dr[rewind + nf:after].max() <= np.abs(np.diff(walk.root_positions[:, 0])).max() + d0 / 2 + 1e-9


def test_floor_lift_leaves_frames_before_start_alone_and_eases_in(walk):
    low0 = np.minimum(walk.positions[..., 1].min(axis=1), walk.end_site_positions()[..., 1].min(axis=1))
    floor = float(low0.min())
    sink = np.zeros(walk.n_frames)
    sink[25:31] = 0.15
    sunk = walk.replace(root_positions=walk.root_positions - sink[:, None] * np.array([0, 1, 0]))
    out, lift = floor_lift(sunk, floor, tolerance=0.005, start=20, ramp_frames=5)
    assert np.all(lift[:20] == 0)
    np.testing.assert_allclose(out.root_positions[:20], sunk.root_positions[:20])
    low = np.minimum(out.positions[..., 1].min(axis=1), out.end_site_positions()[..., 1].min(axis=1))
    assert np.all(low[20:] >= floor - 0.005 - 1e-9)
    assert np.all(np.diff(lift[20:26]) >= -1e-12)          # eased in, not a step at the start


def test_correction_splits_the_root_error_into_vertical_and_horizontal(walk):
    sim = walk.replace(root_positions=walk.root_positions + np.array([0.3, -0.4, 0.0]))
    out = final_blend(sim, walk)
    assert out.root_error_m == pytest.approx(0.5)
    assert out.root_error_vertical_m == pytest.approx(0.4)            # clip minus simulation, signed
    assert out.root_error_horizontal_m == pytest.approx(0.3)
    d = out.to_dict()
    assert d["root_error_vertical_m"] == pytest.approx(0.4) and d["root_error_horizontal_m"] == pytest.approx(0.3)
