"""The dynamics against the exact physics of mocomp.synth (known masses, constant L, COM parabola)."""
import numpy as np
import pytest

from mocomp.dynamics import airborne_intervals, center_of_mass, detect_contacts, momentum

from mocomp.datasets import load_example

NAMES = ["backflip", "frontflip", "sideflip", "twist180", "twist360", "jump"]


def _example(name):
    return load_example(name)


@pytest.mark.parametrize("name", NAMES)
def test_com_follows_the_exact_parabola(name):
    ex = _example(name)
    a, b = ex.flight
    com = center_of_mass(ex.body, ex.motion)[a:b]
    t = ex.motion.times[a:b]
    P = np.stack([np.polyval(ex.com_parabola[k], t) for k in range(3)], axis=1)
    assert np.abs(com - P).max() < 1e-9


@pytest.mark.parametrize("name", NAMES)
def test_contacts_and_flight_against_ground_truth(name):
    ex = _example(name)
    c = detect_contacts(ex.motion)
    names = {"LeftFoot": "foot_l", "RightFoot": "foot_r", "LeftToeBase": "toe_l", "RightToeBase": "toe_r"}
    for joint, truth in ex.contacts.items():
        e = c.effectors.index(names[joint])
        assert (c.labels[:, e] == truth).mean() > 0.985, joint
    air = airborne_intervals(c, min_frames=3)
    assert len(air) == 1
    (a, b), (ta, tb) = air[0], ex.flight
    # the height threshold (5 cm) makes the detected flight a little shorter, never longer
    assert ta <= a <= ta + 5 and tb - 5 <= b <= tb


def test_angular_momentum_conserved_in_flight_and_differences_converge():
    """|L(t) - L0| / |L0| over the flight, measured with our finite differences at the true
    masses: second-order differences converge as h^2, fourth-order ones as h^4."""
    from mocomp.synth.flights import backflip

    rows = []
    for fps in (120, 240, 480):
        ex = _example("backflip") if fps == 120 else backflip(fps=fps)
        a, b = ex.flight
        k = int(fps // 60)  # stay clear of the take-off/landing kinks by 1/60 s
        errs = {}
        for order in (2, 4):
            L = momentum(ex.body, ex.motion, order=order).angular[a + k:b - k]
            errs[order] = float(np.max(np.linalg.norm(L - ex.L0, axis=1)) / np.linalg.norm(ex.L0))
        rows.append((fps, errs[2], errs[4]))
    print("\n[synthetic backflip] flight |L - L0|/|L0| with our finite differences:")
    for fps, e2, e4 in rows:
        print(f"  {fps:4d} Hz: order 2 {e2:.1e}, order 4 {e4:.1e}")
    (_, a2, a4), (_, b2, b4), (_, c2, c4) = rows
    assert 3.0 < a2 / b2 < 5.0 and 3.0 < b2 / c2 < 5.0
    assert a4 / b4 > 8 and b4 / c4 > 8
    assert b4 < 1e-4 and c4 < 1e-5
