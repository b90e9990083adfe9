"""The synthetic performer's true mass distribution, with optional per-segment perturbation.

The body comes from :meth:`mocomp.body.BodyModel.from_skeleton` (a published
table and a solid shape). A perturbation multiplies chosen segment masses by
factors and renormalises to the requested total mass, so the *distribution*
changes while the body weight stays; each segment's inertia is recomputed for
its new mass by :meth:`~mocomp.body.BodyModel.with_masses` (same solid, same
length, density and width/depth ratio: a heavier segment is a thicker one).

The flips paper (section 4.2) and the dissertation (App. C) note that their tall
performer's optimised masses showed "lower weight of limbs and higher weight of
the trunk" than the average table (after Clauser et al. 1969); the preset
``"tall_performer"`` imitates that pattern: trunk x1.10, head x1.00, arms x0.88,
legs x0.92 before renormalisation. Its numbers are illustrative, not measured.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ..body.model import BodyModel
from ..core.skeleton import Skeleton

__all__ = ["MASS_PRESETS", "SEGMENT_GROUPS", "true_body", "perturb_masses"]

#: Group name -> segment names of the body model (de Leva / Dempster segment kinds).
SEGMENT_GROUPS: dict[str, tuple[str, ...]] = {
    "trunk": ("upper_trunk", "middle_trunk", "lower_trunk"),
    "head": ("head",),
    "arms": ("upper_arm_l", "upper_arm_r", "forearm_l", "forearm_r", "hand_l", "hand_r"),
    "legs": ("thigh_l", "thigh_r", "shank_l", "shank_r", "foot_l", "foot_r"),
    "upper_arm": ("upper_arm_l", "upper_arm_r"),
    "forearm": ("forearm_l", "forearm_r"),
    "hand": ("hand_l", "hand_r"),
    "thigh": ("thigh_l", "thigh_r"),
    "shank": ("shank_l", "shank_r"),
    "foot": ("foot_l", "foot_r"),
}

#: Named perturbations: group or segment -> mass factor (before renormalisation).
MASS_PRESETS: dict[str, dict[str, float]] = {
    "tall_performer": {"trunk": 1.10, "head": 1.00, "arms": 0.88, "legs": 0.92},
}


def _factor_vector(body: BodyModel, factors: Mapping[str, float]) -> np.ndarray:
    f = np.ones(body.n_segments)
    names = body.segment_names
    joints = body.skeleton.names
    for key, value in factors.items():
        value = float(value)
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"mass factor for {key!r} must be positive and finite, got {value!r}")
        if key in names:
            idx = [names.index(key)]
        elif key in SEGMENT_GROUPS:
            idx = [names.index(s) for s in SEGMENT_GROUPS[key] if s in names]
        elif key in joints:
            j = joints.index(key)
            idx = [i for i, sj in enumerate(body.segment_joint) if sj == j]
            if not idx:
                raise ValueError(f"joint {key!r} carries no segment (massless joints: {body.massless_joints})")
        else:
            raise ValueError(f"unknown mass-factor key {key!r}: use a segment {names}, a group "
                             f"{sorted(SEGMENT_GROUPS)} or a joint that carries a segment")
        f[idx] *= value
    return f


def perturb_masses(body: BodyModel, factors: Mapping[str, float] | str | None = None, noise: float = 0.0,
                   rng: np.random.Generator | int | None = None) -> BodyModel:
    """A new body with segment masses multiplied by ``factors`` (and optional
    log-normal ``noise``, relative sigma), renormalised to the same total mass.

    ``factors`` keys are segment names, group names (:data:`SEGMENT_GROUPS`) or
    joint names; a string names a preset of :data:`MASS_PRESETS`. Inertias follow
    the new masses with unchanged shapes. The input body is not changed.
    """
    if isinstance(factors, str):
        try:
            factors = MASS_PRESETS[factors]
        except KeyError:
            raise ValueError(f"unknown mass preset {factors!r}; presets: {sorted(MASS_PRESETS)}") from None
    f = _factor_vector(body, factors or {})
    if noise:
        if not (np.isfinite(noise) and noise >= 0):
            raise ValueError(f"mass noise must be >= 0, got {noise!r}")
        if rng is None:
            raise ValueError("mass noise needs an explicit seed or numpy Generator (rng=...)")
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        f = f * np.exp(gen.normal(0.0, noise, body.n_segments))
    if np.allclose(f, 1.0, rtol=0, atol=0):
        return body
    m = body.masses * f
    m *= body.total_mass / m.sum()
    return body.with_masses(m)


def true_body(skeleton: Skeleton, total_mass: float = 70.0, table: str = "de_leva_male",
              shape: str = "ellipsoid", mass_factors: Mapping[str, float] | str | None = None,
              mass_noise: float = 0.0, rng: np.random.Generator | int | None = None) -> BodyModel:
    """The generator's body: ``BodyModel.from_skeleton`` then :func:`perturb_masses`."""
    if not (np.isfinite(total_mass) and total_mass > 0):
        raise ValueError(f"total_mass must be positive, got {total_mass!r}")
    body = BodyModel.from_skeleton(skeleton, total_mass=total_mass, table=table, shape=shape)
    return perturb_masses(body, mass_factors, mass_noise, rng)
