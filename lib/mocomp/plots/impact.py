"""Figures of the impact response (dissertation ch. 4): both characters as stick figures over time
(Fig. 4.3-style filmstrips) and the waist height of Fig. 4.1."""
from __future__ import annotations

import numpy as np

__all__ = ["impact_filmstrip", "plot_waist_height", "facing_sweep_figure", "render_impact_tiles"]


def _side_view(victim, attacker):
    """Horizontal unit vector along which the two characters are spread (attacker -> victim)."""
    d = victim.root_positions[0] - attacker.root_positions[0]
    d[1] = 0.0
    n = np.linalg.norm(d)
    return d / n if n > 1e-6 else np.array([1.0, 0.0, 0.0])


def _draw(ax, motion, frame: int, axis, color, alpha=1.0, lw=2.0):
    P = motion.positions[frame]
    x = P @ axis
    y = P[:, 1]
    for j, p in enumerate(motion.skeleton.parents):
        if p >= 0:
            ax.plot([x[p], x[j]], [y[p], y[j]], color=color, lw=lw, alpha=alpha, solid_capstyle="round")


def impact_filmstrip(victim, attacker, frames: dict | None = None, n_poses: int = 8, times=None, ax_row=None,
                     title: str | None = None, fig=None):
    """One row of panels, each both characters (attacker red, victim blue) at one time, seen from the
    side of the line joining them; the panel titles give time and, where it applies, the stage
    (impact, window start, re-entry) from ``frames`` (:attr:`mocomp.impact.pipeline.ImpactResult.frames`)."""
    import matplotlib.pyplot as plt

    n = min(victim.n_frames, max(attacker.n_frames, 1))
    if times is None:
        lo = max(0, (frames or {}).get("rewind", 0) - int(0.3 * victim.fps))
        hi = min(victim.n_frames - 1, (frames or {}).get("reentry", n - 1) + int(0.8 * victim.fps))
        ks = np.unique(np.linspace(lo, hi, n_poses).round().astype(int))
    else:
        ks = np.unique((np.asarray(times) * victim.fps).round().astype(int).clip(0, victim.n_frames - 1))
    axis = _side_view(victim, attacker)
    if ax_row is None:
        fig = fig or plt.figure(figsize=(2.0 * len(ks), 2.6))
        axs = fig.subplots(1, len(ks), sharey=True)
        axs = np.atleast_1d(axs)
    else:
        axs = ax_row
    allx = np.concatenate([(victim.positions[ks] @ axis).ravel(),            # the two skeletons may differ
                           (attacker.positions[np.minimum(ks, attacker.n_frames - 1)] @ axis).ravel()])
    xmid = float(np.median(allx))
    labels = {v: k for k, v in (frames or {}).items() if k in ("impact", "window_start", "reentry")}
    for a, k in zip(axs, ks):
        _draw(a, attacker, min(k, attacker.n_frames - 1), axis, "tab:red")
        _draw(a, victim, k, axis, "tab:blue")
        a.axhline(0.0, color="0.6", lw=1)
        a.set_xlim(xmid - 1.3, xmid + 1.3)
        a.set_ylim(-0.05, 2.0)
        a.set_aspect("equal")
        a.set_xticks([])
        a.set_yticks([])
        a.set_title(f"{k / victim.fps:.2f} s" + (f"\n{labels[k]}" if k in labels else ""), fontsize=8)
    if title and ax_row is None:
        fig.suptitle(title, fontsize=9)
    return fig if ax_row is None else axs


def facing_sweep_figure(results: dict, n_poses: int = 7):
    """Fig. 4.3: one filmstrip row per facing angle (``{label: ImpactResult}``)."""
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(2.0 * n_poses, 2.4 * len(results)))
    axs = np.atleast_2d(fig.subplots(len(results), n_poses, sharey=True))
    for row, (label, r) in zip(axs, results.items()):
        impact_filmstrip(r.victim, r.attacker, r.frames, n_poses=n_poses, ax_row=row)
        row[0].set_ylabel(label, fontsize=8)
        row[0].set_yticks([])
    fig.tight_layout()
    return fig


def plot_waist_height(result, ax=None, joint: str | None = None):
    """Fig. 4.1: the waist (root) height over time of the motion capture before the impact, the naive
    simulation, the active simulation, the final blend, and the found clip after the re-entry."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 3.2))
    v = result.victim
    fps = v.fps
    j = 0 if joint is None else v.skeleton.index(joint)
    fr = result.frames
    rw, re = fr["rewind"], fr["reentry"]
    t = np.arange(v.n_frames) / fps
    y = v.positions[:, j, 1]
    ax.plot(t[:rw + 1], y[:rw + 1], color="k", lw=2, label="mocap before")
    tn = (rw + np.arange(result.naive.victim.n_frames)) / fps
    ax.plot(tn, result.naive.victim.positions[:, j, 1], color="tab:orange", ls="--", label="simulation 1 (naive)")
    ta = (rw + np.arange(result.active.victim.n_frames)) / fps
    ax.plot(ta, result.active.victim.positions[:, j, 1], color="tab:green", ls="-.", label="simulation 2 (active)")
    ax.plot(t[rw:re + 1], y[rw:re + 1], color="tab:red", lw=2, label="final blend")
    ax.plot(t[re:], y[re:], color="tab:blue", lw=2, label="mocap after (found clip)")
    tf = (rw + np.arange(result.found.n_frames)) / fps
    ax.plot(tf, result.found.positions[:, j, 1], color="tab:blue", lw=1, ls=":", label="found clip (aligned)")
    marks = [(fr["impact"], "impact"), (re, "re-entry")]
    if fr["window_start"] != re:
        marks.insert(1, (fr["window_start"], "window start"))
    for k, name in marks:
        ax.axvline(k / fps, color="0.7", lw=0.8)
        ax.text(k / fps, ax.get_ylim()[1], name, fontsize=7, rotation=90, va="top", ha="right")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{v.skeleton.names[j]} height (m)")
    ax.legend(fontsize=7, loc="best")
    return ax


def render_impact_tiles(victim, attacker, times, *, width: int = 360, height: int = 300, path=None):
    """A 3D filmstrip (:mod:`mocomp.plots.render3d`, offscreen VTK): one tile per time in ``times`` (s),
    both characters in it (attacker red, victim blue), one camera fitted to every shown pose. Both must
    be on the same skeleton (the renderer draws one character type). Returns the ``(H, W, 3)`` image."""
    from .render3d import MotionRenderer, RenderStyle, fit_camera, joint_matrices, same_skeleton, save_png

    if not same_skeleton(victim.skeleton, attacker.skeleton):
        raise ValueError("render_impact_tiles draws both characters with one skeleton; these differ "
                         "(use impact_filmstrip, the stick figures)")
    ts = np.asarray(times, dtype=float)
    poses = [(attacker.sample([min(max(t, 0.0), attacker.duration)]), victim.sample([min(max(t, 0.0), victim.duration)]))
             for t in ts]
    style = RenderStyle(width=width, height=height)
    pts = np.concatenate([p.positions[0] for pair in poses for p in pair])
    cam = fit_camera(pts, aspect=width / height, margin=0.08)
    tiles = []
    with MotionRenderer(victim.skeleton, style, cam, n_characters=2,
                        colors=[(0.85, 0.25, 0.2), (0.25, 0.45, 0.85)]) as r:
        for a, v in poses:
            r.set_pose(0, joint_matrices(a)[0])
            r.set_pose(1, joint_matrices(v)[0])
            tiles.append(r.snapshot())
    img = np.concatenate(tiles, axis=1)
    if path is not None:
        save_png(img, path)
    return img
