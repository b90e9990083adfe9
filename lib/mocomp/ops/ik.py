"""Analytic two-bone inverse kinematics of a limb (hip-knee-ankle), vectorised over frames.

:func:`two_bone_ik` moves the end joint (the ankle) of a three-joint chain onto a target:
the middle joint (the knee) bends in the limb's current plane until the root-end distance is
right (law of cosines), which keeps the knee pointing where it pointed; then the whole limb
swings about its root joint (the hip) onto the target by the shortest arc. The end joint keeps
its world orientation, or takes the one given (``end_rotation``: the foot orientation of a
footplant). A target out of reach is approached as far as the limb allows: the end joint stops
on the line from the hip to the target with the knee straight (or fully folded), and the miss
in metres is returned per frame, so callers can report unreachable frames.

**Soft reach** (``soft_reach=s`` m; :func:`plant_rotations` uses :data:`SOFT_REACH` of the leg's
length). With a hard clamp the knee angle goes as ``sqrt(L - d)`` near full extension
(``L = l1 + l2``), so a target moving at constant speed toward and past the reach straightens the
knee at an unbounded angular rate and then stops it dead: the knee *snaps* straight (and back).
The common soft-IK formulation (A. Nicholas, "Soft IK", 2012, as used in animation rigs) replaces
the hip-ankle distance ``d`` beyond ``d_s = L - s`` by

    ``d' = d_s + s (1 - exp(-(d - d_s) / s))``,

which equals ``d`` with slope 1 at ``d_s`` (C1), stays below ``L`` for every ``d`` and approaches it
exponentially, so the knee straightens smoothly and never quite locks. The ankle then stops short
of a target near or beyond the reach (by ``d - d'``, returned as the miss). So that a target at the
ankle's own position (a vanishing correction) is still reached exactly, ``d'`` is never taken below
``min(d, d_0)``, the chain's current hip-ankle distance ``d_0``.

The hip does not move, and bone lengths are those of the skeleton (forward kinematics of the
returned local rotations): only the rotations of the hip, knee and ankle change.

This module is the project's one leg IK (issue 15): it generalises the former ``mocomp.edit.legs``
(same signatures and results, checked to 1e-14 before that module was removed), and the flight
edits (:mod:`mocomp.edit.seams`, :mod:`mocomp.edit.landing`), the take-off repair
(:mod:`mocomp.flips.takeoff`) and the footplants of this package all call it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_inverse, quat_multiply

__all__ = ["two_bone_ik", "hinge_axis", "leg_chains", "plant_feet", "plant_rotations", "run_starts", "descends",
           "arc_quaternions", "axis_angle_quaternions", "REACH_MARGIN", "SOFT_REACH", "UNREACHABLE_TOL", "soft_distance",
           "PlantReach", "plant_targets"]

#: m: a target is reached with the limb at most this much shorter than fully straight (or this much
#: longer than fully folded); a straight knee has no bending plane, so it is never quite reached.
REACH_MARGIN = 1e-6

#: fraction of a leg's length ``l1 + l2`` over which :func:`plant_rotations` softens the reach
#: (``soft_reach`` of :func:`two_bone_ik`; the same as :data:`mocomp.ops.footplant.SOFT_REACH`)
SOFT_REACH = 0.02

#: m: :func:`plant_rotations` reports a frame as unreachable where the leg misses its target by more
#: than this (the soft reach alone leaves misses of a few mm near full extension)
UNREACHABLE_TOL = 0.005


def soft_distance(d, full, soft, floor=None) -> np.ndarray:
    """The soft-reach hip-ankle distance (module docstring): ``d`` below ``d_s = full - soft``,
    ``d_s + soft (1 - exp(-(d - d_s) / soft))`` above it, never below ``floor`` (``min(d, d_0)``
    in :func:`two_bone_ik`); ``soft <= 0``: ``d`` unchanged. Broadcasts over its arguments."""
    d = np.asarray(d, dtype=float)
    soft = np.asarray(soft, dtype=float)
    full = np.asarray(full, dtype=float)
    s = np.where(soft > 0, soft, 1.0)
    d_s = full - s
    out = np.where((soft > 0) & (d > d_s), d_s + s * (1.0 - np.exp(-np.maximum(d - d_s, 0.0) / s)), d)
    if floor is not None:
        out = np.maximum(out, np.minimum(d, floor))
    return out


def leg_chains(skeleton) -> list[tuple[int, int, int]]:
    """``(hip, knee, ankle)`` joint indices of each leg: an ankle (name with ``ankle`` or
    ``foot`` but not ``toe``) whose parent and grandparent exist.
    :func:`mocomp.ops.plants.leg_layout` finds the legs from the body-segment mapping instead."""
    out = []
    for j, nm in enumerate(skeleton.names):
        low = nm.lower()
        if ("ankle" in low or "foot" in low) and "toe" not in low:
            k = int(skeleton.parents[j])
            h = int(skeleton.parents[k]) if k >= 0 else -1
            if k > 0 and h > 0:
                out.append((h, k, j))
    return out


def _dot(a, b) -> np.ndarray:
    """Row-wise dot products over the last axis (einsum: ~3x faster than ``np.sum(a * b, -1)`` on
    ``(n, 3)``)."""
    return np.einsum("...i,...i->...", a, b)


def _norm(a) -> np.ndarray:
    """Row-wise Euclidean norms over the last axis."""
    return np.sqrt(np.einsum("...i,...i->...", a, a))


def _cross(u, v) -> np.ndarray:
    """``np.cross`` of ``(..., 3)`` rows, written out (the same operations; less per-call overhead)."""
    u0, u1, u2 = u[..., 0], u[..., 1], u[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0], axis=-1)


def axis_angle_quaternions(axis, angle) -> np.ndarray:
    """Quaternions (scalar-last) of rotations by ``angle (...)`` rad about ``axis (..., 3)``
    (any length; a zero axis gives the identity)."""
    n = _norm(axis)[..., None]
    a = np.asarray(axis, dtype=float) / np.where(n > 1e-12, n, 1.0)
    a = np.where(n > 1e-12, a, 0.0)
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([a * np.sin(half), np.where(n > 1e-12, np.cos(half), 1.0)], axis=-1)


def arc_quaternions(u, v) -> np.ndarray:
    """Shortest-arc quaternions taking the directions of rows ``u (..., 3)`` to those of ``v``.

    Antiparallel rows (no unique arc) turn by 180 deg about an axis perpendicular to ``u``."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u = u / _norm(u)[..., None]
    v = v / _norm(v)[..., None]
    c = _cross(u, v)
    w = 1.0 + _dot(u, v)[..., None]
    anti = w[..., 0] < 1e-12
    if np.any(anti):
        perp = _cross(u, np.array([1.0, 0.0, 0.0]))
        perp = np.where(_norm(perp)[..., None] < 1e-6, _cross(u, np.array([0.0, 1.0, 0.0])),
                        perp)
        c = np.where(anti[..., None], perp, c)
        w = np.where(anti[..., None], 0.0, w)
    q = np.concatenate([c, w], axis=-1)
    return q / _norm(q)[..., None]


def _parent_rotation(G, parents, j):
    p = int(parents[j])
    if p < 0:
        out = np.zeros(G.shape[:-2] + (4,))
        out[..., 3] = 1.0
        return out
    return G[..., p, :]


def two_bone_ik(P: np.ndarray, G: np.ndarray, rot: np.ndarray, parents, chain, target, *,
                end_rotation: np.ndarray | None = None, reach_margin: float = REACH_MARGIN,
                bend_axis=(1.0, 0.0, 0.0), bend_prior: float = 0.0, soft_reach=0.0) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations with the chain's end joint on ``target``.

    Parameters
    ----------
    P, G: ``(..., J, 3)`` world positions and ``(..., J, 4)`` world orientations of the frames
        (one frame or a batch), e.g. ``motion.fk()`` or a slice of it.
    rot: ``(..., J, 4)`` the frames' local rotations; a changed copy is returned.
    parents: ``(J,)`` parent indices.
    chain: ``(hip, knee, ankle)`` joint indices, each the parent of the next.
    target: ``(..., 3)`` m, where the ankle joint should go.
    end_rotation: ``(..., 4)`` world orientation for the ankle (default: it keeps its own, so
        the foot does not turn).
    reach_margin: m; the hip-ankle distance is clamped to ``[|l1 - l2| + margin, l1 + l2 - margin]``.
    bend_axis: ``(3,)`` or ``(..., 3)`` the hip's local axis the knee bends about when the leg is
        straight (no plane), e.g. the knee's hinge axis in the thigh frame
        (:func:`hinge_axis`).
    bend_prior: weight of ``bend_axis`` against the measured plane normal ``w x u`` (whose length
        is ``l1 l2 sin(knee angle)``): the knee bends about ``w x u + bend_prior l1 l2 G_hip bend_axis``,
        so a nearly straight leg, whose plane is noise, bends about its hinge. 0 (default): the axis
        is used only where the leg is exactly straight.
    soft_reach: m (scalar or ``(...)``), the width ``s`` of the soft reach (module docstring);
        0 (default): the hard clamp alone.

    Returns ``(rot, miss)``: ``miss (...)`` m, the distance left between the ankle and the
    target (0 to rounding where it is reachable; the clamped or softened excess otherwise).
    """
    h, k, a = (int(c) for c in chain)
    H, K, A = P[..., h, :], P[..., k, :], P[..., a, :]
    T = np.asarray(target, dtype=float)
    l1 = _norm(K - H)
    l2 = _norm(A - K)
    d_want = _norm(T - H)
    d = d_want
    if np.any(np.asarray(soft_reach) > 0):
        d = soft_distance(d_want, l1 + l2 - reach_margin, soft_reach, floor=_norm(A - H))
    d = np.clip(d, np.abs(l1 - l2) + reach_margin, l1 + l2 - reach_margin)
    # knee: bend in the leg's plane (normal n = w x u) so that |ankle - hip| = d
    u, w = H - K, A - K
    n = _cross(w, u)
    if bend_prior > 0:
        n = n + (bend_prior * l1 * l2)[..., None] * quat_apply(G[..., h, :], np.asarray(bend_axis, dtype=float))
    straight = _norm(n) < 1e-9
    if np.any(straight):
        n = np.where(straight[..., None], quat_apply(G[..., h, :], np.asarray(bend_axis, dtype=float)), n)
    # the bend is about n: only its component normal to the leg's plane changes the hip-ankle distance
    th0 = np.arctan2(_norm(_cross(u, w)), _dot(u, w))
    th1 = np.arccos(np.clip((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0, 1.0))
    if bend_prior > 0:
        # about an axis off the plane normal, turning w by phi gives the angle th1 to u: solve for phi
        # (w's angle to u as w turns about the unit axis a: cos = (u.a)(w.a) + |u_p||w_p| cos(phi + phi0))
        ax = n / _norm(n)[..., None]
        ua, wa = _dot(u, ax), _dot(w, ax)
        up, wp = u - ua[..., None] * ax, w - wa[..., None] * ax
        nup, nwp = _norm(up), _norm(wp)
        phi0 = np.arctan2(_dot(_cross(wp, up), ax), _dot(wp, up))   # from w_p to u_p
        c = np.clip((l1 * l2 * np.cos(th1) - ua * wa) / np.maximum(nup * nwp, 1e-300), -1.0, 1.0)
        # w_p at angle phi from its start has angle (phi0 - phi) to u_p; the smallest |phi| with the right cosine
        cand = np.stack([phi0 - np.arccos(c), phi0 + np.arccos(c)], axis=-1)
        cand = (cand + np.pi) % (2 * np.pi) - np.pi
        phi = np.take_along_axis(cand, np.argmin(np.abs(cand), axis=-1)[..., None], axis=-1)[..., 0]
        q_knee = axis_angle_quaternions(ax, phi)
    else:
        q_knee = axis_angle_quaternions(n, th0 - th1)      # rotating w about n = w x u turns it toward u
    A1 = K + quat_apply(q_knee, w)
    # hip: swing the whole leg onto the target
    q_hip = arc_quaternions(A1 - H, T - H)
    Gh = quat_multiply(q_hip, G[..., h, :])
    Gk = quat_multiply(q_hip, quat_multiply(q_knee, G[..., k, :]))
    Ga = G[..., a, :] if end_rotation is None else np.asarray(end_rotation, dtype=float)
    out = np.array(rot)
    out[..., h, :] = quat_multiply(quat_inverse(_parent_rotation(G, parents, h)), Gh)
    out[..., k, :] = quat_multiply(quat_inverse(Gh), Gk)
    out[..., a, :] = quat_multiply(quat_inverse(Gk), Ga)
    return out, np.abs(d_want - d)


def hinge_axis(P: np.ndarray, G: np.ndarray, chain) -> np.ndarray:
    """``(3,)`` the knee's bending axis in the hip joint's local frame, averaged over the frames
    (``P (T, J, 3)``, ``G (T, J, 4)``) weighted by how bent the knee is (``|w x u| = l1 l2 sin``),
    for :func:`two_bone_ik`'s ``bend_axis``: a hinge knee bends about one axis fixed in the thigh."""
    h, k, a = (int(c) for c in chain)
    n = np.cross(P[:, a] - P[:, k], P[:, h] - P[:, k])
    local = quat_apply(quat_inverse(G[:, h]), n)
    s = local.sum(axis=0)
    norm = np.linalg.norm(s)
    return s / norm if norm > 1e-12 else np.array([1.0, 0.0, 0.0])


def run_starts(on: np.ndarray) -> np.ndarray:
    """``(n, C)`` for each frame and column the frame where its current run of ``on`` began
    (-1 where ``on`` is False)."""
    on = np.asarray(on, dtype=bool)
    n = on.shape[0]
    first = on & ~np.vstack([np.zeros((1,) + on.shape[1:], dtype=bool), on[:-1]])
    idx = np.where(first, np.arange(n).reshape((n,) + (1,) * (on.ndim - 1)), -1)
    return np.where(on, np.maximum.accumulate(idx, axis=0), -1)


def descends(parents, j: int, ancestor: int) -> bool:
    """Whether joint ``j`` is ``ancestor`` or lies below it in the tree given by ``parents``."""
    while j >= 0:
        if j == ancestor:
            return True
        j = int(parents[j])
    return False


def plant_feet(motion: Motion, start: int, weights: np.ndarray, chains, tol: float = 1e-3) -> tuple[Motion, int]:
    """Hold each leg's ankle still while its contact weight is high, from frame ``start`` on
    (the flight edits' planting, :mod:`mocomp.edit.seams`).

    ``weights (n, C)`` in [0, 1] per frame (``n = T - start``) and chain. A contact is a run of frames
    with weight >= 0.5; its anchor is the ankle's horizontal position on the run's first frame. The
    ankle's horizontal target is its own position moved toward the anchor by the weight,
    ``p + w (anchor - p)`` (its height stays the frame's own), on the run and on the frames of weight
    above 0 next to it, so the hold comes and goes with the weight: a continuous weight gives a
    continuous pose, with no step where the weight crosses 0.5 (see :func:`plant_targets`). Frames
    where the ankle is within ``tol`` m of its target are left alone. The chains must be disjoint
    (two legs). Returns the motion and the number of IK solves.
    :func:`mocomp.ops.enforce_footplants` is the general footplant enforcement.
    """
    sk = motion.skeleton
    P, G = forward_kinematics(sk.parents, sk.offsets, motion.root_positions[start:], motion.rotations[start:])
    rot, solves = plant_rotations(sk.parents, motion.rotations, P, G, start, weights, chains, tol)
    return motion.replace(rotations=rot), solves


def plant_targets(pos: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(n, C, 2)`` horizontal ankle targets of :func:`plant_feet` from the ankles' horizontal
    positions ``pos (n, C, 2)`` and the contact weights ``(n, C)``.

    Each run of weight >= 0.5 anchors the ankle at its position on the run's first frame. A frame of
    weight above 0 that is not in a run but in the same stretch of positive weight as one takes the
    nearest run's anchor (before the first run, after the last one); between two runs of one such
    stretch (the weight dips without reaching 0) the anchor moves from the earlier run's to the later
    one's, linearly in frames, so that nothing jumps where the later run begins. The target is
    ``pos + w (anchor - pos)``: where the weight is continuous, so is the target (the former rule,
    the anchor weighted only while ``w >= 0.5`` and dropped below, let go of a planted foot in one
    frame: half its correction at once)."""
    pos = np.asarray(pos, dtype=float)
    w = np.clip(np.asarray(weights, dtype=float), 0.0, 1.0)
    n = w.shape[0]
    t = np.arange(n)[:, None]
    on = w >= 0.5
    pos_ = w > 0
    seg = np.cumsum(np.vstack([pos_[:1], pos_[1:] & ~pos_[:-1]]), axis=0) * pos_      # positive-weight stretch id
    starts = run_starts(on)
    first = on & (starts == t)
    # the last run start at or before each frame, the last on-frame at or before, the next run start after
    prev_s = np.maximum.accumulate(np.where(first, t, -1), axis=0)
    prev_on = np.maximum.accumulate(np.where(on, t, -1), axis=0)
    next_s = np.minimum.accumulate(np.where(first, t, n)[::-1], axis=0)[::-1]
    cols = np.arange(w.shape[1])[None]
    same = lambda f, ok: ok & (seg[np.clip(f, 0, n - 1), cols] == seg) & pos_       # noqa: E731
    has_p = same(prev_s, prev_s >= 0)
    has_n = same(next_s, next_s < n)
    a_p = pos[np.clip(prev_s, 0, n - 1), cols]
    a_n = pos[np.clip(next_s, 0, n - 1), cols]
    # in a dip between two runs: the fraction of the way from the earlier run's last frame to the later's first
    gap = np.maximum(next_s - prev_on, 1)
    s = np.where(has_p & has_n & ~on, (t - prev_on) / gap, 0.0)
    s = np.where(has_p, s, 1.0)
    anchor = a_p + s[..., None] * (a_n - a_p)
    anchor = np.where((has_p | has_n)[..., None], anchor, pos)
    return pos + w[..., None] * (anchor - pos)


@dataclass(frozen=True)
class PlantReach:
    """Where :func:`plant_rotations` could not put the ankles on their targets.

    unreachable: per chain (in the order given), half-open runs ``(start, stop)`` of clip frames where
        the ankle missed its target by more than :data:`UNREACHABLE_TOL` (the target beyond the soft
        reach, or beyond the leg).
    max_miss: m, the largest miss per chain (0 where every target was reached).
    softened: per chain, the number of solved frames whose target lay in the soft zone
        (within ``soft_reach`` of full extension) or beyond.
    """

    unreachable: tuple
    max_miss: tuple
    softened: tuple

    @property
    def n_unreachable(self) -> int:
        return int(sum(b - a for runs in self.unreachable for a, b in runs))

    def summary(self) -> str:
        if not self.n_unreachable:
            return "every plant target within reach"
        return (f"{self.n_unreachable} leg-frame(s) out of reach (ankle short of its target by up to "
                f"{max(self.max_miss) * 100:.1f} cm): " + "; ".join(
                    f"leg {i}: frames " + ", ".join(f"{a}-{b - 1}" for a, b in runs)
                    for i, runs in enumerate(self.unreachable) if runs))


def _runs(mask: np.ndarray, offset: int) -> list[tuple[int, int]]:
    from ..dynamics.contacts import label_intervals

    return [(a + offset, b + offset) for a, b in label_intervals(mask)]


def plant_rotations(parents, rotations, P, G, start, weights, chains, tol=1e-3, *, soft_reach: float = SOFT_REACH,
                    return_reach: bool = False):
    """:func:`plant_feet` on arrays: ``rotations (T, J, 4)`` and the FK ``P``, ``G`` of frames
    ``start..`` only; returns the new rotations (a copy) and the number of IK solves.

    soft_reach: fraction of each leg's length ``l1 + l2`` over which the reach is softened
        (module docstring; 0: the hard clamp, whose knee snaps straight where a target passes the reach).
    return_reach: also return a :class:`PlantReach` (the unreachable frames), as a third element.
    """
    for c1 in chains:
        for c2 in chains:
            if c1 is not c2 and descends(parents, c2[0], c1[0]):
                raise ValueError(f"leg chains {c1} and {c2} overlap; plant_feet needs disjoint legs")
    if not (np.isfinite(soft_reach) and 0.0 <= soft_reach < 0.5):
        raise ValueError(f"soft_reach must be a fraction of the leg length in [0, 0.5), got {soft_reach!r}")
    rot = np.array(rotations)
    solves = 0
    weights = np.asarray(weights, dtype=float)
    if weights.shape != (P.shape[0], len(chains)):
        raise ValueError(f"plant weights: expected shape {(P.shape[0], len(chains))} (frames from {start} x legs), "
                         f"got {weights.shape}")
    ank = [c[2] for c in chains]
    hor = plant_targets(P[:, ank][..., [0, 2]], weights)
    unreachable, max_miss, softened = [], [], []
    for c, chain in enumerate(chains):
        h, k, a = chain
        tgt = np.array(P[:, a])
        tgt[:, [0, 2]] = hor[:, c]
        idx = np.flatnonzero(np.linalg.norm(tgt - P[:, a], axis=1) > tol)
        miss = np.zeros(P.shape[0])
        n_soft = 0
        if idx.size:
            f = start + idx
            full = _norm(P[idx, k] - P[idx, h]) + _norm(P[idx, a] - P[idx, k])
            rot[f], miss[idx] = two_bone_ik(P[idx], G[idx], rot[f], parents, chain, tgt[idx],
                                            soft_reach=soft_reach * full)
            n_soft = int(np.count_nonzero(_norm(tgt[idx] - P[idx, h]) > (1.0 - soft_reach) * full))
            solves += idx.size
        unreachable.append(_runs(miss > UNREACHABLE_TOL, start))
        max_miss.append(float(miss.max(initial=0.0)))
        softened.append(n_soft)
    if return_reach:
        return rot, solves, PlantReach(tuple(unreachable), tuple(max_miss), tuple(softened))
    return rot, solves
