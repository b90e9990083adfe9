"""Figures of the editing primitives (:mod:`mocomp.ops`): ground paths seen from above with the
foot plants, and the audit's foot-slide / penetration numbers before and after an edit."""
from __future__ import annotations

import numpy as np

__all__ = ["plot_ground_paths", "plot_slide_bars", "evidence_table"]

COLORS = ("tab:orange", "tab:cyan", "tab:purple", "tab:green", "tab:red")


def plot_ground_paths(motions, labels, plants=None, reference=None, ax=None, title: str | None = None):
    """Top view (x right, z up the page) of each motion's root track, with its planted ankle points
    (dots, from ``plants``: a list of :class:`~mocomp.ops.plants.FootPlants` or ``None`` entries, or
    the contact detector when ``plants`` is ``None``) and an optional ``reference`` ``(n, 2)`` path
    (a curve's points, drawn dashed)."""
    import matplotlib.pyplot as plt

    from ..ops.footplant import foot_points
    from ..ops.plants import foot_plants

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 6))
    if reference is not None:
        r = np.asarray(reference, dtype=float)
        ax.plot(r[:, 0], r[:, 1], "--", color="0.4", lw=1.2, label="target path")
    for i, (m, lab) in enumerate(zip(motions, labels)):
        c = COLORS[i % len(COLORS)]
        ax.plot(m.root_positions[:, 0], m.root_positions[:, 2], "-", color=c, lw=1.6, label=lab)
        pl = plants[i] if plants is not None else foot_plants(m, require=False)
        if pl is None:
            continue
        P, G = m.fk()
        pts = foot_points(P, G, pl)
        for k in (0, 2):
            on = pl.labels[:, k]
            ax.plot(pts[on, k, 0], pts[on, k, 2], ".", ms=2.5, color=c, alpha=0.6)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.legend(fontsize=8, loc="best")
    if title:
        ax.set_title(title, fontsize=10)
    return ax.figure


def evidence_table(reports: dict):
    """A pandas DataFrame, one row per named :class:`~mocomp.audit.AuditReport`, of the numbers
    :func:`mocomp.ops.evidence.audit_numbers` takes from it (foot slide in cm, penetration in cm,
    joint and root speeds, verdict)."""
    import pandas as pd

    from ..ops.evidence import audit_numbers

    rows = []
    for name, rep in reports.items():
        d = audit_numbers(rep)
        rows.append({"motion": name, "foot slide max (cm)": 100 * d["foot_slide_max_m"],
                     "foot slide mean (cm)": 100 * d["foot_slide_mean_m"], "foot contacts": d["foot_contacts"],
                     "penetration max (cm)": 100 * d["penetration_max_m"],
                     "joint rate max (rad/s)": d["joint_speed_max_rad_s"], "root speed max (m/s)": d["root_speed_max_m_s"],
                     "verdict": d["verdict"]})
    return pd.DataFrame(rows).set_index("motion")


def plot_slide_bars(reports: dict, ax=None, title: str | None = None):
    """Bars of the largest foot slide and floor penetration (cm) per named audit report, with the
    1 cm footplant goal and the audit's limits as lines."""
    import matplotlib.pyplot as plt

    from ..ops.evidence import audit_numbers

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 3.2))
    names = list(reports)
    d = [audit_numbers(reports[n]) for n in names]
    x = np.arange(len(names))
    ax.bar(x - 0.2, [100 * v["foot_slide_max_m"] for v in d], 0.4, label="largest foot slide", color="tab:orange")
    ax.bar(x + 0.2, [100 * v["penetration_max_m"] for v in d], 0.4, label="deepest penetration", color="tab:cyan")
    ax.axhline(1.0, color="0.3", lw=1, ls="--", label="1 cm goal")
    ax.set_xticks(x)
    ax.set_xticklabels(names, fontsize=8, rotation=15)
    ax.set_ylabel("cm")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return ax.figure
