"""Non-uniform retiming across seams (dissertation section 5.4.2.2, last paragraph, and the
fallback of section 5.2, both with eq. 5.22 of section 5.5.2).

Slerping joint angles over a seam window (eq. 5.14) makes the poses continuous but not
the angular momentum: the blended joints move with velocities the performer never had
while the root keeps its own rotation rate, so ``|L|`` dips or bulges over the window
(on the CMU back flip 88_01 by 15-20 %; the root's perpendicular-part blend contributes
almost nothing, the joints almost all of it). The dissertation prescribes the remedy:
"if two adjoining frames are dissimilar, resulting changes in momentum can be adjusted
by non-uniform retiming, the same way as in the case of motion modification" (5.4.2.2),
and for clips without a self-looping fragment, transitions made "automatically by
smoothing", whose momentum "we can adjust ... by applying non-uniform motion retiming"
(5.2). Eq. 5.22 plays the frames at a local speed ``1 / ratio(f)``,

    next_frame = last_frame + 1 / ratio(last_frame),   ratio(f) = |L_new(f)| / |L_ref(f)|,

so a frame whose ``|L|`` fell by the seam is shown faster (velocities, and with them
``L``, scale with the playback speed, eq. 5.8). Section 5.5 corrects the direction of ``L``
first (eq. 5.21) so that only the magnitude is left to retiming; seams are not
direction-corrected here, so the speed is the least-squares one, ``s = L_new . L_ref /
|L_new|^2`` (:func:`seam_speed`), which is eq. 5.22's ratio when the seam left the direction
alone and does not distort the genuine rotation to offset a spurious perpendicular part when
it did not (a root-tilt blend in a twist jump). Here:

* ``L_new`` is the angular momentum of the smoothed frames at the sequence's own timing
  (central differences, as :func:`mocomp.dynamics.momentum`; the root position does not
  enter ``L`` about the COM, so only rotations are needed); ``L_ref`` is the original
  clip's ``|L|`` at the same source frames, its level blended across the seam with the
  same ramp as the poses (so a level step between the two sides is smoothed, not kept).
  Only frames whose momentum the seam changed (the window and one neighbour each side,
  reached by the central differences) get a speed other than 1; the unedited frames keep
  the original's own timing.
* speeds are clipped to ``[1/2, 2]``, the range in which the dissertation found retiming
  by interpolation reliable (section 5.4.1);
* the seam speed profile of the self-looping sequence is computed once and reused for
  every repetition (as the seam smoothing itself: rotating a copy about ``L`` does not
  change ``|L|``); the landing seam's is computed at run time on its few frames.

The speed profile ``s(tau)`` over sequence frames defines a warped time ``W`` (in original
frames) with ``dW/dtau = 1/s``; the uniform factor ``k`` of section 5.4.3 then acts on
``W``: output frame ``i`` shows the sequence at ``W^-1(i k)``. With ``s = 1`` this is the
plain uniform retiming.
"""
from __future__ import annotations

import math

import numpy as np

from ..body.model import BodyModel
from ..core._compiled import centroid, fk_pose, njit, qdelta, qrot, spin

__all__ = ["AngularMomentumEvaluator", "seam_speed", "reference_levels", "warp_time", "warped_positions",
           "SPEED_BOUNDS"]

#: playback-speed range of the non-uniform retiming (section 5.4.1: 1/2 <= n <= 2)
SPEED_BOUNDS = (0.5, 2.0)

class AngularMomentumEvaluator:
    """``L`` about the whole-body COM (eq. 5.5) of a short block of frames, from local
    rotations only, with the same finite differences as :func:`mocomp.dynamics.momentum`
    (second-order central differences of segment COM positions and of segment world
    rotations). Root translation does not enter ``L`` about the COM (a velocity shared by
    all segments cancels: ``sum_i m_i (c_i - COM) = 0``), so the block is evaluated with the
    root at the origin. Values are for the interior frames ``1 .. n-2``.
    """

    def __init__(self, body: BodyModel):
        sk = body.skeleton
        if not body.total_mass > 0:
            raise ValueError("the body model has zero total mass")
        self.parents = np.ascontiguousarray(sk.parents, dtype=np.int64)
        self.offsets = np.ascontiguousarray(sk.offsets, dtype=np.float64)
        self.seg_joint = np.ascontiguousarray(body.segment_joint, dtype=np.int64)
        self.local_coms = np.ascontiguousarray(body.local_coms, dtype=np.float64)
        self.masses = np.ascontiguousarray(body.masses, dtype=np.float64)
        self.inertias = np.ascontiguousarray(body.inertias, dtype=np.float64)
        self.total_mass = float(body.total_mass)

    def angular(self, rotations: np.ndarray, fps: float) -> np.ndarray:
        """``(n - 2, 3)`` kg m^2/s, ``L`` at frames ``1 .. n-2`` of ``rotations (n, J, 4)``."""
        q = np.ascontiguousarray(rotations, dtype=np.float64)
        if q.shape[0] < 3:
            raise ValueError("angular momentum by central differences needs at least 3 frames")
        if not q.flags.writeable:
            q = q.copy()
        return _angular_nb(q, self.parents, self.offsets, self.seg_joint, self.local_coms, self.masses,
                           self.inertias, float(fps), np.empty((q.shape[0] - 2, 3)))

    def magnitude(self, rotations: np.ndarray, fps: float) -> np.ndarray:
        """``(n - 2,)`` ``|L|`` at the interior frames."""
        L = self.angular(rotations, fps)
        return np.sqrt(np.einsum("ti,ti->t", L, L))

@njit
def _angular_nb(q, parents, offsets, seg_joint, local_coms, masses, inertias, fps, out):
    """:meth:`AngularMomentumEvaluator.angular` into ``out (n-2, 3)``: forward kinematics per frame
    (core's :func:`~mocomp.core._compiled.fk_pose`, root at the origin), segment COMs and
    orientations, then eq. 5.5 with central differences at frames ``1 .. n-2``. Compiled with
    numba; without it, the same code runs as Python (the blocks are a few dozen frames)."""
    n, J, _ = q.shape
    S = seg_joint.shape[0]
    G = np.empty((J, 4))
    P = np.empty((J, 3))
    R = np.empty((n, S, 4))
    C = np.empty((n, S, 3))
    for t in range(n):
        fk_pose(parents, offsets, q, t, 0.0, 0.0, 0.0, G, P)
        for s in range(S):
            j = seg_joint[s]
            x, y, z, w = G[j, 0], G[j, 1], G[j, 2], G[j, 3]
            R[t, s, 0], R[t, s, 1], R[t, s, 2], R[t, s, 3] = x, y, z, w
            dx, dy, dz = qrot(x, y, z, w, local_coms[s, 0], local_coms[s, 1], local_coms[s, 2])
            C[t, s, 0] = P[j, 0] + dx
            C[t, s, 1] = P[j, 1] + dy
            C[t, s, 2] = P[j, 2] + dz
    M = 0.0
    for s in range(S):
        M += masses[s]
    h = 0.5 * fps
    for t in range(1, n - 1):
        cx, cy, cz = centroid(masses, C, t, M)
        Lx = 0.0
        Ly = 0.0
        Lz = 0.0
        for s in range(S):
            # world angular velocity: mean of the two one-step rotation vectors Log(R_b R_a^-1)
            wx = 0.0
            wy = 0.0
            wz = 0.0
            for a, b in ((t, t + 1), (t - 1, t)):
                lx, ly, lz = qdelta(R, a, b, s)
                wx += lx
                wy += ly
                wz += lz
            wx *= h
            wy *= h
            wz *= h
            # R I R^T w: to the body frame, times I, back
            ex, ey, ez = spin(R[t, s, 0], R[t, s, 1], R[t, s, 2], R[t, s, 3], inertias, s, wx, wy, wz)
            Lx += ex
            Ly += ey
            Lz += ez
            # m (c - COM) x v
            m = masses[s]
            rx, ry, rz = C[t, s, 0] - cx, C[t, s, 1] - cy, C[t, s, 2] - cz
            vx = h * (C[t + 1, s, 0] - C[t - 1, s, 0])
            vy = h * (C[t + 1, s, 1] - C[t - 1, s, 1])
            vz = h * (C[t + 1, s, 2] - C[t - 1, s, 2])
            Lx += m * (ry * vz - rz * vy)
            Ly += m * (rz * vx - rx * vz)
            Lz += m * (rx * vy - ry * vx)
        out[t - 1, 0] = Lx
        out[t - 1, 1] = Ly
        out[t - 1, 2] = Lz
    return out


@njit
def _landing_speed_nb(rot, lo, hi, parents, offsets, seg_joint, local_coms, masses, inertias, fps, frames,
                      extra, axis, Lv, a, w, lev_l, lev_r, mid, lo_b, hi_b):
    """Eq. 5.22 speeds of the landing seam's sequence frames ``lo+1 .. hi-2`` (see
    :func:`mocomp.flips.multiflip._seam_speeds`, whose numpy version this mirrors): ``L`` of the
    smoothed frames ``rot[lo:hi]`` (:func:`_angular_nb`), the original's ``L`` at the source
    frames turned with them about the unit ``axis``, its level blended across the seam after
    frame ``a`` with the pose ramp, and :func:`seam_speed`'s least-squares speed, clipped."""
    n = hi - lo
    L_new = _angular_nb(rot[lo:hi], parents, offsets, seg_joint, local_coms, masses, inertias, fps,
                        np.empty((n - 2, 3)))
    blend = lev_l > 0 and lev_r > 0
    out = np.empty(n - 2)
    ax, ay, az = axis[0], axis[1], axis[2]
    for k in range(n - 2):
        i = lo + 1 + k
        h = 0.5 * extra[i]
        s_ = math.sin(h)
        c = math.cos(h)
        ux, uy, uz = s_ * ax, s_ * ay, s_ * az
        f = frames[i]
        vx, vy, vz = Lv[f, 0], Lv[f, 1], Lv[f, 2]
        rx, ry, rz = qrot(ux, uy, uz, c, vx, vy, vz)
        if blend:
            d = abs(i - a) / (w + 1.0)
            wt = 0.5 * (1.0 + math.cos(math.pi * min(max(d, 0.0), 1.0)))
            sc = (mid / lev_l if i <= a else mid / lev_r) ** wt
            rx, ry, rz = rx * sc, ry * sc, rz * sc
        nx, ny, nz = L_new[k, 0], L_new[k, 1], L_new[k, 2]
        nn = nx * nx + ny * ny + nz * nz
        num = nx * rx + ny * ry + nz * rz
        ref2 = rx * rx + ry * ry + rz * rz
        sp = num / max(nn, 1e-300)
        if nn <= 1e-18 * max(ref2, 1e-24):
            sp = hi_b
        out[k] = min(max(sp, lo_b), hi_b)
    return out


def seam_speed(L_new: np.ndarray, L_ref: np.ndarray, bounds: tuple[float, float] = SPEED_BOUNDS) -> np.ndarray:
    """Eq. 5.22's local playback speed, clipped to ``bounds``.

    With magnitudes ``(n,)``: ``1 / ratio = |L_ref| / |L_new|`` as printed. With vectors
    ``(n, 3)``: the speed ``s`` that brings ``s L_new`` closest to ``L_ref`` (least squares,
    ``s = L_new . L_ref / |L_new|^2``). The two agree when the seam left the direction of ``L``
    alone, which section 5.5 arranges by correcting the direction first (eq. 5.21); where a seam
    also tilts ``L`` (a root-tilt blend in a twist jump, whose ``|L|`` is small) the magnitude
    ratio would speed up or slow down the genuine rotation to compensate for the spurious
    perpendicular part, the projection does not. A vanishing ``L_new`` gets the upper bound."""
    L_new = np.asarray(L_new, dtype=float)
    L_ref = np.asarray(L_ref, dtype=float)
    if L_new.ndim == 2:
        nn = np.einsum("ij,ij->i", L_new, L_new)
        num = np.einsum("ij,ij->i", L_new, L_ref)
        ref2 = np.einsum("ij,ij->i", L_ref, L_ref)
        s = num / np.maximum(nn, 1e-300)
        s[nn <= 1e-18 * np.maximum(ref2, 1e-24)] = bounds[1]
    else:
        s = L_ref / np.maximum(L_new, 1e-300)
        s[L_new <= 1e-9 * np.maximum(L_ref, 1e-12)] = bounds[1]
    return np.clip(s, bounds[0], bounds[1], out=s)


def warp_time(speed: np.ndarray) -> np.ndarray:
    """``(n,)`` warped time ``W`` (in original frames) of sequence frames ``0 .. n-1`` played at
    local speeds ``speed (n,)``: ``dW/dtau = 1 / s``, the time between frames ``i`` and ``i+1``
    being the mean of ``1/s`` at its ends (all ones: ``W = tau``)."""
    inv = 1.0 / np.asarray(speed, dtype=float)
    W = np.empty(inv.size)
    W[0] = 0.0
    np.cumsum(0.5 * (inv[:-1] + inv[1:]), out=W[1:])
    return W


def warped_positions(W: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Output frames of the retiming by ``k`` on warped time ``W``: ``(times, tau)`` where output
    frame ``i`` is at warped time ``i k`` (original frames) and shows sequence position
    ``tau = W^-1(i k)``; the last output frame is at or before the sequence's end."""
    n_out = int(math.floor(W[-1] / k + 1e-9)) + 1
    tw = np.arange(n_out) * k
    tw = np.minimum(tw, W[-1])
    return tw, np.interp(tw, W, np.arange(W.size, dtype=float))


def reference_levels(L_src: np.ndarray, level_side: float, level_mid: float, weights: np.ndarray) -> np.ndarray:
    """Reference ``|L|`` of one side of a seam: the original ``|L|`` of its source frames, its level
    moved from this side's level at the seam (``level_side``) toward the seam's middle level
    (``level_mid``, geometric mean of the two sides) with the pose ramp ``weights``, so a level
    step between the two sides is smoothed like the poses rather than kept."""
    if not level_side > 0:
        return np.asarray(L_src, dtype=float)
    return np.asarray(L_src, dtype=float) * (level_mid / level_side) ** np.asarray(weights, dtype=float)
