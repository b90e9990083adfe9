"""Contact labels and airborne intervals."""
import numpy as np
import pytest

from dyn_helpers import _stick_skeleton
from mocomp.core import Motion
from mocomp.dynamics import airborne_intervals, detect_contacts
from mocomp.dynamics.contacts import label_intervals


def _hops(fps=120.0, n_hops=3, flight=0.4, stance=0.5):
    """A rigid standing pose doing vertical ballistic hops; flights are known exactly."""
    sk = _stick_skeleton()
    flights = []
    g = 9.81
    T_total = n_hops * (flight + stance) + stance
    n = int(round(T_total * fps)) + 1
    times = np.arange(n) / fps
    y = np.zeros(n)
    for k in range(n_hops):
        t0 = stance + k * (flight + stance)
        inside = (times > t0) & (times < t0 + flight)
        tau = times[inside] - t0
        y[inside] = 0.5 * g * tau * (flight - tau)
        flights.append((t0, t0 + flight))
    rest = sk.rest_positions(include_end_sites=True)  # root at its offset
    root = np.repeat(sk.offsets[:1], n, axis=0)
    root[:, 1] += y - rest[:, 1].min()  # lowest point (toe tips) on y = 0 between hops
    rot = np.zeros((n, sk.n_joints, 4))
    rot[..., 3] = 1
    return Motion(sk, fps, root, rot), flights


def test_label_intervals():
    assert label_intervals(np.array([0, 1, 1, 0, 1], bool)) == [(1, 3), (4, 5)]
    assert label_intervals(np.zeros(3, bool)) == []


def test_hops_give_known_flights():
    m, flights = _hops()
    c = detect_contacts(m)
    assert c.ground_y == pytest.approx(0.0, abs=1e-9)  # the toe tips
    air = airborne_intervals(c, min_frames=3)
    assert len(air) == len(flights)
    # airborne while the feet are more than height_tol = 5 cm up: g tau (T - tau) / 2 = 0.05
    T = flights[0][1] - flights[0][0]
    tau = (T - np.sqrt(T * T - 4 * 0.05 * 2 / 9.81)) / 2
    for (a, b), (t0, t1) in zip(air, flights):
        assert abs(a / m.fps - (t0 + tau)) <= 1.01 / m.fps and abs(b / m.fps - (t1 - tau)) <= 1.01 / m.fps
    # hands never touch; feet are planted between hops
    assert not c.labels[:, c.effectors.index("hand_l")].any()
    assert c.labels[: int(0.4 * m.fps), c.effectors.index("foot_l")].all()
    # planted is stricter than touching
    assert np.all(c.labels <= c.touching)
    assert len(airborne_intervals(c, use="planted")) == len(flights)
    with pytest.raises(ValueError):
        airborne_intervals(c, use="flying")


def test_custom_effectors_and_bad_input():
    m, _ = _hops(n_hops=1)
    c = detect_contacts(m, effectors=["LeftFoot", "RightToeBase_end"])
    assert c.effectors == ("LeftFoot", "RightToeBase_end")
    c2 = detect_contacts(m, effectors={"heel": ("LeftFoot", (0, -0.05, -0.03))})
    assert c2.positions.shape == (m.n_frames, 1, 3)
    with pytest.raises(Exception, match="neither a joint nor an end site"):
        detect_contacts(m, effectors=["Tail"])
    with pytest.raises(ValueError):
        detect_contacts(m, height_tol=0)


@pytest.mark.realdata
@pytest.mark.parametrize("clip, n_flights, first", [
    ("jumps/01_01.bvh", 10, None),
    ("twists/cmu_83_58_hopturn270.bvh", 1, (153, 198)),  # MANIFEST: one 0.375 s flight
    ("flips/cmu_88_01_backflip.bvh", 2, (47, 80)),  # main flight (MANIFEST frames 49-80 incl. T-pose) + a small hop
    ("walks/sfu_0008_Walking002.bvh", 0, None),
    ("walks/bandai2_walk_normal_001.bvh", 0, None),
])
def test_real_clip_flights(real_data_dir, clip, n_flights, first):
    from mocomp.datasets import load

    m = load(real_data_dir / clip)
    air = airborne_intervals(detect_contacts(m), min_frames=3)
    assert len(air) == n_flights
    if first is not None:
        a, b = air[0]
        assert abs(a - first[0]) <= 3 and abs(b - first[1]) <= 3


# ------------------------------------------------------------------ several support levels
_NAMES = {"LeftFoot": "foot_l", "RightFoot": "foot_r", "LeftToeBase": "toe_l", "RightToeBase": "toe_r"}


def _levels_case(kind, takeoff_level, landing_level):
    from mocomp.synth import backflip, straight_jump

    gen = {"jump": straight_jump, "backflip": backflip}[kind]
    return gen(takeoff_level=takeoff_level, landing_level=landing_level)


def _level_ground_toe_height(kind) -> float:
    c = detect_contacts(_levels_case(kind, 0.0, 0.0).motion)
    return c.ground_y + c.support_levels["toe_l"][0]


@pytest.mark.parametrize("kind, takeoff_level, landing_level", [
    ("jump", 0.3, 0.0),       # take-off from a box (was: airborne from frame 0, agreement 0.63)
    ("jump", 0.0, 0.3),       # landing on a step (was: airborne until frame 306)
    ("backflip", 0.0, 0.4),
    ("backflip", 0.4, 0.0),
])
def test_take_off_and_landing_on_different_levels(kind, takeoff_level, landing_level):
    r = _levels_case(kind, takeoff_level, landing_level)
    c = detect_contacts(r.motion)
    for joint, truth in r.contacts.items():
        e = c.effectors.index(_NAMES[joint])
        assert (c.labels[:, e] == truth).mean() > 0.97, joint
    air = airborne_intervals(c, min_frames=3)
    assert len(air) == 1
    (a, b), (ta, tb) = air[0], r.flight
    assert ta <= a <= ta + 5 and tb - 5 <= b <= tb
    # the toes rest on two floors 0.3-0.4 m apart: both found, at the generator's levels
    lv = c.support_levels["toe_l"]
    assert len(lv) == 2
    assert lv[1] - lv[0] == pytest.approx(abs(landing_level - takeoff_level), abs=2e-3)
    # the toe tip rests tip_h above the floor it stands on (as on level ground)
    tip_h = _level_ground_toe_height(kind)
    assert c.ground_y + lv[0] == pytest.approx(min(takeoff_level, landing_level) + tip_h, abs=2e-3)
    # each contact frame says which level it touches: the take-off level before, the landing level after
    e = c.effectors.index("toe_l")
    assert c.contact_levels[: r.flight[0] - 10, e] + c.ground_y == pytest.approx(takeoff_level + tip_h, abs=2e-3)
    assert c.contact_levels[r.flight[1] + 10:, e] + c.ground_y == pytest.approx(landing_level + tip_h, abs=2e-3)
    assert np.isnan(c.contact_levels[a:b]).all()
    # hands hang still above the feet during the stand: never a support level
    assert c.support_levels["hand_l"] == () and not c.touching[:, c.effectors.index("hand_l")].any()
    assert any("several support levels" in n for n in c.notes)


def test_level_ground_keeps_the_single_floor_rule():
    """On one floor the labels are exactly the single-level rule (touching within height_tol
    of the effector's 1st-percentile height, planted if also slow)."""
    from mocomp.synth import make_example

    for name in ("jump", "backflip", "twist360"):
        m = make_example(name).motion
        c = detect_contacts(m)
        old_levels = np.percentile(c.heights, 1, axis=0)
        touching = (c.heights <= old_levels + c.height_tol) & (old_levels <= 0.2)[None]
        from mocomp.dynamics.contacts import _drop_short

        labels = touching & (c.speeds <= c.speed_tol)
        for arr in (labels, touching):
            for e in range(arr.shape[1]):
                arr[:, e] = _drop_short(_drop_short(arr[:, e], False, 2), True, 2)
        assert np.array_equal(c.touching, touching) and np.array_equal(c.labels, labels), name
        assert all(len(v) <= 1 for v in c.support_levels.values())
        np.testing.assert_allclose(c.levels, old_levels)


def test_a_limb_passing_the_landing_height_in_flight_does_not_touch():
    """Landing 0.3 m up: the toes rise through 0.25-0.35 m early in the flight; that band
    holds no rest until after touchdown, so it is not a contact."""
    r = _levels_case("jump", 0.0, 0.3)
    c = detect_contacts(r.motion)
    e = c.effectors.index("toe_l")
    a, b = r.flight
    apex = int(np.argmax(c.heights[a:b, e]))
    rising = np.flatnonzero(np.abs(c.heights[a:a + apex, e] + c.ground_y - 0.3) <= c.height_tol)
    assert rising.size > 0                                   # it does pass that height
    assert np.all(c.heights[a + rising, e] + c.ground_y > 0.2)   # far above the take-off floor
    assert not c.touching[a + rising, e].any()
