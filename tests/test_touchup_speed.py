"""Touch-up's compiled hot paths (mocomp.touchup._fast, issue 16's speed goal) against the numpy code
they replace: the same touched-up motions on the paper's examples, to rounding."""
from __future__ import annotations

import numpy as np
import pytest
from _touchup_compare import assert_same_touchup
from _touchup_compare import quat_close as _quat_close

from mocomp.audit import default_body
from mocomp.audit.zmp import smoothed_segment_positions
from mocomp.dynamics.derivatives import second_difference
from mocomp.ops.synthetic import synthetic_walk
from mocomp.touchup import _fast, link_sets, touchup
from mocomp.touchup.examples import PAPER_TIMINGS, paper_examples
from mocomp.touchup.ground import rotation_centres
from mocomp.touchup.linksets import local_from_global, rotate_sets

pytestmark = pytest.mark.skipif(not _fast.COMPILED, reason="numba switched off: nothing compiled to compare")


@pytest.fixture(scope="module")
def walk():
    m = synthetic_walk(duration=2.0, fps=30.0).motion
    return m, default_body(m)


def test_fk_fills_the_cache_with_core_fk_bit_for_bit(walk):
    m, _ = walk
    fresh = m.replace_trusted(m.root_positions, m.rotations)
    P, G = _fast.fk(fresh)
    P0, G0 = m.replace_trusted(m.root_positions, m.rotations).fk()      # the numpy FK
    assert np.array_equal(P, P0) and np.array_equal(G, G0)
    assert fresh.fk()[0] is P                                          # cached: callees find it


def test_segment_chains_equal_the_audits_smoothed_segment_positions(walk):
    m, body = walk
    ch = _fast.SegmentChains(body, m.skeleton)
    for sigma in (None, 2.0, 40.0):                 # 40: the Gaussian reaches past both ends
        r0 = smoothed_segment_positions(body, m, sigma)
        assert np.abs(ch.positions(m, sigma) - r0).max() < 1e-12
        r, a = ch.positions_and_accelerations(m, sigma)
        assert np.abs(r - r0).max() < 1e-12
        a0 = second_difference(r0, m.times)
        assert np.abs(a - a0).max() < 1e-9 and np.abs(a0).max() > (1.0 if sigma != 40.0 else 0.1)   # m/s^2


@pytest.mark.parametrize("s1,s2,s3,fallback", [("lower", "upper", (), False), ((), "lower", "upper", True),
                                               ("rest", "arms", (), False)])
def test_turn_sets_equals_rotate_sets_then_local_rotations(walk, s1, s2, s3, fallback):
    m, body = walk
    ls = link_sets(body, s1, s2, s3)
    P, G = m.fk()
    rng = np.random.default_rng(3)
    rv = rng.normal(scale=0.3, size=(m.n_frames, 3))
    rv[::7] = 0.0                                                      # the identity turn too
    C = rotation_centres(P, ls, P[:, 5] + 0.1 if fallback else None)
    root, local = _fast.turn_sets(P, G, ls, rv, C)
    from scipy.spatial.transform import Rotation

    Pn, Gn = rotate_sets(P, G, ls, Rotation.from_rotvec(rv).as_matrix(), C)
    assert np.abs(root - Pn[:, 0]).max() < 1e-12
    assert _quat_close(local, local_from_global(Gn, ls.parents)) < 1e-12
    # the turn really moved S2: the numbers compared are not all the input's
    assert _quat_close(local, m.rotations) > 0.05


def test_touchup_compiled_equals_numpy_on_the_paper_examples(monkeypatch):
    """Every example the data allow (synthetic curved walk and uphill without MOCOMP_DATA_DIR),
    cut to the paper's frame counts with its schedule: the touched-up motion, the per-iteration
    ZMP record and the reported frame lists agree with the numpy path to 1e-9 m / 1e-9."""
    for name, e in paper_examples().items():
        m = e.motion.slice(0, min(PAPER_TIMINGS[name][0], e.motion.n_frames))
        body = default_body(m)
        fast = touchup(m, body, e.schedule)
        monkeypatch.setattr(_fast, "COMPILED", False)
        ref = touchup(m, body, e.schedule)
        monkeypatch.setattr(_fast, "COMPILED", True)
        assert_same_touchup(fast, ref, m, name)
        np.testing.assert_allclose(fast.distance_after, ref.distance_after, atol=1e-9, rtol=0)


def test_polygon_distance_and_target_compiled_equal_the_dynamics_functions(monkeypatch):
    """Random frames of 4 foot points with every mask (none, one point, two, collinear, a
    quadrilateral), ZMPs inside, outside, on a vertex and undefined: the signed distance and eq. 7's
    target agree with :func:`mocomp.dynamics.zmp.support_polygon_distance` / ``nearest_on_polygon``."""
    rng = np.random.default_rng(7)
    T = 600
    pts = rng.normal(scale=0.15, size=(T, 4, 3))
    pts[100:150, 2] = pts[100:150, 0] + 0.5 * (pts[100:150, 1] - pts[100:150, 0])   # collinear triples
    pts[150:200, :, 2] = 0.3                                                        # all on a line z = 0.3
    mask = rng.random((T, 4)) < 0.6
    mask[:20] = False
    zmp = np.column_stack([rng.normal(scale=0.2, size=T), np.zeros(T), rng.normal(scale=0.2, size=T)])
    zmp[200:220, [0, 2]] = pts[200:220, 0][:, [0, 2]]                              # on a point
    zmp[220:230] = np.nan                                                           # no ZMP
    mask[300:400] = True
    zmp[300:400] = pts[300:400].mean(axis=1)                                        # inside the quadrilateral
    d, t = _fast.polygon_distance_and_target(zmp, pts, mask)
    monkeypatch.setattr(_fast, "COMPILED", False)
    d0, t0 = _fast.polygon_distance_and_target(zmp, pts, mask)
    assert np.array_equal(np.isnan(d), np.isnan(d0)) and np.array_equal(np.isnan(t), np.isnan(t0))
    assert np.nanmax(np.abs(d - d0)) < 1e-12 and np.nanmax(np.abs(t - t0)) < 1e-12
    assert (d0 < 0).sum() > 50 and (d0 > 0).sum() > 50 and np.isnan(d0).sum() >= 30   # every case met
    out = d0 > 0
    assert np.abs(t[out] - zmp[out]).max() > 0.05                                    # targets moved


def test_running_products_compiled_equal_quat_multiply_frame_by_frame(monkeypatch):
    """Eq. 9's per-frame turns accumulated from the take-off: the compiled loop against
    quat_multiply frame by frame, and a known answer (n equal turns about one axis: n times the angle)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(5)
    inc = Rotation.from_rotvec(rng.normal(scale=0.2, size=(40, 3))).as_quat()
    acc = _fast.running_products(inc)
    monkeypatch.setattr(_fast, "COMPILED", False)
    acc0 = _fast.running_products(inc)
    assert acc.shape == (41, 4) and np.abs(acc - acc0).max() < 1e-14
    assert np.array_equal(acc[0], [0.0, 0.0, 0.0, 1.0]) and np.array_equal(_fast.running_products(inc[:0]), acc[:1])
    monkeypatch.setattr(_fast, "COMPILED", True)
    same = np.tile(Rotation.from_rotvec([0.0, 0.05, 0.0]).as_quat(), (12, 1))
    np.testing.assert_allclose(Rotation.from_quat(_fast.running_products(same)[-1]).as_rotvec(), [0.0, 0.6, 0.0], atol=1e-12)
