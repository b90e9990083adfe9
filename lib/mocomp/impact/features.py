"""Per-body features of a motion for the impact-response search (dissertation sec. 4.1).

The search compares *frames* ``f = (p_1, theta_1, ..., p_n, theta_n)``: the positions and
orientations of the character's ``n`` body parts (eq. 4.1). Here the body parts are the 16
canonical segments of the project's body model (:mod:`mocomp.body`: head, upper/middle/lower
trunk, and per side upper arm, forearm, hand, thigh, shank, foot), which are exactly the paper's
16 parts (Table A.1: head, chest = upper trunk, stomach = middle trunk, pelvis = lower trunk,
upper arms, forearms, hands, thighs, shanks, feet). A body's position is its segment centre of
mass (core forward kinematics + the body model's local COM), its orientation the world rotation
of the joint that carries it.

Windows are compared after removing coordinate-frame differences "by aligning the roots in the
start frames of each window" (sec. 4.1): every frame of a window is expressed in the ground frame
of the window's first frame -- the root's ground projection as origin and the root's heading (the
twist of its world rotation about the vertical, :func:`mocomp.ops.align.headings`) as the zero
yaw. Only a rotation about the vertical and a horizontal shift are removed, so height, lean and
lying are compared as they are.

Linear and angular velocities of every body are carried too (central differences on the frame
times, :mod:`mocomp.dynamics.derivatives`); the window distance of eq. 4.1 does not use them
(windows of several frames carry the dynamics), the transition stage can.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..body import BodyModel
from ..core.motion import Motion
from ..core.rotations import quat_multiply
from ..dynamics.com import segment_positions, segment_rotations
from ..dynamics.derivatives import angular_velocity, central_difference
from ..errors import MotionFormatError
from ..ops.align import headings, yaw_quaternion

__all__ = ["BODY_PARTS", "TABLE_A1", "SUPPORT_WEIGHTS", "BodyFeatures", "body_features", "part_weights",
           "body_model_for", "ground_frame_features", "FOOT_PARTS"]

#: the 16 body parts, in the project's canonical segment order (mocomp.body.mapping.sided_segments)
BODY_PARTS: tuple[str, ...] = (
    "head", "upper_trunk", "middle_trunk", "lower_trunk",
    "upper_arm_l", "upper_arm_r", "forearm_l", "forearm_r", "hand_l", "hand_r",
    "thigh_l", "thigh_r", "shank_l", "shank_r", "foot_l", "foot_r",
)

#: dissertation Table A.1: body part -> (mass kg, linear weight w_p, angular weight w_theta).
#: Chest = upper trunk, stomach = middle trunk, pelvis = lower trunk. The feet's weights are
#: those of a non-supporting foot; the supporting foot takes :data:`SUPPORT_WEIGHTS`.
TABLE_A1: dict[str, tuple[float, float, float]] = {
    "head": (3.66, 0.1, 0.01),
    "upper_arm_l": (2.16, 0.5, 0.05), "upper_arm_r": (2.16, 0.5, 0.05),
    "forearm_l": (1.37, 0.2, 0.02), "forearm_r": (1.37, 0.2, 0.02),
    "upper_trunk": (12.83, 1.0, 0.10),
    "middle_trunk": (8.61, 1.0, 0.10),
    "lower_trunk": (8.70, 1.0, 0.10),
    "thigh_l": (5.17, 0.5, 0.05), "thigh_r": (5.17, 0.5, 0.05),
    "shank_l": (2.14, 0.2, 0.02), "shank_r": (2.14, 0.2, 0.02),
    "foot_l": (1.88, 0.1, 0.01), "foot_r": (1.88, 0.1, 0.01),
    "hand_l": (1.48, 0.1, 0.01), "hand_r": (1.48, 0.1, 0.01),
}

#: Table A.1: (w_p, w_theta) of the supporting foot ("feet weights are higher for supporting limbs")
SUPPORT_WEIGHTS: tuple[float, float] = (1.0, 0.10)

#: side -> foot part
FOOT_PARTS: dict[str, str] = {"left": "foot_l", "right": "foot_r"}


def part_weights(support: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(w_p (16,), w_theta (16,))`` of Table A.1 in :data:`BODY_PARTS` order; ``support``
    (``"left"``/``"right"``, or ``"both"``) gives that foot the supporting weights. Read-only arrays."""
    if support not in _WEIGHTS:
        _WEIGHTS[support] = _part_weights(support)
    return _WEIGHTS[support]


_WEIGHTS: dict = {}


def _part_weights(support):
    wp = np.array([TABLE_A1[b][1] for b in BODY_PARTS])
    wr = np.array([TABLE_A1[b][2] for b in BODY_PARTS])
    if support is not None:
        sides = ("left", "right") if support == "both" else (support,)
        for s in sides:
            if s not in FOOT_PARTS:
                raise ValueError(f"support foot must be 'left', 'right' or None, got {support!r}")
            k = BODY_PARTS.index(FOOT_PARTS[s])
            wp[k], wr[k] = SUPPORT_WEIGHTS
    wp.setflags(write=False)
    wr.setflags(write=False)
    return wp, wr


def body_model_for(skeleton) -> BodyModel:
    """The project's body model of ``skeleton`` (de Leva segments through the detected naming
    convention, :meth:`BodyModel.from_skeleton`), checked to carry the 16 body parts."""
    body = BodyModel.from_skeleton(skeleton)
    missing = [b for b in BODY_PARTS if b not in body.segment_names]
    if missing:
        raise MotionFormatError(f"the body model of this skeleton lacks the body parts {missing}")
    return body


@dataclass(frozen=True, eq=False)
class BodyFeatures:
    """The 16 body parts of a motion, frame by frame (world frame, y up, SI units).

    Attributes
    ----------
    fps: frames per second of the motion they came from.
    positions: ``(T, 16, 3)`` m, segment centres of mass (:data:`BODY_PARTS` order).
    orientations: ``(T, 16, 4)`` world orientations (scalar-last unit quaternions).
    velocities: ``(T, 16, 3)`` m/s, central differences of ``positions``.
    angular_velocities: ``(T, 16, 3)`` rad/s, world frame.
    com: ``(T, 3)`` m, whole-body centre of mass (the body model's masses).
    ground: ``(T, 3)`` m, the root's ground projection (``y = 0``).
    heading: ``(T,)`` rad, the root's heading (twist about +y), unwrapped.
    masses: ``(16,)`` kg, the body model's segment masses.
    """

    fps: float
    positions: np.ndarray
    orientations: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    com: np.ndarray
    ground: np.ndarray
    heading: np.ndarray
    masses: np.ndarray

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]


def body_features(motion: Motion, body: BodyModel | None = None, *, velocities: bool = True) -> BodyFeatures:
    """:class:`BodyFeatures` of ``motion`` (core FK + the body model; ``body`` defaults to
    :func:`body_model_for` of the motion's skeleton). ``velocities=False`` leaves the two
    velocity arrays zero (the search does not use them)."""
    body = body_model_for(motion.skeleton) if body is None else body
    order = [body.segment_names.index(b) for b in BODY_PARTS]
    pos = np.ascontiguousarray(segment_positions(body, motion)[:, order])
    ori = np.ascontiguousarray(segment_rotations(body, motion)[:, order])
    masses = body.masses[order]
    com = np.einsum("s,tsk->tk", masses, pos) / masses.sum()
    T = motion.n_frames
    if velocities and T >= 2:
        vel = central_difference(pos, motion.times)
        avel = angular_velocity(ori, motion.times)
    else:
        vel = np.zeros_like(pos)
        avel = np.zeros_like(pos)
    ground = np.array(motion.root_positions)
    ground[:, 1] = 0.0
    return BodyFeatures(float(motion.fps), pos, ori, vel, avel, com, ground, headings(motion), masses)


def ground_frame_features(positions: np.ndarray, orientations: np.ndarray, ground: np.ndarray,
                          heading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions and orientations expressed in a ground frame (origin ``ground``, yaw ``heading``):
    ``p' = R_y(-heading) (p - ground)``, ``q' = q_y(-heading) q``. ``ground`` ``(..., 3)`` and
    ``heading`` ``(...)`` broadcast against the leading shape of ``positions[..., 0, 0]``
    (one ground frame per frame, or one for a whole window)."""
    c, s = np.cos(heading)[..., None], np.sin(heading)[..., None]
    d = positions - ground[..., None, :]
    out = np.empty_like(d)
    # R_y(-psi) (x, y, z) = (c x - s z, y, s x + c z)
    out[..., 0] = c * d[..., 0] - s * d[..., 2]
    out[..., 1] = d[..., 1]
    out[..., 2] = s * d[..., 0] + c * d[..., 2]
    qy = yaw_quaternion(-np.asarray(heading))[..., None, :]
    return out, quat_multiply(qy, orientations)
