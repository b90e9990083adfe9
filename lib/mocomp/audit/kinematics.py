"""Kinematic sanity between frames: bone lengths, joint rotation rates, root and point jumps.

* **Bone lengths**: ``|P_j - P_parent(j)|`` of the forward kinematics against the
  skeleton's offset length, every frame. A :class:`~mocomp.core.Motion` keeps its
  offsets fixed, so on a motion this measures the FK's rounding (~1e-15 m);
  :func:`bone_length_deviation` takes any positions (e.g. marker-derived joint
  centres) and finds stretched bones there.
* **Joint rotation rate**: the angle of ``q_i^-1 q_{i+1}`` of each joint's local
  rotation over the frame step (rad/s, the short way round) -- a joint that flips
  by 180 degrees in one frame is a glitch.
* **Root / point jumps**: root travel and the largest travel of any joint between
  two frames, as speeds (m/s).

A finding between frames ``i`` and ``i+1`` covers frames ``(i, i+2)`` (half-open).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.rotations import quat_angle, quat_inverse, quat_multiply
from .findings import Finding, runs_above

__all__ = ["KinematicsAudit", "bone_length_deviation", "step_rates", "kinematics_audit"]


def bone_length_deviation(positions: np.ndarray, parents, rest_lengths: np.ndarray) -> np.ndarray:
    """``(T, J)`` m: ``| |P_j - P_parent| - rest_length_j |`` (0 for the root)."""
    P = np.asarray(positions, dtype=float)
    par = np.asarray(parents).copy()
    par[0] = 0
    v = P - P[:, par]
    d = np.sqrt(np.einsum("tjk,tjk->tj", v, v))           # |v|, ~3x faster than linalg.norm here
    out = np.abs(d - np.asarray(rest_lengths, dtype=float)[None])
    out[:, 0] = 0.0
    return out


def step_rates(motion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(joint rates (T-1, J) rad/s, root speed (T-1,) m/s, largest joint speed (T-1,) m/s)`` between
    consecutive frames.

    The joint rate is ``quat_angle(quat_multiply(quat_inverse(q_i), q_{i+1})) * fps`` written out on
    component-major arrays (``2 atan2(|v|, |w|)`` of the product ``q_i^* q_{i+1} = (v, w)``), which
    :func:`step_rates_reference` keeps in the straightforward form (``tests/test_audit.py``)."""
    ax, ay, az, aw = np.moveaxis(motion.rotations, -1, 0)
    a = ax[:-1], ay[:-1], az[:-1], aw[:-1]
    b = ax[1:], ay[1:], az[1:], aw[1:]
    # conj(a) * b = (aw b_v - bw a_v - a_v x b_v, aw bw + a_v . b_v)   (quat_multiply's formula)
    x = a[3] * b[0] - a[0] * b[3] - a[1] * b[2] + a[2] * b[1]
    y = a[3] * b[1] + a[0] * b[2] - a[1] * b[3] - a[2] * b[0]
    z = a[3] * b[2] - a[0] * b[1] + a[1] * b[0] - a[2] * b[3]
    w = a[3] * b[3] + a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    rate = 2.0 * np.arctan2(np.sqrt(x * x + y * y + z * z), np.minimum(np.abs(w), 1.0)) * motion.fps
    root = np.linalg.norm(np.diff(motion.root_positions, axis=0), axis=1) * motion.fps
    P = motion.fk()[0]
    dP = P[1:] - P[:-1]
    pts = np.sqrt(np.einsum("tjk,tjk->tj", dP, dP).max(axis=1)) * motion.fps
    return rate, root, pts


def step_rates_reference(motion) -> np.ndarray:
    """``(T-1, J)`` rad/s: the joint rates of :func:`step_rates` in their straightforward form."""
    q = motion.rotations
    return quat_angle(quat_multiply(quat_inverse(q[:-1]), q[1:])) * motion.fps


@dataclass(frozen=True)
class KinematicsAudit:
    """Largest values over the clip: ``bone_length`` m (with its joint), ``joint_speed`` rad/s (with its
    joint and step frame), ``root_speed`` and ``point_speed`` m/s (with their step frames); ``rates``:
    the ``(T-1, J)`` joint rates of :func:`step_rates` (not in ``to_dict``)."""

    bone_length: float
    bone_joint: str
    joint_speed: float
    joint_speed_joint: str
    joint_speed_frame: int
    root_speed: float
    root_speed_frame: int
    point_speed: float
    point_speed_frame: int
    rates: np.ndarray | None = field(default=None, repr=False, compare=False)   # (T-1, J) rad/s, step_rates

    def to_dict(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "rates"}


def inert_joints(body) -> np.ndarray:
    """``(J,)`` bool: joints whose rotation moves no segment of ``body`` (neither they nor any
    descendant carries one)."""
    sk = body.skeleton
    moves = np.zeros(sk.n_joints, bool)
    for c in set(int(j) for j in body.segment_joint):
        moves[sk.chain(c)] = True
    return ~moves


def kinematics_audit(motion, thresholds, body=None) -> tuple[KinematicsAudit, list]:
    sk = motion.skeleton
    inert = inert_joints(body) if body is not None else np.zeros(sk.n_joints, bool)
    names = sk.names
    P = motion.fk()[0]
    dev = bone_length_deviation(P, sk.parents, np.linalg.norm(sk.offsets, axis=1))
    jb = int(np.argmax(dev.max(axis=0)))
    findings = []
    T = motion.n_frames
    if T < 2:
        return KinematicsAudit(float(dev.max()), names[jb], 0.0, names[0], 0, 0.0, 0, 0.0, 0), findings
    rate, root, pts = step_rates(motion)
    jr_f, jr_j = np.unravel_index(int(np.argmax(rate)), rate.shape)
    k = KinematicsAudit(float(dev.max()), names[jb], float(rate[jr_f, jr_j]), names[jr_j], int(jr_f),
                        float(root.max()), int(np.argmax(root)), float(pts.max()), int(np.argmax(pts)), rate)
    bl = dev.max(axis=1)
    for a, b, p in runs_above(bl, thresholds.bone_length):
        j = int(np.argmax(dev[p]))
        findings.append(Finding("bone_length", "violation", (a, b), p, float(bl[p]), thresholds.bone_length,
                                "bone_length", "m", names[j],
                                f"bone {names[sk.parents[j]]}->{names[j]} off its length by {bl[p] * 1000:.3f} mm"))
    for sev, mask in (("violation", ~inert), ("advisory", inert)):
        if not mask.any():
            continue
        r = np.where(mask[None], rate, 0.0)
        per_step = r.max(axis=1)
        for a, b, p in runs_above(per_step, thresholds.joint_speed):
            j = int(np.argmax(r[p]))
            findings.append(Finding(
                "joint_speed", sev, (a, b + 1), p, float(per_step[p]), thresholds.joint_speed, "joint_speed", "rad/s",
                names[j], f"{names[j]} turns {np.degrees(per_step[p] / motion.fps):.0f} deg between frames {p} and "
                f"{p + 1} ({per_step[p]:.0f} rad/s); limit {thresholds.joint_speed:g} rad/s"
                + (" (moves no mass of the body model)" if sev == "advisory" else "")))
    for check, v, lim, what in (("root_speed", root, thresholds.root_speed, "root"),
                                ("point_speed", pts, thresholds.point_speed, "a joint")):
        for a, b, p in runs_above(v, lim):
            where = names[0] if check == "root_speed" else names[int(np.argmax(np.linalg.norm(P[p + 1] - P[p], axis=-1)))]
            findings.append(Finding(check, "violation", (a, b + 1), p, float(v[p]), lim, check, "m/s", where,
                                    f"{what} ({where}) travels {v[p] / motion.fps * 100:.1f} cm between frames {p} "
                                    f"and {p + 1} ({v[p]:.1f} m/s); limit {lim:g} m/s"))
    return k, findings
