"""Alignment in the ground plane: a rotation about the vertical plus a translation (issue 15, item 3).

The heading of a motion is the twist of its root orientation about the world vertical (y): for
two motions of one skeleton the difference of headings is the turn that makes them face the
same way, whatever axis the skeleton calls forward. A :class:`GroundTransform` maps world points
``p -> R_y(yaw) (p - pivot) + pivot + shift`` with ``shift`` horizontal; :func:`align` finds the
one that puts motion ``b`` at frame ``fb`` where motion ``a`` is at frame ``fa`` (root, or the
centre of the feet) facing the same way.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_apply, swing_twist

__all__ = ["GroundTransform", "headings", "reference_points", "align", "yaw_quaternion", "ALIGN_BY"]

ALIGN_BY = ("root", "feet")
_UP = np.array([0.0, 1.0, 0.0])


def yaw_quaternion(yaw) -> np.ndarray:
    """``(..., 4)`` rotations by ``yaw`` rad about the world vertical (counter-clockwise seen from above)."""
    yaw = np.asarray(yaw, dtype=float)
    q = np.zeros(yaw.shape + (4,))
    q[..., 1] = np.sin(0.5 * yaw)
    q[..., 3] = np.cos(0.5 * yaw)
    return q


def headings(motion: Motion, frames=None) -> np.ndarray:
    """``(T,)`` rad: the root's heading, the angle of the twist of its world orientation about the
    vertical (swing/twist split), unwrapped over frames; only at ``frames`` (not unwrapped) when given."""
    q = motion.rotations[:, 0] if frames is None else motion.rotations[np.asarray(frames, dtype=int), 0]
    _, tw = swing_twist(q, _UP)
    ang = 2.0 * np.arctan2(tw[:, 1], tw[:, 3])
    return np.unwrap(ang) if frames is None else ang


def reference_points(motion: Motion, by: str = "root") -> np.ndarray:
    """``(T, 3)`` the ground reference of each frame, on ``y = 0``: the root's ground projection
    (``by="root"``) or the centre of the two ankle points (``"feet"``)."""
    if by == "root":
        p = np.array(motion.root_positions)
    elif by == "feet":
        from .plants import leg_layout

        legs = leg_layout(motion.skeleton)
        P, G = motion.fk()
        p = 0.5 * sum(P[:, leg.ankle_point[0]] + quat_apply(G[:, leg.ankle_point[0]], leg.ankle_point[1]) for leg in legs)
    else:
        raise ValueError(f"align by must be one of {', '.join(ALIGN_BY)}, got {by!r}")
    p[:, 1] = 0.0
    return p


@dataclass(frozen=True)
class GroundTransform:
    """``p -> R_y(yaw) (p - pivot) + pivot + shift``: a turn about the vertical through ``pivot``
    then a horizontal ``shift`` (m)."""

    yaw: float = 0.0
    pivot: tuple = (0.0, 0.0, 0.0)
    shift: tuple = (0.0, 0.0, 0.0)

    @property
    def quaternion(self) -> np.ndarray:
        return yaw_quaternion(self.yaw)

    def apply_points(self, p: np.ndarray) -> np.ndarray:
        piv = np.asarray(self.pivot, dtype=float)
        return quat_apply(self.quaternion, np.asarray(p, dtype=float) - piv) + piv + np.asarray(self.shift, dtype=float)

    def apply(self, motion: Motion) -> Motion:
        """The motion moved rigidly (root position and orientation; joints unchanged)."""
        out = motion.rotated(self.quaternion, center=self.pivot) if self.yaw != 0.0 else motion
        return out.translated(self.shift) if np.any(np.asarray(self.shift) != 0.0) else out

    def to_dict(self) -> dict:
        return {"yaw_deg": float(np.degrees(self.yaw)), "pivot_m": [float(x) for x in self.pivot],
                "shift_m": [float(x) for x in self.shift]}


def _frame(motion: Motion, f: int, what: str) -> int:
    f = int(f)
    if f < 0:
        f += motion.n_frames
    if not 0 <= f < motion.n_frames:
        raise ValueError(f"{what} frame {f} is outside the motion's frames 0-{motion.n_frames - 1}")
    return f


def align(a: Motion, b: Motion, fa: int, fb: int, by: str = "root") -> GroundTransform:
    """The ground transform that moves ``b`` so that at its frame ``fb`` it stands where ``a``
    stands at frame ``fa`` (reference point ``by``: root or feet centre, on the ground) and faces
    the same way (root heading). ``align(a, a, f, f)`` is the identity."""
    fa, fb = _frame(a, fa, "A"), _frame(b, fb, "B")
    yaw = float(headings(a, [fa])[0] - headings(b, [fb])[0])
    yaw = (yaw + np.pi) % (2 * np.pi) - np.pi
    pa = reference_points(a[fa], by)[0]
    pb = reference_points(b[fb], by)[0]
    return GroundTransform(yaw, tuple(pb.tolist()), tuple((pa - pb).tolist()))
