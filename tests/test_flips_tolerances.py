"""The multi-flip's outputs pinned by what matters, to tolerances that hold on any host.

These replace the SHA-256 hashes of ``tests/test_flips_bitexact.py``: floating-point bits are not a
portable contract (BLAS kernels, FMA, libm and the synthetic generator's shooting tolerance differ
between CPUs by ~1e-7 relative), and the hashes failed on every other x86-64 host. What is pinned
instead, for the same synthetic back/front/side flips and option paths:

* the chosen frames (loop ``m, n``, landing join ``f, g`` and its copy, the output flight) within
  +-2 frames of the values below (exact under 1e-7 input noise, see the perturbation tests);
* the rotation about ``L`` measured on the output motion (not the plan) against the request;
* ``|L|`` measured on the output by :func:`mocomp.dynamics.momentum`: its direction, its
  variation over the new flight and its level ``k |L_original|`` (eq. 5.8);
* the COM measured on the output against the eq. 5.15/5.17 parabola;
* the seams' effect on ``|L|`` (the report's profile deviation, each case's measured value plus
  a margin, far below a bad seam's 0.3-0.8: ``tests/test_flips_seamtime.py``);
* ``evaluate=True`` and ``False`` give the same motion (to 1e-12).

The choice of the loop and landing frames was ill-conditioned (a held tuck makes dozens of pairs
match to rounding) and is now a documented tie rule (:mod:`mocomp.flips.looping`,
:func:`mocomp.flips.sequence.find_landing`); the perturbation tests show 1e-7 noise (five seeds)
no longer moves it, and the known-answer tests that the rule picks what it says.
"""
import warnings

import numpy as np
import pytest

from mocomp import datasets
from mocomp.dynamics import center_of_mass, momentum
from mocomp.flips import multiflip, prepare
from mocomp.flips.looping import PHI_TOL, TIE_ATOL, _pick_loop, choose_tied, find_self_loop
from mocomp.flips.sequence import _pick_landing, build_sequence
from mocomp.flips.similarity import frame_distance, similarity_weights
from mocomp.flips.smoothing import split_root

from _flips_data import spinning_motion, synthetic
from _host_noise import perturb as _perturb

SYNTH = ("backflip", "frontflip", "sideflip")

# (name, options) -> (loop m, loop n, join f, join g, join copy, output flight); made with the tie
# rule; every case but "k_ratio=1.0" and "k=1.1" pins the paper's k = 0.7 k* path (k_ratio=0.7 given
# explicitly since the default became k = k*) (the same values under seeded 1e-7 perturbations of the input)
REFERENCE = {
    ("backflip", "flips=2"): (141, 173, 149, 173, 3, (122, 276)),
    ("backflip", "flips=3"): (141, 173, 158, 173, 5, (100, 288)),
    ("backflip", "flips=4"): (141, 173, 166, 173, 7, (87, 303)),
    ("frontflip", "flips=2"): (140, 172, 166, 172, 2, (127, 275)),
    ("frontflip", "flips=3"): (140, 172, 159, 172, 4, (107, 283)),
    ("frontflip", "flips=4"): (140, 172, 153, 172, 6, (94, 294)),
    ("sideflip", "flips=2"): (139, 150, 147, 150, 6, (125, 274)),
    ("sideflip", "flips=3"): (139, 150, 143, 150, 12, (104, 282)),
    ("sideflip", "flips=4"): (139, 150, 149, 150, 17, (91, 295)),
    ("backflip", "flips=2,seam_retime=False"): (141, 173, 149, 173, 3, (122, 276)),
    ("backflip", "flips=2,k_ratio=1.0"): (141, 173, 149, 173, 3, (85, 194)),
    ("backflip", "flips=3,height_change=-0.3,takeoff_height_change=0.2"): (141, 173, 158, 173, 5, (104, 300)),
    ("sideflip", "flips=None,extra_rotation=300deg"): (139, 150, 147, 150, 5, (130, 273)),
    ("frontflip", "flips=2,window=4"): (140, 172, 166, 172, 2, (127, 275)),
    ("backflip", "flips=2,k=1.1"): (141, 173, 149, 173, 3, (108, 245)),
}
OPTIONS = {
    "flips=2": dict(flips=2, k_ratio=0.7), "flips=3": dict(flips=3, k_ratio=0.7), "flips=4": dict(flips=4, k_ratio=0.7),
    "flips=2,seam_retime=False": dict(flips=2, seam_retime=False, k_ratio=0.7), "flips=2,k_ratio=1.0": dict(flips=2, k_ratio=1.0),
    "flips=3,height_change=-0.3,takeoff_height_change=0.2": dict(flips=3, height_change=-0.3,
                                                                 takeoff_height_change=0.2, k_ratio=0.7),
    "flips=None,extra_rotation=300deg": dict(flips=None, extra_rotation=np.deg2rad(300), k_ratio=0.7),
    "flips=2,window=4": dict(flips=2, window=4, k_ratio=0.7), "flips=2,k=1.1": dict(flips=2, k=1.1),
}
# Bounds: the measured value of every case plus a margin. Measured: L_profile_deviation_max
# 0.009-0.034; |L| coefficient of variation over the new flight 0.001-0.008; mean |L| / (k
# |L_original|) 0.992-1.004; L's largest angle to the clip's L 0.00 deg (back/front: planar) and
# 3.5 deg (side flip, whose seams are not exact: D ~ 0.12). The 300 degree side flip (a landing
# fragment turned by a non-whole number of turns) is worse: 0.29, 0.065, 1.10 and 4.6 deg.
# (profile max, cv, |ratio - 1|, direction degrees)
BOUNDS = {"backflip": (0.05, 0.02, 0.02, 0.05), "frontflip": (0.05, 0.02, 0.02, 0.05),
          "sideflip": (0.05, 0.02, 0.02, 4.5)}
BOUNDS_300 = (0.33, 0.08, 0.12, 5.5)


@pytest.fixture(scope="module")
def prepared():
    return {n: prepare(synthetic(n).motion) for n in SYNTH}




def _choices(P, flips=(2, 3)):
    out = [P.flight, (P.loop.m, P.loop.n)]
    for fl in flips:
        j = multiflip(P, flips=fl).sequence.join
        out.append((j.u, j.f, j.copy, j.g))
    return out


@pytest.mark.parametrize("case", list(REFERENCE), ids=lambda c: f"{c[0]}-{c[1]}")
def test_multiflip_meets_its_tolerances(prepared, case):
    name, opt = case
    P = prepared[name]
    kw = OPTIONS[opt]
    res = multiflip(P, evaluate=True, ease=0.0, **kw)     # the paper's uniform retiming (the reference's)
    R = res.report
    m, n, f, g, copy, flight = REFERENCE[case]
    # chosen frames within +-2 of the reference
    got = (P.loop.m, P.loop.n, res.sequence.join.f, res.sequence.join.g)
    assert np.all(np.abs(np.subtract(got, (m, n, f, g))) <= 2), (got, (m, n, f, g))
    assert abs(res.sequence.join.copy - copy) <= 1
    assert np.all(np.abs(np.subtract(res.flight, flight)) <= 2), (res.flight, flight)
    # rotation about L measured on the output: the original's plus the requested extra
    extra = kw["extra_rotation"] if kw.get("flips") is None else 2 * np.pi * (kw["flips"] - 1)
    theta_out, _ = split_root(np.asarray(res.motion.rotations)[:, 0], P.axis, ref=P.root_ref)
    turned = theta_out[-1] - theta_out[0]
    if "extra_rotation" in opt:
        # 300 degrees is not whole turns and L is horizontal: to land upright the body is turned a
        # further 60 degrees over the flight (the report's note), 720 in all
        assert any("not whole turns" in t and "59.9 deg" in t for t in R.notes)
        assert turned == pytest.approx(4 * np.pi, abs=np.deg2rad(0.5))
        assert R.rotation_error == pytest.approx(60.0, abs=0.5) and R.landing_orientation_error < 5.0
    else:
        assert turned == pytest.approx(P.total_rotation + extra, abs=np.deg2rad(0.5))
        assert abs(R.rotation_error) < 0.1 and R.landing_orientation_error < 1.0
    # L measured on the output: direction L, nearly constant in flight, level k |L_original| (eq. 5.8)
    prof, cv, level, direction = BOUNDS_300 if "extra_rotation" in opt else BOUNDS[name]
    a, b = res.flight
    L = momentum(P.body, res.motion).angular[a + 2:b - 2]
    mag = np.linalg.norm(L, axis=1)
    cos = (L @ P.axis) / mag
    assert np.degrees(np.arccos(np.clip(cos.min(), -1, 1))) < direction
    assert mag.std() / mag.mean() < cv
    assert mag.mean() == pytest.approx(R.k * P.L_stats["mean"], rel=level)
    assert R.L_profile_deviation_max < prof
    # the COM measured on the output follows the eq. 5.15/5.17 parabola
    com = center_of_mass(P.body, res.motion)[a:b]
    tt = np.arange(a, b) / P.fps - res.takeoff_seconds          # the flight is played at k (retime.TimeWarp)
    np.testing.assert_allclose(com, res.trajectory(tt), rtol=0, atol=1e-9)
    assert R.com_residual_max < 1e-9 and R.com_target_error < 1e-9
    assert res.trajectory.a_y == pytest.approx(-9.81 / 2, rel=1e-3)
    # the evaluation does not change the result
    plain = multiflip(P, evaluate=False, ease=0.0, **kw)
    np.testing.assert_allclose(plain.motion.root_positions, res.motion.root_positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(plain.motion.rotations, res.motion.rotations, rtol=0, atol=1e-12)
    assert plain.sequence.join == res.sequence.join


@pytest.mark.parametrize("name", ["backflip", "frontflip"])
def test_synthetic_choices_survive_1e_7_noise(prepared, name):
    """The held tuck of the synthetic flips makes ~200 loop pairs match to rounding; before the tie
    rule, five seeded 1e-7 perturbations gave loop starts 141-144 with periods 24-29 frames and
    landing frames 143-167 (back flip). Now none of them moves any choice."""
    ref = _choices(prepared[name])
    base = synthetic(name).motion
    for seed in range(5):
        assert _choices(prepare(_perturb(base, seed))) == ref, seed


@pytest.mark.realdata
def test_real_choices_survive_1e_7_noise(real_data_dir):
    """CMU 88_01 (a real back flip, whose best pair is unique by ~1 %): unchanged by 1e-7 noise."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = datasets.load("cmu_88_01_backflip")
        ref = _choices(prepare(base))
        assert ref[1] == (63, 73)
        for seed in range(3):
            assert _choices(prepare(_perturb(base, seed))) == ref, seed


# --- the tie rule on a case with a known answer ------------------------------------------------
AXIS = np.array([1.0, 0.0, 0.0])
FLIGHT = (40, 160)
PERIOD = 24
RATE = 2.5 * np.pi            # 90 degrees per pose period


@pytest.fixture(scope="module")
def periodic():
    """Joint angles exactly periodic (24 frames) through the whole flight, a constant rotation
    rate: every pair a whole number of periods apart matches exactly (D is rounding noise)."""
    m = spinning_motion(T=200, flight=FLIGHT, rate=RATE, period=PERIOD)
    return m, similarity_weights(m.skeleton)


def _loop(m, w):
    theta, _ = split_root(np.asarray(m.rotations)[:, 0], AXIS)
    return theta, find_self_loop(m.rotations, theta, FLIGHT, AXIS, w)


def test_loop_tie_rule_known_answer(periodic):
    """Candidate frames 52..147 (10 % margins). Exact pairs are 24, 48 or 72 frames apart (90, 180,
    270 degrees; 96 frames do not fit): the largest phi is 72 frames, m in 52..75; nearest the
    flight's middle (m + n = 199) are m = 63 and 64 (|2m + 72 - 199| = 1), the earliest is 63."""
    m, w = periodic
    theta, loop = _loop(m, w)
    assert (loop.m, loop.n) == (63, 135)
    assert loop.phi == pytest.approx(np.deg2rad(270), abs=1e-9) and loop.distance < 1e-9
    assert tuple(loop.candidates[0, :2]) == (63, 135)          # the chosen pair comes first
    for seed in range(5):
        _, lp = _loop(_perturb(m, seed), w)
        assert (lp.m, lp.n) == (63, 135), seed


def test_landing_tie_rule_known_answer(periodic):
    """Every join a whole number of periods from ``g`` matches exactly with zero twist mismatch;
    the rule then takes the earliest cut ``u`` (and, for it, the earliest ``g``)."""
    m, w = periodic
    theta, loop = _loop(m, w)
    for flips in (2, 3):
        seq = build_sequence(m.rotations, theta, FLIGHT, loop, AXIS, w, flips=flips)
        j = seq.join
        assert j.distance < 1e-9 and abs(j.delta) < 1e-9
        # brute force over the candidate pairs: the exact ones, and the earliest cut among them
        extra = 2 * np.pi * (flips - 1)
        P = loop.period
        u = np.arange((seq.r + 1) * P)
        src, cp = loop.m + u % P, u // P
        best = None
        for g in range(loop.n, FLIGHT[1] - 1):
            d = theta[src] + cp * loop.phi - theta[g] - extra
            for uu in np.flatnonzero(np.abs(d) < 1e-9):
                D, _ = frame_distance(m.rotations[src[uu]], m.rotations[g], AXIS, w)
                if D < 1e-9 and (best is None or (uu, g) < best):
                    best = (int(uu), g)
        assert (j.u, j.g) == best
        for seed in range(3):
            mp = _perturb(m, seed)
            th, lp = _loop(mp, w)
            jp = build_sequence(mp.rotations, th, FLIGHT, lp, AXIS, w, flips=flips).join
            assert (jp.u, jp.g) == (j.u, j.g), seed


def test_ties_never_override_a_better_cost():
    """The rule only acts between costs equal to within the tolerance: a pair better by more wins
    even with a smaller phi or farther from the apex; within it the larger phi wins."""
    wsum = 5.0
    tol = TIE_ATOL * wsum
    cost = np.array([0.10, 0.10 + 0.2 * tol, 0.10 + 5 * tol, 0.09])
    phi = np.array([2.0, 2.5, 3.0, 1.2])
    mi = np.array([10, 12, 11, 30])
    ni = np.array([40, 45, 50, 44])
    assert _pick_loop(cost, phi, mi, ni, np.arange(4), wsum, 60) == 3             # strictly best
    assert _pick_loop(cost, phi, mi, ni, np.arange(3), wsum, 60) == 1             # tied: larger phi
    phi2 = np.array([2.5, 2.5 + 0.5 * PHI_TOL, 3.0, 1.2])
    assert _pick_loop(cost, phi2, mi, ni, np.arange(3), wsum, 50) == 0            # then nearest the apex
    assert list(choose_tied(np.array([np.nan, 1.0, 1.0 + 1e-5, 1.1]), 1.0)) == [1, 2]
    # the landing: D first, then |delta|, then the earliest u, then the earliest g
    D = np.array([0.5, 0.5 + 0.1 * tol, 0.5, 0.4 + 0.0])
    delta = np.array([0.02, -0.01, 0.01, 0.05])
    u = np.array([5, 9, 7, 3])
    g = np.array([40, 41, 40, 42])
    assert _pick_landing(D, delta, u, g, wsum) == 3
    assert _pick_landing(D[:3], delta[:3], u[:3], g[:3], wsum) == 2
    assert _pick_landing(D[:3], np.abs(delta[:3]) * 0 + 0.01, u[:3], g[:3], wsum) == 0


# --- former bit-for-bit checks, now to 1e-12 -----------------------------------------------------
def test_trajectory_end_is_the_call_at_T_new():
    from mocomp.flips.reposition import flight_trajectory

    rng = np.random.default_rng(4)
    for _ in range(50):
        c0, (ax, az, ay, k, vy, T) = rng.normal(size=3), rng.normal(size=6)
        tr = flight_trajectory(c0, ax, az, -abs(ay), abs(k) + 0.3, vy, abs(T) + 0.1)
        ref = tr(np.array([tr.T_new]))[0]
        np.testing.assert_allclose(tr.end, ref, rtol=1e-12, atol=1e-12)


def test_compiled_reposition_equals_the_numpy_steps():
    from mocomp.flips._kernels import AVAILABLE, reposition_nb
    from mocomp.flips.reposition import flight_trajectory

    if not AVAILABLE:
        pytest.skip("numba not available")
    P = prepare(datasets.load("backflip"))
    rng = np.random.default_rng(7)
    n_seq, N = 60, 80
    rp = rng.normal(size=(n_seq, 3))
    tau = np.sort(rng.uniform(0, n_seq - 1, N))
    i0 = np.minimum(np.floor(tau).astype(int), n_seq - 2)
    al = tau - i0
    tw = tau * 1.01
    rot_out = np.ascontiguousarray(P.rotations[rng.integers(0, P.rotations.shape[0], N)])
    traj = flight_trajectory(rng.normal(size=3), 0.3, -0.2, -4.9, 0.9, 3.0, 1.2)
    f0, f1, w_to, div = 10, 70, 9.5, 0.9 * 120.0
    r0 = rp[i0]
    ref = r0 + al[:, None] * (rp[i0 + 1] - r0)
    ref[f0:f1] = traj((tw[f0:f1] - w_to) / div) - P.com_eval.relative_numpy(rot_out[f0:f1])
    got, finite = reposition_nb(rp, i0, al, tw, f0, f1, w_to, div, traj, rot_out, P.com_eval)
    assert finite
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    # a wrong interpolation weight is seen
    bad, _ = reposition_nb(rp, i0, al * 0.999, tw, f0, f1, w_to, div, traj, rot_out, P.com_eval)
    assert np.abs(bad[:f0] - ref[:f0]).max() > 1e-6
    rp[i0[3], 1] = np.inf
    with np.errstate(invalid="ignore"):              # inf - inf, as intended (plain Python with the JIT off)
        assert not reposition_nb(rp, i0, al, tw, f0, f1, w_to, div, traj, rot_out, P.com_eval)[1]
