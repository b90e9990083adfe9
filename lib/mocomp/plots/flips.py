"""Figures of the multi-flip method (flips paper Fig. 4a / dissertation Fig. 5.6, momentum curves).

* :func:`plot_momentum_comparison` -- angular momentum magnitude and vertical linear
  momentum of the original and the generated jump, aligned at take-off, flights shaded.
* :func:`filmstrip` -- the original (yellow) beside the multi-flip (turquoise), rendered
  with :func:`mocomp.plots.render3d.render_filmstrip` (PyVista, offscreen) when it is
  available, else matplotlib stick figures (:func:`stick_filmstrip`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

__all__ = ["plot_momentum_comparison", "stick_filmstrip", "filmstrip", "ORIGINAL_COLOR", "EDITED_COLOR"]

#: the paper's colours: original in yellow, generated motion in turquoise (Fig. 4a / 5.6)
ORIGINAL_COLOR = (0.93, 0.78, 0.15)
EDITED_COLOR = (0.15, 0.72, 0.75)


def plot_momentum_comparison(result, fig=None, title: str | None = None):
    """Momentum before and after (estimated masses): ``|L|``, its components along the flight's
    axis, and vertical linear momentum ``p_y``, time 0 at take-off, flights shaded."""
    import matplotlib.pyplot as plt

    from ..dynamics import momentum

    P = result.prepared
    mo = P.momentum
    mn = result.momentum if result.momentum is not None else momentum(P.body, result.motion,
                                                                         smooth_sigma=P.smooth_sigma)
    fps = P.fps
    s, e = P.flight
    a, b = result.flight
    t0 = (np.arange(P.motion.n_frames) - s) / fps
    t1 = np.arange(result.motion.n_frames) / fps - result.takeoff_seconds
    if fig is None:
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    else:
        axes = fig.subplots(2, 1, sharex=True)
    for ax in axes:
        ax.axvspan(t0[s], t0[e - 1], color=ORIGINAL_COLOR, alpha=0.15, lw=0)
        ax.axvspan(t1[a], t1[b - 1], color=EDITED_COLOR, alpha=0.12, lw=0)
    axes[0].plot(t0, np.linalg.norm(mo.angular, axis=1), color="#b8900a", label="original |L|")
    axes[0].plot(t1, np.linalg.norm(mn.angular, axis=1), color="#138f93", label=f"multi-flip |L| (k = {result.plan.k:.2f})")
    axes[0].plot(t0, mo.angular @ P.axis, color="#b8900a", ls=":", lw=1, label="original L . axis")
    axes[0].plot(t1, mn.angular @ P.axis, color="#138f93", ls=":", lw=1, label="multi-flip L . axis")
    axes[0].set_ylabel("angular momentum (kg m$^2$/s)")
    axes[0].legend(fontsize=8, loc="upper left")
    axes[1].plot(t0, mo.linear[:, 1], color="#b8900a", label="original $p_y$")
    axes[1].plot(t1, mn.linear[:, 1], color="#138f93", label="multi-flip $p_y$")
    axes[1].set_ylabel("vertical linear momentum (kg m/s)")
    axes[1].set_xlabel("time from take-off (s)")
    axes[1].legend(fontsize=8, loc="upper left")
    r = result.report
    if title is None and r is not None:
        title = (f"{r.flips or ''} flips: |L| variation {100 * r.L_std_original:.1f}% -> {100 * r.L_std_new:.1f}% "
                 f"(std/mean); p jump at take-off {r.p_jump_takeoff:+.0f} kg m/s")
    if title:
        axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def _side_axes(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Screen axes for a view along the flip axis: horizontal and up (world y)."""
    up = np.array([0.0, 1.0, 0.0])
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    h = np.cross(up, a)
    if np.linalg.norm(h) < 1e-6:          # axis vertical (twist): look along world z
        h = np.array([1.0, 0.0, 0.0])
    return h / np.linalg.norm(h), up


def stick_filmstrip(motions: Sequence, n_poses: int = 9, axis=(1.0, 0.0, 0.0), colors=None, spacing: float = 1.0,
                    labels: Sequence[str] | None = None, ax=None, path=None):
    """Matplotlib stick figures of several motions, one row each, viewed along ``axis``
    (the somersault axis), ``n_poses`` poses evenly spaced in time and spread sideways by
    ``spacing`` metres; earlier poses lighter."""
    import matplotlib.pyplot as plt

    colors = colors or [ORIGINAL_COLOR, EDITED_COLOR]
    h, up = _side_axes(np.asarray(axis, float))
    if ax is None:
        fig, ax = plt.subplots(figsize=(max(8, 1.1 * n_poses), 2.6 * len(motions)))
    else:
        fig = ax.figure
    row_gap = 2.6
    for k, m in enumerate(motions):
        ts = np.linspace(0, m.duration, n_poses)
        P = m.sample(ts).positions
        parents = m.skeleton.parents
        base = np.array([P[0, 0] @ h, 0.0])
        for i in range(n_poses):
            X = P[i] @ h - base[0] + i * spacing
            Y = P[i] @ up - k * row_gap
            c = np.asarray(colors[k % len(colors)], float)
            c = c + (1 - c) * 0.55 * (1 - i / max(n_poses - 1, 1))
            for j in range(1, len(parents)):
                ax.plot([X[parents[j]], X[j]], [Y[parents[j]], Y[j]], color=c, lw=2, solid_capstyle="round")
        ax.axhline(-k * row_gap, color="0.75", lw=0.8, zorder=0)
        if labels:
            ax.text(-0.8, -k * row_gap + 1.9, labels[k], fontsize=9)
    ax.set_aspect("equal")
    ax.axis("off")
    if path is not None:
        fig.savefig(path, dpi=110, bbox_inches="tight")
    return fig


def filmstrip(result, path=None, n_poses: int = 9, renderer: str = "auto", width: int = 1400, height: int = 520):
    """Fig. 4a / 5.6: the original single flip (yellow) and the multi-flip (turquoise).

    ``renderer``: ``"pyvista"`` (offscreen 3-D, :mod:`mocomp.plots.render3d`), ``"matplotlib"``
    (stick figures) or ``"auto"`` (PyVista if it can render here, else matplotlib). Returns
    ``(kind, image_or_figure)``; with ``path`` the PNG is written too.
    """
    orig, new = result.original, result.motion
    axis = result.prepared.axis
    if renderer in ("auto", "pyvista"):
        try:
            from .render3d import RenderStyle, fit_camera, render_filmstrip

            tile = RenderStyle(width=max(64, (width // n_poses) // 2 * 2), height=max(64, (height // 2) // 2 * 2))
            # a side view along the somersault axis (the paper's filmstrips), shared by all tiles
            pts = np.concatenate([m.sample(np.linspace(0, m.duration, n_poses)).positions.reshape(-1, 3)
                                  for m in (orig, new)])
            d = np.asarray(axis, float) * np.array([1.0, 0.0, 1.0])
            cam = fit_camera(pts, direction=d if np.linalg.norm(d) > 0.3 else (0.0, 0.0, -1.0),
                             aspect=tile.width / tile.height, margin=0.1)
            img = render_filmstrip([orig, new], n_poses=n_poses, layout="tiles",
                                   colors=[ORIGINAL_COLOR, EDITED_COLOR], style=tile, camera=cam)
            if path is not None:
                from .render3d import save_png

                save_png(img, path)
            return "pyvista", img
        except Exception as exc:               # no EGL/OSMesa here: fall back, say why
            if renderer == "pyvista":
                raise
            import warnings

            warnings.warn(f"3-D filmstrip unavailable ({type(exc).__name__}: {exc}); drawing stick figures")
    labels = ["original", f"{result.report.flips if result.report else ''} flips".strip()]
    fig = stick_filmstrip([orig, new], n_poses=n_poses, axis=axis, labels=labels, path=path)
    return "matplotlib", fig
