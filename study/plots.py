"""Figures of the perception-study analysis (matplotlib; the analysis itself never imports this)."""
from __future__ import annotations

import numpy as np

_COLOURS = {("am_abrupt", "increase"): "#d62728", ("am_abrupt", "decrease"): "#ff9896",
            ("am_smooth", "increase"): "#1f77b4", ("am_smooth", "decrease"): "#aec7e8",
            ("takeoff", "increase"): "#2ca02c", ("takeoff", "decrease"): "#98df8a"}


def _plt():
    import matplotlib.pyplot as plt

    return plt


def close(fig) -> None:
    _plt().close(fig)


def _series(df):
    p = df[df["perturbation"] != "none"]
    return sorted({(a, b) for a, b in zip(p["perturbation"], p["direction"])})


def _control(cond, group):
    c = cond[(cond["perturbation"] == "none") & (cond["group"].isin([group, "(all)"]))]
    return c.iloc[0] if len(c) else None


def plot_ratings(res, ax=None):
    """Mean % rated correct against the error level per error type (controls at 0), Wilson 95 % CIs."""
    plt = _plt()
    cond = res.conditions if hasattr(res, "conditions") else res
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7, 4.2))
    for s in _series(cond):
        d = cond[(cond["perturbation"] == s[0]) & (cond["direction"] == s[1])].sort_values("level")
        c = _control(cond, d["group"].iloc[0])
        xs = np.r_[0.0, d["level"]] if c is not None else d["level"].to_numpy()
        ys = np.r_[c["pct_rated_correct"], d["pct_rated_correct"]] if c is not None else d["pct_rated_correct"]
        lo = np.r_[c["pct_ci_low"], d["pct_ci_low"]] if c is not None else d["pct_ci_low"]
        hi = np.r_[c["pct_ci_high"], d["pct_ci_high"]] if c is not None else d["pct_ci_high"]
        col = _COLOURS.get(s)
        yerr = np.clip([ys - lo, hi - ys], 0, None)  # (a bound equal to the estimate may differ by rounding)
        ax.errorbar(xs, ys, yerr=yerr, marker="o", capsize=3, color=col, label=f"{s[0]} {s[1]}")
    ax.set_xlabel("error level (nominal)")
    ax.set_ylabel("% rated correct")
    ax.set_ylim(0, 100)
    ax.axhline(50, color="0.8", lw=0.8, zorder=0)
    ax.legend(fontsize=8)
    ax.set_title("Mean ratings (cf. flips paper Table 2)")
    return fig


def plot_dprime(res, ax=None, truth=None):
    """The headline d' per condition with its bootstrap CI (filled markers), the other estimate
    (pooled or mean of participants) as open markers; ``truth(perturbation, direction, level)``
    overlays true values."""
    plt = _plt()
    cond = res.conditions if hasattr(res, "conditions") else res
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7, 4.2))
    ser = _series(cond)
    head = str(cond["headline"].iloc[0]) if "headline" in cond.columns and len(cond) else "pooled"
    main = "dprime_mean" if head == "mean" else "dprime"
    other = "dprime" if head == "mean" else "dprime_mean"
    names = {"dprime_mean": "mean of participants' d'", "dprime": "pooled d'"}
    for j, s in enumerate(ser):
        d = cond[(cond["perturbation"] == s[0]) & (cond["direction"] == s[1])].sort_values("level")
        off = (j - (len(ser) - 1) / 2) * 0.4
        col = _COLOURS.get(s)
        yerr = np.clip([d[main] - d[main + "_ci_low"], d[main + "_ci_high"] - d[main]], 0, None)
        ax.errorbar(d["level"] + off, d[main], yerr=yerr,
                    marker="o", capsize=3, color=col, label=f"{s[0]} {s[1]}")
        if other in d.columns:
            ax.plot(d["level"] + off, d[other], ls="none", marker="o", mfc="none", color=col, alpha=0.7,
                    label=f"({names[other]})" if j == 0 else None)
        if truth is not None:
            xs = np.linspace(0, d["level"].max() * 1.05, 100)
            ax.plot(xs, truth(s[0], s[1], xs), color=col, ls=":", lw=1)
    p = cond[cond["perturbation"] != "none"]
    col_ceil = "dprime_mean_ceiling" if head == "mean" and "dprime_mean_ceiling" in p.columns else "ceiling"
    if len(p) and np.isfinite(p[col_ceil]).any():
        what = "mean of participants' ceilings" if col_ceil != "ceiling" else "ceiling"
        ax.axhline(p[col_ceil].min(), color="0.5", ls="--", lw=0.8, label=f"{what} ({p['correction'].iloc[0]})")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("error level (nominal)")
    ax.set_ylabel("d'")
    ax.legend(fontsize=8)
    ax.set_title(f"Sensitivity: {names[main]} (participant bootstrap 95% CI)")
    return fig


def plot_psychometric(res, axes=None):
    """Psychometric GLM fits (P rated correct vs level) with 95 % bands, one panel per error type."""
    from .analysis import psychometric_curve

    plt = _plt()
    psy = res.psychometric
    cond = res.conditions
    n = max(len(psy), 1)
    cols = min(n, 3)
    rows = int(np.ceil(n / cols))
    if axes is None:
        fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.2 * rows), squeeze=False)
    else:
        fig = np.ravel(axes)[0].figure
    axes = np.ravel(axes)
    for ax, (_, r) in zip(axes, psy.iterrows()):
        s = (r["perturbation"], r["direction"])
        d = cond[(cond["perturbation"] == s[0]) & (cond["direction"] == s[1])]
        c = _control(cond, r["group"])
        xmax = d["level"].max() * 1.1
        xs = np.linspace(0, xmax, 200)
        mid, lo, hi = psychometric_curve(r, xs)
        col = _COLOURS.get(s, "k")
        ax.fill_between(xs, 100 * lo, 100 * hi, color=col, alpha=0.2, lw=0)
        ax.plot(xs, 100 * mid, color=col)
        ax.plot(d["level"], d["pct_rated_correct"], "o", color=col)
        if c is not None:
            ax.plot([0], [c["pct_rated_correct"]], "s", color="k")
        if np.isfinite(r["threshold"]) and r["threshold"] < xmax:
            ax.axvline(r["threshold"], color=col, ls=":", lw=1)
        ax.set_title(f"{s[0]} {s[1]}  ({r['link']})", fontsize=9)
        ax.set_ylim(0, 100)
        ax.set_xlabel("level")
        ax.set_ylabel("% rated correct")
    for ax in axes[len(psy):]:
        ax.set_visible(False)
    fig.tight_layout()
    return fig


def plot_participants(res, ax=None):
    """Per-participant d' (error types pooled over levels) with bootstrap 95 % CIs."""
    plt = _plt()
    ps = res.participants_series
    parts = sorted(ps["participant_id"].unique())
    ser = sorted({(a, b) for a, b in zip(ps["perturbation"], ps["direction"])})
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7, 0.25 * len(parts) * len(ser) ** 0.5 + 2))
    for j, s in enumerate(ser):
        d = ps[(ps["perturbation"] == s[0]) & (ps["direction"] == s[1])].set_index("participant_id").reindex(parts)
        y = np.arange(len(parts)) + (j - (len(ser) - 1) / 2) * 0.12
        ax.errorbar(d["dprime"], y, xerr=[d["dprime"] - d["ci_low"], d["ci_high"] - d["dprime"]], fmt="o",
                    ms=3, capsize=2, color=_COLOURS.get(s), label=f"{s[0]} {s[1]}", lw=0.8)
    ax.set_yticks(np.arange(len(parts)), parts, fontsize=7)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlabel("d' (levels pooled)")
    ax.legend(fontsize=7, loc="best")
    ax.set_title("Per-participant sensitivity")
    return fig
