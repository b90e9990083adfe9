"""The ASE humanoid's own body model (NVIDIA ASE / AMP, sword-and-shield variant).

The Reallusion sword-and-shield clips of ASE (Peng et al., "ASE: Large-scale
reusable adversarial skill embeddings for physically simulated characters",
ACM TOG 41(4), 2022) are retargeted to one 17-body humanoid whose MuJoCo model is
``ase/data/assets/mjcf/amp_humanoid_sword_shield.xml`` (staged in the data
directory as ``skeletons/ase_amp_humanoid_sword_shield.xml``). Its bodies are the
skeleton joints ``pelvis, torso, head, right_upper_arm, right_lower_arm,
right_hand, sword, left_upper_arm, left_lower_arm, shield, left_hand,
right_thigh, right_shin, right_foot, left_thigh, left_shin, left_foot``.

MuJoCo derives each body's mass, centre of mass and inertia from its geoms
(spheres, capsules, boxes, a cylinder) at the densities the file gives. This
module carries those geoms (:data:`ASE_GEOMS`, transcribed from the MJCF) and
computes the same inertials with MuJoCo's solid formulas (``mjCGeom::SetInertia``:
sphere ``I = 2/5 m r^2``; capsule = cylinder + two hemispheres,
``I_perp = m_cyl (3 r^2 + h^2)/12 + m_sph (2 r^2/5 + h^2/4 + 3 h r/8)``,
``I_axis = m_cyl r^2/2 + m_sph 2 r^2/5``; box ``I = m/3 (b^2 + c^2)`` with half
sizes; cylinder ``I_perp = m (3 r^2 + h^2)/12``, ``I_axis = m r^2/2``), combined per
body by the parallel-axis theorem. Body masses: pelvis 10.0, torso 12.0, head
3.9, thighs 4.5, shins 3.0, feet 1.0, upper arms 1.5, forearms 1.0, hands 0.5 kg
(48.9 kg without props) and the props sword 0.7 and shield 2.1 kg (51.7 kg in all);
``tests/test_body_ase.py`` checks every number against MuJoCo reading the XML.

Frames: the MJCF is Z-up with x forward; the derived BVH clips are Y-up with x
forward, ``v_bvh = M v_mjcf`` with ``M = [[1,0,0],[0,0,1],[0,-1,0]]`` (the
conversion the data MANIFEST describes), so MJCF body frames are the BVH joint
frames rotated by ``M`` and inertias transform as ``M I M^T``.

Two ways to use it:

* ``BodyModel.from_skeleton(skeleton, total_mass, props="ase")``: the body from an
  anthropometric table (as for every convention) plus the sword and shield with
  ASE's prop masses (:func:`prop_segments`); the default ``props="massless"`` lists
  the prop joints in ``massless_joints``.
* :func:`ase_body`: ASE's own 17 (or 15, props massless) rigid bodies as a ``"given"``
  :class:`~mocomp.body.BodyModel` -- the model ASE's simulation uses.
"""
from __future__ import annotations

import numpy as np

from ..core.skeleton import Skeleton
from ..errors import MotionFormatError

__all__ = ["ASE_GEOMS", "ASE_BODY_POS", "ASE_PROPS", "MJCF_TO_BVH", "geom_inertial", "body_inertials",
           "prop_segments", "ase_body", "PROP_OPTIONS"]

#: the rotation from ASE's MJCF frame (Z-up) to the derived BVH frame (Y-up): v_bvh = M v_mjcf
MJCF_TO_BVH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

#: the prop joints of the sword-and-shield humanoid
ASE_PROPS = ("sword", "shield")

#: accepted values of the ``props`` option
PROP_OPTIONS = ("massless", "ase")

#: body -> geoms in the body's MJCF frame (metres, kg/m^3), from amp_humanoid_sword_shield.xml:
#: ("sphere", pos, r, rho), ("capsule", from, to, r, rho), ("box", pos, half_sizes, rho),
#: ("cylinder", from, to, r, rho)
ASE_GEOMS: dict[str, tuple] = {
    "pelvis": (("sphere", (0, 0, 0.07), 0.09, 2226.0), ("sphere", (0, 0, 0.205), 0.07, 2226.0)),
    "torso": (("sphere", (0, 0, 0.12), 0.11, 1794.0),
              ("capsule", (-0.0060125, -0.0457775, 0.2287955), (-0.016835, -0.128177, 0.2376182), 0.045, 1100.0),
              ("capsule", (-0.0060125, 0.0457775, 0.2287955), (-0.016835, 0.128177, 0.2376182), 0.045, 1100.0)),
    "head": (("sphere", (0, 0, 0.175), 0.095, 1081.0),),
    "right_upper_arm": (("capsule", (0, 0, -0.05), (0, 0, -0.23), 0.045, 982.0),),
    "right_lower_arm": (("capsule", (0, 0, -0.0525), (0, 0, -0.1875), 0.04, 1056.0),),
    "right_hand": (("sphere", (0, 0, 0), 0.04, 1865.0),),
    "sword": (("capsule", (-0.87, 0, 0), (-0.64, 0, 0), 0.023, 300.0),
              ("box", (-0.34, 0, 0), (0.34, 0.01, 0.035), 600.0)),
    "left_upper_arm": (("capsule", (0, 0, -0.05), (0, 0, -0.23), 0.045, 982.0),),
    "left_lower_arm": (("capsule", (0, 0, -0.0525), (0, 0, -0.1875), 0.04, 1056.0),),
    "shield": (("cylinder", (0, 0, 0), (0, 0.03, 0), 0.3, 250.0),),
    "left_hand": (("sphere", (0, 0, 0), 0.04, 1865.0),),
    "right_thigh": (("capsule", (0, 0, -0.06), (0, 0, -0.36), 0.055, 1269.0),),
    "right_shin": (("capsule", (0, 0, -0.045), (0, 0, -0.355), 0.05, 1014.0),),
    "right_foot": (("box", (0.045, 0, -0.0225), (0.0885, 0.045, 0.0275), 1141.0),),
    "left_thigh": (("capsule", (0, 0, -0.06), (0, 0, -0.36), 0.055, 1269.0),),
    "left_shin": (("capsule", (0, 0, -0.045), (0, 0, -0.355), 0.05, 1014.0),),
    "left_foot": (("box", (0.045, 0, -0.0225), (0.0885, 0.045, 0.0275), 1141.0),),
}

#: body -> (parent, pos in the parent's MJCF frame), from the same file (the pelvis' own pos is the free root)
ASE_BODY_POS: dict[str, tuple[str | None, tuple[float, float, float]]] = {
    "pelvis": (None, (0.0, 0.0, 0.0)),
    "torso": ("pelvis", (0.0, 0.0, 0.236151)),
    "head": ("torso", (0.0, 0.0, 0.223894)),
    "right_upper_arm": ("torso", (-0.02405, -0.18311, 0.24350)),
    "right_lower_arm": ("right_upper_arm", (0.0, 0.0, -0.274788)),
    "right_hand": ("right_lower_arm", (0.0, 0.0, -0.258947)),
    "sword": ("right_hand", (0.74, 0.0, 0.0)),
    "left_upper_arm": ("torso", (-0.02405, 0.18311, 0.24350)),
    "left_lower_arm": ("left_upper_arm", (0.0, 0.0, -0.274788)),
    "shield": ("left_lower_arm", (0.0, 0.07, -0.12)),
    "left_hand": ("left_lower_arm", (0.0, 0.0, -0.258947)),
    "right_thigh": ("pelvis", (0.0, -0.084887, 0.0)),
    "right_shin": ("right_thigh", (0.0, 0.0, -0.421546)),
    "right_foot": ("right_shin", (0.0, 0.0, -0.409870)),
    "left_thigh": ("pelvis", (0.0, 0.084887, 0.0)),
    "left_shin": ("left_thigh", (0.0, 0.0, -0.421546)),
    "left_foot": ("left_shin", (0.0, 0.0, -0.409870)),
}


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation whose third column is the unit ``axis``."""
    z = axis / np.linalg.norm(axis)
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(ref, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def geom_inertial(geom: tuple) -> tuple[float, np.ndarray, np.ndarray]:
    """``(mass kg, com (3,), inertia about the com (3, 3))`` of one :data:`ASE_GEOMS` entry,
    in its body's MJCF frame, by MuJoCo's formulas (see the module docstring)."""
    kind = geom[0]
    if kind == "sphere":
        _, pos, r, rho = geom
        m = rho * 4.0 / 3.0 * np.pi * r ** 3
        return m, np.asarray(pos, dtype=float), np.eye(3) * (0.4 * m * r * r)
    if kind == "box":
        _, pos, half, rho = geom
        a, b, c = half
        m = rho * 8.0 * a * b * c
        return m, np.asarray(pos, dtype=float), np.diag([m / 3 * (b * b + c * c), m / 3 * (a * a + c * c),
                                                          m / 3 * (a * a + b * b)])
    if kind in ("capsule", "cylinder"):
        _, p0, p1, r, rho = geom
        p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
        h = float(np.linalg.norm(p1 - p0))
        m_cyl = rho * np.pi * r * r * h
        if kind == "cylinder":
            m, perp, ax = m_cyl, m_cyl * (3 * r * r + h * h) / 12.0, m_cyl * r * r / 2.0
        else:
            m_sph = rho * 4.0 / 3.0 * np.pi * r ** 3
            m = m_cyl + m_sph
            perp = m_cyl * (3 * r * r + h * h) / 12.0 + m_sph * (0.4 * r * r + 0.25 * h * h + 0.375 * h * r)
            ax = m_cyl * r * r / 2.0 + m_sph * 0.4 * r * r
        R = _axis_frame(p1 - p0)
        return m, 0.5 * (p0 + p1), R @ np.diag([perp, perp, ax]) @ R.T
    raise ValueError(f"unknown geom kind {kind!r}")


def body_inertials(frame: str = "bvh") -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """body -> ``(mass, com (3,), inertia about the com (3, 3))`` of every ASE body, combining its
    geoms (parallel-axis theorem), in the body's frame: ``"bvh"`` (Y-up joint frames of the
    derived clips, default) or ``"mjcf"`` (the MJCF's Z-up body frames)."""
    if frame not in ("bvh", "mjcf"):
        raise ValueError(f"frame must be 'bvh' or 'mjcf', got {frame!r}")
    out = {}
    for body, geoms in ASE_GEOMS.items():
        parts = [geom_inertial(g) for g in geoms]
        m = sum(p[0] for p in parts)
        c = sum(p[0] * p[1] for p in parts) / m
        inertia = np.zeros((3, 3))
        for mi, ci, Ii in parts:
            d = ci - c
            inertia += Ii + mi * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
        if frame == "bvh":
            c, inertia = MJCF_TO_BVH @ c, MJCF_TO_BVH @ inertia @ MJCF_TO_BVH.T
        out[body] = (float(m), c, inertia)
    return out


def _check_skeleton(skeleton: Skeleton, bodies, tol: float = 1e-3) -> None:
    """The skeleton must be ASE's (joint names, parents, offsets in metres) for its bodies to apply."""
    for b in bodies:
        j = skeleton.find(b)
        if j is None:
            raise MotionFormatError(f"the ASE body model needs joint {b!r}, which this skeleton lacks; "
                                    f"joints: {list(skeleton.names)}")
        parent, pos = ASE_BODY_POS[b]
        if parent is None:
            continue
        p = int(skeleton.parents[j])
        if p < 0 or skeleton.names[p] != parent:
            got = "none" if p < 0 else repr(skeleton.names[p])
            raise MotionFormatError(f"ASE body model: joint {b!r} hangs from {got}, ASE's from {parent!r}")
        want = MJCF_TO_BVH @ np.asarray(pos)
        if np.linalg.norm(skeleton.offsets[j] - want) > tol:
            raise MotionFormatError(
                f"ASE body model: joint {b!r} has offset {np.round(skeleton.offsets[j], 5).tolist()} m, ASE's is "
                f"{np.round(want, 5).tolist()} m (Y-up metres); this is not ASE's humanoid or not in metres")


def _check_props(props: str) -> None:
    if props not in PROP_OPTIONS:
        raise ValueError(f"props must be one of {PROP_OPTIONS} ('massless': the sword and shield carry no mass; "
                         f"'ase': ASE's MJCF masses sword 0.7 kg, shield 2.1 kg), got {props!r}")


def prop_segments(skeleton: Skeleton) -> list[tuple[str, int, float, np.ndarray, np.ndarray]]:
    """``(name, joint index, mass, local com, inertia)`` of the sword and shield with ASE's MJCF
    masses, COMs and inertias (in the joint frames of the derived BVH), for ``props="ase"``."""
    _check_skeleton(skeleton, ASE_PROPS)
    inert = body_inertials("bvh")
    return [(b, skeleton.find(b), *inert[b]) for b in ASE_PROPS]


def ase_body(skeleton: Skeleton, props: str = "massless"):
    """ASE's own rigid bodies as a ``"given"`` :class:`~mocomp.body.BodyModel`: one segment per
    body, named after it, with the MJCF's masses, COMs and inertias (see the module docstring).

    ``props="massless"`` (default) leaves the sword and shield out (listed in
    ``massless_joints``; 48.9 kg); ``props="ase"`` includes them (51.7 kg). The
    skeleton must be ASE's humanoid in metres (joint names, parents and offsets
    are checked to 1 mm); otherwise :class:`~mocomp.errors.MotionFormatError`.
    """
    from .inertia import SegmentGeometry
    from .model import BodyModel

    _check_props(props)
    names = [b for b in ASE_GEOMS if props == "ase" or b not in ASE_PROPS]
    _check_skeleton(skeleton, names)
    inert = body_inertials("bvh")
    S = len(names)
    masses = np.array([inert[b][0] for b in names])
    inertias = np.array([inert[b][2] for b in names])
    geom = SegmentGeometry(("given",) * S, np.full(S, np.nan), np.full(S, np.nan), np.full(S, np.nan),
                           np.broadcast_to(np.eye(3), (S, 3, 3)).copy(), np.full((S, 3), np.nan))
    used = set(names)
    return BodyModel(
        skeleton=skeleton,
        segment_names=tuple(names),
        segment_joint=np.array([skeleton.find(b) for b in names]),
        masses=masses,
        local_coms=np.array([inert[b][1] for b in names]),
        inertias=inertias,
        massless_joints=tuple(n for n in skeleton.names if n not in used),
        table="ASE humanoid MJCF (nv-tlabs/ASE amp_humanoid_sword_shield.xml; Peng et al. 2022)",
        shape="given",
        geometry=geom,
        notes=("masses, COMs and inertias from the MJCF geoms and densities (MuJoCo's solid formulas)",
               "props: sword 0.7 kg and shield 2.1 kg included" if props == "ase" else
               "props: sword and shield massless"),
    )
