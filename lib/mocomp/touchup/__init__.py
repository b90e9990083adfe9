"""Physical touch-up of edited motions (Shin, Kovar & Gleicher 2003, issue 16).

Closed-form per-frame adjustments smoothed into hierarchical displacement maps
(:func:`mocomp.ops.apply_hierarchy`), one module per part:

* :mod:`~mocomp.touchup.stages` -- ground and flight frames from the foot plants (CSV overrides);
* :mod:`~mocomp.touchup.zmp` -- eq. 4 on the Gaussian-smoothed motion, the support polygon, the
  ZMP's distance outside it and its projection;
* :mod:`~mocomp.touchup.linksets` -- S1 (unchanged), S2 (rotated), S3 (translated, orientation
  kept) by presets or joint names, and the rigid rotation of S2;
* :mod:`~mocomp.touchup.ground` -- sec. 3.3, eq. 6-7 and the appendix's coefficients.
"""
from .ground import GroundAdjustment, eq6_coefficients, eq7_angle, ground_adjustment
from .linksets import PRESETS, LinkSetError, LinkSets, body_parts, link_sets, rotate_sets
from .stages import Stages, StageError, stages
from .zmp import ZmpState, project_to_polygon, zmp_state

__all__ = ["Stages", "StageError", "stages", "ZmpState", "zmp_state", "project_to_polygon",
           "LinkSets", "LinkSetError", "PRESETS", "body_parts", "link_sets", "rotate_sets",
           "GroundAdjustment", "eq6_coefficients", "eq7_angle", "ground_adjustment"]
