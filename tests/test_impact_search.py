"""mocomp.impact.search: eq. 4.1 window distance, unique-frame search vs the exhaustive reference."""
from __future__ import annotations

import numpy as np
import pytest

import mocomp.datasets as datasets
from mocomp.errors import MotionFormatError
from mocomp.impact import _kernels
from mocomp.impact.features import BODY_PARTS, body_features, ground_frame_features
from mocomp.impact.index import build_index
from mocomp.impact.search import (_distances, _Query, search, support_foot_of, window_distance, window_weights)
from mocomp.io import load, write_bvh
from mocomp.ops.align import yaw_quaternion
from mocomp.ops.synthetic import synthetic_walk


@pytest.fixture(scope="module")
def index(tmp_path_factory):
    d = tmp_path_factory.mktemp("lib")
    write_bvh(synthetic_walk(duration=2.0, fps=30.0).motion, d / "walk.bvh")
    write_bvh(synthetic_walk(duration=1.5, fps=30.0, speed=1.2, stride_time=1.0).motion, d / "fast_walk.bvh")
    write_bvh(datasets.load_example("jump").motion, d / "jump.bvh")
    write_bvh(datasets.load_example("backflip").motion.resample(60.0), d / "backflip.bvh")
    victim = synthetic_walk(duration=1.0, fps=30.0).motion.skeleton
    return build_index(d, victim, cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def _wrap(a):
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def test_window_weights_eq_a1():
    np.testing.assert_allclose(window_weights(5), [1.0, 15 / 16, 3 / 4, 7 / 16, 0.0])
    np.testing.assert_allclose(window_weights(2), [1.0, 0.0])
    with pytest.raises(ValueError, match="at least 2"):
        window_weights(1)


def test_kernel_equals_the_written_out_eq_4_1(index):
    """The compiled kernel, the numpy reference and eq. 4.1 written out (both windows aligned at their
    first frame with ground_frame_features) agree on random library windows."""
    m = index.motion("jump.bvh")
    c = index.clip("jump.bvh")
    q = _Query(index, m, 20, 36, "left")
    L = q.L
    rows = np.array([0, 3, 17, 40, c.n_frames - L], dtype=np.int64) + int(index.concatenated()["start"][1])
    ref = q.terms(rows).sum(axis=1)
    cat = index.concatenated()
    Fq = body_features(m[20:36])
    qp, qo = ground_frame_features(Fq.positions, Fq.orientations, Fq.ground[0], Fq.heading[0])
    np.testing.assert_allclose(q.qp, qp[:-1], atol=1e-12)    # the search's own FK path = body_features
    np.testing.assert_allclose(q.qo, qo[:-1], atol=1e-12)
    for r, d_ref in zip(rows, ref):
        P, O = cat["positions"][r:r + L], cat["orientations"][r:r + L]
        cp, co = ground_frame_features(P, O, cat["ground"][r], cat["heading"][r])
        np.testing.assert_allclose(window_distance(qp, qo, cp, co, "left"), d_ref, rtol=1e-10)
    if _kernels.AVAILABLE:
        d, n = _distances(q, rows)
        np.testing.assert_allclose(d, ref, rtol=1e-10)
        assert n == rows.size * (L - 1)                     # the last frame has weight 0
        # early abandoning never changes a distance within the threshold
        thr = float(np.median(ref))
        d2, n2 = _distances(q, rows, thr, acc0=q.terms(rows, slice(0, 1))[:, 0], bound=True)
        np.testing.assert_allclose(d2[ref <= thr], ref[ref <= thr], rtol=1e-10)
        assert np.all(np.isinf(d2[ref > thr])) and n2 < n


@pytest.mark.parametrize("clip,start,length", [("walk.bvh", 7, 16), ("jump.bvh", 120, 108), ("backflip.bvh", 24, 20),
                                               ("fast_walk.bvh", 0, 20)])
def test_query_cut_from_a_clip_finds_it_after_any_yaw_and_shift(index, clip, start, length):
    yaw, shift = 2.3, np.array([1.5, 0.0, -0.7])
    m = index.motion(clip)
    query = m.rotated(yaw_quaternion(yaw)).translated(shift)
    for exhaustive in (True, False):
        r = search(index, query, start, start + length, exhaustive=exhaustive)
        assert (r.clip, r.frame) == (str(index.clip(clip).path), start) and r.distance < 1e-5   # arccos near 1: ~1e-8 rad per body
        assert abs(_wrap(r.root_transform.yaw - yaw)) < 1e-9
        # the transform maps the clip onto the query: every joint of the window, not only the root
        moved = r.root_transform.apply(m)
        np.testing.assert_allclose(moved.positions[start:start + length], query.positions[start:start + length],
                                   atol=1e-9)
        y, t = r.root_transform
        assert t[1] == 0.0 and y == r.root_transform.yaw
        assert r.runner_up is not None and r.runner_up.distance >= r.distance
        assert r.runner_up.clip != r.clip or abs(r.runner_up.frame - r.frame) >= length - 1
        s = r.stats
        L = int(round(length * index.fps / m.fps))           # the window at the index rate (30 Hz)
        assert s["window_frames"] == L and s["frames_exhaustive"] == s["windows_exhaustive"] * (L - 1)
        if exhaustive:
            assert s["frames_compared"] == s["frames_exhaustive"]
        else:
            # compiled: early abandoning with bounds; numpy fallback: whole windows, still fewer of them
            assert s["frames_compared"] < s["frames_exhaustive"] / (3 if _kernels.AVAILABLE else 1)
            assert s["unique_windows"] > 0 and s["frames_exact"] <= s["frames_compared"]


def test_resampled_query_and_native_frame_numbers(index):
    """A 120 Hz query of a 60 Hz library clip (indexed at 30 Hz): the window is resampled to the index
    rate and the result is in the clip's own 60 Hz frame numbers."""
    m = index.motion("backflip.bvh")                          # 60 Hz
    c = index.clip("backflip.bvh")
    assert c.resampled and abs(c.native_fps - 60.0) < 1e-6
    q = m.resample(120.0)
    r = search(index, q, 80, 80 + 60, exhaustive=True)        # 0.5 s from t = 2/3 s: index frame 20, 60 Hz frame 40
    assert r.clip == c.path and r.frame == 40 and r.stats["query_resampled"] and r.stats["index_frame"] == 20
    assert r.distance < 1e-6


def test_same_best_as_exhaustive_on_the_synthetic_library(index):
    rng = np.random.default_rng(7)
    walk = synthetic_walk(duration=3.0, fps=30.0, speed=0.9).motion          # not in the library
    for _ in range(6):
        L = int(rng.integers(8, 28))
        s = int(rng.integers(0, walk.n_frames - L))
        q = walk.rotated(yaw_quaternion(rng.uniform(-3, 3)))
        a, b = search(index, q, s, s + L), search(index, q, s, s + L, exhaustive=True)
        assert (a.clip, a.frame) == (b.clip, b.frame)
        np.testing.assert_allclose(a.distance, b.distance, rtol=1e-12)


def test_support_foot_nearest_the_com_among_feet_on_the_ground():
    P = np.zeros((16, 3))
    kl, kr = BODY_PARTS.index("foot_l"), BODY_PARTS.index("foot_r")
    P[kl] = [0.2, 0.05, 0.0]
    P[kr] = [-0.2, 0.06, 0.0]
    assert support_foot_of(np.array([0.15, 1.0, 0.0]), P) == "left"
    assert support_foot_of(np.array([-0.1, 1.0, 0.0]), P) == "right"
    P[kr, 1] = 0.3                                                            # right foot in the air
    assert support_foot_of(np.array([-0.1, 1.0, 0.0]), P) == "left"


def test_bad_queries(index):
    m = index.motion("walk.bvh")
    with pytest.raises(ValueError, match="0 <= start < stop"):
        search(index, m, 10, 5)
    with pytest.raises(ValueError, match="0 <= start < stop"):
        search(index, m, 0, m.n_frames + 1)
    with pytest.raises(ValueError, match="support_foot"):
        search(index, m, 0, 10, support_foot="middle")
    long = synthetic_walk(duration=12.0, fps=30.0).motion
    with pytest.raises(ValueError, match="no clip can hold the window"):
        search(index, long, 0, 300)
    other = load_example_other()
    with pytest.raises(MotionFormatError, match="skeleton"):
        search(index, other, 0, 10)


def load_example_other():
    m = synthetic_walk(duration=1.0, fps=30.0).motion
    return m.replace(skeleton=m.skeleton.scaled(1.1))


# ------------------------------------------------------------------ real data
@pytest.fixture(scope="module")
def shared(real_data_dir, tmp_path_factory):
    ase = load(real_data_dir / "idle" / "ase_rl_Idle_Ready.derived.bvh").skeleton
    return build_index(real_data_dir / "reactions", ase, cache_dir=tmp_path_factory.mktemp("c"), progress=False)


@pytest.mark.realdata
def test_unique_frame_search_matches_exhaustive_on_the_shared_library(shared, real_data_dir):
    """The victims (standing, walking, running) at 4 starts each and 11 windows cut from library clips
    (turned and shifted at random), 0.9 s windows (the paper's search window is 0.1-1.0 s after the
    impact): the unique-frame search returns the exhaustive best everywhere and compares >= 10x fewer
    frame pairs in all."""
    rng = np.random.default_rng(18)
    queries = []
    for f in ("idle/ase_rl_Idle_Ready.derived.bvh", "walks/ase_rl_WalkForward01.derived.bvh",
              "runs/ase_rl_RunForward.derived.bvh"):
        m = load(real_data_dir / f)
        queries += [(m, int(s)) for s in np.linspace(0, m.n_frames - 28, 4).astype(int)]
    for c in shared.clips[:11]:
        m = shared.motion(c.path).rotated(yaw_quaternion(rng.uniform(-np.pi, np.pi)))
        queries.append((m.translated([rng.uniform(-2, 2), 0.0, rng.uniform(-2, 2)]), int(rng.integers(0, c.n_frames - 27))))
    compared = exhaustive = 0
    for m, s in queries:
        a, b = search(shared, m, s, s + 27), search(shared, m, s, s + 27, exhaustive=True)
        assert (a.clip, a.frame) == (b.clip, b.frame)
        np.testing.assert_allclose(a.distance, b.distance, rtol=1e-12)
        compared += a.stats["frames_compared"]
        exhaustive += b.stats["frames_compared"]
    # compiled: early abandoning on the bound stage; the numpy fallback compares whole windows
    assert exhaustive >= (10 if _kernels.AVAILABLE else 2) * compared, exhaustive / compared


@pytest.mark.realdata
def test_cmu_match_reports_file_frame_numbers(shared):
    """The CMU stumble (120 Hz, T-pose frame 0 not searched): a window cut at its own 120 Hz frame 121
    is found there (index frame 30 at 30 Hz) with the root transform of that frame."""
    c = shared.clip("cmu_91_59_stumble.bvh")
    m = shared.motion(c.path)
    q = m.rotated(yaw_quaternion(-1.0)).translated([0.3, 0.0, 0.4])
    r = search(shared, q, 121, 121 + 100, exhaustive=True)
    # the file says 120.00048 Hz: index frame 30 is native frame 121.0006, hence not exactly 0
    assert r.clip == c.path and r.frame == 121 and r.stats["index_frame"] == 30 and r.distance < 1e-2
    assert abs(_wrap(r.root_transform.yaw + 1.0)) < 1e-9
    np.testing.assert_allclose(r.root_transform.apply(m).root_positions[121], q.root_positions[121], atol=1e-9)


def test_numpy_fallback_gives_the_same_search(index, monkeypatch):
    """Without numba the search runs on the numpy reference (no abandoning): same result."""
    q = synthetic_walk(duration=2.0, fps=30.0, speed=0.9).motion.rotated(yaw_quaternion(0.4))
    fast = [search(index, q, s, s + 20, exhaustive=e) for s in (3, 25) for e in (False, True)]
    monkeypatch.setattr(_kernels, "AVAILABLE", False)
    slow = [search(index, q, s, s + 20, exhaustive=e) for s in (3, 25) for e in (False, True)]
    for a, b in zip(fast, slow):
        assert (a.clip, a.frame) == (b.clip, b.frame)
        # arccos of dot products within rounding of 1 (numpy's vs numba's): ~1e-9 apart
        np.testing.assert_allclose(a.distance, b.distance, rtol=1e-7)
        assert (a.runner_up.clip, a.runner_up.frame) == (b.runner_up.clip, b.runner_up.frame)
        np.testing.assert_allclose(a.runner_up.distance, b.runner_up.distance, rtol=1e-7)
        assert a.stats.get("refined_regions") == b.stats.get("refined_regions")


def test_mocomp_no_numba_switches_the_search_to_numpy(tmp_path):
    """``MOCOMP_NO_NUMBA=1`` (the project's switch) turns the compiled search off; it still runs."""
    import os
    import subprocess
    import sys

    code = ("from mocomp.impact import _kernels; from mocomp.impact.search import search; "
            "from mocomp.impact.index import build_index; from mocomp.io import write_bvh; "
            "from mocomp.ops.synthetic import synthetic_walk; import pathlib; "
            f"d = pathlib.Path({str(tmp_path)!r}); m = synthetic_walk(duration=2.0, fps=30.0).motion; "
            "write_bvh(m, d / 'walk.bvh'); i = build_index(d, m.skeleton, progress=False, use_cache=False); "
            "r = search(i, m, 10, 30); print(_kernels.AVAILABLE, r.frame, r.stats['frames_compared'] == "
            "r.stats['frames_exact'])")
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, "MOCOMP_NO_NUMBA": "1"},
                         capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "10", "True"]


@pytest.mark.skipif(not _kernels.AVAILABLE, reason="the compiled bound stage")
def test_bound_stage_is_below_every_exact_term_and_tight(index):
    """The compiled search's first stage: the chord bound 2 sqrt(2 (1 - |d|)) of each angle 2 acos|d|
    makes every frame term a lower bound of the exact one, within theta^2/96 (relative) per angle."""
    m = synthetic_walk(duration=2.0, fps=30.0, speed=0.9).motion.rotated(yaw_quaternion(1.1))
    q = _Query(index, m, 5, 30, None)
    rows = np.arange(0, q.P.shape[0] - q.L, 7)
    lo = np.empty((rows.size, q.frames.size))
    ex = np.empty_like(lo)
    for i, r in enumerate(rows):
        psi = q.H[r]
        trig = (np.cos(psi), np.sin(psi), np.cos(0.5 * psi), np.sin(0.5 * psi))
        for f in range(q.frames.size):
            args = (q.P, q.O, int(r + f), q.qp, q.qo, q.yqo, f, q.wp, q.wr, *q.G[r], *trig)
            lo[i, f] = _kernels._frame_term(*args, False)
            ex[i, f] = _kernels._frame_term(*args, True)
    np.testing.assert_allclose((ex * q.w).sum(axis=1), q.terms(rows).sum(axis=1), rtol=1e-10)
    assert np.all(lo <= ex) and np.all(lo >= 0)
    # the angular part is at most ~10 % of a term here, and its bound loses < 1/96 of angles below 1 rad
    assert np.median((ex - lo) / ex) < 2e-3


def test_exhaustive_runner_up_is_the_best_window_far_from_the_best(index):
    """exhaustive=True: the runner-up is the least eq. 4.1 distance over every window in another clip
    or at least a window length from the best one (brute force over all windows)."""
    m = synthetic_walk(duration=3.0, fps=30.0, speed=0.9).motion
    cat = index.concatenated()
    for s, L in ((4, 20), (30, 12)):
        r = search(index, m, s, s + L, exhaustive=True)
        q = _Query(index, m, s, s + L, None)
        rows = np.concatenate([st + np.arange(n - L + 1) for st, n in zip(cat["start"], cat["length"]) if n >= L])
        d = q.terms(rows).sum(axis=1)
        best = rows[np.argmin(d)]
        far = (cat["row_clip"][rows] != cat["row_clip"][best]) | (np.abs(rows - best) >= L)
        np.testing.assert_allclose([r.distance, r.runner_up.distance], [d.min(), d[far].min()], rtol=1e-7)
        # the rows found (the synthetic walks repeat their steps: near-ties, compare distances)
        row = {}
        for k, res in (("best", r), ("ru", r.runner_up)):
            ci = [c.path for c in index.clips].index(res.clip)
            row[k] = int(cat["start"][ci] + res.stats["index_frame"])
        assert cat["row_clip"][row["ru"]] != cat["row_clip"][row["best"]] or abs(row["ru"] - row["best"]) >= L
        np.testing.assert_allclose(d[rows == row["ru"]], d[far].min(), rtol=1e-7)


@pytest.mark.realdata
def test_exact_runner_up_mode_equals_the_exhaustive_runner_up(shared, real_data_dir):
    """runner_up='exact': the best from the unique-frame search, every far window it left uncomputed
    summed in full: the exhaustive runner-up (clip, frame, distance) in every query where the best is the
    exhaustive best (the default 'fast' runner-up: 16 of the benchmark's 23). The default is unchanged."""
    rng = np.random.default_rng(18)
    queries = []
    for f in ("idle/ase_rl_Idle_Ready.derived.bvh", "runs/ase_rl_RunForward.derived.bvh"):
        m = load(real_data_dir / f)
        queries += [(m, int(s)) for s in np.linspace(0, m.n_frames - 28, 3).astype(int)]
    for c in shared.clips[:6]:
        m = shared.motion(c.path).rotated(yaw_quaternion(rng.uniform(-np.pi, np.pi)))
        queries.append((m, int(rng.integers(0, c.n_frames - 27))))
    for m, s in queries:
        fast = search(shared, m, s, s + 27)
        ex = search(shared, m, s, s + 27, runner_up="exact")
        ref = search(shared, m, s, s + 27, exhaustive=True)
        assert (ex.clip, ex.frame, ex.distance) == (fast.clip, fast.frame, fast.distance)   # the best untouched
        assert fast.stats["runner_up_mode"] == "fast" and ex.stats["runner_up_mode"] == "exact"
        assert (ex.clip, ex.frame) == (ref.clip, ref.frame)
        assert (ex.runner_up.clip, ex.runner_up.frame) == (ref.runner_up.clip, ref.runner_up.frame)
        np.testing.assert_allclose(ex.runner_up.distance, ref.runner_up.distance, rtol=1e-9)
        assert ex.runner_up.distance <= fast.runner_up.distance + 1e-12
        assert 0 < ex.stats["frames_runner_up"] <= ref.stats["frames_compared"]
    with pytest.raises(ValueError, match="runner_up"):
        search(shared, queries[0][0], 0, 27, runner_up="best")
