"""Editing primitives shared by the methods (issue 15, Foundation III).

Each is a pure function over immutable :class:`~mocomp.core.Motion` values that returns a result
dataclass carrying the output motion and its evidence (measured with :mod:`mocomp.audit` where
it says so):

* foot plants and their enforcement -- :func:`foot_plants` (the project's contact detector, CSV
  overrides ``joint,start,stop``), :func:`enforce_footplants` (analytic two-bone leg IK,
  :func:`two_bone_ik`, knee direction kept, reach clamped, unreachable frames reported; foot and
  toe orientation; faded in and out);
* displacement maps -- :class:`DisplacementMap` (root additive, joints by the log map; Gaussian or
  B-spline smoothing of a given width; damping), :func:`apply_displacement`, :func:`apply_hierarchy`
  (a schedule of (sigma, rho) levels, touch-up sec. 3.1);
* alignment and transitions -- :func:`align` (rotation about the vertical + ground translation, by
  root or feet centre), :func:`blend` (slerp with an ease curve, root by blended velocity, optional
  time warping, feet planted);
* path editing -- :func:`path_edit` onto a polyline or spline (:class:`PathCurve`), heading along
  the tangent, fine root motion kept, plants re-enforced;
* slope rotation -- :func:`slope` (the ground tilted about a horizontal axis).
"""
from .align import GroundTransform, align, headings, reference_points
from .blend import BlendResult, blend, step_period
from .displacement import (DisplacementMap, HierarchyResult, HierarchyStep, apply_displacement, apply_hierarchy,
                           smooth_offsets)
from .easing import ease, ramp_fill
from .footplant import FootplantResult, enforce_footplants, plant_slides
from .ik import leg_chains, plant_feet, two_bone_ik
from .path import CurveError, PathCurve, PathEditResult, motion_path, path_distance, path_edit, step_lengths
from .plants import FootPlants, NoContactError, foot_plants, leg_layout, read_contacts_csv
from .slope import SlopeResult, slope

__all__ = [
    "FootPlants", "NoContactError", "foot_plants", "leg_layout", "read_contacts_csv",
    "FootplantResult", "enforce_footplants", "plant_slides", "two_bone_ik", "leg_chains", "plant_feet",
    "DisplacementMap", "apply_displacement", "smooth_offsets", "HierarchyStep", "HierarchyResult", "apply_hierarchy",
    "GroundTransform", "align", "headings", "reference_points", "BlendResult", "blend", "step_period",
    "ease", "ramp_fill",
    "CurveError", "PathCurve", "PathEditResult", "path_edit", "motion_path", "path_distance", "step_lengths",
    "SlopeResult", "slope",
]
