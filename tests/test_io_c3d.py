"""C3D markers via ezc3d: units, rate, labels, gaps (NaN + mask), axis mapping to
y-up; the HDM05 sample against its own AMC (same take); bad input."""
from __future__ import annotations

import warnings

import ezc3d
import numpy as np
import pytest

from mocomp.errors import MotionFormatError
from mocomp.io import UnitWarning, read_amc, read_c3d
from mocomp.io.c3d import UP_AXIS_MAPS



def write_c3d(path, pts, labels, rate=100.0, units="mm", residuals=None, y_screen=None):
    """pts: (3, M, T) file coordinates."""
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [rate]
    c["parameters"]["POINT"]["LABELS"]["value"] = list(labels)
    c["parameters"]["POINT"]["UNITS"]["value"] = [units]
    if y_screen is not None:
        c.add_parameter("POINT", "Y_SCREEN", [y_screen])
    M, T = pts.shape[1], pts.shape[2]
    data = np.ones((4, M, T))
    data[:3] = pts
    c["data"]["points"] = data
    res = np.zeros((1, M, T)) if residuals is None else residuals
    c["data"]["meta_points"] = {"residuals": res}
    c.write(str(path))
    return path


def sample_points(M=3, T=6, seed=0):
    return np.random.default_rng(seed).uniform(-1000, 1000, (3, M, T))


def test_units_rate_labels_and_z_up_mapping(tmp_path):
    pts = sample_points()
    f = write_c3d(tmp_path / "a.c3d", pts, ["LASI", "RASI", "*2"], rate=150.0, units="mm")
    mk = read_c3d(f)
    assert mk.names == ("LASI", "RASI", "*2") and mk.fps == 150.0 and mk.unit_scale == 0.001
    assert mk.positions.shape == (6, 3, 3) and mk.mask.all()
    # z-up (x, y, z) -> (x, z, -y), metres
    expect = np.stack([pts[0], pts[2], -pts[1]], axis=-1).transpose(1, 0, 2) * 0.001
    np.testing.assert_allclose(mk.positions, expect, atol=1e-9)  # C3D stores float32
    assert any("(x, z, -y)" in n for n in mk.notes) and any("assumed" in n for n in mk.notes)
    assert read_c3d(f, labeled_only=True).names == ("LASI", "RASI")
    assert read_c3d(f, fps=300).fps == 300
    m_units = read_c3d(write_c3d(tmp_path / "b.c3d", pts, "ABC", units="m"))
    np.testing.assert_allclose(m_units.positions, expect * 1000, rtol=1e-6)
    assert read_c3d(f, scale="cm").unit_scale == 0.01


@pytest.mark.parametrize("up", ["x", "y", "z"])
def test_axis_maps_are_proper_rotations_taking_up_to_y(up):
    R = UP_AXIS_MAPS[up]
    np.testing.assert_allclose(R @ R.T, np.eye(3))
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(R @ np.eye(3)["xyz".index(up)], [0, 1, 0])


def test_y_screen_parameter_and_explicit_matrix(tmp_path):
    pts = sample_points()
    f = write_c3d(tmp_path / "y.c3d", pts, "ABC", y_screen="+Y")
    mk = read_c3d(f)
    np.testing.assert_allclose(mk.positions, pts.transpose(2, 1, 0) * 0.001, atol=1e-9)
    assert any("Y_SCREEN" in n for n in mk.notes)
    R = np.array([[0, 1.0, 0], [0, 0, 1], [1, 0, 0]])
    mr = read_c3d(f, up=R)
    np.testing.assert_allclose(mr.positions, np.einsum("ij,jmt->tmi", R, pts) * 0.001, atol=1e-9)
    with pytest.raises(ValueError, match="proper rotation"):
        read_c3d(f, up=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="up must be"):
        read_c3d(f, up="w")


def test_gaps_become_nan_with_mask(tmp_path):
    pts = sample_points(M=3, T=5)
    pts[:, 1, 2] = 0.0  # exporter-style gap: exact zeros
    res = np.zeros((1, 3, 5))
    res[0, 2, 3] = -1.0  # invalid by residual
    mk = read_c3d(write_c3d(tmp_path / "g.c3d", pts, "ABC", residuals=res))
    expect = np.ones((5, 3), bool)
    expect[2, 1] = expect[3, 2] = False
    np.testing.assert_array_equal(mk.mask, expect)
    assert np.isnan(mk.positions[2, 1]).all() and np.isnan(mk.positions[3, 2]).all()
    assert np.isfinite(mk.positions[mk.mask]).all()
    assert any("2 missing samples" in n for n in mk.notes)


def test_bad_files(tmp_path):
    with pytest.raises(MotionFormatError, match="no such file"):
        read_c3d(tmp_path / "none.c3d")
    (tmp_path / "junk.c3d").write_bytes(bytes(range(256)) * 40)
    with pytest.raises(MotionFormatError) as e:
        read_c3d(tmp_path / "junk.c3d")
    assert "junk.c3d" in str(e.value)
    (tmp_path / "empty.c3d").write_bytes(b"")
    with pytest.raises(MotionFormatError):
        read_c3d(tmp_path / "empty.c3d")
    f = write_c3d(tmp_path / "u.c3d", sample_points(), "ABC", units="furlong")
    with pytest.raises(MotionFormatError, match="POINT:UNITS is 'furlong'"):
        read_c3d(f)
    assert read_c3d(f, scale=201.168).unit_scale == 201.168


@pytest.mark.realdata
def test_hdm05_sample_facts_and_agreement_with_its_amc(real_data_dir):
    """Known facts (MANIFEST: 120 Hz, mm, wrist/finger markers) and the same take's
    AMC: with HDM05's own frame (a cyclic axis permutation, our z-up mapping yawed
    90 deg) the ankle marker stays a constant ~5 cm from the AMC ankle joint over
    all 202 frames; that confirms units, rate, axes and the ASF length unit."""
    f = real_data_dir / "hands" / "HDM_dg_06-03_03_120.c3d"
    mk = read_c3d(f)
    assert mk.n_frames == 202 and mk.fps == 120.0 and mk.unit_scale == 0.001
    assert len(mk.names) == 44 and {"Daniel:LWRA", "Daniel:RFIN", "Daniel:LANK"} <= set(mk.names)
    assert mk.mask.all()
    head = mk.positions[:, mk.index("Daniel:LFHD"), 1]
    assert 1.5 < np.median(head) < 1.9  # y is up after the mapping
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        amc = read_amc(real_data_dir / "hands" / "HDM_dg_06-03_03_120.amc")
    R = np.array([[0, 1.0, 0], [0, 0, 1], [1, 0, 0]])
    mh = read_c3d(f, up=R)
    for marker, joint in (("Daniel:LANK", "lfoot"), ("Daniel:RANK", "rfoot")):
        d = np.linalg.norm(mh.positions[:, mh.index(marker)] - amc.joint_positions(joint), axis=1)
        assert 0.02 < d.mean() < 0.08 and d.std() < 0.003, (marker, d.mean(), d.std())
