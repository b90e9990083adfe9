"""Core data model: skeleton, motion, rotations, forward kinematics."""
from .kinematics import end_site_positions, forward_kinematics
from .motion import Motion, SourceInfo, concatenate, slerp
from .skeleton import EndSite, RemovedRoot, Skeleton

__all__ = ["Skeleton", "EndSite", "RemovedRoot", "Motion", "SourceInfo", "concatenate", "slerp",
           "forward_kinematics", "end_site_positions"]
