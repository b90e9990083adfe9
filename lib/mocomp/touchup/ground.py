"""Ground-frame adjustment (touch-up paper, Shin et al. 2003, sec. 3.3, eq. 6-7 and the appendix).

On a ground frame whose ZMP ``Z`` lies outside the support polygon, S2 (and S3 with it) is rotated
about a horizontal axis perpendicular to the line from ``Z`` to its projection ``Z'`` on the
polygon, so that eq. 4 -- with the accelerations held fixed, the paper's assumption -- puts the ZMP
on ``Z'``; S3's global orientation is then restored (:func:`mocomp.touchup.linksets.rotate_sets`).
The centre is the joint bordering S1 and S2 when S1 holds a foot point, else ``Z'``.

In the frame whose x axis is the unit ``d`` from ``Z`` to ``Z'``, y up and z = x * y (the rotation
axis), a rotation by ``theta`` moves each moved point mass ``i`` by ``R(theta) w_i - w_i``, ``w_i``
its offset from the centre that carries it (S2: the mass itself; S3: the S2/S3 joint). Eq. 4's
``Z_x = sum(alpha_i x_i - beta_i y_i) / sigma`` with ``alpha_i = m_i (y''_i + g)``,
``beta_i = m_i x''_i``, ``sigma = sum alpha_i`` then gives eq. 6::

    Z'_x = a1 cos(theta) - a2 sin(theta) + a3,
    a1 = sum_moved (alpha_i w_ix - beta_i w_iy) / sigma,
    a2 = sum_moved (alpha_i w_iy + beta_i w_ix) / sigma,
    a3 = Z_x - a1

(the appendix's coefficients, whose S3 terms are the S2/S3 joint's offsets ``k3, k4``). Eq. 7::

    theta = atan2(+-sqrt(a1^2 + a2^2 - (Z'_x - a3)^2), Z'_x - a3) - atan2(a2, a1),

the root of smaller ``|theta|``; a negative radicand is clamped to 0 (the ZMP as close to ``Z'``
as the rotation can bring it) and the frame is reported as clamped. The change of ``Z_z`` is
neglected, as the paper argues (appendix).

Departure from the paper: ``|theta|`` is capped at ``max_angle`` (default 20 deg per frame and
iteration, before the damping ``rho``; capped frames are reported). On a clamped frame eq. 7 gives
the angle of the farthest reach, ``-atan2(a2, a1)`` plus ``0`` or ``pi``: for a small S2 about a
high joint (the upper body about the lower back, the arms about the shoulders) that is a turn of
60-90 deg whatever the distance left. On the Bandai walk rotated uphill the first frames' ZMP is
40-50 cm behind the feet, out of the upper body's reach, and the uncapped spine bent 77 deg there.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._fast import fk, turn_sets
from .linksets import LinkSets

__all__ = ["GroundAdjustment", "eq6_coefficients", "eq7_angle", "ground_adjustment", "rotation_centres", "MAX_ANGLE"]

#: rad: the largest per-frame turn of one ground adjustment (module docstring)
MAX_ANGLE = float(np.radians(20.0))


def eq6_coefficients(masses, a, w, moved, zmp_x, direction, g: float):
    """``(a1, a2, a3)`` ``(T,)`` each of eq. 6 (module docstring).

    ``masses`` ``(S,)``, ``a`` ``(T, S, 3)`` accelerations, ``w`` ``(T, S, 3)`` offsets of the moved
    masses from their rotation centres, ``moved`` ``(S,)`` bool, ``zmp_x`` ``(T,)`` the ZMP along
    ``direction`` ``(T, 3)`` (unit, horizontal)."""
    m = np.asarray(masses, float) * np.asarray(moved, float)
    alpha_all = np.asarray(masses, float)[None] * (a[..., 1] + g)
    sigma = alpha_all.sum(axis=1)
    alpha = m[None] * (a[..., 1] + g)
    beta = m[None] * np.einsum("tsk,tk->ts", a, direction)
    wx = np.einsum("tsk,tk->ts", w, direction)
    wy = w[..., 1]
    a1 = (alpha * wx - beta * wy).sum(axis=1) / sigma
    a2 = (alpha * wy + beta * wx).sum(axis=1) / sigma
    return a1, a2, zmp_x - a1


def eq7_angle(a1, a2, a3, target_x):
    """Eq. 7: ``(theta, clamped)`` ``(T,)``: the angle of smaller magnitude (in ``(-pi, pi]``)
    putting eq. 6's ``Z'_x`` on ``target_x``; ``clamped`` where the radicand was negative (then the
    closest reachable ``Z'_x``)."""
    e = np.asarray(target_x, float) - a3
    rad = a1 ** 2 + a2 ** 2 - e ** 2
    clamped = rad < 0
    s = np.sqrt(np.where(clamped, 0.0, rad))
    phi = np.arctan2(a2, a1)
    wrap = lambda x: np.angle(np.exp(1j * x))  # noqa: E731  -- to (-pi, pi]
    t1, t2 = wrap(np.arctan2(s, e) - phi), wrap(np.arctan2(-s, e) - phi)
    return np.where(np.abs(t1) <= np.abs(t2), t1, t2), clamped


def rotation_centres(P: np.ndarray, sets: LinkSets, fallback: np.ndarray | None) -> np.ndarray:
    """``(T, J, 3)``: per S2 component the joint bordering S1/S2 -- the pivot's own position when
    S2 hangs below another set, else the first joint below S2 (S2 holds the root) -- or
    ``fallback`` ``(T, 3)`` for every component when given."""
    T, J, _ = P.shape
    C = np.zeros((T, J, 3))
    if fallback is not None:
        C[:] = fallback[:, None]
        return C
    anchor = sets.anchor
    for p in sets.pivots:
        if sets.parents[p] >= 0:
            C[:, p] = P[:, p]
        else:
            below = [j for j in np.flatnonzero(anchor == np.arange(J)) if sets.component[sets.parents[j]] == p]
            if not below:
                raise ValueError("S2 holds the whole skeleton: no S1/S2 joint to rotate about")
            C[:, p] = P[:, below[0]]
    return C


@dataclass(frozen=True, eq=False)
class GroundAdjustment:
    """Per frame: ``theta`` rad (0 where not adjusted), ``axis`` ``(T, 3)``, ``adjusted``,
    ``clamped`` (eq. 7's radicand negative) and ``capped`` (``|theta|`` cut to ``max_angle``)
    ``(T,)`` bool, and the adjusted ``root_positions`` and local ``rotations``."""

    theta: np.ndarray
    axis: np.ndarray
    adjusted: np.ndarray
    clamped: np.ndarray
    root_positions: np.ndarray
    rotations: np.ndarray
    capped: np.ndarray = None


def segment_offsets(body, P, G, r, sets: LinkSets, C):
    """``(w, moved)``: offsets ``(T, S, 3)`` of the segment masses from the centres that carry them
    (S2 segments: the mass from its component's centre; segments on joints carried below S2: the
    carrying joint from the centre) and ``moved`` ``(S,)``."""
    sj = np.asarray(body.segment_joint)
    comp, anchor = sets.component[sj], sets.anchor[sj]
    w = np.zeros_like(r)
    in2 = comp >= 0
    w[:, in2] = r[:, in2] - C[:, comp[in2]]
    car = anchor >= 0
    if car.any():
        a = anchor[car]
        w[:, car] = P[:, a] - C[:, sets.component[sets.parents[a]]]
    return w, in2 | car


def ground_adjustment(body, motion, sets: LinkSets, state, frames: np.ndarray, *, feet_in_s1: bool,
                      g: float, max_angle: float = MAX_ANGLE) -> GroundAdjustment:
    """Eq. 6-7 on the ``frames`` ``(T,)`` bool (ground frames with the ZMP outside), from the ZMP
    ``state`` (:class:`~mocomp.touchup.zmp.ZmpState`); ``feet_in_s1``: S1 holds a foot point, so the
    centre is the S1/S2 joint, else the ZMP's projection; ``max_angle`` rad caps ``|theta|``
    (module docstring; ``np.inf``: the paper's angles)."""
    if not (max_angle > 0):
        raise ValueError(f"max_angle must be a positive angle in rad, got {max_angle!r}")
    P, G = fk(motion)
    T = motion.n_frames
    frames = np.asarray(frames, bool) & np.isfinite(state.distance) & np.all(np.isfinite(state.target), axis=1)
    dvec = state.target - state.zmp
    dvec[:, 1] = 0.0
    n = np.linalg.norm(dvec, axis=1)
    frames &= n > 1e-12
    d = np.zeros((T, 3))
    d[frames] = dvec[frames] / n[frames, None]
    # the centres and offsets on the adjusted frames only (elsewhere the turn is the identity,
    # whatever its centre): a long clip has most frames inside the polygon
    f = frames
    C = np.zeros(P.shape)
    C[f] = rotation_centres(P[f], sets, None if feet_in_s1 else state.target[f])
    w, moved = segment_offsets(body, P[f], None, state.r[f], sets, C[f])
    theta = np.zeros(T)
    clamped = np.zeros(T, bool)
    capped = np.zeros(T, bool)
    if frames.any():
        a1, a2, a3 = eq6_coefficients(body.masses, state.a[f], w, moved, np.einsum("tk,tk->t", state.zmp[f], d[f]),
                                      d[f], g)
        th, cl = eq7_angle(a1, a2, a3, np.einsum("tk,tk->t", state.target[f], d[f]))
        theta[f], clamped[f] = th, cl
        capped = np.abs(theta) > max_angle
        theta = np.clip(theta, -max_angle, max_angle)
    axis = np.column_stack([-d[:, 2], np.zeros(T), d[:, 0]])      # d x up (y), written out
    root_pos, local = turn_sets(P, G, sets, axis * theta[:, None], C)
    return GroundAdjustment(theta, axis, frames, clamped & frames, root_pos, local, capped & frames)
