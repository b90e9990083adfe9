"""Physical quantities of a motion: COM, momentum, ZMP, contacts (vectorised over frames)."""
from .constants import G_STANDARD
from .com import center_of_mass, segment_positions, segment_rotations
from .contacts import ContactResult, airborne_intervals, detect_contacts
from ..core.kinematics import angular_velocity, central_difference, gaussian_smooth, second_difference
from .derivatives import smooth_motion
from .momentum import MomentumResult, MotionVelocities, composite_inertia, momentum
from .zmp import ZMPResult, support_polygon_distance, zmp

__all__ = [
    "G_STANDARD",
    "center_of_mass", "segment_positions", "segment_rotations",
    "central_difference", "second_difference", "angular_velocity", "gaussian_smooth", "smooth_motion",
    "MomentumResult", "MotionVelocities", "momentum", "composite_inertia",
    "zmp", "ZMPResult", "support_polygon_distance",
    "detect_contacts", "ContactResult", "airborne_intervals",
]
