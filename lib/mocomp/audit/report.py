"""The audit's result: measures, findings, verdict, and the side-by-side comparison with an input."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .findings import Finding
from .pairing import FlightPairing, pair_flights
from .thresholds import G_STANDARD, AuditThresholds

__all__ = ["AuditReport", "AuditComparison", "Measure"]

#: a measure is "worse" in a comparison when its badness exceeds the other's by more than this
#: fraction of the threshold it is judged against
WORSE_FRACTION = 0.25


@dataclass(frozen=True)
class Measure:
    """One scalar of the audit: ``key``, ``label``, ``unit``, ``value`` (NaN: not measured) and
    ``badness`` (how far from ideal, same unit; for g ``|g - 9.81|``), ``tolerance`` (a difference
    in badness below this is not "worse" in a comparison)."""

    key: str
    label: str
    unit: str
    value: float
    badness: float
    tolerance: float


def _nan(x) -> float:
    return float("nan") if x is None else float(x)


@dataclass(frozen=True, eq=False)
class AuditReport:
    """Physical validity of one motion, measured from its frames only.

    Attributes
    ----------
    name: what was audited (file, clip or example name).
    n_frames, fps: of the motion; total_mass: kg of the body model; body: its one-line description.
    thresholds: the :class:`~mocomp.audit.AuditThresholds` used.
    phases: :class:`~mocomp.audit.contacts.Phases` (flights, ground stages, take-offs, landings).
    contact_notes: the contact detector's notes.
    penetration: :class:`~mocomp.audit.contacts.PenetrationAudit`.
    contacts: per planted contact, :class:`~mocomp.audit.contacts.ContactAudit`.
    com: :class:`~mocomp.audit.com.ComAudit` (velocity / momentum jumps, take-off and landing events).
    flights: per airborne run, :class:`~mocomp.audit.flights.FlightAudit`.
    zmp: :class:`~mocomp.audit.zmp.ZmpAudit`.
    kinematics: :class:`~mocomp.audit.kinematics.KinematicsAudit`.
    findings: every measure above its threshold, in frame order.
    comparison: :class:`AuditComparison` against the ``against`` motion, or ``None``.
    against: the :class:`AuditReport` of the ``against`` motion, or ``None``.
    seconds: wall time of the audit.
    external_force: ``(T,)`` bool mask of the frames the caller declared under an external force
        (``audit(..., external_force_frames=...)``, :mod:`mocomp.audit.force`), or ``None``.
    pose_jumps: :class:`~mocomp.audit.posejump.PoseJumpAudit` (per-joint rotation rate against the
        ``against`` motion's on corresponding frames), or ``None`` without ``against`` or when the
        two skeletons share too few joints.
    """

    name: str
    n_frames: int
    fps: float
    total_mass: float
    body: str
    thresholds: AuditThresholds
    phases: object
    contact_notes: tuple[str, ...]
    penetration: object
    contacts: tuple
    com: object
    flights: tuple
    zmp: object
    kinematics: object
    findings: tuple[Finding, ...]
    comparison: "AuditComparison | None" = None
    against: "AuditReport | None" = None
    seconds: float = 0.0
    times: np.ndarray = field(default=None, repr=False)
    external_force: np.ndarray | None = field(default=None, repr=False)
    pose_jumps: object = None

    # ---------------------------------------------------------------- verdict
    @property
    def violations(self) -> tuple[Finding, ...]:
        return tuple(f for f in self.findings if f.is_violation)

    @property
    def advisories(self) -> tuple[Finding, ...]:
        return tuple(f for f in self.findings if f.severity == "advisory")

    @property
    def expected(self) -> tuple[Finding, ...]:
        """Findings in frames declared under an external force (severity ``"expected"``): reported,
        not judged (:mod:`mocomp.audit.force`)."""
        return tuple(f for f in self.findings if f.severity == "expected")

    @property
    def verdict(self) -> str:
        """``"pass"`` (no violation) or ``"fail"``."""
        return "fail" if self.violations else "pass"

    def by_check(self, check: str) -> tuple[Finding, ...]:
        return tuple(f for f in self.findings if f.check == check)

    # --------------------------------------------------------------- measures
    def measures(self) -> list[Measure]:
        """The key scalars, in a fixed order (per-flight ones per flight index)."""
        th = self.thresholds
        feet = [c.slide for c in self.contacts if not c.effector.startswith("hand")]
        hands = [c.slide for c in self.contacts if c.effector.startswith("hand")]
        to = [e.jump for e in self.com.events if e.kind == "take-off" and e.frame is not None]
        la = [e.jump for e in self.com.events if e.kind == "landing" and e.frame is not None]
        fs = max(feet) if feet else float("nan")
        hs = max(hands) if hands else float("nan")
        out = [
            Measure("max_penetration_m", "max floor penetration", "m", self.penetration.max_depth,
                    self.penetration.max_depth, WORSE_FRACTION * th.penetration),
            Measure("max_foot_slide_m", "max foot slide", "m", fs, fs, WORSE_FRACTION * th.foot_slide),
            Measure("max_hand_slide_m", "max hand slide", "m", hs, hs, WORSE_FRACTION * th.hand_slide),
            Measure("max_com_jump_mps", "max COM velocity jump (not at landings)", "m/s", self.com.max_jump,
                    self.com.max_jump, WORSE_FRACTION * th.jump_min),
            Measure("takeoff_jump_mps", "max COM velocity jump at take-off", "m/s", max(to) if to else math.nan,
                    max(to) if to else math.nan, WORSE_FRACTION * th.jump_min),
            Measure("landing_jump_mps", "max COM velocity jump at landing", "m/s", max(la) if la else math.nan,
                    max(la) if la else math.nan, WORSE_FRACTION * th.jump_min),
            Measure("com_jump_noise_mps", "COM velocity jump noise", "m/s", self.com.noise, self.com.noise,
                    WORSE_FRACTION * th.jump_min / th.jump_noise_factor),
        ]
        for f in self.flights:
            if f.fit is None:
                continue
            i = f.index + 1
            out += [
                Measure(f"flight{i}_g", f"flight {i}: fitted g", "m/s^2", f.fit.g, abs(f.fit.g - G_STANDARD),
                        WORSE_FRACTION * max(th.g_tolerance, 0.1)),
                Measure(f"flight{i}_residual_g9.81_m", f"flight {i}: residual to a g = 9.81 parabola", "m",
                        f.fit.rms_standard, f.fit.rms_standard, 0.0025),
                Measure(f"flight{i}_L_direction_rad", f"flight {i}: L direction spread", "rad", f.L_direction,
                        f.L_direction if f.L_judged else math.nan, WORSE_FRACTION * th.L_direction),
                Measure(f"flight{i}_L_magnitude", f"flight {i}: |L| variation", "relative", f.L_magnitude,
                        f.L_magnitude if f.L_judged else math.nan, WORSE_FRACTION * th.L_magnitude),
                Measure(f"flight{i}_takeoff_angle_rad", f"flight {i}: take-off angle from vertical", "rad",
                        f.takeoff_angle, math.nan, 0.0),
            ]
        z = self.zmp
        out += [
            Measure("zmp_outside_fraction", "ZMP outside fraction (ground frames)", "fraction", z.outside_fraction,
                    z.outside_fraction, 0.05),
            Measure("zmp_max_outside_m", "ZMP max distance outside", "m", z.max_outside, z.max_outside,
                    WORSE_FRACTION * th.zmp_outside),
            Measure("bone_length_m", "max bone length change", "m", self.kinematics.bone_length,
                    self.kinematics.bone_length, WORSE_FRACTION * th.bone_length),
            Measure("max_joint_speed", "max joint rotation rate", "rad/s", self.kinematics.joint_speed,
                    self.kinematics.joint_speed, WORSE_FRACTION * th.joint_speed),
            Measure("max_root_speed", "max root speed between frames", "m/s", self.kinematics.root_speed,
                    self.kinematics.root_speed, WORSE_FRACTION * th.root_speed),
            Measure("max_point_speed", "max joint speed between frames", "m/s", self.kinematics.point_speed,
                    self.kinematics.point_speed, WORSE_FRACTION * th.point_speed),
        ]
        if self.pose_jumps is not None:
            pj = self.pose_jumps
            out.append(Measure("max_joint_speed_excess", "max joint rotation rate above the input's own (pose jump)",
                               "rad/s", pj.max_excess, max(pj.max_excess, 0.0), th.pose_jump_excess))
        out += [
            Measure("violations", "violations", "count", float(len(self.violations)), float(len(self.violations)),
                    0.5),
        ]
        return out

    def measure(self, key: str) -> float:
        for m in self.measures():
            if m.key == key:
                return m.value
        raise KeyError(f"no measure {key!r}; have {[m.key for m in self.measures()]}")

    # ------------------------------------------------------------- rendering
    def to_dict(self) -> dict:
        """JSON-ready (NaN as ``None``): measures, phases, contacts, flights, events, ZMP stages, findings."""
        ph = self.phases
        d = {
            "name": self.name, "n_frames": self.n_frames, "fps": self.fps, "total_mass_kg": self.total_mass,
            "body": self.body, "verdict": self.verdict, "violations": len(self.violations),
            "advisories": len(self.advisories), "expected": len(self.expected), "seconds": self.seconds,
            "thresholds": self.thresholds.to_dict(),
            "floor": {"y_m": self.penetration.floor_y, "source": self.penetration.floor_source},
            "phases": {"flights": [list(f) for f in ph.flights], "ground": [list(g) for g in ph.ground],
                       "takeoffs": list(ph.takeoffs), "landings": list(ph.landings)},
            "contact_notes": list(self.contact_notes),
            "measures": {m.key: m.value for m in self.measures()},
            "contacts": [c.to_dict() for c in self.contacts],
            "com": {"window_frames": self.com.window, "noise_mps": self.com.noise,
                    "max_jump_mps": self.com.max_jump, "max_jump_frame": self.com.max_frame,
                    "events": [e.to_dict() for e in self.com.events]},
            "flights": [f.to_dict() for f in self.flights],
            "zmp": {"smooth_sigma_frames": self.zmp.smooth_sigma, "outside_fraction": self.zmp.outside_fraction,
                    "max_outside_m": self.zmp.max_outside, "stages": [s.to_dict() for s in self.zmp.stages]},
            "kinematics": self.kinematics.to_dict(),
            "findings": [f.to_dict() for f in self.findings],
        }
        if self.external_force is not None:
            from ..dynamics.contacts import label_intervals

            d["external_force"] = {"frames": [list(r) for r in label_intervals(self.external_force)]}
        if self.pose_jumps is not None:
            d["pose_jumps"] = self.pose_jumps.to_dict()
        if self.comparison is not None:
            d["comparison"] = self.comparison.to_dict()
        return _json_safe(d)

    def summary_lines(self, max_findings: int = 20) -> list[str]:
        """A readable summary: phases, key measures, findings (at most ``max_findings``), verdict."""
        ph = self.phases
        L = [f"audit of {self.name}: {self.n_frames} frames at {self.fps:g} fps, body {self.total_mass:.1f} kg "
             f"({self.body})",
             f"floor y = {self.penetration.floor_y:.3f} m ({self.penetration.floor_source})",
             f"phases: {len(ph.ground)} ground stage(s), {len(ph.flights)} flight(s)"
             + ("".join(f"; flight {i + 1} frames {a}-{b - 1}" for i, (a, b) in enumerate(ph.flights[:6])))]
        if self.external_force is not None:
            from .force import ranges_text

            L.append(f"external force declared on frames {ranges_text(self.external_force) or '(none)'}: airborne "
                     f"frames there are forced, not free flight; findings of force-dependent checks there are "
                     f"expected, not judged")
        for m in self.measures():
            if m.key.startswith("flight") or m.key == "violations":
                continue
            L.append(f"  {m.label}: {_fmt(m.value, m.unit)}")
        for f in self.flights:
            kind = getattr(f, "kind", "free")
            n = f.frames[1] - f.frames[0]
            if kind == "spurious":
                L.append(f"  flight {f.index + 1} (frames {f.frames[0]}-{f.frames[1] - 1}): {n} frame(s) airborne, "
                         f"shorter than {self.thresholds.min_airborne_frames} frames or "
                         f"{self.thresholds.min_airborne_time * 1000:g} ms: spurious (a contact flicker or a very short "
                         f"airborne run), not measured or paired as a flight")
                continue
            forced = ""
            if kind == "forced":
                jf = f.judged_frames
                forced = (f"; under external force on {f.forced_frames} of its {n} frames, "
                          + (f"judged on its free part, frames {jf[0]}-{jf[1] - 1}" if jf else "no free part long "
                             "enough to judge"))
            if f.fit is None:
                L.append(f"  flight {f.index + 1} (frames {f.frames[0]}-{f.frames[1] - 1}): {n}"
                         f" frames, " + ("too short for a ballistic fit" if kind != "forced" else "not judged") + forced)
                continue
            L.append(f"  flight {f.index + 1} (frames {f.frames[0]}-{f.frames[1] - 1}, {f.duration:.3f} s{forced}): "
                     f"g = {f.fit.g:.2f} m/s^2 [{f.fit.g_low:.2f}, {f.fit.g_high:.2f}], residual "
                     f"{f.fit.rms * 1000:.1f} mm (g = 9.81: {f.fit.rms_standard * 1000:.1f} mm), take-off "
                     f"{f.takeoff_speed:.2f} m/s at {np.degrees(f.takeoff_angle):.1f} deg from vertical, COM rise "
                     f"{f.rise:.2f} m, L spread {np.degrees(f.L_direction):.2f} deg, |L| variation "
                     f"{f.L_magnitude:.1%} (mean |L| {f.L_abs:.1f} kg m^2/s{'' if f.L_judged else ', not judged'})")
        for e in self.com.events:
            if e.frame is not None:
                L.append(f"  {e.kind} of flight {e.flight + 1} (frame {e.event_frame}): largest COM jump "
                         f"{e.jump:.2f} m/s at frame {e.frame} (vertical {e.vy_before:+.2f} -> {e.vy_after:+.2f} m/s)")
        if self.pose_jumps is not None:
            L.append("  " + self.pose_jumps.summary())
        fl = list(self.findings)
        if fl:
            L.append(f"findings ({len(self.violations)} violation(s), {len(self.advisories)} advisory"
                     + (f", {len(self.expected)} expected under external force" if self.expected else "") + "):")
            L += ["  " + f.line() for f in fl[:max_findings]]
            if len(fl) > max_findings:
                L.append(f"  ... {len(fl) - max_findings} more (see the JSON report)")
        if self.comparison is not None:
            L += self.comparison.summary_lines()
        L.append(f"verdict: {self.verdict.upper()} ({len(self.violations)} violation(s), "
                 f"{len(self.advisories)} advisory finding(s)"
                 + (f", {len(self.expected)} expected under external force" if self.expected else "") + ")")
        return L

    def compare(self, other: "AuditReport") -> "AuditComparison":
        return AuditComparison.of(self, other)


_FLIGHT_KEY = re.compile(r"^flight(\d+)_(.+)$")
_FLIGHT_PLACE = re.compile(r"\bflight (\d+)\b")


def _fmt(v: float, unit: str) -> str:
    if v is None or not math.isfinite(v):
        return "-"
    if unit == "m":
        return f"{v * 100:.2f} cm"
    if unit == "rad":
        return f"{np.degrees(v):.2f} deg"
    if unit in ("relative", "fraction"):
        return f"{v:.1%}"
    if unit == "count":
        return f"{v:.0f}"
    return f"{v:.3g} {unit}"


def _json_safe(x):
    if isinstance(x, dict):
        return {str(k): _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, np.ndarray):
        return _json_safe(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x


@dataclass(frozen=True)
class AuditComparison:
    """Each measure of a motion (``this``, e.g. an edit) beside the same measure of another
    (``other``, e.g. its input).

    ``rows``: ``(key, label, unit, this, other, worse)``; ``worse`` is True when this motion's
    badness exceeds the other's by more than the measure's tolerance (a quarter of the threshold
    it is judged against). A measure only one motion has is listed with NaN for the other.

    Per-flight measures are paired by :func:`~mocomp.audit.pairing.pair_flights` (``flight_pairing``):
    by order or by time overlap, spurious airborne runs left out, not by index. The row
    ``flight{i}_X`` holds this motion's flight ``i`` and its partner's value (the label names the
    partner when its number differs); a flight of the other motion with no partner is listed as
    ``against_flight{j}_X`` with NaN for this motion.

    ``max_joint_speed_excess`` (present when this report has ``pose_jumps``) is measured against the
    other motion itself, so its ``against`` value is NaN; it is worse when above ``pose_jump_excess``
    and the frames were matched by seconds or by a given map (not when normalised by the durations:
    a retimed output's frame map is only a guess).
    """

    this_name: str
    other_name: str
    rows: tuple[tuple[str, str, str, float, float, bool], ...]
    this_verdict: str
    other_verdict: str
    flight_pairing: FlightPairing | None = None

    @classmethod
    def of(cls, this: AuditReport, other: AuditReport) -> "AuditComparison":
        a = {m.key: m for m in this.measures()}
        b = {m.key: m for m in other.measures()}
        pairing = pair_flights(this, other)
        used_b = set()
        rows = []

        def row(k, label, ma, mb):
            m = ma or mb
            va = ma.value if ma else math.nan
            vb = mb.value if mb else math.nan
            worse = bool(ma and mb and math.isfinite(ma.badness) and math.isfinite(mb.badness)
                         and ma.badness - mb.badness > m.tolerance)
            rows.append((k, label, m.unit, va, vb, worse))

        for k, ma in a.items():
            fm = _FLIGHT_KEY.match(k)
            if fm:
                i, suffix = int(fm.group(1)), fm.group(2)
                j = pairing.other_of(i - 1)
                kb = None if j is None else f"flight{j + 1}_{suffix}"
                mb = b.get(kb) if kb else None
                if kb:
                    used_b.add(kb)
                label = ma.label + ("" if j is None or j + 1 == i else f" (against: flight {j + 1})")
                row(k, label, ma, mb)
            elif k == "max_joint_speed_excess":
                trusted = getattr(this.pose_jumps, "mapping", "") in ("seconds", "given")
                rows.append((k, ma.label + ("" if trusted else " (frames matched by normalised time: indicative)"),
                             ma.unit, ma.value, math.nan,
                             bool(trusted and math.isfinite(ma.value) and ma.value > ma.tolerance)))
            else:
                mb = b.get(k)
                used_b.add(k)
                row(k, ma.label, ma, mb)
        for k, mb in b.items():
            if k in used_b or k in a:
                continue
            fm = _FLIGHT_KEY.match(k)
            if fm:
                row(f"against_{k}", f"against flight {fm.group(1)} (no partner): "
                    + mb.label.split(": ", 1)[-1], None, mb)
            else:
                row(k, mb.label, None, mb)
        return cls(this.name, other.name, tuple(rows), this.verdict, other.verdict, pairing)

    def place_in_other(self, where: str) -> str:
        """A finding's place (``Finding.where``) of this motion in the other motion's flight numbering:
        ``"take-off of flight 2"`` -> ``"take-off of flight 3"`` when this motion's flight 2 is paired
        with the other's flight 3 (:attr:`flight_pairing`); a flight without a partner becomes
        ``"flight 2 (no partner)"``; places that name no flight are returned as they are. Use it to
        match a finding with the other motion's findings by check and place."""
        if self.flight_pairing is None:
            return where

        def sub(m):
            j = self.flight_pairing.other_of(int(m.group(1)) - 1)
            return f"flight {m.group(1)} (no partner)" if j is None else f"flight {j + 1}"

        return _FLIGHT_PLACE.sub(sub, where)

    @property
    def worse(self) -> tuple[str, ...]:
        """Keys of the measures where this motion is worse than the other."""
        return tuple(r[0] for r in self.rows if r[5])

    def to_dict(self) -> dict:
        return _json_safe({"this": self.this_name, "against": self.other_name, "this_verdict": self.this_verdict,
                           "against_verdict": self.other_verdict, "worse": list(self.worse),
                           "flight_pairing": None if self.flight_pairing is None else self.flight_pairing.to_dict(),
                           "rows": [{"key": k, "label": lab, "unit": u, "this": va, "against": vb, "worse": w}
                                    for k, lab, u, va, vb, w in self.rows]})

    def summary_lines(self) -> list[str]:
        wa = max(len(r[1]) for r in self.rows) if self.rows else 10
        L = [f"comparison: {self.this_name} (verdict {self.this_verdict}) against {self.other_name} "
             f"(verdict {self.other_verdict})",
             f"  {'measure'.ljust(wa)}  {'this':>12}  {'against':>12}"]
        if self.flight_pairing is not None and (self.flight_pairing.pairs or self.flight_pairing.unpaired_other):
            L.insert(1, "  " + self.flight_pairing.text())
        for k, lab, u, va, vb, w in self.rows:
            L.append(f"  {lab.ljust(wa)}  {_fmt(va, u):>12}  {_fmt(vb, u):>12}{'  WORSE' if w else ''}")
        L.append(f"  worse than the original on {len(self.worse)} measure(s)"
                 + (f": {', '.join(self.worse)}" if self.worse else ""))
        return L
