"""Sequencing with rotated repetitions and the landing search (dissertation eq. 5.10-5.11).

The clip ``F = [F_S, F_B, F_E]`` (eq. 5.10, ``F_B = f_m .. f_n``) becomes

    F_new = [F_S, F_B, R_B(phi), R_B(2 phi), ..., R_B(r phi)]           (eq. 5.11)

with ``r = ceil((2 pi flips - phi_S - phi_E) / phi)`` (section 5.4.2), then a second
search joins the last repetitions to the landing: frames ``f`` (in the copies)
and ``g`` (in ``F_E``) with ``f ~ g``; ``F*`` is ``F_new`` cut after ``f``
followed by ``F_E`` from the frame after ``g``.

**The count, settled.** Let ``theta`` be the root rotation about ``L`` and
``phi_S = theta(m) - theta(0)``, ``phi_E = theta(end) - theta(n)``,
``phi = theta(n) - theta(m)``. Repetitions are laid end to end without
duplicating the matched frame (copy ``j`` holds frames ``m .. n-1`` rotated by
``j phi``; ``R(f_m, phi)`` takes the place of ``f_n``), so ``F_B`` plus ``c``
rotated copies followed by ``F_E`` (rotated by ``c phi``) turns by
``phi_S + (c + 1) phi + phi_E``. Reaching the target ``Theta`` needs
``c >= (Theta - phi_S - phi_E)/phi - 1`` copies; the paper's
``r = ceil((Theta - phi_S - phi_E)/phi)`` is one more than that, and its
``F_new`` lists ``r + 1`` copies of ``F_B`` (``F_B`` and ``R_B(phi) .. R_B(r phi)``).
That surplus (between ``phi`` and ``2 phi`` of extra turn) is what the landing
search cuts away: ``f`` is taken where the rotation about ``L`` reached so far
equals ``g``'s rotation plus the requested extra, so the cut removes exactly the
surplus and the total is the target (``tests/test_flips_sequence.py``).

**The target.** A multi-flip must land as the original did, so the landing
fragment ``F_E`` is rotated by exactly ``extra = 2 pi (flips - 1)`` (the identity for
flips) and the target is ``Theta = theta_orig + extra`` (``= 2 pi flips`` for a
perfect single flip). The small twist mismatch ``delta`` left at the landing
join (at most about one frame's rotation) is spread linearly over the flight
frames before it, so the rotation about ``L`` is continuous and the landing
is not tilted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import PhysicsError
from .looping import TIE_ATOL, TIE_RTOL, SelfLoop, choose_tied
from ._kernels import AVAILABLE, frame_distance_nb, landing_search_nb
from .similarity import SimilarityWeights, frame_distance

__all__ = ["loop_count", "LandingJoin", "Sequence", "find_landing", "build_sequence", "DELTA_TOL"]

#: radians; landing pairs whose rotation mismatches ``|delta|`` differ by less are equal for the
#: smallest-``|delta|`` rule of :func:`find_landing` (one frame turns ~0.05-0.1 rad)
DELTA_TOL = 1e-4


def loop_count(target: float, phi_S: float, phi_E: float, phi: float) -> int:
    """The paper's ``r = ceil((target - phi_S - phi_E) / phi)``: rotated copies of ``F_B`` in
    ``F_new`` (eq. 5.11), which holds ``r + 1`` copies of ``F_B`` in all."""
    if not phi > 0:
        raise ValueError(f"the loop angle phi must be positive, got {phi!r}")
    return max(int(math.ceil((target - phi_S - phi_E) / phi - 1e-9)), 1)


@dataclass(frozen=True)
class LandingJoin:
    """The second search: ``f`` in the repetitions joined to ``g`` in ``F_E``.

    Attributes
    ----------
    u: position of ``f`` in the unrolled repetitions (0 = ``f_m`` of ``F_B``).
    f: source frame of ``f``; ``copy``: which copy it lies in (0 = ``F_B``).
    g: frame of ``F_E`` that ``f`` replaces (the sequence continues at ``g + 1``).
    distance: eq. 5.13 distance ``D(f, g)``.
    delta: radians, rotation-about-``L`` mismatch at the join before correction
        (spread over the flight, see :func:`build_sequence`).
    n_pairs: pairs compared.
    """

    u: int
    f: int
    copy: int
    g: int
    distance: float
    delta: float
    n_pairs: int


@dataclass(frozen=True)
class Sequence:
    """``F*``: the multi-flip frame sequence at the original timing (before retiming).

    Attributes
    ----------
    frames: ``(T*,)`` source frame of each frame.
    extra: ``(T*,)`` radians of rotation about ``L`` added to each frame (``j phi`` in
        copy ``j``, ``extra_total`` in ``F_E``, plus the spread join correction).
    copy: ``(T*,)`` ``-1`` in ``F_S``, ``j`` in copy ``j``, ``-2`` in ``F_E``.
    r: the paper's repetition count (rotated copies in ``F_new``).
    takeoff, landing: sequence indices of the first and last airborne frames.
    loop_seams: sequence indices ``a`` of loop seams (between ``a`` and ``a + 1``).
    landing_seam: sequence index of ``f`` (the seam is between it and ``g + 1``).
    join: the :class:`LandingJoin`.
    target: radians, total rotation about ``L`` requested for the whole clip.
    extra_total: radians, rotation added (``target - theta_orig``).
    phi_S, phi_E: radians, rotation about ``L`` in ``F_S`` and ``F_E``.
    """

    frames: np.ndarray
    extra: np.ndarray
    copy: np.ndarray
    r: int
    takeoff: int
    landing: int
    loop_seams: tuple[int, ...]
    landing_seam: int
    join: LandingJoin
    target: float
    extra_total: float
    phi_S: float
    phi_E: float
    notes: tuple[str, ...] = field(default=())

    @property
    def n_frames(self) -> int:
        return int(self.frames.size)


def _unrolled(theta: np.ndarray, loop: SelfLoop, copies: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Source frame, copy index and rotation about ``L`` of the unrolled repetitions."""
    P = loop.period
    u = np.arange(copies * P)
    src = loop.m + u % P
    cp = u // P
    return src, cp, theta[src] + cp * loop.phi


def find_landing(rotations: np.ndarray, theta: np.ndarray, flight: tuple[int, int], loop: SelfLoop,
                 extra_total: float, copies: int, axis: np.ndarray, weights: SimilarityWeights,
                 omegas: np.ndarray | None = None, max_delta: float | None = None) -> LandingJoin:
    """The second search of section 5.2: ``f`` among the ``copies`` repetitions, ``g`` in the
    flight part of ``F_E``, with ``f ~ g`` (eq. 5.13) and ``f``'s rotation about ``L``
    equal to ``g``'s plus ``extra_total`` to within ``max_delta`` (default: 1.5 frames of
    the flight's mean rotation rate, at least 2 degrees).

    The choice is robust to rounding: pairs whose ``D`` is within
    :data:`~mocomp.flips.looping.TIE_RTOL` (relative) plus :data:`~mocomp.flips.looping.TIE_ATOL`
    (radians of mean joint mismatch) of the lowest are tied, and among them the rule is, in
    order: the smallest rotation mismatch ``|delta|`` (to within :data:`DELTA_TOL` rad; the least
    twist correction to spread over the flight), then the earliest cut ``u`` (the most of the
    original landing fragment kept), then the earliest ``g``. In a held tuck (the synthetic
    flips) dozens of pairs match exactly and ``D`` is rounding noise: a plain argmin picked
    ``f`` 143-167 over five seeded 1e-7 perturbations of the input."""
    s, e = flight
    g0, g1 = loop.n, e - 1                             # F_E frames still in the air, not the last one
    if g1 <= g0:
        raise PhysicsError(f"no flight frames after the loop end n={loop.n} (flight ends at {e - 1}): "
                           "the loop search must leave part of the flight for the landing join")
    if max_delta is None:
        rate = (theta[e - 1] - theta[s]) / max(e - 1 - s, 1)
        max_delta = max(1.5 * abs(rate), np.deg2rad(2.0))
    wsum = weights.root + float(np.sum(weights.joints))
    if AVAILABLE and not weights.velocity_weight > 0:
        # the same pairs and distances as below, without building the (G, U) candidate arrays
        u, g, d, delta = landing_search_nb(rotations, theta, loop.m, loop.period, copies * loop.period,
                                           loop.phi, g0, g1, extra_total, max_delta, axis, weights)
        if u.size:
            k = _pick_landing(d, delta, u, g, wsum)
            return LandingJoin(u=int(u[k]), f=int(loop.m + u[k] % loop.period), copy=int(u[k] // loop.period),
                               g=int(g[k]), distance=float(d[k]), delta=float(delta[k]), n_pairs=int(u.size))
    src, cp, th_u = _unrolled(theta, loop, copies)
    g = np.arange(g0, g1)
    want = theta[g] + extra_total
    diff = th_u[None, :] - want[:, None]               # (G, U)
    ok = np.abs(diff) <= max_delta
    gi, ui = np.nonzero(ok)
    if gi.size == 0:
        raise PhysicsError(
            f"no frame of the {copies} repetitions reaches the requested rotation for any landing frame "
            f"(needed up to {np.degrees(want.max()):.0f} deg, repetitions reach {np.degrees(th_u.max()):.0f} deg)")
    rot = np.asarray(rotations, dtype=float)
    om1 = om2 = None
    if weights.velocity_weight > 0:
        om1, om2 = omegas[src[ui]], omegas[g[gi]]
    if weights.velocity_weight > 0:
        D, _ = frame_distance(rot[src[ui]], rot[g[gi]], axis, weights, om1, om2)
    else:
        D = (frame_distance_nb if AVAILABLE else frame_distance)(rot[src[ui]], rot[g[gi]], axis, weights)[0]
    k = _pick_landing(D, diff[gi, ui], ui, g[gi], wsum)
    return LandingJoin(u=int(ui[k]), f=int(src[ui[k]]), copy=int(cp[ui[k]]), g=int(g[gi[k]]),
                       distance=float(D[k]), delta=float(diff[gi[k], ui[k]]), n_pairs=int(D.size))


def _pick_landing(D: np.ndarray, delta: np.ndarray, u: np.ndarray, g: np.ndarray, wsum: float) -> int:
    """The tie rule of :func:`find_landing` over candidate pairs ``(u, g)``: index of the chosen one."""
    tied = choose_tied(D, wsum, TIE_RTOL, TIE_ATOL)
    ad = np.abs(delta[tied])
    tied = tied[ad <= ad.min() + DELTA_TOL]
    return int(tied[np.lexsort((g[tied], u[tied]))[0]])


def build_sequence(rotations: np.ndarray, theta: np.ndarray, flight: tuple[int, int], loop: SelfLoop,
                   axis: np.ndarray, weights: SimilarityWeights, flips: int | None = 2,
                   extra_rotation: float | None = None, omegas: np.ndarray | None = None,
                   max_delta: float | None = None) -> Sequence:
    """Eq. 5.10-5.11 plus the landing search: the frame plan of a multi-flip.

    Give ``flips`` (total somersaults, >= 2; the landing fragment is rotated by
    ``2 pi (flips - 1)``) or ``extra_rotation`` (radians added about ``L``, e.g. to
    turn a 180 degree twist jump into a 270 degree one).
    """
    theta = np.asarray(theta, dtype=float)
    T = theta.size
    s, e = int(flight[0]), int(flight[1])
    if extra_rotation is None:
        if flips is None or int(flips) != flips or flips < 2:
            raise ValueError(f"flips must be an integer >= 2 (the input is one flip), got {flips!r}")
        extra_total = 2 * np.pi * (int(flips) - 1)
        requested = 2 * np.pi * int(flips)
    else:
        extra_total = float(extra_rotation)
        if not extra_total > 0:
            raise ValueError(f"extra_rotation must be positive (radians), got {extra_rotation!r}")
        requested = None
    m, n, phi = loop.m, loop.n, loop.phi
    theta_orig = theta[-1] - theta[0]
    phi_S = theta[m] - theta[0]
    phi_E = theta[-1] - theta[n]
    target = theta_orig + extra_total
    r = loop_count(target, phi_S, phi_E, phi)
    copies = r + 1
    join = find_landing(rotations, theta, (s, e), loop, extra_total, copies, axis, weights, omegas, max_delta)
    P = loop.period
    u_idx = np.arange(join.u + 1)
    src_u = m + u_idx % P
    cp_u = u_idx // P
    # [F_S, the repetitions up to f, F_E after g] filled in place (eq. 5.11 cut at the landing join)
    b = m + join.u + 1
    N = b + T - join.g - 1
    frames = np.empty(N, dtype=np.int64)
    frames[:m] = np.arange(0, m)
    frames[m:b] = src_u
    frames[b:] = np.arange(join.g + 1, T)
    copy = np.full(N, -1, dtype=np.int64)
    copy[m:b] = cp_u
    copy[b:] = -2
    extra = np.zeros(N)
    extra[m:b] = cp_u * phi
    extra[b:] = extra_total
    f_idx = m + join.u
    # spread the join mismatch over the flight frames up to f (linear in time from take-off);
    # in place on the slice: elsewhere the correction is +0, which adds nothing
    span = f_idx - s
    extra[s:f_idx + 1] += -join.delta * (np.arange(span + 1) / max(span, 1))
    loop_seams = tuple(range(m + P - 1, m + int(cp_u[-1]) * P, P))
    landing = f_idx + (e - 1 - join.g)
    notes = []
    if requested is not None and abs(theta_orig - 2 * np.pi) > np.deg2rad(20):
        notes.append(f"the input turns {np.degrees(theta_orig):.0f} deg about L in all (not 360): the target is "
                     f"its rotation plus {np.degrees(extra_total):.0f} deg so that the landing matches the original")
    return Sequence(frames=frames, extra=extra, copy=copy, r=r, takeoff=s, landing=int(landing),
                    loop_seams=loop_seams, landing_seam=int(f_idx), join=join, target=float(target),
                    extra_total=float(extra_total), phi_S=float(phi_S), phi_E=float(phi_E), notes=tuple(notes))
