"""Root split about L and seam smoothing (dissertation section 5.4.2.2, eq. 5.14).

Eq. 5.14 splits the root orientation into a rotation about the angular momentum
direction ``L`` and a rotation about an axis perpendicular to it, and smooths
only the latter, so that the (already continuous) rotation about ``L`` is not
disturbed. Here the split is written with the rotation about the *world* axis
``L`` on the left,

    q_r = q_L(theta) q_P,          q_P maps b = q_r^-1 L onto L by the shortest arc,

so that rotating a frame about ``L`` (``q' = q_L(a) q``) changes only ``theta``
(by ``a``) and leaves ``q_P`` and ``b`` untouched. The dissertation writes the
product as ``q_P q_L``; both orders have the same twist angle (the projection of
the quaternion on ``L``), and the left order is the one for which one seam
correction is valid for every rotated repetition (tested), which section
5.4.2.2 relies on ("computed only once and re-used").

Seam smoothing slerps joint angles over small windows on both sides of a seam:
the mismatch between the two sides at the seam time is split in half and each
side is offset towards the middle with a raised-cosine ramp, so the result is
continuous and the correction fades out over ``window`` frames. Root positions
are left to repositioning (section 5.4.4).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_apply, quat_inverse, quat_multiply, shortest_arc, slerp
from .similarity import axis_quat, twist_angle

__all__ = ["root_reference", "split_root", "compose_root", "shortest_arc", "ramp", "SeamSide", "seam_corrections",
           "apply_rotation_offsets", "apply_direction_offsets"]


def root_reference(b_ref: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A fixed root offset ``q_0`` with ``q_0 b_ref = axis``: the split below is taken of
    ``q q_0^-1`` so that it is well conditioned for every frame whose body-frame ``L``
    direction ``b`` is near ``b_ref`` (typically the mean over the flight). Without it the
    split is singular when a body axis happens to be anti-parallel to the world ``L``
    (e.g. a back flip about the body's -x axis with ``L`` along world +x)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    r = np.asarray(b_ref, dtype=float)
    r = r / np.linalg.norm(r)
    return shortest_arc(r, a)


def split_root(q: np.ndarray, axis: np.ndarray, ref: np.ndarray | None = None,
               unwrap: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 5.14 split of root orientations ``q (T, 4)``: ``(theta (T,), b (T, 3))``.

    ``theta`` is the rotation about the world ``axis`` of ``q q_0^-1`` (``q_0 = ref``, a
    fixed offset from :func:`root_reference`, identity by default), unwrapped over
    frames when ``unwrap``; ``b = q^-1 axis`` is the axis direction in the body frame,
    which fixes the perpendicular part ``q_P`` (see :func:`compose_root`). Rotating a
    frame about the world axis by ``a`` adds ``a`` to ``theta`` and leaves ``b``.
    """
    q = np.asarray(q, dtype=float)
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    qq = q if ref is None else quat_multiply(q, quat_inverse(ref))
    theta = twist_angle(qq, a)
    if unwrap and theta.ndim == 1 and theta.size > 1:
        theta = np.unwrap(theta, period=2 * np.pi)
    b = quat_apply(quat_inverse(q), a)
    return theta, b


def compose_root(theta: np.ndarray, b: np.ndarray, axis: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """Inverse of :func:`split_root`: ``q = q_L(theta) q_P q_0`` with ``q_P`` the shortest
    arc from ``q_0 b`` to ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    b = np.asarray(b, dtype=float)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    if ref is None:
        return quat_multiply(axis_quat(a, theta), shortest_arc(b, a))
    return quat_multiply(quat_multiply(axis_quat(a, theta), shortest_arc(quat_apply(np.asarray(ref, float), b), a)), ref)


def ramp(d: np.ndarray, window: int) -> np.ndarray:
    """Raised-cosine weight: 1 at distance 0 from the seam, 0 at ``window + 1`` frames (C1 at both ends)."""
    d = np.asarray(d, dtype=float)
    x = np.clip(d / (window + 1.0), 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * x))


@dataclass(frozen=True)
class SeamSide:
    """Offsets for one side of a seam (evidence and a reusable correction).

    Attributes
    ----------
    weights: ``(w,)`` ramp weight per frame of this side, ordered as the frames.
    joint_offset: ``(J, 4)`` full local-rotation offset ``q_ref^-1 q_mid`` (joint 0 unused).
    dir_offset: ``(4,)`` full body-frame rotation taking this side's ``b`` to the middle ``b``.
    """

    weights: np.ndarray
    joint_offset: np.ndarray
    dir_offset: np.ndarray


def seam_corrections(left_ref: np.ndarray, right_ref: np.ndarray, b_left: np.ndarray, b_right: np.ndarray,
                     window: int, pair_at_left: bool) -> tuple[SeamSide, SeamSide]:
    """Half-and-half corrections for a seam between a left block ending at frame ``a`` and
    a right block starting at ``a + 1``.

    ``left_ref``/``right_ref`` (``(J, 4)``) are the two sides' poses *at the same
    instant* (the matched pair, e.g. ``f_n`` and ``f_m`` of a self-loop, or ``f``
    and ``g`` of the landing join); that instant is frame ``a`` when
    ``pair_at_left`` else ``a + 1``. ``b_left``/``b_right`` are the body-frame
    directions of ``L`` (root swing, eq. 5.14) of the pair. The left block gets
    ``window + 1`` weights (frames ``a - window .. a``), the right block ``window + 1``
    (frames ``a + 1 .. a + 1 + window``); weights are 0 beyond the ramp.
    """
    mid = slerp(left_ref, right_ref, np.full(left_ref.shape[:-1], 0.5))
    off_l = quat_multiply(quat_inverse(left_ref), mid)
    off_r = quat_multiply(quat_inverse(right_ref), mid)
    bl = b_left / np.linalg.norm(b_left)
    br = b_right / np.linalg.norm(b_right)
    bm = bl + br
    bm = bm / np.linalg.norm(bm) if np.linalg.norm(bm) > 1e-9 else bl
    left_d = np.arange(window, -1, -1) + (0 if pair_at_left else 1)   # frames a-w .. a
    right_d = np.arange(0, window + 1) + (1 if pair_at_left else 0)   # frames a+1 .. a+1+w
    return (SeamSide(ramp(left_d, window), off_l, shortest_arc(bl, bm)),
            SeamSide(ramp(right_d, window), off_r, shortest_arc(br, bm)))


def _fraction(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``q^w`` for unit quaternions ``q (..., 4)`` and weights ``w`` broadcasting on the leading axes."""
    ident = np.zeros_like(q)
    ident[..., 3] = 1.0
    return slerp(ident, q, np.broadcast_to(w, q.shape[:-1]))


def apply_rotation_offsets(rot: np.ndarray, side: SeamSide) -> np.ndarray:
    """Joint rotations ``rot (w, J, 4)`` of one seam side with the ramped offsets applied
    (``q' = q off^weight``; joint 0, the root, is left alone: see :func:`apply_direction_offsets`)."""
    out = np.array(rot, dtype=float, copy=True)
    off = np.broadcast_to(side.joint_offset[None, 1:], (rot.shape[0],) + side.joint_offset[1:].shape)
    frac = _fraction(off, side.weights[:, None])
    out[:, 1:] = quat_multiply(out[:, 1:], frac)
    return out


def apply_direction_offsets(b: np.ndarray, side: SeamSide) -> np.ndarray:
    """Root swing directions ``b (w, 3)`` of one seam side rotated by the ramped offset
    (eq. 5.14: only the part perpendicular to ``L`` is smoothed)."""
    frac = _fraction(np.broadcast_to(side.dir_offset, (b.shape[0], 4)), side.weights)
    return quat_apply(frac, b)
