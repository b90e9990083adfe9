"""Is this motion physically valid? Measured from its frames only (issue #13, section 1).

``audit(motion, body=None, *, thresholds=AuditThresholds(), against=None) -> AuditReport``
takes any :class:`~mocomp.core.Motion` and, with no knowledge of the method that made
it, measures:

* contacts and phases (the project's detector), floor penetration and foot slide per
  contact (:mod:`~mocomp.audit.contacts`);
* COM velocity and linear momentum jumps at every frame against one-sided local fits,
  with take-off and landing singled out (:mod:`~mocomp.audit.com`);
* per flight, the ballistic fit of the COM (fitted g with its t-interval, the residual
  to a g = 9.81 parabola), the spread of the L direction and the variation of |L|
  (the paper's error measures) and the take-off angle (:mod:`~mocomp.audit.flights`);
* per ground stage, the ZMP distance outside the support polygon (touch-up paper
  eq. 4; :mod:`~mocomp.audit.zmp`);
* kinematic sanity: bone lengths, joint rotation rates, root and joint jumps between
  frames (:mod:`~mocomp.audit.kinematics`).

Each :class:`Finding` states its frames, size and the threshold it exceeds;
:class:`AuditThresholds` documents every default. ``report.violations``,
``report.verdict`` (``"pass"``/``"fail"``), ``report.to_dict()``, ``report.summary_lines()``;
with ``against=original`` the report carries an :class:`AuditComparison` (each measure
of both motions side by side, flagged where the edit is worse; flights paired by time, not index:
:mod:`~mocomp.audit.pairing`) and ``pose_jumps`` (each joint's rotation rate against the input's
own on the corresponding frames: :mod:`~mocomp.audit.posejump`).

``audit(motion, external_force_frames=slice(a, b))`` (or a mask, frame indices, ``(start, stop)``
pairs; ``mocomp audit --external-force A:B``) declares frames under an external force (a hit):
airborne frames there are ``"forced"`` flights, judged only on their free part, and findings of the
force-dependent checks there get severity ``"expected"`` (``report.expected``), not violations
(:mod:`~mocomp.audit.force`). Airborne runs shorter than ``min_airborne_frames`` / ``min_airborne_time``
are ``"spurious"`` flights: listed, not measured, never paired.
"""
from .findings import Finding
from .force import FORCE_CHECKS, forced_mask, parse_frame_ranges
from .pairing import FlightPairing, pair_flights
from .posejump import PoseJumpAudit
from .report import AuditComparison, AuditReport, Measure
from .run import audit, default_body
from .thresholds import G_STANDARD, AuditConfigError, AuditThresholds

__all__ = ["audit", "default_body", "AuditReport", "AuditComparison", "AuditThresholds", "AuditConfigError",
           "Finding", "Measure", "G_STANDARD", "FlightPairing", "pair_flights", "PoseJumpAudit", "forced_mask",
           "parse_frame_ranges", "FORCE_CHECKS"]
