"""The bone -> segment mapping covers every real clip (all formats with a reader)."""
import warnings

import numpy as np
import pytest

from conftest import real_files
from mocomp.body import BodyModel, detect_convention

EXPECTED = {  # file-name prefix -> naming convention
    "cmu_": "cmu_bvh", "01_01.bvh": "cmu_bvh", "131_": "cmu_3dsmax", "sfu_": "sfu", "bandai": "bandai",
    "mass_": "mass", "deepmimic_": "deepmimic", ".amc": "cmu_asf", "ase_rl_": "ase",
}


def _expected(name):
    for k, v in EXPECTED.items():
        if name.startswith(k) or name.endswith(k):
            return v
    raise AssertionError(f"no expected convention for {name}")


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if path.suffix == ".bvh":
            from mocomp.io import read_bvh

            return read_bvh(path)
        if path.suffix == ".amc":
            from mocomp.io.asf_amc import read_amc

            return read_amc(path)
        from mocomp.io.deepmimic import read_deepmimic

        return read_deepmimic(path)


MOTION_FILES = [p for p in real_files("**/*") if p.suffix in (".bvh", ".amc")
                or (p.suffix == ".txt" and p.name.startswith("deepmimic_") and p.parent.name != "skeletons")]


@pytest.mark.realdata
@pytest.mark.parametrize("path", MOTION_FILES, ids=lambda p: p.name)
def test_mapping_covers_clip(path, real_data_dir):
    motion = _load(path)
    sk = motion.skeleton
    conv = detect_convention(sk)
    assert conv.name == _expected(path.name)
    body = BodyModel.from_skeleton(sk, total_mass=70.0)
    assert body.total_mass == pytest.approx(70.0)
    assert body.n_segments == 16
    carriers = {sk.names[j] for j in body.segment_joint}
    # every bone is either a carrier or listed as massless, never dropped
    assert carriers | set(body.massless_joints) == set(sk.names)
    assert not carriers & set(body.massless_joints)
    # limb segments of the two sides ride on mirror-image joints
    mirror = sk.mirror_map()
    for kind in ("upper_arm", "forearm", "hand", "thigh", "shank", "foot"):
        jl, jr = body.segment_joint[body.segment(kind + "_l")], body.segment_joint[body.segment(kind + "_r")]
        assert mirror[jl] == jr, (kind, sk.names[jl], sk.names[jr])
    # in a standing frame-0 pose, the COM lies between the feet and the head
    P = motion.positions[0]
    com = (body.masses[:, None] * (P[body.segment_joint] + np.einsum(
        "sij,sj->si", _rotm(motion.global_rotations[0, body.segment_joint]), body.local_coms))).sum(0) / 70.0
    lo, hi = P[:, 1].min(), P[:, 1].max()
    assert lo < com[1] < hi


def _rotm(q):
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).as_matrix()


@pytest.mark.realdata
def test_deepmimic_character_masses_load_into_body_model(real_data_dir):
    from mocomp.io.deepmimic import read_deepmimic, read_deepmimic_body

    char = real_data_dir / "skeletons" / "deepmimic_humanoid3d_character.txt"
    motion = read_deepmimic(real_data_dir / "flips" / "deepmimic_backflip.txt", character=char)
    given = read_deepmimic_body(char, motion.skeleton)
    assert given.total_mass == pytest.approx(45.0)
    table = BodyModel.from_skeleton(motion.skeleton, total_mass=45.0)
    # the character's own trunk (root + chest + neck bodies: 22 kg) vs de Leva trunk + head (50.4 %)
    own_trunk = sum(m for n, m in zip(given.segment_names, given.masses) if n in ("root", "chest", "neck"))
    assert own_trunk == pytest.approx(22.0)
    assert table.masses[:4].sum() == pytest.approx(0.504 * 45.0, rel=1e-3)
    # left/right pairs of the character's own bodies are found through the joint mirror map
    from mocomp.body import symmetric_groups

    pairs = {tuple(sorted(given.segment_names[i] for i in g)) for g in symmetric_groups(given) if len(g) == 2}
    assert ("left_hip", "right_hip") in pairs and ("left_wrist", "right_wrist") in pairs and len(pairs) == 6


def _oracle_landmark(sk, spec, landmarks, rest, depth=0):
    """The landmark resolution asking the skeleton for every name (Skeleton.find, a scan of its end
    sites), as mapping did before it built its name lookups once: the oracle for those lookups."""
    rec = lambda s: _oracle_landmark(sk, s, landmarks, rest, depth + 1)  # noqa: E731
    if isinstance(spec, str):
        if spec.endswith("/end"):
            j = sk.find(spec[:-4])
            ends = [e for e in sk.end_sites if j is not None and e.parent == j]
            p = rest[j] + ends[0].offset if ends else None
        elif sk.find(spec) is not None:
            p = rest[sk.find(spec)]
        else:
            ends = [e for e in sk.end_sites if e.name == spec]
            p = rest[ends[0].parent] + ends[0].offset if ends else None
        if p is None and spec in landmarks and landmarks[spec] != spec:
            p = rec(landmarks[spec])
        return p
    if spec[0] == "first":
        return next((p for p in map(rec, spec[1:]) if p is not None), None)
    if spec[0] == "offset":
        return None if sk.find(spec[1]) is None else rest[sk.find(spec[1])] + np.asarray(spec[2], dtype=float)
    a, b = rec(spec[1]), rec(spec[2])
    if a is None or b is None:
        return None
    return 0.5 * (a + b) if spec[0] == "mid" else (a + spec[3] * (b - a) if spec[0] == "lerp" else b + spec[3] * (b - a))


@pytest.mark.realdata
def test_landmarks_and_carriers_equal_the_per_name_lookup_on_every_clip(real_data_dir):
    """Every landmark of every convention, on every real clip's skeleton: the mapping's one-time
    name lookups give the same point (or the same None) as asking the skeleton name by name; the
    resolved carriers are the joints the skeleton finds by name; the toe effector rides on the foot
    carrier's descendant nearest the toe tip (found with Skeleton.chain)."""
    from mocomp.body.mapping import CONVENTIONS, resolve_landmark, resolve_mapping
    from mocomp.dynamics.contacts import default_effectors

    seen = set()
    checked = 0
    for path in MOTION_FILES:
        sk = _load(path).skeleton
        key = (sk.names, sk.offsets.tobytes(), tuple(e.name for e in sk.end_sites))
        if key in seen:
            continue
        seen.add(key)
        rest = sk.rest_positions()
        for conv in CONVENTIONS.values():
            for lm, spec in conv.landmarks.items():
                want = _oracle_landmark(sk, spec, conv.landmarks, rest)
                got = resolve_landmark(sk, spec, conv.landmarks)
                assert (got is None) == (want is None), (path.name, conv.name, lm)
                if got is not None:
                    np.testing.assert_array_equal(got, want)
                    checked += 1
        rm = resolve_mapping(sk)
        assert [sk.names[j] for j in rm.carriers] == [rm.convention.carriers[s] for s in rm.segments]
        eff = default_effectors(sk)
        for side in ("l", "r"):
            foot = int(rm.carriers[rm.segments.index(f"foot_{side}")])
            tip = _oracle_landmark(sk, rm.convention.landmarks[f"TTIP_{side}"], rm.convention.landmarks, rest)
            desc = [c for c in range(sk.n_joints) if foot in sk.chain(c)]
            j = min(desc, key=lambda c: np.linalg.norm(rest[c] - tip))
            assert eff[f"toe_{side}"][0] == j
            np.testing.assert_allclose(eff[f"toe_{side}"][1], tip - rest[j], atol=0)
    assert len(seen) >= 8 and checked > 500
