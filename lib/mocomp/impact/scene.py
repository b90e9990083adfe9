"""Both characters in one MuJoCo model (dissertation sec. 4.3.1, App. A).

Each character is its skeleton's :class:`~mocomp.body.BodyModel` exported by
:func:`mocomp.body.mjcf.to_mjcf` (one MuJoCo body per joint, free root, ball joints,
the body model's masses, COMs and inertias); the paper's character had 16 parts on ball
joints with the masses of Table A.1, ours has the skeleton's joints with the body model's
masses (ASE's own MJCF inertials for the ASE humanoid, :func:`mocomp.body.ase_body`).

Added here, not in the exporter:

* **collision geoms**: on the ASE humanoid exactly ASE's geoms (spheres, capsules, the foot
  boxes, sword and shield; :data:`mocomp.body.ase.ASE_GEOMS`, turned into the BVH frames);
  on any other skeleton a capsule along each bone (radius by body part) and a box under each
  ankle;
* **joint limits from the captured range**: each ball joint's rotation from the rest pose is
  limited to the largest angle it reaches in the given clips plus a margin (MuJoCo's ball
  ``range``, a cone on the rotation angle);
* **collision groups**: no self-collision; the attacker's striking bodies (``contact_body`` and
  the bodies it carries) touch the victim, every body touches the floor;
* **the floor**: a plane at ``y = 0`` (the world is y-up) with the pass's friction (App. A: 1.0 for
  the naive pass, 0.5 for the active one) and a torsional friction (the paper's "rotational
  friction to impede free spinning" of the foot, k_omega = 0.05);
* **the attacker's root servo**: a soft weld (time constant :data:`ROOT_SERVO_TIMECONST`) from its
  pelvis to a mocap body that follows the attack clip's root, so the attacker strikes with its
  captured motion yet yields to the contact (sec. 4.3.1: both characters simulated);
* **the step**: 0.5 ms (App. A: "good contact required ... a time step of about 0.0005 s").

Character ``a`` is the attacker, ``v`` the victim; MuJoCo names are prefixed ``a_``/``v_``.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..body.ase import ASE_GEOMS, MJCF_TO_BVH
from ..body.mjcf import mjcf_names, to_mjcf
from ..core.motion import Motion
from ..core.rotations import quat_angle
from ..errors import MocompError

__all__ = ["ImpactError", "TouchAtStartError", "Scenario", "strike_at", "CharacterLayout", "Scene", "build_scene", "place_victim", "joint_limits",
           "strike_direction", "strike_joints", "strike_window", "default_impact_body", "STEP", "FRICTION_NAIVE", "FRICTION_ACTIVE", "TORSIONAL_FRICTION"]

#: simulation step, s (App. A)
STEP = 0.0005
#: ground friction of the naive pass and of the active pass (App. A)
FRICTION_NAIVE = 1.0
FRICTION_ACTIVE = 0.5
#: the paper's rotational damping constant k_omega, used as the foot-ground torsional friction
TORSIONAL_FRICTION = 0.05
#: s, time constant of the attacker's root weld to its clip (critically damped)
ROOT_SERVO_TIMECONST = 0.03
#: friction between the two characters' bodies
BODY_FRICTION = 0.3

_ATT, _VIC, _FLOOR, _ATT_PASSIVE = 1, 2, 4, 8


class ImpactError(MocompError, ValueError):
    """An impact scenario cannot be simulated (no contact, victim on the ground, bad placement...)."""


class TouchAtStartError(ImpactError):
    """The characters already touch at the first frame (the victim placed too close)."""


@dataclass(frozen=True)
class Scenario:
    """Where the victim stands relative to the attacker (at the attack clip's first frame).

    facing_deg: the victim's heading relative to facing the attacker, degrees in [-180, 180]:
        0 = face to face (a front hit), 90 / -90 = the attacker on the victim's left / right
        side, 180 = the victim's back to the attacker.
    offset: ``(x, z)`` m, the victim's root on the ground relative to the attacker's root, in
        the frame of the attacker's strike (x along it, z to its right; :func:`place_victim`);
        ``None`` places the victim straight ahead at the strike's reach minus ``overlap``.
    contact_body: the attacker joint that strikes (its carried bodies strike too), or ``None``
        for every attacker body.
    overlap: m, how far inside the contact body's largest reach the victim's root stands.
    """

    facing_deg: float = 0.0
    offset: tuple[float, float] | None = None
    contact_body: str | None = None
    overlap: float = 0.25

    def __post_init__(self):
        f = float(self.facing_deg)
        if not np.isfinite(f) or not -180.0 <= f <= 180.0:
            raise ImpactError(f"facing must be an angle in [-180, 180] degrees, got {self.facing_deg!r}")
        if self.offset is not None:
            o = tuple(float(x) for x in self.offset)
            if len(o) != 2 or not all(np.isfinite(o)):
                raise ImpactError(f"offset must be two finite numbers X,Z in metres, got {self.offset!r}")
            object.__setattr__(self, "offset", o)


@dataclass(frozen=True)
class CharacterLayout:
    """Where one character's state lives in the combined model.

    prefix: ``"a_"`` or ``"v_"``; body_ids (J,): MuJoCo body per skeleton joint;
    qpos_adr / dof_adr: first qpos / dof index of the free joint; ball_qpos (J-1,), ball_dof
    (J-1,): first qpos / dof index of each ball joint (joints 1..J-1 in skeleton order);
    geom_ids: the character's collision geoms; strike_geoms: those allowed to touch the other
    character (attacker only).
    """

    prefix: str
    body_ids: np.ndarray
    qpos_adr: int
    dof_adr: int
    ball_qpos: np.ndarray
    ball_dof: np.ndarray
    geom_ids: np.ndarray
    strike_geoms: np.ndarray


@dataclass(frozen=True)
class Scene:
    """Both characters in one MuJoCo model (see the module docstring).

    xml: the MJCF (floor friction is set per pass with :meth:`model`); attacker, victim:
    :class:`CharacterLayout`; limits_deg (J,): the victim's ball-joint limits (NaN: root);
    step: s.
    """

    xml: str
    attacker_skeleton: object
    victim_skeleton: object
    attacker: CharacterLayout
    victim: CharacterLayout
    floor_geom: int
    limits_deg: np.ndarray
    attacker_limits_deg: np.ndarray
    attacker_mocap: int = 0
    step: float = STEP
    notes: tuple[str, ...] = field(default=())

    def model(self, friction: float):
        """A fresh ``mujoco.MjModel`` with the floor's sliding friction ``friction``."""
        import mujoco

        m = mujoco.MjModel.from_xml_string(self.xml)
        m.geom_friction[self.floor_geom, 0] = float(friction)
        return m


def _fmt(v) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(v))


def _wxyz(q_xyzw) -> np.ndarray:
    q = np.asarray(q_xyzw, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def joint_limits(motions, skeleton, margin_deg: float = 20.0) -> np.ndarray:
    """``(J,)`` degrees: per joint the largest rotation angle from the rest pose over ``motions``
    (each on ``skeleton``) plus ``margin_deg``, capped at 180 (NaN for the root)."""
    J = skeleton.n_joints
    lim = np.zeros(J)
    for m in motions:
        if m.skeleton.names != skeleton.names:
            continue
        lim = np.maximum(lim, np.degrees(quat_angle(m.rotations).max(axis=0)))
    lim = np.minimum(lim + margin_deg, 180.0)
    lim[0] = np.nan
    return lim


def _is_ase(skeleton) -> bool:
    return all(skeleton.find(b) is not None for b in ASE_GEOMS)


def _ase_geoms(name: str):
    """ASE's collision geoms of body ``name`` in the BVH joint frame: (type, attrs)."""
    M = MJCF_TO_BVH
    qM = _wxyz(Rotation.from_matrix(M).as_quat())
    out = []
    for g in ASE_GEOMS[name]:
        kind = g[0]
        if kind == "sphere":
            out.append(("sphere", {"pos": _fmt(M @ np.asarray(g[1], float)), "size": _fmt([g[2]])}))
        elif kind in ("capsule", "cylinder"):
            ft = np.concatenate([M @ np.asarray(g[1], float), M @ np.asarray(g[2], float)])
            out.append((kind, {"fromto": _fmt(ft), "size": _fmt([g[3]])}))
        elif kind == "box":
            out.append(("box", {"pos": _fmt(M @ np.asarray(g[1], float)), "size": _fmt(g[2]), "quat": _fmt(qM)}))
    return out


def _bone_geoms(skeleton, j: int):
    """Capsules along the bones leaving joint ``j`` (radius by body part), a box under an ankle."""
    name = skeleton.names[j].lower()
    kids = [c for c in skeleton.children(j)]
    ends = [skeleton.offsets[c] for c in kids] + [e.offset for e in skeleton.end_sites if e.parent == j]
    r = 0.06 if any(k in name for k in ("hip", "pelvis", "spine", "chest", "torso", "abdomen")) else \
        0.05 if any(k in name for k in ("thigh", "upleg", "femur")) else 0.04
    out = []
    if "head" in name:
        out.append(("sphere", {"pos": "0 0.09 0", "size": "0.095"}))
    for e in ends:
        if np.linalg.norm(e) < 0.03:
            continue
        out.append(("capsule", {"fromto": _fmt(np.concatenate([np.zeros(3), e])), "size": _fmt([r])}))
    if not out:
        out.append(("sphere", {"pos": "0 0 0", "size": "0.035"}))
    return out


def _character(body, prefix: str, limits_deg: np.ndarray, strike: set[int] | None, is_attacker: bool):
    """The ``<body>`` tree of one character (prefixed names, collision geoms, limits)."""
    xml = to_mjcf(body, geoms=False, massless_mass=0.02)
    root = ET.fromstring(xml)
    top = root.find("worldbody").find("body")
    sk = body.skeleton
    names = mjcf_names(sk)
    ase = _is_ase(sk)
    by_name = {}
    for el in top.iter("body"):
        by_name[el.get("name")] = el
    for el in top.iter():
        if el.get("name"):
            el.set("name", prefix + el.get("name"))
    for j, n in enumerate(names):
        el = by_name[n]
        if j > 0 and np.isfinite(limits_deg[j]) and limits_deg[j] < 180.0:
            jt = el.find("joint")
            jt.set("range", f"0 {float(np.radians(limits_deg[j]))!r}")
        geoms = _ase_geoms(sk.names[j]) if ase else _bone_geoms(sk, j)
        striking = strike is None or j in strike
        if is_attacker:
            ctype, caff = (_ATT if striking else _ATT_PASSIVE), _FLOOR
        else:
            ctype, caff = _VIC, _ATT | _FLOOR
        for k, (kind, attrs) in enumerate(geoms):
            g = ET.SubElement(el, "geom", name=f"{prefix}{n}_col{k}", type=kind, contype=str(ctype),
                              conaffinity=str(caff), condim="3", friction=f"{BODY_FRICTION} 0.005 0.0001",
                              rgba="0.8 0.3 0.3 1" if is_attacker else "0.3 0.5 0.8 1", **attrs)
            # put geoms after the joint/inertial children (MJCF order does not matter, readability)
            el.remove(g)
            el.append(g)
    return top


def strike_direction(attacker: Motion, contact_body: str | None) -> tuple[np.ndarray, float, int]:
    """``(direction (3,), reach m, frame)``: the horizontal unit vector from the attacker's root at its
    first frame to the farthest point its contact body (and the joints it carries; every joint when
    None) reaches over the clip, that distance and the frame. A fighter's pelvis is often turned
    away from its strike (a kick from a side stance), so the strike, not the pelvis, says "forward"."""
    P = attacker.positions
    if contact_body is not None:
        sub = sorted(strike_joints(attacker.skeleton, contact_body))
        P = P[:, sub]
    d = P - attacker.root_positions[0]
    d[..., 1] = 0.0
    n = np.linalg.norm(d, axis=-1)
    k, j = np.unravel_index(int(np.argmax(n)), n.shape)
    reach = float(n[k, j])
    if reach < 1e-6:
        raise ImpactError("the attacker's contact body never leaves its root's vertical: no strike direction")
    return d[k, j] / reach, reach, int(k)


def strike_window(attacker: Motion, contact_body: str | None = None, *, lead: float = 1.5,
                  tail: float = 1.5) -> tuple[int, int, int]:
    """``(start, stop, peak)`` frames of the strike in a long attack clip (a 13 s Bandai take holds
    walking about and three slashes): ``peak`` is the frame where the striking joints (``contact_body``
    and the joints it carries; every joint when None) move fastest *relative to the root* (the
    strike, not the walk), and the window runs from ``lead`` s before it to ``tail`` s after it
    (clipped to the clip). :func:`mocomp.impact.pipeline.impact_response` plays that window as the
    attack when the clip is longer than ``ImpactConfig.max_attack``, so the placement
    (:func:`place_victim`: the strike's reach and direction from the window's first frame) and the
    victim's timeline fit the strike."""
    if attacker.n_frames < 3:
        raise ImpactError(f"the attack clip has {attacker.n_frames} frame(s): no strike to find")
    P = attacker.positions
    sub = sorted(strike_joints(attacker.skeleton, contact_body)) if contact_body is not None else \
        list(range(1, attacker.skeleton.n_joints))
    rel = P[:, sub] - attacker.root_positions[:, None]
    speed = np.linalg.norm(np.diff(rel, axis=0), axis=-1).max(axis=1) * attacker.fps     # (T-1,) m/s
    peak = int(np.argmax(speed)) + 1
    a = max(0, peak - int(round(lead * attacker.fps)))
    b = min(attacker.n_frames, peak + int(round(tail * attacker.fps)) + 1)
    return a, b, peak


def strike_at(attacker: Motion, contact_body: str | None, frame: int) -> tuple[np.ndarray, float, int]:
    """``(direction (3,), reach m, frame)`` of the strike at a given ``frame`` (the fastest swing of
    :func:`strike_window`): the striking joint moving fastest relative to the root there (the end
    effector of the swing), its horizontal direction and distance from the attacker's root at its first
    frame -- :func:`strike_direction`'s answer for that frame instead of the clip's farthest reach
    (a 13 s Bandai take reaches farthest when it walks about, not when it slashes)."""
    T = attacker.n_frames
    if not 0 <= frame < T:
        raise ImpactError(f"strike frame {frame} outside the attack clip's {T} frames")
    P = attacker.positions
    sub = sorted(strike_joints(attacker.skeleton, contact_body)) if contact_body is not None else \
        list(range(1, attacker.skeleton.n_joints))
    rel = P[:, sub] - attacker.root_positions[:, None]
    a, b = max(frame - 1, 0), min(frame + 1, T - 1)
    speed = np.linalg.norm(rel[b] - rel[a], axis=-1)
    j = sub[int(np.argmax(speed))]
    d = P[frame, j] - attacker.root_positions[0]
    d[1] = 0.0
    reach = float(np.linalg.norm(d))
    if reach < 1e-6:
        raise ImpactError("the attacker's striking joint is above its root at the strike: no strike direction")
    return d / reach, reach, int(frame)


def place_victim(attacker: Motion, victim: Motion, scenario: Scenario, *, strike_frame: int | None = None) -> Motion:
    """The victim clip moved rigidly (about the vertical, on the ground) for the scenario.

    The frame of reference is the attacker's strike (:func:`strike_direction`): x along the strike,
    z to its right (y up), origin at the attacker's root on the ground at its first frame. At the
    strike's frame (the contact body's farthest reach; the victim's last frame if it is shorter) the
    victim's root goes to ``scenario.offset`` in that frame (default: straight ahead at the strike's
    reach minus ``scenario.overlap``), heading toward the attacker turned by ``facing_deg`` (0: face
    to face, 180: its back to the attacker) -- so a walking or running victim arrives there when the
    strike does. ``strike_frame``: the strike is the one at that frame (:func:`strike_at`: its fastest
    joint's reach there), not the farthest reach."""
    from ..ops.align import headings, yaw_quaternion

    fwd, reach, k_strike = strike_direction(attacker, scenario.contact_body) if strike_frame is None else \
        strike_at(attacker, scenario.contact_body, strike_frame)
    k = int(min(round(k_strike / attacker.fps * victim.fps), victim.n_frames - 1))
    right = np.cross(fwd, np.array([0.0, 1.0, 0.0]))
    off = scenario.offset if scenario.offset is not None else (max(reach - scenario.overlap, 0.2), 0.0)
    pa = attacker.root_positions[0]
    target = np.array([pa[0], 0.0, pa[2]]) + off[0] * fwd + off[1] * right
    # a yaw h turns the local x axis (the ASE/BVH forward) to (cos h, 0, -sin h)
    h_fwd = float(np.arctan2(-fwd[2], fwd[0]))
    want = h_fwd + np.pi + np.radians(scenario.facing_deg)
    hv = float(headings(victim, [k])[0])
    pv = victim.root_positions[k]
    turned = victim.rotated(yaw_quaternion(want - hv), center=np.array([pv[0], 0.0, pv[2]]))
    p0 = turned.root_positions[k]
    return turned.translated(np.array([target[0] - p0[0], 0.0, target[2] - p0[2]]))


def strike_joints(skeleton, contact_body: str | None) -> set[int] | None:
    """The joints whose geoms strike: ``contact_body`` and every joint below it (None: all)."""
    if contact_body is None:
        return None
    j = skeleton.find(contact_body)
    if j is None:
        raise ImpactError(f"contact body {contact_body!r} is not a joint of the attacker's skeleton; joints: "
                          f"{', '.join(skeleton.names)}")
    return {k for k in range(skeleton.n_joints) if j in skeleton.chain(k)}


def default_impact_body(skeleton_or_motion):
    """The body model a character gets: ASE's own inertials (props included) on the ASE humanoid; for a
    motion on another skeleton the audit's default (a DeepMimic clip's own character, else de Leva's
    table at 70 kg); for a bare skeleton de Leva's table at 70 kg."""
    from ..core.motion import Motion as _Motion

    motion = skeleton_or_motion if isinstance(skeleton_or_motion, _Motion) else None
    skeleton = motion.skeleton if motion is not None else skeleton_or_motion
    if _is_ase(skeleton):
        from ..body import ase_body

        return ase_body(skeleton, props="ase")
    if motion is not None:
        from ..audit import default_body

        return default_body(motion)
    from ..body import BodyModel

    return BodyModel.from_skeleton(skeleton, total_mass=70.0)


def _layout(model, prefix: str, skeleton, strike: set[int] | None) -> CharacterLayout:
    import mujoco

    names = mjcf_names(skeleton)
    bids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, prefix + n) for n in names])
    if np.any(bids < 0):
        raise RuntimeError(f"scene: body missing for {prefix}")
    jfree = model.body_jntadr[bids[0]]
    ball_q = np.array([model.jnt_qposadr[model.body_jntadr[b]] for b in bids[1:]], dtype=int)
    ball_d = np.array([model.jnt_dofadr[model.body_jntadr[b]] for b in bids[1:]], dtype=int)
    geoms = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] in set(bids.tolist())], dtype=int)
    if strike is None:
        sg = geoms
    else:
        sb = {int(bids[j]) for j in strike}
        sg = np.array([g for g in geoms if int(model.geom_bodyid[g]) in sb], dtype=int)
    return CharacterLayout(prefix, bids, int(model.jnt_qposadr[jfree]), int(model.jnt_dofadr[jfree]), ball_q, ball_d,
                           geoms, sg)


def build_scene(attacker_skeleton, victim_skeleton, *, attacker_body=None, victim_body=None,
                attacker_motions=(), victim_motions=(), contact_body: str | None = None,
                margin_deg: float = 20.0, step: float = STEP, g: float = 9.81) -> Scene:
    """Both characters in one MuJoCo model (see the module docstring).

    attacker_body / victim_body: their :class:`~mocomp.body.BodyModel` (default
    :func:`default_impact_body`); attacker_motions / victim_motions: the clips whose captured range
    sets each character's ball-joint limits (``margin_deg`` added); contact_body: the attacker's
    striking joint (None: every body strikes).
    """
    import mujoco

    ab = default_impact_body(attacker_skeleton) if attacker_body is None else attacker_body
    vb = default_impact_body(victim_skeleton) if victim_body is None else victim_body
    strike = strike_joints(attacker_skeleton, contact_body)
    alim = joint_limits(attacker_motions, attacker_skeleton, margin_deg) if attacker_motions else \
        np.full(attacker_skeleton.n_joints, np.nan)
    vlim = joint_limits(victim_motions, victim_skeleton, margin_deg) if victim_motions else \
        np.full(victim_skeleton.n_joints, np.nan)
    root = ET.Element("mujoco", model="impact")
    ET.SubElement(root, "compiler", inertiafromgeom="false", angle="radian", autolimits="true")
    ET.SubElement(root, "option", gravity=f"0 {-g!r} 0", timestep=repr(float(step)), integrator="Euler", jacobian="sparse")
    ET.SubElement(root, "size", memory="20M")
    vis = ET.SubElement(root, "visual")
    ET.SubElement(vis, "headlight", ambient="0.4 0.4 0.4", diffuse="0.6 0.6 0.6")
    wb = ET.SubElement(root, "worldbody")
    # the floor: MuJoCo planes face +z; turn it to face +y (rotation of -90 deg about x)
    s = float(np.sqrt(0.5))
    ET.SubElement(wb, "geom", name="floor", type="plane", size="0 0 0.05", quat=f"{s!r} {-s!r} 0 0",
                  contype=str(_FLOOR), conaffinity=str(_ATT | _VIC | _ATT_PASSIVE), condim="4",
                  friction=f"{FRICTION_NAIVE} {TORSIONAL_FRICTION} 0.0001", rgba="0.85 0.85 0.8 1")
    wb.append(_character(ab, "a_", alim, strike, True))
    wb.append(_character(vb, "v_", vlim, None, False))
    # the attacker's root follows its clip through a soft weld to a mocap body (implicit, stable)
    ET.SubElement(wb, "body", name="a_root_target", mocap="true")
    eq = ET.SubElement(root, "equality")
    ET.SubElement(eq, "weld", name="a_root_servo", body1="a_root_target", body2="a_" + mjcf_names(attacker_skeleton)[0],
                  relpose="0 0 0 1 0 0 0", solref=f"{ROOT_SERVO_TIMECONST!r} 1")
    ET.indent(root)
    xml = ET.tostring(root, encoding="unicode")
    model = mujoco.MjModel.from_xml_string(xml)
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    mocap = int(model.body_mocapid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "a_root_target")])
    notes = (f"attacker body model: {ab.table} ({ab.total_mass:.1f} kg)",
             f"victim body model: {vb.table} ({vb.total_mass:.1f} kg)",
             "collision geoms: " + ("ASE's MJCF geoms" if _is_ase(victim_skeleton) else "capsules along bones"))
    return Scene(xml, attacker_skeleton, victim_skeleton, _layout(model, "a_", attacker_skeleton, strike),
                 _layout(model, "v_", victim_skeleton, None), int(floor), vlim, alim, mocap, step, notes)
