"""Figures of physical touch-up (:mod:`mocomp.touchup`): the ZMP's distance outside the support
polygon per frame before and after (the paper's Fig. 8) with the stages shaded, and the mean
distance per iteration (Fig. 9)."""
from __future__ import annotations

import numpy as np

__all__ = ["plot_zmp_distance"]


def plot_zmp_distance(result, path=None, title: str | None = None):
    """Two panels: per frame the signed ZMP distance to the support polygon (cm; positive outside)
    of the input and the touched-up motion, flight frames shaded and clamped frames marked; and the
    mean distance outside after each iteration. Saves to ``path`` when given; returns the figure."""
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..touchup.stages import runs

    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9, 6.5), gridspec_kw={"height_ratios": [2, 1]})
    T = result.stages.n_frames
    t = np.arange(T) / result.input.fps
    for a, b in runs(~result.stages.ground):
        ax.axvspan(t[a], t[min(b, T - 1)], color="0.85", lw=0, label="flight" if a == runs(~result.stages.ground)[0][0]
                   else None)
    ax.axhline(0, color="0.3", lw=0.8)
    ax.plot(t, result.distance_before * 100, color="tab:red", lw=1.2, label="input")
    ax.plot(t, result.distance_after * 100, color="tab:blue", lw=1.2, label="touched up")
    cl = sorted({f for v in result.clamped.values() for f in v})
    if cl:
        ax.plot(t[cl], np.nan_to_num(result.distance_after[cl]) * 100, "x", color="k", ms=4,
                label="clamped (eq. 7)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("ZMP outside support polygon (cm)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title or "ZMP distance to the support polygon (positive: outside)")
    means = [result.before["mean_outside_m"]] + [h["mean_outside_m"] for h in result.history]
    ax2.plot(np.arange(len(means)), np.asarray(means) * 100, "o-", color="tab:blue")
    ax2.set_xticks(np.arange(len(means)))
    ax2.set_xticklabels(["in"] + [f"{h['step'] + 1}.{h['iteration'] + 1}" for h in result.history], fontsize=7)
    ax2.set_xlabel("step.iteration")
    ax2.set_ylabel("mean outside (cm)")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
