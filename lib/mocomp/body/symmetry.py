"""Left/right symmetric parameterisation of segment masses (flips paper section 4.2:
"we assume perfect symmetry between right and left limbs")."""
from __future__ import annotations

import numpy as np

__all__ = ["symmetric_groups", "expand_symmetric", "reduce_symmetric"]


def symmetric_groups(body) -> list[list[int]]:
    """Segment-index groups that share one mass: ``[i]`` for unpaired segments,
    ``[left, right]`` for pairs, in order of first appearance.

    Pairs are found by the ``_l``/``_r`` suffix of segment names, else by the
    skeleton's mirror map applied to the carrier joints (e.g. DeepMimic bodies).
    """
    names = body.segment_names
    index = {n: i for i, n in enumerate(names)}
    mirror = body.skeleton.mirror_map()
    carrier_to_seg: dict[int, list[int]] = {}
    for i, j in enumerate(body.segment_joint):
        carrier_to_seg.setdefault(int(j), []).append(i)
    partner = {}
    for i, n in enumerate(names):
        k = None
        if n.endswith("_l"):
            k = index.get(n[:-2] + "_r")
        elif n.endswith("_r"):
            k = index.get(n[:-2] + "_l")
        if k is None:
            mj = int(mirror[body.segment_joint[i]])
            if mj != body.segment_joint[i]:
                cands = carrier_to_seg.get(mj, [])
                pos = carrier_to_seg[int(body.segment_joint[i])].index(i)
                if pos < len(cands):
                    k = cands[pos]
        if k is not None and k != i:
            partner[i] = k
    groups, seen = [], set()
    for i in range(len(names)):
        if i in seen:
            continue
        k = partner.get(i)
        if k is not None and partner.get(k) == i:
            groups.append([i, k])
            seen.update((i, k))
        else:
            groups.append([i])
            seen.add(i)
    return groups


def expand_symmetric(groups: list[list[int]], values) -> np.ndarray:
    """Per-group values ``(..., G)`` -> per-segment values ``(..., S)``."""
    values = np.asarray(values, dtype=float)
    S = sum(len(g) for g in groups)
    out = np.empty(values.shape[:-1] + (S,))
    for gi, g in enumerate(groups):
        out[..., g] = values[..., gi : gi + 1]
    return out


def reduce_symmetric(groups: list[list[int]], values) -> np.ndarray:
    """Per-segment values ``(..., S)`` -> per-group means ``(..., G)``."""
    values = np.asarray(values, dtype=float)
    return np.stack([values[..., g].mean(axis=-1) for g in groups], axis=-1)
