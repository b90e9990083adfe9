"""Finite differences on true frame times and angular velocity from quaternions."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.dynamics.derivatives import (angular_velocity, central_difference, gaussian_smooth,
                                         second_difference, smooth_quaternions)


def test_central_difference_exact_for_quadratics_on_uneven_times():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.02, 50))
    x = np.stack([3 * t**2 - t + 2, -0.5 * t**2, 7 * t], axis=1)
    dx = central_difference(x, t)
    exact = np.stack([6 * t - 1, -t, np.full_like(t, 7)], axis=1)
    assert np.allclose(dx[1:-1], exact[1:-1], atol=1e-9)
    # one-sided (first order) at the ends: exact for the linear column only
    assert np.allclose(dx[[0, -1], 2], 7)
    assert np.allclose(central_difference(x, t, edge_order=2), exact, atol=1e-8)
    assert np.allclose(second_difference(x[:, :2], t)[2:-2], [[6, -1]] * 46, atol=1e-6)


def test_scalar_times_is_a_frame_rate():
    x = np.arange(10.0) ** 2
    assert np.allclose(central_difference(x, 10.0)[1:-1], 2 * np.arange(1, 9) * 10)


def test_bad_times_raise():
    with pytest.raises(ValueError, match="increase strictly"):
        central_difference(np.zeros(3), [0, 0.1, 0.1])
    with pytest.raises(ValueError, match="at least 2 frames"):
        central_difference(np.zeros((1, 3)), [0.0])


def test_angular_velocity_exact_for_constant_rate_on_uneven_times():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.004, 0.012, 80))
    w = np.array([1.5, -4.0, 2.2])
    q0 = Rotation.from_rotvec([0.3, 0.2, -1.0])
    q = (Rotation.from_rotvec(np.outer(t, w)) * q0).as_quat()
    q[::3] *= -1  # sign flips are irrelevant
    om = angular_velocity(q, t)
    assert np.allclose(om, w, atol=1e-10)


def _two_axis(t, a=2.0, b=3.0):
    """q(t) = Rz(a t) Rx(b t): world angular velocity a e_z + Rz(a t) b e_x."""
    Rz = Rotation.from_rotvec(np.outer(t, [0, 0, a]))
    Rx = Rotation.from_rotvec(np.outer(t, [b, 0, 0]))
    q = (Rz * Rx).as_quat()
    w = np.array([0, 0, a]) + Rz.apply(np.array([b, 0, 0]))
    return q, w


def test_angular_velocity_second_order_convergence():
    errs = []
    for fps in (30, 60, 120, 240):
        t = np.arange(int(fps) + 1) / fps
        q, w = _two_axis(t)
        errs.append(np.abs(angular_velocity(q, t)[1:-1] - w[1:-1]).max())
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all(ratios > 3.5) and errs[-1] < 1e-3


def test_angular_velocity_batched_shape():
    t = np.arange(11) / 10
    q, w = _two_axis(t)
    qq = np.stack([q, q, q], axis=1)
    assert angular_velocity(qq, t).shape == (11, 3, 3)


def test_gaussian_smoothing_preserves_lines_and_unit_quaternions():
    x = np.linspace(0, 1, 50)[:, None] * [1.0, 2.0]
    assert np.allclose(gaussian_smooth(x, 2.0)[10:-10], x[10:-10])
    assert np.array_equal(gaussian_smooth(x, 0), x)
    rng = np.random.default_rng(1)
    q = Rotation.from_rotvec(np.cumsum(rng.normal(0, 0.05, (40, 3)), 0)).as_quat()
    s = smooth_quaternions(q, 1.5)
    assert np.allclose(np.linalg.norm(s, axis=1), 1)
    # smoothing moves each orientation by much less than the random walk's spread
    assert (Rotation.from_quat(s).inv() * Rotation.from_quat(q)).magnitude().max() < 0.1
    with pytest.raises(ValueError):
        gaussian_smooth(x, -1)


def test_fourth_order_differences_converge_faster():
    e2, e4, w4 = [], [], []
    for fps in (30, 60, 120):
        t = np.arange(int(fps) + 1) / fps
        x = np.sin(3 * t)[:, None] * [1.0, -2.0]
        dx = 3 * np.cos(3 * t)[:, None] * [1.0, -2.0]
        e2.append(np.abs(central_difference(x, t)[2:-2] - dx[2:-2]).max())
        e4.append(np.abs(central_difference(x, t, order=4)[2:-2] - dx[2:-2]).max())
        q, w = _two_axis(t)
        w4.append(np.abs(angular_velocity(q, t, order=4)[2:-2] - w[2:-2]).max())
    assert all(a / b > 14 for a, b in zip(e4, e4[1:])), e4
    assert all(a / b > 14 for a, b in zip(w4, w4[1:])), w4
    assert all(a / b > 3.5 for a, b in zip(e2, e2[1:]))
    assert e4[-1] < 1e-3 * e2[-1]
    with pytest.raises(ValueError, match="uniformly spaced"):
        central_difference(np.zeros((6, 2)), [0, 0.1, 0.2, 0.35, 0.4, 0.5], order=4)
