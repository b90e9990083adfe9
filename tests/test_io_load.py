"""``mocomp.io.load``: dispatch by extension, options passed on, clear errors."""
from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest

from mocomp.errors import MotionFormatError
from mocomp.io import UnitWarning, load, read_amc, read_bvh, read_deepmimic, write_bvh
from test_io_asf_amc import ASF, amc_text
from test_io_bvh import synthetic_motion
from test_io_deepmimic import motion_doc, small_character, write_motion


def test_bvh_with_scale_and_fps(tmp_path):
    m = synthetic_motion()
    f = write_bvh(m, tmp_path / "m.BVH", scale=0.01)  # centimetres, upper-case extension
    r = load(f, scale="cm", fps=30)
    assert r.fps == 30 and r.source.unit_scale == 0.01
    np.testing.assert_allclose(r.positions, m.positions, atol=1e-6)
    with pytest.warns(UnitWarning):
        load(f, scale=1.0)
    assert load(f, scale=1.0, height_check=False).source.unit_scale == 1.0


def test_amc_finds_its_asf_or_takes_one(tmp_path):
    (tmp_path / "07.asf").write_text(ASF)
    (tmp_path / "07_02.amc").write_text(amc_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        m = load(tmp_path / "07_02.amc", fps=60)
        ref = read_amc(tmp_path / "07_02.amc", fps=60)
        other = tmp_path / "sub"
        other.mkdir()
        shutil.copy(tmp_path / "07_02.amc", other / "x.amc")
        m2 = load(other / "x.amc", asf=tmp_path / "07.asf", fps=60)
    assert m.fps == 60
    np.testing.assert_array_equal(m.positions, ref.positions)
    np.testing.assert_array_equal(m2.positions, ref.positions)
    with pytest.raises(MotionFormatError, match="an .asf file holds only a skeleton"):
        load(tmp_path / "07.asf")


def test_deepmimic_txt_and_json(tmp_path):
    c = small_character(tmp_path)
    f = write_motion(tmp_path, motion_doc(), "clip.txt")
    g = tmp_path / "clip.json"
    g.write_text(f.read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        a = load(f, character=c)
        b = load(g, character=c, fps=40)
        ref = read_deepmimic(f, character=c)
    np.testing.assert_array_equal(a.positions, ref.positions)
    assert b.fps == 40


def test_unknown_and_missing(tmp_path):
    (tmp_path / "x.fbx").write_bytes(b"Kaydara FBX Binary")
    with pytest.raises(MotionFormatError, match=r"unknown motion file extension '\.fbx'; supported: .amc, .bvh"):
        load(tmp_path / "x.fbx")
    with pytest.raises(MotionFormatError, match="no such file"):
        load(tmp_path / "nope.bvh")
    (tmp_path / "m.c3d").write_bytes(b"")
    with pytest.raises(MotionFormatError, match="read_c3d"):
        load(tmp_path / "m.c3d")
    (tmp_path / "notes.txt").write_text("just some notes")
    with pytest.raises(MotionFormatError, match=r"notes\.txt:1: not valid JSON"):
        load(tmp_path / "notes.txt", character=small_character(tmp_path))
    (tmp_path / "character.txt").write_text("{}")  # found beside the motion, but empty
    with pytest.raises(MotionFormatError, match=r"character\.txt:1: character file needs"):
        load(tmp_path / "notes.txt")


@pytest.mark.realdata
def test_real_files_by_extension(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        b = load(real_data_dir / "walks" / "131_01.bvh")
        a = load(real_data_dir / "kicks_punches" / "11_01.amc")
        d = load(real_data_dir / "walks" / "deepmimic_walk.txt")
    assert (b.source.format, a.source.format, d.source.format) == ("bvh", "asf/amc", "deepmimic")
    assert b.n_frames == read_bvh(real_data_dir / "walks" / "131_01.bvh").n_frames
