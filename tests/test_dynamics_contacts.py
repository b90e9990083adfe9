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
