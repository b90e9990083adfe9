"""Ease curves and the ramps that fade a correction in and out around the frames it is defined on."""
from __future__ import annotations

import numpy as np

__all__ = ["ease", "EASE_KINDS", "ramp_fill", "RampPlan", "fade_clock"]

EASE_KINDS = ("linear", "smoothstep", "smootherstep", "cosine")


def ease(x, kind: str = "smoothstep") -> np.ndarray:
    """Ease curve on ``[0, 1]`` (clipped): ``linear`` x; ``smoothstep`` 3x^2 - 2x^3 (zero slope at
    both ends, continuous velocity); ``smootherstep`` 6x^5 - 15x^4 + 10x^3 (also zero curvature at
    the ends); ``cosine`` (1 - cos(pi x)) / 2. Each maps 0 -> 0, 1 -> 1, 1/2 -> 1/2."""
    x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    if kind == "linear":
        return x
    if kind == "smoothstep":
        return x * x * (3.0 - 2.0 * x)
    if kind == "smootherstep":
        return x * x * x * (x * (6.0 * x - 15.0) + 10.0)
    if kind == "cosine":
        return 0.5 - 0.5 * np.cos(np.pi * x)
    raise ValueError(f"ease must be one of {', '.join(EASE_KINDS)}, got {kind!r}")


class RampPlan:
    """The weights of :func:`ramp_fill` for one mask, width and ease curve, to fill several arrays
    (``plan.fill(values)``) without recomputing them."""

    def __init__(self, defined: np.ndarray, width: int, kind: str = "smoothstep"):
        d = np.asarray(defined, dtype=bool)
        self.defined = d
        T = d.shape[0]
        self.trivial = width <= 0 or not d.any() or d.all()
        if self.trivial:
            return
        idx = np.arange(T)
        prev = np.maximum.accumulate(np.where(d, idx, -1))
        nxt = np.minimum.accumulate(np.where(d, idx, T)[::-1])[::-1]
        wp = np.where(prev >= 0, ease(1.0 - (idx - prev) / (width + 1.0), kind), 0.0)
        wn = np.where(nxt < T, ease(1.0 - (nxt - idx) / (width + 1.0), kind), 0.0)
        s = np.maximum(1.0, wp + wn)
        und = ~d
        self.und = und
        self.wp, self.wn = (wp / s)[und], (wn / s)[und]
        self.prev, self.nxt = np.clip(prev, 0, T - 1)[und], np.clip(nxt, 0, T - 1)[und]

    @classmethod
    def many(cls, defined: np.ndarray, width: int, kind: str = "smoothstep", clock: np.ndarray | None = None
             ) -> list["RampPlan"]:
        """One plan per column of ``defined (T, C)``, their weights computed together (the same
        numbers as ``RampPlan(defined[:, c], width, kind)``).

        ``clock`` ``(T - 1,)``: how far each step between two frames advances the fades, >= 0 (default 1
        everywhere: the ease curve over ``width + 1`` equal steps). A fade still spans the same
        ``width + 1`` steps, but the ease curve's argument advances by each step's share of their summed
        clock: a step of small clock barely changes the weight (:func:`fade_clock` slows the fades where
        the motion itself is turning fastest, so a correction faded in there does not add to its peak)."""
        d = np.asarray(defined, dtype=bool)
        T = d.shape[0]
        plans = [cls.__new__(cls) for _ in range(d.shape[1])]
        for c, p in enumerate(plans):
            p.defined = d[:, c]
            p.trivial = width <= 0 or not p.defined.any() or p.defined.all()
        if all(p.trivial for p in plans):
            return plans
        idx = np.arange(T)[:, None]
        prev = np.maximum.accumulate(np.where(d, idx, -1), axis=0)
        nxt = np.minimum.accumulate(np.where(d, idx, T)[::-1], axis=0)[::-1]
        if clock is None:
            wp = np.where(prev >= 0, ease(1.0 - (idx - prev) / (width + 1.0), kind), 0.0)
            wn = np.where(nxt < T, ease(1.0 - (nxt - idx) / (width + 1.0), kind), 0.0)
        else:
            ck = np.asarray(clock, dtype=float).reshape(-1)
            if ck.shape != (T - 1,) or not np.all(ck >= 0):
                raise ValueError(f"clock: {T - 1} numbers >= 0 (one per step between frames) expected, "
                                 f"got shape {ck.shape}")
            C = np.concatenate([[0.0], np.cumsum(ck)])

            def at(i):                  # the cumulative clock, continued with steps of 1 beyond the ends
                ic = np.clip(i, 0, T - 1)
                return C[ic] + (i - ic)

            # a fade whose steps all have clock 0 runs on the frame count instead
            span_p = at(prev + width + 1) - at(prev)
            span_n = at(nxt) - at(nxt - width - 1)
            gp = np.where(span_p > 0, (at(idx) - at(prev)) / np.where(span_p > 0, span_p, 1.0), (idx - prev) / (width + 1.0))
            gn = np.where(span_n > 0, (at(nxt) - at(idx)) / np.where(span_n > 0, span_n, 1.0), (nxt - idx) / (width + 1.0))
            wp = np.where(prev >= 0, ease(1.0 - gp, kind), 0.0)
            wn = np.where(nxt < T, ease(1.0 - gn, kind), 0.0)
            wp = np.where(idx - prev > width, 0.0, wp)
            wn = np.where(nxt - idx > width, 0.0, wn)
        s = np.maximum(1.0, wp + wn)
        wp, wn = wp / s, wn / s
        prev, nxt = np.clip(prev, 0, T - 1), np.clip(nxt, 0, T - 1)
        for c, p in enumerate(plans):
            if p.trivial:
                continue
            und = ~d[:, c]
            p.und = und
            p.wp, p.wn = wp[und, c], wn[und, c]
            p.prev, p.nxt = prev[und, c], nxt[und, c]
        return plans

    def fill(self, values: np.ndarray) -> np.ndarray:
        values = np.asarray(values, dtype=float)
        T = self.defined.shape[0]
        out = np.where(self.defined.reshape((T,) + (1,) * (values.ndim - 1)), values, 0.0)
        if self.trivial:
            return out
        shape = (-1,) + (1,) * (values.ndim - 1)
        out[self.und] = self.wp.reshape(shape) * values[self.prev] + self.wn.reshape(shape) * values[self.nxt]
        return out


def ramp_fill(values: np.ndarray, defined: np.ndarray, width: int, kind: str = "smoothstep") -> np.ndarray:
    """``values (T, ...)`` kept where ``defined (T,)``; elsewhere faded from the nearest defined
    frames to zero over ``width`` frames on each side (the ease curve ``kind``). A frame within
    reach of a defined frame on both sides takes the weighted mix of both, normalised when the
    weights sum above 1 (a short gap between two plants is bridged, not dipped to zero).
    :class:`RampPlan` fills several arrays with one mask."""
    return RampPlan(defined, width, kind).fill(values)


def fade_clock(rates: np.ndarray, limit: float, slack: float = 0.5, floor: float = 0.0) -> np.ndarray:
    """``(T - 1,)`` clock for :meth:`RampPlan.many` from the rates ``(T - 1,)`` at which what a fade
    corrects is already moving on each step (e.g. a leg's fastest joint, rad per frame): 1 on steps
    below ``(1 - slack) limit``, falling linearly to ``floor`` at ``limit`` and above. A fade then
    hardly advances on the steps where the motion is near its fastest (``limit``), and makes up on the
    slower steps around them: the correction's own rate is not added to the peak."""
    r = np.asarray(rates, dtype=float)
    if not limit > 0:
        return np.ones_like(r)
    return np.clip((limit - r) / (slack * limit), floor, 1.0)
