"""ZMP distance outside the support polygon, per ground stage.

The ZMP is the project's :func:`mocomp.dynamics.zmp.zmp` (touch-up paper,
Shin et al. 2003, eq. 4: point masses at the segment COMs, gravity 9.81 m/s^2,
the floor at the audit's floor height), on the motion smoothed with a Gaussian
of ``zmp_smooth_sigma`` frames before the second differences. Its signed distance to
the support polygon (the convex hull of the planted effectors' points in the
floor plane, :func:`mocomp.dynamics.zmp.support_polygon_distance`; positive
outside) is measured on every frame where both exist. Per ground stage the
audit reports the fraction of those frames with the ZMP more than
``zmp_outside`` outside and the largest distance; runs outside lasting at
least ``zmp_min_time`` are findings (advisory unless ``zmp_is_violation``).

Speed (issue #13): the stage does not build the smoothed motion and its whole forward
kinematics. :func:`smoothed_segment_positions` smooths (the same
:func:`~mocomp.dynamics.derivatives.gaussian_smooth` /
:func:`~mocomp.dynamics.derivatives.smooth_quaternions`, which act on each joint's track
alone) and runs the core FK on the chains that carry a segment only (23 of 31 joints on a
CMU skeleton; fingers and toe tips move no mass), and :func:`zmp_from_segments` is eq. 4 on
those positions. Together they equal :func:`mocomp.dynamics.zmp.zmp` on
``smooth_motion(motion, sigma)`` to rounding (``tests/test_audit.py`` pins both).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scipy.ndimage import gaussian_filter1d

from ..core.kinematics import forward_kinematics
from ..core.rotations import quat_apply
from ..dynamics.constants import G_STANDARD
from ..dynamics.derivatives import gaussian_smooth, second_difference
from ..dynamics.zmp import support_polygon_distance, zmp_of_point_masses
from .findings import Finding, runs_above

__all__ = ["ZmpStage", "ZmpAudit", "zmp_audit", "smoothed_segment_positions", "zmp_from_segments",
           "smooth_quaternions_fast"]

#: gravity (m/s^2) and the smallest vertical ground force (fraction of the weight) with a ZMP,
#: as :func:`mocomp.dynamics.zmp.zmp`'s defaults
G = G_STANDARD
MIN_SUPPORT = 0.05


def smooth_quaternions_fast(quats: np.ndarray, sigma: float) -> np.ndarray:
    """:func:`~mocomp.dynamics.derivatives.smooth_quaternions` of ``(T, J, 4)`` unit quaternions
    (hemisphere-continuous components Gaussian-filtered over time, ``mode="nearest"``, then
    renormalised) on a component-major ``(J, 4, T)`` copy: each filtered line is contiguous, and the
    result, a ``(T, J, 4)`` view of it, is the layout :func:`~mocomp.core.kinematics.forward_kinematics`
    works in (no copy there). Equal to ``smooth_quaternions`` to rounding (``tests/test_audit.py``)."""
    q = np.ascontiguousarray(np.transpose(np.asarray(quats, dtype=float), (1, 2, 0)))   # (J, 4, T)
    if q.shape[2] > 1:
        dots = np.einsum("jkt,jkt->jt", q[:, :, 1:], q[:, :, :-1])
        flips = np.cumprod(np.where(dots < 0.0, -1.0, 1.0), axis=1)
        q[:, :, 1:] *= flips[:, None]
    s = gaussian_filter1d(q, sigma, axis=-1, mode="nearest")
    s /= np.sqrt(np.einsum("jkt,jkt->jt", s, s))[:, None]
    return np.transpose(s, (2, 0, 1))


def smoothed_segment_positions(body, motion, sigma: float | None) -> np.ndarray:
    """``(T, S, 3)`` m: the segment COMs of ``motion`` Gaussian-smoothed by ``sigma`` frames
    (root positions and local rotations, as :func:`~mocomp.dynamics.derivatives.smooth_motion`),
    i.e. ``segment_positions(body, smooth_motion(motion, sigma))``, computed on the kinematic
    chains of the segments' carrier joints only and without building the smoothed motion."""
    sk = motion.skeleton
    need = np.zeros(sk.n_joints, bool)
    for c in set(int(j) for j in body.segment_joint):
        need[sk.chain(c)] = True
    idx = np.flatnonzero(need)                     # ascending: parents still precede children
    remap = np.full(sk.n_joints, -1)
    remap[idx] = np.arange(idx.size)
    parents = np.where(np.asarray(sk.parents)[idx] < 0, -1, remap[np.asarray(sk.parents)[idx]])
    root = gaussian_smooth(motion.root_positions, sigma, axis=0) if sigma else motion.root_positions
    rot = smooth_quaternions_fast(motion.rotations[:, idx], sigma) if sigma else motion.rotations[:, idx]
    P, Gr = forward_kinematics(parents, sk.offsets[idx], root, rot)
    j = remap[np.asarray(body.segment_joint)]
    return P[:, j] + quat_apply(Gr[:, j], body.local_coms[None])


def zmp_from_segments(body, r: np.ndarray, times: np.ndarray, ground_y: float, g: float = G,
                      min_support: float = MIN_SUPPORT) -> np.ndarray:
    """``(T, 3)`` m ZMP on the floor ``y = ground_y`` of point masses ``body.masses`` at the
    segment COMs ``r`` ``(T, S, 3)`` (touch-up paper, Shin et al. 2003, eq. 4, y up)::

        Z_x = [sum m_i (a_iy + g) x_i - sum m_i a_ix (y_i - y0)] / sum m_i (a_iy + g)

    (likewise ``Z_z``), accelerations by second central differences on ``times``; NaN where the
    vertical ground force ``sum m_i (a_iy + g)`` is below ``min_support`` of the weight -- the
    numbers of :func:`mocomp.dynamics.zmp.zmp`."""
    Z, _, _ = zmp_of_point_masses(body.masses, r, second_difference(r, times), ground_y, g,
                                  min_support * body.total_mass * g)
    return Z


@dataclass(frozen=True)
class ZmpStage:
    """One ground stage: half-open ``frames``, ``measured`` frames (ZMP and polygon defined),
    ``outside_fraction`` of them beyond ``zmp_outside``, ``max_outside`` m (NaN: none measured)."""

    frames: tuple[int, int]
    measured: int
    outside_fraction: float
    max_outside: float

    def to_dict(self) -> dict:
        return {"frames": list(self.frames), "measured": self.measured, "outside_fraction": self.outside_fraction,
                "max_outside_m": self.max_outside}


@dataclass(frozen=True)
class ZmpAudit:
    """``distance`` ``(T,)`` m (NaN where undefined), ``zmp`` ``(T, 3)`` m, the stages, and over the
    whole clip the ``outside_fraction`` of measured frames and ``max_outside`` m."""

    distance: np.ndarray
    zmp: np.ndarray
    stages: tuple[ZmpStage, ...]
    outside_fraction: float
    max_outside: float
    smooth_sigma: float


def zmp_audit(body, motion, contacts, floor_y: float, phases, thresholds) -> tuple[ZmpAudit, list]:
    T = motion.n_frames
    if T < 3:
        nan = np.full(T, np.nan)
        return ZmpAudit(nan, np.full((T, 3), np.nan), (), float("nan"), float("nan"), thresholds.zmp_smooth_sigma), []
    sigma = thresholds.zmp_smooth_sigma or None
    zp = zmp_from_segments(body, smoothed_segment_positions(body, motion, sigma), motion.times, float(floor_y))
    pts, lab = contacts.contact_points()
    # points never in contact take no part in any frame's polygon (the distance ignores masked
    # points); dropping them cuts the pairs x points work, e.g. 6 -> 4 points: 126 -> 40 per frame
    keep = lab.any(axis=0)
    d = support_polygon_distance(zp, pts[:, keep], lab[:, keep])
    lim = thresholds.zmp_outside
    stages = []
    for a, b in phases.ground:
        seg = d[a:b]
        ok = np.isfinite(seg)
        n = int(ok.sum())
        stages.append(ZmpStage((a, b), n, float(np.mean(seg[ok] > lim)) if n else float("nan"),
                               float(seg[ok].max()) if n else float("nan")))
    ok = np.isfinite(d)
    frac = float(np.mean(d[ok] > lim)) if ok.any() else float("nan")
    mx = float(d[ok].max()) if ok.any() else float("nan")
    res = ZmpAudit(d, zp, tuple(stages), frac, mx, thresholds.zmp_smooth_sigma)
    min_len = max(1, int(np.ceil(thresholds.zmp_min_time * motion.fps - 1e-9)))
    sev = "violation" if thresholds.zmp_is_violation else "advisory"
    findings = [Finding("zmp_outside", sev, (a, b), p, float(d[p]), lim, "zmp_outside", "m", "support polygon",
                        f"ZMP up to {d[p] * 100:.1f} cm outside the support polygon for {b - a} frames "
                        f"({(b - a) / motion.fps:.2f} s); limit {lim * 100:.1f} cm for at least "
                        f"{thresholds.zmp_min_time:g} s")
                for a, b, p in runs_above(d, lim, min_len)]
    return res, findings
