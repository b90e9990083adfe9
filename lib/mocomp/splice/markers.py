"""The four hand markers of dissertation ch. 6 (two on the wrist, one on the
forearm, one on the hand), the shoulder and the trunk heading, for one arm.

They come either from optical markers (:class:`mocomp.io.markers.Markers`, e.g.
a Vicon Plug-in-Gait C3D: ``RWRA``, ``RWRB``, ``RFRM``, ``RFIN``, ``RSHO``) or,
for skeleton data, from *virtual markers* rigidly attached to the forearm and
hand bones (:func:`virtual_hand_markers`).

Marker order (``p1 .. p4`` of eq. 6.8): wrist A (radial), wrist B (ulnar),
forearm, hand.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import PchipInterpolator

from ..core.motion import Motion
from ..core.rotations import quat_apply
from ..errors import AlignmentError, MotionFormatError

__all__ = [
    "HandMarkers",
    "MARKER_ROLES",
    "ArmJoints",
    "find_arm_joints",
    "virtual_hand_markers",
    "hand_markers_from_markers",
    "heading_angle",
    "forearm_frame",
]

#: roles of the four markers, in the order p1..p4 of eq. 6.8
MARKER_ROLES = ("wrist_a", "wrist_b", "forearm", "hand")


def heading_angle(v: np.ndarray) -> np.ndarray:
    """Angle ``psi`` of the horizontal projection of ``v (..., 3)`` such that the
    rotation ``R_y(theta)`` of eq. 6.6 turns ``psi`` into ``psi + theta``.

    ``R_y(theta) = [[c, 0, s], [0, 1, 0], [-s, 0, c]]`` maps ``(1, 0, 0)`` to
    ``(c, 0, -s)``, so ``psi = atan2(-v_z, v_x)``.
    """
    v = np.asarray(v, dtype=float)
    return np.arctan2(-v[..., 2], v[..., 0])


def forearm_frame(positions: np.ndarray, source=None) -> tuple[np.ndarray, np.ndarray]:
    """The distal forearm's own frame from the markers p1..p3 ``(T, 4, 3)``.

    Origin the wrist centre ``c = (p1 + p2)/2``; axes ``e1`` along the eq. 6.8
    forearm vector ``f = p3 - c``, ``e2`` the wrist axis ``p1 - p2`` made
    orthogonal to ``e1``, ``e3 = e1 x e2``. Returns ``c (T, 3)`` and
    ``R (T, 3, 3)`` with the axes as columns (world = ``c + R local``). It
    depends on the forearm alone, not on the shoulder or the heading, so a
    hand-only capture can be expressed in it. Raises
    :class:`~mocomp.errors.AlignmentError` naming the first frame where the
    wrist axis is (nearly) parallel to the forearm.
    """
    P = np.asarray(positions, dtype=float)
    c = 0.5 * (P[:, 0] + P[:, 1])
    f = P[:, 2] - c
    w = P[:, 0] - P[:, 1]
    nf = np.linalg.norm(f, axis=1)
    e1 = f / np.maximum(nf, 1e-300)[:, None]
    w = w - np.sum(w * e1, axis=1, keepdims=True) * e1
    nw = np.linalg.norm(w, axis=1)
    bad = (nf < 1e-6) | (nw < 1e-3 * np.maximum(np.linalg.norm(P[:, 0] - P[:, 1], axis=1), 1e-300)) | (nw < 1e-6)
    if np.any(bad):
        t = int(np.argmax(bad))
        raise AlignmentError(
            f"frame {t}: the wrist markers' axis (p1 - p2) is parallel to the forearm vector (p3 - wrist centre) or a "
            f"vector has zero length, so the forearm frame is undefined" + (f" ({source})" if source else "")
        )
    e2 = w / nw[:, None]
    e3 = np.cross(e1, e2)
    return c, np.stack([e1, e2, e3], axis=2)


@dataclass(frozen=True, eq=False)
class HandMarkers:
    """Hand markers of one arm over time (world, y-up, metres).

    Attributes
    ----------
    positions: ``(T, 4, 3)`` the markers p1..p4 (:data:`MARKER_ROLES`).
    fps: frames per second.
    shoulder: ``(T, 3)`` shoulder position subtracted before the sign metric
        (eq. 6.6 text), or ``None`` (e.g. a hand-only capture with a static body).
    trunk_heading: ``(T,)`` radians, heading of the trunk's left-right axis
        (:func:`heading_angle`), for the trunk-angle variant of ``theta``, or ``None``.
    side: ``"right"`` or ``"left"``.
    labels: the source names of the four markers (or joints they hang from).
    source: file path or description.
    virtual: True for markers computed from a skeleton.
    notes: what the constructor did (filled gaps, chosen joints, ...).
    """

    positions: np.ndarray
    fps: float
    shoulder: np.ndarray | None = None
    trunk_heading: np.ndarray | None = None
    side: str = "right"
    labels: tuple[str, ...] = MARKER_ROLES
    source: str | None = None
    virtual: bool = False
    notes: tuple[str, ...] = ()
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        P = np.array(self.positions, dtype=float, copy=True)
        if P.ndim != 3 or P.shape[1:] != (4, 3):
            raise MotionFormatError(f"hand markers must be (T, 4, 3), got {P.shape}", self.source)
        T = P.shape[0]
        if not np.all(np.isfinite(P)):
            t, k = np.argwhere(~np.all(np.isfinite(P), axis=2))[0]
            raise MotionFormatError(
                f"hand marker {self.labels[k]!r} ({MARKER_ROLES[k]}) is missing at frame {t}; fill gaps first", self.source
            )
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise MotionFormatError(f"fps must be positive, got {self.fps}", self.source)
        P.setflags(write=False)
        object.__setattr__(self, "positions", P)
        object.__setattr__(self, "fps", float(self.fps))
        for name, shape in (("shoulder", (T, 3)), ("trunk_heading", (T,))):
            v = getattr(self, name)
            if v is None:
                continue
            v = np.array(v, dtype=float, copy=True)
            if v.shape != shape:
                raise MotionFormatError(f"{name} must have shape {shape}, got {v.shape}", self.source)
            if not np.all(np.isfinite(v)):
                raise MotionFormatError(f"{name} has non-finite values (frame {int(np.argwhere(~np.isfinite(v))[0, 0])})", self.source)
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        if self.side not in ("right", "left"):
            raise ValueError(f"side must be 'right' or 'left', got {self.side!r}")
        object.__setattr__(self, "labels", tuple(self.labels))

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    def __len__(self) -> int:
        return self.n_frames

    @property
    def relative(self) -> np.ndarray:
        """``(T, 4, 3)`` markers minus the shoulder (the arm's own movement; eq. 6.6 text)."""
        if self.shoulder is None:
            return self.positions
        return self.positions - self.shoulder[:, None, :]

    def __getitem__(self, index: slice) -> "HandMarkers":
        if not isinstance(index, slice):
            raise TypeError("HandMarkers supports frame slices, e.g. hm[10:50]")
        start, stop, step = index.indices(self.n_frames)
        if step != 1:
            raise ValueError("HandMarkers slices must have step 1")
        return HandMarkers(
            self.positions[index], self.fps,
            None if self.shoulder is None else self.shoulder[index],
            None if self.trunk_heading is None else self.trunk_heading[index],
            self.side, self.labels, self.source, self.virtual, self.notes,
        )

    def sample(self, frames: np.ndarray) -> "HandMarkers":
        """Markers at fractional frame numbers (linear interpolation; headings unwrapped)."""
        from .dtw import warp_values

        f = np.asarray(frames, dtype=float)
        head = None
        if self.trunk_heading is not None:
            head = warp_values(np.unwrap(self.trunk_heading), f)
        return HandMarkers(
            warp_values(self.positions, f), self.fps,
            None if self.shoulder is None else warp_values(self.shoulder, f), head,
            self.side, self.labels, self.source, self.virtual, self.notes,
        )

    def resample(self, fps: float) -> "HandMarkers":
        """The same recording at another frame rate (linear interpolation)."""
        n = int(np.floor((self.n_frames - 1) * fps / self.fps + 1e-9)) + 1
        out = self.sample(np.minimum(np.arange(n) * self.fps / fps, self.n_frames - 1))
        return HandMarkers(out.positions, fps, out.shoulder, out.trunk_heading, self.side, self.labels,
                           self.source, self.virtual, self.notes + (f"resampled {self.fps:g} -> {fps:g} fps",))


# ----------------------------------------------------------------- skeletons
@dataclass(frozen=True)
class ArmJoints:
    """Joint indices of one arm: clavicle (may be None), upper arm (shoulder
    joint), forearm (elbow joint), hand (wrist joint); plus both shoulders for
    the trunk heading."""

    side: str
    clavicle: int | None
    upper: int
    forearm: int
    hand: int
    left_upper: int | None = None
    right_upper: int | None = None
    names: tuple[str, ...] = ()


# (clavicle, upper arm, forearm, hand) name templates; {S} is replaced by the side token
_CONVENTIONS = (
    (("Shoulder_{S}", "UpperArm_{S}", "LowerArm_{S}", "Hand_{S}"), {"right": "R", "left": "L"}),  # Bandai Namco
    (("{S}Shoulder", "{S}Arm", "{S}ForeArm", "{S}Hand"), {"right": "Right", "left": "Left"}),  # CMU / MotionBuilder BVH
    (("{S}Collar", "{S}Shoulder", "{S}Elbow", "{S}Wrist"), {"right": "Right", "left": "Left"}),  # SFU / 3ds Max BVH
    (("{S}clavicle", "{S}humerus", "{S}radius", "{S}wrist"), {"right": "r", "left": "l"}),  # ASF/AMC (CMU, HDM05)
    (("{S}_clavicle", "{S}_shoulder", "{S}_elbow", "{S}_wrist"), {"right": "right", "left": "left"}),  # DeepMimic-like
    (("{S}_collar", "{S}_shoulder", "{S}_elbow", "{S}_wrist"), {"right": "R", "left": "L"}),
    (("Character1_{S}Shoulder", "Character1_{S}Arm", "Character1_{S}ForeArm", "Character1_{S}Hand"), {"right": "Right", "left": "Left"}),  # MASS
)


def find_arm_joints(skeleton, side: str = "right", joints: dict | None = None) -> ArmJoints:
    """Locate the arm joints by known naming conventions (Bandai, CMU, SFU, ASF,
    MASS); ``joints={"clavicle": ..., "upper": ..., "forearm": ..., "hand": ...}``
    overrides. Raises :class:`~mocomp.errors.MotionFormatError` listing the
    arm-like joints when nothing matches."""
    if side not in ("right", "left"):
        raise ValueError(f"side must be 'right' or 'left', got {side!r}")
    other = "left" if side == "right" else "right"
    found = None
    if joints:
        need = ("upper", "forearm", "hand")
        missing = [k for k in need if k not in joints]
        if missing:
            raise ValueError(f"joints= needs keys {need} (and optionally 'clavicle'); missing {missing}")
        for k, v in joints.items():
            if v is not None and v not in skeleton:
                raise MotionFormatError(f"joint {v!r} ({k}) is not in the skeleton; joints: {skeleton.names}")
        found = (joints.get("clavicle"), joints["upper"], joints["forearm"], joints["hand"])
        # the other arm's upper-arm joint by the known conventions, for the trunk heading
        other_upper = next((t[1].format(S=tk[other]) for t, tk in _CONVENTIONS if t[1].format(S=tk[other]) in skeleton), None)
        pair = (other_upper, joints["upper"]) if side == "right" else (joints["upper"], other_upper)
        lu = None if pair[0] is None else skeleton.find(pair[0])
        ru = None if pair[1] is None else skeleton.find(pair[1])
    else:
        for templates, tokens in _CONVENTIONS:
            names = [t.format(S=tokens[side]) for t in templates]
            if all(n in skeleton for n in names[1:]):
                found = (names[0] if names[0] in skeleton else None, *names[1:])
                other_upper = templates[1].format(S=tokens[other])
                lu_name, ru_name = (other_upper, names[1]) if side == "right" else (names[1], other_upper)
                lu = skeleton.find(lu_name)
                ru = skeleton.find(ru_name)
                break
        if found is None:
            armlike = [n for n in skeleton.names if re.search(r"arm|hand|wrist|elbow|shoulder|humerus|radius|clav", n, re.I)]
            raise MotionFormatError(
                f"cannot find the {side} arm joints (clavicle, upper arm, forearm, hand) by name; arm-like joints: "
                f"{armlike or skeleton.names}; pass joints={{'upper': ..., 'forearm': ..., 'hand': ...}}"
            )
    idx = [None if n is None else skeleton.index(n) for n in found]
    up, fa, hd = idx[1], idx[2], idx[3]
    if skeleton.parents[hd] != fa or skeleton.parents[fa] != up:
        raise MotionFormatError(
            f"arm joints {found[1:]} must form a chain upper arm -> forearm -> hand in the skeleton"
        )
    return ArmJoints(side, idx[0], up, fa, hd, lu, ru, tuple(n for n in found if n is not None))


def _unit(v):
    n = np.linalg.norm(v)
    if n < 1e-9:
        raise MotionFormatError("zero-length bone where a direction is needed for virtual markers")
    return v / n


def virtual_hand_markers(motion: Motion, side: str = "right", joints: dict | None = None, *,
                         wrist_halfwidth: float = 0.12, forearm_offset: float = 0.15,
                         hand_length: float | None = None, noise: float = 0.0, rng=None) -> HandMarkers:
    """Virtual markers rigidly attached to the forearm and hand bones of a skeleton.

    In the rest pose (all local rotations identity) every joint frame is
    aligned with the world, so marker offsets are built there and carried by
    the bones' global rotations. With forearm length ``L`` (elbow to wrist),
    forearm axis ``u``, a horizontal axis ``v`` across the wrist and
    ``w = u x v``:

    * p1, p2 (wrist A/B) = wrist ``+- wrist_halfwidth L v``, on the forearm bone
      (like Plug-in-Gait ``WRA``/``WRB``, which sit on the distal radius/ulna);
    * p3 (forearm) = elbow ``+ 0.5 L u + forearm_offset L w``, on the forearm bone;
    * p4 (hand) = wrist ``+ hand_length u_h + 0.1 L w``, on the hand bone, with
      ``u_h`` the hand's axis (towards its child or end site) and
      ``hand_length`` defaulting to the hand bone's length or ``0.35 L``.

    The shoulder is the upper-arm joint; the trunk heading is that of the
    left-to-right shoulder line (both upper-arm joints). ``noise`` adds white
    Gaussian noise (metres) to the markers, drawn from ``rng`` (seeded).
    """
    sk = motion.skeleton
    arm = find_arm_joints(sk, side, joints)
    L = float(np.linalg.norm(sk.offsets[arm.hand]))
    u = _unit(sk.offsets[arm.hand])
    up = np.array([0.0, 1.0, 0.0])
    ref = up if abs(u @ up) < 0.9 else np.array([0.0, 0.0, 1.0])
    v = _unit(np.cross(u, ref))
    w = np.cross(u, v)
    # hand axis: the longest child offset or end-site offset of the hand joint
    cands = [sk.offsets[c] for c in sk.children(arm.hand)] + [e.offset for e in sk.end_sites if e.parent == arm.hand]
    cands = [c for c in cands if np.linalg.norm(c) > 1e-6]
    if cands:
        c = max(cands, key=np.linalg.norm)
        u_h = _unit(c)
        hl = float(np.linalg.norm(c)) if hand_length is None else float(hand_length)
        hl = min(hl, 0.6 * L) if hand_length is None else hl
    else:
        u_h = u
        hl = 0.35 * L if hand_length is None else float(hand_length)
    local = {
        "wrist_a": (arm.forearm, L * u + wrist_halfwidth * L * v),
        "wrist_b": (arm.forearm, L * u - wrist_halfwidth * L * v),
        "forearm": (arm.forearm, 0.5 * L * u + forearm_offset * L * w),
        "hand": (arm.hand, hl * u_h + 0.1 * L * w),
    }
    P, G = motion.fk()
    pos = np.stack([P[:, j] + quat_apply(G[:, j], off) for j, off in (local[r] for r in MARKER_ROLES)], axis=1)
    if noise:
        rng = np.random.default_rng(rng)
        pos = pos + rng.normal(scale=noise, size=pos.shape)
    heading = None
    if arm.left_upper is not None and arm.right_upper is not None:
        heading = heading_angle(P[:, arm.left_upper] - P[:, arm.right_upper])
    names = sk.names
    labels = (f"{names[arm.forearm]}:wrist_a", f"{names[arm.forearm]}:wrist_b", f"{names[arm.forearm]}:forearm", f"{names[arm.hand]}:hand")
    return HandMarkers(
        pos, motion.fps, P[:, arm.upper].copy(), heading, side, labels,
        source=motion.source.path or motion.source.format, virtual=True,
        notes=(f"virtual markers on {names[arm.forearm]!r}/{names[arm.hand]!r}, forearm {L:.3f} m, hand marker {hl:.3f} m from the wrist",),
    )


# ------------------------------------------------------------------ markers
_PLUG_IN_GAIT = {
    "right": ("RWRA", "RWRB", "RFRM", "RFIN", "RSHO"),
    "left": ("LWRA", "LWRB", "LFRM", "LFIN", "LSHO"),
}
_WAIST = (("LFWT", "LBWT"), ("RFWT", "RBWT"))


def _lookup(markers, name: str) -> int | None:
    """Marker index by exact name or by name after a ``Subject:`` prefix."""
    if name in markers.names:
        return markers.names.index(name)
    hits = [k for k, n in enumerate(markers.names) if n.split(":")[-1] == name]
    if len(hits) > 1:
        raise MotionFormatError(f"marker name {name!r} is ambiguous: {[markers.names[k] for k in hits]}", markers.source)
    return hits[0] if hits else None


def _fill_gaps(x: np.ndarray, mask: np.ndarray, max_gap: int, label: str, source) -> tuple[np.ndarray, int]:
    """Fill gaps of at most ``max_gap`` frames by shape-preserving (PCHIP) interpolation."""
    if mask.all():
        return x, 0
    T = len(mask)
    good = np.nonzero(mask)[0]
    if good.size < 2:
        raise MotionFormatError(f"marker {label!r} is visible in {good.size} frame(s) only", source)
    bad = ~mask
    edges = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    for s, e in zip(starts, stops):
        if s == 0 or e == T:
            raise MotionFormatError(f"marker {label!r} is missing at the {'start' if s == 0 else 'end'} of the clip (frames {s}-{e - 1}); trim the clip", source)
        if e - s > max_gap:
            raise MotionFormatError(f"marker {label!r} has a gap of {e - s} frames ({s}-{e - 1}); at most {max_gap} are filled", source)
    f = PchipInterpolator(good, x[good], axis=0)
    out = np.array(x, copy=True)
    out[bad] = f(np.nonzero(bad)[0])
    return out, int(bad.sum())


def hand_markers_from_markers(markers, side: str = "right", names: tuple[str, ...] | None = None, *,
                              shoulder: str | None = "auto", trunk: str = "auto", max_gap: int | None = None) -> HandMarkers:
    """The four hand markers (and shoulder, trunk heading) from optical marker data.

    ``names`` = (wrist A, wrist B, forearm, hand[, shoulder]) labels; default the
    Vicon Plug-in-Gait set ``RWRA RWRB RFRM RFIN RSHO`` (left: ``L...``), matched
    with or without a ``Subject:`` prefix. A shoulder named in ``names`` (or
    by ``shoulder=``) must exist; the default one (``shoulder="auto"``) is
    optional: without it ``shoulder`` is ``None`` (a hand-only capture; noted). The trunk heading comes from the waist
    markers ``(LFWT+LBWT)/2 - (RFWT+RBWT)/2`` or else ``LSHO - RSHO``. Gaps of
    at most ``max_gap`` frames (default 0.1 s) are filled by PCHIP interpolation
    (reported in ``notes``); longer gaps raise
    :class:`~mocomp.errors.MotionFormatError` naming the marker and frames.
    """
    if side not in ("right", "left"):
        raise ValueError(f"side must be 'right' or 'left', got {side!r}")
    # the default set's shoulder is optional (a hand-only capture has none): as with shoulder="auto"
    labels = tuple(names) if names is not None else _PLUG_IN_GAIT[side][:4]
    if len(labels) not in (4, 5):
        raise ValueError(f"names must list 4 hand markers and optionally the shoulder marker, got {labels}")
    sh_label = labels[4] if len(labels) == 5 else (None if shoulder in (None, "auto") else shoulder)
    if len(labels) == 4 and shoulder == "auto":
        sh_label = _PLUG_IN_GAIT[side][4]
    max_gap = int(round(0.1 * markers.fps)) if max_gap is None else int(max_gap)
    idx = []
    missing = []
    for lab in labels[:4]:
        k = _lookup(markers, lab)
        (missing.append(lab) if k is None else idx.append(k))
    if missing:
        raise MotionFormatError(
            f"hand markers {missing} not found; markers in the file: {list(markers.names)}", markers.source
        )
    notes = []
    cols = []
    for lab, k in zip(labels[:4], idx):
        x, nfill = _fill_gaps(markers.positions[:, k], markers.mask[:, k], max_gap, lab, markers.source)
        if nfill:
            notes.append(f"filled {nfill} missing frame(s) of {lab}")
        cols.append(x)
    pos = np.stack(cols, axis=1)
    sh = None
    if sh_label is not None:
        k = _lookup(markers, sh_label)
        if k is None:
            if shoulder != "auto" or len(labels) == 5:
                raise MotionFormatError(f"shoulder marker {sh_label!r} not found; markers: {list(markers.names)}", markers.source)
            notes.append(f"no shoulder marker {sh_label!r}: markers are used without subtracting the shoulder")
        else:
            sh, nfill = _fill_gaps(markers.positions[:, k], markers.mask[:, k], max_gap, sh_label, markers.source)
    heading = None
    if trunk != "none":
        lw = [_lookup(markers, n) for n in _WAIST[0]]
        rw = [_lookup(markers, n) for n in _WAIST[1]]
        if all(k is not None for k in lw + rw):
            P = np.stack([_fill_gaps(markers.positions[:, k], markers.mask[:, k], max_gap, markers.names[k], markers.source)[0] for k in lw + rw], axis=1)
            heading = heading_angle(0.5 * (P[:, 0] + P[:, 1]) - 0.5 * (P[:, 2] + P[:, 3]))
            notes.append("trunk heading from the waist markers")
        else:
            ls, rs = _lookup(markers, "LSHO"), _lookup(markers, "RSHO")
            if ls is not None and rs is not None:
                P = np.stack([_fill_gaps(markers.positions[:, k], markers.mask[:, k], max_gap, markers.names[k], markers.source)[0] for k in (ls, rs)], axis=1)
                heading = heading_angle(P[:, 0] - P[:, 1])
                notes.append("trunk heading from the shoulder markers")
    return HandMarkers(pos, markers.fps, sh, heading, side, tuple(markers.names[k] for k in idx),
                       source=markers.source, virtual=False, notes=tuple(notes))


def require_frames(hm: HandMarkers, need: int, what: str, role: str):
    """Raise :class:`AlignmentError` if a sequence is shorter than ``need`` frames."""
    if hm.n_frames < need:
        raise AlignmentError(f"the {role} motion has {hm.n_frames} frames; {what} needs at least {need}")
