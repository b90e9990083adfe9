"""Small test figures shared by the dataset tests."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from mocomp.core import EndSite, Motion, Skeleton


def small_motion(T: int = 12, fps: float = 120.0, tpose: bool = False, seed: int = 0) -> Motion:
    """A 5-joint figure, 1.7 m tall, moving; frame 0 is a T-pose (identity, root still) if asked."""
    names = ("Hips", "Spine", "Head", "LeftUpLeg", "RightUpLeg")
    off = [[0, 0, 0], [0, 0.3, 0], [0, 0.5, 0], [0.1, -0.1, 0], [-0.1, -0.1, 0]]
    sk = Skeleton(names, [-1, 0, 1, 0, 0], off,
                  end_sites=(EndSite(2, [0, 0.2, 0], "Head_end"), EndSite(3, [0, -0.8, 0], "LFoot"),
                             EndSite(4, [0, -0.8, 0], "RFoot")))
    rng = np.random.default_rng(seed)
    rv = rng.normal(size=(T, 5, 3)) * 0.1
    rv[:, 3, 0] += 0.7  # left leg raised forward by ~40 deg (so no frame looks like a T-pose)
    rot = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(T, 5, 4)
    root = np.column_stack([np.linspace(0, 1, T), np.full(T, 0.95), np.zeros(T)])
    if tpose:
        rot[0] = [0, 0, 0, 1]
        root[1] = root[0]
    return Motion(sk, fps, root, rot)
