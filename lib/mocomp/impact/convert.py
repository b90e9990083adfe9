"""MuJoCo state <-> :class:`~mocomp.core.Motion` for one character of a :class:`~mocomp.impact.scene.Scene`.

The exported model's body frames equal the skeleton's joint frames at rest
(:mod:`mocomp.body.mjcf`), so a pose maps one to one: the free joint's ``qpos`` is the root
position (m, world, y-up) and the root's rotation, each ball joint's ``qpos`` its local rotation,
MuJoCo quaternions being scalar-first ``(w, x, y, z)`` where ours are scipy's scalar-last.
Velocities: the free joint's linear ``qvel`` is the root's world velocity, its angular ``qvel``
and each ball joint's are angular velocities in the body's own (child) frame, ``omega_local =
log(q_t^-1 q_{t+dt}) / dt`` for a finite step.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_inverse, quat_log, quat_multiply

__all__ = ["to_wxyz", "to_xyzw", "pose_to_qpos", "qpos_to_pose", "motion_state", "frames_to_motion",
           "local_angular_velocity"]


def to_wxyz(q: np.ndarray) -> np.ndarray:
    """scalar-last -> MuJoCo's scalar-first quaternions (any leading shape)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def to_xyzw(q: np.ndarray) -> np.ndarray:
    """MuJoCo's scalar-first -> scalar-last quaternions (any leading shape)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def pose_to_qpos(qpos: np.ndarray, layout, root_position: np.ndarray, rotations: np.ndarray) -> None:
    """Write one pose (root ``(3,)``, local rotations ``(J, 4)`` scalar-last) into ``qpos`` in place
    (``qpos`` is MuJoCo's state buffer, not an input value)."""
    a = layout.qpos_adr
    qpos[a:a + 3] = root_position
    qpos[a + 3:a + 7] = to_wxyz(rotations[0])
    idx = layout.ball_qpos[:, None] + np.arange(4)
    qpos[idx] = to_wxyz(rotations[1:])


def qpos_to_pose(qpos: np.ndarray, layout) -> tuple[np.ndarray, np.ndarray]:
    """``(root (3,), rotations (J, 4) scalar-last, normalised)`` of one character from ``qpos``."""
    a = layout.qpos_adr
    rot = np.empty((len(layout.ball_qpos) + 1, 4))
    rot[0] = to_xyzw(qpos[a + 3:a + 7])
    rot[1:] = to_xyzw(qpos[layout.ball_qpos[:, None] + np.arange(4)])
    rot /= np.linalg.norm(rot, axis=1, keepdims=True)
    return np.array(qpos[a:a + 3]), rot


def local_angular_velocity(q0: np.ndarray, q1: np.ndarray, dt: float) -> np.ndarray:
    """``(..., 3)`` rad/s: the body-frame angular velocity taking ``q0`` to ``q1`` in ``dt`` s
    (``log(q0^-1 q1) / dt``, the short way: core's :func:`~mocomp.core.rotations.quat_log` of the
    normalised relative rotation)."""
    d = quat_multiply(quat_inverse(q0), q1)
    d = d / np.sqrt(np.einsum("...i,...i->...", d, d))[..., None]
    return quat_log(d) / dt


def motion_state(motion: Motion, t: float, layout, qpos: np.ndarray, qvel: np.ndarray, h: float | None = None) -> None:
    """Set one character's ``qpos``/``qvel`` (MuJoCo buffers, in place) to ``motion`` at time ``t`` s,
    velocities by a forward difference over ``h`` s (default one frame; backward at the clip's end)."""
    h = motion.dt if h is None else h
    t0 = float(np.clip(t, 0.0, motion.duration))
    t1 = t0 + h
    if t1 > motion.duration:
        t0, t1 = max(motion.duration - h, 0.0), motion.duration
    s = motion.sample([t0, t1]) if t1 > t0 else motion.sample([t0, t0])
    p = motion.sample([float(np.clip(t, 0.0, motion.duration))])
    pose_to_qpos(qpos, layout, p.root_positions[0], p.rotations[0])
    d = layout.dof_adr
    dt = max(t1 - t0, 1e-9)
    qvel[d:d + 3] = (s.root_positions[1] - s.root_positions[0]) / dt if t1 > t0 else 0.0
    w = local_angular_velocity(s.rotations[0], s.rotations[1], dt) if t1 > t0 else np.zeros((motion.skeleton.n_joints, 3))
    qvel[d + 3:d + 6] = w[0]
    qvel[layout.ball_dof[:, None] + np.arange(3)] = w[1:]


def frames_to_motion(skeleton, fps: float, roots: np.ndarray, rotations: np.ndarray, like: Motion | None = None,
                     note: str = "") -> Motion:
    """A :class:`Motion` from recorded ``roots (T, 3)`` and ``rotations (T, J, 4)`` (scalar-last)."""
    from dataclasses import replace as _replace

    from ..core.motion import SourceInfo
    from ..core.rotations import make_continuous

    src = SourceInfo(path=None, format="simulation", notes=(note,) if note else ())
    if like is not None:
        src = _replace(like.source, path=None, format="simulation", notes=like.source.notes + ((note,) if note else ()))
    return Motion(skeleton=skeleton, fps=float(fps), root_positions=np.asarray(roots, float),
                  rotations=make_continuous(np.asarray(rotations, float), axis=0), source=src)
