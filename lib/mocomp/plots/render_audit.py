"""A motion drawn with its audit (issue #13 section 4): videos, GIFs and phase filmstrips.

``render_with_audit(motion, "out.mp4" | "out.gif" | "strip.png", against=other)`` draws a motion
(and, side by side, another: an edit and its input) with the offscreen renderer of
:mod:`mocomp.plots.render3d` and what :func:`mocomp.audit.audit` measured on its frames:

* **the audit's floor on the ground**: each motion is drawn shifted vertically so that the floor
  the audit measured (``report.penetration.floor_y``) lies one toe-capsule radius above the
  ground plane, where a resting foot's joints are drawn; the ground is translucent, so a body
  part below the floor shows through it;
* **penetrating body parts red**: a bone whose joint or end point lies more than the audit's
  ``penetration`` threshold below the floor (the audit's own measure, per bone) is drawn red, and
  the deepest point gets a red depth mark from the floor down to it with its depth in cm;
* **planted contacts marked**: a green disc on the floor under each effector the contact detector
  (:func:`mocomp.dynamics.detect_contacts`, the audit's detector) labels planted;
* **the COM path** (dark line, the audit's COM with its body model) with the current COM, a red
  ring where the audit found a COM velocity jump, and **each flight's ballistic fit** (blue: the
  audit's least-squares parabola in height, lines in x and z, over the flight's frames): where
  the motion leaves the fit, the two curves part;
* **a time bar** under each panel: ground stages (grey) and flights (blue), the audit's
  violations (red), advisories (orange) and findings expected under a declared external force
  (violet: severity ``"expected"``, :mod:`mocomp.audit.force`; neither judged nor advised) over the
  frames they cover, the current frame, and the findings active at that frame in words above the scene.

Filmstrips (``.png``) pick poses by phase, not by uniform time (:func:`phase_poses`): per flight
its take-off, apex and landing frames (the audit's phases) with poses in between at most
``max_gap_s`` apart (so a flight is never one pose), per ground stage its deepest crouch, and the
first and last frames; each tile is captioned with its phase, frame and time, and the row's time
bar marks where the poses were taken.

Cameras (:data:`CAMERAS`): ``side`` looks along the flights' mean angular momentum (the
somersault axis; the study's convention) or, without a judged flight, across the root's travel;
``front`` looks at the motion from the direction it travels to; ``top`` looks down; ``follow``
is the side view moving with the root (smoothed). Side by side, both motions share one camera
fitted to both, so sizes and positions compare directly.

Speed: one render per output frame for all panels (one VTK window with one viewport per motion),
the 2-D marks drawn on the read-back pixels with Pillow; ``benchmarks/bench_render.py`` measures it
against the goal of 30 frames/s at 640x480.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.motion import Motion
from .render3d import (RADIUS_FRACTION, Camera, OffscreenScene, RenderStyle, _open_writer, _shadow_matrix, add_characters,
                       add_ground, add_lights, apply_camera, bone_capsules, configure_offscreen, fit_camera,
                       joint_matrices, place_bones, rotate_about_y, save_png, ENCODER)

__all__ = ["OUTPUT_KINDS", "CAMERAS", "OverlayStyle", "AuditTrack", "audit_track", "Pose", "phase_poses",
           "parse_frames", "resolve_frames", "output_kind", "view_directions", "make_cameras",
           "AuditRenderer", "AuditRenderResult", "render_with_audit", "project_points"]

#: what each output extension writes
OUTPUT_KINDS = {".mp4": "video", ".gif": "gif", ".png": "filmstrip"}
#: camera choices (module docstring)
CAMERAS = ("side", "front", "top", "follow")
#: the highest playback rate of an MP4 (frames are taken every k-th frame of the motion: never interpolated)
VIDEO_MAX_FPS = 60.0
#: the highest playback rate of a GIF (its frame delays are whole centiseconds; browsers slow faster GIFs)
GIF_MAX_FPS = 25.0
_UP = np.array([0.0, 1.0, 0.0])


def output_kind(path) -> str:
    """``"video"``, ``"gif"`` or ``"filmstrip"`` from the file extension; a ``ValueError`` naming an
    unknown one."""
    suffix = Path(path).suffix.lower()
    if suffix not in OUTPUT_KINDS:
        raise ValueError(f"output {path}: unknown output type {suffix or '(no extension)'!r}; use .mp4 (video), "
                         ".gif (animated GIF) or .png (phase filmstrip)")
    return OUTPUT_KINDS[suffix]


def parse_frames(text: str) -> tuple[int | None, int | None]:
    """``"A:B"`` (half-open, like a Python slice; ``"A:"`` and ``":B"`` leave an end open) as
    ``(A, B)``; a ``ValueError`` for anything else (negative numbers included)."""
    a, sep, b = str(text).partition(":")
    if not sep or ":" in b:
        raise ValueError(f"frames {text!r} must be A:B (first frame, stop frame; either may be left out)")
    out = []
    for part in (a, b):
        part = part.strip()
        if part == "":
            out.append(None)
            continue
        if not part.isdigit():
            raise ValueError(f"frames {text!r}: {part!r} is not a frame number (a whole number >= 0)")
        out.append(int(part))
    return out[0], out[1]


def resolve_frames(frames, n_frames: int, name: str = "the motion") -> tuple[int, int]:
    """The half-open range ``frames`` (``None``, ``(A, B)`` with ``None`` ends, or ``"A:B"``) checked
    against ``n_frames``: ``0 <= A``, ``A + 2 <= B <= n_frames`` (at least two frames)."""
    if frames is None:
        return 0, n_frames
    if isinstance(frames, str):
        frames = parse_frames(frames)
    a, b = frames
    a = 0 if a is None else int(a)
    b = n_frames if b is None else int(b)
    txt = f"{'' if frames[0] is None else a}:{'' if frames[1] is None else b}"
    if a < 0 or b < 0:
        raise ValueError(f"frames {txt}: frame numbers must be >= 0")
    if b > n_frames:
        raise ValueError(f"frames {txt}: {name} has {n_frames} frames (0-{n_frames - 1}), so the stop frame can "
                         f"be at most {n_frames}")
    if b - a < 2:
        raise ValueError(f"frames {txt}: the range must hold at least 2 frames (A < B - 1; {name} has "
                         f"{n_frames} frames)")
    return a, b


# -------------------------------------------------------------------- style
@dataclass(frozen=True)
class OverlayStyle:
    """The look of the audit's marks (colours RGB in [0, 1]; sizes in pixels unless stated).

    ground_opacity: of the ground plane (below 1: body parts below the floor show through).
    penetration_color: bones below the floor by more than the audit's threshold, the depth mark.
    contact_color: the disc under a planted effector; contact_radius: its radius, m.
    com_color / fit_color: COM path / ballistic fits; line_width: of both.
    flight_color, ground_color: phases in the time bar; advisory_color: advisory findings;
    expected_color: findings expected under a declared external force (severity ``"expected"``),
    with their own legend entry where a report has any.
    bar_height: the time bar strip under each panel; caption_height: the caption under a filmstrip
    tile; header_height: the title strip over a filmstrip row; font_size: text size.
    """

    ground_opacity: float = 0.45
    penetration_color: tuple[float, float, float] = (0.88, 0.04, 0.04)
    contact_color: tuple[float, float, float] = (0.05, 0.62, 0.22)
    contact_radius: float = 0.07
    com_color: tuple[float, float, float] = (0.15, 0.15, 0.15)
    fit_color: tuple[float, float, float] = (0.10, 0.33, 0.95)
    line_width: int = 2
    flight_color: tuple[float, float, float] = (0.55, 0.74, 0.96)
    ground_color: tuple[float, float, float] = (0.78, 0.78, 0.76)
    advisory_color: tuple[float, float, float] = (0.98, 0.62, 0.12)
    expected_color: tuple[float, float, float] = (0.52, 0.36, 0.86)
    bar_height: int = 56
    caption_height: int = 52
    header_height: int = 40
    font_size: int = 13

    def __post_init__(self):
        if not (0.0 < self.ground_opacity <= 1.0):
            raise ValueError(f"OverlayStyle.ground_opacity must be in (0, 1], got {self.ground_opacity}")
        for name in ("bar_height", "caption_height", "header_height"):
            v = getattr(self, name)
            if v < 24 or v % 2:
                raise ValueError(f"OverlayStyle.{name} must be an even number >= 24, got {v}")


def _rgb255(c) -> tuple[int, int, int]:
    return tuple(int(round(255 * float(v))) for v in c)


def finding_color(f, style: "OverlayStyle") -> tuple[float, float, float]:
    """The colour of a finding in the time bar: violations ``penetration_color`` (red), findings
    expected under a declared external force ``expected_color`` (violet), advisories ``advisory_color``."""
    if f.is_violation:
        return style.penetration_color
    return style.expected_color if f.severity == "expected" else style.advisory_color


#: text colours (0-255) of the findings written above the scene, by severity
_TEXT_COLORS = {"advisory": (170, 95, 0), "expected": (95, 55, 170)}


# -------------------------------------------------------------- the data
@dataclass(frozen=True, eq=False)
class AuditTrack:
    """One motion with everything of its audit that is drawn (computed once, vectorised over frames).

    Attributes
    ----------
    name: label of the panel.
    motion: the motion as drawn: the input shifted by ``shift`` in y (the audit's floor at
        ``floor_drawn``, one toe-capsule radius above the ground plane).
    report: its :class:`~mocomp.audit.AuditReport` (frames and sizes of the unshifted motion).
    shift: m added to y; floor_drawn: m, where the audit's floor is drawn.
    bone_joint: ``(B,)`` joint of each drawn bone (:func:`~mocomp.plots.render3d.bone_capsules`).
    bone_depth: ``(T, B)`` m, depth of each bone's lower end below the audit's floor (0 above it).
    penetrating: ``(T, B)`` bool, ``bone_depth > report.thresholds.penetration``.
    planted: ``(T, E)`` bool, effector planted (the contact detector's labels);
    contact_points: ``(T, E, 3)`` m, effector positions (drawn frame).
    com: ``(T, 3)`` m, the audit's COM (drawn frame).
    fits: per flight with a ballistic fit, ``(flight index, (a, b), points (n, 3))`` (drawn frame).
    lowest: ``(T, 3)`` m, the lowest body point (drawn frame); depth: ``(T,)`` m below the floor.
    jump_frames: peak frames of the audit's COM velocity jump findings.
    """

    name: str
    motion: Motion
    report: object
    shift: float
    floor_drawn: float
    bone_joint: np.ndarray
    bone_depth: np.ndarray
    penetrating: np.ndarray
    planted: np.ndarray
    contact_points: np.ndarray
    com: np.ndarray
    fits: tuple
    lowest: np.ndarray
    depth: np.ndarray
    jump_frames: tuple[int, ...]

    @property
    def n_frames(self) -> int:
        return self.motion.n_frames

    def findings_at(self, frame: int, slack: int = 1) -> list:
        """Findings whose frames contain ``frame`` (one-frame events within ``slack`` frames),
        violations first."""
        out = [f for f in self.report.findings
               if f.frames[0] - (slack if f.frames[1] - f.frames[0] <= 2 else 0) <= frame
               < f.frames[1] + (slack if f.frames[1] - f.frames[0] <= 2 else 0)]
        return sorted(out, key=lambda f: (not f.is_violation, f.frames[0]))

    def phase_at(self, frame: int) -> str:
        for k, (a, b) in enumerate(self.report.phases.flights):
            if a <= frame < b:
                return f"flight {k + 1}"
        return "ground"


def audit_track(motion: Motion, report=None, *, name: str | None = None, style: RenderStyle | None = None,
                body=None, thresholds=None) -> AuditTrack:
    """Audit ``motion`` (unless its ``report`` is given) and compute what is drawn of it."""
    from ..audit import AuditThresholds, audit
    from ..audit.contacts import body_points
    from ..dynamics.contacts import detect_contacts

    style = style or RenderStyle()
    if report is None:
        report = audit(motion, body, thresholds=thresholds or AuditThresholds(), name=name)
    if report.n_frames != motion.n_frames:
        raise ValueError(f"the audit report has {report.n_frames} frames but the motion {motion.n_frames}")
    floor = float(report.penetration.floor_y)
    clearance = RADIUS_FRACTION["toe"] * max(motion.skeleton.height(), 0.5) * style.radius_scale
    shift = clearance - floor
    drawn = motion.translated([0.0, shift, 0.0])
    caps = bone_capsules(motion.skeleton, style)
    jb = np.array([c.joint for c in caps])
    ends = np.stack([c.end for c in caps])
    M = joint_matrices(drawn)
    Mb = M[:, jb]
    p0 = Mb[..., :3, 3]
    p1 = np.einsum("tbij,bj->tbi", Mb[..., :3, :3], ends) + p0
    low = np.minimum(p0[..., 1], p1[..., 1]) - shift
    bone_depth = np.maximum(0.0, floor - low)
    pen = bone_depth > report.thresholds.penetration
    contacts = detect_contacts(motion)
    sh = np.array([0.0, shift, 0.0])
    com = np.asarray(report.com.com, float) + sh
    t = motion.times
    fits = []
    for f in report.flights:
        if f.fit is None:
            continue
        a, b = f.frames
        ts = np.linspace(t[a], t[b - 1], max(24, 2 * (b - a)))
        c2, c1, c0 = f.fit.coef
        tau = ts - f.fit.t_mid
        y = c2 * tau ** 2 + c1 * tau + c0
        raw = np.asarray(report.com.com, float)
        x = np.polyval(np.polyfit(t[a:b], raw[a:b, 0], 1), ts)
        z = np.polyval(np.polyfit(t[a:b], raw[a:b, 2], 1), ts)
        fits.append((f.index, (a, b), np.column_stack([x, y, z]) + sh))
    pts, _ = body_points(motion)
    k = np.argmin(pts[..., 1], axis=1)
    lowest = pts[np.arange(pts.shape[0]), k] + sh
    jumps = tuple(int(f.peak_frame) for f in report.findings if f.check == "com_velocity_jump")
    return AuditTrack(str(name or report.name), drawn, report, float(shift), float(clearance), jb, bone_depth, pen,
                      np.asarray(contacts.labels, bool), np.asarray(contacts.positions, float) + sh, com, tuple(fits),
                      lowest, np.asarray(report.penetration.depth, float), jumps)


# ------------------------------------------------------------- phase poses
#: violations whose peak frame becomes a filmstrip pose, with its label
_POSE_CHECKS = {"floor_penetration": "below floor", "com_velocity_jump": "COM jump"}


@dataclass(frozen=True)
class Pose:
    """A filmstrip pose: ``frame`` of the motion and its ``label`` (``"take-off 1"``, ``"apex 1"``,
    ``"landing 1"``, ``"flight 1"`` (between those), ``"stance"``, ``"below floor"``, ``"COM jump"``,
    ``"start"``, ``"end"``)."""

    frame: int
    label: str


def phase_poses(report, frames: tuple[int, int] | None = None, *, max_gap_s: float = 0.15) -> tuple[Pose, ...]:
    """Poses chosen by phase from an audit (:class:`~mocomp.audit.AuditReport`), in frame order.

    Within ``frames`` (half-open; default all): for each flight, its take-off (the audit's first
    airborne frame), apex (the frame of the highest COM) and landing (the first ground frame after
    it; not for the audit's *spurious* airborne runs, too short to be flights, such as the one-frame
    flicker a body moved centimetres in one step reads as), and evenly spaced flight poses between
    take-off and apex and between apex and landing, at most ``max_gap_s`` apart (so a somersault shows its rotation); for each ground stage the
    frame of its lowest COM (the deepest crouch) when it lies at least 3 frames from the stage's
    ends; the peak frame of each floor-penetration and COM-velocity-jump violation (``"below floor"``,
    ``"COM jump"``: where the motion is worst); the first and the last frame. A pose closer than 2
    frames to one of higher priority (flight poses, then crouches and violation peaks, then the
    poses between flight poses, then first and last frame) is dropped.
    """
    n = report.n_frames
    a0, b0 = (0, n) if frames is None else frames
    fps = report.fps
    com_y = np.asarray(report.com.com, float)[:, 1]
    cand: list[tuple[int, str, int]] = []  # (frame, label, priority: lower wins)
    ph = report.phases
    kinds = [getattr(f, "is_flight", True) for f in getattr(report, "flights", ())]
    for k, (fa, fb) in enumerate(ph.flights):
        if k < len(kinds) and not kinds[k]:
            continue   # a spurious airborne run (a contact flicker): no take-off/apex/landing poses
        apex = fa + int(np.argmax(com_y[fa:fb]))
        key = [(fa, f"take-off {k + 1}"), (apex, f"apex {k + 1}")]
        if fb < n:
            key.append((fb, f"landing {k + 1}"))
        else:
            key.append((fb - 1, f"flight {k + 1} end"))
        for f, lab in key:
            cand.append((f, lab, 0))
        for (u, v) in ((fa, apex), (apex, key[-1][0])):
            gap = (v - u) / fps
            m = int(math.ceil(gap / max_gap_s)) - 1 if gap > 0 else 0
            for i in range(1, m + 1):
                cand.append((u + int(round(i * (v - u) / (m + 1))), f"flight {k + 1}", 2))
    for ga, gb in ph.ground:
        lo, hi = max(ga, a0), min(gb, b0)
        if hi - lo < 7:
            continue
        f = lo + int(np.argmin(com_y[lo:hi]))
        if f - lo >= 3 and hi - 1 - f >= 3:
            cand.append((f, "stance", 1))
    worst: dict[int, list[str]] = {}   # where the motion is worst: the deepest frame below the floor, COM jumps
    for f in report.findings:
        if f.is_violation and f.check in _POSE_CHECKS and _POSE_CHECKS[f.check] not in worst.get(f.peak_frame, []):
            worst.setdefault(int(f.peak_frame), []).append(_POSE_CHECKS[f.check])
    cand += [(f, " + ".join(sorted(labels)), 1) for f, labels in worst.items()]
    cand.append((a0, "start", 3))
    cand.append((b0 - 1, "end", 3))
    cand = [c for c in cand if a0 <= c[0] < b0]
    cand.sort(key=lambda c: (c[2], c[0]))
    chosen: list[tuple[int, str, int]] = []
    for c in cand:
        if all(abs(c[0] - d[0]) >= 2 or (c[2] == 0 and d[2] == 0 and c[0] != d[0]) for d in chosen):
            chosen.append(c)
    chosen.sort(key=lambda c: c[0])
    return tuple(Pose(int(f), lab) for f, lab, _ in chosen)


# ------------------------------------------------------------------ cameras
def view_directions(track: AuditTrack) -> tuple[np.ndarray, np.ndarray]:
    """``(side, front)``: unit horizontal viewing directions (camera -> scene) of the ``side`` and
    ``front`` cameras (module docstring)."""
    rep = track.report
    Ls = [np.asarray(f.L_mean, float) * (f.frames[1] - f.frames[0]) for f in rep.flights
          if f.L_judged and f.L_mean is not None]
    root = np.asarray(track.motion.root_positions, float)
    travel = (root[-1] - root[0]) * np.array([1.0, 0.0, 1.0])
    side = None
    if Ls:
        L = np.sum(Ls, axis=0) * np.array([1.0, 0.0, 1.0])
        if np.linalg.norm(L) > 1e-6:
            side = -L / np.linalg.norm(L)          # the study's view: L towards the camera
    if side is None and np.linalg.norm(travel) > 0.3:
        right = travel / np.linalg.norm(travel)
        side = np.cross(_UP, right)                # travel goes left -> right on screen
    if side is None:
        side = np.array([0.0, 0.0, -1.0])
    right = np.cross(side, _UP)
    if np.linalg.norm(travel) > 0.3 and travel @ right < 0:
        front = right.copy()                       # camera ahead of the travel, looking back at it
    else:
        front = -right
    return side, front


@dataclass(frozen=True)
class FollowCamera:
    """A side camera that moves with the root: ``base`` is placed relative to the origin and
    translated by ``offsets[t]`` (``(T, 3)``, the smoothed horizontal root position) per frame."""

    base: Camera
    offsets: np.ndarray

    def at(self, frame: int) -> Camera:
        d = self.offsets[int(np.clip(frame, 0, len(self.offsets) - 1))]
        return Camera(tuple(np.asarray(self.base.position) + d), tuple(np.asarray(self.base.focal_point) + d),
                      self.base.view_up, self.base.view_angle)


def _top_camera(points: np.ndarray, side: np.ndarray, aspect: float, view_angle: float = 30.0,
                margin: float = 0.1) -> Camera:
    right = np.cross(side, _UP)
    u, v = points @ right, points @ side
    cu, cv = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
    hu, hv = 0.5 * (u.max() - u.min()) + 0.2, 0.5 * (v.max() - v.min()) + 0.2
    tn = math.tan(math.radians(view_angle) / 2.0) * (1.0 - margin)
    dist = max(hv / tn, hu / (aspect * tn), 1.0) + float(points[:, 1].max())
    focal = cu * right + cv * side
    pos = focal + dist * _UP
    return Camera(tuple(np.round(pos, 3)), tuple(np.round(focal, 3)), tuple(side), view_angle)


def make_cameras(kind: str, tracks: Sequence[AuditTrack], ranges: Sequence[tuple[int, int]], aspect: float,
                 elevation: float = 8.0) -> list:
    """One camera per track (:class:`Camera`, or :class:`FollowCamera` for ``follow``), all fitted to
    the displayed frames of every track so that side-by-side panels share scale and viewpoint."""
    if kind not in CAMERAS:
        raise ValueError(f"camera must be one of {', '.join(CAMERAS)}, got {kind!r}")
    side, front = view_directions(tracks[0])
    pts = np.concatenate([np.concatenate([t.motion.positions[a:b].reshape(-1, 3), t.com[a:b]])
                          for t, (a, b) in zip(tracks, ranges)])
    if kind == "side":
        cam = fit_camera(pts, direction=side, elevation=elevation, aspect=aspect)
    elif kind == "front":
        cam = fit_camera(pts, direction=front, elevation=elevation, aspect=aspect)
    elif kind == "top":
        cam = _top_camera(pts, side, aspect)
    else:
        from scipy.ndimage import gaussian_filter1d

        rel, offs = [], []
        for t, (a, b) in zip(tracks, ranges):
            root = np.asarray(t.motion.root_positions, float) * np.array([1.0, 0.0, 1.0])
            sigma = max(1.0, 0.25 * t.motion.fps)
            o = np.column_stack([gaussian_filter1d(root[:, 0], sigma, mode="nearest"), np.zeros(len(root)),
                                 gaussian_filter1d(root[:, 2], sigma, mode="nearest")])
            offs.append(o)
            rel.append(t.motion.positions[a:b] - o[a:b, None, :])
        base = fit_camera(np.concatenate([r.reshape(-1, 3) for r in rel]), direction=side, elevation=elevation,
                          aspect=aspect, margin=0.15)
        return [FollowCamera(base, o) for o in offs]
    return [cam for _ in tracks]


def _camera_yaw(cam) -> float:
    """The rotation about the vertical (rad) that turns the study's viewing direction (-z) into the
    horizontal part of ``cam``'s (for a camera looking straight down: into its ``view_up``)."""
    c = cam.base if isinstance(cam, FollowCamera) else cam
    d = np.subtract(c.focal_point, c.position) * np.array([1.0, 0.0, 1.0])
    if np.linalg.norm(d) < 1e-6 * max(1.0, float(np.linalg.norm(np.subtract(c.focal_point, c.position)))):
        d = np.asarray(c.view_up, float) * np.array([1.0, 0.0, 1.0])
    return float(np.arctan2(-d[0], -d[2]))


def _camera_at(cam, frame: int) -> Camera:
    return cam.at(frame) if isinstance(cam, FollowCamera) else cam


def project_points(matrix: np.ndarray, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates ``(n, 2)`` (x right, y down, origin top-left) of world ``points`` ``(n, 3)``
    under the 4x4 world-to-clip ``matrix`` of a camera (VTK's composite projection), and ``(n,)``
    bool: in front of the camera."""
    P = np.asarray(points, float).reshape(-1, 3)
    h = np.column_stack([P, np.ones(len(P))]) @ np.asarray(matrix).T
    w = h[:, 3]
    ok = w > 1e-9
    ws = np.where(ok, w, 1.0)
    x = (h[:, 0] / ws + 1.0) * 0.5 * width
    y = (1.0 - h[:, 1] / ws) * 0.5 * height
    return np.column_stack([x, y]), ok


# ------------------------------------------------------------------ drawing
_FONT_CACHE: dict = {}


def _font(size: int, bold: bool = False):
    from PIL import ImageFont

    key = (size, bold)
    if key not in _FONT_CACHE:
        import matplotlib

        name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
        path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / name
        try:
            _FONT_CACHE[key] = ImageFont.truetype(str(path), size)
        except OSError:  # pragma: no cover - matplotlib always ships DejaVu
            _FONT_CACHE[key] = ImageFont.load_default()
    return _FONT_CACHE[key]


def _fit(draw, text: str, font, width: float) -> str:
    """``text`` cut (with an ellipsis) to at most ``width`` pixels."""
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(text + "…", font=font) > width:
        text = text[:-1]
    return text.rstrip(", ") + "…"


def _finding_text(f) -> str:
    if f.unit == "m":
        size = f"{f.size * 100:.1f} cm (limit {f.threshold * 100:.1f})"
    elif f.unit == "rad":
        size = f"{math.degrees(f.size):.1f} deg (limit {math.degrees(f.threshold):.1f})"
    elif f.unit == "relative":
        size = f"{f.size:.0%} (limit {f.threshold:.0%})"
    else:
        size = f"{f.size:.3g} {f.unit} (limit {f.threshold:.3g})"
    return f"{f.check.replace('_', ' ')} · {f.where}: {size}"


def _verdict_text(rep) -> tuple[str, tuple[int, int, int]]:
    counts: dict[str, int] = {}
    for f in rep.violations:
        counts[f.check] = counts.get(f.check, 0) + 1
    n_exp = len(getattr(rep, "expected", ()))
    exp = f" · {n_exp} expected (external force)" if n_exp else ""
    if not counts:
        return f"audit PASS · {len(rep.advisories)} advisory{exp}", (20, 120, 40)
    return (f"audit FAIL · {len(rep.violations)} violation(s): " + ", ".join(f"{k.replace('_', ' ')} {v}"
                                                                              for k, v in counts.items()) + exp,
            (200, 20, 20))


class _TimeBar:
    """The static part of a time bar (phases, findings) for one track, drawn once; per frame only the
    cursor and the text are added."""

    def __init__(self, track: AuditTrack, width: int, style: OverlayStyle, frames: tuple[int, int]):
        from PIL import Image, ImageDraw

        self.track, self.width, self.style = track, width, style
        h = style.bar_height
        self.x0, self.x1 = 8, width - 8
        self.rows = (h - 34, h - 22, h - 20, h - 6)  # phases row y0, y1; findings row y0, y1
        img = Image.new("RGB", (width, h), (250, 250, 250))
        d = ImageDraw.Draw(img)
        rep = track.report
        y0, y1, z0, z1 = self.rows
        d.rectangle([self.x0, y0, self.x1, y1], fill=_rgb255(style.ground_color))
        for a, b in rep.phases.flights:
            d.rectangle([self.xf(a), y0, max(self.xf(b) - 1, self.xf(a) + 1), y1], fill=_rgb255(style.flight_color))
        d.rectangle([self.x0, z0, self.x1, z1], fill=(236, 236, 236))
        # expected first, then advisories, violations on top
        order = {"expected": 0, "advisory": 1, "violation": 2}
        for f in sorted(rep.findings, key=lambda f: order.get(f.severity, 1)):
            col = _rgb255(finding_color(f, style))
            top = z0 if f.is_violation else (z0 + z1) // 2
            a, b = f.frames
            d.rectangle([self.xf(a), top, max(self.xf(b) - 1, self.xf(a) + 1), z1], fill=col)
        a, b = frames
        if a > 0 or b < track.n_frames:  # dim what is outside the shown range
            arr = np.asarray(img).copy()
            for lo, hi in ((self.x0, self.xf(a)), (self.xf(b), self.x1 + 1)):
                if hi > lo:
                    arr[y0:z1 + 1, lo:hi] = (arr[y0:z1 + 1, lo:hi] * 0.35 + 255 * 0.65).astype(np.uint8)
            img = Image.fromarray(arr)
        d = ImageDraw.Draw(img)
        f = _font(style.font_size - 1)
        x = self.x1
        legend = [("flight", style.flight_color), ("ground", style.ground_color),
                  ("violation", style.penetration_color), ("advisory", style.advisory_color)]
        if any(f.severity == "expected" for f in rep.findings):
            legend.append(("expected", style.expected_color))
        for lab, col in reversed(legend):
            x -= int(d.textlength(lab, font=f))
            d.text((x, 2), lab, fill=(60, 60, 60), font=f)
            x -= 12
            d.rectangle([x, 5, x + 9, 13], fill=_rgb255(col))
            x -= 8
        self.text_right = x
        self.image = np.asarray(img)

    def xf(self, frame: float) -> int:
        n = max(self.track.n_frames, 1)
        return int(round(self.x0 + (self.x1 - self.x0) * frame / n))

    def draw(self, frame: int, ended: bool = False, ticks: Sequence[int] = ()):
        """The bar at ``frame`` as a PIL image (cursor, frame/time text; ``ticks``: pose frames)."""
        from PIL import Image, ImageDraw

        img = Image.fromarray(self.image.copy())
        d = ImageDraw.Draw(img)
        y0, y1, z0, z1 = self.rows
        f = _font(self.style.font_size - 1)
        for i, tk in enumerate(ticks):
            x = self.xf(tk + 0.5)
            d.line([x, y0 - 2, x, z1], fill=(40, 40, 40), width=1)
        if frame is not None:
            x = self.xf(frame + 0.5)
            d.rectangle([x - 1, y0 - 3, x + 1, z1 + 3], fill=(0, 0, 0))
            t = frame / self.track.motion.fps
            txt = (f"frame {frame}/{self.track.n_frames - 1}  t = {t:.3f} s  {self.track.phase_at(frame)}"
                   + ("  (ended)" if ended else ""))
            d.text((self.x0, 2), txt, fill=(30, 30, 30), font=f)
        return img


class AuditRenderer(OffscreenScene):
    """One offscreen VTK window with one viewport (panel) per track, the audit's 3-D marks in each
    (translucent ground, red bones, contact discs) and its 2-D marks drawn on the pixels.

    ``cameras``: one per track (:func:`make_cameras`). ``frame(frames)`` renders the tracks at the
    given frame indices (one per track) and returns the ``(H + bar, W * n, 3)`` uint8 image, or, with
    ``bar=False``, the scene only.
    """

    def __init__(self, tracks: Sequence[AuditTrack], style: RenderStyle | None = None,
                 overlay: OverlayStyle | None = None, cameras: Sequence | None = None,
                 ranges: Sequence[tuple[int, int]] | None = None):
        self.tracks = list(tracks)
        if not self.tracks:
            raise ValueError("AuditRenderer needs at least one track")
        self.style = style = style or RenderStyle()
        self.overlay = ov = overlay or OverlayStyle()
        configure_offscreen(style.backend)
        import pyvista as pv
        import vtk

        n = len(self.tracks)
        self.ranges = list(ranges) if ranges is not None else [(0, t.n_frames) for t in self.tracks]
        self.cameras = list(cameras) if cameras is not None else make_cameras(
            "side", self.tracks, self.ranges, style.width / style.height)
        pl = pv.Plotter(off_screen=True, shape=(1, n), border=False, window_size=(style.width * n, style.height),
                        lighting="none")
        self._pl = pl
        pl.ren_win.SetMultiSamples(int(style.multi_samples))
        pl.set_background(style.background)
        # the lights (and the shadows' projection) turn with the camera: every view sees the lit side
        self.yaw = _camera_yaw(self.cameras[0])
        self._S = _shadow_matrix(rotate_about_y(style.light_direction, self.yaw))
        self._panels = []
        disc = pv.Cylinder(center=(0, 0, 0), direction=(0, 1, 0), radius=ov.contact_radius, height=0.004,
                           resolution=24).triangulate()
        for k, tr in enumerate(self.tracks):
            pl.subplot(0, k)
            add_lights(pl, style, only_active=True, yaw=self.yaw)
            ground = add_ground(pl, style)
            ground.GetProperty().SetOpacity(ov.ground_opacity)
            # one translucent object (the ground): plain alpha blending is exact; VTK's default
            # order-independent translucency costs 3-4x the frame time on llvmpipe
            pl.renderer.SetUseOIT(False)
            caps = bone_capsules(tr.motion.skeleton, style)
            mats, smats, acts = add_characters(pl, style, caps, [style.body_color])
            bones = acts[0][::2] if style.shadow else acts[0]
            discs = []
            for _ in range(tr.planted.shape[1]):
                a = pl.add_mesh(disc, color=ov.contact_color, lighting=False, reset_camera=False)
                m = vtk.vtkMatrix4x4()
                a.SetUserMatrix(m)
                a.SetVisibility(False)
                discs.append((a, m))
            self._panels.append({"renderer": pl.renderer, "mats": mats[0], "smats": smats[0], "bones": bones,
                                 "red": np.zeros(len(bones), bool), "discs": discs,
                                 "M": joint_matrices(tr.motion), "camera": None})
        self._bars = [_TimeBar(t, style.width, ov, r) for t, r in zip(self.tracks, self.ranges)]
        self._paths = [self._static_paths(t, r) for t, r in zip(self.tracks, self.ranges)]
        self._layers: dict = {}
        self.render_seconds = 0.0

    # ----------------------------------------------------------- scene state
    @staticmethod
    def _static_paths(track: AuditTrack, rng: tuple[int, int]):
        a, b = rng
        return track.com[a:b], [(i, (fa, fb), p) for i, (fa, fb), p in track.fits if fb > a and fa < b]

    def _pose(self, k: int, frame: int) -> None:
        tr, p, ov = self.tracks[k], self._panels[k], self.overlay
        place_bones(p["mats"], p["smats"], self._S, p["M"][frame][tr.bone_joint])
        red = tr.penetrating[frame]
        for i in np.flatnonzero(red != p["red"]):
            col = ov.penetration_color if red[i] else self.style.body_color
            p["bones"][i].GetProperty().SetColor(*col)
        p["red"] = red.copy()
        for e, (actor, m) in enumerate(p["discs"]):
            on = bool(tr.planted[frame, e])
            actor.SetVisibility(on)
            if on:
                x, _, z = tr.contact_points[frame, e]
                m.DeepCopy((1, 0, 0, x, 0, 1, 0, 0.006, 0, 0, 1, z, 0, 0, 0, 1))
        cam = _camera_at(self.cameras[k], frame)
        if cam is not p["camera"]:
            apply_camera(p["renderer"].camera, cam)
            p["camera"] = cam
            aspect = self.style.width / self.style.height
            mat = p["renderer"].GetActiveCamera().GetCompositeProjectionTransformMatrix(aspect, -1, 1)
            p["proj"] = np.array([[mat.GetElement(i, j) for j in range(4)] for i in range(4)])

    def projection(self, k: int) -> np.ndarray:
        """The 4x4 world-to-clip matrix of panel ``k``'s current camera."""
        return self._panels[k]["proj"]

    # --------------------------------------------------------------- drawing
    def _px(self, k: int, P: np.ndarray, offset: int = 0) -> tuple[np.ndarray, np.ndarray]:
        xy, ok = project_points(self.projection(k), P, self.style.width, self.style.height)
        xy[:, 0] += offset
        return xy, ok

    def _draw_static(self, draw, k: int, title: bool, offset: int) -> None:
        """What does not change from frame to frame under a fixed camera: COM path, ballistic fits,
        the rings at COM jumps, the panel's name and verdict."""
        tr, ov = self.tracks[k], self.overlay
        lw = ov.line_width
        path, fits = self._paths[k]
        xy, ok = self._px(k, path, offset)
        if ok.all() and len(xy) > 1:
            draw.line([tuple(p) for p in xy], fill=_rgb255(ov.com_color), width=lw)
        for _, _, pts in fits:
            fxy, fok = self._px(k, pts, offset)
            if fok.all():
                draw.line([tuple(p) for p in fxy], fill=_rgb255(ov.fit_color), width=lw)
        red = _rgb255(ov.penetration_color)
        a, b = self.ranges[k]
        jumps = [jf for jf in tr.jump_frames if a <= jf < b]
        if jumps:
            for x, y in self._px(k, tr.com[jumps], offset)[0]:
                draw.ellipse([x - 7, y - 7, x + 7, y + 7], outline=red, width=2)
        if title:
            f, fb = _font(ov.font_size), _font(ov.font_size, True)
            draw.text((offset + 8, 4), tr.name, fill=(20, 20, 20), font=fb, stroke_width=2,
                      stroke_fill=(255, 255, 255))
            txt, col = _verdict_text(tr.report)
            draw.text((offset + 8, 8 + ov.font_size), txt, fill=col, font=f, stroke_width=2,
                      stroke_fill=(255, 255, 255))

    def _static_layer(self, k: int, title: bool):
        """The static marks of panel ``k``: a transparent RGBA image cropped to what is drawn and its
        top-left corner in the panel, drawn once per camera."""
        from PIL import Image, ImageDraw

        key = (k, title, id(self._panels[k]["camera"]))
        if key not in self._layers:
            layer = Image.new("RGBA", (self.style.width, self.style.height), (0, 0, 0, 0))
            self._draw_static(ImageDraw.Draw(layer), k, title, 0)
            box = layer.getbbox() or (0, 0, 1, 1)       # paste only the drawn part (4x faster)
            self._layers = {kk: v for kk, v in self._layers.items() if kk[0] != k or kk[1] != title}
            self._layers[key] = (layer.crop(box), box[:2])
        return self._layers[key]

    def _draw_dynamic(self, draw, k: int, frame: int, title: bool, findings: bool) -> None:
        """The marks of one frame: the current COM, the depth mark of a body part below the floor
        and the findings active at the frame in words."""
        tr, ov = self.tracks[k], self.overlay
        ox = k * self.style.width
        red = _rgb255(ov.penetration_color)
        (x, y), = self._px(k, tr.com[frame][None], ox)[0]
        draw.ellipse([x - 4, y - 4, x + 4, y + 4], fill=_rgb255(ov.com_color), outline=(255, 255, 255))
        if tr.depth[frame] > tr.report.thresholds.penetration:
            p = tr.lowest[frame]
            top = np.array([p[0], tr.floor_drawn, p[2]])
            (x0, y0), (x1, y1) = self._px(k, np.stack([top, p]), ox)[0]
            y1 = max(y1, y0 + 6)
            draw.line([(x0, y0), (x1, y1)], fill=red, width=3)
            draw.line([(x0 - 7, y0), (x0 + 7, y0)], fill=red, width=3)
            draw.text((x1 + 6, y1 - 2), f"-{tr.depth[frame] * 100:.1f} cm", fill=red,
                      font=_font(ov.font_size + 1, True), stroke_width=2, stroke_fill=(255, 255, 255))
        if findings:
            f = _font(ov.font_size)
            y = 4 + (2 * (ov.font_size + 4) if title else 0)
            for fd in tr.findings_at(frame)[:4]:
                col = red if fd.is_violation else _TEXT_COLORS.get(fd.severity, _TEXT_COLORS["advisory"])
                draw.text((ox + 8, y), _finding_text(fd), fill=col, font=f, stroke_width=2,
                          stroke_fill=(255, 255, 255))
                y += ov.font_size + 3

    def scene(self, frames: Sequence[int]) -> np.ndarray:
        """Render every panel at its frame (``frames[k]`` for track ``k``) and read the pixels back:
        ``(H, W * n, 3)`` uint8, the 3-D scene only."""
        for k, fr in enumerate(frames):
            self._pose(k, int(fr))
        t0 = time.perf_counter()
        img = self.read_pixels(self.style.width * len(self.tracks), self.style.height)
        self.render_seconds += time.perf_counter() - t0
        return img

    def frame(self, frames: Sequence[int], *, ended: Sequence[bool] | None = None, bar: bool = True,
              title: bool = True, findings: bool = True,
              ticks: Sequence[Sequence[int]] | None = None) -> np.ndarray:
        """The annotated image of every panel at ``frames``: the scene with the audit's marks, the
        panel's name and verdict (``title``), the findings active at the frame in words
        (``findings``) and the time bar under it (``bar``)."""
        from PIL import Image, ImageDraw

        img = Image.fromarray(self.scene(frames))
        d = ImageDraw.Draw(img)
        for k, fr in enumerate(frames):
            if isinstance(self.cameras[k], FollowCamera):        # the marks move with the camera
                self._draw_static(d, k, title, k * self.style.width)
            else:
                layer, (x0, y0) = self._static_layer(k, title)
                img.paste(layer, (k * self.style.width + x0, y0), layer)
            self._draw_dynamic(d, k, int(fr), title, findings)
        out = np.asarray(img)
        if bar:
            bars = [np.asarray(self._bars[k].draw(int(fr), bool(ended[k]) if ended is not None else False,
                                                  ticks[k] if ticks is not None else ()))
                    for k, fr in enumerate(frames)]
            out = np.concatenate([out, np.concatenate(bars, axis=1)], axis=0)
        return out


# ------------------------------------------------------------------ outputs
@dataclass(frozen=True)
class AuditRenderResult:
    """What :func:`render_with_audit` wrote.

    path: the file; kind: ``"video"``, ``"gif"`` or ``"filmstrip"``; size: ``(width, height)``
    of the image or video; n_frames: frames written (videos) or poses shown (filmstrips); fps:
    playback rate (``None`` for a filmstrip); stride: every ``stride``-th motion frame is shown;
    frames: the half-open range shown per track; poses: the filmstrip's :class:`Pose` per track;
    camera: the camera choice; reports: the audit reports drawn; seconds: wall time;
    render_seconds: VTK render + read-back time; frames_per_second: images per wall second.
    """

    path: Path
    kind: str
    size: tuple[int, int]
    n_frames: int
    fps: float | None
    stride: int
    frames: tuple[tuple[int, int], ...]
    poses: tuple[tuple[Pose, ...], ...]
    camera: str
    reports: tuple
    seconds: float
    render_seconds: float
    frames_per_second: float

    def summary(self) -> str:
        what = (f"{self.n_frames} frames at {self.fps:g} fps" if self.kind != "filmstrip" else
                "poses " + " | ".join(", ".join(f"{p.label} (f {p.frame})" for p in ps) for ps in self.poses))
        return (f"wrote {self.path} ({self.kind}, {self.size[0]}x{self.size[1]}, {what}, camera {self.camera}; "
                f"{self.seconds:.1f} s)")


def _stride(fps: float, max_fps: float) -> int:
    return max(1, int(math.ceil(fps / max_fps - 1e-9)))


def _timeline(tracks: Sequence[AuditTrack], ranges, stride: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Per output frame, the frame of each track (the first track's frames every ``stride``; the
    others at the same time from their start, held at their last frame), which tracks have ended,
    and the playback rate."""
    t0 = tracks[0]
    a, b = ranges[0]
    idx0 = np.arange(a, b, stride)
    t = idx0 / t0.motion.fps
    cols, ended = [idx0], [np.zeros(len(idx0), bool)]
    for tr, (ra, rb) in zip(tracks[1:], ranges[1:]):
        fi = np.rint(t * tr.motion.fps).astype(int)
        ended.append(fi >= rb)
        cols.append(np.clip(fi, ra, rb - 1))
    return np.stack(cols, 1), np.stack(ended, 1), t0.motion.fps / stride


def _write_video(r: AuditRenderer, path: Path, frames: np.ndarray, ended: np.ndarray, fps: float,
                 progress: bool) -> tuple[int, tuple[int, int]]:
    it = range(len(frames))
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="render", unit="frame", leave=False)
    tmp = path.with_name(path.stem + ".partial" + path.suffix)
    gen = None
    size = None
    try:
        for i in it:
            img = r.frame(frames[i], ended=ended[i])
            if gen is None:
                size = (img.shape[1], img.shape[0])
                gen = _open_writer(tmp, size[0], size[1], fps, dict(ENCODER))
            gen.send(np.ascontiguousarray(img))
        gen.close()
        gen = None
        tmp.replace(path)
    finally:
        if gen is not None:
            gen.close()
        if tmp.exists():
            tmp.unlink()
    return len(frames), size


def _write_gif(r: AuditRenderer, path: Path, frames: np.ndarray, ended: np.ndarray, fps: float,
               progress: bool) -> tuple[int, tuple[int, int]]:
    from PIL import Image

    it = range(len(frames))
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="render", unit="frame", leave=False)

    def images():
        for i in it:
            yield Image.fromarray(r.frame(frames[i], ended=ended[i])).quantize(
                colors=255, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)

    gen = images()
    first = next(gen)
    tmp = path.with_name(path.stem + ".partial" + path.suffix)
    try:
        first.save(tmp, format="GIF", save_all=True, append_images=gen, duration=int(round(1000.0 / fps)), loop=0,
                   optimize=False, disposal=1)
        tmp.replace(path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return len(frames), first.size


def _filmstrip(tracks, ranges, style: RenderStyle, overlay: OverlayStyle, camera: str, max_gap_s: float):
    """Rows of phase-chosen tiles, one row per track, each with a title strip and a time bar."""
    from PIL import Image, ImageDraw

    tile = replace(style, width=max(16, (style.width * 3 // 8) // 2 * 2),
                   height=max(16, (style.height * 2 // 3) // 2 * 2))
    cams = make_cameras(camera, tracks, ranges, tile.width / tile.height)
    poses = [phase_poses(t.report, r, max_gap_s=max_gap_s) for t, r in zip(tracks, ranges)]
    rows = []
    render_s = 0.0
    for k, tr in enumerate(tracks):
        with AuditRenderer([tr], tile, overlay, [cams[k]], [ranges[k]]) as r:
            tiles = []
            for p in poses[k]:
                img = Image.fromarray(r.frame([p.frame], bar=False, title=False, findings=False))
                cap = Image.new("RGB", (tile.width, overlay.caption_height), (250, 250, 250))
                d = ImageDraw.Draw(cap)
                d.text((6, 3), p.label, fill=(20, 20, 20), font=_font(overlay.font_size, True))
                d.text((6, 3 + overlay.font_size + 3), f"f {p.frame} · {p.frame / tr.motion.fps:.3f} s",
                       fill=(60, 60, 60), font=_font(overlay.font_size - 1))
                hits = sorted({f.check.replace("_", " ") for f in tr.findings_at(p.frame) if f.is_violation})
                if hits:
                    f = _font(overlay.font_size - 1)
                    d.text((6, 3 + 2 * (overlay.font_size + 3)), _fit(d, ", ".join(hits), f, tile.width - 10),
                           fill=(200, 20, 20), font=f)
                tiles.append(np.concatenate([np.asarray(img), np.asarray(cap)], axis=0))
            render_s += r.render_seconds
        body = np.concatenate(tiles, axis=1)
        bar = _TimeBar(tr, body.shape[1], overlay, ranges[k]).draw(None, ticks=[p.frame for p in poses[k]])
        head = Image.new("RGB", (body.shape[1], overlay.header_height), (250, 250, 250))
        d = ImageDraw.Draw(head)
        d.text((8, 3), tr.name, fill=(20, 20, 20), font=_font(overlay.font_size + 1, True))
        txt, col = _verdict_text(tr.report)
        a, b = ranges[k]
        d.text((8, 5 + overlay.font_size + 2), f"{txt} · frames {a}-{b - 1} of {tr.n_frames} at {tr.motion.fps:g} Hz",
               fill=col, font=_font(overlay.font_size))
        rows.append(np.concatenate([np.asarray(head), body, np.asarray(bar)], axis=0))
    width = max(r.shape[1] for r in rows)
    padded = [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0)), constant_values=255) for r in rows]
    sep = np.full((6, width, 3), 255, np.uint8)
    out = padded[0]
    for r in padded[1:]:
        out = np.concatenate([out, sep, r], axis=0)
    return out, tuple(poses), render_s


def render_with_audit(motion: Motion, path: str | Path, *, against: Motion | None = None, name: str | None = None,
                      against_name: str | None = None, frames=None, camera: str = "side",
                      style: RenderStyle | None = None, overlay: OverlayStyle | None = None, reports=None,
                      max_gap_s: float = 0.15, progress: bool = False) -> AuditRenderResult:
    """Draw ``motion`` (and ``against`` beside it) with its audit into ``path``: ``.mp4`` (H.264 at
    the motion's rate, every k-th frame above :data:`VIDEO_MAX_FPS`), ``.gif`` (at most
    :data:`GIF_MAX_FPS`) or ``.png`` (phase filmstrip, :func:`phase_poses`).

    ``frames``: ``"A:B"`` or ``(A, B)`` (half-open, of ``motion``; ``against`` is shown at the same
    times). ``camera``: one of :data:`CAMERAS`. ``style``: size (per panel) and look of the scene;
    ``overlay``: of the marks. ``reports``: the audits of ``motion`` (and ``against``) if already
    computed (e.g. a command's :class:`~mocomp.cli._common.OutputAudit`); else
    :func:`mocomp.audit.audit` runs on each. Returns an :class:`AuditRenderResult`.
    """
    t_start = time.perf_counter()
    path = Path(path)
    kind = output_kind(path)
    if camera not in CAMERAS:
        raise ValueError(f"camera must be one of {', '.join(CAMERAS)}, got {camera!r}")
    style = style or RenderStyle()
    overlay = overlay or OverlayStyle()
    motions = [motion] + ([against] if against is not None else [])
    names = [name or "motion", against_name or "against"][:len(motions)]
    reps = list(reports) if reports is not None else []
    while len(reps) < len(motions):
        reps.append(None)
    tracks = [audit_track(m, rp, name=n, style=style) for m, rp, n in zip(motions, reps, names)]
    rng0 = resolve_frames(frames, motion.n_frames, names[0])
    ranges = [rng0]
    if against is not None and kind == "filmstrip" and frames is None:
        ranges.append((0, against.n_frames))
    elif against is not None:
        t0, t1 = rng0[0] / motion.fps, (rng0[1] - 1) / motion.fps
        a = min(int(round(t0 * against.fps)), against.n_frames - 2)
        b = min(int(round(t1 * against.fps)) + 1, against.n_frames)
        ranges.append((a, max(b, a + 2)))
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "filmstrip":
        img, poses, render_s = _filmstrip(tracks, ranges, style, overlay, camera, max_gap_s)
        save_png(img, path)
        secs = time.perf_counter() - t_start
        n = sum(len(p) for p in poses)
        return AuditRenderResult(path, kind, (img.shape[1], img.shape[0]), n, None, 1, tuple(ranges), poses, camera,
                                 tuple(t.report for t in tracks), secs, render_s, n / secs)
    stride = _stride(motion.fps, VIDEO_MAX_FPS if kind == "video" else GIF_MAX_FPS)
    fr, ended, fps = _timeline(tracks, ranges, stride)
    cams = make_cameras(camera, tracks, ranges, style.width / style.height)
    with AuditRenderer(tracks, style, overlay, cams, ranges) as r:
        writer = _write_video if kind == "video" else _write_gif
        n, size = writer(r, path, fr, ended, fps, progress)
        render_s = r.render_seconds
    secs = time.perf_counter() - t_start
    return AuditRenderResult(path, kind, size, n, fps, stride, tuple(ranges), (), camera,
                             tuple(t.report for t in tracks), secs, render_s, n / secs)
