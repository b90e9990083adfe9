"""Linear and angular momentum of a motion (flips paper section 4.3; dissertation eq. 5.4-5.5).

``p(t) = sum_i m_i v_i(t)`` (eq. 5.4) and, about the whole-body COM,
``L(t) = sum_i R_i I_i R_i^T w_i + m_i (c_i - COM) x v_i`` (eq. 5.5; the extracted
text drops ``w_i`` from the first term, it belongs there). ``R_i`` is the
segment's world rotation, ``I_i`` its inertia about its COM in its own frame,
``w_i`` its world angular velocity, ``c_i`` and ``v_i`` its COM position and
velocity.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kinematics import (angular_velocity, central_difference, point_velocities, propagate_velocities,
                               world_angular_velocities)
from ..core.rotations import quat_apply, quat_inverse, quat_matrix
from ..errors import MotionFormatError
from .com import check_compatible
from .derivatives import smooth_motion

__all__ = ["MomentumResult", "MotionVelocities", "momentum", "assemble_momentum", "composite_inertia",
           "world_inertias", "joint_velocities"]

VELOCITY_MODES = ("finite_difference", "kinematic")


def _compiled():
    """The compiled kernels' module when numba is available, else ``None`` (imported on first use,
    so that ``import mocomp.dynamics`` does not pay numba's import)."""
    from . import _kernels

    return _kernels if _kernels.AVAILABLE else None


@dataclass(frozen=True, eq=False)
class MotionVelocities:
    """Known time derivatives of a motion's coordinates, frame by frame (e.g. the exact
    rates a synthetic generator integrated with; see :attr:`mocomp.synth.SynthResult.velocities`).

    Attributes
    ----------
    root_velocity: ``(T, 3)`` m/s, world velocity of the root joint's origin.
    root_angular_velocity: ``(T, 3)`` rad/s, world angular velocity of the root frame.
    joint_angular_velocities: ``(T, J, 3)`` rad/s, each joint's rotation rate relative to
        its parent, in the joint's own (child) frame: ``d/dt R_local = R_local [w]x``
        (entry 0, the root, is ignored). For a local rotation ``Exp(phi(t))`` this is
        ``J_r(phi) phi_dot`` (right Jacobian of SO(3)).

    Pass it as ``momentum(body, motion, velocity=...)``: the world angular velocity of
    joint ``j`` is ``w_parent + G_j w_j`` and its origin moves with
    ``v_j = v_parent + w_parent x (P_j - P_parent)`` (rigid-body propagation down the
    tree, :func:`joint_velocities`), so eq. 5.4-5.5 are evaluated with no time
    differences at all.
    """

    root_velocity: np.ndarray
    root_angular_velocity: np.ndarray
    joint_angular_velocities: np.ndarray

    def __post_init__(self):
        v = np.array(self.root_velocity, dtype=float, copy=True)
        w = np.array(self.root_angular_velocity, dtype=float, copy=True)
        wj = np.array(self.joint_angular_velocities, dtype=float, copy=True)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"root_velocity must have shape (T, 3), got {v.shape}")
        if w.shape != v.shape:
            raise ValueError(f"root_angular_velocity must have shape {v.shape}, got {w.shape}")
        if wj.ndim != 3 or wj.shape[0] != v.shape[0] or wj.shape[2] != 3:
            raise ValueError(f"joint_angular_velocities must have shape ({v.shape[0]}, J, 3), got {wj.shape}")
        for name, a in (("root_velocity", v), ("root_angular_velocity", w), ("joint_angular_velocities", wj)):
            if not np.all(np.isfinite(a)):
                k = int(np.argwhere(~np.isfinite(a))[0][0])
                raise ValueError(f"{name} is not finite at frame {k}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def n_frames(self) -> int:
        return self.root_velocity.shape[0]

    def __getitem__(self, frames) -> "MotionVelocities":
        """The rates of a frame slice (as :meth:`mocomp.core.Motion.__getitem__` slices the motion)."""
        if not isinstance(frames, slice):
            raise TypeError("MotionVelocities supports slices of frames only")
        return MotionVelocities(self.root_velocity[frames], self.root_angular_velocity[frames],
                                self.joint_angular_velocities[frames])

    def check_fits(self, motion) -> None:
        """Raise ``ValueError`` unless these rates have ``motion``'s frames and joints."""
        if motion.n_frames != self.n_frames or motion.skeleton.n_joints != self.joint_angular_velocities.shape[1]:
            raise ValueError(f"velocities for {self.n_frames} frames x {self.joint_angular_velocities.shape[1]} "
                             f"joints do not fit a motion of {motion.n_frames} frames x "
                             f"{motion.skeleton.n_joints} joints")

    def world_angular_velocities(self, motion) -> np.ndarray:
        """``(T, J, 3)`` rad/s world angular velocity of every joint frame of ``motion``."""
        self.check_fits(motion)
        _, G = motion.fk()
        # w_j = w_root + sum of G_k w_k over the joints k on the path root -> j (k != root)
        return world_angular_velocities(motion.skeleton.parents, G, self.root_angular_velocity,
                                        self.joint_angular_velocities)


@dataclass(frozen=True, eq=False)
class MomentumResult:
    """Momentum of a motion, frame by frame.

    Attributes
    ----------
    times: ``(T,)`` s, frame times.
    com: ``(T, 3)`` m, whole-body centre of mass.
    com_velocity: ``(T, 3)`` m/s, ``linear / total_mass``.
    linear: ``(T, 3)`` kg m/s, ``p = sum_i m_i v_i`` (eq. 5.4).
    angular: ``(T, 3)`` kg m^2/s, ``L`` about the COM (eq. 5.5), world axes.
    segment_positions: ``(T, S, 3)`` m, segment COMs.
    segment_velocities: ``(T, S, 3)`` m/s, segment COM velocities.
    segment_angular_velocities: ``(T, S, 3)`` rad/s, world frame.
    total_mass: kg.
    smooth_sigma: Gaussian sigma in frames applied to the motion's root positions
        and joint rotations before differentiating (``None``: no smoothing).
    velocity_mode: ``"finite_difference"`` (segment COM velocities by central
        differences of their positions, as in the papers), ``"kinematic"``
        (rigid-body propagation of the root velocity and the joints' angular
        velocities down the tree, as a physics engine does) or ``"given"``
        (known rates, :class:`MotionVelocities`, propagated the same way).
    """

    times: np.ndarray
    com: np.ndarray
    com_velocity: np.ndarray
    linear: np.ndarray
    angular: np.ndarray
    segment_positions: np.ndarray
    segment_velocities: np.ndarray
    segment_angular_velocities: np.ndarray
    total_mass: float
    smooth_sigma: float | None = None
    velocity_mode: str = "finite_difference"
    order: int = 2

    @property
    def n_frames(self) -> int:
        return len(self.times)

    def angular_speed_about_com(self) -> np.ndarray:
        """``(T,)`` ``|L|`` kg m^2/s."""
        return np.linalg.norm(self.angular, axis=1)

    def drift(self, start: int = 0, stop: int | None = None) -> dict:
        """Conservation evidence over frames ``[start, stop)``: max relative change of ``|L - L_mean|``
        and of horizontal ``p``; handy for flight phases."""
        L = self.angular[start:stop]
        Lm = L.mean(axis=0)
        p = self.linear[start:stop, [0, 2]]
        pm = p.mean(axis=0)
        return {
            "L_mean": Lm,
            "L_rel_dev": float(np.max(np.linalg.norm(L - Lm, axis=1)) / max(np.linalg.norm(Lm), 1e-12)),
            "p_horizontal_mean": pm,
            "p_horizontal_dev": float(np.max(np.linalg.norm(p - pm, axis=1))),
        }


def world_inertias(body, rotations) -> np.ndarray:
    """``(T, S, 3, 3)`` segment inertias about their COMs in world axes: ``R_i I_i R_i^T``."""
    R = quat_matrix(rotations)
    return np.einsum("tsij,sjk,tslk->tsil", R, body.inertias, R, optimize=True)


def joint_velocities(motion, omega_joints=None, order: int = 2, root_velocity=None):
    """Rigid-body velocities of every joint origin ``(T, J, 3)`` and world angular velocities ``(T, J, 3)``.

    The root's linear velocity is ``root_velocity`` or else the central difference
    of its positions; angular velocities are ``omega_joints`` (world) or else
    :func:`~mocomp.core.kinematics.angular_velocity` of the global joint rotations; child
    origins follow ``v_j = v_parent + w_parent x (P_j - P_parent)``
    (:func:`~mocomp.core.kinematics.propagate_velocities`).
    """
    P, G = motion.fk()
    t = motion.times
    w = angular_velocity(G, t, order=order) if omega_joints is None else omega_joints
    v0 = central_difference(motion.root_positions, t, order=order) if root_velocity is None else root_velocity
    return propagate_velocities(motion.skeleton.parents, P, w, v0), w


def momentum(body, motion, smooth_sigma: float | None = None, velocity="finite_difference",
             order: int = 2) -> MomentumResult:
    """Linear momentum (eq. 5.4) and angular momentum about the COM (eq. 5.5) for every frame.

    Parameters
    ----------
    body: :class:`~mocomp.body.BodyModel` of ``motion``'s skeleton.
    motion: the :class:`~mocomp.core.Motion` (at least 2 frames).
    smooth_sigma: optional Gaussian pre-smoothing of root positions and joint
        rotations, sigma in frames (recorded in the result).
    velocity: ``"finite_difference"`` (default; papers), ``"kinematic"`` (see
        :class:`MomentumResult`; both use the same angular velocities) or a
        :class:`MotionVelocities` of known rates (``velocity_mode="given"``: no time
        differences; ``smooth_sigma`` and ``order`` must then be left at their defaults).
    order: accuracy order of the time differences, 2 (default) or 4 (uniform frame
        times; for exact synthetic motions, see :func:`~mocomp.core.kinematics.central_difference`).

    ``velocity="kinematic"`` propagates the root velocity and the joints' angular
    velocities down the tree as a physics engine does: it is the mode that matches
    MuJoCo's ``qvel`` (:mod:`mocomp.dynamics.mujoco_check`). It is *not* more accurate
    than finite differences of the segment COMs: ``L`` about the COM is blind to a
    velocity error shared by all segments, but the lever-arm terms
    ``w_parent x (P_j - P_parent)`` carry every ancestor's angular-velocity
    difference error to its descendants; over the embedded synthetic flights at
    120 fps its ``|L - L0| / |L0|`` measured 1.8x (frontflip) to 5.7x (backflip)
    that of ``"finite_difference"``. For a synthetic motion the exact
    figure comes from the generator's own rates,
    ``momentum(r.body, r.motion, velocity=r.velocities)`` (issue 3's conservation
    check, ``tests/test_synth_conservation.py``).
    """
    if isinstance(velocity, MotionVelocities):
        if smooth_sigma or order != 2:
            raise ValueError("known velocities are used as given: smooth_sigma and order do not apply")
        check_compatible(body, motion)
        velocity.check_fits(motion)
        if _compiled() is not None:
            return _momentum_given_compiled(body, motion, velocity)
        return _momentum_given_numpy(body, motion, velocity)
    if isinstance(velocity, str) and velocity not in VELOCITY_MODES:
        raise ValueError(f"velocity must be one of {VELOCITY_MODES} or a MotionVelocities, got {velocity!r}")
    if not isinstance(velocity, str):
        raise TypeError(f"velocity must be one of {VELOCITY_MODES} or a MotionVelocities, got {type(velocity).__name__}")
    check_compatible(body, motion)
    if motion.n_frames < 2:
        raise MotionFormatError("momentum needs at least 2 frames")
    m_in = smooth_motion(motion, smooth_sigma) if smooth_sigma else motion
    t = m_in.times
    P, G = m_in.fk()
    j = body.segment_joint
    rot = G[:, j]
    pos = P[:, j] + quat_apply(rot, body.local_coms[None])
    if velocity == "finite_difference":
        omega = angular_velocity(rot, t, order=order)
        vel = central_difference(pos, t, order=order)
    else:
        vj, wj = joint_velocities(m_in, order=order)
        omega = wj[:, j]
        vel = point_velocities(vj[:, j], omega, P[:, j], pos)
    return assemble_momentum(body, t, pos, rot, vel, omega, smooth_sigma=smooth_sigma, velocity_mode=velocity,
                             order=order)


def _momentum_given_numpy(body, motion, velocity: MotionVelocities) -> MomentumResult:
    """The numpy reference of ``momentum(body, motion, velocity=MotionVelocities)`` (and the
    path taken without numba): :meth:`Motion.fk`, :meth:`MotionVelocities.world_angular_velocities`,
    :func:`joint_velocities`, then eq. 5.4-5.5 (:func:`_assemble_numpy`)."""
    P, G = motion.fk()
    j = body.segment_joint
    rot = G[:, j]
    pos = P[:, j] + quat_apply(rot, body.local_coms[None])
    vj, wj = joint_velocities(motion, omega_joints=velocity.world_angular_velocities(motion),
                              root_velocity=velocity.root_velocity)
    omega = wj[:, j]
    vel = point_velocities(vj[:, j], omega, P[:, j], pos)
    return _assemble_numpy(body, motion.times, pos, rot, vel, omega, velocity_mode="given")


def _momentum_given_compiled(body, motion, velocity: MotionVelocities) -> MomentumResult:
    """``momentum(body, motion, velocity=MotionVelocities)`` in one compiled loop over frames and
    joints (:func:`mocomp.dynamics._kernels.momentum_given_nb`: forward kinematics, rate
    propagation, segment COMs and velocities, eq. 5.4-5.5); equal to
    :func:`_momentum_given_numpy` to rounding. The motion's own FK cache is neither read nor filled."""
    M = body.total_mass
    if M <= 0:
        raise MotionFormatError("body model has zero total mass")
    sk = motion.skeleton
    k = _compiled().momentum_given_nb(sk.parents, sk.offsets, motion.root_positions, motion.rotations,
                                     velocity.root_velocity, velocity.root_angular_velocity,
                                     velocity.joint_angular_velocities, body.segment_joint, body.local_coms,
                                     body.masses, body.inertias, total_mass=M)
    return MomentumResult(times=motion.times, com=k["com"], com_velocity=k["linear"] / M, linear=k["linear"],
                          angular=k["angular"], segment_positions=k["pos"], segment_velocities=k["vel"],
                          segment_angular_velocities=k["omega"], total_mass=M, velocity_mode="given")


def assemble_momentum(body, times, pos, rot, vel, omega, smooth_sigma=None, velocity_mode="given",
                      order: int = 2) -> MomentumResult:
    """eq. 5.4-5.5 from segment kinematics already in hand: COM positions ``pos`` ``(T, S, 3)``,
    orientations ``rot`` ``(T, S, 4)``, COM velocities ``vel`` ``(T, S, 3)`` and world angular
    velocities ``omega`` ``(T, S, 3)`` (what :func:`momentum` computes from a motion).

    The sums run in a compiled loop (:func:`mocomp.dynamics._kernels.assemble_nb`) when numba is
    available, else in numpy (:func:`_assemble_numpy`, the reference; equal to rounding)."""
    kern = _compiled()
    if kern is None:
        return _assemble_numpy(body, times, pos, rot, vel, omega, smooth_sigma, velocity_mode, order)
    M = body.total_mass
    if M <= 0:
        raise MotionFormatError("body model has zero total mass")
    pos, rot, vel, omega = (np.asarray(a, dtype=float) for a in (pos, rot, vel, omega))
    S = body.n_segments
    for name, a, d in (("pos", pos, 3), ("rot", rot, 4), ("vel", vel, 3), ("omega", omega, 3)):
        if a.ndim != 3 or a.shape[1:] != (S, d) or a.shape[0] != pos.shape[0]:
            raise ValueError(f"{name} must have shape ({pos.shape[0]}, {S}, {d}), got {a.shape}")
    com, p, L = kern.assemble_nb(body.masses, body.inertias, rot, pos, vel, omega, total_mass=M)
    return MomentumResult(times=np.asarray(times), com=com, com_velocity=p / M, linear=p, angular=L,
                          segment_positions=pos, segment_velocities=vel, segment_angular_velocities=omega,
                          total_mass=M, smooth_sigma=smooth_sigma if smooth_sigma else None,
                          velocity_mode=velocity_mode, order=order)


def _assemble_numpy(body, times, pos, rot, vel, omega, smooth_sigma=None, velocity_mode="given",
                    order: int = 2) -> MomentumResult:
    """The numpy reference of :func:`assemble_momentum` (eq. 5.4-5.5)."""
    m = body.masses
    M = body.total_mass
    if M <= 0:
        raise MotionFormatError("body model has zero total mass")
    com = np.einsum("s,tsk->tk", m, pos) / M
    p = np.einsum("s,tsk->tk", m, vel)
    # sum_i R_i I_i R_i^T w_i, as R_i (I_i (R_i^T w_i)) with quaternions (no 3x3 products per frame)
    rot = np.asarray(rot, dtype=float)
    u = quat_apply(quat_inverse(rot), omega)
    spin = quat_apply(rot, (body.inertias[None] @ u[..., None])[..., 0]).sum(axis=1)
    L = spin + np.einsum("s,tsk->tk", m, np.cross(pos - com[:, None], vel))
    return MomentumResult(times=np.asarray(times), com=com, com_velocity=p / M, linear=p, angular=L,
                          segment_positions=pos, segment_velocities=vel, segment_angular_velocities=omega,
                          total_mass=M, smooth_sigma=smooth_sigma if smooth_sigma else None,
                          velocity_mode=velocity_mode, order=order)


def composite_inertia(body, motion) -> np.ndarray:
    """``(T, 3, 3)`` whole-body inertia tensor about the COM, world axes:
    ``sum_i R_i I_i R_i^T + m_i (|r_i|^2 1 - r_i r_i^T)``, ``r_i = c_i - COM``."""
    check_compatible(body, motion)
    P, G = motion.fk()
    j = body.segment_joint
    rot = G[:, j]
    pos = P[:, j] + quat_apply(rot, body.local_coms[None])
    com = np.einsum("s,tsk->tk", body.masses, pos) / body.total_mass
    r = pos - com[:, None]
    Iw = world_inertias(body, rot).sum(axis=1)
    r2 = np.einsum("tsk,tsk->ts", r, r)
    par = np.einsum("s,ts->t", body.masses, r2)[:, None, None] * np.eye(3) - np.einsum("s,tsi,tsj->tij", body.masses, r, r)
    return Iw + par
