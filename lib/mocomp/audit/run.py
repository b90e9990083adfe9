"""``audit(motion, body=None, ...)``: every measure of :mod:`mocomp.audit`, one report."""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..body.model import BodyModel
from ..dynamics.com import check_compatible, segment_positions
from ..dynamics.contacts import detect_contacts
from ..errors import MotionFormatError
from .com import com_audit
from .contacts import body_points, body_support, contact_audits, floor_level, lowest_points, penetration, phases_of
from .flights import flight_audits
from .force import FORCE_CHECKS, dilate, forced_mask, ranges_text
from .kinematics import inert_joints, kinematics_audit
from .posejump import pose_jump_audit
from .report import AuditReport
from .thresholds import AuditThresholds
from .zmp import zmp_audit

__all__ = ["audit", "default_body", "same_skeleton", "MIN_FRAMES"]

#: the shortest motion the audit measures (two one-sided quadratic fits of 3 frames share one frame)
MIN_FRAMES = 5


def _character(motion) -> str | None:
    if getattr(motion.source, "format", None) == "deepmimic":
        for note in motion.source.notes:
            if note.startswith("character "):
                return note[len("character "):]
    return None


def default_body(motion, like=None) -> BodyModel:
    """The body model the audit uses when none is given: a DeepMimic clip's own character
    (its bodies' masses, from the character file the loader recorded), else de Leva's (1996)
    male table on the skeleton at 70 kg with constant-density ellipsoids. ``like``: the motion
    ``motion`` was made from; when both have the same skeleton (:func:`same_skeleton`, e.g. a
    command's BVH output of a DeepMimic clip, which no longer names the character) ``like``'s
    character is used, matched into ``motion``'s skeleton by joint name. Without either, a
    skeleton that is exactly a known DeepMimic character's (its joints by name and parent in any
    order, bone offsets within 0.1 mm: :func:`mocomp.io.deepmimic.match_character`; e.g. a BVH the
    project wrote from a DeepMimic clip, read back alone) gets that character's bodies, the reason
    being the model's first note (and part of the audit's body line)."""
    char = _character(motion)
    if char is None and like is not None and same_skeleton(motion.skeleton, like.skeleton):
        char = _character(like)
    if char is not None:
        from ..io.deepmimic import read_deepmimic_body

        return read_deepmimic_body(char, motion.skeleton)
    # a file that names no character (e.g. a BVH the project wrote from a DeepMimic clip, read back):
    # the character whose skeleton it is exactly (joints by name and parent, bone offsets within
    # 0.1 mm; mocomp.io.deepmimic.match_character), its masses mapped by joint name
    from ..io.deepmimic import recognized_body

    body = recognized_body(motion.skeleton)
    if body is not None:
        return body
    return BodyModel.from_skeleton(motion.skeleton, total_mass=70.0)


def same_skeleton(a, b, tol: float = 1e-4) -> bool:
    """``True`` when skeletons ``a`` and ``b`` have the same joints (names, each joint's parent by
    name; the order may differ, as a BVH writer's depth-first order does) and the same bone offsets
    within ``tol`` m (a written BVH file keeps them to its printed precision)."""
    na, nb = tuple(a.names), tuple(b.names)
    if len(na) != len(nb) or set(na) != set(nb):
        return False
    idx = np.array([nb.index(n) for n in na])
    pa = [None if p < 0 else na[p] for p in np.asarray(a.parents)]
    pb = [None if p < 0 else nb[p] for p in np.asarray(b.parents)[idx]]
    if pa != pb:
        return False
    return bool(np.allclose(np.asarray(a.offsets), np.asarray(b.offsets)[idx], rtol=0.0, atol=tol))


def _body_text(body) -> str:
    table = str(getattr(body, "table", "") or "").split(" (")[0]
    why = next((n for n in getattr(body, "notes", ()) if n.startswith("skeleton recognised as")), None)
    return f"{body.n_segments} segments, {table or 'given masses'}" + (f"; {why}" if why else "")


def audit(motion, body=None, *, thresholds: AuditThresholds = AuditThresholds(), against=None,
          name: str | None = None, against_name: str | None = None, against_body=None,
          external_force_frames=None, against_external_force_frames=None,
          against_frame_map=None) -> AuditReport:
    """Measure the physical validity of ``motion`` from its frames alone.

    Parameters
    ----------
    motion: a :class:`~mocomp.core.Motion` (at least :data:`MIN_FRAMES` frames).
    body: its :class:`~mocomp.body.BodyModel` (default :func:`default_body`).
    thresholds: :class:`~mocomp.audit.AuditThresholds` (documented defaults).
    against: optionally the motion this one was made from; it is audited with the same
        thresholds (and ``against_body``, default :func:`default_body` of it) and the report's
        ``comparison`` lists each measure of both side by side. When ``body`` is not given and
        ``motion`` has ``against``'s skeleton (:func:`same_skeleton`: a command's output), it is
        measured with ``against``'s body (``default_body(motion, like=against)``: a DeepMimic
        clip's own character, which its BVH output no longer names).
    name, against_name: labels for the reports.
    external_force_frames: frames of ``motion`` under an external force (a hit, a push): a ``slice``,
        a ``(T,)`` bool mask, frame indices, ``(start, stop)`` pairs or ``"A:B"`` strings
        (:func:`mocomp.audit.force.forced_mask`). Airborne runs with such frames are ``"forced"``
        flights, judged (ballistic fit, L) only on their longest free part; findings of the
        force-dependent checks (:data:`mocomp.audit.force.FORCE_CHECKS`) touching those frames get
        severity ``"expected"`` (reported in ``report.expected``, not violations). The mask is
        ``report.external_force``.
    against_external_force_frames: the same for the ``against`` motion.
    against_frame_map: ``(T,)`` fractional frame of ``against`` for each frame of ``motion``, for the
        pose-jump check (:mod:`mocomp.audit.posejump`; default: matched by time, normalised by the
        durations when they differ). With ``against`` on joints of the same names, the report's
        ``pose_jumps`` compares every joint's rotation rate with the input's own around the
        corresponding frames; joints turning more than ``pose_jump_excess`` faster are ``pose_jump``
        findings, and ``measures()`` gains ``max_joint_speed_excess``.

    Measures (see each module): phases and contacts, floor penetration and foot slide
    (:mod:`~mocomp.audit.contacts`), COM velocity / linear momentum jumps
    (:mod:`~mocomp.audit.com`), per flight the ballistic fit, L spread and take-off angle
    (:mod:`~mocomp.audit.flights`), ZMP outside the support polygon (:mod:`~mocomp.audit.zmp`),
    bone lengths, joint rates and frame-to-frame jumps (:mod:`~mocomp.audit.kinematics`).
    Nothing of the method that made the motion is used.
    """
    t0 = time.perf_counter()
    if not isinstance(thresholds, AuditThresholds):
        raise TypeError(f"thresholds must be an AuditThresholds, got {type(thresholds).__name__}")
    label = name or (motion.source.path if getattr(motion, "source", None) and motion.source.path else "motion")
    if motion.n_frames < MIN_FRAMES:
        raise MotionFormatError(f"{label}: the audit needs at least {MIN_FRAMES} frames, got {motion.n_frames}")
    body = default_body(motion, like=against) if body is None else body
    check_compatible(body, motion)
    if not body.total_mass > 0:
        raise MotionFormatError(f"{label}: the body model has no mass")
    forced = forced_mask(external_force_frames, motion.n_frames, str(label))
    contacts = detect_contacts(motion)
    pts = body_points(motion)
    low, low_i, names = lowest_points(motion, pts)
    floor_y, floor_src = floor_level(low, contacts, phases_of(contacts, motion.n_frames), thresholds.floor_y)
    seg_rot = np.asarray(motion.global_rotations[:, body.segment_joint])
    seg_pos = segment_positions(body, motion)
    com = np.einsum("s,tsk->tk", body.masses, seg_pos) / body.total_mass
    support = body_support(pts[0], motion.fps, low, low_i, floor_y, thresholds.support_clearance, contacts.speed_tol)
    phases = phases_of(contacts, motion.n_frames, com[:, 1] - floor_y, thresholds.flight_com_height, support)
    findings = []
    pen, f = penetration(low, low_i, names, floor_y, floor_src, thresholds)
    findings += f
    cons, f = contact_audits(contacts, pen.depth, thresholds)
    findings += f
    ca, f = com_audit(com, motion.fps, body.total_mass, phases, thresholds, forced)
    findings += f
    fl, f = flight_audits(body, motion, com, phases, thresholds, seg_pos, seg_rot, forced)
    findings += f
    za, f = zmp_audit(body, motion, contacts, floor_y, phases, thresholds)
    findings += f
    ka, f = kinematics_audit(motion, thresholds, body)
    findings += f
    other = pj = None
    if against is not None:
        other = audit(against, against_body, thresholds=thresholds, name=against_name or "original",
                      external_force_frames=against_external_force_frames)
        pj, f = pose_jump_audit(motion, against, thresholds, ka.rates, other.kinematics.rates, against_frame_map,
                                inert_joints(body), str(label))
        findings += f
    elif against_frame_map is not None:
        raise ValueError("against_frame_map needs against=")
    if forced is not None:
        findings = _expected_under_force(findings, forced, ca.window)
    findings.sort(key=lambda x: (x.frames[0], x.check))
    rep = AuditReport(str(label), motion.n_frames, float(motion.fps), float(body.total_mass), _body_text(body),
                      thresholds, phases, tuple(contacts.notes), pen, cons, ca, fl, za, ka, tuple(findings),
                      times=motion.times, external_force=forced, pose_jumps=pj)
    if other is not None:
        rep = dataclasses.replace(rep, comparison=rep.compare(other), against=other)
    return dataclasses.replace(rep, seconds=time.perf_counter() - t0)


def _expected_under_force(findings, forced: np.ndarray, window: int) -> list:
    """Findings of :data:`~mocomp.audit.force.FORCE_CHECKS` touching a forced frame (a COM jump: within
    its fit ``window``) become severity ``"expected"``; the others are kept as they are."""
    near = {0: forced, window: dilate(forced, window)}
    out = []
    for f in findings:
        if f.check in FORCE_CHECKS:
            m = near[window if f.check == "com_velocity_jump" else 0]
            a, b = f.frames
            if m[a:max(b, a + 1)].any():
                f = dataclasses.replace(f, severity="expected", message=f.message + " -- expected under the declared "
                                        f"external force (frames {ranges_text(forced)}), not judged")
        out.append(f)
    return out
