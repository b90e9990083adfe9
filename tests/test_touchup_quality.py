"""Issue 16's quality acceptance on the paper's four edited cases, measured on the BVH written and
read back: per-frame rise of the ZMP distance outside the contact polygon against the input's
measurement noise (:func:`mocomp.touchup.examples.zmp_rise`), footplant slide, flight COM on the
g = 9.81 parabola. What holds is asserted as it is; where the criterion is not met (the curved
hop's last push frames, one uphill frame whose toe contact flips) the test pins where and how large
the miss is, so that a change that moves or widens it fails."""
import numpy as np
import pytest

from mocomp.ops.synthetic import synthetic_walk
from mocomp.touchup import touchup
from mocomp.touchup.examples import ZmpRise, zmp_rise


def _written(m, tmp_path, name):
    from mocomp.io import read_bvh, write_bvh

    p = tmp_path / f"{name}.bvh"
    write_bvh(m, p)
    return read_bvh(p)


def test_zmp_rise_of_a_motion_against_itself_and_moved_is_zero():
    """Known answers: a motion against itself rises nowhere; moved 0.4 m across the floor (support
    polygon and ZMP move with it) it rises nowhere either; the noise is the input's, >= 0, finite
    where the distance is."""
    m = synthetic_walk(duration=2.0, fps=60).motion
    z = zmp_rise(m, m)
    ok = np.isfinite(z.input)
    assert ok.sum() > 0.5 * m.n_frames
    np.testing.assert_array_equal(z.rise[ok], 0.0)
    assert z.above.size == 0 and np.all(z.noise[ok] >= 0)
    moved = m.replace(root_positions=m.root_positions + [0.4, 0.0, -0.3])
    np.testing.assert_allclose(zmp_rise(m, moved).rise[ok], 0.0, atol=1e-9)


def test_zmp_rise_flags_a_frame_pushed_out_and_errors():
    """A frame whose rise exceeds the noise by more than tol is listed; a frame-count mismatch is
    an error naming both counts."""
    d0 = np.array([0.0, 0.01, np.nan, 0.02])
    z = ZmpRise(d0, np.array([0.0, 0.05, np.nan, 0.021]), np.array([0.0, 0.01, np.nan, 0.0]), 0.005)
    assert z.above.tolist() == [1] and z.worst == 1
    assert z.to_dict()["frames_above_noise"] == [1]
    m = synthetic_walk(duration=1.0, fps=30).motion
    with pytest.raises(ValueError, match=rf"{m.n_frames} vs 15"):
        zmp_rise(m, m.slice(0, 15))


@pytest.fixture(scope="module")
def cases(real_data_dir, tmp_path_factory):
    from mocomp.touchup.examples import paper_examples

    tmp = tmp_path_factory.mktemp("quality")
    out = {}
    for k, e in paper_examples(real_data_dir).items():
        r = touchup(e.motion, schedule=e.schedule)
        out[k] = (e, r, _written(e.motion, tmp, f"{k}_in"), _written(r.motion, tmp, f"{k}_out"))
    return out


def test_walks_never_rise_above_the_inputs_noise(cases):
    """Walk -> jog and the curved walk: no frame's ZMP distance rises by more than the input's
    noise (measured worst rises 0.9 cm at frame 126 of the blend, noise 1.0 cm there; 0.5 cm on
    the curved walk, noise 1.4 cm); their mean falls by more than 80 % (84.5 %, 93.0 %)."""
    for k in ("walk-jog", "curved-walk"):
        e, r, a, b = cases[k]
        z = zmp_rise(a, b)
        assert z.above.size == 0, (k, z.to_dict())
        assert np.nanmean(z.output) < 0.2 * np.nanmean(z.input), k


def test_uphill_rises_on_one_frame_where_the_toe_contact_flips(cases):
    """Uphill: the mean falls 91 %; one frame (52) rises 1.6 -> 10.1 cm, beyond its 1.0 cm noise.
    It is the measure's contact label: the detector calls the right toe off one frame earlier on
    the touched-up motion, whose toe there is 2 mm higher (lift_feet's smoothed hold), and the
    polygon loses that corner (the ZMP itself moved 2.7 cm)."""
    from mocomp.dynamics.contacts import detect_contacts

    e, r, a, b = cases["uphill"]
    z = zmp_rise(a, b)
    assert np.nanmean(z.output) < 0.2 * np.nanmean(z.input)
    assert len(z.above) <= 1
    for f in z.above:
        ca, cb = detect_contacts(a), detect_contacts(b)
        flipped = np.asarray(ca.touching)[f] != np.asarray(cb.touching)[f]
        assert flipped.any()
        k = int(np.flatnonzero(flipped)[0])
        assert abs(cb.heights[f, k] - ca.heights[f, k]) < 0.005


def test_curved_hop_misses_only_on_the_last_push_frames(cases):
    """Curved hop: the flight's COM is on the g = 9.81 parabola within 1 mm (read back: 0.00 mm) and
    no planted foot point slides more than the input's + 1 cm; the ZMP rises above the noise only
    on the last push frames (measured 23-26, 3.6-7.4 cm against 1-2.5 cm of noise: the 0.37 m/s
    sideways take-off velocity the parabola asks for, made by the push), never on the quiet
    stance nor the landing; the last push frame, at a quarter of the weight, 47 -> 72 cm within its
    28 cm noise (108 cm when the flight's COM correction was eased into the push instead of in
    proportion to the vertical force: flight.continue_into_ground)."""
    from mocomp.audit import default_body
    from mocomp.dynamics.com import center_of_mass
    from mocomp.ops.footplant import foot_points, plant_slides
    from mocomp.touchup.flight import com_residual

    e, r, a, b = cases["curved-jump"]
    (fa, fb), = r.stages.flight_runs
    c = center_of_mass(default_body(b), b)
    assert com_residual(c, fa, fb, b.fps) < 1e-3
    pl = r.stages.plants
    s0, s1 = plant_slides(foot_points(*e.motion.fk(), pl), pl), plant_slides(foot_points(*b.fk(), pl), pl)
    assert np.nanmax(s1 - s0) < 0.01
    z = zmp_rise(a, b)
    assert np.all((z.above >= fa - 12) & (z.above < fa)), z.to_dict()       # push frames only
    assert np.nanmax((z.rise - z.noise)[z.above]) < 0.10 if z.above.size else True
    far = np.ones(b.n_frames, bool)
    far[max(fa - 12, 0):fb + 12] = False
    assert np.nanmax((z.rise - z.noise)[far]) < 0.005
    assert np.nanmean(z.output) < 0.6 * np.nanmean(z.input)


def test_hop_windows_fall_on_average(real_data_dir, tmp_path):
    """Not a lucky pick: 12 windows of CMU 01_01 (one hop each, 100-270 frames, 30 and 60 deg arcs),
    the default schedule, read back: the mean ZMP distance outside the contact polygon falls by 35 %
    on average (25 % with the flight's COM correction eased into the push and landing, 22 % with its
    ramps over the whole 1/2 s neighbourhood), on 11 of the 12; every flight's COM on the parabola."""
    from mocomp import datasets
    from mocomp.audit import default_body
    from mocomp.dynamics.com import center_of_mass
    from mocomp.ops import path_edit
    from mocomp.touchup.examples import _arc
    from mocomp.touchup.flight import com_residual

    full = datasets.load(real_data_dir / "jumps" / "01_01.bvh")
    falls = []
    for w0, w1 in [(400, 500), (360, 540), (330, 560), (300, 570), (570, 680), (200, 300)]:
        j = full.slice(w0, w1)
        for deg in (30.0, 60.0):
            m = path_edit(j, _arc(j, deg)).motion
            r = touchup(m, schedule="default")
            a, b = _written(m, tmp_path, "in"), _written(r.motion, tmp_path, "out")
            z = zmp_rise(a, b, sigmas=())
            falls.append(1 - np.nanmean(z.output) / np.nanmean(z.input))
            c = center_of_mass(default_body(b), b)
            for fa, fb in r.stages.flight_runs:
                assert com_residual(c, fa, fb, b.fps) < 1e-3
    assert np.mean(falls) > 0.30 and sum(f > 0 for f in falls) >= 11, np.round(falls, 3)
