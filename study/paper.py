"""The published results of the flips paper's perception study (Table 2).

Majkowska & Faloutsos, "Flipping with physics", SCA 2007, section 7, Table 2
(= dissertation Table 5.2): mean ratings (percent of presentations rated
*correct*) and, in parentheses, "sensitivity levels" (d').

How the paper computed d' from the mean ratings (derived here, pinned in
``tests/test_study_table2.py``): with the hit rate H = P("incorrect" |
perturbed) and the false-alarm rate F = P("incorrect" | unperturbed motion of
the same group), d' = z(H) - z(F) = z(r0) - z(r), where r is the condition's
mean rating and r0 the 0 % rating of its group (72 % for angular momentum, 63 %
for take-off), z the inverse standard-normal CDF, and no correction (no rate
is 0 or 1). Every published value is reproduced within the rounding of the
published ratings (whole percent) and of the published d' (two decimals, or
one for 1.0, 1.4, 1.3); e.g. 72 vs 41 gives 0.811 (published .81) and 72 vs 22
gives 1.355 (published 1.4).

One cell is missing from the "smooth increase" row of the extracted table
(four values for five columns). The text fixes the 25 % cell ("for both
smooth and abrupt changes, a 25 % increase ... was as likely to be classified
physically valid as the original motion": the 72 / .00 entry), which puts 71
at 17 %; the text also says smooth errors "ranged from -50 % to 50 %", so the
last value (41) is placed at 50 % and the 37 % cell is taken as not reported.
This placement does not affect any d' value.
"""
from __future__ import annotations

import pandas as pd

#: Table 2 as tidy rows: (group, perturbation, direction, level %, mean rating %, published d', d' decimals).
_ROWS = [
    # angular momentum, smooth increase (37 % not reported, see module docstring)
    ("angular_momentum", "am_smooth", "increase", 17, 71, 0.05, 2),
    ("angular_momentum", "am_smooth", "increase", 25, 72, 0.00, 2),
    ("angular_momentum", "am_smooth", "increase", 50, 41, 0.81, 2),
    ("angular_momentum", "am_smooth", "decrease", 17, 79, -0.22, 2),
    ("angular_momentum", "am_smooth", "decrease", 25, 78, -0.18, 2),
    ("angular_momentum", "am_smooth", "decrease", 37, 78, -0.18, 2),
    ("angular_momentum", "am_smooth", "decrease", 50, 62, 0.27, 2),
    ("angular_momentum", "am_abrupt", "increase", 17, 76, -0.13, 2),
    ("angular_momentum", "am_abrupt", "increase", 25, 78, -0.18, 2),
    ("angular_momentum", "am_abrupt", "increase", 37, 48, 0.63, 2),
    ("angular_momentum", "am_abrupt", "increase", 50, 44, 0.75, 2),
    ("angular_momentum", "am_abrupt", "decrease", 17, 83, -0.38, 2),
    ("angular_momentum", "am_abrupt", "decrease", 25, 68, 0.11, 2),
    ("angular_momentum", "am_abrupt", "decrease", 37, 33, 1.0, 1),
    ("angular_momentum", "am_abrupt", "decrease", 50, 22, 1.4, 1),
    ("takeoff", "takeoff", "increase", 10, 81, -0.53, 2),
    ("takeoff", "takeoff", "increase", 20, 50, 0.34, 2),
    ("takeoff", "takeoff", "increase", 30, 63, 0.00, 2),
    ("takeoff", "takeoff", "increase", 40, 18, 1.3, 1),
]
#: The 0 % (unperturbed) mean rating of each group, percent rated correct.
TABLE2_CONTROL_RATING = {"angular_momentum": 72, "takeoff": 63}
#: Participants in the study (section 7): 19 student volunteers.
N_PARTICIPANTS = 19
#: Each motion was shown twice.
N_SHOWINGS = 2


def table2() -> pd.DataFrame:
    """Table 2 as a tidy frame.

    Columns: group, perturbation, direction, level (percent), rating (percent
    rated correct), control_rating (the group's 0 % rating), dprime_published,
    decimals (how many the paper printed).
    """
    df = pd.DataFrame(_ROWS, columns=["group", "perturbation", "direction", "level", "rating",
                                      "dprime_published", "decimals"])
    df.insert(5, "control_rating", df["group"].map(TABLE2_CONTROL_RATING))
    return df


def reproduce_table2(dprime=None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Recompute Table 2's d' from its mean ratings and check them against the published values.

    ``dprime(control_rating, rating)`` (percent) defaults to
    :func:`study.sdt.dprime_from_ratings`, the paper's z(r0) - z(r). Because
    the paper prints ratings in whole percent and d' with 2 (or 1) decimals,
    a cell is *consistent* when some unrounded ratings within +-0.5 % of the
    printed ones give a d' that rounds to the printed d'. For a formula that is
    monotone increasing in r0 and decreasing in r (as z(r0) - z(r) is), the set
    of unrounded control ratings that make a cell consistent is an interval;
    the second frame gives, per group, the intersection over its cells: the
    range of one unrounded 0 % rating that reproduces every d' of the group.

    Returns (cells, groups): ``cells`` = :func:`table2` plus ``dprime_ours``
    (from the printed ratings), ``deviation`` (ours - published),
    ``control_lo``/``control_hi`` (the consistent unrounded control ratings, %)
    and ``consistent``; ``groups`` = group, control_rating, control_lo,
    control_hi, consistent.
    """
    import numpy as np
    from scipy.optimize import brentq

    from .sdt import dprime_from_ratings

    f = dprime_from_ratings if dprime is None else dprime
    cells = table2()
    cells["dprime_ours"] = [float(f(r0, r)) for r0, r in zip(cells["control_rating"], cells["rating"])]
    cells["deviation"] = cells["dprime_ours"] - cells["dprime_published"]
    los, his = [], []
    for _, c in cells.iterrows():
        half = 0.5 * 10.0 ** (-int(c["decimals"]))
        b_lo, b_hi = c["control_rating"] - 0.5, c["control_rating"] + 0.5
        # largest attainable d' for a control rating b uses the lowest rating, the smallest uses the highest
        dmax = lambda b: float(f(b, c["rating"] - 0.5))  # noqa: E731
        dmin = lambda b: float(f(b, c["rating"] + 0.5))  # noqa: E731
        target_lo, target_hi = c["dprime_published"] - half, c["dprime_published"] + half
        # need dmax(b) >= target_lo and dmin(b) <= target_hi; both increase with b
        if dmax(b_hi) < target_lo or dmin(b_lo) > target_hi:
            los.append(np.nan)
            his.append(np.nan)
            continue
        lo = b_lo if dmax(b_lo) >= target_lo else brentq(lambda b: dmax(b) - target_lo, b_lo, b_hi, xtol=1e-10)
        hi = b_hi if dmin(b_hi) <= target_hi else brentq(lambda b: dmin(b) - target_hi, b_lo, b_hi, xtol=1e-10)
        los.append(lo)
        his.append(hi)
    cells["control_lo"] = los
    cells["control_hi"] = his
    cells["consistent"] = cells["control_lo"].notna() & (cells["control_lo"] <= cells["control_hi"])
    groups = []
    for g, d in cells.groupby("group", sort=False):
        lo, hi = d["control_lo"].max(), d["control_hi"].min()
        groups.append(dict(group=g, control_rating=TABLE2_CONTROL_RATING[g], control_lo=lo, control_hi=hi,
                           consistent=bool(d["consistent"].all() and lo <= hi)))
    return cells, pd.DataFrame(groups)


def write_table2_responses(root, n_parts: int = 20, per_part: int = 5) -> list:
    """Write responses CSVs whose pooled counts give exactly Table 2's mean ratings.

    Every condition of :func:`table2`, and each group's unperturbed motions, is
    shown ``n_parts x per_part`` times (default 100, so a rating of r % is r
    "correct" answers), the answers dealt round-robin over ``n_parts``
    participants (``P00``...) in the layout of ``responses.csv``
    (``root/<participant>/S1/responses.csv``). The paper reports neither trial
    counts nor per-participant data: only the pooled counts are Table 2's, which
    is what the group d' of :func:`study.analysis.condition_table` uses. Nor
    does it report response times: ``rt_s`` (a required, finite column of the
    schema) is written as 0 s on these rows, marked ``input="published"``, and no
    analysis of them uses it. Returns the files written.
    """
    import csv
    from pathlib import Path

    from .session import RESPONSE_COLUMNS

    root = Path(root)
    cells = [(g, "none", "none", 0, r0) for g, r0 in TABLE2_CONTROL_RATING.items()]
    cells += [tuple(r) for r in table2()[["group", "perturbation", "direction", "level", "rating"]].itertuples(
        index=False)]
    n = int(n_parts) * int(per_part)
    if n <= 0 or n % 100:
        raise ValueError(f"n_parts x per_part must be a multiple of 100 (whole-percent ratings), got {n}")
    rows: dict[str, list] = {f"P{i:02d}": [] for i in range(int(n_parts))}
    for g, p, d, lv, rating in cells:
        k = int(rating) * n // 100
        answers = ["correct"] * k + ["incorrect"] * (n - k)
        for j, a in enumerate(answers):
            pid = f"P{j % int(n_parts):02d}"
            r = {c: "" for c in RESPONSE_COLUMNS}
            r.update(participant_id=pid, session_id="S1", stimulus_set_id="TABLE2", trial_index=len(rows[pid]),
                     kind="test", group=g, repetition=1 + (j // int(n_parts)) % 2, stimulus_id=f"{g}:{p}_{d}_{lv}",
                     perturbation=p, direction=d, nominal_level=lv, achieved_error=lv, response=a,
                     rated_correct=int(a == "correct"), input="published", rt_s=0.0)
            rows[pid].append(r)
    files = []
    for pid, rr in rows.items():
        f = root / pid / "S1" / "responses.csv"
        f.parent.mkdir(parents=True, exist_ok=True)
        with open(f, "x", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(RESPONSE_COLUMNS), lineterminator="\n")
            w.writeheader()
            w.writerows(rr)
        files.append(f)
    return files
