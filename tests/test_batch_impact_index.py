"""``mocomp batch impact-index``: the impact library index (dissertation sec. 4.1, eq. 4.2) built with
the per-clip work mapped over Dask workers into the content-addressed cache, then merged; it must
equal the index :func:`mocomp.impact.index.build_index` builds in one process."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

import mocomp.datasets as datasets
from _cli import exit_code
from mocomp.batch.impact_index import build_index_batch
from mocomp.impact.index import _FEATURES, build_index
from mocomp.io import write_bvh
from mocomp.ops.synthetic import synthetic_walk


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    """Three synthetic clips on one 31-joint skeleton (30 and 60 Hz), a clip that cannot be read, and
    a file that is not a motion."""
    d = tmp_path_factory.mktemp("lib")
    write_bvh(synthetic_walk(duration=2.0, fps=30.0).motion, d / "walk.bvh")
    write_bvh(datasets.load_example("jump").motion, d / "jump.bvh")
    (d / "sub").mkdir()
    write_bvh(datasets.load_example("twist180").motion.resample(60.0), d / "sub" / "twist.bvh")
    (d / "broken.bvh").write_text("HIERARCHY\nROOT hips {\n")
    (d / "README.md").write_text("# reactions\n")
    return d


@pytest.fixture(scope="module")
def victim():
    return synthetic_walk(duration=1.0, fps=30.0).motion.skeleton


def _same_index(a, b):
    """The two indexes hold the same clips, frames, unique frames and features, and refuse the same files."""
    assert [c.name for c in a.clips] == [c.name for c in b.clips]
    assert [p for p, _ in a.refused] == [p for p, _ in b.refused]
    assert (a.n_frames, a.n_unique, a.tolerance, a.fps) == (b.n_frames, b.n_unique, b.tolerance, b.fps)
    for ca, cb in zip(a.clips, b.clips):
        assert (ca.native_frames, ca.native_fps, ca.first_frame, ca.resampled, ca.key) == \
               (cb.native_frames, cb.native_fps, cb.first_frame, cb.resampled, cb.key)
        np.testing.assert_array_equal(ca.unique, cb.unique)  # frame indices
        for k in _FEATURES:
            np.testing.assert_allclose(getattr(ca.features, k), getattr(cb.features, k), rtol=1e-12, atol=1e-12,
                                       err_msg=f"{ca.name}: {k}")
        np.testing.assert_allclose(ca.native_heading, cb.native_heading, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("workers", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_batch_index_equals_the_in_process_index(lib, victim, tmp_path, workers):
    ref = build_index(lib, victim, use_cache=False, progress=False)
    res = build_index_batch(lib, victim, cache_dir=tmp_path / "cache", workers=workers, out_dir=tmp_path / "out",
                            progress=False)
    assert res.rebuilt == [] and all(c.cached for c in res.index.clips)  # merged from the workers' cache files
    _same_index(res.index, ref)
    t = res.table.set_index("clip")
    assert t["status"].to_dict() == {"README.md": "skipped", "broken.bvh": "failed", "jump.bvh": "ok",
                                     "sub/twist.bvh": "ok", "walk.bvh": "ok"}
    assert "cannot be read as a motion" in t.at["broken.bvh", "error"] and "broken.bvh" in t.at["broken.bvh", "error"]
    for c in ref.clips:
        assert t.at[c.name, "unique"] == c.unique.size and t.at[c.name, "index_frames"] == c.n_frames
        assert t.at[c.name, "cached"] is False
    assert t.at["sub/twist.bvh", "index_frames"] < t.at["sub/twist.bvh", "frames"]  # 60 Hz resampled to 30
    saved = json.loads((tmp_path / "out" / "index.json").read_text())
    assert [c["clip"] for c in saved["clips"]] == [c.name for c in ref.clips]
    assert (tmp_path / "out" / "results.parquet").is_file() and (tmp_path / "out" / "results.csv").is_file()
    # a second run reads every clip back from the cache (what --resume is for the other commands)
    again = build_index_batch(lib, victim, cache_dir=tmp_path / "cache", workers=workers, progress=False)
    assert again.table.set_index("clip").loc[[c.name for c in ref.clips], "cached"].tolist() == [True] * 3
    _same_index(again.index, ref)
    # and an in-process build_index on that cache reads the batch's files
    assert all(c.cached for c in build_index(lib, victim, cache_dir=tmp_path / "cache", progress=False).clips)


def test_cli_batch_impact_index(lib, tmp_path, capsys):
    out, cache = tmp_path / "out", tmp_path / "cache"
    assert exit_code(["batch", "impact-index", str(lib), "-o", str(out), "--cache", str(cache), "--workers", "0",
                      "--no-progress", "--tolerance", "0.5"]) == 0
    text = capsys.readouterr().out
    assert "3 clips indexed (0 from the cache), 1 refused" in text and "1 skipped" in text
    assert "index: 3 clips" in text
    saved = json.loads((out / "index.json").read_text())
    assert saved["tolerance"] == 0.5 and len(saved["clips"]) == 3
    # bad options are the impact-index parser's, in one line
    assert exit_code(["batch", "impact-index", str(lib), "-o", str(out), "--tolerance", "-1", "--workers", "0"]) == 2
    err = capsys.readouterr().err
    assert "--tolerance" in err and err.count("\n") == 1
    assert exit_code(["batch", "impact-index", str(lib), "-o", str(lib / "out"), "--workers", "0"]) == 2
    assert "inside the library" in capsys.readouterr().err
    assert exit_code(["batch", "impact-index", str(tmp_path / "nowhere"), "-o", str(out), "--workers", "0"]) == 2
    assert "not a directory" in capsys.readouterr().err


@pytest.mark.realdata
@pytest.mark.slow
def test_reaction_library_on_two_workers_equals_in_process(real_data_dir, tmp_path):
    """The shared data's reaction library (ASE clips, 1739 frames at 30 Hz, 394 unique at T = 0.5)."""
    from mocomp.cli.impact_index import _majority_skeleton

    d = real_data_dir / "reactions"
    sk = _majority_skeleton(d)
    ref = build_index(d, sk, use_cache=False, progress=False)
    res = build_index_batch(d, sk, cache_dir=tmp_path / "cache", workers=2, progress=False)
    assert res.workers == 2 and res.rebuilt == []
    _same_index(res.index, ref)
    assert (res.index.n_frames, res.index.n_unique) == (1739, 394)
    pids = set(res.table["worker"].dropna().str.split(":").str[1])
    assert pids and str(os.getpid()) not in pids  # indexed on the workers, not here
