"""Frame distance functions of dissertation ch. 6.2, evaluated on band cells only.

* Phase matching, eq. 6.6: the signs of the first and second time derivatives
  of the four hand markers (shoulder subtracted) are compared after rotating
  the hand motion about the vertical by ``theta``, from eq. 6.7 over windows of
  5 frames x 4 markers (or from the trunk headings, or not at all).
* Value variant of eq. 6.6 (the paper's Figure 6.4 foil): the same with the
  derivative values instead of their signs.
* Within-phase refinement, eq. 6.8-6.9: forearm vector ``f = p3 - (p1+p2)/2``
  and hand vector ``h = p4 - (p1+p2)/2``; rotate the second motion so its forearm
  matches the first one's, then take the angle between the hand vectors.

The per-cell loops (including eq. 6.7's sums over windows) run compiled (numba).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.signal import savgol_coeffs

from ..core._compiled import njit
from ..errors import AlignmentError
from .bands import Band
from .markers import HandMarkers, require_frames

__all__ = [
    "ArmFeatures",
    "arm_features",
    "forearm_hand_vectors",
    "theta_band",
    "theta_eq67",
    "matched_theta",
    "rotate_vertical",
    "sign_band_costs",
    "value_band_costs",
    "angle_band_costs",
    "sign_distance",
    "hand_angle_distance",
    "marker_jitter",
]


@dataclass(frozen=True, eq=False)
class ArmFeatures:
    """Per-frame quantities the ch. 6 metrics need, for one hand-marker sequence.

    Attributes
    ----------
    rel: ``(T, 4, 3)`` markers minus the shoulder, metres.
    vel, acc: ``(T, 4, 3)`` first and second time derivatives of ``rel`` (m/s,
        m/s^2), Savitzky-Golay (cubic) over ``smooth_frames`` frames.
    vel_sign, acc_sign: ``(T, 4, 3)`` int8 signs with a dead zone: components
        with ``|.| < eps_v`` (``eps_a``) count as 0 (Table 6.1's ``v = 0``/``a = 0``).
    eps_v, eps_a: the dead zones, ``dead_zone`` times the 95th percentile of the
        absolute components over the sequence (so they scale with amplitude).
    win_x, win_z: ``(T, 4 w)`` x and z coordinates of the markers in the
        ``w``-frame window around each frame (clamped at the ends), centred
        (for eq. 6.7).
    heading: ``(T,)`` trunk heading in radians, or ``None``.
    forearm, hand: ``(T, 3)`` the vectors ``f`` and ``h`` of eq. 6.8.
    fps, smooth_frames, theta_window, dead_zone: the parameters used.
    """

    rel: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    vel_sign: np.ndarray
    acc_sign: np.ndarray
    eps_v: float
    eps_a: float
    win_x: np.ndarray
    win_z: np.ndarray
    heading: np.ndarray | None
    forearm: np.ndarray
    hand: np.ndarray
    fps: float
    smooth_frames: int
    theta_window: int
    dead_zone: float

    @property
    def n_frames(self) -> int:
        return self.rel.shape[0]


def forearm_hand_vectors(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 6.8: ``f = p3 - (p1 + p2)/2`` and ``h = p4 - (p1 + p2)/2`` for ``(..., 4, 3)`` markers."""
    P = np.asarray(positions, dtype=float)
    mid = 0.5 * (P[..., 0, :] + P[..., 1, :])
    return P[..., 2, :] - mid, P[..., 3, :] - mid


@lru_cache(maxsize=64)
def _sg_coeffs(k: int, deriv: int) -> tuple[np.ndarray, np.ndarray]:
    inner = savgol_coeffs(k, 3, deriv=deriv, use="dot")
    edge = np.stack([savgol_coeffs(k, 3, deriv=deriv, pos=p, use="dot") for p in range(k // 2)])
    return inner, edge


def savgol(x: np.ndarray, k: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """Cubic Savitzky-Golay filter (or derivative) along axis 0 over ``k`` frames.

    Equal (to round-off) to ``scipy.signal.savgol_filter(x, k, 3, deriv,
    delta, axis=0, mode="interp")`` -- the ends use the polynomial fitted to
    the first/last ``k`` frames -- but several times faster on the short
    arrays used here (tested against scipy).
    """
    x = np.asarray(x, dtype=float)
    T = x.shape[0]
    if T < k:
        raise AlignmentError(f"Savitzky-Golay window of {k} frames is longer than the {T}-frame sequence")
    inner, edge = _sg_coeffs(int(k), int(deriv))
    h = k // 2
    flat = x.reshape(T, -1)
    out = np.empty_like(flat)
    out[h:T - h] = np.lib.stride_tricks.sliding_window_view(flat, k, axis=0) @ inner
    out[:h] = edge @ flat[:k]
    out[T - h:] = (edge[::-1, ::-1] @ flat[T - k:]) * (-1.0) ** deriv
    if deriv:
        out /= delta ** deriv
    return out.reshape(x.shape)


def marker_jitter(positions: np.ndarray, k: int = 5) -> float:
    """Robust estimate of white measurement noise (metres, per coordinate) in
    marker trajectories ``(T, ...)``: the median absolute residual of a cubic
    Savitzky-Golay fit over ``k`` frames, scaled to a standard deviation
    (``1.4826 MAD``) and divided by ``sqrt(1 - c_0)``, the residual's share of
    white noise (``c_0``: the fit's centre weight). Signal the cubic cannot
    follow also counts, so on fast motion at low frame rates this is an upper
    bound. Used to calibrate the ground truth's noise against real clips."""
    x = np.asarray(positions, dtype=float)
    r = x - savgol(x, k)
    c0 = savgol_coeffs(k, 3, use="dot")[k // 2]
    return float(1.4826 * np.median(np.abs(r)) / np.sqrt(1.0 - c0))


def _signs(x: np.ndarray, eps: float) -> np.ndarray:
    return (np.sign(x) * (np.abs(x) >= eps)).astype(np.int8)


def smoothing_frames(fps: float, seconds: float) -> int:
    """Odd Savitzky-Golay window (>= 5) covering ``seconds`` at ``fps``."""
    k = int(round(seconds * fps))
    k = max(5, k + (1 - k % 2))
    return k


def arm_features(hm: HandMarkers, *, smooth: float = 0.2, dead_zone: float = 0.05, theta_window: int = 5,
                 role: str = "") -> ArmFeatures:
    """Derivatives, their signs, eq. 6.7 windows and eq. 6.8 vectors of a hand-marker sequence.

    ``smooth`` is the Savitzky-Golay window in seconds (the derivatives are
    those of a local cubic fit, on the true frame spacing ``1/fps``);
    ``dead_zone`` is relative to the 95th percentile of each derivative;
    ``theta_window`` is the eq. 6.7 window in frames (the paper: 5, i.e. 20
    marker positions).
    """
    k = smoothing_frames(hm.fps, smooth)
    require_frames(hm, k, f"a {k}-frame derivative window ({smooth:g} s at {hm.fps:g} fps)", role or "input")
    if theta_window < 1:
        raise AlignmentError(f"theta window must be >= 1 frame, got {theta_window}")
    rel = hm.relative
    dt = 1.0 / hm.fps
    vel = savgol(rel, k, 1, dt)
    acc = savgol(rel, k, 2, dt)
    eps_v = float(dead_zone * np.percentile(np.abs(vel), 95))
    eps_a = float(dead_zone * np.percentile(np.abs(acc), 95))
    T = rel.shape[0]
    w = min(int(theta_window), T)
    start = np.clip(np.arange(T) - (w - 1) // 2, 0, T - w)
    idx = start[:, None] + np.arange(w)[None, :]  # (T, w)
    win = rel[idx]  # (T, w, 4, 3)
    wx = win[..., 0].reshape(T, -1)
    wz = win[..., 2].reshape(T, -1)
    wx = wx - wx.mean(axis=1, keepdims=True)
    wz = wz - wz.mean(axis=1, keepdims=True)
    f, h = forearm_hand_vectors(savgol(hm.positions, k))
    head = None if hm.trunk_heading is None else np.unwrap(hm.trunk_heading)
    out = ArmFeatures(rel, vel, acc, _signs(vel, eps_v), _signs(acc, eps_a), eps_v, eps_a,
                      np.ascontiguousarray(wx), np.ascontiguousarray(wz), head, f, h, hm.fps, k, w, dead_zone)
    for a in (out.rel, out.vel, out.acc, out.vel_sign, out.acc_sign, out.win_x, out.win_z, out.forearm, out.hand):
        a.setflags(write=False)
    return out


def theta_eq67(p: np.ndarray, q: np.ndarray) -> float:
    """Eq. 6.7 for one pair of point sets ``p, q (N, 3)``: the rotation ``theta``
    about the vertical such that ``R_y(theta) q`` best matches ``p`` (least
    squares in the horizontal plane after removing the centroids).

    ``tan theta = (sum(x z' - x' z) - (xbar z'bar - x'bar zbar)/N) / (sum(x x' + z z') - (xbar x'bar + zbar z'bar)/N)``
    with bars denoting sums; ``atan2`` resolves the quadrant.
    """
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    N = len(p)
    x, z = p[:, 0], p[:, 2]
    xp, zp = q[:, 0], q[:, 2]
    num = np.sum(x * zp - xp * z) - (x.sum() * zp.sum() - xp.sum() * z.sum()) / N
    den = np.sum(x * xp + z * zp) - (x.sum() * xp.sum() + z.sum() * zp.sum()) / N
    return float(np.arctan2(num, den))


def theta_band(body: ArmFeatures, hand: ArmFeatures, band: Band, mode: str = "window") -> tuple[np.ndarray, np.ndarray]:
    """``cos theta`` and ``sin theta`` for every band cell.

    ``mode="window"``: eq. 6.7 over the ``w``-frame windows around both
    frames (``4 w`` marker positions); with centred window coordinates the
    numerator and denominator of eq. 6.7 are two dot products per cell
    (compiled loop). ``mode="trunk"``: the difference of the trunk
    headings. ``mode="none"``: ``theta = 0``.
    """
    if mode == "none":
        return np.ones(band.cells), np.zeros(band.cells)
    if mode == "trunk":
        if body.heading is None or hand.heading is None:
            which = "body" if body.heading is None else "hand"
            raise AlignmentError(f"theta='trunk' needs the trunk heading of the {which} motion (shoulder or waist markers)")
        r, c = band.cell_indices()
        th = body.heading[r] - hand.heading[c]
        return np.cos(th), np.sin(th)
    if mode != "window":
        raise ValueError(f"theta mode must be 'window', 'trunk' or 'none', got {mode!r}")
    if body.win_x.shape[1] != hand.win_x.shape[1]:
        raise AlignmentError(
            f"eq. 6.7 windows differ in size ({body.theta_window} vs {hand.theta_window} frames): a sequence is shorter than the window"
        )
    cs = np.empty(band.cells)
    sn = np.empty(band.cells)
    _theta_kernel(band.lo, band.hi, band.offsets, body.win_x, body.win_z, hand.win_x, hand.win_z, cs, sn)
    return cs, sn


def matched_theta(body: ArmFeatures, hand: ArmFeatures, frame_map: np.ndarray, mode: str = "window",
                  span: int = 1) -> np.ndarray:
    """``theta`` of the first pass along a frame map: for each body frame ``i``
    the rotation about the vertical that takes the hand recording at its
    matched (fractional) frame ``frame_map[i]`` onto the body recording.

    ``mode`` as in :func:`theta_band`: ``"window"`` evaluates eq. 6.7 on the
    body's window around ``i`` and the hand's window linearly interpolated at
    ``frame_map[i]``; its numerator and denominator are sums over the window,
    so summing them over ``span`` consecutive body frames is eq. 6.7 over the
    union of those windows (a least-squares angle over a longer stretch,
    which stays defined in holds, where one window barely moves).
    ``"trunk"``: the trunk-heading difference ``psi_body(i) - psi_hand(frame_map[i])``
    (unwrapped headings, interpolated). ``"none"``: zeros.
    Radians, ``(n,)``; used to turn the hand recording's eq. 6.8 vectors
    into the body's heading before the second pass (eq. 6.9).
    """
    f = np.asarray(frame_map, dtype=float)
    if f.shape != (body.n_frames,):
        raise AlignmentError(f"frame map has shape {f.shape}, the body motion {body.n_frames} frames")
    if mode == "none":
        return np.zeros(body.n_frames)
    if mode == "trunk":
        if body.heading is None or hand.heading is None:
            which = "body" if body.heading is None else "hand"
            raise AlignmentError(f"theta='trunk' needs the trunk heading of the {which} motion (shoulder or waist markers)")
        return body.heading - np.interp(f, np.arange(hand.n_frames), hand.heading)
    if mode != "window":
        raise ValueError(f"theta mode must be 'window', 'trunk' or 'none', got {mode!r}")
    if body.win_x.shape[1] != hand.win_x.shape[1]:
        raise AlignmentError(
            f"eq. 6.7 windows differ in size ({body.theta_window} vs {hand.theta_window} frames): a sequence is shorter than the window"
        )
    from .dtw import warp_values

    hx, hz = warp_values(hand.win_x, f), warp_values(hand.win_z, f)
    nu = np.einsum("ij,ij->i", body.win_x, hz) - np.einsum("ij,ij->i", body.win_z, hx)
    de = np.einsum("ij,ij->i", body.win_x, hx) + np.einsum("ij,ij->i", body.win_z, hz)
    span = int(span)
    if span > 1:
        from scipy.ndimage import uniform_filter1d

        nu = uniform_filter1d(nu, span, mode="nearest")
        de = uniform_filter1d(de, span, mode="nearest")
    return np.arctan2(nu, de)


def rotate_vertical(v: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``R_y(theta_t) v_t`` for vectors ``v (T, ..., 3)`` and angles ``theta (T,)``
    (the rotation of eq. 6.6: ``x' = c x + s z``, ``z' = -s x + c z``)."""
    v = np.asarray(v, dtype=float)
    th = np.asarray(theta, dtype=float).reshape((-1,) + (1,) * (v.ndim - 2))
    c, s = np.cos(th), np.sin(th)
    x, z = v[..., 0], v[..., 2]
    return np.stack([c * x + s * z, v[..., 1], -s * x + c * z], axis=-1)


@njit(fastmath=True)
def _theta_kernel(lo, hi, off, bx, bz, hx, hz, cs, sn):  # pragma: no cover - compiled
    L = bx.shape[1]
    for i in range(lo.shape[0]):
        for j in range(lo[i], hi[i] + 1):
            k = off[i] + j - lo[i]
            nu = 0.0
            de = 0.0
            for q in range(L):
                nu += bx[i, q] * hz[j, q] - bz[i, q] * hx[j, q]
                de += bx[i, q] * hx[j, q] + bz[i, q] * hz[j, q]
            r = np.sqrt(nu * nu + de * de)
            if r > 1e-300:
                cs[k] = de / r
                sn[k] = nu / r
            else:
                cs[k] = 1.0
                sn[k] = 0.0


@njit(inline="always")
def _sgn(x, eps):  # pragma: no cover - compiled
    # branch-free: signs of real motion data are unpredictable for a branch predictor
    return np.int64(x >= eps) - np.int64(x <= -eps)


@njit
def _sign_kernel(lo, hi, off, sv, sa, vh, ah, eps_v, eps_a, cs, sn, out):  # pragma: no cover - compiled
    n = lo.shape[0]
    M = sv.shape[1]
    m = vh.shape[0]
    yv = np.empty((m, M), dtype=np.int64)  # R_y leaves the vertical component alone
    ya = np.empty((m, M), dtype=np.int64)
    for j in range(m):
        for q in range(M):
            yv[j, q] = _sgn(vh[j, q, 1], eps_v)
            ya[j, q] = _sgn(ah[j, q, 1], eps_a)
    for i in range(n):
        for j in range(lo[i], hi[i] + 1):
            k = off[i] + j - lo[i]
            c = cs[k]
            s = sn[k]
            tot = 0
            for q in range(M):
                x = vh[j, q, 0]
                z = vh[j, q, 2]
                d = sv[i, q, 0] - _sgn(c * x + s * z, eps_v)
                tot += d * d
                d = sv[i, q, 1] - yv[j, q]
                tot += d * d
                d = sv[i, q, 2] - _sgn(-s * x + c * z, eps_v)
                tot += d * d
                x = ah[j, q, 0]
                z = ah[j, q, 2]
                d = sa[i, q, 0] - _sgn(c * x + s * z, eps_a)
                tot += d * d
                d = sa[i, q, 1] - ya[j, q]
                tot += d * d
                d = sa[i, q, 2] - _sgn(-s * x + c * z, eps_a)
                tot += d * d
            out[k] = tot


@njit
def _value_kernel(lo, hi, off, vb, ab, vh, ah, tau2, cs, sn, out):  # pragma: no cover - compiled
    n = lo.shape[0]
    M = vb.shape[1]
    for i in range(n):
        for j in range(lo[i], hi[i] + 1):
            k = off[i] + j - lo[i]
            c = cs[k]
            s = sn[k]
            tot = 0.0
            for q in range(M):
                x = vh[j, q, 0]
                z = vh[j, q, 2]
                d0 = vb[i, q, 0] - (c * x + s * z)
                d1 = vb[i, q, 1] - vh[j, q, 1]
                d2 = vb[i, q, 2] - (-s * x + c * z)
                tot += d0 * d0 + d1 * d1 + d2 * d2
                x = ah[j, q, 0]
                z = ah[j, q, 2]
                d0 = ab[i, q, 0] - (c * x + s * z)
                d1 = ab[i, q, 1] - ah[j, q, 1]
                d2 = ab[i, q, 2] - (-s * x + c * z)
                tot += tau2 * (d0 * d0 + d1 * d1 + d2 * d2)
            out[k] = tot


@njit
def _angle_kernel(lo, hi, off, fb, hb, fh, hh, out):  # pragma: no cover - compiled
    n = lo.shape[0]
    # fb, fh: unit forearm vectors
    for i in range(n):
        bx, by, bz = fb[i, 0], fb[i, 1], fb[i, 2]
        gx, gy, gz = hb[i, 0], hb[i, 1], hb[i, 2]
        for j in range(lo[i], hi[i] + 1):
            k = off[i] + j - lo[i]
            ax, ay, az = fh[j, 0], fh[j, 1], fh[j, 2]
            # minimal rotation R with R a = b (Rodrigues): R v = c v + u x v + u (u.v) / (1 + c), u = a x b
            c = ax * bx + ay * by + az * bz
            vx, vy, vz = hh[j, 0], hh[j, 1], hh[j, 2]
            if c > -1.0 + 1e-9:
                ux = ay * bz - az * by
                uy = az * bx - ax * bz
                uz = ax * by - ay * bx
                uv = (ux * vx + uy * vy + uz * vz) / (1.0 + c)
                rx = c * vx + (uy * vz - uz * vy) + ux * uv
                ry = c * vy + (uz * vx - ux * vz) + uy * uv
                rz = c * vz + (ux * vy - uy * vx) + uz * uv
            else:
                # antiparallel: half turn about an axis p perpendicular to a
                if abs(ax) < 0.9:
                    px, py, pz = 0.0, -az, ay
                else:
                    px, py, pz = az, 0.0, -ax
                npp = np.sqrt(px * px + py * py + pz * pz)
                px /= npp
                py /= npp
                pz /= npp
                pv = px * vx + py * vy + pz * vz
                rx = 2.0 * pv * px - vx
                ry = 2.0 * pv * py - vy
                rz = 2.0 * pv * pz - vz
            cx = gy * rz - gz * ry
            cy = gz * rx - gx * rz
            cz = gx * ry - gy * rx
            out[k] = np.arctan2(np.sqrt(cx * cx + cy * cy + cz * cz), gx * rx + gy * ry + gz * rz)


def _check(body: ArmFeatures, hand: ArmFeatures, band: Band):
    if (body.n_frames, hand.n_frames) != (band.n, band.m):
        raise AlignmentError(f"band is {band.n}x{band.m}, the features are {body.n_frames}x{hand.n_frames} frames")


def sign_band_costs(body: ArmFeatures, hand: ArmFeatures, band: Band, theta: str = "window") -> np.ndarray:
    """Eq. 6.6 on every band cell: ``sum_k |sgn(v_k) - sgn(R_y(theta) v'_k)|^2 + |sgn(a_k) - sgn(R_y(theta) a'_k)|^2``.

    The body's derivatives are ``v, a``; the hand's ``v', a'`` are rotated
    per cell by ``theta`` (:func:`theta_band`) and then take signs with the
    hand's dead zones. Values are integers in ``[0, 96]``.
    """
    _check(body, hand, band)
    cs, sn = theta_band(body, hand, band, theta)
    out = np.empty(band.cells)
    _sign_kernel(band.lo, band.hi, band.offsets, body.vel_sign, body.acc_sign, np.ascontiguousarray(hand.vel),
                 np.ascontiguousarray(hand.acc), hand.eps_v, hand.eps_a, cs, sn, out)
    return out


def value_band_costs(body: ArmFeatures, hand: ArmFeatures, band: Band, theta: str = "window", tau: float = 0.1) -> np.ndarray:
    """The value-based foil of eq. 6.6 (Figure 6.4, right):
    ``sum_k |v_k - R v'_k|^2 + tau^2 |a_k - R a'_k|^2`` (``tau`` in seconds makes
    the acceleration term a velocity)."""
    _check(body, hand, band)
    cs, sn = theta_band(body, hand, band, theta)
    out = np.empty(band.cells)
    _value_kernel(band.lo, band.hi, band.offsets, np.ascontiguousarray(body.vel), np.ascontiguousarray(body.acc),
                  np.ascontiguousarray(hand.vel), np.ascontiguousarray(hand.acc), float(tau) ** 2, cs, sn, out)
    return out


def angle_band_costs(body_forearm: np.ndarray, body_hand: np.ndarray, hand_forearm: np.ndarray,
                     hand_hand: np.ndarray, band: Band) -> np.ndarray:
    """Eq. 6.9 on every band cell: the angle (radians) between ``h`` and ``R h'``,
    ``R`` the smallest rotation taking the forearm ``f'`` onto ``f`` (eq. 6.8 vectors)."""
    fb, hb, fh, hh = (np.ascontiguousarray(a, dtype=float) for a in (body_forearm, body_hand, hand_forearm, hand_hand))
    if fb.shape != hb.shape or fh.shape != hh.shape or (len(fb), len(fh)) != (band.n, band.m):
        raise AlignmentError(f"forearm/hand vectors {fb.shape}, {hb.shape}, {fh.shape}, {hh.shape} do not fit a {band.n}x{band.m} band")
    for name, a in (("body forearm", fb), ("hand forearm", fh)):
        if np.any(np.linalg.norm(a, axis=1) < 1e-9):
            raise AlignmentError(f"{name} vector has zero length at frame {int(np.argmin(np.linalg.norm(a, axis=1)))}")
    out = np.empty(band.cells)
    fb = fb / np.linalg.norm(fb, axis=1, keepdims=True)
    fh = fh / np.linalg.norm(fh, axis=1, keepdims=True)
    _angle_kernel(band.lo, band.hi, band.offsets, fb, hb, fh, hh, out)
    return out


# ----------------------------------------------------- single-pair reference
def sign_distance(v1, a1, v2, a2, theta: float = 0.0, eps1=(0.0, 0.0), eps2=(0.0, 0.0)) -> float:
    """Eq. 6.6 for one pair of frames (reference implementation for tests and
    readers): derivatives ``(4, 3)`` of the two frames, ``theta`` in radians,
    dead zones ``(eps_v, eps_a)`` of each frame's sequence."""
    c, s = np.cos(theta), np.sin(theta)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    sg = lambda x, e: np.sign(x) * (np.abs(x) >= e)
    v2r = np.asarray(v2) @ R.T
    a2r = np.asarray(a2) @ R.T
    return float(np.sum((sg(np.asarray(v1), eps1[0]) - sg(v2r, eps2[0])) ** 2)
                 + np.sum((sg(np.asarray(a1), eps1[1]) - sg(a2r, eps2[1])) ** 2))


def hand_angle_distance(f, h, f2, h2) -> float:
    """Eq. 6.9 for one pair of frames via scipy (reference for tests)."""
    from scipy.spatial.transform import Rotation

    f = np.asarray(f, float) / np.linalg.norm(f)
    f2 = np.asarray(f2, float) / np.linalg.norm(f2)
    R, _ = Rotation.align_vectors(f[None], f2[None])
    rh = R.apply(np.asarray(h2, float))
    return float(np.arctan2(np.linalg.norm(np.cross(h, rh)), np.dot(h, rh)))
