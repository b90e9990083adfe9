"""Seams: the root split about L, pose smoothing and momentum retiming across a seam
(dissertation section 5.4.2.2, eq. 5.14 and eq. 5.22).

Smoothing (eq. 5.14)
--------------------

Eq. 5.14 splits the root orientation into a rotation about the angular momentum
direction ``L`` and a rotation about an axis perpendicular to it, and smooths
only the latter, so that the (already continuous) rotation about ``L`` is not
disturbed. Here the split is written with the rotation about the *world* axis
``L`` on the left,

    q_r = q_L(theta) q_P,          q_P maps b = q_r^-1 L onto L by the shortest arc,

so that rotating a frame about ``L`` (``q' = q_L(a) q``) changes only ``theta``
(by ``a``) and leaves ``q_P`` and ``b`` untouched. The dissertation writes the
product as ``q_P q_L``; both orders have the same twist angle (the projection of
the quaternion on ``L``), and the left order is the one for which one seam
correction is valid for every rotated repetition (tested), which section
5.4.2.2 relies on ("computed only once and re-used").

Seam smoothing slerps joint angles over small windows on both sides of a seam:
the mismatch between the two sides at the seam time is split in half and each
side is offset towards the middle with a raised-cosine ramp, so the result is
continuous and the correction fades out over ``window`` frames. Root positions
are left to repositioning (section 5.4.4).

Retiming across seams (section 5.4.2.2, last paragraph, and the fallback of section 5.2, both
with eq. 5.22 of section 5.5.2)
-----------------------------------------------------------------------------------------------

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
from dataclasses import dataclass

import numpy as np

from ..body.model import BodyModel
from ..core._compiled import centroid, fk_pose, njit, qdelta, qrot, spin
from ..core.rotations import axis_quat, quat_apply, quat_inverse, quat_multiply, shortest_arc, slerp, twist_angle

__all__ = ["root_reference", "split_root", "split_root_about", "compose_root", "shortest_arc", "ramp", "SeamSide", "seam_corrections",
           "apply_rotation_offsets", "apply_direction_offsets", "loop_seams",
           "AngularMomentumEvaluator", "seam_speed", "reference_levels", "warp_time", "warped_positions",
           "SPEED_BOUNDS"]

def root_reference(b_ref: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A fixed root offset ``q_0`` with ``q_0 b_ref = axis``: the split below is taken of
    ``q q_0^-1`` so that it is well conditioned for every frame whose body-frame ``L``
    direction ``b`` is near ``b_ref`` (typically the mean over the flight). Without it the
    split is singular when a body axis happens to be anti-parallel to the world ``L``
    (e.g. a back flip about the body's -x axis with ``L`` along world +x)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    r = np.asarray(b_ref, dtype=float)
    r = r / np.linalg.norm(r)
    return shortest_arc(r, a)


def split_root(q: np.ndarray, axis: np.ndarray, ref: np.ndarray | None = None,
               unwrap: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 5.14 split of root orientations ``q (T, 4)``: ``(theta (T,), b (T, 3))``.

    ``theta`` is the rotation about the world ``axis`` of ``q q_0^-1`` (``q_0 = ref``, a
    fixed offset from :func:`root_reference`, identity by default), unwrapped over
    frames when ``unwrap``; ``b = q^-1 axis`` is the axis direction in the body frame,
    which fixes the perpendicular part ``q_P`` (see :func:`compose_root`). Rotating a
    frame about the world axis by ``a`` adds ``a`` to ``theta`` and leaves ``b``.
    """
    q = np.asarray(q, dtype=float)
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    qq = q if ref is None else quat_multiply(q, quat_inverse(ref))
    theta = twist_angle(qq, a)
    if unwrap and theta.ndim == 1 and theta.size > 1:
        theta = np.unwrap(theta, period=2 * np.pi)
    b = quat_apply(quat_inverse(q), a)
    return theta, b


def split_root_about(q: np.ndarray, axis: np.ndarray, frames: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`split_root` of root orientations ``q (T, 4)`` about the unit ``axis`` relative to the
    reference that conditions it for ``frames`` (typically the flight): ``(theta (T,), b (T, 3), ref (4,))``
    with ``ref = root_reference(mean of b over frames, axis)`` and ``theta`` unwrapped (``b`` does not
    depend on the reference, so it is computed once)."""
    q = np.asarray(q, dtype=float)
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    b = quat_apply(quat_inverse(q), a)
    ref = root_reference(b[frames].mean(axis=0), axis)
    theta = twist_angle(quat_multiply(q, quat_inverse(ref)), a)
    if theta.size > 1:
        theta = np.unwrap(theta, period=2 * np.pi)
    return theta, b, ref


def compose_root(theta: np.ndarray, b: np.ndarray, axis: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """Inverse of :func:`split_root`: ``q = q_L(theta) q_P q_0`` with ``q_P`` the shortest
    arc from ``q_0 b`` to ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    b = np.asarray(b, dtype=float)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    if ref is None:
        return quat_multiply(axis_quat(a, theta), shortest_arc(b, a))
    return quat_multiply(quat_multiply(axis_quat(a, theta), shortest_arc(quat_apply(np.asarray(ref, float), b), a)), ref)


def ramp(d: np.ndarray, window: int) -> np.ndarray:
    """Raised-cosine weight: 1 at distance 0 from the seam, 0 at ``window + 1`` frames (C1 at both ends)."""
    d = np.asarray(d, dtype=float)
    x = np.clip(d / (window + 1.0), 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * x))


@dataclass(frozen=True)
class SeamSide:
    """Offsets for one side of a seam (evidence and a reusable correction).

    Attributes
    ----------
    weights: ``(w,)`` ramp weight per frame of this side, ordered as the frames.
    joint_offset: ``(J, 4)`` full local-rotation offset ``q_ref^-1 q_mid`` (joint 0 unused); or
        ``(w, J, 4)``, one per frame (frames of several seams or windows corrected in one call).
    dir_offset: ``(4,)`` full body-frame rotation taking this side's ``b`` to the middle ``b``; or
        ``(w, 4)``, one per frame.
    """

    weights: np.ndarray
    joint_offset: np.ndarray
    dir_offset: np.ndarray


def seam_corrections(left_ref: np.ndarray, right_ref: np.ndarray, b_left: np.ndarray, b_right: np.ndarray,
                     window: int, pair_at_left: bool) -> tuple[SeamSide, SeamSide]:
    """Half-and-half corrections for a seam between a left block ending at frame ``a`` and
    a right block starting at ``a + 1``.

    ``left_ref``/``right_ref`` (``(J, 4)``) are the two sides' poses *at the same
    instant* (the matched pair, e.g. ``f_n`` and ``f_m`` of a self-loop, or ``f``
    and ``g`` of the landing join); that instant is frame ``a`` when
    ``pair_at_left`` else ``a + 1``. ``b_left``/``b_right`` are the body-frame
    directions of ``L`` (root swing, eq. 5.14) of the pair. The left block gets
    ``window + 1`` weights (frames ``a - window .. a``), the right block ``window + 1``
    (frames ``a + 1 .. a + 1 + window``); weights are 0 beyond the ramp.
    """
    mid = slerp(left_ref, right_ref, np.full(left_ref.shape[:-1], 0.5))
    off_l, off_r = quat_multiply(quat_inverse(np.stack([left_ref, right_ref])), mid)     # both sides at once
    bl = b_left / np.linalg.norm(b_left)
    br = b_right / np.linalg.norm(b_right)
    bm = bl + br
    bm = bm / np.linalg.norm(bm) if np.linalg.norm(bm) > 1e-9 else bl
    arc_l, arc_r = shortest_arc(np.stack([bl, br]), bm)
    left_d = np.arange(window, -1, -1) + (0 if pair_at_left else 1)   # frames a-w .. a
    right_d = np.arange(0, window + 1) + (1 if pair_at_left else 0)   # frames a+1 .. a+1+w
    return SeamSide(ramp(left_d, window), off_l, arc_l), SeamSide(ramp(right_d, window), off_r, arc_r)


def _fraction(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``q^w`` for unit quaternions ``q (..., 4)`` and weights ``w`` broadcasting on the leading axes."""
    ident = np.zeros_like(q)
    ident[..., 3] = 1.0
    return slerp(ident, q, np.broadcast_to(w, q.shape[:-1]))


def apply_rotation_offsets(rot: np.ndarray, side: SeamSide) -> np.ndarray:
    """Joint rotations ``rot (w, J, 4)`` of one seam side with the ramped offsets applied
    (``q' = q off^weight``; joint 0, the root, is left alone: see :func:`apply_direction_offsets`)."""
    out = np.array(rot, dtype=float, copy=True)
    off = np.broadcast_to(side.joint_offset[..., 1:, :], out[:, 1:].shape)
    frac = _fraction(off, side.weights[:, None])
    out[:, 1:] = quat_multiply(out[:, 1:], frac)
    return out


def apply_direction_offsets(b: np.ndarray, side: SeamSide) -> np.ndarray:
    """Root swing directions ``b (w, 3)`` of one seam side rotated by the ramped offset
    (eq. 5.14: only the part perpendicular to ``L`` is smoothed)."""
    frac = _fraction(np.broadcast_to(side.dir_offset, (b.shape[0], 4)), side.weights)
    return quat_apply(frac, b)


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


# ------------------------------------------------------------------ the loop seam of a prepared flip
def loop_seams(prep, windows) -> dict:
    """The self-looping seam ``f_{n-1} -> R(f_m)`` of a prepared flip (a
    :class:`~mocomp.flips.preprocess.PreparedFlip`) smoothed with each half-window in ``windows``, and
    its eq. 5.22 speeds, all windows in one vectorised pass (section 5.4.2.2: the seam correction is
    "computed only once and re-used" for every repetition; the candidate windows of
    :meth:`~mocomp.flips.preprocess.PreparedFlip.best_window` are evaluated together).

    Returns ``{w: (left, right, L_new, L_ref, speed_left, speed_right)}``:

    * ``left (w+1, J, 4)``, ``right (w+1, J, 4)``: smoothed rotations of source frames
      ``n-1-w .. n-1`` and ``m .. m+w`` (:func:`seam_corrections` with the pair ``f_n ~ f_m`` at
      the right block's instant, :func:`apply_rotation_offsets`; the root recomposed from its own
      rotation about ``L`` and the smoothed perpendicular part, :func:`compose_root`, eq. 5.14), at
      zero extra rotation (a copy's rotation about ``L`` is applied on the left later);
    * ``L_new``, ``L_ref`` ``(2w+4, 3)``: ``L`` of the smoothed seam at the sequence's own timing
      (source frames ``n-2-w .. n-1`` then ``R(f_m) .. R(f_{m+w+1})``) and the original's at those
      source frames (rotated with the copy), its level blended across the seam like the poses
      (:func:`reference_levels`);
    * ``speed_left``, ``speed_right`` ``(w+2,)``: :func:`seam_speed` of the two.

    The offsets at the seam do not depend on the window (only the ramp weights do), so one
    :func:`seam_corrections` serves every window; the frames of all windows are corrected in one
    call, and their ``L`` is one :meth:`AngularMomentumEvaluator.angular` over the blocks laid end to
    end (each frame's ``L`` needs only its two neighbours, and a block's first and last frames,
    where it meets the next block, are not among those kept).
    """
    ws = [int(w) for w in windows]
    if not ws:
        return {}
    m, n, phi = prep.loop.m, prep.loop.n, prep.loop.phi
    R, th, b = prep.rotations, prep.theta, prep.bdir
    left, right = seam_corrections(R[n], R[m], b[n], b[m], ws[0], pair_at_left=False)
    # rows: for each window, its left block's frames then its right block's
    frames = np.concatenate([np.r_[n - 1 - w:n, m:m + w + 1] for w in ws])
    on_right = np.concatenate([np.r_[np.zeros(w + 1, bool), np.ones(w + 1, bool)] for w in ws])
    weights = np.concatenate([np.r_[ramp(np.arange(w, -1, -1) + 1, w), ramp(np.arange(0, w + 1), w)] for w in ws])
    rows = SeamSide(weights, np.where(on_right[:, None, None], right.joint_offset, left.joint_offset),
                    np.where(on_right[:, None], right.dir_offset, left.dir_offset))
    smooth = apply_rotation_offsets(R[frames], rows)
    smooth[:, 0] = compose_root(th[frames], apply_direction_offsets(b[frames], rows), prep.axis, prep.root_ref)
    # L of every window's seam: 2 unsmoothed frames, the two blocks, 2 unsmoothed frames (the right
    # half turned by phi about L, as the copy it starts), all windows' blocks end to end
    q_phi = axis_quat(prep.axis, phi)
    blocks, turned, k = [], [], 0
    for w in ws:
        blk = smooth[k:k + 2 * w + 2]
        k += 2 * w + 2
        blocks.append(np.concatenate([R[n - 3 - w:n - 1 - w], blk, R[m + w + 1:m + w + 3]]))
        turned.append(np.r_[np.zeros(w + 3, bool), np.ones(w + 3, bool)])
    allR = np.concatenate(blocks)
    turned = np.concatenate(turned)
    allR[turned, 0] = quat_multiply(q_phi, allR[turned, 0])
    L_all = prep.momentum_evaluator.angular(allR, prep.fps)
    # the original's L at the same source frames, turned with the copy, its level blended like the poses
    L0 = prep.L_magnitude
    Lv = np.asarray(prep.momentum.angular)
    mid = float(np.sqrt(L0[n] * L0[m]))
    src = np.concatenate([np.r_[n - 2 - w:n, m:m + w + 2] for w in ws])
    ref_right = np.concatenate([np.r_[np.zeros(w + 2, bool), np.ones(w + 2, bool)] for w in ws])
    ramps = np.concatenate([np.r_[ramp(np.arange(w + 2, 0, -1), w), ramp(np.arange(0, w + 2), w)] for w in ws])
    L_ref = Lv[src]
    L_ref[ref_right] = quat_apply(np.broadcast_to(q_phi, (int(ref_right.sum()), 4)), L_ref[ref_right])
    level = np.where(ref_right, L0[m], L0[n])
    L_ref *= np.where(level > 0, (mid / np.where(level > 0, level, 1.0)) ** ramps, 1.0)[:, None]
    L_new = np.concatenate([L_all[o:o + 2 * w + 4] for o, w in zip(np.cumsum([0] + [2 * w + 6 for w in ws]), ws)])
    speed = seam_speed(L_new, L_ref)
    out, k, r = {}, 0, 0
    for w in ws:
        blk, sp = smooth[k:k + 2 * w + 2], speed[r:r + 2 * w + 4]
        Ln, Lr = L_new[r:r + 2 * w + 4], L_ref[r:r + 2 * w + 4]
        k += 2 * w + 2
        r += 2 * w + 4
        parts = (blk[:w + 1], blk[w + 1:], Ln, Lr, sp[:w + 2], sp[w + 2:])
        for a in parts:
            a.setflags(write=False)
        out[w] = parts
    return out
