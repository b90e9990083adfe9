"""Build a :class:`~mocomp.body.BodyModel` from a skeleton, a parameter table and a shape."""
from __future__ import annotations

import numpy as np

from ..core.skeleton import Skeleton
from ..errors import MotionFormatError
from .inertia import SegmentGeometry, geometry_inertias, segment_axes
from .mapping import resolve_landmark, resolve_mapping
from .tables import ELLIPSOID_DENSITY, SEGMENT_KINDS, SHAPE_DENSITY_RATIO, get_table

__all__ = ["build_from_table", "body_directions", "SHAPES", "DENSITY_SOURCES", "DEFAULT_DENSITIES", "density_of"]

SHAPES = ("ellipsoid", "cuboid", "gyration")
#: density sources of the solids, and each shape's default (see :mod:`mocomp.body.tables`)
DENSITY_SOURCES = ("table_c1", "winter")
DEFAULT_DENSITIES = {"ellipsoid": "winter", "cuboid": "table_c1"}


def _kind(seg: str) -> str:
    return seg[:-2] if seg.endswith(("_l", "_r")) and seg[:-2] in SEGMENT_KINDS else seg


def body_directions(skeleton: Skeleton, resolved) -> tuple[np.ndarray, np.ndarray]:
    """The body's ``(forward, up)`` unit vectors in the rest pose, from its landmarks.

    up = MIDH -> CERV (trunk axis); left = right hip -> left hip; forward = left x up
    (y-up, right-handed: a body facing +z has its left at +x).
    """
    rest = skeleton.rest_positions()
    lm = resolved.convention.landmarks
    get = lambda k: resolve_landmark(skeleton, lm[k], lm, rest)  # noqa: E731
    up = get("CERV") - get("MIDH")
    left = get("HJC_l") - get("HJC_r")
    up = up / np.linalg.norm(up)
    left = left - np.dot(left, up) * up
    if np.linalg.norm(left) < 1e-9:
        raise MotionFormatError("cannot tell left from right: hip joints coincide in the rest pose")
    left /= np.linalg.norm(left)
    return np.cross(left, up), up


def density_of(kind: str, source: str) -> float:
    """Density kg/m^3 of segment ``kind`` from ``source`` (``"table_c1"`` or ``"winter"``)."""
    if source == "table_c1":
        return SHAPE_DENSITY_RATIO[kind][0]
    if source == "winter":
        return ELLIPSOID_DENSITY[kind]
    raise ValueError(f"unknown density source {source!r}; choose one of {DENSITY_SOURCES}")


def build_from_table(cls, skeleton: Skeleton, total_mass: float, table, shape: str, mapping,
                     densities: str | None = None, props: str = "massless"):
    if not (np.isfinite(total_mass) and total_mass > 0):
        raise ValueError(f"total_mass must be a positive number of kilograms, got {total_mass!r}")
    if shape not in SHAPES:
        raise ValueError(f"unknown shape {shape!r}; choose one of {SHAPES}")
    if densities is not None and densities not in DENSITY_SOURCES:
        raise ValueError(f"unknown density source {densities!r}; choose one of {DENSITY_SOURCES}")
    from .ase import _check_props

    _check_props(props)
    t = get_table(table)
    rm = resolve_mapping(skeleton, mapping)
    rest = skeleton.rest_positions()
    segs = rm.segments
    kinds = [_kind(s) for s in segs]
    rows = t.rows(kinds)
    frac = np.array([r.mass_fraction for r in rows])
    fsum = frac.sum()
    masses = total_mass * frac / fsum
    vec = rm.distal - rm.proximal
    lengths = np.linalg.norm(vec, axis=1)
    cf = np.array([r.com_fraction for r in rows])
    com_world = rm.proximal + cf[:, None] * vec
    local_coms = com_world - rest[rm.carriers]

    forward, up = body_directions(skeleton, rm)
    axes = segment_axes(vec, forward, up, np.array([k == "foot" for k in kinds]))
    S = len(segs)
    dens = np.full(S, np.nan)
    ratio = np.full(S, np.nan)
    gyr = np.full((S, 3), np.nan)
    source = None
    if shape in ("cuboid", "ellipsoid"):
        source = densities or DEFAULT_DENSITIES[shape]
        dens[:] = [density_of(k, source) for k in kinds]
        ratio[:] = [SHAPE_DENSITY_RATIO[k][1] for k in kinds]
    else:
        for i, r in enumerate(rows):
            g = r.gyration
            if g is None or any(x is None for x in g):
                raise ValueError(f"table {t.key!r} gives no complete radii of gyration for {r.kind!r}; "
                                 "use shape='ellipsoid' or 'cuboid'")
            sag, trans, lon = g
            # de Leva: sagittal axis = antero-posterior (our depth axis), transverse = medio-lateral (width)
            gyr[i] = (lon, trans, sag)
    geom = SegmentGeometry(tuple([shape] * S), lengths, dens, ratio, axes, gyr)
    inertias = geometry_inertias(geom, masses)
    notes = [f"mapping: {rm.convention.name}", *rm.convention.notes]
    if source is not None:
        notes.append(f"densities: {'dissertation Table C.1' if source == 'table_c1' else 'Winter Table 4.1'}; "
                     "width/depth ratios: dissertation Table C.1")
    if abs(fsum - 1.0) > 1e-12:
        notes.append(f"table mass fractions sum to {fsum:.6f}; normalised to 1")
    carriers, massless = rm.carriers, rm.massless_joints
    if props == "ase":
        # the sword and shield of ASE's humanoid, with ASE's MJCF masses, on top of total_mass
        from .ase import prop_segments

        extra = prop_segments(skeleton)
        segs = tuple(segs) + tuple(e[0] for e in extra)
        carriers = np.concatenate([carriers, [e[1] for e in extra]])
        masses = np.concatenate([masses, [e[2] for e in extra]])
        local_coms = np.concatenate([local_coms, [e[3] for e in extra]])
        inertias = np.concatenate([inertias, [e[4] for e in extra]])
        n = len(extra)
        geom = SegmentGeometry(geom.kinds + ("given",) * n, np.concatenate([geom.lengths, np.full(n, np.nan)]),
                               np.concatenate([geom.densities, np.full(n, np.nan)]),
                               np.concatenate([geom.ratios, np.full(n, np.nan)]),
                               np.concatenate([geom.axes, np.broadcast_to(np.eye(3), (n, 3, 3))]),
                               np.concatenate([geom.gyration, np.full((n, 3), np.nan)]))
        massless = tuple(j for j in massless if j not in {e[0] for e in extra})
        notes.append("props: " + ", ".join(f"{e[0]} {e[2]:.3f} kg" for e in extra) + " from ASE's MJCF geoms, "
                     f"added to the body's {total_mass:g} kg (mocomp.body.ase)")
    elif any(p in massless for p in ("sword", "shield")) and rm.convention.name == "ase":
        notes.append("props: sword and shield massless (props='ase' gives them ASE's MJCF masses)")
    return cls(
        skeleton=skeleton,
        segment_names=segs,
        segment_joint=carriers,
        masses=masses,
        local_coms=local_coms,
        inertias=inertias,
        massless_joints=massless,
        table=t.citation,
        shape=shape,
        geometry=geom,
        notes=tuple(notes),
    )
