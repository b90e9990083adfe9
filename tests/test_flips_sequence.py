"""Self-looping search (eq. 5.9), the repetition count r and sequencing (eq. 5.10-5.11)."""
import numpy as np
import pytest

from mocomp.errors import PhysicsError
from mocomp.flips.looping import find_self_loop
from mocomp.flips.sequence import build_sequence, loop_count
from mocomp.flips.similarity import similarity_weights
from mocomp.flips.smoothing import split_root

from _flips_data import spinning_motion

AXIS = np.array([1.0, 0.0, 0.0])
FLIGHT = (40, 160)
PERIOD = 24
RATE = 2.5 * np.pi        # 90 deg per pose period at 120 fps: 360 deg is 4 periods


@pytest.fixture(scope="module")
def clip():
    m = spinning_motion(T=200, flight=FLIGHT, rate=RATE, period=PERIOD)
    theta, _ = split_root(m.rotations[:, 0], AXIS)
    w = similarity_weights(m.skeleton)
    loop = find_self_loop(m.rotations, theta, FLIGHT, AXIS, w)
    return m, theta, w, loop


def test_loop_count_paper_example():
    # section 5.2: double flip, phi ~ 3 pi / 4, phi_S ~ phi_E ~ pi / 2 -> "repeat four times"
    assert loop_count(2 * 2 * np.pi, np.pi / 2, np.pi / 2, 3 * np.pi / 4) == 4
    assert loop_count(3 * 2 * np.pi, np.pi / 2, np.pi / 2, 3 * np.pi / 4) == 7
    with pytest.raises(ValueError):
        loop_count(4 * np.pi, 0, 0, 0.0)


def test_self_loop_found_exactly(clip):
    m, theta, w, loop = clip
    assert loop.found
    assert (loop.n - loop.m) % PERIOD == 0
    assert loop.distance == pytest.approx(0.0, abs=1e-9)
    assert loop.phi == pytest.approx(RATE * (loop.n - loop.m) / m.fps, abs=1e-9)
    assert np.degrees(loop.phi) >= 60
    lo = FLIGHT[0] + int(np.ceil(0.1 * (FLIGHT[1] - FLIGHT[0])))
    assert lo <= loop.m < loop.n <= FLIGHT[1] - 1 - (lo - FLIGHT[0])


def test_no_flip_is_a_clear_error():
    m = spinning_motion(rate=0.2)       # 0.2 rad/s: barely turning
    theta, _ = split_root(m.rotations[:, 0], AXIS)
    with pytest.raises(PhysicsError, match="not a flip"):
        find_self_loop(m.rotations, theta, FLIGHT, AXIS, similarity_weights(m.skeleton))


def test_fallback_when_nothing_is_similar():
    from scipy.spatial.transform import Rotation

    m = spinning_motion()
    rot = np.array(m.rotations)
    k = m.skeleton.index("LeftLeg")                    # a knee that keeps extending: no frame repeats
    ramp = np.linspace(0.0, 2.5, m.n_frames)
    rot[:, k] = (Rotation.from_quat(rot[:, k]) * Rotation.from_rotvec(np.outer(ramp, [1, 0, 0]))).as_quat()
    theta, _ = split_root(rot[:, 0], AXIS)
    w = similarity_weights(m.skeleton)
    loop = find_self_loop(rot, theta, FLIGHT, AXIS, w, max_mean_angle=1.0)
    assert not loop.found and "section 5.2" in loop.note and loop.mean_angle_deg > 1.0
    assert loop.phi >= np.deg2rad(60)


@pytest.mark.parametrize("flips", [2, 3, 4])
def test_sequence_total_rotation_and_count(clip, flips):
    m, theta, w, loop = clip
    seq = build_sequence(m.rotations, theta, FLIGHT, loop, AXIS, w, flips=flips)
    th = theta[seq.frames] + seq.extra
    orig = theta[-1] - theta[0]
    # the whole clip turns by its own rotation plus (flips - 1) full turns: it lands as it took off
    assert th[-1] - th[0] == pytest.approx(orig + 2 * np.pi * (flips - 1), abs=1e-9)
    assert seq.target == pytest.approx(orig + 2 * np.pi * (flips - 1))
    # exact periodic data: the landing join is exact and needs no twist correction
    assert seq.join.distance == pytest.approx(0.0, abs=1e-9)
    assert seq.join.delta == pytest.approx(0.0, abs=1e-9)
    assert (seq.join.f - seq.join.g) % PERIOD == 0
    # 360 deg = 4 loop periods of 90 deg: (flips - 1) turns add exactly 4 (flips - 1) periods
    periods_per_turn = round(2 * np.pi / (RATE * PERIOD / m.fps))
    assert seq.n_frames == m.n_frames + (flips - 1) * periods_per_turn * PERIOD
    # rotation about L is continuous: no step larger than one frame's turn
    step = RATE / m.fps
    assert np.max(np.abs(np.diff(th))) == pytest.approx(step, rel=1e-6)
    # the paper's r: F_new holds F_B and r rotated copies; the join falls in the last two
    phi_S, phi_E = theta[loop.m] - theta[0], theta[-1] - theta[loop.n]
    assert seq.r == loop_count(2 * np.pi * flips + (orig - 2 * np.pi), phi_S, phi_E, loop.phi)
    assert seq.join.copy in (seq.r - 1, seq.r)
    # the join: f (copy c) has turned exactly the requested extra beyond g
    c = seq.join.copy
    assert theta[seq.join.f] + c * loop.phi - theta[seq.join.g] == pytest.approx(2 * np.pi * (flips - 1), abs=1e-9)
    # repetitions never duplicate the matched frame: inside the copies the source frame
    # advances by one or wraps from n-1 to m
    src = seq.frames[loop.m:seq.landing_seam + 1]
    d = np.diff(src)
    assert set(np.unique(d)) <= {1, loop.m - (loop.n - 1)}
    assert seq.loop_seams == tuple(loop.m + j * loop.period - 1 for j in range(1, c + 1))
    assert seq.takeoff == FLIGHT[0] and seq.landing == seq.landing_seam + (FLIGHT[1] - 1 - seq.join.g)


def test_bad_flip_counts(clip):
    m, theta, w, loop = clip
    for bad in (1, 0, 2.5, None):
        with pytest.raises(ValueError):
            build_sequence(m.rotations, theta, FLIGHT, loop, AXIS, w, flips=bad)
    with pytest.raises(ValueError):
        build_sequence(m.rotations, theta, FLIGHT, loop, AXIS, w, extra_rotation=-1.0)


def test_extra_rotation_for_twists(clip):
    m, theta, w, loop = clip
    seq = build_sequence(m.rotations, theta, FLIGHT, loop, AXIS, w, extra_rotation=np.pi / 2)
    th = theta[seq.frames] + seq.extra
    assert th[-1] - th[0] == pytest.approx(theta[-1] - theta[0] + np.pi / 2, abs=1e-9)
    assert seq.n_frames == m.n_frames + PERIOD
