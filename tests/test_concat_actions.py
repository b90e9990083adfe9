"""mocomp.concat.find_actions (issue 17): single strikes cut out of takes holding several, checked
against the MANIFEST's counts (Bandai: five left / five right punches, three spinning kicks) and a
known answer (a take made of one strike repeated)."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp import datasets
from mocomp.concat import ConcatError, cut_actions, find_actions
from mocomp.concat.actions import parse_selection


def _load(d, rel):
    return datasets.load(str(d / rel))


@pytest.mark.parametrize("rel, n, effector", [
    ("kicks_punches/bandai1_punch_normal_001.bvh", 5, "hand_l"),
    ("kicks_punches/bandai1_punch_normal_002.bvh", 5, "hand_r"),
    ("kicks_punches/bandai1_kick_normal_001.bvh", 3, "toe_r"),
    ("combos/ase_rl_Atk_2xCombo01.derived.bvh", 2, "hand_r"),
    ("combos/ase_rl_Atk_3xCombo01.derived.bvh", 3, "hand_r"),
])
def test_strike_counts_match_the_manifest(real_data_dir, rel, n, effector):
    m = _load(real_data_dir, rel)
    acts = find_actions(m)
    assert len(acts) == n and all(a.effector == effector for a in acts)
    for a, b in zip(acts, acts[1:]):
        assert a.start < a.peak < a.stop and a.peak < b.peak and a.stop <= b.peak and b.start > a.peak
    pieces = cut_actions(m)
    assert [p.n_frames for p in pieces] == [a.stop - a.start for a in acts]
    np.testing.assert_array_equal(pieces[0].rotations, m.rotations[acts[0].start:acts[0].stop])


def test_bandai_spinning_kicks_at_the_manifest_times(real_data_dir):
    """MANIFEST: three right-leg spinning kicks at t ~ 1.5-3.0, 6.0-7.5, 10.5-11.9 s."""
    m = _load(real_data_dir, "kicks_punches/bandai1_kick_normal_001.bvh")
    for a, (t0, t1) in zip(find_actions(m), [(1.5, 3.0), (6.0, 7.5), (10.5, 11.9)]):
        assert t0 <= a.peak / m.fps <= t1


def test_a_strike_and_its_reverse_repeated_are_found_each_time(real_data_dir):
    """Known answer: one cut strike, then the same played backwards, twice (a continuous take: each
    piece ends where the next begins) holds four strikes, peaking at ``p``, ``2n - 1 - p``,
    ``2n + p``, ``4n - 1 - p`` (``n`` frames per piece, ``p`` the strike's own peak)."""
    m = _load(real_data_dir, "kicks_punches/bandai1_punch_normal_002.bvh")
    one = find_actions(m)[1].cut(m)
    n, p = one.n_frames, find_actions(m)[1].peak - find_actions(m)[1].start
    order = [slice(None), slice(None, None, -1)] * 2
    take = one.replace(root_positions=np.concatenate([one.root_positions[o] for o in order]),
                       rotations=np.concatenate([one.rotations[o] for o in order]))
    peaks = [a.peak for a in find_actions(take)]
    np.testing.assert_allclose(peaks, [p, 2 * n - 1 - p, 2 * n + p, 4 * n - 1 - p], atol=1)


def test_errors_and_selection_syntax(real_data_dir):
    m = _load(real_data_dir, "kicks_punches/bandai1_punch_normal_001.bvh")
    still = m.replace(root_positions=np.repeat(m.root_positions[:1], 40, 0),
                      rotations=np.repeat(m.rotations[:1], 40, 0))
    with pytest.raises(ConcatError, match="no hand or foot moves"):
        find_actions(still)
    with pytest.raises(ConcatError, match="too short"):
        find_actions(m[:3])
    assert parse_selection("a/b.bvh@2") == ("a/b.bvh", 2, None)
    assert parse_selection("a/b.bvh@10:20") == ("a/b.bvh", None, (10, 20))
    assert parse_selection("a@b.bvh") == ("a@b.bvh", None, None)
