"""mocomp.touchup.flight: the ballistic COM (sec. 3.4.2, eq. 10) and the angular momentum (sec.
3.4.1, eq. 8-9) on a flight block made by contact overrides on the synthetic walk, and on a real jump."""
import numpy as np
import pytest

from mocomp.audit import default_body
from mocomp.dynamics.com import center_of_mass, segment_positions
from mocomp.dynamics.constants import G_STANDARD
from mocomp.ops.synthetic import synthetic_walk
from mocomp.touchup.flight import (ballistic_targets, com_residual, continue_into_ground, flight_com_adjustment,
                                   flight_momentum_adjustment, support_ramp)
from mocomp.touchup.linksets import link_sets
from mocomp.touchup.stages import stages


@pytest.fixture(scope="module")
def hop():
    m = synthetic_walk(duration=2.0, fps=60).motion
    T = m.n_frames
    over = {"foot_l": [(0, 40)], "toe_l": [(0, 40)], "foot_r": [(70, T)], "toe_r": [(70, T)]}
    st = stages(m, over, max_plant_travel=5.0)
    return m, default_body(m), st.flight_runs


def test_ballistic_target_known_answer():
    fps = 100.0
    t = np.arange(50) / fps
    v0 = np.array([1.0, 3.0, -0.5])
    c = np.array([0.2, 1.0, 0.3]) + t[:, None] * v0 + 0.5 * t[:, None] ** 2 * [0.0, -G_STANDARD, 0.0]
    noisy = c + np.where(np.arange(50)[:, None] % 7 == 3, 0.01, 0.0) * [0, 1, 0]
    tgt = ballistic_targets(noisy, 0, 50, fps)
    assert np.allclose(ballistic_targets(c, 0, 50, fps), c, atol=1e-12)
    assert np.allclose(tgt[[0, -1]], noisy[[0, -1]])
    acc = np.diff(tgt, 2, axis=0) * fps ** 2
    assert np.allclose(acc, [0.0, -G_STANDARD, 0.0], atol=1e-9)
    assert com_residual(c, 0, 50, fps) < 1e-12 and abs(com_residual(noisy, 0, 50, fps) - 0.01) < 1e-3


def test_com_onto_parabola_by_root_translation_is_exact(hop):
    m, body, fl = hop
    assert fl == [(40, 70)]
    c0 = center_of_mass(body, m)
    assert com_residual(c0, 40, 70, m.fps) > 0.01
    adj = flight_com_adjustment(body, m, link_sets(body, s2="all"), fl, c0, neighbourhood=8)
    m2 = m.replace(root_positions=adj.root_positions, rotations=adj.rotations)
    c2 = center_of_mass(body, m2)
    assert com_residual(c2, 40, 70, m.fps) < 1e-9
    assert np.allclose(c2[:30], c0[:30]) and np.allclose(c2[80:], c0[80:])   # beyond the neighbourhood
    assert adj.weight[39] < 1 and adj.weight[40] == 1 and adj.weight[31] == 0


def test_com_by_rotating_s2_points_s2_com_at_its_goal(hop):
    """Eq. 10: S2 turns about the S1/S2 joint until its COM lies on the ray to its goal
    c*_M2 = (c*_M M - c_M1 M1) / M2 (the closest it can come: its distance to the joint is fixed)."""
    m, body, fl = hop
    c0 = center_of_mass(body, m)
    ls = link_sets(body, s1="lower", s2="upper")
    adj = flight_com_adjustment(body, m, ls, fl, c0, neighbourhood=8)
    m2 = m.replace(root_positions=adj.root_positions, rotations=adj.rotations)
    in2 = ls.component[np.asarray(body.segment_joint)] >= 0
    mass = np.asarray(body.masses)
    M, M2 = mass.sum(), mass[in2].sum()
    c_m2 = lambda mm: np.einsum("s,tsk->tk", mass[in2], segment_positions(body, mm)[:, in2]) / M2  # noqa: E731
    tgt = c0 + adj.correction                                  # the parabola, its ends moved by the push/landing ramps
    np.testing.assert_allclose(np.diff(tgt[40:70], 2, axis=0) * m.fps ** 2, np.tile([0.0, -G_STANDARD, 0.0], (28, 1)),
                               atol=1e-6)
    goal = (tgt * M - (c0 * M - c_m2(m) * M2)) / M2            # c_M1 unchanged
    p = m.fk()[0][:, m.skeleton.index("LowerBack")]
    u, v = c_m2(m2) - p, goal - p
    cosang = np.einsum("tk,tk->t", u, v) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
    assert np.all(cosang[40:70] > 1 - 1e-9)
    assert np.allclose(np.linalg.norm(u, axis=1), np.linalg.norm(c_m2(m) - p, axis=1))
    P0, _ = m.fk()
    P2, _ = m2.fk()
    assert np.abs(P2[:, :11] - P0[:, :11]).max() < 1e-9          # S1 (the lower body) unchanged


def _L_spread(body, motion, a, b):
    """Largest distance of L about the COM (segment spins included, the audit's) from its mean over
    the flight's inner frames."""
    from mocomp.dynamics.momentum import momentum

    h = momentum(body, motion).angular[a + 1:b - 1]
    return float(np.linalg.norm(h - h.mean(0), axis=1).max())


@pytest.mark.parametrize("spec", [dict(s2="all"), dict(s1="upper", s2="lower"), dict(s1="lower", s2="upper")])
def test_momentum_adjustment_evens_out_L(hop, spec):
    m, body, fl = hop
    cur = m
    for _ in range(3):
        adj = flight_momentum_adjustment(body, cur, link_sets(body, **spec), fl, neighbourhood=8)
        cur = cur.replace(root_positions=adj.root_positions, rotations=adj.rotations)
    assert _L_spread(body, cur, 40, 70) < 0.7 * _L_spread(body, m, 40, 70)
    assert np.allclose(cur.rotations[:40], m.rotations[:40]) and np.allclose(cur.root_positions[:40], m.root_positions[:40])


def test_real_jump_flight(real_data_dir):
    from mocomp import datasets

    m = datasets.load(real_data_dir / "jumps" / "sfu_0005_2FeetJump001.bvh").slice(0, 400)
    body = default_body(m)
    fl = stages(m).flight_runs
    from mocomp.audit import audit

    assert fl == [(105, 132), (310, 348)] == list(audit(m, body).phases.flights)   # the audit's flights
    ls = link_sets(body, s2="all")
    cur = m
    for _ in range(3):
        adj = flight_momentum_adjustment(body, cur, ls, fl, neighbourhood=15)
        cur = cur.replace(root_positions=adj.root_positions, rotations=adj.rotations)
    assert _L_spread(body, cur, 105, 132) < 0.5 * _L_spread(body, m, 105, 132)
    adj = flight_com_adjustment(body, cur, ls, fl, center_of_mass(body, cur), neighbourhood=15)
    out = cur.replace(root_positions=adj.root_positions, rotations=adj.rotations)
    for a, b in fl:
        assert com_residual(center_of_mass(body, out), a, b, m.fps) < 1e-6


def test_ballistic_completion_puts_the_com_on_the_parabola_and_leaves_ground_frames(hop):
    """The unsmoothed root translation after the flight steps (sec. 3.4.2, S1 empty): every
    flight's COM on the g parabola through its end points to rounding, the end frames and the
    ground frames untouched, the angular momentum about the COM unchanged (a translation)."""
    from mocomp.dynamics.momentum import momentum
    from mocomp.touchup.iterate import ballistic_completion

    m, body, fl = hop
    (a, b), = fl
    bent = m.root_positions.copy()
    bent[a:b, 1] += 0.05 * np.sin(np.linspace(0, np.pi, b - a))         # 5 cm off any parabola
    m2 = m.replace(root_positions=bent)
    c2 = center_of_mass(body, m2)
    assert com_residual(c2, a, b, m.fps) > 0.01
    out, shift = ballistic_completion(body, m2, fl)
    c = center_of_mass(body, out)
    # the walk's level COM is g T^2 / 8 above the parabola mid-flight (T = 0.48 s: 0.28 m), plus the bump
    T = (b - 1 - a) / m.fps
    assert com_residual(c, a, b, m.fps) < 1e-9 and 0.01 < shift < G_STANDARD * T ** 2 / 8 + 0.06
    ground = np.ones(m.n_frames, bool)
    ground[a + 1:b - 1] = False
    np.testing.assert_allclose(out.root_positions[ground], m2.root_positions[ground], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(out.rotations, m2.rotations)
    L0, L1 = momentum(body, m2).angular, momentum(body, out).angular
    np.testing.assert_allclose(L1[a + 2:b - 2], L0[a + 2:b - 2], atol=1e-9)
    same, s0 = ballistic_completion(body, m2, [])
    assert same is m2 and s0 == 0.0


def test_support_ramp_known_answer():
    """Constant support: second differences 1 from rest, so delta_k = (k-1) k / 2 and the last
    velocity is n - 1; no support in the middle: constant velocity there."""
    d, v = support_ramp(np.ones(6))
    np.testing.assert_allclose(d, [0, 0, 1, 3, 6, 10])
    assert v == 4
    d, v = support_ramp(np.array([1.0, 1.0, 0.0, 0.0, 1.0, 1.0]))
    np.testing.assert_allclose(np.diff(d), [0, 1, 1, 1, 2])


def test_continue_into_ground_joins_the_flight_smoothly_and_pushes_where_the_ground_pushes():
    """A 30-frame flight whose COM drifts sideways: the continued correction starts at rest where
    the neighbourhood begins, joins the flight with its velocity at take-off and landing (no velocity
    jump), keeps the flight a g parabola, and its acceleration on the push is in proportion to the
    vertical force (no acceleration on frames without support)."""
    fps, T, (a, b), nb = 60.0, 140, (60, 90), 25
    t = np.arange(T) / fps
    com = np.column_stack([0.9 * t, 1.0 - 0.5 * G_STANDARD * np.clip(t - a / fps, 0, None) * np.clip((b - 1) / fps - t, 0, None),
                           0.4 * np.sin(2.0 * t)])
    corr = np.zeros((T, 3))
    corr[a:b] = ballistic_targets(com, a, b, fps) - com[a:b]
    support = np.ones(T)
    support[a - 6:a] = 0.0                                     # the toes still touch, no force
    support[a - 20:a - 12] = 2.0
    out = continue_into_ground(corr, [(a, b)], support, nb)
    np.testing.assert_array_equal(out[:a - nb], 0.0)
    np.testing.assert_array_equal(out[b + nb:], 0.0)
    c = com + out
    np.testing.assert_allclose(np.diff(c[a:b], 2, axis=0) * fps ** 2, np.tile([0.0, -G_STANDARD, 0.0], (b - a - 2, 1)), atol=1e-9)
    v = np.diff(out, axis=0)
    # velocity of the correction: continuous into the flight (the frame before take-off has the flight's)
    np.testing.assert_allclose(v[a - 1], v[a], atol=1e-12)
    np.testing.assert_allclose(v[b - 1], v[b - 2], atol=1e-12)
    acc = np.diff(out[a - nb:a + 1], 2, axis=0)                # second differences on the push
    k = np.arange(a - nb + 1, a)
    ok = support[k] > 0
    ratio = acc[ok, 2] / support[k][ok]
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)       # one constant per component
    np.testing.assert_allclose(acc[~ok], 0.0, atol=1e-15)
    assert abs(ratio[0]) > 0
