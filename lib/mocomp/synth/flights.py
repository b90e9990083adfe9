"""Physically exact synthetic jumps: somersaults, twists and straight jumps.

Every generator returns a :class:`~mocomp.synth.result.SynthResult`: the motion
of the 31-joint CMU-named performer (:func:`~mocomp.synth.skeleton.synthetic_skeleton`)
and its ground truth (true body model, angular momentum ``L0``, flight frames,
contacts, gravity, COM parabola).

Physics of the flight (take-off ``t0`` to touchdown ``t1``)
------------------------------------------------------------
* The joint angles follow a smooth script (septic-smoothstep keyframes: take-off
  pose -> tuck -> hold -> landing pose), written as local rotation vectors with
  analytic rates.
* The root (pelvis) **orientation** is integrated so that the whole-body angular
  momentum about the COM stays ``L0``: with the composite inertia ``I_c`` and the
  joints' relative momentum ``h`` in the pelvis frame (dissertation eq. 5.5 split
  into root and joint parts), ``w = I_c^-1 (R^T L0 - h)`` and
  ``q' = 1/2 q (x) (w, 0)``, integrated with classical RK4 on a sub-step grid
  (default 960 Hz, a whole number of sub-steps per frame) and renormalised.
* The root **translation** is set in closed form so that the COM (the same
  :class:`~mocomp.body.BodyModel` fields as :func:`mocomp.dynamics.center_of_mass`)
  follows ``COM(t) = COM(t0) + v0 (t - t0) - g/2 (t - t0)^2 y`` with ``g = 9.81``.
* ``L0`` is found by shooting: a secant search on its magnitude along the nominal
  axis (so the requested number of turns is reached), then chord-Newton on all
  three components until the integrated root orientation at touchdown equals the
  designed landing orientation (residual ~1e-14 rad).

Continuity at take-off and touchdown
-------------------------------------
* **Take-off** (``t0`` is a frame time): *everything* is C^1 -- root position and
  orientation, their velocities, every joint angle and joint angular velocity.
  Hence the COM velocity and ``L`` are continuous and the ball of each foot has
  zero velocity as it leaves the ground. The take-off velocities are solved from
  a linear system (COM velocity = parabola's, ``L = L0``, mean knee rate = the
  design's) whose unknowns are the pelvis velocity, its angular velocity and the
  heel-rise rate, with the legs' rates given by the planted-foot IK; the flight
  script starts with exactly those leg rates (a decaying correction over the
  first ~0.08 s). The root acceleration is also continuous (C^2); angular and
  joint accelerations are not.
* **Touchdown** (``t1``, in general between frames): the pelvis position,
  orientation, velocity and angular velocity and the upper-body joints are
  continuous; the balls of the feet stop dead (foot velocity jumps to zero, as in
  a real impact) and the heels come down at the rate that gives the designed
  knee flexion rate (at most 40 rad/s; a harder landing puts the rest on the
  knees, and more than 40 rad/s there is refused), so the leg joint rates, the
  COM velocity and ``L`` jump. The jumps are reported in
  ``result.evidence.landing`` (``dp``, ``dL``). Keeping ``p`` and ``L``
  continuous instead would need a jump of several rad/s in the pelvis rotation
  (a visible jolt of the whole upper body), which real landings do not show.
* Ground phases (stand, countermovement crouch, extension, absorption,
  recovery) are kinematic: pelvis paths are quintic Hermite pieces, legs come
  from closed-form IK with the toe joints fixed (foot skate at rounding level).

Measured with the project's own dynamics
----------------------------------------
The result carries the exact rates of every frame (``result.velocities``, a
:class:`~mocomp.dynamics.momentum.MotionVelocities`: in flight the RK4 solution's
root angular velocity, the root velocity from the COM parabola and the script's
joint rates). From them :func:`mocomp.dynamics.momentum` (``velocity=result.velocities``,
or ``result.exact_momentum()``) evaluates eq. 5.5 at the true masses with no time
differences: at the shipped 120 fps ``|L(t) - L0| / |L0|`` over every flight frame
is 1e-14 .. 4e-14 for all six embedded examples (issue 3 asks <= 1e-4;
``tests/test_synth_conservation.py`` pins it, ``benchmarks/bench_synth.py`` prints it;
MuJoCo fed the same rates as ``qvel`` gives 1e-9 .. 6e-9).
The RK4 error of the orientation itself is ~1e-10 rad
(``evidence.integration_error_rad``). :func:`mocomp.dynamics.center_of_mass`
follows the parabola to ~1e-15 m.

Estimating the velocities by central differences of the motion instead (the
default of :func:`~mocomp.dynamics.momentum`, as for capture data) adds the
differences' O(dt^2) truncation error: over the flight (frames whose stencil
lies inside it) 3.1e-3 (jump), 3.4e-3 (backflip), 3.8e-3 (sideflip), 9.8e-3
(frontflip), 2.7e-2 (twist360) and 5.5e-2 (twist180) at 120 fps (``order=4``:
2.5e-4 .. 2.1e-2); for the backflip 8.7e-4 at 240, 2.2e-4 at 480 and 5.4e-5 at
960 fps (4x per doubling, toward the exact figure). The twists, with a small
``L0`` and fast arm folding, have the largest relative error.

What is *not* modelled: ground reaction forces during the ground phases (the
ground phases are kinematic, not dynamically consistent), muscle limits, and a
heel-toe roll at touchdown beyond the heel lowering.

Parameters common to all generators
-----------------------------------
height, mass: the performer's stature (m) and body mass (kg).
table, shape: body segment table and solid (:meth:`~mocomp.body.BodyModel.from_skeleton`).
mass_factors: per-segment mass factors (segment, group or joint names, or the
    preset ``"tall_performer"``), renormalised to ``mass``; see :mod:`~mocomp.synth.bodies`.
mass_noise: log-normal relative sigma of random per-segment mass factors (seeded).
variation: 0..1, random variation of the key poses (about 6 deg per joint axis
    at 1), phase durations (10 %) and jump height (5 %); 0 gives the canonical motion.
seed: seeds ``mass_noise`` and ``variation`` (a motion is a pure function of its parameters).
jump_height: COM rise from take-off to apex, m.
takeoff_level, landing_level: floor heights (m) at take-off and landing.
fps: frame rate of the returned motion (default 120); substep_rate: RK4 rate, Hz.
"""
from __future__ import annotations

import math

import numpy as np

from ._engine import Design, Key, generate
from .bodies import true_body
from .poses import pose
from .result import SynthResult
from .skeleton import synthetic_skeleton

__all__ = ["backflip", "frontflip", "sideflip", "twist_jump", "straight_jump", "GENERATORS"]


def _check(name, value, lo, hi):
    v = float(value)
    if not (np.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} must be in [{lo}, {hi}], got {value!r}")
    return v


def _check_turns(rotations) -> int:
    """Whole turns only: a somersault lands on the feet after 1, 2, ... turns."""
    r = _check("rotations", rotations, 1.0, 4.0)
    if r != round(r):
        raise ValueError(f"rotations must be a whole number of turns (1..4) to land on the feet, got {rotations!r}")
    return int(round(r))


class _Builder:
    """Common parameter handling: skeleton, body, seeded variation, key construction."""

    def __init__(self, generator, params):
        self.generator = generator
        self.params = {"generator": generator, **params}
        p = params
        self.H = _check("height", p["height"], 1.0, 2.4)
        _check("mass", p["mass"], 20.0, 250.0)
        self.variation = _check("variation", p["variation"], 0.0, 1.0)
        self.tuck = _check("tuck", p["tuck"], 0.0, 1.0)
        _check("jump_height", p["jump_height"], 0.05, 3.0)
        _check("takeoff_level", p["takeoff_level"], -5.0, 5.0)
        _check("landing_level", p["landing_level"], -5.0, 5.0)
        _check("fps", p["fps"], 1.0, 20000.0)
        seq = np.random.SeedSequence(int(p["seed"]))
        mass_seq, style_seq = seq.spawn(2)
        self.style = np.random.default_rng(style_seq)
        self.sk = synthetic_skeleton(self.H)
        # root and hip carriers stay at identity (see mocomp.synth._engine)
        self.fixed = [self.sk.index(n) for n in ("Hips", "LHipJoint", "RHipJoint")]
        self.body = true_body(self.sk, p["mass"], p["table"], p["shape"], p["mass_factors"], p["mass_noise"],
                              np.random.default_rng(mass_seq))

    def pose(self, **kw):
        rv = pose(self.sk, **kw)
        if self.variation:
            noise = self.style.normal(0.0, math.radians(6.0) * self.variation, rv.shape)
            noise[self.fixed] = 0.0
            rv = rv + noise
        return rv

    def dur(self, seconds):
        if self.variation:
            seconds *= math.exp(self.style.normal(0.0, 0.10 * self.variation))
        return seconds

    def key(self, theta, knee, heel, lead, upper, tilt=(0.0, 0.0, 0.0)):
        return Key(math.radians(theta), tuple(math.radians(a) for a in tilt), knee, heel, lead, upper)

    def run(self, **design) -> SynthResult:
        p = self.params
        h = p["jump_height"]
        if self.variation:
            h *= math.exp(self.style.normal(0.0, 0.05 * self.variation))
        d = Design(generator=self.generator, jump_height=h, takeoff_level=p["takeoff_level"],
                   landing_level=p["landing_level"], params=self.params, **design)
        return generate(d, self.sk, self.body, fps=p["fps"], substep_rate=p["substep_rate"])


def _common(height, mass, table, shape, mass_factors, mass_noise, variation, seed, fps, substep_rate):
    return dict(height=height, mass=mass, table=table, shape=shape, mass_factors=mass_factors,
                mass_noise=mass_noise, variation=variation, seed=seed, fps=fps, substep_rate=substep_rate)


def _tuck_legs(b: _Builder, tuck: float):
    return b.pose(hip_flex=15 + 110 * tuck, hip_abd=4, knee=10 + 120 * tuck, ankle=35)


def _tuck_upper(b: _Builder, tuck: float):
    return b.pose(flex=8 + 27 * tuck, neck=12 * tuck, shoulder_flex=55 + 10 * tuck, shoulder_abd=12,
                  elbow=25 + 40 * tuck)


def backflip(*, rotations: float = 1.0, tuck: float = 1.0, jump_height: float = 0.5, travel: float = 0.4,
             takeoff_level: float = 0.0, landing_level: float = 0.0, height: float = 1.75, mass: float = 70.0,
             table: str = "de_leva_male", shape: str = "ellipsoid", mass_factors=None, mass_noise: float = 0.0,
             variation: float = 0.0, seed: int = 0, fps: float = 120.0, substep_rate: float = 960.0) -> SynthResult:
    """Standing back somersault (tucked by default): ``rotations`` backward turns
    about the performer's left-right axis, travelling ``travel`` metres backwards.

    See the module docstring for the physics and the common parameters.
    """
    rotations = _check_turns(rotations)
    b = _Builder("backflip", dict(rotations=rotations, tuck=tuck, jump_height=jump_height, travel=travel,
                                  takeoff_level=takeoff_level, landing_level=landing_level,
                                  **_common(height, mass, table, shape, mass_factors, mass_noise, variation, seed,
                                            fps, substep_rate)))
    turn = 360.0 * rotations
    return b.run(
        axis=np.array([-1.0, 0.0, 0.0]), total_angle=math.radians(turn),
        travel=np.array([0.0, 0.0, -_check("travel", travel, -3.0, 3.0)]),
        stand=b.dur(0.25), crouch=b.dur(0.45), extend=b.dur(0.28), recover=b.dur(0.55), hold=b.dur(0.30),
        stand_key=b.key(0, 5, 0, 0.0, b.pose()),
        crouch_key=b.key(-25, 85, 0, 0.0, b.pose(flex=25, shoulder_flex=-50, elbow=20)),
        takeoff_key=b.key(20, 30, 25, 0.04, b.pose(flex=-15, shoulder_flex=160, shoulder_abd=5, elbow=10, head=-20)),
        landing_key=b.key(turn - 40, 30, 20, 0.0, b.pose(flex=20, shoulder_flex=80, shoulder_abd=20, elbow=20)),
        absorbed_key=b.key(turn - 35, 75, 0, 0.0, b.pose(flex=30, shoulder_flex=70, shoulder_abd=15, elbow=25)),
        final_key=b.key(turn, 5, 0, 0.0, b.pose()),
        tuck_legs=_tuck_legs(b, b.tuck), tuck_upper=_tuck_upper(b, b.tuck),
        tuck_in=0.28, tuck_out=0.32, knee_rate=-15.0, landing_knee_rate=12.0, upper_lag=0.08)


def frontflip(*, rotations: float = 1.0, tuck: float = 1.0, jump_height: float = 0.5, travel: float = 0.6,
              takeoff_level: float = 0.0, landing_level: float = 0.0, height: float = 1.75, mass: float = 70.0,
              table: str = "de_leva_male", shape: str = "ellipsoid", mass_factors=None, mass_noise: float = 0.0,
              variation: float = 0.0, seed: int = 0, fps: float = 120.0, substep_rate: float = 960.0) -> SynthResult:
    """Standing front somersault (tucked by default): ``rotations`` forward turns,
    travelling ``travel`` metres forwards. See the module docstring."""
    rotations = _check_turns(rotations)
    b = _Builder("frontflip", dict(rotations=rotations, tuck=tuck, jump_height=jump_height, travel=travel,
                                   takeoff_level=takeoff_level, landing_level=landing_level,
                                   **_common(height, mass, table, shape, mass_factors, mass_noise, variation, seed,
                                             fps, substep_rate)))
    turn = 360.0 * rotations
    return b.run(
        axis=np.array([1.0, 0.0, 0.0]), total_angle=math.radians(turn),
        travel=np.array([0.0, 0.0, _check("travel", travel, -3.0, 3.0)]),
        stand=b.dur(0.25), crouch=b.dur(0.45), extend=b.dur(0.28), recover=b.dur(0.55), hold=b.dur(0.30),
        stand_key=b.key(0, 5, 0, 0.0, b.pose()),
        crouch_key=b.key(25, 85, 0, 0.0, b.pose(flex=25, shoulder_flex=-40, elbow=20)),
        takeoff_key=b.key(15, 30, 25, 0.05, b.pose(flex=10, shoulder_flex=170, shoulder_abd=5, elbow=10, head=5)),
        landing_key=b.key(turn + 20, 30, 20, 0.0, b.pose(flex=25, shoulder_flex=90, shoulder_abd=25, elbow=20)),
        absorbed_key=b.key(turn + 30, 75, 0, 0.0, b.pose(flex=30, shoulder_flex=70, shoulder_abd=15, elbow=25)),
        final_key=b.key(turn, 5, 0, 0.0, b.pose()),
        tuck_legs=_tuck_legs(b, b.tuck), tuck_upper=_tuck_upper(b, b.tuck),
        tuck_in=0.28, tuck_out=0.32, knee_rate=-15.0, landing_knee_rate=12.0, upper_lag=0.08)


def sideflip(*, rotations: float = 1.0, tuck: float = 1.0, jump_height: float = 0.5, travel: float = 0.5,
             takeoff_level: float = 0.0, landing_level: float = 0.0, height: float = 1.75, mass: float = 70.0,
             table: str = "de_leva_male", shape: str = "ellipsoid", mass_factors=None, mass_noise: float = 0.0,
             variation: float = 0.0, seed: int = 0, fps: float = 120.0, substep_rate: float = 960.0) -> SynthResult:
    """Side somersault toward the performer's left (head leads to the left, about
    the forward axis), travelling ``travel`` metres to the left. See the module docstring.

    The body is not symmetric about the rotation plane: raising the legs into the
    tuck and lowering the arms make it counter-rotate about the left-right axis,
    so ``L0`` leans off the nominal axis (about 16 deg for the full tuck); the
    shooting finds all three components. ``tuck`` must be at least 0.6: a more
    open body has two nearly equal largest principal moments (layout: 11.5 and
    11.7 kg m^2 for the default performer) or rotates about its unstable
    intermediate axis, and the landing orientation then depends too sensitively
    on ``L0`` for the shooting.
    """
    rotations = _check_turns(rotations)
    if _check("tuck", tuck, 0.0, 1.0) < 0.6:
        raise ValueError(f"sideflip needs tuck >= 0.6 (got {tuck!r}): a more open side somersault rotates about a "
                         "(nearly) intermediate principal axis and cannot be shot reliably")
    b = _Builder("sideflip", dict(rotations=rotations, tuck=tuck, jump_height=jump_height, travel=travel,
                                  takeoff_level=takeoff_level, landing_level=landing_level,
                                  **_common(height, mass, table, shape, mass_factors, mass_noise, variation, seed,
                                            fps, substep_rate)))
    turn = 360.0 * rotations
    return b.run(
        axis=np.array([0.0, 0.0, -1.0]), total_angle=math.radians(turn),
        travel=np.array([_check("travel", travel, -3.0, 3.0), 0.0, 0.0]),
        stand=b.dur(0.25), crouch=b.dur(0.45), extend=b.dur(0.28), recover=b.dur(0.55), hold=b.dur(0.30),
        stand_key=b.key(0, 5, 0, 0.0, b.pose()),
        crouch_key=b.key(-5, 85, 0, 0.0, b.pose(flex=25, side=-5, shoulder_flex=-30, shoulder_abd=30, elbow=20),
                         tilt=(25, 0, 0)),
        takeoff_key=b.key(12, 30, 25, 0.04, b.pose(flex=0, side=10, shoulder_flex=150, shoulder_abd=40, elbow=10),
                          tilt=(0, 0, 0)),
        landing_key=b.key(turn - 20, 30, 20, 0.0, b.pose(flex=20, side=-8, shoulder_flex=60, shoulder_abd=50,
                                                          elbow=20), tilt=(0, 0, 0)),
        absorbed_key=b.key(turn - 5, 75, 0, 0.0, b.pose(flex=30, shoulder_flex=60, shoulder_abd=30, elbow=25),
                           tilt=(30, 0, 0)),
        final_key=b.key(turn, 5, 0, 0.0, b.pose()),
        tuck_legs=_tuck_legs(b, b.tuck), tuck_upper=_tuck_upper(b, b.tuck),
        tuck_in=0.28, tuck_out=0.32, knee_rate=-15.0, landing_knee_rate=12.0, upper_lag=0.08)


def twist_jump(*, twist: float = 360.0, tuck: float = 0.0, jump_height: float = 0.45, travel: float = 0.0,
               takeoff_level: float = 0.0, landing_level: float = 0.0, height: float = 1.75, mass: float = 70.0,
               table: str = "de_leva_male", shape: str = "ellipsoid", mass_factors=None, mass_noise: float = 0.0,
               variation: float = 0.0, seed: int = 0, fps: float = 120.0, substep_rate: float = 960.0) -> SynthResult:
    """Vertical jump with ``twist`` degrees of turn about the vertical (positive: to
    the performer's left, counter-clockwise seen from above); the feet land turned
    by ``twist``. The arms are pulled in to the chest in the air to spin faster.
    ``tuck`` > 0 also draws the knees up. See the module docstring."""
    twist = _check("twist", twist, -1080.0, 1080.0)
    if abs(twist) < 45:
        raise ValueError(f"twist must be at least 45 degrees in magnitude (use straight_jump), got {twist!r}")
    b = _Builder("twist_jump", dict(twist=twist, tuck=tuck, jump_height=jump_height, travel=travel,
                                    takeoff_level=takeoff_level, landing_level=landing_level,
                                    **_common(height, mass, table, shape, mass_factors, mass_noise, variation, seed,
                                              fps, substep_rate)))
    sgn = 1.0 if twist > 0 else -1.0
    T = abs(twist)
    wind = min(25.0, 0.1 * T)
    return b.run(
        axis=np.array([0.0, sgn, 0.0]), total_angle=math.radians(T),
        travel=np.array([0.0, 0.0, _check("travel", travel, -3.0, 3.0)]),
        stand=b.dur(0.25), crouch=b.dur(0.45), extend=b.dur(0.28), recover=b.dur(0.55), hold=b.dur(0.30),
        stand_key=b.key(0, 5, 0, 0.0, b.pose()),
        crouch_key=b.key(-wind, 80, 0, 0.0, b.pose(flex=20, twist=-sgn * 15, shoulder_flex=30, shoulder_abd=40,
                                                   elbow=60), tilt=(20, 0, 0)),
        takeoff_key=b.key(wind, 25, 25, 0.0, b.pose(flex=0, twist=sgn * 10, shoulder_flex=100, shoulder_abd=40,
                                                    elbow=60), tilt=(0, 0, 0)),
        landing_key=b.key(T - wind, 25, 20, 0.0, b.pose(flex=15, shoulder_flex=60, shoulder_abd=45, elbow=30),
                          tilt=(0, 0, 0)),
        absorbed_key=b.key(T - 3, 70, 0, 0.0, b.pose(flex=25, shoulder_flex=50, shoulder_abd=30, elbow=30),
                           tilt=(28, 0, 0)),
        final_key=b.key(T, 5, 0, 0.0, b.pose()),
        tuck_legs=b.pose(hip_flex=5 + 110 * b.tuck, knee=5 + 120 * b.tuck, ankle=35),
        tuck_upper=b.pose(flex=2 + 25 * b.tuck, shoulder_flex=25, shoulder_abd=18, shoulder_rot=65, elbow=115,
                          neck=5),
        tuck_in=0.25, tuck_out=0.30, knee_rate=-15.0, landing_knee_rate=12.0, upper_lag=0.06)


def straight_jump(*, tuck: float = 0.0, jump_height: float = 0.4, travel: float = 0.0,
                  takeoff_level: float = 0.0, landing_level: float = 0.0, height: float = 1.75, mass: float = 70.0,
                  table: str = "de_leva_male", shape: str = "ellipsoid", mass_factors=None, mass_noise: float = 0.0,
                  variation: float = 0.0, seed: int = 0, fps: float = 120.0,
                  substep_rate: float = 960.0) -> SynthResult:
    """Countermovement jump straight up with an arm swing (``tuck`` > 0: a tuck
    jump), travelling ``travel`` metres forwards. ``L0`` is small but not zero:
    the shooting chooses it so the performer lands upright. See the module docstring."""
    b = _Builder("straight_jump", dict(tuck=tuck, jump_height=jump_height, travel=travel,
                                       takeoff_level=takeoff_level, landing_level=landing_level,
                                       **_common(height, mass, table, shape, mass_factors, mass_noise, variation,
                                                 seed, fps, substep_rate)))
    return b.run(
        axis=np.array([1.0, 0.0, 0.0]), total_angle=0.0,
        travel=np.array([0.0, 0.0, _check("travel", travel, -3.0, 3.0)]),
        stand=b.dur(0.25), crouch=b.dur(0.45), extend=b.dur(0.28), recover=b.dur(0.55), hold=b.dur(0.30),
        stand_key=b.key(0, 5, 0, 0.0, b.pose()),
        crouch_key=b.key(25, 85, 0, 0.0, b.pose(flex=25, shoulder_flex=-50, elbow=20)),
        takeoff_key=b.key(5, 25, 25, 0.0, b.pose(flex=0, shoulder_flex=150, shoulder_abd=10, elbow=10)),
        landing_key=b.key(15, 25, 20, 0.0, b.pose(flex=15, shoulder_flex=70, shoulder_abd=20, elbow=20)),
        absorbed_key=b.key(30, 70, 0, 0.0, b.pose(flex=25, shoulder_flex=50, shoulder_abd=15, elbow=25)),
        final_key=b.key(0, 5, 0, 0.0, b.pose()),
        tuck_legs=b.pose(hip_flex=5 + 115 * b.tuck, knee=5 + 125 * b.tuck, ankle=30),
        tuck_upper=b.pose(flex=2 + 20 * b.tuck, shoulder_flex=120 - 60 * b.tuck, shoulder_abd=15,
                          elbow=15 + 40 * b.tuck),
        tuck_in=0.3, tuck_out=0.35, knee_rate=-15.0, landing_knee_rate=12.0, upper_lag=0.06)


#: generator name -> function
GENERATORS = {"backflip": backflip, "frontflip": frontflip, "sideflip": sideflip, "twist_jump": twist_jump,
              "straight_jump": straight_jump}
