"""Figure of a physics audit (:class:`mocomp.audit.AuditReport`), matplotlib."""
from __future__ import annotations

import numpy as np

from ..audit.thresholds import G_STANDARD

__all__ = ["plot_audit"]


def _shade(ax, t, intervals, color="0.9", label=None):
    for k, (a, b) in enumerate(intervals):
        ax.axvspan(t[a], t[min(b, len(t)) - 1], color=color, zorder=0, label=label if k == 0 else None)


def plot_audit(report, against=None, fig=None):
    """Four stacked panels over time, flights shaded:

    1. COM height with each flight's ballistic fit (dashed) and the best g = 9.81 parabola (dotted);
    2. COM velocity (x, y, z) with the velocity-jump findings marked;
    3. the lowest body point above the floor, with the penetration findings and the threshold;
    4. the ZMP's signed distance to the support polygon (positive outside) with its threshold.

    ``against``: the original's report; its COM height and lowest point are drawn in grey.
    """
    import matplotlib.pyplot as plt

    fig = fig or plt.figure(figsize=(10, 9.5))
    ax = fig.subplots(4, 1, sharex=True)
    t = report.times
    fl = report.phases.flights
    th = report.thresholds
    floor = report.penetration.floor_y
    com = report.com.com
    for a in ax:
        _shade(a, t, fl, label="flight")
    # 1: COM height and fits
    if against is not None and len(against.times):
        ax[0].plot(against.times, against.com.com[:, 1] - against.penetration.floor_y, color="0.6", lw=1,
                   label="original COM")
    ax[0].plot(t, com[:, 1] - floor, color="C0", label="COM height")
    for f in report.flights:
        if f.fit is None:
            continue
        a, b = f.frames
        tt = np.linspace(t[a], t[b - 1], 50)
        tau = tt - f.fit.t_mid
        c2, c1, c0 = f.fit.coef
        ax[0].plot(tt, c2 * tau ** 2 + c1 * tau + c0 - floor, "k--", lw=1,
                   label="ballistic fit" if f.index == report.flights[0].index else None)
        ts, ys = t[a:b] - f.fit.t_mid, com[a:b, 1] + 0.5 * G_STANDARD * (t[a:b] - f.fit.t_mid) ** 2
        s1, s0 = np.polyfit(ts, ys, 1)
        ax[0].plot(tt, -0.5 * G_STANDARD * tau ** 2 + s1 * tau + s0 - floor, "k:", lw=1,
                   label="best g = 9.81 parabola" if f.index == report.flights[0].index else None)
        ax[0].annotate(f"g={f.fit.g:.2f}", (tt[len(tt) // 2], c0 - floor), textcoords="offset points",
                       xytext=(0, -14), ha="center", fontsize=8)
    ax[0].set_ylabel("COM above floor (m)")
    ax[0].legend(loc="upper right", fontsize=8)
    # 2: velocity and jumps
    vel = np.gradient(com, t, axis=0) if len(t) > 1 else np.zeros_like(com)
    for k, c in enumerate("xyz"):
        ax[1].plot(t, vel[:, k], lw=1, label=f"v$_{c}$")
    jumps = report.by_check("com_velocity_jump")
    for k, f in enumerate(jumps):
        ax[1].axvline(t[f.peak_frame], color="red", lw=1.2, alpha=0.8, label="velocity jump" if k == 0 else None)
        ax[1].annotate(f"{f.size:.2f}", (t[f.peak_frame], 0), textcoords="offset points", xytext=(3, 3),
                       color="red", fontsize=8)
    ax[1].set_ylabel("COM velocity (m/s)")
    ax[1].legend(loc="upper right", fontsize=8, ncol=4)
    # 3: lowest point and penetration
    if against is not None and len(against.times):
        ax[2].plot(against.times, against.penetration.lowest - against.penetration.floor_y, color="0.6", lw=1,
                   label="original")
    ax[2].plot(t, report.penetration.lowest - floor, color="C2", label="lowest body point")
    ax[2].axhline(0.0, color="k", lw=0.8)
    ax[2].axhline(-th.penetration, color="red", ls=":", lw=1, label=f"-{th.penetration * 100:g} cm")
    for k, f in enumerate(report.by_check("floor_penetration")):
        a, b = f.frames
        ax[2].axvspan(t[a], t[b - 1] if b - 1 > a else t[a] + 0.5 / report.fps, color="red", alpha=0.25,
                      label="penetration" if k == 0 else None)
    ax[2].set_ylabel("height above floor (m)")
    ax[2].legend(loc="upper right", fontsize=8, ncol=4)
    # 4: ZMP distance
    d = report.zmp.distance
    ax[3].plot(t, d, color="C4", lw=1, label="ZMP distance (+ outside)")
    ax[3].axhline(th.zmp_outside, color="red", ls=":", lw=1, label=f"{th.zmp_outside * 100:g} cm")
    ax[3].axhline(0.0, color="k", lw=0.8)
    finite = d[np.isfinite(d)]
    if finite.size:
        hi = float(np.percentile(finite, 99))
        ax[3].set_ylim(min(-0.2, float(finite.min())), max(0.3, min(hi, 1.0)))
    ax[3].set_ylabel("ZMP outside (m)")
    ax[3].set_xlabel("time (s)")
    ax[3].legend(loc="upper right", fontsize=8)
    nv = len(report.violations)
    ax[0].set_title(f"audit of {report.name}: {report.verdict.upper()} ({nv} violation(s), "
                    f"{len(report.advisories)} advisory)", fontsize=10)
    fig.tight_layout()
    return fig
