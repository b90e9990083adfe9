"""Pose similarity with alignment about the angular momentum (flips paper App. A,
dissertation section 5.4.2.1, eq. 5.12-5.13).

Two frames are compared after rotating the second one about the (unit) angular
momentum direction ``L`` by the angle that best aligns the root orientations:

* eq. 5.12: ``phi = P(q_r2 q_r1^-1, L)``, the rotation angle of ``q_r2 q_r1^-1``
  projected on the plane perpendicular to ``L`` (its *twist* about ``L``);
* eq. 5.13: ``D = w_r |angle(q_r2 (q_phi q_r1)^-1)| + sum_i w_i |angle(q_i2 q_i1^-1)|``.

The conference paper (App. A) also weighs angular-velocity differences; pass
``velocity_weight > 0`` (seconds) and per-frame angular velocities to use it.

Quaternions are scipy scalar-last ``(x, y, z, w)``; ``L`` is a world-frame
direction, and rotations about it act on the *left* of the root orientation
(``q' = q_L q``), which is what rotating a frame about a world axis does.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.rotations import axis_quat, quat_angle, quat_apply, quat_inverse, quat_log, quat_multiply, twist_angle
from ..core.skeleton import Skeleton

__all__ = [
    "DEFAULT_CLASS_WEIGHTS",
    "SimilarityWeights",
    "classify_joint",
    "similarity_weights",
    "twist_angle",
    "axis_quat",
    "alignment_angle",
    "frame_distance",
    "local_angular_velocities",
]

#: dissertation section 5.4.2.1 / flips paper App. A, used "for all of our motions"
DEFAULT_CLASS_WEIGHTS = {"root": 2.0, "trunk": 0.7, "thigh": 0.7, "knee": 0.5,
                         "shoulder": 0.3, "elbow": 0.1, "other": 0.0}


def _has_arm_joint(names_lower) -> bool:
    return any(_is_upper_arm(n) for n in names_lower)


def _is_upper_arm(n: str) -> bool:
    if "forearm" in n or "lowerarm" in n:
        return False
    return "upperarm" in n or "humerus" in n or n.endswith("arm") or n.endswith("arm_joint")


def classify_joint(name: str, skeleton_names=(), is_root: bool = False) -> str:
    """Anatomical class of a joint for the similarity weights.

    Returns one of ``"root", "trunk", "thigh", "knee", "shoulder", "elbow", "other"``.
    A joint's class describes the rotation it carries (BVH/ASF convention: the
    rotation of the bone that starts at the joint). Naming conventions handled:
    CMU/cgspeed BVH (``LeftUpLeg, LeftLeg, LeftShoulder`` = clavicle, ``LeftArm``,
    ``LeftForeArm``), 3dsMax-style BVH (``LeftHip, LeftKnee, LeftCollar,
    LeftShoulder, LeftElbow``), CMU ASF (``lfemur, ltibia, lhumerus, lradius``),
    DeepMimic (``right_hip, right_knee, right_shoulder, right_elbow, chest``), SFU
    and Bandai Namco BVH. ``skeleton_names`` disambiguates "shoulder": it is the
    clavicle when the skeleton also has an upper-arm joint (``LeftArm``).
    """
    if is_root:
        return "root"
    n = name.lower()
    names_lower = [s.lower() for s in skeleton_names]
    if any(t in n for t in ("forearm", "elbow", "radius", "lowerarm")):
        return "elbow"
    if _is_upper_arm(n):
        return "shoulder"
    if "clavicle" in n or "collar" in n:
        return "other"
    if "shoulder" in n:
        return "other" if _has_arm_joint(names_lower) else "shoulder"
    if any(t in n for t in ("upleg", "thigh", "femur", "upperleg")):
        return "thigh"
    if "hip" in n and "hipjoint" not in n and n not in ("hips", "hip"):
        return "thigh"
    if any(t in n for t in ("knee", "tibia", "shin", "calf", "lowleg", "lowerleg")) or n.endswith("leg"):
        return "knee"
    if any(t in n for t in ("spine", "chest", "back", "thorax", "torso", "abdomen", "waist")):
        return "trunk"
    return "other"


@dataclass(frozen=True)
class SimilarityWeights:
    """Per-joint weights of eq. 5.13 for one skeleton.

    Attributes
    ----------
    root: weight of the root-orientation term ``w_r``.
    joints: ``(J,)`` weight of each joint's local rotation (entry 0, the root, is 0:
        the root enters through ``root`` after alignment).
    classes: ``(J,)`` the anatomical class each joint was given (evidence).
    velocity_weight: seconds; weight of the angular-velocity term (0 = eq. 5.13
        of the dissertation; > 0 = the conference paper's variant).
    """

    root: float
    joints: np.ndarray
    classes: tuple[str, ...]
    velocity_weight: float = 0.0
    names: tuple[str, ...] = field(default=())

    def table(self):
        """A pandas DataFrame joint -> class -> weight (which joints count)."""
        import pandas as pd

        return pd.DataFrame({"joint": self.names, "class": self.classes, "weight": self.joints})


def similarity_weights(skeleton: Skeleton, overrides: dict | None = None,
                       class_weights: dict | None = None, velocity_weight: float = 0.0) -> SimilarityWeights:
    """Weights of eq. 5.13 for ``skeleton``: the paper's class weights by joint name.

    ``overrides`` maps joint names to weights (or ``"root"`` to the root weight);
    unknown names raise ``KeyError``. ``class_weights`` replaces the paper's class
    table (:data:`DEFAULT_CLASS_WEIGHTS`).
    """
    cw = dict(DEFAULT_CLASS_WEIGHTS)
    if class_weights:
        unknown = set(class_weights) - set(cw)
        if unknown:
            raise KeyError(f"unknown joint class(es) {sorted(unknown)}; classes: {sorted(cw)}")
        cw.update(class_weights)
    classes = tuple(classify_joint(n, skeleton.names, is_root=(j == 0)) for j, n in enumerate(skeleton.names))
    w = np.array([0.0 if c == "root" else cw[c] for c in classes])
    root = cw["root"]
    for name, value in (overrides or {}).items():
        if name == "root":
            root = float(value)
            continue
        w[skeleton.index(name)] = float(value)
    if np.any(w < 0) or root < 0 or velocity_weight < 0:
        raise ValueError("similarity weights must be non-negative")
    if not np.any(w > 0) and root == 0:
        raise ValueError("all similarity weights are zero: no joint of this skeleton matched a class; pass overrides")
    w.setflags(write=False)
    return SimilarityWeights(root=float(root), joints=w, classes=classes,
                             velocity_weight=float(velocity_weight), names=skeleton.names)


def alignment_angle(q_r1: np.ndarray, q_r2: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Eq. 5.12: the angle ``phi`` about ``axis`` that best aligns root ``q_r1`` to ``q_r2``.

    The projection of ``q_r2 q_r1^-1`` on the plane perpendicular to ``axis`` (its
    twist about ``axis``), wrapped to ``(-pi, pi]``. Broadcasts over leading axes.
    """
    rel = quat_multiply(np.asarray(q_r2, dtype=float), quat_inverse(np.asarray(q_r1, dtype=float)))
    phi = twist_angle(rel, axis)
    return (phi + np.pi) % (2 * np.pi) - np.pi


def frame_distance(rot1: np.ndarray, rot2: np.ndarray, axis: np.ndarray, weights: SimilarityWeights,
                   omega1: np.ndarray | None = None, omega2: np.ndarray | None = None,
                   phi: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 5.13 distance between frames ``rot1`` and ``rot2`` (``(..., J, 4)`` local rotations,
    joint 0 the root's world orientation), after aligning ``rot1``'s root about ``axis``.

    Returns ``(D, phi)``: the distance (radians, weighted) and the alignment angle
    of eq. 5.12 (pass ``phi`` to impose it instead, e.g. a fixed extra rotation).
    With ``weights.velocity_weight > 0`` the angular velocities ``omega1/omega2``
    (``(..., J, 3)`` rad/s: world frame for the root, parent frame for joints)
    add ``velocity_weight * (w_r |R_phi w_r1 - w_r2| + sum_i w_i |w_i1 - w_i2|)``.
    """
    rot1 = np.asarray(rot1, dtype=float)
    rot2 = np.asarray(rot2, dtype=float)
    if phi is None:
        phi = alignment_angle(rot1[..., 0, :], rot2[..., 0, :], axis)
    q_phi = axis_quat(axis, phi)
    w = weights.joints
    nz = np.flatnonzero(w)
    # the aligned root and the weighted joints side by side: one relative rotation, one angle each
    idx = np.r_[0, nz]
    one = rot1[..., idx, :]
    one[..., 0, :] = quat_multiply(q_phi, one[..., 0, :])
    d = quat_angle(quat_multiply(rot2[..., idx, :], quat_inverse(one)))
    D = weights.root * d[..., 0] + d[..., 1:] @ w[nz]
    if weights.velocity_weight > 0:
        if omega1 is None or omega2 is None:
            raise ValueError("velocity_weight > 0 needs the angular velocities omega1 and omega2")
        o1 = np.asarray(omega1, dtype=float)
        o2 = np.asarray(omega2, dtype=float)
        dv_root = np.linalg.norm(quat_apply(q_phi, o1[..., 0, :]) - o2[..., 0, :], axis=-1)
        dv = np.linalg.norm(o1[..., nz, :] - o2[..., nz, :], axis=-1)
        D = D + weights.velocity_weight * (weights.root * dv_root + dv @ w[nz])
    return D, phi


def local_angular_velocities(rotations: np.ndarray, fps: float) -> np.ndarray:
    """``(T, J, 3)`` angular velocities (rad/s) of local rotations by central differences.

    For each joint, ``omega(t) = Log(q(t+1) q(t-1)^-1) / (2 dt)`` (core's
    :func:`~mocomp.core.rotations.quat_log`; one-sided at the ends): expressed in the parent's frame (world frame for the root), which
    is the frame eq. 5.13's velocity term compares in.
    """
    q = np.asarray(rotations, dtype=float)
    T = q.shape[0]
    if T < 2:
        return np.zeros(q.shape[:-1] + (3,))
    nxt = np.concatenate([q[1:], q[-1:]], axis=0)
    prv = np.concatenate([q[:1], q[:-1]], axis=0)
    span = np.full(T, 2.0)
    span[0] = span[-1] = 1.0
    rel = quat_multiply(nxt, quat_inverse(prv))
    return quat_log(rel) * (fps / span)[:, None, None]
