"""Transition rules, the spatial alignment of eq. 2 and the blendable periods (Shum et al. 2009).

* forward rule: the two main phases turn the same way; the momentum of the first main phase is
  kept up to start the second;
* reverse rule: they turn opposite ways; the end of the first motion winds up the second.

:func:`choose_rule` (``--rule auto``) compares the main phases' mean L, each expressed in its
motion's own heading frame (the root's heading at ``t_m``), so the choice does not depend on where
the two clips happened to face in the capture volume.

Eq. 2: ``theta_2 = argmax (forward) | argmin (reverse) of  L1_bar . (R_y(theta) L2_bar)``. With
``R_y`` a rotation about the vertical the product is ``A cos(theta) + B sin(theta) + C``, so the
optimum is closed form: ``A, B, C`` come from three evaluations (theta = 0, pi/2, pi) and
``theta* = atan2(B, A)`` (max) or ``theta* + pi`` (min) -- independent of the handedness convention
of the rotation, since it uses the same :func:`mocomp.ops.align.yaw_quaternion` that is applied.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_apply
from ..ops.align import headings, yaw_quaternion
from .phases import ConcatError, MomentumTrack, Phases

__all__ = ["RULES", "RuleChoice", "choose_rule", "alignment_yaw", "blendable_periods", "support_truncate"]

RULES = ("forward", "reverse")


@dataclass(frozen=True)
class RuleChoice:
    rule: str
    dot: float
    L1_mean: tuple
    L2_mean: tuple
    reason: str

    def to_dict(self) -> dict:
        return {"rule": self.rule, "main_mean_L_dot": self.dot, "L1_main_mean_heading_frame": list(self.L1_mean),
                "L2_main_mean_heading_frame": list(self.L2_mean), "why": self.reason}


def _main_mean(track: MomentumTrack, ph: Phases) -> np.ndarray:
    return track.L[ph.main[0]:ph.main[1]].mean(axis=0)


def _heading_frame(motion, track: MomentumTrack, ph: Phases) -> np.ndarray:
    """The main phase's mean L turned so the root faces heading 0 at ``t_m``."""
    h = float(headings(motion, [ph.t_m])[0])
    return quat_apply(yaw_quaternion(-h), _main_mean(track, ph))


def choose_rule(m1, t1: MomentumTrack, p1: Phases, m2, t2: MomentumTrack, p2: Phases,
                rule: str = "auto") -> RuleChoice:
    """The rule to apply and why: forward when the main phases' mean L (heading frames) point the same
    way (positive dot product), reverse otherwise; a rule given explicitly is kept and the reason says
    whether the angular momenta agree with it."""
    a, b = _heading_frame(m1, t1, p1), _heading_frame(m2, t2, p2)
    d = float(a @ b)
    cos = d / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-12)
    same = d > 0
    fact = (f"mean L of the main phases in each motion's heading frame: A {np.round(a, 2).tolist()}, "
            f"B {np.round(b, 2).tolist()} kg m^2/s; dot {d:+.1f} (cos {cos:+.2f}): "
            + ("same direction" if same else "opposite directions"))
    if rule == "auto":
        chosen = "forward" if same else "reverse"
        reason = f"auto: {fact} -> {chosen} rule"
    elif rule in RULES:
        chosen = rule
        agree = (rule == "forward") == same
        reason = f"given: {fact}" + ("" if agree else f" (the {rule} rule was asked for all the same)")
    else:
        raise ValueError(f"rule must be forward, reverse or auto, got {rule!r}")
    return RuleChoice(chosen, d, tuple(map(float, a)), tuple(map(float, b)), reason)


def alignment_yaw(L1_bar, L2_bar, rule: str) -> tuple[float, float]:
    """Eq. 2 in closed form: ``(theta, value)``, the yaw (rad, in (-pi, pi]) about the vertical that
    maximises (forward) or minimises (reverse) ``L1_bar . R_y(theta) L2_bar``, and that product."""
    L1 = np.asarray(L1_bar, dtype=float)
    L2 = np.asarray(L2_bar, dtype=float)
    f0, f90, f180 = (float(L1 @ quat_apply(yaw_quaternion(t), L2)) for t in (0.0, 0.5 * np.pi, np.pi))
    C = 0.5 * (f0 + f180)
    A = 0.5 * (f0 - f180)
    B = f90 - C
    th = float(np.arctan2(B, A))
    if rule == "reverse":
        th += np.pi
    elif rule != "forward":
        raise ValueError(f"rule must be forward or reverse, got {rule!r}")
    th = float((th + np.pi) % (2 * np.pi) - np.pi)
    return th, float(L1 @ quat_apply(yaw_quaternion(th), L2))


def _half(r: tuple[int, int], which: str) -> tuple[int, int]:
    a, b = r
    mid = (a + b) // 2
    return (mid, b) if which == "latter" else (a, max(mid, a + 1) if b > a else a)


def blendable_periods(rule: str, p1: Phases, p2: Phases) -> list[tuple[str, tuple[int, int], tuple[int, int]]]:
    """The blendable periods of each motion (half-open frames of motion 1 and of motion 2) per rule:
    forward -- latter half of main 1 with initial half of main 2; reverse -- (1) latter half of main 1
    with latter half of preparatory 2, (2) initial half of posterior 1 with initial half of main 2.
    Empty candidates (a phase that does not exist) are dropped; none left raises :class:`ConcatError`."""
    if rule == "forward":
        cands = [("latter half of main A + initial half of main B", _half(p1.main, "latter"), _half(p2.main, "initial"))]
    elif rule == "reverse":
        cands = [("latter half of main A + latter half of preparatory B", _half(p1.main, "latter"),
                  _half(p2.preparatory, "latter")),
                 ("initial half of posterior A + initial half of main B", _half(p1.posterior, "initial"),
                  _half(p2.main, "initial"))]
    else:
        raise ValueError(f"rule must be forward or reverse, got {rule!r}")
    out = [(n, a, b) for n, a, b in cands if a[1] > a[0] and b[1] > b[0]]
    if not out:
        raise ConcatError(
            f"the {rule} rule cannot apply: " + "; ".join(
                f"{n}: A frames {a[0]}-{a[1]}, B frames {b[0]}-{b[1]}" + (" (empty)" if a[1] <= a[0] or b[1] <= b[0] else "")
                for n, a, b in cands)
            + f" (A phases {p1.to_dict()}, B phases {p2.to_dict()})")
    return out


def support_truncate(labels: np.ndarray, period: tuple[int, int], hands: np.ndarray | None = None
                     ) -> tuple[tuple[int, int], str]:
    """Truncate a blendable period to double support where the motion is on the ground: with
    ``labels`` ``(T, 4)`` foot-plant labels (foot_l, toe_l, foot_r, toe_r), the frames allowed are
    those in the air (no foot planted) or on both feet; the period becomes the longest run of
    allowed frames in it. When it has none (on one foot throughout, as in a kick) it is kept whole,
    with a note. ``hands``: ``(T, k)`` bool, hand contacts (the contact detector's ``hand_l``,
    ``hand_r``): a frame with a hand planted and no foot is hand support (a cartwheel's inverted
    frames), not flight, and is left out like single support."""
    a, b = period
    lab = np.asarray(labels, dtype=bool)[a:b]
    left, right = lab[:, 0] | lab[:, 1], lab[:, 2] | lab[:, 3]
    air = ~(left | right)
    if hands is not None:
        air &= ~np.asarray(hands, dtype=bool)[a:b].any(axis=1)
    ok = (left & right) | air
    if not ok.any():
        return period, "on one foot (or hands) throughout: kept whole"
    if ok.all():
        return period, "airborne or on both feet throughout"
    d = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
    starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    k = int(np.argmax(stops - starts))
    lo, hi = a + int(starts[k]), a + int(stops[k])
    return (lo, hi), (f"truncated to {lo}-{hi} (airborne or double support; single support"
                      + (" and hand support" if hands is not None and np.asarray(hands, dtype=bool)[a:b].any() else "")
                      + " left out)")
