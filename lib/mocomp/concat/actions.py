"""Single strikes (punches, kicks, slashes) cut out of a clip that holds several (issue 17).

The paper chains single motions from a database; the staged captures hold several in a take (the
Bandai clips: five left or five right punches, three spinning kicks; the ASE sword combos: two to
four strikes). :func:`find_actions` finds each strike by the speed of the extremities (hands and
toes) relative to the root -- a punch or kick is its striking limb's speed peak (|L| alone is a
poor marker for punches: the Bandai left punches carry 2-4 kg m^2/s, with more |L| peaks than
punches) -- and :func:`cut_actions` returns the sub-motions.

Per clip: the per-frame largest extremity speed ``s(t)`` (m/s, Gaussian-smoothed over
``smooth_seconds``); strikes are its peaks with a prominence of at least ``prominence`` x its
maximum, at least ``min_gap`` seconds apart (:func:`scipy.signal.find_peaks`; a strike and its retraction, or a
kick and its recoil, are two peaks ~0.3-0.4 s apart). Between two
successive strikes the cut is at the slowest frame (a piece may reach ``margin`` past it, never past
the neighbour's peak); two peaks whose slowest frame between stays
above ``merge`` x the smaller peak are one strike (a kick's two legs, a punch's follow-through); (the quiet pose between them); a strike starts
``margin`` seconds before the last frame under ``quiet`` x its peak speed before the peak (at the
earliest at the previous cut) and ends ``margin`` after the first such frame after it (at the
latest at the next cut), so each piece keeps a wind-up and a recovery (the paper's preparatory and
posterior phases).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from .phases import ConcatError

__all__ = ["Action", "find_actions", "cut_actions", "parse_selection", "EXTREMITIES"]

#: the detector effectors whose speed marks a strike
EXTREMITIES = ("hand_l", "hand_r", "toe_l", "toe_r")


@dataclass(frozen=True)
class Action:
    """One strike: frames ``[start, stop)`` of the clip, its speed ``peak`` frame, the extremity
    that strikes and its speed there (m/s, relative to the root)."""

    start: int
    stop: int
    peak: int
    effector: str
    speed: float

    def cut(self, motion: Motion) -> Motion:
        return motion[self.start:self.stop]

    def to_dict(self) -> dict:
        return {"start": self.start, "stop": self.stop, "peak": self.peak, "effector": self.effector,
                "speed_mps": self.speed}


def extremity_speeds(motion: Motion, smooth_seconds: float = 0.03) -> np.ndarray:
    """``(T, 4)`` m/s: speeds of :data:`EXTREMITIES` relative to the root position, smoothed."""
    from scipy.ndimage import gaussian_filter1d

    from ..dynamics.contacts import effector_positions
    from ..ops.plants import effectors_of

    eff = effectors_of(motion.skeleton)
    P = effector_positions(motion, [eff[n][0] for n in EXTREMITIES], [eff[n][1] for n in EXTREMITIES])
    rel = P - np.asarray(motion.root_positions)[:, None]
    v = np.linalg.norm(np.gradient(rel, axis=0), axis=-1) * motion.fps
    sig = smooth_seconds * motion.fps
    return gaussian_filter1d(v, sig, axis=0, mode="nearest") if sig >= 0.5 else v


def find_actions(motion: Motion, *, prominence: float = 0.35, min_gap: float = 0.45, quiet: float = 0.25,
                 margin: float = 0.25, merge: float = 0.4, smooth_seconds: float = 0.03) -> list[Action]:
    """The strikes of ``motion`` in time order (see the module docstring). Raises
    :class:`~mocomp.concat.ConcatError` when the clip is too short or no extremity moves."""
    if motion.n_frames < 5:
        raise ConcatError(f"{motion.source.path or 'the motion'}: {motion.n_frames} frame(s), too short to find strikes in")
    from scipy.signal import find_peaks

    v = extremity_speeds(motion, smooth_seconds)
    s = v.max(axis=1)
    if not np.isfinite(s).all() or s.max() <= 1e-6:
        raise ConcatError(f"{motion.source.path or 'the motion'}: no hand or foot moves; no strike to cut")
    pk, _ = find_peaks(s, prominence=prominence * s.max(), distance=max(1, int(round(min_gap * motion.fps))))
    if pk.size == 0:                              # one monotone strike: its fastest frame
        pk = np.array([int(np.argmax(s))])
    keep = [int(pk[0])]                           # two peaks without a slow frame between: one strike
    for q in pk[1:]:
        p = keep[-1]
        if s[p:q + 1].min() > merge * min(s[p], s[q]):
            if s[q] > s[p]:
                keep[-1] = int(q)
        else:
            keep.append(int(q))
    pk = np.array(keep)
    T = motion.n_frames
    cuts = [0] + [int(p + np.argmin(s[p:q + 1])) for p, q in zip(pk[:-1], pk[1:])] + [T]
    mg = int(round(margin * motion.fps))
    out = []
    for i, p in enumerate(pk):
        # a piece may reach ``margin`` past the cuts into its neighbours (never past their peaks): strikes
        # of a combo follow each other closely, and each piece needs a wind-up and a recovery
        lo = max(0, cuts[i] - mg, int(pk[i - 1]) + 1 if i else 0)
        hi = min(T, cuts[i + 1] + mg, int(pk[i + 1]) if i + 1 < pk.size else T)
        low = s < quiet * s[p]
        before = np.flatnonzero(low[lo:p])
        after = np.flatnonzero(low[p:hi])
        a = max(lo, (lo + int(before[-1]) if before.size else lo) - mg)
        b = min(hi, (p + int(after[0]) if after.size else hi) + mg + 1)
        out.append(Action(int(a), int(b), int(p), EXTREMITIES[int(np.argmax(v[p]))], float(s[p])))
    return out


def cut_actions(motion: Motion, **kw) -> list[Motion]:
    """The sub-motions of :func:`find_actions` (each a frame slice of ``motion``)."""
    return [a.cut(motion) for a in find_actions(motion, **kw)]


_SEL = re.compile(r"^(?P<path>.+)@(?:(?P<k>\d+)|(?P<a>\d+):(?P<b>\d+))$")


def parse_selection(text: str) -> tuple[str, int | None, tuple[int, int] | None]:
    """``"clip.bvh@2"`` -> ``("clip.bvh", 2, None)`` (the 2nd strike, 1-based); ``"clip.bvh@30:90"``
    -> ``("clip.bvh", None, (30, 90))`` (frames, stop exclusive); else ``(text, None, None)``."""
    m = _SEL.match(text)
    if m is None:
        return text, None, None
    if m.group("k") is not None:
        k = int(m.group("k"))
        if k < 1:
            raise ValueError(f"{text!r}: strikes are numbered from 1")
        return m.group("path"), k, None
    a, b = int(m.group("a")), int(m.group("b"))
    if not a < b:
        raise ValueError(f"{text!r}: need START < STOP (frames, STOP exclusive)")
    return m.group("path"), None, (a, b)


def select(motion: Motion, name: str, k: int | None, frames: tuple[int, int] | None) -> tuple[Motion, str]:
    """The piece of ``motion`` a selection names, and a description of it."""
    if frames is not None:
        a, b = frames
        if b > motion.n_frames:
            raise ValueError(f"{name}@{a}:{b}: the clip has only {motion.n_frames} frames")
        return motion[a:b], f"frames {a}-{b - 1}"
    if k is not None:
        acts = find_actions(motion)
        if k > len(acts):
            raise ValueError(f"{name}@{k}: the clip holds {len(acts)} strike(s) (" + ", ".join(
                f"{i + 1}: frames {x.start}-{x.stop - 1}, {x.effector}" for i, x in enumerate(acts)) + ")")
        x = acts[k - 1]
        return x.cut(motion), (f"strike {k} of {len(acts)}: frames {x.start}-{x.stop - 1}, {x.effector} at "
                               f"{x.speed:.1f} m/s (frame {x.peak})")
    return motion, "whole clip"
