"""BVH reading/writing: exact round trips (synthetic and every real clip), exact
number parsing, Euler conventions against scipy, and bad input -> MotionFormatError
naming the line (specific cases and a hypothesis mutation test)."""
from __future__ import annotations

import itertools
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from conftest import real_files
from mocomp.core import EndSite, Motion, Skeleton, SourceInfo
from mocomp.errors import MotionFormatError
from mocomp.io import UnitWarning, format_bvh, parse_bvh, read_bvh, write_bvh
from mocomp.io.bvh import _euler_columns_to_quat

ORDERS = ["".join(p) for p in itertools.permutations("XYZ")]


def rot_channels(order: str) -> tuple[str, ...]:
    return tuple(f"{a}rotation" for a in order)


def synthetic_motion(T: int = 25, fps: float = 60.0, seed: int = 0, channels=None, order=None) -> Motion:
    """Small branching skeleton, random smooth rotations, moving root (metres)."""
    rng = np.random.default_rng(seed)
    names = ("Hips", "Spine", "Head", "LArm", "RArm", "LUpLeg", "LLeg", "RUpLeg", "RLeg")  # depth-first
    parents = (-1, 0, 1, 1, 1, 0, 5, 0, 7)
    off = np.array([[0, 0, 0], [0, .2, 0], [0, .35, .02], [.2, .3, 0], [-.2, .3, 0], [.1, -.05, 0],
                    [0, -.45, 0], [-.1, -.05, 0], [0, -.45, 0]], dtype=float)
    ends = (EndSite(2, [0, .15, 0], "Head_end"), EndSite(3, [.5, 0, 0], "LArm_end"),
            EndSite(4, [-.5, 0, 0], "RArm_end"), EndSite(6, [0, -.42, .05], "LLeg_end"),
            EndSite(8, [0, -.42, .05], "RLeg_end"))
    J = len(names)
    if channels is None:
        orders = order or [ORDERS[j % 6] for j in range(J)]
        channels = [("Xposition", "Yposition", "Zposition") + rot_channels(orders[0])] + \
                   [rot_channels(orders[j]) for j in range(1, J)]
    sk = Skeleton(names, parents, off, channels, ends)
    t = np.arange(T) / fps
    amp = rng.uniform(0.2, 0.8, (J, 3))
    w = rng.uniform(1, 6, (J, 3))
    ph = rng.uniform(0, 2 * np.pi, (J, 3))
    rotvec = amp * np.sin(w * t[:, None, None] + ph)  # joint angles up to ~45 deg on each axis
    rotvec[:, 0, 1] = 1.5 * t  # the root turns steadily about the vertical
    rot = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_quat().reshape(T, J, 4)
    root = np.column_stack([0.7 * t, 0.95 + 0.1 * np.sin(5 * t), -0.2 * t])
    return Motion(sk, fps, root, rot, source=SourceInfo(format="synthetic"))


def assert_same_pose(a: Motion, b: Motion, atol: float = 1e-6):
    idx = [b.skeleton.index(n) for n in a.skeleton.names]
    assert np.abs(a.positions - b.positions[:, idx]).max() < atol
    if a.skeleton.end_sites:
        assert np.abs(a.end_site_positions() - b.end_site_positions()).max() < atol


def bvh_text(motion: Motion, scale: float = 0.01, precision: int = 6) -> str:
    return format_bvh(motion, scale=scale, precision=precision)


# ------------------------------------------------------------------ round trips
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_synthetic_round_trip_every_rotation_order(tmp_path, seed):
    m = synthetic_motion(seed=seed)
    p = write_bvh(m, tmp_path / "a.bvh")
    r = read_bvh(p, scale=1.0)
    assert r.skeleton.names == m.skeleton.names
    assert r.skeleton.channels == m.skeleton.channels  # layout reproduced
    assert r.n_frames == m.n_frames and abs(r.fps - m.fps) < 1e-6
    assert_same_pose(m, r)
    # and a second generation is identical text
    assert format_bvh(r) == format_bvh(read_bvh(write_bvh(r, tmp_path / "b.bvh"), scale=1.0))


def test_round_trip_six_channel_joints_and_single_axis_channels(tmp_path):
    """Every joint with 6 channels (positions equal to offsets, as Bandai writes them)
    and hinge joints with one rotation channel."""
    m = synthetic_motion()
    six = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")] * m.skeleton.n_joints
    p = write_bvh(m, tmp_path / "six.bvh", channels=six)
    r = read_bvh(p, scale=1.0)
    assert all(len(c) == 6 for c in r.skeleton.channels)
    assert_same_pose(m, r)
    # a hinge: knee rotating about z only, written as "CHANNELS 1 Zrotation"
    rot = np.array(m.rotations)
    k = m.skeleton.index("LLeg")
    ang = np.linspace(0, 2.0, m.n_frames)
    rot[:, k] = np.column_stack([np.zeros_like(ang), np.zeros_like(ang), np.sin(ang / 2), np.cos(ang / 2)])
    ch = list(m.skeleton.channels)
    ch[k] = ("Zrotation",)
    hinge = m.replace(rotations=rot, skeleton=m.skeleton.with_channels(ch))
    text = format_bvh(hinge)
    assert "CHANNELS 1 Zrotation" in text
    assert_same_pose(hinge, parse_bvh(text, scale=1.0))
    # the writer refuses to drop a rotation the channels cannot express
    ch[2] = ("Zrotation",)
    with pytest.raises(MotionFormatError, match="Head.*lack"):
        format_bvh(m.replace(skeleton=m.skeleton.with_channels(ch)))


def test_round_trip_crlf_cr_tabs_and_blank_lines():
    m = synthetic_motion()
    text = bvh_text(m)
    ref = parse_bvh(text, scale=0.01)
    variants = [text.replace("\n", "\r\n"), text.replace("\n", "\r"), text.replace(" ", "\t"),
                text.replace("\n", "\n\n"), "\n\n" + text.replace(" ", "   ")]
    for v in variants:
        r = parse_bvh(v, scale=0.01)
        np.testing.assert_array_equal(r.positions, ref.positions)


def test_non_dfs_joint_order_is_written_in_hierarchy_order(tmp_path):
    """A skeleton whose joint order is not the BVH depth-first order (DeepMimic's is
    not): frame columns must follow the written hierarchy."""
    names = ("root", "a", "b", "a_child", "b_child")
    parents = (-1, 0, 0, 1, 2)
    off = [[0, 0, 0], [.1, 0, 0], [-.1, 0, 0], [0, -.4, 0], [0, -.4, 0]]
    sk = Skeleton(names, parents, off)
    rng = np.random.default_rng(3)
    rot = Rotation.random(10 * 5, random_state=4).as_quat().reshape(10, 5, 4)
    m = Motion(sk, 30, rng.normal(size=(10, 3)), rot)
    r = read_bvh(write_bvh(m, tmp_path / "x.bvh"), scale=1.0, height_check=False)
    assert r.skeleton.names == ("root", "a", "a_child", "b", "b_child")
    assert_same_pose(m, r)


def test_parsed_numbers_are_exactly_python_floats(real_data_dir):
    """The fast table reader gives the same doubles as float(token)."""
    f = real_data_dir / "jumps" / "01_01.bvh"
    text = f.read_text()
    block = text[re.search(r"Frame Time:[^\n]*\n", text).end():]
    tokens = np.array([float(t) for t in block.split()]).reshape(-1, 96)
    m = read_bvh(f, scale=1.0, height_check=False)
    np.testing.assert_array_equal(m.root_positions, tokens[:, :3])  # root offset is 0 in this file


@pytest.mark.realdata
@pytest.mark.parametrize("path", real_files("*/*.bvh"), ids=lambda p: p.name)
def test_real_bvh_round_trip(path, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        m = read_bvh(path)
    assert m.source.unit_scale > 0 and m.source.unit_reason
    r = read_bvh(write_bvh(m, tmp_path / path.name), scale=1.0, height_check=False)
    assert r.n_frames == m.n_frames
    assert_same_pose(m, r, atol=1e-6)


@pytest.mark.realdata
def test_real_units_are_recorded(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)  # every real clip has a human height in its unit
        cmu = read_bvh(real_data_dir / "jumps" / "01_01.bvh")
        bandai = read_bvh(real_data_dir / "walks" / "bandai1_walk_normal_001.bvh")
        sfu = read_bvh(real_data_dir / "walks" / "sfu_0008_Walking002.bvh")
    assert cmu.source.unit_scale == pytest.approx(0.0254 / 0.45)
    assert bandai.source.unit_scale == 0.01
    assert sfu.source.unit_scale == 0.0254
    assert cmu.fps == pytest.approx(120.0, rel=1e-4) and cmu.n_frames == 2752
    # Bandai: static joint_Root above Hips is folded away, noted
    assert bandai.skeleton.names[0] == "Hips" and any("folded" in n for n in bandai.source.notes)
    # explicit scale is honoured and recorded; an implausible one warns
    with pytest.warns(UnitWarning, match="outside 1.2-2.2"):
        big = read_bvh(real_data_dir / "jumps" / "01_01.bvh", scale="cm")
    assert big.source.unit_scale == 0.01 and "given by caller" in big.source.unit_reason
    # a frame-rate override is applied and noted
    slow = read_bvh(real_data_dir / "jumps" / "01_01.bvh", fps=60)
    assert slow.fps == 60 and slow.source.header_fps == pytest.approx(120.0, rel=1e-4)


# ------------------------------------------------------------------ Euler conventions
@pytest.mark.parametrize("seq", ORDERS + ["ZXZ", "XYX", "XY", "Z"])
def test_euler_conversion_matches_scipy(seq):
    rng = np.random.default_rng(len(seq))
    ang = rng.uniform(-400, 400, (50, 4, len(seq)))
    out = np.empty((50, 6, 4))
    _euler_columns_to_quat(seq, [ang[..., k] for k in range(len(seq))], out, [1, 2, 3, 4])
    ref = Rotation.from_euler(seq, ang.reshape(-1, len(seq)), degrees=True).as_quat().reshape(50, 4, 4)
    got = out[:, 1:5]
    d = np.minimum(np.abs(got - ref).max(-1), np.abs(got + ref).max(-1))
    assert d.max() < 1e-14


# ------------------------------------------------------------------ bad input
GOOD = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Leg
\t{
\t\tOFFSET 0 -40 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -40 0
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: 0.008333
0 90 0 1 2 3 4 5 6
0 91 0 1 2 3 4 5 6
0 92 0 1 2 3 4 5 6
"""


def parse(text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        return parse_bvh(text, path="x.bvh", scale=0.01)


def test_good_fixture_parses():
    m = parse(GOOD)
    assert m.n_frames == 3 and m.skeleton.names == ("Hips", "Leg")
    assert m.root_positions[2, 1] == pytest.approx(0.92)


def _lines(text):
    return text.split("\n")


@pytest.mark.parametrize("mutate, line, words", [
    (lambda L: L[:18] + [L[18] + " 7"] + L[19:], 19, "10 values"),                # extra value
    (lambda L: L[:19] + ["0 91 0 1 2 3 4 5"] + L[20:], 20, "8 values"),         # missing value
    (lambda L: L[:20] + ["0 92 0 1 2 abc 4 5 6"] + L[21:], 21, "'abc' is not a number"),
    (lambda L: L[:19] + ["0 91 0 1 nan 3 4 5 6"] + L[20:], 20, "not finite"),
    (lambda L: L[:19] + ["0 91 0 1 2 3 inf 5 6"] + L[20:], 20, "not finite"),
    (lambda L: L[:20], 20, "only 2 frame lines"),                               # truncated data
    (lambda L: L[:21] + ["0 93 0 1 2 3 4 5 6"] + L[21:], 22, "4 frame lines follow"),
    (lambda L: L[:16] + L[17:], 17, "expected 'Frames:'"),                      # no Frames:
    (lambda L: L[:17] + L[18:], 18, "expected 'Frame Time:'"),                  # no Frame Time:
    (lambda L: L[:16] + ["Frames: 0"] + L[17:], 17, "at least one frame"),
    (lambda L: L[:16] + ["Frames: three"] + L[17:], 17, "not a whole number"),
    (lambda L: L[:17] + ["Frame Time: 0"] + L[18:], 18, "must be positive"),
    (lambda L: L[:17] + ["Frame Time: nan"] + L[18:], 18, "not a finite number"),
    (lambda L: L[:5] + ["\tJOINT Hips"] + L[6:], 6, "duplicate joint name 'Hips'"),
    (lambda L: L[:8] + ["\t\tCHANNELS 3 Zrotation Xrotation"] + L[9:], 9, "says 3 channels but lists 2"),
    (lambda L: L[:8] + ["\t\tCHANNELS 3 Zrotation Xrotation Wrotation"] + L[9:], 9, "unknown channel"),
    (lambda L: L[:7] + ["\t\tOFFSET 0 -40"] + L[8:], 8, "OFFSET needs 3 numbers"),
    (lambda L: L[:7] + ["\t\tOFFSET 0 x 0"] + L[8:], 8, "'x' is not a number"),
    (lambda L: L[:6] + L[7:], 7, "expected '{' after joint 'Leg'"),
    (lambda L: L[:10] + L[11:], 11, "expected '{' after End Site"),
    (lambda L: L[:10], 10, "open block"),                                       # truncated header
    (lambda L: L[:15], 15, "no MOTION section"),
    (lambda L: ["HIERARCH"] + L[1:], 1, "does not start with HIERARCHY"),
])
def test_bad_input_names_the_line(mutate, line, words):
    text = "\n".join(mutate(_lines(GOOD)))
    with pytest.raises(MotionFormatError) as e:
        parse(text)
    assert e.value.line == line, str(e.value)
    assert f"x.bvh:{line}: " in str(e.value)
    assert words in str(e.value)


def test_unreadable_and_empty_files(tmp_path):
    with pytest.raises(MotionFormatError, match="cannot read"):
        read_bvh(tmp_path / "missing.bvh")
    (tmp_path / "empty.bvh").write_bytes(b"")
    with pytest.raises(MotionFormatError, match="HIERARCHY"):
        read_bvh(tmp_path / "empty.bvh")
    (tmp_path / "bin.bvh").write_bytes(bytes(range(256)) * 10)
    with pytest.raises(MotionFormatError):
        read_bvh(tmp_path / "bin.bvh")


# ------------------------------------------------------------------ property test
SEED_TEXTS = [GOOD, GOOD.replace("\n", "\r\n"), bvh_text(synthetic_motion(T=4, seed=5), precision=3)]
GARBAGE = ["nan", "inf", "-inf", "abc", "1e999", "", "{", "}", "JOINT", "ROOT", "1.2.3", "0x10", "-", "End",
           "Site", "CHANNELS", "OFFSET", "MOTION", "Frames:", "Frame", "Time:", "1e-320", "9" * 40, "\x00", "é"]


@st.composite
def mutated_bvh(draw):
    text = draw(st.sampled_from(SEED_TEXTS))
    lines = text.split("\n")
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "duplicate", "token", "truncate", "count", "dupname", "swap"]))
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "token":
            toks = lines[i].split(" ")
            k = draw(st.integers(0, max(0, len(toks) - 1)))
            toks[k] = draw(st.sampled_from(GARBAGE))
            lines[i] = " ".join(toks)
        elif kind == "truncate":
            joined = "\n".join(lines)
            lines = joined[:draw(st.integers(0, len(joined)))].split("\n")
        elif kind == "count":
            lines = [re.sub(r"Frames: \d+", f"Frames: {draw(st.integers(-2, 9))}", ln) for ln in lines]
        elif kind == "dupname":
            lines = [re.sub(r"JOINT \w+", "JOINT Hips", ln, count=1) if j == i else ln for j, ln in enumerate(lines)]
        else:
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
    return "\n".join(lines)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_bvh())
def test_mutated_bvh_parses_or_raises_motion_format_error(text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            m = parse_bvh(text, path="m.bvh", scale=0.01)
        except MotionFormatError as e:
            assert e.path == "m.bvh"
            event("MotionFormatError")
            return
    event("parsed")
    assert isinstance(m, Motion) and m.n_frames >= 1
    assert np.all(np.isfinite(m.rotations))


@pytest.mark.parametrize("name", ["backflip", "frontflip", "sideflip", "twist180", "twist360", "jump"])
def test_embedded_synthetic_examples_round_trip(name, tmp_path):
    """Issue 2 section 3: the synthetic examples survive write -> read -> write -> read within 1e-6 m."""
    from mocomp.datasets import load

    m = load(name)
    a = read_bvh(write_bvh(m, tmp_path / "a.bvh"), scale=1.0)
    b = read_bvh(write_bvh(a, tmp_path / "b.bvh"), scale=1.0)
    assert a.n_frames == b.n_frames == m.n_frames and a.fps == pytest.approx(m.fps, rel=1e-14) and b.fps == a.fps
    assert_same_pose(m, a, atol=1e-6)
    assert_same_pose(a, b, atol=1e-6)
