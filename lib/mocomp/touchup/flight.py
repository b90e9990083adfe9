"""Flight-frame adjustment: the centre of mass onto the ballistic parabola (touch-up paper, Shin
et al. 2003, sec. 3.4.2, eq. 10), g = 9.81 m/s^2 (:data:`mocomp.dynamics.constants.G_STANDARD`).

For a flight block of frames ``a .. b-1`` (no foot planted), duration ``T = (b-1-a)/fps`` and COM
displacement ``d = c(b-1) - c(a)``, the parabola through the block's end points is::

    v0 = d / T - g T / 2,    c*(t) = c(t0) + v0 (t - t0) + g (t - t0)^2 / 2.

Ground frames within ``neighbourhood`` of the flight are adjusted with it (Fig. 4): the correction
leaves the take-off frame with its velocity there (and reaches the landing frame with its
velocity), so that the push makes the parabola's take-off velocity instead of the COM's velocity
jumping between two frames. How that velocity change is spread over the push (landing) frames is
ours (:func:`continue_into_ground`): the COM's extra acceleration is in proportion to the vertical
ground force of each frame (:func:`support_fraction`). Eq. 4 divides the horizontal accelerations
by that force, so an extra horizontal acceleration ``da`` moves the ZMP by ``h da / (a_y + g)``;
in proportion to the force, the ZMP moves by about the same amount on every push frame, and the
frames the foot only touches (no force: already in free fall) are left in free fall. The paper's
blend to zero (an ease over the neighbourhood, then the flight maps' smoothing) put the velocity
change on the last push frames, where the force falls to a quarter of the weight: on the CMU 01_01
hop path-edited onto a 60 deg arc (the parabola asks 0.37 m/s more sideways at take-off and
landing) frame 27's ZMP went 47 -> 108 cm outside, the mean 11.7 -> 7.4 cm; with the force-shaped
ramps 47 -> 72 cm (within that frame's 28 cm noise, :func:`mocomp.touchup.examples.zmp_rise`) and
11.7 -> 5.9 cm, the flips method's back flip unchanged (|L| variation 1.4 % as its input).

With S1 empty the root is translated by ``c* - c``. Otherwise S2 is rotated about the joint
bordering S1 and S2 (``p``) so that S2's COM ``c_M2`` comes as close as it can to its goal (eq. 10)::

    c*_M2 = (c*_M sum_i m_i - c_M1 sum_{S1} m_i) / sum_{S2} m_i,

the smallest rotation turning ``c_M2 - p`` toward ``c*_M2 - p`` (its length cannot change),
on the flight frames and on the ground frames its correction was continued into.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..dynamics.constants import G_STANDARD
from ..ops import ease
from .ground import rotation_centres
from ._fast import fk, running_products, turn_sets
from .linksets import LinkSets

__all__ = ["ballistic_targets", "FlightAdjustment", "flight_com_adjustment", "com_residual", "angular_momentum",
           "flight_momentum_adjustment", "support_fraction", "support_ramp", "continue_into_ground"]


def ballistic_targets(com: np.ndarray, a: int, b: int, fps: float, g: float = G_STANDARD) -> np.ndarray:
    """``(b - a, 3)`` m: the g parabola through ``com[a]`` and ``com[b-1]`` on frames ``a .. b-1``."""
    if b - a < 2:
        return np.array(com[a:b])
    t = (np.arange(a, b) - a) / fps
    T = t[-1]
    gv = np.array([0.0, -g, 0.0])
    v0 = (com[b - 1] - com[a]) / T - gv * T / 2
    return com[a] + t[:, None] * v0 + 0.5 * t[:, None] ** 2 * gv


def com_residual(com: np.ndarray, a: int, b: int, fps: float, g: float = G_STANDARD) -> float:
    """m: the largest distance of ``com[a:b]`` from the g parabola through its end points."""
    return float(np.linalg.norm(com[a:b] - ballistic_targets(com, a, b, fps, g), axis=1).max(initial=0.0))


@dataclass(frozen=True, eq=False)
class FlightAdjustment:
    """``correction`` ``(T, 3)``: the wanted COM shift m (flight steps' COM part; the momentum part
    holds its turn's rotation vector, rad), ``weight`` ``(T,)`` the Fig. 4 blend of the flight and its
    neighbourhood (1 in flight, easing to 0), the adjusted ``root_positions`` and local ``rotations``."""

    correction: np.ndarray
    weight: np.ndarray
    root_positions: np.ndarray
    rotations: np.ndarray


def _weights(T: int, flights, nb: int) -> tuple[np.ndarray, np.ndarray]:
    """Per frame the blend weight (1 in flight, easing to 0 over ``nb`` ground frames each side) and
    the index of the flight it belongs to (-1: none)."""
    w = np.zeros(T)
    owner = np.full(T, -1)
    i = np.arange(1, int(nb) + 1)
    v = ease(1.0 - i / (nb + 1))                     # (nb,) the weights 1..nb frames away
    for k, (a, b) in enumerate(flights):
        w[a:b] = 1.0
        owner[a:b] = k
        for f in (a - i, b - 1 + i):                 # before the take-off, after the landing
            ok = (f >= 0) & (f < T)
            f, vv = f[ok], v[ok]
            up = vv > w[f]
            w[f[up]], owner[f[up]] = vv[up], k
    return w, owner


def support_fraction(com: np.ndarray, fps: float, g: float = G_STANDARD, smooth_sigma: float | None = None) -> np.ndarray:
    """``(T,)``: the vertical ground force over the weight, ``(y''_c + g) / g`` of the COM ``com``
    ``(T, 3)`` smoothed by ``smooth_sigma`` frames (default: the ZMP's,
    :data:`mocomp.touchup.zmp.DEFAULT_SMOOTH_SIGMA`), clipped at 0 (a frame in free fall or
    pulled down has none)."""
    from ..dynamics.derivatives import gaussian_smooth, second_difference
    from .zmp import DEFAULT_SMOOTH_SIGMA

    sigma = DEFAULT_SMOOTH_SIGMA if smooth_sigma is None else smooth_sigma
    y = np.asarray(com, float)[:, 1]
    if y.shape[0] < 3:
        return np.ones(y.shape[0])
    y = gaussian_smooth(y, sigma) if sigma else y
    a = second_difference(y, np.arange(y.shape[0]) / float(fps))
    return np.clip((a + g) / g, 0.0, None)


def support_ramp(support: np.ndarray) -> tuple[np.ndarray, float]:
    """``(shape (n + 1,), end velocity)``: the displacement ``delta_0 .. delta_n`` of a ramp that
    starts at rest (``delta_0 = delta_1 = 0``) with second differences ``support_k`` on
    ``k = 1 .. n-1`` (``support`` ``(n + 1,)`` >= 0), and its last per-frame velocity
    ``delta_n - delta_{n-1}``. Scaled by ``v / velocity`` it reaches the velocity ``v`` with an
    acceleration in proportion to the vertical ground force of each frame (module docstring)."""
    s = np.asarray(support, float)
    n = s.shape[0] - 1
    d = np.zeros(n + 1)
    if n >= 2:
        d[2:] = np.cumsum(np.cumsum(s[1:n]))
    return d, float(d[n] - d[n - 1]) if n >= 1 else 0.0


def continue_into_ground(corr: np.ndarray, flights, support: np.ndarray, neighbourhood: int) -> np.ndarray:
    """``(T, 3)``: a COM correction ``corr`` (the parabola less the COM on the ``flights``' frames,
    zero elsewhere) continued into the ground frames within ``neighbourhood`` frames of each flight
    of 3 frames or more, but over no more frames than the flight lasts and no farther than the
    previous / next flight (Fig. 4).

    Before the take-off the ramp starts at rest ``n0`` frames away and reaches the correction's
    velocity at the take-off frame with an acceleration in proportion to ``support`` ``(T,)``
    (:func:`support_fraction`, :func:`support_ramp`); the landing side mirrors it. The ramp does
    not return to the flight's end value: it ends at an offset ``D0`` (``D1`` at the landing) that
    the whole flight takes as well, linearly from ``D0`` to ``D1`` -- a linear term added to a g
    parabola is a g parabola, through the moved end points. The offsets change the flight's end
    velocities by ``(D1 - D0) / (b - 1 - a)`` per frame, which the ramps then reach: ``D0, D1``
    solve the two linear conditions together. Requiring the ramp to come back to the flight's end
    value (offset 0) needs an acceleration one way and then the other, about six times the
    velocity change over the push; measured on the CMU 01_01 hop on an arc: mean ZMP outside 7.4
    -> 8.6 cm that way, 5.9 cm with the offsets. The offsets grow with the ramp's length (about the
    velocity change times half of it): over the paper's whole 1/2 s neighbourhood a 60 deg arc
    moved a longer window's flight 9 cm and its ZMP rose. No longer than the flight (as the ground
    maps' reach next to a flight, :func:`mocomp.touchup.iterate.ground_weights`): on 12 windows of
    CMU 01_01 (100-270 frames around one hop, 30 and 60 deg arcs) the mean fall of the read-back
    ZMP distance is 35 % (25 % with the eased continuation, 22 % with the whole neighbourhood)."""
    corr = np.asarray(corr, dtype=float)
    out = np.array(corr)
    T = out.shape[0]
    nb = int(neighbourhood)
    for k, (a, b) in enumerate(flights):
        if b - a < 3:
            continue
        prev_b = flights[k - 1][1] if k > 0 else 0
        next_a = flights[k + 1][0] if k + 1 < len(flights) else T
        n0, n1 = min(nb, b - a, a - prev_b), min(nb, b - a, next_a - b)     # no longer than the flight
        d0, B0 = support_ramp(support[a - n0:a + 1]) if n0 >= 3 else (None, 0.0)
        d1, B1 = support_ramp(support[b - 1:b + n1][::-1]) if n1 >= 3 else (None, 0.0)
        l0 = d0[-1] / B0 if B0 > 1e-12 else 0.0           # end offset per unit end velocity
        l1 = d1[-1] / B1 if B1 > 1e-12 else 0.0
        v0, v1 = corr[a + 1] - corr[a], corr[b - 1] - corr[b - 2]
        N = float(b - 1 - a)
        # D0 = l0 (v0 + (D1 - D0) / N),  D1 = -l1 (v1 + (D1 - D0) / N)    (per component)
        A = np.array([[1.0 + l0 / N, -l0 / N], [-l1 / N, 1.0 + l1 / N]])
        D0, D1 = np.linalg.solve(A, np.vstack([l0 * v0, -l1 * v1]))
        dv = (D1 - D0) / N
        u = (np.arange(a, b) - a) / N
        out[a:b] += (1.0 - u)[:, None] * D0 + u[:, None] * D1
        if B0 > 1e-12:
            out[a - n0:a] += d0[:-1, None] * ((v0 + dv) / B0)[None]
        if B1 > 1e-12:
            out[b:b + n1] += d1[::-1][1:, None] * (-(v1 + dv) / B1)[None]
    return out


def flight_com_adjustment(body, motion, sets: LinkSets, flights, com: np.ndarray, *, neighbourhood: int,
                          g: float = G_STANDARD) -> FlightAdjustment:
    """Sec. 3.4.2 on the ``flights`` (half-open frame runs) of ``motion``; ``com`` ``(T, 3)`` its COM."""
    T = motion.n_frames
    P, G = fk(motion)
    corr = np.zeros((T, 3))
    for a, b in flights:
        corr[a:b] = ballistic_targets(com, a, b, motion.fps, g) - com[a:b]
    w, _ = _weights(T, flights, neighbourhood)
    # neighbourhood frames (Fig. 4): the correction is zero at the flight's end points (the parabola
    # goes through them) but its slope is not; held at zero outside, the COM's velocity jumped at
    # take-off and landing, and the ZMP of the push and impact frames with it. Continued with its
    # velocity and faded, in proportion to the vertical ground force (module docstring)
    if neighbourhood > 0:
        corr = continue_into_ground(corr, flights, support_fraction(com, motion.fps, g), neighbourhood)
    root = int(np.flatnonzero(sets.parents < 0)[0])
    if not sets.s1.any():
        return FlightAdjustment(corr, w, motion.root_positions + corr, np.array(motion.rotations))
    C = rotation_centres(P, sets, None)
    sj = np.asarray(body.segment_joint)
    from ..dynamics.com import segment_positions

    r = segment_positions(body, motion)
    m = np.asarray(body.masses)
    in2 = sets.component[sj] >= 0
    M, M2 = m.sum(), m[in2].sum()
    if M2 <= 0:
        raise ValueError("S2 carries no mass: nothing to rotate toward the parabola")
    c2 = np.einsum("s,tsk->tk", m[in2], r[:, in2]) / M2
    goal2 = c2 + corr * M / M2                       # eq. 10 with c_M1 unchanged
    pivots = sets.pivots
    if len(pivots) != 1:
        raise ValueError(f"a flight step with S1 needs one connected S2 (one S1/S2 joint), got {len(pivots)}")
    p = C[:, pivots[0]]
    u, v = c2 - p, goal2 - p
    ax = np.cross(u, v)
    ang = np.arctan2(np.linalg.norm(ax, axis=1), np.einsum("tk,tk->t", u, v))
    n = np.linalg.norm(ax, axis=1, keepdims=True)
    rv = np.where(n > 1e-15, ax / np.where(n > 0, n, 1.0), 0.0) * ang[:, None]
    root_pos, local = turn_sets(P, G, sets, rv, C)
    return FlightAdjustment(corr, w, root_pos, local)


def angular_momentum(masses, r: np.ndarray, v: np.ndarray, about: np.ndarray) -> np.ndarray:
    """``(T, 3)``: ``sum_i m_i (r_i - about) x v_i`` (eq. 2 about the point ``about`` ``(T, 3)``)."""
    return np.einsum("s,tsk->tk", np.asarray(masses, float), np.cross(r - about[:, None], v))


def flight_momentum_adjustment(body, motion, sets: LinkSets, flights, *, neighbourhood: int) -> FlightAdjustment:
    """Sec. 3.4.1, eq. 8-9: on each flight frame S2 is turned so that the angular momentum about the
    centre of rotation ``p`` (the COM when S1 is empty, else the S1/S2 joint) is the one the
    block's average ``h_CM`` asks for, with the velocities held::

        h*_p = mean(h_CM) - r_c x p_lin,    w*_S2 = I_S2^-1 (h*_p - h_S1),    w_S2 = I_S2^-1 h_S2,
        dq = exp(w*_S2 dt / 2) exp(-w_S2 dt / 2)                                       (eq. 8-9)

    (``r_c = p - c_M``; ``I_S2`` the inertia tensor of S2 about ``p``: its point masses'
    ``sum m (|u|^2 1 - u u^T)`` -- the paper's footnote prints ``sum m u u^T``, which is not an
    inertia -- plus its segments' own inertias in world axes). Departure from the paper's point
    masses: the momenta include each segment's spin ``R I R^T omega``
    (:func:`mocomp.dynamics.momentum.momentum`, the audit's L), so that what is evened out is what
    the audit measures; with point masses only, an exactly conserving flip (the flips method's
    output) shows a 22 % |L| variation that touch-up would then put into its true L. Eq. 9 relates frame ``t`` to the adjusted frame ``t - 1`` (``q = exp(w dt/2) q'``),
    so the per-frame turns accumulate from the take-off frame (unchanged) through the block; the
    landing neighbourhood eases the last frame's turn to zero. ``correction`` holds the turn's
    rotation vector (rad)."""
    from ..dynamics.momentum import momentum, world_inertias

    T = motion.n_frames
    P, G = fk(motion)
    dt = 1.0 / motion.fps
    mo = momentum(body, motion)
    r, v, om = mo.segment_positions, mo.segment_velocities, mo.segment_angular_velocities
    m = np.asarray(body.masses, float)
    c = mo.com
    p_lin = mo.linear
    Iw = world_inertias(body, np.asarray(motion.global_rotations[:, body.segment_joint]))   # (T, S, 3, 3)
    spin = np.einsum("tsij,tsj->tsi", Iw, om)
    sj = np.asarray(body.segment_joint)
    in2 = sets.component[sj] >= 0
    if sets.s1.any():
        C = rotation_centres(P, sets, None)
        pivots = sets.pivots
        if len(pivots) != 1:
            raise ValueError(f"a flight step with S1 needs one connected S2 (one S1/S2 joint), got {len(pivots)}")
        prot = C[:, pivots[0]]
    else:
        prot = c
        C = np.broadcast_to(c[:, None], P.shape).copy()
    h_cm = mo.angular
    u = r - prot[:, None]
    h_s2 = angular_momentum(m * in2, r, v, prot) + spin[:, in2].sum(axis=1)
    h_s1 = angular_momentum(m * ~in2, r, v, prot) + spin[:, ~in2].sum(axis=1)
    uu = np.einsum("s,tsi,tsj->tij", m * in2, u, u)
    I = np.trace(uu, axis1=1, axis2=2)[:, None, None] * np.eye(3) - uu + Iw[:, in2].sum(axis=1)
    rot = np.zeros((T, 3))
    w, owner = _weights(T, flights, neighbourhood)
    for k, (a, b) in enumerate(flights):
        inner = slice(a + 1, b - 1) if b - a >= 5 else slice(a, b)   # end frames' differences reach the ground
        h_star = h_cm[inner].mean(axis=0) - np.cross(prot[a:b] - c[a:b], p_lin[a:b])
        Iinv = np.linalg.pinv(I[a:b])
        w_star = np.einsum("tij,tj->ti", Iinv, h_star - h_s1[a:b])
        w_now = np.einsum("tij,tj->ti", Iinv, h_s2[a:b])
        # per-frame increments exp(w* dt) exp(-w dt) at once; their running product frame by frame
        inc = (Rotation.from_rotvec(w_star[1:] * dt) * Rotation.from_rotvec(-w_now[1:] * dt)).as_quat()
        acc = running_products(inc)
        rot[a:b] = Rotation.from_quat(acc).as_rotvec()
        for f in np.flatnonzero((owner == k) & (w < 1) & (np.arange(T) >= b)):
            rot[f] = rot[b - 1] * w[f]
    root_pos, local = turn_sets(P, G, sets, rot, C)
    return FlightAdjustment(rot, w, root_pos, local)
