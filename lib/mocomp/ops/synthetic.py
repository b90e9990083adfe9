"""A synthetic straight walk with exactly planted feet: the embedded input of the editing
primitives' tests and notebook when no real clip is available (the project's synthetic motions
are flights; they have no gait).

The synthetic performer (:func:`mocomp.synth.synthetic_skeleton`) walks along +z at a constant
speed: the pelvis sways and bobs once per step, the arms swing against the legs, and each foot's
toe joint is fixed on the floor through its stance (heel down, then rising before toe-off) and
moves on a smooth arc through its swing; the legs follow by the synthetic generator's closed-form
leg IK (:func:`mocomp.synth.legs.leg_ik`), so the planted toe joints do not move (to rounding).
It is kinematic, not dynamically exact.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.motion import Motion, SourceInfo
from .easing import ease

__all__ = ["SyntheticWalk", "synthetic_walk"]

_MAX_REACH = 0.9995


@dataclass(frozen=True, eq=False)
class SyntheticWalk:
    """The walk and its ground truth: ``stance`` side -> half-open frame runs in which that foot's
    toe joint is fixed at ``toe_positions[side]`` ``(T, 3)`` (m)."""

    motion: Motion
    stance: dict
    toe_positions: dict
    speed: float
    stride_time: float


@lru_cache(maxsize=8)
def synthetic_walk(duration: float = 4.0, fps: float = 120.0, speed: float = 1.0, height: float = 1.75,
                   stride_time: float = 1.1, stance_fraction: float = 0.6) -> SyntheticWalk:
    """A straight walk of ``duration`` s at ``speed`` m/s (see the module docstring)."""
    from ..synth.legs import leg_chain, leg_ik
    from ..synth.poses import pose
    from ..synth.skeleton import synthetic_skeleton

    sk = synthetic_skeleton(height)
    n = int(round(duration * fps)) + 1
    t = np.arange(n) / fps
    stride = speed * stride_time
    w = 2 * np.pi / stride_time
    root = np.column_stack([0.02 * height / 1.75 * np.sin(w * t), np.full(n, 0.575 * height - 0.06 * height / 1.75)
                            - 0.008 * np.cos(2 * w * t), speed * t])
    yaw = 0.06 * np.sin(w * t)                                     # pelvis rotation with the stride
    root_R = Rotation.from_rotvec(np.column_stack([np.zeros(n), yaw, np.zeros(n)])).as_matrix()
    rv = np.zeros((n, sk.n_joints, 3))
    for i in range(n):                                               # arms swing against the legs
        a = 18.0 * np.sin(w * t[i])
        rv[i] = pose(sk, shoulder_flex=(-a, a), elbow=15.0, twist=-np.degrees(yaw[i]) * 0.8)
    rot = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(n, sk.n_joints, 4)
    rot[:, 0] = Rotation.from_matrix(root_R).as_quat()
    stance, toes = {}, {}
    toe_y = sk.rest_positions()[sk.index("LeftToeBase"), 1]
    for side, phase0, lat in (("left", 0.0, 1.0), ("right", 0.5, -1.0)):
        ch = leg_chain(sk, side)
        ph = (t / stride_time + phase0) % 1.0                       # 0 at heel strike
        k = np.floor(t / stride_time + phase0)                      # stride index of the current stance
        on = ph < stance_fraction
        # toe joint at stride k: ankle 0.25 m ahead of the hip at heel strike, toe 0.08 H ahead of the ankle
        z_strike = lambda kk: speed * (kk - phase0) * stride_time + 0.25 * height / 1.75 + 0.08 * height  # noqa: E731
        x = lat * 0.09 * height / 1.75
        toe = np.column_stack([np.full(n, x), np.full(n, toe_y), z_strike(k)])
        u = np.clip((ph - stance_fraction) / (1.0 - stance_fraction), 0.0, 1.0)
        sw = ~on
        e = ease(u[sw], "smoothstep")
        toe[sw, 2] = z_strike(k[sw]) + e * stride
        toe[sw, 1] = toe_y + 0.05 * np.sin(np.pi * u[sw])
        beta = np.where(on, np.radians(40.0) * ease((ph / stance_fraction - 0.5) / 0.5, "smoothstep"), 0.0)
        beta[sw] = np.radians(40.0) * (1.0 - ease(u[sw] / 0.5, "smoothstep"))
        lp = leg_ik(ch, root, root_R, toe, 0.0, beta, max_reach=_MAX_REACH)
        q = Rotation.from_matrix(lp.R_local.reshape(-1, 3, 3)).as_quat().reshape(n, 4, 4)
        for c, j in enumerate((ch.hip, ch.knee, ch.ankle, ch.toe)):
            rot[:, j] = q[:, c]
        from ..dynamics.contacts import label_intervals

        stance[side] = label_intervals(on)
        toes[side] = toe
    m = Motion(sk, fps, root, rot, SourceInfo(None, "synthetic", notes=(f"synthetic walk {speed:g} m/s",)))
    return SyntheticWalk(m, stance, toes, float(speed), float(stride_time))
