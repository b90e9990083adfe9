"""Smooth time functions for scripted motion: eased keyframe tracks and quintic Hermite pieces.

Every function returns values *and* exact time derivatives, so the flight
integrator knows the joint angular velocities analytically (no finite
differences inside the generator).

* :func:`smoothstep7` -- the septic "smootherstep" ``35u^4 - 84u^5 + 70u^6 - 20u^7``:
  0 -> 1 with zero 1st..3rd derivatives at both ends (C^3 joins).
* :class:`KeyTrack` -- piecewise eased interpolation between keyframe vectors
  (C^3, zero velocity at every key).
* :func:`quintic_hermite` -- the quintic matching position, velocity and
  acceleration at both ends of an interval (C^2 joins), for root trajectories.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["smoothstep7", "KeyTrack", "quintic_hermite", "bump_ramp"]


def smoothstep7(u: np.ndarray, order: int = 0) -> np.ndarray:
    """Septic smoothstep ``S(u)`` on ``[0, 1]`` (clamped outside) or its ``order``-th derivative (<= 2)."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    if order == 0:
        return u**4 * (35.0 - 84.0 * u + 70.0 * u**2 - 20.0 * u**3)
    if order == 1:
        return 140.0 * u**3 * (1.0 - u) ** 3
    if order == 2:
        return 420.0 * u**2 * (1.0 - u) ** 2 * (1.0 - 2.0 * u)
    raise ValueError("smoothstep7 derivatives of order > 2 are not implemented")


def bump_ramp(s: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``f(s) = s (1 - S(s/tau))`` for ``s in [0, tau]``, 0 elsewhere, and ``f'(s)``.

    ``f(0) = 0``, ``f'(0) = 1``, and ``f`` joins 0 with C^3 continuity at
    ``s = tau``: used to add a prescribed initial velocity to a scripted track
    without moving its start or its later keys.
    """
    s = np.asarray(s, dtype=float)
    inside = (s >= 0.0) & (s <= tau)
    u = np.clip(s / tau, 0.0, 1.0)
    S = smoothstep7(u)
    dS = smoothstep7(u, 1) / tau
    f = np.where(inside, s * (1.0 - S), 0.0)
    df = np.where(inside, (1.0 - S) - s * dS, 0.0)
    return f, df


@dataclass(frozen=True)
class KeyTrack:
    """Eased keyframe interpolation of vectors: ``value(t)`` and ``rate(t)``.

    ``times`` ``(K,)`` strictly increasing; ``values`` ``(K, ...)``. Between
    keys ``k`` and ``k+1`` the value is ``v_k + S(u) (v_{k+1} - v_k)`` with the
    septic smoothstep ``S``; before the first key and after the last the track
    holds its end values. The velocity is zero at every key.
    """

    times: np.ndarray
    values: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if t.ndim != 1 or v.shape[0] != t.shape[0] or t.size < 1:
            raise ValueError(f"KeyTrack needs (K,) times and (K, ...) values, got {t.shape}, {v.shape}")
        if np.any(np.diff(t) <= 0):
            raise ValueError(f"KeyTrack key times must increase strictly, got {t}")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        K = self.times.size
        if K == 1:
            val = np.broadcast_to(self.values[0], t.shape + self.values.shape[1:]).copy()
            return val, np.zeros_like(val)
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, K - 2)
        t0, t1 = self.times[k], self.times[k + 1]
        u = (t - t0) / (t1 - t0)
        S = smoothstep7(u)
        dS = smoothstep7(u, 1) / (t1 - t0) * ((u > 0) & (u < 1))
        extra = (1,) * (self.values.ndim - 1)
        v0, v1 = self.values[k], self.values[k + 1]
        val = v0 + S.reshape(-1, *extra) * (v1 - v0)
        rate = dS.reshape(-1, *extra) * (v1 - v0)
        return val, rate


def quintic_hermite(t, ta: float, tb: float, pa, va, aa, pb, vb, ab):
    """Quintic on ``[ta, tb]`` matching value, velocity and acceleration at both ends.

    Returns ``(p, v, a)`` at times ``t`` (arrays broadcast over trailing vector
    dimensions of the end conditions). Times outside the interval extrapolate
    the polynomial; callers evaluate inside only.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    h = tb - ta
    if h <= 0:
        raise ValueError(f"quintic_hermite needs tb > ta, got [{ta}, {tb}]")
    pa, va, aa, pb, vb, ab = (np.asarray(x, dtype=float) for x in (pa, va, aa, pb, vb, ab))
    s = (t - ta) / h
    s = s.reshape((-1,) + (1,) * pa.ndim)
    # Basis in normalised time with derivatives scaled by h.
    V0, A0, V1, A1 = va * h, aa * h * h, vb * h, ab * h * h
    c0 = pa
    c1 = V0
    c2 = 0.5 * A0
    c3 = 10 * (pb - pa) - 6 * V0 - 4 * V1 - 1.5 * A0 + 0.5 * A1
    c4 = -15 * (pb - pa) + 8 * V0 + 7 * V1 + 1.5 * A0 - A1
    c5 = 6 * (pb - pa) - 3 * V0 - 3 * V1 - 0.5 * A0 + 0.5 * A1
    p = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
    dp = (c1 + s * (2 * c2 + s * (3 * c3 + s * (4 * c4 + s * 5 * c5)))) / h
    ddp = (2 * c2 + s * (6 * c3 + s * (12 * c4 + s * 20 * c5))) / (h * h)
    return p, dp, ddp
