"""flips' prior mass distribution (thesis sec. 5.2, eq. 5.1-5.2 start from it): a DeepMimic clip
and a BVH the project wrote from one both get the character's own masses; a CMU clip the table."""
from __future__ import annotations

import numpy as np

from mocomp.flips.preprocess import _own_character, clip_prior
from mocomp.io import read_bvh, write_bvh
from mocomp.io.deepmimic import read_deepmimic


def test_deepmimic_bvh_written_and_read_back_keeps_the_characters_prior(real_data_dir, tmp_path):
    m = read_deepmimic(real_data_dir / "flips" / "deepmimic_backflip.txt")
    write_bvh(m, tmp_path / "bf.bvh")
    r = read_bvh(tmp_path / "bf.bvh")
    b0, b1 = clip_prior(m), clip_prior(r)
    assert _own_character(m) and _own_character(r)
    assert abs(b0.total_mass - 45.0) < 1e-6 and abs(b1.total_mass - b0.total_mass) < 1e-9
    # the same segment masses, matched by segment name (the BVH reorders the joints)
    m0, m1 = dict(zip(b0.segment_names, b0.masses)), dict(zip(b1.segment_names, b1.masses))
    assert m0.keys() == m1.keys()
    assert np.allclose([m0[k] for k in m0], [m1[k] for k in m0], rtol=1e-12)

def test_cmu_clip_gets_the_table_prior(real_data_dir):
    c = read_bvh(real_data_dir / "flips" / "cmu_88_01_backflip.bvh", fps=60)
    assert not _own_character(c)
    assert abs(clip_prior(c).total_mass - 70.0) < 1e-6
