"""Hand/body splicing end to end (dissertation ch. 6): markers -> two-stage
alignment -> median merge -> blended, combined motion.

* :func:`splice_motions` for skeleton data (BVH, ASF/AMC): virtual markers
  on the forearm and hand bones of both clips, alignment per arm, and the body
  clip with the arm joints driven by the aligned hand clip.
* :func:`splice_markers` for optical markers (C3D): the body recording's four
  hand markers replaced by the aligned hand recording's, carried to the body's
  shoulder and turned by the matched ``theta``; or, for a hand-only capture
  without a shoulder marker, the hand marker carried in the forearm's frame.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.motion import Motion, SourceInfo
from ..errors import AlignmentError
from .align import Alignment, SpliceConfig, align_hands
from .bands import MatchPoint, as_points
from .markers import HandMarkers, find_arm_joints, hand_markers_from_markers, virtual_hand_markers
from .merge import BlendReport, blend_discontinuities, median_frames, median_rotations
from .phases import PhaseLabels, motion_phases

__all__ = ["SpliceResult", "splice_motions", "splice_markers", "arm_layer_joints", "rescale_points"]


@dataclass(frozen=True, eq=False)
class SpliceResult:
    """The combined motion and the evidence of how it was made.

    Attributes
    ----------
    motion: the spliced :class:`~mocomp.core.Motion` (skeleton data) or ``None``.
    markers: the spliced :class:`~mocomp.io.markers.Markers` (marker data) or ``None``.
    alignments: per arm (``"right"``/``"left"``) the :class:`~mocomp.splice.align.Alignment`.
    body_phases, hand_phases: per arm, Table 6.1 labels of both recordings.
    joints: per arm, names of the joints (or markers) taken from the hand recording.
    blends: per arm, the :class:`~mocomp.splice.merge.BlendReport`.
    points: the user's matching points as given (body frame, hand frame in the hand file's frame rate).
    hand_resampled: ``(from_fps, to_fps)`` if the hand recording was resampled to the body's rate.
    timings: seconds (``markers``, ``align``, ``merge``, ``phases``, ``total``).
    """

    motion: Motion | None
    markers: object | None
    alignments: dict
    body_phases: dict
    hand_phases: dict
    joints: dict
    blends: dict
    points: tuple[MatchPoint, ...] = ()
    hand_resampled: tuple[float, float] | None = None
    timings: dict = field(default_factory=dict)

    def summary(self) -> str:
        lines = []
        for side, al in self.alignments.items():
            sc = al.pass1.step_counts()
            lines.append(
                f"{side} arm: body {al.n} frames, hand {al.m} frames; pass 1 cost {al.pass1.cost:.0f} "
                f"(band {al.pass1.band.cells} cells, {100 * al.pass1.band.fill:.0f}%), "
                + (f"pass 2 cost {al.pass2.cost:.2f} rad; " if al.pass2 is not None else "")
                + f"steps diag/horiz/vert {sc['diagonal']}/{sc['horizontal']}/{sc['vertical']}; "
                f"phases body {self.body_phases[side].sequence()} hand {self.hand_phases[side].sequence()}; "
                f"{len(self.blends[side].frames)} discontinuities blended"
            )
            if al.points:
                res = al.point_residuals()
                lines.append(f"  matching points {', '.join(map(str, al.points))}: residuals {np.round(res, 2).tolist()} frames")
        lines.append(f"time {1000 * self.timings.get('total', 0):.1f} ms (align {1000 * self.timings.get('align', 0):.1f} ms)")
        return "\n".join(lines)


def arm_layer_joints(skeleton, side: str, layer: str = "arm", joints: dict | None = None) -> list[int]:
    """Joint indices the hand recording drives: ``"arm"`` (clavicle, upper arm,
    forearm, hand and below), ``"forearm"`` (forearm, hand and below) or
    ``"hand"`` (the wrist joint and below, e.g. fingers)."""
    arm = find_arm_joints(skeleton, side, joints)
    top = {"arm": arm.clavicle if arm.clavicle is not None else arm.upper, "forearm": arm.forearm, "hand": arm.hand}
    if layer not in top:
        raise ValueError(f"layer must be 'arm', 'forearm' or 'hand', got {layer!r}")
    root = top[layer]
    return [j for j in range(skeleton.n_joints) if root in skeleton.chain(j)]


def rescale_points(points, hand_fps: float, body_fps: float) -> tuple[MatchPoint, ...]:
    """Hand frames of matching points re-expressed at the body's frame rate."""
    r = body_fps / hand_fps
    return tuple(MatchPoint(p.x, int(round(p.y * r)), int(np.ceil(p.tol * r))) for p in as_points(points))


def _sides(side: str) -> tuple[str, ...]:
    if side == "both":
        return ("right", "left")
    if side not in ("right", "left"):
        raise ValueError(f"side must be 'right', 'left' or 'both', got {side!r}")
    return (side,)


def splice_motions(body: Motion, hand: Motion, points=(), *, side: str = "right", layer: str = "arm",
                   config: SpliceConfig | None = None, joints: dict | None = None, blend_window: float = 0.2,
                   jump: float = 1.5, **overrides) -> SpliceResult:
    """Splice the arm(s) of a hand recording onto a full-body recording (skeleton data).

    Both clips need the arm joints (found by name, see
    :func:`~mocomp.splice.markers.find_arm_joints`, or ``joints=``); the
    layered joints (``layer``) must exist in both under the same names. The
    hand clip is resampled to the body's frame rate if they differ; ``points``
    (body frame, hand frame[, tolerance]) are in each file's own frames.
    ``side="both"`` aligns each arm separately. ``blend_window`` is in seconds.
    """
    t0 = time.perf_counter()
    cfg = config or SpliceConfig()
    if overrides:
        cfg = replace(cfg, **overrides)
    pts_in = as_points(points)
    resampled = None
    if abs(hand.fps - body.fps) > 1e-6 * body.fps:
        resampled = (hand.fps, body.fps)
        pts = rescale_points(pts_in, hand.fps, body.fps)
        hand = hand.resample(body.fps)
    else:
        pts = pts_in
    rot = np.array(body.rotations)
    alignments, bph, hph, names, blends = {}, {}, {}, {}, {}
    tm = {"markers": 0.0, "align": 0.0, "merge": 0.0, "phases": 0.0}
    for s in _sides(side):
        ta = time.perf_counter()
        jb = joints.get(s) if isinstance(joints, dict) and s in joints else joints
        hb = virtual_hand_markers(body, s, jb)
        hh = virtual_hand_markers(hand, s, jb)
        tb = time.perf_counter()
        al = align_hands(hb, hh, pts, cfg)
        tc = time.perf_counter()
        idx_b = arm_layer_joints(body.skeleton, s, layer, jb)
        nm = [body.skeleton.names[j] for j in idx_b]
        missing = [x for x in nm if x not in hand.skeleton]
        if missing:
            raise AlignmentError(f"the hand recording's skeleton lacks the joints {missing} that the {s} {layer} layer drives")
        idx_h = [hand.skeleton.index(x) for x in nm]
        merged = median_rotations(hand.rotations[:, idx_h], al.path, body.n_frames, al.hand_frame)
        win = max(3, int(round(blend_window * body.fps)) | 1)
        merged, rep = blend_discontinuities(merged, al.hand_frame, window=win, jump=jump, rotations=True)
        rot[:, idx_b] = merged
        td = time.perf_counter()
        bph[s] = motion_phases(hb, smooth=cfg.smooth)
        hph[s] = motion_phases(hh, smooth=cfg.smooth)
        te = time.perf_counter()
        alignments[s], names[s], blends[s] = al, tuple(nm), rep
        tm["markers"] += tb - ta
        tm["align"] += tc - tb
        tm["merge"] += td - tc
        tm["phases"] += te - td
    note = f"spliced {side} {layer} from {hand.source.path or hand.source.format}"
    out = body.replace(rotations=rot, source=replace(body.source, notes=body.source.notes + (note,)))
    tm["total"] = time.perf_counter() - t0
    return SpliceResult(out, None, alignments, bph, hph, names, blends, pts_in, resampled, tm)


def splice_markers(body, hand, points=(), *, side: str = "right", body_names=None, hand_names=None,
                   layer: str = "auto", config: SpliceConfig | None = None, blend_window: float = 0.2,
                   jump: float = 1.5, **overrides) -> SpliceResult:
    """Splice optical hand markers (:class:`~mocomp.io.markers.Markers`, e.g. C3D)
    onto a full-body marker recording.

    The four hand markers (default Plug-in-Gait ``WRA, WRB, FRM, FIN``; see
    :func:`~mocomp.splice.markers.hand_markers_from_markers`) of both
    recordings are aligned (two-stage DTW), then, per body frame, the median
    over the matched hand frames (ch. 6.2) replaces the body's markers;
    discontinuities are blended. ``layer``:

    * ``"arm"``: all four markers. The hand recording's shoulder-relative
      positions are turned about the vertical by the trunk-heading
      difference (both recordings need a trunk heading: waist or both
      shoulder markers), else by eq. 6.7's ``theta`` between the matched
      frames (windows clamped at the clip's ends, sums pooled over
      ``SpliceConfig.refine_theta_span``,
      :func:`~mocomp.splice.metrics.matched_theta`), and added to the body's
      shoulder. Needs a shoulder marker in both recordings.
    * ``"hand"``: only the hand marker (``FIN``), carried in the distal
      forearm's own frame (:func:`~mocomp.splice.markers.forearm_frame`: wrist
      centre, forearm vector, wrist axis) from the hand recording onto the
      body's forearm, which keeps its own markers. Needs no shoulder and no
      heading: what a hand-only capture (no shoulder marker, the arm resting
      on a table) records is the hand relative to the forearm.
    * ``"auto"`` (default): ``"arm"`` when both recordings have a shoulder
      marker, else ``"hand"``.
    """
    from .markers import forearm_frame
    from .metrics import matched_theta, rotate_vertical

    t0 = time.perf_counter()
    cfg = config or SpliceConfig()
    if overrides:
        cfg = replace(cfg, **overrides)
    if layer not in ("auto", "arm", "hand"):
        raise ValueError(f"layer must be 'auto', 'arm' or 'hand', got {layer!r}")
    if abs(hand.fps - body.fps) > 1e-6 * body.fps:
        raise AlignmentError(f"body ({body.fps:g} fps) and hand ({hand.fps:g} fps) marker recordings must share a frame rate")
    pts = as_points(points)
    P = np.array(body.positions)
    alignments, bph, hph, names, blends = {}, {}, {}, {}, {}
    tm = {"markers": 0.0, "align": 0.0, "merge": 0.0, "phases": 0.0}
    layers = {}
    for s in _sides(side):
        ta = time.perf_counter()
        hb = hand_markers_from_markers(body, s, body_names)
        hh = hand_markers_from_markers(hand, s, hand_names)
        lay = layer
        if lay == "auto":
            lay = "arm" if hb.shoulder is not None and hh.shoulder is not None else "hand"
        if lay == "arm" and (hb.shoulder is None or hh.shoulder is None):
            which = "body" if hb.shoulder is None else "hand"
            raise AlignmentError(
                f"layer='arm' carries the hand recording's four {s} markers to the body's shoulder, so both recordings "
                f"need a {s} shoulder marker; the {which} recording ({(body if which == 'body' else hand).source or which}) "
                f"has none. Use layer='hand' (the hand marker carried in the forearm's frame) for a hand-only capture, "
                f"or name the shoulder marker (names=(..., shoulder))"
            )
        tb = time.perf_counter()
        al = align_hands(hb, hh, pts, cfg)
        tc = time.perf_counter()
        if lay == "arm":
            rel = median_frames(hh.relative, al.path, al.n, al.hand_frame)  # (n, 4, 3)
            both = al.body_features.heading is not None and al.hand_features.heading is not None
            span = max(1, int(round(cfg.refine_theta_span * body.fps)) | 1)
            theta = matched_theta(al.body_features, al.hand_features, al.hand_frame, "trunk" if both else "window", span)
            merged = hb.shoulder[:, None, :] + rotate_vertical(rel, theta)
            labels = hb.labels
        else:
            ch, Rh = forearm_frame(hh.positions, hand.source)
            local = np.einsum("tji,tj->ti", Rh, hh.positions[:, 3] - ch)  # hand marker in the hand recording's forearm frame
            local = median_frames(local, al.path, al.n, al.hand_frame)
            cb, Rb = forearm_frame(hb.positions, body.source)
            merged = (cb + np.einsum("tij,tj->ti", Rb, local))[:, None, :]
            labels = hb.labels[3:]
        win = max(3, int(round(blend_window * body.fps)) | 1)
        merged, rep = blend_discontinuities(merged, al.hand_frame, window=win, jump=jump)
        idx = [body.names.index(lab) for lab in labels]
        P[:, idx] = merged
        td = time.perf_counter()
        bph[s] = motion_phases(hb, smooth=cfg.smooth)
        hph[s] = motion_phases(hh, smooth=cfg.smooth)
        te = time.perf_counter()
        alignments[s], names[s], blends[s], layers[s] = al, labels, rep, lay
        tm["markers"] += tb - ta
        tm["align"] += tc - tb
        tm["merge"] += td - tc
        tm["phases"] += te - td
    mask = np.array(body.mask)
    for s in names:
        for lab in names[s]:
            mask[:, body.names.index(lab)] = True
    note = (f"spliced {side} hand markers ({', '.join(f'{k}: {v} layer' for k, v in layers.items())}) "
            f"from {hand.source or 'hand recording'}")
    out = replace(body, positions=P, mask=mask, notes=tuple(getattr(body, "notes", ())) + (note,))
    tm["total"] = time.perf_counter() - t0
    return SpliceResult(None, out, alignments, bph, hph, names, blends, pts, None, tm)
