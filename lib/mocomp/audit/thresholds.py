"""Thresholds of the physics audit: documented defaults a user can change.

Every finding of :func:`mocomp.audit.audit` states the threshold it exceeds. The
defaults are chosen so that the embedded synthetic motions (exact physics at
120 fps, including their landing impact) pass with no violation, while the
defects of issue #13 (feet 5 cm and more below the floor, a COM velocity that
doubles between two frames, a flight falling at 7.6 or 11.8 m/s^2) are found.
Real captures have their own foot slide and noise: their findings under these
defaults are the baseline in ``docs/audit_baseline.md``.

Change one with ``dataclasses.replace(AuditThresholds(), penetration=0.03)`` or
``AuditThresholds.from_strings(["penetration=0.03"])`` (the ``--threshold`` option
of ``mocomp audit``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

from ..dynamics.constants import G_STANDARD  # the audit's "truth", never a gravity fitted to the clip
from ..errors import MocompError

__all__ = ["AuditThresholds", "AuditConfigError", "G_STANDARD"]


class AuditConfigError(MocompError, ValueError):
    """An audit threshold is unknown or out of its range (the message names the field)."""


@dataclass(frozen=True)
class AuditThresholds:
    """Limits above which a measure becomes a finding. SI units.

    Contacts and floor
    ------------------
    penetration: m (default 0.02). A frame's lowest body point (every joint and end site)
        more than this below the floor is a *floor penetration* (violation). The floor is
        ``floor_y`` when given, else the resting level of the lowest body point during the
        clip's first ground stage ("the floor the motion took off from"; see
        :func:`mocomp.audit.contacts.floor_level`).
    floor_y: m or ``None`` (default): an explicit floor height instead of the estimate.
    foot_slide: m (default 0.03). A planted foot or toe whose horizontal position moves
        more than this from where it was planted, within one contact, slides (violation).
    hand_slide: m (default 0.05), the same for a planted hand (advisory: a hand on the
        floor rolls over its palm).

    COM velocity / linear momentum
    ------------------------------
    jump_window: frames (default 0 = automatic: ``max(2, round(0.03 s x fps))``) in each
        one-sided quadratic fit of the COM (see :mod:`mocomp.audit.com`).
    jump_min: m/s (default 0.5). Smallest COM velocity jump that is a finding.
    jump_noise_factor: (default 8). The jump threshold is
        ``max(jump_min, jump_noise_factor x noise)`` with ``noise`` the motion's own jump
        noise, ``1.4826 x median |jump|`` over all frames (a robust standard deviation).
    landing_jump_max: m/s (default 1.5). At a landing the ground may stop the body with an
        impulse (the synthetic landings lose 0.5-0.7 m/s in a frame); a jump there is a
        violation only above this (and above the noise threshold).
    event_window: s (default 0.05). Frames within this of a take-off or landing frame of the
        phases belong to that event (the detector's borders lie a few frames inside the
        true flight).

    Flights
    -------
    flight_com_height: m (default 0.45). A run with no effector touching is a flight only on
        frames where the COM is at least this above the floor: lying, sitting or rolling on the
        floor (COM within ~0.3 m of it) is support by the trunk. In the flights of the embedded
        examples and of the real captures the COM stays above 0.6 m.
    support_clearance: m (default 0.08). Frames where the body's lowest point is within this of
        the floor and slower than the contact detector's speed threshold rest on the floor (a knee,
        a hip, a foot on its side), so they are not flight either.
    min_flight_frames: (default 5, at least 4) shortest airborne run that gets a ballistic fit.
    min_airborne_frames: (default 3) and min_airborne_time: s (default 0.03). An airborne run
        shorter than ``min_airborne_frames`` frames *or* than ``min_airborne_time`` is *spurious*
        (a contact-detector flicker: CMU 90_08 has a one-frame "flight" at frame 0): it stays in
        the phases and in ``report.flights`` (``kind == "spurious"``), but it gets no ballistic or
        L measure and is never paired with a flight of the other motion in ``--against``
        comparisons. A real running flight lasts ~0.1 s (12 frames at 120 Hz, 3 at 30 Hz).
    g_tolerance: m/s^2 (default 1.0). The fitted g is a violation when 9.81 lies outside its
        95 % t-interval widened by this on both sides.
    confidence: (default 0.95) level of that interval.
    L_direction: rad (default 0.0873 = 5 deg). Largest angle of L (about the COM, eq. 5.5)
        from its mean direction over the flight (violation above).
    L_magnitude: relative (default 0.10). Largest ``| |L| - mean |L| | / mean |L|`` over the
        flight (violation above). Finite differences of an exact synthetic flight at 120 fps
        give 0.2-0.9 % (order-2 differences, as the audit uses).
    L_min: kg m^2/s (default 10). Below this mean |L| neither L measure is judged: a hop or
        a straight jump has a few kg m^2/s, within the finite-difference noise of captured L
        (real hops: 4-6 kg m^2/s with 10-60 deg of direction spread), so it has no meaningful
        direction. The flips and twists of the examples have 11-54 kg m^2/s.

    ZMP (touch-up paper eq. 4)
    --------------------------
    zmp_outside: m (default 0.05). ZMP farther than this outside the support polygon.
    zmp_min_time: s (default 0.1). Only runs at least this long are findings (single
        frames of a noisy second difference are not).
    zmp_smooth_sigma: frames (default 2.0) of Gaussian smoothing before the second
        differences of the ZMP (the paper smooths with a Gaussian of width 5).
    zmp_is_violation: (default False) ZMP findings are advisory: the point-mass ZMP ignores
        segment rotation and the support polygon is spanned by ankle, toe and hand points only.

    Kinematics
    ----------
    bone_length: m (default 1e-6). Largest change of a bone's length from the skeleton's.
    joint_speed: rad/s (default 60). Rotation rate of a joint relative to its parent between
        two frames (a 180-degree flip of one joint in one frame is 94 rad/s at 30 fps, 377 at
        120 fps; the synthetic twists swing the arms at 48 rad/s). A finding on a joint whose
        rotation moves no mass of the body model (e.g. CMU's thumbs) is advisory.
    root_speed: m/s (default 12). Root travel between two frames.
    point_speed: m/s (default 25). Any joint's travel between two frames.

    Against the input (``audit(..., against=input)``, same joint names)
    --------------------------------------------------------------------
    pose_jump_excess: rad/s (default 20). A *pose jump*: a joint of the audited motion turns faster
        between two frames than the input's same joint anywhere in the neighbourhood of the
        corresponding input frames (see :mod:`mocomp.audit.posejump`), by more than this. A
        30-degree jump of one joint in one frame is 31 rad/s at 60 Hz and 63 rad/s at 120 Hz;
        the leg IK of footplant enforcement on real walks turns joints up to ~5-8 rad/s faster than
        the input (measured on the project's outputs: see the module).
    pose_jump_ratio: (default 0.5). And by more than this fraction of the input's own rate there
        (a fast input swing played a little faster is not a jump).
    pose_jump_window: s (default 0.05). Half-width of the input neighbourhood whose largest rate is
        the reference (an input glitch of 375 rad/s raises the reference only near itself).
    pose_jump_is_violation: (default False) pose-jump findings are advisory: the check compares with
        the input, and a method may legitimately move a joint faster than the input did (a spliced
        hand, a simulated response to a hit, a flip retimed non-uniformly whose frame map the audit
        can only guess). Set it (``--threshold pose_jump_is_violation=true``) where the output should
        follow its input's timing, e.g. footplant enforcement. ``measures()`` has
        ``max_joint_speed_excess`` either way.
    """

    penetration: float = 0.02
    floor_y: float | None = None
    foot_slide: float = 0.03
    hand_slide: float = 0.05
    jump_window: int = 0
    jump_min: float = 0.5
    jump_noise_factor: float = 8.0
    landing_jump_max: float = 1.5
    event_window: float = 0.05
    flight_com_height: float = 0.45
    support_clearance: float = 0.08
    min_flight_frames: int = 5
    min_airborne_frames: int = 3
    min_airborne_time: float = 0.03
    g_tolerance: float = 1.0
    confidence: float = 0.95
    L_direction: float = math.radians(5.0)
    L_magnitude: float = 0.10
    L_min: float = 10.0
    zmp_outside: float = 0.05
    zmp_min_time: float = 0.1
    zmp_smooth_sigma: float = 2.0
    zmp_is_violation: bool = False
    bone_length: float = 1e-6
    joint_speed: float = 60.0
    root_speed: float = 12.0
    point_speed: float = 25.0
    pose_jump_excess: float = 20.0
    pose_jump_ratio: float = 0.5
    pose_jump_window: float = 0.05
    pose_jump_is_violation: bool = False

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "floor_y":
                if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
                    raise AuditConfigError(f"threshold floor_y must be a finite height (m) or None, got {v!r}")
                continue
            if f.name in ("zmp_is_violation", "pose_jump_is_violation"):
                if not isinstance(v, bool):
                    raise AuditConfigError(f"threshold {f.name} must be True or False, got {v!r}")
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise AuditConfigError(f"threshold {f.name} must be a finite number, got {v!r}")
            if f.name in ("jump_window", "min_flight_frames", "min_airborne_frames"):
                if f.name == "jump_window":
                    bad, lo = int(v) != v or v < 0 or v == 1, "0 (automatic) or >= 2"
                elif f.name == "min_airborne_frames":
                    bad, lo = int(v) != v or v < 1, ">= 1"
                else:
                    bad, lo = int(v) != v or v < 4, ">= 4"
                if bad:
                    raise AuditConfigError(f"threshold {f.name} must be an integer {lo}, got {v!r}")
                object.__setattr__(self, f.name, int(v))
            elif f.name == "confidence":
                if not 0 < v < 1:
                    raise AuditConfigError(f"threshold confidence must lie strictly between 0 and 1, got {v!r}")
            elif f.name in ("g_tolerance", "zmp_smooth_sigma", "pose_jump_ratio", "min_airborne_time"):
                if v < 0:
                    raise AuditConfigError(f"threshold {f.name} must be >= 0, got {v!r}")
            elif not v > 0:
                raise AuditConfigError(f"threshold {f.name} must be positive, got {v!r}")

    @classmethod
    def from_strings(cls, items, base: "AuditThresholds | None" = None) -> "AuditThresholds":
        """Thresholds from ``NAME=VALUE`` strings (``"penetration=0.03"``, ``"floor_y=none"``,
        ``"zmp_is_violation=true"``) on top of ``base`` (default: the defaults)."""
        base = base or cls()
        names = {f.name: f for f in fields(cls)}
        changes = {}
        for item in items or ():
            name, sep, text = str(item).partition("=")
            name, text = name.strip(), text.strip()
            if not sep or not name:
                raise AuditConfigError(f"threshold {item!r} is not NAME=VALUE")
            if name not in names:
                raise AuditConfigError(f"unknown threshold {name!r}; known: {', '.join(names)}")
            if name in ("zmp_is_violation", "pose_jump_is_violation"):
                low = text.lower()
                if low not in ("true", "false", "1", "0", "yes", "no"):
                    raise AuditConfigError(f"threshold {name} must be true or false, got {text!r}")
                changes[name] = low in ("true", "1", "yes")
            elif name == "floor_y" and text.lower() in ("none", "auto", ""):
                changes[name] = None
            else:
                try:
                    changes[name] = float(text)
                except ValueError:
                    raise AuditConfigError(f"threshold {name}: {text!r} is not a number") from None
        return dataclasses.replace(base, **changes)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def jump_frames(self, fps: float) -> int:
        """Frames per one-sided fit: ``jump_window`` or ``max(2, round(0.03 s x fps))``."""
        return self.jump_window if self.jump_window else max(2, int(round(0.03 * fps)))

    def spurious_flight(self, n_frames: int, fps: float) -> bool:
        """An airborne run of ``n_frames`` frames at ``fps`` is spurious (see ``min_airborne_frames``)."""
        return n_frames < self.min_airborne_frames or n_frames / fps < self.min_airborne_time - 1e-12
