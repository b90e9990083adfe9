"""COM velocity and linear momentum discontinuities, frame by frame.

A velocity jump at frame ``i`` is measured against local fits on each side:
a least-squares quadratic through the COM positions of frames ``i-w .. i``
(the left side) and one through ``i .. i+w`` (the right side), each
differentiated at ``t_i``::

    jump_i = v_right(t_i) - v_left(t_i)          (m/s, a 3-vector)

For a motion whose COM is smooth across ``i`` both fits see the same
trajectory and the jump is ``O(jerk w^2 dt^2)`` (zero for a parabola); a
velocity step of ``dv`` placed at frame ``i`` (positions continuous, velocity
changing from frame ``i`` on) gives ``jump_i = dv`` exactly, its neighbours a
part of it. Both derivatives are fixed linear filters of the positions
(the end-point derivative of a quadratic least-squares fit), so the whole
measurement is two correlations over frames. The linear momentum jump is
``M x jump`` (kg m/s, eq. 5.4: ``p = M v_COM``).

The threshold follows the motion's own noise: ``noise = 1.4826 median |jump_i|``
(a robust standard deviation over all frames), and a jump is a finding when
``|jump_i| > max(jump_min, jump_noise_factor x noise)``; within
``event_window`` of a landing the limit is ``max(landing_jump_max, ...)``
(the ground may stop the body with an impulse; it cannot launch it with one).
Frames within ``w`` of the clip's ends have no jump (NaN). Take-off and landing
frames of the phases are singled out: the largest jump within ``event_window``
of each is reported with the vertical COM velocity before and after it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from .findings import Finding, runs_above

__all__ = ["ComAudit", "EventJump", "endpoint_derivative_weights", "velocity_jumps", "com_audit"]


def endpoint_derivative_weights(w: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Weights ``(w+1,)`` of the derivative at the first (``right``) and at the last (``left``)
    sample of a least-squares quadratic through ``w+1`` samples ``dt`` apart:
    ``v = weights @ x[window]``."""
    if w < 2:
        raise ValueError(f"a quadratic fit needs at least 3 samples per side (w >= 2), got w={w}")
    tt = np.arange(w + 1) * dt
    right = np.linalg.pinv(np.vander(tt, 3, increasing=True))[1]             # d/dt at tt[0]
    left = np.linalg.pinv(np.vander(tt - tt[-1], 3, increasing=True))[1]     # d/dt at tt[-1]
    return right, left


def velocity_jumps(x: np.ndarray, fps: float, w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(jump, v_left, v_right)``, each ``(T, 3)``: one-sided quadratic-fit velocities of the
    positions ``x`` ``(T, 3)`` at every frame and their difference (NaN within ``w`` of the ends)."""
    x = np.asarray(x, dtype=float)
    T = x.shape[0]
    jump = np.full(x.shape, np.nan)
    vl = np.full(x.shape, np.nan)
    vr = np.full(x.shape, np.nan)
    if T < 2 * w + 1:
        return jump, vl, vr
    wr, wl = endpoint_derivative_weights(w, 1.0 / fps)
    win = sliding_window_view(x, w + 1, axis=0)          # (T-w, 3, w+1): window k = frames k..k+w
    right = win @ wr                                      # velocity at frame k from frames k..k+w
    left = win @ wl                                       # velocity at frame k+w from frames k..k+w
    vr[w:T - w] = right[w:T - w]
    vl[w:T - w] = left[:T - 2 * w]
    jump[w:T - w] = vr[w:T - w] - vl[w:T - w]
    return jump, vl, vr


@dataclass(frozen=True)
class EventJump:
    """The largest COM velocity jump near one take-off or landing.

    Attributes
    ----------
    kind: ``"take-off"`` or ``"landing"``; flight: flight index (0-based).
    event_frame: the phase border (first airborne / first ground frame).
    frame: frame of the largest jump within the event window (``None``: no frame measurable).
    jump: m/s, ``|v_right - v_left|`` there; momentum_jump: kg m/s (``M x jump``).
    vy_before, vy_after: m/s, vertical COM velocity of the left and right fits there.
    threshold: m/s, the limit that applies there.
    """

    kind: str
    flight: int
    event_frame: int
    frame: int | None
    jump: float
    momentum_jump: float
    vy_before: float
    vy_after: float
    threshold: float

    def to_dict(self) -> dict:
        return {k: (None if v is None else (v if isinstance(v, (int, str)) else float(v)))
                for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class ComAudit:
    """COM velocity jumps of a motion.

    Attributes
    ----------
    window: frames per one-sided fit (``w``).
    com: ``(T, 3)`` m; jump, v_left, v_right: ``(T, 3)`` m/s (NaN at the ends).
    magnitude: ``(T,)`` m/s, ``|jump|``; threshold: ``(T,)`` m/s, the limit per frame.
    noise: m/s, ``1.4826 median |jump|``.
    total_mass: kg (momentum jump = ``total_mass x jump``).
    events: take-off and landing jumps (:class:`EventJump`), in time order.
    max_jump, max_frame: largest jump outside landing windows (and outside declared external-force
        frames with their fit window) and its frame (``None`` if none).
    """

    window: int
    com: np.ndarray
    jump: np.ndarray
    v_left: np.ndarray
    v_right: np.ndarray
    magnitude: np.ndarray
    threshold: np.ndarray
    noise: float
    total_mass: float
    events: tuple[EventJump, ...]
    max_jump: float
    max_frame: int | None


def com_audit(com: np.ndarray, fps: float, total_mass: float, phases, thresholds,
              forced: np.ndarray | None = None) -> tuple[ComAudit, list]:
    """The COM velocity jumps (module docstring) and their findings. ``forced``: ``(T,)`` bool, frames
    under a declared external force (:mod:`mocomp.audit.force`); jumps within the fit window of them
    are left out of ``max_jump`` and of the take-off / landing events (their findings are marked
    expected by :func:`mocomp.audit.audit`)."""
    T = com.shape[0]
    w = thresholds.jump_frames(fps)
    jump, vl, vr = velocity_jumps(com, fps, w)
    mag = np.linalg.norm(jump, axis=1)
    ok = np.isfinite(mag)
    noise = float(1.4826 * np.median(mag[ok])) if ok.any() else 0.0
    base = max(thresholds.jump_min, thresholds.jump_noise_factor * noise)
    land_thr = max(thresholds.landing_jump_max, thresholds.jump_noise_factor * noise)
    ew = max(1, int(np.ceil(thresholds.event_window * fps - 1e-9)))
    thr = np.full(T, base)
    near_landing = np.zeros(T, bool)
    for b in phases.landings:
        if b is not None:
            near_landing[max(0, b - ew - w):min(T, b + ew + w + 1)] = True
    thr[near_landing] = land_thr
    free = ok.copy()
    if forced is not None and forced.any():
        from .force import dilate

        free &= ~dilate(forced, w)
    events = []
    for k, ((a, b), ta, lb) in enumerate(zip(phases.flights, phases.takeoffs, phases.landings)):
        for kind, f in (("take-off", ta), ("landing", lb)):
            if f is None:
                continue
            lo, hi = max(0, f - ew - w), min(T, f + ew + w + 1)
            seg = np.where(free[lo:hi], mag[lo:hi], -1.0)
            if seg.max() < 0:
                events.append(EventJump(kind, k, int(f), None, float("nan"), float("nan"), float("nan"),
                                        float("nan"), float(thr[f])))
                continue
            i = lo + int(np.argmax(seg))
            events.append(EventJump(kind, k, int(f), i, float(mag[i]), float(total_mass * mag[i]), float(vl[i, 1]),
                                    float(vr[i, 1]), float(thr[i])))
    events.sort(key=lambda e: e.event_frame)
    away = free & ~near_landing
    if away.any():
        mf = int(np.flatnonzero(away)[np.argmax(mag[away])])
        mj = float(mag[mf])
    else:
        mf, mj = None, 0.0
    res = ComAudit(w, com, jump, vl, vr, mag, thr, noise, float(total_mass), tuple(events), mj, mf)
    findings = []
    for a, b, p in runs_above(mag, thr):
        what = _event_name(p, phases, ew + w)
        findings.append(Finding(
            "com_velocity_jump", "violation", (a, b), p, float(mag[p]), float(thr[p]),
            "landing_jump_max" if near_landing[p] else "jump_min", "m/s", what,
            f"COM velocity jumps by {mag[p]:.2f} m/s (momentum {total_mass * mag[p]:.1f} kg m/s; vertical "
            f"{vl[p, 1]:+.2f} -> {vr[p, 1]:+.2f} m/s) at frame {p}; limit {thr[p]:.2f} m/s "
            f"(noise {noise:.3f} m/s)"))
    return res, findings


def _event_name(frame: int, phases, reach: int) -> str:
    for k, (ta, lb) in enumerate(zip(phases.takeoffs, phases.landings)):
        if ta is not None and abs(frame - ta) <= reach:
            return f"take-off of flight {k + 1}"
        if lb is not None and abs(frame - lb) <= reach:
            return f"landing of flight {k + 1}"
    for k, (a, b) in enumerate(phases.flights):
        if a <= frame < b:
            return f"in flight {k + 1}"
    return "on the ground"
