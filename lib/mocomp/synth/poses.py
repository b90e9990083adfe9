"""Key poses of the synthetic performer from anatomical angles (degrees).

A pose is a ``(J, 3)`` array of local joint rotation vectors for the
:func:`~mocomp.synth.skeleton.synthetic_skeleton` (root entry unused). Angles
follow anatomical sign conventions in the T-pose rest frame (x: performer's
left, y: up, z: forward):

* trunk ``flex`` (forward bend) is shared by ``LowerBack``/``Spine``/``Spine1``
  as 0.40/0.35/0.25; ``side`` bends toward the performer's left; ``twist`` turns
  the chest to the left;
* ``neck`` is shared by ``Neck``/``Neck1``, ``head`` nods the ``Head`` joint;
* arms: ``shoulder_flex`` raises the arm forward from hanging (0 = down, 90 =
  forward, 180 = overhead), ``shoulder_abd`` sideways (90 = T-pose),
  ``shoulder_rot`` rotates the upper arm inwards about its own axis (with a bent
  elbow: forearm across the chest), ``elbow`` flexes the forearm, ``clavicle``
  elevates the shoulder girdle;
* legs: ``hip_flex`` raises the thigh forward, ``hip_abd`` spreads it,
  ``knee`` flexes, ``ankle`` plantar-flexes (points the toes), ``toe`` flexes the toes.

Per-side arguments take one value (both sides) or ``(left, right)``. Right-side
rotations are the mirror images (x -> -x) of left-side ones: rotation vector
``(a, b, c)`` -> ``(a, -b, -c)``.
"""
from __future__ import annotations

import numpy as np

from ..core.rotations import euler_to_quat, quat_log
from ..core.skeleton import Skeleton

__all__ = ["pose", "mirror_rotvec", "LEG_POSE_JOINTS"]

#: Joints whose rotations the leg inverse kinematics owns during ground phases.
LEG_POSE_JOINTS = ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
                   "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase")


def mirror_rotvec(v: np.ndarray) -> np.ndarray:
    """Mirror image (x -> -x) of rotation vectors ``(..., 3)``."""
    v = np.array(v, dtype=float, copy=True)
    v[..., 1:] *= -1.0
    return v


def _rv(seq: str, angles_deg) -> np.ndarray:
    """Rotation vector of the composition ``R_a1 R_a2 ...`` (intrinsic sequence), with core's
    :func:`~mocomp.core.rotations.euler_to_quat` and :func:`~mocomp.core.rotations.quat_log`."""
    return quat_log(euler_to_quat(seq.upper(), np.asarray(angles_deg, dtype=float), degrees=True))


def _sides(v):
    if isinstance(v, (tuple, list)):
        if len(v) != 2:
            raise ValueError(f"per-side pose values take one number or (left, right), got {v!r}")
        return float(v[0]), float(v[1])
    return float(v), float(v)


def pose(skeleton: Skeleton, *, flex=0.0, side=0.0, twist=0.0, neck=0.0, head=0.0,
         shoulder_flex=0.0, shoulder_abd=10.0, shoulder_rot=0.0, elbow=10.0, clavicle=0.0,
         hip_flex=0.0, hip_abd=0.0, knee=0.0, ankle=0.0, toe=0.0) -> np.ndarray:
    """``(J, 3)`` local rotation vectors of a pose given in anatomical degrees (see module docstring).

    The default is a relaxed stance: legs straight, arms hanging 10 deg from the
    body with elbows bent 10 deg.
    """
    out = np.zeros((skeleton.n_joints, 3))

    def put(name, rv):
        out[skeleton.index(name)] = rv

    for name, share in (("LowerBack", 0.40), ("Spine", 0.35), ("Spine1", 0.25)):
        # R_y(twist) R_x(flex) R_z(-side): twist about the spine, forward flexion, lateral bend
        put(name, _rv("YXZ", [twist * share, flex * share, -side * share]))
    put("Neck", _rv("X", [neck * 0.5]))
    put("Neck1", _rv("X", [neck * 0.5]))
    put("Head", _rv("X", [head]))
    sf, sa, sr, el, cl = (_sides(x) for x in (shoulder_flex, shoulder_abd, shoulder_rot, elbow, clavicle))
    hf, ha, kn, an, to = (_sides(x) for x in (hip_flex, hip_abd, knee, ankle, toe))
    for k, (pre, arm_prefix) in enumerate((("Left", "Left"), ("Right", "Right"))):
        mirror = (lambda v: v) if k == 0 else mirror_rotvec
        # arm: turn inwards about its axis (R_x(rot)), hang (R_z(-90)), spread sideways (R_z(abd)),
        # raise forward (R_x(-flex))
        put(f"{arm_prefix}Arm", mirror(_rv("XZX", [-sf[k], sa[k] - 90.0, sr[k]])))
        put(f"{arm_prefix}ForeArm", mirror(_rv("Y", [-el[k]])))
        put(f"{pre}Shoulder", mirror(_rv("Z", [cl[k]])))
        put(f"{pre}UpLeg", mirror(_rv("XZ", [-hf[k], ha[k]])))
        put(f"{pre}Leg", mirror(_rv("X", [kn[k]])))
        put(f"{pre}Foot", mirror(_rv("X", [an[k]])))
        put(f"{pre}ToeBase", mirror(_rv("X", [to[k]])))
    return out
