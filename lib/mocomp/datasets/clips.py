"""Known facts about the real capture clips, and the corrections ``load`` applies.

The facts come from the data set's ``MANIFEST.md`` (``../shared/data/mocap``),
where each was checked on the clips themselves:

* **Frame rate.** The cgspeed CMU BVH files all say ``Frame Time: .0083333``
  (120 Hz), but CMU subjects 88 and 90 were captured at 60 Hz: the centre of
  mass fitted with a parabola during flight gives g = 40-50 m/s^2 at 120 Hz and
  10-12.6 m/s^2 at 60 Hz (88_01, 88_05, 90_08), and the COM rise matches the
  60 Hz flight time. Subject 83 (83_58: g = 9.85 m/s^2), 01 and 131 really are
  120 Hz. Subjects 75, 141 and 143 are reported as 60 Hz by a third-party
  gravity fit (141_16's header already says 60 Hz).
* **Units.** CMU BVH and ASF: 1 unit = 1/0.45 inch (0.05644 m); SFU BVH:
  inches; Bandai Namco and MASS BVH: centimetres; DeepMimic: metres; HDM05
  C3D: millimetres.
* **T-pose frame.** The cgspeed "MotionBuilder-friendly" CMU BVH files start
  with a T-pose frame that is not part of the take (the real motion starts at
  file frame 1); finite differences across it are meaningless.
* **ASE clips** (``ase_rl_*.derived.bvh``: the Reallusion sword-and-shield library of NVIDIA's
  ASE, retargeted to ASE's 17-body humanoid with ``sword`` and ``shield`` prop joints) are in
  metres and carry their source's own frame rates (the npy ``fps`` field, 29.857-30.000 Hz,
  written as ``Frame Time = 1/fps``); the rate is kept as written, never rounded. Some joint
  centres go 0.10-0.19 m below the floor while lying after the falls (retargeting penetration).
* **MASS clips** are retargeted and their 120 Hz header is not physical (the
  back flip's flight implies ~50-60 Hz); no fps is imposed, a note says so.

:func:`facts_for` returns the :class:`ClipFacts` of a file; ``mocomp.datasets.load``
applies them to known clips only (see :mod:`mocomp.datasets.known`) unless told otherwise
(``raw=True``, explicit ``fps=``/``scale=``).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ClipFacts", "facts_for", "CMU_SUBJECT_FPS", "cmu_trial", "is_tpose_frame"]

#: true capture rate of CMU subjects whose BVH headers say otherwise: subject -> (fps, evidence)
CMU_SUBJECT_FPS: dict[int, tuple[float, str]] = {
    88: (60.0, "gravity fitted in flight is 10-12.6 m/s^2 at 60 Hz vs 46-50 at the 120 Hz header "
               "(88_01, 88_05; data MANIFEST)"),
    90: (60.0, "gravity fitted in flight is 10.1 m/s^2 at 60 Hz vs 40 at the 120 Hz header (90_08; data MANIFEST)"),
    75: (60.0, "reported as 60 Hz by a third-party gravity fit (data MANIFEST; not verified here)"),
    141: (60.0, "reported as 60 Hz by a third-party gravity fit; 141_16's header says 60 Hz (data MANIFEST)"),
    143: (60.0, "reported as 60 Hz by a third-party gravity fit (data MANIFEST; not verified here)"),
}

_CMU_STEM = re.compile(r"^(?:cmu_)?(\d{1,3})_(\d{1,3})(?:_.*)?$", re.IGNORECASE)


def cmu_trial(stem: str) -> tuple[int, int] | None:
    """``(subject, trial)`` for a CMU-style file stem (``88_01``, ``cmu_88_01_backflip``), else ``None``."""
    m = _CMU_STEM.match(stem)
    return (int(m.group(1)), int(m.group(2))) if m else None


@dataclass(frozen=True)
class ClipFacts:
    """What is known about one real clip.

    Attributes
    ----------
    source: data source (``"cmu"``, ``"sfu"``, ``"bandai"``, ``"mass"``, ``"deepmimic"``,
        ``"hdm05"``, ``"ase"`` or ``"unknown"``).
    unit: length unit of the file (a key of :data:`mocomp.io.UNITS`), ``None`` when the
        format itself says (ASF ``units`` block) or the source is unknown.
    unit_reason: where that unit comes from.
    fps: the true frame rate when the header is wrong, else ``None``.
    fps_reason: the evidence for ``fps``.
    tpose_first_frame: the file's first frame is a T-pose that is not part of the take.
    notes: further remarks ``load`` copies into ``SourceInfo.notes``.
    """

    source: str = "unknown"
    unit: str | None = None
    unit_reason: str = ""
    fps: float | None = None
    fps_reason: str = ""
    tpose_first_frame: bool = False
    notes: tuple[str, ...] = ()


def facts_for(path: str | Path) -> ClipFacts:
    """The known facts of a clip, from its file name and extension.

    Name-based: they hold for the known clip of that name only. ``mocomp.datasets.load``
    applies them only to files :func:`mocomp.datasets.known.identify` says *are* known clips
    (in the data directory, or a byte copy by SHA-256), never to another file sharing the name.
    """
    path = Path(path)
    stem, ext = path.stem, path.suffix.lower()
    low = stem.lower()
    if low.startswith("sfu_"):
        return ClipFacts("sfu", "inch", "SFU Motion Capture Database BVH files are in inches")
    if low.startswith("bandai"):
        return ClipFacts("bandai", "cm", "Bandai Namco Research Motion Dataset BVH files are in centimetres")
    if low.startswith("mass_"):
        return ClipFacts("mass", "cm", "MASS BVH files are in centimetres", notes=(
            "MASS clips are retargeted and their 120 Hz header is not physical (the back flip's flight implies "
            "~50-60 Hz); check timing with a gravity-from-flight fit before momentum work",))
    if low.startswith("ase_"):
        return ClipFacts("ase", "m", "ASE derived BVH files are in metres (data MANIFEST)", notes=(
            "ASE clip: the source's own frame rate (npy fps field, Frame Time = 1/fps) is kept as written",
            "ASE humanoid: the sword and shield joints are props (massless in BodyModel.from_skeleton unless "
            "props='ase'); lying after a fall, some joint centres go 0.10-0.19 m below the floor (retargeting "
            "penetration, data MANIFEST)"))
    if low.startswith("deepmimic_"):
        return ClipFacts("deepmimic", "m", "DeepMimic motions are in metres")
    if low.startswith("hdm_"):
        unit = "mm" if ext == ".c3d" else None
        return ClipFacts("hdm05", unit, "HDM05 C3D markers are in millimetres" if unit else
                         "ASF units block (length 0.45, as CMU)")
    trial = cmu_trial(stem)
    if trial is not None:
        subject, _ = trial
        fps, why = CMU_SUBJECT_FPS.get(subject, (None, ""))
        if ext == ".bvh":
            unit, reason = "cmu", "CMU BVH: 1 unit = 1/0.45 inch (ASF length 0.45)"
        else:
            unit, reason = None, "ASF units block"
        return ClipFacts("cmu", unit, reason, fps, f"CMU subject {subject}: {why}" if fps else "",
                         tpose_first_frame=(ext == ".bvh"))
    return ClipFacts()


def is_tpose_frame(motion, frame: int = 0, max_angle_deg: float = 25.0) -> bool:
    """Whether ``frame`` looks like the cgspeed CMU T-pose: no joint below the root
    bent by more than ``max_angle_deg`` (the T-pose keeps only the fixed clavicle and
    thumb angles, 17-21 degrees) while the next frame is bent further, and the root
    does not move between the two frames.

    Only the MotionBuilder-friendly cgspeed files (joint ``LHipJoint``) carry it;
    the 3dsMax-friendly ones (``131_xx``) start with motion.
    """
    if motion.n_frames < frame + 2 or motion.skeleton.n_joints < 2:
        return False
    q = motion.rotations[frame:frame + 2, 1:]
    ang = np.degrees(2.0 * np.arccos(np.clip(np.abs(q[..., 3]), 0.0, 1.0))).max(axis=1)
    still = np.allclose(motion.root_positions[frame], motion.root_positions[frame + 1], atol=1e-6)
    return bool(ang[0] <= max_angle_deg < ang[1] and still)
