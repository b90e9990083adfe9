"""Body segment parameters: masses, COMs and inertias per skeleton segment."""
from .model import BodyModel

__all__ = ["BodyModel"]
