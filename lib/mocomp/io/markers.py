"""``Markers``: optical marker trajectories (e.g. from C3D), in metres."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MotionFormatError

__all__ = ["Markers"]


@dataclass(frozen=True, eq=False)
class Markers:
    """Marker trajectories.

    Attributes
    ----------
    names: ``(M,)`` marker labels.
    positions: ``(T, M, 3)`` metres, y-up world; gaps are NaN.
    fps: frames per second.
    mask: ``(T, M)`` bool, True where the marker was seen (not a gap).
    source: file path, if any.
    unit_scale: metres per file unit applied by the loader.
    notes: loader remarks (axis mapping to y-up, gaps, first frame number, ...).
    """

    names: tuple[str, ...]
    positions: np.ndarray
    fps: float
    mask: np.ndarray = None  # type: ignore[assignment]
    source: str | None = None
    unit_scale: float = 1.0
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        P = np.array(self.positions, dtype=float, copy=True)
        if P.ndim != 3 or P.shape[2] != 3 or P.shape[1] != len(self.names):
            raise MotionFormatError(f"marker positions must be (T, {len(self.names)}, 3), got {P.shape}", self.source)
        mask = np.all(np.isfinite(P), axis=2) if self.mask is None else np.array(self.mask, dtype=bool)
        if mask.shape != P.shape[:2]:
            raise MotionFormatError(f"marker mask must be {P.shape[:2]}, got {mask.shape}", self.source)
        P[~mask] = np.nan
        P.setflags(write=False)
        mask.setflags(write=False)
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise MotionFormatError(f"fps must be positive, got {self.fps}", self.source)
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "positions", P)
        object.__setattr__(self, "mask", mask)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no marker {name!r}; markers: {self.names}") from None

    def select(self, names) -> "Markers":
        """Only the named markers, in that order (KeyError names any missing)."""
        missing = [n for n in names if n not in self.names]
        if missing:
            raise KeyError(f"markers {missing} not in {self.source or 'marker set'}; available: {self.names}")
        idx = [self.names.index(n) for n in names]
        return Markers(tuple(names), self.positions[:, idx], self.fps, self.mask[:, idx], self.source, self.unit_scale,
                       self.notes)
