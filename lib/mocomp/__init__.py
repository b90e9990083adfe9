"""mocomp: physically based editing of human motion capture.

Layers (see DESIGN.md): ``core`` (skeleton, motion, kinematics), ``io`` (files),
``body`` (segment masses and inertias), ``dynamics`` (COM, momentum, ZMP,
contacts), ``synth`` (physically exact ground-truth motions), and one package
per paper method.
"""
from .core import Motion, Skeleton, SourceInfo, concatenate
from .errors import DataNotFoundError, MocompError, MotionFormatError, NoFlightPhaseError, PhysicsError

__version__ = "0.1.0"

__all__ = ["Motion", "Skeleton", "SourceInfo", "concatenate", "MocompError", "MotionFormatError",
           "DataNotFoundError", "NoFlightPhaseError", "PhysicsError", "__version__"]
