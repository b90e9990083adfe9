"""Physically exact synthetic motions: the ground truth every method is tested on.

>>> from mocomp import synth
>>> r = synth.backflip()                 # SynthResult: .motion and its ground truth
>>> r.L0, r.flight, r.body.masses        # angular momentum, airborne frames, true masses
>>> r = synth.twist_jump(twist=180, fps=240, mass_factors="tall_performer")
>>> noisy = synth.capture_noise(r.motion, seed=1, joint_jitter_deg=1.0, fps_scale=2.0)

* :mod:`~mocomp.synth.skeleton` -- the 31-joint CMU-named performer, scaled by height;
* :mod:`~mocomp.synth.flights` -- back/front/side somersaults, twist jumps, straight
  jumps: constant angular momentum and an exact COM parabola in flight, planted feet
  on the ground (the physics and what is continuous are documented there);
* :mod:`~mocomp.synth.bodies` -- the true body model and per-segment mass perturbations;
* :mod:`~mocomp.synth.noise` -- capture-noise model (jitter, unit and frame-rate errors);
* :mod:`~mocomp.synth.registry` -- the embedded examples of :mod:`mocomp.datasets`
  (``"backflip"``, ``"frontflip"``, ``"sideflip"``, ``"twist180"``, ``"twist360"``, ``"jump"``).
"""
from .bodies import MASS_PRESETS, SEGMENT_GROUPS, perturb_masses, true_body
from .flights import GENERATORS, backflip, frontflip, sideflip, straight_jump, twist_jump
from .noise import NoisyMotion, capture_noise, position_noise
from .poses import pose
from .result import FlightEvidence, SynthResult
from .skeleton import FOOT_EFFECTORS, JOINT_NAMES, synthetic_skeleton
from . import registry  # noqa: E402  (registers the embedded examples)
from .registry import EXAMPLE_NAMES, make_example

__all__ = [
    "synthetic_skeleton", "JOINT_NAMES", "FOOT_EFFECTORS",
    "backflip", "frontflip", "sideflip", "twist_jump", "straight_jump", "GENERATORS",
    "SynthResult", "FlightEvidence",
    "true_body", "perturb_masses", "MASS_PRESETS", "SEGMENT_GROUPS",
    "capture_noise", "position_noise", "NoisyMotion",
    "pose", "EXAMPLE_NAMES", "make_example", "registry",
]
