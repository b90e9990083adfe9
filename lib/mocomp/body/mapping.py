"""Skeleton bones -> anatomical segments, for the naming conventions of real clips.

A :class:`SegmentMap` says, for one naming convention,

* ``landmarks``: where each canonical landmark of :data:`~mocomp.body.tables.SEGMENT_KINDS`
  (``VERT``, ``CERV``, ``XYPH``, ``OMPH``, ``MIDH`` and per side ``SJC_l``, ``EJC_l``,
  ``WJC_l``, ``MET3_l``, ``HJC_l``, ``KJC_l``, ``AJC_l``, ``TTIP_l``, ...) lies on the
  skeleton, as a :data:`Landmark` spec resolved in the rest pose;
* ``carriers``: which joint's frame carries each sided segment (``"thigh_l"`` -> the
  hip joint). A segment is rigid in its carrier's frame.

Joints that carry no segment are listed in ``BodyModel.massless_joints``, never
dropped silently.

How the trunk is split across bones: the de Leva / Dempster trunk is three
stacked parts (upper, middle, lower; see :mod:`~mocomp.body.tables`). ``MIDH`` is
the midpoint of the two hip joints and ``CERV`` the base of the neck; ``OMPH``
and ``XYPH`` are placed on the line MIDH -> CERV at 27.4 % and 67.9 % of its
length (de Leva's mean male proportions: LPT 0.1457 m, MPT 0.2155 m, UPT
0.1707 m). Each part is carried by the spine bone that spans it: for the CMU
BVH skeleton lower = ``Hips``, middle = ``LowerBack``, upper = ``Spine``
(``Spine1``, ``Neck``, ``Neck1``, the clavicles ``LeftShoulder``/``RightShoulder``
and the hip-joint helpers ``LHipJoint``/``RHipJoint`` are massless). The
``head`` segment (vertex to C7, neck included) rides on the ``Head`` joint.

Landmark specs (nest freely):

* ``"Name"``: a joint, or an end site by its name; ``"Joint/end"``: the first end
  site hanging from ``Joint``.
* ``("mid", a, b)``: midpoint; ``("lerp", a, b, t)``: ``a + t (b - a)``;
  ``("extend", a, b, f)``: ``b + f (b - a)`` (for skeletons whose end sites have
  zero length, e.g. Bandai Namco, MASS);
* ``("offset", joint, (x, y, z))``: a point fixed in the joint's frame, metres;
* ``("first", a, b, ...)``: the first spec that resolves (naming variants).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.skeleton import Skeleton
from ..errors import MotionFormatError
from .tables import SEGMENT_KINDS

__all__ = [
    "SegmentMap",
    "CONVENTIONS",
    "detect_convention",
    "resolve_mapping",
    "resolve_landmark",
    "sided_segments",
    "OMPH_FRACTION",
    "XYPH_FRACTION",
]

Landmark = Any

#: omphalion / xiphion positions along MIDH -> CERV (de Leva 1996 male lengths)
OMPH_FRACTION = 0.1457 / (0.1457 + 0.2155 + 0.1707)
XYPH_FRACTION = (0.1457 + 0.2155) / (0.1457 + 0.2155 + 0.1707)


def sided_segments() -> list[str]:
    """Canonical sided segment names in model order (head, trunk, then left/right limbs)."""
    out = []
    for kind, (_, _, paired) in SEGMENT_KINDS.items():
        if paired:
            out += [kind + "_l", kind + "_r"]
        else:
            out.append(kind)
    return out


@dataclass(frozen=True)
class SegmentMap:
    """Where the canonical landmarks lie and which joint carries each segment.

    Attributes
    ----------
    name: convention name (``"cmu_bvh"``, ``"sfu"``, ...).
    landmarks: canonical landmark -> :data:`Landmark` spec.
    carriers: sided segment name -> joint name.
    notes: approximations this convention makes.
    """

    name: str
    landmarks: dict = field(default_factory=dict)
    carriers: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def updated(self, override: dict | "SegmentMap") -> "SegmentMap":
        """A copy with ``override['landmarks']`` / ``override['carriers']`` entries replaced."""
        if isinstance(override, SegmentMap):
            lm, ca, name = override.landmarks, override.carriers, override.name
        else:
            unknown = set(override) - {"landmarks", "carriers", "name", "notes"}
            if unknown:
                raise ValueError(f"mapping override has unknown keys {sorted(unknown)}; use 'landmarks' and/or 'carriers'")
            lm, ca, name = override.get("landmarks", {}), override.get("carriers", {}), override.get("name", self.name + "+override")
        return SegmentMap(name, {**self.landmarks, **lm}, {**self.carriers, **ca},
                          self.notes + tuple(override.get("notes", ()) if isinstance(override, dict) else override.notes))


def _trunk(midh, cerv) -> dict:
    return {
        "MIDH": midh,
        "CERV": cerv,
        "OMPH": ("lerp", "MIDH", "CERV", OMPH_FRACTION),
        "XYPH": ("lerp", "MIDH", "CERV", XYPH_FRACTION),
    }


def _limbs(names: dict[str, str], side_fmt) -> dict:
    """``names`` maps landmark -> pattern with ``{S}``/``{s}``/``{Side}`` placeholders."""
    out = {}
    for side in ("l", "r"):
        subs = side_fmt(side)
        for lm, pat in names.items():
            out[f"{lm}_{side}"] = _fmt(pat, subs)
    return out


def _fmt(spec, subs):
    if isinstance(spec, str):
        return spec.format(**subs)
    if isinstance(spec, tuple):
        return tuple(_fmt(s, subs) for s in spec)
    return spec


def _carriers(head, upper, middle, lower, limb: dict[str, str], side_fmt) -> dict:
    out = {"head": head, "upper_trunk": upper, "middle_trunk": middle, "lower_trunk": lower}
    for side in ("l", "r"):
        subs = side_fmt(side)
        for seg, pat in limb.items():
            out[f"{seg}_{side}"] = pat.format(**subs)
    return out


def _lr(side):
    return {"Side": "Left" if side == "l" else "Right", "S": side.upper(), "s": side, "side": "left" if side == "l" else "right"}


_LIMB_SEGS = ("upper_arm", "forearm", "hand", "thigh", "shank", "foot")


def _convention(name, trunk, limb_landmarks, head_carrier, trunk_carriers, limb_carriers, notes=()):
    lm = {**trunk, **_limbs(limb_landmarks, _lr)}
    ca = _carriers(head_carrier, *trunk_carriers, dict(zip(_LIMB_SEGS, limb_carriers)), _lr)
    return SegmentMap(name, lm, ca, tuple(notes))


#: Naming conventions of the real clips (see shared MANIFEST) and of mocomp.synth.
CONVENTIONS: dict[str, SegmentMap] = {}

# Order matters for detection: most specific first (SFU's carrier names are a subset of CMU's).
# CMU / cgspeed "MotionBuilder-friendly" BVH (Hips, LeftUpLeg, ...); also mocomp.synth
CONVENTIONS["cmu_bvh"] = _convention(
    "cmu_bvh",
    {**_trunk(("mid", "LeftUpLeg", "RightUpLeg"), "Neck"), "VERT": "Head/end"},
    {"SJC": "{Side}Arm", "EJC": "{Side}ForeArm", "WJC": "{Side}Hand",
     "MET3": ("first", "{Side}HandIndex1/end", "{S}Fingers/end", "{Side}FingerBase/end", ("extend", "{Side}ForeArm", "{Side}Hand", 0.32)),
     "HJC": "{Side}UpLeg", "KJC": "{Side}Leg", "AJC": "{Side}Foot",
     "TTIP": ("first", "{Side}ToeBase/end", ("extend", "{Side}Foot", "{Side}ToeBase", 0.45))},
    "Head", ("Spine", "LowerBack", "Hips"),
    ("{Side}Arm", "{Side}ForeArm", "{Side}Hand", "{Side}UpLeg", "{Side}Leg", "{Side}Foot"),
    ("hand: wrist -> finger end site (CMU hands are short)",),
)

# CMU ASF/AMC bone names (joint = proximal end of the bone of that name)
CONVENTIONS["cmu_asf"] = _convention(
    "cmu_asf",
    {**_trunk(("mid", "lfemur", "rfemur"), "lowerneck"), "VERT": "head/end"},
    {"SJC": "{s}humerus", "EJC": "{s}radius", "WJC": "{s}wrist",
     "MET3": ("first", "{s}fingers/end", "{s}hand/end", ("extend", "{s}radius", "{s}wrist", 0.32)),
     "HJC": "{s}femur", "KJC": "{s}tibia", "AJC": "{s}foot",
     "TTIP": ("first", "{s}toes/end", ("extend", "{s}foot", "{s}toes", 0.45))},
    "head", ("thorax", "lowerback", "root"),
    ("{s}humerus", "{s}radius", "{s}wrist", "{s}femur", "{s}tibia", "{s}foot"),
    ("joints named after ASF bones sit at the bone's proximal end",),
)

# 3dsMax-friendly CMU BVH (LeftHip, LeftKnee, LeftAnkle, Chest, Chest2, LeftCollar, ...)
CONVENTIONS["cmu_3dsmax"] = _convention(
    "cmu_3dsmax",
    {**_trunk(("mid", "LeftHip", "RightHip"), "lowerneck"), "VERT": "Head/end"},
    {"SJC": "{Side}Shoulder", "EJC": "{Side}Elbow", "WJC": "{Side}Wrist",
     "MET3": ("first", "{S}Fingers/end", "{s}hand/end", ("extend", "{Side}Elbow", "{Side}Wrist", 0.32)),
     "HJC": "{Side}Hip", "KJC": "{Side}Knee", "AJC": "{Side}Ankle",
     "TTIP": ("first", "{Side}Toe/end", ("extend", "{Side}Ankle", "{Side}Toe", 0.45))},
    "Head", ("Chest", "lowerback", "Hips"),
    ("{Side}Shoulder", "{Side}Elbow", "{Side}Wrist", "{Side}Hip", "{Side}Knee", "{Side}Ankle"),
)

# SFU motion capture database BVH (no LHipJoint/LowerBack; L_Wrist_End joint)
CONVENTIONS["sfu"] = _convention(
    "sfu",
    {**_trunk(("mid", "LeftUpLeg", "RightUpLeg"), "Neck"), "VERT": "Head/end"},
    {"SJC": "{Side}Arm", "EJC": "{Side}ForeArm", "WJC": "{Side}Hand",
     "MET3": ("first", "{S}_Wrist_End", ("extend", "{Side}ForeArm", "{Side}Hand", 0.32)),
     "HJC": "{Side}UpLeg", "KJC": "{Side}Leg", "AJC": "{Side}Foot",
     "TTIP": ("first", "{Side}ToeBase/end", ("extend", "{Side}Foot", "{Side}ToeBase", 0.45))},
    "Head", ("Spine1", "Spine", "Hips"),
    ("{Side}Arm", "{Side}ForeArm", "{Side}Hand", "{Side}UpLeg", "{Side}Leg", "{Side}Foot"),
    ("hand: wrist -> L_Wrist_End/R_Wrist_End joint",),
)

# Bandai Namco Research Motion dataset (Hips, Spine, Chest, UpperArm_L, ...); end sites have zero length
CONVENTIONS["bandai"] = _convention(
    "bandai",
    {**_trunk(("mid", "UpperLeg_L", "UpperLeg_R"), "Neck"), "VERT": ("extend", "Neck", "Head", 2.6)},
    {"SJC": "UpperArm_{S}", "EJC": "LowerArm_{S}", "WJC": "Hand_{S}",
     "MET3": ("extend", "LowerArm_{S}", "Hand_{S}", 0.32),
     "HJC": "UpperLeg_{S}", "KJC": "LowerLeg_{S}", "AJC": "Foot_{S}",
     "TTIP": ("extend", "Foot_{S}", "Toes_{S}", 0.45)},
    "Head", ("Chest", "Spine", "Hips"),
    ("UpperArm_{S}", "LowerArm_{S}", "Hand_{S}", "UpperLeg_{S}", "LowerLeg_{S}", "Foot_{S}"),
    ("end sites have zero length: head top 2.6 neck lengths beyond Head, hand end 0.32 forearm lengths "
     "beyond the wrist (de Leva hand/forearm), toe tip 0.45 ankle-to-ball lengths beyond the ball",),
)

# MASS (Character1_* rig with *_RIGMESH helper joints)
CONVENTIONS["mass"] = _convention(
    "mass",
    {**_trunk(("mid", "Character1_LeftUpLeg", "Character1_RightUpLeg"), "Character1_Neck"),
     "VERT": ("extend", "Character1_Neck", "Character1_Head", 2.0)},
    {"SJC": "Character1_{Side}Arm", "EJC": "Character1_{Side}ForeArm", "WJC": "Character1_{Side}Hand",
     "MET3": ("extend", "Character1_{Side}ForeArm", "Character1_{Side}Hand", 0.32),
     "HJC": "Character1_{Side}UpLeg", "KJC": "Character1_{Side}Leg", "AJC": "Character1_{Side}Foot",
     "TTIP": ("extend", "Character1_{Side}Foot", "Character1_{Side}ToeBase", 0.45)},
    "Character1_Head", ("Character1_Spine1", "Character1_Spine", "Character1_Hips"),
    ("Character1_{Side}Arm", "Character1_{Side}ForeArm", "Character1_{Side}Hand",
     "Character1_{Side}UpLeg", "Character1_{Side}Leg", "Character1_{Side}Foot"),
    ("end sites have zero length: head top 2 neck lengths beyond the Head joint; hand and toe ends extrapolated",
     "*_RIGMESH helper joints are massless"),
)

# DeepMimic humanoid3d (root, chest, neck, right_hip, right_knee, ...), x forward, y up
CONVENTIONS["deepmimic"] = _convention(
    "deepmimic",
    {**_trunk(("mid", "left_hip", "right_hip"), "neck"), "VERT": ("offset", "neck", (0.0, 0.2775, 0.0))},
    {"SJC": "{side}_shoulder", "EJC": "{side}_elbow", "WJC": "{side}_wrist",
     "MET3": ("extend", "{side}_elbow", "{side}_wrist", 0.32),
     "HJC": "{side}_hip", "KJC": "{side}_knee", "AJC": "{side}_ankle",
     "TTIP": ("offset", "{side}_ankle", (0.1335, -0.05, 0.0))},
    "neck", ("chest", "root", "root"),
    ("{side}_shoulder", "{side}_elbow", "{side}_wrist", "{side}_hip", "{side}_knee", "{side}_ankle"),
    ("head top and toe tip from the DeepMimic character's body shapes (head sphere 0.175 m above the neck, "
     "foot box 0.177 m long, 0.045 m ahead of the ankle)",),
)

# ASE humanoid (NVIDIA ASE / AMP, Reallusion sword-and-shield clips): pelvis, torso, head,
# {side}_upper_arm, {side}_lower_arm, {side}_hand, {side}_thigh, {side}_shin, {side}_foot, plus the
# prop joints sword (under right_hand) and shield (under left_lower_arm). Offsets and body shapes
# from ASE's MJCF (amp_humanoid_sword_shield.xml; Z-up there, Y-up x-forward in the derived BVH).
CONVENTIONS["ase"] = _convention(
    "ase",
    {**_trunk(("mid", "left_thigh", "right_thigh"), "head"), "VERT": ("offset", "head", (0.0, 0.27, 0.0))},
    {"SJC": "{side}_upper_arm", "EJC": "{side}_lower_arm", "WJC": "{side}_hand",
     "MET3": ("extend", "{side}_lower_arm", "{side}_hand", 0.32),
     "HJC": "{side}_thigh", "KJC": "{side}_shin", "AJC": "{side}_foot",
     "TTIP": ("offset", "{side}_foot", (0.1335, -0.05, 0.0))},
    "head", ("torso", "pelvis", "pelvis"),
    ("{side}_upper_arm", "{side}_lower_arm", "{side}_hand", "{side}_thigh", "{side}_shin", "{side}_foot"),
    ("head top and toe tip from ASE's MJCF body shapes (head sphere r 0.095 m centred 0.175 m above the head "
     "joint; foot box 0.177 m long, 0.045 m ahead of and 0.05 m below the ankle); CERV = the head joint "
     "(at shoulder level); trunk split as for DeepMimic (upper on torso, middle and lower on pelvis)",
     "props: the sword and shield joints carry no mass unless props='ase' "
     "(BodyModel.from_skeleton; masses, COMs and inertias of ASE's MJCF prop geoms, mocomp.body.ase)"),
)

# SFU's carrier names are a subset of the CMU BVH ones: try it last.
CONVENTIONS["sfu"] = CONVENTIONS.pop("sfu")


# ------------------------------------------------------------------ resolving
class _Names:
    """A skeleton's name -> index lookups, built once per resolution (a few dicts of J entries) so
    that resolving the ~60 landmarks and 15 carriers of a convention stays in this module instead of
    asking the skeleton for each name (the same answers as ``Skeleton.find`` / ``in skeleton``):
    ``joints`` name -> joint index, ``first_end`` joint index -> offset of its first end site,
    ``ends`` end-site name -> (parent, offset) of the first site of that name, and the rest pose."""

    __slots__ = ("joints", "first_end", "ends", "rest")

    def __init__(self, skeleton: Skeleton, rest: np.ndarray | None = None):
        self.joints = {n: j for j, n in enumerate(skeleton.names)}
        self.first_end: dict[int, np.ndarray] = {}
        self.ends: dict[str, tuple[int, np.ndarray]] = {}
        for e in skeleton.end_sites:
            self.first_end.setdefault(e.parent, e.offset)
            self.ends.setdefault(e.name, (e.parent, e.offset))
        self.rest = skeleton.rest_positions() if rest is None else rest


def _joint_or_end(names: _Names, name: str):
    rest = names.rest
    if name.endswith("/end"):
        j = names.joints.get(name[:-4])
        if j is None or j not in names.first_end:
            return None
        return rest[j] + names.first_end[j]
    j = names.joints.get(name)
    if j is not None:
        return rest[j]
    e = names.ends.get(name)
    return None if e is None else rest[e[0]] + e[1]


def resolve_landmark(skeleton: Skeleton, spec: Landmark, landmarks: dict | None = None,
                     rest: np.ndarray | None = None, _depth: int = 0):
    """Rest-pose world position ``(3,)`` of a landmark spec, or ``None`` if it does not resolve.

    Strings naming another canonical landmark (``"MIDH"``) are looked up in ``landmarks``.
    ``rest``: the skeleton's rest positions, when the caller has them already.
    """
    return _resolve(_Names(skeleton, rest), spec, landmarks or {}, _depth)


def _resolve(names: _Names, spec: Landmark, landmarks: dict, _depth: int = 0):
    """:func:`resolve_landmark` on a skeleton's prebuilt lookups."""
    if _depth > 20:
        raise ValueError(f"landmark spec nests too deeply (cycle?): {spec!r}")
    rec = lambda s: _resolve(names, s, landmarks, _depth + 1)  # noqa: E731
    if isinstance(spec, str):
        p = _joint_or_end(names, spec)
        if p is None and spec in landmarks and landmarks[spec] != spec:
            p = rec(landmarks[spec])
        return p
    if not isinstance(spec, tuple) or not spec:
        raise ValueError(f"bad landmark spec {spec!r}")
    op = spec[0]
    if op == "first":
        for s in spec[1:]:
            p = rec(s)
            if p is not None:
                return p
        return None
    if op == "offset":
        j = names.joints.get(spec[1])
        return None if j is None else names.rest[j] + np.asarray(spec[2], dtype=float)
    if op in ("mid", "lerp", "extend"):
        a, b = rec(spec[1]), rec(spec[2])
        if a is None or b is None:
            return None
        if op == "mid":
            return 0.5 * (a + b)
        t = float(spec[3])
        return a + t * (b - a) if op == "lerp" else b + t * (b - a)
    raise ValueError(f"unknown landmark operation {op!r} in {spec!r}")


def _referenced_names(spec) -> list[str]:
    if isinstance(spec, str):
        return [spec]
    if isinstance(spec, tuple) and spec and spec[0] in ("mid", "lerp", "extend"):
        return _referenced_names(spec[1]) + _referenced_names(spec[2])
    if isinstance(spec, tuple) and spec and spec[0] == "offset":
        return [spec[1]]
    return []


def _score(skeleton: Skeleton | _Names, m: SegmentMap) -> float:
    """Fraction of ``m``'s carrier joints present in the skeleton."""
    joints = skeleton.joints if isinstance(skeleton, _Names) else set(skeleton.names)
    carriers = list(m.carriers.values())
    hits = sum(1 for c in carriers if c in joints)
    return hits / max(1, len(carriers))


def detect_convention(skeleton: Skeleton) -> SegmentMap:
    """The first convention (in :data:`CONVENTIONS` order, most specific first) whose carrier
    joints all exist in ``skeleton`` and whose landmarks resolve on it.

    Raises :class:`~mocomp.errors.MotionFormatError` listing the joint names when none fits.
    """
    return _detect(skeleton, _Names(skeleton))


def _detect(skeleton: Skeleton, names: _Names) -> SegmentMap:
    errors = []
    for m in CONVENTIONS.values():
        if _score(names, m) < 1.0:
            continue
        try:
            _apply(skeleton, names, m)
            return m
        except MotionFormatError as e:
            errors.append(str(e))
    best = max(CONVENTIONS.values(), key=lambda m: _score(names, m))
    raise MotionFormatError(
        f"no body-segment mapping fits this skeleton (best: {best.name!r}, {_score(names, best):.0%} of its "
        f"carrier joints present{'; ' + errors[0] if errors else ''}); joints: {list(skeleton.names)}. "
        "Pass mapping=... to BodyModel.from_skeleton (see mocomp.body.mapping)")


@dataclass(frozen=True)
class ResolvedMapping:
    """A mapping applied to one skeleton.

    Attributes
    ----------
    convention: the :class:`SegmentMap` used.
    segments: sided segment names in model order.
    carriers: ``(S,)`` joint index per segment.
    proximal, distal: ``(S, 3)`` rest-pose world positions of each segment's landmarks, metres.
    massless_joints: joints that carry no segment.
    """

    convention: SegmentMap
    segments: tuple[str, ...]
    carriers: np.ndarray
    proximal: np.ndarray
    distal: np.ndarray
    massless_joints: tuple[str, ...]


def resolve_mapping(skeleton: Skeleton, mapping: SegmentMap | dict | str | None = None) -> ResolvedMapping:
    """Apply a mapping (``None``: detect; a convention name; a :class:`SegmentMap`; or a dict
    override ``{"landmarks": {...}, "carriers": {...}}`` on top of the detected convention).

    The skeleton's names are looked up once (:class:`_Names`) for the detection and the
    resolution together."""
    names = _Names(skeleton)
    if mapping is None:
        m = _detect(skeleton, names)
    elif isinstance(mapping, str):
        if mapping not in CONVENTIONS:
            raise ValueError(f"unknown mapping convention {mapping!r}; choose one of {sorted(CONVENTIONS)}")
        m = CONVENTIONS[mapping]
    elif isinstance(mapping, SegmentMap):
        m = mapping
    elif isinstance(mapping, dict):
        base = mapping.get("base")
        m0 = CONVENTIONS[base] if base else max(CONVENTIONS.values(), key=lambda c: _score(names, c))
        m = m0.updated({k: v for k, v in mapping.items() if k != "base"})
    else:
        raise TypeError(f"mapping must be None, a convention name, a SegmentMap or a dict, got {type(mapping).__name__}")
    return _apply(skeleton, names, m)


def _apply(skeleton: Skeleton, names: _Names, m: SegmentMap) -> ResolvedMapping:
    """Resolve every segment's carrier and landmarks of ``m`` on the skeleton's lookups."""
    segs = sided_segments()
    carriers, prox, dist = [], [], []
    for seg in segs:
        kind = seg[:-2] if seg.endswith(("_l", "_r")) else seg
        p_name, d_name, paired = SEGMENT_KINDS[kind]
        suffix = seg[-2:] if paired else ""
        c = m.carriers.get(seg)
        if c is None:
            raise MotionFormatError(f"mapping {m.name!r} gives no carrier joint for segment {seg!r}")
        j = names.joints.get(c)
        if j is None:
            raise MotionFormatError(f"mapping {m.name!r}: carrier joint {c!r} of segment {seg!r} is not in the skeleton")
        pts = []
        for lm in (p_name + suffix, d_name + suffix):
            if lm not in m.landmarks:
                raise MotionFormatError(f"mapping {m.name!r} does not place landmark {lm!r} (segment {seg!r})")
            p = _resolve(names, m.landmarks[lm], m.landmarks)
            if p is None:
                raise MotionFormatError(
                    f"mapping {m.name!r}: landmark {lm!r} = {m.landmarks[lm]!r} does not resolve on this skeleton "
                    f"(segment {seg!r}); override it with mapping={{'landmarks': {{{lm!r}: ...}}}}")
            pts.append(p)
        if np.linalg.norm(pts[1] - pts[0]) < 1e-6:
            raise MotionFormatError(f"mapping {m.name!r}: segment {seg!r} has zero length (landmarks coincide)")
        carriers.append(j)
        prox.append(pts[0])
        dist.append(pts[1])
    used = set(carriers)
    massless = tuple(n for n, j in names.joints.items() if j not in used)
    return ResolvedMapping(m, tuple(segs), np.array(carriers), np.array(prox), np.array(dist), massless)


def detect_convention_lenient(skeleton: Skeleton) -> SegmentMap:
    """Best-scoring convention even if some carriers are missing (a base for overrides)."""
    return max(CONVENTIONS.values(), key=lambda m: _score(skeleton, m))
