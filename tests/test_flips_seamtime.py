"""Non-uniform retiming across seams (dissertation 5.4.2.2 and the fallback of 5.2, eq. 5.22)."""
import dataclasses
import warnings

import numpy as np
import pytest

from mocomp.dynamics import center_of_mass, momentum
from mocomp.flips import multiflip, prepare
from mocomp.flips.retime import sample_positions
from mocomp.flips.smoothing import (SPEED_BOUNDS, AngularMomentumEvaluator, reference_levels, seam_speed, warp_time,
                                   warped_positions)
from mocomp.flips.similarity import frame_distance

from _flips_data import synthetic


def angular_numpy(ev: AngularMomentumEvaluator, rotations: np.ndarray, fps: float) -> np.ndarray:
    """The numpy oracle of :meth:`AngularMomentumEvaluator.angular` (moved here from
    mocomp.flips.smoothing, where only the compiled kernel runs): FK joint by joint, segment COMs
    and orientations, central differences, eq. 5.5."""
    from mocomp.core.rotations import cross, quat_apply, quat_inverse, quat_log, quat_multiply

    q = np.asarray(rotations, dtype=float)
    n, J, _ = q.shape
    G = np.empty_like(q)
    P = np.zeros((n, J, 3))
    G[:, 0] = q[:, 0]
    for j in range(1, J):
        p = ev.parents[j]
        G[:, j] = quat_multiply(G[:, p], q[:, j])
        P[:, j] = P[:, p] + quat_apply(G[:, p], np.broadcast_to(ev.offsets[j], (n, 3)))
    R = G[:, ev.seg_joint]
    c = P[:, ev.seg_joint] + quat_apply(R, np.broadcast_to(ev.local_coms, R.shape[:-1] + (3,)))
    w = 0.5 * fps * (quat_log(quat_multiply(R[2:], quat_inverse(R[1:-1])))
                     + quat_log(quat_multiply(R[1:-1], quat_inverse(R[:-2]))))
    v = 0.5 * fps * (c[2:] - c[:-2])
    ci = c[1:-1]
    Ri = R[1:-1]
    com = np.einsum("s,tsk->tk", ev.masses, ci) / ev.total_mass
    wb = quat_apply(quat_inverse(Ri), w)
    Iw = quat_apply(Ri, np.einsum("sij,tsj->tsi", ev.inertias, wb))
    return Iw.sum(axis=1) + np.einsum("s,tsk->tk", ev.masses, cross(ci - com[:, None], v))


@pytest.fixture(scope="module")
def backflip():
    return prepare(synthetic("backflip").motion)


def test_block_angular_momentum_matches_dynamics(backflip):
    """The run-time L of a few frames equals mocomp.dynamics.momentum (eq. 5.5, central
    differences) on the same frames, and does not depend on the root position."""
    P = backflip
    s = P.flight[0] + 20
    R = np.array(P.rotations[s:s + 12])
    ev = P.momentum_evaluator
    ref = np.asarray(P.momentum.angular[s + 1:s + 11])
    np.testing.assert_allclose(ev.angular(R, P.fps), ref, atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(angular_numpy(ev, R, P.fps), ref, atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(ev.angular(R, P.fps), angular_numpy(ev, R, P.fps), rtol=0,
                               atol=1e-12 * np.abs(ref).max())                    # kernel vs its oracle
    np.testing.assert_allclose(ev.magnitude(R, P.fps), np.linalg.norm(ref, axis=1), rtol=1e-9)
    assert isinstance(ev, AngularMomentumEvaluator)
    with pytest.raises(ValueError, match="at least 3 frames"):
        ev.angular(R[:2], P.fps)


def test_warp_is_uniform_retiming_at_unit_speed():
    W = warp_time(np.ones(50))
    np.testing.assert_allclose(W, np.arange(50))
    tw, tau = warped_positions(W, 0.8)
    np.testing.assert_allclose(tau, sample_positions(50, 0.8))
    # twice the speed over frames 10..19: that stretch takes half the time
    sp = np.ones(50)
    sp[10:20] = 2.0
    W = warp_time(sp)
    assert W[19] - W[10] == pytest.approx(4.5)
    assert W[-1] == pytest.approx(49 - 4.5 - 0.5)          # the two half-speed-change intervals
    tw, tau = warped_positions(W, 1.0)
    steps = np.diff(tau)
    assert np.allclose(steps[10:14], 2.0) and np.allclose(steps[:9], 1.0) and np.allclose(steps[15:], 1.0)


def test_seam_speed_is_eq_5_22_clipped():
    s = seam_speed([10.0, 5.0, 40.0, 0.0], [10.0, 10.0, 10.0, 10.0])
    np.testing.assert_allclose(s, [1.0, 2.0, 0.5, SPEED_BOUNDS[1]])
    # vectors: least-squares speed; equal to the magnitude ratio when the directions agree, blind to a
    # spurious perpendicular part (which retiming cannot remove)
    a = np.array([[0.0, 8.0, 0.0], [0.0, 8.0, 6.0]])
    ref = np.array([[0.0, 10.0, 0.0], [0.0, 10.0, 0.0]])
    np.testing.assert_allclose(seam_speed(a, ref), [1.25, 0.8])
    np.testing.assert_allclose(seam_speed(a[:1], ref[:1]), seam_speed([8.0], [10.0]))
    # the reference level moves toward the middle with the pose ramp weights
    np.testing.assert_allclose(reference_levels([4.0, 4.0], 4.0, 6.0, np.array([0.0, 1.0])), [4.0, 6.0])


def _forced(P, dm):
    """``P`` with its self-loop start moved by ``dm`` frames: a dissimilar seam. Its dissimilarity
    (and with it every |L| figure below) depends on where the chosen loop starts: before the loop
    search had a tie rule (:mod:`mocomp.flips.looping`) the synthetic back flip's loop start moved
    with 1e-7 noise (141 on one host, 143 on another), the forced seam went from 27 to 17 degrees
    and the plain-slerp rms from 0.33 to 0.209, failing the bound below on the second host. The
    loop is now (141, 173) under any 1e-7 perturbation (``tests/test_flips_tolerances.py``)."""
    m, n = P.loop.m + dm, P.loop.n
    loop = dataclasses.replace(P.loop, m=m, phi=float(P.theta[n] - P.theta[m]))
    return dataclasses.replace(P, loop=loop, _cache={})


def test_dissimilar_seam_is_repaired_by_retiming(backflip):
    """Ground truth: a synthetic back flip (|L| exactly constant in flight) repeated through a
    seam whose poses differ by ~27 degrees (weighted mean joint angle). Slerping the joints alone
    leaves |L| swinging by tens of percent (max 85 %, rms 33 %); eq. 5.22 retiming brings it back
    near the original's."""
    assert (backflip.loop.m, backflip.loop.n) == (141, 173)
    Q = _forced(backflip, -10)
    D, _ = frame_distance(Q.rotations[Q.loop.m], Q.rotations[Q.loop.n], Q.axis, Q.weights)
    assert 25 < np.degrees(D / (Q.weights.root + Q.weights.joints.sum())) < 29      # measured 26.9
    plain = multiflip(Q, flips=3, seam_retime=False).report
    fixed = multiflip(Q, flips=3).report
    assert plain.L_variation_new > 0.3 and plain.L_profile_deviation_max > 0.4
    assert fixed.L_variation_new < plain.L_variation_new / 3
    # Measured 0.135 (rms 0.0247; plain slerp: max 0.845, rms 0.330) with the loop (141, 173),
    # 0.128 (rms 0.024) with the loop (141, 171) that an earlier, tie-sensitive search chose on the
    # host that set this bound. The largest deviation sits on the two
    # output frames straddling each loop seam, where the frame-wise eq. 5.22 speed steps 0.54 ->
    # 0.90 -> 1.73 within two frames: its size depends on where the k-spaced output frames fall
    # relative to the seam (0.166 / 0.128 / 0.117 for 2 / 3 / 4 flips; 0.11-0.13 across the
    # seams of one 3-flip), hence the margin; the rms is the phase-independent figure.
    assert fixed.L_profile_deviation_max < 0.14
    assert fixed.L_profile_deviation_rms < 0.03 < plain.L_profile_deviation_rms / 10
    assert fixed.seam_retimed and SPEED_BOUNDS[0] <= fixed.seam_speed_min < 0.8 and fixed.seam_speed_max <= 2.0
    # the rest of the method is untouched: rotation, landing, exact parabola
    assert abs(fixed.rotation_error) < 0.1 and fixed.landing_orientation_error < 1.0
    assert fixed.com_target_error < 1e-9 and fixed.com_residual_max < 1e-9


def test_similar_seam_is_left_alone(backflip):
    """A self-loop whose seam barely disturbs L gets speeds of ~1: the retiming only acts where
    the smoothing changed the momentum."""
    R = multiflip(backflip, flips=3).report
    assert 0.97 < R.seam_speed_min <= R.seam_speed_max < 1.03
    assert R.L_profile_deviation_max < 0.03


def test_retimed_flight_still_follows_the_parabola_and_k_star(backflip):
    """Warped time feeds App. B: k* uses the retimed sequence's flight duration, and the new
    flight's COM lies on eq. 5.15/5.17 at the output frame times."""
    Q = _forced(backflip, -10)
    res = multiflip(Q, flips=2, k_ratio=1.0)
    R = res.report
    assert R.T_sequenced == pytest.approx((res.sequence.landing - res.sequence.takeoff) / Q.fps, rel=0.1)
    assert R.T_sequenced != pytest.approx((res.sequence.landing - res.sequence.takeoff) / Q.fps, rel=1e-6)
    from mocomp.flips.reposition import event_velocity

    v0 = event_velocity(Q.com, Q.flight[0], Q.fps)[1]     # the flight continues the measured take-off velocity
    assert R.k_star == pytest.approx(np.sqrt(0.5 * R.gravity * R.T_sequenced / (v0 - R.dy / R.T_sequenced)))
    a, b = res.flight
    com = center_of_mass(Q.body, res.motion)[a:b]
    t = np.arange(a, b) / Q.fps - res.takeoff_seconds
    np.testing.assert_allclose(com, res.trajectory(t), atol=1e-9)


@pytest.mark.realdata
def test_real_seams_follow_the_original_momentum(real_data_dir):
    """CMU 88_01 (60 Hz): the loop seams' |L| dips are about halved (largest deviation from k x the
    original's |L| at the frames shown: measured 21.2 % with slerp alone, 11.4 % retimed; rms 8.0 -> 4.3 %)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        P = prepare("cmu_88_01_backflip")
    plain = multiflip(P, flips=2, seam_retime=False).report
    fixed = multiflip(P, flips=2).report
    assert fixed.L_profile_deviation_rms < plain.L_profile_deviation_rms / 1.5
    assert fixed.L_profile_deviation_max < 0.13 and fixed.L_profile_deviation_max < plain.L_profile_deviation_max / 1.7
    assert fixed.L_std_new < fixed.L_std_original
    mom = momentum(P.body, P.motion)
    np.testing.assert_allclose(P.L_magnitude, np.linalg.norm(mom.angular, axis=1))


def test_fallback_without_self_loop_says_so():
    """Section 5.2: no pair meets the similarity threshold -> the best pair is joined by smoothing,
    |L| across the transitions adjusted by non-uniform retiming; the report says which."""
    m = synthetic("sideflip").motion
    P = prepare(m, loop_options={"max_mean_angle": 0.1})
    assert not P.loop.found and "section 5.2" in P.loop.note
    R = multiflip(P, flips=2).report
    assert not R.loop_found and R.seam_retimed
    fb = [n for n in R.notes if n.startswith("fallback (section 5.2)")]
    assert len(fb) == 1 and "smoothing" in fb[0] and "non-uniform retiming (eq. 5.22)" in fb[0]
    assert sum("section 5.2" in n for n in R.notes) == 1
    off = multiflip(P, flips=2, seam_retime=False).report
    assert any("seam retiming is off" in n for n in off.notes)
    assert abs(R.rotation_error) < 1.0 and R.L_variation_new < 0.05


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["cmu_90_08_sideflip", "deepmimic_backflip", "deepmimic_sideflip"])
def test_real_fallbacks_are_reported(real_data_dir, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        P = prepare(name, estimate=True)    # the flight-fitted masses (a DeepMimic clip's own are used by
        # default since issue 13; with them the side flip's |L| std is 0.103 against the input's 0.090)
    R = multiflip(P, flips=2).report
    assert not R.loop_found
    assert any(n.startswith("fallback (section 5.2)") and "eq. 5.22" in n for n in R.notes)
    assert R.seam_retimed and R.L_std_new < R.L_std_original
