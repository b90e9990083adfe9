"""Physical touch-up of edited motions (Shin, Kovar & Gleicher 2003, issue 16).

Closed-form per-frame adjustments smoothed into hierarchical displacement maps
(:func:`mocomp.ops.apply_hierarchy`), one module per part:

* :mod:`~mocomp.touchup.stages` -- ground and flight frames from the foot plants (CSV overrides);
* :mod:`~mocomp.touchup.zmp` -- eq. 4 on the Gaussian-smoothed motion, the support polygon, the
  ZMP's distance outside it and its projection;
* :mod:`~mocomp.touchup.linksets` -- S1 (unchanged), S2 (rotated), S3 (translated, orientation
  kept) by presets or joint names, and the rigid rotation of S2;
* :mod:`~mocomp.touchup.ground` -- sec. 3.3, eq. 6-7 and the appendix's coefficients;
* :mod:`~mocomp.touchup.flight` -- sec. 3.4: angular momentum to the block's average (eq. 8-9)
  and the COM onto the g = 9.81 parabola through the block's end points (eq. 10), ground frames
  near a flight adjusted with it and eased to zero (Fig. 4);
* :mod:`~mocomp.touchup.masses` -- sec. 3.2, eq. 5: masses fitted to reference motions by
  conjugate gradients from the table (:func:`fit_masses`);
* :mod:`~mocomp.touchup.schedule` -- the paper's schedules as presets (``ground-default``,
  ``flight-default``, ``uphill``) and TOML schedules;
* :mod:`~mocomp.touchup.iterate` -- :func:`touchup`: each step's per-frame adjustments smoothed
  into displacement maps (:func:`mocomp.ops.apply_hierarchy`), footplants re-enforced
  (:func:`mocomp.ops.enforce_footplants`), measured after every iteration.
"""
from .flight import (FlightAdjustment, angular_momentum, ballistic_targets, com_residual, flight_com_adjustment,
                     flight_momentum_adjustment)
from .ground import GroundAdjustment, eq6_coefficients, eq7_angle, ground_adjustment
from .iterate import NEIGHBOURHOOD_S, TouchupResult, touchup
from .linksets import PRESETS, LinkSetError, LinkSets, body_parts, link_sets, rotate_sets
from .masses import MassFit, fit_masses
from .schedule import PRESET_SCHEDULES, ScheduleError, Step, preset_schedule, read_schedule, schedule_from_spec
from .stages import Stages, StageError, stages
from .zmp import ZmpState, project_to_polygon, zmp_state

__all__ = ["Stages", "StageError", "stages", "ZmpState", "zmp_state", "project_to_polygon",
           "LinkSets", "LinkSetError", "PRESETS", "body_parts", "link_sets", "rotate_sets",
           "GroundAdjustment", "eq6_coefficients", "eq7_angle", "ground_adjustment",
           "FlightAdjustment", "angular_momentum", "ballistic_targets", "com_residual", "flight_com_adjustment",
           "flight_momentum_adjustment", "Step", "ScheduleError", "PRESET_SCHEDULES", "preset_schedule",
           "read_schedule", "schedule_from_spec", "TouchupResult", "touchup", "NEIGHBOURHOOD_S",
           "MassFit", "fit_masses"]
