"""The synthetic performer: a 31-joint skeleton with CMU/cgspeed BVH joint names.

The hierarchy, joint names, zero-length "carrier" joints (``LHipJoint``,
``LowerBack``, ``Neck``, ``LeftShoulder``, ``LeftFingerBase``, ``LThumb``) and
channel order (``Zrotation Yrotation Xrotation``) follow the cgspeed BVH
conversion of the CMU database, so every tool that understands CMU BVH files
understands ours. The *proportions* are the project's own, stated below as
fractions of standing height ``H`` (metres), chosen from anthropometric
landmarks (de Leva 1996, Table 1 segment lengths of the 1.741 m reference male,
scaled by stature; Winter 2009, Fig. 4.1 for heights of the hip, knee, ankle and
shoulder):

=================  ==================  =========================================
joint              height above sole   landmark
=================  ==================  =========================================
Head end site      1.000 H             vertex (top of head)
Head               0.910 H             skull base (atlas)
Neck1              0.875 H             mid-neck
Spine1 (= Neck)    0.840 H             C7 / suprasternale ("CERV")
LeftArm            0.820 H             gleno-humeral joint centre, 0.105 H lateral
Spine              0.695 H             T12-L1 (near xiphion level)
Hips (=LowerBack)  0.575 H             pelvis, 0.041 H above the hip joint centres
LeftUpLeg          0.534 H             hip joint centre, 0.052 H lateral
LeftLeg            0.2915 H            knee joint centre (thigh 0.2425 H)
LeftFoot           0.039 H             ankle joint centre (shank 0.2525 H)
LeftToeBase        0.012 H             metatarso-phalangeal joint, 0.080 H forward
toe end site       0.008 H             tip of the toes, 0.120 H ahead of the ankle
=================  ==================  =========================================

Arms: upper arm 0.172 H, forearm 0.150 H, wrist to knuckles 0.050 H, knuckles
to finger tips 0.045 H; the thumb end site sits 0.025 H along the hand and
0.025 H forward. The rest pose is the CMU T-pose: standing upright (y-up),
facing +z, the performer's left on +x, legs vertical, arms horizontal. The root
offset places the soles on ``y = 0`` in the rest pose, so
:meth:`~mocomp.core.Skeleton.rest_positions` stands on the floor and
:meth:`~mocomp.core.Skeleton.height` is ``H`` minus the toe-tip height (0.992 H).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..core.skeleton import EndSite, Skeleton

__all__ = ["JOINT_NAMES", "PROPORTIONS", "FOOT_EFFECTORS", "LEG_JOINTS", "synthetic_skeleton"]

#: The 31 joint names in hierarchy order (cgspeed CMU BVH), with their parents.
_HIERARCHY: tuple[tuple[str, str | None], ...] = (
    ("Hips", None),
    ("LHipJoint", "Hips"), ("LeftUpLeg", "LHipJoint"), ("LeftLeg", "LeftUpLeg"),
    ("LeftFoot", "LeftLeg"), ("LeftToeBase", "LeftFoot"),
    ("RHipJoint", "Hips"), ("RightUpLeg", "RHipJoint"), ("RightLeg", "RightUpLeg"),
    ("RightFoot", "RightLeg"), ("RightToeBase", "RightFoot"),
    ("LowerBack", "Hips"), ("Spine", "LowerBack"), ("Spine1", "Spine"),
    ("Neck", "Spine1"), ("Neck1", "Neck"), ("Head", "Neck1"),
    ("LeftShoulder", "Spine1"), ("LeftArm", "LeftShoulder"), ("LeftForeArm", "LeftArm"),
    ("LeftHand", "LeftForeArm"), ("LeftFingerBase", "LeftHand"), ("LeftHandIndex1", "LeftFingerBase"),
    ("LThumb", "LeftHand"),
    ("RightShoulder", "Spine1"), ("RightArm", "RightShoulder"), ("RightForeArm", "RightArm"),
    ("RightHand", "RightForeArm"), ("RightFingerBase", "RightHand"), ("RightHandIndex1", "RightFingerBase"),
    ("RThumb", "RightHand"),
)

JOINT_NAMES: tuple[str, ...] = tuple(n for n, _ in _HIERARCHY)

#: Offsets of the left side and the midline as fractions of height (x: left, y: up, z: forward).
#: Right-side joints mirror their left counterparts (x -> -x).
PROPORTIONS: dict[str, tuple[float, float, float]] = {
    "Hips": (0.0, 0.575, 0.0),
    "LHipJoint": (0.0, 0.0, 0.0),
    "LeftUpLeg": (0.052, -0.041, 0.0),
    "LeftLeg": (0.0, -0.2425, 0.0),
    "LeftFoot": (0.0, -0.2525, 0.0),
    "LeftToeBase": (0.0, -0.027, 0.080),
    "LowerBack": (0.0, 0.0, 0.0),
    "Spine": (0.0, 0.120, 0.0),
    "Spine1": (0.0, 0.145, 0.0),
    "Neck": (0.0, 0.0, 0.0),
    "Neck1": (0.0, 0.035, 0.0),
    "Head": (0.0, 0.035, 0.0),
    "LeftShoulder": (0.0, 0.0, 0.0),
    "LeftArm": (0.105, -0.020, 0.0),
    "LeftForeArm": (0.172, 0.0, 0.0),
    "LeftHand": (0.150, 0.0, 0.0),
    "LeftFingerBase": (0.0, 0.0, 0.0),
    "LeftHandIndex1": (0.050, 0.0, 0.0),
    "LThumb": (0.0, 0.0, 0.0),
}

#: End sites (parent joint -> offset as fraction of height), left side and midline.
_END_SITES: dict[str, tuple[float, float, float]] = {
    "LeftToeBase": (0.0, -0.004, 0.040),
    "Head": (0.0, 0.090, 0.0),
    "LeftHandIndex1": (0.045, 0.0, 0.0),
    "LThumb": (0.025, 0.0, 0.025),
}

#: Joints whose positions carry ground contact: ankle (heel) and ball of the foot.
FOOT_EFFECTORS: tuple[str, ...] = ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase")

#: The joints driven by the planted-foot inverse kinematics, per side.
LEG_JOINTS: dict[str, tuple[str, str, str, str]] = {
    "left": ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"),
    "right": ("RightUpLeg", "RightLeg", "RightFoot", "RightToeBase"),
}

_CGSPEED_ROOT = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
_CGSPEED_JOINT = ("Zrotation", "Yrotation", "Xrotation")


def _left_name(name: str) -> tuple[str, float]:
    """The left/midline entry a joint's offset is taken from, and the x sign."""
    if name in PROPORTIONS:
        return name, 1.0
    if name.startswith("Right"):
        return "Left" + name[5:], -1.0
    if name == "RHipJoint":
        return "LHipJoint", -1.0
    if name == "RThumb":
        return "LThumb", -1.0
    raise KeyError(name)


@lru_cache(maxsize=32)
def _build(height: float) -> Skeleton:
    index = {n: i for i, n in enumerate(JOINT_NAMES)}
    parents = np.array([-1 if p is None else index[p] for _, p in _HIERARCHY])
    offsets = np.zeros((len(JOINT_NAMES), 3))
    for j, name in enumerate(JOINT_NAMES):
        src, sx = _left_name(name)
        offsets[j] = np.array(PROPORTIONS[src]) * (sx, 1.0, 1.0) * height
    ends = []
    for name in JOINT_NAMES:
        src, sx = _left_name(name)
        if src in _END_SITES:
            ends.append(EndSite(index[name], np.array(_END_SITES[src]) * (sx, 1.0, 1.0) * height, f"{name}_end"))
    channels = tuple(_CGSPEED_ROOT if j == 0 else _CGSPEED_JOINT for j in range(len(JOINT_NAMES)))
    return Skeleton(JOINT_NAMES, parents, offsets, channels, tuple(ends))


def synthetic_skeleton(height: float = 1.75) -> Skeleton:
    """The project's 31-joint CMU-named skeleton for a performer ``height`` metres tall.

    Offsets are in metres; the rest pose is an upright T-pose facing +z with the
    soles on ``y = 0`` (see the module docstring for the proportions).
    Deterministic and cached per height.
    """
    h = float(height)
    if not (np.isfinite(h) and 0.5 <= h <= 2.6):
        raise ValueError(f"synthetic performer height must be between 0.5 and 2.6 m, got {height!r}")
    return _build(round(h, 12))
