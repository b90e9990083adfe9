"""Time derivatives of motion quantities on true frame times, and Gaussian pre-smoothing.

The papers differentiate capture data numerically and smooth first (the touch-up
paper: "a gaussian filter of width 5 ... and then used finite differences").
Here derivatives are second-order central differences on the given frame times
(non-uniform spacing allowed, :func:`numpy.gradient`), one-sided at the ends.
Angular velocities of orientations are :func:`mocomp.core.kinematics.angular_velocity`
(re-exported here as ``angular_velocity``).
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

# frame-time validation and angular velocities are core's (one implementation for every package);
# re-exported here, where they have always been importable from
from ..core.kinematics import _uniform_step, angular_velocity, frame_times
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


def central_difference(x, times, edge_order: int = 1, order: int = 2) -> np.ndarray:
    """``d x / d t`` along axis 0.

    Parameters
    ----------
    x: ``(T, ...)`` samples.
    times: ``(T,)`` frame times in seconds (strictly increasing), or a frame rate (fps).
    edge_order: 1 (one-sided first-order at the ends, default) or 2.
    order: 2 (default) or 4. Order 2: the second-order central difference on the
        true spacing ``h1 = t_i - t_{i-1}``, ``h2 = t_{i+1} - t_i`` (for uniform
        spacing ``(x_{i+1} - x_{i-1}) / 2h``). Order 4 (uniform spacing only): the
        five-point stencil ``(x_{i-2} - 8 x_{i-1} + 8 x_{i+1} - x_{i+2}) / 12h``
        on frames 2..T-3, order 2 next to the ends -- for exact synthetic data; on
        noisy capture it amplifies noise ~1.3x more.
    """
    x = np.asarray(x, dtype=float)
    T = x.shape[0]
    t = frame_times(times, T)
    if T < 2:
        raise ValueError("a derivative needs at least 2 frames")
    if order not in (2, 4):
        raise ValueError(f"order must be 2 or 4, got {order!r}")
    d = np.gradient(x, t, axis=0, edge_order=min(edge_order, T - 1))
    if order == 4 and T >= 5:
        h = _uniform_step(t)
        d[2:-2] = (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * h)
    return d


def second_difference(x, times, edge_order: int = 1) -> np.ndarray:
    """``d^2 x / d t^2`` along axis 0 (central difference of the central difference;
    for uniform spacing ``(x_{i+2} - 2 x_i + x_{i-2}) / 4h^2`` in the interior)."""
    return central_difference(central_difference(x, times, edge_order), times, edge_order)


def gaussian_smooth(x, sigma: float, axis: int = 0) -> np.ndarray:
    """Gaussian filter along ``axis`` with standard deviation ``sigma`` in frames
    (:func:`scipy.ndimage.gaussian_filter1d`, ``mode="nearest"``; truncated at 4 sigma).
    ``sigma`` of 0 or ``None`` returns a copy."""
    x = np.asarray(x, dtype=float)
    if not sigma:
        return x.copy()
    if sigma < 0 or not np.isfinite(sigma):
        raise ValueError(f"smoothing sigma must be >= 0 frames, got {sigma!r}")
    return gaussian_filter1d(x, sigma, axis=axis, mode="nearest")


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
