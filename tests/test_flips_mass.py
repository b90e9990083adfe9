"""Mass distribution from flight (eq. 5.1-5.2), gravity scale and its diagnosis."""
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp import datasets
from mocomp.core.motion import concatenate
from mocomp.core.rotations import quat_multiply
from mocomp.flips.mass import FlightTooShortError, diagnose_gravity, estimate_masses, fit_ballistic
from mocomp.flips.phases import default_prior, detect_flights
from mocomp.flips import multiflip, prepare
from mocomp.flips.preprocess import clip_prior, spline_resample

from _flips_data import synthetic


@pytest.fixture(scope="module")
def tall():
    """Synthetic flips of a "tall performer" (heavier trunk, lighter limbs) and the average prior."""
    out = {}
    for name in ("backflip", "sideflip"):
        r = synthetic(name, mass_factors="tall_performer")
        out[name] = (r, default_prior(r.motion.skeleton))
    return out


def noisy(motion, deg, mm, seed):
    rng = np.random.default_rng(seed)
    T, J, _ = motion.rotations.shape
    jit = Rotation.from_rotvec(rng.normal(scale=np.radians(deg), size=(T * J, 3))).as_quat().reshape(T, J, 4)
    return motion.replace(rotations=quat_multiply(motion.rotations, jit),
                          root_positions=motion.root_positions + rng.normal(scale=mm / 1000, size=(T, 3)))


@pytest.mark.parametrize("name", ["backflip", "sideflip"])
def test_exact_recovery_without_regulariser(tall, name):
    r, prior = tall[name]
    est = estimate_masses(prior, r.motion, r.flight, W=0.0, smooth=0.0)
    np.testing.assert_allclose(est.masses, r.body.masses, rtol=1e-6, atol=1e-6)
    assert est.residual_rms < 1e-9 and est.prior_residual_rms > 1e-3
    assert est.fits[0].gravity == pytest.approx(r.g, rel=1e-6)


@pytest.mark.parametrize("name", ["backflip", "sideflip"])
@pytest.mark.parametrize("noise", [(0.0, 0.0, 0), (0.3, 1.0, 0), (0.3, 1.0, 1), (0.3, 1.0, 2)])
def test_estimate_closer_to_truth_than_prior(tall, name, noise):
    r, prior = tall[name]
    m = noisy(r.motion, *noise) if noise[0] else r.motion
    est = estimate_masses(prior, m, r.flight)
    err, err0 = est.error_vs(r.body.masses)
    # measured err/err0: 0.936-0.938 (back flip), 0.954-0.957 (side flip) over these noise draws
    assert err <= 0.97 * err0, est.table(r.body.masses).to_string()
    tab = est.table(r.body.masses)
    assert {"initial_%", "optimized_%", "true_%", "initial_error_%", "optimized_error_%"} <= set(tab.columns)
    # the tall-performer pattern of the dissertation: trunk up, limbs down
    trunk = [i for i, s in enumerate(est.body.segment_names) if "trunk" in s]
    assert est.masses[trunk].sum() > prior.masses[trunk].sum()


def test_constraints_symmetry_sum_bounds(tall):
    r, prior = tall["backflip"]
    est = estimate_masses(prior, noisy(r.motion, 1.0, 3.0, 5), r.flight, W=1e-6)
    assert est.body.total_mass == pytest.approx(prior.total_mass)
    assert np.all(est.masses >= 0)
    for g in est.groups:
        assert np.ptp(est.masses[list(g)]) < 1e-12
    assert any(len(g) == 2 for g in est.groups)
    # inertias were recomputed for the new masses
    assert not np.allclose(est.body.inertias, prior.inertias)


def test_joint_estimation_over_two_flights(tall):
    r, prior = tall["backflip"]
    r2 = synthetic("straight_jump", mass_factors="tall_performer")
    m = concatenate([r.motion, r2.motion.translated(r.motion.root_positions[-1] - r2.motion.root_positions[0])])
    T1 = r.motion.n_frames
    flights = [r.flight, (r2.flight[0] + T1, r2.flight[1] + T1)]
    est = estimate_masses(prior, m, flights, W=0.0, smooth=0.0)
    np.testing.assert_allclose(est.masses, r.body.masses, rtol=1e-6, atol=1e-6)
    assert len(est.fits) == 2 and all(f.gravity == pytest.approx(r.g, rel=1e-6) for f in est.fits)
    assert est.fits[1].start == flights[1][0]


def test_gravity_scale_reveals_frame_rate_and_units(tall):
    r, prior = tall["backflip"]
    fast = r.motion.with_fps(240.0)                       # a 120 Hz capture stamped 240 Hz
    est = estimate_masses(prior, fast, r.flight)
    assert est.gravity_scale == pytest.approx(4.0, rel=0.06)     # the regularised masses are not exact
    assert "labelled 240 Hz" in est.diagnosis and "fps=120" in est.diagnosis
    slow = r.motion.with_fps(60.0)
    assert "fps=120" in estimate_masses(prior, slow, r.flight).diagnosis
    assert "consistent" in estimate_masses(prior, r.motion, r.flight).diagnosis
    assert "length unit" in diagnose_gravity(100.0, 120.0, height=175.0)
    assert "not a downward parabola" in diagnose_gravity(-0.5, 120.0)


def test_too_short_flight_is_a_clear_error(tall):
    r, prior = tall["backflip"]
    s = r.flight[0]
    with pytest.raises(FlightTooShortError, match="5 frames") as e:
        estimate_masses(prior, r.motion, (s, s + 5))
    assert "longer flight" in str(e.value)
    with pytest.raises(FlightTooShortError):
        fit_ballistic(np.zeros((3, 3)), 120.0)


REAL_FLIPS = [("cmu_88_01_backflip", None), ("cmu_88_05_cartwheel_backflip", None), ("cmu_90_08_sideflip", None),
              ("mass_backflip", 60.0), ("deepmimic_backflip", None), ("deepmimic_sideflip", None)]


def _real(name, fps):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name, fps=fps)
    if m.fps < 50:
        m = spline_resample(m, 120.0)
    return m


@pytest.mark.realdata
@pytest.mark.parametrize("name, fps", REAL_FLIPS)
def test_real_flights_momentum_deviation_reduced(real_data_dir, name, fps):
    """The paper reports a 30% reduction of the linear-momentum deviation from its ballistic
    pattern relative to the prior (section 4.2); with the default regulariser (no segment moved
    by more than ~5 points, where Table C.1 moves one by 2.6) ours is 16-39% on five of the six
    real flips, and a smaller W buys more reduction with implausible masses (the regularisation
    path, mass.py). On the side flip 90_08 the estimate makes it worse (-2.2%): ``prepare`` keeps
    the prior there and says so."""
    m = _real(name, fps)
    prior = clip_prior(m)
    d = detect_flights(m, prior)
    est = estimate_masses(prior, m, d.flight)
    if name == "cmu_90_08_sideflip":
        assert -0.05 < est.reduction <= 0.0, est.reduction             # measured -2.2 %
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            P = prepare(m)
        assert P.flight == d.flight and P.mass.reduction == pytest.approx(est.reduction)
        assert not P.mass_used and P.body is P.prior
        np.testing.assert_array_equal(P.body.masses, prior.masses)
        assert P.fit == next(f for f in P.mass.prior_fits if (f.start, f.stop) == P.flight)
        note = [n for n in P.notes if n.startswith("mass estimate not used")]
        assert len(note) == 1 and "-2.2% reduction" in note[0] and "prior masses are kept" in note[0]
        assert "prior masses used" in P.summary()
        assert note[0] in multiflip(P, flips=2).report.notes
        kept = prepare(m, keep_prior_if_worse=False)
        assert kept.mass_used and kept.body is kept.mass.body
        return
    assert est.reduction > 0.12, (est.prior_momentum_deviation, est.momentum_deviation)
    assert est.residual_rms < 0.8 * est.prior_residual_rms          # eq. 5.1's own objective
    change = 100 * np.abs(est.body.masses / est.body.total_mass - prior.masses / prior.total_mass)
    assert change.max() < 5.0
    loose = estimate_masses(prior, m, d.flight, W=3e-4)
    assert loose.reduction >= est.reduction - 0.02                   # smaller W: more reduction ...
    assert 100 * np.abs(loose.body.masses / loose.body.total_mass - prior.masses / prior.total_mass).max() \
        >= change.max()                                              # ... bought with larger shifts
    # MASS read at 60 Hz still gives s = 1.50 (its implied rate is ~49 Hz; MANIFEST: 50-60 Hz)
    assert 0.7 < est.gravity_scale < (1.55 if name == "mass_backflip" else 1.45)
    if name == "cmu_88_01_backflip":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            P = prepare(m)
        assert P.mass_used and P.body is P.mass.body
        assert not any(n.startswith("mass estimate not used") for n in P.notes)


@pytest.mark.realdata
def test_min_fraction_bounds_the_masses(real_data_dir):
    """At the default W the bound m_i >= 0 is active on 88_01 (forearms, hands, feet get 0 kg);
    ``min_fraction`` keeps each segment at that fraction of the prior for a small loss of
    reduction (measured 18.3 -> 15.1 % with 0.5)."""
    m = _real("cmu_88_01_backflip", None)
    prior = clip_prior(m)
    d = detect_flights(m, prior)
    free = estimate_masses(prior, m, d.flight)
    zero = [s for s, x in zip(free.body.segment_names, free.masses) if x < 1e-9]
    assert {"forearm_l", "forearm_r", "hand_l", "hand_r", "foot_l", "foot_r"} <= set(zero)
    half = estimate_masses(prior, m, d.flight, min_fraction=0.5)
    assert np.all(half.masses >= 0.5 * prior.masses * (1 - 1e-9))
    assert half.body.total_mass == pytest.approx(prior.total_mass)
    assert 0.12 < half.reduction < free.reduction
    with pytest.raises(ValueError, match="min_fraction"):
        estimate_masses(prior, m, d.flight, min_fraction=1.0)


@pytest.mark.realdata
def test_joint_estimation_over_ten_real_hops(real_data_dir):
    m = datasets.load("jumps/01_01.bvh")
    prior = clip_prior(m)
    d = detect_flights(m, prior)
    assert len(d.flights) == 10
    est = estimate_masses(prior, m, d.intervals)
    assert len(est.fits) == 10
    assert all(0.9 < f.scale < 1.12 for f in est.fits)
    assert est.momentum_deviation <= est.prior_momentum_deviation


def _fit(s, start=0, n=40, se=0.0):
    """A FlightFit with gravity scale ``s`` (only the fields the diagnosis reads matter)."""
    from mocomp.flips.mass import G, FlightFit

    return FlightFit(start, start + n, 0.0, 0.0, -s * G / 2, 2.0, 1.0, 0.0, 0.0, s * G, s, 0.0, 0.0, se)


def test_timing_diagnosis_combines_flights():
    from mocomp.flips.mass import diagnose_timing

    one = diagnose_timing([_fit(4.0)], 120.0, 1.75, turns=[1.0])          # a single flip, stamped 2x too fast
    many = diagnose_timing([_fit(4.0, 100 * i) for i in range(4)], 120.0, 1.75, turns=[1.0, 0.05, 0.05, 0.05])
    for d in (one, many):
        assert d.implied_fps == pytest.approx(60.0) and not d.consistent and d.suggested == 60.0
        assert d.implied_interval[0] < 60.0 < d.implied_interval[1]
        assert "labelled 120 Hz" in d.text and "fps=60" in d.text
    # the hops pin the rate down: a narrower interval than the flip alone
    assert np.ptp(many.implied_interval) < 0.5 * np.ptp(one.implied_interval)
    assert one.candidates[0] == 60.0 and 50.0 in one.candidates and "cannot tell them apart" in one.text
    assert many.candidates == (60.0,) and "the one common capture rate" in many.text
    # flights that disagree beyond their errors widen the interval (random effects)
    split = diagnose_timing([_fit(3.2, 0), _fit(5.0, 100)], 120.0, 1.75, turns=[0.05, 0.05])
    agree = diagnose_timing([_fit(4.0, 0), _fit(4.0, 100)], 120.0, 1.75, turns=[0.05, 0.05])
    assert split.tau > 0 and agree.tau == 0
    assert np.ptp(np.log(split.scale_interval)) > np.ptp(np.log(agree.scale_interval))
    # right rate: consistent, nothing suggested
    ok = diagnose_timing([_fit(1.02)], 120.0, 1.75)
    assert ok.consistent and ok.suggested is None and "consistent with 9.81" in ok.text
    # a rate between the common ones: said so, no relabelling
    odd = diagnose_timing([_fit(s) for s in (2.0, 2.02, 1.98)], 120.0, 1.75)
    assert odd.suggested is None and not odd.consistent and "no common capture rate" in odd.text
    assert "length unit" in diagnose_timing([_fit(30.0)], 120.0, 50.0).text


@pytest.mark.realdata
@pytest.mark.parametrize("name, truth", [("cmu_88_01_backflip", 60.0), ("cmu_88_05_cartwheel_backflip", 60.0),
                                         ("cmu_90_08_sideflip", 60.0), ("twists/cmu_83_58_hopturn270.bvh", 120.0),
                                         ("jumps/01_01.bvh", 120.0)])
def test_timing_diagnosis_on_real_clips_read_at_120_hz(real_data_dir, name, truth):
    """Every clip read at its header's 120 Hz: the true rate is among the consistent common
    rates; the 60 Hz captures are told to reload at 60 Hz, the 120 Hz ones left alone. All the
    clip's flights count (hops beside the flip)."""
    from mocomp.flips.preprocess import clip_timing

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name, fps=120.0)
    prior = clip_prior(m)
    d = detect_flights(m, prior)
    t = clip_timing(estimate_masses(prior, m, d.intervals).body, m, d.intervals)
    assert truth in t.candidates, t.text
    assert t.implied_interval[0] <= truth <= t.implied_interval[1]
    if truth == 120.0:
        assert t.consistent and t.suggested is None and "look right" in t.text
    else:
        assert not t.consistent and t.suggested == 60.0 and "labelled 120 Hz" in t.text and "fps=60" in t.text


@pytest.mark.realdata
def test_prepare_joint_flights_on_88_01(real_data_dir):
    """``prepare(joint_flights=True)``: the flip (47-78) and the hop (95-108) of CMU 88_01 share the
    masses (the same estimate as :func:`estimate_masses` over both), each has its own trajectory,
    and the flight used is still the flip's."""
    m = _real("cmu_88_01_backflip", None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        P = prepare(m, joint_flights=True)
    assert [(f.start, f.stop) for f in P.mass.fits] == [(47, 79), (95, 109)] and P.flight == (47, 79)
    assert P.fit == P.mass.fits[0] and P.mass_used
    ref = estimate_masses(P.prior, m, [(47, 79), (95, 109)])
    np.testing.assert_allclose(P.body.masses, ref.masses, rtol=1e-9)
    single = estimate_masses(P.prior, m, (47, 79))
    assert np.abs(P.body.masses - single.masses).max() > 0.05
