"""mocomp.concat's parts on data whose answer is known: eq. 1 phases, rules, eq. 2, eq. 3-7 (issue 17)."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.concat import (ConcatError, MomentumTrack, alignment_yaw, blendable_periods, find_phases, timing_table)
from mocomp.concat.phases import Phases
from mocomp.concat.rules import support_truncate
from mocomp.core.rotations import quat_apply
from mocomp.ops.align import yaw_quaternion


def _track(L, arms=None, masses=None, fps=60.0):
    L = np.asarray(L, float)
    S = 4
    if arms is None:
        t = np.arange(len(L))[:, None, None]
        arms = np.sin(0.07 * t + np.arange(S)[None, :, None] + np.arange(3)[None, None, :])
    return MomentumTrack(L, np.asarray(arms, float), np.ones(S) if masses is None else masses, fps)


def _base(n=400, seed=0):
    """A smooth, non-periodic 3-D trajectory (no two frames alike)."""
    t = np.arange(n, dtype=float)
    rng = np.random.default_rng(seed)
    c = rng.normal(size=(3, 3))
    return np.stack([c[k, 0] * np.sin(0.031 * t * (k + 1) + c[k, 1]) + 0.01 * t * c[k, 2] + 0.0002 * t ** 2
                     for k in range(3)], axis=1)


# ---- phases (sec. "Typical Angular Momentum Trajectories")

def test_phases_from_sign_changes_of_L_dot_L_tm():
    t = np.arange(100)
    # L_x: negative (wind-up) 0-29, positive 30-69 (peak at 50), negative 70-99
    lx = np.where((t >= 30) & (t < 70), 20.0 * np.sin(np.pi * (t - 30.0) / 40.0) + 0.1, -3.0)
    tr = _track(np.stack([lx, 0.5 * np.ones(100), np.zeros(100)], 1))
    ph = find_phases(tr, level_fraction=0.0)     # the paper's rule: the sign of L(t) . L(t_m)
    assert ph.t_m == 50
    assert ph.main == (30, 70)
    assert ph.preparatory == (0, 30) and ph.posterior == (70, 100)
    # a given t_m inside the main phase gives the same borders
    assert find_phases(tr, t_m=35, level_fraction=0.0).main == (30, 70)
    # the default also stops where L . L(t_m) < 0.1 |L(t_m)|^2 (L(t_m) = (20.1, 0.5, 0)):
    # 20.1 lx + 0.25 >= 40.43 <=> sin(pi u) >= 0.0950, u = (t - 30) / 40 in [0.0303, 0.9697] -> t = 32 .. 68
    assert find_phases(tr).main == (32, 69)
    lx2 = lx.copy()
    lx2[70:] = 0.5                               # a quiet tail keeping the sign (capture noise)
    assert find_phases(_track(np.stack([lx2, 0.5 * np.ones(100), np.zeros(100)], 1)), level_fraction=0.0).main == (30, 100)
    assert find_phases(_track(np.stack([lx2, 0.5 * np.ones(100), np.zeros(100)], 1))).main == (32, 69)


def test_phases_borders_given_and_no_main_phase():
    L = np.zeros((50, 3))
    L[:, 1] = 1.0
    with pytest.raises(ConcatError, match=r"no main phase: \|L\| peaks at 1.00 kg m\^2/s .* never above 4"):
        find_phases(_track(L), name="A")
    ph = find_phases(_track(L), borders=(10, 20))
    assert ph.main == (10, 20) and ph.given and 10 <= ph.t_m < 20
    with pytest.raises(ConcatError, match="borders 20,10"):
        find_phases(_track(L), borders=(20, 10), name="A")


# ---- eq. 2

@pytest.mark.parametrize("theta0", [0.3, -2.0, 2.9])
def test_alignment_yaw_recovers_a_known_turn(theta0):
    L1 = np.array([3.0, 1.5, -2.0])
    L2 = quat_apply(yaw_quaternion(-theta0), L1)       # motion 2 turned away by -theta0
    th, v = alignment_yaw(L1, L2, "forward")
    assert th == pytest.approx(theta0, abs=1e-9)
    assert v == pytest.approx(L1 @ L1)
    thr, vr = alignment_yaw(L1, L2, "reverse")
    assert abs(np.angle(np.exp(1j * (thr - theta0 - np.pi)))) < 1e-9
    # against a dense scan of the product
    grid = np.linspace(-np.pi, np.pi, 20001)
    vals = np.array([L1 @ quat_apply(yaw_quaternion(g), L2) for g in grid[::50]])
    assert v >= vals.max() - 1e-9 and vr <= vals.min() + 1e-9


# ---- blendable periods

def test_blendable_periods_per_rule():
    p1 = Phases(100, 50, (30, 70))
    p2 = Phases(80, 40, (20, 60))
    (case, a, b), = blendable_periods("forward", p1, p2)
    assert a == (50, 70) and b == (20, 40)
    cands = blendable_periods("reverse", p1, p2)
    assert [(a, b) for _, a, b in cands] == [((50, 70), (10, 20)), ((70, 85), (20, 40))]
    with pytest.raises(ConcatError, match="reverse rule cannot apply"):
        blendable_periods("reverse", Phases(60, 30, (0, 60)), Phases(60, 30, (0, 60)))


def test_support_truncation_to_double_support():
    lab = np.zeros((40, 4), bool)
    lab[:, 0] = True
    lab[12:20, 2] = True
    lab[25:27, 3] = True
    assert support_truncate(lab, (10, 30))[0] == (12, 20)        # single support left out
    assert support_truncate(lab, (0, 10))[0] == (0, 10)          # never both feet: kept whole
    lab[14:24] = False                                           # airborne 14-23, then double 24-26
    lab[24:27, 2] = True
    assert support_truncate(lab, (10, 30))[0] == (12, 27)


# ---- eq. 3-7

def test_optimal_T_recovers_a_known_shift_exactly():
    base = _track(_base())
    s = 37
    t1 = MomentumTrack(base.L[0:200], base.arms[0:200], base.masses, 60.0)
    t2 = MomentumTrack(base.L[s:s + 200], base.arms[s:s + 200], base.masses, 60.0)   # L2(g) = L1(g + s)
    tab = timing_table(t1, t2, (120, 180), (60, 130))
    k = tab.best
    assert tab.T[k] == s
    assert tab.f_T[k] == 120                 # F_time = 0 at the first frame of period 1
    assert tab.F[k] == pytest.approx(0.0, abs=1e-9)
    assert tab.F_inertia[k] == pytest.approx(0.0, abs=1e-12)
    ru = tab.runner_up()
    assert ru is not None and abs(tab.T[ru] - s) > 1 and tab.F[ru] > 1e-3


def test_timing_table_equals_the_papers_brute_force():
    rng = np.random.default_rng(3)
    t1 = _track(rng.normal(size=(60, 3)) * 5)
    t2 = _track(rng.normal(size=(50, 3)) * 5)
    p1, p2 = (20, 45), (5, 30)
    tab = timing_table(t1, t2, p1, p2)
    for k, T in enumerate(tab.T):
        fs = [f for f in range(*p1) if p2[0] <= f - T < p2[1]]
        d = [np.sum((t1.L[f] - t2.L[f - T]) ** 2) for f in fs]
        fT = fs[int(np.argmin(d))]
        assert tab.f_T[k] == fT
        assert tab.F_dm[k] == pytest.approx(min(d), rel=1e-9, abs=1e-9)
        r1, r2 = t1.arms[fT], t2.arms[fT - T]
        assert tab.F_inertia[k] == pytest.approx(sum(t1.masses[j] * (r1[j] @ (r2[j] - r1[j])) ** 2
                                                     for j in range(len(t1.masses))))
        assert tab.F_time[k] == pytest.approx(np.sum((t1.L[fT] - t1.L[p1[0]]) ** 2))
    # every overlapping offset scanned: T from p1[0] - (p2[1] - 1) to p1[1] - 1 - p2[0]
    assert tab.T.min() == p1[0] - (p2[1] - 1) and tab.T.max() == p1[1] - 1 - p2[0]
    with pytest.raises(ConcatError, match="no offset T >= 999"):
        timing_table(t1, t2, p1, p2, min_T=999)


def test_support_truncation_hand_support_is_not_flight():
    """A cartwheel: both feet 0-10, hands only 10-20 (inverted), both feet 20-40. Without the hands
    every frame counts (no foot = flight); with them the inverted frames are support, left out like
    single support, and the period keeps its longer double-support stretch."""
    lab = np.zeros((40, 4), bool)
    lab[:10] = True
    lab[20:] = True
    hands = np.zeros((40, 2), bool)
    hands[10:20, 0] = True
    hands[12:18, 1] = True
    assert support_truncate(lab, (5, 32))[0] == (5, 32)
    (lo, hi), note = support_truncate(lab, (5, 32), hands)
    assert (lo, hi) == (20, 32) and "hand support" in note
    assert support_truncate(lab, (5, 16), hands)[0] == (5, 10)
    # a real flight (no foot, no hand) still counts
    hands[:] = False
    assert support_truncate(lab, (5, 32), hands)[0] == (5, 32)
