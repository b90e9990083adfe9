"""Body segment parameter tables, shipped as data with their citations.

Every table lists the same 11 anatomical segment kinds on the same canonical
landmarks (see :data:`SEGMENT_KINDS`), so that one skeleton mapping serves all
tables. Paired segments (``paired=True``) exist once per side; their mass
fraction is per side.

The trunk is *subdivided* in every table into three stacked parts, each carried
by its own skeleton bone (see :mod:`mocomp.body.mapping`):

========== ================================ ======================================
segment     de Leva (1996)                   Dempster (via Winter)
========== ================================ ======================================
upper_trunk suprasternale -> xiphion (UPT)   thorax: C7-T1 -> T12-L1
middle_trunk xiphion -> omphalion (MPT)      abdomen: T12-L1 -> L4-L5
lower_trunk omphalion -> mid hip joints (LPT) pelvis: L4-L5 -> greater trochanter
========== ================================ ======================================

The canonical landmarks are: ``VERT`` (top of head), ``CERV`` (base of the neck,
C7 / suprasternale level), ``XYPH`` (xiphion / T12-L1 level), ``OMPH``
(omphalion / L4-L5 level), ``MIDH`` (midpoint of the hip joint centres), and per
side ``SJC EJC WJC MET3 HJC KJC AJC TTIP`` (shoulder, elbow, wrist joint
centres, 3rd metacarpal head, hip, knee, ankle joint centres, tip of the
longest toe). Where a table's published endpoints differ from these (e.g. de
Leva's foot runs from the heel, Dempster's head-neck COM sits at the ear
canal), the entry's ``note`` says how it was converted.

Sources
-------
* P. de Leva, "Adjustments to Zatsiorsky-Seluyanov's segment inertia
  parameters", J. Biomechanics 29(9):1223-1230, 1996, Table 4 (male and
  female; head VERT-CERV, shank KJC-AJC variants from the lower half of the
  table). Reference subjects: male 1.741 m / 73.0 kg, female 1.735 m / 61.9 kg.
  The published female mass fractions sum to 99.99 % (rounding in the paper);
  :func:`mass_fractions` reports them as printed.
* W. T. Dempster, "Space requirements of the seated operator", WADC TR 55-159,
  1955, as tabulated by D. A. Winter, "Biomechanics and Motor Control of Human
  Movement", 4th ed., Wiley 2009, Table 4.1 (mass fraction, COM from the
  proximal end, radius of gyration about the COM, density).
* Segment densities and width/depth ratios for the solid-cuboid model:
  A. Majkowska, "Motion Composition for Character Animation", PhD
  dissertation, UCLA 2007, Appendix C, Table C.1 (after Dempster & Gaughran
  1967). Densities for the constant-density ellipsoid of the flips paper
  (Majkowska & Faloutsos 2007, section 4.2): Dempster & Gaughran 1967 as listed
  in Winter's Table 4.1.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "SegmentParameters",
    "SegmentTable",
    "SEGMENT_KINDS",
    "TABLES",
    "get_table",
    "mass_fractions",
    "DISSERTATION_TABLE_C1",
    "SHAPE_DENSITY_RATIO",
    "ELLIPSOID_DENSITY",
]

#: canonical segment kinds: name -> (proximal landmark, distal landmark, paired)
SEGMENT_KINDS: dict[str, tuple[str, str, bool]] = {
    "head": ("VERT", "CERV", False),
    "upper_trunk": ("CERV", "XYPH", False),
    "middle_trunk": ("XYPH", "OMPH", False),
    "lower_trunk": ("OMPH", "MIDH", False),
    "upper_arm": ("SJC", "EJC", True),
    "forearm": ("EJC", "WJC", True),
    "hand": ("WJC", "MET3", True),
    "thigh": ("HJC", "KJC", True),
    "shank": ("KJC", "AJC", True),
    "foot": ("AJC", "TTIP", True),
}


@dataclass(frozen=True)
class SegmentParameters:
    """One row of a table.

    Attributes
    ----------
    kind: segment kind (a key of :data:`SEGMENT_KINDS`).
    mass_fraction: segment mass / body mass (per side for paired segments).
    com_fraction: COM position along proximal -> distal landmark, as a fraction
        of that distance from the proximal landmark.
    gyration: radii of gyration / segment length about the COM, as
        ``(sagittal, transverse, longitudinal)`` (de Leva) or one value for all
        transverse axes (Dempster/Winter; longitudinal unknown -> ``None``), or
        ``None`` when the table gives none.
    length_m: mean segment length of the table's reference subjects (metres), if published.
    published: the table's own endpoint names, verbatim.
    note: how the published endpoints were mapped onto the canonical landmarks.
    """

    kind: str
    mass_fraction: float
    com_fraction: float
    gyration: tuple | None = None
    length_m: float | None = None
    published: str = ""
    note: str = ""


@dataclass(frozen=True)
class SegmentTable:
    """A body segment parameter table.

    Attributes
    ----------
    key: short name used by :meth:`BodyModel.from_skeleton` (``"de_leva_male"``...).
    citation: full reference.
    segments: the rows, one per segment kind.
    stature_m, body_mass_kg: the reference subjects' mean stature and mass (if published).
    """

    key: str
    citation: str
    segments: tuple[SegmentParameters, ...]
    stature_m: float | None = None
    body_mass_kg: float | None = None

    def row(self, kind: str) -> SegmentParameters:
        return self.rows([kind])[0]

    def rows(self, kinds) -> list[SegmentParameters]:
        """The rows of segment ``kinds`` (a sequence of kind names, repeats allowed), in that order."""
        by_kind = {s.kind: s for s in self.segments}
        missing = [k for k in kinds if k not in by_kind]
        if missing:
            raise KeyError(f"table {self.key!r} has no segment {missing[0]!r}")
        return [by_kind[k] for k in kinds]


_DL = ("P. de Leva (1996), Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters, "
       "J. Biomech. 29(9):1223-1230, Table 4")

_DL_NOTES = {
    "head": "published VERT-CERV (vertex to C7), the head+neck variant of Table 4",
    "upper_trunk": "published SUPR-XYPH; the skeleton's neck base (C7 level) stands in for the suprasternale",
    "middle_trunk": "published XYPH-OMPH",
    "lower_trunk": "published OMPH-MIDH",
    "hand": "published WJC-MET3",
    "shank": "published KJC-AJC variant (knee to ankle joint centre)",
    "foot": "published HEEL-TTIP; skeletons lack a heel, so the line runs ankle -> toe tip",
}


def _deleva(key, sex, rows, stature, mass):
    segs = []
    for kind, (mf, cf, rs, rt, rl, length, pub) in rows.items():
        segs.append(SegmentParameters(kind, mf / 100.0, cf / 100.0, (rs / 100.0, rt / 100.0, rl / 100.0),
                                      length, pub, _DL_NOTES.get(kind, "")))
    return SegmentTable(key, f"{_DL} ({sex})", tuple(segs), stature, mass)


# kind: (mass %, COM % from proximal, r_sag %, r_trans %, r_long %, length m, published endpoints)
DE_LEVA_MALE = _deleva("de_leva_male", "male", {
    "head": (6.94, 50.02, 30.3, 31.5, 26.1, 0.2429, "VERT-CERV"),
    "upper_trunk": (15.96, 29.99, 71.6, 45.4, 65.9, 0.1707, "SUPR-XYPH"),
    "middle_trunk": (16.33, 45.02, 48.2, 38.3, 46.8, 0.2155, "XYPH-OMPH"),
    "lower_trunk": (11.17, 61.15, 61.5, 55.1, 58.7, 0.1457, "OMPH-MIDH"),
    "upper_arm": (2.71, 57.72, 28.5, 26.9, 15.8, 0.2817, "SJC-EJC"),
    "forearm": (1.62, 45.74, 27.6, 26.5, 12.1, 0.2689, "EJC-WJC"),
    "hand": (0.61, 79.00, 62.8, 51.3, 40.1, 0.0862, "WJC-MET3"),
    "thigh": (14.16, 40.95, 32.9, 32.9, 14.9, 0.4222, "HJC-KJC"),
    "shank": (4.33, 43.95, 25.1, 24.6, 10.2, 0.4403, "KJC-AJC"),
    "foot": (1.37, 44.15, 25.7, 24.5, 12.4, 0.2581, "HEEL-TTIP"),
}, 1.741, 73.0)

DE_LEVA_FEMALE = _deleva("de_leva_female", "female", {
    "head": (6.68, 48.41, 27.1, 29.5, 26.1, 0.2437, "VERT-CERV"),
    "upper_trunk": (15.45, 20.77, 74.6, 50.2, 71.8, 0.1425, "SUPR-XYPH"),
    "middle_trunk": (14.65, 45.12, 43.3, 35.4, 41.5, 0.2053, "XYPH-OMPH"),
    "lower_trunk": (12.47, 49.20, 43.3, 40.2, 44.4, 0.1815, "OMPH-MIDH"),
    "upper_arm": (2.55, 57.54, 27.8, 26.0, 14.8, 0.2751, "SJC-EJC"),
    "forearm": (1.38, 45.59, 26.1, 25.7, 9.4, 0.2643, "EJC-WJC"),
    "hand": (0.56, 74.74, 53.1, 45.4, 33.5, 0.0780, "WJC-MET3"),
    "thigh": (14.78, 36.12, 36.9, 36.4, 16.2, 0.3685, "HJC-KJC"),
    "shank": (4.81, 43.52, 26.7, 26.3, 9.2, 0.4386, "KJC-AJC"),
    "foot": (1.29, 40.14, 29.9, 27.9, 13.9, 0.2283, "HEEL-TTIP"),
}, 1.735, 61.9)

_W = ("W. T. Dempster (1955), WADC TR 55-159, via D. A. Winter (2009), Biomechanics and Motor Control "
      "of Human Movement, 4th ed., Table 4.1")

#: kind: (mass fraction, COM from proximal, radius of gyration about COM / length or None, published, note)
_DEMPSTER_ROWS = {
    "head": (0.081, 0.535, 0.495, "C7-T1 and 1st rib to ear canal (head and neck)",
             "Winter puts the head-neck COM at the ear canal (1.000 of C7 -> ear canal); on the canonical "
             "VERT -> CERV line that is 0.535 from the vertex (tragion ~0.13 m below the vertex over de "
             "Leva's 0.2429 m vertex-C7 length). The radius of gyration is relative to Winter's C7-ear length "
             "and is not used for the canonical line."),
    "upper_trunk": (0.216, 0.82, None, "thorax: C7-T1 to T12-L1 and diaphragm", "T12-L1 mapped to XYPH"),
    "middle_trunk": (0.139, 0.44, None, "abdomen: T12-L1 to L4-L5", "L4-L5 mapped to OMPH"),
    "lower_trunk": (0.142, 0.105, None, "pelvis: L4-L5 to greater trochanter",
                    "greater trochanter level mapped to MIDH (mid hip joint centres)"),
    "upper_arm": (0.028, 0.436, 0.322, "glenohumeral axis to elbow axis", ""),
    "forearm": (0.016, 0.430, 0.303, "elbow axis to ulnar styloid", ""),
    "hand": (0.006, 0.506, 0.297, "wrist axis to knuckle II middle finger", "knuckle mapped to MET3"),
    "thigh": (0.100, 0.433, 0.323, "greater trochanter to femoral condyles", "mapped to HJC-KJC"),
    "shank": (0.0465, 0.433, 0.302, "femoral condyles to medial malleolus", "mapped to KJC-AJC"),
    "foot": (0.0145, 0.50, 0.475, "lateral malleolus to head metatarsal II",
             "mapped to AJC-TTIP (skeletons end the foot at the toe tip)"),
}

DEMPSTER = SegmentTable(
    "dempster", _W,
    tuple(SegmentParameters(k, mf, cf, None if rg is None else (rg, rg, None), None, pub, note)
          for k, (mf, cf, rg, pub, note) in _DEMPSTER_ROWS.items()),
)

TABLES: dict[str, SegmentTable] = {t.key: t for t in (DE_LEVA_MALE, DE_LEVA_FEMALE, DEMPSTER)}


def get_table(table) -> SegmentTable:
    """A :class:`SegmentTable` from its key (``"de_leva_male"``, ``"de_leva_female"``, ``"dempster"``)."""
    if isinstance(table, SegmentTable):
        return table
    try:
        return TABLES[table]
    except KeyError:
        raise ValueError(f"unknown body segment table {table!r}; choose one of {sorted(TABLES)}") from None


def mass_fractions(table) -> dict[str, float]:
    """Mass fraction per *sided* segment (``"thigh_l"``, ``"thigh_r"``, ``"head"``, ...), as published."""
    t = get_table(table)
    out = {}
    for s in t.segments:
        if SEGMENT_KINDS[s.kind][2]:
            out[s.kind + "_l"] = s.mass_fraction
            out[s.kind + "_r"] = s.mass_fraction
        else:
            out[s.kind] = s.mass_fraction
    return out


#: Dissertation Table C.1, verbatim: CMU ASF bone -> (density g/cm^3, width/depth ratio,
#: initial mass %, optimized mass %). Left/right rows as printed.
DISSERTATION_TABLE_C1: dict[str, tuple[float, float, float, float]] = {
    "root": (1.029, 1.40, 7.4, 6.7),
    "lfemur": (1.040, 0.86, 10.2, 11.8), "ltibia": (1.079, 0.89, 7.9, 5.3),
    "lfoot": (1.066, 2.00, 0.3, 0.0), "ltoes": (1.066, 3.00, 0.1, 0.0),
    "rfemur": (1.040, 0.86, 9.8, 11.8), "rtibia": (1.079, 0.89, 7.6, 5.3),
    "rfoot": (1.066, 2.00, 0.3, 0.0), "rtoes": (1.066, 3.00, 0.1, 0.0),
    "lowerback": (1.029, 1.20, 5.8, 5.8), "upperback": (1.029, 1.08, 7.4, 7.4),
    "thorax": (1.009, 1.00, 8.9, 8.8), "lowerneck": (1.009, 1.00, 1.0, 0.9),
    "upperneck": (1.009, 1.00, 0.6, 0.8), "head": (1.171, 1.00, 5.9, 7.4),
    "lclavicle": (1.009, 1.17, 5.9, 6.5), "lhumerus": (1.068, 1.00, 3.6, 3.9),
    "lradius": (1.102, 1.17, 2.6, 3.1), "lwrist": (1.102, 1.00, 0.7, 0.5),
    "lhand": (1.070, 4.00, 0.0, 0.0), "lfingers": (1.070, 8.00, 0.0, 0.0), "lthumb": (1.070, 2.00, 0.0, 0.0),
    "rclavicle": (1.009, 1.17, 7.5, 6.5), "rhumerus": (1.068, 1.00, 3.5, 3.9),
    "rradius": (1.102, 1.17, 2.3, 3.1), "rwrist": (1.102, 1.00, 0.6, 0.5),
    "rhand": (1.070, 4.00, 0.0, 0.0), "rfingers": (1.070, 8.00, 0.0, 0.0), "rthumb": (1.070, 2.00, 0.0, 0.0),
}

#: Segment kind -> (density kg/m^3, width/depth ratio) for the solid cuboid of
#: dissertation eq. 5.3, from Table C.1. The kind -> row choice: lower_trunk =
#: root, middle_trunk = lowerback, upper_trunk = mean of upperback and thorax,
#: head = head, upper_arm = humerus, forearm = radius, hand = hand, thigh =
#: femur, shank = tibia, foot = foot.
SHAPE_DENSITY_RATIO: dict[str, tuple[float, float]] = {
    "head": (1171.0, 1.00),
    "upper_trunk": (1019.0, 1.04),
    "middle_trunk": (1029.0, 1.20),
    "lower_trunk": (1029.0, 1.40),
    "upper_arm": (1068.0, 1.00),
    "forearm": (1102.0, 1.17),
    "hand": (1070.0, 4.00),
    "thigh": (1040.0, 0.86),
    "shank": (1079.0, 0.89),
    "foot": (1066.0, 2.00),
}

#: Segment kind -> density kg/m^3 for the constant-density ellipsoid (flips
#: paper section 4.2: "typical densities of body parts from [DG67]"), as listed
#: in Winter's Table 4.1 (thorax 0.92; abdomen and pelvis from "abdomen and
#: pelvis" 1.01; head and neck 1.11). Width/depth ratios come from Table C.1.
#:
#: Which densities each solid uses (pinned by ``tests/test_body_tables.py``):
#: the cuboid (dissertation eq. 5.3) uses Table C.1's densities and ratios, as the
#: dissertation does. The ellipsoid (flips paper section 4.2) uses Table C.1's
#: ratios but, by default, these densities: the paper cites [DG67] for them without
#: listing values, and Table C.1 lists densities per *CMU bone* of the dissertation's
#: box model (its trunk rows root/lowerback/upperback/thorax are mapped onto our three
#: trunk segments by a choice of ours, see SHAPE_DENSITY_RATIO). Issue 3 asks for Table
#: C.1's densities for both solids; ``BodyModel.from_skeleton(..., densities="table_c1")``
#: gives the ellipsoid those. On the 1.75 m synthetic performer that lowers the upper
#: trunk's principal moments by 8-10 %, the head's by 1-5 %, raises the hands' by up
#: to 8 % and changes the others by at most 3 %. The default is *not* switched here
#: because every embedded synthetic example (the project's ground truth, whose figures
#: the other packages' tests and notebooks pin) is built with the ellipsoid default;
#: switching it is a coordinated change (all examples, figures and pinned numbers
#: regenerated together).
ELLIPSOID_DENSITY: dict[str, float] = {
    "head": 1110.0,
    "upper_trunk": 920.0,
    "middle_trunk": 1010.0,
    "lower_trunk": 1010.0,
    "upper_arm": 1070.0,
    "forearm": 1130.0,
    "hand": 1160.0,
    "thigh": 1050.0,
    "shank": 1090.0,
    "foot": 1100.0,
}
