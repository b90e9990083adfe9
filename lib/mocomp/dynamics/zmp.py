"""Zero moment point (touch-up paper, Shin et al. 2003, eq. 4) and support-polygon distance.

With gravity ``g = (0, -g, 0)`` (y up) and the floor at ``y = y0``, point masses
``m_i`` at the segment COMs ``r_i`` give::

    Z_x = [sum m_i (a_iy + g) x_i - sum m_i a_ix (y_i - y0)] / sum m_i (a_iy + g)
    Z_z = [sum m_i (a_iy + g) z_i - sum m_i a_iz (y_i - y0)] / sum m_i (a_iy + g)
    Z_y = y0

(eq. 4 with ``g_y = -g``, ``g_x = g_z = 0``, shifted from ``y = 0`` to ``y0``). The
denominator is the vertical ground reaction force; where it is below
``min_support`` of the body weight (flight) the ZMP is undefined and reported
as NaN with ``defined == False``. Like the paper, segments are point masses
(rotational inertia ignored).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kinematics import second_difference
from .com import segment_positions
from .constants import G_STANDARD
from .derivatives import smooth_motion

__all__ = ["ZMPResult", "zmp", "zmp_of_point_masses", "support_polygon_distance", "nearest_on_polygon"]


@dataclass(frozen=True, eq=False)
class ZMPResult:
    """ZMP per frame.

    Attributes
    ----------
    times: ``(T,)`` s.
    zmp: ``(T, 3)`` m, ZMP on the floor plane (``y = ground_y``); NaN where not ``defined``.
    defined: ``(T,)`` bool, vertical ground force >= ``min_support`` x body weight.
    vertical_force: ``(T,)`` N, ``sum m_i (a_iy + g)`` (the denominator of eq. 4).
    com_acceleration: ``(T, 3)`` m/s^2.
    ground_y: m, floor height used.
    g: m/s^2.
    smooth_sigma: Gaussian sigma (frames) applied to the motion before differentiating.
    """

    times: np.ndarray
    zmp: np.ndarray
    defined: np.ndarray
    vertical_force: np.ndarray
    com_acceleration: np.ndarray
    ground_y: float
    g: float
    smooth_sigma: float | None


def zmp(body, motion, g: float = G_STANDARD, ground_y: float | None = None, smooth_sigma: float | None = None,
        min_support: float = 0.05) -> ZMPResult:
    """ZMP of ``motion`` with ``body``'s segment masses (touch-up paper eq. 4).

    ``ground_y`` defaults to the clip's own ground level from
    :func:`~mocomp.dynamics.contacts.detect_contacts`. ``smooth_sigma`` (frames)
    smooths the motion first; the paper used a Gaussian of width 5.
    """
    if not (np.isfinite(g) and g > 0):
        raise ValueError(f"g must be a positive number (m/s^2), got {g!r}")
    if motion.n_frames < 3:
        raise ValueError("the ZMP needs accelerations: at least 3 frames")
    m_in = smooth_motion(motion, smooth_sigma) if smooth_sigma else motion
    if ground_y is None:
        from .contacts import detect_contacts

        ground_y = detect_contacts(m_in).ground_y
    r = segment_positions(body, m_in)
    a = second_difference(r, m_in.times)
    Z, defined, den = zmp_of_point_masses(body.masses, r, a, ground_y, g, min_support * body.total_mass * g)
    com_acc = np.einsum("s,tsk->tk", body.masses, a) / body.total_mass
    return ZMPResult(m_in.times, Z, defined, den, com_acc, float(ground_y), float(g), smooth_sigma or None)


def zmp_of_point_masses(masses, r: np.ndarray, a: np.ndarray, ground_y: float, g: float, min_force: float):
    """Eq. 4 of the touch-up paper (Shin et al. 2003, y up) for point masses ``masses`` ``(S,)``
    kg at positions ``r`` ``(T, S, 3)`` m with accelerations ``a`` ``(T, S, 3)`` m/s^2::

        Z_x = [sum m_i (a_iy + g) x_i - sum m_i a_ix (y_i - y0)] / sum m_i (a_iy + g)

    (likewise ``Z_z``) on the floor ``y0 = ground_y``. Returns ``(Z, defined, vertical_force)``:
    ``Z`` ``(T, 3)`` m, NaN where the vertical ground force ``sum m_i (a_iy + g)`` ``(T,)`` N is
    below ``min_force``."""
    m = np.asarray(masses, float)
    fy = a[..., 1] + g  # (T, S)
    den = np.einsum("s,ts->t", m, fy)
    ry = r[..., 1] - ground_y
    num_x = np.einsum("s,ts,ts->t", m, fy, r[..., 0]) - np.einsum("s,ts,ts->t", m, a[..., 0], ry)
    num_z = np.einsum("s,ts,ts->t", m, fy, r[..., 2]) - np.einsum("s,ts,ts->t", m, a[..., 2], ry)
    defined = den >= min_force
    safe = np.where(defined, den, 1.0)
    Z = np.stack([num_x / safe, np.full_like(den, ground_y), num_z / safe], axis=1)
    Z[~defined] = np.nan
    return Z, defined, den


def support_polygon_distance(zmp_points, contact_points, contact_mask=None) -> np.ndarray:
    """Signed horizontal distance ``(T,)`` m from each frame's ZMP to the support polygon.

    Parameters
    ----------
    zmp_points: ``(T, 3)`` (x, y, z) or ``(T, 2)`` (x, z) points, or a :class:`ZMPResult`.
    contact_points: ``(T, K, 3)`` world contact points (or ``(T, K, 2)`` in x, z).
    contact_mask: ``(T, K)`` bool, which points touch the ground on each frame
        (default: all).

    The support polygon is the convex hull of the frame's contact points in the
    floor plane (x, z). The distance is negative inside, positive outside, 0 on
    the boundary. With one or two contact points (collinear), the polygon is a
    point or a segment and the distance is >= 0. Frames without contact points or
    with an undefined ZMP give NaN (there is no support polygon / no ZMP).
    """
    if isinstance(zmp_points, ZMPResult):
        zmp_points = zmp_points.zmp
    z = np.asarray(zmp_points, dtype=float)
    c = np.asarray(contact_points, dtype=float)
    if z.ndim != 2 or z.shape[1] not in (2, 3):
        raise ValueError(f"zmp points must be (T, 3) or (T, 2), got {z.shape}")
    if c.ndim != 3 or c.shape[0] != z.shape[0] or c.shape[2] not in (2, 3):
        raise ValueError(f"contact points must be (T, K, 3) or (T, K, 2) with T={z.shape[0]}, got {c.shape}")
    z2 = z[:, [0, 2]] if z.shape[1] == 3 else z
    c2 = c[..., [0, 2]] if c.shape[2] == 3 else c
    mask = np.ones(c.shape[:2], dtype=bool) if contact_mask is None else np.asarray(contact_mask, dtype=bool)
    if mask.shape != c.shape[:2]:
        raise ValueError(f"contact_mask must be {c.shape[:2]}, got {mask.shape}")
    return _signed_distance_frames(z2, c2, mask)


def _pair_segments(p, pts, mask):
    """Every pair ``i <= j`` of the points ``pts`` ``(N, K, 2)`` as a segment (``i == j``: the point
    itself) and the parameter ``tt`` ``(N, P)`` of the nearest point ``a + tt (b - a)`` of each to
    ``p`` ``(N, 2)``; returns ``(iu, ju, a, ab, valid, denom, ap, tt)`` (``valid``: both ends
    masked in, ``ap = p - a``)."""
    K = mask.shape[1]
    iu, ju = np.triu_indices(K)                               # pairs i <= j, self pairs included
    a, b = pts[:, iu], pts[:, ju]                             # (N, P, 2)
    valid = mask[:, iu] & mask[:, ju]
    ab = b - a
    denom = np.einsum("npk,npk->np", ab, ab)
    ap = p[:, None] - a
    tt = np.clip(np.einsum("npk,npk->np", ap, ab) / np.where(denom > 0, denom, 1.0), 0.0, 1.0)
    tt = np.where(denom > 0, tt, 0.0)
    return iu, ju, a, ab, valid, denom, ap, tt


def nearest_on_polygon(p, pts, mask) -> np.ndarray:
    """``(T, 2)``: the nearest point to ``p`` ``(T, 2)`` on the segments between every pair of the
    masked points ``pts`` ``(T, K, 2)``. For a ``p`` outside their convex hull (the support
    polygon) this is the nearest point of the hull: it lies on a hull edge, and every segment lies
    in the hull (touch-up eq. 7's target, :mod:`mocomp.touchup.zmp`). NaN where a frame has no
    masked point or ``p`` is not finite."""
    p, pts, mask = np.asarray(p, dtype=float), np.asarray(pts, dtype=float), np.asarray(mask, dtype=bool)
    T = mask.shape[0]
    _, _, a, ab, valid, _, _, tt = _pair_segments(p, pts, mask)
    near = a + tt[..., None] * ab
    dist = np.linalg.norm(p[:, None] - near, axis=-1)
    dist = np.where(valid & np.isfinite(dist), dist, np.inf)
    k = np.argmin(dist, axis=1)
    out = near[np.arange(T), k]
    out[~np.isfinite(dist[np.arange(T), k])] = np.nan
    return out


def _signed_distance_frames(p, pts, mask, rel_eps: float = 1e-10) -> np.ndarray:
    """Vectorised over frames: signed distance ``(T,)`` of ``p`` ``(T, 2)`` to the convex hull of
    the masked points ``pts`` ``(T, K, 2)``.

    Every pair ``i <= j`` of contact points is a candidate segment (``i == j``: the point
    itself). A pair ``i < j`` is a hull edge when no two of the other points lie strictly
    on opposite sides of its line. Outside (or for a degenerate polygon: one point, or
    all points on a line -- cross products below ``rel_eps`` times the squared extent)
    the distance is the minimum over the segments, which is the distance to the hull
    (its nearest point lies on a hull edge, and every segment lies inside the hull);
    inside, minus the minimum over the hull edges. The same answers as a per-frame
    :class:`scipy.spatial.ConvexHull` (``tests/test_dynamics_zmp.py``), without a loop
    over frames.
    """
    T, K = mask.shape
    out = np.full(T, np.nan)
    ok = np.all(np.isfinite(p), axis=1) & mask.any(axis=1)
    if not ok.any() or K == 0:
        return out
    p, pts, mask = p[ok], pts[ok], mask[ok]
    iu, ju, a, ab, valid, denom, ap, tt = _pair_segments(p, pts, mask)
    dist = np.linalg.norm(ap - tt[..., None] * ab, axis=-1)    # (N, P)
    # side of every point k relative to the line of each pair
    rel = pts[:, None, :, :] - a[:, :, None, :]               # (N, P, K, 2)
    cr = ab[:, :, None, 0] * rel[..., 1] - ab[:, :, None, 1] * rel[..., 0]
    lo, hi = np.nanmin(np.where(mask[..., None], pts, np.nan), axis=1), np.nanmax(
        np.where(mask[..., None], pts, np.nan), axis=1)
    eps = rel_eps * np.max(hi - lo, axis=1) ** 2              # (N,)
    pos = ((cr > eps[:, None, None]) & mask[:, None, :]).any(axis=2)
    neg = ((cr < -eps[:, None, None]) & mask[:, None, :]).any(axis=2)
    flat = ~((pos | neg) & valid).any(axis=1) | (eps == 0)   # one point, or all on a line
    edge = valid & (iu < ju)[None] & (denom > 0) & ~(pos & neg)
    side = np.where(pos, 1.0, -1.0)                           # the interior's side of a hull edge
    cp = ab[..., 0] * ap[..., 1] - ab[..., 1] * ap[..., 0]    # side of p
    inside = ~flat & np.all(~edge | (cp * side >= 0), axis=1)
    d_all = np.min(np.where(valid, dist, np.inf), axis=1)
    d_edge = np.min(np.where(edge, dist, np.inf), axis=1)
    res = np.where(flat, d_all, np.where(inside, -d_edge, d_edge))
    out[ok] = res
    return out
