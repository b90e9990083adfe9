"""The Motion-Graph transition between two motions: the baseline of issue 17 (Kovar, Gleicher &
Pighin 2002, sec. 3.1).

The distance between frame ``i`` of A and frame ``j`` of B is the point-cloud distance over a
window of ``k`` frames (all joint positions of frames ``i .. i+k-1`` and ``j .. j+k-1``), after the
rigid 2-D transform (a turn about the vertical and a ground translation) of B that minimises it,
in closed form:

``D = Var_a + Var_b - 2 sqrt(C^2 + S^2) + mean (y_a - y_b)^2``

with, over the ``k x J`` points (uniform weights), ``Var`` the ground-plane variance of each cloud,
``C = cov(x_a, x_b) + cov(z_a, z_b)`` and ``S = cov(x_a, z_b) - cov(z_a, x_b)``; the turn is
``theta = atan2(S, C)`` (:func:`mocomp.ops.align.yaw_quaternion`'s sense) and the translation
moves B's turned centroid onto A's. The whole ``(i, j)`` table comes from per-frame cross sums
(matrix products over joints) summed along the diagonals over the window.

The transition between the two motions is taken where a Motion Graph of the two clips would take
it to chain the two actions: the pair ``(i, j)`` of least ``D`` with A's main phase played out
(``i`` at or after its end) and B's not begun (``j + k`` at or before its start); when a main phase
reaches the clip's edge (DeepMimic clips: no posterior phase), A past its peak and B's window
before its peak. fairmotion's
motion graph uses a different, windowed pose distance (joint angles and velocities); this follows
Kovar et al.'s point clouds. The blend over the window is the same as the method's (eq. 8).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from ..ops import GroundTransform
from .phases import ConcatError, Phases

__all__ = ["CloudTable", "point_cloud_table", "MotionGraphTransition", "motion_graph_transition"]


@dataclass(frozen=True, eq=False)
class CloudTable:
    """``D``, ``theta``, ``shift_x``, ``shift_z``: ``(nA - k + 1, nB - k + 1)``; ``window`` ``k``."""

    D: np.ndarray
    theta: np.ndarray
    shift_x: np.ndarray
    shift_z: np.ndarray
    window: int

    def transform(self, i: int, j: int) -> GroundTransform:
        return GroundTransform(float(self.theta[i, j]), (0.0, 0.0, 0.0),
                               (float(self.shift_x[i, j]), 0.0, float(self.shift_z[i, j])))


def _diag_window(M: np.ndarray, k: int) -> np.ndarray:
    """``W[i, j] = sum_{m<k} M[i+m, j+m]``."""
    n1, n2 = M.shape[0] - k + 1, M.shape[1] - k + 1
    W = np.zeros((n1, n2))
    for m in range(k):
        W += M[m:m + n1, m:m + n2]
    return W


def _win(v: np.ndarray, k: int) -> np.ndarray:
    c = np.concatenate([[0.0], np.cumsum(v)])
    return c[k:] - c[:-k]


def point_cloud_table(a: Motion, b: Motion, window: int) -> CloudTable:
    """Kovar et al.'s distance for every frame pair (see the module docstring)."""
    k = int(window)
    if k < 1 or k > min(a.n_frames, b.n_frames):
        raise ValueError(f"the point-cloud window must be 1-{min(a.n_frames, b.n_frames)} frames, got {k}")
    Pa, _ = a.fk()
    Pb, _ = b.fk()
    n = k * Pa.shape[1]
    xa, ya, za = (Pa[..., c] for c in range(3))
    xb, yb, zb = (Pb[..., c] for c in range(3))
    ma = {c: _win(v.sum(1), k) / n for c, v in (("x", xa), ("z", za))}
    mb = {c: _win(v.sum(1), k) / n for c, v in (("x", xb), ("z", zb))}
    qa = _win((xa ** 2 + za ** 2).sum(1), k) / n - ma["x"] ** 2 - ma["z"] ** 2
    qb = _win((xb ** 2 + zb ** 2).sum(1), k) / n - mb["x"] ** 2 - mb["z"] ** 2
    cov = {key: _diag_window(u @ v.T, k) / n for key, (u, v) in
           {"xx": (xa, xb), "zz": (za, zb), "xz": (xa, zb), "zx": (za, xb)}.items()}
    ax, az = ma["x"][:, None], ma["z"][:, None]
    bx, bz = mb["x"][None, :], mb["z"][None, :]
    C = cov["xx"] - ax * bx + cov["zz"] - az * bz
    S = cov["xz"] - ax * bz - (cov["zx"] - az * bx)
    yy = (_win((ya ** 2).sum(1), k)[:, None] + _win((yb ** 2).sum(1), k)[None, :]
          - 2.0 * _diag_window(ya @ yb.T, k)) / n
    D = np.maximum(qa[:, None] + qb[None, :] - 2.0 * np.hypot(C, S) + yy, 0.0)
    th = np.arctan2(S, C)
    c, s = np.cos(th), np.sin(th)
    # B's centroid turned (x' = c x + s z, z' = -s x + c z) onto A's
    sx = ax - (c * bx + s * bz)
    sz = az - (-s * bx + c * bz)
    return CloudTable(D, th, sx, sz, k)


@dataclass(frozen=True, eq=False)
class MotionGraphTransition:
    """The chosen transition: A's frames ``i .. i+k-1`` blended with B's ``j .. j+k-1``."""

    i: int
    j: int
    distance: float
    transform: GroundTransform
    window: int
    constraint: str = ""

    def to_dict(self) -> dict:
        return {"A_frame": self.i, "B_frame": self.j, "window": self.window, "point_cloud_distance_m2": self.distance,
                "constraint": self.constraint,
                "transform": self.transform.to_dict(), "criterion": "Kovar et al. 2002 point-cloud distance"}


def motion_graph_transition(a: Motion, b: Motion, pa: Phases, pb: Phases, window: int) -> MotionGraphTransition:
    """The least-distance transition with A's main phase played out and B's not begun."""
    tab = point_cloud_table(a, b, window)
    k = tab.window
    n1, n2 = tab.D.shape
    i0, j1 = pa.main[1], pb.main[0] - k + 1
    rule = "A's main phase played out, B's not begun"
    if i0 > n1 - 1 or j1 < 1:
        # a main phase reaching the clip's end (no posterior phase) or start: keep the peaks instead
        i0, j1 = pa.t_m, pb.t_m - k + 1
        rule = "A past its peak |L| (t_m), B's window before its peak (a main phase reaches the clip's edge)"
        if i0 > n1 - 1 or j1 < 1:
            k2 = min(pb.t_m, a.n_frames - pa.t_m, k - 1)
            if k2 >= 2:                          # the longest window that fits there (short cut pieces)
                tr = motion_graph_transition(a, b, pa, pb, k2)
                return dataclasses.replace(tr, constraint=f"{tr.constraint}; window shortened from {k} to {tr.window} "
                                                          "frames to fit")
            raise ConcatError(f"no Motion-Graph transition: a {k}-frame window does not fit after A's peak (frame "
                              f"{pa.t_m} of {a.n_frames}) and before B's (frame {pb.t_m})")
    sub = tab.D[i0:, :j1]
    ii, jj = np.unravel_index(int(np.argmin(sub)), sub.shape)
    i, j = i0 + int(ii), int(jj)
    return MotionGraphTransition(i, j, float(tab.D[i, j]), tab.transform(i, j), k, rule)
