"""Gaussian pre-smoothing of motions; the time derivatives on true frame times, re-exported.

The papers differentiate capture data numerically and smooth first (the touch-up
paper: "a gaussian filter of width 5 ... and then used finite differences").
The derivatives themselves -- :func:`central_difference`, :func:`second_difference`
(second-order central differences on the given frame times, non-uniform spacing
allowed, one-sided at the ends), :func:`angular_velocity` of orientations -- and
the Gaussian filter :func:`gaussian_smooth` are core's
(:mod:`mocomp.core.kinematics`, one implementation for every package) and are
re-exported here, where they have always been importable from. This module adds
the smoothing of a whole motion (:func:`smooth_quaternions`, :func:`smooth_motion`).
"""
from __future__ import annotations

import numpy as np

# time derivatives, frame-time validation and the Gaussian filter are core's (one implementation for
# every package); re-exported here, where they have always been importable from
from ..core.kinematics import angular_velocity, central_difference, frame_times, gaussian_smooth, second_difference
from ..core.rotations import make_continuous

__all__ = [
    "central_difference",
    "second_difference",
    "angular_velocity",
    "gaussian_smooth",
    "smooth_quaternions",
    "smooth_motion",
    "frame_times",
]


def smooth_quaternions(quats, sigma: float) -> np.ndarray:
    """Gaussian-smooth unit quaternions ``(T, ..., 4)`` over time: hemisphere-continuous
    components filtered, then renormalised (a good approximation for the small
    rotation changes between neighbouring capture frames)."""
    q = make_continuous(np.asarray(quats, dtype=float), axis=0)
    if not sigma:
        return q
    s = gaussian_smooth(q, sigma, axis=0)
    return s / np.linalg.norm(s, axis=-1, keepdims=True)


def smooth_motion(motion, sigma: float):
    """A new :class:`~mocomp.core.Motion` with root positions and joint rotations
    Gaussian-smoothed over time (``sigma`` in frames); the input is unchanged."""
    if not sigma:
        return motion
    return motion.replace(root_positions=gaussian_smooth(motion.root_positions, sigma, axis=0),
                          rotations=smooth_quaternions(motion.rotations, sigma))
