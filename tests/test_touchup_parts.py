"""mocomp.touchup: stages, ZMP, link sets and the ground-frame adjustment (Shin et al. 2003,
sec. 3.1-3.3, eq. 4, 6, 7), on the synthetic walk with known answers."""
import numpy as np
import pytest

from mocomp.audit import audit, default_body
from mocomp.dynamics.com import segment_positions
from mocomp.dynamics.zmp import support_polygon_distance, zmp_of_point_masses
from mocomp.ops.synthetic import synthetic_walk
from mocomp.touchup.ground import eq6_coefficients, eq7_angle, ground_adjustment
from mocomp.touchup.linksets import LinkSetError, link_sets, rotate_sets
from mocomp.touchup.stages import StageError, stages
from mocomp.touchup.zmp import project_to_polygon, zmp_state

G = 9.81


@pytest.fixture(scope="module")
def walk():
    m = synthetic_walk(duration=2.0, fps=60).motion
    return m, default_body(m)


def test_stages_walk_all_ground_and_overrides_make_a_flight(walk):
    m, _ = walk
    st = stages(m)
    assert st.ground.all() and st.flight_runs == []
    T = m.n_frames
    over = {"foot_l": [(0, 40)], "toe_l": [(0, 40)], "foot_r": [(70, T)], "toe_r": [(70, T)]}
    st2 = stages(m, over, max_plant_travel=5.0)
    assert st2.flight_runs == [(40, 70)]
    assert st2.to_dict()["plants"]["foot_l"]["source"] == "given"


def test_stages_errors(walk):
    m, _ = walk
    T = m.n_frames
    with pytest.raises(StageError, match="no ground frames"):
        stages(m, {"foot_l": [], "toe_l": [], "foot_r": [], "toe_r": []})
    with pytest.raises(StageError, match=r"foot_l is labelled planted on frames 0-%d" % (T - 1)):
        stages(m, {"foot_l": [(0, T)]})          # the walk moves 2 m: the label contradicts it


def test_zmp_matches_the_audit(walk):
    m, body = walk
    st = stages(m)
    z = zmp_state(body, m, st.contact_points, st.contact_mask, st.plants.contacts.ground_y)
    ra = audit(m, body)
    assert np.allclose(z.zmp, ra.zmp.zmp, atol=1e-9, equal_nan=True)
    assert np.allclose(z.distance, ra.zmp.distance, atol=1e-9, equal_nan=True)


def test_projection_to_polygon_known_answers():
    sq = np.array([[[0, 0], [1, 0], [1, 1], [0, 1]]], float)
    mask = np.ones((1, 4), bool)
    assert np.allclose(project_to_polygon(np.array([[2.0, 0.5]]), sq, mask), [[1.0, 0.5]])
    assert np.allclose(project_to_polygon(np.array([[2.0, 3.0]]), sq, mask), [[1.0, 1.0]])
    m2 = np.array([[True, True, False, False]])   # a segment
    assert np.allclose(project_to_polygon(np.array([[0.3, -2.0]]), sq, m2), [[0.3, 0.0]])


def test_link_set_presets_partition(walk):
    m, body = walk
    names = m.skeleton.names
    ls = link_sets(body, s2="lower", s3="upper")
    d = ls.to_dict(names)
    assert "Hips" in d["S2"] and "LeftFoot" in d["S2"] and "LowerBack" in d["S3"] and d["S1"] == []
    arms = link_sets(body, s1="rest", s2="arms")
    assert set(np.asarray(names)[arms.pivots]) == {"LeftArm", "RightArm"}
    assert "LeftShoulder" in arms.to_dict(names)["S1"]
    j = link_sets(body, s1="rest", s2=["Spine1"])
    assert set(j.to_dict(names)["S2"]) >= {"Spine1", "Head", "LeftHand"} and "Spine" in j.to_dict(names)["S1"]
    with pytest.raises(LinkSetError, match="S2: 'legs' is neither a preset"):
        link_sets(body, s2="legs")
    with pytest.raises(LinkSetError, match="S2 .* is empty"):
        link_sets(body, s1="all")


def test_rotate_sets_rigid_and_s3_orientation_kept(walk):
    m, body = walk
    P, Gq = m.fk()
    ls = link_sets(body, s2="lower", s3="upper")
    T, J = P.shape[:2]
    from scipy.spatial.transform import Rotation
    R = Rotation.from_rotvec(np.tile([0.0, 0.0, 0.3], (T, 1))).as_matrix()
    C = np.broadcast_to(P[:, :1] * [1, 0, 1], (T, J, 3)).copy()
    Pn, Gn = rotate_sets(P, Gq, ls, R, C)
    par = np.asarray(m.skeleton.parents)
    bl = lambda Q: np.linalg.norm(Q[:, 1:] - Q[:, par[1:]], axis=-1)   # noqa: E731
    assert np.allclose(bl(Pn), bl(P), atol=1e-12)
    s3 = ls.s3
    assert np.allclose(np.abs(np.einsum("tjk,tjk->tj", Gn[:, s3], Gq[:, s3])), 1.0, atol=1e-12)
    assert not np.allclose(Gn[:, ls.s2], Gq[:, ls.s2])


def _zmp_after(body, motion, adj, a, gy):
    m2 = motion.replace(root_positions=adj.root_positions, rotations=adj.rotations)
    Z2, _, _ = zmp_of_point_masses(body.masses, segment_positions(body, m2), a, gy, G, 1.0)
    return m2, Z2


def test_eq6_is_eq4_under_rotation(walk):
    """Eq. 6 with the derived a1..a3 equals eq. 4 recomputed on the rotated frame (accelerations held)."""
    m, body = walk
    st = stages(m)
    gy = st.plants.contacts.ground_y
    z = zmp_state(body, m, st.contact_points, st.contact_mask, gy, smooth_sigma=None)
    ls = link_sets(body, s1="lower", s2="upper")
    f = z.outside()
    adj = ground_adjustment(body, m, ls, z, f, feet_in_s1=True, g=G, max_angle=np.inf)
    _, Z2 = _zmp_after(body, m, adj, z.a, gy)
    d = np.cross(adj.axis, [0.0, 1.0, 0.0])
    d /= np.linalg.norm(d, axis=1, keepdims=True).clip(1e-300)
    reached = f & ~adj.clamped
    assert reached.sum() > 50
    # along d the ZMP is exactly on its target (eq. 7 solves eq. 6 exactly)
    assert np.allclose(np.einsum("tk,tk->t", Z2, d)[reached], np.einsum("tk,tk->t", z.target, d)[reached], atol=1e-9)
    # the feet (S1) do not move
    P1, _ = m.fk()
    P2, _ = m.replace(root_positions=adj.root_positions, rotations=adj.rotations).fk()
    assert np.abs(P2[:, [4, 5, 9, 10]] - P1[:, [4, 5, 9, 10]]).max() < 1e-9


def test_per_frame_turn_capped(walk):
    """Departure from the paper: |theta| is cut to max_angle (eq. 7's clamped frames turn by the
    angle of farthest reach, up to 90 deg for the arms); the capped frames are reported and keep
    the sign of eq. 7's angle."""
    m, body = walk
    st = stages(m)
    z = zmp_state(body, m, st.contact_points, st.contact_mask, st.plants.contacts.ground_y, smooth_sigma=None)
    ls = link_sets(body, s1="rest", s2="arms")
    free = ground_adjustment(body, m, ls, z, z.outside(), feet_in_s1=True, g=G, max_angle=np.inf)
    lim = 0.05
    cap = ground_adjustment(body, m, ls, z, z.outside(), feet_in_s1=True, g=G, max_angle=lim)
    big = np.abs(free.theta) > lim
    assert big.sum() > 10 and not free.capped.any()
    assert np.array_equal(cap.capped, big)
    np.testing.assert_allclose(cap.theta[big], lim * np.sign(free.theta[big]), atol=1e-15)
    np.testing.assert_array_equal(cap.theta[~big], free.theta[~big])
    with pytest.raises(ValueError, match="max_angle"):
        ground_adjustment(body, m, ls, z, z.outside(), feet_in_s1=True, g=G, max_angle=0.0)


def test_single_static_frame_lands_on_polygon_boundary(walk):
    """Known answer: a pose held still (zero accelerations: the ZMP is the COM's ground projection,
    and eq. 6's neglected Z_z change is exactly 0) standing on the left foot only, with the COM
    beside the foot. Rotating the whole body (S2) about the ZMP's projection Z' must put the ZMP on
    the polygon's boundary, by the angle atan(D / h) (D: distance to Z', h: COM height)."""
    m, body = walk
    pose = m.slice(20, 21)
    still = pose.replace(root_positions=np.repeat(pose.root_positions, 9, 0),
                         rotations=np.repeat(pose.rotations, 9, 0))
    over = {"foot_l": [(0, 9)], "toe_l": [(0, 9)], "foot_r": [], "toe_r": []}
    st = stages(still, over)
    gy = float(np.nanmin(st.contact_points[0, :, 1]))
    z = zmp_state(body, still, st.contact_points, st.contact_mask, gy, smooth_sigma=None)
    assert np.abs(z.a).max() < 1e-9
    D = float(z.distance[4])
    assert D > 0.02
    com = np.einsum("s,sk->k", body.masses, z.r[4]) / body.total_mass
    single = np.zeros(9, bool)
    single[4] = True
    adj = ground_adjustment(body, still, link_sets(body, s2="all"), z, single, feet_in_s1=False, g=G)
    assert adj.adjusted.tolist() == single.tolist() and not adj.clamped.any()
    assert abs(abs(adj.theta[4]) - np.arctan2(D, com[1] - gy)) < 1e-9
    _, Z2 = _zmp_after(body, still, adj, z.a, gy)
    d2 = support_polygon_distance(Z2, st.contact_points, st.contact_mask)
    assert abs(d2[4]) < 1e-9
    assert np.allclose(d2[:4], z.distance[:4])


def test_eq7_roots_and_clamp():
    a1, a2, a3 = np.array([0.5]), np.array([0.2]), np.array([0.1])
    th, cl = eq7_angle(a1, a2, a3, np.array([0.45]))
    assert not cl[0] and np.isclose(a1 * np.cos(th) - a2 * np.sin(th) + a3, 0.45).all()
    # the other root is larger in magnitude
    e = 0.45 - 0.1
    other = -np.arccos(e / np.hypot(0.5, 0.2)) - np.arctan2(0.2, 0.5)
    assert abs(th[0]) < abs(other)
    th, cl = eq7_angle(a1, a2, a3, np.array([5.0]))     # out of reach: clamped to the nearest
    assert cl[0] and np.isclose(a1 * np.cos(th) - a2 * np.sin(th) + a3, 0.1 + np.hypot(0.5, 0.2)).all()


def test_eq6_coefficients_match_appendix_s2_form():
    """Appendix: sigma a1 = sum_S2 (alpha k2 - beta k1), sigma a2 = sum_S2 (alpha k1 + beta k2)
    with k1 = y - c_y, k2 = x - c_x; a3 from theta = 0."""
    rng = np.random.default_rng(1)
    mass = rng.uniform(1, 10, 5)
    a = rng.normal(size=(1, 5, 3))
    w = rng.normal(size=(1, 5, 3))
    moved = np.array([True, True, False, True, False])
    a1, a2, a3 = eq6_coefficients(mass, a, w, moved, np.array([0.3]), np.array([[1.0, 0, 0]]), G)
    alpha, beta = mass * (a[0, :, 1] + G), mass * a[0, :, 0]
    sig = alpha.sum()
    k1, k2 = w[0, :, 1], w[0, :, 0]
    assert np.isclose(a1[0], (moved * (alpha * k2 - beta * k1)).sum() / sig)
    assert np.isclose(a2[0], (moved * (alpha * k1 + beta * k2)).sum() / sig)
    assert np.isclose(a1[0] + a3[0], 0.3)
