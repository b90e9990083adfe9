"""Capture-noise model for robustness tests: what real clips do to clean motions.

:func:`capture_noise` applies, in this order and each optional,

* **joint-angle jitter**: every selected joint's local rotation is multiplied
  on the right (child frame) by ``Exp(n)`` with ``n ~ N(0, sigma^2 I)`` per axis
  (``joint_jitter_deg`` = sigma). With ``correlation_frames > 0`` the noise is
  Gaussian-filtered over time with that sigma (in frames) and rescaled to keep
  the per-sample sigma, like the slow drift of marker-based fits; the lag-k
  autocorrelation is then ``exp(-k^2 / (4 s^2))``;
* **root position noise**: ``N(0, root_jitter_m^2)`` per axis on the root
  positions (same temporal filtering);
* **bone-length scale** (unit errors): the skeleton and root positions scaled by
  ``length_scale`` (e.g. 2.54 for inches read as centimetres, 1/0.45 for the CMU
  length unit mistaken for inches);
* **frame-rate mislabelling**: the frames are kept, the stated rate is
  multiplied by ``fps_scale`` (2.0 labels 60 Hz data as 120 Hz: everything
  seems twice as fast and gravity fits give 4 g).

:func:`position_noise` gives virtual markers at the joints with independent
Gaussian position noise (:class:`~mocomp.io.markers.Markers`). Every function
takes an explicit ``seed`` (int or :class:`numpy.random.Generator`).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..core.motion import Motion
from ..core.rotations import quat_exp, quat_multiply
from ..io.markers import Markers

__all__ = ["NoisyMotion", "capture_noise", "position_noise"]


@dataclass(frozen=True, eq=False)
class NoisyMotion:
    """A noisy copy of a motion and the exact noise that was applied.

    Attributes
    ----------
    motion: the noisy :class:`~mocomp.core.Motion`.
    clean: the input motion.
    joint_noise: ``(T, J, 3)`` rad, rotation vectors applied to the local rotations
        (zero for joints left alone), before any length/rate change.
    root_noise: ``(T, 3)`` m, added to the root positions (before scaling).
    length_scale, fps_scale: the unit and frame-rate errors applied.
    params: the arguments of :func:`capture_noise`.
    """

    motion: Motion
    clean: Motion
    joint_noise: np.ndarray
    root_noise: np.ndarray
    length_scale: float
    fps_scale: float
    params: dict


def _rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None:
        raise ValueError("capture noise needs an explicit seed (int) or numpy Generator")
    return np.random.default_rng(seed)


def _noise(rng, shape, sigma, corr):
    """Gaussian noise with per-sample std ``sigma``, optionally Gaussian-correlated over axis 0."""
    n = rng.normal(0.0, 1.0, shape)
    if corr and corr > 0:
        n = gaussian_filter1d(n, corr, axis=0, mode="wrap")
        # a Gaussian filter (sigma s) divides the variance of white noise by 2 s sqrt(pi);
        # rescale with the exact discrete kernel's energy
        radius = int(4.0 * corr + 0.5)
        k = np.exp(-0.5 * (np.arange(-radius, radius + 1) / corr) ** 2)
        k /= k.sum()
        n /= np.sqrt(np.sum(k * k))
    return sigma * n


def capture_noise(motion: Motion, *, seed, joint_jitter_deg: float = 0.0, root_jitter_m: float = 0.0,
                  correlation_frames: float = 0.0, length_scale: float = 1.0, fps_scale: float = 1.0,
                  joints=None) -> NoisyMotion:
    """A noisy copy of ``motion`` (see the module docstring).

    Parameters
    ----------
    seed: int or numpy Generator (required).
    joint_jitter_deg: per-axis sigma of the local rotation jitter, degrees.
    root_jitter_m: per-axis sigma of the root position noise, metres.
    correlation_frames: temporal Gaussian correlation of both noises (sigma, frames); 0 = white.
    length_scale: multiply the skeleton offsets and root positions by this (unit error).
    fps_scale: multiply the stated frame rate by this (frames unchanged).
    joints: names of the joints to jitter (default: all, the root's orientation included).
    """
    for name, v in (("joint_jitter_deg", joint_jitter_deg), ("root_jitter_m", root_jitter_m),
                    ("correlation_frames", correlation_frames)):
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be >= 0, got {v!r}")
    for name, v in (("length_scale", length_scale), ("fps_scale", fps_scale)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive, got {v!r}")
    rng = _rng(seed)
    T, J = motion.n_frames, motion.skeleton.n_joints
    sel = np.ones(J, bool) if joints is None else np.isin(np.arange(J), [motion.skeleton.index(n) for n in joints])
    jn = np.zeros((T, J, 3))
    if joint_jitter_deg > 0:
        jn[:, sel] = _noise(rng, (T, int(sel.sum()), 3), np.radians(joint_jitter_deg), correlation_frames)
    rn = _noise(rng, (T, 3), root_jitter_m, correlation_frames) if root_jitter_m > 0 else np.zeros((T, 3))
    rot = quat_multiply(motion.rotations, quat_exp(jn))
    out = motion.replace(rotations=rot, root_positions=motion.root_positions + rn)
    notes = []
    if length_scale != 1.0:
        out = out.replace(skeleton=out.skeleton.scaled(length_scale), root_positions=out.root_positions * length_scale)
        notes.append(f"capture noise: lengths x{length_scale:g}")
    if fps_scale != 1.0:
        out = out.replace(fps=motion.fps * fps_scale)
        notes.append(f"capture noise: frame rate labelled x{fps_scale:g}")
    if joint_jitter_deg or root_jitter_m:
        notes.append(f"capture noise: joint jitter {joint_jitter_deg:g} deg, root jitter {root_jitter_m:g} m, "
                     f"correlation {correlation_frames:g} frames")
    out = out.replace(source=dataclasses.replace(motion.source, notes=motion.source.notes + tuple(notes)))
    params = dict(joint_jitter_deg=joint_jitter_deg, root_jitter_m=root_jitter_m,
                  correlation_frames=correlation_frames, length_scale=length_scale, fps_scale=fps_scale,
                  joints=None if joints is None else tuple(joints))
    return NoisyMotion(out, motion, jn, rn, float(length_scale), float(fps_scale), params)


def position_noise(motion: Motion, sigma_m: float, *, seed, include_end_sites: bool = True) -> Markers:
    """Virtual markers at every joint (and end site) with i.i.d. ``N(0, sigma_m^2)`` noise per axis."""
    if not (np.isfinite(sigma_m) and sigma_m >= 0):
        raise ValueError(f"sigma_m must be >= 0, got {sigma_m!r}")
    rng = _rng(seed)
    P = motion.positions
    names = list(motion.skeleton.names)
    if include_end_sites and motion.skeleton.end_sites:
        P = np.concatenate([P, motion.end_site_positions()], axis=1)
        names += [e.name for e in motion.skeleton.end_sites]
    noisy = P + rng.normal(0.0, sigma_m, P.shape)
    return Markers(tuple(names), noisy, motion.fps, source=motion.source.path)
