"""Restoring angular-momentum conservation after in-flight edits, steps 1 and 2
(dissertation section 5.5.1-5.5.2, flips paper section 5.5).

1. :func:`correct_direction` -- the direction of L (eq. 5.18-5.21). ``L_f`` is
   computed from poses ``f-1, f, f+1`` (central differences, the discretisation
   of :func:`mocomp.dynamics.momentum`). Walking forward through the flight,
   whenever ``unit(L_f)`` departs from the target the whole body at frame
   ``f+1`` is rotated about its COM by the rotation ``R`` that restores the
   direction; the solution for one frame warm-starts the next (eq. 5.21).
2. :func:`correct_magnitude` -- the magnitude of L by non-uniform retiming
   (eq. 5.22): ``next = last + 1/ratio(last)``, with L evaluated on
   interpolated (slerped) poses.

Step 3 (uniform retiming and COM repositioning) is :mod:`mocomp.edit.linear`;
the whole pipeline with its evidence is :func:`mocomp.edit.restore_momentum`.

**The target.** The dissertation writes the target as the constant flight
momentum ``L*`` of the unedited motion (eq. 5.19) and ``ratio(f) = |L_new(f)| /
|L*|``; the conference paper (section 5.5) writes ``ratio(f) = |L_modif(f)| /
|L(f)|`` with the original motion's own ``L(f)``. Both are supported: pass a
constant ``L_star`` (3,), or per-frame targets (T, 3) / a ``reference`` motion
(the unedited original). On exact synthetic flights they coincide; on capture
data the per-frame form leaves the unedited frames exactly untouched and
removes only what the edit changed (the capture's own momentum noise stays).
Section 5.5 starts step 1 at the first frame ``f*`` where the *edited* L departs
from ``L*`` (eq. 5.18-5.21); against a constant ``L*`` a capture's unedited frames
already depart (its own L direction varies by 0.05-0.40 rad on the CMU and DeepMimic
flips), so :func:`mocomp.edit.restore_momentum` defaults to ``reference="auto"``:
the per-frame target on such flights, the constant one on exact flights.

Every step returns the evidence the paper plots (Figures 3, 5.4, 5.5): the
per-frame direction error (radians) and magnitude error (fraction) before and
after.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_exp, quat_inverse, quat_log, quat_matrix, quat_multiply, shortest_arc
from ..dynamics.com import check_compatible
from .layers import EditRangeError

__all__ = [
    "DirectionResult",
    "MagnitudeResult",
    "correct_direction",
    "correct_magnitude",
    "direction_error",
    "magnitude_error",
    "flight_momentum",
    "interior_L",
    "sampled_L",
    "fast_sample",
    "segment_state",
    "validate_flight",
]


# ----------------------------------------------------------------- evidence
def _rows(L_star, n):
    Ls = np.asarray(L_star, dtype=float)
    return np.broadcast_to(Ls, (n, 3)) if Ls.ndim == 1 else Ls


def direction_error(L: np.ndarray, L_star: np.ndarray) -> np.ndarray:
    """``(T,)`` angle in radians between each ``L`` row and ``L*`` (one vector, or one per row)."""
    L = np.atleast_2d(np.asarray(L, dtype=float))
    u = _rows(L_star, L.shape[0])
    return np.arctan2(np.linalg.norm(np.cross(L, u), axis=1), np.sum(L * u, axis=1))


def magnitude_error(L: np.ndarray, L_star: np.ndarray) -> np.ndarray:
    """``(T,)`` relative magnitude error ``| |L| - |L*| | / |L*|`` (``L*`` one vector or one per row)."""
    L = np.atleast_2d(np.asarray(L, dtype=float))
    s = np.linalg.norm(_rows(L_star, L.shape[0]), axis=1)
    return np.abs(np.linalg.norm(L, axis=1) - s) / s


def _finite_max(errors: np.ndarray) -> float:
    """Largest finite entry (frames without an error are NaN); 0 when there is none."""
    return float(np.nanmax(errors)) if np.any(np.isfinite(errors)) else 0.0


def _nan_rows(fn, L, ref):
    """``fn(L, ref)`` on the finite rows of ``L`` (and ``ref`` when it has rows), NaN elsewhere."""
    out = np.full(L.shape[0], np.nan)
    ref = np.asarray(ref, dtype=float)
    ok = np.all(np.isfinite(L), axis=1)
    if ref.ndim == 2:
        ok &= np.all(np.isfinite(ref), axis=1)
    if ok.any():
        out[ok] = fn(L[ok], ref[ok] if ref.ndim == 2 else ref)
    return out


def segment_state(body, motion: Motion, start: int = 0, stop: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(X (n, S, 3), Q (n, S, 4))``: segment COM positions and world orientations (contiguous)
    of frames ``start:stop`` (default all; a range needs FK of its own frames only)."""
    P, G = motion.fk(frames=slice(start, stop))
    Q = np.ascontiguousarray(G[:, body.segment_joint])
    X = np.ascontiguousarray(P[:, body.segment_joint] + quat_apply(Q, body.local_coms[None]))
    return X, Q


def _frame_weights(motion: Motion, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i0, i1, alpha)`` for sampling at ``times`` exactly as :meth:`Motion.sample` does
    (times within 1e-9 frames of a frame snap to it; no clipping beyond rounding)."""
    t = np.asarray(times, dtype=float).reshape(-1)
    tol = 1e-9 * max(1.0, motion.duration)
    if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < -tol or t.max() > motion.duration + tol:
        raise ValueError(f"sample times must be finite and lie in [0, {motion.duration:.6g}] s")
    f = np.clip(t * motion.fps, 0.0, motion.n_frames - 1)
    r = np.rint(f)
    f = np.where(np.abs(f - r) <= 1e-9, r, f)
    i0 = np.minimum(np.floor(f).astype(np.int64), motion.n_frames - 1)
    i1 = np.minimum(i0 + 1, motion.n_frames - 1)
    return i0, i1, f - i0


def fast_sample(motion: Motion, times, fps: float | None = None) -> Motion:
    """:meth:`Motion.sample` with the slerp compiled (same results to rounding)."""
    rp, rot = _sample_arrays(motion, times)
    return motion.replace(root_positions=rp, rotations=rot, fps=motion.fps if fps is None else fps)


def _sample_arrays(motion: Motion, times) -> tuple[np.ndarray, np.ndarray]:
    """The ``(root_positions, rotations)`` :func:`fast_sample` builds its motion from."""
    from ._kernels import slerp_frames

    i0, i1, a = _frame_weights(motion, times)
    rp = (1 - a)[:, None] * motion.root_positions[i0] + a[:, None] * motion.root_positions[i1]
    return rp, slerp_frames(np.ascontiguousarray(motion.rotations), i0, i1, a)


def sampled_L(body, motion: Motion, times) -> np.ndarray:
    """``(n, 3)`` L (eq. 5.5, central differences on the sampled grid) of ``motion`` sampled at
    ``times`` (slerped poses, as :meth:`Motion.sample`), rows 0 and n-1 NaN; compiled and fused
    (no intermediate motion)."""
    from ._kernels import interior_momentum, sampled_segments

    i0, i1, a = _frame_weights(motion, times)
    sk = motion.skeleton
    X, Q = sampled_segments(np.asarray(sk.parents, dtype=np.int64), np.ascontiguousarray(sk.offsets, dtype=float),
                            np.ascontiguousarray(motion.root_positions), np.ascontiguousarray(motion.rotations),
                            i0, i1, a, np.asarray(body.segment_joint, dtype=np.int64),
                            np.ascontiguousarray(body.local_coms, dtype=float))
    return interior_momentum(np.ascontiguousarray(body.masses, dtype=float),
                             np.ascontiguousarray(body.inertias, dtype=float), X, Q,
                             np.asarray(times, dtype=float).reshape(-1))


def interior_L(body, motion: Motion, start: int = 0, stop: int | None = None) -> np.ndarray:
    """``(n, 3)`` L about the COM (eq. 5.5) of frames ``start:stop`` (default all) as a clip of
    their own: rows ``1 .. n-2`` (NaN at the ends), compiled; equals :func:`mocomp.dynamics.momentum`'s
    ``angular`` there (central differences)."""
    from ._kernels import interior_momentum

    start, stop, _ = slice(start, stop).indices(motion.n_frames)
    X, Q = segment_state(body, motion, start, stop)
    return interior_momentum(np.ascontiguousarray(body.masses, dtype=float),
                             np.ascontiguousarray(body.inertias, dtype=float), X, Q,
                             np.arange(stop - start) / motion.fps)


def flight_momentum(body, motion: Motion, flight) -> np.ndarray:
    """``(T, 3)`` angular momentum about the COM (eq. 5.5, central differences) on the
    flight's interior frames ``start+1 .. stop-2`` (NaN elsewhere: their differences
    straddle take-off or landing). Computed on the flight's frames only."""
    a, b = int(flight[0]), int(flight[1])
    L = np.full((motion.n_frames, 3), np.nan)
    if b - a >= 3:
        L[a + 1:b - 1] = interior_L(body, motion, a, b)[1:-1]
    return L


def validate_flight(motion: Motion, flight) -> tuple[int, int]:
    """``(start, stop)`` as ints, checked against the motion (at least 4 frames)."""
    a, b = int(flight[0]), int(flight[1])
    if not (0 <= a < b <= motion.n_frames):
        raise EditRangeError(f"flight frames [{a}, {b}) lie outside the motion's 0..{motion.n_frames}")
    if b - a < 4:
        raise EditRangeError(f"flight [{a}, {b}) has {b - a} frames; momentum correction needs at least 4")
    return a, b


class _FrameMomentum:
    """Angular momentum at one frame ``f`` as a function of a rigid rotation of
    the pose at ``f+1`` about that pose's COM (eq. 5.21), with the discretisation
    of :func:`mocomp.dynamics.momentum` (central differences of segment COMs;
    angular velocity blending the backward and forward rotation vectors).

    The orbital term is reduced to a 3x3 matrix once per frame
    (``sum_i m_i a_i x (R d_i) = axial(C0 R^T)`` with ``C0 = sum_i m_i a_i d_i^T``),
    so an evaluation costs one small matrix product plus S rotation logarithms.
    """

    def __init__(self, masses, I_local, X, Q, t, f):
        M = masses.sum()
        self.h1 = t[f] - t[f - 1]
        self.h2 = t[f + 1] - t[f]
        self.dt = self.h1 + self.h2
        Xf = X[f]
        a = Xf - masses @ Xf / M                     # (S, 3) lever arms at f
        Rf = quat_matrix(Q[f])
        self.Iw = np.einsum("sij,sjk,slk->sil", Rf, I_local, Rf)
        back = quat_log(quat_multiply(Q[f], quat_inverse(Q[f - 1]))) / self.h1
        self.w_back = self.h2 / self.dt * back
        self.wf = self.h1 / self.dt / self.h2
        c1 = masses @ X[f + 1] / M
        self.d = X[f + 1] - c1                       # (S, 3)
        ma = masses[:, None] * a
        self.C0 = ma.T @ self.d                      # (3, 3)
        self.const = np.cross(ma, c1 - X[f - 1]).sum(axis=0) / self.dt
        self.D = quat_multiply(Q[f + 1], quat_inverse(Q[f]))   # (S, 4) forward steps
        self.Iw_sum = self.Iw.sum(axis=0)
        self.ma = ma

    def L(self, q: np.ndarray) -> np.ndarray:
        """L at frame f when pose f+1 is rotated by quaternion ``q`` about its COM."""
        R = quat_matrix(q)
        C = self.C0 @ R.T
        orb = np.array([C[1, 2] - C[2, 1], C[2, 0] - C[0, 2], C[0, 1] - C[1, 0]]) / self.dt + self.const
        w = self.wf * quat_log(quat_multiply(q, self.D)) + self.w_back
        return np.einsum("sij,sj->i", self.Iw, w) + orb

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Approximate ``dL/dphi`` for ``q <- exp(phi) q`` (small-step linearisation:
        positions rotate as ``phi x d``; the forward rotation vectors change by ``phi``)."""
        d = self.d @ quat_matrix(q).T                # (S, 3) rotated lever arms at f+1
        # d/dphi sum_i m_i a_i x (phi x d_i) = sum_i m_i ((a_i . d_i) 1 - d_i a_i^T)
        ad = np.einsum("si,si->", self.ma, d)
        K = ad * np.eye(3) - d.T @ self.ma
        return K / self.dt + self.Iw_sum * self.wf


def _angle(L: np.ndarray, u: np.ndarray) -> float:
    """Angle between one vector and a unit vector."""
    c = np.cross(L, u)
    return math.atan2(math.sqrt(float(c @ c)), float(L @ u))


# ---------------------------------------------------------------- step 1
@dataclass(frozen=True, eq=False)
class DirectionResult:
    """Step 1 (eq. 5.18-5.21) output and evidence.

    Attributes
    ----------
    motion: the corrected motion (root orientation/position changed per frame, each frame
        turned about its own COM; frames after the flight carry the last frame's rotation, so
        the COM path stays the input's).
    corrections: ``(T, 4)`` rotation applied to each frame about its COM (identity before the edit).
    error_before, error_after: ``(T,)`` radians, angle between ``L_f`` and the target
        (NaN outside the flight's interior frames, where ``L_f`` is not defined by the method).
    L_before, L_after: ``(T, 3)`` kg m^2/s, ``L_f`` of the input and of the output (NaN off-flight).
    L_star: ``(3,)`` or ``(T, 3)`` kg m^2/s, the target.
    first_departure: ``f*``, the first frame whose direction error exceeded ``tol``
        (``None`` if none did).
    method: ``"smooth"``, ``"gauss-newton"`` or ``"bfgs"``.
    evaluations: number of ``L`` evaluations used.
    smoothing: ``"smooth"`` only: the joint solve's evidence
        (:class:`mocomp.edit.smooth_direction.SmoothSolve`; ``None`` when it did not run:
        nothing departed, the per-frame solution was smooth already, or it missed the
        0.01 rad acceptance so there was nothing to smooth);
        per_frame_roughness_deg: the per-frame sweep's roughness it started from.
    seconds: wall time (``solve_seconds``: the frame loop alone, without the evidence).
    flight: the flight frames corrected.
    """

    motion: Motion
    corrections: np.ndarray
    error_before: np.ndarray
    error_after: np.ndarray
    L_before: np.ndarray
    L_after: np.ndarray
    L_star: np.ndarray
    first_departure: int | None
    method: str
    evaluations: int
    seconds: float
    solve_seconds: float = 0.0
    flight: tuple[int, int] | None = None
    smoothing: object | None = None
    per_frame_roughness_deg: float | None = None

    @property
    def max_error_before(self) -> float:
        return _finite_max(self.error_before)

    @property
    def max_error_after(self) -> float:
        return _finite_max(self.error_after)

    @property
    def max_rotation_deg(self) -> float:
        """Largest correction applied to any frame (degrees)."""
        return float(np.degrees(np.max(2 * np.arccos(np.clip(np.abs(self.corrections[:, 3]), 0.0, 1.0)))))

    @property
    def roughness_deg(self) -> float:
        """Largest frame-to-frame change of the correction's per-frame increment (degrees): the
        second difference of the corrections. Eq. 5.21 fixes frame ``f+1`` from frames ``f-1``
        and ``f`` (a two-step recurrence), which can oscillate from frame to frame when limbs
        move fast relative to the frame rate; a few degrees or more means visible jitter
        (``method="smooth"`` removes the oscillation; what remains is the body's reaction
        to the limbs' own accelerations)."""
        from .smooth_direction import second_difference_deg

        c = self.corrections if self.flight is None else self.corrections[self.flight[0]:self.flight[1]]
        return float(np.max(second_difference_deg(c), initial=0.0))


def _targets(L_star, L_before, a, b, n_frames) -> np.ndarray:
    """Per-frame unit targets ``(T, 3)`` (rows outside the flight interior are unused)."""
    if L_star is None:
        L_star = L_before[a + 1]
    Ls = np.asarray(L_star, dtype=float)
    if Ls.ndim == 1:
        if Ls.shape != (3,) or not np.linalg.norm(Ls) > 0:
            raise ValueError(f"L_star must be a non-zero 3-vector, got {Ls!r}")
        U = np.broadcast_to(Ls / np.linalg.norm(Ls), (n_frames, 3)).copy()
    else:
        if Ls.shape != (n_frames, 3):
            raise ValueError(f"per-frame L_star must have shape ({n_frames}, 3), got {Ls.shape}")
        seg = Ls[a + 1:b - 1]
        n = np.linalg.norm(seg, axis=1)
        if not np.all(np.isfinite(seg)) or np.any(n <= 0):
            raise ValueError(f"per-frame L_star must be finite and non-zero on the flight frames {a + 1}..{b - 2}")
        U = np.zeros((n_frames, 3))
        U[a + 1:b - 1] = seg / n[:, None]
    return U


def correct_direction(body, motion: Motion, flight, L_star=None, method: str = "smooth",
                      tol: float = 1e-7, max_iter: int = 20, sigma: float = 1.5,
                      smooth_above_deg: float = 1.0) -> DirectionResult:
    """Keep the direction of L constant over the flight (dissertation eq. 5.18-5.21).

    Parameters
    ----------
    body: body model of the motion's skeleton.
    motion: the edited motion.
    flight: ``(start, stop)`` half-open frame range of the ballistic phase.
    L_star: the target: one vector ``(3,)`` (eq. 5.19's constant ``L*``; default: L at
        the first interior flight frame of ``motion``, which the edit must not touch),
        or per-frame targets ``(T, 3)`` (e.g. the unedited original's own ``L_f``).
    method: ``"gauss-newton"`` (compiled, an analytic linearisation of ``L(R)`` with a
        minimum-norm update, a few evaluations per frame), ``"bfgs"``
        (``scipy.optimize.minimize(method="BFGS")`` on the direction error, the paper's
        quasi-Newton method -- it used Matlab's), or ``"smooth"`` (default): the
        Gauss-Newton sweep, then all frames' corrections together
        (:mod:`mocomp.edit.smooth_direction`). The two per-frame methods are eq. 5.21
        as written, started from the previous frame's rotation; BFGS's first correction
        starts from the rotation between ``L_new`` and ``L*`` (section 5.5.1).

        *Deviation from the paper (``"smooth"``).* Eq. 5.21 frame after frame is a
        two-step recurrence (``L_f`` fixes ``R_{f+1}`` from ``R_{f-1}`` and ``R_f``) whose
        parasitic even/odd mode nothing damps: after fast limb edits the corrections
        jitter from frame to frame (:attr:`DirectionResult.roughness_deg`; 50 deg on the
        synthetic side flip with the ``straight-legs`` preset and a 0.2 ease; with the
        default 0.45 ease anywhere from 0.3 to 8 deg, set by round-off: the neutrally
        stable mode amplifies a 1e-9 rad change of one input frame to 0.03 rad). ``"smooth"`` low-passes the sweep's rotation vectors (Gaussian, ``sigma``
        frames) and projects them back onto the same constraints (unit(L_f) = unit(L*_f)
        on every flight frame, to ``tol``) by Newton steps that are smallest in a
        second- plus first-difference metric, solved as one sparse system over the whole
        flight. Same constraints, same tolerance; of their solutions, a smooth one
        (0.33 and 1.0 deg in the two cases above). If that projection does not converge,
        the per-frame solution is kept (``smoothing.converged`` is False).
    tol: direction error (radians) below which a frame is left alone.
    sigma: ``"smooth"`` only: the low-pass width in frames.
    smooth_above_deg: ``"smooth"`` only: the joint solve runs when the per-frame solution's
        roughness exceeds this (degrees; 0: always). Below ~1 deg nothing oscillates and the
        joint solution is the per-frame one to within a degree (measured: the default
        ``arms-twist`` preset on the synthetic back flip, 0.18 -> 0.17 deg), so it is not
        worth its ~8 ms.
    """
    if method not in ("smooth", "gauss-newton", "bfgs"):
        raise ValueError(f"method must be 'smooth', 'gauss-newton' or 'bfgs', got {method!r}")
    check_compatible(body, motion)
    a, b = validate_flight(motion, flight)
    t0 = time.perf_counter()
    from ._kernels import interior_momentum

    # the sweep reads frames a .. b-1 only
    X, Q = segment_state(body, motion, a, b)
    t = np.arange(b - a) / motion.fps                   # the times of motion[a:b]
    m = np.ascontiguousarray(body.masses, dtype=float)
    I_loc = np.ascontiguousarray(body.inertias, dtype=float)
    L_before = np.full((motion.n_frames, 3), np.nan)
    L_before[a + 1:b - 1] = interior_momentum(m, I_loc, X, Q, t)[1:-1]
    U = _targets(L_star, L_before, a, b, motion.n_frames)
    L_star_out = np.asarray(L_before[a + 1] if L_star is None else L_star, dtype=float)
    M = m.sum()
    n = b - a
    pivots_fl = np.einsum("s,tsk->tk", m, X) / M  # each frame's COM: the rotation pivot
    Uf = np.ascontiguousarray(U[a:b])
    ts = time.perf_counter()
    smoothing = None
    per_frame_rough = None
    if method in ("gauss-newton", "smooth"):
        from ._kernels import direction_sweep

        X0, Q0 = (X.copy(), Q.copy()) if method == "smooth" else (X, Q)
        corr_fl, evals, first, _ = direction_sweep(m, I_loc, X, Q, t, Uf, 0, n, float(tol), int(max_iter))
        if method == "smooth" and first >= 0 and n - first >= 4:
            from ._kernels import rotate_frames
            from .smooth_direction import second_difference_deg, smooth_corrections

            per_frame_rough = float(np.max(second_difference_deg(corr_fl), initial=0.0))
            sweep_err = _finite_max(direction_error(interior_momentum(m, I_loc, X, Q, t)[1:-1], Uf[1:-1]))
            if per_frame_rough > smooth_above_deg and sweep_err < 1e-2:
                smoothing = smooth_corrections(m, I_loc, X0, Q0, t, Uf, int(first), corr_fl, sigma=sigma, tol=tol)
                evals += smoothing.evaluations
            if smoothing is not None and smoothing.max_error <= max(tol, sweep_err):
                corr_fl = smoothing.corrections
                X, Q = rotate_frames(X0, Q0, np.ascontiguousarray(pivots_fl), corr_fl)
        first = None if first < 0 else int(first) + a
    else:
        corr_fl, evals, first, X, Q = _bfgs_sweep(m, body.inertias, X, Q, t, Uf, 0, n, tol, pivots_fl)
        first = None if first is None else int(first) + a
    corr = np.tile([0.0, 0.0, 0.0, 1.0], (motion.n_frames, 1))
    corr[a:b] = corr_fl
    corr[b:] = corr_fl[-1]
    solve_s = time.perf_counter() - ts
    current = corr[b - 1]
    # Apply: rotate each frame's whole body about its own COM (flight frames by their correction,
    # the frames after the flight by the last one). The COM path is the input's everywhere: the
    # frames after the flight keep its velocity at landing and its fall until the feet reach the
    # floor (a rigid turn of that block about the landing COM tilted its path: a 22 deg turn made
    # the landing COM velocity jump by 1.3 m/s sideways and the last airborne frames fall along a
    # tilted "gravity"). Frames before the flight are untouched.
    rp = np.array(motion.root_positions)
    rot = np.array(motion.rotations)
    rp[a:b] = pivots_fl + quat_apply(corr_fl, rp[a:b] - pivots_fl)
    rot[a:, 0] = quat_multiply(corr[a:], rot[a:, 0])
    if b < motion.n_frames:
        from ..flips.reposition import ComEvaluator

        rel = ComEvaluator(body).relative(np.asarray(motion.rotations[b:]))    # COM - root before the turn
        rp[b:] = motion.root_positions[b:] + rel - quat_apply(current, rel)
    out = motion.replace(root_positions=rp, rotations=rot)
    # the sweep left the corrected segment states of frames a .. b-1 in X, Q
    L_after = np.full((motion.n_frames, 3), np.nan)
    L_after[a + 1:b - 1] = interior_momentum(m, I_loc, X, Q, t)[1:-1]
    return DirectionResult(
        motion=out, corrections=corr, error_before=_nan_rows(direction_error, L_before, U),
        error_after=_nan_rows(direction_error, L_after, U), L_before=L_before, L_after=L_after,
        L_star=L_star_out, first_departure=first, method=method, evaluations=int(evals),
        seconds=time.perf_counter() - t0, solve_seconds=solve_s, flight=(a, b), smoothing=smoothing,
        per_frame_roughness_deg=per_frame_rough)


def _bfgs_sweep(m, I_local, X, Q, t, U, a, b, tol, pivots):
    """The frame loop of eq. 5.21 with scipy's BFGS per frame (the paper's optimiser)."""
    X = np.array(X)
    Q = np.array(Q)
    T = X.shape[0]
    corr = np.tile([0.0, 0.0, 0.0, 1.0], (T, 1))
    current = np.array([0.0, 0.0, 0.0, 1.0])
    first = None
    evals = 0
    for f in range(a + 1, b - 1):
        qf = current
        if qf[3] < 1.0:
            X[f + 1] = pivots[f + 1] + (X[f + 1] - pivots[f + 1]) @ quat_matrix(qf).T
            Q[f + 1] = quat_multiply(qf, Q[f + 1])
        fm = _FrameMomentum(m, I_local, X, Q, t, f)
        u = U[f]
        L0 = fm.L(np.array([0.0, 0.0, 0.0, 1.0]))
        evals += 1
        if _angle(L0, u) <= tol:
            corr[f + 1] = qf
            continue
        is_first = first is None
        if is_first:
            first = f
        # Eq. 5.21 fixes two of R's three degrees of freedom (one family of rotations keeps
        # unit(L) on target); search the plane of rotation vectors orthogonal to that family's
        # direction at the start, so the answer is the smallest such rotation (as the
        # Gauss-Newton variant's minimum-norm step) rather than an arbitrary member.
        n0 = float(np.linalg.norm(L0))
        J = ((np.eye(3) - np.outer(L0, L0) / (n0 * n0)) / n0) @ fm.jacobian(np.array([0.0, 0.0, 0.0, 1.0]))
        B = np.linalg.svd(J)[2][:2].T                      # (3, 2): the two constrained directions
        # start: the previous frame's rotation (already applied, so zero here); at the first
        # departure f*, the rotation between L_new and L* (section 5.5.1), projected on the plane
        start = B.T @ quat_log(shortest_arc(L0, u)[None])[0] if is_first else np.zeros(2)

        def cost(x):
            L = fm.L(quat_exp(B @ x))
            c = min(float(L @ u) / float(np.linalg.norm(L)), 1.0)
            return (1.0 - c) * 2.0           # ~ angle^2 near the optimum

        r = minimize(cost, start, method="BFGS", options={"gtol": 1e-14, "maxiter": 200})
        evals += int(r.nfev)
        dq = quat_exp(B @ r.x)
        X[f + 1] = pivots[f + 1] + (X[f + 1] - pivots[f + 1]) @ quat_matrix(dq).T
        Q[f + 1] = quat_multiply(dq, Q[f + 1])
        current = quat_multiply(dq, qf)
        current /= np.linalg.norm(current)
        corr[f + 1] = current
    corr[b:] = current
    return corr, evals, first, X, Q


# ---------------------------------------------------------------- step 2
@dataclass(frozen=True, eq=False)
class MagnitudeResult:
    """Step 2 (eq. 5.22) output and evidence.

    Attributes
    ----------
    motion: the retimed motion (take-off and landing frames unchanged, flight re-sampled).
    flight: new ``(start, stop)`` flight frames.
    source_times: ``(T_new,)`` s, the time in the input motion each output frame shows.
    ratio_times, ratio: the curve ``|L_new(t)| / |L_ref(t)|`` over the input flight (fine grid).
    ref_times, ref_magnitude: ``|L_ref|`` on the same fine grid (the target magnitude).
    error_before, error_after: ``(T,)``/``(T_new,)`` relative magnitude errors (NaN off-flight).
    L_before, L_after: ``(T, 3)``/``(T_new, 3)`` kg m^2/s on the interior flight frames.
    seconds: wall time.
    """

    motion: Motion
    flight: tuple[int, int]
    source_times: np.ndarray
    ratio_times: np.ndarray
    ratio: np.ndarray
    ref_magnitude: np.ndarray
    error_before: np.ndarray
    error_after: np.ndarray
    L_before: np.ndarray
    L_after: np.ndarray
    seconds: float

    @property
    def time_stretch(self) -> float:
        """New flight duration over the old one."""
        return float((self.flight[1] - 1 - self.flight[0]) / max(self.ratio_times[-1] - self.ratio_times[0], 1e-12)
                     / self.motion.fps)

    @property
    def max_error_before(self) -> float:
        return _finite_max(self.error_before)

    @property
    def max_error_after(self) -> float:
        return _finite_max(self.error_after)


def correct_magnitude(body, motion: Motion, flight, L_star=None, oversample: int = 8,
                      reference: Motion | None = None, L_before: np.ndarray | None = None) -> MagnitudeResult:
    """Non-uniform retiming of the flight so ``|L|`` stays on target (eq. 5.22).

    Eq. 5.22 steps through the input as ``next = last + 1 / ratio(last)``; here
    its continuous form ``d t_in / d t_out = 1 / ratio(t_in)`` is integrated
    exactly on a fine grid (``oversample`` x the frame rate; poses slerped and L
    computed from the interpolated poses, as the paper does for in-between
    frames) and inverted by interpolation, so frames land at exact times
    instead of accumulating Euler error. Outside the flight ``ratio = 1``.
    ``L_before`` (the input's :func:`flight_momentum`, if already known) saves its
    recomputation.

    The target magnitude is ``|L_star|`` (dissertation: ``ratio = |L_new| / |L*|``),
    or, with ``reference`` (the unedited original, same frame times), that motion's
    own ``|L(t)|`` computed the same way on the same fine grid (the conference
    paper's ``ratio = |L_modif(f)| / |L(f)|``): frames the edit did not change then
    get ``ratio = 1`` exactly.
    """
    check_compatible(body, motion)
    a, b = validate_flight(motion, flight)
    if (L_star is None) == (reference is None):
        raise ValueError("give exactly one of L_star (a constant target) or reference (the original motion)")
    if reference is not None and (reference.n_frames != motion.n_frames or reference.fps != motion.fps):
        raise ValueError(f"reference motion has {reference.n_frames} frames at {reference.fps:g} Hz; the edited "
                         f"one {motion.n_frames} at {motion.fps:g} Hz: they must share their frame times")
    if not (isinstance(oversample, (int, np.integer)) and oversample >= 1):
        raise ValueError(f"oversample must be a positive integer, got {oversample!r}")
    t0 = time.perf_counter()
    ta, tb = a / motion.fps, (b - 1) / motion.fps
    fine_fps = motion.fps * oversample
    n_fine = (b - 1 - a) * oversample + 1
    tf = ta + np.arange(n_fine) / fine_fps
    tf[-1] = tb
    Lf = sampled_L(body, motion, tf)
    if reference is not None:
        ref = np.linalg.norm(sampled_L(body, reference, tf), axis=1)
        # identical poses give identical L: keep ratio exactly 1 there (no spurious retiming)
        ref[0], ref[-1] = ref[1], ref[-2]
    else:
        ref = np.full(n_fine, float(np.linalg.norm(L_star)))
    if not np.all(ref > 0):
        raise ValueError("the target angular momentum is zero somewhere in the flight: nothing to retime against")
    mag = np.linalg.norm(Lf, axis=1)
    # ends of the flight: the one-sided differences are less accurate; hold the nearest interior value
    mag[0], mag[-1] = mag[1], mag[-2]
    ratio = mag / ref
    if not np.all(np.isfinite(ratio) & (ratio > 0)):
        raise ValueError("the edited flight has zero or undefined angular momentum somewhere; cannot retime it")
    # output time as a function of input time: tau(t) = ta + integral ratio
    tau_f = ta + np.concatenate([[0.0], np.cumsum(0.5 * (ratio[1:] + ratio[:-1]) * np.diff(tf))])
    shift = (tau_f[-1] - ta) - (tb - ta)
    total = motion.duration + shift
    n_out = int(np.floor(total * motion.fps + 1e-9)) + 1
    tau_out = np.arange(n_out) / motion.fps
    src = np.where(tau_out <= ta, tau_out, tau_out - shift)
    inside = (tau_out > ta) & (tau_out <= tau_f[-1])
    src[inside] = np.interp(tau_out[inside], tau_f, tf)
    src = np.clip(src, 0.0, motion.duration)
    # frames up to the take-off are the input's own (src = their times): copy them
    tail_rp, tail_rot = _sample_arrays(motion, src[a:])
    out = motion.replace(root_positions=np.concatenate([motion.root_positions[:a], tail_rp]),
                         rotations=np.concatenate([motion.rotations[:a], tail_rot]))
    new_b = int(np.floor(tau_f[-1] * motion.fps + 1e-9)) + 1
    if L_before is None:
        L_before = flight_momentum(body, motion, (a, b))
    L_after = flight_momentum(body, out, (a, new_b))
    tgt_before = np.interp(motion.times, tf, ref)
    tgt_after = np.interp(src, tf, ref)

    def rel(L, tgt):
        return np.abs(np.linalg.norm(L, axis=1) - tgt) / tgt

    return MagnitudeResult(
        motion=out, flight=(a, new_b), source_times=src, ratio_times=tf, ratio=ratio, ref_magnitude=ref,
        error_before=rel(L_before, tgt_before), error_after=rel(L_after, tgt_after), L_before=L_before,
        L_after=L_after, seconds=time.perf_counter() - t0)
