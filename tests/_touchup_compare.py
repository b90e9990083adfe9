"""Shared checks of the touch-up speed tests: a compiled run against the numpy reference run."""
from __future__ import annotations

import numpy as np


def quat_close(a, b) -> float:
    """Largest component difference of two quaternion arrays, sign-blind."""
    return float(np.minimum(np.abs(a - b).max(axis=-1), np.abs(a + b).max(axis=-1)).max())


def assert_same_touchup(fast, ref, original, name: str, tol: float = 1e-9) -> None:
    """``fast`` and ``ref`` (TouchupResult) agree: motion, per-iteration ZMP records, frame lists;
    and touch-up did change ``original`` (the edited input), so the comparison is not vacuous."""
    assert np.abs(fast.motion.root_positions - ref.motion.root_positions).max() < tol, name
    assert quat_close(fast.motion.rotations, ref.motion.rotations) < tol, name
    assert quat_close(fast.motion.rotations, original.rotations) > 1e-3, name
    assert len(fast.history) == len(ref.history) > 0
    for h, r in zip(fast.history, ref.history):
        assert abs(h["mean_outside_m"] - r["mean_outside_m"]) < tol, (name, h["step"], h["iteration"])
        assert h["frames_outside"] == r["frames_outside"]
    assert fast.clamped == ref.clamped and fast.capped == ref.capped and fast.lifted == ref.lifted
