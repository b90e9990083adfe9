"""Figures for in-flight edits and their restoration (dissertation Figures 5.4, 5.5;
flips paper Figure 3) and quick stick-figure filmstrips (matplotlib).

- :func:`plot_momentum_errors`: per-frame direction error (rad) and magnitude error (%)
  of ``L`` over the flight, one curve per stage of a
  :class:`~mocomp.edit.RestoreResult` (``figure="5.4"``: before/after step 1;
  ``"5.5"`` or ``"3"``: before/after the non-uniform retiming; ``"all"``: every stage).
- :func:`plot_stick_filmstrip`: poses of one or more motions side by side as stick
  figures projected on a vertical plane (a light fallback for the PyVista renderer).
"""
from __future__ import annotations

import numpy as np

__all__ = ["plot_momentum_errors", "plot_stick_filmstrip", "filmstrip_figure", "STAGE_LABELS"]

STAGE_LABELS = {
    "original": "unedited original",
    "edited": "edited (before correction)",
    "direction": "after step 1 (direction, eq. 5.21)",
    "magnitude": "after step 2 (non-uniform retiming, eq. 5.22)",
    "final": "after step 3 (uniform retiming + repositioning)",
}
_STYLE = {"original": ("0.55", ":"), "edited": ("tab:red", "-"), "direction": ("tab:blue", "-"),
          "magnitude": ("tab:green", "-"), "final": ("k", "--")}
_FIGURES = {"5.4": (("edited", "direction"), ("direction",)),
            "5.5": (("direction", "magnitude"), ("magnitude",)),
            "3": (("direction", "magnitude"), ("magnitude",)),
            "all": (("original", "edited", "direction", "magnitude", "final"), ("direction", "magnitude"))}


def plot_momentum_errors(result, figure: str = "all", x: str = "phase", stages=None, title: str | None = None,
                         fig=None, log_direction: bool = True):
    """Per-frame angular-momentum errors of a :class:`~mocomp.edit.RestoreResult`.

    Parameters
    ----------
    figure: ``"5.4"`` (direction error before/after step 1, as dissertation Fig. 5.4),
        ``"5.5"`` / ``"3"`` (magnitude error before/after the non-uniform retiming, as
        Fig. 5.5 and the flips paper's Fig. 3) or ``"all"`` (both panels, every stage).
    x: ``"phase"`` (fraction of each stage's flight: the stages' flights differ in length)
        or ``"time"`` (seconds since each stage's take-off).
    stages: override the stages shown.
    log_direction: log scale for the direction error (it falls by orders of magnitude).
    """
    import matplotlib.pyplot as plt

    if figure not in _FIGURES:
        raise ValueError(f"figure must be one of {sorted(_FIGURES)}, got {figure!r}")
    if x not in ("phase", "time"):
        raise ValueError(f"x must be 'phase' or 'time', got {x!r}")
    show, panels = _FIGURES[figure]
    show = tuple(stages) if stages is not None else show
    fig = fig or plt.figure(figsize=(8, 3.2 * len(panels) + 0.4))
    axes = np.atleast_1d(fig.subplots(len(panels), 1, sharex=True))
    for ax, panel in zip(axes, panels):
        for name in show:
            e = result.stages[name]
            xs = e.phase if x == "phase" else e.times
            col, ls = _STYLE.get(name, (None, "-"))
            if panel == "direction":
                y = np.maximum(e.direction, 1e-12) if log_direction else e.direction
                ax.plot(xs, y, ls, color=col, lw=1.4, label=f"{STAGE_LABELS.get(name, name)} (max {e.max_direction:.2g})")
                ax.set_ylabel("direction error of L (rad)")
                if log_direction:
                    ax.set_yscale("log")
            else:
                ax.plot(xs, 100 * e.magnitude, ls, color=col, lw=1.4,
                        label=f"{STAGE_LABELS.get(name, name)} (max {100 * e.max_magnitude:.1f}%)")
                ax.set_ylabel("|L| error (%)")
        ax.legend(fontsize=8, loc="best")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("fraction of the flight" if x == "phase" else "time since take-off (s)")
    ref = "constant L*" if result.reference == "constant" else "the original's L(f)"
    axes[0].set_title((title + "\n" if title else "") + f"errors against {ref}; after step 3 against k L* "
                      f"(k = {result.k:.2f})", fontsize=10)
    fig.tight_layout()
    return fig


def _view_axes(motions, view):
    if view is not None:
        h = np.asarray(view, dtype=float)
        h = h - h[1] * np.array([0, 1, 0])
        return h / np.linalg.norm(h)
    # horizontal axis of largest spread of all root positions (the travel/side direction)
    pts = np.concatenate([m.root_positions[:, [0, 2]] for m in motions])
    pts = pts - pts.mean(axis=0)
    if np.allclose(pts, 0):
        return np.array([1.0, 0.0, 0.0])
    w, v = np.linalg.eigh(pts.T @ pts)
    d = v[:, -1]
    return np.array([d[0], 0.0, d[1]])


def plot_stick_filmstrip(motions, n_poses: int = 8, times=None, labels=None, colors=None, view=None,
                         spread: float = 0.0, fig=None, title: str | None = None):
    """Stick figures of one or more motions, one row per motion, poses overlaid along time.

    ``view`` is the horizontal world direction shown left-to-right (default: the main
    horizontal direction of the root paths); ``spread`` (m) pulls successive poses apart
    along it (for jumps that travel little). Each pose is drawn a little darker than the
    last; the ground (y = 0) is a grey line.
    """
    import matplotlib.pyplot as plt
    from ..core.motion import Motion

    ms = [motions] if isinstance(motions, Motion) else list(motions)
    labels = labels or [f"motion {i}" for i in range(len(ms))]
    colors = colors or ["tab:orange", "tab:cyan", "tab:purple", "tab:red", "tab:green"]
    ax_dir = _view_axes(ms, view)
    fig = fig or plt.figure(figsize=(11, 2.6 * len(ms) + 0.4))
    axes = np.atleast_1d(fig.subplots(len(ms), 1, sharex=True))
    for k, (m, ax) in enumerate(zip(ms, axes)):
        ts = np.linspace(0, m.duration, n_poses) if times is None else np.clip(np.asarray(times, float), 0,
                                                                                   m.duration)
        poses = m.sample(ts)
        P = poses.positions
        par = m.skeleton.parents
        base = np.array(plt.matplotlib.colors.to_rgb(colors[k % len(colors)]))
        for i in range(P.shape[0]):
            xy = np.column_stack([P[i] @ ax_dir + spread * i, P[i, :, 1]])
            f = 0.55 * (1 - i / max(P.shape[0] - 1, 1))
            c = base + (1 - base) * f
            for j in range(1, len(par)):
                ax.plot(xy[[par[j], j], 0], xy[[par[j], j], 1], "-", color=c, lw=1.6, solid_capstyle="round")
            ax.plot(xy[0, 0], xy[0, 1], "o", color=c, ms=2.5)
        ax.axhline(0.0, color="0.6", lw=1)
        ax.set_aspect("equal")
        ax.set_ylabel("height (m)")
        ax.set_title(labels[k], fontsize=9, loc="left")
    axes[-1].set_xlabel("horizontal position (m)")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def filmstrip_figure(motions, labels, n_poses: int = 7, renderer: str = "pyvista", tile=(180, 240),
                     title: str | None = None, view=None):
    """Rows of rendered poses (one row per motion, poses evenly spaced in time) as a matplotlib
    figure: PyVista offscreen capsule renders (:func:`mocomp.plots.render3d.render_filmstrip`,
    ``layout="tiles"``, one shared camera) or, with ``renderer="matplotlib"`` or when
    offscreen rendering is unavailable, :func:`plot_stick_filmstrip`. Motions of different
    durations are sampled at their own evenly spaced times."""
    import matplotlib.pyplot as plt

    if renderer == "pyvista":
        try:
            from .render3d import RenderStyle, render_filmstrip

            rows = []
            for m in motions:
                rows.append(render_filmstrip([m], n_poses=n_poses, layout="tiles",
                                             style=RenderStyle(width=int(tile[0]), height=int(tile[1]))))
            w = max(r.shape[1] for r in rows)
            rows = [np.pad(r, ((0, 0), (0, w - r.shape[1]), (0, 0)), constant_values=255) for r in rows]
            fig = plt.figure(figsize=(min(16, w / 100), 0.01 * sum(r.shape[0] for r in rows) + 0.6))
            axes = np.atleast_1d(fig.subplots(len(rows), 1))
            for ax, img, lab in zip(axes, rows, labels):
                ax.imshow(img)
                ax.set_axis_off()
                ax.set_title(lab, fontsize=9, loc="left")
            if title:
                fig.suptitle(title, fontsize=10)
            fig.tight_layout()
            return fig
        except Exception as exc:  # no offscreen OpenGL here: fall back to stick figures
            import warnings

            warnings.warn(f"offscreen rendering failed ({exc}); drawing stick figures instead", stacklevel=2)
    return plot_stick_filmstrip(motions, n_poses=n_poses, labels=labels, title=title, view=view)
