"""The physics burst: first contact, rewind, the naive and the active simulation (sec. 4.2-4.3, App. A).

* :func:`find_first_contact` drives both characters kinematically by their clips at the capture
  rate until the attacker's striking geoms first touch the victim ("looks for the first contact
  at 30 fps", App. A); the simulation then rewinds to the last motion-capture frame before it and
  starts from that frame's state (pose and finite-difference velocities) at the small step.
* :func:`simulate` runs one pass at :data:`~mocomp.impact.scene.STEP` (0.5 ms). Every joint of
  both characters is driven by the inertia-scaled PD servo of **eq. 4.3**,
  ``tau = I (k_p (theta_d - theta) - k_v theta_dot)``, with ``I`` the inertia of the outboard
  bodies about the joint (the joint's 3x3 block of MuJoCo's joint-space inertia matrix) and the
  error ``theta_d - theta`` the rotation vector of ``q^-1 q_d`` in the child frame.

  Units. App. A gives ``k_p = 1.0``, ``k_v = 2.0`` without units; ``k_v = 2 sqrt(k_p)`` is the
  critically damped pair of a unit-frequency servo, so we read them as dimensionless and scale
  time by a natural frequency ``omega``: ``tau = I (omega^2 k_p e - omega k_v theta_dot)``
  (damping ratio ``k_v / (2 sqrt(k_p)) = 1`` as in the paper). Taken literally in SI units
  (``omega = 1`` rad/s) the servos could not hold a limb against gravity (hip: ``I ~ 1 kg m^2``
  gives 1 N m/rad); :class:`ServoGains` documents the frequencies used.

  The damping term is applied as MuJoCo joint damping ``I_ii k_v omega`` (the diagonal of ``I``),
  which MuJoCo's Euler integrator treats implicitly; the spring term is an applied joint torque.
  The root (6 dof) is not actuated for the victim (no balance controller, as in the paper).
  The attacker's root follows its clip through a soft weld to a mocap body (:mod:`.scene`), so it strikes with its captured motion yet feels the contact ("the impact
  simulation of both the recipient and the attacker", sec. 4.3.1).
* The **naive** pass (friction 1.0) tracks the victim's own clip as it continues (the victim has
  not reacted yet: the "rag-doll-like" first response of sec. 4.5, with the muscle tone of the
  same servos); the **active** pass (friction 0.5) tracks a slerp blend, eased in and out, from the
  attacked clip toward the found clip, starting after a reaction delay (0.1-0.2 s, sec. 4.2).

Each pass records both characters at the capture rate, the contacts between them (first and
last time, body pairs, the impulse on the victim), the floor penetration MuJoCo resolved and
MuJoCo's own warnings (counts per kind: ill-conditioned accelerations, contact buffer full, ...).
MuJoCo is deterministic: the same inputs give bit-identical passes.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion, slerp
from ..core.rotations import quat_angle, quat_inverse, quat_log, quat_multiply
from .convert import frames_to_motion, motion_state, qpos_to_pose, to_wxyz, to_xyzw
from .scene import _ATT, _ATT_PASSIVE, FRICTION_ACTIVE, FRICTION_NAIVE, ImpactError, Scene, TouchAtStartError

_ATT_BITS = _ATT | _ATT_PASSIVE

__all__ = ["ServoGains", "FirstContact", "PassResult", "find_first_contact", "simulate", "clip_targets",
           "blend_targets", "ease_in_out", "on_ground", "naive_targets", "FRICTION_NAIVE", "FRICTION_ACTIVE"]


@dataclass(frozen=True)
class ServoGains:
    """Eq. 4.3 gains (App. A) and their time scale.

    kp, kv: the paper's dimensionless spring and damping constants (1.0, 2.0: critically damped).
    omega_victim, omega_attacker: rad/s, the servos' natural frequency (see the module docstring):
        50 rad/s holds the unhit victim's stance through the search window (at 20 rad/s it sagged
        10 cm in 0.2 s: the naive pass showed a collapse, not the hit) while a hit still moves its
        limbs; the attacker's are stiffer (it keeps its attack). The attacker's root follows its clip
        through the scene's weld (:data:`~mocomp.impact.scene.ROOT_SERVO_TIMECONST`).
    control_every: simulation steps per servo update (zero-order hold between updates).
    """

    kp: float = 1.0
    kv: float = 2.0
    omega_victim: float = 50.0
    omega_attacker: float = 60.0
    control_every: int = 4


@dataclass(frozen=True)
class FirstContact:
    """The first capture frame at which the attacker's striking geoms touch the victim.

    frame: capture frame (victim clip timeline) of the first contact; rewind_frame = frame - 1;
    time: s, of ``frame``; pairs: (attacker body, victim body) names touching at ``frame``;
    closest (T,): m, the smallest distance between striking and victim geoms per frame up to
    ``frame`` (only computed on request).
    """

    frame: int
    rewind_frame: int
    time: float
    pairs: tuple[tuple[str, str], ...]


@dataclass(frozen=True)
class PassResult:
    """One simulation pass, recorded at the capture rate from ``t0``.

    victim, attacker: :class:`Motion` of the simulated frames (frame ``i`` at clip time
    ``t0 + i / fps``); friction: the floor's; impact_time / contact_end: s (clip timeline) of the
    first and last step with attacker-victim contact (None without contact); impulse: N s
    ``(3,)`` world, the contact impulse on the victim from the attacker; pairs: body pairs that
    touched (attacker body, victim body); penetration_m: deepest floor contact MuJoCo resolved
    for the victim; warnings: MuJoCo warning kind -> count; tracking_error_rad ``(n,)``: mean
    joint-angle error of the victim's servos per recorded frame; steps; seconds; strike_end: when and
    by which limit the strike was ended (:func:`simulate` ``max_contact``/``max_impulse``), or None.
    """

    t0: float
    fps: float
    victim: Motion
    attacker: Motion
    friction: float
    impact_time: float | None
    contact_end: float | None
    impulse: np.ndarray
    pairs: tuple[tuple[str, str], ...]
    penetration_m: float
    warnings: dict
    tracking_error_rad: np.ndarray
    steps: int
    seconds: float
    notes: tuple[str, ...] = field(default=())
    strike_end: dict | None = None

    def to_dict(self) -> dict:
        return {"t0_s": self.t0, "frames": self.victim.n_frames, "friction": self.friction,
                "impact_time_s": self.impact_time, "contact_end_s": self.contact_end,
                "impulse_Ns": self.impulse.tolist(), "impulse_norm_Ns": float(np.linalg.norm(self.impulse)),
                "contact_pairs": [list(p) for p in self.pairs], "floor_penetration_m": self.penetration_m,
                "mujoco_warnings": self.warnings,
                "tracking_error_deg": {"mean": float(np.degrees(self.tracking_error_rad.mean())),
                                       "max": float(np.degrees(self.tracking_error_rad.max()))},
                "steps": self.steps, "seconds": self.seconds, "strike_end": self.strike_end}


def ease_in_out(x) -> np.ndarray:
    """The ease-in/ease-out weight of the transition blend (sec. 4.2): ``3x^2 - 2x^3`` on [0, 1]."""
    from ..ops import ease

    return ease(np.clip(np.asarray(x, dtype=float), 0.0, 1.0), "smoothstep")


def _sample_clamped(motion: Motion, times: np.ndarray) -> Motion:
    return motion.sample(np.clip(times, 0.0, motion.duration))


def clip_targets(motion: Motion, times: np.ndarray) -> np.ndarray:
    """``(K, J, 4)`` the clip's local rotations at ``times`` (held at its ends)."""
    return np.array(_sample_clamped(motion, times).rotations)


def blend_targets(attacked: np.ndarray, found: np.ndarray, times: np.ndarray, t_start: float,
                  t_end: float) -> np.ndarray:
    """``(K, J, 4)`` theta_d(t) of the active pass (sec. 4.2): the attacked clip's rotations
    ``attacked (K, J, 4)`` slerped toward the found clip's ``found (K, J, 4)`` (aligned on the same
    ``times``) with the ease-in/out weight of ``(t - t_start) / (t_end - t_start)`` (0 before
    ``t_start``: the reaction delay)."""
    w = ease_in_out((np.asarray(times, float) - t_start) / max(t_end - t_start, 1e-9))
    return slerp(attacked, found, np.broadcast_to(w[:, None], attacked.shape[:2]))


def on_ground(victim: Motion, frame: int) -> tuple[bool, float, float]:
    """``(lying, root height, threshold)``: the victim counts as already on the ground when its root
    is lower than half its leg length (hip -> knee -> ankle bone lengths) at ``frame``."""
    from ..ops import leg_chains

    sk = victim.skeleton
    lengths = [np.linalg.norm(sk.offsets[k]) + np.linalg.norm(sk.offsets[a]) for _, k, a in leg_chains(sk)]
    leg = float(np.mean(lengths)) if lengths else 0.5 * sk.height()
    h = float(victim.root_positions[frame, 1])
    return h < 0.5 * leg, h, 0.5 * leg


def _body_name(model, b: int) -> str:
    import mujoco

    n = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(b)) or str(b)
    return n[2:] if n[:2] in ("a_", "v_") else n


def _pairs(model, data, strike: np.ndarray, victim: np.ndarray):
    """Indices of active contacts between striking and victim geoms, and their (attacker, victim) bodies."""
    n = data.ncon
    if n == 0:
        return np.zeros(0, dtype=int), []
    g = np.asarray(data.contact.geom[:n])
    d = np.asarray(data.contact.dist[:n])
    sa = strike[g[:, 0]] & victim[g[:, 1]]
    sb = strike[g[:, 1]] & victim[g[:, 0]]
    idx = np.nonzero((sa | sb) & (d <= 0))[0]
    pairs = []
    for i in idx:
        ga, gv = (g[i, 0], g[i, 1]) if sa[i] else (g[i, 1], g[i, 0])
        pairs.append((_body_name(model, model.geom_bodyid[ga]), _body_name(model, model.geom_bodyid[gv])))
    return idx, pairs


def _masks(scene: Scene, model):
    strike = np.zeros(model.ngeom, bool)
    strike[scene.attacker.strike_geoms] = True
    vic = np.zeros(model.ngeom, bool)
    vic[scene.victim.geom_ids] = True
    return strike, vic


def _closest(scene: Scene, model, data, attacker: Motion, victim: Motion, frames) -> tuple[float, int]:
    import mujoco

    best, when = np.inf, -1
    ft = np.zeros(6)
    for k in frames:
        _set_pose(scene, data, attacker, victim, k)
        mujoco.mj_kinematics(model, data)
        for ga in scene.attacker.strike_geoms:
            for gv in scene.victim.geom_ids:
                dist = mujoco.mj_geomDistance(model, data, int(ga), int(gv), 10.0, ft)
                if dist < best:
                    best, when = float(dist), int(k)
    return best, when


def _set_pose(scene: Scene, data, attacker: Motion, victim: Motion, k: int) -> None:
    from .convert import pose_to_qpos

    pose_to_qpos(data.qpos, scene.victim, victim.root_positions[k], victim.rotations[k])
    pose_to_qpos(data.qpos, scene.attacker, attacker.root_positions[k], attacker.rotations[k])


def find_first_contact(scene: Scene, attacker: Motion, victim: Motion) -> FirstContact:
    """The first capture frame where the attacker's striking geoms touch the victim (App. A's
    first-contact search at the capture rate). ``attacker`` must be sampled on the victim's frames
    (same fps and frame count). Raises :class:`ImpactError` when no frame has contact (naming the
    closest distance and when), when the characters already touch at the first frame, or when the
    victim is already on the ground at the contact."""
    import mujoco

    if attacker.n_frames != victim.n_frames or abs(attacker.fps - victim.fps) > 1e-9:
        raise ValueError("find_first_contact: sample the attacker on the victim's frames first")
    model = scene.model(FRICTION_NAIVE)
    data = mujoco.MjData(model)
    strike, vic = _masks(scene, model)
    for k in range(victim.n_frames):
        _set_pose(scene, data, attacker, victim, k)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        idx, pairs = _pairs(model, data, strike, vic)
        if len(idx):
            if k == 0:
                raise TouchAtStartError(
                    f"the characters already touch at the first frame ({', '.join(sorted({'-'.join(p) for p in pairs}))}): "
                    "place the victim farther away (--offset)")
            lying, h, thr = on_ground(victim, k)
            if lying:
                raise ImpactError(f"the victim is already on the ground at the contact (frame {k}, "
                                  f"{k / victim.fps:.2f} s): root {h:.2f} m high, below half its leg length "
                                  f"({thr:.2f} m); a hit needs a standing victim")
            return FirstContact(k, k - 1, k / victim.fps, tuple(sorted(set(pairs))))
    step = max(1, victim.n_frames // 60)
    d, k = _closest(scene, model, data, attacker, victim, range(0, victim.n_frames, step))
    lo, hi = max(k - step + 1, 0), min(k + step, victim.n_frames)
    d, k = _closest(scene, model, data, attacker, victim, range(lo, hi)) if step > 1 else (d, k)
    raise ImpactError(f"no contact: the attacker's striking bodies never touch the victim over "
                      f"{victim.n_frames} frames; closest {d:.3f} m at frame {k} ({k / victim.fps:.2f} s); move the "
                      f"victim closer (--offset) or choose another --contact-body")


class _Servo:
    """Eq. 4.3 for the ball joints of both characters, vectorised over joints."""

    def __init__(self, scene: Scene, model, gains: ServoGains):
        self.qadr = np.concatenate([scene.attacker.ball_qpos, scene.victim.ball_qpos])
        self.dadr = np.concatenate([scene.attacker.ball_dof, scene.victim.ball_dof])
        self.qidx = self.qadr[:, None] + np.arange(4)
        self.didx = self.dadr[:, None] + np.arange(3)
        na = len(scene.attacker.ball_qpos)
        om = np.concatenate([np.full(na, gains.omega_attacker), np.full(len(scene.victim.ball_qpos), gains.omega_victim)])
        self.kp = (om ** 2 * gains.kp)[:, None]
        self.kv = (om * gains.kv)[:, None]
        self.na = na
        self.M = np.zeros((model.nv, model.nv))
        self.blk = (self.didx[:, :, None], self.didx[:, None, :])

    def torques(self, model, data, q_des_wxyz: np.ndarray) -> np.ndarray:
        """``(n, 3)`` joint torques and ``(n,)`` angle errors for the desired local rotations (wxyz)."""
        import mujoco

        q = data.qpos[self.qidx]
        q = q / np.sqrt(np.einsum("ij,ij->i", q, q))[:, None]
        # e = log(q^-1 q_d), the short way (core's quaternion kernel, scalar-last)
        d = quat_multiply(quat_inverse(to_xyzw(q)), to_xyzw(q_des_wxyz))
        e = quat_log(d)
        ang = quat_angle(d)
        mujoco.mj_fullM(model, data, self.M)
        I = self.M[self.blk]
        # the damping term -I k_v omega theta_dot goes to MuJoCo's joint damping (diagonal of I),
        # integrated implicitly by MuJoCo's Euler integrator: an explicit damping torque scaled by
        # the outboard inertia is unstable where the joint's effective inertia is far smaller
        self.damping = self.kv * np.einsum("nii->ni", I)
        return np.einsum("nij,nj->ni", I, self.kp * e), ang


def simulate(scene: Scene, attacker: Motion, victim: Motion, t0: float, t_end: float, *,
             victim_targets: np.ndarray, friction: float, gains: ServoGains = ServoGains(),
             start_state: tuple[np.ndarray, np.ndarray] | None = None, max_contact: float | None = None,
             max_impulse: float | None = None) -> PassResult:
    """One pass from clip time ``t0`` to ``t_end`` (s), see the module docstring.

    attacker, victim: the clips on the same timeline and frame rate (the attacker sampled on the
    victim's frames, the victim placed by the scenario). victim_targets: ``(K, J, 4)`` the victim's
    desired local rotations at ``t0 + k / fps`` (K covers ``t_end``); the attacker tracks its clip.
    friction: the floor's sliding friction. start_state: ``(qpos, qvel)`` to start from (default:
    both clips' state at ``t0``, velocities by forward difference over one frame).
    The step is the scene's, rounded so that a whole number of steps fills a capture frame.
    max_contact (s), max_impulse (N s): the strike ends -- the attacker's striking bodies stop colliding
    with the victim for the rest of the pass -- once the contact has lasted ``max_contact`` since the
    impact or its impulse on the victim reaches ``max_impulse`` (None: never). A strike is brief: a
    clip whose striking limb stays where the victim's body is (a counter attack ending inside it)
    would otherwise push for a second (840 N s), the attacker's root weld driving it through.
    The cut is reported in ``notes`` and :attr:`PassResult.strike_end`.
    """
    import mujoco

    t_start = time.perf_counter()
    model = scene.model(friction)
    data = mujoco.MjData(model)
    fps = victim.fps
    if start_state is None:
        motion_state(victim, t0, scene.victim, data.qpos, data.qvel)
        motion_state(attacker, t0, scene.attacker, data.qpos, data.qvel)
    else:
        data.qpos[:], data.qvel[:] = start_state
    K = int(np.floor((t_end - t0) * fps + 1e-9)) + 1
    if victim_targets.shape[0] < K:
        raise ValueError(f"victim_targets has {victim_targets.shape[0]} frames, the pass needs {K}")
    ce = max(1, int(gains.control_every))
    fine = max(ce, int(round(1.0 / (fps * scene.step) / ce)) * ce)   # steps per capture frame
    h = 1.0 / (fps * fine)
    model.opt.timestep = h
    sub = fine // ce                                                 # servo updates per capture frame
    la, lv = scene.attacker, scene.victim
    mc = scene.attacker_mocap
    # targets on the servo grid: attacker clip and victim targets slerped between capture frames
    times = t0 + np.arange(K) / fps
    a_clip = _sample_clamped(attacker, times)
    a_rot, a_root = np.array(a_clip.rotations), np.array(a_clip.root_positions)
    u = np.arange(sub) / sub
    k1 = np.minimum(np.arange(K) + 1, K - 1)

    def grid(q):                                                     # (K, J, 4) -> (K, sub, J, 4)
        return slerp(np.broadcast_to(q[:, None], (K, sub) + q.shape[1:]),
                     np.broadcast_to(q[k1][:, None], (K, sub) + q.shape[1:]),
                     np.broadcast_to(u[None, :, None], (K, sub, q.shape[1])))

    qdes = to_wxyz(np.concatenate([grid(a_rot[:, 1:]), grid(np.asarray(victim_targets[:K, 1:], float))], axis=2))
    mpos = a_root[:, None] * (1 - u)[None, :, None] + a_root[k1][:, None] * u[None, :, None]
    mquat = to_wxyz(grid(a_rot[:, :1])[:, :, 0])
    data.mocap_pos[mc], data.mocap_quat[mc] = mpos[0, 0], mquat[0, 0]
    mujoco.mj_forward(model, data)
    servo = _Servo(scene, model, gains)
    strike, vic = _masks(scene, model)
    floor = scene.floor_geom
    v_roots, v_rots = np.zeros((K, 3)), np.zeros((K, victim.skeleton.n_joints, 4))
    a_roots, a_rots = np.zeros((K, 3)), np.zeros((K, attacker.skeleton.n_joints, 4))
    track = np.zeros(K)
    impact, contact_end = None, None
    impulse = np.zeros(3)
    pairs: set = set()
    pen = 0.0
    frc = np.zeros(6)
    nsteps = 0
    ang_err_v = 0.0
    cut = None
    for k in range(K):
        v_roots[k], v_rots[k] = qpos_to_pose(data.qpos, lv)
        a_roots[k], a_rots[k] = qpos_to_pose(data.qpos, la)
        if k == K - 1:
            track[k] = ang_err_v
            break
        for s in range(sub):
            tau, ang = servo.torques(model, data, qdes[k, s])
            data.qfrc_applied[servo.didx] = tau
            model.dof_damping[servo.didx] = servo.damping
            ang_err_v = float(ang[servo.na:].mean())
            data.mocap_pos[mc], data.mocap_quat[mc] = mpos[k, s], mquat[k, s]
            mujoco.mj_step(model, data, nstep=ce)
            nsteps += ce
            # contacts after the steps: impulse on the victim, pairs, the victim's floor penetration
            n = data.ncon
            if n:
                gg = np.asarray(data.contact.geom[:n])
                dd = np.asarray(data.contact.dist[:n])
                fl = (gg[:, 0] == floor) & vic[gg[:, 1]]
                if fl.any():
                    pen = max(pen, float(-dd[fl].min()))
                sa = strike[gg[:, 0]] & vic[gg[:, 1]]
                sb = strike[gg[:, 1]] & vic[gg[:, 0]]
                idx = np.nonzero((sa | sb) & (dd <= 0))[0]
                if len(idx) and not cut:
                    t_now = t0 + (k + (s + 1) / sub) / fps
                    if impact is None:
                        impact = t_now
                    contact_end = t_now
                    for i in idx:
                        ga, gv = (gg[i, 0], gg[i, 1]) if sa[i] else (gg[i, 1], gg[i, 0])
                        pairs.add((_body_name(model, model.geom_bodyid[ga]), _body_name(model, model.geom_bodyid[gv])))
                        mujoco.mj_contactForce(model, data, int(i), frc)
                        fw = np.asarray(data.contact.frame[i]).reshape(3, 3).T @ frc[:3]   # on geom2's body
                        impulse += (fw if sa[i] else -fw) * ce * h
                    why = ("duration" if max_contact is not None and t_now - impact >= max_contact else
                           "impulse" if max_impulse is not None and np.linalg.norm(impulse) >= max_impulse else None)
                    if why is not None:
                        # the strike is over: the victim's geoms stop accepting the attacker's
                        model.geom_conaffinity[lv.geom_ids] = model.geom_conaffinity[lv.geom_ids] & ~_ATT_BITS
                        cut = (t_now, why)
            if cut is None and impact is not None and max_contact is not None:
                # the strike is one touch: its time runs out whether or not the bodies touch just now (a
                # limb that comes back later is not a second strike)
                t_now = t0 + (k + (s + 1) / sub) / fps
                if t_now - impact >= max_contact:
                    model.geom_conaffinity[lv.geom_ids] = model.geom_conaffinity[lv.geom_ids] & ~_ATT_BITS
                    cut = (t_now, "duration")
        track[k] = ang_err_v
        if not np.all(np.isfinite(data.qpos)):
            raise ImpactError(f"the simulation became unstable at {t0 + k / fps:.3f} s (non-finite state); "
                              f"MuJoCo warnings: {_warnings(data)}")
    vm = frames_to_motion(victim.skeleton, fps, v_roots, v_rots, like=victim, note=f"impact simulation (friction {friction})")
    am = frames_to_motion(attacker.skeleton, fps, a_roots, a_rots, like=attacker, note="impact simulation (attacker)")
    notes = (f"{fine} steps of {h * 1000:.4f} ms per capture frame, servos every {ce} steps",)
    if cut is not None:
        notes += (f"strike ended at {cut[0]:.4f} s ({cut[0] - impact:.3f} s after the impact) by its {cut[1]} limit "
                  f"(max_contact {max_contact} s, max_impulse {max_impulse} N s): impulse {np.linalg.norm(impulse):.1f} N s",)
    return PassResult(t0, fps, vm, am, float(friction), impact, contact_end, impulse,
                      tuple(sorted(pairs)), pen, _warnings(data), track, nsteps, time.perf_counter() - t_start,
                      notes, None if cut is None else {"time_s": cut[0], "after_impact_s": cut[0] - impact,
                                                       "limit": cut[1]})


def _warnings(data) -> dict:
    import mujoco

    out = {}
    for name, w in mujoco.mjtWarning.__members__.items():
        if name == "mjNWARNING":
            continue
        n = int(data.warning[int(w)].number)
        if n:
            out[name.replace("mjWARN_", "").lower()] = n
    return out


def naive_targets(victim: Motion, t0: float, t_end: float) -> np.ndarray:
    """The naive pass's theta_d: the victim's own clip continuing (held at its end)."""
    K = int(np.floor((t_end - t0) * victim.fps + 1e-9)) + 1
    return clip_targets(victim, t0 + np.arange(K) / victim.fps)

