"""Compiled (numba) per-frame loops of :mod:`mocomp.dynamics.momentum`.

* :func:`momentum_given_nb` -- the whole ``momentum(body, motion, velocity=MotionVelocities)``
  evaluation in one loop over frames and joints: forward kinematics
  (``G_j = G_parent L_j``, ``P_j = P_parent + G_parent offset_j``), world angular velocities
  propagated from the local joint rates (``w_j = w_parent + G_j w_j^local``), joint-origin
  velocities (``v_j = v_parent + w_parent x (P_j - P_parent)``), segment COMs
  ``c_i = P_j + R_i l_i`` and their velocities ``v_i = v_j + w_j x (c_i - P_j)``, then eq. 5.4
  ``p = sum_i m_i v_i`` and eq. 5.5 ``L = sum_i R_i I_i R_i^T w_i + m_i (c_i - COM) x v_i``
  (dissertation; flips paper section 4.3), with no per-joint temporaries; the quaternion algebra
  is the core kernel's inline ``qmul``/``qrot`` (:mod:`mocomp.core._compiled`);
* :func:`assemble_nb` -- eq. 5.4-5.5 alone from segment kinematics in hand
  (:func:`mocomp.dynamics.momentum.assemble_momentum`).

They exist because the numpy versions are dominated by per-call overhead: for a 240-frame,
31-joint clip the numpy path makes ~40 array calls per joint on length-240 vectors. They give the
numpy versions' results to rounding (``tests/test_dynamics_kernels.py``: 1e-12 relative on the
synthetic backflip with its exact rates and on a random motion); the numpy versions stay in
:mod:`mocomp.dynamics.momentum` as the reference and as the fallback when numba cannot be imported
(``AVAILABLE`` False: numba missing or ``MOCOMP_NO_NUMBA`` set, decided in
:mod:`mocomp.core._compiled`). Numba is a project dependency (also used by :mod:`mocomp.flips` and
:mod:`mocomp.splice`); compiled code is cached on disk (``cache=True``). The first call in a
process loads it from that cache (or compiles it, the first time on a machine: a few seconds);
:func:`warmup` does that ahead of time (:mod:`~mocomp.dynamics.momentum` imports this module, and
so numba, on its first call, not at import). All array arguments are passed as C-contiguous
read-only float64/int64 views (:func:`_ro`), so a single compiled signature serves every caller.
"""
from __future__ import annotations

import numpy as np

from ..core._compiled import AVAILABLE, centroid, njit, point_velocity, qmul, qrot, spin

__all__ = ["AVAILABLE", "momentum_given_nb", "assemble_nb", "warmup"]

_WARM = False


def _ro(a, dtype=np.float64) -> np.ndarray:
    """C-contiguous read-only view (a copy only when the dtype or layout differ): one numba signature."""
    a = np.ascontiguousarray(a, dtype=dtype).view()
    a.setflags(write=False)
    return a


if AVAILABLE:
    @njit
    def _sum_frame(t, masses, M, inertias, rot, pos, vel, omega, com, lin, ang):
        """eq. 5.4-5.5 for frame ``t`` from segment kinematics ``rot`` (T, S, 4), ``pos``, ``vel``,
        ``omega`` (T, S, 3) into ``com``, ``lin``, ``ang`` (T, 3); the same operations, in the same
        order per segment, as the numpy ``assemble_momentum`` (``R (I (R^T w))`` with quaternions)."""
        S = masses.shape[0]
        cx, cy, cz = centroid(masses, pos, t, M)
        px, py, pz = centroid(masses, vel, t, 1.0)
        com[t, 0] = cx
        com[t, 1] = cy
        com[t, 2] = cz
        lin[t, 0] = px
        lin[t, 1] = py
        lin[t, 2] = pz
        sx = sy = sz = 0.0
        ox = oy = oz = 0.0
        for s in range(S):
            # R I R^T w
            ex, ey, ez = spin(rot[t, s, 0], rot[t, s, 1], rot[t, s, 2], rot[t, s, 3], inertias, s,
                              omega[t, s, 0], omega[t, s, 1], omega[t, s, 2])
            sx += ex
            sy += ey
            sz += ez
            # m (c - COM) x v
            m = masses[s]
            rx, ry, rz = pos[t, s, 0] - cx, pos[t, s, 1] - cy, pos[t, s, 2] - cz
            vx, vy, vz = vel[t, s, 0], vel[t, s, 1], vel[t, s, 2]
            ox += m * (ry * vz - rz * vy)
            oy += m * (rz * vx - rx * vz)
            oz += m * (rx * vy - ry * vx)
        ang[t, 0] = sx + ox
        ang[t, 1] = sy + oy
        ang[t, 2] = sz + oz

    @njit
    def _assemble(masses, M, inertias, rot, pos, vel, omega, com, lin, ang):
        for t in range(pos.shape[0]):
            _sum_frame(t, masses, M, inertias, rot, pos, vel, omega, com, lin, ang)

    @njit
    def _momentum_given(parents, offsets, root_pos, local_rot, root_vel, root_omega, joint_rates,
                        seg_joint, local_coms, masses, M, inertias,
                        G, P, W, V, rot, pos, vel, omega, com, lin, ang):
        T, J = local_rot.shape[0], local_rot.shape[1]
        S = seg_joint.shape[0]
        for t in range(T):
            # root: its own rotation, position and rates
            for k in range(4):
                G[t, 0, k] = local_rot[t, 0, k]
            for k in range(3):
                P[t, 0, k] = root_pos[t, k]
                W[t, 0, k] = root_omega[t, k]
                V[t, 0, k] = root_vel[t, k]
            for j in range(1, J):
                p = parents[j]
                ax, ay, az, aw = G[t, p, 0], G[t, p, 1], G[t, p, 2], G[t, p, 3]
                bx, by, bz, bw = local_rot[t, j, 0], local_rot[t, j, 1], local_rot[t, j, 2], local_rot[t, j, 3]
                # G_j = G_p L_j (as forward_kinematics)
                gx, gy, gz, gw = qmul(ax, ay, az, aw, bx, by, bz, bw)
                G[t, j, 0], G[t, j, 1], G[t, j, 2], G[t, j, 3] = gx, gy, gz, gw
                # P_j = P_p + G_p offset_j
                dx, dy, dz = qrot(ax, ay, az, aw, offsets[j, 0], offsets[j, 1], offsets[j, 2])
                P[t, j, 0] = P[t, p, 0] + dx
                P[t, j, 1] = P[t, p, 1] + dy
                P[t, j, 2] = P[t, p, 2] + dz
                # v_j = v_p + w_p x (P_j - P_p)   (before w_j: uses the parent's rate)
                wpx, wpy, wpz = W[t, p, 0], W[t, p, 1], W[t, p, 2]
                V[t, j, 0], V[t, j, 1], V[t, j, 2] = point_velocity(V[t, p, 0], V[t, p, 1], V[t, p, 2], wpx, wpy, wpz,
                                                                    dx, dy, dz)
                # w_j = w_p + G_j w_j^local
                ex, ey, ez = qrot(gx, gy, gz, gw, joint_rates[t, j, 0], joint_rates[t, j, 1], joint_rates[t, j, 2])
                W[t, j, 0] = wpx + ex
                W[t, j, 1] = wpy + ey
                W[t, j, 2] = wpz + ez
            for s in range(S):
                j = seg_joint[s]
                qx, qy, qz, qw = G[t, j, 0], G[t, j, 1], G[t, j, 2], G[t, j, 3]
                rot[t, s, 0], rot[t, s, 1], rot[t, s, 2], rot[t, s, 3] = qx, qy, qz, qw
                # c_i = P_j + R_i l_i
                dx, dy, dz = qrot(qx, qy, qz, qw, local_coms[s, 0], local_coms[s, 1], local_coms[s, 2])
                pos[t, s, 0] = P[t, j, 0] + dx
                pos[t, s, 1] = P[t, j, 1] + dy
                pos[t, s, 2] = P[t, j, 2] + dz
                # v_i = v_j + w_j x (c_i - P_j)
                wx, wy, wz = W[t, j, 0], W[t, j, 1], W[t, j, 2]
                omega[t, s, 0], omega[t, s, 1], omega[t, s, 2] = wx, wy, wz
                vel[t, s, 0], vel[t, s, 1], vel[t, s, 2] = point_velocity(V[t, j, 0], V[t, j, 1], V[t, j, 2], wx, wy,
                                                                          wz, dx, dy, dz)
            _sum_frame(t, masses, M, inertias, rot, pos, vel, omega, com, lin, ang)


def momentum_given_nb(parents, offsets, root_positions, rotations, root_velocity, root_angular_velocity,
                      joint_angular_velocities, segment_joint, local_coms, masses, inertias,
                      total_mass=None) -> dict:
    """Forward kinematics, rate propagation and eq. 5.4-5.5 for every frame (see the module docstring).

    Parameters as :func:`mocomp.core.kinematics.forward_kinematics` (``parents`` with the root's
    entry ignored) and :class:`mocomp.dynamics.momentum.MotionVelocities`; ``segment_joint``,
    ``local_coms``, ``masses`` and ``inertias`` of the :class:`~mocomp.body.BodyModel`.
    Returns a dict of arrays: ``positions``/``global_rotations`` (T, J, 3/4), joint
    ``angular_velocities``/``velocities`` (T, J, 3), segment ``rot`` (T, S, 4), ``pos``, ``vel``,
    ``omega`` (T, S, 3), ``com``, ``linear``, ``angular`` (T, 3). ``total_mass`` defaults to
    ``masses.sum()``.
    """
    q = _ro(rotations)
    T, J = q.shape[:2]
    S = len(segment_joint)
    G = np.empty((T, J, 4))
    P = np.empty((T, J, 3))
    W = np.empty((T, J, 3))
    V = np.empty((T, J, 3))
    rot = np.empty((T, S, 4))
    pos = np.empty((T, S, 3))
    vel = np.empty((T, S, 3))
    omega = np.empty((T, S, 3))
    com = np.empty((T, 3))
    lin = np.empty((T, 3))
    ang = np.empty((T, 3))
    par = np.array(parents, dtype=np.int64)
    par[0] = 0
    _momentum_given(_ro(par, np.int64), _ro(offsets), _ro(root_positions), q, _ro(root_velocity),
                    _ro(root_angular_velocity), _ro(joint_angular_velocities), _ro(segment_joint, np.int64),
                    _ro(local_coms), _ro(masses), float(np.sum(masses)) if total_mass is None else float(total_mass),
                    _ro(inertias), G, P, W, V, rot, pos, vel, omega, com, lin, ang)
    return {"positions": P, "global_rotations": G, "angular_velocities": W, "velocities": V, "rot": rot,
            "pos": pos, "vel": vel, "omega": omega, "com": com, "linear": lin, "angular": ang}


def assemble_nb(masses, inertias, rot, pos, vel, omega, total_mass=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(com, p, L)`` each ``(T, 3)`` from segment kinematics (eq. 5.4-5.5)."""
    pos = _ro(pos)
    T = pos.shape[0]
    com = np.empty((T, 3))
    lin = np.empty((T, 3))
    ang = np.empty((T, 3))
    M = float(np.sum(masses)) if total_mass is None else float(total_mass)
    _assemble(_ro(masses), M, _ro(inertias), _ro(rot), pos, _ro(vel), _ro(omega), com, lin, ang)
    return com, lin, ang


def warmup() -> None:
    """Load (or compile, the first time on a machine) the kernels, so that the first
    :func:`~mocomp.dynamics.momentum` call in a process is not charged for it."""
    global _WARM
    if not AVAILABLE or _WARM:
        return
    q = np.zeros((2, 2, 4))
    q[..., 3] = 1.0
    z = np.zeros((2, 3))
    momentum_given_nb(np.array([-1, 0]), z, z, q, z, z, np.zeros((2, 2, 3)), np.array([0, 1]), z, np.ones(2),
                      np.tile(np.eye(3), (2, 1, 1)))
    assemble_nb(np.ones(2), np.tile(np.eye(3), (2, 1, 1)), q, np.zeros((2, 2, 3)), np.zeros((2, 2, 3)),
                np.zeros((2, 2, 3)))
    _WARM = True

