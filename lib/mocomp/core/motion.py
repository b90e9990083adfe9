"""The immutable ``Motion`` value: a skeleton animated over uniformly spaced frames."""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..errors import MotionFormatError
from .kinematics import end_site_positions, forward_kinematics
from .rotations import make_continuous, quat_multiply, slerp
from .skeleton import EndSite, Skeleton

__all__ = ["Motion", "SourceInfo", "slerp", "concatenate"]


@dataclass(frozen=True)
class SourceInfo:
    """Where a motion came from and what the loader did to it.

    Attributes
    ----------
    path: file it was read from (``None`` for generated motions).
    format: ``"bvh"``, ``"asf/amc"``, ``"deepmimic"``, ``"synthetic"``, ...
    unit_scale: metres per file length unit that the loader applied.
    unit_reason: how that scale was chosen (explicit, known format, guessed from height).
    header_fps: the frame rate the file stated (may differ from ``Motion.fps``
        when the caller overrode a wrong header).
    notes: free-form remarks from the loader (e.g. a T-pose first frame).
    """

    path: str | None = None
    format: str = "unknown"
    unit_scale: float = 1.0
    unit_reason: str = "metres"
    header_fps: float | None = None
    notes: tuple[str, ...] = ()


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Motion:
    """A skeleton animated at a constant frame rate. Immutable: edits return new motions.

    Attributes
    ----------
    skeleton: the :class:`Skeleton`.
    fps: frames per second (> 0).
    root_positions: ``(T, 3)`` world position of the root joint, metres.
    rotations: ``(T, J, 4)`` local joint rotations, unit quaternions,
        scipy scalar-last ``(x, y, z, w)``; the root's is its world orientation.
    source: provenance and loader decisions (:class:`SourceInfo`).

    The world is y-up. Frame ``i`` is at time ``i / fps``.
    """

    skeleton: Skeleton
    fps: float
    root_positions: np.ndarray
    rotations: np.ndarray
    source: SourceInfo = field(default_factory=SourceInfo)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        rp = _frozen(self.root_positions)
        rot = np.array(self.rotations, dtype=float, copy=True)
        J = self.skeleton.n_joints
        if rp.ndim != 2 or rp.shape[1] != 3:
            raise MotionFormatError(f"root_positions must have shape (T, 3), got {rp.shape}")
        T = rp.shape[0]
        if rot.shape != (T, J, 4):
            raise MotionFormatError(f"rotations must have shape ({T}, {J}, 4), got {rot.shape}")
        if T == 0:
            raise MotionFormatError("a motion needs at least one frame")
        try:
            fps = float(self.fps)
        except (TypeError, ValueError):
            fps = float("nan")
        if not (np.isfinite(fps) and fps > 0):
            raise MotionFormatError(f"fps must be a positive finite number, got {self.fps!r}")
        for name, arr in (("root_positions", rp), ("rotations", rot)):
            if not np.all(np.isfinite(arr)):
                bad = np.argwhere(~np.isfinite(arr))[0]
                raise MotionFormatError(f"{name} has a non-finite value at frame {bad[0]}")
        norm = np.sqrt(np.einsum("...i,...i->...", rot, rot))  # 3x faster than linalg.norm on (T, J, 4)
        if np.any(norm < 1e-6):
            t, j = np.argwhere(norm < 1e-6)[0]
            raise MotionFormatError(
                f"rotation of joint {self.skeleton.names[j]!r} at frame {t} is a zero quaternion"
            )
        # Normalise only quaternions that are not already unit (to rounding), so that
        # slicing, concatenating or replacing fields keeps rotations bit for bit.
        off_unit = np.abs(norm - 1.0) > 1e-14
        if off_unit.any():
            rot[off_unit] /= norm[off_unit][:, None]
        rot.setflags(write=False)
        object.__setattr__(self, "root_positions", rp)
        object.__setattr__(self, "rotations", rot)
        object.__setattr__(self, "fps", fps)

    # ------------------------------------------------------------ basic facts
    @property
    def n_frames(self) -> int:
        return self.root_positions.shape[0]

    def __len__(self) -> int:
        return self.n_frames

    @property
    def dt(self) -> float:
        return 1.0 / self.fps

    @property
    def times(self) -> np.ndarray:
        """``(T,)`` frame times in seconds, starting at 0."""
        return np.arange(self.n_frames) / self.fps

    @property
    def duration(self) -> float:
        """Time from the first to the last frame, seconds."""
        return (self.n_frames - 1) / self.fps

    # --------------------------------------------------------------- kinematics
    def _fk(self):
        if "fk" not in self._cache:
            P, G = forward_kinematics(self.skeleton.parents, self.skeleton.offsets, self.root_positions, self.rotations)
            P.setflags(write=False)
            G.setflags(write=False)
            self._cache["fk"] = (P, G)
        return self._cache["fk"]

    def fk(self, frames: slice | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(positions (T, J, 3), global_rotations (T, J, 4))`` by
        :func:`~mocomp.core.kinematics.forward_kinematics`; the whole motion's is computed once and
        cached (read-only arrays).

        ``frames``: a ``slice`` of frames (step 1), e.g. ``slice(a, b)``: only those frames'
        FK, taken from the cache when the whole motion's is there, else computed for those frames
        alone (not cached; the same values as the whole motion's rows, bit for bit). A slice that
        covers every frame fills the cache as ``fk()`` does."""
        if frames is None:
            return self._fk()
        if not isinstance(frames, slice):
            raise TypeError(f"fk(frames=...) takes a slice of frames, got {type(frames).__name__}")
        start, stop, step = frames.indices(self.n_frames)
        if step != 1:
            raise ValueError(f"fk(frames=...) takes a slice with step 1, got step {step}")
        stop = max(stop, start)
        if start == 0 and stop == self.n_frames:
            return self._fk()
        if "fk" in self._cache:
            P, G = self._cache["fk"]
            return P[start:stop], G[start:stop]
        return forward_kinematics(self.skeleton.parents, self.skeleton.offsets, self.root_positions[start:stop],
                                  self.rotations[start:stop])

    @property
    def positions(self) -> np.ndarray:
        """``(T, J, 3)`` global joint positions, metres."""
        return self._fk()[0]

    @property
    def global_rotations(self) -> np.ndarray:
        """``(T, J, 4)`` global joint orientations."""
        return self._fk()[1]

    def end_site_positions(self) -> np.ndarray:
        """``(T, E, 3)`` world positions of the skeleton's end sites."""
        P, G = self._fk()
        return end_site_positions(self.skeleton.end_sites, P, G)

    def joint_positions(self, name: str) -> np.ndarray:
        """``(T, 3)`` world trajectory of one joint."""
        return self.positions[:, self.skeleton.index(name)]

    # ---------------------------------------------------------------- editing
    def replace(self, **changes) -> "Motion":
        """A new motion with some fields replaced (``dataclasses.replace``)."""
        changes.setdefault("_cache", {})
        return dataclasses.replace(self, **changes)

    def replace_trusted(self, root_positions: np.ndarray, rotations: np.ndarray,
                        source: SourceInfo | None = None, *, fk: tuple | None = None) -> "Motion":
        """:meth:`replace` for arrays a library hot path has just made and checked, skipping the
        defensive copy and validation of :meth:`__post_init__` (on a 400-frame flip its norm check
        costs more than the slerp that made the rotations). ``source`` defaults to this motion's.

        ``fk``: optionally the new motion's forward kinematics ``(positions (T, J, 3),
        global_rotations (T, J, 4))`` when the caller derived it exactly from this motion's (e.g. a
        rigid turn per frame: :func:`mocomp.ops.path_edit`); it becomes the cached result of
        :meth:`fk` (frozen here). Shapes are checked; values are the caller's guarantee.

        The caller guarantees what ``__post_init__`` would check: shapes ``(T, 3)`` and
        ``(T, J, 4)`` with ``T > 0``, finite values, and rotations that are unit quaternions to
        rounding (``__post_init__`` would keep those bit for bit). The arrays are frozen here, as
        ``__post_init__`` freezes its own. Keep this next to ``__post_init__``: a new field or
        check there must be mirrored here. Used by the multi-flip run-time stage and the editing
        primitives of :mod:`mocomp.ops`."""
        source = self.source if source is None else source
        T, J = rotations.shape[0], self.skeleton.n_joints
        if fk is not None:
            P, G = fk
            if P.shape != (T, J, 3) or G.shape != (T, J, 4):
                raise ValueError(f"fk shapes {P.shape}, {G.shape} do not match {T} frames x {J} joints")
        if root_positions.shape != (T, 3) or rotations.shape != (T, J, 4) or T == 0:
            new = self.replace(root_positions=root_positions, rotations=rotations, source=source)
            if fk is not None:
                new._set_fk(fk)
            return new
        new = copy.copy(self)                                   # same skeleton and fps
        root_positions.setflags(write=False)
        rotations.setflags(write=False)
        object.__setattr__(new, "root_positions", root_positions)
        object.__setattr__(new, "rotations", rotations)
        object.__setattr__(new, "source", source)
        object.__setattr__(new, "_cache", {})
        if fk is not None:
            new._set_fk(fk)
        return new

    def _set_fk(self, fk) -> None:
        P, G = fk
        P.setflags(write=False)
        G.setflags(write=False)
        self._cache["fk"] = (P, G)

    def __getitem__(self, index) -> "Motion":
        """Frame slicing: ``motion[10:50]`` or ``motion[::2]`` (step changes fps)."""
        if isinstance(index, (int, np.integer)):
            index = slice(int(index), int(index) + 1 if int(index) != -1 else None)
        if not isinstance(index, slice):
            raise TypeError("Motion supports slices of frames, e.g. motion[10:50]")
        start, stop, step = index.indices(self.n_frames)
        if step <= 0:
            raise ValueError("frame slices must have a positive step")
        rp = self.root_positions[start:stop:step]
        if rp.shape[0] == 0:
            raise MotionFormatError(f"empty frame slice {index} of a {self.n_frames}-frame motion")
        return self.replace(root_positions=rp, rotations=self.rotations[start:stop:step], fps=self.fps / step)

    def slice(self, start: int, stop: int | None = None) -> "Motion":
        """Frames ``start`` (inclusive) to ``stop`` (exclusive)."""
        return self[start:stop]

    def sample(self, times: Sequence[float] | np.ndarray, fps: float | None = None) -> "Motion":
        """Resample at arbitrary ``times`` (seconds): linear root, slerp per joint.

        Times must lie within ``[0, duration]`` (to 1e-9 s); nothing is clipped
        silently. The result has frame rate ``fps`` (default: this motion's),
        i.e. its frames are taken as uniformly spaced at that rate.
        """
        t = np.asarray(times, dtype=float).reshape(-1)
        if t.size == 0:
            raise ValueError("sample() needs at least one time")
        if not np.all(np.isfinite(t)):
            raise ValueError(f"sample times must be finite; time {int(np.argmax(~np.isfinite(t)))} is {t[~np.isfinite(t)][0]}")
        tol = 1e-9 * max(1.0, self.duration)
        if t.min() < -tol or t.max() > self.duration + tol:
            raise ValueError(
                f"sample times must lie in [0, {self.duration:.6g}] s; got [{t.min():.6g}, {t.max():.6g}]"
            )
        f = np.clip(t * self.fps, 0.0, self.n_frames - 1)
        # Times that are frame times up to rounding (i / fps * fps != i in floating
        # point) snap to the frame, so sampling at frame times reproduces the frames
        # exactly (bit for bit, including the quaternion sign).
        r = np.rint(f)
        f = np.where(np.abs(f - r) <= 1e-9, r, f)
        i0 = np.minimum(np.floor(f).astype(int), self.n_frames - 1)
        i1 = np.minimum(i0 + 1, self.n_frames - 1)
        a = f - i0
        rp = (1 - a)[:, None] * self.root_positions[i0] + a[:, None] * self.root_positions[i1]
        rot = slerp(self.rotations[i0], self.rotations[i1], np.broadcast_to(a[:, None], (t.size, self.skeleton.n_joints)))
        on_frame = a == 0.0
        rot[on_frame] = self.rotations[i0[on_frame]]
        return self.replace(root_positions=rp, rotations=rot, fps=self.fps if fps is None else fps)

    def resample(self, fps: float) -> "Motion":
        """The same motion (same duration) at another frame rate."""
        n = int(np.floor(self.duration * fps + 1e-9)) + 1
        return self.sample(np.arange(n) / fps, fps=fps)

    def retime(self, speed: float, fps: float | None = None) -> "Motion":
        """Uniform retiming: play ``speed`` times faster (flips paper eq. 5.8).

        Velocities, linear and angular momentum scale by ``speed``; the duration
        divides by it. The result keeps the frame rate (or ``fps``) and samples
        the original at ``t = speed * t'``.
        """
        if not (np.isfinite(speed) and speed > 0):
            raise ValueError(f"retiming speed must be positive and finite, got {speed!r}")
        fps = self.fps if fps is None else fps
        new_duration = self.duration / speed
        n = int(np.floor(new_duration * fps + 1e-9)) + 1
        return self.sample(np.minimum(np.arange(n) / fps * speed, self.duration), fps=fps)

    def with_fps(self, fps: float) -> "Motion":
        """Relabel the frame rate (frames unchanged), e.g. to fix a wrong header."""
        return self.replace(fps=fps, source=dataclasses.replace(self.source, notes=self.source.notes + (f"fps set to {fps:g}",)))

    def translated(self, delta: Sequence[float]) -> "Motion":
        """Shift the whole motion by ``delta`` metres."""
        return self.replace(root_positions=self.root_positions + np.asarray(delta, dtype=float))

    def rotated(self, quat: Sequence[float], center: Sequence[float] = (0.0, 0.0, 0.0)) -> "Motion":
        """Rotate the whole motion rigidly by ``quat`` (scalar-last) about world point ``center``.

        ``quat`` may be one quaternion or one per frame ``(T, 4)``.
        """
        from .rotations import quat_apply

        q = np.broadcast_to(np.asarray(quat, dtype=float), (self.n_frames, 4))
        c = np.broadcast_to(np.asarray(center, dtype=float), (self.n_frames, 3))
        rp = c + quat_apply(q, self.root_positions - c)
        rot = np.array(self.rotations)
        rot[:, 0] = quat_multiply(q, rot[:, 0])
        return self.replace(root_positions=rp, rotations=rot)

    def continuous(self) -> "Motion":
        """Same motion with quaternion signs made continuous over time per joint."""
        return self.replace(rotations=make_continuous(self.rotations, axis=0))

    def mirrored(self, axis: int = 0) -> "Motion":
        """Left/right mirror image: reflect across the plane normal to world ``axis``
        (default x) and swap left/right joints (``Skeleton.mirror_map``).

        Exact: the mirrored motion's joint positions are the reflected positions of
        the original with left and right labels swapped. For an asymmetric
        skeleton the offsets are mirrored too, so the skeleton may change.
        """
        sk = self.skeleton
        m = sk.mirror_map()
        S = np.ones(3)
        S[axis] = -1.0
        offsets = sk.offsets[m] * S
        # End sites swap labels like joints: end site k keeps its parent and takes the
        # reflected offset of its counterpart (the end site of the same rank on the
        # parent's mirror joint), so it lands on the reflection of that counterpart.
        # Without a counterpart it keeps its own reflected point, hanging from the
        # mirror joint. Either way positions are exact and mirroring twice is identity.
        by_parent: dict[int, list[int]] = {}
        for k, e in enumerate(sk.end_sites):
            by_parent.setdefault(e.parent, []).append(k)
        ends = []
        for k, e in enumerate(sk.end_sites):
            rank = by_parent[e.parent].index(k)
            partners = by_parent.get(int(m[e.parent]), [])
            if rank < len(partners):
                ends.append(EndSite(e.parent, sk.end_sites[partners[rank]].offset * S, e.name))
            else:
                ends.append(EndSite(int(m[e.parent]), e.offset * S, e.name))
        same = np.allclose(offsets, sk.offsets, rtol=0, atol=1e-12) and all(
            a.parent == b.parent and np.allclose(a.offset, b.offset, rtol=0, atol=1e-12) for a, b in zip(ends, sk.end_sites)
        )
        new_sk = sk if same else Skeleton(sk.names, sk.parents, offsets, sk.channels, tuple(ends), sk.removed_root)
        q = self.rotations[:, m]
        # Reflection R -> S R S: for reflection across axis a, the quaternion vector
        # part keeps its a-component sign and negates the other two.
        qs = np.array(q)
        qs[..., :3] *= -S
        rp = self.root_positions * S
        return self.replace(skeleton=new_sk, root_positions=rp, rotations=qs)

    def __repr__(self) -> str:
        return (
            f"Motion({self.skeleton.n_joints} joints, {self.n_frames} frames at {self.fps:g} fps, "
            f"{self.duration:.3f} s, source={self.source.path or self.source.format})"
        )


def concatenate(motions: Sequence[Motion]) -> Motion:
    """Join motions end to end (frames appended, same skeleton and frame rate).

    No alignment or blending is done: callers align root position/orientation first.
    """
    motions = list(motions)
    if not motions:
        raise ValueError("concatenate() needs at least one motion")
    first = motions[0]
    for k, m in enumerate(motions[1:], 1):
        if m.skeleton != first.skeleton:
            raise MotionFormatError(f"motion {k} has a different skeleton from motion 0")
        if abs(m.fps - first.fps) > 1e-9:
            raise MotionFormatError(f"motion {k} runs at {m.fps:g} fps, motion 0 at {first.fps:g} fps")
    return first.replace(
        root_positions=np.concatenate([m.root_positions for m in motions]),
        rotations=np.concatenate([m.rotations for m in motions]),
    )
