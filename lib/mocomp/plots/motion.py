"""Overview plots of one motion: root trajectory (top and side views) and a
joint-speed heat map over time. Matplotlib's object API only (no pyplot state):
figures render with the Agg canvas and are safe in scripts, tests and notebooks.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..io.summary import joint_speeds

__all__ = ["plot_root_top", "plot_root_side", "plot_joint_speed", "motion_overview", "main_direction"]


def main_direction(ground_xz: np.ndarray) -> np.ndarray:
    """Unit ground-plane direction ``(dx, dz)`` of largest spread of a path (PCA);
    the start->end direction when the path is a point. The sign points start->end."""
    c = ground_xz - ground_xz.mean(axis=0)
    if np.allclose(c, 0.0):
        return np.array([1.0, 0.0])
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    d = vt[0]
    if np.dot(ground_xz[-1] - ground_xz[0], d) < 0:
        d = -d
    return d / np.linalg.norm(d)


def plot_root_top(motion, ax) -> None:
    """Root path seen from above: x (right) against z, coloured by time, equal scales."""
    rp = motion.root_positions
    sc = ax.scatter(rp[:, 0], rp[:, 2], c=motion.times, s=4, cmap="viridis")
    ax.plot(rp[:, 0], rp[:, 2], lw=0.5, color="0.6", zorder=0)
    ax.plot(rp[0, 0], rp[0, 2], "o", ms=7, mfc="none", mec="k", label="start")
    ax.plot(rp[-1, 0], rp[-1, 2], "s", ms=7, mfc="none", mec="k", label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_title("root, top view")
    ax.legend(loc="best", fontsize="small")
    ax.figure.colorbar(sc, ax=ax, label="time (s)", shrink=0.8)


def plot_root_side(motion, ax) -> None:
    """Root height against distance along the main travel direction (side view), and
    the lowest joint's height for reference (where the feet are)."""
    rp = motion.root_positions
    d = main_direction(rp[:, [0, 2]])
    s = (rp[:, [0, 2]] - rp[0, [0, 2]]) @ d
    ax.plot(s, rp[:, 1], lw=1.2, color="C0", label="root")
    low = motion.positions[..., 1].min(axis=1)
    ax.plot(s, low, lw=0.8, color="C3", label="lowest joint")
    ax.axhline(0.0, color="0.5", lw=0.5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"distance along ({d[0]:+.2f} x, {d[1]:+.2f} z) (m)")
    ax.set_ylabel("height y (m)")
    ax.set_title("root, side view")
    ax.legend(loc="best", fontsize="small")


def plot_joint_speed(motion, ax, vmax: float | None = None) -> None:
    """Heat map of every joint's linear speed (m/s) over time (central differences).

    ``vmax`` caps the colour scale (default: the 99th percentile, so a few glitch
    frames do not wash out the map; the title gives the true peak).
    """
    v = joint_speeds(motion)
    vmax = float(np.percentile(v, 99)) if vmax is None else vmax
    t = motion.times
    T = motion.n_frames
    x_edges = np.concatenate([[t[0] - 0.5 * motion.dt], t + 0.5 * motion.dt]) if T else t
    y_edges = np.arange(motion.skeleton.n_joints + 1) - 0.5
    im = ax.pcolormesh(x_edges, y_edges, v.T, cmap="magma", vmin=0.0, vmax=max(vmax, 1e-9), shading="flat")
    names = motion.skeleton.names
    ax.set_yticks(np.arange(len(names)))
    ax.set_yticklabels(names, fontsize=max(4, min(8, 240 // max(1, len(names)))))
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    j = int(np.argmax(v.max(axis=0))) if v.size else 0
    ax.set_title(f"joint speed (peak {v.max() if v.size else 0:.2f} m/s at {names[j]})")
    ax.figure.colorbar(im, ax=ax, label="speed (m/s)", shrink=0.9)


def motion_overview(motion, title: str | None = None) -> Figure:
    """A figure with the top view, the side view and the joint-speed heat map."""
    fig = Figure(figsize=(12, 8.5), layout="constrained")
    gs = fig.add_gridspec(2, 2, height_ratios=[1, 1.3])
    plot_root_top(motion, fig.add_subplot(gs[0, 0]))
    plot_root_side(motion, fig.add_subplot(gs[0, 1]))
    plot_joint_speed(motion, fig.add_subplot(gs[1, :]))
    if title:
        fig.suptitle(title)
    return fig
