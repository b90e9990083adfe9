"""Known-clip facts apply only to the known files themselves (issue #13 §3).

A file the project wrote as ``88_01_x2.bvh`` was read back at 1/18 scale (standing height
0.078 m) and at the 60 Hz of CMU subject 88 because the facts were matched by file stem.
Now a fact applies when the file is in the data directory, or is a byte copy (SHA-256 in
the data MANIFEST) of a listed file; files the project writes read back exactly as written.
"""
from __future__ import annotations

import os
import shutil

import numpy as np
import pytest
from mocomp import datasets
from mocomp.cli import main
from mocomp.core import Motion
from mocomp.io import UNITS, write_bvh
from mocomp.io import load as io_load

from _figures import small_motion

CLIP = "flips/cmu_88_01_backflip.bvh"


def figure(T: int = 12, fps: float = 120.0, tpose: bool = True, seed: int = 0) -> Motion:
    """A 5-joint figure 1.7 m tall in metres; frame 0 a T-pose (identity, root still) if asked."""
    return small_motion(T, fps, tpose, seed)


def height(m: Motion) -> float:
    p = m.positions
    return float(p[0, :, 1].max() - p[0, :, 1].min())


# ------------------------------------------------------------------ project-written files
@pytest.mark.realdata
def test_written_88_01_x2_reads_back_as_written(real_data_dir, tmp_path):
    """A motion written under a CMU-like name reads back in metres at its own rate, no frame dropped."""
    src = datasets.load("88_01")
    assert src.fps == 60.0 and 1.2 < height(src) < 2.2
    out = write_bvh(src, tmp_path / "88_01_x2.bvh", precision=11)
    back = datasets.load(out)
    assert back.fps == src.fps
    assert back.n_frames == src.n_frames
    assert back.source.unit_scale == pytest.approx(1.0, abs=0)
    np.testing.assert_allclose(back.positions, src.positions, rtol=0, atol=1e-9)
    assert any("name matches known clip flips/cmu_88_01_backflip.bvh but content differs" in n
               for n in back.source.notes), back.source.notes


@pytest.mark.realdata
def test_flips_cli_output_reads_back_as_written(real_data_dir, tmp_path):
    """``mocomp flips 88_01 -o 88_01_x2.bvh`` then the CLI's reader: 60 Hz as written, metres, human height."""
    out = tmp_path / "88_01_x2.bvh"
    assert main(["flips", "88_01", "--flips", "2", "-o", str(out)]) == 0
    back = datasets.load(str(out))                   # what `mocomp info <file>` reads
    as_written = io_load(out, scale=1.0, fps=60.0)  # the file's own numbers, metres
    assert back.fps == 60.0                         # Frame Time 1/60 as written, not a subject-88 fact
    assert back.source.unit_scale == 1.0
    assert back.n_frames == as_written.n_frames
    np.testing.assert_allclose(back.positions, as_written.positions, rtol=0, atol=1e-9)
    assert 1.2 < height(back) < 2.2                 # was 0.078 m (read in CMU units)


def test_same_stem_other_content_gets_no_facts(tmp_path, monkeypatch):
    """A file named like a CMU subject-88 clip but not one: header fps, metres, T-pose frame kept."""
    monkeypatch.delenv(datasets.ENV_VAR, raising=False)
    for name in ("cmu_88_01_backflip.bvh", "88_01.bvh"):
        m = figure(fps=120.0, tpose=True)
        p = write_bvh(m, tmp_path / name, precision=11)
        back = datasets.load(p)
        assert back.fps == 120.0
        assert back.n_frames == m.n_frames          # frame 0 (a T-pose) not dropped
        assert back.source.unit_scale == 1.0
        np.testing.assert_allclose(back.positions, m.positions, rtol=0, atol=1e-9)
        assert any("not applied" in n and "scale='cmu', fps=60" in n for n in back.source.notes)


@pytest.mark.realdata
def test_same_stem_other_content_with_data_dir_names_the_known_clip(real_data_dir, tmp_path):
    m = figure(fps=120.0)
    p = write_bvh(m, tmp_path / "cmu_88_01_backflip.bvh", precision=11)
    back = datasets.load(p)
    assert (back.fps, back.n_frames, back.source.unit_scale) == (120.0, m.n_frames, 1.0)
    assert any(f"name matches known clip {CLIP} but content differs" in n for n in back.source.notes)


# ------------------------------------------------------------------ byte copies: SHA-256
@pytest.mark.realdata
@pytest.mark.parametrize("name", ["cmu_88_01_backflip.bvh", "renamed.bvh"])
def test_byte_copy_elsewhere_keeps_its_facts(real_data_dir, tmp_path, name):
    ref = datasets.load(CLIP)
    copy = tmp_path / name
    shutil.copyfile(real_data_dir / CLIP, copy)
    m = datasets.load(copy)
    assert m.fps == ref.fps == 60.0
    assert m.n_frames == ref.n_frames              # T-pose frame dropped as for the original
    assert m.source.unit_scale == pytest.approx(ref.source.unit_scale, rel=1e-12)
    np.testing.assert_allclose(m.positions, ref.positions, rtol=0, atol=1e-12)
    assert any("identified by its SHA-256 as the data directory's " + CLIP in n for n in m.source.notes)


@pytest.mark.realdata
def test_one_changed_byte_loses_the_facts(real_data_dir, tmp_path):
    data = (real_data_dir / CLIP).read_bytes()
    i = data.rindex(b"0")                          # last digit of the last number
    copy = tmp_path / "cmu_88_01_backflip.bvh"
    copy.write_bytes(data[:i] + b"1" + data[i + 1:])
    m = datasets.load(copy, height_check=False)
    assert m.fps == pytest.approx(120.0, rel=1e-4)   # the header's rate, not subject 88's
    assert not any("identified by its SHA-256" in n for n in m.source.notes)


@pytest.mark.realdata
def test_every_manifest_hash_is_its_files_hash(real_data_dir):
    """The MANIFEST parse finds the listed files, and each listed hash is that file's SHA-256."""
    from mocomp.datasets.known import file_sha256, manifest_sha256

    table = manifest_sha256(real_data_dir)
    assert CLIP in table.values() and "reactions/deepmimic_humanoid3d_getup_facedown.txt" in table.values()
    assert len(table) >= 90
    for digest, rel in table.items():
        assert file_sha256(real_data_dir / rel) == digest, rel


def test_manifest_parse_checksum_lines_and_tables(tmp_path):
    from mocomp.datasets.known import manifest_sha256

    h = [f"{i:x}" * 64 for i in range(1, 5)]
    (tmp_path / "MANIFEST.md").write_text(
        "# data\n\n```\n"
        f"{h[0]}  flips/a.bvh\n"
        "```\n\n"
        "| file | content | sha256 |\n|---|---|---|\n"
        f"| `walks/b.bvh` | a walk | `{h[1]}` |\n\n"
        "| file | upstream | sha256 of the upstream .npy |\n|---|---|---|\n"
        f"| `runs/c.derived.bvh` | npy | `{h[2]}` |\n\n"
        "| file | frames | sha256 of the BVH | sha256 of the upstream .npy (bytes) |\n|---|---|---|---|\n"
        f"| `idle/d.derived.bvh` | 40 | `{h[3]}` | `{h[2]}` |\n", encoding="utf-8")
    assert manifest_sha256(tmp_path) == {h[0]: "flips/a.bvh", h[1]: "walks/b.bvh", h[3]: "idle/d.derived.bvh"}
    # the cache follows the file: a grown MANIFEST is re-read
    with open(tmp_path / "MANIFEST.md", "a", encoding="utf-8") as f:
        f.write(f"\n{h[2]}  runs/e.bvh\n")
    os.utime(tmp_path / "MANIFEST.md", ns=(1, 10**18))
    assert manifest_sha256(tmp_path)[h[2]] == "runs/e.bvh"


# ------------------------------------------------------------------ location in the data directory
def test_data_dir_location_gives_facts_byte_copy_too_other_content_none(tmp_path, monkeypatch):
    """A clip in the data directory (no MANIFEST row needed) gets its facts, as does a byte
    copy of it elsewhere; a copy with other content gets none."""
    root = tmp_path / "data"
    (root / "flips").mkdir(parents=True)
    m = figure(fps=120.0, tpose=True)
    inside = write_bvh(m, root / "flips" / "88_07.bvh", scale=UNITS["cmu"], precision=11)
    monkeypatch.setenv(datasets.ENV_VAR, str(root))
    a = datasets.load(inside)
    b = datasets.load("88_07")
    for x in (a, b):
        assert x.fps == 60.0
        assert x.n_frames == m.n_frames - 1        # T-pose dropped
        assert x.source.unit_scale == pytest.approx(UNITS["cmu"], rel=1e-12)
        np.testing.assert_allclose(x.positions, m.positions[1:], rtol=0, atol=1e-9)
    outside = tmp_path / "88_07.bvh"
    shutil.copyfile(inside, outside)
    c = datasets.load(outside)
    assert (c.fps, c.n_frames) == (60.0, m.n_frames - 1)
    np.testing.assert_allclose(c.positions, a.positions, rtol=0, atol=0)
    assert any("identified by its SHA-256 as the data directory's flips/88_07.bvh" in n for n in c.source.notes)
    other = tmp_path / "elsewhere" / "88_07.bvh"
    other.parent.mkdir()
    write_bvh(m.replace(fps=30.0), other, precision=11)   # same name, other content, in metres
    d = datasets.load(other)
    assert (d.fps, d.n_frames, d.source.unit_scale) == (30.0, m.n_frames, 1.0)
    np.testing.assert_allclose(d.positions, m.positions, rtol=0, atol=1e-9)
    assert any("name matches known clip flips/88_07.bvh but content differs" in n for n in d.source.notes)
