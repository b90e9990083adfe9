"""Ready-made flight edits for the paper's cases (dissertation Figures 5.9-5.10).

- ``straight-legs``: a tucked somersault becomes a straight-leg (layout/pike)
  one: thighs and shanks aimed along the trunk's long axis (Fig. 5.9).
- ``arms-twist``: arms thrown out asymmetrically, one above the head and one
  to the side, as divers do to start a twist (Fig. 5.10).
- ``arms-out``: both arms extended sideways (changes |L| only, like Fig. 5.9).

Joints are found through the body-segment mapping (:mod:`mocomp.body.mapping`),
so the presets work on every rig the mapping knows (CMU, SFU, Bandai, MASS,
DeepMimic, the synthetic skeleton). Directions come from the rest pose's own
landmarks, so no rig's axis convention is assumed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..body.mapping import resolve_mapping
from ..core.motion import Motion
from .layers import AimLayer, EditRangeError, apply_layers

__all__ = ["PRESETS", "preset_layers", "apply_preset", "EditPlan"]

PRESETS = {
    "straight-legs": "tucked -> straight legs: thighs and shanks along the trunk axis",
    "arms-twist": "asymmetric arms (one up, one to the side) for a somersault with twist",
    "arms-out": "both arms extended sideways",
}


@dataclass(frozen=True)
class EditPlan:
    """The layers of a preset and the frames they span."""

    name: str
    layers: tuple
    start: int
    stop: int


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def preset_layers(motion: Motion, flight, name: str, margin: float = 0.15, ease: float = 0.45,
                  up_side: str = "l") -> EditPlan:
    """Layers for preset ``name`` over the flight ``(start, stop)`` frames.

    The edit spans the flight minus ``margin`` (fraction of the flight) at both
    ends, easing in and out over ``ease`` (fraction of the edited span), so the
    take-off and the landing poses are untouched (eq. 5.19: L at the start of
    the flight stays L*). ``up_side`` picks which arm goes up for ``arms-twist``.

    The default ease (0.45: the limbs take ~45% of the edited span to open and as
    long to close) keeps limb speeds human. Faster edits (e.g. straightening the
    legs of a side flip) make the per-frame direction recurrence of eq. 5.21
    oscillate from frame to frame (:attr:`~mocomp.edit.DirectionResult.roughness_deg`);
    step 1's default joint solve (:mod:`mocomp.edit.smooth_direction`) removes that.
    """
    if name not in PRESETS:
        raise ValueError(f"unknown edit preset {name!r}; choose one of {sorted(PRESETS)}")
    a, b = int(flight[0]), int(flight[1])
    if not (0 <= a < b <= motion.n_frames):
        raise EditRangeError(f"flight [{a}, {b}) is outside the motion's 0..{motion.n_frames} frames")
    n = b - a
    s0 = a + int(round(margin * n))
    s1 = b - int(round(margin * n))
    if s1 - s0 < 4:
        raise EditRangeError(f"flight [{a}, {b}) is too short ({n} frames) for the {name!r} edit")
    e = max(1, int(round(ease * (s1 - s0))))
    sk = motion.skeleton
    rm = resolve_mapping(sk)
    seg = {s: i for i, s in enumerate(rm.segments)}

    def carrier(s):
        return sk.names[int(rm.carriers[seg[s]])]

    def axis(s):  # rest-pose direction proximal -> distal, in the carrier's rest (= world) frame
        i = seg[s]
        return tuple(_unit(rm.distal[i] - rm.proximal[i]))

    # trunk axis: from the neck base (CERV) down to the hips (MIDH), in the rest pose
    trunk_down = _unit(rm.distal[seg["lower_trunk"]] - rm.proximal[seg["upper_trunk"]])
    pelvis, chest = carrier("lower_trunk"), carrier("upper_trunk")
    layers = []
    if name == "straight-legs":
        for side in ("l", "r"):
            for s in ("thigh", "shank"):
                layers.append(AimLayer(s0, s1, e, joint=carrier(f"{s}_{side}"), reference=pelvis,
                                       direction=tuple(trunk_down), axis=axis(f"{s}_{side}")))
    else:
        lateral = {  # rest-pose direction from one shoulder to the other
            "l": _unit(rm.proximal[seg["upper_arm_l"]] - rm.proximal[seg["upper_arm_r"]]),
            "r": _unit(rm.proximal[seg["upper_arm_r"]] - rm.proximal[seg["upper_arm_l"]]),
        }
        if name == "arms-twist":
            if up_side not in ("l", "r"):
                raise ValueError(f"up_side must be 'l' or 'r', got {up_side!r}")
            other = "r" if up_side == "l" else "l"
            targets = {up_side: -trunk_down, other: lateral[other]}
        else:
            targets = {"l": lateral["l"], "r": lateral["r"]}
        for side, d in targets.items():
            for s in ("upper_arm", "forearm"):
                layers.append(AimLayer(s0, s1, e, joint=carrier(f"{s}_{side}"), reference=chest,
                                       direction=tuple(d), axis=axis(f"{s}_{side}")))
    return EditPlan(name, tuple(layers), s0, s1)


def apply_preset(motion: Motion, flight, name: str, **kw) -> tuple[Motion, EditPlan]:
    """Apply preset ``name`` to the flight; returns ``(edited motion, plan)``."""
    plan = preset_layers(motion, flight, name, **kw)
    return apply_layers(motion, plan.layers), plan
