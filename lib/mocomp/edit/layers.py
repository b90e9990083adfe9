"""Animator edits of the flight phase as layers over a motion (issue 5, section 1).

A layer changes some joints' local rotations over a frame range with a smooth
ease-in/ease-out weight, and returns a new :class:`~mocomp.core.Motion`; the
input is never changed. Three kinds cover the paper's cases (flips paper
section 5.5, dissertation section 5.5, Figures 5.9-5.10):

- :class:`OffsetLayer`: post-multiply a fixed local rotation (rotation vector,
  radians, in the joint's own frame), scaled by the weight.
- :class:`TargetLayer`: slerp the joint's local rotation toward a target local
  rotation (e.g. identity = straight knee in a rig whose rest pose is straight).
- :class:`AimLayer`: rotate a bone (joint -> child joint) so it points along a
  direction given in the frame of a reference joint (e.g. the thigh along the
  trunk's "down" axis, or an arm up above the head). Rig-independent: it needs
  only the rest-pose direction of the bone and of the reference.

Layers compose in order: each sees the previous layer's result.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.motion import Motion, slerp
from ..core.rotations import quat_apply, quat_inverse, quat_multiply, shortest_arc
from ..errors import MocompError

__all__ = ["ease_weights", "OffsetLayer", "TargetLayer", "AimLayer", "apply_layers", "EditRangeError"]


class EditRangeError(MocompError, ValueError):
    """An edit's frame range lies outside the motion (or outside the flight)."""


def ease_weights(n_frames: int, start: int, stop: int, ease: int) -> np.ndarray:
    """``(T,)`` weights: 0 outside ``[start, stop)``, smoothstep ramps of ``ease``
    frames at both ends, 1 in between (C1-continuous: zero slope at the joins).
    """
    if not (0 <= start < stop <= n_frames):
        raise EditRangeError(f"edit frames [{start}, {stop}) are outside the motion's 0..{n_frames}")
    ease = int(max(0, min(ease, (stop - start) // 2)))
    w = np.zeros(n_frames)
    w[start:stop] = 1.0
    if ease > 0:
        ramp = np.arange(1, ease + 1) / (ease + 1)
        s = ramp * ramp * (3 - 2 * ramp)
        w[start:start + ease] = s
        w[stop - ease:stop] = s[::-1]
    return w


@dataclass(frozen=True)
class _Range:
    start: int
    stop: int
    ease: int = 10


@dataclass(frozen=True)
class OffsetLayer(_Range):
    """Add a local rotation (rotation vector ``rotvec``, radians) to ``joint``."""

    joint: str = ""
    rotvec: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def apply(self, motion: Motion) -> Motion:
        j = motion.skeleton.index(self.joint)
        w = ease_weights(motion.n_frames, self.start, self.stop, self.ease)
        off = Rotation.from_rotvec(w[:, None] * np.asarray(self.rotvec, dtype=float)[None]).as_quat()
        rot = np.array(motion.rotations)
        on = w > 0   # frames outside the layer stay bit-identical
        rot[on, j] = quat_multiply(rot[on, j], off[on])
        return motion.replace(rotations=rot)


@dataclass(frozen=True)
class TargetLayer(_Range):
    """Blend ``joint``'s local rotation toward ``target`` (quaternion, scalar-last)."""

    joint: str = ""
    target: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)

    def apply(self, motion: Motion) -> Motion:
        j = motion.skeleton.index(self.joint)
        w = ease_weights(motion.n_frames, self.start, self.stop, self.ease)
        tgt = np.broadcast_to(np.asarray(self.target, dtype=float), (motion.n_frames, 4))
        rot = np.array(motion.rotations)
        on = w > 0
        rot[on, j] = slerp(rot[on, j], tgt[on], w[on])
        return motion.replace(rotations=rot)


@dataclass(frozen=True)
class AimLayer(_Range):
    """Point the bone ``joint -> child`` along ``direction`` expressed in the rest
    frame of ``reference`` (a joint whose global rotation carries the direction),
    blended in with the ease weight.

    Example: ``AimLayer(a, b, joint="LeftUpLeg", child="LeftLeg",
    reference="Hips", direction=(0, -1, 0))`` straightens the left thigh along
    the pelvis's down axis (for a rest pose standing upright, y-up). Instead of
    ``child``, ``axis`` may give the bone's direction in the joint's rest frame.
    """

    joint: str = ""
    child: str = ""
    reference: str = ""
    direction: tuple[float, float, float] = (0.0, -1.0, 0.0)
    axis: tuple[float, float, float] | None = None

    def apply(self, motion: Motion) -> Motion:
        sk = motion.skeleton
        j, r = sk.index(self.joint), sk.index(self.reference)
        if self.axis is not None:
            bone = np.asarray(self.axis, dtype=float)
        else:
            c = sk.index(self.child)
            if sk.parents[c] != j:
                raise ValueError(f"{self.child!r} is not a child of {self.joint!r}")
            bone = sk.offsets[c]
        if np.linalg.norm(bone) < 1e-9:
            raise ValueError(f"bone axis of {self.joint!r} has zero length")
        bone = bone / np.linalg.norm(bone)
        w = ease_weights(motion.n_frames, self.start, self.stop, self.ease)
        G = motion.global_rotations
        d = np.asarray(self.direction, dtype=float)
        d = d / np.linalg.norm(d)
        cur = quat_apply(G[:, j], bone)                       # (T, 3) bone direction now
        want = quat_apply(G[:, r], d)                         # (T, 3) target direction
        fix = shortest_arc(cur, want)                    # world rotation taking cur -> want
        fix = slerp(np.broadcast_to([0.0, 0.0, 0.0, 1.0], fix.shape), fix, w)
        p = sk.parents[j]
        Gp = G[:, p] if p >= 0 else np.broadcast_to([0.0, 0.0, 0.0, 1.0], (motion.n_frames, 4))
        new_global = quat_multiply(fix, G[:, j])
        rot = np.array(motion.rotations)
        on = w > 0   # frames outside the layer stay bit-identical
        rot[on, j] = quat_multiply(quat_inverse(Gp[on]), new_global[on])
        return motion.replace(rotations=rot)


def apply_layers(motion: Motion, layers: Sequence) -> Motion:
    """Apply edit layers in order; returns a new motion (the input is unchanged)."""
    out = motion
    for layer in layers:
        out = layer.apply(out)
    return out
