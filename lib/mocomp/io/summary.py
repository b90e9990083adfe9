"""A one-screen summary of a loaded motion: size, timing, units, body height, root travel.

Used by ``mocomp info``; every number is computed from the :class:`Motion` and
its :class:`SourceInfo` (what the loader did), so a wrong frame-rate header or
length unit shows up as an implausible height, travel or joint speed.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["MotionSummary", "summarize", "joint_speeds"]


def joint_speeds(motion) -> np.ndarray:
    """``(T, J)`` linear speed of every joint, m/s, by central differences on the
    frame times (one-sided at the ends; zeros for a one-frame motion)."""
    P = motion.positions
    if motion.n_frames < 2:
        return np.zeros(P.shape[:2])
    return np.linalg.norm(np.gradient(P, motion.dt, axis=0), axis=-1)


@dataclass(frozen=True)
class MotionSummary:
    """Facts about a motion, SI units.

    Attributes
    ----------
    source: file path (or the example/format name for generated motions).
    format: file format (``SourceInfo.format``).
    n_joints, joint_names, root: skeleton size, names, root joint name.
    n_frames: frames.
    fps: frame rate used (Hz); header_fps: the file's own rate (``None`` if none: an
        AMC file, a generated motion).
    fps_basis: where ``fps`` comes from, in words: ``"as the header"`` / ``"header says
        X"`` (BVH), ``"from the key-frame times"`` / ``"key frames at X fps"`` (DeepMimic),
        ``"generated at this rate"`` (synthetic), ``"the file states none"`` (ASF/AMC).
    duration: seconds from first to last frame.
    unit_scale: metres per file length unit the loader applied; unit_reason: why.
    standing_height: the performer's height, m (:func:`mocomp.body.height.estimate_height`:
        the measured head-top to foot extent, 95th percentile over frames, when the clip
        stands upright; the skeleton's straight-chain stature from its bone lengths when
        it never does; the vertical extent of all joints and end sites when no
        body-segment mapping fits); height_basis: which of the three and why, in words;
        rest_height: vertical extent of the rest pose, m.
    root_path_length: length of the root's path on the ground (x-z) plane, m.
    root_displacement: straight-line ground-plane distance first -> last frame, m.
    root_height_range: ``(min, max)`` root height (y), m.
    peak_joint_speed: fastest joint speed over the clip, m/s; peak_joint, peak_time (s).
    notes: the loader's remarks (corrections applied, dropped frames, ...).
    """

    source: str
    format: str
    n_joints: int
    root: str
    joint_names: tuple[str, ...]
    n_frames: int
    fps: float
    header_fps: float | None
    duration: float
    unit_scale: float
    unit_reason: str
    standing_height: float
    rest_height: float
    root_path_length: float
    root_displacement: float
    root_height_range: tuple[float, float]
    peak_joint_speed: float
    peak_joint: str
    peak_time: float
    notes: tuple[str, ...]
    fps_basis: str = ""
    height_basis: str = ""

    def to_dict(self) -> dict:
        d = asdict(self)
        d["joint_names"] = list(self.joint_names)
        d["root_height_range"] = list(self.root_height_range)
        d["notes"] = list(self.notes)
        return d

    def to_text(self) -> str:
        """Aligned human-readable lines."""
        hdr = f" ({self.fps_basis})" if self.fps_basis else ""
        lo, hi = self.root_height_range
        lines = [
            ("source", f"{self.source} [{self.format}]"),
            ("joints", f"{self.n_joints} (root {self.root})"),
            ("frames", f"{self.n_frames}"),
            ("fps", f"{self.fps:.6g}{hdr}"),
            ("duration", f"{self.duration:.3f} s"),
            ("unit scale", f"{self.unit_scale:.6g} m per file unit: {self.unit_reason}"),
            ("height", f"{self.standing_height:.3f} m standing (rest pose {self.rest_height:.3f} m)"
                       + (f"; {self.height_basis}" if self.height_basis else "")),
            ("root travel", f"{self.root_path_length:.3f} m along the ground, {self.root_displacement:.3f} m "
                            f"start to end; root height {lo:.3f}-{hi:.3f} m"),
            ("peak speed", f"{self.peak_joint_speed:.2f} m/s ({self.peak_joint} at {self.peak_time:.3f} s)"),
        ]
        w = max(len(k) for k, _ in lines)
        out = [f"{k.ljust(w)}  {v}" for k, v in lines]
        for i, n in enumerate(self.notes):
            out.append(f"{('notes' if i == 0 else '').ljust(w)}  - {n}")
        return "\n".join(out)


def fps_basis(fmt: str, fps: float, header_fps: float | None) -> str:
    """Where a motion's frame rate comes from, worded for its source format (see
    :class:`MotionSummary`); ``""`` when nothing is known."""
    fmt = (fmt or "").lower()
    same = header_fps is not None and abs(header_fps - fps) <= 1e-6 * fps
    if fmt == "synthetic":
        return "generated at this rate" if header_fps is None or same else f"generated at {header_fps:.6g} fps"
    if fmt == "deepmimic":
        if header_fps is None:
            return "single key frame: no timing in the file"
        return "from the key-frame times" if same else f"key frames at {header_fps:.6g} fps"
    if fmt in ("asf/amc", "amc"):
        return "the file states none" if header_fps is None else ("as the file says" if same else
                                                                   f"file says {header_fps:.6g}")
    if header_fps is None:
        return ""
    if fmt == "bvh":
        return "as the header" if same else f"header says {header_fps:.6g}"
    return "as the source says" if same else f"source says {header_fps:.6g}"


def summarize(motion, name: str | None = None) -> MotionSummary:
    """The :class:`MotionSummary` of ``motion`` (``name`` labels generated motions)."""
    src = motion.source
    sk = motion.skeleton
    rp = motion.root_positions
    ground = rp[:, [0, 2]]
    path = float(np.linalg.norm(np.diff(ground, axis=0), axis=1).sum()) if motion.n_frames > 1 else 0.0
    speeds = joint_speeds(motion)
    t, j = np.unravel_index(int(np.argmax(speeds)), speeds.shape)
    rest = sk.rest_positions(include_end_sites=True)
    from ..body.height import estimate_height

    height = estimate_height(motion)
    return MotionSummary(
        source=str(src.path) if src.path else (name or src.format),
        format=src.format,
        n_joints=sk.n_joints,
        root=sk.names[0],
        joint_names=sk.names,
        n_frames=motion.n_frames,
        fps=float(motion.fps),
        # a generated motion has no file, hence no header (the generator records its rate)
        header_fps=None if (src.header_fps is None or src.format == "synthetic") else float(src.header_fps),
        duration=float(motion.duration),
        unit_scale=float(src.unit_scale),
        unit_reason=src.unit_reason,
        standing_height=height.value,
        rest_height=float(rest[:, 1].max() - rest[:, 1].min()),
        root_path_length=path,
        root_displacement=float(np.linalg.norm(ground[-1] - ground[0])),
        root_height_range=(float(rp[:, 1].min()), float(rp[:, 1].max())),
        peak_joint_speed=float(speeds[t, j]),
        peak_joint=sk.names[j],
        peak_time=float(t / motion.fps),
        notes=tuple(src.notes),
        fps_basis=fps_basis(src.format, float(motion.fps), src.header_fps),
        height_basis=height.reason,
    )
