"""Step 1 (direction of L, dissertation eq. 5.18-5.21) solved for all flight frames together
(:mod:`mocomp.edit.smooth_direction`): the per-frame recurrence's even/odd oscillation after
fast limb edits is gone, the direction constraints still hold to the same tolerance.

Ground truth: the embedded synthetic flips keep L exactly constant (``result.L0``).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from mocomp import datasets
from mocomp.core.rotations import quat_multiply
from mocomp.dynamics import center_of_mass
from mocomp.edit import apply_preset, correct_direction, restore_momentum
from mocomp.edit._kernels import interior_momentum, momentum_blocks, rotate_frames
from mocomp.core.rotations import quat_exp as _qexp
from mocomp.edit.restore import segment_state
from mocomp.edit.smooth_direction import rotvecs_continuous, second_difference_deg


@lru_cache(maxsize=None)
def example(name):
    return datasets.load_example(name)


@lru_cache(maxsize=None)
def edited(name, preset, ease):
    r = example(name)
    return apply_preset(r.motion, r.flight, preset, ease=ease)[0]


@lru_cache(maxsize=None)
def solved(name, preset, ease, method):
    r = example(name)
    return correct_direction(r.body, edited(name, preset, ease), r.flight, L_star=r.L0, method=method)


def test_block_jacobians_match_finite_differences_and_rotate_L_rigidly():
    """dL_f / d(rotation of frame f-1, f, f+1 about its COM), analytic, on a randomly
    corrected state with non-uniform frame times; the three blocks sum to -[L]x (turning
    every frame by the same rotation turns L with it)."""
    r = example("sideflip")
    ed = edited("sideflip", "straight-legs", 0.45)
    a, b = r.flight
    X, Q = segment_state(r.body, ed[a:b])
    t = ed[a:b].times.copy()
    t[5:] += 0.001
    m, I = r.body.masses, r.body.inertias
    piv = np.ascontiguousarray(np.einsum("s,tsk->tk", m, X) / m.sum())
    corr = np.ascontiguousarray(_qexp(np.random.default_rng(3).normal(0, 0.3, (X.shape[0], 3))))
    Xc, Qc = rotate_frames(X, Q, piv, corr)
    L, Jm, J0, Jp = momentum_blocks(m, I, Xc, Qc, t, piv)
    ref = interior_momentum(m, I, Xc, Qc, t)
    np.testing.assert_allclose(L[1:-1], ref[1:-1], rtol=1e-12, atol=1e-9)
    h = 1e-6
    for f in (2, 30, X.shape[0] - 3):
        for J, g in ((Jm, f - 1), (J0, f), (Jp, f + 1)):
            num = np.zeros((3, 3))
            for k in range(3):
                c2 = corr.copy()
                c2[g] = quat_multiply(_qexp(h * np.eye(3)[k]), corr[g])
                X2, Q2 = rotate_frames(X, Q, piv, c2)
                num[:, k] = (interior_momentum(m, I, X2, Q2, t)[f] - ref[f]) / h
            np.testing.assert_allclose(J[f], num, atol=1e-5 * np.abs(num).max())
        Lx = np.array([[0, -L[f, 2], L[f, 1]], [L[f, 2], 0, -L[f, 0]], [-L[f, 1], L[f, 0], 0]])
        np.testing.assert_allclose(Jm[f] + J0[f] + Jp[f], -Lx, atol=1e-9 * np.abs(Jp[f]).max())


# (case, per-frame roughness at least, smooth roughness at most) -- measured 46-52 / 0.95-1.07,
# 12.2 / 3.4 deg under 1e-9..1e-8 rad changes of one input frame (robust; see the next test for a case
# that is not: side flip straight-legs with the default 0.45 ease was listed here with "> 6 deg",
# measured 8.2 deg until 32837b5 and 72ed8b8 changed kernels' summation order: 5.8, then 3.9 deg)
OSCILLATING = [(("sideflip", "straight-legs", 0.2), 30.0, 1.5),
               (("backflip", "arms-twist", 0.05), 10.0, 4.5)]


def _nudged(ed, frame, eps):
    rot = np.array(ed.rotations)
    rot[frame, 3] = quat_multiply(_qexp(np.array([eps, 0.0, 0.0])), rot[frame, 3])
    return ed.replace(rotations=rot)


def test_weakly_excited_per_frame_jitter_is_round_off_the_joint_solve_is_not():
    """Side flip + straight-legs, default 0.45 ease: the recurrence's neutrally stable mode is only
    weakly excited, so its size is whatever round-off seeds it. Turning one knee of one early flight
    frame by 1e-9..1e-8 rad moves the per-frame solution's roughness between 0.3 and 6 deg (measured
    3.86, 0.30, 3.84, 5.66, 6.15) -- the per-frame result is not determined by the problem to better
    than degrees -- while the joint solve stays at 0.30-0.36 deg; all meet eq. 5.21 to 1e-6 rad."""
    r = example("sideflip")
    ed = edited("sideflip", "straight-legs", 0.45)
    a, b = r.flight
    gn, sm = [], []
    for eps in (0.0, 1e-9, -1e-9, 1e-8, 3e-9):
        e = _nudged(ed, a + 5, eps)
        g = correct_direction(r.body, e, r.flight, L_star=r.L0, method="gauss-newton")
        s = correct_direction(r.body, e, r.flight, L_star=r.L0, method="smooth", smooth_above_deg=0.0)
        for d in (g, s):
            assert d.error_after[a + 1:b - 1].max() < 1e-6
        gn.append(g.roughness_deg)
        sm.append(s.roughness_deg)
    # The per-frame values depend on how round-off seeds the mode, which differs between CPUs and
    # BLAS builds, so only the joint solve's stability is asserted; the per-frame spread is not.
    assert max(sm) < 0.6 and max(sm) - min(sm) < 0.1, (sm, gn)
    assert min(gn) >= min(sm) - 0.05, (sm, gn)         # the per-frame solve is never the smoother one


@pytest.mark.parametrize("case,rough_gn,rough_smooth", OSCILLATING)
def test_fast_edits_no_longer_oscillate_and_still_meet_the_direction_acceptance(case, rough_gn, rough_smooth):
    """Issue 5 acceptance (< 0.01 rad after step 1 on every flight frame) with both methods;
    the per-frame recurrence jitters by tens of degrees, the joint solve does not."""
    r = example(case[0])
    gn = solved(*case, "gauss-newton")
    sm = solved(*case, "smooth")
    assert gn.roughness_deg > rough_gn
    assert sm.roughness_deg < rough_smooth
    assert sm.per_frame_roughness_deg == pytest.approx(gn.roughness_deg)
    assert sm.smoothing.converged
    a, b = r.flight
    for d in (gn, sm):
        err = d.error_after[a + 1:b - 1]
        assert np.all(np.isfinite(err)) and err.max() < 1e-6      # far below the 0.01 rad acceptance
    # same first departure, untouched before it; rotations about each frame's COM keep the COM
    f0 = sm.first_departure
    assert f0 == gn.first_departure
    np.testing.assert_array_equal(sm.motion.rotations[:f0 + 1], edited(*case).rotations[:f0 + 1])
    np.testing.assert_allclose(center_of_mass(r.body, sm.motion)[:b], center_of_mass(r.body, edited(*case))[:b],
                               atol=1e-9)
    # no drift bought with the smoothness: the largest correction stays that of the per-frame solution
    assert sm.max_rotation_deg < gn.max_rotation_deg + 3.0


def test_remaining_roughness_is_the_bodys_reaction_not_the_recurrence():
    """At 4x the frame rate the per-frame recurrence still jitters (12.2 -> 11.2 deg on the
    120 Hz grid); the joint solution is the same at both rates (3.4 vs 3.2 deg): what is left
    is the body's reaction to arms snapped out within 3 frames."""
    r = example("backflip")
    ed = edited("backflip", "arms-twist", 0.05)
    a, b = r.flight
    fine = ed.resample(4 * ed.fps)
    fl = (4 * a, 4 * (b - 1) + 1)
    sm4 = correct_direction(r.body, fine, fl, L_star=r.L0, method="smooth", sigma=6.0)
    r120 = second_difference_deg(sm4.corrections[fl[0]:fl[1]][::4]).max()
    sm = solved("backflip", "arms-twist", 0.05, "smooth")
    assert sm4.max_error_after < 1e-6
    assert abs(sm.roughness_deg - r120) < 1.0
    assert solved("backflip", "arms-twist", 0.05, "gauss-newton").roughness_deg > 2.5 * r120


def test_smooth_equals_per_frame_when_nothing_oscillates():
    """The default preset on the back flip: the per-frame solution is already smooth (0.18 deg);
    the joint one (forced) stays within a degree of it, and by default it is not run at all."""
    r = example("backflip")
    ed = edited("backflip", "arms-twist", 0.45)
    gn = solved("backflip", "arms-twist", 0.45, "gauss-newton")
    sm = correct_direction(r.body, ed, r.flight, L_star=r.L0, smooth_above_deg=0.0)
    assert gn.roughness_deg < 0.5 and sm.roughness_deg <= gn.roughness_deg + 0.05
    assert sm.smoothing is not None and sm.smoothing.converged and sm.max_error_after < 1e-6
    d = np.linalg.norm(rotvecs_continuous(sm.corrections) - rotvecs_continuous(gn.corrections), axis=1)
    assert np.degrees(d.max()) < 1.0
    default = solved("backflip", "arms-twist", 0.45, "smooth")
    assert default.smoothing is None and default.per_frame_roughness_deg == pytest.approx(gn.roughness_deg)
    np.testing.assert_array_equal(default.corrections, gn.corrections)


def test_pipeline_default_has_no_jitter_note_and_meets_acceptance():
    # a 0.2 ease: the per-frame recurrence oscillates whatever the round-off (46-52 deg), so the
    # gauss-newton run's note is certain (with the 0.45 ease its roughness is 0.3-8 deg: see above)
    r = example("sideflip")
    ed = edited("sideflip", "straight-legs", 0.2)
    res = restore_momentum(r.body, r.motion, ed, r.flight, L_star=r.L0)
    assert res.direction.method == "smooth"
    assert res.stages["direction"].max_direction < 0.01
    assert res.stages["magnitude"].max_magnitude < 0.05
    assert not any("jitter" in n for n in res.notes)
    assert res.report(curves=False)["direction"]["per_frame_roughness_deg"] > 30.0
    gn = restore_momentum(r.body, r.motion, ed, r.flight, L_star=r.L0, method="gauss-newton")
    assert any("jitter" in n for n in gn.notes)


def test_unknown_method_is_refused():
    r = example("backflip")
    with pytest.raises(ValueError, match="smooth"):
        correct_direction(r.body, r.motion, r.flight, method="joint")
