"""Analytic two-bone inverse kinematics of the legs, to plant feet on the ground.

:func:`two_bone_ik` moves an end joint (the ankle) of a hip-knee-ankle chain to a target:
the knee bends in the leg's current plane until the hip-ankle distance is right (law of
cosines), then the whole leg swings about the hip onto the target (shortest arc). The
ankle keeps its world orientation, so the foot does not turn. Targets out of reach are
approached as far as the leg allows (the leftover is returned).

:func:`plant_feet` uses it for the frames after a landing: each foot joint that is on the
ground (contact weight from its height) is held where it touched down.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_apply, quat_inverse, quat_multiply

__all__ = ["two_bone_ik", "leg_chains", "plant_feet", "run_starts"]


def leg_chains(skeleton) -> list[tuple[int, int, int]]:
    """``(hip, knee, ankle)`` joint indices of each leg: an ankle (name with ``ankle`` or
    ``foot`` but not ``toe``) whose parent and grandparent exist."""
    out = []
    for j, nm in enumerate(skeleton.names):
        low = nm.lower()
        if ("ankle" in low or "foot" in low) and "toe" not in low:
            k = int(skeleton.parents[j])
            h = int(skeleton.parents[k]) if k >= 0 else -1
            if k > 0 and h > 0:
                out.append((h, k, j))
    return out


def _axis_angle_rows(axis, angle) -> np.ndarray:
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    a = axis / np.where(n > 1e-12, n, 1.0)
    return np.concatenate([a * np.sin(0.5 * angle)[..., None], np.cos(0.5 * angle)[..., None]], axis=-1)


def _arc_rows(u, v) -> np.ndarray:
    """Shortest-arc quaternions taking rows of ``u`` to rows of ``v`` (not antiparallel: legs)."""
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    q = np.concatenate([np.cross(u, v), 1.0 + np.sum(u * v, axis=-1, keepdims=True)], axis=-1)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def two_bone_ik(P: np.ndarray, G: np.ndarray, rot: np.ndarray, parents, chain, target) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations (``rot (..., J, 4)``, returned as a copy) with the chain's ankle on ``target
    (..., 3)``, given the frames' world positions ``P (..., J, 3)`` and orientations ``G (..., J, 4)``
    (one frame or a batch). Returns ``(rot, miss)``: ``miss (...)`` m left where the target is
    out of reach (the ankle then stops on the line to it, the leg straight or folded)."""
    h, k, a = chain
    H, K, A = P[..., h, :], P[..., k, :], P[..., a, :]
    T = np.asarray(target, dtype=float)
    l1 = np.linalg.norm(K - H, axis=-1)
    l2 = np.linalg.norm(A - K, axis=-1)
    d_want = np.linalg.norm(T - H, axis=-1)
    d = np.clip(d_want, np.abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6)
    # knee: bend in the leg's plane so that |ankle - hip| = d
    u, w = H - K, A - K
    n = np.cross(w, u)
    straight = np.linalg.norm(n, axis=-1) < 1e-9        # straight leg: bend about the hip's own x axis
    if np.any(straight):
        n = np.where(straight[..., None], quat_apply(G[..., h, :], np.array([1.0, 0.0, 0.0])), n)
    th0 = np.arctan2(np.linalg.norm(np.cross(u, w), axis=-1), np.sum(u * w, axis=-1))
    th1 = np.arccos(np.clip((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0, 1.0))
    q_knee = _axis_angle_rows(n, th0 - th1)            # rotating w about n = w x u turns it toward u
    A1 = K + quat_apply(q_knee, w)
    # hip: swing the whole leg onto the target
    q_hip = _arc_rows(A1 - H, T - H)
    Gh = quat_multiply(q_hip, G[..., h, :])
    Gk = quat_multiply(q_hip, quat_multiply(q_knee, G[..., k, :]))
    out = np.array(rot)
    out[..., h, :] = quat_multiply(quat_inverse(G[..., int(parents[h]), :]), Gh)
    out[..., k, :] = quat_multiply(quat_inverse(Gh), Gk)
    out[..., a, :] = quat_multiply(quat_inverse(Gk), G[..., a, :])   # the foot keeps its world orientation
    return out, np.abs(d_want - d)


def run_starts(on: np.ndarray) -> np.ndarray:
    """``(n, C)`` for each frame and column the frame where its current run of ``on`` began
    (-1 where ``on`` is False)."""
    on = np.asarray(on, dtype=bool)
    n = on.shape[0]
    first = on & ~np.vstack([np.zeros((1,) + on.shape[1:], dtype=bool), on[:-1]])
    idx = np.where(first, np.arange(n).reshape((n,) + (1,) * (on.ndim - 1)), -1)
    return np.where(on, np.maximum.accumulate(idx, axis=0), -1)


def _descends(parents, j: int, ancestor: int) -> bool:
    while j >= 0:
        if j == ancestor:
            return True
        j = int(parents[j])
    return False


def plant_feet(motion: Motion, start: int, weights: np.ndarray, chains, tol: float = 1e-3) -> tuple[Motion, int]:
    """Hold each leg's ankle still while its contact weight is high, from frame ``start`` on.

    ``weights (n, C)`` in [0, 1] per frame (``n = T - start``) and chain. A contact starts when
    the weight rises to 0.5; from then until it falls below 0.5 the ankle's target is its
    horizontal position at that start (its height stays the frame's own), blended with the
    unplanted position by the weight. Frames where the ankle is within ``tol`` m of its target
    are left alone. The chains must be disjoint (two legs). Returns the motion and the number
    of IK solves.
    """
    from ._kernels import motion_fk

    P, G = motion_fk(motion, start)                     # frames start.. only (compiled FK)
    rot, solves = _plant_rotations(motion.skeleton.parents, motion.rotations, P, G, start, weights, chains, tol)
    return motion.replace(rotations=rot), solves


def _plant_rotations(parents, rotations, P, G, start, weights, chains, tol=1e-3) -> tuple[np.ndarray, int]:
    """:func:`plant_feet` on arrays: ``rotations (T, J, 4)`` and the FK ``P``, ``G`` of frames
    ``start..`` only; returns the new rotations (a copy) and the number of IK solves."""
    for c1 in chains:
        for c2 in chains:
            if c1 is not c2 and _descends(parents, c2[0], c1[0]):
                raise ValueError(f"leg chains {c1} and {c2} overlap; plant_feet needs disjoint legs")
    rot = np.array(rotations)
    solves = 0
    starts = run_starts(np.asarray(weights) >= 0.5)
    for c, chain in enumerate(chains):
        a = chain[2]
        tgt = np.array(P[:, a])
        on = starts[:, c] >= 0
        plant = tgt[np.maximum(starts[:, c], 0)][:, [0, 2]]
        blend = np.where(on, weights[:, c], 0.0)[:, None]
        tgt[:, [0, 2]] += blend * (plant - tgt[:, [0, 2]])
        idx = np.flatnonzero(np.linalg.norm(tgt - P[:, a], axis=1) > tol)
        if idx.size:
            f = start + idx
            rot[f], _ = two_bone_ik(P[idx], G[idx], rot[f], parents, chain, tgt[idx])
            solves += idx.size
    return rot, solves
