"""Closed-form leg inverse kinematics with the ball of the foot planted.

During ground phases the toe segment (``LeftToeBase`` frame) is fixed in the
world: its joint sits at ``toe_pos`` and its orientation is a pure heading
``R_y(yaw)`` (flat on the ground). The foot (``LeftFoot`` frame) pivots about
the toe joint by the heel-rise angle ``beta``: ``G_foot = R_y(yaw) R_x(beta)``
(``beta = 0``: heel down, foot flat; ``beta > 0``: heel up). Given the pelvis
pose, the hip joint centre follows; the knee angle comes from the law of
cosines and the knee swivel from the rule "the knee lies in the plane through
hip and ankle that contains the foot's forward direction" (knee over toes).
The thigh, shank, foot and toe local rotations follow exactly, so the toe joint
stays where it was put to rounding error (foot skate ~ 1e-15 m).

Needs a skeleton whose rest legs are straight and vertical (thigh and shank
offsets along -y) with the toe offset in the sagittal plane, as
:func:`~mocomp.synth.skeleton.synthetic_skeleton` builds them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_matrix
from ..core.skeleton import Skeleton
from ..errors import PhysicsError
from ._so3 import rot_x, rot_y
from .skeleton import LEG_JOINTS

__all__ = ["LegChain", "LegPose", "leg_chain", "leg_ik"]


@dataclass(frozen=True)
class LegChain:
    """Indices and rest geometry of one leg (see module docstring)."""

    side: str
    carrier: int          # LHipJoint (kept at identity)
    hip: int              # LeftUpLeg: hip joint centre, rotates the thigh
    knee: int             # LeftLeg
    ankle: int            # LeftFoot
    toe: int              # LeftToeBase
    hip_offset: np.ndarray    # hip joint centre in the root frame
    l_thigh: float
    l_shank: float
    toe_offset: np.ndarray    # toe joint in the foot (ankle) frame


@dataclass(frozen=True)
class LegPose:
    """Result of :func:`leg_ik` for ``N`` frames.

    Attributes
    ----------
    R_local: ``(N, 4, 3, 3)`` local rotations of hip, knee, ankle, toe joints.
    knee_angle: ``(N,)`` knee flexion, radians (0 = straight).
    reach: ``(N,)`` hip-ankle distance / (thigh + shank).
    ankle: ``(N, 3)`` ankle joint positions; hip: ``(N, 3)`` hip joint centres.
    """

    R_local: np.ndarray
    knee_angle: np.ndarray
    reach: np.ndarray
    ankle: np.ndarray
    hip: np.ndarray


def leg_chain(skeleton: Skeleton, side: str) -> LegChain:
    hip, knee, ankle, toe = (skeleton.index(n) for n in LEG_JOINTS[side])
    carrier = int(skeleton.parents[hip])
    off = skeleton.offsets
    for j, what in ((knee, "thigh"), (ankle, "shank")):
        o = off[j]
        if not (abs(o[0]) < 1e-9 and abs(o[2]) < 1e-9 and o[1] < 0):
            raise ValueError(f"leg IK needs a vertical rest {what} (offset of {skeleton.names[j]!r} is {o.tolist()})")
    if abs(off[toe][0]) > 1e-9:
        raise ValueError("leg IK needs the toe offset in the sagittal plane")
    return LegChain(side, carrier, hip, knee, ankle, toe, off[carrier] + off[hip], float(-off[knee][1]),
                    float(-off[ankle][1]), off[toe].copy())


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def leg_ik(chain: LegChain, root_pos, root_R, toe_pos, foot_yaw, heel_rise, max_reach: float = 0.9995) -> LegPose:
    """Local leg rotations that keep the toe joint at ``toe_pos`` (see module docstring).

    Parameters
    ----------
    root_pos: ``(N, 3)`` pelvis (root joint) positions; root_R: ``(N, 3, 3)`` its orientations.
    toe_pos: ``(N, 3)`` or ``(3,)`` planted toe joint position; foot_yaw: heading of the foot (rad);
    heel_rise: ``beta`` (rad), scalars or ``(N,)``.
    max_reach: raise :class:`~mocomp.errors.PhysicsError` if the hip-ankle distance
        exceeds this fraction of the leg length (a straight knee has no unique swivel).
    """
    root_pos = np.atleast_2d(np.asarray(root_pos, dtype=float))
    N = root_pos.shape[0]
    root_R = np.broadcast_to(np.asarray(root_R, dtype=float), (N, 3, 3))
    toe = np.broadcast_to(np.asarray(toe_pos, dtype=float), (N, 3))
    yaw = np.broadcast_to(np.asarray(foot_yaw, dtype=float), (N,))
    beta = np.broadcast_to(np.asarray(heel_rise, dtype=float), (N,))
    G_toe = quat_matrix(rot_y(yaw))
    G_foot = G_toe @ quat_matrix(rot_x(beta))
    A = toe - G_foot @ chain.toe_offset
    H = root_pos + root_R @ chain.hip_offset
    l1, l2 = chain.l_thigh, chain.l_shank
    HA = A - H
    d = np.linalg.norm(HA, axis=-1)
    reach = d / (l1 + l2)
    if np.any(reach > max_reach) or np.any(d < abs(l1 - l2) + 1e-6):
        k = int(np.argmax(reach))
        raise PhysicsError(
            f"{chain.side} leg cannot reach its planted foot: hip-ankle distance {d[k]:.4f} m is "
            f"{reach[k]:.4f} of the leg length (limit {max_reach}); lower the pelvis or raise the heel")
    u = HA / d[:, None]
    fwd = G_toe[:, :, 2]
    w = _unit(fwd - np.sum(fwd * u, -1, keepdims=True) * u)
    cos_a = np.clip((l1 * l1 + d * d - l2 * l2) / (2 * l1 * d), -1.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a**2)
    a1 = cos_a[:, None] * u + sin_a[:, None] * w          # thigh direction (hip -> knee)
    zt = -sin_a[:, None] * u + cos_a[:, None] * w         # thigh "forward", in the leg plane
    yt = -a1                                              # rest thigh points along -y
    xt = np.cross(yt, zt)
    G_thigh = np.stack([xt, yt, zt], axis=-1)
    cos_k = np.clip((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0, 1.0)
    knee = np.pi - np.arccos(cos_k)
    R_knee = quat_matrix(rot_x(knee))
    G_shank = G_thigh @ R_knee
    R_hip = np.swapaxes(root_R, -1, -2) @ G_thigh         # the hip carrier joint stays at identity
    R_ankle = np.swapaxes(G_shank, -1, -2) @ G_foot
    R_toe = quat_matrix(rot_x(-beta))
    return LegPose(np.stack([R_hip, R_knee, R_ankle, R_toe], axis=1), knee, reach, A, H)
