"""Hand-made motions for the flips unit tests (core only; no physics engine needed)."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from mocomp.core import EndSite, Motion, Skeleton

NAMES = ("Hips", "LowerBack", "Spine", "Head", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg",
         "RightFoot", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm", "RightHand")
PARENTS = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 2, 10, 11, 2, 13, 14)
OFFSETS = ((0, 1.0, 0), (0, 0.1, 0), (0, 0.25, 0), (0, 0.25, 0), (0.1, -0.05, 0), (0, -0.42, 0), (0, -0.42, 0),
           (-0.1, -0.05, 0), (0, -0.42, 0), (0, -0.42, 0), (0.18, 0.2, 0), (0.28, 0, 0), (0.25, 0, 0),
           (-0.18, 0.2, 0), (-0.28, 0, 0), (-0.25, 0, 0))


ENDS = ((3, (0, 0.2, 0), "Head/end"), (6, (0, -0.05, 0.15), "LeftFoot/end"), (9, (0, -0.05, 0.15), "RightFoot/end"),
        (12, (0.15, 0, 0), "LeftHand/end"), (15, (-0.15, 0, 0), "RightHand/end"))


def skeleton() -> Skeleton:
    return Skeleton(NAMES, np.array(PARENTS), np.array(OFFSETS, dtype=float),
                    end_sites=tuple(EndSite(p, np.array(o, dtype=float), n) for p, o, n in ENDS))


def rot_x(angle) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    return Rotation.from_rotvec(np.stack([angle, 0 * angle, 0 * angle], axis=-1)).as_quat()


def spinning_motion(T: int = 200, fps: float = 120.0, flight=(40, 160), rate: float = 2 * np.pi * 1.2,
                    period: int = 24, amplitude: float = 0.3, seed: int = 0, ramp: int = 20) -> Motion:
    """Root turning about world +x at ``rate`` rad/s (ramping in/out over ``ramp`` frames
    around the flight) with joint angles that are exactly periodic (``period`` frames)
    inside the flight and a tucked pose; the root height is arbitrary (no physics)."""
    rng = np.random.default_rng(seed)
    sk = skeleton()
    J = sk.n_joints
    t = np.arange(T)
    s, e = flight
    # rotation rate: 0 outside, smooth ramps, constant in [s, e)
    w = np.zeros(T)
    w[s:e] = 1.0
    up = np.arange(ramp) / ramp
    w[s - ramp:s] = 0.5 - 0.5 * np.cos(np.pi * up)
    w[e:e + ramp] = 0.5 + 0.5 * np.cos(np.pi * up)
    theta = np.concatenate([[0.0], np.cumsum(w[:-1])]) * rate / fps
    rot = np.zeros((T, J, 4))
    rot[..., 3] = 1.0
    rot[:, 0] = rot_x(theta)
    axes = rng.normal(size=(J, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    phase = rng.uniform(0, 2 * np.pi, size=J)
    tuck = np.zeros(J)
    tuck[[4, 7]] = -1.6          # thighs up
    tuck[[5, 8]] = 2.0           # knees bent
    blend = np.clip(w, 0, 1)
    for j in range(1, J):
        wig = amplitude * np.sin(2 * np.pi * t / period + phase[j])
        ang = blend * tuck[j] + wig
        rv = np.zeros((T, 3))
        if tuck[j] != 0:
            rv[:, 0] = blend * tuck[j]
            rv += wig[:, None] * axes[j]
        else:
            rv = ang[:, None] * axes[j]
        rot[:, j] = Rotation.from_rotvec(rv).as_quat()
    root = np.zeros((T, 3))
    root[:, 1] = 1.0
    return Motion(sk, fps, root, rot)


def synthetic(name: str, **params):
    """A synthetic example's full result (``.motion``, ``.body``, ``.flight``, ``.L0``): the
    registered embedded example when no parameters are given, else the generator."""
    from mocomp import datasets
    from mocomp.errors import DataNotFoundError

    if not params:
        try:
            return datasets.load_example(name)
        except DataNotFoundError:
            pass
    from mocomp.synth import flights

    return getattr(flights, name)(**params)
