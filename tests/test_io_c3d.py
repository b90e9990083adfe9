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
    f = write_c3d(tmp_path / "u.c3d", sample_points() / 100, "ABC", units="furlong")  # within +-2 km
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


# ------------------------------------------------------------------ corrupt and truncated files
# ezc3d (C++) segfaults, loops or silently returns fewer frames on such files; read_c3d checks
# the header and parameter section itself first. The reads run in a child process here, so a
# regression fails the test instead of killing pytest.
_CHILD = """
import sys, json
from mocomp.errors import MotionFormatError
from mocomp.io import read_c3d
out = []
for p in sys.argv[1:]:
    try:
        m = read_c3d(p)
        out.append(["ok", m.n_frames])
    except MotionFormatError as e:
        out.append(["error", str(e)])
    except Exception as e:
        out.append(["other", type(e).__name__ + ": " + str(e)])
print(json.dumps(out))
"""


def read_in_child(*paths, timeout=120):
    """[(kind, n_frames or message)] for each file, read by read_c3d in one child process."""
    import json
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", _CHILD, *map(str, paths)], capture_output=True, timeout=timeout)
    assert r.returncode == 0, f"reader process died with status {r.returncode}: {r.stderr.decode()[-2000:]}"
    return [tuple(x) for x in json.loads(r.stdout)]


HDM05 = "hands/HDM_dg_06-03_03_120.c3d"


@pytest.mark.realdata
def test_truncated_real_file_is_refused_naming_the_missing_frames(real_data_dir, tmp_path):
    """The issue's cases: ``head -c 696`` segfaulted ezc3d, ``head -c 648`` hung it,
    ``head -c 20000`` returned 21 of 202 frames without a word."""
    raw = (real_data_dir / HDM05).read_bytes()
    assert len(raw) == 146816  # 9 blocks of header + parameters, 202 frames x 44 points x 16 bytes
    cuts = [0, 1, 100, 511, 512, 515, 648, 696, 1024, 4607, 4608, 4609, 20000, 20000 + 704, len(raw) - 1]
    paths = []
    for n in cuts:
        p = tmp_path / f"cut{n}.c3d"
        p.write_bytes(raw[:n])
        paths.append(p)
    got = dict(zip(cuts, read_in_child(*paths)))
    for n, (kind, msg) in got.items():
        assert kind == "error", (n, kind, msg)
        assert f"cut{n}.c3d" in msg
    assert "181 of 202 frames are missing (only 21 complete" in got[20000][1]
    assert "180 of 202 frames are missing" in got[20704][1]
    assert "1 of 202 frames are missing (only 201 complete" in got[len(raw) - 1][1]
    assert "202 of 202 frames are missing" in got[4609][1]
    for n in (648, 696, 1024):
        assert "parameter section should have 8 blocks" in got[n][1]
    assert "shorter than the 512-byte header" in got[511][1]


def _patch(raw: bytes, at: int, new: bytes) -> bytes:
    return raw[:at] + new + raw[at + len(new):]


def test_corrupt_header_and_parameter_section_are_refused(tmp_path):
    import struct

    from mocomp.io.c3d import inspect_c3d

    f = write_c3d(tmp_path / "ok.c3d", sample_points(M=3, T=6), ["A", "B", "C"])
    raw = f.read_bytes()
    L = inspect_c3d(f)
    assert (L.n_points, L.n_frames, L.processor, L.scale < 0) == (3, 6, "Intel", True)
    assert len(raw) - 512 < L.data_bytes <= len(raw) and L.bytes_per_frame == 3 * 16  # ezc3d pads to a block
    p0 = (raw[0] - 1) * 512
    cases = {
        "key": (_patch(raw, 1, b"\x51"), "not the C3D key 0x50"),
        "pblock0": (_patch(raw, 0, b"\x01"), "parameter section at block 1"),
        "pblock_far": (_patch(raw, 0, b"\xff"), "beyond the end of the file"),
        "processor": (_patch(raw, p0 + 3, b"\x57"), "processor type 87"),
        "nblocks": (_patch(raw, p0 + 2, b"\x00"), "0 parameter blocks"),
        "first_after_last": (_patch(raw, 6, struct.pack("<H", 9)), "first frame 9, last frame 6"),
        "frames_claimed": (_patch(raw, 8, struct.pack("<H", 60000)), "59990 of 60000 frames are missing"),
        "points": (_patch(raw, 2, struct.pack("<H", 4)), "header word 2 says 4 points but POINT:USED is [3]"),
        "scale0": (_patch(raw, 12, struct.pack("<f", 0.0)), "scale factor 0.0"),
        "analog_per_channel_0": (_patch(raw, 4, struct.pack("<H", 2)), "not a multiple of 0"),
        "data_in_params": (_patch(raw, 16, struct.pack("<H", 2)), "inside the header or the parameter section"),
    }
    # the first parameter record's offset to the next record, made to point backwards (ezc3d loops)
    nchar = abs(struct.unpack("b", raw[p0 + 4:p0 + 5])[0])
    cases["offset_back"] = (_patch(raw, p0 + 6 + nchar, struct.pack("<h", -6)), "points outside the parameter section "
                                                                               "or backwards")
    cases["gid0"] = (_patch(raw, p0 + 5, b"\x00"), "group id 0")
    paths = []
    for name, (data, _) in cases.items():
        p = tmp_path / f"{name}.c3d"
        p.write_bytes(data)
        paths.append(p)
    for (name, (_, words)), (kind, msg) in zip(cases.items(), read_in_child(*paths)):
        assert kind == "error" and words in msg and f"{name}.c3d" in msg, (name, kind, msg)


def test_parameter_record_retyped_is_refused_or_read_in_a_child_process(tmp_path):
    """A parameter turned into a group by one flipped byte: in ezc3d's own files the
    record then does not fit (refused here); in the HDM05 file it still walks cleanly
    but POINT:LABELS is gone, so the section is not canonical and ezc3d runs in a child
    process (next test)."""
    import struct

    from mocomp.io.c3d import _canonical, inspect_c3d

    f = write_c3d(tmp_path / "ok.c3d", sample_points(M=3, T=6), ["A", "B", "C"])
    assert _canonical(inspect_c3d(f))  # normal files are read in this process (no child, no cost)
    raw = f.read_bytes()
    p0 = (raw[0] - 1) * 512
    pos = 4
    while True:  # find POINT:LABELS and make its group id negative (a group record)
        nchar, gid = struct.unpack("bb", raw[p0 + pos:p0 + pos + 2])
        name = raw[p0 + pos + 2:p0 + pos + 2 + abs(nchar)]
        off = struct.unpack("<h", raw[p0 + pos + 2 + abs(nchar):p0 + pos + 4 + abs(nchar)])[0]
        if name == b"LABELS" and gid > 0:
            break
        pos += 2 + abs(nchar) + off
    bad = tmp_path / "retyped.c3d"
    bad.write_bytes(_patch(raw, p0 + pos + 1, struct.pack("b", -61)))
    with pytest.raises(MotionFormatError, match="retyped.c3d: group record 'LABELS' at byte .* is cut short"):
        inspect_c3d(bad)


@pytest.mark.parametrize("script, words", [
    ("kill -SEGV $$", r"ezc3d crashed \(SIGSEGV\)"),
    ("sleep 30", "did not finish reading the file within"),
    ("echo 'RuntimeError: boom' >&2; exit 3", r"reader process failed \(RuntimeError: boom\)"),
])
def test_child_reader_turns_crash_hang_and_failure_into_motion_format_error(tmp_path, monkeypatch, script, words):
    import sys

    from mocomp.io import c3d as c3d_mod

    f = write_c3d(tmp_path / "ok.c3d", sample_points(), "ABC")
    assert c3d_mod._ezc3d_read_guarded(f)["data"]["points"].shape == (4, 3, 6)  # the real child works
    fake = tmp_path / "fake_python"
    fake.write_text("#!/bin/sh\n" + script + "\n")
    fake.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(fake))
    monkeypatch.setattr(c3d_mod, "_CHILD_TIMEOUT", 0.5)
    with pytest.raises(MotionFormatError, match=words) as e:
        c3d_mod._ezc3d_read_guarded(f)
    assert "ok.c3d" in str(e.value)


@pytest.mark.realdata
def test_real_file_retyped_labels_crash_is_contained(real_data_dir, tmp_path):
    """The fuzzer's crash case on the HDM05 file (POINT:LABELS' group id byte flipped to -61)."""
    raw = (real_data_dir / HDM05).read_bytes()
    assert raw[512 + 413 + 1] == 3 and raw[512 + 413 + 2:512 + 413 + 8] == b"LABELS"
    bad = tmp_path / "hdm_retyped.c3d"
    bad.write_bytes(_patch(raw, 512 + 413 + 1, b"\xc3"))
    [(kind, msg)] = read_in_child(bad)
    assert kind == "error" and "hdm_retyped.c3d" in msg and ("crashed" in msg or "ezc3d" in msg), msg


def test_non_finite_or_extreme_coordinates_with_a_valid_residual_are_refused(tmp_path):
    pts = sample_points(M=2, T=4)
    pts[1, 1, 2] = np.inf
    with pytest.raises(MotionFormatError, match=r"point 'B' at frame 2 .* non-finite"):
        read_c3d(write_c3d(tmp_path / "inf.c3d", pts, "AB"))
    res = np.zeros((1, 2, 4))
    res[0, 1, 2] = -1.0  # the same sample flagged invalid is a gap, whatever its coordinates
    mk = read_c3d(write_c3d(tmp_path / "gap.c3d", pts, "AB", residuals=res))
    assert not mk.mask[2, 1] and mk.mask.sum() == 7
    pts = sample_points(M=2, T=4)
    pts[0, 0, 3] = 3e7  # 30 km in mm
    with pytest.raises(MotionFormatError, match=r"marker 'A' at frame 3 .*beyond the accepted"):
        read_c3d(write_c3d(tmp_path / "far.c3d", pts, "AB"))
    with pytest.raises(MotionFormatError, match="POINT:RATE 1e\\+06 Hz is outside"):
        read_c3d(write_c3d(tmp_path / "fast.c3d", sample_points(), "ABC", rate=1e6))
    with pytest.raises(MotionFormatError, match="fps argument 0 Hz"):
        read_c3d(write_c3d(tmp_path / "r.c3d", sample_points(), "ABC"), fps=0)
