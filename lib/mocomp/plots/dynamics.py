"""Figures of COM, momentum and mass distributions (matplotlib)."""
from __future__ import annotations

import numpy as np

__all__ = ["plot_momentum", "plot_mass_comparison"]


def _shade(ax, times, intervals, label="airborne"):
    for k, (a, b) in enumerate(intervals or ()):
        t0 = times[a]
        t1 = times[min(b, len(times)) - 1]
        ax.axvspan(t0, t1, color="0.88", zorder=0, label=label if k == 0 else None)


def plot_momentum(result, airborne=None, title: str | None = None, fig=None):
    """Three stacked panels over time: COM (m), linear momentum p (kg m/s), angular momentum
    L about the COM with |L| (kg m^2/s); ``airborne`` half-open frame ranges are shaded."""
    import matplotlib.pyplot as plt

    fig = fig or plt.figure(figsize=(9, 7.5))
    axes = fig.subplots(3, 1, sharex=True)
    t = result.times
    for ax, data, name, unit in ((axes[0], result.com, "COM", "m"), (axes[1], result.linear, "p", "kg m/s"),
                                 (axes[2], result.angular, "L", "kg m$^2$/s")):
        _shade(ax, t, airborne)
        for k, c in enumerate("xyz"):
            ax.plot(t, data[:, k], label=f"{name}$_{c}$")
        if name == "L":
            ax.plot(t, np.linalg.norm(data, axis=1), "k--", lw=1, label="|L|")
        ax.set_ylabel(f"{name} ({unit})")
        ax.legend(loc="upper right", fontsize=8, ncol=5)
    axes[-1].set_xlabel("time (s)")
    sm = f", Gaussian sigma {result.smooth_sigma:g} frames" if result.smooth_sigma else ""
    order = getattr(result, "order", 2)
    axes[0].set_title((title + "\n" if title else "") + f"{result.total_mass:.0f} kg, {result.velocity_mode.replace('_', ' ')} "
                      f"velocities (order {order}){sm}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_mass_comparison(df, columns=None, fig=None):
    """Grouped horizontal bars of mass percentages per group (rows of ``df``, e.g. from
    :func:`mocomp.body.compare.table_c1_comparison`)."""
    import matplotlib.pyplot as plt

    columns = columns or [c for c in df.columns if c.endswith(" %")]
    fig = fig or plt.figure(figsize=(9, 0.45 * len(df) + 1.5))
    ax = fig.subplots()
    y = np.arange(len(df))
    h = 0.8 / len(columns)
    for k, c in enumerate(columns):
        ax.barh(y + (k - (len(columns) - 1) / 2) * h, df[c].to_numpy(), height=h, label=c)
    ax.set_yticks(y, df.index)
    ax.invert_yaxis()
    ax.set_xlabel("% of body mass")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
