"""Forward kinematics, vectorized over frames (a Python loop runs over joints only)."""
from __future__ import annotations

import numpy as np

from .rotations import quat_apply, quat_multiply

__all__ = ["forward_kinematics", "end_site_positions"]


def forward_kinematics(parents: np.ndarray, offsets: np.ndarray, root_positions: np.ndarray,
                       rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions and rotations.

    Parameters
    ----------
    parents: ``(J,)`` parent indices (root ``-1``; parents precede children).
    offsets: ``(J, 3)`` metres in the parent frame (the root's is ignored here:
        ``root_positions`` is the root joint's world position).
    root_positions: ``(T, 3)`` metres.
    rotations: ``(T, J, 4)`` local unit quaternions, scalar-last.

    Returns
    -------
    positions: ``(T, J, 3)`` world positions (metres).
    global_rotations: ``(T, J, 4)`` world orientations (scalar-last).

    ``G_j = G_parent(j) L_j`` and ``P_j = P_parent(j) + G_parent(j) offset_j``.
    """
    T, J = rotations.shape[:2]
    G = np.empty((T, J, 4))
    P = np.empty((T, J, 3))
    G[:, 0] = rotations[:, 0]
    P[:, 0] = root_positions
    for j in range(1, J):
        p = parents[j]
        G[:, j] = quat_multiply(G[:, p], rotations[:, j])
        P[:, j] = P[:, p] + quat_apply(G[:, p], offsets[j])
    return P, G


def end_site_positions(end_sites, positions: np.ndarray, global_rotations: np.ndarray) -> np.ndarray:
    """``(T, E, 3)`` world positions of end sites given FK results."""
    if not end_sites:
        return np.zeros((positions.shape[0], 0, 3))
    par = np.array([e.parent for e in end_sites])
    off = np.array([e.offset for e in end_sites])
    return positions[:, par] + quat_apply(global_rotations[:, par], off[None])
