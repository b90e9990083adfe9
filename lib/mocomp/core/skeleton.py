"""The immutable skeleton description: joint names, hierarchy, offsets, channels."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import MotionFormatError

__all__ = ["Skeleton", "EndSite", "RemovedRoot"]

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
JOINT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
_VALID_CHANNELS = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"}


def _frozen(a, dtype=float) -> np.ndarray:
    a = np.array(a, dtype=dtype, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class EndSite:
    """A BVH ``End Site``: a point fixed in its parent joint's frame.

    Attributes
    ----------
    parent: index of the joint it hangs from.
    offset: ``(3,)`` metres, in the parent's local frame.
    name: a readable name (``"<parent>_end"`` unless the file names it).
    """

    parent: int
    offset: np.ndarray
    name: str

    def __post_init__(self):
        object.__setattr__(self, "offset", _frozen(np.reshape(self.offset, 3)))


_POSITIONS = ("Xposition", "Yposition", "Zposition")
_ROTATIONS = ("Xrotation", "Yrotation", "Zrotation")


@dataclass(frozen=True, eq=False)
class RemovedRoot:
    """A static BVH root joint that the reader folded into its only child.

    The Bandai Namco files put a ``joint_Root`` (offset 0, six channels, all zero)
    above ``Hips``, whose position channels carry the root motion. The BVH reader
    removes it (the loaded skeleton is rooted at ``Hips``) and keeps this record so
    that :func:`mocomp.io.write_bvh` writes the file's hierarchy and channel layout
    again. Any constant root transform reproduces every joint position exactly: the
    writer puts the remaining motion into the child's channels.

    Attributes
    ----------
    name: the removed joint's name (``"joint_Root"``).
    offset: ``(3,)`` metres, its ``OFFSET``.
    channels: its channel names as loaded, e.g. ``("Xposition", ..., "Yrotation")``.
    values: ``(len(channels),)`` its channel values on the first frame, in channel
        order: positions in metres, rotations in degrees (the writer repeats them on
        every frame).
    child_offset: ``(3,)`` metres, the ``OFFSET`` line of the child that became the
        root (BVH readers ignore it: the child's position channels replace it).
    constant: whether the file's values were the same on every frame (``False``
        for a root that moved; the joint positions are reproduced either way).
    """

    name: str
    offset: np.ndarray
    channels: tuple[str, ...]
    values: np.ndarray
    child_offset: np.ndarray
    constant: bool = True

    def __post_init__(self):
        chans = tuple(str(c) for c in self.channels)
        bad = [c for c in chans if c not in _VALID_CHANNELS]
        if bad or len(set(chans)) != len(chans):
            raise MotionFormatError(f"removed root {self.name!r}: bad channel list {chans}")
        values = _frozen(np.reshape(self.values, -1))
        if values.shape != (len(chans),):
            raise MotionFormatError(
                f"removed root {self.name!r}: {values.size} channel values for {len(chans)} channels")
        offset = _frozen(np.reshape(self.offset, 3))
        child = _frozen(np.reshape(self.child_offset, 3))
        if not (np.all(np.isfinite(values)) and np.all(np.isfinite(offset)) and np.all(np.isfinite(child))):
            raise MotionFormatError(f"removed root {self.name!r}: non-finite offset or channel value")
        object.__setattr__(self, "name", str(self.name))
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "offset", offset)
        object.__setattr__(self, "child_offset", child)
        object.__setattr__(self, "constant", bool(self.constant))

    def scaled(self, factor: float) -> "RemovedRoot":
        """A copy with lengths (offsets, position values) multiplied by ``factor``."""
        f = np.array([factor if c in _POSITIONS else 1.0 for c in self.channels])
        return RemovedRoot(self.name, self.offset * factor, self.channels, self.values * f,
                           self.child_offset * factor, self.constant)

    def transform(self) -> tuple[np.ndarray, np.ndarray]:
        """The removed joint's global ``(position (3,), unit quaternion (4,))``: its
        offset plus its position channels, and the rotation of its rotation channels
        (intrinsic, in channel order, as a BVH reader composes them)."""
        from scipy.spatial.transform import Rotation

        from .rotations import euler_sequence

        pos = np.array(self.offset, dtype=float)
        for c, v in zip(self.channels, self.values):
            if c in _POSITIONS:
                pos[_POSITIONS.index(c)] += v
        rot_ch = [c for c in self.channels if c in _ROTATIONS]
        if not rot_ch:
            return pos, np.array([0.0, 0.0, 0.0, 1.0])
        angles = [v for c, v in zip(self.channels, self.values) if c in _ROTATIONS]
        return pos, Rotation.from_euler(euler_sequence(rot_ch), angles, degrees=True).as_quat()


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A kinematic tree in its rest pose (all local rotations identity).

    Attributes
    ----------
    names: ``(J,)`` joint names, unique; joint 0 is the root.
    parents: ``(J,)`` int parent index, ``-1`` for the root; parents precede children.
    offsets: ``(J, 3)`` metres, each joint's position in its parent's frame
        (the root's offset is added to the root translation, as in BVH).
    channels: per joint, the channel names as loaded (BVH spelling, e.g.
        ``("Zrotation", "Xrotation", "Yrotation")``); BVH export reproduces them.
    end_sites: the end sites (leaf points), for body-segment lengths and drawing.
    removed_root: the static root joint the BVH reader removed above joint 0
        (:class:`RemovedRoot`, e.g. Bandai's ``joint_Root``), re-emitted by the BVH
        writer; ``None`` for every other skeleton. Not part of equality: it
        changes no joint position.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...] = None  # type: ignore[assignment]
    end_sites: tuple[EndSite, ...] = ()
    removed_root: RemovedRoot | None = None
    _index: dict = field(default=None, repr=False, compare=False)  # type: ignore[assignment]

    def __post_init__(self):
        names = tuple(str(n) for n in self.names)
        parents = _frozen(self.parents, dtype=np.int64).reshape(-1)
        offsets = _frozen(self.offsets).reshape(-1, 3) if len(names) else _frozen(np.zeros((0, 3)))
        J = len(names)
        if J == 0:
            raise MotionFormatError("a skeleton needs at least one joint")
        if parents.shape != (J,) or offsets.shape != (J, 3):
            raise MotionFormatError(
                f"skeleton arrays disagree: {J} names, parents {parents.shape}, offsets {offsets.shape}"
            )
        if parents[0] != -1:
            raise MotionFormatError(f"joint 0 ({names[0]!r}) must be the root (parent -1), got parent {parents[0]}")
        for j in range(1, J):
            if not (0 <= parents[j] < j):
                raise MotionFormatError(
                    f"joint {j} ({names[j]!r}) has parent index {parents[j]}; parents must precede children"
                )
        seen: dict[str, int] = {}
        for j, n in enumerate(names):
            if n in seen:
                raise MotionFormatError(f"duplicate joint name {n!r} (joints {seen[n]} and {j})")
            seen[n] = j
        if not np.all(np.isfinite(offsets)):
            bad = int(np.argwhere(~np.isfinite(offsets))[0, 0])
            raise MotionFormatError(f"joint {names[bad]!r} has a non-finite offset {offsets[bad].tolist()}")
        chans = self.channels
        if chans is None:
            chans = tuple(ROOT_CHANNELS if j == 0 else JOINT_CHANNELS for j in range(J))
        chans = tuple(tuple(c) for c in chans)
        if len(chans) != J:
            raise MotionFormatError(f"{len(chans)} channel lists for {J} joints")
        for j, c in enumerate(chans):
            bad = [x for x in c if x not in _VALID_CHANNELS]
            if bad:
                raise MotionFormatError(f"joint {names[j]!r} has unknown channel(s) {bad}")
            if len(set(c)) != len(c):
                raise MotionFormatError(f"joint {names[j]!r} repeats a channel: {c}")
        for e in self.end_sites:
            if not (0 <= e.parent < J):
                raise MotionFormatError(f"end site {e.name!r} hangs from joint index {e.parent}, out of range")
            if not np.all(np.isfinite(e.offset)):
                raise MotionFormatError(f"end site {e.name!r} has a non-finite offset {e.offset.tolist()}")
        if self.removed_root is not None:
            if not isinstance(self.removed_root, RemovedRoot):
                raise MotionFormatError(f"removed_root must be a RemovedRoot, got {type(self.removed_root).__name__}")
            if self.removed_root.name in seen:
                raise MotionFormatError(f"removed root {self.removed_root.name!r} is also a joint of the skeleton")
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "end_sites", tuple(self.end_sites))
        object.__setattr__(self, "_index", seen)

    # ------------------------------------------------------------------ lookup
    @property
    def n_joints(self) -> int:
        return len(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of the joint called ``name``; ``KeyError`` lists near names."""
        try:
            return self._index[name]
        except KeyError:
            close = [n for n in self.names if name.lower() in n.lower() or n.lower() in name.lower()]
            raise KeyError(f"no joint {name!r} in skeleton; similar: {close[:5] or 'none'}") from None

    def find(self, name: str) -> int | None:
        """Index of ``name`` or ``None``."""
        return self._index.get(name)

    def __contains__(self, name: str) -> bool:
        return name in self._index

    def children(self, j: int) -> list[int]:
        return [int(c) for c in np.nonzero(self.parents == j)[0]]

    def chain(self, j: int) -> list[int]:
        """Joint indices from the root down to ``j`` inclusive."""
        out = []
        while j >= 0:
            out.append(j)
            j = int(self.parents[j])
        return out[::-1]

    # ------------------------------------------------------------- rest pose
    def rest_positions(self, include_end_sites: bool = False) -> np.ndarray:
        """Joint (and optionally end-site) positions in the rest pose, root at its offset."""
        pos = np.zeros((self.n_joints, 3))
        for j in range(self.n_joints):
            p = self.parents[j]
            pos[j] = self.offsets[j] + (pos[p] if p >= 0 else 0.0)
        if include_end_sites and self.end_sites:
            ends = np.array([pos[e.parent] + e.offset for e in self.end_sites])
            pos = np.concatenate([pos, ends])
        return pos

    def height(self) -> float:
        """Standing-height estimate in metres: vertical (y) extent of the rest pose.

        Uses joints and end sites (the head end site stands in for the top of the
        head). For a T-pose or an A-pose this is close to body height minus the
        scalp above the head end and the sole below the ankle/toe markers.
        """
        p = self.rest_positions(include_end_sites=True)
        return float(p[:, 1].max() - p[:, 1].min())

    def bone_lengths(self) -> np.ndarray:
        """``(J,)`` length of the offset from each joint's parent (root: 0)."""
        lengths = np.linalg.norm(self.offsets, axis=1)
        lengths[0] = 0.0
        return lengths

    # -------------------------------------------------------------- editing
    def scaled(self, factor: float) -> "Skeleton":
        """A copy with every offset multiplied by ``factor``."""
        return Skeleton(
            self.names,
            self.parents,
            self.offsets * factor,
            self.channels,
            tuple(EndSite(e.parent, e.offset * factor, e.name) for e in self.end_sites),
            None if self.removed_root is None else self.removed_root.scaled(factor),
        )

    def with_channels(self, channels) -> "Skeleton":
        return Skeleton(self.names, self.parents, self.offsets, channels, self.end_sites, self.removed_root)

    def without_removed_root(self) -> "Skeleton":
        """The same skeleton with no :attr:`removed_root` (BVH export then starts at joint 0)."""
        return Skeleton(self.names, self.parents, self.offsets, self.channels, self.end_sites)

    def mirror_map(self) -> np.ndarray:
        """``(J,)`` index of each joint's left/right counterpart (itself if none).

        Recognises ``Left``/``Right``, ``left``/``right``, ``L``/``R`` prefixes and
        ``_l``/``_r`` suffixes, as used by CMU, SFU, Bandai and DeepMimic names.
        """
        pairs = [("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT")]
        out = np.arange(self.n_joints)
        for j, n in enumerate(self.names):
            cands = []
            for a, b in pairs:
                if a in n:
                    cands.append(n.replace(a, b))
                if b in n:
                    cands.append(n.replace(b, a))
            if n[:1] in ("l", "r", "L", "R") and len(n) > 1:  # existence is checked below (ASF: lfemur/rfemur)
                swap = {"l": "r", "r": "l", "L": "R", "R": "L"}[n[0]]
                cands.append(swap + n[1:])
            for suf_a, suf_b in (("_l", "_r"), ("_L", "_R")):
                if n.endswith(suf_a):
                    cands.append(n[: -len(suf_a)] + suf_b)
                if n.endswith(suf_b):
                    cands.append(n[: -len(suf_b)] + suf_a)
            for c in cands:
                k = self._index.get(c)
                if k is not None:
                    out[j] = k
                    break
        return out

    def __eq__(self, other) -> bool:
        if not isinstance(other, Skeleton):
            return NotImplemented
        return (
            self.names == other.names
            and np.array_equal(self.parents, other.parents)
            and np.allclose(self.offsets, other.offsets, atol=1e-9)
        )

    def __hash__(self) -> int:
        return hash((self.names, self.parents.tobytes(), np.round(self.offsets, 9).tobytes()))

    def __repr__(self) -> str:
        return f"Skeleton({self.n_joints} joints, root={self.names[0]!r}, height={self.height():.3f} m)"
