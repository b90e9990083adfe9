"""Library clips of another skeleton onto the victim's skeleton, by joint-name mapping (issue 18).

The reaction library may hold clips of several skeletons (the shared one: ASE's 17-body humanoid,
a CMU 31-joint BVH, DeepMimic's 15-joint humanoid). The search compares body parts of the victim's
skeleton, so every clip is first brought onto it:

* **same skeleton** (names, parents and offsets): used as it is;
* **same joint names and parents, other bone lengths**: the local rotations are copied and the
  root trajectory scaled by the ratio of leg lengths;
* **another naming convention**: joints are paired through the body model's naming conventions
  (:data:`mocomp.body.mapping.CONVENTIONS`): each of the 16 canonical segments (head, three trunk
  parts, upper arm, forearm, hand, thigh, shank, foot per side) has a carrier joint in both
  skeletons. A carrier's world orientation is transferred with a rest-pose correction ``C``:
  ``G_victim = G_clip C`` where ``C`` turns the victim's rest-pose body frame (trunk up, hip line)
  onto the clip's and then its rest bone direction (proximal -> distal landmark) onto the clip's,
  so every segment points where the clip's does and faces the same way. Joints of the victim that
  carry no segment (the ASE sword and shield, CMU's clavicles) keep an identity local rotation.
  The root is placed so that the mid-hip point follows the clip's, scaled by the leg-length
  ratio (heights stay on the same floor ``y = 0``).

A clip whose skeleton has no convention that resolves (joints missing) is refused with a
:class:`RetargetError` naming the clip and the missing joints.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from ..body.mapping import detect_convention_lenient, resolve_mapping
from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_inverse, quat_multiply
from ..core.skeleton import Skeleton
from ..errors import MotionFormatError

__all__ = ["RetargetError", "retarget", "same_skeleton"]

# which segment a joint carrying several stands for (the root before the spine, trunk before limbs)
_PRIORITY = ("lower_trunk", "middle_trunk", "upper_trunk", "head")


class RetargetError(MotionFormatError):
    """A clip cannot be mapped onto the victim's skeleton (joints missing)."""


def same_skeleton(a: Skeleton, b: Skeleton) -> bool:
    """Same joint names, parents and offsets (to 1e-9 m)."""
    return a == b


def _leg_length(res) -> float:
    segs = list(res.segments)
    lengths = [np.linalg.norm(res.distal[segs.index(s)] - res.proximal[segs.index(s)])
               for s in ("thigh_l", "thigh_r", "shank_l", "shank_r")]
    return float(np.sum(lengths) / 2.0)


def _resolve(skeleton: Skeleton, what: str):
    try:
        return resolve_mapping(skeleton)
    except MotionFormatError as e:
        best = detect_convention_lenient(skeleton)
        missing = sorted({c for c in best.carriers.values() if c not in skeleton})
        if missing:
            raise RetargetError(f"{what}: no joint-name mapping: the closest naming convention {best.name!r} "
                                f"needs the joints {missing}, missing from its skeleton "
                                f"(joints: {list(skeleton.names)})") from None
        raise RetargetError(f"{what}: no joint-name mapping: {e}") from None


def _body_frame(res) -> np.ndarray:
    """``(3, 3)`` rest-pose body frame columns (lateral = right->left hips, up = mid-hip -> neck, forward)."""
    segs = list(res.segments)
    hl = res.proximal[segs.index("thigh_l")]
    hr = res.proximal[segs.index("thigh_r")]
    up = res.proximal[segs.index("upper_trunk")] - 0.5 * (hl + hr)
    lat = hl - hr
    up = up / np.linalg.norm(up)
    lat = lat - up * (lat @ up)
    lat = lat / np.linalg.norm(lat)
    return np.stack([lat, up, np.cross(lat, up)], axis=1)


def _min_rotation(a: np.ndarray, b: np.ndarray) -> Rotation:
    """The smallest rotation taking direction ``a`` onto direction ``b``."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(a @ b)
    if s < 1e-12:
        if c > 0:
            return Rotation.identity()
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return Rotation.from_rotvec(np.pi * perp / np.linalg.norm(perp))
    return Rotation.from_rotvec(axis / s * np.arctan2(s, c))


def _mid_hip(motion: Motion, res) -> np.ndarray:
    """``(T, 3)`` world mid-hip point of a motion (hip landmarks fixed in the thigh carriers' frames)."""
    P, G = motion.fk()
    rest = motion.skeleton.rest_positions()
    segs = list(res.segments)
    out = 0.0
    for s in ("thigh_l", "thigh_r"):
        k = segs.index(s)
        j = int(res.carriers[k])
        out = out + P[:, j] + quat_apply(G[:, j], res.proximal[k] - rest[j])
    return 0.5 * out


def retarget(motion: Motion, skeleton: Skeleton, name: str | None = None) -> tuple[Motion, tuple[str, ...]]:
    """``motion`` on ``skeleton`` (see the module docstring) and notes saying what was done.

    ``name`` names the clip in errors (default: its source path). Raises :class:`RetargetError`
    when either skeleton has no joint-name mapping.
    """
    what = name or motion.source.path or "clip"
    src = motion.skeleton
    if same_skeleton(src, skeleton):
        return motion, ()
    if src.names == skeleton.names and np.array_equal(src.parents, skeleton.parents):
        res_s, res_d = _resolve(src, what), _resolve(skeleton, "the victim's skeleton")
        scale = _leg_length(res_d) / _leg_length(res_s)
        out = Motion(skeleton, motion.fps, motion.root_positions * scale, motion.rotations,
                     dataclasses.replace(motion.source, notes=motion.source.notes + (
                         f"retargeted: same joints, other bone lengths; local rotations copied, root x {scale:.4f}",)))
        return out, (f"same joint names, other bone lengths: root scaled by {scale:.4f}",)
    res_s = _resolve(src, what)
    res_d = _resolve(skeleton, "the victim's skeleton")
    segs = list(res_d.segments)
    # the rest-pose body frames: turn the victim's onto the clip's
    R_body = Rotation.from_matrix(_body_frame(res_s) @ _body_frame(res_d).T)
    J = skeleton.n_joints
    role = [None] * J
    for k, seg in enumerate(segs):
        j = int(res_d.carriers[k])
        cur = role[j]
        rank = _PRIORITY.index(seg) if seg in _PRIORITY else len(_PRIORITY)
        if cur is None or rank < (_PRIORITY.index(cur) if cur in _PRIORITY else len(_PRIORITY)):
            role[j] = seg
    if role[0] is None:
        raise RetargetError(f"{what}: the victim's root joint {skeleton.names[0]!r} carries no body segment; "
                            "cannot place the retargeted root")
    _, G_s = motion.fk()
    T = motion.n_frames
    G = np.empty((T, J, 4))
    for j in range(J):
        seg = role[j]
        if seg is None:
            G[:, j] = G[:, int(skeleton.parents[j])]
            continue
        k = segs.index(seg)
        ks = list(res_s.segments).index(seg)
        d_d = res_d.distal[k] - res_d.proximal[k]
        d_s = res_s.distal[ks] - res_s.proximal[ks]
        C = (_min_rotation(R_body.apply(d_d), d_s) * R_body).as_quat()
        G[:, j] = quat_multiply(G_s[:, int(res_s.carriers[ks])], C)
    local = np.empty_like(G)
    local[:, 0] = G[:, 0]
    par = skeleton.parents[1:]
    local[:, 1:] = quat_multiply(quat_inverse(G[:, par]), G[:, 1:])
    scale = _leg_length(res_d) / _leg_length(res_s)
    probe = Motion(skeleton, motion.fps, np.zeros((T, 3)), local)
    root = scale * _mid_hip(motion, res_s) - _mid_hip(probe, res_d)
    note = (f"retargeted from {src.n_joints} joints ({res_s.convention.name}) to {skeleton.n_joints} "
            f"({res_d.convention.name}) by segment carriers; positions x {scale:.4f} (leg lengths)")
    out = Motion(skeleton, motion.fps, root, local,
                 dataclasses.replace(motion.source, notes=motion.source.notes + (note,)))
    return out, (note,)

