"""The compiled momentum kernels (mocomp.dynamics._kernels) against the numpy reference path
of mocomp.dynamics.momentum, and against a closed-form answer.

The numpy path is what ``momentum`` runs when numba is missing (``_kernels.AVAILABLE`` False);
forcing it here gives the reference for every velocity mode. The compiled path must give the
same numbers to ~1e-12 relative, on the synthetic backflip with its exact rates and on a random
motion with random rates, random full inertia tensors and a root far from the origin.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dyn_helpers import rigid_spin, wavy_motion
from mocomp.body import BodyModel
from mocomp.core import Motion, _compiled
from mocomp.dynamics import MotionVelocities, _kernels, composite_inertia, momentum
from mocomp.dynamics.momentum import assemble_momentum
from mocomp.synth import make_example
from mocomp.synth.skeleton import synthetic_skeleton

#: these tests compare the compiled kernels with the numpy path: without numba (MOCOMP_NO_NUMBA=1)
#: there is only the numpy path, so they skip (the numpy path is tested in test_dynamics_momentum)
needs_numba = pytest.mark.skipif(not _kernels.AVAILABLE, reason="compiled backend off (MOCOMP_NO_NUMBA or no numba)")

FIELDS = ("com", "com_velocity", "linear", "angular", "segment_positions", "segment_velocities",
          "segment_angular_velocities")


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300))


def _reference(monkeypatch, fn):
    """``fn()`` on the numpy path (as without numba)."""
    with monkeypatch.context() as mp:
        mp.setattr(_kernels, "AVAILABLE", False)
        return fn()


def _assert_same(a, b, tol=1e-12):
    for f in FIELDS:
        assert _rel(getattr(a, f), getattr(b, f)) <= tol, f
    assert a.velocity_mode == b.velocity_mode and a.total_mass == b.total_mass
    assert a.smooth_sigma == b.smooth_sigma and a.order == b.order
    np.testing.assert_array_equal(a.times, b.times)


def random_case(seed: int = 3, n_frames: int = 97):
    """Random poses on the 31-joint synthetic skeleton (root 40 m from the origin), random rates and
    a body with random full (non-diagonal) inertia tensors and random local COMs."""
    rng = np.random.default_rng(seed)
    sk = synthetic_skeleton(1.8)
    J = sk.n_joints
    rot = Rotation.random(n_frames * J, random_state=seed).as_quat().reshape(n_frames, J, 4)
    root = np.array([40.0, 1.0, -25.0]) + rng.normal(0, 0.5, (n_frames, 3))
    m = Motion(sk, 90.0, root, rot)
    vel = MotionVelocities(rng.normal(0, 2.0, (n_frames, 3)), rng.normal(0, 5.0, (n_frames, 3)),
                           rng.normal(0, 8.0, (n_frames, J, 3)))
    b0 = BodyModel.from_skeleton(sk, 80.0)
    S = b0.n_segments
    A = rng.normal(0, 0.05, (S, 3, 3))
    inertias = A @ A.transpose(0, 2, 1) + 0.01 * np.eye(3)
    body = dataclasses.replace(b0, masses=rng.uniform(0.5, 12.0, S), inertias=inertias,
                               local_coms=rng.normal(0, 0.2, (S, 3)), geometry=None)
    return body, m, vel


@pytest.mark.skipif(_compiled.DISABLED, reason="MOCOMP_NO_NUMBA set: the numpy path runs by request")
def test_numba_is_there():
    """numba is a project dependency: the compiled path is the one that runs (unless switched off)."""
    assert _kernels.AVAILABLE


@needs_numba
def test_backflip_exact_rates_compiled_equals_numpy(monkeypatch):
    r = make_example("backflip")
    got = momentum(r.body, r.motion.replace(), velocity=r.velocities)
    ref = _reference(monkeypatch, lambda: momentum(r.body, r.motion.replace(), velocity=r.velocities))
    _assert_same(got, ref)
    # and the figure the rates exist for: L conserved over the flight (test_synth_conservation.py)
    a, b = r.flight
    assert np.max(np.linalg.norm(got.angular[a:b] - r.L0, axis=1)) / np.linalg.norm(r.L0) <= 1e-9


@needs_numba
@pytest.mark.parametrize("seed", [3, 11])
def test_random_motion_given_rates_compiled_equals_numpy(monkeypatch, seed):
    body, m, vel = random_case(seed)
    got = momentum(body, m.replace(), velocity=vel)
    ref = _reference(monkeypatch, lambda: momentum(body, m.replace(), velocity=vel))
    _assert_same(got, ref)
    # the numpy path really is a different computation (FK cache filled there, not here)
    fresh = m.replace()
    momentum(body, fresh, velocity=vel)
    assert "fk" not in fresh._cache


@needs_numba
@pytest.mark.parametrize("mode", ["finite_difference", "kinematic"])
@pytest.mark.parametrize("order", [2, 4])
def test_difference_modes_compiled_sums_equal_numpy(monkeypatch, mode, order):
    body, m, _ = random_case(5, n_frames=40)
    got = momentum(body, m, velocity=mode, order=order)
    ref = _reference(monkeypatch, lambda: momentum(body, m.replace(), velocity=mode, order=order))
    _assert_same(got, ref)
    sm = momentum(body, m, smooth_sigma=2.0)
    _assert_same(sm, _reference(monkeypatch, lambda: momentum(body, m.replace(), smooth_sigma=2.0)))


@needs_numba
def test_assemble_compiled_equals_numpy_and_checks_shapes(monkeypatch):
    body, m, _ = random_case(7, n_frames=30)
    rng = np.random.default_rng(0)
    S = body.n_segments
    rot = Rotation.random(30 * S, random_state=1).as_quat().reshape(30, S, 4)
    pos, vel, om = (rng.normal(0, 3.0, (30, S, 3)) for _ in range(3))
    got = assemble_momentum(body, m.times, pos, rot, vel, om, velocity_mode="kinematic")
    ref = _reference(monkeypatch, lambda: assemble_momentum(body, m.times, pos, rot, vel, om,
                                                            velocity_mode="kinematic"))
    _assert_same(got, ref)
    with pytest.raises(ValueError, match="vel must have shape"):
        assemble_momentum(body, m.times, pos, rot, vel[:, :-1], om)


@needs_numba
def test_compiled_rigid_spin_gives_L_equals_I_omega():
    """Closed form, no reference path: a frozen pose spinning at constant w about its principal axis
    with its COM drifting; the exact rates are w for the root, 0 for every joint and
    d/dt root = v_com + w x R(t)(-c0). Then L = I w and p = M v_com at every frame."""
    m0 = wavy_motion(60)
    body = BodyModel.from_skeleton(m0.skeleton, 72.0, shape="cuboid")
    still, _ = rigid_spin(body, np.zeros(3), 100, duration=0.1)
    evals, evecs = np.linalg.eigh(composite_inertia(body, still)[0])
    w = 2 * np.pi * 1.7 * evecs[:, 2]
    vc = np.array([0.5, 2.0, -0.3])
    m, c0 = rigid_spin(body, w, 100, duration=0.8, com_velocity=vc)
    R = Rotation.from_quat(m.rotations[:, 0])
    T, J = m.n_frames, m.skeleton.n_joints
    vel = MotionVelocities(vc + np.cross(w, R.apply(-c0)), np.tile(w, (T, 1)), np.zeros((T, J, 3)))
    r = momentum(body, m, velocity=vel)
    assert np.allclose(r.angular, evals[2] * w, rtol=0, atol=1e-11 * evals[2] * np.linalg.norm(w))
    assert np.allclose(r.linear, body.total_mass * vc, rtol=0, atol=1e-11 * body.total_mass)
    assert np.allclose(r.com, c0 + np.outer(m.times, vc), rtol=0, atol=1e-12)


def test_rates_for_another_motion_are_rejected_before_the_kernel():
    body, m, vel = random_case(3, n_frames=20)
    with pytest.raises(ValueError, match="do not fit"):
        momentum(body, m[:10], velocity=vel)
    short = MotionVelocities(vel.root_velocity, vel.root_angular_velocity, vel.joint_angular_velocities[:, :5])
    with pytest.raises(ValueError, match="do not fit"):
        momentum(body, m, velocity=short)
