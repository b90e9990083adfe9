"""Rotation-vector calculus used by the generator (vectorised, scalar-last quaternions): the
Jacobians of SO(3) and axis rotations. Exp/Log, products and matrices are core's
(:mod:`mocomp.core.rotations`: ``quat_exp``, ``quat_log``, ``quat_matrix``, ``quat_from_matrix``).

A joint's local rotation in a scripted phase is ``Exp(phi(t))`` for a smooth
rotation vector ``phi(t)``; its angular velocity in the child (body) frame is
``J_r(phi) phi_dot`` with the right Jacobian of SO(3)
(``J_r(phi) = I - (1 - cos a)/a^2 [phi]x + (a - sin a)/a^3 [phi]x^2``, ``a = |phi|``),
and in the parent frame ``J_l(phi) phi_dot`` (``J_l(phi) = J_r(-phi)``).
These closed forms are checked against finite differences of
:func:`~mocomp.core.rotations.quat_exp` in the tests.
"""
from __future__ import annotations

import numpy as np

__all__ = ["right_jacobian", "left_jacobian", "skew", "rot_x", "rot_y", "rot_z"]


def skew(v: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` cross-product matrices of ``(..., 3)`` vectors."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def _jac_coeffs(a: np.ndarray):
    small = a < 1e-5
    safe = np.where(small, 1.0, a)
    c1 = np.where(small, 0.5 - a * a / 24.0, (1.0 - np.cos(safe)) / safe**2)
    c2 = np.where(small, 1.0 / 6.0 - a * a / 120.0, (safe - np.sin(safe)) / safe**3)
    return c1, c2


def right_jacobian(phi: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` right Jacobian of SO(3): body angular velocity = ``J_r(phi) @ phi_dot``."""
    phi = np.asarray(phi, dtype=float)
    a = np.linalg.norm(phi, axis=-1)
    c1, c2 = _jac_coeffs(a)
    K = skew(phi)
    return np.eye(3) - c1[..., None, None] * K + c2[..., None, None] * (K @ K)


def left_jacobian(phi: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` left Jacobian: spatial (parent-frame) angular velocity = ``J_l(phi) @ phi_dot``."""
    return right_jacobian(-np.asarray(phi, dtype=float))


def _axis_quat(axis: int, angle) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    q = np.zeros(angle.shape + (4,))
    q[..., axis] = np.sin(0.5 * angle)
    q[..., 3] = np.cos(0.5 * angle)
    return q


def rot_x(angle) -> np.ndarray:
    """Quaternions of rotations by ``angle`` (radians) about x."""
    return _axis_quat(0, angle)


def rot_y(angle) -> np.ndarray:
    """Quaternions of rotations by ``angle`` (radians) about y."""
    return _axis_quat(1, angle)


def rot_z(angle) -> np.ndarray:
    """Quaternions of rotations by ``angle`` (radians) about z."""
    return _axis_quat(2, angle)
