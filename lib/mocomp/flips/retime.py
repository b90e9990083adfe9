"""Uniform retiming of take-off, flight and landing (section 5.3 / 5.4.3, App. B).

Retiming by ``k`` (``k > 1`` = faster) multiplies velocities, and so linear and
angular momentum, by ``k`` (eq. 5.8) and divides durations by ``k``. With the
take-off vertical velocity ``v0`` and the flight duration ``T`` of the
sequenced motion (before retiming), App. B's end condition
``-1/2 g (T/k)^2 + k v0 (T/k) = dy`` gives (eq. B.5)

    k* = sqrt( (g T / 2) / (v0 - dy / T) ),

the one factor for which the retimed take-off velocity ``k v0`` flies exactly
to the landing level ``dy`` above the take-off level in the retimed time
``T / k``: linear momentum is then continuous at take-off and landing. The
radicand is positive only for ``dy < v0 T`` (App. B's limit on raising the
landing).

**When k differs from k*** (the paper's choice is ``k ~ 0.7 k*``: "higher jumps
with slower rotations", section 5.3 / 5.4.3; here ``k = k*`` is the default and ``k_ratio=0.7``
the paper's aesthetic option) the flight cannot both leave with ``k v0``
and land at the requested level after ``T / k``. Eq. 5.17 as printed,
``COM_y(t) = a_y t^2 + k b_y t + c_y`` over ``t = 0 .. T_new``, keeps the take-off velocity
``k b_y`` but then ends at ``a_y (T/k)^2 + b_y T`` above ``c_y`` instead of at ``dy``: for
``k < k*`` the COM would come down *below* the landing level (and eq. 5.16 offsets only x and
z), and the apex ``(k b_y)^2 / 2g`` would be *lower* -- the opposite of the "higher jumps"
the paper chose ``0.7 k*`` for. Keeping ``k b_y`` and letting the parabola set the flight
time instead would need the flight played at a different rate from take-off and landing,
against "one factor k" (and again a lower, faster jump). The one reading consistent with
one ``k`` for all phases *and* with "higher jumps with slower rotations" is used here:
the flight keeps its retimed duration ``T_new = T / k`` (so the rotation rate is ``k``
times the original) and both end levels, so its parabola is the ballistic one through
the take-off and landing points, ``v0' = dy / T_new + g T_new / 2`` (eq. 5.17 with ``k b_y``
replaced by ``v0'``; the two agree at ``k = k*``). The take-off and landing phases keep
their ``k``-retimed velocities, so the vertical velocity jumps by ``v0' - k v0`` at
take-off and by the corresponding amount at landing. With level take-off and landing
the jump is ``(k*/k)^2 - 1`` of ``k v0``: **+104 % at k = 0.7 k***, not small, although the
paper calls such discontinuities imperceptible; it vanishes at ``k = k*`` (``k_ratio=1``, the
default), which is continuous at take-off and, for ``dy = 0``, at landing.
Both jumps are in :class:`RetimePlan` and the physics report (as planned values; the audit of
the written frames measures them). :mod:`mocomp.flips.takeoff` (``multiflip(..., takeoff="repair")``,
CLI ``--takeoff repair``) goes beyond the paper and makes ``k < k*`` physical: the last ground
frames before take-off (and the first after landing) are reshaped so the COM reaches the new
flight's velocity within the stance.

**Stances played as captured** (issue 13, beyond the paper). The paper plays the whole clip ``k``
times faster; the stances then carry ``k`` times their captured velocities and ``k^2`` times their
accelerations (a hop after the landing falls with ``k^2 g``; CMU 88_01 + arms-twist: 7.06 m/s^2).
:class:`TimeWarp` keeps the flight at ``k`` and eases the rate back to 1 over :data:`EASE_S` of each
stance (smoothstep in the rate, so the COM velocity stays continuous and equals the ``k``-retimed
one at take-off and landing: ``k*`` and the plan above are unchanged). ``ease=0`` in
:func:`~mocomp.flips.multiflip.multiflip` and :func:`~mocomp.edit.linear.correct_linear` is the
uniform retiming. What easing cannot remove: the take-off is still played at ``k``, so the push's
acceleration step at take-off is ``k^2`` the captured one, which the audit's one-sided velocity
fits measure as a take-off "jump" of about ``k^2`` the input's (synthetic back flip at ``k* = 1.40``:
0.22 -> 0.47 m/s), and the landing impact grows with the arrival speed (``k`` times).

**Gravity.** The new flight falls with ``g`` as :func:`resolve_gravity` chooses it:
standard gravity (:data:`~mocomp.dynamics.constants.G_STANDARD`, 9.81 m/s^2) by default, after the
loaders' known frame-rate corrections; the gravity fitted to the clip's flight is a diagnostic
(it is 11.8 m/s^2 on CMU 88_01's flight although the clip-level fit, 10.2, is consistent with 9.81;
7.6 and 13.0 on the DeepMimic back and side flips), ``gravity="clip"`` keeps it (the behaviour
before issue #13), a number sets it.

Relative jumps use one basis everywhere (the plan's note, :attr:`RetimePlan.p_jump_takeoff_rel`
and the physics report's ``p_jump_takeoff_rel`` / ``p_jump_landing_rel``): the magnitude of the
linear momentum the ``k``-retimed ground phase has at take-off, ``M k |v|`` with ``|v| =
sqrt(v_h^2 + v0^2)`` (``v_h``: the flight's horizontal COM speed, ``v_horizontal``). The jump
itself is vertical (the horizontal velocity is ``k v_h`` on both sides), so with ``v_h = 0`` the
relative jump is the ``(k*/k)^2 - 1`` above; a forward-moving flip gives a smaller percentage of
the larger total.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..dynamics.constants import GRAVITY_CHOICES, resolve_gravity  # noqa: F401  (re-exported)
from ..errors import PhysicsError

__all__ = ["k_star", "RetimePlan", "plan_retime", "sample_positions", "resolve_gravity", "GRAVITY_CHOICES",
           "EASE_S", "TimeWarp", "ease_limits"]

#: s (of source time): the stretch of each stance next to the flight over which the play rate eases
#: between 1 (the ground phases as captured) and ``k`` (the flight; :class:`TimeWarp`)
EASE_S = 0.5


def k_star(g: float, T: float, v0: float, dy: float = 0.0) -> float:
    """App. B eq. B.5: ``k* = sqrt((g T / 2) / (v0 - dy / T))``.

    ``g`` is the (clip's) gravity, positive; ``T`` the flight duration before
    retiming (s); ``v0`` the original take-off vertical velocity (m/s); ``dy`` the
    landing level minus the take-off level (m). Raises :class:`PhysicsError` when
    the radicand is not positive, saying which parameter to change.
    """
    if not (g > 0 and T > 0):
        raise PhysicsError(f"k* needs positive gravity and flight time, got g={g!r}, T={T!r}")
    denom = v0 - dy / T
    if not denom > 0:
        if v0 <= 0:
            raise PhysicsError(
                f"k* is undefined: the take-off vertical velocity v0 = {v0:.3f} m/s is not upward, so no "
                "retiming lets the flight reach its landing; check the detected flight phase")
        raise PhysicsError(
            f"k* is undefined (negative radicand): the landing would be {dy:.3f} m above the take-off but "
            f"the take-off velocity v0 = {v0:.3f} m/s over the {T:.3f} s flight only allows dy < v0*T = "
            f"{v0 * T:.3f} m (App. B); lower the height change (--height-change) below "
            f"{v0 * T:.3f} m minus the clip's own landing offset, or give an explicit k (--k)")
    return math.sqrt(0.5 * g * T / denom)


@dataclass(frozen=True)
class RetimePlan:
    """The retiming decision and its physical consequences.

    Attributes
    ----------
    k: the factor used (``k > 1`` = faster); ``k_star``: eq. B.5 (``nan`` if undefined
        and ``k`` was given explicitly); ``k_ratio``: ``k / k_star``.
    g: m/s^2, the gravity the new flight falls with (:func:`resolve_gravity`: 9.81 by default, or the clip's fit).
    T_seq: s, flight duration of the sequenced motion before retiming; ``T_new = T_seq / k``.
    v0: m/s, original take-off vertical velocity (``b_y``); ``dy``: m, landing minus take-off level.
    vy_takeoff_new: m/s, vertical take-off velocity of the new flight parabola.
    vy_takeoff_jump, vy_landing_jump: m/s, vertical velocity discontinuities at take-off
        and landing (new flight minus the ``k``-retimed ground phase; 0 at ``k = k*``).
    note: plain-words remark.
    takeoff_speed: m/s, ``k |v|``, the ``k``-retimed ground phase's COM speed at take-off (``|v|``
        from ``v0`` and ``v_horizontal``): the basis of the relative jumps (module docstring).
    """

    k: float
    k_star: float
    k_ratio: float
    g: float
    T_seq: float
    T_new: float
    v0: float
    dy: float
    vy_takeoff_new: float
    vy_takeoff_jump: float
    vy_landing_jump: float
    note: str = ""
    takeoff_speed: float = float("nan")

    @property
    def p_jump_takeoff_rel(self) -> float:
        """Take-off linear-momentum jump over ``M k |v|`` (``vy_takeoff_jump / takeoff_speed``)."""
        return self.vy_takeoff_jump / self.takeoff_speed if self.takeoff_speed > 0 else float("nan")

    @property
    def p_jump_landing_rel(self) -> float:
        """Landing linear-momentum jump over the same take-off basis ``M k |v|``."""
        return self.vy_landing_jump / self.takeoff_speed if self.takeoff_speed > 0 else float("nan")


def plan_retime(g: float, T_seq: float, v0: float, dy: float, v_land: float,
                k: float | None = None, k_ratio: float | None = None, v_horizontal: float = 0.0) -> RetimePlan:
    """Choose ``k`` (explicit, or ``k_ratio * k*``, default ``k = k*``, continuous at take-off;
    ``k_ratio=0.7`` is the paper's choice of section 5.3, whose take-off jump the note states) and
    derive the new flight's vertical velocity. ``g`` is the gravity the new flight falls with
    (:func:`resolve_gravity`).

    ``v_land`` is the original vertical velocity at landing (``b_y + 2 a_y T0``),
    used for the landing discontinuity; ``v_horizontal`` (m/s) the flight's horizontal COM
    speed ``sqrt(a_x^2 + a_z^2)``, which only enters the basis ``M k |v|`` of the relative jumps.
    """
    if k is not None and k_ratio is not None:
        raise ValueError("give either k or k_ratio, not both")
    if k is None and k_ratio is None:
        k_ratio = 1.0
    note = ""
    try:
        ks = k_star(g, T_seq, v0, dy)
    except PhysicsError:
        if k is None:
            raise
        ks = float("nan")
        note = "k* is undefined for this height change; the explicit k is used and the take-off velocity jumps"
    if k is None:
        if not (k_ratio is not None and np.isfinite(k_ratio) and k_ratio > 0):
            raise ValueError(f"k_ratio must be a positive number, got {k_ratio!r}")
        k = float(k_ratio) * ks
    if not (np.isfinite(k) and k > 0):
        raise ValueError(f"the retiming factor k must be positive and finite, got {k!r}")
    if not (0.25 <= k <= 4.0):
        raise PhysicsError(f"retiming factor k = {k:.3f} is outside [0.25, 4]: finite-difference momentum "
                           "scaling (eq. 5.8) is unreliable there; choose k (or --k-ratio) nearer 1")
    T_new = T_seq / k
    vy_new = dy / T_new + 0.5 * g * T_new
    vy_land_new = vy_new - g * T_new
    speed = float(k * math.hypot(float(v_horizontal), float(v0)))
    if np.isfinite(ks) and abs(k / ks - 1.0) > 1e-6 and not note:
        kv0 = k * v0
        rel = (vy_new - kv0) / speed if speed > 1e-12 else float("nan")
        note = (f"k = {k / ks:.2f} k*: the flight keeps its retimed duration and both end levels, so it leaves "
                f"at {vy_new:.2f} m/s vertically while the retimed take-off reaches {kv0:.2f} m/s: the linear "
                f"momentum jumps at take-off by {100 * rel:+.0f}% of the retimed take-off momentum M k|v| "
                f"(k|v| = {speed:.2f} m/s; p_jump_takeoff_rel), and the vertical velocity by "
                f"{vy_land_new - k * v_land:+.2f} m/s at landing; k = k* (k_ratio=1, the default) keeps it "
                f"continuous, takeoff='repair' (--takeoff repair) reshapes the stance to reach it")
    return RetimePlan(k=float(k), k_star=float(ks), k_ratio=float(k / ks) if np.isfinite(ks) else float("nan"),
                      g=float(g), T_seq=float(T_seq), T_new=float(T_new), v0=float(v0), dy=float(dy),
                      vy_takeoff_new=float(vy_new), vy_takeoff_jump=float(vy_new - k * v0),
                      vy_landing_jump=float(vy_land_new - k * v_land), note=note, takeoff_speed=speed)


def sample_positions(n_seq: int, k: float) -> np.ndarray:
    """Output frame ``i`` shows sequence time ``i k`` (in sequence frames): the retimed
    frame grid at the original frame rate, ending at or before the last frame."""
    n_out = int(math.floor((n_seq - 1) / k + 1e-9)) + 1
    return np.minimum(np.arange(n_out) * k, n_seq - 1.0)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


@dataclass(frozen=True, eq=False)
class TimeWarp:
    """Retiming by ``k`` over the flight eased back to the captured rate over the stances.

    Section 5.3 / 5.4.3 retimes "by one factor ``k``" and the paper applies it to the whole clip,
    so the ground phases also play ``k`` times faster: with ``k* ~ 1.3-1.5`` every captured velocity
    jump and fingertip speed of the stances grows by ``k`` and every acceleration by ``k^2`` (a hop
    after the landing falls with ``k^2 g``). Here output frame ``u`` shows source position ``s(u)``
    (source frames) with the play rate ``r = ds/du``

        r = k                                      over the flight [takeoff, landing],
        r = 1 + (k - 1) S((s - takeoff + R0) / R0)  over the ``R0`` source frames before the take-off,
        r = 1 + (k - 1) S((landing + R1 - s) / R1)  over the ``R1`` frames after the landing,
        r = 1                                      elsewhere,

    ``S(x) = 3x^2 - 2x^3`` (smoothstep): ``r`` and ``dr/du`` are continuous, so the COM velocity of
    the stance (``r v``) is continuous everywhere and equals ``k v`` at the take-off and the landing,
    where the flight (played at ``k``, eq. 5.8) meets it: at ``k = k*`` (eq. B.5) the linear momentum
    stays continuous exactly as with the uniform retiming. The easing adds ``(dr/du) v`` to the
    stance's COM acceleration (at most ``1.5 (k - 1) v / R`` per frame^2, smooth). ``R0 = R1 = 0``
    is the paper's uniform retiming for the flight's neighbourhood (``ease=0`` in the callers:
    all frames at ``k``).

    ``u(s) = integral ds / r`` is tabulated on a grid of 1/32 source frame (trapezoid rule; exact
    where ``r`` is constant) and inverted by interpolation.
    """

    k: float
    takeoff: float
    landing: float
    ease_before: float
    ease_after: float
    end: float
    grid_s: np.ndarray
    grid_u: np.ndarray

    @classmethod
    def build(cls, k: float, takeoff: float, landing: float, end: float, ease_before: float,
              ease_after: float) -> "TimeWarp":
        """``takeoff``, ``landing`` (the last flight frame) and ``end`` (the last source position) in
        source frames; ``ease_before`` / ``ease_after`` the ramp lengths in source frames (clipped to
        the source before the take-off and after the landing; ``0``: uniform by ``k``)."""
        k = float(k)
        if not (np.isfinite(k) and k > 0):
            raise ValueError(f"k must be positive, got {k!r}")
        if not (0.0 <= takeoff <= landing <= end):
            raise ValueError(f"need 0 <= takeoff <= landing <= end, got {takeoff}, {landing}, {end}")
        r0 = float(np.clip(ease_before, 0.0, takeoff))
        r1 = float(np.clip(ease_after, 0.0, end - landing))
        n = max(2, int(np.ceil(end * 32)) + 1)
        gs = np.linspace(0.0, float(end), n)
        inv = 1.0 / cls._rate(gs, k, float(takeoff), float(landing), r0, r1, ease_before > 0, ease_after > 0)
        gu = np.zeros(n)
        np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(gs), out=gu[1:])
        return cls(k, float(takeoff), float(landing), r0, r1, float(end), gs, gu)

    @staticmethod
    def _rate(s, k, s0, s1, r0, r1, ease0: bool, ease1: bool) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        r = np.full(s.shape, k)
        if ease0:
            x = (s - (s0 - r0)) / r0 if r0 > 0 else np.ones_like(s)
            r = np.where(s < s0, 1.0 + (k - 1.0) * _smoothstep(x), r)
        if ease1:
            x = ((s1 + r1) - s) / r1 if r1 > 0 else np.ones_like(s)
            r = np.where(s > s1, 1.0 + (k - 1.0) * _smoothstep(x), r)
        return r

    def rate(self, s) -> np.ndarray:
        """Play rate ``ds/du`` at source positions ``s``."""
        return self._rate(s, self.k, self.takeoff, self.landing, self.ease_before, self.ease_after,
                          self.ease_before > 0, self.ease_after > 0)

    def output_frame(self, s) -> np.ndarray:
        """Output time (in output frames, fractional) at which source position ``s`` is shown."""
        return np.interp(s, self.grid_s, self.grid_u)

    @property
    def takeoff_output(self) -> float:
        return float(self.output_frame(self.takeoff))

    @property
    def landing_output(self) -> float:
        return float(self.output_frame(self.landing))

    def source_positions(self) -> np.ndarray:
        """``(n_out,)`` source position of each output frame ``0, 1, ...`` (the last at or before ``end``)."""
        n_out = int(math.floor(self.grid_u[-1] + 1e-9)) + 1
        return np.minimum(np.interp(np.arange(n_out, dtype=float), self.grid_u, self.grid_s), self.end)


def ease_limits(fps: float, takeoff: float, landing: float, before_limit: float, after_limit: float,
                ease_s: float = EASE_S) -> tuple[float, float]:
    """Ramp lengths (source frames) for :class:`TimeWarp`: ``ease_s`` seconds, but no further back than
    ``before_limit`` (e.g. the end of the clip's previous flight) and no further on than
    ``after_limit`` (the start of its next flight), so other flights are played as captured."""
    n = max(0.0, float(ease_s)) * float(fps)
    return (float(min(n, max(0.0, takeoff - before_limit))), float(min(n, max(0.0, after_limit - landing))))
