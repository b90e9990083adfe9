"""Link sets S1 (unchanged), S2 (rotated), S3 (translated, global orientation kept) and the rigid
rotation of S2 that the ground and flight adjustments apply (touch-up paper, Shin et al. 2003,
sec. 3.1, Fig. 1).

Sets are given by presets or joint names. The presets split the skeleton at joints found from the
body model: ``upper`` is the subtree of the root's child that leads to the head and the arms
(the spine), ``lower`` the rest (root, hips, legs), ``arms`` the subtrees of the joints carrying the
upper-arm segments, ``all`` every joint and ``rest`` every joint not named in another set of the
same step. A joint name stands for its whole subtree.

A rotation ``R`` about a centre ``c`` of S2 moves, on every frame: S2's joints rigidly
(``P' = c + R (P - c)``, ``G' = R G``); every other joint below an S2 joint is carried by the
S2 joint it hangs from (``P' = P + (R - I)(P_a - c)`` with ``a`` the first joint below S2 on its
path) with its global orientation kept -- S3 by definition, and S1 when it hangs below S2
(then the centre is the S1/S2 joint and it does not move); joints above S2 are unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.rotations import quat_inverse, quat_multiply
from ..errors import MocompError

__all__ = ["LinkSets", "LinkSetError", "PRESETS", "body_parts", "link_sets", "rotate_sets"]

PRESETS = ("lower", "upper", "arms", "all", "rest")


class LinkSetError(MocompError, ValueError):
    """A link set names an unknown preset or joint, or the sets overlap."""


def _subtree(parents: np.ndarray, j: int) -> np.ndarray:
    J = parents.shape[0]
    inside = np.zeros(J, bool)
    inside[j] = True
    for k in range(j + 1, J):            # parents precede children in the project's skeletons
        if parents[k] >= 0 and inside[parents[k]]:
            inside[k] = True
    return inside


def body_parts(body) -> dict[str, np.ndarray]:
    """``(J,)`` bool masks of the presets ``lower``, ``upper``, ``arms``, ``all`` for ``body``'s skeleton."""
    sk = body.skeleton
    par = np.asarray(sk.parents)
    J = sk.n_joints
    names = list(body.segment_names)

    def carrier(*cands):
        for c in cands:
            if c in names:
                return int(body.segment_joint[names.index(c)])
        raise LinkSetError(f"body model has no segment {cands[0]!r} (segments: {', '.join(names)}): "
                           "the link-set presets need the upper arms and the head")

    arms = [carrier("upper_arm_l", "upperarm_l"), carrier("upper_arm_r", "upperarm_r")]
    head = carrier("head")
    root = int(np.flatnonzero(par < 0)[0])
    # the root's child on the path to the head: the base of the upper body
    j = head
    while par[j] != root:
        if par[j] < 0:
            raise LinkSetError("the head is not below the root")
        j = int(par[j])
    if j == head:
        raise LinkSetError("the head hangs from the root directly: no spine to split at")
    upper = _subtree(par, j)
    for a in arms:
        if not upper[a]:
            raise LinkSetError(f"arm joint {sk.names[a]!r} is not below the spine joint {sk.names[j]!r}")
    arm_mask = _subtree(par, arms[0]) | _subtree(par, arms[1])
    return {"lower": ~upper, "upper": upper, "arms": arm_mask, "all": np.ones(J, bool)}


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class LinkSets:
    """Per joint its set: ``label`` ``(J,)`` int in {1, 2, 3}; ``spec`` the text it came from.

    Derived: ``anchor`` ``(J,)`` -- for a joint outside S2 that hangs below S2, the first joint
    below S2 on its path (it is carried by that joint's position); ``-1`` elsewhere. ``pivots``:
    the S2 joints whose parent is not in S2 (each S2 component's joint bordering the rest).
    The derived arrays are computed once per instance (read-only: the touch-up loop asks for them
    on every iteration)."""

    label: np.ndarray
    spec: dict
    parents: np.ndarray

    @property
    def s1(self) -> np.ndarray:
        return self.label == 1

    @property
    def s2(self) -> np.ndarray:
        return self.label == 2

    @property
    def s3(self) -> np.ndarray:
        return self.label == 3

    @cached_property
    def pivots(self) -> np.ndarray:
        s2 = self.s2
        par = self.parents
        return _frozen(np.array([j for j in np.flatnonzero(s2) if par[j] < 0 or not s2[par[j]]], int))

    @cached_property
    def component(self) -> np.ndarray:
        """``(J,)``: for S2 joints the pivot of their component, -1 elsewhere."""
        out = np.full(self.label.shape, -1)
        for j in range(out.size):
            if self.label[j] == 2:
                p = self.parents[j]
                out[j] = j if (p < 0 or self.label[p] != 2) else out[p]
        return _frozen(out)

    @cached_property
    def anchor(self) -> np.ndarray:
        out = np.full(self.label.shape, -1)
        for j in range(out.size):
            p = self.parents[j]
            if self.label[j] == 2 or p < 0:
                continue
            if self.label[p] == 2:
                out[j] = j
            elif out[p] >= 0:
                out[j] = out[p]
        return _frozen(out)

    def to_dict(self, names) -> dict:
        return {f"S{k}": [names[j] for j in np.flatnonzero(self.label == k)] for k in (1, 2, 3)} | {"spec": self.spec}


def _mask_of(item, parts: dict, skeleton, field: str) -> np.ndarray:
    items = [item] if isinstance(item, str) else list(item)
    m = np.zeros(skeleton.n_joints, bool)
    for it in items:
        if not isinstance(it, str):
            raise LinkSetError(f"{field}: expected a preset or joint name, got {it!r}")
        if it in parts:
            m |= parts[it]
        elif it in skeleton.names:
            m |= _subtree(np.asarray(skeleton.parents), skeleton.index(it))
        else:
            raise LinkSetError(f"{field}: {it!r} is neither a preset ({', '.join(PRESETS)}) nor a joint of the "
                               f"skeleton")
    return m


def link_sets(body, s1=(), s2=(), s3=(), *, where: str = "link sets") -> LinkSets:
    """S1/S2/S3 from presets or joint names (a name: its subtree; ``"rest"``: every joint not in
    another set). Joints named in no set are S1. A joint in two sets belongs to the more specific
    one (the later of S1 < S3 < S2 for nested subtrees given as presets, e.g. ``s1="rest"``,
    ``s2="arms"``); an empty S2 is an error."""
    sk = body.skeleton
    parts = body_parts(body)
    spec = {"S1": s1, "S2": s2, "S3": s3}
    rest_in = [k for k, v in spec.items() if (v == "rest" or (not isinstance(v, str) and "rest" in list(v)))]
    if len(rest_in) > 1:
        raise LinkSetError(f"{where}: 'rest' may name one set only, got {', '.join(rest_in)}")
    masks = {}
    for k, v in spec.items():
        vv = [x for x in ([v] if isinstance(v, str) else list(v)) if x != "rest"]
        masks[k] = _mask_of(vv, parts, sk, f"{where} {k}")
    label = np.ones(sk.n_joints, int)
    label[masks["S3"]] = 3
    label[masks["S2"]] = 2
    if rest_in:
        named = masks["S2"] | masks["S3"] | masks["S1"]
        label[~named] = {"S1": 1, "S2": 2, "S3": 3}[rest_in[0]]
    if not (label == 2).any():
        raise LinkSetError(f"{where}: S2 (the links to rotate) is empty")
    return LinkSets(label, {k: (v if isinstance(v, str) else list(v)) for k, v in spec.items()},
                    np.asarray(sk.parents))


def rotate_sets(P: np.ndarray, G: np.ndarray, sets: LinkSets, R: np.ndarray, centre: np.ndarray):
    """Global joint positions and orientations after rotating S2 (module docstring).

    ``P`` ``(T, J, 3)``, ``G`` ``(T, J, 4)`` (scalar-last quaternions), ``R`` ``(T, 3, 3)``,
    ``centre`` ``(T, J, 3)``: the rotation centre of each S2 joint's component (only S2 pivots' and
    anchors' entries are read). Returns ``(P', G')``."""
    comp = sets.component
    anchor = sets.anchor
    Pn = np.array(P)
    Gn = np.array(G)
    s2 = np.flatnonzero(comp >= 0)
    c2 = centre[:, comp[s2]]
    Pn[:, s2] = c2 + np.einsum("tij,tsj->tsi", R, P[:, s2] - c2)
    qR = Rotation.from_matrix(R).as_quat()
    Gn[:, s2] = quat_multiply(qR[:, None], G[:, s2])
    carried = np.flatnonzero(anchor >= 0)
    if carried.size:
        a = anchor[carried]
        par_comp = comp[sets.parents[a]]
        ca = centre[:, par_comp]
        w = P[:, a] - ca
        Pn[:, carried] = P[:, carried] + np.einsum("tij,tsj->tsi", R, w) - w
    return Pn, Gn


def local_from_global(G: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """``(T, J, 4)`` local rotations from global ones: ``q_j = G_parent^-1 G_j`` (the root's is global)."""
    par = np.asarray(parents)
    q = np.array(G)
    nz = par >= 0
    q[:, nz] = quat_multiply(quat_inverse(G[:, par[nz]]), G[:, nz])
    return q
