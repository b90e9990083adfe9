"""Joining two flights in mid-air (issue 5, section 3; flips paper section 6, Fig. 5.8)."""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from mocomp import datasets
from mocomp.dynamics import center_of_mass
from mocomp.edit.join import join_flights
from mocomp.errors import JoinError
from mocomp.flips.mass import fit_ballistic


@lru_cache(maxsize=None)
def example(name):
    return datasets.load_example(name)


@lru_cache(maxsize=None)
def joined(a, b, **kw):
    return join_flights(example(a).motion, example(b).motion, body=example(a).body, **dict(kw))


def test_backflip_takeoff_joined_with_sideflip_landing():
    A, B = example("backflip"), example("sideflip")
    r = joined("backflip", "sideflip")
    al = r.alignment
    # the side flip is turned about the vertical so both L point the same way
    assert al["residual_deg"] < 3.0 and not al["full"]
    assert al["angle_after_deg"] < 3.0
    assert abs(al["yaw_deg"]) > 30.0
    # |L| matched by retiming the landing part (eq. 5.8)
    assert r.landing.speed == pytest.approx(np.linalg.norm(A.L0) / np.linalg.norm(B.L0), rel=0.01)
    assert np.linalg.norm(r.landing.L) == pytest.approx(np.linalg.norm(r.takeoff.L), rel=0.02)
    # the seam lies inside both flights
    assert r.takeoff.flight[0] < r.seam["f"] < r.takeoff.flight[1] - 1
    assert r.landing.flight[0] < r.seam["g"] < r.landing.flight[1] - 1
    # after the magnitude step |L| is on target except at the seam's frames
    mag = r.restore.stages["magnitude"].magnitude
    assert np.median(mag) < 0.01 and np.mean(mag < 0.02) > 0.9 and mag.max() < 0.15
    # the whole flight follows one parabola from A's take-off
    a, b = r.restore.flight_out
    fit = fit_ballistic(center_of_mass(A.body, r.motion)[a:b], r.motion.fps, a)
    assert fit.max < 1e-9 and fit.gravity == pytest.approx(9.81, rel=1e-6)
    # it takes off as A and lands as B: the take-off frames are A's, the final pose B's
    src = r.restore.linear.source_times[:a - 2]            # retimed by k: frame j shows A at k j / fps
    ref = A.motion.sample(src)
    np.testing.assert_allclose(np.abs(np.sum(r.motion.rotations[:a - 2, 1:] * ref.rotations[:, 1:], axis=-1)), 1.0,
                               atol=1e-12)
    last = np.abs(np.sum(r.motion.rotations[-1, 1:] * B.motion.rotations[-1, 1:], axis=-1))
    assert np.degrees(2 * np.arccos(np.clip(last.min(), 0, 1))) < 2.0
    assert r.landing_tilt_deg < 10.0


def test_raised_takeoff_join():
    r = joined("backflip", "sideflip", takeoff_height=0.6)
    A = example("backflip")
    assert r.motion.root_positions[0, 1] == pytest.approx(A.motion.root_positions[0, 1] + 0.6)
    assert r.restore.linear.plan.dy < -0.5
    assert r.restore.linear.platform is not None and r.restore.linear.platform.clearance >= -1e-9


def test_opposite_somersaults_cannot_be_joined():
    with pytest.raises(JoinError, match="opposite senses|oriented"):
        joined("backflip", "frontflip")


def test_unalignable_L_directions_are_refused_with_the_measured_angles():
    # a back flip turns about a horizontal axis, a twist jump about the vertical
    with pytest.raises(JoinError, match=r"cannot be aligned.*\+8\d\.\d deg|cannot be aligned.*differ by"):
        joined("backflip", "twist180")


def test_different_skeletons_are_refused(real_data_dir):
    with pytest.raises(JoinError, match="different skeletons"):
        join_flights(example("backflip").motion, "cmu_88_01_backflip")


def test_real_deepmimic_backflip_and_sideflip(real_data_dir):
    r = join_flights("deepmimic_backflip", "deepmimic_sideflip")
    assert r.alignment["residual_deg"] < 3.0
    a, b = r.restore.flight_out
    assert r.restore.linear.com_residual < 1e-9
    own = r.restore.stages["original"]
    fin = r.restore.stages["final"]
    assert fin.rms_magnitude <= own.rms_magnitude
    assert np.isfinite(r.report()["seam"]["mean_angle_deg"])


def test_real_backflip_and_spinkick_needs_full_alignment(real_data_dir):
    r = join_flights("deepmimic_backflip", "deepmimic_spinkick")
    assert r.alignment["full"] and 30.0 < r.alignment["tilt_deg"] < 45.0
    assert r.alignment["angle_after_deg"] < 3.0
    assert r.foot_slide is not None          # the tilt is eased out after touchdown and reported
    with pytest.raises(JoinError, match="max_tilt_deg = 20"):
        join_flights("deepmimic_backflip", "deepmimic_spinkick", max_tilt_deg=20.0)
