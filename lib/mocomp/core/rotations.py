"""Rotation helpers on top of :class:`scipy.spatial.transform.Rotation`.

Quaternions are unit quaternions in scipy's scalar-last order ``(x, y, z, w)``
and arrays of them have shape ``(..., 4)``. Only what scipy lacks lives here:
hemisphere continuity, the swing/twist split about an axis, and converting
BVH channel names to scipy's Euler sequence.
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
    "make_continuous",
    "swing_twist",
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


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` (apply ``b`` first, then ``a``), broadcasting.

    Equivalent to ``(Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()``
    without canonicalising the sign; written out so that it broadcasts over any
    leading shape without flattening (tests compare it with scipy).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def quat_inverse(q: np.ndarray) -> np.ndarray:
    """Inverse (conjugate) of unit quaternions."""
    q = np.array(q, dtype=float, copy=True)
    q[..., :3] *= -1.0
    return q


def quat_apply(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)``, broadcasting.

    Uses ``v' = v + 2 w (u x v) + 2 u x (u x v)`` with ``q = (u, w)``.
    """
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    ux, uy, uz, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    # written out (np.cross has a large per-call overhead); same operations as
    # t = 2 (u x v); v + w t + u x t
    tx = 2.0 * (uy * vz - uz * vy)
    ty = 2.0 * (uz * vx - ux * vz)
    tz = 2.0 * (ux * vy - uy * vx)
    return np.stack(
        [vx + w * tx + (uy * tz - uz * ty), vy + w * ty + (uz * tx - ux * tz), vz + w * tz + (ux * ty - uy * tx)],
        axis=-1,
    )


def quat_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle in ``[0, pi]`` of unit quaternions (sign-independent)."""
    q = np.asarray(q, dtype=float)
    w = np.clip(np.abs(q[..., 3]), 0.0, 1.0)
    vec = np.linalg.norm(q[..., :3], axis=-1)
    return 2.0 * np.arctan2(vec, w)


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
