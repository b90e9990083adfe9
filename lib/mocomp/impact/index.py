"""The reaction-library index: per-clip body features and unique frames, cached on disk (sec. 4.1).

:func:`build_index` reads every motion file below a library directory (any format
:func:`mocomp.io.load` reads), brings each clip onto the victim's skeleton
(:func:`mocomp.impact.retarget.retarget`; clips that cannot be mapped are refused with the reason
and listed in :attr:`LibraryIndex.refused`), resamples it to the index rate when its own rate
differs by more than 2 % (CMU 120 Hz, DeepMimic 60 Hz; the ASE clips at 29.86-30 Hz are used
frame for frame), computes the 16 body parts' features (:mod:`mocomp.impact.features`) and the
clip's **unique frames** (eq. 4.2):

    F_0 = f_0;  F_k = f_i  iff  F_{k-1} = f_j, i > j, d(F_{k-1}, f_i) > T  and  d(F_{k-1}, f_l) <= T
    for every j < l < i

i.e. scanning forward, a frame is unique when it differs from the *last unique frame* by more than
the tolerance ``T`` (Appendix A: ``T = 0.5``), with ``d`` the frame distance of eq. 4.1 (one frame,
window weight 1, both frames aligned at their own root in the ground plane, Table A.1 weights with
neither foot supporting). The scan compares each frame once with the last unique frame (in
vectorised blocks that grow while no frame exceeds ``T``), so building is linear in the number of
library frames.

Cache: one ``.npz`` per clip under ``cache_dir`` (default ``$MOCOMP_CACHE_DIR/impact_index`` or
the user's cache folder, :func:`mocomp.datasets.download.cache_dir`), named by the SHA-256 of the
clip's bytes (and of a DeepMimic clip's character file), the victim skeleton, the tolerance, the
index rate and :data:`INDEX_VERSION`: a changed clip gets a new key and is rebuilt, an unchanged one
is read back. Files are written atomically (a temporary file in the same folder, then
``os.replace``).
"""
from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
import time
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.motion import Motion
from ..core.skeleton import Skeleton
from ..errors import MocompError
from .features import BODY_PARTS, BodyFeatures, body_features, body_model_for, ground_frame_features, part_weights
from .retarget import RetargetError, retarget

__all__ = ["LibraryError", "ClipIndex", "LibraryIndex", "build_index", "unique_frames", "frame_distances",
           "default_cache_dir", "library_files", "INDEX_VERSION", "DEFAULT_TOLERANCE", "DEFAULT_FPS"]

#: bump when the cached arrays or their meaning change (old cache files are then ignored)
INDEX_VERSION = 3
#: Appendix A: the unique-frame tolerance
DEFAULT_TOLERANCE = 0.5
#: the index rate, frames per second (the paper searched at the 30 fps capture rate)
DEFAULT_FPS = 30.0
#: a clip whose rate differs from the index rate by more than this fraction is resampled
RATE_TOLERANCE = 0.02
_EXTENSIONS = (".bvh", ".amc", ".txt", ".json")
_FEATURES = ("positions", "orientations", "velocities", "angular_velocities", "com", "ground", "heading", "masses")
_ARRAYS = ("unique", "native_ground", "native_heading")


class LibraryError(MocompError, ValueError):
    """The library directory has no usable clip (or is not a directory)."""


def default_cache_dir() -> Path:
    """``$MOCOMP_CACHE_DIR/impact_index`` or the user's cache folder for mocomp + ``impact_index``."""
    from ..datasets.download import cache_dir

    return cache_dir() / "impact_index"


def library_files(directory) -> list[Path]:
    """Motion files below ``directory`` (recursively, hidden folders skipped), sorted."""
    d = Path(directory)
    if not d.is_dir():
        raise LibraryError(f"{d}: the reaction library is not a directory")
    out = []
    for p in sorted(d.rglob("*")):
        rel = p.relative_to(d).parts
        if p.is_file() and p.suffix.lower() in _EXTENSIONS and not any(s.startswith(".") for s in rel):
            out.append(p)
    return out


# ------------------------------------------------------------------ frame distance and unique frames
def frame_distances(pos_a, ori_a, pos_b, ori_b, wp, wr) -> np.ndarray:
    """Eq. 4.1's per-frame term without the window weight: ``sum_b w_p,b |p_b - p'_b| +
    w_theta,b angle(theta_b, theta'_b)`` over the trailing ``(16, 3)``/``(16, 4)`` axes (broadcast),
    with the geodesic angle ``2 acos |<q, q'>|`` in radians."""
    lin = np.sqrt(np.einsum("...bk,...bk->...b", pos_a - pos_b, pos_a - pos_b)) @ wp
    dot = np.abs(np.einsum("...bk,...bk->...b", ori_a, ori_b))
    return lin + (2.0 * np.arccos(np.minimum(dot, 1.0))) @ wr


def unique_frames(pos_local: np.ndarray, ori_local: np.ndarray, tolerance: float = DEFAULT_TOLERANCE,
                  support: str | None = None) -> tuple[np.ndarray, int]:
    """Indices of the unique frames of one clip (eq. 4.2) and the number of frame distances computed.

    ``pos_local (N, 16, 3)`` and ``ori_local (N, 16, 4)`` are each frame's body parts in its own
    ground frame. Frame 0 is unique; scanning forward, frame ``i`` is unique when its distance to
    the last unique frame exceeds ``tolerance``. Each frame is compared with the last unique frame
    at most once plus the tail of one block per unique frame (blocks start at 4 frames and double
    while no frame exceeds the tolerance): linear in ``N``.
    """
    if not (np.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"tolerance must be a finite number >= 0, got {tolerance!r}")
    wp, wr = part_weights(support)
    N = pos_local.shape[0]
    out = [0]
    last, i, block, computed = 0, 1, 4, 0
    while i < N:
        stop = min(N, i + block)
        d = frame_distances(pos_local[last], ori_local[last], pos_local[i:stop], ori_local[i:stop], wp, wr)
        computed += stop - i
        over = np.flatnonzero(d > tolerance)
        if over.size:
            last = i + int(over[0])
            out.append(last)
            i, block = last + 1, 4
        else:
            i, block = stop, block * 2
    return np.array(out, dtype=np.int64), computed


# ------------------------------------------------------------------ the index
@dataclass(frozen=True, eq=False)
class ClipIndex:
    """One library clip on the victim's skeleton, at the index rate.

    Attributes
    ----------
    path: the clip file. name: its path relative to the library directory.
    sha256: hash of the clip's bytes. key: the cache key (content + parameters).
    native_fps, native_frames: the file's own rate and frame count.
    first_frame: native frames not searched at the start (1 for a leading cgspeed T-pose), else 0.
    resampled: whether the index frames are a resampling of the native ones.
    features: the body features at the index rate (:class:`~mocomp.impact.features.BodyFeatures`).
    unique: ``(U,)`` unique frames (index frame numbers), eq. 4.2.
    native_ground, native_heading: the root's ground point and heading at every native frame
        (for the root transform of a match in native frame numbers).
    notes: what was done to the clip (retargeting, resampling, frames dropped).
    seconds: build time (0 when read from the cache). cached: read from the cache.
    """

    path: str
    name: str
    sha256: str
    key: str
    native_fps: float
    native_frames: int
    first_frame: int
    resampled: bool
    fps: float
    features: BodyFeatures
    unique: np.ndarray
    native_ground: np.ndarray
    native_heading: np.ndarray
    notes: tuple[str, ...] = ()
    seconds: float = 0.0
    cached: bool = False

    @property
    def n_frames(self) -> int:
        return self.features.n_frames

    def native_frame(self, k) -> np.ndarray | int:
        """Native frame number of index frame ``k`` (nearest frame at the same time)."""
        k = np.asarray(k)
        f = np.rint(k * self.native_fps / self.fps).astype(int) if self.resampled else k.astype(int)
        f = np.minimum(f + self.first_frame, self.native_frames - 1)
        return int(f) if f.ndim == 0 else f

    def index_frame(self, native) -> int:
        """Index frame nearest to a native frame number (inverse of :meth:`native_frame`)."""
        k = int(native) - self.first_frame
        if self.resampled:
            k = int(round(k * self.fps / self.native_fps))
        return int(np.clip(k, 0, self.n_frames - 1))


@dataclass(frozen=True, eq=False)
class LibraryIndex:
    """The indexed library: clips on one skeleton at one rate, with unique frames.

    Attributes
    ----------
    directory: the library folder. skeleton: the victim's skeleton every clip was mapped onto.
    tolerance: ``T`` of eq. 4.2. fps: the index rate.
    clips: the usable clips (:class:`ClipIndex`), sorted by name.
    refused: ``(path, reason)`` of files that could not be used (unreadable, unmappable, too short).
    cache_dir: where the per-clip cache files live (``None``: no cache).
    seconds: wall time of :func:`build_index`.
    """

    directory: str
    skeleton: Skeleton
    tolerance: float
    fps: float
    clips: tuple[ClipIndex, ...]
    refused: tuple[tuple[str, str], ...] = ()
    cache_dir: str | None = None
    seconds: float = 0.0
    _cat: dict = field(default_factory=dict, repr=False)

    @property
    def n_frames(self) -> int:
        return int(sum(c.n_frames for c in self.clips))

    @property
    def n_unique(self) -> int:
        return int(sum(c.unique.size for c in self.clips))

    def clip(self, name_or_path) -> ClipIndex:
        """The clip by relative name or path."""
        s = str(name_or_path)
        for c in self.clips:
            if s in (c.name, c.path) or Path(s).resolve() == Path(c.path).resolve():
                return c
        raise KeyError(f"no clip {s!r} in the index of {self.directory} (clips: {[c.name for c in self.clips]})")

    def motion(self, name_or_path) -> Motion:
        """The clip on the victim's skeleton at its own rate (frame numbers as in :class:`SearchResult`),
        re-read from its file; raises :class:`LibraryError` if the file changed since indexing."""
        c = self.clip(name_or_path)
        data = Path(c.path).read_bytes()
        if hashlib.sha256(data).hexdigest() != c.sha256:
            raise LibraryError(f"{c.path}: the clip changed since the index was built; rebuild the index "
                               "(mocomp impact-index)")
        return _load_on(c.path, self.skeleton)[0]

    def concatenated(self) -> dict:
        """All clips' arrays end to end (for the vectorised search): ``positions (N, 16, 3)``,
        ``orientations``, ``ground``, ``heading``, ``start (C,)`` first row of each clip,
        ``length (C,)``, ``row_clip (N,)`` the clip of each row. The search caches derived arrays here too."""
        if "positions" not in self._cat:
            cl = self.clips
            self._cat.update(
                positions=np.ascontiguousarray(np.concatenate([c.features.positions for c in cl])),
                orientations=np.ascontiguousarray(np.concatenate([c.features.orientations for c in cl])),
                ground=np.concatenate([c.features.ground for c in cl]),
                heading=np.concatenate([c.features.heading for c in cl]),
                length=np.array([c.n_frames for c in cl], dtype=np.int64),
            )
            self._cat["start"] = np.concatenate([[0], np.cumsum(self._cat["length"])[:-1]]).astype(np.int64)
            self._cat["row_clip"] = np.repeat(np.arange(len(cl)), self._cat["length"])
        return self._cat


# ------------------------------------------------------------------ building
def _skeleton_signature(skeleton: Skeleton) -> bytes:
    return json.dumps([list(skeleton.names), skeleton.parents.tolist(),
                       np.round(skeleton.offsets, 9).tolist()]).encode()


def _content_hash(path: Path) -> tuple[str, bytes]:
    data = path.read_bytes()
    h = hashlib.sha256(data).hexdigest()
    extra = b""
    if path.suffix.lower() in (".txt", ".json"):
        from ..io.deepmimic import find_character

        try:
            extra = Path(find_character(path)).read_bytes()
        except (MocompError, OSError):
            extra = b""
    if path.suffix.lower() == ".amc":
        asf = path.with_suffix(".asf")
        if asf.exists():
            extra = asf.read_bytes()
    return h, extra


def _load_on(path, skeleton: Skeleton) -> tuple[Motion, tuple[str, ...], int]:
    """The clip on ``skeleton`` (retargeted), notes, and 1 when its frame 0 is a cgspeed T-pose
    (searched windows then start at frame 1; the frame stays in the motion, so frame numbers are
    the file's)."""
    from .. import io
    from ..datasets.clips import is_tpose_frame

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = io.load(path)
    tpose = int(is_tpose_frame(m, 0))
    m, notes = retarget(m, skeleton, name=str(path))
    return m, notes + (("frame 0 (the T-pose before the capture) is not searched",) if tpose else ()), tpose


def _build_clip(path: Path, name: str, sha: str, key: str, skeleton, body, tolerance, fps) -> ClipIndex:
    t0 = time.perf_counter()
    m, notes, first = _load_on(path, skeleton)
    notes = list(notes)
    native_fps, native_n = float(m.fps), m.n_frames
    nat = body_features(m, body, velocities=False)
    if first:
        m = m[first:]
    resampled = abs(native_fps / fps - 1.0) > RATE_TOLERANCE
    if resampled:
        m = m.resample(fps)
        notes.append(f"resampled {native_fps:g} -> {fps:g} Hz")
    F = body_features(m, body)
    pl, ol = ground_frame_features(F.positions, F.orientations, F.ground, F.heading)
    uniq, _ = unique_frames(pl, ol, tolerance)
    for a in (*(getattr(F, k) for k in _FEATURES), uniq, nat.ground, nat.heading):
        a.setflags(write=False)                          # as read back from the cache
    return ClipIndex(str(path), name, sha, key, native_fps, native_n, first, resampled, fps, F, uniq, nat.ground,
                     nat.heading, tuple(notes), time.perf_counter() - t0, False)


def _save(cache: Path, clip: ClipIndex) -> None:
    cache.mkdir(parents=True, exist_ok=True)
    meta = {k: getattr(clip, k) for k in ("name", "sha256", "key", "native_fps", "native_frames", "first_frame",
                                           "resampled", "fps")}
    meta["notes"] = list(clip.notes)
    fd, tmp = tempfile.mkstemp(dir=cache, prefix=".tmp-", suffix=".npz")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **{k: getattr(clip, k) for k in _ARRAYS},
                     **{"f_" + k: getattr(clip.features, k) for k in _FEATURES})
        os.replace(tmp, cache / f"{clip.key}.npz")
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _read(cache: Path, key: str, path: Path, name: str) -> ClipIndex | None:
    f = cache / f"{key}.npz"
    if not f.exists():
        return None
    t0 = time.perf_counter()
    try:
        with np.load(f, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in _ARRAYS}
            feats = {k: z["f_" + k] for k in _FEATURES}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None  # damaged (e.g. truncated) or from another version: rebuilt
    if meta.get("key") != key:
        return None
    for a in (*arrays.values(), *feats.values()):
        a.setflags(write=False)
    return ClipIndex(str(path), name, meta["sha256"], key, meta["native_fps"], meta["native_frames"],
                     meta["first_frame"], meta["resampled"], meta["fps"], BodyFeatures(meta["fps"], **feats),
                     notes=tuple(meta["notes"]), seconds=time.perf_counter() - t0, cached=True, **arrays)


def index_parameters(skeleton: Skeleton, tolerance: float, fps: float) -> str:
    """The index parameters' part of every cache key: :data:`INDEX_VERSION`, ``T``, the index rate,
    the body parts and the victim's skeleton signature (hex SHA-256)."""
    return hashlib.sha256(json.dumps({"v": INDEX_VERSION, "T": float(tolerance), "fps": float(fps),
                                      "parts": BODY_PARTS}).encode() + _skeleton_signature(skeleton)).hexdigest()


def clip_cache_key(path, params: str) -> tuple[str, str]:
    """``(sha256 of the clip's bytes, cache key)`` of one clip file for :func:`index_parameters`'
    ``params``: the key changes with the file's bytes (and a DeepMimic clip's character file or an
    AMC's ASF) and with every index parameter."""
    sha, extra = _content_hash(Path(path))
    return sha, hashlib.sha256((params + sha).encode() + hashlib.sha256(extra).digest()).hexdigest()[:32]


def index_clip_file(path, name: str, skeleton: Skeleton, body, params: str, cache=None,
                    tolerance: float = DEFAULT_TOLERANCE, fps: float = DEFAULT_FPS) -> ClipIndex:
    """Index one library clip: read back from ``cache`` when its file for this key exists, else built
    (retarget onto ``skeleton``, resample to ``fps``, features, eq. 4.2's unique frames) and, with a
    ``cache`` folder, written there atomically. ``params`` is :func:`index_parameters` for the same
    skeleton, tolerance and fps. This is the per-clip step of :func:`build_index`, and what
    ``mocomp batch impact-index`` runs on its workers. Raises ``RetargetError`` for a skeleton that
    cannot be mapped and ``MocompError``/``ValueError``/``OSError`` for an unreadable file."""
    p = Path(path)
    sha, key = clip_cache_key(p, params)
    c = _read(Path(cache), key, p, name) if cache is not None else None
    if c is None:
        c = _build_clip(p, name, sha, key, skeleton, body, tolerance, fps)
        if cache is not None:
            _save(Path(cache), c)
    return c


def build_index(library_dir, skeleton: Skeleton, *, cache_dir=None, tolerance: float = DEFAULT_TOLERANCE,
                progress: bool = True, fps: float = DEFAULT_FPS, use_cache: bool = True) -> LibraryIndex:
    """Index every clip below ``library_dir`` for the victim's ``skeleton`` (see the module docstring).

    Parameters
    ----------
    library_dir: folder of reaction clips (any format :func:`mocomp.io.load` reads, recursively).
    skeleton: the victim's skeleton; other skeletons are retargeted by joint-name mapping or refused.
    cache_dir: cache folder (default :func:`default_cache_dir`).
    tolerance: ``T`` of eq. 4.2 (Appendix A: 0.5).
    progress: print one line per clip on stderr.
    fps: the index rate (clips whose rate differs by more than 2 % are resampled to it).
    use_cache: ``False`` builds everything afresh and writes nothing.

    Raises :class:`LibraryError` when no clip is usable (the message lists every refused file and why).
    """
    t0 = time.perf_counter()
    if not (np.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"tolerance must be a finite number >= 0, got {tolerance!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps!r}")
    directory = Path(library_dir)
    files = library_files(directory)
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    body = body_model_for(skeleton)
    params = index_parameters(skeleton, tolerance, fps)
    clips, refused = [], []
    for p in files:
        name = p.relative_to(directory).as_posix()
        try:
            c = index_clip_file(p, name, skeleton, body, params, cache if use_cache else None, tolerance, fps)
        except RetargetError as e:
            refused.append((str(p), str(e)))
            continue
        except (MocompError, ValueError, OSError) as e:
            refused.append((str(p), f"{p}: cannot be read as a motion: {' '.join(str(e).split())}"))
            continue
        clips.append(c)
        if progress:
            print(f"impact index: {name}: {c.n_frames} frames, {c.unique.size} unique, "
                  f"{c.seconds * 1e3:.0f} ms{' (cached)' if c.cached else ''}", file=sys.stderr)
    if not clips:
        why = "; ".join(r for _, r in refused) or "no motion files (.bvh, .amc, .txt, .json)"
        raise LibraryError(f"{directory}: no usable clip for the victim's skeleton "
                           f"({skeleton.n_joints} joints, root {skeleton.names[0]!r}): {why}")
    return LibraryIndex(str(directory), skeleton, float(tolerance), float(fps), tuple(clips), tuple(refused),
                        None if not use_cache else str(cache), time.perf_counter() - t0)
