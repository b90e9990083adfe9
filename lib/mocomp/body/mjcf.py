"""Export a skeleton + :class:`~mocomp.body.BodyModel` to MuJoCo's MJCF.

One MuJoCo body per skeleton joint, at the joint's offset in its parent's frame
(rest-pose frames are aligned, so MuJoCo body frames equal our joint frames);
the root has a free joint, every other joint a ball joint. Each body's
``<inertial>`` is the combination of the segments that joint carries (total
mass, mass-weighted COM, inertias moved to that COM by the parallel-axis
theorem) -- the same masses, COMs and inertias as the body model. MuJoCo
refuses moving bodies without mass, so joints that carry nothing get
``massless_mass`` kg (default 1e-9) and a matching tiny inertia; at 70 kg this
changes COM and momentum by ~1e-11 relative.

The world is y-up like ours: ``<option gravity="0 -9.81 0"/>``. Visual geoms
(the ellipsoids/boxes behind the inertias) have no contacts and no mass.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["to_mjcf", "joint_inertials", "mjcf_names"]


def _fmt(v) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(v))


def mjcf_names(skeleton) -> list[str]:
    """MuJoCo-safe unique body names for the skeleton's joints (same order)."""
    out, seen = [], set()
    for n in skeleton.names:
        s = re.sub(r"[^A-Za-z0-9_.:-]", "_", n) or "joint"
        base, k = s, 1
        while s in seen:
            k += 1
            s = f"{base}_{k}"
        seen.add(s)
        out.append(s)
    return out


def joint_inertials(body) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per skeleton joint: ``mass (J,)``, ``com (J, 3)`` in the joint frame and
    ``inertia (J, 3, 3)`` about that COM, combining the segments it carries."""
    J = body.skeleton.n_joints
    mass = np.zeros(J)
    mc = np.zeros((J, 3))
    np.add.at(mass, body.segment_joint, body.masses)
    np.add.at(mc, body.segment_joint, body.masses[:, None] * body.local_coms)
    com = np.divide(mc, mass[:, None], out=np.zeros_like(mc), where=mass[:, None] > 0)
    inertia = np.zeros((J, 3, 3))
    for i, j in enumerate(body.segment_joint):
        r = body.local_coms[i] - com[j]
        inertia[j] += body.inertias[i] + body.masses[i] * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    return mass, com, inertia


def to_mjcf(body, model_name: str = "mocomp", geoms: bool = True, g: float = 9.81,
            massless_mass: float = 1e-9, timestep: float = 1.0 / 600.0) -> str:
    """MJCF XML string for ``body`` (free root, ball joints, the model's masses/COMs/inertias).

    Body names come from :func:`mjcf_names` (the joint names, made XML/MuJoCo safe);
    the free joint is ``root_free``, ball joints are ``<body>_ball``. Load it with
    ``mujoco.MjModel.from_xml_string``.
    """
    sk = body.skeleton
    names = mjcf_names(sk)
    mass, com, inertia = joint_inertials(body)
    root = ET.Element("mujoco", model=model_name)
    ET.SubElement(root, "compiler", inertiafromgeom="false", angle="radian", autolimits="true")
    ET.SubElement(root, "option", gravity=f"0 {-g!r} 0", timestep=repr(float(timestep)))
    wb = ET.SubElement(root, "worldbody")
    elems = {}
    seg_by_joint: dict[int, list[int]] = {}
    for i, j in enumerate(body.segment_joint):
        seg_by_joint.setdefault(int(j), []).append(i)
    geom_dims = None
    geom_kinds = None
    if geoms and body.geometry is not None:
        geom_dims = body.geometry.dimensions(body.masses)
        geom_kinds = body.geometry.kinds
    for j in range(sk.n_joints):
        p = int(sk.parents[j])
        parent = wb if p < 0 else elems[p]
        pos = np.zeros(3) if p < 0 else sk.offsets[j]
        b = ET.SubElement(parent, "body", name=names[j], pos=_fmt(pos))
        elems[j] = b
        if p < 0:
            ET.SubElement(b, "freejoint", name="root_free")
        else:
            ET.SubElement(b, "joint", name=f"{names[j]}_ball", type="ball")
        if mass[j] > 0:
            I = inertia[j]
            full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
            ET.SubElement(b, "inertial", pos=_fmt(com[j]), mass=repr(float(mass[j])), fullinertia=_fmt(full))
        else:
            d = massless_mass * 1e-2
            ET.SubElement(b, "inertial", pos="0 0 0", mass=repr(float(massless_mass)), diaginertia=_fmt([d, d, d]))
        if geom_dims is not None:
            for i in seg_by_joint.get(j, []):
                kind = geom_kinds[i]
                if kind not in ("ellipsoid", "cuboid"):
                    continue
                q = Rotation.from_matrix(body.geometry.axes[i]).as_quat()
                size = geom_dims[i] if kind == "ellipsoid" else geom_dims[i] / 2.0
                ET.SubElement(b, "geom", name=f"{body.segment_names[i]}_geom",
                              type="ellipsoid" if kind == "ellipsoid" else "box", size=_fmt(size),
                              pos=_fmt(body.local_coms[i]), quat=_fmt([q[3], q[0], q[1], q[2]]),
                              contype="0", conaffinity="0", mass="0", rgba="0.55 0.6 0.7 1")
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")
