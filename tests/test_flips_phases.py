"""Ballistic phase detection (flips paper section 4.1): synthetic truth and every real flip/jump."""
import warnings

import numpy as np
import pytest

from mocomp import datasets
from mocomp.errors import NoFlightPhaseError
from mocomp.flips.phases import detect_flights
from mocomp.flips.preprocess import clip_prior, spline_resample

from _flips_data import spinning_motion, synthetic

GENERATORS = ["backflip", "frontflip", "sideflip", "twist180", "twist360", "jump"]


@pytest.mark.parametrize("name", GENERATORS)
def test_synthetic_flight_found_within_two_frames(name):
    r = synthetic(name)
    # with the true masses and with the average prior (the paper's choice, section 4.1)
    for prior in (r.body, None):
        d = detect_flights(r.motion, prior)
        s, e = d.flight
        assert abs(s - r.flight[0]) <= 2 and abs(e - r.flight[1]) <= 2, (name, (s, e), r.flight)
        assert len(d.flights) == 1
        f = d.flights[0]
        assert f.gravity == pytest.approx(r.g, rel=0.02)


def test_no_flight_is_a_clear_error():
    m = spinning_motion()
    still = m.replace(root_positions=np.zeros_like(m.root_positions), rotations=np.repeat(m.rotations[:1], m.n_frames, 0))
    from mocomp.body import BodyModel
    from mocomp.core import Skeleton

    d = detect_flights(still, com=np.zeros((m.n_frames, 3)),
                       effectors={"foot": ("LeftFoot", (0, 0, 0)), "hand": ("RightHand", (0, 0, 0))})
    with pytest.raises(NoFlightPhaseError, match="no flight phase found"):
        d.flight


# Real clips: (name, expected flight frames of the motion as loaded, tolerance in frames).
# Expected ranges are the data MANIFEST's (file frames minus the dropped T-pose frame for
# cgspeed CMU files); tolerances cover its different border rule (every joint 5 cm above the
# floor, which comes a few frames after the end of the push).
REAL_FLIPS = [
    ("cmu_88_01_backflip", (48, 80), 3),
    ("cmu_88_05_cartwheel_backflip", (58, 96), 3),
    ("cmu_90_08_sideflip", (206, 233), 3),
    ("cmu_83_58_hopturn270", (153, 198), 7),
    ("mass_backflip", (45, 78), 3),
]


@pytest.mark.realdata
@pytest.mark.parametrize("name, expected, tol", REAL_FLIPS)
def test_real_flips_and_twist(real_data_dir, name, expected, tol):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name)
    d = detect_flights(m, clip_prior(m))
    s, e = d.flight
    assert abs(s - expected[0]) <= tol and abs(e - expected[1]) <= tol, (name, (s, e), expected)


@pytest.mark.realdata
@pytest.mark.parametrize("name, duration", [("deepmimic_backflip", (0.38, 0.6)), ("deepmimic_sideflip", (0.33, 0.5))])
def test_real_keyframed_flips_after_resampling(real_data_dir, name, duration):
    m = datasets.load(name)
    assert m.fps == 16.0
    r = spline_resample(m, 120.0)
    d = detect_flights(r, clip_prior(r))
    s, e = d.flight
    assert duration[0] <= (e - s) / r.fps <= duration[1]
    # the flight is the flip: the root's orientation path in it is longer than half a turn
    # (measured 190 / 183 deg) and the net rotation from take-off to landing, at most 180 deg by
    # construction (angle of one relative rotation), is close to it (measured 172 / 179 deg)
    from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
    from mocomp.flips.mass import flight_turns

    turn = np.degrees(quat_angle(quat_multiply(r.rotations[e - 1, 0], quat_inverse(r.rotations[s, 0]))))
    assert turn > 150
    assert 360 * flight_turns(r, [(s, e)])[0] > 180


# jump clips: (name, number of flights, flight duration range s, gravity range)
REAL_JUMPS = [
    ("jumps/01_01.bvh", 10, (0.3, 0.45), (8.5, 11.0)),
    ("jumps/01_01.amc", 10, (0.3, 0.45), (8.5, 11.0)),
    ("sfu_0005_2FeetJump001", 24, (0.14, 0.5), (9.2, 10.4)),
    ("sfu_0005_JumpRope001", 13, (0.25, 0.42), (9.3, 10.1)),
    ("131_03", 1, (0.2, 0.32), (8.5, 10.5)),
    ("deepmimic_jump", 1, (0.4, 0.5), (9.3, 10.1)),
]


@pytest.mark.realdata
@pytest.mark.parametrize("name, count, duration, gravity", REAL_JUMPS)
def test_real_jumps(real_data_dir, name, count, duration, gravity):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name)
    d = detect_flights(m, clip_prior(m))
    good = [f for f in d.flights if duration[0] <= f.n_frames / m.fps <= duration[1]
            and gravity[0] <= f.gravity <= gravity[1]]
    assert len(good) == count, [(f.start, f.stop, f.n_frames / m.fps, f.gravity) for f in d.flights]
    longest = d.flights[d.longest]
    assert longest in good


@pytest.mark.realdata
def test_jump_and_roll_dive_is_found(real_data_dir):
    m = datasets.load("sfu_0017_JumpAndRoll001")
    d = detect_flights(m, clip_prior(m))
    f = d.flights[d.longest]
    assert 0.35 <= f.n_frames / m.fps <= 0.6 and 9.3 <= f.gravity <= 10.3
    # the two jumps are kept; short "flights" in the rolls (gravity 4-5 m/s^2) are not free flight:
    # one clip has one frame rate, so its flights must share one gravity
    assert len(d.flights) == 2 and all(9.3 <= g.gravity <= 10.3 for g in d.flights)
    assert sum("disagrees with the clip's other flights" in r[2] for r in d.rejected) == 2
    assert len(detect_flights(m, clip_prior(m), agree_factor=None).flights) == 4


@pytest.mark.realdata
@pytest.mark.parametrize("name, flights", [("kicks_punches/deepmimic_spinkick.txt", [(33, 56)]),
                                           ("kicks_punches/sfu_0017_WushuKicks001.bvh", [(1891, 1941), (2084, 2124)])])
def test_airborne_kicks_are_found(real_data_dir, name, flights):
    """The jumping kicks of the data set (MANIFEST: spin kick flight 0.40 s; wushu airborne kicks
    at frames ~1891-1941 and ~2084-2124 by its 'every joint 5 cm up' rule)."""
    m = datasets.load(name)
    d = detect_flights(m, clip_prior(m))
    assert len(d.flights) == len(flights)
    for f, (a, b) in zip(d.flights, flights):
        assert abs(f.start - a) <= 5 and abs(f.stop - b) <= 5 and 9.3 <= f.gravity <= 10.3


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["deepmimic_cartwheel", "sfu_0007_Cartwheel001", "bandai2_walk_normal_001"])
def test_hand_supported_or_walking_has_no_flight(real_data_dir, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name)
    d = detect_flights(m, clip_prior(m))
    with pytest.raises(NoFlightPhaseError):
        d.flight
