"""Segment inertia tensors from simple solids.

* Constant-density **ellipsoid** (flips paper section 4.2, after Liu, Hertzmann &
  Popovic 2005): semi-axes ``a`` (along the segment), ``b`` (width), ``c``
  (depth); ``I = m/5 (b^2 + c^2, a^2 + c^2, a^2 + b^2)`` about (long, width, depth).
* **Solid cuboid** (dissertation eq. 5.3): edge lengths ``l, w, d``;
  ``I = m/12 (w^2 + d^2, l^2 + d^2, l^2 + w^2)``.
* **Radii of gyration** from a table (``I = m (r L)^2`` per axis).

Cross-sections: the segment length ``l`` comes from the skeleton; the volume from
mass and density (``V = m / rho``); width/depth stay in the ratio of dissertation
Table C.1. For the ellipsoid ``a = l/2`` and ``(4/3) pi a b c = V``; for the
cuboid ``l w d = V``. The solid is centred on the segment COM.

The principal axes of each segment, in its carrier joint's frame, are the
columns of ``axes``: the long axis (proximal -> distal landmark), the width axis
(medio-lateral for most segments) and the depth axis (the body's forward
direction; for the foot the body's up direction, since a foot's thickness is
vertical).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "ellipsoid_moments",
    "cuboid_moments",
    "ellipsoid_semi_axes",
    "cuboid_edges",
    "rotate_inertia",
    "SegmentGeometry",
    "geometry_inertias",
    "inertia_for_masses",
    "segment_axes",
]


def ellipsoid_moments(mass, semi_axes) -> np.ndarray:
    """Principal moments ``(..., 3)`` of a solid ellipsoid of ``mass`` (kg) and ``semi_axes`` ``(..., 3)`` (m)."""
    m = np.asarray(mass, dtype=float)[..., None]
    a2 = np.asarray(semi_axes, dtype=float) ** 2
    return m / 5.0 * np.stack([a2[..., 1] + a2[..., 2], a2[..., 0] + a2[..., 2], a2[..., 0] + a2[..., 1]], axis=-1)


def cuboid_moments(mass, edges) -> np.ndarray:
    """Principal moments ``(..., 3)`` of a solid cuboid with edge lengths ``(l, w, d)`` (dissertation eq. 5.3)."""
    m = np.asarray(mass, dtype=float)[..., None]
    e2 = np.asarray(edges, dtype=float) ** 2
    return m / 12.0 * np.stack([e2[..., 1] + e2[..., 2], e2[..., 0] + e2[..., 2], e2[..., 0] + e2[..., 1]], axis=-1)


def ellipsoid_semi_axes(mass, length, density, ratio) -> np.ndarray:
    """Semi-axes ``(..., 3)``: ``a = length/2`` and ``b/c = ratio`` with volume ``mass/density``."""
    m, L, rho, r = (np.asarray(x, dtype=float) for x in (mass, length, density, ratio))
    a = L / 2.0
    bc = 3.0 * (m / rho) / (4.0 * np.pi * a)
    c = np.sqrt(bc / r)
    return np.stack(np.broadcast_arrays(a, r * c, c), axis=-1)


def cuboid_edges(mass, length, density, ratio) -> np.ndarray:
    """Edges ``(l, w, d)`` ``(..., 3)`` with ``w/d = ratio`` and ``l w d = mass/density``."""
    m, L, rho, r = (np.asarray(x, dtype=float) for x in (mass, length, density, ratio))
    d = np.sqrt((m / rho) / (L * r))
    return np.stack(np.broadcast_arrays(L, r * d, d), axis=-1)


def rotate_inertia(moments, axes) -> np.ndarray:
    """``axes @ diag(moments) @ axes^T`` for stacks: moments ``(..., 3)``, axes ``(..., 3, 3)`` (columns = axes)."""
    moments = np.asarray(moments, dtype=float)
    axes = np.asarray(axes, dtype=float)
    return np.einsum("...ik,...k,...jk->...ij", axes, moments, axes)


def segment_axes(long_dirs, forward, up, depth_up) -> np.ndarray:
    """``(S, 3, 3)`` orthonormal frames, columns (long, width, depth).

    ``long_dirs`` ``(S, 3)``; ``forward``/``up`` ``(3,)``: the body's directions in
    the rest pose; ``depth_up`` ``(S,)`` bool: use ``up`` rather than ``forward`` as
    the depth reference. When the reference is parallel to the long axis the
    other reference is used.
    """
    u = np.asarray(long_dirs, dtype=float)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    out = np.empty((len(u), 3, 3))
    for i in range(len(u)):
        refs = (up, forward) if depth_up[i] else (forward, up)
        for ref in refs + (np.cross(forward, up),):
            d = ref - np.dot(ref, u[i]) * u[i]
            if np.linalg.norm(d) > 0.3:
                break
        d = d / np.linalg.norm(d)
        w = np.cross(d, u[i])
        out[i] = np.column_stack([u[i], w, d])
    return out


@dataclass(frozen=True, eq=False)
class SegmentGeometry:
    """The solids behind a :class:`~mocomp.body.BodyModel`'s inertias (kept so that
    inertias can be recomputed for other masses).

    Attributes
    ----------
    kinds: ``(S,)`` ``"ellipsoid"``, ``"cuboid"``, ``"gyration"`` or ``"given"``.
    lengths: ``(S,)`` metres, proximal -> distal landmark distance.
    densities: ``(S,)`` kg/m^3 (ellipsoid/cuboid; NaN otherwise).
    ratios: ``(S,)`` width/depth ratio (ellipsoid/cuboid; NaN otherwise).
    axes: ``(S, 3, 3)`` principal axes in the carrier joint frame, columns (long, width, depth).
    gyration: ``(S, 3)`` radii of gyration / length about (long, width, depth) (``"gyration"`` only; NaN otherwise).
    """

    kinds: tuple[str, ...]
    lengths: np.ndarray
    densities: np.ndarray
    ratios: np.ndarray
    axes: np.ndarray
    gyration: np.ndarray

    def dimensions(self, masses) -> np.ndarray:
        """``(..., S, 3)`` semi-axes (ellipsoid) or edges (cuboid) for ``masses`` ``(..., S)``; NaN for other kinds."""
        masses = np.asarray(masses, dtype=float)
        out = np.full(masses.shape + (3,), np.nan)
        k = np.asarray(self.kinds)
        for kind, fn in (("ellipsoid", ellipsoid_semi_axes), ("cuboid", cuboid_edges)):
            sel = k == kind
            if sel.any():
                out[..., sel, :] = fn(np.maximum(masses[..., sel], 0.0), self.lengths[sel], self.densities[sel], self.ratios[sel])
        return out


def geometry_inertias(geometry: SegmentGeometry, masses, given=None) -> np.ndarray:
    """Inertia tensors ``(..., S, 3, 3)`` about each COM in the carrier frames, for ``masses`` ``(..., S)``.

    Ellipsoids and cuboids keep their density, length and width/depth ratio, so
    their cross-section grows with mass (volume = mass / density; the
    dissertation's section 5.3.2 recipe). ``"gyration"`` segments keep their radii
    (``I`` proportional to mass). ``"given"`` segments scale ``given`` (the
    original inertias, ``(S, 3, 3)``) by ``masses / given_masses`` -- pass
    ``given=(inertias, masses0)``.
    """
    masses = np.asarray(masses, dtype=float)
    k = np.asarray(geometry.kinds)
    moments = np.zeros(masses.shape + (3,))
    dims = geometry.dimensions(masses)
    sel = k == "ellipsoid"
    if sel.any():
        moments[..., sel, :] = ellipsoid_moments(masses[..., sel], dims[..., sel, :])
    sel = k == "cuboid"
    if sel.any():
        moments[..., sel, :] = cuboid_moments(masses[..., sel], dims[..., sel, :])
    sel = k == "gyration"
    if sel.any():
        r = geometry.gyration[sel] * geometry.lengths[sel, None]
        moments[..., sel, :] = masses[..., sel, None] * r ** 2
    out = rotate_inertia(moments, np.broadcast_to(geometry.axes, masses.shape + (3, 3)))
    sel = k == "given"
    if sel.any():
        if given is None:
            raise ValueError("segments of kind 'given' need given=(inertias, masses) to rescale")
        I0, m0 = given
        m0 = np.asarray(m0, dtype=float)[sel]
        scale = np.divide(masses[..., sel], m0, out=np.zeros_like(masses[..., sel]), where=m0 > 0)
        out[..., sel, :, :] = np.asarray(I0)[sel] * scale[..., None, None]
    return out


def inertia_for_masses(body, masses) -> np.ndarray:
    """Inertias ``(..., S, 3, 3)`` of ``body``'s segments recomputed for other ``masses`` ``(..., S)``,
    with the same shapes (see :func:`geometry_inertias`). Vectorised over leading axes of ``masses``.

    Models without geometry (e.g. loaded inertias) scale each inertia with its mass.
    """
    masses = np.asarray(masses, dtype=float)
    if masses.shape[-1] != body.n_segments:
        raise ValueError(f"masses has {masses.shape[-1]} entries for {body.n_segments} segments")
    if np.any(masses < 0) or not np.all(np.isfinite(masses)):
        raise ValueError("masses must be finite and >= 0")
    geom = getattr(body, "geometry", None)
    if geom is None:
        geom = SegmentGeometry(("given",) * body.n_segments, np.full(body.n_segments, np.nan),
                               np.full(body.n_segments, np.nan), np.full(body.n_segments, np.nan),
                               np.broadcast_to(np.eye(3), (body.n_segments, 3, 3)).copy(),
                               np.full((body.n_segments, 3), np.nan))
    return geometry_inertias(geom, masses, given=(body.inertias, body.masses))
