"""Plots for banded DTW and hand/body splicing (dissertation Figures 6.3-6.5).

* :func:`plot_band`: local cost inside the band, the band's outline, the
  optimal path, user matching points and (optionally) the true alignment
  (Figure 6.3 a/b).
* :func:`plot_alignment`: both passes of the two-stage alignment and the
  final frame map against the truth; :func:`plot_alignments` stacks several
  (both arms) in one figure.
* :func:`plot_metric_comparison`: sign metric vs. value metric (Figure 6.4).
* :func:`plot_phases`: Table 6.1 phase labels over the hand marker's speed.

Axes: the body (first) sequence runs along x, the hand (second) along y, so a
path reads as "hand frame shown at each body frame".
"""
from __future__ import annotations

import numpy as np

__all__ = ["plot_band", "plot_alignment", "plot_alignments", "plot_metric_comparison", "plot_phases", "PHASE_COLORS",
           "QUALITY_COLORS"]

PHASE_COLORS = {"S": "#d62728", "H": "#7f7f7f", "P": "#2ca02c", "R": "#1f77b4"}


def _ax(ax, figsize=(5, 5)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_band(result, ax=None, *, cost: bool = True, truth=None, title: str | None = None, cmap: str = "viridis",
              path_color: str = "white", xlabel: str = "body frame", ylabel: str = "hand frame", colorbar: bool = False,
              tube=None, frame_map=None):
    """Figure 6.3: the band's local costs (darker = lower), its outline (as
    defined by eq. 6.3-6.5, before pruning), the optimal path and the
    matching points (squares; tolerance as a vertical bar). ``truth (n,)``
    adds the true map as a dashed line; ``tube = (lo, hi)`` shades the
    near-optimal tube and ``frame_map (n,)`` draws the frame map taken through
    it (:mod:`~mocomp.splice.warpmap`). ``result`` is a
    :class:`~mocomp.splice.dtw.DTWResult`."""
    ax = _ax(ax)
    band = result.band
    n, m = band.n, band.m
    if cost:
        dense = band.to_dense(result.local_cost).T  # (m, n): y = hand frame
        lo_c, hi_c = np.nanpercentile(dense, [1, 98])  # robust colour range: a few huge costs must not flatten it
        im = ax.imshow(dense, origin="lower", aspect="auto", cmap=cmap, interpolation="nearest",
                       extent=(-0.5, n - 0.5, -0.5, m - 0.5), vmin=lo_c, vmax=max(hi_c, lo_c + 1e-12))
        ax.set_facecolor("#eeeeee")
        if colorbar:
            ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="local cost")
    i = np.arange(n)
    ax.plot(i, band.raw_lo - 0.5, color="orange", lw=1, label="band")
    ax.plot(i, band.raw_hi + 0.5, color="orange", lw=1)
    if tube is not None:
        ax.fill_between(i, np.asarray(tube[0]) - 0.5, np.asarray(tube[1]) + 0.5, color="white", alpha=0.35, lw=0,
                        label="near-optimal tube")
    ax.plot(result.path[:, 0], result.path[:, 1], color=path_color, lw=1.5, label="optimal path")
    if frame_map is not None:
        ax.plot(i, np.asarray(frame_map), color="red", lw=1.2, label="frame map")
    if truth is not None:
        ax.plot(i, np.asarray(truth), "--", color="magenta", lw=1.2, label="truth")
    for p in band.points:
        ax.plot([p.x], [p.y], "s", mfc="none", mec="red", ms=7, mew=1.5)
        if p.tol:
            ax.plot([p.x, p.x], [p.y - p.tol, p.y + p.tol], color="red", lw=2)
    if band.points:
        ax.plot([], [], "s", mfc="none", mec="red", label="matching points")
    ax.set_xlim(-0.5, n - 0.5)
    ax.set_ylim(-0.5, m - 0.5)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.legend(loc="upper left", fontsize=7, framealpha=0.7)
    return ax


QUALITY_COLORS = {"frozen": "#d62728", "reversed": "#9467bd", "slope": "#ff7f0e", "residual": "#8c564b"}


def _shade_quality(ax, quality, offset: int = 0):
    """Problem stretches of a :class:`~mocomp.splice.quality.SpliceQuality` as
    coloured spans (x in body-clip frames minus ``offset``), and its suggested
    matching points as green diamonds with their tolerance."""
    kinds = set()
    for st in quality.stretches:
        ax.axvspan(st.start - offset - 0.5, st.stop - offset - 0.5, color=QUALITY_COLORS[st.kind], alpha=0.18, lw=0)
        kinds.add(st.kind)
    for k in sorted(kinds):
        ax.fill_between([], [], color=QUALITY_COLORS[k], alpha=0.3, label=f"{k} ({sum(s.frames for s in quality.of_kind(k))} fr)")
    sug = quality.suggestion
    if sug is not None:
        for p in sug.new_points:
            ax.errorbar([p.x - offset], [p.y], yerr=[p.tol], fmt="D", color="green", mfc="none", ms=7, capsize=3)
        ax.plot([], [], "D", color="green", mfc="none",
                label=f"suggested points (frozen {sug.frozen_before} -> {sug.frozen_after})")


def plot_alignment(alignment, truth=None, fig=None, title: str | None = None, quality=None):
    """Three panels: pass 1 (sign metric, eq. 6.6) band and path, pass 2
    (hand angle, eq. 6.9) band and path on the warped hand (each with its
    near-optimal tube and frame map when the taut map was used), and the final
    frame map (with the truth and its error if given). ``quality`` (a
    :class:`~mocomp.splice.quality.SpliceQuality`) shades the problem
    stretches on the frame map and marks the suggested matching points. In
    subsequence mode (``alignment.interval``) the frame map is drawn in body-clip
    frames with the matched interval marked, the band panels within the
    interval. ``fig`` may be a figure or a :class:`matplotlib.figure.SubFigure`
    (several alignments in one file: :func:`plot_alignments`); a subfigure is
    left to its parent's layout."""
    import matplotlib.pyplot as plt

    if fig is None:
        fig = plt.figure(figsize=(15, 4.6))
    axs = fig.subplots(1, 3)
    metric = "eq. 6.6 sign metric" if alignment.config.metric == "sign" else "derivative values"
    tubes = getattr(alignment, "tubes", {}) or {}
    off = getattr(alignment, "offset", 0)
    kind = getattr(alignment.config, "band_width_kind", "half")
    xl = "body frame" if not off else f"body frame - {off} (matched interval)"
    plot_band(alignment.pass1, axs[0], truth=None if truth is None else np.asarray(truth)[off:off + alignment.n],
              title=f"pass 1: {metric}, W = {alignment.config.phase_width:.0%} n ({kind})",
              tube=tubes.get("pass1"), frame_map=alignment.stage1_map, xlabel=xl)
    if alignment.pass2 is not None:
        plot_band(alignment.pass2, axs[1], ylabel="warped hand frame", xlabel=xl,
                  title=f"pass 2: eq. 6.9 hand angle, W = {alignment.config.refine_width:.0%} n ({kind})",
                  tube=tubes.get("pass2"), frame_map=alignment.stage2_map)
    else:
        axs[1].set_axis_off()
    ax = axs[2]
    i = np.arange(alignment.n) + off
    ax.plot(i, alignment.stage1_map, color="C1", lw=1, label="after pass 1")
    ax.plot(i, alignment.hand_frame, color="C0", lw=1.5, label="final")
    if truth is not None:
        truth = np.asarray(truth)
        tr = truth[off:off + alignment.n] if truth.shape[0] != alignment.n else truth
        ax.plot(np.arange(truth.shape[0]) if truth.shape[0] != alignment.n else i, truth, "--", color="magenta", lw=1.2,
                label="truth")
        ok = np.isfinite(tr)  # subsequence ground truth is NaN outside the true interval
        from ..splice.align import alignment_error

        e = alignment_error(alignment.hand_frame[ok], tr[ok])
        ax2 = ax.twinx()
        ax2.fill_between(i, 0, np.abs(alignment.hand_frame - tr), color="C3", alpha=0.25, lw=0)
        ax2.set_ylabel("|error| (frames)", color="C3")
        ax2.set_ylim(0, max(10.0, 4 * e["mean"]))
        ax.set_title(f"frame map: mean |error| {e['mean']:.2f} frames")
    else:
        ax.set_title("frame map" + ("" if quality is None else
                                    (": no problems found" if quality.ok else f": {len(quality.stretches)} problem stretch(es)")))
    if alignment.interval is not None:
        for x in alignment.interval:
            ax.axvline(x, color="k", ls=":", lw=1)
        ax.plot([], [], ":", color="k", label=f"matched interval {alignment.interval[0]}-{alignment.interval[1]}")
    if quality is not None:
        _shade_quality(ax, quality)
    for p in alignment.points:
        ax.plot([p.x], [p.y], "s", mfc="none", mec="red")
    ax.set_xlabel("body frame")
    ax.set_ylabel("hand frame")
    ax.legend(loc="upper left", fontsize=7)
    if title:
        fig.suptitle(title)
    if hasattr(fig, "tight_layout"):
        fig.tight_layout()
    return fig


def plot_alignments(alignments: dict, truth=None, title: str | None = None, quality: dict | None = None):
    """:func:`plot_alignment` for several alignments (e.g. ``{"right": ..., "left": ...}``
    of a ``side="both"`` splice) stacked in one figure, one row of three panels
    each, titled ``"<title> (<key> arm)"``; ``quality`` per key as in :func:`plot_alignment`."""
    import matplotlib.pyplot as plt

    if not alignments:
        raise ValueError("no alignments to plot")
    k = len(alignments)
    fig = plt.figure(figsize=(15, 4.6 * k), layout="constrained")
    subs = np.atleast_1d(fig.subfigures(k, 1))
    for sub, (key, al) in zip(subs, alignments.items()):
        t = f"{title} ({key} arm)" if title else f"{key} arm"
        plot_alignment(al, truth=truth, fig=sub, title=t, quality=(quality or {}).get(key))
    return fig


def plot_metric_comparison(sign_alignment, value_alignment, truth, body_markers=None, hand_markers=None, fig=None):
    """Figure 6.4: amplitude-different trajectories (left), the first-pass
    alignment with the sign metric (centre) and with the derivative values
    (right), each with the truth; the title of each panel gives the mean
    frame error of the first pass."""
    import matplotlib.pyplot as plt

    if fig is None:
        fig = plt.figure(figsize=(15, 4.6))
    axs = fig.subplots(1, 3)
    ax = axs[0]
    if body_markers is not None and hand_markers is not None:
        yb = body_markers.relative[:, 3, 1]
        yh = hand_markers.relative[:, 3, 1]
        ax.plot(np.arange(len(yb)), yb, label="body recording", color="C0")
        ax.plot(np.arange(len(yb)), np.interp(np.asarray(truth), np.arange(len(yh)), yh), "--", color="C1", lw=1,
                label="hand recording, warped by the truth")
        ax.set_xlabel("body frame")
        ax.set_ylabel("hand marker height above shoulder (m)")
        ax.set_title("same gesture, different amplitude and timing")
        ax.legend(fontsize=7)
    else:
        ax.set_axis_off()
    truth = np.asarray(truth)
    for ax, al, name in ((axs[1], sign_alignment, "signs of derivatives (eq. 6.6)"),
                         (axs[2], value_alignment, "values of derivatives")):
        err = np.abs(al.stage1_map - truth).mean()
        plot_band(al.pass1, ax, truth=truth, title=f"{name}: pass-1 error {err:.2f} frames")
    fig.tight_layout()
    return fig


def plot_phases(phases, ax=None, title: str | None = None):
    """Table 6.1 phases as coloured spans behind the hand marker's speed."""
    ax = _ax(ax, figsize=(10, 2.5))
    t = np.arange(len(phases.labels)) / phases.fps
    for p in phases.phases:
        ax.axvspan(p.start / phases.fps, p.stop / phases.fps, color=PHASE_COLORS[p.label], alpha=0.25, lw=0)
    ax.plot(t, phases.speed, color="k", lw=1)
    ax.axhline(phases.thresholds["hold_speed"], color="k", ls=":", lw=0.8)
    for lab, col in PHASE_COLORS.items():
        ax.fill_between([], [], color=col, alpha=0.25, label={"S": "stroke", "H": "hold", "P": "preparation", "R": "retraction"}[lab])
    ax.set_xlabel("time (s)")
    ax.set_ylabel("hand speed (m/s)")
    ax.set_xlim(t[0], t[-1])
    ax.legend(loc="upper right", fontsize=7, ncol=4)
    if title:
        ax.set_title(title)
    return ax
