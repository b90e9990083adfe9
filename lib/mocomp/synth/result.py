"""``SynthResult``: a generated motion together with its exact ground truth."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..body.model import BodyModel
from ..core.motion import Motion
from ..dynamics.momentum import MotionVelocities

__all__ = ["SynthResult", "FlightEvidence"]


@dataclass(frozen=True)
class FlightEvidence:
    """How the flight was made, and how well (numbers a researcher checks first).

    Attributes
    ----------
    rotation_target_deg, rotation_deg: requested and achieved root rotation about
        the nominal axis during the flight (take-off to touchdown), degrees,
        accumulated (unwrapped) over the integration steps.
    total_rotation_deg: achieved rotation about the nominal axis from the first
        to the last frame (the requested ``rotations`` x 360, or the twist angle).
    landing_error_rad: angle between the integrated root orientation at
        touchdown and the designed landing orientation (shooting residual).
    shooting_evaluations: flight integrations the shooting needed.
    substep_dt: RK4 step, seconds; n_steps: RK4 steps over the flight.
    integration_error_rad: root-orientation difference at touchdown between the
        RK4 solution and one with half the step (a bound on the integration error).
    takeoff: root linear velocity ``v_root`` and angular velocity ``w_root``
        (world, m/s and rad/s), heel-rise rate ``heel_rate`` (rad/s) and mean
        knee angular velocity ``knee_rate`` (rad/s, negative = extending) at take-off.
    landing: root velocities at touchdown (continuous across it), the COM velocity
        before and after, ``L`` after, and the momentum jumps ``dp`` (kg m/s) and
        ``dL`` (kg m^2/s) as the feet stop -- the impact (see :mod:`mocomp.synth.flights`).
    seconds: wall-clock time of the generation.
    """

    rotation_target_deg: float
    rotation_deg: float
    total_rotation_deg: float
    landing_error_rad: float
    shooting_evaluations: int
    substep_dt: float
    n_steps: int
    integration_error_rad: float
    takeoff: dict
    landing: dict
    seconds: float


@dataclass(frozen=True, eq=False)
class SynthResult:
    """A physically exact synthetic motion and its ground truth.

    Attributes
    ----------
    motion: the :class:`~mocomp.core.Motion` (31-joint CMU-named skeleton, y-up, metres).
    body: the :class:`~mocomp.body.BodyModel` with the *true* masses and inertias
        the flight was integrated with.
    L0: ``(3,)`` kg m^2/s, whole-body angular momentum about the COM during the
        flight (world axes); constant over the flight by construction.
    flight: ``(start, stop)`` half-open range of the airborne frames (no contact:
        every frame ``start <= i < stop`` lies strictly between take-off and touchdown).
    flight_times: ``(t0, t1)`` seconds, take-off and touchdown instants (``t0`` is
        a frame time; ``t1`` in general is not).
    contacts: effector joint name -> ``(T,)`` bool, True while that joint is a
        ground contact (``LeftToeBase``: ball of the foot planted; ``LeftFoot``:
        heel down as well).
    g: gravity used, m/s^2 (along -y).
    com_parabola: ``(3, 3)`` polynomial coefficients of the COM over the flight,
        one row per axis (x, y, z), highest power first, in *absolute* time:
        ``COM_k(t) = c[k, 0] t^2 + c[k, 1] t + c[k, 2]`` for ``t0 <= t <= t1``
        (``c[1, 0] = -g/2``; ``c[0, 0] = c[2, 0] = 0``).
    params: the generator name and every parameter it was called with.
    phases: phase name -> ``(start, stop)`` half-open frame range
        (``stand``, ``crouch``, ``extension``, ``flight``, ``absorption``, ``recovery``, ``hold``).
    evidence: :class:`FlightEvidence`.
    velocities: :class:`~mocomp.dynamics.momentum.MotionVelocities`, the exact rates of
        every frame as the generator knows them: in flight the root angular velocity
        of the RK4 solution (``w = I_c^-1 (R^T L0 - h)`` at that orientation), the root
        velocity from the closed-form COM parabola and the joint rates of the script
        (``J_r(phi) phi_dot``); on the ground the analytic rates of the pelvis pieces
        and the upper-body script, and the legs' rates as the directional derivative
        of the planted-foot IK along the pelvis and heel motion (central difference
        with a 1e-6 step of the closed-form IK: ~1e-9 rad/s). ``None`` only for a
        result built by hand.
    """

    motion: Motion
    body: BodyModel
    L0: np.ndarray
    flight: tuple[int, int]
    flight_times: tuple[float, float]
    contacts: dict
    g: float
    com_parabola: np.ndarray
    params: dict = field(default_factory=dict)
    phases: dict = field(default_factory=dict)
    evidence: FlightEvidence | None = None
    velocities: MotionVelocities | None = None

    def __post_init__(self):
        for name in ("L0", "com_parabola"):
            a = np.array(getattr(self, name), dtype=float, copy=True)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        cont = {}
        for k, v in self.contacts.items():
            a = np.array(v, dtype=bool, copy=True)
            a.setflags(write=False)
            cont[k] = a
        object.__setattr__(self, "contacts", cont)

    def com_target(self, times: Any = None) -> np.ndarray:
        """``(N, 3)`` the exact COM parabola at ``times`` (default: the flight frames' times)."""
        if times is None:
            times = self.motion.times[self.flight[0]:self.flight[1]]
        t = np.asarray(times, dtype=float).reshape(-1)
        return np.stack([np.polyval(self.com_parabola[k], t) for k in range(3)], axis=1)

    def com_velocity_target(self, times: Any = None) -> np.ndarray:
        """``(N, 3)`` the exact COM velocity over the flight at ``times``."""
        if times is None:
            times = self.motion.times[self.flight[0]:self.flight[1]]
        t = np.asarray(times, dtype=float).reshape(-1)
        return np.stack([np.polyval(np.polyder(self.com_parabola[k]), t) for k in range(3)], axis=1)

    def exact_momentum(self):
        """:func:`mocomp.dynamics.momentum` of the motion at the true masses from the exact
        :attr:`velocities` (no time differences): ``angular`` stays ``L0`` over the flight
        to the RK4 error (issue 3's conservation figure)."""
        from ..dynamics.momentum import momentum

        if self.velocities is None:
            raise ValueError("this SynthResult carries no velocities")
        return momentum(self.body, self.motion, velocity=self.velocities)

    @property
    def airborne(self) -> np.ndarray:
        """``(T,)`` bool, True on the flight frames."""
        a = np.zeros(self.motion.n_frames, dtype=bool)
        a[self.flight[0]:self.flight[1]] = True
        return a

    def flight_motion(self) -> Motion:
        """The airborne frames as a motion of their own."""
        return self.motion[self.flight[0]:self.flight[1]]

    def __repr__(self) -> str:
        name = self.params.get("generator", "synthetic")
        return (f"SynthResult({name}: {self.motion.n_frames} frames at {self.motion.fps:g} fps, "
                f"flight frames {self.flight}, |L0|={np.linalg.norm(self.L0):.3f} kg m^2/s, "
                f"{self.body.total_mass:.1f} kg)")
