"""``BodyModel``: the mass distribution of a skeleton (immutable)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.skeleton import Skeleton
from ..errors import MotionFormatError

__all__ = ["BodyModel"]


def _frozen(a, dtype=float) -> np.ndarray:
    a = np.array(a, dtype=dtype, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class BodyModel:
    """Rigid segments attached to skeleton joints, with masses and inertias.

    A segment is rigidly attached to the frame of one joint (``segment_joint``):
    it moves with that joint's global position and rotation. Usually the
    segment spans from that joint to its child (e.g. the thigh hangs from the
    hip joint).

    Attributes
    ----------
    skeleton: the :class:`~mocomp.core.Skeleton` it describes.
    segment_names: ``(S,)`` names (anatomical, e.g. ``"thigh_l"``, or the bone name).
    segment_joint: ``(S,)`` int, index of the joint whose frame carries the segment.
    masses: ``(S,)`` kilograms, ``>= 0``.
    local_coms: ``(S, 3)`` metres, segment COM in the joint's local frame.
    inertias: ``(S, 3, 3)`` kg m^2, inertia tensor about the segment COM,
        in the joint's local frame (symmetric positive semi-definite).
    massless_joints: names of joints that carry no segment (listed, never dropped silently).
    table: name/citation of the parameter table the model came from.
    shape: ``"ellipsoid"``, ``"cuboid"``, ``"given"`` (e.g. DeepMimic), ...
    """

    skeleton: Skeleton
    segment_names: tuple[str, ...]
    segment_joint: np.ndarray
    masses: np.ndarray
    local_coms: np.ndarray
    inertias: np.ndarray
    massless_joints: tuple[str, ...] = ()
    table: str = ""
    shape: str = "given"

    def __post_init__(self):
        S = len(self.segment_names)
        sj = _frozen(self.segment_joint, dtype=np.int64).reshape(-1)
        m = _frozen(self.masses).reshape(-1)
        c = _frozen(self.local_coms).reshape(-1, 3) if S else _frozen(np.zeros((0, 3)))
        I = _frozen(self.inertias).reshape(-1, 3, 3) if S else _frozen(np.zeros((0, 3, 3)))
        if not (sj.shape == m.shape == (S,) and c.shape == (S, 3) and I.shape == (S, 3, 3)):
            raise MotionFormatError(
                f"BodyModel arrays disagree: {S} segments, joints {sj.shape}, masses {m.shape}, "
                f"coms {c.shape}, inertias {I.shape}")
        if S and (sj.min() < 0 or sj.max() >= self.skeleton.n_joints):
            raise MotionFormatError("BodyModel.segment_joint has an index outside the skeleton")
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(c)) and np.all(np.isfinite(I))):
            raise MotionFormatError("BodyModel has non-finite masses, COMs or inertias")
        if np.any(m < 0):
            k = int(np.argmin(m))
            raise MotionFormatError(f"segment {self.segment_names[k]!r} has negative mass {m[k]}")
        object.__setattr__(self, "segment_names", tuple(self.segment_names))
        object.__setattr__(self, "segment_joint", sj)
        object.__setattr__(self, "masses", m)
        object.__setattr__(self, "local_coms", c)
        object.__setattr__(self, "inertias", I)
        object.__setattr__(self, "massless_joints", tuple(self.massless_joints))

    @property
    def n_segments(self) -> int:
        return len(self.segment_names)

    @property
    def total_mass(self) -> float:
        return float(self.masses.sum())

    def segment(self, name: str) -> int:
        try:
            return self.segment_names.index(name)
        except ValueError:
            raise KeyError(f"no segment {name!r}; segments: {self.segment_names}") from None

    def with_masses(self, masses, inertias=None) -> "BodyModel":
        """A new model with other masses (and optionally inertias); the input is not changed."""
        import dataclasses

        return dataclasses.replace(self, masses=masses, inertias=self.inertias if inertias is None else inertias)

    def table_frame(self):
        """A pandas DataFrame: segment, joint, mass, COM and principal moments."""
        import pandas as pd

        return pd.DataFrame({
            "segment": self.segment_names,
            "joint": [self.skeleton.names[j] for j in self.segment_joint],
            "mass_kg": self.masses,
            "com_x": self.local_coms[:, 0], "com_y": self.local_coms[:, 1], "com_z": self.local_coms[:, 2],
            "Ixx": self.inertias[:, 0, 0], "Iyy": self.inertias[:, 1, 1], "Izz": self.inertias[:, 2, 2],
        })
