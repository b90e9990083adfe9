"""Issue 3's conservation figure, pinned for every embedded example at its shipped rate.

"Measured with the project's own dynamics at the true masses:
|L(t) - L0| / |L0| <= 1e-4 over the flight."

The generator knows the exact rates of every frame (``SynthResult.velocities``:
the root angular velocity of the RK4 solution, the root velocity from the COM
parabola, the joint rates of the script), and :func:`mocomp.dynamics.momentum`
takes known rates (``velocity=MotionVelocities``) and evaluates eq. 5.4-5.5
with no time differences. At the shipped 120 fps that gives, over every flight
frame (printed with ``pytest -s``; measured here):

==========  ===================  =============  =============
example     exact rates (given)  order-2 diffs  order-4 diffs
==========  ===================  =============  =============
backflip    3.5e-14              3.4e-3         5.7e-4
frontflip   1.2e-14              9.8e-3         2.2e-3
sideflip    2.0e-14              3.8e-3         9.4e-4
twist180    4.4e-14              5.5e-2         2.1e-2
twist360    1.9e-14              2.7e-2         9.8e-3
jump        3.2e-14              3.1e-3         2.5e-4
==========  ===================  =============  =============

(the finite-difference columns over the flight frames whose stencil lies inside
the flight; see ``benchmarks/bench_synth.py`` for the full table). The
finite-difference figures are the truncation error of the velocity estimate:
they fall 4x (order 2) per doubling of the frame rate toward the exact value,
checked below, and the exact rates agree with differences of the motion on the
ground phases too. What the exact figure checks is that the motion's positions,
its rates and the project's eq. 5.5 are one consistent rigid-body system at the
true masses; how closely the RK4 orientation follows the true solution of the
ODE is ``evidence.integration_error_rad`` (~1e-9 rad, ``test_synth_flights.py``).
A peer gives the same figure: MuJoCo's ``subtree_angmom`` on the exported MJCF with
the exact rates as ``qvel`` keeps ``L0`` to 1e-9 .. 6e-9 at 120 fps (backflip 1.1e-9,
sideflip 9.5e-10, twist180 5.9e-9; tiny masses on massless joints in the MJCF).
"""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.dynamics import MotionVelocities, momentum
from mocomp.synth import EXAMPLE_NAMES, backflip, frontflip, make_example, sideflip, straight_jump, twist_jump

GENERATORS = {"backflip": backflip, "frontflip": frontflip, "sideflip": sideflip, "jump": straight_jump,
              "twist180": lambda **k: twist_jump(twist=180.0, **k),
              "twist360": lambda **k: twist_jump(twist=360.0, **k)}


def inner_flight(r, half_width: int) -> np.ndarray:
    """Flight frames whose difference stencil (``half_width`` frames each side) lies inside the flight
    (the landing impact makes the velocities jump at touchdown)."""
    m = r.motion
    a, b = r.flight
    t0, t1 = r.flight_times
    idx = np.arange(a, b)
    return idx[(m.times[idx] - half_width * m.dt >= t0 - 1e-12) & (m.times[idx] + half_width * m.dt <= t1 + 1e-12)]


def rel_dev(r, L, idx) -> float:
    return float(np.max(np.linalg.norm(L[idx] - r.L0, axis=1)) / np.linalg.norm(r.L0))


def test_every_example_is_covered():
    assert set(EXAMPLE_NAMES) == set(GENERATORS)


@pytest.mark.parametrize("name", EXAMPLE_NAMES)
def test_exact_rates_conserve_L_at_the_shipped_rate(name):
    r = make_example(name)
    m = r.motion
    assert m.fps == 120.0                                    # the shipped example, not a resampled one
    a, b = r.flight
    idx = np.arange(a, b)                                    # every flight frame, touchdown side included
    res = r.exact_momentum()
    assert res.velocity_mode == "given"
    dev = rel_dev(r, res.angular, idx)
    dev2 = rel_dev(r, momentum(r.body, m).angular, inner_flight(r, 1))
    dev4 = rel_dev(r, momentum(r.body, m, order=4).angular, inner_flight(r, 2))
    print(f"\n{name} at {m.fps:g} fps: |L - L0|/|L0| over the flight: exact rates {dev:.1e}, "
          f"order-2 differences {dev2:.1e}, order-4 {dev4:.1e}")
    assert dev <= 1e-4                                       # the figure ...
    assert dev <= 1e-9                                       # ... and what the RK4 solution actually keeps
    assert dev2 > 1e3 * dev and dev4 > 1e3 * dev             # the differences are the coarse measurement
    # the linear momentum from the same rates is M times the parabola's velocity (independent of L)
    v = res.com_velocity[a:b]
    assert np.abs(v - r.com_velocity_target()).max() <= 1e-9
    # positions untouched: the COM is the parabola
    assert np.abs(res.com[a:b] - r.com_target()).max() <= 1e-9


@pytest.mark.parametrize("name", ["backflip", "twist360"])
def test_finite_differences_converge_to_the_exact_figure(name):
    """At 120/240/480 fps the order-2 deviation falls ~4x per doubling (O(dt^2)), and
    the exact-rate figure stays at rounding level at every rate."""
    devs, exact = {}, {}
    for fps in (120.0, 240.0, 480.0):
        r = make_example(name) if fps == 120.0 else GENERATORS[name](fps=fps)
        devs[fps] = rel_dev(r, momentum(r.body, r.motion).angular, inner_flight(r, 1))
        exact[fps] = rel_dev(r, r.exact_momentum().angular, np.arange(*r.flight))
    print(f"\n{name}: order-2 {({int(k): f'{v:.1e}' for k, v in devs.items()})}, "
          f"exact {({int(k): f'{v:.0e}' for k, v in exact.items()})}")
    ratios = [devs[f] / devs[2 * f] for f in (120.0, 240.0)]
    assert all(3.0 < q < 5.0 for q in ratios), ratios
    assert max(exact.values()) <= 1e-9


def test_exact_rates_match_differences_on_the_ground_phases():
    """The rates off the flight (pelvis pieces, upper-body script, planted-foot IK legs) are
    checked against order-4 differences of the motion itself: the difference falls with
    the frame rate (it is the differences' error)."""
    gaps = {}
    for fps in (240.0, 960.0):
        r = backflip(fps=fps)
        m = r.motion
        a, b = r.flight
        k = int(fps / 40)                                  # stay clear of the take-off and touchdown joins
        g = np.r_[3:a - k, b + k:m.n_frames - 3]
        ex = r.exact_momentum()
        fd = momentum(r.body, m, order=4)
        scale = np.abs(ex.segment_velocities[g]).max()
        gaps[fps] = float(np.abs(ex.segment_velocities[g] - fd.segment_velocities[g]).max() / scale)
        # no frame is left without a rate
        assert np.all(np.isfinite(r.velocities.joint_angular_velocities))
    print(f"\nbackflip ground phases: max |v_exact - v_fd4| / max |v|: {gaps}")
    assert gaps[960.0] < 2e-4
    assert gaps[240.0] / gaps[960.0] > 8.0


def test_given_velocities_are_checked():
    r = make_example("jump")
    v = r.velocities
    with pytest.raises(ValueError, match="do not fit"):
        momentum(r.body, r.motion[:10], velocity=v)
    assert momentum(r.body, r.motion[5:20], velocity=v[5:20]).angular == pytest.approx(
        r.exact_momentum().angular[5:20], abs=1e-12)
    with pytest.raises(ValueError, match="smooth_sigma and order"):
        momentum(r.body, r.motion, velocity=v, order=4)
    bad = np.array(v.root_velocity)
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="root_velocity is not finite at frame 3"):
        MotionVelocities(bad, v.root_angular_velocity, v.joint_angular_velocities)
    with pytest.raises(ValueError, match="velocity must be one of"):
        momentum(r.body, r.motion, velocity="exact")


@pytest.mark.parametrize("name", ["backflip", "sideflip", "twist180"])
def test_mujoco_with_the_exact_rates_keeps_L0(name):
    """A peer's figure: MuJoCo (subtree_angmom of the root on the exported MJCF), fed the
    generator's exact rates as qvel at the shipped 120 fps, gives L0 over the flight."""
    pytest.importorskip("mujoco")
    from mocomp.dynamics.mujoco_check import build_mujoco, mujoco_momentum, qpos_qvel

    r = make_example(name)
    model, data = build_mujoco(r.body)
    q, v = qpos_qvel(r.motion, model, velocities=r.velocities)
    mj = mujoco_momentum(r.body, r.motion, model, data, q, v)
    dev = rel_dev(r, mj.angular, np.arange(*r.flight))
    ours = r.exact_momentum()
    agree = float(np.max(np.linalg.norm(mj.angular - ours.angular, axis=1)) / np.max(np.linalg.norm(ours.angular,
                                                                                                   axis=1)))
    print(f"\n{name} at 120 fps, MuJoCo with the exact rates: |L - L0|/|L0| over the flight {dev:.1e}; "
          f"MuJoCo vs ours over the whole clip {agree:.1e}")
    assert dev <= 1e-8          # measured 1e-9 .. 6e-9 (MuJoCo adds tiny masses to massless joints)
    assert agree <= 1e-8
