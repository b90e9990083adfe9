"""Perturbed ballistic motions: the stimuli of the flips paper's perception study.

Flips paper section 7 (dissertation section 5.7): "Errors in angular momentum
were created by the motion retiming during the flight phase. We tested both
abrupt changes - sudden introduction of retiming in the middle of the flight
phase, and smooth changes in angular momentum - retiming factor growing
linearly and achieving maximum value just before landing. [...] The errors
didn't change the direction of the angular momentum vector. Errors in take-off
angle were introduced by modifying the linear velocity in the flight phase
along the direction of the jump."

How the flight is rebuilt (the paper leaves this open; our choices)
--------------------------------------------------------------------
Let the base flight run from the first airborne frame ``a`` (time ``t_a``) to the
last airborne frame ``b - 1`` (time ``t_b``), ``T = t_b - t_a``, and let ``c(s)`` be
the base motion's centre of mass (COM) at original time ``s``.

1. **Retiming** (angular-momentum errors). The new clock ``u`` runs from take-off;
   the flight's poses are taken at original time ``t_a + sigma(u)`` with rate
   ``r(u) = dsigma/du``. Retiming scales every velocity by ``r`` (flips paper
   eq. 5.8: ``v_new = n v``), hence the angular momentum about the COM by ``r``
   with its direction unchanged; the relative error is ``r - 1``:

   * abrupt, error ``e`` (``+level`` increase, ``-level`` decrease): ``r = 1`` until
     the original time reaches ``t_a + phi T`` (``phi`` = ``switch_fraction``,
     0.5 = "the middle of the flight"), then ``r = 1 + e``;
   * smooth: ``r(u) = 1 + e u / T'``, reaching ``1 + e`` at landing;

   the new flight lasts ``T'`` with ``sigma(T') = T``: all the flight's poses are
   shown, in order, and the character lands in the original landing pose
   (on its feet). Abrupt: ``T' = phi T + (1 - phi) T / (1 + e)``; smooth:
   ``T' = T / (1 + e/2)``. Take-off and landing phases keep their timing
   (the landing phase starts ``T' - T`` later).

2. **COM parabola re-fitted**. ``P0(u) = c(t_a) + v0 u - g u^2/2 y`` with
   ``v0 = (c(t_b) - c(t_a)) / T + g T / 2 y`` is the exact ballistic flight
   (gravity ``g``, default 9.81 m/s^2) through the captured take-off and
   landing COM. A perturbed flight gets its own parabola ``P(u)`` over ``T'``:
   for a retimed flight ``v = kappa v0`` with ``kappa`` chosen so the COM comes
   back to the landing height exactly at ``T'``:
   ``kappa = (dy + g T'^2/2) / (v0_y T')`` (``dy`` = landing minus take-off COM
   height). Scaling the whole take-off velocity keeps the **take-off angle**
   unchanged (only its speed changes, ``kappa ~ T'/T``), so angular-momentum
   stimuli are not confounded with the take-off-angle stimuli; this is the
   repositioning of flips paper section 5.4 (``COM_y = a_y t^2 + k b_y t + c_y``,
   horizontal velocity scaled by ``k``). Two ways to move the body onto it
   (``com_mode``):

   * ``"capture"`` (default): the root is moved by ``P(u) - P0(sigma(u))``, the
     difference between the new and the original *ideal* flights. The
     unperturbed control is then the capture itself, untouched ("original
     motion capture clips were used as base motions", sec. 7), and every
     stimulus keeps the capture's own small deviations from a ballistic COM
     (retimed with the poses), so control and stimulus differ only by the
     perturbation;
   * ``"ballistic"``: the root is moved by ``P(u) - c(u)`` so that the flight COM
     *is* the parabola in every stimulus, control included (physically exact
     COM; the change is reported as ``root_offset``).

   Either way the translation does not change the angular momentum about the
   COM (section 5.1, "Repositioning of the center of mass"); for an exact
   (synthetic) flight both modes give the same motions.

3. **Take-off-angle errors**: the flight keeps its timing (``T' = T``) and the
   horizontal velocity component along the jump direction ``h`` (the horizontal
   direction of ``v0``) is scaled: ``v = v0 + e (v0 . h) h``; the vertical
   component, the flight time and the angular momentum are unchanged, so the
   take-off angle ``atan(v_y / v_h)`` changes and the body lands
   ``e (v0 . h) T`` further along ``h``.

4. **Landing**: after the flight the landing phase is translated by the
   horizontal offset ``P(T') - c(t_b)`` (its vertical offset is zero by
   construction): the character lands on its feet at the original landing
   height, further or nearer along the jump direction. The take-off phase is
   untouched: every stimulus of a base starts at the same take-off position.

What is *not* preserved (and is reported as evidence): the COM velocity jumps
at take-off and landing when ``v != v0`` (the linear-momentum discontinuity that
any retimed flight or changed take-off angle carries: ``|v - v0|`` at take-off
and ``|(v - g T' y) - (v0 - g T y)|`` at touchdown, manifest columns
``takeoff_dv_added_ms`` / ``landing_dv_added_ms``), and the rotation speed, which
drops by the factor ``r(T')`` at touchdown where the captured landing resumes.
The paper's :math:`k^*` retiming of take-off/landing (App. B) would hide the
linear jump but also alter the ground phases, which the study holds fixed (the
paper's study retimed "during the flight phase" only; section 5.3 notes that
small linear-momentum discontinuities are not perceptible). What a participant
sees, with the numbers of the paper design: ``stimuli/README.md``.

Rotation-only angular-momentum errors (``am_mode = "rotation"``, :func:`rotate_flight`)
------------------------------------------------------------------------------------
The retiming above changes the flight time, the jump height and the take-off speed
together with ``L`` (issue 19: the synthetic back flip at -50 % abrupt rises 0.47 ->
1.14 m and flies 0.66 -> 0.99 s), so a study on it partly measures those cues. The
rotation-only mode changes the rotation alone: every frame keeps the base's posture
(joint angles) and its COM at the same time (the COM trajectory, the flight's frames
and duration, and every ground frame are the base's exactly); only the body's
orientation about the axis ``n`` of the flight's mean ``L`` is retimed. With
``omega_n(u) = L_n(u) / I_nn(u)`` the base's effective somersault rate (``I`` the
whole-body inertia about the COM, :func:`mocomp.dynamics.composite_inertia`), the
stimulus turns at ``rho(u) omega_n(u)`` with ``rho(u) = s r(u)``: ``r(u)`` the paper's
rate profile (abrupt: 1 before the switch, ``1 + e`` after; smooth: ``1 + e u / T``) and
``s`` chosen so that the total turn over the flight is the base's (for ``L`` along ``n``,
``s = int omega_n du / int r omega_n du``) and the character lands on its feet in the base's landing pose. Each frame is
rotated rigidly about ``n`` through its COM by
``dtheta(u) = int_0^u (rho - 1) omega_n du`` (zero at take-off and at landing), which adds
``I n x`` to ``L`` for an extra rate ``x = d dtheta / du`` (a rigid turn ``R`` about ``n`` maps
``L`` to ``R (L + I n x)``, which has the same length, and translating about the COM does not
change ``L``, flips paper section 5.1); ``x`` is the root nearest 0 of
``|L + x I n| = rho |L|`` per frame, so ``|L|`` becomes exactly ``rho |L|`` even where the
capture's ``L`` is not along ``n`` (for ``L`` along ``n``: ``x = (rho - 1) omega_n``). The nominal error is therefore the *change* of ``|L|`` the paper's profile
makes: abrupt, ``|L|`` after the switch over ``|L|`` before it is ``1 + e``; smooth,
``|L|`` at landing over ``|L|`` at take-off is ``1 + e``. The price of holding the landing
pose with a fixed flight time: ``|L|`` is ``s`` times the base's at take-off and ``s (1 + e)``
times at landing (abrupt +50 %: 0.80 and 1.20 for a rigid body), so the rotation speed
changes at take-off and at touchdown; both are measured and written to the manifest
(``takeoff_rotation_ratio``, ``landing_rotation_ratio``), as the paper-literal mode's
touchdown change (``landing_rate``) is.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from mocomp.core.motion import Motion
from mocomp.errors import NoFlightPhaseError, PhysicsError

__all__ = ["KINDS", "AM_MODES", "TimeWarp", "time_warp", "ballistic_velocity", "FlightRebuild", "rebuild_flight",
           "rotate_flight", "signed_level"]

#: How angular-momentum errors are made: ``"rotation"`` (:func:`rotate_flight`, the default of new
#: specs) or ``"retime"`` (the paper-literal flight retiming of :func:`rebuild_flight`).
AM_MODES = ("rotation", "retime")

#: Perturbation kinds understood by :func:`rebuild_flight`.
KINDS = ("none", "am_abrupt", "am_smooth", "takeoff")
_Y = np.array([0.0, 1.0, 0.0])


def signed_level(direction: str, level: float) -> float:
    """The signed relative error ``e``: ``+level`` for ``"increase"``, ``-level`` for ``"decrease"``."""
    if direction == "increase":
        return float(level)
    if direction == "decrease":
        return -float(level)
    if direction == "none":
        if level != 0:
            raise ValueError(f"direction 'none' needs level 0, got {level}")
        return 0.0
    raise ValueError(f"direction must be increase, decrease or none, got {direction!r}")


@dataclass(frozen=True)
class TimeWarp:
    """Retiming of the flight: original elapsed flight time ``sigma(u)`` at new elapsed time ``u``.

    Attributes
    ----------
    kind: ``"none"``, ``"am_abrupt"`` or ``"am_smooth"`` (``"takeoff"`` uses ``"none"``).
    error: signed relative angular-momentum error ``e`` at its peak.
    T: original flight duration (s); ``new_T``: retimed duration ``T'`` (s).
    switch_u: new elapsed time at which an abrupt retiming switches on (``None`` otherwise).
    """

    kind: str
    error: float
    T: float
    new_T: float
    switch_u: float | None

    def sigma(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        e = self.error
        if self.kind == "am_smooth":
            return u + e * u * u / (2.0 * self.new_T)
        if self.kind == "am_abrupt":
            us = self.switch_u
            return np.where(u <= us, u, us + (1.0 + e) * (u - us))
        return u.copy()

    def rate(self, u: np.ndarray) -> np.ndarray:
        """``r(u) = dsigma/du``: the factor applied to velocities and momenta."""
        u = np.asarray(u, dtype=float)
        e = self.error
        if self.kind == "am_smooth":
            return 1.0 + e * u / self.new_T
        if self.kind == "am_abrupt":
            return np.where(u < self.switch_u, 1.0, 1.0 + e)
        return np.ones_like(u)


def time_warp(kind: str, error: float, T: float, switch_fraction: float = 0.5) -> TimeWarp:
    """The flight retiming for a perturbation (see the module docstring, step 1)."""
    if not (np.isfinite(T) and T > 0):
        raise NoFlightPhaseError(f"flight duration must be > 0, got {T}")
    if kind in ("none", "takeoff"):
        return TimeWarp("none", 0.0, T, T, None)
    if not (-1.0 < error < 10.0):
        raise PhysicsError(f"angular-momentum error {error:+.0%} is impossible by retiming (needs > -100%)")
    if kind == "am_smooth":
        return TimeWarp(kind, float(error), T, T / (1.0 + error / 2.0), None)
    if kind == "am_abrupt":
        if not (0.0 < switch_fraction < 1.0):
            raise ValueError(f"switch_fraction must be in (0, 1), got {switch_fraction}")
        us = switch_fraction * T
        return TimeWarp(kind, float(error), T, us + (1.0 - switch_fraction) * T / (1.0 + error), us)
    raise ValueError(f"unknown perturbation kind {kind!r}; expected one of {KINDS}")


def ballistic_velocity(p0: np.ndarray, p1: np.ndarray, T: float, gravity: float) -> np.ndarray:
    """Initial velocity of the parabola under gravity ``-g y`` from ``p0`` to ``p1`` in time ``T``."""
    return (np.asarray(p1, float) - np.asarray(p0, float)) / T + 0.5 * gravity * T * _Y


@dataclass(frozen=True, eq=False)
class FlightRebuild:
    """A perturbed (or re-fitted control) motion and the evidence of how it was made.

    Attributes
    ----------
    motion: the stimulus motion, at the base motion's frame rate.
    kind: perturbation kind (:data:`KINDS`); ``error``: signed nominal relative error.
    warp: the flight's :class:`TimeWarp`.
    flight: ``(start, stop)`` half-open airborne frames of ``motion``.
    base_flight: the same for the base motion.
    takeoff_time: ``t_a`` (s, same in both motions).
    velocity: ``(3,)`` m/s, initial velocity of the rebuilt COM parabola.
    base_velocity: ``(3,)`` m/s, ``v0`` of the re-fitted control flight.
    jump_direction: ``(3,)`` unit horizontal direction of ``v0`` (zeros if ``v0`` is vertical).
    landing_shift: ``(3,)`` m, translation applied to the landing phase.
    gravity: m/s^2 used for the parabola.
    original_time: ``(T_new,)`` s, the base motion's time shown at each new frame.
    rate: ``(T_new,)`` retiming rate at each new frame (1 outside the flight).
    root_offset: ``(T_new,)`` m, magnitude of the root translation applied per frame.
    com_mode: ``"capture"`` or ``"ballistic"`` (module docstring, step 2).
    am_mode: ``"retime"`` (this function's flights) or ``"rotation"`` (:func:`rotate_flight`; then
        ``rate`` is the orientation's rate ``rho``, ``rotation_angle`` the ``(T_new,)`` rad added about
        ``rotation_axis`` and ``rotation_scale`` the factor ``s``).
    capture_deviation: m, largest distance of the base flight's COM from its
        ideal parabola ``P0`` (0 for an exact flight; the capture's non-ballistic part).
    """

    motion: Motion
    kind: str
    error: float
    warp: TimeWarp
    flight: tuple[int, int]
    base_flight: tuple[int, int]
    takeoff_time: float
    velocity: np.ndarray
    base_velocity: np.ndarray
    jump_direction: np.ndarray
    landing_shift: np.ndarray
    gravity: float
    original_time: np.ndarray
    rate: np.ndarray
    root_offset: np.ndarray
    com_mode: str = "capture"
    capture_deviation: float = 0.0
    am_mode: str = "retime"
    rotation_angle: np.ndarray | None = None
    rotation_scale: float = 1.0
    rotation_axis: np.ndarray | None = None

    @property
    def flight_duration(self) -> float:
        return self.warp.new_T

    @property
    def takeoff_angle_deg(self) -> float:
        """Elevation of the take-off velocity above the horizontal, degrees."""
        v = self.velocity
        return float(np.degrees(np.arctan2(v[1], np.hypot(v[0], v[2]))))


def rebuild_flight(base: Motion, flight: tuple[int, int], com: Callable[[Motion], np.ndarray], *,
                   kind: str = "none", error: float = 0.0, gravity: float = 9.81,
                   switch_fraction: float = 0.5, min_horizontal_speed: float = 0.05,
                   com_mode: str = "capture") -> FlightRebuild:
    """Make one stimulus from ``base`` (see the module docstring for the method).

    Parameters
    ----------
    base: the base motion (one single flight inside it).
    flight: ``(a, b)`` half-open airborne frame range of ``base`` (``a >= 1``, ``b < n_frames``:
        there must be ground frames on both sides).
    com: ``com(motion) -> (T, 3)`` centre of mass of every frame (e.g.
        ``lambda m: mocomp.dynamics.center_of_mass(body, m)``).
    kind: ``"none"`` (re-fitted control), ``"am_abrupt"``, ``"am_smooth"``, ``"takeoff"``.
    error: signed relative error (``+0.25`` = 25 % increase); see :func:`signed_level`.
    gravity: m/s^2 of the rebuilt parabola.
    switch_fraction: where in the original flight an abrupt retiming switches on.
    min_horizontal_speed: m/s; a take-off-angle error needs a jump direction.
    com_mode: ``"capture"`` (control = the capture; stimuli add the change of the ideal
        flight) or ``"ballistic"`` (flight COM replaced by the exact parabola); step 2.

    Raises
    ------
    NoFlightPhaseError: the flight range is empty or touches the clip's ends.
    PhysicsError: the requested change is impossible (e.g. no horizontal travel for a
        take-off-angle error, or a retimed flight that cannot return to the landing height).
    """
    if kind not in KINDS:
        raise ValueError(f"unknown perturbation kind {kind!r}; expected one of {KINDS}")
    if kind == "none" and error != 0:
        raise ValueError("the unperturbed control ('none') takes error 0")
    if com_mode not in ("capture", "ballistic"):
        raise ValueError(f"com_mode must be 'capture' or 'ballistic', got {com_mode!r}")
    a, b = int(flight[0]), int(flight[1])
    n = base.n_frames
    if not (1 <= a and b - a >= 3 and b < n):
        raise NoFlightPhaseError(
            f"flight frames [{a}, {b}) of a {n}-frame motion: need >= 3 airborne frames and ground frames "
            "before and after (trim the clip less tightly)")
    fps = base.fps
    ta, tb = a / fps, (b - 1) / fps
    T = tb - ta
    c_base = np.asarray(com(base), dtype=float)
    if c_base.shape != (n, 3):
        raise ValueError(f"com(base) must return ({n}, 3), got {c_base.shape}")
    p0, p1 = c_base[a], c_base[b - 1]
    v0 = ballistic_velocity(p0, p1, T, gravity)
    vh = v0 * np.array([1.0, 0.0, 1.0])
    sh = float(np.linalg.norm(vh))
    h = vh / sh if sh > 1e-12 else np.zeros(3)

    warp = time_warp(kind, error, T, switch_fraction)
    Tn = warp.new_T
    if kind in ("am_abrupt", "am_smooth"):
        dy = p1[1] - p0[1]
        if v0[1] <= 0:
            raise PhysicsError(f"base flight has a non-rising take-off velocity (v_y = {v0[1]:.3f} m/s)")
        kappa = (dy + 0.5 * gravity * Tn * Tn) / (v0[1] * Tn)
        if kappa <= 0:
            raise PhysicsError(f"retimed flight of {Tn:.3f} s cannot return to the landing height")
        v = kappa * v0
    elif kind == "takeoff":
        if sh < min_horizontal_speed:
            raise PhysicsError(
                f"the base flight travels only {sh:.3f} m/s horizontally; a take-off-angle error along the "
                f"jump direction needs >= {min_horizontal_speed} m/s")
        v = v0 + error * (v0 @ h) * h
    else:
        v = v0.copy()

    # New clock: take-off phase unchanged, flight warped, landing phase shifted by T' - T.
    new_dur = base.duration + (Tn - T)
    m_frames = int(np.floor(new_dur * fps + 1e-9)) + 1
    t = np.arange(m_frames) / fps
    u = t - ta
    in_flight = (u >= -1e-12) & (u <= Tn + 1e-12)
    s = np.where(u < 0, t, np.where(in_flight, ta + warp.sigma(np.clip(u, 0.0, Tn)), t - (Tn - T)))
    s = np.clip(s, 0.0, base.duration)
    rate = np.where(in_flight, warp.rate(np.clip(u, 0.0, Tn)), 1.0)
    m = base.sample(s)

    def parabola(vel, uu):
        uu = np.asarray(uu, dtype=float)
        return p0 + np.outer(uu, vel) - 0.5 * gravity * (uu ** 2)[:, None] * _Y

    uf = np.clip(u, 0.0, Tn)
    kb = np.arange(a, b)
    dev = float(np.linalg.norm(c_base[kb] - parabola(v0, (kb - a) / fps), axis=1).max())
    delta = np.zeros((m_frames, 3))
    if com_mode == "ballistic":
        c_new = np.asarray(com(m), dtype=float)
        delta[in_flight] = parabola(v, uf[in_flight]) - c_new[in_flight]
    else:
        delta[in_flight] = parabola(v, uf[in_flight]) - parabola(v0, warp.sigma(uf[in_flight]))
    land = parabola(v, [Tn])[0]
    after = u > Tn + 1e-12
    shift = land - p1
    if abs(shift[1]) > 1e-6:
        raise PhysicsError(f"internal: rebuilt flight lands {shift[1]:+.2e} m off the landing height")
    shift[1] = 0.0
    delta[after] = shift
    out = m.replace(root_positions=m.root_positions + delta)
    fa = int(np.flatnonzero(in_flight)[0])
    fb = int(np.flatnonzero(in_flight)[-1]) + 1
    return FlightRebuild(
        motion=out, kind=kind, error=float(error), warp=warp, flight=(fa, fb), base_flight=(a, b),
        takeoff_time=ta, velocity=v, base_velocity=v0, jump_direction=h, landing_shift=shift,
        gravity=float(gravity), original_time=s, rate=rate, root_offset=np.linalg.norm(delta, axis=1),
        com_mode=com_mode, capture_deviation=dev)


def rotate_flight(base: Motion, flight: tuple[int, int], com: Callable[[Motion], np.ndarray],
                  angular: Callable[[Motion], np.ndarray], inertia: Callable[[Motion], np.ndarray], *,
                  kind: str, error: float, gravity: float = 9.81, switch_fraction: float = 0.5) -> FlightRebuild:
    """Rotation-only angular-momentum error (module docstring, "Rotation-only"): the base's COM,
    posture, flight frames and ground frames kept exactly; the orientation about the flight's
    mean ``L`` retimed by ``rho(u) = s r(u)`` so the total turn is the base's.

    ``angular(motion) -> (T, 3)`` angular momentum about the COM (eq. 5.5) and
    ``inertia(motion) -> (T, 3, 3)`` whole-body inertia about the COM.
    """
    from scipy.integrate import cumulative_trapezoid, trapezoid
    from scipy.spatial.transform import Rotation

    if kind not in ("am_abrupt", "am_smooth"):
        raise ValueError(f"rotate_flight makes angular-momentum errors (am_abrupt, am_smooth), got {kind!r}")
    a, b = int(flight[0]), int(flight[1])
    n = base.n_frames
    if not (1 <= a and b - a >= 5 and b < n):
        raise NoFlightPhaseError(f"flight frames [{a}, {b}) of a {n}-frame motion: need >= 5 airborne frames and "
                                 "ground frames before and after")
    fps = base.fps
    T = (b - 1 - a) / fps
    time_warp(kind, error, T, switch_fraction)  # validates error and switch_fraction
    # the paper's rate profile r(u) over the base's own flight time (the duration is kept)
    u = (np.arange(a, b) - a) / fps
    if kind == "am_abrupt":
        r = np.where(u < switch_fraction * T, 1.0, 1.0 + error)
        # the frame nearest the switch shows the mean of both rates (the step falls between frames)
        ks = int(np.argmin(np.abs(u - switch_fraction * T)))
        if abs(u[ks] - switch_fraction * T) < 1e-9:
            r[ks] = 1.0 + 0.5 * error
    else:
        r = 1.0 + error * u / T
    L = np.asarray(angular(base), dtype=float)[a:b]
    I = np.asarray(inertia(base), dtype=float)[a:b]
    Lin = L[1:-1] if b - a >= 5 else L                 # end frames' differences straddle the ground
    nvec = Lin.mean(axis=0)
    if np.linalg.norm(nvec) < 1e-9:
        raise PhysicsError("the base flight has no angular momentum to change")
    nvec = nvec / np.linalg.norm(nvec)
    In = np.einsum("tij,j->ti", I, nvec)                 # I n: the L one rad/s about n adds
    # the first and last airborne frames' L straddles take-off/landing: use their neighbours'
    L = L.copy()
    L[0], L[-1] = L[1], L[-2]
    qa = np.einsum("ti,ti->t", In, In)
    qb = 2.0 * np.einsum("ti,ti->t", L, In)
    L2 = np.einsum("ti,ti->t", L, L)

    def extra_rate(rho):
        """Rate x about n with |L + x I n| = rho |L| (the root nearest 0); for L along n this is
        (rho - 1) L_n / I_nn (the module docstring's)."""
        disc = np.maximum(qb * qb - 4.0 * qa * L2 * (1.0 - rho * rho), 0.0)
        sq = np.sqrt(disc)
        x1, x2 = (-qb + sq) / (2.0 * qa), (-qb - sq) / (2.0 * qa)
        return np.where(np.abs(x1) <= np.abs(x2), x1, x2)

    from scipy.optimize import brentq

    net = lambda sc: float(trapezoid(extra_rate(sc * r), u))  # noqa: E731  total extra turn
    s = float(brentq(net, 0.2, 5.0, xtol=1e-12))
    rho = s * r
    dtheta = cumulative_trapezoid(extra_rate(rho), u, initial=0.0)
    angle = np.zeros(n)
    angle[a:b] = dtheta
    q = Rotation.from_rotvec(np.outer(angle, nvec)).as_quat()
    c = np.asarray(com(base), dtype=float)
    turned = base.rotated(q, center=c)   # rigid turn of each frame about its own COM: the COM stays
    rp, rot = np.array(base.root_positions), np.array(base.rotations)
    rp[a:b], rot[a:b] = turned.root_positions[a:b], turned.rotations[a:b]   # ground frames: the base's bytes
    out = base.replace(root_positions=rp, rotations=rot)
    rate = np.ones(n)
    rate[a:b] = rho
    t = np.arange(n) / fps
    c0, c1 = c[a], c[b - 1]
    v0 = ballistic_velocity(c0, c1, T, gravity)
    vh = v0 * np.array([1.0, 0.0, 1.0])
    sh = float(np.linalg.norm(vh))
    h = vh / sh if sh > 1e-12 else np.zeros(3)
    warp_r = TimeWarp(kind, float(error), T, T, switch_fraction * T if kind == "am_abrupt" else None)
    kb = np.arange(a, b)
    uu = (kb - a) / fps
    ideal = c0 + np.outer(uu, v0) - 0.5 * gravity * (uu ** 2)[:, None] * _Y
    dev = float(np.linalg.norm(c[kb] - ideal, axis=1).max())
    return FlightRebuild(
        motion=out, kind=kind, error=float(error), warp=warp_r, flight=(a, b), base_flight=(a, b),
        takeoff_time=a / fps, velocity=v0, base_velocity=v0, jump_direction=h, landing_shift=np.zeros(3),
        gravity=float(gravity), original_time=t, rate=rate, root_offset=np.linalg.norm(
            out.root_positions - base.root_positions, axis=1),
        com_mode="capture", capture_deviation=dev, am_mode="rotation", rotation_angle=angle,
        rotation_scale=s, rotation_axis=nvec)
