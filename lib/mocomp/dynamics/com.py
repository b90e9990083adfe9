"""Segment COMs, segment orientations and the whole-body centre of mass over a motion."""
from __future__ import annotations

import numpy as np

from ..core.rotations import quat_apply
from ..errors import MotionFormatError

__all__ = ["segment_positions", "segment_rotations", "center_of_mass", "check_compatible"]


def check_compatible(body, motion) -> None:
    """Raise :class:`~mocomp.errors.MotionFormatError` unless ``body`` describes ``motion``'s skeleton."""
    if body.skeleton is motion.skeleton:
        return
    a, b = body.skeleton, motion.skeleton
    if a.names != b.names:
        raise MotionFormatError(
            f"body model and motion have different skeletons ({a.n_joints} vs {b.n_joints} joints; "
            f"first differing names: {[x for x in zip(a.names, b.names) if x[0] != x[1]][:3]})")
    if not np.allclose(a.offsets, b.offsets, atol=1e-6, rtol=1e-6):
        j = int(np.argmax(np.abs(a.offsets - b.offsets).max(axis=1)))
        raise MotionFormatError(
            f"body model and motion skeletons differ in bone offsets (joint {a.names[j]!r}: "
            f"{a.offsets[j].tolist()} vs {b.offsets[j].tolist()}); rebuild the body model for this skeleton")


def segment_positions(body, motion) -> np.ndarray:
    """``(T, S, 3)`` world positions of the segment COMs, metres."""
    check_compatible(body, motion)
    P, G = motion.fk()
    j = body.segment_joint
    return P[:, j] + quat_apply(G[:, j], body.local_coms[None])


def segment_rotations(body, motion) -> np.ndarray:
    """``(T, S, 4)`` world orientations of the segments (their carrier joints' global rotations)."""
    check_compatible(body, motion)
    return np.asarray(motion.global_rotations[:, body.segment_joint])


def center_of_mass(body, motion) -> np.ndarray:
    """``(T, 3)`` whole-body centre of mass, metres: ``sum_i m_i c_i / M``."""
    if body.total_mass <= 0:
        raise MotionFormatError("body model has zero total mass")
    return np.einsum("s,tsk->tk", body.masses, segment_positions(body, motion)) / body.total_mass
