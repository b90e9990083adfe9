"""Repositioning of the flight (dissertation eq. 5.15-5.17, App. B height changes).

Over the new flight (``t = 0 .. T_new`` from take-off) the COM follows

    COM_x(t) = k a_x t + b_x,  COM_z(t) = k a_z t + b_z                 (eq. 5.15)
    COM_y(t) = a_y t^2 + v0' t + c_y                                     (eq. 5.17)

where ``v0' = k b_y`` at ``k = k*`` (eq. 5.17 as printed) and, for other ``k``, the
vertical take-off velocity that lands at the requested level (see
:mod:`mocomp.flips.retime`). ``b_x, b_z, c_y`` are anchored at the COM of the
take-off frame (rather than the fitted intercepts, which differ from it by the
fit residual) so positions are continuous at take-off. Likewise the velocities ``a_x, b_y, a_z``
are by default the COM velocity the input *has* at its take-off frame (:func:`event_velocity`),
not the intercepts of its flight's ballistic fit: the two agree on a ballistic flight, but on
the DeepMimic back flip (a key-framed flight that is not ballistic) the fit leaves at 0.80 m/s
while the take-off reaches 1.74, and at ``k = k*`` the frames jumped from 3.3 to 1.3 m/s
(``multiflip(..., takeoff_velocity="fit")`` keeps the printed equations). ``a_y = -g/2`` with
the gravity the new flight falls with (9.81 m/s^2 by default; :func:`~mocomp.flips.retime.resolve_gravity`). Every flight frame is
translated so its COM (computed exactly from its pose with the estimated
masses) lies on that trajectory; translation leaves angular momentum about the
COM unchanged (section 5.4.1). Frames after the landing are offset by
``COM_new(T_new) - COM(T)`` (eq. 5.16), including the height change ``dy``
(App. B: changing ``c_y``/``dy`` moves the take-off or landing level).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..body.model import BodyModel
from ..core.rotations import quat_apply, quat_multiply

__all__ = ["ComEvaluator", "FlightTrajectory", "flight_trajectory", "landing_offset", "event_velocity",
           "EVENT_HALF_WIDTH_S"]

#: s: half-width of the local quadratic fit of :func:`event_velocity` (2 frames at 120 Hz, 1 at 60 Hz)
EVENT_HALF_WIDTH_S = 0.015


def event_velocity(com: np.ndarray, frame: int, fps: float, half_width: int | None = None) -> np.ndarray:
    """``(3,)`` m/s COM velocity at ``frame`` from a local quadratic least-squares fit over
    ``frame - h .. frame + h`` (a Savitzky-Golay derivative, :func:`scipy.signal.savgol_coeffs`;
    ``h = max(1, round(EVENT_HALF_WIDTH_S fps))`` unless given; shrunk at the clip's ends). Centred
    on a take-off or landing frame it is the velocity the body has there, whichever side of the
    event the detector put the frame (the velocity is continuous through a take-off)."""
    com = np.asarray(com, dtype=float)
    T = com.shape[0]
    h = max(1, int(round(EVENT_HALF_WIDTH_S * fps))) if half_width is None else int(half_width)
    h = max(1, min(h, frame, T - 1 - frame))
    if not (0 < frame < T - 1):
        raise ValueError(f"event_velocity needs a frame with neighbours on both sides, got {frame} of {T}")
    return _derivative_weights(h, float(fps)) @ com[frame - h:frame + h + 1]


@functools.lru_cache(maxsize=64)
def _derivative_weights(h: int, fps: float) -> np.ndarray:
    """Savitzky-Golay first-derivative weights (quadratic, ``2 h + 1`` samples at ``fps``), cached:
    :func:`scipy.signal.savgol_coeffs` takes ~0.1 ms, the run-time stage ~0.8 ms in all."""
    from scipy.signal import savgol_coeffs

    c = savgol_coeffs(2 * h + 1, 2, deriv=1, delta=1.0 / fps, use="dot")
    c.setflags(write=False)
    return c


class ComEvaluator:
    """Whole-body COM relative to the root, fast, for many frames of one skeleton/body.

    ``COM - root = sum_j G_j u_j`` where ``G_j`` is joint ``j``'s global rotation and
    ``u_j = sum_{segments s on j} f_s c_s + sum_{children k of j} F(k) o_k`` (``f`` mass
    fractions, ``c`` local COMs, ``o`` bone offsets, ``F(k)`` the mass fraction of the
    subtree below ``k``): the mass-weighted forward kinematics collapsed onto one
    constant vector per joint. Joints whose subtree carries no mass are skipped and
    the rotation chain is evaluated one tree level at a time, vectorized over
    joints and frames (exact; tested against full forward kinematics).
    """

    def __init__(self, body: BodyModel):
        sk = body.skeleton
        J = sk.n_joints
        M = body.total_mass
        if not M > 0:
            raise ValueError("the body model has zero total mass")
        f = np.zeros(J)
        fc = np.zeros((J, 3))
        np.add.at(f, body.segment_joint, body.masses / M)
        np.add.at(fc, body.segment_joint, (body.masses / M)[:, None] * body.local_coms)
        F = f.copy()                                   # subtree mass fractions
        parents = sk.parents
        for j in range(J - 1, 0, -1):
            F[parents[j]] += F[j]
        u = fc.copy()
        for j in range(1, J):
            u[parents[j]] += F[j] * sk.offsets[j]
        needed = F > 1e-15
        needed[0] = True
        depth = np.zeros(J, dtype=int)
        for j in range(1, J):
            depth[j] = depth[parents[j]] + 1
        # joints whose rotation matters, ordered by depth so each tree level is a contiguous block
        needed_idx = np.flatnonzero(needed)
        order = needed_idx[np.argsort(depth[needed_idx], kind="stable")]
        self.joints = order
        pos = {int(j): i for i, j in enumerate(order)}
        self._levels = []
        d_of = depth[order]
        for d in range(1, int(d_of.max()) + 1 if order.size else 1):
            sel = np.flatnonzero(d_of == d)
            if sel.size:
                self._levels.append((slice(int(sel[0]), int(sel[-1]) + 1),
                                     np.array([pos[int(parents[order[i]])] for i in sel])))
        self.u = u[order]
        self.total_mass = M
        self._parent_pos = np.array([0] + [pos[int(parents[j])] for j in order[1:]], dtype=np.int64)
        self._joints64 = np.ascontiguousarray(order, dtype=np.int64)
        self._u = np.ascontiguousarray(self.u, dtype=np.float64)

    def relative(self, rotations: np.ndarray) -> np.ndarray:
        """``(T, 3)`` COM minus root position for local rotations ``(T, J, 4)`` (root = world orientation)."""
        from ._kernels import AVAILABLE, com_relative_nb

        if AVAILABLE:
            return com_relative_nb(rotations, self._joints64, self._parent_pos, self._u)
        return self.relative_numpy(rotations)

    def relative_numpy(self, rotations: np.ndarray) -> np.ndarray:
        """The vectorised numpy version of :meth:`relative` (the fallback without numba; same result
        to rounding): the needed joints' world orientations level by level with core's
        :func:`~mocomp.core.rotations.quat_multiply`, each constant ``u_j`` rotated by its joint's
        (:func:`~mocomp.core.rotations.quat_apply`) and summed."""
        q = np.asarray(rotations, dtype=float)
        L = np.ascontiguousarray(np.swapaxes(q[:, self.joints], 0, 1))     # (n, T, 4) joint-major
        G = np.empty_like(L)
        G[0] = L[0]
        for blk, pidx in self._levels:
            G[blk] = quat_multiply(G[pidx], L[blk])
        return quat_apply(G, self.u[:, None, :]).sum(axis=0)

    def __call__(self, root_positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """``(T, 3)`` world COM."""
        return np.asarray(root_positions, dtype=float) + self.relative(rotations)


@dataclass(frozen=True)
class FlightTrajectory:
    """The new flight's COM trajectory (eq. 5.15, 5.17).

    Attributes
    ----------
    c0: ``(3,)`` m, COM at take-off (``b_x, c_y, b_z``).
    velocity: ``(3,)`` m/s, COM velocity at take-off (``k a_x, v0', k a_z``).
    a_y: m/s^2 / 2, the vertical quadratic coefficient (``-g/2``, ``g`` the gravity the flight falls with).
    T_new: s, flight duration.
    """

    c0: np.ndarray
    velocity: np.ndarray
    a_y: float
    T_new: float

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """``(n, 3)`` COM at times ``t`` (s since take-off)."""
        t = np.asarray(t, dtype=float)
        out = self.c0 + t[:, None] * self.velocity
        out[:, 1] += self.a_y * t * t
        return out

    @property
    def end(self) -> np.ndarray:
        """``(3,)`` COM at landing: :meth:`__call__` at ``T_new``, written for one instant (the same
        operations, so the same bits, without the ``(1, 3)`` temporaries)."""
        T = self.T_new
        out = self.c0 + T * self.velocity
        out[1] += self.a_y * T * T
        return out


def flight_trajectory(c0: np.ndarray, a_x: float, a_z: float, a_y: float, k: float, vy_takeoff: float,
                      T_new: float) -> FlightTrajectory:
    """Eq. 5.15/5.17 anchored at the take-off COM ``c0``."""
    c0 = np.asarray(c0, dtype=float).copy()
    v = np.array([k * a_x, vy_takeoff, k * a_z])
    c0.setflags(write=False)
    v.setflags(write=False)
    return FlightTrajectory(c0=c0, velocity=v, a_y=float(a_y), T_new=float(T_new))


def landing_offset(trajectory: FlightTrajectory, com_landing_original: np.ndarray) -> np.ndarray:
    """Eq. 5.16 offset (x, z; and y, which carries the height change) for frames after the landing."""
    return trajectory.end - np.asarray(com_landing_original, dtype=float)
