"""The generator behind :mod:`mocomp.synth.flights` (see that module for the physics).

Pipeline (all in SI units, world y-up, performer initially facing +z):

1. key poses: standing, crouch, take-off, landing, absorbed, final stance; pelvis
   positions solved so the knee angle and the COM's horizontal place are as designed;
2. the flight's COM parabola from jump height and take-off/landing levels;
3. shooting on the angular momentum ``L0``: for each candidate the take-off
   velocities are solved so that COM velocity, ``L`` and the knee extension rate
   match, the flight joint script gets those initial rates, and the root
   orientation is integrated with RK4 so that ``L`` stays ``L0``; the residual is
   the landing-orientation error;
4. ground phases: pelvis trajectories by quintic Hermite pieces that meet the
   flight's take-off and touchdown states, legs by planted-foot IK.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import root as sp_root, root_scalar

from ..body.model import BodyModel
from ..core.motion import Motion, SourceInfo
from ..core.kinematics import forward_kinematics, load_compiled
from ..core.rotations import (make_continuous, quat_exp, quat_from_matrix, quat_inverse, quat_log, quat_matrix,
                              quat_multiply)
from ..core.skeleton import Skeleton
from ..dynamics.momentum import MotionVelocities
from ..errors import PhysicsError
from ._bodyframe import body_frame
from ._so3 import right_jacobian, left_jacobian
from .legs import leg_chain, leg_ik
from .poses import LEG_POSE_JOINTS
from .result import FlightEvidence, SynthResult
from .script import KeyTrack, bump_ramp, quintic_hermite, smoothstep7
from .skeleton import FOOT_EFFECTORS

__all__ = ["G", "Key", "Design", "generate"]

#: gravitational acceleration, m/s^2 (along -y)
G = 9.81
#: limits on the joint speeds the ground phases may demand at take-off and touchdown, rad/s
MAX_HEEL_RATE = 40.0
MAX_KNEE_RATE = 40.0


@dataclass(frozen=True)
class Key:
    """A key pose of the ground phases.

    theta: rotation (rad) about the design axis, accumulated from the standing pose;
    tilt: ``(3,)`` extra pelvis rotation vector in the body frame (rad), applied after;
    knee: mean knee flexion (deg) the pelvis height is solved for;
    heel: heel rise (deg, 0 = foot flat);
    lead: COM horizontal lead (m) along the travel direction relative to the
        reference point of the feet (mid-foot; the ball of the foot at take-off);
    upper: ``(J, 3)`` pose of the non-leg joints (rotation vectors).
    """

    theta: float
    tilt: tuple
    knee: float
    heel: float
    lead: float
    upper: np.ndarray


@dataclass(frozen=True)
class Design:
    """Everything a generator decides; see :mod:`mocomp.synth.flights`."""

    generator: str
    axis: np.ndarray            # unit world axis of the nominal rotation
    total_angle: float          # rad about axis, standing to standing
    travel: np.ndarray          # (3,) horizontal COM displacement over the flight, m
    jump_height: float          # COM apex above take-off COM, m
    takeoff_level: float
    landing_level: float
    stand: float                # durations, s
    crouch: float
    extend: float
    recover: float
    hold: float
    stand_key: Key
    crouch_key: Key
    takeoff_key: Key
    landing_key: Key
    absorbed_key: Key
    final_key: Key
    tuck_legs: np.ndarray       # (J, 3) leg pose in the tuck (leg joints used)
    tuck_upper: np.ndarray      # (J, 3) upper-body pose in the tuck
    tuck_in: float              # fraction of the flight time to reach the tuck
    tuck_out: float             # fraction of the flight time to open for landing
    knee_rate: float            # knee angular velocity at take-off, rad/s (negative = extending)
    landing_knee_rate: float = 12.0  # knee flexion rate just after touchdown, rad/s
    crouch_accel: float = 8.0   # upward pelvis acceleration at the bottom of the crouch, m/s^2
    upper_lag: float = 0.06     # the upper body reaches its take-off key this long after take-off, s
                                # (arms still swinging up at take-off)
    params: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- helpers
def _key_quat(axis, key: Key) -> np.ndarray:
    return quat_multiply(quat_exp(axis * key.theta), quat_exp(np.asarray(key.tilt, float)))


def _rotvec_from_matrices(R):
    return quat_log(quat_from_matrix(R))


class _Body:
    """The skeleton, body model and leg chains, with pose -> mass-property evaluation."""

    def __init__(self, skeleton: Skeleton, body: BodyModel):
        self.sk = skeleton
        self.body = body
        self.J = skeleton.n_joints
        self.chains = (leg_chain(skeleton, "left"), leg_chain(skeleton, "right"))
        self.leg_idx = np.array([skeleton.index(n) for n in LEG_POSE_JOINTS])
        # joints held at identity: the root (its rotation is the pelvis orientation) and the
        # hip carriers LHipJoint/RHipJoint (the leg IK treats the pelvis as one rigid bone)
        self.fixed = np.array([0] + [c.carrier for c in self.chains])
        self.is_leg = np.zeros(self.J, bool)
        self.is_leg[self.leg_idx] = True
        rest = skeleton.rest_positions(include_end_sites=False)
        # rest-pose (root at origin) toe and ankle positions relative to the root, per side
        self.rest_root = rest[0]
        self.rest_toe = [rest[c.toe] - rest[0] for c in self.chains]
        self.rest_ankle = [rest[c.ankle] - rest[0] for c in self.chains]
        self.toe_height = float(rest[self.chains[0].toe][1])   # toe joint above the sole

    def legs(self, root_pos, root_R, toes, yaws, heels, max_reach: float = 0.9995):
        """Leg local rotation matrices ``(N, 8, 3, 3)`` and knee angles ``(N, 2)``."""
        Rs, knees = [], []
        for c, toe, yaw, heel in zip(self.chains, toes, yaws, heels):
            lp = leg_ik(c, root_pos, root_R, toe, yaw, heel, max_reach=max_reach)
            Rs.append(lp.R_local)
            knees.append(lp.knee_angle)
        return np.concatenate(Rs, axis=1), np.stack(knees, axis=1)

    def local_rates(self, upper_rv, upper_rate, leg_w):
        """Full ``(N, J, 3)`` local angular velocities (child frames) from the upper-body
        rotation vectors and their rates (``J_r(phi) phi_dot``) and the legs' body rates."""
        N = leg_w.shape[0]
        phi = np.broadcast_to(upper_rv, (N, self.J, 3))
        w = np.einsum("njab,njb->nja", right_jacobian(phi), np.broadcast_to(upper_rate, (N, self.J, 3)))
        w[:, self.leg_idx] = leg_w
        w[:, self.fixed] = 0.0
        return w

    def local_matrices(self, upper_rv, leg_R):
        """Full ``(N, J, 3, 3)`` local rotations from upper-body rotation vectors and leg matrices."""
        N = leg_R.shape[0]
        R = quat_matrix(quat_exp(np.broadcast_to(upper_rv, (N, self.J, 3))))
        R = np.array(R)
        R[:, self.leg_idx] = leg_R
        R[:, self.fixed] = np.eye(3)
        return R


# --------------------------------------------------------------------------- key poses
@dataclass(frozen=True)
class _Stance:
    """A solved key pose: pelvis position/orientation, legs, COM."""

    root_pos: np.ndarray
    root_q: np.ndarray
    leg_R: np.ndarray          # (8, 3, 3)
    knees: np.ndarray          # (2,)
    com: np.ndarray            # (3,) world
    upper: np.ndarray          # (J, 3)
    toes: tuple
    yaw: float
    heel: float


def _feet(B: _Body, origin, yaw):
    """Toe-joint world positions of the two feet placed as in the rest pose, turned by ``yaw``
    about the vertical through ``origin`` (a point on the ground under the pelvis)."""
    Ry = quat_matrix(quat_exp(np.array([0.0, yaw, 0.0])))
    out = []
    for t in B.rest_toe:
        local = np.array([t[0], 0.0, t[2]])
        p = np.asarray(origin, float) + Ry @ local
        p[1] = origin[1] + B.toe_height
        out.append(p)
    return tuple(out)


def _foot_reference(B: _Body, toes, yaw, ball: bool) -> np.ndarray:
    """Horizontal reference point of the feet: the ball of the foot (``ball``) or the mid-foot."""
    Ry = quat_matrix(quat_exp(np.array([0.0, yaw, 0.0])))
    pts = []
    for t, ta, aa in zip(toes, B.rest_toe, B.rest_ankle):
        if ball:
            pts.append(t)
        else:
            back = Ry @ (np.array([aa[0], 0, aa[2]]) - np.array([ta[0], 0, ta[2]]))
            pts.append(t + 0.5 * back)
    return np.mean(pts, axis=0)


def _ankle(chain, toe, yaw, heel):
    """Ankle position of a planted foot (see :mod:`mocomp.synth.legs`)."""
    G_foot = quat_matrix(quat_exp(np.array([0.0, yaw, 0.0]))) @ quat_matrix(quat_exp(np.array([heel, 0, 0])))
    return np.asarray(toe) - G_foot @ chain.toe_offset


def _solve_stance(B: _Body, key: Key, q: np.ndarray, toes, yaw: float, travel_dir: np.ndarray,
                  ball_reference: bool, guess: np.ndarray) -> _Stance:
    """Pelvis position such that the mean knee flexion is ``key.knee`` and the COM's
    horizontal position leads the feet reference point by ``key.lead`` along ``travel_dir``."""
    R = quat_matrix(q)
    heel = math.radians(key.heel)
    ref = _foot_reference(B, toes, yaw, ball_reference)
    target = ref + key.lead * travel_dir
    knee_target = math.radians(key.knee)

    def evaluate(p, max_reach):
        legR, knees = B.legs(p[None], R[None], toes, (yaw, yaw), (heel, heel), max_reach=max_reach)
        Rloc = B.local_matrices(key.upper, legR)
        bf = body_frame(B.sk, B.body, Rloc)
        com = p + R @ bf.C[0]
        return legR[0], knees[0], com

    def residual(p):
        # soft IK while searching: an over-stretched leg reads as a straight knee and the
        # excess length as extra "negative flexion", so the residual stays continuous
        _, knees, com = evaluate(p, np.inf)
        over = [max(0.0, np.linalg.norm(p + R @ c.hip_offset - _ankle(c, t, yaw, heel)) - (c.l_thigh + c.l_shank))
                for c, t in zip(B.chains, toes)]
        return np.array([knees.mean() - 10.0 * np.mean(over) - knee_target, com[0] - target[0], com[2] - target[2]])

    sol = sp_root(residual, guess, method="hybr", options={"xtol": 1e-13})
    if not sol.success or np.max(np.abs(residual(sol.x))) > 1e-9:
        raise PhysicsError(f"cannot pose the performer with knee flexion {key.knee:.1f} deg and COM lead "
                           f"{key.lead:.3f} m ({sol.message}); choose a less extreme pose")
    legR, knees, com = evaluate(sol.x, 0.9995)
    return _Stance(sol.x, q, legR, knees, com, key.upper, toes, yaw, heel)


def _leg_rate_jacobian(B: _Body, p, R, toes, yaw, heel, eps: float = 1e-6):
    """Leg joint rates per unit (root velocity, root angular velocity (world), heel rate)
    with the balls of the feet planted: ``K (8, 3, 7)`` body angular velocities of the
    leg joints and ``Kknee (2, 7)`` knee angle rates, by central differences of the IK
    (step ``eps``; the IK is smooth, so the error is ~1e-10 relative)."""
    P, Rs, betas = [], [], []
    for k in range(7):
        e = np.zeros(7)
        e[k] = 1.0
        for sgn in (+1, -1):
            P.append(p + sgn * eps * e[:3])
            Rs.append(quat_matrix(quat_exp(sgn * eps * e[3:6])) @ R)
            betas.append(heel + sgn * eps * e[6])
    betas = np.array(betas)
    legR, knees = B.legs(np.array(P), np.array(Rs), toes, (yaw, yaw), (betas, betas))
    rel = np.swapaxes(legR[1::2], -1, -2) @ legR[0::2]          # R-^T R+
    K = np.moveaxis(_rotvec_from_matrices(rel) / (2 * eps), 0, -1)
    Kknee = ((knees[0::2] - knees[1::2]) / (2 * eps)).T
    return K, Kknee


def _leg_rates(B: _Body, root, R, v, w, toes, yaw, beta, beta_dot, eps: float = 1e-6):
    """Body-frame rates ``(N, 8, 3)`` of the leg joints' local rotations on a ground-phase
    path with the balls of the feet planted: the directional derivative of the closed-form
    IK along the pelvis velocity ``v``, world angular velocity ``w`` and heel rate
    ``beta_dot``, by a central difference of step ``eps`` (the IK is smooth: truncation
    ~eps^2, rounding ~1e-16/eps, together ~1e-10 rad/s)."""
    N = root.shape[0]
    if N == 0:
        return np.zeros((0, B.leg_idx.size, 3))
    P = np.concatenate([root + eps * v, root - eps * v])
    Rs = np.concatenate([quat_matrix(quat_exp(eps * w)) @ R, quat_matrix(quat_exp(-eps * w)) @ R])
    b = np.concatenate([beta + eps * beta_dot, beta - eps * beta_dot])
    legR, _ = B.legs(P, Rs, toes, (yaw, yaw), (b, b), max_reach=1.0)
    rel = np.swapaxes(legR[N:], -1, -2) @ legR[:N]              # R-^T R+
    return _rotvec_from_matrices(rel) / (2 * eps)


def _momentum_map(B: _Body, R, phi_up, phidot_up, leg_R, K):
    """Affine map ``[v_com; L] = A [v_root; w_root; heel_rate] + b`` at one pose.

    ``R`` root orientation; ``phi_up``/``phidot_up`` ``(J, 3)`` the scripted joints'
    rotation vectors and rates (leg entries ignored); ``leg_R`` ``(8, 3, 3)`` the
    leg rotations; ``K`` the leg-rate Jacobian of :func:`_leg_rate_jacobian`.
    ``v_com = v + w x (R C) + R C_dot`` and ``L = R I_c R^T w + R h`` (module
    :mod:`~mocomp.synth._bodyframe`).
    """
    n_in = K.shape[-1]
    Rloc = B.local_matrices(phi_up, leg_R[None])[0]
    w_up = np.einsum("jab,jb->ja", right_jacobian(phi_up), phidot_up)
    w_up[B.leg_idx] = 0.0
    w_up[B.fixed] = 0.0
    W = np.zeros((n_in + 1, B.J, 3))
    W[0] = w_up
    for k in range(n_in):
        W[k + 1, B.leg_idx] = K[:, :, k]
    bf = body_frame(B.sk, B.body, np.broadcast_to(Rloc, (n_in + 1,) + Rloc.shape), W)
    C = R @ bf.C[0]
    A = np.zeros((6, n_in))
    A[:3, :3] = np.eye(3)
    A[:3, 3:6] = -_skew_np(C)                      # w x C = -C x w
    A[3:6, 3:6] = R @ bf.I_c[0] @ R.T
    for k in range(n_in):
        A[:3, k] += R @ bf.C_dot[k + 1]
        A[3:6, k] += R @ bf.h[k + 1]
    b = np.concatenate([R @ bf.C_dot[0], R @ bf.h[0]])
    return A, b


# --------------------------------------------------------------------------- flight integration
def _rk4(q0, L, Iinv, hvec, dt, n_steps, last_dt, axis):
    """Integrate the root orientation with constant world angular momentum ``L``.

    ``q' = 1/2 q (x) (w, 0)``, ``w = I_c^-1 (R(q)^T L - h)`` (body frame; dissertation
    eq. 5.5 split into the root's and the joints' parts, see :mod:`._bodyframe`), with the
    composite inertia inverse ``Iinv`` and relative momentum ``hvec`` sampled on the
    half-step grid (``2 n_steps + 1`` points, then 2 more for the final partial step
    of length ``last_dt``). Pure-Python floats: a few microseconds per stage.
    Returns quaternions at the grid points ``(n_steps + 1 [+1], 4)``, body angular
    velocities there and the rotation about ``axis`` accumulated over the steps.
    """
    Lx, Ly, Lz = L
    ax_, ay_, az_ = axis

    def f(x, y, z, w, k):
        # R(q)^T L: rotate L by the conjugate quaternion
        ux, uy, uz = -x, -y, -z
        tx = 2.0 * (uy * Lz - uz * Ly)
        ty = 2.0 * (uz * Lx - ux * Lz)
        tz = 2.0 * (ux * Ly - uy * Lx)
        vx = Lx + w * tx + (uy * tz - uz * ty) - hvec[k][0]
        vy = Ly + w * ty + (uz * tx - ux * tz) - hvec[k][1]
        vz = Lz + w * tz + (ux * ty - uy * tx) - hvec[k][2]
        a = Iinv[k]
        ox = a[0] * vx + a[1] * vy + a[2] * vz
        oy = a[3] * vx + a[4] * vy + a[5] * vz
        oz = a[6] * vx + a[7] * vy + a[8] * vz
        return (0.5 * (w * ox + y * oz - z * oy), 0.5 * (w * oy + z * ox - x * oz),
                0.5 * (w * oz + x * oy - y * ox), -0.5 * (x * ox + y * oy + z * oz), ox, oy, oz)

    x, y, z, w = (float(c) for c in q0)
    qs = [(x, y, z, w)]
    oms = []
    acc = 0.0
    steps = [(2 * n, dt) for n in range(n_steps)]
    if last_dt > 1e-12:
        steps.append((-1, last_dt))
    base_last = 2 * n_steps
    for k0, h in steps:
        if k0 >= 0:
            k1, k2 = k0 + 1, k0 + 2
        else:
            k0, k1, k2 = base_last, base_last + 1, base_last + 2
        d1 = f(x, y, z, w, k0)
        oms.append(d1[4:])
        hh = 0.5 * h
        d2 = f(x + hh * d1[0], y + hh * d1[1], z + hh * d1[2], w + hh * d1[3], k1)
        d3 = f(x + hh * d2[0], y + hh * d2[1], z + hh * d2[2], w + hh * d2[3], k1)
        d4 = f(x + h * d3[0], y + h * d3[1], z + h * d3[2], w + h * d3[3], k2)
        s = h / 6.0
        nx = x + s * (d1[0] + 2 * d2[0] + 2 * d3[0] + d4[0])
        ny = y + s * (d1[1] + 2 * d2[1] + 2 * d3[1] + d4[1])
        nz = z + s * (d1[2] + 2 * d2[2] + 2 * d3[2] + d4[2])
        nw = w + s * (d1[3] + 2 * d2[3] + 2 * d3[3] + d4[3])
        inv = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
        nx, ny, nz, nw = nx * inv, ny * inv, nz * inv, nw * inv
        # world increment q_new q_old^-1, its angle about the axis
        dx = nw * -x + nx * w + ny * -z - nz * -y
        dy = nw * -y - nx * -z + ny * w + nz * -x
        dz = nw * -z + nx * -y - ny * -x + nz * w
        dw = nw * w - nx * -x - ny * -y - nz * -z
        if dw < 0:
            dx, dy, dz, dw = -dx, -dy, -dz, -dw
        acc += 2.0 * math.atan2(dx * ax_ + dy * ay_ + dz * az_, dw)
        x, y, z, w = nx, ny, nz, nw
        qs.append((x, y, z, w))
    oms.append(f(x, y, z, w, k2 if steps else 0)[4:])
    return np.array(qs), np.array(oms), acc


class _Flight:
    """The flight: joint script, take-off velocity solve and the shooting on ``L0``."""

    def __init__(self, B: _Body, design: Design, t0: float, t1: float, takeoff: _Stance, landing_rel: _Stance,
                 upper_track: KeyTrack, com0: np.ndarray, vcom0: np.ndarray):
        self.B, self.d, self.t0, self.t1 = B, design, t0, t1
        self.T = t1 - t0
        self.takeoff = takeoff
        self.upper_track = upper_track
        self.com0, self.vcom0 = com0, vcom0
        tin, tout = design.tuck_in * self.T, design.tuck_out * self.T
        legs0 = _rotvec_from_matrices(takeoff.leg_R)          # (8, 3)
        legs1 = _rotvec_from_matrices(landing_rel.leg_R)
        tuck = design.tuck_legs[B.leg_idx]
        self.leg_track = KeyTrack(np.array([t0, t0 + tin, t1 - tout, t1]), np.stack([legs0, tuck, tuck, legs1]))
        self.legs0 = legs0
        self.tau_c = min(0.08, 0.45 * tin)                    # window of the take-off rate correction
        self._setup_takeoff_solve()
        self._cache = {}

    # -- take-off velocities ------------------------------------------------------------
    def _setup_takeoff_solve(self):
        """Linear map from (root velocity, root angular velocity, heel-rise rate) to
        (COM velocity, L, mean knee rate), with the ball of each foot planted (IK)."""
        B, st = self.B, self.takeoff
        R0 = quat_matrix(st.root_q)
        self.K, self.Kknee = _leg_rate_jacobian(B, st.root_pos, R0, st.toes, st.yaw, st.heel)
        phi_up, phidot_up = self.upper_track(self.t0)
        A6, b6 = _momentum_map(B, R0, phi_up[0], phidot_up[0], st.leg_R, self.K)
        self.A = np.vstack([A6, self.Kknee.mean(axis=0)])
        self.b = np.concatenate([b6, [0.0]])
        self.R0 = R0

    def takeoff_state(self, L0):
        rhs = np.concatenate([self.vcom0, L0, [self.d.knee_rate]]) - self.b
        x = np.linalg.solve(self.A, rhs)
        return x  # (v_root (3), w_root world (3), heel rate)

    # -- joint script in flight -------------------------------------------------------------
    def script(self, t, x):
        """Local rotation vectors and their rates ``(N, J, 3)`` at flight times ``t``."""
        B = self.B
        phi, phidot = self.upper_track(t)
        phi = np.array(phi)
        phidot = np.array(phidot)
        lv, lr = self.leg_track(t)
        w_legs = np.einsum("jak,k->ja", self.K, x)                         # body rates at take-off
        c = np.linalg.solve(right_jacobian(self.legs0), w_legs[..., None])[..., 0]
        f, df = bump_ramp(np.asarray(t) - self.t0, self.tau_c)
        phi[:, B.leg_idx] = lv + f[:, None, None] * c
        phidot[:, B.leg_idx] = lr + df[:, None, None] * c
        phi[:, B.fixed] = 0.0
        phidot[:, B.fixed] = 0.0
        return phi, phidot

    def mass_properties(self, t, x):
        phi, phidot = self.script(t, x)
        w = np.einsum("njab,njb->nja", right_jacobian(phi), phidot)
        bf = body_frame(self.B.sk, self.B.body, quat_exp(phi), w)
        return bf, phi

    def grid(self, dt):
        n = int(math.floor(self.T / dt + 1e-9))
        last = self.T - n * dt
        if last < 1e-9 * dt:
            last = 0.0
        ts = self.t0 + 0.5 * dt * np.arange(2 * n + 1)
        if last > 0:
            tn = self.t0 + n * dt
            ts = np.concatenate([ts, [tn + 0.5 * last, self.t1]])
        return n, last, ts

    def integrate(self, L0, dt):
        x = self.takeoff_state(L0)
        n, last, ts = self.grid(dt)
        key = (dt,)
        early = ts <= self.t0 + self.tau_c + 1e-12
        if key not in self._cache:
            bf_late, _ = self.mass_properties(ts[~early], x)
            self._cache[key] = (np.linalg.inv(bf_late.I_c), bf_late.h)
        Iinv_late, h_late = self._cache[key]
        bf_e, _ = self.mass_properties(ts[early], x)
        Iinv = np.empty((ts.size, 3, 3))
        hv = np.empty((ts.size, 3))
        Iinv[early], hv[early] = np.linalg.inv(bf_e.I_c), bf_e.h
        Iinv[~early], hv[~early] = Iinv_late, h_late
        q0 = self.takeoff.root_q
        qs, oms, acc = _rk4(q0, tuple(L0), Iinv.reshape(-1, 9).tolist(), hv.tolist(), dt, n, last,
                            tuple(self.d.axis))
        return qs, oms, acc, x, (n, last, ts)


def _skew_np(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


# --------------------------------------------------------------------------- ground phases
def _orientation_piece(t, ta, tb, qa, wa, qb, wb):
    """Orientation on [ta, tb] as ``Exp(r(t)) qb`` with a quintic ``r`` meeting the end
    orientations and world angular velocities (zero chart acceleration at both ends)."""
    ra = quat_log(quat_multiply(qa, quat_inverse(qb)))
    va = np.linalg.solve(left_jacobian(ra), wa)
    r, rd, _ = quintic_hermite(t, ta, tb, ra, va, np.zeros(3), np.zeros(3), wb, np.zeros(3))
    q = quat_multiply(quat_exp(r), qb)
    w = np.einsum("nab,nb->na", left_jacobian(r), rd)
    return q, w


def generate(design: Design, skeleton: Skeleton, body: BodyModel, fps: float = 120.0,
             substep_rate: float = 960.0, check_integration: bool = True) -> SynthResult:
    """Run the pipeline of the module docstring; see :mod:`mocomp.synth.flights`.

    The ~120 forward kinematics of a motion (core's, in :func:`._bodyframe.body_frame` and
    :func:`_world_fk`; 100 of them of one pose, in the stance solves) run compiled when numba is
    available (:func:`mocomp.core.kinematics.load_compiled`); with ``MOCOMP_NO_NUMBA`` the numpy
    reference gives the same motion (to rounding), ~1.4x slower."""
    load_compiled()
    tic = time.perf_counter()
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps!r}")
    d = design
    B = _Body(skeleton, body)
    H = float(skeleton.offsets[0, 1])  # pelvis height scale for initial guesses
    axis = np.asarray(d.axis, float) / np.linalg.norm(d.axis)
    travel = np.asarray(d.travel, float)
    tnorm = np.linalg.norm(travel)
    travel_dir = travel / tnorm if tnorm > 1e-9 else np.array([0.0, 0.0, 1.0])

    # ---- timing (take-off on a frame)
    t_s = d.stand
    t_c = t_s + d.crouch
    t0 = math.ceil((t_c + d.extend) * fps - 1e-9) / fps
    i0 = int(round(t0 * fps))

    # ---- pre-flight stances (feet where the rest pose puts them, on the take-off level)
    origin0 = np.array([0.0, d.takeoff_level, 0.0])
    toes0 = _feet(B, origin0, 0.0)
    guess = np.array([0.0, d.takeoff_level + H * 0.99, 0.0])
    stand = _solve_stance(B, d.stand_key, _key_quat(axis, d.stand_key), toes0, 0.0, travel_dir, False, guess)
    crouch = _solve_stance(B, d.crouch_key, _key_quat(axis, d.crouch_key), toes0, 0.0, travel_dir, False,
                           stand.root_pos - [0, 0.2 * H, 0])
    # the upper body is still moving at take-off: it reaches its take-off key upper_lag later
    u_lag = (t0 - t_c) / (t0 + d.upper_lag - t_c)
    upper0 = crouch.upper + smoothstep7(u_lag) * (d.takeoff_key.upper - crouch.upper)
    takeoff = _solve_stance(B, replace(d.takeoff_key, upper=upper0), _key_quat(axis, d.takeoff_key), toes0, 0.0,
                            travel_dir, True, stand.root_pos + [0, 0.05 * H, 0])

    # ---- landing stances, relative to feet at the origin of the landing level
    feet_yaw = float(d.total_angle * axis[1]) if abs(axis[1]) > 0.5 else 0.0
    originL = np.array([0.0, d.landing_level, 0.0])
    toesL = _feet(B, originL, feet_yaw)
    guessL = originL + [0.0, H * 0.9, 0.0]
    land = _solve_stance(B, d.landing_key, _key_quat(axis, d.landing_key), toesL, feet_yaw, travel_dir, False, guessL)
    absorbed = _solve_stance(B, d.absorbed_key, _key_quat(axis, d.absorbed_key), toesL, feet_yaw, travel_dir, False,
                             land.root_pos - [0, 0.2 * H, 0])
    Ryaw = quat_matrix(quat_exp(np.array([0.0, feet_yaw, 0.0])))
    final = _solve_stance(B, d.final_key, _key_quat(axis, d.final_key), toesL, feet_yaw, travel_dir, False,
                          originL + Ryaw @ (stand.root_pos - origin0))

    # ---- COM parabola
    com0 = takeoff.com
    vy = math.sqrt(2.0 * G * d.jump_height)
    y1 = land.com[1]
    disc = vy * vy + 2.0 * G * (com0[1] - y1)
    if disc <= 0:
        raise PhysicsError(f"a jump height of {d.jump_height:.3f} m cannot reach the landing level "
                           f"{d.landing_level:.3f} m (landing COM at {y1:.3f} m, take-off COM at {com0[1]:.3f} m)")
    T = (vy + math.sqrt(disc)) / G
    t1 = t0 + T
    vcom0 = np.array([travel[0] / T, vy, travel[2] / T])
    com1 = com0 + vcom0 * T + np.array([0.0, -0.5 * G * T * T, 0.0])
    shift = com1 - land.com
    shift[1] = 0.0
    parabola = np.array([[0.0, vcom0[0], com0[0]], [-0.5 * G, vy, com0[1]], [0.0, vcom0[2], com0[2]]])
    # express in absolute time t: c(t) = a (t - t0)^2 + b (t - t0) + c0
    for k in range(3):
        a_, b_, c_ = parabola[k]
        parabola[k] = [a_, b_ - 2 * a_ * t0, a_ * t0 * t0 - b_ * t0 + c_]

    # ---- landing-phase durations (absorb by the touchdown speed)
    drop = land.root_pos[1] - absorbed.root_pos[1]
    v_td = abs(vy - G * T)
    d_absorb = float(np.clip(2.2 * max(drop, 0.05) / max(v_td, 0.5), 0.18, 0.5))
    t_a = t1 + d_absorb
    t_r = t_a + d.recover
    t_end = t_r + d.hold
    n_frames = int(math.floor(t_end * fps + 1e-9)) + 1

    # ---- upper-body script over the whole motion
    tin, tout = d.tuck_in * T, d.tuck_out * T
    key_t = [0.0, t_s, t_c, t0 + d.upper_lag, t0 + tin, t1 - tout, t1, t_a, t_r]
    key_v = [stand.upper, stand.upper, crouch.upper, d.takeoff_key.upper, d.tuck_upper, d.tuck_upper, land.upper,
             absorbed.upper, final.upper]
    if not np.all(np.diff(key_t) > 0):
        raise PhysicsError(f"phase times overlap: {np.round(key_t, 4).tolist()}; lengthen the flight or shorten tuck times")
    upper_track = KeyTrack(np.array(key_t), np.array(key_v))

    # ---- shooting on L0
    landing_rel = _Stance(land.root_pos + shift, land.root_q, land.leg_R, land.knees, land.com + shift, land.upper,
                          tuple(t + shift for t in land.toes), land.yaw, land.heel)
    fl = _Flight(B, d, t0, t1, takeoff, landing_rel, upper_track, com0, vcom0)
    q1_target = land.root_q
    theta_target = d.landing_key.theta - d.takeoff_key.theta
    evals = [0]

    def residual(L0, dt):
        evals[0] += 1
        qs, _, acc, _, _ = fl.integrate(np.asarray(L0, float), dt)
        err = quat_log(quat_multiply(qs[-1], quat_inverse(q1_target)))
        return err, acc

    # initial guess from the mean composite inertia about the axis
    _, _, ts_c = fl.grid(1.0 / 240.0)
    bf_guess, _ = fl.mass_properties(ts_c[::8], np.zeros(7))
    Iax = np.mean([axis @ (fl.R0 @ I @ fl.R0.T) @ axis for I in bf_guess.I_c])
    lam = Iax * theta_target / T
    # 1-D secant (scipy) on the accumulated angle, coarse grid: the requested number of turns;
    # then 3-D Newton on the landing orientation (see _newton for why not MINPACK)
    dt_c = 1.0 / 240.0
    sol1 = root_scalar(lambda lam_: residual(lam_ * axis, dt_c)[1] - theta_target, x0=lam, x1=lam * 1.05 + 1e-3,
                       method="secant", xtol=1e-9, maxiter=40)
    k_sub = max(1, int(math.ceil(substep_rate / fps - 1e-9)))
    dt_f = 1.0 / (fps * k_sub)
    L, r, acc = _newton(lambda L_: residual(L_, dt_c), lambda L_: residual(L_, dt_f), sol1.root * axis,
                        valid=lambda a: abs(a - theta_target) < 0.5 * math.pi)
    if np.linalg.norm(r) > 1e-8:
        raise PhysicsError(f"shooting for the angular momentum did not converge (landing error {np.linalg.norm(r):.2e} rad)")
    if abs(_twist_angle(takeoff.root_q, q1_target, axis, acc) - theta_target) > 1e-6:
        raise PhysicsError(f"the flight rotated {math.degrees(acc):.1f} deg instead of {math.degrees(theta_target):.1f}")
    L0 = L
    qs, oms, acc, x0, (n_steps, last, ts) = fl.integrate(L0, dt_f)
    integration_error = float("nan")
    if check_integration:
        qs2, _, _, _, _ = fl.integrate(L0, dt_f / 2)
        integration_error = float(np.linalg.norm(quat_log(quat_multiply(qs2[-1], quat_inverse(qs[-1])))))

    # ---- flight frames
    times = np.arange(n_frames) / fps
    start = i0 + 1
    stop = int(math.ceil(t1 * fps - 1e-9))
    fi = np.arange(start, stop)
    grid_idx = (fi - i0) * k_sub
    q_fl = qs[grid_idx]
    bf_fl, phi_fl = fl.mass_properties(times[fi], x0)
    R_fl = quat_matrix(q_fl)
    com_fl = np.stack([np.polyval(parabola[k], times[fi]) for k in range(3)], 1)
    root_fl = com_fl - np.einsum("nab,nb->na", R_fl, bf_fl.C)
    # exact flight rates: the RK4 solution's angular velocity at each frame's orientation, the
    # root velocity from the parabola (v = v_com - w x R C - R C_dot), the script's joint rates
    w_fl = np.einsum("nab,nb->na", R_fl, oms[grid_idx])
    vcom_fl = np.stack([np.polyval(np.polyder(parabola[k]), times[fi]) for k in range(3)], 1)
    RC_fl = np.einsum("nab,nb->na", R_fl, bf_fl.C)
    vroot_fl = vcom_fl - np.cross(w_fl, RC_fl) - np.einsum("nab,nb->na", R_fl, bf_fl.C_dot)
    phi_chk, phidot_fl = fl.script(times[fi], x0)
    wloc_fl = np.einsum("njab,njb->nja", right_jacobian(phi_chk), phidot_fl)

    # ---- touchdown on the balls of the feet: the pelvis keeps its velocity and angular
    # velocity (C1 root); the feet stop, the heels come down at the rate that gives the
    # designed knee flexion rate; COM velocity and L jump (the impact)
    q1 = qs[-1]
    bf1, phi1 = fl.mass_properties(np.array([t1]), x0)
    R1 = quat_matrix(q1)
    w1 = R1 @ oms[-1]
    com1_exact = np.array([np.polyval(parabola[k], t1) for k in range(3)])
    vcom1 = np.array([np.polyval(np.polyder(parabola[k]), t1) for k in range(3)])
    p1 = com1_exact - R1 @ bf1.C[0]
    v1 = vcom1 - np.cross(w1, R1 @ bf1.C[0]) - R1 @ bf1.C_dot[0]
    PL, _ = _world_fk(skeleton, p1, q1, quat_exp(phi1[0]))
    toes1 = tuple(PL[c.toe] for c in B.chains)
    yaw1 = feet_yaw
    heel1 = land.heel
    K1, Kk1 = _leg_rate_jacobian(B, p1, R1, toes1, yaw1, heel1)
    phi_up1, phidot_up1 = upper_track(np.array([t1]))
    A1, b1 = _momentum_map(B, R1, phi_up1[0], phidot_up1[0], land.leg_R, K1)
    kk = Kk1.mean(axis=0)
    heel_rate1 = 0.0
    if heel1 > 0:
        # heels come down at the rate giving the designed knee flexion rate, within a
        # physiological range; a harder landing puts the rest on the knees
        heel_rate1 = float((d.landing_knee_rate - kk[:6] @ np.concatenate([v1, w1])) / kk[6])
        heel_rate1 = float(np.clip(heel_rate1, -MAX_HEEL_RATE, 0.0))
    knee_rate1 = float(kk @ np.concatenate([v1, w1, [heel_rate1]]))
    if not (-5.0 <= knee_rate1 <= MAX_KNEE_RATE):
        raise PhysicsError(f"touchdown needs a knee flexion rate of {knee_rate1:.1f} rad/s (allowed -5..{MAX_KNEE_RATE:g}) "
                           "with the heels at their limit; land from lower, with more knee flexion or a higher heel")
    after = A1 @ np.concatenate([v1, w1, [heel_rate1]]) + b1
    vcom_plus, L_plus = after[:3], after[3:]

    # ---- pre-flight ground phase: frames 0..i0
    fpre = np.arange(0, i0 + 1)
    tp = times[fpre]
    q0 = takeoff.root_q
    w0 = x0[3:6]
    v0 = x0[:3]
    # root acceleration just after take-off (for a C2 join), by differentiating the flight solution
    h_ = dt_f
    bf_a, _ = fl.mass_properties(t0 + h_ * np.arange(5), x0)
    Ra = quat_matrix(qs[:5])
    pa = np.stack([np.polyval(parabola[k], t0 + h_ * np.arange(5)) for k in range(3)], 1) - np.einsum(
        "nab,nb->na", Ra, bf_a.C)
    acc0 = (35 * pa[0] - 104 * pa[1] + 114 * pa[2] - 56 * pa[3] + 11 * pa[4]) / (12 * h_ * h_)
    up = np.array([0.0, d.crouch_accel, 0.0])
    root_pre = np.empty((fpre.size, 3))
    q_pre = np.empty((fpre.size, 4))
    v_pre = np.zeros((fpre.size, 3))
    w_pre = np.zeros((fpre.size, 3))
    m_st = tp <= t_s
    root_pre[m_st] = stand.root_pos
    q_pre[m_st] = stand.root_q
    m_cr = (tp > t_s) & (tp <= t_c)
    if m_cr.any():
        root_pre[m_cr], v_pre[m_cr], _ = quintic_hermite(tp[m_cr], t_s, t_c, stand.root_pos, 0 * up, 0 * up,
                                                         crouch.root_pos, 0 * up, up)
        q_pre[m_cr], w_pre[m_cr] = _orientation_piece(tp[m_cr], t_s, t_c, stand.root_q, np.zeros(3), crouch.root_q,
                                                      np.zeros(3))
    m_ex = tp > t_c
    root_pre[m_ex], v_pre[m_ex], _ = quintic_hermite(tp[m_ex], t_c, t0, crouch.root_pos, 0 * up, up,
                                                     takeoff.root_pos, v0, acc0)
    q_pre[m_ex], w_pre[m_ex] = _orientation_piece(tp[m_ex], t_c, t0, crouch.root_q, np.zeros(3), q0, w0)
    # heel rise: flat, then up to the take-off angle and rate; the quintic from rest is
    # monotonic when (rate x duration) <= 2.5 x angle, so the rise lasts 2 angle / rate
    heel_rate = float(x0[6])
    if heel_rate < 0 or heel_rate > MAX_HEEL_RATE:
        raise PhysicsError(f"take-off needs a heel-rise rate of {heel_rate:.1f} rad/s (allowed 0..{MAX_HEEL_RATE:g}); "
                           "change the take-off knee angle, knee rate or jump height")
    rise = min(0.6 * (t0 - t_c), 2.0 * takeoff.heel / max(heel_rate, 1e-9))
    t_h = t0 - rise
    beta = np.zeros(fpre.size)
    beta_dot = np.zeros(fpre.size)
    m_h = tp > t_h
    beta[m_h], beta_dot[m_h], _ = quintic_hermite(tp[m_h], t_h, t0, 0.0, 0.0, 0.0, takeoff.heel, x0[6], 0.0)
    if np.any(beta < -1e-12):
        raise PhysicsError("the heel would sink below the floor before take-off; raise the take-off heel angle")
    beta_dot[beta < 0.0] = 0.0
    beta = np.maximum(beta, 0.0)
    R_pre = quat_matrix(q_pre)
    legR_pre, _ = B.legs(root_pre, R_pre, toes0, (0.0, 0.0), (beta, beta))
    up_pre, updot_pre = upper_track(tp)
    Rloc_pre = B.local_matrices(up_pre, legR_pre)
    wloc_pre = B.local_rates(up_pre, updot_pre,
                             _leg_rates(B, root_pre, R_pre, v_pre, w_pre, toes0, 0.0, beta, beta_dot))

    # ---- post-landing ground phase: frames stop..end
    fpost = np.arange(stop, n_frames)
    tq = times[fpost]
    root_post = np.empty((fpost.size, 3))
    q_post = np.empty((fpost.size, 4))
    v_post = np.zeros((fpost.size, 3))
    w_post = np.zeros((fpost.size, 3))
    a_root = absorbed.root_pos + shift
    f_root = final.root_pos + shift
    m1 = tq <= t_a
    root_post[m1], v_post[m1], _ = quintic_hermite(tq[m1], t1, t_a, p1, v1, np.zeros(3), a_root, 0 * up, up)
    q_post[m1], w_post[m1] = _orientation_piece(tq[m1], t1, t_a, q1, w1, absorbed.root_q, np.zeros(3))
    m2 = (tq > t_a) & (tq <= t_r)
    root_post[m2], v_post[m2], _ = quintic_hermite(tq[m2], t_a, t_r, a_root, 0 * up, up, f_root, 0 * up, 0 * up)
    q_post[m2], w_post[m2] = _orientation_piece(tq[m2], t_a, t_r, absorbed.root_q, np.zeros(3), final.root_q,
                                                np.zeros(3))
    m3 = tq > t_r
    root_post[m3] = f_root
    q_post[m3] = final.root_q
    R_post = quat_matrix(q_post)
    # heels down from the touchdown angle and rate (monotonic quintic, see the take-off)
    beta_post = np.zeros(fpost.size)
    betadot_post = np.zeros(fpost.size)
    if heel1 > 0:
        t_hd = t1 + min(0.8 * d_absorb, 2.0 * heel1 / max(-heel_rate1, 1e-9))
        m_hd = tq < t_hd
        beta_post[m_hd], betadot_post[m_hd], _ = quintic_hermite(tq[m_hd], t1, t_hd, heel1, heel_rate1, 0.0, 0.0,
                                                                 0.0, 0.0)
        betadot_post[beta_post < 0.0] = 0.0
        beta_post = np.maximum(beta_post, 0.0)
    legR_post, _ = B.legs(root_post, R_post, toes1, (yaw1, yaw1), (beta_post, beta_post))
    up_post, updot_post = upper_track(tq)
    Rloc_post = B.local_matrices(up_post, legR_post)
    wloc_post = B.local_rates(up_post, updot_post,
                              _leg_rates(B, root_post, R_post, v_post, w_post, toes1, yaw1, beta_post, betadot_post))

    # ---- assemble
    rot = np.empty((n_frames, B.J, 4))
    rp = np.empty((n_frames, 3))
    rot[fpre] = quat_from_matrix(Rloc_pre)
    rot[fpre, 0] = q_pre
    rp[fpre] = root_pre
    rot[fi] = quat_exp(phi_fl)
    rot[fi, 0] = q_fl
    rp[fi] = root_fl
    rot[fpost] = quat_from_matrix(Rloc_post)
    rot[fpost, 0] = q_post
    rp[fpost] = root_post
    rot = make_continuous(rot, axis=0)
    v_all = np.empty((n_frames, 3))
    w_all = np.empty((n_frames, 3))
    wl_all = np.empty((n_frames, B.J, 3))
    v_all[fpre], w_all[fpre], wl_all[fpre] = v_pre, w_pre, wloc_pre
    v_all[fi], w_all[fi], wl_all[fi] = vroot_fl, w_fl, wloc_fl
    v_all[fpost], w_all[fpost], wl_all[fpost] = v_post, w_post, wloc_post
    wl_all[:, B.fixed] = 0.0
    velocities = MotionVelocities(v_all, w_all, wl_all)
    motion = Motion(skeleton, fps, rp, rot, SourceInfo(path=None, format="synthetic", unit_scale=1.0,
                                                       unit_reason="generated in metres", header_fps=fps,
                                                       notes=(f"mocomp.synth.{d.generator}",)))

    # ---- contacts and phases
    contacts = {}
    pre_contact = np.zeros(n_frames, bool)
    pre_contact[: i0 + 1] = True
    post_contact = np.zeros(n_frames, bool)
    post_contact[stop:] = True
    heel_down = np.zeros(n_frames, bool)
    heel_down[: i0 + 1] = beta <= 0.0
    heel_down[stop:] = beta_post <= 0.0
    for name in FOOT_EFFECTORS:
        contacts[name] = (pre_contact | post_contact) if name.endswith("ToeBase") else heel_down.copy()

    def fr(t):
        return int(min(n_frames, math.ceil(t * fps - 1e-9)))

    phases = {"stand": (0, fr(t_s)), "crouch": (fr(t_s), fr(t_c)), "extension": (fr(t_c), i0 + 1),
              "flight": (start, stop), "absorption": (stop, fr(t_a)), "recovery": (fr(t_a), fr(t_r)),
              "hold": (fr(t_r), n_frames)}

    # ---- evidence
    total = _twist_angle(motion.rotations[0, 0], motion.rotations[-1, 0], axis,
                         _accumulated_angle(motion.rotations[:, 0], axis))
    acc = _twist_angle(takeoff.root_q, qs[-1], axis, acc)
    knee_rate0 = float(fl.Kknee.mean(axis=0) @ x0)
    evidence = FlightEvidence(
        rotation_target_deg=math.degrees(theta_target), rotation_deg=math.degrees(acc),
        total_rotation_deg=math.degrees(total), landing_error_rad=float(np.linalg.norm(
            quat_log(quat_multiply(qs[-1], quat_inverse(q1_target))))),
        shooting_evaluations=evals[0], substep_dt=dt_f, n_steps=int(n_steps + (last > 0)),
        integration_error_rad=integration_error,
        takeoff={"v_root": v0, "w_root": w0, "heel_rate": float(x0[6]), "knee_rate": knee_rate0,
                 "knee_deg": np.degrees(takeoff.knees), "heel_deg": d.takeoff_key.heel},
        landing={"v_root": v1, "w_root": w1, "heel_rate": heel_rate1, "knee_rate": knee_rate1,
                 "v_com_before": vcom1, "v_com_after": vcom_plus, "L_after": L_plus,
                 "dp": body.total_mass * (vcom_plus - vcom1), "dL": L_plus - L0,
                 "knee_deg": np.degrees(land.knees), "heel_deg": d.landing_key.heel, "absorb_s": d_absorb},
        seconds=time.perf_counter() - tic)
    return SynthResult(motion=motion, body=body, L0=L0, flight=(start, stop), flight_times=(t0, t1),
                       contacts=contacts, g=G, com_parabola=parabola, params=dict(d.params), phases=phases,
                       evidence=evidence, velocities=velocities)


def _fd_jacobian(fun, L, r):
    """Forward-difference Jacobian ``(3, 3)`` of the landing residual at ``L`` (``r = fun(L)[0]``)."""
    scale = max(1.0, float(np.linalg.norm(L)))
    Jm = np.zeros((3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-5 * scale
        Jm[:, k] = (fun(L + e)[0] - r) / e[k]
    return Jm


def _descend(fun, L, r, jacobian, iters: int, tol: float, valid):
    """Newton steps with a trust region and backtracking.

    ``jacobian(L, r)`` gives the matrix for each step; a step is at most a quarter
    of ``|L|`` (near-degenerate inertias make the Jacobian nearly singular) and is
    accepted when the residual decreases and ``valid(accumulated angle)`` holds
    (the flight keeps the requested number of turns).
    """
    acc = None
    for _ in range(iters):
        if np.linalg.norm(r) < tol:
            break
        step = np.linalg.solve(jacobian(L, r), r)
        cap = 0.25 * max(1.0, float(np.linalg.norm(L)))
        if np.linalg.norm(step) > cap:
            step *= cap / np.linalg.norm(step)
        t = 1.0
        accepted = False
        for _ in range(10):
            r_new, acc_new = fun(L - t * step)
            if np.linalg.norm(r_new) < np.linalg.norm(r) and valid(acc_new):
                accepted = True
                break
            t *= 0.5
        if not accepted:
            break
        L, r, acc = L - t * step, r_new, acc_new
    return L, r, acc


def _newton(coarse, fine, L, valid=lambda acc: True):
    """Solve ``residual(L) = 0`` (landing-orientation error, 3 components).

    Newton with a finite-difference Jacobian and backtracking on the cheap coarse
    grid (240 Hz RK4), then chord iterations (the last coarse Jacobian) with
    backtracking on the fine grid; if those stall (a sensitive flight, e.g. a
    layout side somersault near the unstable intermediate principal axis, where
    the coarse model is not close enough), Newton with fine-grid Jacobians.
    ``coarse``/``fine`` return ``(residual, accumulated angle)``. Measured against
    ``scipy.optimize.root`` (MINPACK hybrd on the coarse grid, hybrj with the
    coarse Jacobian on the fine grid) this needs 2-3x fewer flight integrations
    (backflip 11 vs 33, sideflip 33 vs 59): the fine grid mostly evaluates residuals.
    """
    last = {}

    def coarse_jac(L_, r_):
        last["J"] = _fd_jacobian(coarse, L_, r_)
        return last["J"]

    r, acc = coarse(L)
    L, r, acc_c = _descend(coarse, L, r, coarse_jac, 20, 1e-11, valid)
    r, acc = fine(L)
    if np.linalg.norm(r) >= 1e-12:
        J = last.get("J")
        if J is None:
            J = _fd_jacobian(coarse, L, coarse(L)[0])
        L, r, acc_f = _descend(fine, L, r, lambda L_, r_: J, 8, 1e-12, valid)
        acc = acc_f if acc_f is not None else acc
    if np.linalg.norm(r) >= 1e-10:
        L, r, acc_f = _descend(fine, L, r, lambda L_, r_: _fd_jacobian(fine, L_, r_), 12, 1e-12, valid)
        acc = acc_f if acc_f is not None else acc
    return L, r, acc


def _world_fk(skeleton, p, q, qloc):
    """World joint positions ``(J, 3)`` and orientations ``(J, 4)`` of one pose: root at ``p`` with
    orientation ``q``, local rotations ``qloc (J, 4)`` (the root's entry replaced by ``q``);
    core's :func:`~mocomp.core.kinematics.forward_kinematics`."""
    rot = np.array(qloc, dtype=float)
    rot[0] = q
    P, G = forward_kinematics(skeleton.parents, skeleton.offsets, np.asarray(p, dtype=float)[None], rot[None])
    return P[0], G[0]


def _accumulated_angle(q, axis) -> float:
    """Rotation about ``axis`` accumulated over a quaternion sequence (world increments)."""
    d = quat_multiply(q[1:], quat_inverse(q[:-1]))
    d = np.where(d[:, 3:4] < 0, -d, d)
    return float(np.sum(2.0 * np.arctan2(d[:, :3] @ axis, d[:, 3])))


def _twist_angle(q_start, q_end, axis, approx: float) -> float:
    """Angle of the twist part (swing-twist about ``axis``) of ``q_end q_start^-1``,
    on the 2 pi branch nearest ``approx`` (an accumulated count of the turns)."""
    d = quat_multiply(np.asarray(q_end, float), quat_inverse(np.asarray(q_start, float)))
    a = 2.0 * math.atan2(float(d[:3] @ axis), float(d[3]))
    return a + 2.0 * math.pi * round((approx - a) / (2.0 * math.pi))
