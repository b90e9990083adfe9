"""Compare mass distributions with the dissertation's Table C.1 (App. C)."""
from __future__ import annotations

import numpy as np

from .tables import DISSERTATION_TABLE_C1

__all__ = ["TABLE_C1_GROUPS", "table_c1_comparison"]

#: comparison group -> (our sided segments, Table C.1 CMU ASF bones). Table C.1 puts part
#: of the chest mass on the clavicles, so the trunk is compared as a whole (with the
#: clavicles) and, approximately, part by part.
TABLE_C1_GROUPS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "head + neck": (("head",), ("lowerneck", "upperneck", "head")),
    "trunk (incl. clavicles)": (("upper_trunk", "middle_trunk", "lower_trunk"),
                                ("root", "lowerback", "upperback", "thorax", "lclavicle", "rclavicle")),
    "  lower trunk ~ root": (("lower_trunk",), ("root",)),
    "  middle trunk ~ lowerback": (("middle_trunk",), ("lowerback",)),
    "  upper trunk ~ upperback + thorax + clavicles": (("upper_trunk",),
                                                       ("upperback", "thorax", "lclavicle", "rclavicle")),
    "upper arm L": (("upper_arm_l",), ("lhumerus",)),
    "upper arm R": (("upper_arm_r",), ("rhumerus",)),
    "forearm L": (("forearm_l",), ("lradius",)),
    "forearm R": (("forearm_r",), ("rradius",)),
    "hand L": (("hand_l",), ("lwrist", "lhand", "lfingers", "lthumb")),
    "hand R": (("hand_r",), ("rwrist", "rhand", "rfingers", "rthumb")),
    "thigh L": (("thigh_l",), ("lfemur",)),
    "thigh R": (("thigh_r",), ("rfemur",)),
    "shank L": (("shank_l",), ("ltibia",)),
    "shank R": (("shank_r",), ("rtibia",)),
    "foot L": (("foot_l",), ("lfoot", "ltoes")),
    "foot R": (("foot_r",), ("rfoot", "rtoes")),
}


def table_c1_comparison(bodies: dict):
    """A pandas DataFrame of mass percentages per group: Table C.1 "initial" and
    "optimized" columns beside one column per body model in ``bodies`` (label -> BodyModel
    with the canonical sided segment names), and each model's difference from "initial"."""
    import pandas as pd

    rows = []
    for group, (ours, bones) in TABLE_C1_GROUPS.items():
        row = {"group": group,
               "C.1 initial %": sum(DISSERTATION_TABLE_C1[b][2] for b in bones),
               "C.1 optimized %": sum(DISSERTATION_TABLE_C1[b][3] for b in bones)}
        for label, body in bodies.items():
            idx = [body.segment(s) for s in ours]
            row[f"{label} %"] = 100.0 * float(np.sum(body.masses[idx])) / body.total_mass
        rows.append(row)
    df = pd.DataFrame(rows).set_index("group")
    for label in bodies:
        df[f"{label} - initial"] = df[f"{label} %"] - df["C.1 initial %"]
    return df
