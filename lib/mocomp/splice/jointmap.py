"""Which hand-recording joint drives which body joint (issue #19 item 8).

The splice copies the local rotations of the arm chain (clavicle, upper arm,
forearm, hand) and the joints below the hand (fingers) from the hand
recording onto the body recording. Two CMU clips of the same 31-joint
hierarchy already disagree on the finger names (``RFingers`` in 01_01,
``RightHandIndex1`` in 141_16), so joints are paired in this order:

1. the same name in both skeletons;
2. a ``--map FILE.toml`` entry (``[joints]`` body name = hand name);
3. the body model's naming conventions (:data:`mocomp.body.mapping.CONVENTIONS`):
   names given as alternatives for the same landmark (``("first", ...)``
   specs, e.g. the CMU hand end ``{Side}HandIndex1`` / ``{S}Fingers`` /
   ``{Side}FingerBase``) are the same joint under different conventions;
4. structure: the only still unpaired child of two paired joints.

Rotations are copied as *local* joint rotations, so a pairing is only as
good as the agreement of the two skeletons' rest poses (both CMU clips: the
same hierarchy and T-pose, different bone lengths); pairing joints of
different conventions by role (a Bandai hand recording on a CMU body) runs,
but its arm pose is right only if their rest poses agree.

What stays unpaired is an error (:class:`~mocomp.errors.AlignmentError`)
listing the body joints without a counterpart and the hand recording's
unpaired joints below the arm, unless the map's ``keep`` list names them
(they then keep the body's own rotations).

Map file (TOML)::

    # body joint = hand-recording joint
    [joints]
    RFingers = "RightHandIndex1"
    # body joints that keep their own rotation (no counterpart)
    keep = ["RThumb"]

    # optional: the arm chain of either recording, when not found by name
    [arm.body.right]
    clavicle = "RightShoulder"
    upper = "RightArm"
    forearm = "RightForeArm"
    hand = "RightHand"
    [arm.hand.right]
    ...
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import AlignmentError, MotionFormatError

__all__ = ["JointMap", "load_joint_map", "pair_joints", "convention_aliases"]

_ARM_KEYS = ("clavicle", "upper", "forearm", "hand")


@dataclass(frozen=True)
class JointMap:
    """A user's joint map (see the module docstring).

    joints: body joint name -> hand-recording joint name.
    keep: body joints that keep their own rotations.
    arms: ``{"body"|"hand": {"right"|"left": {"clavicle", "upper", "forearm", "hand"}}}``.
    source: the file it came from.
    """

    joints: dict = field(default_factory=dict)
    keep: tuple[str, ...] = ()
    arms: dict = field(default_factory=dict)
    source: str | None = None

    def arm(self, which: str, side: str) -> dict | None:
        return self.arms.get(which, {}).get(side)


def load_joint_map(path) -> JointMap:
    """Read a ``--map`` TOML file; errors name the file and the offending key."""
    import tomllib

    p = Path(path)
    try:
        d = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"joint map {p} does not exist") from None
    except tomllib.TOMLDecodeError as e:
        raise MotionFormatError(f"joint map {p}: not valid TOML ({e})") from None
    unknown = set(d) - {"joints", "arm"}
    if unknown:
        raise MotionFormatError(f"joint map {p}: unknown table(s) {sorted(unknown)}; expected [joints] and [arm.body|hand.right|left]")
    jt = dict(d.get("joints", {}))
    keep = jt.pop("keep", [])
    if not isinstance(keep, list) or not all(isinstance(k, str) for k in keep):
        raise MotionFormatError(f"joint map {p}: joints.keep must be a list of body joint names, got {keep!r}")
    for k, v in jt.items():
        if not isinstance(v, str):
            raise MotionFormatError(f"joint map {p}: joints.{k} must be a hand-recording joint name (a string), got {v!r}")
    arms: dict = {}
    for which, sides in d.get("arm", {}).items():
        if which not in ("body", "hand") or not isinstance(sides, dict):
            raise MotionFormatError(f"joint map {p}: [arm.{which}] must be [arm.body.<side>] or [arm.hand.<side>]")
        for side, roles in sides.items():
            if side not in ("right", "left") or not isinstance(roles, dict):
                raise MotionFormatError(f"joint map {p}: [arm.{which}.{side}]: the side must be 'right' or 'left'")
            bad = set(roles) - set(_ARM_KEYS)
            if bad or any(k not in roles for k in ("upper", "forearm", "hand")):
                raise MotionFormatError(
                    f"joint map {p}: [arm.{which}.{side}] needs upper, forearm, hand (and optionally clavicle); "
                    f"got {sorted(roles)}")
            arms.setdefault(which, {})[side] = {k: roles.get(k) for k in _ARM_KEYS}
    return JointMap(jt, tuple(keep), arms, str(p))


def convention_aliases() -> list[set[str]]:
    """Sets of joint names that the body model's conventions give as alternatives
    for one landmark (``("first", a, b, ...)`` specs in :data:`mocomp.body.mapping.CONVENTIONS`,
    per side, ``/end`` suffixes dropped, geometric constructions skipped)."""
    from ..body.mapping import CONVENTIONS

    out = []
    for conv in CONVENTIONS.values():
        for spec in conv.landmarks.values():
            if isinstance(spec, tuple) and spec and spec[0] == "first":
                names = {s[:-4] if s.endswith("/end") else s for s in spec[1:] if isinstance(s, str)}
                if len(names) > 1:
                    out.append(names)
    return out


def _role_of(name: str) -> str:
    n = name.lower()
    for role in ("thumb", "index", "middle", "ring", "pinky"):
        if role in n:
            return role
    return "finger" if re.search(r"finger|hand_end|handend", n) else "other"


def pair_joints(body_sk, hand_sk, body_joints, body_arm, hand_arm, jmap: JointMap | None = None) -> dict[str, str | None]:
    """Pair each of ``body_joints`` (indices into ``body_sk``: the layer the hand
    recording drives) with a hand-recording joint name (``None``: keeps the body's own).

    ``body_arm``/``hand_arm`` are the :class:`~mocomp.splice.markers.ArmJoints`
    of both skeletons (the arm chain pairs by role). Raises
    :class:`~mocomp.errors.AlignmentError` listing what stays unpaired."""
    jmap = jmap or JointMap()
    bn, hn = body_sk.names, hand_sk.names
    pairs: dict[str, str | None] = {}
    for k in jmap.joints:
        if k not in bn:
            raise AlignmentError(f"joint map {jmap.source or ''}: body joint {k!r} is not in the body skeleton; joints: {list(bn)}")
        if jmap.joints[k] not in hn:
            raise AlignmentError(f"joint map {jmap.source or ''}: hand joint {jmap.joints[k]!r} (for {k!r}) is not in the "
                                 f"hand recording's skeleton; joints: {list(hn)}")
    roles_b = {getattr(body_arm, r): r for r in ("clavicle", "upper", "forearm", "hand") if getattr(body_arm, r) is not None}
    roles_h = {r: getattr(hand_arm, r) for r in ("clavicle", "upper", "forearm", "hand") if getattr(hand_arm, r) is not None}
    aliases = convention_aliases()
    todo = [bn[j] for j in body_joints]
    for name in todo:
        j = body_sk.index(name)
        if name in jmap.joints:
            pairs[name] = jmap.joints[name]
        elif name in jmap.keep:
            pairs[name] = None
        elif name in hand_sk:
            pairs[name] = name
        elif j in roles_b and roles_b[j] in roles_h:
            pairs[name] = hn[roles_h[roles_b[j]]]
    used = {v for v in pairs.values() if v is not None}
    for name in todo:  # naming conventions of the body model
        if name in pairs:
            continue
        for group in aliases:
            if name in group:
                cands = [c for c in group if c in hand_sk and c not in body_sk and c not in used]
                if len(cands) == 1:
                    pairs[name] = cands[0]
                    used.add(cands[0])
                    break
    changed = True
    while changed:  # structure: the only unpaired child (same role) of paired parents
        changed = False
        for name in todo:
            if name in pairs:
                continue
            j = body_sk.index(name)
            pb = bn[body_sk.parents[j]] if body_sk.parents[j] >= 0 else None
            ph = pairs.get(pb) if pb is not None else None
            if ph is None:
                continue
            kids_b = [bn[c] for c in body_sk.children(body_sk.index(pb)) if bn[c] not in pairs]
            kids_h = [hn[c] for c in hand_sk.children(hand_sk.index(ph)) if hn[c] not in used]
            if len(kids_b) == 1 and len(kids_h) == 1 and _role_of(kids_b[0]) in (_role_of(kids_h[0]), "finger", "other") :
                pairs[name] = kids_h[0]
                used.add(kids_h[0])
                changed = True
            elif len(kids_b) == len(kids_h) > 1:
                for kb in kids_b:
                    m = [kh for kh in kids_h if _role_of(kh) == _role_of(kb) != "other"]
                    if len(m) == 1:
                        pairs[kb] = m[0]
                        used.add(m[0])
                        changed = True
    missing = [n for n in todo if n not in pairs]
    if missing:
        below = {hn[j] for j in range(hand_sk.n_joints) if hand_arm.hand in hand_sk.chain(j) or j in roles_h.values()}
        spare = sorted(below - used - set(bn))
        raise AlignmentError(
            f"cannot pair the body joints {missing} with joints of the hand recording (same name, the body model's "
            f"naming conventions and the skeleton structure tried); unpaired hand-recording joints of that arm: "
            f"{spare or 'none'}. Give a map: --map FILE.toml with [joints] " +
            ", ".join(f'{b} = "..."' for b in missing) + " (or keep = [...] to leave them as the body has them)")
    return pairs
