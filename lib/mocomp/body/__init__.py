"""Body segment parameters: masses, COMs and inertias per skeleton segment.

``BodyModel.from_skeleton(skeleton, total_mass, table, shape, mapping)`` builds
one from the de Leva (1996) or Dempster (via Winter) tables
(:mod:`~mocomp.body.tables`) through a bone -> segment mapping
(:mod:`~mocomp.body.mapping`); :mod:`~mocomp.body.inertia` has the solids,
:mod:`~mocomp.body.mjcf` the MuJoCo export. The ASE humanoid's own MJCF bodies
(and its sword and shield props) are in :mod:`~mocomp.body.ase`. A DeepMimic character file's own
bodies load with :func:`mocomp.io.deepmimic.read_deepmimic_body`; a skeleton that is exactly a known
character's (e.g. a BVH the project wrote from a DeepMimic clip: joints by name and parent in any order,
bone offsets within 0.1 mm) gets them from :func:`mocomp.io.deepmimic.recognized_body`, which
:func:`mocomp.audit.default_body` consults before falling back to de Leva's table at 70 kg.
"""
from .ase import ase_body
from .inertia import inertia_for_masses
from .mapping import CONVENTIONS, SegmentMap, detect_convention
from .model import BodyModel
from .symmetry import expand_symmetric, reduce_symmetric, symmetric_groups
from .tables import TABLES, get_table, mass_fractions

__all__ = [
    "BodyModel",
    "ase_body",
    "inertia_for_masses",
    "symmetric_groups",
    "expand_symmetric",
    "reduce_symmetric",
    "TABLES",
    "get_table",
    "mass_fractions",
    "CONVENTIONS",
    "SegmentMap",
    "detect_convention",
]
