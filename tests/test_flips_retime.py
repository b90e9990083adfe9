"""Retiming factor k* (App. B, eq. B.5), the retiming plan, repositioning (eq. 5.15-5.17)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.body import BodyModel
from mocomp.dynamics import center_of_mass
from mocomp.errors import PhysicsError
from mocomp.flips.reposition import ComEvaluator, flight_trajectory, landing_offset
from mocomp.flips.retime import k_star, plan_retime, sample_positions

from _flips_data import skeleton, spinning_motion

G = 9.81


def test_k_star_known_answers():
    T0 = 0.6
    v0 = G * T0 / 2                       # level flight of T0
    assert k_star(G, T0, v0, 0.0) == pytest.approx(1.0)
    # the sequenced flight is twice as long: k* = sqrt(2) (take-off sqrt(2) faster, flight sqrt(2) longer)
    assert k_star(G, 2 * T0, v0, 0.0) == pytest.approx(np.sqrt(2.0))
    # eq. B.4 holds at k*: -1/2 g (T/k)^2 + v0 T = dy
    for dy in (-1.0, -0.2, 0.3):
        T = 1.3
        k = k_star(G, T, v0, dy)
        assert -0.5 * G * (T / k) ** 2 + v0 * T == pytest.approx(dy, abs=1e-12)


def test_negative_radicand_says_what_to_change():
    with pytest.raises(PhysicsError, match="height-change") as e:
        k_star(G, 1.0, 2.0, 2.5)           # dy > v0 T
    assert "2.000 m" in str(e.value)
    with pytest.raises(PhysicsError, match="not upward"):
        k_star(G, 1.0, -1.0, 0.0)
    with pytest.raises(PhysicsError):
        k_star(0.0, 1.0, 2.0, 0.0)


def test_plan_at_k_star_is_continuous_and_default_is_k_star():
    T0, v0 = 0.6, G * 0.3
    v_land = v0 - G * T0
    p = plan_retime(G, 1.2, v0, 0.0, v_land, k_ratio=1.0)
    assert p.vy_takeoff_jump == pytest.approx(0.0, abs=1e-12)
    assert p.vy_landing_jump == pytest.approx(0.0, abs=1e-9)
    default = plan_retime(G, 1.2, v0, 0.0, v_land)        # issue #13: the default is k = k*, continuous
    assert default.k == pytest.approx(default.k_star) and default.vy_takeoff_jump == pytest.approx(0.0, abs=1e-12)
    d = plan_retime(G, 1.2, v0, 0.0, v_land, k_ratio=0.7)  # the paper's aesthetic option
    assert d.k == pytest.approx(0.7 * d.k_star) and d.k_ratio == pytest.approx(0.7)
    # lands at the requested level after T/k
    assert -0.5 * G * d.T_new ** 2 + d.vy_takeoff_new * d.T_new == pytest.approx(0.0, abs=1e-12)
    # slower than k*: higher jump, the take-off velocity has to jump up (factor (k*/k)^2 for dy = 0)
    assert d.vy_takeoff_new / (d.k * v0) == pytest.approx(1 / 0.49)
    # one basis for the relative jump (note and p_jump_takeoff_rel): M k|v| of the retimed take-off;
    # without horizontal speed it is the vertical (k*/k)^2 - 1 = +104 %
    assert d.p_jump_takeoff_rel == pytest.approx(1 / 0.49 - 1) and "+104% of the retimed take-off" in d.note
    h = plan_retime(G, 1.2, v0, 0.0, v_land, v_horizontal=2.0, k_ratio=0.7)
    assert h.vy_takeoff_jump == pytest.approx(d.vy_takeoff_jump)           # the jump itself is vertical
    assert h.takeoff_speed == pytest.approx(h.k * np.hypot(2.0, v0))
    assert h.p_jump_takeoff_rel == pytest.approx(h.vy_takeoff_jump / (h.k * np.hypot(2.0, v0)))
    assert h.p_jump_landing_rel == pytest.approx(h.vy_landing_jump / h.takeoff_speed)
    assert f"{100 * h.p_jump_takeoff_rel:+.0f}% of the retimed take-off" in h.note
    e = plan_retime(G, 1.2, v0, 0.0, v_land, k=1.2)
    assert e.k == 1.2
    with pytest.raises(ValueError):
        plan_retime(G, 1.2, v0, 0.0, v_land, k=1.2, k_ratio=0.7)
    with pytest.raises(PhysicsError):
        plan_retime(G, 1.2, v0, 0.0, v_land, k=10.0)
    # an explicit k survives an impossible k* (reported as nan), the k_ratio default does not
    x = plan_retime(G, 1.2, v0, 4.0, v_land, k=1.0)
    assert np.isnan(x.k_star) and x.note
    with pytest.raises(PhysicsError):
        plan_retime(G, 1.2, v0, 4.0, v_land)


def test_sample_positions():
    s = sample_positions(101, 1.25)
    assert s[0] == 0 and s[-1] <= 100 and np.allclose(np.diff(s), 1.25)
    assert len(s) == 81


def test_com_evaluator_is_exact():
    m = spinning_motion()
    rng = np.random.default_rng(0)
    rot = Rotation.random(m.n_frames * m.skeleton.n_joints, random_state=1).as_quat().reshape(m.rotations.shape)
    m2 = m.replace(rotations=rot, root_positions=rng.normal(size=(m.n_frames, 3)))
    sk = skeleton()
    carriers = [j for j in range(sk.n_joints) if j not in (12, 15)]     # hands carry nothing
    S = len(carriers)
    body = BodyModel(sk, tuple(sk.names[j] for j in carriers), np.array(carriers), rng.uniform(0.5, 9.0, S),
                     rng.normal(scale=0.1, size=(S, 3)), np.tile(np.eye(3) * 0.01, (S, 1, 1)))
    ev = ComEvaluator(body)
    np.testing.assert_allclose(ev(m2.root_positions, m2.rotations), center_of_mass(body, m2), atol=1e-12)
    # joints that carry no mass below them (finger tips etc.) are skipped
    assert 12 not in ev.joints and 15 not in ev.joints


def test_flight_trajectory_and_offset():
    c0 = np.array([0.1, 1.0, -0.3])
    tr = flight_trajectory(c0, a_x=0.5, a_z=-0.2, a_y=-G / 2, k=1.2, vy_takeoff=4.0, T_new=0.8)
    t = np.array([0.0, 0.4, 0.8])
    c = tr(t)
    np.testing.assert_allclose(c[0], c0)
    np.testing.assert_allclose(c[:, 0], 0.1 + 1.2 * 0.5 * t)          # eq. 5.15
    np.testing.assert_allclose(c[:, 2], -0.3 - 1.2 * 0.2 * t)
    np.testing.assert_allclose(c[:, 1], 1.0 + 4.0 * t - G / 2 * t * t)  # eq. 5.17
    np.testing.assert_allclose(landing_offset(tr, c0), tr.end - c0)       # eq. 5.16


# ------------------------------------------------------------------ eased retiming (issue 13)
def test_time_warp_rate_is_k_in_flight_one_on_the_ground_and_continuous():
    from mocomp.flips.retime import TimeWarp

    k, s0, s1, end = 1.4, 100.0, 180.0, 330.0
    w = TimeWarp.build(k, s0, s1, end, 60.0, 60.0)
    s = w.source_positions()
    rate = np.diff(s)                                   # source frames per output frame
    u0, u1 = w.takeoff_output, w.landing_output
    mid = np.arange(int(np.ceil(u0)) + 1, int(np.floor(u1)) - 1)
    np.testing.assert_allclose(rate[mid], k, atol=1e-9)                  # the flight at k (eq. 5.8)
    np.testing.assert_allclose(rate[:int(np.floor(w.output_frame(s0 - 60.0))) - 1], 1.0, atol=1e-9)
    np.testing.assert_allclose(rate[int(np.ceil(w.output_frame(s1 + 60.0))) + 1:-1], 1.0, atol=1e-9)
    assert np.max(np.abs(np.diff(rate))) < 1.5 * (k - 1) / 60.0 * k + 1e-6   # no step in the rate
    # the flight keeps T/k: landing minus take-off output time
    assert u1 - u0 == pytest.approx((s1 - s0) / k, abs=1e-6)
    # ease 0 is the paper's uniform retiming
    w0 = TimeWarp.build(k, s0, s1, end, 0.0, 0.0)
    np.testing.assert_allclose(w0.source_positions(), sample_positions(int(end) + 1, k), atol=1e-9)


def test_multiflip_plays_the_stances_at_the_captured_rate():
    """Issue 13: uniform k* retiming played the whole clip k times faster (ground velocities k times,
    accelerations k^2); the eased warp keeps the flight at k and the stances as captured away from it,
    with the COM velocity continuous at the take-off (k = k*)."""
    from mocomp.audit import audit
    from mocomp.flips import multiflip, prepare

    P = prepare("backflip")
    res = multiflip(P, flips=2)
    uni = multiflip(P, flips=2, ease=0.0)
    k = res.plan.k
    assert k > 1.2
    tau = res.seq_positions
    s = P.flight[0]
    early = tau < s - 0.5 * P.fps - 1                   # before the ease window: the captured rate
    assert early.sum() > 20
    np.testing.assert_allclose(np.diff(tau)[early[:-1]], 1.0, atol=1e-9)
    assert np.diff(uni.seq_positions)[0] == pytest.approx(k)
    # the COM of the early stance moves as the input's, not k times faster
    c_in = center_of_mass(P.body, P.motion)
    c_out = center_of_mass(P.body, res.motion)
    n = int(early.sum())
    np.testing.assert_allclose(np.diff(c_out[:n], axis=0), np.diff(c_in[:n], axis=0), atol=1e-9)
    # same flight: the parabola and T_new, and no velocity jump at take-off beyond the uniform one's
    assert res.plan.T_new == pytest.approx(uni.plan.T_new)
    a, b = res.flight
    np.testing.assert_allclose(c_out[a:b], res.trajectory(np.arange(a, b) / P.fps - res.takeoff_seconds), atol=1e-9)
    rep, rep_u = audit(res.motion, P.body), audit(uni.motion, P.body)
    assert rep.measure("takeoff_jump_mps") <= rep_u.measure("takeoff_jump_mps") + 0.05
    # the output is longer than the uniform one by the stances played at rate 1 instead of k
    assert res.motion.n_frames > uni.motion.n_frames + 0.3 * P.fps


def test_edit_keeps_a_later_hop_at_its_captured_rate(real_data_dir):
    """CMU 88_01 + arms-twist (issue 13): with the whole clip retimed by k = 0.86 the hop after the
    landing fell with 7.06 m/s^2 (k^2 g); eased, it keeps the capture's own timing."""
    import tempfile
    from pathlib import Path

    from mocomp.audit import audit
    from mocomp.cli import main
    from mocomp.datasets import load
    from mocomp.io.bvh import read_bvh

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "o.bvh"
        assert main(["edit", "88_01", "--preset", "arms-twist", "-o", str(out), "--no-audit"]) == 0
        m = read_bvh(out, scale=1.0)
    src = load("88_01")
    rep = audit(m, against=src)
    g_in = rep.against.measure("flight2_g")
    g_out = rep.measure("flight2_g")
    assert abs(g_out - g_in) < 0.6, (g_in, g_out)
    assert not rep.comparison.worse or "flight2_g" not in rep.comparison.worse
