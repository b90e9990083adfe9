"""Displacement maps: per-DOF offsets added to a motion (issue 15, item 2).

A :class:`DisplacementMap` holds, per frame, an offset of the root position (m, added) and a
rotation vector per joint (rad, applied through the exponential map on the right,
``q'_j = q_j exp(v_j)``: the displacement is expressed in the joint's own frame, as in the
hierarchical displacement maps of Lee & Shin 1999 that the touch-up paper uses, Shin et al.
2003 sec. 3.1). Maps are made from two motions (:meth:`DisplacementMap.between`, the log map
of ``q_j^-1 q'_j``, :func:`mocomp.core.rotations.quat_log`; applied through
:func:`~mocomp.core.rotations.quat_exp`, Sola 2017 eq. 101, 105), smoothed by a kernel of a given width in frames (Gaussian of standard
deviation ``sigma`` frames, or a least-squares cubic B-spline with knots every ``sigma``
frames), scaled by a damping factor ``rho``, and applied in turn: touch-up's schedule of
(sigma, rho) steps is :func:`apply_hierarchy`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..core.motion import Motion
from ..core.rotations import quat_exp, quat_inverse, quat_log, quat_multiply

__all__ = ["DisplacementMap", "apply_displacement", "smooth_offsets", "HierarchyStep", "HierarchyResult",
           "apply_hierarchy", "KERNELS"]

KERNELS = ("gaussian", "bspline")


#: frames of Gaussian kernel (``2 * radius + 1``) from which :func:`smooth_offsets` convolves by FFT
#: instead of directly (a direct correlation costs ``T * taps``: touch-up's 40-paper-frame ground maps
#: are 160 frames wide at 120 Hz, a 215-tap kernel)
FFT_TAPS = 64
#: rad: :meth:`DisplacementMap.between` drops a joint whose offset stays within this on every frame (rounding:
#: touch-up's targets differ from the current motion by 1e-16-1e-13 rad on 28-30 of the 31 joints of the
#: synthetic walk, one or two joints really turn; smoothing and applying the rounding was 90 % of its maps' cost)
NEGLIGIBLE_RAD = 1e-12
#: scipy's ``gaussian_filter1d`` default: the kernel is cut at this many standard deviations
TRUNCATE = 4.0


def _gaussian_kernel(sigma: float) -> np.ndarray:
    """The normalised Gaussian of ``scipy.ndimage.gaussian_filter1d`` (standard deviation ``sigma``,
    cut at :data:`TRUNCATE` sd: radius ``int(TRUNCATE sigma + 0.5)``)."""
    r = int(TRUNCATE * float(sigma) + 0.5)
    x = np.arange(-r, r + 1, dtype=float)
    k = np.exp(-0.5 / (sigma * sigma) * x * x)
    return k / k.sum()


def _gaussian_nearest(x: np.ndarray, sigma: float) -> np.ndarray:
    """``gaussian_filter1d(x, sigma, axis=0, mode="nearest")`` of a ``(T, C)`` array: scipy's direct
    correlation for short kernels, else the same truncated kernel convolved by FFT over the signal
    padded with its end values (equal to scipy to rounding, ~1e-16 of the values' range)."""
    k = _gaussian_kernel(sigma)
    r = k.size // 2
    if k.size < FFT_TAPS or x.shape[1] == 0:
        return gaussian_filter1d(x, sigma, axis=0, mode="nearest")
    from scipy.fft import irfft, next_fast_len, rfft

    T = x.shape[0]
    xp = np.concatenate([np.repeat(x[:1], r, axis=0), x, np.repeat(x[-1:], r, axis=0)])
    n = next_fast_len(xp.shape[0] + k.size - 1, real=True)
    y = irfft(rfft(xp, n, axis=0) * rfft(k, n)[:, None], n, axis=0)
    return y[2 * r:2 * r + T]


def _compiled() -> bool:
    """Whether the compiled kernels of :mod:`mocomp.ops._kernels` run (numba present and not switched off by
    ``MOCOMP_NO_NUMBA``; :data:`mocomp.core._compiled.AVAILABLE`). Module attribute ``USE_COMPILED``
    (default ``None``: follow ``AVAILABLE``) forces either path, for tests."""
    if USE_COMPILED is not None:
        return bool(USE_COMPILED)
    from ..core._compiled import AVAILABLE

    return AVAILABLE


#: ``None`` (default): the compiled kernels when numba is available; ``True`` / ``False`` forces a path
USE_COMPILED: bool | None = None


def _joints_where(mask: np.ndarray) -> np.ndarray:
    """Indices ``j`` of ``mask (T, J, K)`` true on some frame and component (``np.any(mask, axis=(0, 2))``
    through a contiguous reduction over frames: 20x faster on 10,000 x 31 x 3)."""
    T, J = mask.shape[:2]
    return np.flatnonzero(mask.reshape(T, -1).any(axis=0).reshape(J, -1).any(axis=1))


def _moving_columns(x: np.ndarray) -> np.ndarray:
    """Indices of the columns of ``x (T, C)`` that are not all zero (zero columns smooth, scale and
    apply to exactly nothing: touch-up's maps turn a few joints, a footplant hold the legs only)."""
    return np.flatnonzero((x != 0.0).any(axis=0))


def smooth_offsets(x: np.ndarray, width: float, kernel: str = "gaussian") -> np.ndarray:
    """``x (T, ...)`` smoothed along frames: ``"gaussian"`` (standard deviation ``width`` frames,
    edges by their nearest value: a constant stays constant, to rounding; scipy's
    ``gaussian_filter1d``, by FFT for kernels of :data:`FFT_TAPS` frames and more, and only on the
    columns that are not all zero) or ``"bspline"`` (the
    least-squares cubic B-spline with interior knots every ``width`` frames, end knots at the first
    and last frame; reproduces any cubic polynomial, constants included). ``width`` 0: unchanged."""
    x = np.array(x, dtype=float)
    if not (np.isfinite(width) and width >= 0):
        raise ValueError(f"smoothing width must be 0 or more frames, got {width!r}")
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {', '.join(KERNELS)}, got {kernel!r}")
    T = x.shape[0]
    if width == 0 or T < 2:
        return np.array(x)
    if kernel == "gaussian":
        flat = x.reshape(T, -1)
        cols = _moving_columns(flat)
        out = np.zeros_like(flat)
        if cols.size:
            out[:, cols] = _gaussian_nearest(flat[:, cols], width)
        return out.reshape(x.shape)
    from scipy.interpolate import make_lsq_spline

    k = 3
    t = np.arange(T, dtype=float)
    n_int = max(0, int(np.ceil((T - 1) / width)) - 1)
    inner = np.linspace(0.0, T - 1.0, n_int + 2)[1:-1]
    if T < n_int + k + 1 + 1:            # too few frames for the knots: fewer knots
        inner = inner[: max(0, T - k - 2)]
    knots = np.r_[[0.0] * (k + 1), inner, [T - 1.0] * (k + 1)]
    if T <= k:                           # 2-3 frames: a straight least-squares line
        A = np.vstack([np.ones(T), t]).T
        coef, *_ = np.linalg.lstsq(A, x.reshape(T, -1), rcond=None)
        return (A @ coef).reshape(x.shape)
    spl = make_lsq_spline(t, x.reshape(T, -1), knots, k=k)
    return spl(t).reshape(x.shape)


@dataclass(frozen=True, eq=False)
class DisplacementMap:
    """Per-frame offsets for a motion's degrees of freedom.

    Attributes
    ----------
    root: ``(T, 3)`` m, added to the root position.
    rotations: ``(T, J, 3)`` rad, rotation vectors applied on the right of each joint's local
        rotation (``q' = q exp(v)``, the root's included).
    """

    root: np.ndarray
    rotations: np.ndarray

    def __post_init__(self):
        r = np.array(self.root, dtype=float)
        v = np.array(self.rotations, dtype=float)
        if r.ndim != 2 or r.shape[1] != 3 or v.ndim != 3 or v.shape[2] != 3 or v.shape[0] != r.shape[0]:
            raise ValueError(f"a displacement map needs root (T, 3) and rotations (T, J, 3), got {r.shape} and {v.shape}")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(v))):
            raise ValueError("a displacement map must be finite")
        r.setflags(write=False)
        v.setflags(write=False)
        object.__setattr__(self, "root", r)
        object.__setattr__(self, "rotations", v)

    @classmethod
    def _trusted(cls, root: np.ndarray, rotations: np.ndarray) -> "DisplacementMap":
        """A map of arrays this module computed from valid ones (finite, the right shapes, owned by
        nobody else): made read-only and wrapped without the checks and copies of ``__init__``."""
        root.setflags(write=False)
        rotations.setflags(write=False)
        out = object.__new__(cls)
        object.__setattr__(out, "root", root)
        object.__setattr__(out, "rotations", rotations)
        return out

    @property
    def n_frames(self) -> int:
        return self.root.shape[0]

    def moving_joints(self) -> np.ndarray:
        """Indices of the joints with a non-zero rotation offset on some frame."""
        return _joints_where(self.rotations != 0.0)

    @classmethod
    def zeros(cls, n_frames: int, n_joints: int) -> "DisplacementMap":
        return cls(np.zeros((n_frames, 3)), np.zeros((n_frames, n_joints, 3)))

    @classmethod
    def constant(cls, n_frames: int, n_joints: int, root=(0.0, 0.0, 0.0), rotations=None) -> "DisplacementMap":
        """The same offset on every frame: ``root (3,)``, ``rotations (J, 3)`` (default zero)."""
        rv = np.zeros((n_joints, 3)) if rotations is None else np.asarray(rotations, dtype=float)
        return cls(np.tile(np.asarray(root, dtype=float), (n_frames, 1)), np.tile(rv, (n_frames, 1, 1)))

    @classmethod
    def between(cls, base: Motion, target: Motion, joints: Sequence[int] | None = None, *,
                negligible: float = NEGLIGIBLE_RAD) -> "DisplacementMap":
        """The map taking ``base`` to ``target`` (same skeleton and frames): root difference and
        ``log(q_base^-1 q_target)`` per joint (only ``joints`` when given, zero elsewhere). A joint whose
        offset stays within ``negligible`` rad on every frame is set to zero (default
        :data:`NEGLIGIBLE_RAD`: the rounding of a caller that recomputes every local rotation from world
        ones, as touch-up's link-set turns do; ``0`` keeps them: exact)."""
        if base.n_frames != target.n_frames or base.skeleton.n_joints != target.skeleton.n_joints:
            raise ValueError(f"displacement between motions of different size: {base.n_frames} x "
                             f"{base.skeleton.n_joints} and {target.n_frames} x {target.skeleton.n_joints}")
        J = base.skeleton.n_joints
        keep = np.ones(J, bool)
        if joints is not None:
            keep[:] = False
            keep[list(joints)] = True
        # the joints that turn by more than ``negligible`` (an unchanged joint's offset is exactly zero: q^-1 q
        # has a zero vector part in floating point too)
        if _compiled():
            from ._kernels import log_between, turned_joints

            cols = turned_joints(base.rotations, target.rotations, negligible)
            cols = cols[keep[cols]]
            v = log_between(base.rotations, target.rotations, cols) if cols.size else np.zeros((base.n_frames, J, 3))
        else:
            cols = _joints_where(base.rotations != target.rotations)
            cols = cols[keep[cols]]
            v = np.zeros((base.n_frames, J, 3))
            if cols.size:
                v[:, cols] = quat_log(quat_multiply(quat_inverse(base.rotations[:, cols]), target.rotations[:, cols]))
            if negligible > 0 and cols.size:
                vc = v[:, cols]
                small = cols[np.einsum("tjk,tjk->tj", vc, vc).max(axis=0) <= negligible * negligible]
                v[:, small] = 0.0
        return cls._trusted(target.root_positions - base.root_positions, v)

    def smoothed(self, width: float, kernel: str = "gaussian") -> "DisplacementMap":
        """Each offset smoothed along frames (:func:`smooth_offsets`)."""
        return DisplacementMap._trusted(smooth_offsets(self.root, width, kernel),
                                        smooth_offsets(self.rotations, width, kernel))

    def scaled(self, rho: float) -> "DisplacementMap":
        """Damped by ``rho`` (root offsets and rotation angles times ``rho``)."""
        if not np.isfinite(rho):
            raise ValueError(f"damping factor must be finite, got {rho!r}")
        return DisplacementMap._trusted(self.root * rho, self.rotations * rho)

    def weighted(self, weight) -> "DisplacementMap":
        """Each frame's offsets times ``weight`` ``(T,)`` (a per-frame fade: 0 leaves a frame
        alone, 1 applies the map fully)."""
        w = np.asarray(weight, dtype=float)
        if w.shape != (self.n_frames,) or not np.all(np.isfinite(w)):
            raise ValueError(f"a per-frame weight must be {self.n_frames} finite numbers, got shape {w.shape}")
        return DisplacementMap._trusted(self.root * w[:, None], self.rotations * w[:, None, None])

    def masked(self, joints: Sequence[int], root: bool = True) -> "DisplacementMap":
        """Only the given joints' rotations (and the root offset when ``root``) kept."""
        keep = np.zeros(self.rotations.shape[1], bool)
        keep[list(joints)] = True
        return DisplacementMap(self.root if root else np.zeros_like(self.root),
                               np.where(keep[None, :, None], self.rotations, 0.0))

    def __add__(self, other: "DisplacementMap") -> "DisplacementMap":
        """Sum of the offsets (first order: applying two maps in turn composes the rotations
        exactly, see :func:`apply_displacement`; the sum agrees to second order in the angles)."""
        return DisplacementMap(self.root + other.root, self.rotations + other.rotations)

    def magnitude(self) -> tuple[float, float]:
        """``(largest root offset m, largest rotation angle rad)``."""
        v = self.rotations[:, self.moving_joints()]
        return (float(np.sqrt(np.einsum("tk,tk->t", self.root, self.root)).max(initial=0.0)),
                float(np.sqrt(np.einsum("tjk,tjk->tj", v, v)).max(initial=0.0)))


def apply_displacement(motion: Motion, dmap: DisplacementMap) -> Motion:
    """``motion`` with ``dmap`` added: root positions plus ``dmap.root``, local rotations
    ``q exp(v)``. The input is not changed."""
    if dmap.n_frames != motion.n_frames or dmap.rotations.shape[1] != motion.skeleton.n_joints:
        raise ValueError(f"displacement map of {dmap.n_frames} frames x {dmap.rotations.shape[1]} joints does not "
                         f"fit a motion of {motion.n_frames} frames x {motion.skeleton.n_joints} joints")
    # products of unit quaternions and a finite offset: what Motion's validation would check holds; only
    # the joints the map turns are multiplied (q exp(0) = q exactly)
    cols = dmap.moving_joints()
    if cols.size and _compiled():
        from ._kernels import displace

        rot = displace(motion.rotations, dmap.rotations, cols)
    else:
        rot = np.array(motion.rotations)
        if cols.size:
            rot[:, cols] = quat_multiply(motion.rotations[:, cols], quat_exp(dmap.rotations[:, cols]))
    return motion.replace_trusted(motion.root_positions + dmap.root, rot)


@dataclass(frozen=True)
class HierarchyStep:
    """One level of a hierarchical displacement map: smoothing width ``sigma`` (frames), damping
    ``rho``, kernel, how many times it is applied, and an optional label (touch-up: the link sets)."""

    sigma: float
    rho: float
    kernel: str = "gaussian"
    iterations: int = 1
    label: str = ""

    def __post_init__(self):
        if not (np.isfinite(self.sigma) and self.sigma >= 0):
            raise ValueError(f"sigma must be 0 or more frames, got {self.sigma!r}")
        if not (np.isfinite(self.rho) and self.rho >= 0):
            raise ValueError(f"rho must be 0 or more, got {self.rho!r}")
        if self.kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {', '.join(KERNELS)}, got {self.kernel!r}")
        if int(self.iterations) < 1:
            raise ValueError(f"iterations must be at least 1, got {self.iterations!r}")


@dataclass(frozen=True, eq=False)
class HierarchyResult:
    """The motion after every step, the maps applied (one per iteration, in order), the step
    and iteration of each, and the magnitudes ``(root m, angle rad)`` of each map."""

    motion: Motion
    maps: tuple
    steps: tuple
    magnitudes: tuple
    seconds: float = 0.0
    post: tuple = field(default=())


def _step_weights(weights, schedule, n_frames: int) -> list:
    """One ``(T,)`` weight (or ``None``) per step from ``apply_hierarchy``'s ``weights``."""
    if weights is None:
        return [None] * len(schedule)
    if isinstance(weights, np.ndarray) and weights.ndim == 1:
        per = [weights] * len(schedule)
    else:
        per = list(weights)
        if len(per) != len(schedule):
            raise ValueError(f"weights: give one (T,) array for every step or one entry per step ({len(schedule)}), "
                             f"got {len(per)}")
    out = []
    for k, w in enumerate(per):
        if w is None:
            out.append(None)
            continue
        w = np.asarray(w, dtype=float)
        if w.shape != (n_frames,) or not np.all(np.isfinite(w)):
            raise ValueError(f"weights of step {k + 1}: expected {n_frames} finite numbers (one per frame), got "
                             f"shape {w.shape}")
        out.append(w)
    return out


def apply_hierarchy(motion: Motion, adjust: Callable[[Motion, HierarchyStep], Motion],
                    schedule: Sequence[HierarchyStep],
                    post: Callable[[Motion], Motion] | None = None, *, weights=None) -> HierarchyResult:
    """Apply a schedule of displacement-map levels (touch-up paper sec. 3.1, 4.1).

    For each step and iteration: ``target = adjust(current, step)`` gives the per-frame adjusted
    motion; the map ``current -> target`` (:meth:`DisplacementMap.between`) is smoothed with the
    step's ``sigma`` and kernel, damped by ``rho``, weighted per frame (``weights``: one ``(T,)``
    array for every step, or a sequence with one array or ``None`` per step; the weight multiplies
    the smoothed map, so a frame of weight 0 is left exactly as it is -- touch-up keeps its ground
    maps off the flights, Fig. 4) and added; then ``post`` (e.g. footplant re-enforcement,
    :func:`mocomp.ops.enforce_footplants`) is applied. Returns every map (as added, weights included).
    """
    t0 = time.perf_counter()
    cur = motion
    per_step = _step_weights(weights, schedule, motion.n_frames)
    maps, steps, mags, posts = [], [], [], []
    for s, step in enumerate(schedule):
        for it in range(int(step.iterations)):
            target = adjust(cur, step)
            d = DisplacementMap.between(cur, target).smoothed(step.sigma, step.kernel).scaled(step.rho)
            if per_step[s] is not None:
                d = d.weighted(per_step[s])
            cur = apply_displacement(cur, d)
            if post is not None:
                cur = post(cur)
                posts.append((s, it))
            maps.append(d)
            steps.append((s, it))
            mags.append(d.magnitude())
    return HierarchyResult(cur, tuple(maps), tuple(steps), tuple(mags), time.perf_counter() - t0, tuple(posts))
