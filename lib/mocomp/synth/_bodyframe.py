"""Whole-body mass properties in the root (pelvis) frame, with exact velocities.

For a pose given by local joint rotations and local joint angular velocities,
with the root held fixed at the origin with identity orientation, this module
computes, vectorised over ``N`` poses:

* the composite centre of mass ``C`` and its velocity ``C_dot`` (root frame),
* the composite inertia ``I_c`` about ``C`` (root frame),
* the *relative* angular momentum ``h`` about ``C`` produced by the joint
  motion alone (root frame).

With the root at world orientation ``R``, angular velocity ``w`` (world) and
position ``p``, the whole-body angular momentum about the COM is
``L = R (I_c R^T w + h)`` -- flips paper section 4.3 / dissertation eq. 5.5,
``L = sum_i R_i I_i R_i^T w_i + m_i (pos_i - COM) x v_i``, split into the part
due to the root rotation (composite inertia) and the part due to the joints.
The segment conventions are those of :class:`~mocomp.body.BodyModel`: segment
``i`` rides on joint ``segment_joint[i]``; its COM is ``P_j + G_j local_com``,
its inertia ``G_j I_i G_j^T``, its angular velocity that of joint ``j``'s frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..body.model import BodyModel
from ..core.kinematics import forward_kinematics, propagate_velocities, world_angular_velocities
from ..core.rotations import quat_from_matrix, quat_matrix
from ..core.skeleton import Skeleton

__all__ = ["BodyFrame", "body_frame"]


@dataclass(frozen=True)
class BodyFrame:
    """Root-frame kinematics and mass properties of ``N`` poses (see module docstring).

    Attributes
    ----------
    P: ``(N, J, 3)`` joint positions (root at the origin), metres.
    G: ``(N, J, 3, 3)`` joint orientations relative to the root.
    Om: ``(N, J, 3)`` joint-frame angular velocities relative to the root, rad/s.
    V: ``(N, J, 3)`` joint velocities relative to the root, m/s.
    C, C_dot: ``(N, 3)`` composite COM and its velocity.
    I_c: ``(N, 3, 3)`` composite inertia about ``C``, kg m^2.
    h: ``(N, 3)`` relative angular momentum about ``C``, kg m^2/s.
    """

    P: np.ndarray
    G: np.ndarray
    Om: np.ndarray
    V: np.ndarray
    C: np.ndarray
    C_dot: np.ndarray
    I_c: np.ndarray
    h: np.ndarray


def body_frame(skeleton: Skeleton, body: BodyModel, R_local: np.ndarray, w_local: np.ndarray | None = None,
               ) -> BodyFrame:
    """Root-frame kinematics of poses ``R_local`` -- local rotations as matrices ``(N, J, 3, 3)`` or
    unit quaternions ``(N, J, 4)`` -- with local angular velocities ``w_local (N, J, 3)`` (each in
    its own child frame; ``None`` = at rest).

    The root's own entries (joint 0) are ignored: the root is the reference frame. The kinematics
    are core's: :func:`~mocomp.core.kinematics.forward_kinematics` (``G_j = G_parent L_j``,
    ``P_j = P_parent + G_parent offset_j``), :func:`~mocomp.core.kinematics.world_angular_velocities`
    (``Om_j = Om_parent + G_j w_j``) and :func:`~mocomp.core.kinematics.propagate_velocities`
    (``V_j = V_parent + Om_parent x (P_j - P_parent)``).
    """
    R_local = np.asarray(R_local, dtype=float)
    if R_local.ndim == 4 and R_local.shape[-2:] == (3, 3):
        q_local = quat_from_matrix(R_local)
    elif R_local.ndim == 3 and R_local.shape[-1] == 4:
        q_local = np.array(R_local)
    else:
        raise ValueError(f"local rotations must have shape (N, J, 3, 3) or (N, J, 4), got {R_local.shape}")
    N, J = q_local.shape[:2]
    parents = skeleton.parents
    q_local[:, 0] = (0.0, 0.0, 0.0, 1.0)
    zero = np.zeros((N, 3))
    P, Gq = forward_kinematics(parents, skeleton.offsets, zero, q_local)
    G = quat_matrix(Gq)
    moving = w_local is not None
    if moving:
        Om = world_angular_velocities(parents, Gq, zero, w_local)
        V = propagate_velocities(parents, P, Om, zero)
    else:
        Om = np.zeros((N, J, 3))
        V = np.zeros((N, J, 3))
    sj = body.segment_joint
    m = body.masses
    M = m.sum()
    Gs = G[:, sj]                                           # (N, S, 3, 3)
    rc = np.einsum("nsab,sb->nsa", Gs, body.local_coms)     # COM offsets from joints
    c = P[:, sj] + rc
    C = np.einsum("s,nsa->na", m, c) / M
    r = c - C[:, None, :]
    Iw = Gs @ body.inertias[None] @ np.swapaxes(Gs, -1, -2)
    rr = np.einsum("nsa,nsa->ns", r, r)
    I_c = np.einsum("nsab->nab", Iw) + np.einsum("s,ns->n", m, rr)[:, None, None] * np.eye(3) \
        - np.einsum("s,nsa,nsb->nab", m, r, r)
    if moving:
        u = V[:, sj] + np.cross(Om[:, sj], rc)
        C_dot = np.einsum("s,nsa->na", m, u) / M
        h = np.einsum("nsab,nsb->na", Iw, Om[:, sj]) + np.einsum("s,nsa->na", m, np.cross(r, u - C_dot[:, None, :]))
    else:
        C_dot = np.zeros((N, 3))
        h = np.zeros((N, 3))
    return BodyFrame(P, G, Om, V, C, C_dot, I_c, h)
