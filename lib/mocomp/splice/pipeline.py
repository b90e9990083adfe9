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
    joints: per arm, names of the body joints (or markers) driven by the hand recording.
    blends: per arm, the :class:`~mocomp.splice.merge.BlendReport`.
    points: the user's matching points as given (body frame, hand frame in the hand file's frame rate).
    hand_resampled: ``(from_fps, to_fps)`` if the hand recording was resampled to the body's rate.
    timings: seconds (``markers``, ``align``, ``merge``, ``phases``, ``quality``, ``total``).
    quality: per arm, the :class:`~mocomp.splice.quality.SpliceQuality` measured on
        the frames written (frozen/reversed hand, warp slope, eq. 6.9 residual)
        with a verified matching-point suggestion when a freeze can be cut.
    pairs: per arm, body joint -> hand-recording joint it takes its rotation
        from (``None``: kept as the body has it; :mod:`~mocomp.splice.jointmap`).
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
    quality: dict = field(default_factory=dict)
    pairs: dict = field(default_factory=dict)

    def warnings(self) -> list[str]:
        """Quality warnings of every arm (one line each, with body frames)."""
        return [w for q in self.quality.values() for w in q.warnings()]

    def summary(self) -> str:
        lines = []
        for side, al in self.alignments.items():
            sc = al.pass1.step_counts()
            where = ""
            if al.interval is not None:
                a, e = al.interval
                where = (f"; matched interval body frames {a}-{e} ({e - a + 1} frames, "
                         f"{(e - a + 1) / al.body_features.fps:.2f} s; subsequence search)")
            lines.append(
                f"{side} arm: body {al.n} frames, hand {al.m} frames{where}; pass 1 cost {al.pass1.cost:.0f} "
                f"(band {al.pass1.band.cells} cells, {100 * al.pass1.band.fill:.0f}%, "
                f"{al.config.band_width_kind}-width reading), "
                + (f"pass 2 cost {al.pass2.cost:.2f} rad; " if al.pass2 is not None else "")
                + f"steps diag/horiz/vert {sc['diagonal']}/{sc['horizontal']}/{sc['vertical']}; "
                f"phases body {self.body_phases[side].sequence()} hand {self.hand_phases[side].sequence()}; "
                f"{len(self.blends[side].frames)} discontinuities blended"
            )
            if al.points:
                res = al.point_residuals()
                lines.append(f"  matching points {', '.join(map(str, al.points))}: residuals {np.round(res, 2).tolist()} frames")
            q = self.quality.get(side)
            if q is not None:
                lines.append(f"  quality: " + ("no frozen or reversed hand, warp slope within "
                                               f"{q.thresholds.slope_range[0]:.2f}-{q.thresholds.slope_range[1]:.2f}x"
                                               + (", residual within the limit" if q.residual_deg is not None else "")
                                               if q.ok else f"{len(q.stretches)} problem stretch(es), "
                                               f"{q.frozen_frames} frozen frame(s) (see the warnings)"))
            renamed = {b: h for b, h in self.pairs.get(side, {}).items() if h != b}
            if renamed:
                lines.append("  joints paired by name map: " + ", ".join(
                    f"{b} <- {h if h is not None else '(kept)'}" for b, h in renamed.items()))
        lines.append(f"time {1000 * self.timings.get('total', 0):.1f} ms (align {1000 * self.timings.get('align', 0):.1f} ms)")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The report (JSON-ready): per arm the alignment's numbers, the matched
        interval, phases, quality stretches and suggestion, joint pairs; timings."""
        arms = {}
        for side, al in self.alignments.items():
            d = {
                "body_frames": al.n, "hand_frames": al.m,
                "interval": None if al.interval is None else {"start": al.interval[0], "end": al.interval[1],
                                                              **({"search": al.locate.to_dict()} if al.locate is not None else {})},
                "pass1": {"cost": float(al.pass1.cost), "band_cells": al.pass1.band.cells, "band_fill": al.pass1.band.fill,
                          "steps": al.pass1.step_counts()},
                "pass2": None if al.pass2 is None else {"cost_rad": float(al.pass2.cost), "band_fill": al.pass2.band.fill},
                "band_width_kind": al.config.band_width_kind,
                "phase_width": al.config.phase_width, "refine_width": al.config.refine_width,
                "points": [str(p) for p in al.points],
                "point_residuals": al.point_residuals().tolist() if al.points else [],
                "hand_frame": np.round(al.hand_frame, 3).tolist(),
                "phases": {"body": self.body_phases[side].sequence(), "hand": self.hand_phases[side].sequence(),
                           "body_counts": self.body_phases[side].counts(), "hand_counts": self.hand_phases[side].counts()},
                "blended_frames": list(self.blends[side].frames),
                "joints": list(self.joints[side]),
                "pairs": self.pairs.get(side, {}),
            }
            if side in self.quality:
                d["quality"] = self.quality[side].to_dict()
            arms[side] = d
        return {"arms": arms, "points": [str(p) for p in self.points],
                "hand_resampled": list(self.hand_resampled) if self.hand_resampled else None,
                "timings_s": dict(self.timings), "warnings": self.warnings()}


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
        raise ValueError(f"side must be 'right' or 'left', got {side!r}")
    return (side,)


def _edge_crossfade(inside: np.ndarray, own: np.ndarray, window: int) -> np.ndarray:
    """Rotations ``inside (k, J, 4)`` of a matched interval eased in from and out
    to the body's ``own`` ones over ``window`` frames at each end (minimum-jerk
    slerp weights; subsequence mode, where the body keeps its arm outside)."""
    from ..core.motion import slerp

    k = inside.shape[0]
    i = np.arange(k)
    u = np.clip(np.minimum(i + 1, k - i) / float(window + 1), 0.0, 1.0)
    u = u ** 3 * (10 - 15 * u + 6 * u ** 2)
    own = np.where(np.sum(own * inside, axis=-1, keepdims=True) < 0, -own, own)
    return slerp(own, inside, np.broadcast_to(u[:, None], inside.shape[:-1]))


def _merge_arm(body: Motion, hand: Motion, al: Alignment, idx_b, idx_h, win: int, jump: float):
    """The body's rotations with the layer joints ``idx_b`` driven by the hand
    recording's ``idx_h`` through the alignment: median merge (ch. 6.2), blending,
    and in subsequence mode only inside the matched interval (eased at its ends)."""
    rot = np.array(body.rotations)
    merged = median_rotations(hand.rotations[:, idx_h], al.path, al.n, al.hand_frame)
    merged, rep = blend_discontinuities(merged, al.hand_frame, window=win, jump=jump, rotations=True)
    a = al.offset
    if al.interval is not None:
        merged = _edge_crossfade(merged, rot[a:a + al.n][:, idx_b], max(1, win // 2))
        rep = replace(rep, frames=tuple(f + a for f in rep.frames))
    sub = rot[a:a + al.n]
    sub[:, idx_b] = merged
    rot[a:a + al.n] = sub
    return rot, rep


def _spliced_hand(rot: np.ndarray, body: Motion, side: str, jb, al: Alignment) -> np.ndarray:
    """The spliced hand marker (p4, shoulder-relative) on the frames written, over the alignment's rows."""
    out = body.replace(rotations=rot)
    hm = virtual_hand_markers(out, side, jb)
    return hm.relative[al.offset:al.offset + al.n, 3]


def splice_motions(body: Motion, hand: Motion, points=(), *, side: str = "right", layer: str = "arm",
                   config: SpliceConfig | None = None, joints: dict | None = None, blend_window: float = 0.2,
                   jump: float = 1.5, joint_map=None, quality: bool = True, suggest: bool = True,
                   thresholds=None, **overrides) -> SpliceResult:
    """Splice the arm(s) of a hand recording onto a full-body recording (skeleton data).

    Both clips need the arm joints (found by name, see
    :func:`~mocomp.splice.markers.find_arm_joints`, ``joints=`` or the map's
    ``[arm.body|hand.<side>]``). The layered joints (``layer``) of the body are
    paired with the hand recording's by name, by ``joint_map`` (a
    :class:`~mocomp.splice.jointmap.JointMap` or a TOML path), by the body
    model's naming conventions and by structure
    (:func:`~mocomp.splice.jointmap.pair_joints`); unpaired ones raise
    :class:`~mocomp.errors.AlignmentError` listing them. The hand clip is
    resampled to the body's frame rate if they differ; ``points``
    (body frame, hand frame[, tolerance]) are in each file's own frames.
    ``side="both"`` aligns each arm separately. ``blend_window`` is in seconds.

    ``quality`` measures the splice on the frames written
    (:mod:`~mocomp.splice.quality`, ``thresholds`` a
    :class:`~mocomp.splice.quality.QualityThresholds`); with ``suggest``, a
    frozen stretch gets two tolerant matching points, verified by splicing
    again with them. ``SpliceConfig.subsequence`` splices the hand recording
    onto the body interval found by open-begin/open-end DTW only.
    """
    from .jointmap import JointMap, load_joint_map, pair_joints
    from .quality import dominant_period, measure_quality, suggest_points

    t0 = time.perf_counter()
    cfg = config or SpliceConfig()
    if overrides:
        cfg = replace(cfg, **overrides)
    jmap = joint_map if isinstance(joint_map, JointMap) or joint_map is None else load_joint_map(joint_map)
    pts_in = as_points(points)
    resampled = None
    if abs(hand.fps - body.fps) > 1e-6 * body.fps:
        resampled = (hand.fps, body.fps)
        pts = rescale_points(pts_in, hand.fps, body.fps)
        hand = hand.resample(body.fps)
    else:
        pts = pts_in
    rot = np.array(body.rotations)
    alignments, bph, hph, names, blends, quals, pairs = {}, {}, {}, {}, {}, {}, {}
    tm = {"markers": 0.0, "align": 0.0, "merge": 0.0, "phases": 0.0, "quality": 0.0}
    win = max(3, int(round(blend_window * body.fps)) | 1)
    for s in _sides(side):
        ta = time.perf_counter()
        jb = joints.get(s) if isinstance(joints, dict) and s in joints else joints
        jh = jb
        if jmap is not None:
            jb = jmap.arm("body", s) or jb
            jh = jmap.arm("hand", s) or jh
        hb = virtual_hand_markers(body, s, jb)
        hh = virtual_hand_markers(hand, s, jh)
        idx_b = arm_layer_joints(body.skeleton, s, layer, jb)
        pr = pair_joints(body.skeleton, hand.skeleton, idx_b, find_arm_joints(body.skeleton, s, jb),
                         find_arm_joints(hand.skeleton, s, jh), jmap)
        used_b = [j for j in idx_b if pr[body.skeleton.names[j]] is not None]
        idx_h = [hand.skeleton.index(pr[body.skeleton.names[j]]) for j in used_b]
        tb = time.perf_counter()
        al = align_hands(hb, hh, pts, cfg)
        tc = time.perf_counter()
        new_rot, rep = _merge_arm(body.replace(rotations=rot), hand, al, used_b, idx_h, win, jump)
        td = time.perf_counter()
        bph[s] = motion_phases(hb, smooth=cfg.smooth)
        hph[s] = motion_phases(hh, smooth=cfg.smooth)
        te = time.perf_counter()
        if quality:
            q = measure_quality(al, _spliced_hand(new_rot, body, s, jb, al), side=s, offset=al.offset,
                                thresholds=thresholds)
            if suggest and q.of_kind("frozen"):
                base = rot

                def rerun(p2, s=s, hb=hb, hh=hh, jb=jb, used_b=used_b, idx_h=idx_h, base=base):
                    al2 = align_hands(hb, hh, p2, cfg)
                    r2, _ = _merge_arm(body.replace(rotations=base), hand, al2, used_b, idx_h, win, jump)
                    return measure_quality(al2, _spliced_hand(r2, body, s, jb, al2), side=s, offset=al2.offset,
                                           thresholds=thresholds)

                period = dominant_period(np.linalg.norm(np.gradient(hh.relative[:, 3], axis=0), axis=1) * hh.fps, hh.fps)
                q = q.with_suggestion(suggest_points(q, al, pts, rerun, hand_period=period, offset=al.offset))
            quals[s] = q
        tf = time.perf_counter()
        rot = new_rot
        alignments[s], names[s], blends[s], pairs[s] = al, tuple(body.skeleton.names[j] for j in used_b), rep, pr
        tm["markers"] += tb - ta
        tm["align"] += tc - tb
        tm["merge"] += td - tc
        tm["phases"] += te - td
        tm["quality"] += tf - te
    note = f"spliced {side} {layer} from {hand.source.path or hand.source.format}"
    out = body.replace(rotations=rot, source=replace(body.source, notes=body.source.notes + (note,)))
    tm["total"] = time.perf_counter() - t0
    return SpliceResult(out, None, alignments, bph, hph, names, blends, pts_in, resampled, tm, quals, pairs)


def splice_markers(body, hand, points=(), *, side: str = "right", body_names=None, hand_names=None,
                   layer: str = "auto", config: SpliceConfig | None = None, blend_window: float = 0.2,
                   jump: float = 1.5, quality: bool = True, thresholds=None, **overrides) -> SpliceResult:
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

    ``quality`` measures the written hand marker as :func:`splice_motions`
    does (no suggestion here); ``SpliceConfig.subsequence`` replaces the
    markers of the matched interval only (eased in and out at its ends).
    """
    from .quality import measure_quality

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
    tm = {"markers": 0.0, "align": 0.0, "merge": 0.0, "phases": 0.0, "quality": 0.0}
    layers, quals = {}, {}
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
        a0 = al.offset
        hbi = hb[a0:a0 + al.n] if al.interval is not None else hb  # the body rows the alignment covers
        if lay == "arm":
            rel = median_frames(hh.relative, al.path, al.n, al.hand_frame)  # (n, 4, 3)
            both = al.body_features.heading is not None and al.hand_features.heading is not None
            span = max(1, int(round(cfg.refine_theta_span * body.fps)) | 1)
            theta = matched_theta(al.body_features, al.hand_features, al.hand_frame, "trunk" if both else "window", span)
            merged = hbi.shoulder[:, None, :] + rotate_vertical(rel, theta)
            labels = hb.labels
        else:
            ch, Rh = forearm_frame(hh.positions, hand.source)
            local = np.einsum("tji,tj->ti", Rh, hh.positions[:, 3] - ch)  # hand marker in the hand recording's forearm frame
            local = median_frames(local, al.path, al.n, al.hand_frame)
            cb, Rb = forearm_frame(hbi.positions, body.source)
            merged = (cb + np.einsum("tij,tj->ti", Rb, local))[:, None, :]
            labels = hb.labels[3:]
        win = max(3, int(round(blend_window * body.fps)) | 1)
        merged, rep = blend_discontinuities(merged, al.hand_frame, window=win, jump=jump)
        idx = [body.names.index(lab) for lab in labels]
        if al.interval is not None:  # ease in from and out to the body's own markers at the interval's ends
            own = P[a0:a0 + al.n][:, idx]
            k = al.n
            u = np.clip(np.minimum(np.arange(k) + 1, k - np.arange(k)) / float(max(1, win // 2) + 1), 0.0, 1.0)
            u = (u ** 3 * (10 - 15 * u + 6 * u ** 2))[:, None, None]
            merged = (1 - u) * own + u * merged
            rep = replace(rep, frames=tuple(f + a0 for f in rep.frames))
        blk = P[a0:a0 + al.n]
        blk[:, idx] = merged
        P[a0:a0 + al.n] = blk
        td = time.perf_counter()
        bph[s] = motion_phases(hb, smooth=cfg.smooth)
        hph[s] = motion_phases(hh, smooth=cfg.smooth)
        te = time.perf_counter()
        if quality:
            hand_out = merged[:, -1]  # the hand marker (FIN) as written
            rel_out = hand_out - hbi.shoulder if hbi.shoulder is not None else hand_out
            quals[s] = measure_quality(al, rel_out, side=s, offset=a0, thresholds=thresholds)
        tm["quality"] += time.perf_counter() - te
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
    return SpliceResult(None, out, alignments, bph, hph, names, blends, pts, None, tm, quals)
