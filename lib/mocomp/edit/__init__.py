"""In-flight edits and the restoration of momentum conservation (issue 5;
dissertation section 5.5, flips paper section 5.5)."""
from .layers import AimLayer, EditRangeError, OffsetLayer, TargetLayer, apply_layers, ease_weights
from .presets import PRESETS, EditPlan, apply_preset, preset_layers
from .restore import (DirectionResult, MagnitudeResult, correct_direction, correct_magnitude, direction_error,
                      magnitude_error)

__all__ = ["AimLayer", "OffsetLayer", "TargetLayer", "apply_layers", "ease_weights", "EditRangeError",
           "PRESETS", "EditPlan", "apply_preset", "preset_layers", "DirectionResult", "MagnitudeResult",
           "correct_direction", "correct_magnitude", "direction_error", "magnitude_error"]
