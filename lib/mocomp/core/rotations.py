"""Rotation helpers on top of :class:`scipy.spatial.transform.Rotation`.

Quaternions are unit quaternions in scipy's scalar-last order ``(x, y, z, w)``
and arrays of them have shape ``(..., 4)``.

This module is the numpy reference of the project's one kinematics kernel
(DESIGN.md, "One kinematics kernel"): the quaternion product, rotation of
vectors, inverse, logarithm/exponential (rotation vectors), power, slerp and
rotation matrices, written once, broadcasting over any leading shape, each
tested against :class:`scipy.spatial.transform.Rotation` /
:class:`~scipy.spatial.transform.Slerp`. They are written out rather than
calling scipy because they broadcast without flattening and cost a few array
operations each (scipy's ``Rotation`` objects cost tens of microseconds to build,
which dominates on the small arrays of the run-time stages). The compiled twins
(same operations, same order) are the inline helpers of
:mod:`mocomp.core._compiled`; method packages use these two modules and carry no
quaternion algebra of their own. Beyond that, only what scipy lacks lives here:
hemisphere continuity, the swing/twist split about an axis, and converting BVH
channel names to scipy's Euler sequence.

Quaternion algebra: J. Sola, "Quaternion kinematics for the error-state Kalman
filter" (2017), eq. 12 (product), eq. 101-105 (exponential and logarithm),
and K. Shoemake, "Animating rotation with quaternion curves", SIGGRAPH 1985
(slerp).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "as_rotation",
    "quat_identity",
    "quat_multiply",
    "quat_inverse",
    "quat_apply",
    "quat_angle",
    "quat_log",
    "quat_exp",
    "quat_pow",
    "quat_matrix",
    "quat_from_matrix",
    "slerp",
    "cross",
    "shortest_arc",
    "make_continuous",
    "swing_twist",
    "axis_quat",
    "twist_angle",
    "euler_sequence",
    "euler_to_quat",
]


def quat_identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity quaternions of the given leading shape: ``shape + (4,)``."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 3] = 1.0
    return q


def as_rotation(q: np.ndarray) -> Rotation:
    """A scipy ``Rotation`` stack from quaternions of any leading shape (flattened)."""
    q = np.asarray(q, dtype=float)
    return Rotation.from_quat(q.reshape(-1, 4))


def _components(a: np.ndarray, axis: int) -> tuple:
    if axis == -1:
        return tuple(a[..., k] for k in range(a.shape[-1]))
    if axis == 0:
        return tuple(a)
    raise ValueError(f"the component axis must be -1 (last) or 0 (first), got {axis}")


def quat_multiply(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None, axis: int = -1) -> np.ndarray:
    """Hamilton product ``a * b`` (apply ``b`` first, then ``a``), broadcasting (Sola 2017, eq. 12).

    Equivalent to ``(Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()``
    without canonicalising the sign; written out so that it broadcasts over any
    leading shape without flattening (tests compare it with scipy). ``out``: an
    array of the broadcast shape to write into (may not alias ``a`` or ``b``).
    ``axis``: where the four components are, ``-1`` (``(..., 4)``, the default) or
    ``0`` (``(4, ...)``, component-major: contiguous rows, as forward kinematics uses).
    The compiled twin is :func:`mocomp.core._compiled.qmul`.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = _components(a, axis)
    bx, by, bz, bw = _components(b, axis)
    if out is None:
        out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    ox, oy, oz, ow = _components(out, axis)
    ox[...] = aw * bx + ax * bw + ay * bz - az * by
    oy[...] = aw * by - ax * bz + ay * bw + az * bx
    oz[...] = aw * bz + ax * by - ay * bx + az * bw
    ow[...] = aw * bw - ax * bx - ay * by - az * bz
    return out


def quat_inverse(q: np.ndarray) -> np.ndarray:
    """Inverse (conjugate) of unit quaternions."""
    q = np.array(q, dtype=float, copy=True)
    q[..., :3] *= -1.0
    return q


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` on the last axis, broadcasting (``numpy.cross`` has a large per-call overhead)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = ay * bz - az * by
    out[..., 1] = az * bx - ax * bz
    out[..., 2] = ax * by - ay * bx
    return out


def quat_apply(q: np.ndarray, v: np.ndarray, axis: int = -1) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)``, broadcasting.

    Uses ``v' = v + 2 w (u x v) + 2 u x (u x v)`` with ``q = (u, w)`` (Sola 2017,
    eq. 111, expanded). ``R(q)^T v`` is ``quat_apply(quat_inverse(q), v)``. ``axis``: where
    the components of ``q``, ``v`` and the result are, last (``-1``) or first (``0``), as in
    :func:`quat_multiply`. The compiled twin is :func:`mocomp.core._compiled.qrot`.
    """
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    ux, uy, uz, w = _components(q, axis)
    vx, vy, vz = _components(v, axis)
    # written out (np.cross has a large per-call overhead); same operations as
    # t = 2 (u x v); v + w t + u x t
    tx = 2.0 * (uy * vz - uz * vy)
    ty = 2.0 * (uz * vx - ux * vz)
    tz = 2.0 * (ux * vy - uy * vx)
    lead = np.broadcast_shapes(tx.shape, vx.shape)
    out = np.empty(lead + (3,) if axis == -1 else (3,) + lead)
    ox, oy, oz = _components(out, axis)
    ox[...] = vx + w * tx + (uy * tz - uz * ty)
    oy[...] = vy + w * ty + (uz * tx - ux * tz)
    oz[...] = vz + w * tz + (ux * ty - uy * tx)
    return out


def quat_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle in ``[0, pi]`` of unit quaternions (sign-independent): ``2 atan2(|u|, |w|)``.
    The compiled twin is :func:`mocomp.core._compiled.qangle`."""
    q = np.asarray(q, dtype=float)
    return 2.0 * np.arctan2(np.sqrt(np.einsum("...i,...i->...", q[..., :3], q[..., :3])), np.abs(q[..., 3]))


def quat_log(q: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` of unit quaternions, the short way (angle in ``[0, pi]``).

    ``Log(q) = 2 atan2(|u|, w) u / |u|`` for ``q = (u, w)`` with ``w >= 0`` (Sola 2017,
    eq. 105); ``2 u`` below ``|u| = 1e-12``. Same as ``Rotation.as_rotvec`` (tested).
    The compiled twin is :func:`mocomp.core._compiled.qlog`.
    """
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., 3:4] < 0.0, -q, q)
    v = q[..., :3]
    s = np.sqrt(np.einsum("...i,...i->...", v, v))
    big = s > 1e-12
    k = np.where(big, 2.0 * np.arctan2(s, q[..., 3]) / np.where(big, s, 1.0), 2.0)
    return v * k[..., None]


def quat_exp(phi: np.ndarray) -> np.ndarray:
    """Unit quaternions of rotation vectors ``phi (..., 3)``: ``(sin(a/2) phi/a, cos(a/2))``,
    ``a = |phi|`` (Sola 2017, eq. 101); ``(phi/2, 1)`` below ``a = 1e-12``. Same as
    ``Rotation.from_rotvec`` (tested). The compiled twin is :func:`mocomp.core._compiled.qexp`."""
    phi = np.asarray(phi, dtype=float)
    a = np.sqrt(np.einsum("...i,...i->...", phi, phi))[..., None]
    big = a > 1e-12
    k = np.where(big, np.sin(0.5 * a) / np.where(big, a, 1.0), 0.5)
    out = np.empty(phi.shape[:-1] + (4,))
    out[..., :3] = phi * k
    out[..., 3:] = np.cos(0.5 * a)
    return out


def quat_pow(q: np.ndarray, t) -> np.ndarray:
    """``q^t = Exp(t Log(q))`` (slerp from the identity, the short way) for unit ``q (..., 4)``
    and weights ``t`` broadcasting against ``q[..., 0]``. The compiled twin is
    :func:`mocomp.core._compiled.qpow`."""
    q = np.asarray(q, dtype=float)
    t = np.asarray(t, dtype=float)
    q = q * np.where(q[..., 3:4] < 0.0, -1.0, 1.0)
    vn = np.sqrt(np.einsum("...i,...i->...", q[..., :3], q[..., :3]))
    half = np.arctan2(vn, q[..., 3])
    th = t * half
    big = vn > 1e-12
    scale = np.where(big, np.sin(th) / np.where(big, vn, 1.0), t)
    out = np.empty(np.broadcast_shapes(q.shape, np.shape(t) + (1,)))
    out[..., :3] = q[..., :3] * scale[..., None]
    out[..., 3] = np.where(big, np.cos(th), 1.0)
    return out


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` rotation matrices of unit quaternions ``(..., 4)`` (Sola 2017, eq. 115);
    as ``Rotation.as_matrix`` (tested). The compiled twin is :func:`mocomp.core._compiled.qmat`."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - z * w)
    out[..., 0, 2] = 2 * (x * z + y * w)
    out[..., 1, 0] = 2 * (x * y + z * w)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - x * w)
    out[..., 2, 0] = 2 * (x * z - y * w)
    out[..., 2, 1] = 2 * (y * z + x * w)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` (scalar-last, ``w >= 0``) of rotation matrices ``(..., 3, 3)``,
    the inverse of :func:`quat_matrix`: S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance
    and Control 1(3), 1978 -- of ``4 w^2 = 1 + tr R`` and ``4 x^2 = 1 + 2 R_00 - tr R`` (and y, z
    alike) the largest is used for the square root, the other three components follow from the
    off-diagonal sums/differences (no cancellation); the same as ``Rotation.from_matrix(R).as_quat()``
    up to sign for orthonormal ``R`` (tested; scipy also orthonormalises a matrix that is not)."""
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"rotation matrices must have shape (..., 3, 3), got {R.shape}")
    r00, r11, r22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    # 4 * (x^2, y^2, z^2, w^2): pick the largest per matrix
    d = np.stack([1.0 + 2.0 * r00 - tr, 1.0 + 2.0 * r11 - tr, 1.0 + 2.0 * r22 - tr, 1.0 + tr], axis=-1)
    k = np.argmax(d, axis=-1)
    s21, s12 = R[..., 2, 1], R[..., 1, 2]
    s02, s20 = R[..., 0, 2], R[..., 2, 0]
    s10, s01 = R[..., 1, 0], R[..., 0, 1]
    # 4 x_k q for each choice k: rows are (4xq, 4yq, 4zq, 4wq) without the square-root scale
    c = np.empty(R.shape[:-2] + (4, 4))
    c[..., 0, :] = np.stack([d[..., 0], s01 + s10, s02 + s20, s21 - s12], axis=-1)
    c[..., 1, :] = np.stack([s01 + s10, d[..., 1], s12 + s21, s02 - s20], axis=-1)
    c[..., 2, :] = np.stack([s02 + s20, s12 + s21, d[..., 2], s10 - s01], axis=-1)
    c[..., 3, :] = np.stack([s21 - s12, s02 - s20, s10 - s01, d[..., 3]], axis=-1)
    q = np.take_along_axis(c, k[..., None, None], axis=-2)[..., 0, :]
    q = q / np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]
    return np.where(q[..., 3:4] < 0.0, -q, q)


def slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray, nlerp_below: float | None = None) -> np.ndarray:
    """Spherical linear interpolation between unit quaternions, broadcasting (Shoemake 1985).

    ``t`` has the leading shape of ``q0[..., 0]`` (or broadcasts to it). Takes the
    short way (flips ``q1`` into ``q0``'s hemisphere); the result is normalised.
    Agrees with ``scipy.spatial.transform.Slerp`` (tested). Pairs closer than
    ``nlerp_below`` radians of half-angle (``|q0 . q1| >= cos(nlerp_below)``; default:
    none) and pairs with ``sin(theta) < 1e-9`` use the normalised linear interpolation,
    which differs from slerp by at most ``theta^3 / 12`` and needs no trigonometric
    functions. The compiled twin is :func:`mocomp.core._compiled.slerp4`.
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.minimum(np.abs(dot), 1.0)
    theta = np.arccos(dot)
    sin = np.sin(theta)
    small = sin < 1e-9
    if nlerp_below is not None:
        small |= dot >= np.cos(nlerp_below)
    safe = np.where(small, 1.0, sin)
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(small, t, np.sin(t * theta) / safe)
    out = w0 * q0 + w1 * q1
    return out / np.sqrt(np.sum(out * out, axis=-1, keepdims=True))


def shortest_arc(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Quaternions of the shortest rotations taking directions ``u`` to ``v`` (``(..., 3)``,
    broadcasting; need not be unit): ``(u x v, 1 + u . v)`` normalised, for unit ``u``, ``v``
    (the half-way vector construction). Exactly opposite directions (that quaternion's norm
    below 1e-9) have no unique shortest arc; they get a rotation by pi about ``u x e``, ``e``
    the x axis, or the y axis when ``u`` is within ~26 degrees of x (a deterministic choice)."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u = u / np.sqrt(np.einsum("...i,...i->...", u, u))[..., None]
    v = v / np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    u, v = np.broadcast_arrays(u, v)
    q = np.empty(u.shape[:-1] + (4,))
    q[..., :3] = cross(u, v)
    q[..., 3] = 1.0 + np.einsum("...i,...i->...", u, v)
    n = np.sqrt(np.einsum("...i,...i->...", q, q))
    bad = n < 1e-9
    if np.any(bad):
        ub = u[bad]
        alt = np.where(np.abs(ub[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
        perp = cross(ub, alt)
        perp /= np.sqrt(np.einsum("...i,...i->...", perp, perp))[..., None]
        q[bad] = np.concatenate([perp, np.zeros((perp.shape[0], 1))], axis=-1)
        n = np.where(bad, 1.0, n)
    return q / n[..., None]


def make_continuous(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip quaternion signs so consecutive samples along ``axis`` lie in one hemisphere.

    ``q`` and ``-q`` are the same rotation; interpolation and finite differences
    need neighbours with a positive dot product.
    """
    q = np.moveaxis(np.array(q, dtype=float, copy=True), axis, 0)
    if q.shape[0] > 1:
        dots = np.sum(q[1:] * q[:-1], axis=-1)
        flips = np.cumprod(np.where(dots < 0.0, -1.0, 1.0), axis=0)
        q[1:] *= flips[..., None]
    return np.moveaxis(q, 0, axis)


def swing_twist(q: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split rotations into ``q = swing * twist`` with ``twist`` about ``axis``.

    ``twist`` is the projection of the quaternion onto ``axis`` (renormalised);
    ``swing`` has no component about ``axis``. ``axis`` broadcasts against ``q``
    (shape ``(..., 3)``). Used for the root split ``q_r = q_P q_L`` of the flips
    dissertation eq. 5.14, where the twist part is the rotation about L.
    """
    q = np.asarray(q, dtype=float)
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    proj = np.sum(q[..., :3] * axis, axis=-1, keepdims=True) * axis
    twist = np.concatenate([proj, q[..., 3:4]], axis=-1)
    norm = np.linalg.norm(twist, axis=-1, keepdims=True)
    degenerate = norm[..., 0] < 1e-12
    twist = np.where(degenerate[..., None], quat_identity(twist.shape[:-1]), twist / np.where(norm == 0, 1, norm))
    swing = quat_multiply(q, quat_inverse(twist))
    return swing, twist


def axis_quat(axis: np.ndarray, angle) -> np.ndarray:
    """Quaternions ``(..., 4)`` of rotations by ``angle`` (radians, array ``(...)``) about one ``axis``
    ``(3,)`` (normalised here): ``(sin(a/2) axis, cos(a/2))`` (Sola 2017, eq. 101)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    ang = np.asarray(angle, dtype=float)
    h = 0.5 * ang
    out = np.empty(ang.shape + (4,))
    out[..., :3] = np.sin(h)[..., None] * a
    out[..., 3] = np.cos(h)
    return out


def twist_angle(q: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Signed rotation angle (radians, in ``(-2pi, 2pi]``) about ``axis`` ``(3,)`` of the twist part
    of ``q`` ``(..., 4)`` (:func:`swing_twist`): ``2 atan2(q_xyz . axis, q_w)``.

    The twist is the projection of the quaternion on ``axis``, the same for the left and right
    swing/twist orders, so for ``q = axis_quat(axis, a) s`` with ``s`` perpendicular to the axis
    this returns ``a`` (modulo the 4 pi sign ambiguity of the quaternion; callers unwrap over time).
    """
    q = np.asarray(q, dtype=float)
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    return 2.0 * np.arctan2(q[..., :3] @ a, q[..., 3])


_AXIS = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}


def euler_sequence(channels: tuple[str, ...] | list[str]) -> str:
    """scipy intrinsic Euler sequence (e.g. ``"ZXY"``) for BVH rotation channels.

    BVH applies rotation channels in the listed order as intrinsic rotations:
    ``Zrotation Xrotation Yrotation`` means ``R = Rz Rx Ry``, which is scipy's
    ``Rotation.from_euler("ZXY", [z, x, y])``.
    """
    seq = "".join(_AXIS[c] for c in channels if c in _AXIS)
    return seq


def euler_to_quat(seq: str, angles: np.ndarray, degrees: bool = True) -> np.ndarray:
    """Euler angles ``(..., len(seq))`` to quaternions, scipy's convention for ``seq``.

    Upper-case ``seq`` (e.g. ``"ZXY"``) is intrinsic, lower-case (``"zxy"``)
    extrinsic, as in :meth:`scipy.spatial.transform.Rotation.from_euler`; all 12
    Tait-Bryan and proper-Euler sequences are accepted. Same rotation as
    ``Rotation.from_euler(seq, angles, degrees).as_quat()`` up to sign (tested),
    but several times faster for long clips, which matters for reading BVH files:
    the product of the three elementary rotations is formed directly with
    :func:`quat_multiply`.
    """
    angles = np.asarray(angles, dtype=float)
    up = seq.upper()
    if (not 1 <= len(seq) <= 3 or not (seq.isupper() or seq.islower()) or any(c not in "XYZ" for c in up)
            or any(a == b for a, b in zip(up, up[1:]))):
        raise ValueError(f"Euler sequence must be 1-3 axes from 'XYZ' (intrinsic) or 'xyz' (extrinsic) with no "
                         f"axis repeated consecutively, got {seq!r}")
    if angles.shape[-1:] != (len(seq),):
        raise ValueError(f"{len(seq)} Euler axes {seq!r} need a last angle axis of length {len(seq)}, "
                         f"got shape {angles.shape}")
    if seq.islower():  # extrinsic a-b-c == intrinsic C-B-A with the angles reversed
        seq = seq[::-1].upper()
        angles = angles[..., ::-1]
    if degrees:
        angles = np.deg2rad(angles)
    half = 0.5 * angles
    c, s = np.cos(half), np.sin(half)
    out = None
    for k, ax in enumerate(seq.upper()):
        q = np.zeros(angles.shape[:-1] + (4,))
        q[..., "XYZ".index(ax)] = s[..., k]
        q[..., 3] = c[..., k]
        out = q if out is None else quat_multiply(out, q)
    return out
