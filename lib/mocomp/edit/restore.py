"""Restoring momentum conservation after in-flight edits (dissertation section 5.5,
flips paper section 5.5).

Three steps:

1. :func:`correct_direction` -- the direction of L (eq. 5.18-5.21). ``L_f`` is
   computed from poses ``f-1, f, f+1`` (central differences, the same
   discretisation as :func:`mocomp.dynamics.momentum`). Walking forward through
   the flight, whenever ``unit(L_f)`` departs from ``unit(L*)`` the whole body at
   frame ``f+1`` is rotated about its COM by the rotation ``R`` that restores the
   direction; the solution for one frame warm-starts the next (eq. 5.21).
2. :func:`correct_magnitude` -- the magnitude of L by non-uniform retiming
   (eq. 5.22): ``next = last + 1/ratio(last)``, ``ratio(f) = |L_new(f)| / |L*|``,
   with L evaluated on interpolated (slerped) poses.
3. Uniform retiming and COM repositioning onto the gravity parabola
   (:func:`restore_momentum`, using :mod:`mocomp.flips` retiming/repositioning).

Every step returns the evidence the paper plots (Figures 3, 5.4, 5.5): the
per-frame direction error (radians) and magnitude error (fraction) before and
after.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_inverse, quat_multiply
from ..dynamics.com import check_compatible
from ..dynamics.momentum import momentum

__all__ = [
    "DirectionResult",
    "MagnitudeResult",
    "correct_direction",
    "correct_magnitude",
    "direction_error",
    "magnitude_error",
]


# ----------------------------------------------------------------- evidence
def direction_error(L: np.ndarray, L_star: np.ndarray) -> np.ndarray:
    """``(T,)`` angle in radians between each ``L`` row and ``L*``."""
    L = np.atleast_2d(L)
    u = np.asarray(L_star, dtype=float)
    u = u / np.linalg.norm(u)
    return np.arctan2(np.linalg.norm(np.cross(L, u), axis=1), L @ u)


def magnitude_error(L: np.ndarray, L_star: np.ndarray) -> np.ndarray:
    """``(T,)`` relative magnitude error ``| |L| - |L*| | / |L*|``."""
    n = np.linalg.norm(np.atleast_2d(L), axis=1)
    s = float(np.linalg.norm(L_star))
    return np.abs(n - s) / s


# ------------------------------------------------- small quaternion helpers
def _qlog(q: np.ndarray) -> np.ndarray:
    """Rotation vectors of unit quaternions (short way), rows."""
    q = np.where(q[..., 3:4] < 0, -q, q)
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    ang = 2.0 * np.arctan2(s, q[..., 3:4])
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s > 1e-12, ang / np.where(s > 1e-12, s, 1.0), 2.0)
    return v * k


def _qexp(phi: np.ndarray) -> np.ndarray:
    phi = np.asarray(phi, dtype=float)
    a = np.linalg.norm(phi, axis=-1, keepdims=True)
    half = 0.5 * a
    k = np.where(a > 1e-12, np.sin(half) / np.where(a > 1e-12, a, 1.0), 0.5)
    return np.concatenate([phi * k, np.cos(half)], axis=-1)


def _left_matrix(q: np.ndarray) -> np.ndarray:
    """4x4 matrix ``A`` with ``q * p = p @ A`` for scalar-last quaternions ``p`` (rows)."""
    x, y, z, w = q
    return np.array([
        [w, z, -y, -x],
        [-z, w, x, -y],
        [y, -x, w, -z],
        [x, y, z, w],
    ])


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
        Rf = _quat_matrix(Q[f])
        self.Iw = np.einsum("sij,sjk,slk->sil", Rf, I_local, Rf)
        back = _qlog(quat_multiply(Q[f], quat_inverse(Q[f - 1]))) / self.h1
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
        R = _quat_matrix1(q)
        C = self.C0 @ R.T
        orb = np.array([C[1, 2] - C[2, 1], C[2, 0] - C[0, 2], C[0, 1] - C[1, 0]]) / self.dt + self.const
        w = self.wf * _qlog(self.D @ _left_matrix(q)) + self.w_back
        return np.einsum("sij,sj->i", self.Iw, w) + orb

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Approximate ``dL/dphi`` for ``q <- exp(phi) q`` (small-step linearisation:
        positions rotate as ``phi x d``; the forward rotation vectors change by ``phi``)."""
        d = self.d @ _quat_matrix1(q).T                # (S, 3) rotated lever arms at f+1
        # d/dphi sum_i m_i a_i x (phi x d_i) = sum_i m_i ((a_i . d_i) 1 - d_i a_i^T)
        ad = np.einsum("si,si->", self.ma, d)
        K = ad * np.eye(3) - d.T @ self.ma
        return K / self.dt + self.Iw_sum * self.wf


def _quat_matrix1(q) -> np.ndarray:
    """Rotation matrix of one quaternion (plain floats: cheap for single rotations)."""
    x, y, z, w = (float(v) for v in q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _qmul1(a, b) -> np.ndarray:
    """Hamilton product of two single quaternions (plain floats)."""
    ax, ay, az, aw = (float(v) for v in a)
    bx, by, bz, bw = (float(v) for v in b)
    return np.array([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ])


def _angle(L: np.ndarray, u: np.ndarray) -> float:
    """Angle between one vector and a unit vector."""
    c = np.cross(L, u)
    return math.atan2(math.sqrt(float(c @ c)), float(L @ u))


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    x, y, z, w = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    c = np.cross(a, b)
    d = float(a @ b)
    if d < -1 + 1e-12:
        perp = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(perp) < 1e-6:
            perp = np.cross(a, [0.0, 1.0, 0.0])
        return np.append(perp / np.linalg.norm(perp), 0.0)
    q = np.append(c, 1.0 + d)
    return q / np.linalg.norm(q)


# ---------------------------------------------------------------- step 1
@dataclass(frozen=True, eq=False)
class DirectionResult:
    """Step 1 (eq. 5.18-5.21) output and evidence.

    Attributes
    ----------
    motion: the corrected motion (root orientation/position changed per frame;
        frames after the flight carry the last frame's rotation rigidly).
    corrections: ``(T, 4)`` rotation applied to each frame about its COM (identity before the edit).
    error_before, error_after: ``(T,)`` radians, angle between ``L_f`` and ``L*``
        (NaN outside the flight's interior frames, where ``L_f`` is not defined by the method).
    L_star: ``(3,)`` kg m^2/s target.
    first_departure: ``f*``, the first frame whose direction error exceeded ``tol``
        (``None`` if none did).
    method: ``"gauss-newton"`` or ``"bfgs"``.
    evaluations: number of L evaluations used.
    seconds: wall time.
    """

    motion: Motion
    corrections: np.ndarray
    error_before: np.ndarray
    error_after: np.ndarray
    L_star: np.ndarray
    first_departure: int | None
    method: str
    evaluations: int
    seconds: float


def _flight_L(body, motion, flight):
    L = np.full((motion.n_frames, 3), np.nan)
    res = momentum(body, motion)
    a, b = flight
    L[a + 1:b - 1] = res.angular[a + 1:b - 1]
    return L


def _validate_flight(motion: Motion, flight) -> tuple[int, int]:
    a, b = int(flight[0]), int(flight[1])
    if not (0 <= a < b <= motion.n_frames):
        raise ValueError(f"flight frames [{a}, {b}) lie outside the motion's 0..{motion.n_frames}")
    if b - a < 4:
        raise ValueError(f"flight [{a}, {b}) has {b - a} frames; momentum correction needs at least 4")
    return a, b


def correct_direction(body, motion: Motion, flight, L_star=None, method: str = "gauss-newton",
                      tol: float = 1e-7, max_iter: int = 20) -> DirectionResult:
    """Keep the direction of L constant over the flight (dissertation eq. 5.18-5.21).

    Parameters
    ----------
    body: body model of the motion's skeleton.
    motion: the edited motion.
    flight: ``(start, stop)`` half-open frame range of the ballistic phase.
    L_star: the target angular momentum (the original flight's; default: L at
        the first interior flight frame of ``motion``, which the edit must not
        touch, eq. 5.19).
    method: ``"gauss-newton"`` (default; an analytic linearisation of
        ``L(R)`` with a minimum-norm update, a few evaluations per frame) or
        ``"bfgs"`` (``scipy.optimize.minimize(method="BFGS")`` on the squared
        direction angle plus a tiny pull toward the warm start, as the paper
        used Matlab's quasi-Newton method). Both are started from the previous
        frame's rotation; the first correction starts from the rotation between
        ``L_new`` and ``L*`` (section 5.5.1).
    tol: direction error (radians) below which a frame is left alone.
    """
    if method not in ("gauss-newton", "bfgs"):
        raise ValueError(f"method must be 'gauss-newton' or 'bfgs', got {method!r}")
    check_compatible(body, motion)
    a, b = _validate_flight(motion, flight)
    t0 = time.perf_counter()
    P, G = motion.fk()
    sj = body.segment_joint
    Q = np.array(G[:, sj])
    X = P[:, sj] + quat_apply(Q, body.local_coms[None])
    t = motion.times
    m = body.masses
    M = m.sum()
    L_before = _flight_L(body, motion, (a, b))
    if L_star is None:
        L_star = L_before[a + 1]
    L_star = np.asarray(L_star, dtype=float)
    u = L_star / np.linalg.norm(L_star)
    corr = np.tile([0.0, 0.0, 0.0, 1.0], (motion.n_frames, 1))
    current = np.array([0.0, 0.0, 0.0, 1.0])
    first = None
    evals = 0
    pivots = np.einsum("s,tsk->tk", m, X) / M  # each frame's COM (rotation pivot; unchanged by the rotation)

    for f in range(a + 1, b - 1):
        # Carry the previous correction to frame f+1, then refine it.
        qf = current
        if qf[3] < 1.0:
            X[f + 1] = pivots[f + 1] + (X[f + 1] - pivots[f + 1]) @ _quat_matrix1(qf).T
            Q[f + 1] = quat_multiply(qf, Q[f + 1])
        fm = _FrameMomentum(m, body.inertias, X, Q, t, f)
        L0 = fm.L(np.array([0.0, 0.0, 0.0, 1.0]))
        evals += 1
        err = _angle(L0, u)
        if err <= tol:
            corr[f + 1] = qf
            continue
        is_first = first is None
        if is_first:
            first = f
        dq = _solve_frame(fm, u, method, tol, max_iter, paper_start=is_first)
        evals += dq[1]
        dq = dq[0]
        X[f + 1] = pivots[f + 1] + (X[f + 1] - pivots[f + 1]) @ _quat_matrix1(dq).T
        Q[f + 1] = quat_multiply(dq, Q[f + 1])
        current = _qmul1(dq, qf)
        current /= np.linalg.norm(current)
        corr[f + 1] = current
    corr[b:] = current
    # Apply: rotate each frame's whole body about its COM pivot.
    rp = pivots + quat_apply(corr, motion.root_positions - pivots)
    rot = np.array(motion.rotations)
    rot[:, 0] = quat_multiply(corr, rot[:, 0])
    if b < motion.n_frames:  # after the flight: rigid, about the last flight frame's pivot
        c = pivots[b - 1]
        rp[b:] = c + quat_apply(current, motion.root_positions[b:] - c)
    out = motion.replace(root_positions=rp, rotations=rot)
    L_after = _flight_L(body, out, (a, b))
    return DirectionResult(
        motion=out, corrections=corr, error_before=_nan_rows(direction_error, L_before, u),
        error_after=_nan_rows(direction_error, L_after, u), L_star=L_star, first_departure=first,
        method=method, evaluations=evals, seconds=time.perf_counter() - t0)


def _nan_rows(fn, L, ref):
    out = np.full(L.shape[0], np.nan)
    ok = np.all(np.isfinite(L), axis=1)
    if ok.any():
        out[ok] = fn(L[ok], ref)
    return out


def _solve_frame(fm: _FrameMomentum, u: np.ndarray, method: str, tol: float, max_iter: int,
                 paper_start: bool = False):
    """Rotation ``dq`` (applied on top of the warm start) that aligns ``L_f`` with ``u``."""
    ident = np.array([0.0, 0.0, 0.0, 1.0])
    L0 = fm.L(ident)
    evals = 1
    if method == "bfgs":
        # Start: the previous frame's rotation (already applied, so zero here); at the
        # first departure f*, the rotation between L_new and L* (section 5.5.1).
        start = _qlog(_rotation_between(L0, u)[None])[0] if paper_start else np.zeros(3)

        def cost(phi):
            L = fm.L(_qexp(phi))
            c = float(L @ u) / float(np.linalg.norm(L))
            return (1.0 - c) * 2.0 + 1e-8 * float(phi @ phi)   # ~ angle^2 near the optimum

        r = minimize(cost, start, method="BFGS", options={"gtol": 1e-12, "maxiter": 200})
        return _qexp(r.x), evals + int(r.nfev)
    q = ident
    L = L0
    eye = np.eye(3)
    for _ in range(max_iter):
        n = math.sqrt(float(L @ L))
        err_old = _angle(L, u)
        if err_old <= tol:
            break
        e = L / n - u
        J = ((eye - np.outer(L, L) / (n * n)) / n) @ fm.jacobian(q)
        # minimum-norm Gauss-Newton step (J has rank 2: rotations about L leave its direction alone)
        JtJ = J.T @ J
        step = -np.linalg.solve(JtJ + 1e-12 * np.trace(JtJ) * eye, J.T @ e)
        q_new = _qmul1(_qexp(step), q)
        L_new = fm.L(q_new)
        evals += 1
        k = 0  # backtracking keeps it robust far from the solution
        while _angle(L_new, u) > err_old and k < 6:
            step *= 0.5
            q_new = _qmul1(_qexp(step), q)
            L_new = fm.L(q_new)
            evals += 1
            k += 1
        q, L = q_new, L_new
    return q / np.linalg.norm(q), evals


# ---------------------------------------------------------------- step 2
@dataclass(frozen=True, eq=False)
class MagnitudeResult:
    """Step 2 (eq. 5.22) output and evidence.

    Attributes
    ----------
    motion: the retimed motion (take-off and landing frames unchanged, flight re-sampled).
    flight: new ``(start, stop)`` flight frames.
    source_times: ``(T_new,)`` s, the time in the input motion each output frame shows.
    ratio_times, ratio: the curve ``|L_new(t)| / |L*|`` over the input flight (fine grid).
    error_before, error_after: ``(T,)``/``(T_new,)`` relative magnitude errors (NaN off-flight).
    seconds: wall time.
    """

    motion: Motion
    flight: tuple[int, int]
    source_times: np.ndarray
    ratio_times: np.ndarray
    ratio: np.ndarray
    error_before: np.ndarray
    error_after: np.ndarray
    seconds: float


def correct_magnitude(body, motion: Motion, flight, L_star, oversample: int = 8) -> MagnitudeResult:
    """Non-uniform retiming of the flight so ``|L|`` stays ``|L*|`` (eq. 5.22).

    Eq. 5.22 steps through the input as ``next = last + 1 / ratio(last)``; here
    its continuous form ``d t_in / d t_out = 1 / ratio(t_in)`` is integrated
    exactly on a fine grid (``oversample`` x the frame rate; poses slerped and L
    computed from the interpolated poses, as the paper does for in-between
    frames) and inverted by interpolation, so frames land at exact times
    instead of accumulating Euler error. Outside the flight ``ratio = 1``.
    """
    check_compatible(body, motion)
    a, b = _validate_flight(motion, flight)
    t0 = time.perf_counter()
    Ls = float(np.linalg.norm(L_star))
    ta, tb = a / motion.fps, (b - 1) / motion.fps
    fine_fps = motion.fps * oversample
    n_fine = int(round((tb - ta) * fine_fps)) + 1
    tf = ta + np.arange(n_fine) / fine_fps
    tf[-1] = min(tf[-1], motion.duration)
    fine = motion.sample(tf, fps=fine_fps)
    Lf = momentum(body, fine).angular
    ratio = np.linalg.norm(Lf, axis=1) / Ls
    # ends of the flight: the one-sided differences are less accurate; hold the nearest interior value
    ratio[0], ratio[-1] = ratio[1], ratio[-2]
    # output time as a function of input time: tau(t) = ta + integral ratio
    tau_f = ta + np.concatenate([[0.0], np.cumsum(0.5 * (ratio[1:] + ratio[:-1]) * np.diff(tf))])
    new_flight_len = tau_f[-1] - ta
    shift = new_flight_len - (tb - ta)
    T_in = motion.times

    def t_in_of(tau):
        tau = np.asarray(tau, dtype=float)
        out = np.where(tau <= ta, tau, np.nan)
        inside = (tau > ta) & (tau <= tau_f[-1])
        out[inside] = np.interp(tau[inside], tau_f, tf)
        after = tau > tau_f[-1]
        out[after] = tau[after] - shift
        return out

    total = motion.duration + shift
    n_out = int(np.floor(total * motion.fps + 1e-9)) + 1
    tau_out = np.arange(n_out) / motion.fps
    src = np.clip(t_in_of(tau_out), 0.0, T_in[-1])
    out = motion.sample(src)
    new_a = a
    new_b = int(np.floor(tau_f[-1] * motion.fps + 1e-9)) + 1
    L_before = _flight_L(body, motion, (a, b))
    L_after = _flight_L(body, out, (new_a, new_b))
    return MagnitudeResult(
        motion=out, flight=(new_a, new_b), source_times=src, ratio_times=tf, ratio=ratio,
        error_before=_nan_rows(magnitude_error, L_before, L_star),
        error_after=_nan_rows(magnitude_error, L_after, L_star), seconds=time.perf_counter() - t0)
