"""ZMP (touch-up paper eq. 4) and the signed distance to the support polygon."""
import numpy as np
import pytest

from dyn_helpers import wavy_motion
from mocomp.body import BodyModel
from mocomp.core import Motion
from mocomp.dynamics import center_of_mass, support_polygon_distance, zmp
from scipy.spatial import ConvexHull, QhullError


@pytest.fixture(scope="module")
def body():
    return BodyModel.from_skeleton(wavy_motion(60).skeleton, 70.0)


def _static(body, n=20, fps=60.0):
    m = wavy_motion(fps)
    return Motion(m.skeleton, fps, np.repeat(m.root_positions[:1], n, 0), np.repeat(m.rotations[:1], n, 0))


def test_static_pose_zmp_is_com_projection(body):
    m = _static(body)
    z = zmp(body, m, ground_y=0.1)
    com = center_of_mass(body, m)
    assert np.all(z.defined)
    assert np.allclose(z.zmp[:, [0, 2]], com[:, [0, 2]], atol=1e-12)
    assert np.allclose(z.zmp[:, 1], 0.1)
    assert np.allclose(z.vertical_force, 70.0 * 9.81)


def test_uniform_acceleration_shifts_zmp_backwards(body):
    """A rigid pose translating with constant acceleration a: Z = COM - a (y_COM - y0) / (a_y + g)."""
    fps = 100.0
    base = _static(body, n=40, fps=fps)
    t = base.times
    a = np.array([1.5, 0.8, -0.6])
    m = base.replace(root_positions=base.root_positions + 0.5 * np.outer(t**2, a))
    z = zmp(body, m, ground_y=0.0, g=9.81)
    com = center_of_mass(body, m)
    inner = slice(2, -2)  # central differences of central differences are exact for quadratics here
    assert np.allclose(z.com_acceleration[inner], a, atol=1e-9)
    expect_x = com[:, 0] - a[0] * com[:, 1] / (a[1] + 9.81)
    expect_z = com[:, 2] - a[2] * com[:, 1] / (a[1] + 9.81)
    assert np.allclose(z.zmp[inner, 0], expect_x[inner], atol=1e-9)
    assert np.allclose(z.zmp[inner, 2], expect_z[inner], atol=1e-9)


def test_free_fall_zmp_is_undefined(body):
    fps = 100.0
    base = _static(body, n=30, fps=fps)
    t = base.times
    m = base.replace(root_positions=base.root_positions - 0.5 * 9.81 * np.outer(t**2, [0, 1, 0]))
    z = zmp(body, m, ground_y=0.0)
    assert not z.defined[2:-2].any()
    assert np.all(np.isnan(z.zmp[2:-2]))


def test_support_polygon_signed_distance():
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], float)
    pts = np.array([[0.5, 0, 0.5], [0.9, 0, 0.5], [1.5, 0, 0.5], [2.0, 0, 2.0], [1.0, 0, 0.3]])
    c = np.repeat(square[None], len(pts), 0)
    d = support_polygon_distance(pts, c)
    assert d == pytest.approx([-0.5, -0.1, 0.5, np.sqrt(2), 0.0])
    # masks: only two contacts -> a segment; one -> a point; none -> NaN
    mask = np.array([[1, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 0], [1, 1, 1, 1], [1, 1, 1, 1]], bool)
    d2 = support_polygon_distance(pts, c, mask)
    assert d2[0] == pytest.approx(0.5)
    assert d2[1] == pytest.approx(np.hypot(0.9, 0.5))
    assert np.isnan(d2[2])
    # collinear contact points
    line = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0]]], float)
    assert support_polygon_distance(np.array([[1.0, 0, 0.3]]), line)[0] == pytest.approx(0.3)
    with pytest.raises(ValueError):
        support_polygon_distance(pts, c[:2])


@pytest.mark.realdata
def test_walk_zmp_mostly_inside_support_polygon(real_data_dir):
    """On a captured walk the ZMP (with the touch-up paper's Gaussian pre-smoothing)
    lies within a few centimetres of the support polygon on most stance frames."""
    from mocomp.datasets import load
    from mocomp.dynamics import detect_contacts

    m = load(real_data_dir / "walks" / "sfu_0008_Walking002.bvh")[:600]
    body = BodyModel.from_skeleton(m.skeleton, 60.0)
    c = detect_contacts(m)
    z = zmp(body, m, ground_y=c.ground_y, smooth_sigma=5 / 2.355 * 4)
    feet = [c.effectors.index(n) for n in ("foot_l", "foot_r", "toe_l", "toe_r")]
    pts, lab = c.contact_points()
    d = support_polygon_distance(z, pts[:, feet], c.touching[:, feet])
    ok = np.isfinite(d)
    assert ok.mean() > 0.9
    assert np.median(d[ok]) < 0.05


# --------------------------------------------- the vectorised hull distance vs a per-frame ConvexHull
def _ref_point_segment_distance(p, a, b) -> float:
    ab = b - a
    denom = float(ab @ ab)
    t = 0.0 if denom == 0 else float(np.clip((p - a) @ ab / denom, 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def _ref_signed_distance_2d(p: np.ndarray, pts: np.ndarray) -> float:
    if len(pts) == 0:
        return np.nan
    if len(pts) == 1:
        return float(np.linalg.norm(p - pts[0]))
    try:
        hull = ConvexHull(pts)
        verts = pts[hull.vertices]  # counter-clockwise
    except (QhullError, ValueError):
        # collinear points: the polygon is a segment between the extreme points
        d = pts - pts.mean(axis=0)
        u = np.linalg.svd(d, full_matrices=False)[2][0]
        s = d @ u
        return _ref_point_segment_distance(p, pts[np.argmin(s)], pts[np.argmax(s)])
    n = len(verts)
    dist = min(_ref_point_segment_distance(p, verts[k], verts[(k + 1) % n]) for k in range(n))
    e = np.roll(verts, -1, axis=0) - verts
    w = p - verts
    inside = np.all(e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0] >= 0)
    return -dist if inside else dist



def test_support_polygon_distance_equals_per_frame_convex_hull():
    """The vectorised distance (no loop over frames) against the previous per-frame
    scipy ConvexHull implementation, on random contact sets of 0..6 points with
    collinear sets, coincident points and ZMPs on vertices."""
    rng = np.random.default_rng(0)
    T, K = 3000, 6
    pts = rng.normal(size=(T, K, 2)) * rng.uniform(0.01, 1.0, (T, 1, 1))
    pts[:300, :, 1] = 0.5 * pts[:300, :, 0] + 0.1            # collinear
    pts[300:600, 1] = pts[300:600, 0]                         # coincident points
    mask = rng.random((T, K)) < 0.7
    p = rng.normal(size=(T, 2)) * 0.8
    p[600:700] = pts[600:700, 0]                              # on a (possible) vertex
    p[5] = np.nan
    ref = np.full(T, np.nan)
    for t in range(T):
        if np.all(np.isfinite(p[t])):
            ref[t] = _ref_signed_distance_2d(p[t], pts[t][mask[t]])
    p3 = np.stack([p[:, 0], np.zeros(T), p[:, 1]], axis=1)
    c3 = np.stack([pts[..., 0], np.zeros((T, K)), pts[..., 1]], axis=-1)
    got = support_polygon_distance(p3, c3, mask)
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    f = np.isfinite(ref)
    assert (ref[f] < 0).sum() > 200 and (ref[f] > 0).sum() > 1000   # both inside and outside occur
    np.testing.assert_allclose(got[f], ref[f], rtol=0, atol=1e-12)
    assert np.array_equal(np.sign(got[f]), np.sign(ref[f]))


def test_nearest_on_polygon_matches_a_per_frame_hull():
    """``nearest_on_polygon``: for points outside a random quadrilateral, the nearest hull point is at
    the support-polygon distance and on the hull boundary (scipy ConvexHull per frame)."""
    from scipy.spatial import ConvexHull

    from mocomp.dynamics.zmp import nearest_on_polygon, support_polygon_distance

    rng = np.random.default_rng(3)
    T = 40
    pts = rng.uniform(-0.2, 0.2, (T, 4, 2))
    p = rng.uniform(-1.0, 1.0, (T, 2))
    mask = np.ones((T, 4), dtype=bool)
    mask[5, 1:] = False                                     # a single contact point
    near = nearest_on_polygon(p, pts, mask)
    d = support_polygon_distance(p, pts, mask)
    out = d > 0
    np.testing.assert_allclose(np.linalg.norm(p - near, axis=1)[out], d[out], atol=1e-12)
    np.testing.assert_allclose(near[5], pts[5, 0], atol=1e-15)
    for t in np.flatnonzero(out):
        if mask[t].all():
            h = ConvexHull(pts[t])
            eq = h.equations @ np.append(near[t], 1.0)      # on the boundary: max plane offset 0
            assert abs(eq.max()) < 1e-9
    none = nearest_on_polygon(p[:1], pts[:1], np.zeros((1, 4), dtype=bool))
    assert np.isnan(none).all()
