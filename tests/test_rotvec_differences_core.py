"""Rotation-vector differences written with core's quaternion log (issue 14) against the scipy
``Rotation`` code they replaced, as the oracle: impact.convert.local_angular_velocity,
edit.smooth_direction.second_difference_deg and flips.similarity.local_angular_velocities."""
import numpy as np
from scipy.spatial.transform import Rotation

from mocomp.edit.smooth_direction import second_difference_deg
from mocomp.flips.similarity import local_angular_velocities
from mocomp.impact.convert import local_angular_velocity


def _walk(n, seed, step=0.3):
    """A random walk of unit quaternions with random signs (steps up to ~``step`` rad), plus a
    near-pi step and a zero step."""
    rng = np.random.default_rng(seed)
    r = Rotation.random(random_state=seed)
    qs = [r.as_quat()]
    for i in range(n - 1):
        if i == 3:
            d = Rotation.from_rotvec([0.0, 0.0, 0.0])
        elif i == 5:
            d = Rotation.from_rotvec([0.0, np.pi - 1e-6, 0.0])
        else:
            d = Rotation.from_rotvec(rng.normal(size=3) * step / np.sqrt(3))
        r = d * r
        qs.append(r.as_quat())
    q = np.array(qs)
    return q * rng.choice([-1.0, 1.0], size=(n, 1))


def test_local_angular_velocity_matches_scipy():
    for seed in range(4):
        q = _walk(40, seed)
        q0, q1 = q[:-1], q[1:]
        old = (Rotation.from_quat(q0).inv() * Rotation.from_quat(q1)).as_rotvec() / 0.01
        np.testing.assert_allclose(local_angular_velocity(q0, q1, 0.01), old, rtol=1e-10, atol=1e-9)
        # leading shapes are kept
        got = local_angular_velocity(q0.reshape(3, 13, 4), q1.reshape(3, 13, 4), 0.01)
        np.testing.assert_allclose(got.reshape(-1, 3), old, rtol=1e-10, atol=1e-9)
    # slightly non-unit inputs (a qpos read back from a simulator) give scipy's answer too
    q = _walk(20, 9)
    q0, q1 = q[:-1] * 1.001, q[1:] * 0.999
    old = (Rotation.from_quat(q0).inv() * Rotation.from_quat(q1)).as_rotvec() / 0.02
    np.testing.assert_allclose(local_angular_velocity(q0, q1, 0.02), old, rtol=1e-9, atol=1e-9)


def test_second_difference_deg_matches_scipy():
    for seed in range(4):
        q = _walk(30, seed, step=0.2)
        inc = (Rotation.from_quat(q[1:]) * Rotation.from_quat(q[:-1]).inv()).as_rotvec()
        old = np.degrees(np.linalg.norm(inc[2:] - 2 * inc[1:-1] + inc[:-2], axis=1))
        np.testing.assert_allclose(second_difference_deg(q), old, rtol=1e-9, atol=1e-8)
    assert second_difference_deg(_walk(3, 1)).shape == (0,)


def test_local_angular_velocities_match_scipy():
    q = np.stack([_walk(25, s, step=0.15) for s in range(3)], axis=1)          # (T, J, 4)
    T = q.shape[0]
    nxt = np.concatenate([q[1:], q[-1:]])
    prv = np.concatenate([q[:1], q[:-1]])
    span = np.full(T, 2.0)
    span[0] = span[-1] = 1.0
    rel = Rotation.from_quat(nxt.reshape(-1, 4)) * Rotation.from_quat(prv.reshape(-1, 4)).inv()
    old = rel.as_rotvec().reshape(q.shape[:-1] + (3,)) * (120.0 / span)[:, None, None]
    np.testing.assert_allclose(local_angular_velocities(q, 120.0), old, rtol=1e-10, atol=1e-8)
