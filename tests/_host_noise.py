"""Host-sized floating-point noise for the robustness tests of discrete choices (issue 12, §1):
loop and landing frames (flips), join seams, twist cuts must not move when the input changes
by the ~1e-7 relative differences that BLAS kernels, FMA and thread counts make between hosts."""
from __future__ import annotations

import numpy as np


def perturb(motion, seed, eps=1e-7):
    """``motion`` with root positions and quaternion components scaled by ``1 + eps N(0, 1)``
    (seeded), quaternions renormalised: the size of the differences between hosts."""
    rng = np.random.default_rng(seed)
    rp = np.asarray(motion.root_positions) * (1 + eps * rng.normal(size=motion.root_positions.shape))
    q = np.asarray(motion.rotations) * (1 + eps * rng.normal(size=motion.rotations.shape))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return motion.replace(root_positions=rp, rotations=q)
