"""Distance functions of ch. 6.2 (eq. 6.6-6.9), hand markers and Table 6.1 phases."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.errors import AlignmentError, MotionFormatError
from mocomp.io.markers import Markers
from mocomp.splice import HandMarkers, full_band, hand_markers_from_markers, motion_phases, slanted_band, virtual_hand_markers
from mocomp.splice.metrics import (angle_band_costs, arm_features, hand_angle_distance, matched_theta, rotate_vertical,
                                   sign_band_costs, sign_distance, theta_band, theta_eq67, value_band_costs)
from mocomp.splice.synthetic import gesture_clip


def _ry(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


@pytest.fixture(scope="module")
def gesture():
    return gesture_clip(11, n_gestures=2)


@pytest.fixture(scope="module")
def hm(gesture):
    return virtual_hand_markers(gesture.motion)


def test_theta_eq67_recovers_a_known_rotation():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(20, 3))
    for theta in (0.3, -2.0, 3.0):
        q = (p + [0.4, -0.2, 1.0]) @ _ry(-theta).T  # q rotated by -theta (and shifted): R_y(theta) q ~ p
        th = theta_eq67(p, q)
        assert th == pytest.approx(theta, abs=1e-9)
        qq = q @ _ry(th).T
        np.testing.assert_allclose(qq - qq.mean(0), p - p.mean(0), atol=1e-9)


def test_theta_band_equals_eq67_per_cell(hm):
    f = arm_features(hm)
    g = arm_features(HandMarkers(hm.positions[::-1] @ _ry(0.7).T, hm.fps, hm.shoulder[::-1] @ _ry(0.7).T))
    band = slanted_band(f.n_frames, g.n_frames, 20.0)
    cs, sn = theta_band(f, g, band)
    rng = np.random.default_rng(1)
    r, c = band.cell_indices()
    w = f.theta_window
    for k in rng.choice(band.cells, 40, replace=False):
        i, j = r[k], c[k]
        si = int(np.clip(i - (w - 1) // 2, 0, f.n_frames - w))
        sj = int(np.clip(j - (w - 1) // 2, 0, g.n_frames - w))
        th = theta_eq67(f.rel[si:si + w].reshape(-1, 3), g.rel[sj:sj + w].reshape(-1, 3))
        assert np.arctan2(sn[k], cs[k]) == pytest.approx(th, abs=1e-9)
    # a copy turned by R_y(0.7): on the diagonal eq. 6.7 turns it back, theta = -0.7
    g2 = arm_features(HandMarkers(hm.positions @ _ry(0.7).T, hm.fps, hm.shoulder @ _ry(0.7).T))
    full = full_band(f.n_frames, g2.n_frames)
    cs, sn = theta_band(f, g2, full)
    i = np.arange(f.n_frames)
    k = full.flat_index(i, i)
    np.testing.assert_allclose(np.arctan2(sn[k], cs[k]), -0.7, atol=1e-9)
    th = theta_band(f, g, full, "none")
    assert np.all(th[0] == 1) and np.all(th[1] == 0)


def test_matched_theta_recovers_a_known_turn(hm):
    """The second pass's rotation (eq. 6.7 along a frame map, or the trunk
    headings): a recording turned by R_y(0.9) (trunk heading + 0.9) is turned
    back by -0.9 at every frame, through a non-identity map too; pooling the
    eq. 6.7 sums over a span leaves an exact answer exact."""
    R = _ry(0.9)
    g = HandMarkers(hm.positions @ R.T, hm.fps, hm.shoulder @ R.T, hm.trunk_heading + 0.9)
    f, fg = arm_features(hm), arm_features(g)
    n = f.n_frames
    for span in (1, 31):
        np.testing.assert_allclose(matched_theta(fg, f, np.arange(n, dtype=float), "window", span), 0.9, atol=1e-9)
    np.testing.assert_allclose(matched_theta(f, fg, np.arange(n, dtype=float), "window"), -0.9, atol=1e-9)
    np.testing.assert_allclose(matched_theta(f, fg, np.arange(n, dtype=float), "trunk"), -0.9, atol=1e-9)
    # trunk mode along a fractional map: body heading minus the interpolated hand heading
    fmap = np.linspace(0, n - 1, n) ** 1.5 / (n - 1) ** 0.5
    expect = f.heading - np.interp(fmap, np.arange(n), fg.heading)
    np.testing.assert_allclose(matched_theta(f, fg, fmap, "trunk"), expect, atol=1e-12)
    assert np.all(matched_theta(f, fg, fmap, "none") == 0)
    # rotate_vertical is R_y of eq. 6.6, per frame
    v = np.random.default_rng(2).normal(size=(5, 3))
    th = np.linspace(-3, 3, 5)
    np.testing.assert_allclose(rotate_vertical(v, th), np.stack([_ry(t) @ x for t, x in zip(th, v)]), atol=1e-12)
    with pytest.raises(AlignmentError, match="trunk heading of the hand"):
        matched_theta(f, arm_features(HandMarkers(hm.positions, hm.fps, hm.shoulder)), fmap, "trunk")
    with pytest.raises(AlignmentError, match="frame map has shape"):
        matched_theta(f, fg, fmap[:-1], "window")


def test_sign_cost_matches_reference_per_cell(hm):
    f = arm_features(hm)
    g = arm_features(HandMarkers(hm.positions[20:] @ _ry(-0.4).T * 0.6, hm.fps, hm.shoulder[20:] @ _ry(-0.4).T * 0.6))
    band = slanted_band(f.n_frames, g.n_frames, 15.0)
    costs = sign_band_costs(f, g, band)
    cs, sn = theta_band(f, g, band)
    r, c = band.cell_indices()
    rng = np.random.default_rng(2)
    for k in rng.choice(band.cells, 60, replace=False):
        ref = sign_distance(f.vel[r[k]], f.acc[r[k]], g.vel[c[k]], g.acc[c[k]], np.arctan2(sn[k], cs[k]),
                            (f.eps_v, f.eps_a), (g.eps_v, g.eps_a))
        assert costs[k] == ref
    assert costs.min() >= 0 and costs.max() <= 96 and np.all(costs == np.round(costs))


def test_sign_metric_is_amplitude_invariant_value_metric_is_not(hm):
    """The reason for eq. 6.6: scaling the arm's excursion about the shoulder
    (and rotating the whole recording about the vertical) leaves the signs,
    hence a zero-cost diagonal, unchanged; the derivative values change."""
    rel = hm.relative
    R = _ry(1.1)
    scaled = HandMarkers((hm.shoulder[:, None] + 0.4 * rel) @ R.T, hm.fps, hm.shoulder @ R.T)
    f, g = arm_features(hm), arm_features(scaled)
    band = slanted_band(f.n_frames, g.n_frames, 5.0)
    i = np.arange(f.n_frames)
    diag = band.flat_index(i, i)
    s = sign_band_costs(f, g, band)
    assert np.mean(s[diag] == 0) > 0.97  # a few dead-zone boundary cells may differ by round-off
    v = value_band_costs(f, g, band)
    assert np.median(v[diag]) > 0.05
    v_same = value_band_costs(f, f, slanted_band(f.n_frames, f.n_frames, 5.0))
    np.testing.assert_allclose(v_same[slanted_band(f.n_frames, f.n_frames, 5.0).flat_index(i, i)], 0, atol=1e-18)


def test_hand_angle_known_answer_and_scipy():
    """Eq. 6.8-6.9: with the forearms aligned, the cost is the angle between the hands."""
    f = np.array([[1.0, 0, 0]])
    h = np.array([[0.0, 1.0, 0]])
    for alpha in (0.0, 0.3, 1.2, 3.0):
        R = Rotation.from_rotvec([alpha, 0, 0])  # turn the hand about the forearm
        B = Rotation.from_rotvec([0.2, -1.0, 0.5])  # and the whole arm elsewhere
        f2, h2 = B.apply(f), B.apply(R.apply(h))
        d = angle_band_costs(f, h, f2, h2, full_band(1, 1))[0]
        assert d == pytest.approx(hand_angle_distance(f[0], h[0], f2[0], h2[0]), abs=1e-9)
    # generic vectors against scipy's minimal rotation
    rng = np.random.default_rng(4)
    F, H, F2, H2 = (rng.normal(size=(7, 3)) for _ in range(4))
    band = full_band(7, 7)
    d = band.to_dense(angle_band_costs(F, H, F2, H2, band))
    for i in range(7):
        for j in range(7):
            assert d[i, j] == pytest.approx(hand_angle_distance(F[i], H[i], F2[j], H2[j]), abs=1e-9)
    # antiparallel forearms take the half-turn branch
    d = angle_band_costs(f, h, -f, h, full_band(1, 1))[0]
    assert np.isfinite(d)
    with pytest.raises(AlignmentError, match="zero length"):
        angle_band_costs(np.zeros((1, 3)), h, f, h, full_band(1, 1))


def test_virtual_markers_are_rigid_on_their_bones(gesture):
    hm = virtual_hand_markers(gesture.motion)
    P = hm.positions
    # wrist A, wrist B, forearm sit on the forearm bone: their distances are constant
    for a, b in ((0, 1), (0, 2), (1, 2)):
        d = np.linalg.norm(P[:, a] - P[:, b], axis=1)
        assert np.ptp(d) < 1e-9
    sk = gesture.motion.skeleton
    wrist = gesture.motion.positions[:, sk.index("Hand_R")]
    np.testing.assert_allclose(0.5 * (P[:, 0] + P[:, 1]), wrist, atol=1e-9)  # wrist markers straddle the joint
    np.testing.assert_allclose(hm.shoulder, gesture.motion.positions[:, sk.index("UpperArm_R")])
    assert hm.virtual and hm.side == "right" and hm.trunk_heading is not None
    left = virtual_hand_markers(gesture.motion, "left")
    assert not np.allclose(left.positions, P)
    with pytest.raises(MotionFormatError, match="arm joints"):
        virtual_hand_markers(_renamed(gesture.motion))


def _renamed(motion):
    from mocomp.core import Skeleton

    sk = motion.skeleton
    names = tuple(n.replace("Arm", "Limb").replace("Hand", "Paw") for n in sk.names)
    return motion.replace(skeleton=Skeleton(names, sk.parents, sk.offsets, sk.channels, sk.end_sites))


def test_markers_from_optical_data():
    rng = np.random.default_rng(0)
    T = 50
    names = ("S:RWRA", "S:RWRB", "S:RFRM", "S:RFIN", "S:RSHO", "S:LSHO", "S:X")
    P = rng.normal(size=(T, len(names), 3))
    P[10:13, 2] = np.nan  # a 3-frame gap in the forearm marker
    m = Markers(names, P, 100.0, source="fake.c3d")
    hm = hand_markers_from_markers(m)
    assert hm.labels == ("S:RWRA", "S:RWRB", "S:RFRM", "S:RFIN")
    np.testing.assert_array_equal(hm.shoulder, P[:, 4])
    assert np.all(np.isfinite(hm.positions)) and any("filled 3" in n for n in hm.notes)
    assert hm.trunk_heading is not None  # from LSHO - RSHO
    with pytest.raises(MotionFormatError, match=r"\['RFRM'\] not found") as e:
        hand_markers_from_markers(m.select(["S:RWRA", "S:RWRB", "S:RFIN", "S:RSHO"]))
    assert "fake.c3d" in str(e.value)
    P2 = P.copy()
    P2[10:40, 0] = np.nan
    with pytest.raises(MotionFormatError, match="gap of 30 frames"):
        hand_markers_from_markers(Markers(names, P2, 100.0))


def test_features_need_enough_frames(hm):
    with pytest.raises(AlignmentError, match="at least 7"):
        arm_features(hm[:5])


def test_phases_follow_the_script(gesture):
    """Table 6.1 labels recovered from kinematics agree with the scripted
    phases (rest/hold, preparation, strokes, retraction) on most frames."""
    ph = motion_phases(virtual_hand_markers(gesture.motion), strokes="merged")  # the earlier reading, kept
    agree = np.mean(ph.labels == gesture.labels)
    assert agree > 0.75
    counts = ph.counts()
    assert counts["S"] >= 2 and counts["P"] >= 1 and counts["R"] >= 1
    assert ph.sequence().replace("H", "").startswith("PSR")


def test_phases_known_profiles():
    T, fps = 120, 60.0
    t = np.arange(T) / fps
    sh = np.zeros((T, 3))
    still = np.tile(np.array([[0.3, -0.5, 0.1]]), (T, 4, 1)) + np.arange(4)[None, :, None] * 0.01
    ph = motion_phases(HandMarkers(still + 1e-7 * np.random.default_rng(0).normal(size=still.shape), fps, sh))
    assert ph.sequence() == "H"
    # hand starting at rest (low), moving up and out at constant speed, then back
    up = np.concatenate([np.linspace(0, 1, T // 2), np.linspace(1, 0, T // 2)])
    traj = still.copy()
    traj[..., 1] += 0.4 * up[:, None]
    traj[..., 0] += 0.2 * up[:, None]
    ph = motion_phases(HandMarkers(traj, fps, sh), stroke_acceleration=10.0)  # no stroke: unattainable threshold
    assert ph.sequence().replace("H", "") == "PR"


@pytest.mark.parametrize("k,deriv", [(5, 0), (7, 1), (7, 2), (25, 1)])
def test_savgol_equals_scipy_interp_mode(k, deriv):
    from scipy.signal import savgol_filter

    from mocomp.splice.metrics import savgol

    x = np.random.default_rng(k).normal(size=(60, 4, 3))
    np.testing.assert_allclose(savgol(x, k, deriv, 1 / 30), savgol_filter(x, k, 3, deriv, 1 / 30, axis=0, mode="interp"),
                               rtol=1e-10, atol=1e-9)
