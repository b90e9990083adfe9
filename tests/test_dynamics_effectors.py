"""default_effectors reads the feet, toe tips and hand ends from the resolved body-segment mapping
(foot segment AJC -> TTIP, hand WJC -> MET3): the same points as resolving those landmarks anew."""
from pathlib import Path

import numpy as np
import pytest

from mocomp import datasets
from mocomp.body.mapping import resolve_landmark, resolve_mapping
from mocomp.dynamics.contacts import default_effectors

DATA = Path(__import__("os").environ.get("MOCOMP_DATA_DIR", "/nonexistent"))


def _skeletons():
    yield "backflip", datasets.load("backflip").skeleton
    for name in ("flips/cmu_88_01_backflip.bvh", "flips/mass_backflip.bvh", "flips/deepmimic_backflip.txt"):
        if (DATA / name).is_file():
            yield name, datasets.load(str(DATA / name)).skeleton


@pytest.mark.parametrize("name,skeleton", list(_skeletons()))
def test_effectors_are_the_mapping_landmarks(name, skeleton):
    rm = resolve_mapping(skeleton)
    lm = rm.convention.landmarks
    rest = skeleton.rest_positions()
    eff = default_effectors(skeleton)
    assert set(eff) == {f"{k}_{s}" for k in ("foot", "toe", "hand") for s in "lr"}
    for kind, landmark in (("foot", "AJC"), ("toe", "TTIP"), ("hand", "MET3")):
        for side in "lr":
            j, off = eff[f"{kind}_{side}"]
            want = resolve_landmark(skeleton, lm[f"{landmark}_{side}"], lm, rest)
            np.testing.assert_allclose(rest[j] + off, want, atol=1e-12, err_msg=f"{name} {kind}_{side}")
            if kind != "toe":                       # feet and hands ride on their segment's carrier joint
                assert j == int(rm.carriers[rm.segments.index(f"{kind}_{side}")])
