"""Analytic test motions for the dynamics tests (continuous in time, sampled at any fps)."""
import numpy as np
from scipy.spatial.transform import Rotation

from mocomp.core import Motion
from test_body_tables import _stick_skeleton


def wavy_motion(fps: float, duration: float = 1.0, seed: int = 0, height: float = 1.75, speed: float = 1.0):
    """Every joint rotates by smooth sinusoidal rotation vectors; the root tumbles and travels.
    ``speed`` plays the same continuous motion ``speed`` times faster."""
    sk = _stick_skeleton(height)
    rng = np.random.default_rng(seed)
    J = sk.n_joints
    n = int(round(duration * fps)) + 1
    t = np.arange(n) / fps * speed
    amp = rng.uniform(0.2, 0.7, (J, 3))
    freq = rng.uniform(0.5, 1.5, (J, 3))
    ph = rng.uniform(0, 2 * np.pi, (J, 3))
    rv = amp[None] * np.sin(2 * np.pi * freq[None] * t[:, None, None] + ph[None])
    rv[:, 0] = np.stack([1.3 * t, 2.1 * t + 0.3 * np.sin(3 * t), 0.4 * np.cos(2 * t)], axis=1)
    rot = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(n, J, 4)
    root = np.stack([0.4 * t, 1.0 + 0.3 * np.sin(2 * t), -0.2 * t + 0.1 * np.cos(5 * t)], axis=1)
    return Motion(sk, fps, root, rot)


def rigid_spin(body, omega, fps: float, duration: float = 1.0, pose_seed: int = 1, com_velocity=(0.0, 0.0, 0.0)):
    """A frozen random pose spinning rigidly at constant ``omega`` (rad/s, world) about its COM,
    which moves at constant ``com_velocity``."""
    sk = body.skeleton
    rng = np.random.default_rng(pose_seed)
    pose = Rotation.from_rotvec(rng.normal(0, 0.4, (sk.n_joints, 3))).as_quat()
    pose[0] = [0, 0, 0, 1]
    one = Motion(sk, fps, np.zeros((1, 3)), pose[None])
    P, G = one.fk()
    seg = P[0, body.segment_joint] + Rotation.from_quat(np.array(G[0, body.segment_joint])).apply(np.array(body.local_coms))
    c0 = body.masses @ seg / body.total_mass
    n = int(round(duration * fps)) + 1
    t = np.arange(n) / fps
    R = Rotation.from_rotvec(np.outer(t, omega))
    root = c0 + np.outer(t, com_velocity) + R.apply(-c0)
    rot = np.repeat(pose[None], n, axis=0)
    rot[:, 0] = R.as_quat()
    return Motion(sk, fps, root, rot), c0
