"""Pose jumps against the input: a joint of an edited motion turning faster than the input's same joint.

The audit's own ``joint_speed`` check has one limit for the whole clip (60 rad/s), and a criterion
such as "no pose discontinuity above the input's own maximum joint speed" (issue 15) is defeated by
the input's own glitches: a CMU clip whose joint flips 180 degrees in one frame (375 rad/s at
120 Hz) sets a limit no edit can exceed. This check compares joint by joint and frame by frame.

**Rates.** Per joint and frame step, the rotation rate of the joint's local rotation,
``angle(q_k^-1 q_{k+1}) x fps`` (:func:`mocomp.audit.kinematics.step_rates`), of the audited
motion (``r_out``, ``(T_out - 1, J)``) and of the input (``r_in``). Joints are matched by name.

**Frame map.** Output frame ``k`` corresponds to the fractional input frame ``m_k``: by time in
seconds when the two clips last the same (within 1.5 frames), else by time normalised by each clip's
duration (a uniformly retimed output); a caller that knows its non-uniform time warp passes
``m`` itself (``audit(..., against_frame_map=m)``). The local play factor of step ``k`` is
``s_k = (m_{k+1} - m_k) fps_out / fps_in`` (input seconds per output second; 1 for an edit).

**Reference.** ``ref_k,j = s_k x max r_in[i, j]`` over the input steps ``i`` within
``h = max(1, round(pose_jump_window x fps_in))`` steps (plus half the steps one output step spans)
of ``m_k``: the fastest the input's own joint turns around the corresponding moment, so an input
glitch raises the reference only near itself, and the output copying that glitch is not flagged.

**Finding.** ``excess = r_out - ref``; a step is a *pose jump* of joint ``j`` when
``excess > pose_jump_excess`` (rad/s, default 20) and ``r_out > (1 + pose_jump_ratio) ref``
(default 0.5). Consecutive flagged steps form one finding: severity ``"advisory"`` by default,
``"violation"`` with ``pose_jump_is_violation`` (a method may move a joint faster than its input on
purpose: see :class:`~mocomp.audit.AuditThresholds`), and always ``"advisory"`` on a joint that
moves no mass of the body model (as the ``joint_speed`` check). A copy
of the input has ``excess <= 0`` everywhere; a 30-degree jump of one joint in one frame is
31 rad/s at 60 Hz and 63 rad/s at 120 Hz above a slowly moving input.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import maximum_filter1d

from ..errors import MotionFormatError
from .findings import Finding, runs_above

__all__ = ["PoseJumpAudit", "frame_map_by_time", "pose_jump_audit"]


def frame_map_by_time(n_out: int, fps_out: float, n_in: int, fps_in: float) -> tuple[np.ndarray, str]:
    """``(m (n_out,), "seconds" | "normalised")``: the fractional input frame of each output frame
    (module docstring), within ``[0, n_in - 1]``."""
    k = np.arange(n_out, dtype=float)
    if abs(n_out / fps_out - n_in / fps_in) <= 1.5 * max(1.0 / fps_out, 1.0 / fps_in):
        m, how = k / fps_out * fps_in, "seconds"
    else:
        m, how = k * ((n_in - 1) / max(n_out - 1, 1)), "normalised"
    return np.clip(m, 0.0, n_in - 1.0), how


@dataclass(frozen=True)
class PoseJumpAudit:
    """Per-joint rotation rate of the audited motion against the input's (module docstring).

    Attributes
    ----------
    mapping: ``"seconds"``, ``"normalised"`` or ``"given"`` (the frame map's origin).
    frame_map: ``(T_out,)`` fractional input frame of each output frame.
    joints: names of the joints compared (those both skeletons have).
    step_excess: ``(T_out - 1,)`` rad/s, per output step the largest ``r_out - ref`` over the joints.
    step_joint: ``(T_out - 1,)`` index into ``joints`` of that largest excess.
    max_excess: rad/s (``step_excess.max()``); joint: its joint; frame: its step (frames
        ``frame`` -> ``frame + 1``); rate, reference: rad/s, ``r_out`` and ``ref`` there.
    threshold: ``pose_jump_excess``; n_jumps: flagged steps (any joint).
    """

    mapping: str
    frame_map: np.ndarray = field(repr=False)
    joints: tuple[str, ...] = field(repr=False)
    step_excess: np.ndarray = field(repr=False)
    step_joint: np.ndarray = field(repr=False)
    max_excess: float
    joint: str
    frame: int
    rate: float
    reference: float
    threshold: float
    n_jumps: int

    def to_dict(self) -> dict:
        return {"mapping": self.mapping, "n_joints": len(self.joints), "max_excess_radps": self.max_excess,
                "joint": self.joint, "frame": self.frame, "rate_radps": self.rate,
                "input_reference_radps": self.reference, "threshold_radps": self.threshold,
                "n_jump_steps": self.n_jumps}

    def summary(self) -> str:
        return (f"joint rates against the input ({len(self.joints)} joints, frames matched by {self.mapping} time): "
                f"largest excess {self.max_excess:.1f} rad/s ({self.joint}, frames {self.frame}-{self.frame + 1}: "
                f"{self.rate:.1f} rad/s, input's own there {self.reference:.1f}); {self.n_jumps} step(s) above "
                f"{self.threshold:g} rad/s")


def pose_jump_audit(motion, against, thresholds, rates: np.ndarray | None = None,
                    against_rates: np.ndarray | None = None, frame_map=None, inert: np.ndarray | None = None,
                    label: str = "motion") -> tuple[PoseJumpAudit | None, list]:
    """Compare ``motion``'s joint rates with ``against``'s (module docstring). ``rates`` /
    ``against_rates``: their step rates (``(T - 1, J)`` rad/s) when already computed; ``frame_map``:
    ``(T_out,)`` fractional input frames (default: by time); ``inert``: ``(J_out,)`` bool, joints
    moving no mass (their findings are advisory). ``(None, [])`` when fewer than half of ``motion``'s
    joints (and fewer than 2) are in ``against``'s skeleton."""
    from .kinematics import step_rates

    names_o = tuple(motion.skeleton.names)
    idx_i = {n: i for i, n in enumerate(against.skeleton.names)}
    common = [j for j, n in enumerate(names_o) if n in idx_i]
    if len(common) < max(2, math.ceil(0.5 * len(names_o))):
        return None, []
    ji = np.array([idx_i[names_o[j]] for j in common])
    jo = np.array(common)
    To, Ti = motion.n_frames, against.n_frames
    fo, fi = float(motion.fps), float(against.fps)
    if frame_map is None:
        m, how = frame_map_by_time(To, fo, Ti, fi)
    else:
        m = np.asarray(frame_map, dtype=float)
        if m.shape != (To,) or not np.all(np.isfinite(m)):
            raise MotionFormatError(f"{label}: against_frame_map must be {To} finite input frame numbers (one per "
                                    f"frame), got shape {m.shape}")
        if m.min() < -0.5 or m.max() > Ti - 0.5:
            raise MotionFormatError(f"{label}: against_frame_map runs from {m.min():g} to {m.max():g}, outside the "
                                    f"input's frames 0-{Ti - 1}")
        m, how = np.clip(m, 0.0, Ti - 1.0), "given"
    r_out = (step_rates(motion)[0] if rates is None else rates)[:, jo]
    r_in = (step_rates(against)[0] if against_rates is None else against_rates)[:, ji]
    s = np.abs(np.diff(m)) * fo / fi                               # input seconds per output second
    h = max(1, int(round(thresholds.pose_jump_window * fi))) + int(math.ceil(0.5 * float(np.abs(np.diff(m)).max(initial=0.0))))
    ref_in = maximum_filter1d(r_in, size=2 * h + 1, axis=0, mode="nearest")
    c = np.clip(np.floor(0.5 * (m[:-1] + m[1:])).astype(int), 0, Ti - 2)
    ref = s[:, None] * ref_in[c]
    excess = r_out - ref
    flagged = (excess > thresholds.pose_jump_excess) & (r_out > (1.0 + thresholds.pose_jump_ratio) * ref)
    jmax = np.argmax(excess, axis=1)
    steps = np.arange(excess.shape[0])
    step_excess = excess[steps, jmax]
    k = int(np.argmax(step_excess))
    names_c = tuple(names_o[j] for j in jo)
    res = PoseJumpAudit(how, m, names_c, step_excess, jmax, float(step_excess[k]), names_c[jmax[k]], k,
                        float(r_out[k, jmax[k]]), float(ref[k, jmax[k]]), float(thresholds.pose_jump_excess),
                        int(flagged.any(axis=1).sum()))
    findings = []
    inert_c = np.zeros(len(jo), bool) if inert is None else np.asarray(inert, bool)[jo]
    main = "violation" if thresholds.pose_jump_is_violation else "advisory"
    for sev, mask in ((main, ~inert_c), ("advisory", inert_c)):
        if not mask.any():
            continue
        v = np.where(flagged & mask[None], excess, -np.inf).max(axis=1)
        for a, b, p in runs_above(v, thresholds.pose_jump_excess):
            j = int(np.argmax(np.where(flagged[p] & mask, excess[p], -np.inf)))
            name = names_c[j]
            findings.append(Finding(
                "pose_jump", sev, (a, b + 1), p, float(excess[p, j]), float(thresholds.pose_jump_excess),
                "pose_jump_excess", "rad/s", name,
                f"{name} turns {np.degrees(r_out[p, j] / fo):.0f} deg between frames {p} and {p + 1} "
                f"({r_out[p, j]:.1f} rad/s) where the input's own {name} turns at most {ref[p, j]:.1f} rad/s near "
                f"its frame {m[p]:.0f}; excess {excess[p, j]:.1f} rad/s, limit {thresholds.pose_jump_excess:g} rad/s"
                + (f" (frames matched by {how} time)" if how == "normalised" else "")
                + (" (moves no mass of the body model)" if inert_c[j] else "")))
    return res, findings
