"""mocomp.impact.index / .retarget and `mocomp impact-index`: unique frames (eq. 4.2), the
content-addressed cache, retargeting or refusing clips of other skeletons."""
from __future__ import annotations

import numpy as np
import pytest

import mocomp.datasets as datasets
from mocomp.body.mapping import resolve_mapping
from mocomp.cli import main
from mocomp.core import Motion, Skeleton
from mocomp.core.rotations import quat_apply
from mocomp.impact.features import part_weights
from mocomp.impact.index import (LibraryError, build_index, frame_distances, library_files, unique_frames)
from mocomp.impact.retarget import RetargetError, retarget
from mocomp.io import load, write_bvh
from mocomp.ops.synthetic import synthetic_walk


def _library(d):
    """Four synthetic clips on one 31-joint skeleton, at 30, 120 and 60 Hz."""
    d.mkdir(parents=True, exist_ok=True)
    write_bvh(synthetic_walk(duration=2.0, fps=30.0).motion, d / "walk.bvh")
    write_bvh(synthetic_walk(duration=1.5, fps=30.0, speed=1.2, stride_time=1.0).motion, d / "fast_walk.bvh")
    write_bvh(datasets.load_example("jump").motion, d / "jump.bvh")
    write_bvh(datasets.load_example("twist180").motion.resample(60.0), d / "sub" / "twist.bvh") \
        if (d / "sub").mkdir() is None else None
    return d


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    return _library(tmp_path_factory.mktemp("lib"))


@pytest.fixture(scope="module")
def victim():
    return synthetic_walk(duration=1.0, fps=30.0).motion.skeleton


def _brute_unique(P, O, T, wp, wr):
    """Eq. 4.2 literally: F_0 = f_0; f_i is unique iff d(last unique, f_i) > T."""
    out = [0]
    for i in range(1, P.shape[0]):
        if frame_distances(P[out[-1]], O[out[-1]], P[i], O[i], wp, wr) > T:
            out.append(i)
    return out


def test_unique_frames_known_spacing():
    """All 16 bodies slide 1 cm per frame: d(j, i) = 0.01 |i - j| sum(w_p) = 0.063 |i - j| (Table A.1),
    so with T = 0.5 every 8th frame is unique (7 frames: 0.441 <= T, 8 frames: 0.504 > T)."""
    N = 50
    P = np.zeros((N, 16, 3))
    P[..., 0] = 0.01 * np.arange(N)[:, None]
    O = np.zeros((N, 16, 4))
    O[..., 3] = 1.0
    u, computed = unique_frames(P, O, 0.5)
    np.testing.assert_array_equal(u, np.arange(0, N, 8))
    assert computed <= 2 * N
    # a rotation of every body by 0.1 rad per frame adds 0.1 * sum(w_theta) = 0.063 per frame: every 4th frame
    ang = 0.1 * np.arange(N)
    O2 = np.zeros((N, 16, 4))
    O2[..., 1] = np.sin(ang / 2)[:, None]
    O2[..., 3] = np.cos(ang / 2)[:, None]
    np.testing.assert_array_equal(unique_frames(P, O2, 0.5)[0], np.arange(0, N, 4))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_unique_frames_equal_the_recursive_definition_and_are_linear(seed):
    rng = np.random.default_rng(seed)
    N = 400
    P = np.cumsum(rng.normal(0, 0.01, (N, 16, 3)), axis=0)
    P[rng.integers(0, N, 5)] += 0.3                     # a few jumps back and forth
    O = rng.normal(size=(N, 16, 4))
    O /= np.linalg.norm(O, axis=-1, keepdims=True)
    O = np.cumsum(O * 0.02, axis=0) + np.array([0, 0, 0, 1.0])
    O /= np.linalg.norm(O, axis=-1, keepdims=True)
    wp, wr = part_weights(None)
    for T in (0.2, 0.5, 1.5):
        u, computed = unique_frames(P, O, T)
        assert u.tolist() == _brute_unique(P, O, T, wp, wr)
        assert computed <= 2 * N + 4 * len(u)           # each frame compared once plus block tails


def test_index_cache_reuse_and_invalidation(lib, victim, tmp_path):
    cache = tmp_path / "cache"
    a = build_index(lib, victim, cache_dir=cache, progress=False)
    assert [c.name for c in a.clips] == ["fast_walk.bvh", "jump.bvh", "sub/twist.bvh", "walk.bvh"]
    assert not any(c.cached for c in a.clips) and not a.refused
    assert len(list(cache.glob("*.npz"))) == 4 and not list(cache.glob(".tmp-*"))
    jump = a.clip("jump.bvh")
    assert jump.resampled and jump.native_fps == 120.0 and abs(jump.n_frames - jump.native_frames / 4) <= 1
    assert not a.clip("walk.bvh").resampled
    for c in a.clips:
        assert c.unique[0] == 0 and np.all(np.diff(c.unique) > 0) and c.unique.size < c.n_frames
    b = build_index(lib, victim, cache_dir=cache, progress=False)
    assert all(c.cached for c in b.clips)
    for ca, cb in zip(a.clips, b.clips):
        np.testing.assert_array_equal(ca.unique, cb.unique)
        np.testing.assert_array_equal(ca.features.positions, cb.features.positions)
        np.testing.assert_array_equal(ca.features.masses, cb.features.masses)
    # another tolerance is another key: rebuilt, fewer unique frames for a larger T
    c = build_index(lib, victim, cache_dir=cache, progress=False, tolerance=1.0)
    assert not any(x.cached for x in c.clips)
    assert all(x.unique.size <= y.unique.size for x, y in zip(c.clips, a.clips))
    # one clip's bytes change: only it is rebuilt
    changed = tmp_path / "lib2"
    _library(changed)
    write_bvh(synthetic_walk(duration=2.0, fps=30.0, speed=0.8).motion, changed / "walk.bvh")
    d = build_index(changed, victim, cache_dir=cache, progress=False)
    assert {x.name: x.cached for x in d.clips} == {"fast_walk.bvh": True, "jump.bvh": True, "sub/twist.bvh": True,
                                                  "walk.bvh": False}
    assert d.clip("walk.bvh").sha256 != a.clip("walk.bvh").sha256
    assert not np.allclose(d.clip("walk.bvh").features.positions[10:], a.clip("walk.bvh").features.positions[10:],
                           atol=1e-3)
    # the index's motion() refuses a file that changed after indexing
    write_bvh(synthetic_walk(duration=2.0, fps=30.0, speed=0.7).motion, changed / "walk.bvh")
    with pytest.raises(LibraryError, match="changed since the index"):
        d.motion("walk.bvh")
    m = d.motion("jump.bvh")
    assert m.skeleton == victim and m.n_frames == d.clip("jump.bvh").native_frames


def test_damaged_cache_files_are_rebuilt(lib, victim, tmp_path):
    cache = tmp_path / "cache"
    a = build_index(lib, victim, cache_dir=cache, progress=False)
    files = sorted(cache.glob("*.npz"))
    files[0].write_bytes(files[0].read_bytes()[:200])          # truncated
    files[1].write_text("garbage")
    b = build_index(lib, victim, cache_dir=cache, progress=False)
    assert sum(not c.cached for c in b.clips) == 2
    for ca, cb in zip(a.clips, b.clips):
        np.testing.assert_array_equal(ca.unique, cb.unique)
    assert all(c.cached for c in build_index(lib, victim, cache_dir=cache, progress=False).clips)


def test_no_cache_writes_nothing(lib, victim, tmp_path):
    idx = build_index(lib, victim, cache_dir=tmp_path / "c", progress=False, use_cache=False)
    assert len(idx.clips) == 4 and not (tmp_path / "c").exists() and idx.cache_dir is None


def _legless(walk: Motion) -> Motion:
    """The walk with the legs removed: a skeleton no naming convention can map."""
    sk = walk.skeleton
    keep = [j for j, n in enumerate(sk.names) if not any(s in n for s in ("UpLeg", "Leg", "Foot", "Toe", "HipJoint"))]
    remap = {j: i for i, j in enumerate(keep)}
    parents = [-1 if sk.parents[j] < 0 else remap[int(sk.parents[j])] for j in keep]
    new = Skeleton(tuple(sk.names[j] for j in keep), parents, sk.offsets[keep])
    return Motion(new, walk.fps, walk.root_positions, walk.rotations[:, keep])


def test_refuses_a_clip_it_cannot_map_and_errors_on_an_empty_library(lib, victim, tmp_path):
    d = tmp_path / "mixed"
    d.mkdir()
    walk = synthetic_walk(duration=1.0, fps=30.0).motion
    write_bvh(walk, d / "good.bvh")
    write_bvh(_legless(walk), d / "legless.bvh")
    (d / "notes.txt").write_text("not a motion")
    idx = build_index(d, victim, cache_dir=tmp_path / "c", progress=False)
    assert [c.name for c in idx.clips] == ["good.bvh"]
    reasons = dict(idx.refused)
    why = reasons[str(d / "legless.bvh")]
    assert "legless.bvh" in why and "LeftUpLeg" in why and "missing" in why
    assert "notes.txt" in reasons[str(d / "notes.txt")]
    bad = tmp_path / "bad"
    bad.mkdir()
    write_bvh(_legless(walk), bad / "legless.bvh")
    with pytest.raises(LibraryError, match="no usable clip.*legless.bvh.*LeftUpLeg"):
        build_index(bad, victim, cache_dir=tmp_path / "c", progress=False)
    with pytest.raises(LibraryError, match="not a directory"):
        build_index(tmp_path / "nowhere", victim, progress=False)
    with pytest.raises(RetargetError, match="legless"):
        retarget(_legless(walk), victim, name="legless")


def test_retarget_same_joints_other_bone_lengths():
    walk = synthetic_walk(duration=1.0, fps=30.0).motion
    big = walk.replace(skeleton=walk.skeleton.scaled(1.25), root_positions=walk.root_positions * 1.25)
    out, notes = retarget(big, walk.skeleton)
    assert out.skeleton == walk.skeleton and "other bone lengths" in notes[0]
    np.testing.assert_allclose(out.rotations, walk.rotations, atol=1e-12)
    np.testing.assert_allclose(out.root_positions, walk.root_positions, atol=1e-9)
    same, notes = retarget(walk, walk.skeleton)
    assert same is walk and notes == ()


def test_library_files_skip_hidden(tmp_path):
    (tmp_path / ".hidden").mkdir()
    (tmp_path / ".hidden" / "a.bvh").write_text("x")
    (tmp_path / "b.bvh").write_text("x")
    (tmp_path / "c.csv").write_text("x")
    assert [p.name for p in library_files(tmp_path)] == ["b.bvh"]


def test_cli_impact_index(lib, tmp_path, capsys):
    assert main(["impact-index", str(lib), "--cache", str(tmp_path / "c"), "--json", str(tmp_path / "i.json")]) == 0
    out = capsys.readouterr().out
    assert "walk.bvh" in out and "sub/twist.bvh" in out and "total" in out and "built" in out
    assert main(["impact-index", str(lib), "--cache", str(tmp_path / "c"), "--tolerance", "0.5"]) == 0
    assert "cache" in capsys.readouterr().out
    import json

    rows = json.loads((tmp_path / "i.json").read_text())["clips"]
    assert {r["clip"] for r in rows} == {"walk.bvh", "fast_walk.bvh", "jump.bvh", "sub/twist.bvh"}
    assert main(["impact-index", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mocomp impact-index: error:") and "not a directory" in err and "\n" not in err
    with pytest.raises(SystemExit) as e:
        main(["impact-index", str(lib), "--tolerance", "-1"])
    assert e.value.code == 2 and "--tolerance" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["impact-index", str(empty)]) == 2
    assert "no readable motion file" in capsys.readouterr().err


# ------------------------------------------------------------------ real data
def _segment_directions(motion: Motion) -> np.ndarray:
    """``(T, 16, 3)`` world unit vectors proximal -> distal landmark of each canonical segment."""
    res = resolve_mapping(motion.skeleton)
    P, G = motion.fk()
    rest = motion.skeleton.rest_positions()
    j = res.carriers
    a = P[:, j] + quat_apply(G[:, j], res.proximal - rest[j])
    b = P[:, j] + quat_apply(G[:, j], res.distal - rest[j])
    d = b - a
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


@pytest.mark.realdata
@pytest.mark.parametrize("clip", ["reactions/deepmimic_humanoid3d_getup_faceup.txt", "reactions/cmu_91_59_stumble.bvh"])
def test_retarget_onto_ase_keeps_every_segment_direction(real_data_dir, clip):
    ase = load(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh").skeleton
    src = load(real_data_dir / clip)
    out, notes = retarget(src, ase)
    assert out.skeleton == ase and "by segment carriers" in notes[0]
    # every segment that has a joint of its own on the ASE skeleton points where the clip's does (ASE's
    # pelvis carries the middle and the lower trunk: the middle trunk follows the lower one there)
    res = resolve_mapping(ase)
    own = [k for k, j in enumerate(res.carriers) if np.count_nonzero(res.carriers == j) == 1]
    assert len(own) == 14 and res.segments[2] == "middle_trunk" and 2 not in own
    a, b = _segment_directions(src)[:, own], _segment_directions(out)[:, own]
    angle = np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))
    assert angle.max() < 1e-9
    # the mid-hip point follows the clip's, scaled by the leg-length ratio (printed in the note)
    scale = float(notes[0].rsplit("x ", 1)[1].split()[0])
    mid = lambda m: m.positions[:, [m.skeleton.index(n) for n in (("left_thigh", "right_thigh") if "pelvis" in
                                                                    m.skeleton else ("LeftUpLeg", "RightUpLeg")
                                                                    if "Hips" in m.skeleton else
                                                                    ("left_hip", "right_hip"))]].mean(axis=1)
    a, b = mid(src).ravel(), mid(out).ravel()
    fitted = float(a @ b / (a @ a))
    assert abs(fitted - scale) < 1e-4
    np.testing.assert_allclose(b, fitted * a, atol=1e-9)


@pytest.mark.realdata
def test_shared_library_index(real_data_dir, tmp_path):
    ase = load(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh").skeleton
    idx = build_index(real_data_dir / "reactions", ase, cache_dir=tmp_path, progress=False)
    assert len(idx.clips) == 14 and not idx.refused
    cmu = idx.clip("cmu_91_59_stumble.bvh")
    assert cmu.first_frame == 1 and cmu.resampled and abs(cmu.native_fps - 120.0) < 0.01  # T-pose frame not searched
    assert idx.clip("deepmimic_humanoid3d_getup_facedown.txt").resampled
    assert not idx.clip("ase_rl_Fall_Left.derived.bvh").resampled
    # T = 0.5 on 30 Hz clips: about one unique frame in 3-7
    ratio = idx.n_frames / idx.n_unique
    assert 3.0 < ratio < 8.0, ratio
