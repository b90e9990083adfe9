"""``BodyModel``: the mass distribution of a skeleton (immutable)."""
from __future__ import annotations

import collections
import threading
from dataclasses import dataclass

import numpy as np

from ..core.skeleton import Skeleton
from ..errors import MotionFormatError

__all__ = ["BodyModel"]


def _frozen(a, dtype=float) -> np.ndarray:
    a = np.array(a, dtype=dtype, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class BodyModel:
    """Rigid segments attached to skeleton joints, with masses and inertias.

    A segment is rigidly attached to the frame of one joint (``segment_joint``):
    it moves with that joint's global position and rotation. Usually the
    segment spans from that joint to its child (e.g. the thigh hangs from the
    hip joint).

    Attributes
    ----------
    skeleton: the :class:`~mocomp.core.Skeleton` it describes.
    segment_names: ``(S,)`` names (anatomical, e.g. ``"thigh_l"``, or the bone name).
    segment_joint: ``(S,)`` int, index of the joint whose frame carries the segment.
    masses: ``(S,)`` kilograms, ``>= 0``.
    local_coms: ``(S, 3)`` metres, segment COM in the joint's local frame.
    inertias: ``(S, 3, 3)`` kg m^2, inertia tensor about the segment COM,
        in the joint's local frame (symmetric positive semi-definite).
    massless_joints: names of joints that carry no segment (listed, never dropped silently).
    table: name/citation of the parameter table the model came from.
    shape: ``"ellipsoid"``, ``"cuboid"``, ``"given"`` (e.g. DeepMimic), ...
    geometry: the solids behind the inertias (:class:`~mocomp.body.inertia.SegmentGeometry`),
        so that :meth:`with_masses` can recompute inertias; ``None`` for given inertias.
    notes: how the model was built (mapping convention, approximations, normalisation).

    Build one with :meth:`from_skeleton` (table + shape) or
    :func:`mocomp.io.deepmimic.read_deepmimic_body` (a DeepMimic character file's own bodies).
    """

    skeleton: Skeleton
    segment_names: tuple[str, ...]
    segment_joint: np.ndarray
    masses: np.ndarray
    local_coms: np.ndarray
    inertias: np.ndarray
    massless_joints: tuple[str, ...] = ()
    table: str = ""
    shape: str = "given"
    geometry: object = None
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        S = len(self.segment_names)
        sj = _frozen(self.segment_joint, dtype=np.int64).reshape(-1)
        m = _frozen(self.masses).reshape(-1)
        c = _frozen(self.local_coms).reshape(-1, 3) if S else _frozen(np.zeros((0, 3)))
        I = _frozen(self.inertias).reshape(-1, 3, 3) if S else _frozen(np.zeros((0, 3, 3)))
        if not (sj.shape == m.shape == (S,) and c.shape == (S, 3) and I.shape == (S, 3, 3)):
            raise MotionFormatError(
                f"BodyModel arrays disagree: {S} segments, joints {sj.shape}, masses {m.shape}, "
                f"coms {c.shape}, inertias {I.shape}")
        if S and (sj.min() < 0 or sj.max() >= self.skeleton.n_joints):
            raise MotionFormatError("BodyModel.segment_joint has an index outside the skeleton")
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(c)) and np.all(np.isfinite(I))):
            raise MotionFormatError("BodyModel has non-finite masses, COMs or inertias")
        if np.any(m < 0):
            k = int(np.argmin(m))
            raise MotionFormatError(f"segment {self.segment_names[k]!r} has negative mass {m[k]}")
        object.__setattr__(self, "segment_names", tuple(self.segment_names))
        object.__setattr__(self, "segment_joint", sj)
        object.__setattr__(self, "masses", m)
        object.__setattr__(self, "local_coms", c)
        object.__setattr__(self, "inertias", I)
        object.__setattr__(self, "massless_joints", tuple(self.massless_joints))
        object.__setattr__(self, "notes", tuple(self.notes))
        if self.geometry is not None and len(self.geometry.kinds) != S:
            raise MotionFormatError(f"BodyModel.geometry describes {len(self.geometry.kinds)} segments, model has {S}")

    @property
    def n_segments(self) -> int:
        return len(self.segment_names)

    @property
    def total_mass(self) -> float:
        return float(self.masses.sum())

    def segment(self, name: str) -> int:
        try:
            return self.segment_names.index(name)
        except ValueError:
            raise KeyError(f"no segment {name!r}; segments: {self.segment_names}") from None

    def with_masses(self, masses, inertias=None) -> "BodyModel":
        """A new model with other masses; the input is not changed.

        Without ``inertias`` they are recomputed for the new masses with the same
        shapes (:func:`~mocomp.body.inertia.inertia_for_masses`: ellipsoids and
        cuboids keep density, length and width/depth ratio; given inertias scale
        with mass).
        """
        import dataclasses

        from .inertia import inertia_for_masses

        masses = np.asarray(masses, dtype=float)
        if masses.shape != (self.n_segments,):
            raise ValueError(f"masses must have shape ({self.n_segments},), got {masses.shape}")
        if inertias is None:
            inertias = inertia_for_masses(self, masses)
        return dataclasses.replace(self, masses=masses, inertias=inertias)

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_skeleton(cls, skeleton: Skeleton, total_mass: float = 70.0, table: str = "de_leva_male",
                      shape: str = "ellipsoid", mapping=None, densities: str | None = None,
                     props: str = "massless") -> "BodyModel":
        """Segment masses, COMs and inertias for ``skeleton`` from a parameter table.

        Parameters
        ----------
        skeleton: the skeleton (its rest pose gives segment lengths; any rest pose works,
            the landmarks are fixed in their carrier joints' frames).
        total_mass: body mass, kg (the table's fractions are normalised to sum to 1).
        table: ``"de_leva_male"``, ``"de_leva_female"`` or ``"dempster"`` (:mod:`~mocomp.body.tables`).
        shape: ``"ellipsoid"`` (constant density, flips paper section 4.2), ``"cuboid"``
            (solid box, dissertation eq. 5.3 with Table C.1 densities and width/depth
            ratios) or ``"gyration"`` (the table's radii of gyration; de Leva only).
        mapping: ``None`` (detect the naming convention), a convention name, a
            :class:`~mocomp.body.mapping.SegmentMap`, or a dict override
            ``{"landmarks": {...}, "carriers": {...}}`` (see :mod:`~mocomp.body.mapping`).
        densities: segment densities of the solid, ``"table_c1"`` (dissertation Table C.1,
            :data:`~mocomp.body.tables.SHAPE_DENSITY_RATIO`) or ``"winter"`` (Dempster's
            densities as listed in Winter's Table 4.1, :data:`~mocomp.body.tables.ELLIPSOID_DENSITY`);
            default ``None``: ``"winter"`` for the ellipsoid, ``"table_c1"`` for the cuboid
            (why the ellipsoid keeps Winter's by default: :mod:`mocomp.body.tables`). The
            width/depth ratios are Table C.1's for both solids. Ignored for ``"gyration"``.
        props: hand-held props of the skeleton (the ASE humanoid's ``sword`` and ``shield``
            joints): ``"massless"`` (default; they carry nothing and are listed in
            ``massless_joints``) or ``"ase"`` (two extra segments named ``"sword"`` and
            ``"shield"`` with ASE's MJCF masses 0.70 and 2.12 kg, COMs and inertias, added
            on top of ``total_mass``, which stays the body's own mass; see
            :mod:`~mocomp.body.ase`, whose :func:`~mocomp.body.ase.ase_body` gives ASE's own
            body masses instead of a table's).

        Each anatomical segment is one rigid body carried by one joint; its COM lies
        at the table's fraction along the proximal -> distal landmark line. Joints
        carrying nothing are listed in ``massless_joints``.

        Built once per skeleton object and arguments (named table, shape, mapping): the same call
        again returns the same immutable model (the 32 most recent are kept; custom table or
        mapping objects are built every time).
        """
        key = _table_key(skeleton, total_mass, table, shape, mapping, densities, props)
        if key is not None and cls is BodyModel:
            with _TABLE_LOCK:
                hit = _TABLE_BODIES.get(key)
                if hit is not None and hit[0] is skeleton:
                    _TABLE_BODIES.move_to_end(key)
                    return hit[1]
        from .builder import build_from_table

        body = build_from_table(cls, skeleton, total_mass, table, shape, mapping, densities, props)
        if key is not None and cls is BodyModel:
            for a in (body.geometry.lengths, body.geometry.densities, body.geometry.ratios, body.geometry.axes,
                      body.geometry.gyration):
                a.setflags(write=False)
            with _TABLE_LOCK:
                _TABLE_BODIES[key] = (skeleton, body)
                while len(_TABLE_BODIES) > _TABLE_BODIES_MAX:
                    _TABLE_BODIES.popitem(last=False)
        return body

    # ---------------------------------------------------------------- helpers
    def symmetric_groups(self) -> list[list[int]]:
        """Segment-index groups sharing one mass under left/right symmetry (see :func:`mocomp.body.symmetric_groups`)."""
        from .symmetry import symmetric_groups

        return symmetric_groups(self)

    def to_mjcf(self, **kwargs) -> str:
        """MJCF XML of skeleton + body (see :func:`mocomp.body.mjcf.to_mjcf`)."""
        from .mjcf import to_mjcf

        return to_mjcf(self, **kwargs)

    def principal_moments(self) -> np.ndarray:
        """``(S, 3)`` kg m^2, eigenvalues of each segment's inertia tensor, ascending."""
        return np.linalg.eigvalsh(self.inertias)

    def scaled_to(self, total_mass: float) -> "BodyModel":
        """All masses scaled to a new total (shapes kept, inertias recomputed)."""
        if not (np.isfinite(total_mass) and total_mass > 0):
            raise ValueError(f"total_mass must be positive, got {total_mass!r}")
        return self.with_masses(self.masses * (total_mass / self.total_mass))

    def __repr__(self) -> str:
        return (f"BodyModel({self.n_segments} segments, {self.total_mass:.2f} kg, table={self.table.split(' (')[0]!r}, "
                f"shape={self.shape!r}, {len(self.massless_joints)} massless joints)")

    def table_frame(self):
        """A pandas DataFrame: segment, joint, mass, COM and principal moments."""
        import pandas as pd

        return pd.DataFrame({
            "segment": self.segment_names,
            "joint": [self.skeleton.names[j] for j in self.segment_joint],
            "mass_kg": self.masses,
            "com_x": self.local_coms[:, 0], "com_y": self.local_coms[:, 1], "com_z": self.local_coms[:, 2],
            "Ixx": self.inertias[:, 0, 0], "Iyy": self.inertias[:, 1, 1], "Izz": self.inertias[:, 2, 2],
        })


#: table body models already built, keyed by the skeleton's identity and the arguments (a table
#: model is a pure function of them, and both are immutable): a clip's prior is built once per
#: process, not once per call (``mocomp flips`` asks for it in its phase detection, its mass
#: estimate and its report). The skeleton object is kept with the entry and checked by identity,
#: so a recycled ``id`` never returns another skeleton's body; the 32 most recent are kept.
_TABLE_BODIES: "collections.OrderedDict" = collections.OrderedDict()
_TABLE_BODIES_MAX = 32
_TABLE_LOCK = threading.Lock()          # the reproduce runner calls from threads


def _table_key(skeleton, total_mass, table, shape, mapping, densities, props):
    """The cache key of :meth:`BodyModel.from_skeleton`, ``None`` when an argument is not a plain
    name or number (a custom table or mapping object: built every time)."""
    if not all(x is None or isinstance(x, str) for x in (table, shape, mapping, densities, props)):
        return None
    try:
        mass = float(total_mass)
    except (TypeError, ValueError):
        return None
    return (id(skeleton), mass, table, shape, mapping, densities, props)
