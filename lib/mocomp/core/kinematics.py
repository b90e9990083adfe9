"""Forward kinematics of a skeleton over frames, and the velocities of its joints and segments.

Forward kinematics runs compiled when numba is available, else the numpy reference (a Python loop
over joints, vectorised over frames). The velocities are the project's one implementation of

* time derivatives of samples on their true frame times (:func:`central_difference`,
  :func:`second_difference`: second-order central differences, non-uniform spacing allowed, one-sided
  at the ends; the papers smooth capture data first, :func:`gaussian_smooth`: the touch-up paper's
  "gaussian filter of width 5 ... and then used finite differences");
* angular velocities from orientations sampled over time (:func:`angular_velocity`, world or body
  frame, from the logarithm of the relative rotation between frames over their time step);
* rigid-body propagation down the tree: joint-origin velocities ``v_j = v_parent + w_parent x
  (P_j - P_parent)`` (:func:`propagate_velocities`), world rates from the joints' local rates
  ``w_j = w_parent + G_j w_j^local`` (:func:`world_angular_velocities`) and the velocity of points
  fixed in a moving frame, e.g. segment COMs (:func:`point_velocities`).

:mod:`mocomp.dynamics` (momentum, eq. 5.4-5.5 of the flips dissertation, and the MuJoCo check),
the audit and the impact features call these.
"""
from __future__ import annotations

import sys

import numpy as np

from .rotations import cross, quat_apply, quat_inverse, quat_log, quat_multiply

__all__ = ["forward_kinematics", "forward_kinematics_numpy", "end_site_positions", "load_compiled", "frame_times",
           "central_difference", "second_difference", "gaussian_smooth",
           "angular_velocity", "angular_velocity_numpy", "path_matrix", "propagate_velocities",
           "world_angular_velocities", "point_velocities"]


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


def load_compiled() -> bool:
    """Load the compiled backend (:mod:`mocomp.core._compiled`, which imports numba unless
    ``MOCOMP_NO_NUMBA`` is set) so that :func:`forward_kinematics` and :func:`angular_velocity` run
    compiled from now on in this process; returns whether they will (``_compiled.AVAILABLE``).

    For callers that run many forward kinematics of a few poses each -- the synthetic generator's
    stance solves and shooting call it ~120 times per motion, 100 of them on one pose, where the
    numpy reference's per-joint array calls cost ~50x a compiled pass -- numba's one-time import
    (~0.5 s) pays; for a single clip's FK it does not, hence the rule in :func:`forward_kinematics`."""
    from . import _compiled

    return _compiled.AVAILABLE


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



# ------------------------------------------------------------------ velocities
def frame_times(times, n: int) -> np.ndarray:
    """Validate ``times`` ``(n,)`` strictly increasing (or a scalar frame rate, fps) -> ``(n,)`` seconds."""
    t = np.asarray(times, dtype=float)
    if t.ndim == 0:
        if not (np.isfinite(t) and t > 0):
            raise ValueError(f"a scalar 'times' is a frame rate and must be positive, got {times!r}")
        return np.arange(n) / float(t)
    if t.shape != (n,):
        raise ValueError(f"times must have shape ({n},), got {t.shape}")
    if n > 1 and not np.all(np.diff(t) > 0):
        k = int(np.argmin(np.diff(t)))
        raise ValueError(f"frame times must increase strictly; times[{k}]={t[k]!r} >= times[{k + 1}]={t[k + 1]!r}")
    return t


def _uniform_step(t: np.ndarray) -> float:
    h = np.diff(t)
    if not np.allclose(h, h[0], rtol=1e-9, atol=0):
        raise ValueError("order=4 differences need uniformly spaced frame times")
    return float(h[0])


def central_difference(x, times, edge_order: int = 1, order: int = 2) -> np.ndarray:
    """``d x / d t`` along axis 0.

    Parameters
    ----------
    x: ``(T, ...)`` samples.
    times: ``(T,)`` frame times in seconds (strictly increasing), or a frame rate (fps).
    edge_order: 1 (one-sided first-order at the ends, default) or 2.
    order: 2 (default) or 4. Order 2: the second-order central difference on the
        true spacing ``h1 = t_i - t_{i-1}``, ``h2 = t_{i+1} - t_i`` (for uniform
        spacing ``(x_{i+1} - x_{i-1}) / 2h``). Order 4 (uniform spacing only): the
        five-point stencil ``(x_{i-2} - 8 x_{i-1} + 8 x_{i+1} - x_{i+2}) / 12h``
        on frames 2..T-3, order 2 next to the ends -- for exact synthetic data; on
        noisy capture it amplifies noise ~1.3x more.
    """
    x = np.asarray(x, dtype=float)
    T = x.shape[0]
    t = frame_times(times, T)
    if T < 2:
        raise ValueError("a derivative needs at least 2 frames")
    if order not in (2, 4):
        raise ValueError(f"order must be 2 or 4, got {order!r}")
    d = np.gradient(x, t, axis=0, edge_order=min(edge_order, T - 1))
    if order == 4 and T >= 5:
        h = _uniform_step(t)
        d[2:-2] = (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * h)
    return d


def second_difference(x, times, edge_order: int = 1) -> np.ndarray:
    """``d^2 x / d t^2`` along axis 0 (central difference of the central difference;
    for uniform spacing ``(x_{i+2} - 2 x_i + x_{i-2}) / 4h^2`` in the interior)."""
    return central_difference(central_difference(x, times, edge_order), times, edge_order)


def gaussian_smooth(x, sigma: float, axis: int = 0) -> np.ndarray:
    """Gaussian filter along ``axis`` with standard deviation ``sigma`` in frames
    (:func:`scipy.ndimage.gaussian_filter1d`, ``mode="nearest"``; truncated at 4 sigma).
    ``sigma`` of 0 or ``None`` returns a copy."""
    x = np.asarray(x, dtype=float)
    if not sigma:
        return x.copy()
    if sigma < 0 or not np.isfinite(sigma):
        raise ValueError(f"smoothing sigma must be >= 0 frames, got {sigma!r}")
    from scipy.ndimage import gaussian_filter1d    # not at import: `import mocomp` does not load scipy.ndimage

    return gaussian_filter1d(x, sigma, axis=axis, mode="nearest")


_FRAMES = ("world", "body")


def _check_rate_args(q: np.ndarray, order: int, frame: str) -> None:
    if q.ndim < 2 or q.shape[-1] != 4:
        raise ValueError(f"orientations must have shape (T, ..., 4), got {q.shape}")
    if q.shape[0] < 2:
        raise ValueError("an angular velocity needs at least 2 frames")
    if order not in (2, 4):
        raise ValueError(f"order must be 2 or 4, got {order!r}")
    if frame not in _FRAMES:
        raise ValueError(f"frame must be one of {_FRAMES}, got {frame!r}")


def _rotvec_between(q_from: np.ndarray, q_to: np.ndarray, frame: str) -> np.ndarray:
    """The rotation vector taking ``q_from`` to ``q_to``, the short way: ``Log(q_to q_from^-1)`` in
    world axes, ``Log(q_from^-1 q_to)`` in the body axes of ``q_from``."""
    if frame == "world":
        return quat_log(quat_multiply(q_to, quat_inverse(q_from)))
    return quat_log(quat_multiply(quat_inverse(q_from), q_to))


def angular_velocity(quats, times, order: int = 2, frame: str = "world") -> np.ndarray:
    """Angular velocity ``(T, ..., 3)`` rad/s of orientations ``quats`` ``(T, ..., 4)`` sampled at ``times``.

    ``quats`` map body to world (scipy scalar-last); ``times`` are the ``(T,)`` frame times in
    seconds (strictly increasing) or a frame rate (fps). ``frame="world"`` (default) gives the
    rate in world axes, ``frame="body"`` in each orientation's own axes (``w_body = R^T w_world``).

    The formula (J. Sola, "Quaternion kinematics for the error-state Kalman filter", 2017,
    arXiv:1711.02508, the sections on the time derivative ``q_dot = 1/2 w_world q = 1/2 q w_body``
    and on the time-integration of rotation rates): a constant rate over a step ``h`` moves an
    orientation as ``q_{i+1} = Exp(w_world h) q_i = q_i Exp(w_body h)``, so the rate of each step is the
    logarithm (rotation vector, :func:`~mocomp.core.rotations.quat_log`) of the relative rotation
    over ``h``: ``log(q_{i+1} q_i^-1) / h`` (world) or ``log(q_i^-1 q_{i+1}) / h`` (body). Interior
    frames blend the backward and forward steps with the weights of the non-uniform central
    difference::

        w_i = h1/(h1+h2) * log(dq_{i, i+1})/h2 + h2/(h1+h2) * log(dq_{i-1, i})/h1

    (``h1 = t_i - t_{i-1}``, ``h2 = t_{i+1} - t_i``), which is exact for a constant angular velocity
    and second-order accurate otherwise; the ends use the one-sided step. ``order=4`` (uniform
    spacing) replaces frames 2..T-3 by the Richardson combination of the central rotation vectors
    over 2h and 4h, ``(8 log(dq_{i-1, i+1}) - log(dq_{i-2, i+2})) / 12h`` (also exact for a constant
    rate). Sign flips of the quaternions do not matter (the logarithm takes the short way); a step
    must turn by less than pi.

    Runs compiled (:func:`mocomp.core._compiled.angular_velocity`, order 2) when the compiled
    backend is selected and numba is already loaded in the process (as for
    :func:`forward_kinematics`), else the numpy reference :func:`angular_velocity_numpy`; the two
    agree to rounding (tested).
    """
    q = np.asarray(quats, dtype=float)
    _check_rate_args(q, order, frame)
    t = frame_times(times, q.shape[0])
    if order == 2 and "numba" in sys.modules:
        from . import _compiled

        if _compiled.AVAILABLE:
            T = q.shape[0]
            flat = _ro(q.reshape(T, -1, 4))
            out = _compiled.angular_velocity(flat, _ro(t), frame == "body")
            return out.reshape(q.shape[:-1] + (3,))
    return _angular_velocity_numpy(q, t, order, frame)


def angular_velocity_numpy(quats, times, order: int = 2, frame: str = "world") -> np.ndarray:
    """The numpy reference of :func:`angular_velocity` (same arguments and result)."""
    q = np.asarray(quats, dtype=float)
    _check_rate_args(q, order, frame)
    return _angular_velocity_numpy(q, frame_times(times, q.shape[0]), order, frame)


def _angular_velocity_numpy(q: np.ndarray, t: np.ndarray, order: int, frame: str) -> np.ndarray:
    T = q.shape[0]
    h = np.diff(t).reshape((-1,) + (1,) * (q.ndim - 1))
    step = _rotvec_between(q[:-1], q[1:], frame) / h  # (T-1, ..., 3): rate over [t_i, t_{i+1}]
    out = np.empty(q.shape[:-1] + (3,))
    out[0] = step[0]
    out[-1] = step[-1]
    if T > 2:
        h1 = h[:-1]
        h2 = h[1:]
        out[1:-1] = (h1 * step[1:] + h2 * step[:-1]) / (h1 + h2)
    if order == 4 and T >= 5:
        hu = _uniform_step(t)
        r1 = _rotvec_between(q[1:-3], q[3:-1], frame)
        r2 = _rotvec_between(q[:-4], q[4:], frame)
        out[2:-2] = (8 * r1 - r2) / (12 * hu)
    return out


def path_matrix(parents) -> np.ndarray:
    """``(J, J)`` 0/1: ``A[j, k] = 1`` when joint ``k != 0`` lies on the path from the root to ``j``
    (``j`` included), so a quantity summed along the tree is one matrix product (``parents``: ``(J,)``,
    root ``-1``, parents precede children)."""
    par = np.asarray(parents)
    J = len(par)
    A = np.zeros((J, J))
    for j in range(1, J):
        A[j] = A[par[j]]
        A[j, j] = 1.0
    return A


def propagate_velocities(parents, positions, angular_velocities, root_velocity) -> np.ndarray:
    """``(T, J, 3)`` world velocities of the joint origins of a rigid-body tree.

    ``positions`` ``(T, J, 3)`` (m) and ``angular_velocities`` ``(T, J, 3)`` (rad/s, world axes) of
    every joint frame, ``root_velocity`` ``(T, 3)`` (m/s) of joint 0's origin. Each child origin is
    a point of its parent's rigid frame: ``v_j = v_parent + w_parent x (P_j - P_parent)``, summed
    along the path root -> j at once (:func:`path_matrix`)."""
    P = np.asarray(positions, dtype=float)
    w = np.asarray(angular_velocities, dtype=float)
    par = np.array(parents, dtype=np.int64)
    par[0] = 0
    step = cross(w[:, par], P - P[:, par])
    step[:, 0] = 0.0
    return np.asarray(root_velocity, dtype=float)[:, None] + (path_matrix(parents) @ step)


def world_angular_velocities(parents, global_rotations, root_angular_velocity, local_rates) -> np.ndarray:
    """``(T, J, 3)`` world angular velocity of every joint frame from the joints' local rates.

    ``local_rates`` ``(T, J, 3)``: each joint's rotation rate relative to its parent, in the joint's
    own (child) frame (``d/dt R_local = R_local [w]x``; entry 0 ignored); ``global_rotations``
    ``(T, J, 4)`` from forward kinematics; ``root_angular_velocity`` ``(T, 3)`` world. Angular
    velocities of frames chained by rotations add: ``w_j = w_parent + G_j w_j^local``, i.e.
    ``w_root`` plus ``G_k w_k^local`` summed over the joints ``k != 0`` on the path root -> j."""
    wl = quat_apply(global_rotations, local_rates)
    return np.asarray(root_angular_velocity, dtype=float)[:, None] + (path_matrix(parents) @ wl)


def point_velocities(origin_velocity, angular_velocity, origin, points) -> np.ndarray:
    """Velocities of points fixed in moving rigid frames: ``v = v_o + w x (p - o)``.

    ``origin_velocity`` and ``angular_velocity`` (world) of each frame, its ``origin`` and the
    world ``points``, all ``(..., 3)`` broadcasting (e.g. a segment's COM velocity from its carrier
    joint's origin velocity and rate)."""
    return np.asarray(origin_velocity, dtype=float) + cross(angular_velocity, np.asarray(points, dtype=float)
                                                            - np.asarray(origin, dtype=float))
