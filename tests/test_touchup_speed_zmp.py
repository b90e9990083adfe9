"""Touch-up's ZMP state in one compiled call (mocomp.touchup._fast._zmp_state_nb, issue 16's speed goal)
against the numpy steps of mocomp.touchup.zmp.zmp_state (the smoothed segment COMs, eq. 4 on each
frame's floor, the support polygon's signed distance and eq. 7's target)."""
from __future__ import annotations

import os

import numpy as np
import pytest

from mocomp.audit import default_body
from mocomp.ops.synthetic import synthetic_walk
from mocomp.touchup import _fast
from mocomp.touchup.stages import stages
from mocomp.touchup.zmp import floor_levels, zmp_state

pytestmark = pytest.mark.skipif(not _fast.COMPILED, reason="numba switched off: nothing compiled to compare")


@pytest.mark.parametrize("polygon", ["contact", "planted"])
@pytest.mark.parametrize("sigma", [None, 2.0])
def test_compiled_zmp_state_equals_numpy(monkeypatch, polygon, sigma):
    real = bool(os.environ.get("MOCOMP_DATA_DIR"))
    if real:
        from mocomp.touchup.examples import paper_examples

        m = paper_examples()["walk-jog"].motion.slice(0, 98)
    else:
        m = synthetic_walk(duration=3.0, fps=30.0).motion
    # a lean the walk does not have, growing over the clip: the ZMP leaves the polygon on many frames
    rot = np.array(m.rotations)
    ang = np.clip(np.linspace(-0.3, 0.3, m.n_frames), 0.0, None)       # the first half as it was
    rot[:, 0] = np.column_stack([np.zeros_like(ang), np.zeros_like(ang), np.sin(ang / 2), np.cos(ang / 2)])
    from mocomp.core.rotations import quat_multiply

    rot[:, 0] = quat_multiply(rot[:, 0], m.rotations[:, 0])
    mm = m.replace_trusted(m.root_positions, rot)
    body = default_body(mm)
    st = stages(m)
    mask = st.polygon_mask(polygon)
    y0 = floor_levels(st.plants.levels, float(np.nanmin(st.plants.levels)))
    P, G = mm.fk()
    from mocomp.ops.footplant import foot_points

    pts = foot_points(P, G, st.plants)
    chains = _fast.SegmentChains(body, mm.skeleton)
    a = zmp_state(body, mm, pts, mask, y0, smooth_sigma=sigma, chains=chains)
    monkeypatch.setattr(_fast, "COMPILED", False)
    b = zmp_state(body, mm, pts, mask, y0, smooth_sigma=sigma, chains=chains)
    for x, y in ((a.r, b.r), (a.zmp, b.zmp), (a.distance, b.distance), (a.target, b.target)):
        assert np.array_equal(np.isnan(x), np.isnan(y))
        assert np.nanmax(np.abs(x - y)) < 1e-9
    assert np.nanmax(np.abs(a.a - b.a)) < 1e-6                       # m/s^2
    assert np.array_equal(a.outside(), b.outside())
    # outside frames met (the target moved onto the polygon); with the real walk -> jog inside ones too
    assert a.outside().sum() > 5
    if real:
        assert (np.nan_to_num(a.distance, nan=1.0) < 0).sum() > 5
    out = a.outside()
    assert np.abs(a.target[out] - a.zmp[out]).max() > 0.01
