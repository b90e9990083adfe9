"""In-flight edits and the restoration of momentum conservation (issue 5;
dissertation sections 5.5-5.6, flips paper sections 5.5-6): edit layers and
presets, the three restoration steps (:func:`restore_momentum`), joining two
flights (:mod:`mocomp.edit.join`) and twist-jump variation (:mod:`mocomp.edit.twist`)."""
from .layers import AimLayer, EditRangeError, OffsetLayer, TargetLayer, apply_layers, ease_weights
from .linear import LinearResult, PlatformCheck, correct_linear
from .pipeline import STAGES, RestoreResult, StageErrors, changed_frames, restore_momentum
from .presets import PRESETS, EditPlan, apply_preset, preset_layers
from .restore import (DirectionResult, MagnitudeResult, correct_direction, correct_magnitude, direction_error,
                      flight_momentum, magnitude_error)

__all__ = ["AimLayer", "OffsetLayer", "TargetLayer", "apply_layers", "ease_weights", "EditRangeError",
           "PRESETS", "EditPlan", "apply_preset", "preset_layers", "DirectionResult", "MagnitudeResult",
           "correct_direction", "correct_magnitude", "direction_error", "magnitude_error", "flight_momentum",
           "LinearResult", "PlatformCheck", "correct_linear", "STAGES", "RestoreResult", "StageErrors",
           "changed_frames", "restore_momentum"]
