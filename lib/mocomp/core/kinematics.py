"""Forward kinematics of a skeleton over frames: compiled when numba is available, else the numpy
reference (a Python loop over joints, vectorised over frames)."""
from __future__ import annotations

import sys

import numpy as np

from .rotations import quat_apply, quat_multiply

__all__ = ["forward_kinematics", "forward_kinematics_numpy", "end_site_positions"]


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

    Runs compiled (:func:`mocomp.core._compiled.forward_kinematics`, one pass over frames and
    joints, ~5x faster on a 10,000-frame clip) when the compiled backend is selected
    (:data:`mocomp.core._compiled.AVAILABLE`) and numba is already loaded in the process (by the
    BVH reader, the dynamics or a method's kernels), else the numpy reference
    :func:`forward_kinematics_numpy`: numba's import costs ~0.5 s, more than the numpy FK of any
    clip, so FK alone never pays it. Both give the same bits (tested), so the choice changes
    only the time.
    """
    if "numba" in sys.modules:
        from . import _compiled

        if _compiled.AVAILABLE:
            return _compiled.forward_kinematics(_ro(parents, np.int64), _ro(offsets), _ro(root_positions),
                                                _ro(rotations))
    return forward_kinematics_numpy(parents, offsets, root_positions, rotations)


def _ro(a, dtype=np.float64) -> np.ndarray:
    """C-contiguous read-only view (a copy only when the dtype or layout differ), so one compiled
    signature serves every caller (a Motion's arrays are read-only)."""
    a = np.ascontiguousarray(a, dtype=dtype).view()
    a.setflags(write=False)
    return a


def forward_kinematics_numpy(parents: np.ndarray, offsets: np.ndarray, root_positions: np.ndarray,
                             rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The numpy reference of :func:`forward_kinematics`: a loop over joints, each step
    vectorised over frames with :func:`~mocomp.core.rotations.quat_multiply` and
    :func:`~mocomp.core.rotations.quat_apply` on a component-major ``(J, 4, T)`` layout (every
    operation on contiguous length-T rows)."""
    rotations = np.asarray(rotations, dtype=float)
    root_positions = np.asarray(root_positions, dtype=float)
    offsets = np.asarray(offsets, dtype=float)
    T, J = rotations.shape[:2]
    L = np.ascontiguousarray(np.transpose(rotations, (1, 2, 0)))
    G = np.empty((J, 4, T))
    P = np.empty((J, 3, T))
    G[0] = L[0]
    P[0] = root_positions.T
    for j in range(1, J):
        p = int(parents[j])
        quat_multiply(G[p], L[j], out=G[j], axis=0)
        np.add(P[p], quat_apply(G[p], offsets[j][:, None], axis=0), out=P[j])
    return np.ascontiguousarray(P.transpose(2, 0, 1)), np.ascontiguousarray(G.transpose(2, 0, 1))


def end_site_positions(end_sites, positions: np.ndarray, global_rotations: np.ndarray) -> np.ndarray:
    """``(T, E, 3)`` world positions of end sites given FK results."""
    if not end_sites:
        return np.zeros((positions.shape[0], 0, 3))
    par = np.array([e.parent for e in end_sites])
    off = np.array([e.offset for e in end_sites])
    return positions[:, par] + quat_apply(global_rotations[:, par], off[None])
