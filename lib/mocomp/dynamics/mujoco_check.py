"""MuJoCo as a peer: the same motion's COM and angular momentum from MuJoCo.

:func:`qpos_qvel` turns a motion into MuJoCo generalised coordinates for the
model from :func:`~mocomp.body.mjcf.to_mjcf`, with velocities *matched* to ours:
the root's linear velocity is our central difference of root positions, and
each joint's ball velocity is its angular velocity relative to its parent,
``R_j^T (w_j - w_parent)``, from the same quaternion finite differences
(:func:`~mocomp.core.kinematics.angular_velocity`). MuJoCo then propagates
velocities down the tree as rigid bodies, which equals our
``momentum(..., velocity="kinematic")``; the default finite-difference
velocities differ from it by O(dt^2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..body.mjcf import mjcf_names, to_mjcf
from ..core.rotations import quat_apply, quat_inverse
from ..core.kinematics import angular_velocity, central_difference

__all__ = ["qpos_qvel", "MujocoMomentum", "mujoco_momentum", "build_mujoco"]


def _wxyz(q):
    return np.concatenate([q[..., 3:4], q[..., :3]], axis=-1)


def qpos_qvel(motion, model, order: int = 2, velocities=None) -> tuple[np.ndarray, np.ndarray]:
    """``qpos (T, nq)`` and ``qvel (T, nv)`` of ``motion`` for ``model`` (from
    :func:`~mocomp.body.mjcf.to_mjcf` of a body on the same skeleton).

    MuJoCo orders bodies depth-first, which need not be the skeleton's order;
    joints are placed by name through ``jnt_qposadr`` / ``jnt_dofadr``.
    Quaternions are MuJoCo's ``(w, x, y, z)``; the free joint's linear velocity is
    in world axes, its angular velocity and every ball joint's in the child frame.
    ``velocities``: a :class:`~mocomp.dynamics.momentum.MotionVelocities` of known rates
    (e.g. :attr:`mocomp.synth.SynthResult.velocities`) put into ``qvel`` as they are,
    instead of the finite differences (its joint rates are already each joint's rate
    relative to its parent in its own frame, MuJoCo's ball-joint convention).
    """
    P, G = motion.fk()
    t = motion.times
    T, J = motion.n_frames, motion.skeleton.n_joints
    names = mjcf_names(motion.skeleton)
    if velocities is not None and (velocities.n_frames != T or velocities.joint_angular_velocities.shape[1] != J):
        raise ValueError(f"velocities for {velocities.n_frames} frames x {velocities.joint_angular_velocities.shape[1]} "
                         f"joints do not fit a motion of {T} frames x {J} joints")
    w = angular_velocity(G, t, order=order) if velocities is None else None  # world
    qpos = np.zeros((T, model.nq))
    qvel = np.zeros((T, model.nv))
    fj = model.joint("root_free")
    a, d = int(fj.qposadr[0]), int(fj.dofadr[0])
    qpos[:, a:a + 3] = motion.root_positions
    qpos[:, a + 3:a + 7] = _wxyz(motion.rotations[:, 0])
    if velocities is None:
        qvel[:, d:d + 3] = central_difference(motion.root_positions, t, order=order)
        qvel[:, d + 3:d + 6] = quat_apply(quat_inverse(G[:, 0]), w[:, 0])
    else:
        qvel[:, d:d + 3] = velocities.root_velocity
        qvel[:, d + 3:d + 6] = quat_apply(quat_inverse(G[:, 0]), velocities.root_angular_velocity)
    par = motion.skeleton.parents
    for j in range(1, J):
        jt = model.joint(f"{names[j]}_ball")
        a, d = int(jt.qposadr[0]), int(jt.dofadr[0])
        qpos[:, a:a + 4] = _wxyz(motion.rotations[:, j])
        qvel[:, d:d + 3] = (quat_apply(quat_inverse(G[:, j]), w[:, j] - w[:, par[j]]) if velocities is None
                            else velocities.joint_angular_velocities[:, j])
    return qpos, qvel


def build_mujoco(body, **kwargs):
    """``(mujoco.MjModel, mujoco.MjData)`` from :func:`~mocomp.body.mjcf.to_mjcf`."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(to_mjcf(body, **kwargs))
    return model, mujoco.MjData(model)


@dataclass(frozen=True, eq=False)
class MujocoMomentum:
    """MuJoCo's answers per frame.

    Attributes
    ----------
    com: ``(T, 3)`` m, ``data.subtree_com`` of the root body.
    com_velocity: ``(T, 3)`` m/s, ``data.subtree_linvel`` of the root body.
    angular: ``(T, 3)`` kg m^2/s, ``data.subtree_angmom`` of the root body (about the COM).
    total_mass: kg, ``model.body_subtreemass`` of the root (includes the tiny masses of massless joints).
    seconds: wall time of the per-frame loop (``mj_kinematics``, ``mj_comPos``, ``mj_comVel``, ``mj_subtreeVel``).
    """

    com: np.ndarray
    com_velocity: np.ndarray
    angular: np.ndarray
    total_mass: float
    seconds: float


def mujoco_momentum(body, motion, model=None, data=None, qpos=None, qvel=None, order: int = 2) -> MujocoMomentum:
    """COM, COM velocity and angular momentum about the COM from MuJoCo, frame by frame."""
    import time

    import mujoco

    if model is None:
        model, data = build_mujoco(body)
    if qpos is None:
        qpos, qvel = qpos_qvel(motion, model, order=order)
    T = qpos.shape[0]
    root = model.body(mjcf_names(body.skeleton)[0]).id
    com = np.empty((T, 3))
    vel = np.empty((T, 3))
    L = np.empty((T, 3))
    t0 = time.perf_counter()
    for i in range(T):
        data.qpos[:] = qpos[i]
        data.qvel[:] = qvel[i]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_subtreeVel(model, data)
        com[i] = data.subtree_com[root]
        vel[i] = data.subtree_linvel[root]
        L[i] = data.subtree_angmom[root]
    secs = time.perf_counter() - t0
    return MujocoMomentum(com, vel, L, float(model.body_subtreemass[root]), secs)
