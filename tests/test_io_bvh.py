"""BVH reading/writing: exact round trips (synthetic and every real clip), exact
number parsing, Euler conventions against scipy, and bad input -> MotionFormatError
naming the line (specific cases and a hypothesis mutation test)."""
from __future__ import annotations

import itertools
import math
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from conftest import IN_CI, real_files
from mocomp.core import EndSite, Motion, Skeleton, SourceInfo
from mocomp.errors import MotionFormatError
from mocomp.io import UnitWarning, format_bvh, parse_bvh, read_bvh, write_bvh
from mocomp.io import _bvh_kernels as kern
from mocomp.io import bvh as bvh_module
from mocomp.io.bvh import _euler_all_nb, _euler_columns_to_quat, _fast_frames

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


#: tests of the compiled kernels themselves: skipped when MOCOMP_NO_NUMBA switches numba off
needs_compiled = pytest.mark.skipif(__import__("mocomp.core._compiled", fromlist=["DISABLED"]).DISABLED,
                                    reason="numba switched off by MOCOMP_NO_NUMBA")


@pytest.fixture(params=["numpy", "compiled"])
def frame_path(request, monkeypatch):
    """Run a test through the numpy frame reader and through the compiled one (which the
    reader uses only for frame blocks of ``_FAST_MIN_BYTES`` and more; 0 forces it)."""
    if request.param == "compiled":
        from mocomp.core._compiled import DISABLED

        if DISABLED:
            pytest.skip("numba switched off by MOCOMP_NO_NUMBA")
        assert kern.AVAILABLE, "numba is a dependency"
        monkeypatch.setattr(bvh_module, "_FAST_MIN_BYTES", 0)
    return request.param


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


def test_round_trip_crlf_cr_tabs_and_blank_lines(frame_path):
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


# ------------------------------------------------------------------ static root (Bandai joint_Root)
def reference_bvh_positions(text: str) -> tuple[list[str], np.ndarray]:
    """Joint names and world positions ``(T, J, 3)`` (file units) of BVH text, computed
    independently of mocomp: every joint of the file (no restructuring), position
    channels replace the OFFSET (as Bandai writes them), intrinsic Euler in channel order."""
    head, _, rest = text.partition("MOTION")
    names, parents, offsets, chans, stack, pending = [], [], [], [], [], None
    for line in head.splitlines():
        t = line.split()
        if not t:
            continue
        if t[0] in ("ROOT", "JOINT"):
            names.append(t[1])
            parents.append(stack[-1] if stack else -1)
            offsets.append(None)
            chans.append(())
            pending = len(names) - 1
        elif t[0] == "End":
            pending = -1
        elif t[0] == "{":
            stack.append(pending)
        elif t[0] == "}":
            stack.pop()
        elif t[0] == "OFFSET" and stack[-1] != -1:
            offsets[stack[-1]] = np.array([float(x) for x in t[1:4]])
        elif t[0] == "CHANNELS":
            chans[stack[-1]] = tuple(t[2:])
    block = rest.split("\n", 3)[3] if "\r" not in rest else rest.replace("\r", "").split("\n", 3)[3]
    data = np.array([[float(x) for x in ln.split()] for ln in block.splitlines() if ln.strip()])
    T, J = len(data), len(names)
    pos = np.zeros((T, J, 3))
    glob = [None] * J
    col = 0
    for j in range(J):
        ch = chans[j]
        v = data[:, col:col + len(ch)]
        col += len(ch)
        local = np.tile(offsets[j], (T, 1))
        if "Xposition" in ch:
            local = np.column_stack([v[:, ch.index(a)] for a in ("Xposition", "Yposition", "Zposition")])
        rc = [c for c in ch if c.endswith("rotation")]
        r = Rotation.from_euler("".join(c[0] for c in rc), v[:, [ch.index(c) for c in rc]], degrees=True) \
            if rc else Rotation.identity(T)
        if parents[j] < 0:
            pos[:, j] = local
            glob[j] = r
        else:
            p = parents[j]
            pos[:, j] = pos[:, p] + glob[p].apply(local)
            glob[j] = glob[p] * r
    return names, pos


def hierarchy_outline(text: str) -> list[str]:
    """ROOT/JOINT/End Site lines and channel lists, in file order, whitespace normalised."""
    out = []
    for line in text.partition("MOTION")[0].splitlines():
        t = line.split()
        if t and t[0] in ("ROOT", "JOINT", "End", "CHANNELS", "{", "}"):
            out.append(" ".join(t))
    return out


def hierarchy_offsets(text: str) -> np.ndarray:
    return np.array([[float(x) for x in ln.split()[1:]] for ln in text.partition("MOTION")[0].splitlines()
                     if ln.split()[:1] == ["OFFSET"]])


def bandai_style_text(T: int = 6, root_values=(0, 0, 0, 0, 0, 0), seed: int = 3) -> str:
    """A generated Bandai-style file (cm, 30 Hz): a static 6-channel ``joint_Root`` above a
    translating ``Hips``; every joint has 6 channels whose positions equal the offsets."""
    rng = np.random.default_rng(seed)
    names = ["joint_Root", "Hips", "Spine", "Head", "UpLeg_L", "Leg_L", "UpLeg_R", "Leg_R"]
    parents = [-1, 0, 1, 2, 1, 4, 1, 6]
    off = np.array([[0, 0, 0], [1.5, 93.0, -0.5], [0, 25, 0], [0, 40, 2], [9, -5, 0], [0, -45, 0],
                    [-9, -5, 0], [0, -45, 0]], dtype=float)
    ends = {3: [0, 15, 0], 5: [0, -42, 5], 7: [0, -42, 5]}
    ch6 = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
    lines = ["HIERARCHY"]

    def emit(j, d):
        ind = "  " * d
        lines.extend([f"{ind}{'ROOT' if j == 0 else 'JOINT'} {names[j]}", f"{ind}{{",
                      f"{ind}  OFFSET {off[j, 0]:g} {off[j, 1]:g} {off[j, 2]:g}", f"{ind}  {ch6}"])
        for c in [k for k in range(len(names)) if parents[k] == j]:
            emit(c, d + 1)
        if j in ends:
            e = ends[j]
            lines.extend([f"{ind}  End Site", f"{ind}  {{", f"{ind}    OFFSET {e[0]} {e[1]} {e[2]}", f"{ind}  }}"])
        lines.append(f"{ind}}}")

    emit(0, 0)
    order = [0, 1, 2, 3, 4, 5, 6, 7]
    lines += ["MOTION", f"Frames:\t{T}", "Frame Time:\t0.0333333"]
    for t in range(T):
        row = []
        for j in order:
            if j == 0:
                row += list(root_values)
            elif j == 1:
                row += [3.0 * t + 1.5, 93.0 + np.sin(t), -0.5 + 2.0 * t] + list(rng.uniform(-30, 30, 3))
            else:
                row += list(off[j]) + list(rng.uniform(-40, 40, 3))
        lines.append(" ".join(f"{v:.6g}" for v in row))
    return "\n".join(lines) + "\n"


def _check_static_root_round_trip(src_text: str, tmp_path, n_file_joints: int):
    src = tmp_path / "src.bvh"
    src.write_text(src_text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        m = read_bvh(src, scale="cm")
    # the loaded model is unchanged: rooted at Hips, one joint fewer, the removal recorded
    assert m.skeleton.names[0] == "Hips" and m.skeleton.n_joints == n_file_joints - 1
    rr = m.skeleton.removed_root
    assert rr is not None and rr.name == "joint_Root" and len(rr.channels) == 6
    out = write_bvh(m, tmp_path / "out.bvh", scale=0.01)  # write in the file's unit (cm)
    text_out = out.read_text()
    # hierarchy and channel layout of the file, offsets equal (in cm)
    assert hierarchy_outline(text_out) == hierarchy_outline(src_text)
    assert hierarchy_outline(text_out)[0] == "ROOT joint_Root"
    assert sum(ln.startswith("CHANNELS") for ln in hierarchy_outline(text_out)) == n_file_joints
    np.testing.assert_allclose(hierarchy_offsets(text_out), hierarchy_offsets(src_text), atol=1e-4)  # 1e-6 m
    n_cols = len(text_out.rstrip("\n").split("\n")[-1].split())
    assert n_cols == 6 * n_file_joints
    # every joint's position, joint_Root included, from an independent FK of both files
    names_a, pa = reference_bvh_positions(src_text)
    names_b, pb = reference_bvh_positions(text_out)
    assert names_a == names_b
    assert np.abs(pa - pb).max() * 0.01 < 1e-6
    # and our reader agrees with that FK on the original (21 of the 22 joints)
    idx = [names_a.index(n) for n in m.skeleton.names]
    assert np.abs(m.positions - pa[:, idx] * 0.01).max() < 1e-6
    back = read_bvh(out, scale="cm")
    assert back.skeleton.names == m.skeleton.names and back.skeleton.removed_root is not None
    assert_same_pose(m, back, atol=1e-6)
    # option to drop: the file then starts at Hips, 21 joints, same positions
    dropped = format_bvh(m, scale=0.01, restore_root=False)
    assert hierarchy_outline(dropped)[0] == "ROOT Hips"
    assert sum(ln.startswith("CHANNELS") for ln in hierarchy_outline(dropped)) == n_file_joints - 1
    assert_same_pose(m, parse_bvh(dropped, scale="cm"), atol=1e-6)
    return m


def test_static_root_is_written_again_synthetic(tmp_path):
    m = _check_static_root_round_trip(bandai_style_text(), tmp_path, 8)
    assert m.skeleton.removed_root.constant
    np.testing.assert_array_equal(m.skeleton.removed_root.values, 0.0)


def test_static_root_with_a_non_identity_transform(tmp_path):
    """A root with a (constant) translation and rotation: the writer puts the rest of the motion
    into Hips' channels relative to it, and every joint lands where it was."""
    _check_static_root_round_trip(bandai_style_text(root_values=(5, -2, 7, 30, -20, 45)), tmp_path, 8)


def test_moving_root_keeps_positions(tmp_path):
    """joint_Root translating over the clip (as in bandai1_run_normal_001): the first frame's
    values are written on every frame, Hips takes the rest; positions still reproduced."""
    text = bandai_style_text()
    head, data = text.split("Frame Time:\t0.0333333\n")
    rows = [ln.split() for ln in data.splitlines()]
    for k, r in enumerate(rows):
        r[2] = str(-20.0 * k)
        r[4] = str(3.0 * k)
    text = head + "Frame Time:\t0.0333333\n" + "\n".join(" ".join(r) for r in rows) + "\n"
    src = tmp_path / "src.bvh"
    src.write_text(text)
    m = read_bvh(src, scale="cm", height_check=False)
    assert not m.skeleton.removed_root.constant
    out = write_bvh(m, tmp_path / "o.bvh", scale=0.01)
    assert hierarchy_outline(out.read_text()) == hierarchy_outline(text)
    _, pa = reference_bvh_positions(text)
    _, pb = reference_bvh_positions(out.read_text())
    assert np.abs(pa[:, 1:] - pb[:, 1:]).max() * 0.01 < 1e-6  # every joint below joint_Root


def test_removed_root_scales_and_survives_edits(tmp_path):
    m = parse_bvh(bandai_style_text(root_values=(5, -2, 7, 30, -20, 45)), scale="cm")
    rr = m.skeleton.removed_root
    np.testing.assert_allclose(rr.values, [0.05, -0.02, 0.07, 30, -20, 45])  # metres / degrees
    np.testing.assert_allclose(rr.child_offset, [0.015, 0.93, -0.005])
    assert m.skeleton.scaled(2.0).removed_root.values[0] == pytest.approx(0.1)
    assert m.skeleton.scaled(2.0).removed_root.values[3] == 30
    # equality ignores it (no joint moves); slicing and mirroring keep it, and stay exact
    assert m.skeleton == m.skeleton.without_removed_root()
    for edited in (m[2:5], m.mirrored()):
        assert edited.skeleton.removed_root is not None
        back = parse_bvh(format_bvh(edited, scale=0.01), scale="cm")
        assert_same_pose(edited, back, atol=1e-6)


def test_static_root_not_restored_when_hips_would_not_read_back_as_moving():
    """One frame (or a motion standing still): the reader would keep joint_Root, so the writer
    leaves it out and the file reads back with the same 7 joints."""
    m = parse_bvh(bandai_style_text(), scale="cm")
    for still in (m[:1], m.replace(root_positions=np.repeat(m.root_positions[2:3], m.n_frames, axis=0))):
        text = format_bvh(still, scale=0.01)
        assert hierarchy_outline(text)[0] == "ROOT Hips"
        back = parse_bvh(text, scale="cm", height_check=False)
        assert back.skeleton.names == m.skeleton.names
        assert_same_pose(still, back, atol=1e-6)


@pytest.mark.realdata
def test_real_bandai_clip_hierarchy_channels_and_positions(real_data_dir, tmp_path):
    """bandai1_run_normal_001: 22 joints in the file (joint_Root moves 2 m in it), 21 loaded;
    write_bvh gives the file's hierarchy and 132 channels back, every joint within 1e-6 m."""
    f = real_data_dir / "walks" / "bandai1_run_normal_001.bvh"
    src = f.read_text()
    assert sum(ln.split()[:1] == ["CHANNELS"] for ln in src.splitlines()) == 22
    m = read_bvh(f)
    assert m.skeleton.n_joints == 21 and m.skeleton.names[0] == "Hips"
    out = write_bvh(m, tmp_path / "o.bvh", scale=0.01)
    text_out = out.read_text()
    assert hierarchy_outline(text_out) == hierarchy_outline(src)
    np.testing.assert_allclose(hierarchy_offsets(text_out), hierarchy_offsets(src), atol=1e-4)  # cm
    assert len(text_out.rstrip("\n").split("\n")[-1].split()) == 132
    names_a, pa = reference_bvh_positions(src)
    names_b, pb = reference_bvh_positions(text_out)
    assert names_a == names_b and len(names_a) == 22
    # joint_Root itself is written static (first frame); every joint below it is exact
    assert np.abs(pa[:, 1:] - pb[:, 1:]).max() * 0.01 < 1e-6
    # the CLI's convert reproduces it too (metres by default)
    from mocomp.cli import main

    assert main(["convert", str(f), str(tmp_path / "c.bvh")]) == 0
    conv = (tmp_path / "c.bvh").read_text()
    assert hierarchy_outline(conv) == hierarchy_outline(src)
    _, pc = reference_bvh_positions(conv)
    assert np.abs(pa[:, 1:] * 0.01 - pc[:, 1:]).max() < 1e-6
    assert main(["convert", str(f), str(tmp_path / "d.bvh"), "--drop-static-root"]) == 0
    assert hierarchy_outline((tmp_path / "d.bvh").read_text())[0] == "ROOT Hips"


@pytest.mark.realdata
def test_real_bandai_static_root_clip_exact_joint_root(real_data_dir, tmp_path):
    """A clip whose joint_Root stays at zero: all 22 joints, joint_Root too, within 1e-6 m."""
    f = real_data_dir / "walks" / "bandai2_walk-turn-left_normal_001.bvh"
    src = f.read_text()
    m = read_bvh(f)
    assert m.skeleton.removed_root.constant
    text_out = format_bvh(m, scale=0.01)
    assert hierarchy_outline(text_out) == hierarchy_outline(src)
    _, pa = reference_bvh_positions(src)
    _, pb = reference_bvh_positions(text_out)
    assert np.abs(pa - pb).max() * 0.01 < 1e-6


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


def test_good_fixture_parses(frame_path):
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
def test_bad_input_names_the_line(mutate, line, words, frame_path):
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
def _trimmed_real_cmu(n_frames: int = 3) -> list[str]:
    """The real CMU 88_01 back flip (31 joints) cut to its first frames, read at test time
    from the data directory (no real data is committed): once with CRLF line ends
    throughout, once with the file's own mix (CRLF, but LF around ``Frames:``/``Frame Time:``
    and on some frame lines)."""
    from mocomp.datasets import data_dir

    d = data_dir()
    f = None if d is None else d / "flips" / "cmu_88_01_backflip.bvh"
    if f is None or not f.is_file():
        if IN_CI:
            raise RuntimeError("CI=true but the real CMU seed flips/cmu_88_01_backflip.bvh is missing")
        return []
    text = f.read_bytes().decode("latin-1")
    lines = text.splitlines(keepends=True)
    ft = next(k for k, ln in enumerate(lines) if ln.startswith("Frame Time:"))
    kept = [re.sub(r"Frames:\s*\d+", f"Frames: {n_frames}", ln) for ln in lines[:ft + 1 + n_frames]]
    mixed = "".join(kept)
    crlf = "".join(ln.rstrip("\r\n") + "\r\n" for ln in kept)
    return [crlf, mixed]


REAL_SEEDS = _trimmed_real_cmu()
BANDAI_SEED = bandai_style_text(T=3)
SEED_TEXTS = [GOOD, GOOD.replace("\n", "\r\n"), bvh_text(synthetic_motion(T=4, seed=5), precision=3),
              BANDAI_SEED, *REAL_SEEDS]
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


def test_property_seeds_are_what_they_claim():
    """The seeds parse, the Bandai-style one through the joint_Root restructuring, and the
    real CMU one (when the data is there) keeps its CRLF line ends."""
    for text in SEED_TEXTS:
        assert parse_bvh(text, scale=0.01, height_check=False).n_frames >= 1
    b = parse_bvh(BANDAI_SEED, scale="cm", height_check=False)
    assert b.skeleton.removed_root is not None and b.skeleton.names[0] == "Hips"
    for text in REAL_SEEDS:
        assert text.count("\r\n") > 0.9 * text.count("\n")
        m = parse_bvh(text, scale="cmu", height_check=False)
        assert m.skeleton.n_joints == 31 and m.n_frames == 3
    if REAL_SEEDS:
        assert REAL_SEEDS[0].count("\r\n") == REAL_SEEDS[0].count("\n")


_PROPERTY_DIR = None


def _property_file():
    import tempfile
    from pathlib import Path

    global _PROPERTY_DIR
    if _PROPERTY_DIR is None:
        _PROPERTY_DIR = tempfile.TemporaryDirectory(prefix="mocomp_bvh_property_")
    return Path(_PROPERTY_DIR.name) / "mutated.bvh"


@st.composite
def mutated_bvh_bytes(draw):
    """A mutated seed as file bytes: utf-8 or latin-1 (so the reader's latin-1 fallback
    runs), LF/CRLF/old-Mac CR line ends, and stray bytes spliced in."""
    text = draw(mutated_bvh())
    endings = draw(st.sampled_from(["keep", "lf", "crlf", "cr"]))
    if endings != "keep":
        text = text.replace("\r\n", "\n").replace("\r", "\n")
        text = text.replace("\n", {"lf": "\n", "crlf": "\r\n", "cr": "\r"}[endings])
    data = text.encode(draw(st.sampled_from(["utf-8", "latin-1"])), errors="replace")
    for _ in range(draw(st.integers(0, 2))):
        i = draw(st.integers(0, len(data)))
        data = data[:i] + draw(st.sampled_from([b"\xff", b"\xe9", b"\x00", b"\r", b"\n", b"\t", b" -"])) + data[i:]
    return data


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_bvh_bytes())
def test_mutated_bvh_file_reads_or_raises_motion_format_error(data):
    """Same property through read_bvh on a file: its own Frame Time search on bytes, the
    byte decoding with latin-1 fallback, the old-Mac line-end re-parse and the Bandai
    restructuring all run on mutated input."""
    f = _property_file()
    f.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            m = read_bvh(f, scale=0.01)
        except MotionFormatError as e:
            assert e.path == str(f)
            event("MotionFormatError")
            return
    event("parsed")
    assert isinstance(m, Motion) and m.n_frames >= 1
    assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.root_positions))
    assert np.all(np.isfinite(m.positions))


@pytest.mark.parametrize("endings", ["\n", "\r\n", "\r"])
@pytest.mark.parametrize("encoding", ["utf-8", "latin-1"])
def test_seed_files_read_the_same_with_any_line_end_and_encoding(endings, encoding, tmp_path, frame_path):
    """Unmutated seeds written as files (a latin-1 joint name included) read to the same motion
    as parse_bvh on the text."""
    for k, text in enumerate(SEED_TEXTS):
        text = text.replace("\r\n", "\n").replace("JOINT Leg", "JOINT Leg\u00e9")
        ref = parse_bvh(text, scale=0.01, height_check=False)
        f = tmp_path / f"s{k}.bvh"
        f.write_bytes(text.replace("\n", endings).encode(encoding))
        m = read_bvh(f, scale=0.01, height_check=False)
        assert m.skeleton.names == ref.skeleton.names
        np.testing.assert_array_equal(m.positions, ref.positions)


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


# ------------------------------------------------------------------ compiled frame parse and Euler conversion
def _bits(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float).view(np.int64)


def _number_tokens(rng, n: int) -> list[str]:
    """Decimal tokens of every shape a BVH writer produces: fixed point with 0-12
    decimals over many magnitudes, C-style exponents (``-6.08778e-016``, ``e-023``: past
    the exact fast range), 17-digit ``repr``, signs, leading zeros, no digits before or
    after the point, integers past 2**53, subnormals and the largest double."""
    v = rng.normal(size=n) * 10.0 ** rng.integers(-6, 7, n)
    kind = rng.integers(0, 4, n)
    toks = []
    for x, k, p in zip(v, kind, rng.integers(0, 13, n)):
        if k == 0:
            toks.append(f"{x:.{p}f}")
        elif k == 1:
            toks.append(f"{x * 10.0 ** rng.integers(-30, 20):.{p % 7}e}".replace("e-", "e-0").replace("e+", "e+0"))
        elif k == 2:
            toks.append(repr(float(x)))
        else:
            toks.append(f"{x:.4f}")
    toks += ["+.5", "5.", "-0", "-0.0", "+0", "0e999", "000123.4500", "1E5", "-1e-22", "1e22", "1e23", "-2.5E+3",
             "9007199254740992", "9007199254740993", "1" * 25, "0." + "0" * 30 + "1", "1e-320", "4.9e-324",
             "1.7976931348623157e308", "123456789012345678901234567890e-20"]
    return toks


@needs_compiled
def test_compiled_frame_parse_gives_the_bits_of_float():
    """Every number the compiled reader returns is float(token), bit for bit (signed zeros
    too), whether it took the exact one-operation path (m <= 2**53, |e| <= 22) or was
    handed back to float() (exponent or mantissa out of that range)."""
    rng = np.random.default_rng(11)
    toks = _number_tokens(rng, 6000)
    toks += ["0"] * (-len(toks) % 20)
    rows = [toks[i:i + 20] for i in range(0, len(toks), 20)]
    ref = np.array([[float(t) for t in r] for r in rows])
    for sep, eol in [(" ", "\n"), ("\t", "\r\n"), ("  \t ", "\r"), (" ", " \n\n")]:
        raw = ("Frame Time: 0.01\n" + eol.join(sep.join(r) for r in rows) + eol).encode()
        got = _fast_frames(raw, 17, len(rows), 20)
        assert got is not None
        np.testing.assert_array_equal(_bits(got), _bits(ref))
    # tokens where the naive arithmetic is off by one bit (so they must go to float()): an
    # exponent past 1e22 done in two divisions, a mantissa past 2**53 rounded before dividing
    assert float("175268e-28") != 175268 / 1e22 / 1e6
    assert float("843488751069501777e-5") != float(843488751069501777) / 1e5
    toks = ["175268e-28", "843488751069501777e-5", "1e23", "9007199254740993", "-0"]
    one = _fast_frames(" ".join(toks).encode() + b"\n", 0, 1, 5)
    np.testing.assert_array_equal(_bits(one[0]), _bits([float(t) for t in toks]))
    assert np.signbit(one[0, 4])


@needs_compiled
@pytest.mark.parametrize("block, why", [
    (b"1 2\n3 nan\n", "nan"), (b"1 2\n3 inf\n", "inf"), (b"1 2\n3 1_0\n", "underscore"), (b"1 2\n3 0x10\n", "hex"),
    (b"1 2\n3 1e\n", "no exponent digits"), (b"1 2\n3 -\n", "sign only"), (b"1 2\n3 .\n", "point only"),
    (b"1 2\n3 1.2.3\n", "two points"), (b"1 2\n3\x0b4\n", "vertical tab"), (b"1 2\n3 4\xe9\n", "latin-1 byte"),
    (b"1 2\n3 4\x00\n", "NUL"), (b"1 2\n3 4 5\n", "long row"), (b"1 2\n3\n", "short row"), (b"1 2\n", "few rows"),
    (b"1 2\n3 4\n5 6\n", "many rows"), (b"1 2 3 4\n", "one long line"), (b"", "empty"),
])
def test_compiled_frame_parse_declines_what_it_does_not_handle(block, why):
    """Anything but an exact (2, 2) table of decimal numbers: None (the numpy reader then
    reports it, naming the line), never a wrong table."""
    assert _fast_frames(block, 0, 2, 2) is None, why
    assert _fast_frames(b"1 2\n3 4\n", 0, 2, 2) is not None


@needs_compiled
def test_compiled_frame_parse_limits():
    """A corrupt 'Frames:' count cannot make it allocate (each value needs two bytes),
    and a block of mostly out-of-range numbers (more than one in four) goes back to
    the numpy reader, which still gives float(token)."""
    assert _fast_frames(b"1 2\n3 4\n", 0, 10 ** 12, 2) is None
    vals = np.random.default_rng(2).normal(size=(40, 8))
    block = "\n".join(" ".join(f"{x:.6f}e-30" for x in row) for row in vals)
    raw = block.encode()
    status, n_slow = kern.parse_table(np.frombuffer(raw, np.uint8), 0, np.empty((40, 8)), np.empty((80, 4), np.int64))
    assert (status, n_slow) == (4, 80)  # the span list is full: too many slow tokens
    assert _fast_frames(raw, 0, 40, 8) is None
    assert kern.parse_table(np.frombuffer(raw, np.uint8), 0, np.empty((40, 8)), np.empty((320, 4), np.int64)) \
        == (kern.OK, 320)
    ref = np.array([float(t) for t in block.split()]).reshape(40, 8)
    np.testing.assert_array_equal(_bits(bvh_module._parse_frames(raw)), _bits(ref))


@needs_compiled
@pytest.mark.parametrize("seq", ORDERS + ["ZXZ", "XYX", "YZY", "XY", "ZX", "Z", "Y"])
def test_compiled_euler_conversion_gives_the_numpy_bits(seq):
    """The compiled Euler -> quaternion pass performs the numpy version's operations in its
    order: the same bits (signed zeros included), for all joints of several channel
    orders in one call, with still (zero, -0.0) channels and whole turns."""
    rng = np.random.default_rng(len(seq) * 7 + ord(seq[0]))
    T, J = 300, 6
    ang = rng.uniform(-400, 400, (T, J, len(seq)))
    ang[rng.random(ang.shape) < 0.2] = 0.0
    ang[rng.random(ang.shape) < 0.05] = -0.0
    ang[:, 2] = rng.choice([0.0, 90.0, -180.0, 360.0, 720.0], (T, len(seq)))
    other = "ZYX" if seq != "ZYX" else "XZY"
    ang2 = rng.uniform(-180, 180, (T, 2, 3))
    # frame table: joint 0 no rotation channels; joints 1..J with seq; two more joints with `other`
    data = np.concatenate([rng.normal(size=(T, 3)), ang.reshape(T, -1), ang2.reshape(T, -1)], axis=1)
    js = list(range(1, J + 1))
    cols = [[3 + j * len(seq) + k for k in range(len(seq))] for j in range(J)]
    base = 3 + J * len(seq)
    js2, cols2 = [J + 1, J + 2], [[base + k for k in range(3)], [base + 3 + k for k in range(3)]]
    by_seq = {seq: (js, cols), other: (js2, cols2)}
    ref = np.full((T, J + 3, 4), 7.0)
    got = ref.copy()
    for sq, (jj, cc) in by_seq.items():
        ca = np.array(cc)
        _euler_columns_to_quat(sq, [data[:, ca[:, k]] for k in range(ca.shape[1])], ref, jj)
    assert _euler_all_nb(by_seq, data, got)
    assert np.all(got[:, 0] == 7.0)  # joints without rotation channels are left alone
    h = data[:, 3:] * (np.pi / 360.0)
    same_libm = np.array_equal(_bits(np.sin(h)), _bits(np.vectorize(math.sin)(h)))
    if same_libm:  # numpy's sin/cos are the C library's here (not a SIMD variant): exact
        np.testing.assert_array_equal(_bits(got), _bits(ref))
    else:  # pragma: no cover - e.g. numpy's AVX-512 sin/cos differ from libm in the last bit
        np.testing.assert_array_max_ulp(got, ref, maxulp=4)
    sc = Rotation.from_euler(seq, ang.reshape(-1, len(seq)), degrees=True).as_quat().reshape(T, J, 4)
    d = np.minimum(np.abs(got[:, 1:J + 1] - sc).max(-1), np.abs(got[:, 1:J + 1] + sc).max(-1))
    assert d.max() < 1e-14


def _read_both(path_or_text, monkeypatch, **kw):
    """(compiled, numpy) reads of the same input."""
    fn = read_bvh if not isinstance(path_or_text, str) else parse_bvh
    with monkeypatch.context() as mp:
        mp.setattr(bvh_module, "_FAST_MIN_BYTES", 0)
        a = fn(path_or_text, **kw)
    with monkeypatch.context() as mp:
        mp.setattr(kern, "AVAILABLE", False)
        b = fn(path_or_text, **kw)
    return a, b


def _assert_same_bits(a: Motion, b: Motion):
    assert a.skeleton.names == b.skeleton.names and a.skeleton.channels == b.skeleton.channels
    for x, y in [(a.root_positions, b.root_positions), (a.rotations, b.rotations),
                 (a.skeleton.offsets, b.skeleton.offsets)]:
        np.testing.assert_array_equal(_bits(x), _bits(y))
    assert a.fps == b.fps and a.source == b.source


@pytest.mark.realdata
@pytest.mark.parametrize("path", real_files("*/*.bvh"), ids=lambda p: p.name)
def test_real_clips_compiled_and_numpy_readers_agree_bit_for_bit(path, monkeypatch):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        _assert_same_bits(*_read_both(path, monkeypatch))


@needs_compiled
def test_large_synthetic_file_takes_the_compiled_path_and_matches(tmp_path, monkeypatch):
    """A file over the size threshold with every rotation order, in every line-end style:
    the default read (compiled) equals the numpy read bit for bit."""
    m = synthetic_motion(T=1200, seed=3)
    text = bvh_text(m, precision=8)
    assert len(text) > bvh_module._FAST_MIN_BYTES
    calls = []
    real = kern.parse_table
    monkeypatch.setattr(kern, "parse_table", lambda *a: calls.append(1) or real(*a))
    for eol in ["\n", "\r\n", "\r"]:
        f = tmp_path / "big.bvh"
        f.write_bytes(text.replace("\n", eol).encode())
        a = read_bvh(f, scale=0.01, height_check=False)
        with monkeypatch.context() as mp:
            mp.setattr(kern, "AVAILABLE", False)
            b = read_bvh(f, scale=0.01, height_check=False)
        _assert_same_bits(a, b)
    assert len(calls) == 3


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.function_scoped_fixture])
@given(mutated_bvh())
def test_mutated_bvh_compiled_and_numpy_readers_agree(monkeypatch, text):
    """On mutated input the compiled reader either gives the numpy reader's motion bit for
    bit or raises the same MotionFormatError (same message, same line)."""
    out = []
    for use in (True, False):
        with monkeypatch.context() as mp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mp.setattr(bvh_module, "_FAST_MIN_BYTES", 0 if use else 1 << 62)
            try:
                out.append(parse_bvh(text, path="m.bvh", scale=0.01))
            except MotionFormatError as e:
                out.append((str(e), e.line))
    a, b = out
    if isinstance(a, tuple) or isinstance(b, tuple):
        event("MotionFormatError")
        assert a == b
    else:
        event("parsed")
        _assert_same_bits(a, b)


# ------------------------------------------------------------------ extreme values, sizes, depth (issue 12)
@pytest.mark.parametrize("mutate, line, words", [
    (lambda L: L[:7] + ["\t\tOFFSET 0 -1e308 0"] + L[8:], 8, "offset of joint 'Leg' is"),     # finite but extreme
    (lambda L: L[:11] + ["\t\t\tOFFSET 0 -4e6 0"] + L[12:], 12, "End Site 'Leg_end' offset"),  # 40 km end site
    (lambda L: L[:17] + ["Frame Time: 1e-300"] + L[18:], 18, "gives a frame rate of 1e+300 Hz is outside the "
                                                              "accepted 1-10000 Hz"),
    (lambda L: L[:17] + ["Frame Time: 3600"] + L[18:], 18, "outside the accepted"),
    (lambda L: L[:16] + ["Frames: 1000000000"] + L[17:], 17, "Frames: 1000000000 (more than the 1,000,000"),
    (lambda L: L[:19] + ["0 91 0 1e300 2 3 4 5 6"] + L[20:], 20, "rotation channel 3 is beyond the accepted"),
    (lambda L: L[:20] + ["2e9 92 0 1 2 3 4 5 6"] + L[21:], 21, "root position x = 2e+07 m at frame 2"),
])
def test_extreme_values_and_counts_name_the_line(mutate, line, words):
    with pytest.raises(MotionFormatError) as e:
        parse("\n".join(mutate(_lines(GOOD))))
    assert words in str(e.value) and e.value.line == line and e.value.path == "x.bvh", str(e.value)


def test_extreme_offset_with_guessed_unit_is_refused(tmp_path):
    """OFFSET -1e308 gave NaN joint positions and exit status 0 (the unit guess, FK overflow)."""
    L = _lines(GOOD)
    f = tmp_path / "far.bvh"
    f.write_text("\n".join(L[:7] + ["\t\tOFFSET 0 -1e308 0"] + L[8:]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(MotionFormatError, match=r"far.bvh:8: offset of joint 'Leg'"):
            read_bvh(f)
        with pytest.raises(MotionFormatError, match=r"fps argument 1e\+06 Hz"):
            read_bvh(tmp_path / "ok.bvh" if (tmp_path / "ok.bvh").write_text(GOOD) else None, fps=1e6)


def test_non_bvh_file_is_refused_from_its_first_bytes(tmp_path, monkeypatch):
    """A large file of digits used to be read and decoded whole (15 s, 0.9 GB for 200 MB)
    before 'does not start with HIERARCHY'. Now only the first 64 kB are read."""
    f = tmp_path / "digits.bvh"
    f.write_bytes(b"1234567890 " * 200_000)  # 2.2 MB
    reads = []
    real_open = open

    class Spy:
        def __init__(self, fh):
            self.fh = fh

        def read(self, n=-1):
            out = self.fh.read(n)
            reads.append(len(out))
            return out

        def __enter__(self):
            return self

        def __exit__(self, *a):
            self.fh.close()

    monkeypatch.setattr("builtins.open", lambda p, mode="r", *a, **k: Spy(real_open(p, mode, *a, **k))
                        if str(p) == str(f) else real_open(p, mode, *a, **k))
    with pytest.raises(MotionFormatError, match=r"digits.bvh:1: file does not start with HIERARCHY \(starts with "
                                                r"'1234567890'"):
        read_bvh(f)
    assert reads == [1 << 16]
    monkeypatch.undo()
    bom = tmp_path / "bom.bvh"
    bom.write_bytes(b"\xef\xbb\xbf\r\n\r\n" + GOOD.encode())  # a BOM and blank lines are fine
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert read_bvh(bom, scale=0.01).n_frames == 3
    (tmp_path / "late.bvh").write_bytes(b"\n\n\nMOTION\n")
    with pytest.raises(MotionFormatError, match=r"late.bvh:4: file does not start with HIERARCHY"):
        read_bvh(tmp_path / "late.bvh")


def test_deep_hierarchy_writes_without_recursion_and_reads_back_with_a_clear_error(tmp_path):
    """format_bvh recursed once per level and died at depth ~1000 (RecursionError)."""
    J = 10_000
    sk = Skeleton(tuple(f"j{k}" for k in range(J)), np.arange(-1, J - 1), np.tile([0.0, 0.01, 0.0], (J, 1)),
                  tuple([("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
                        + [("Zrotation", "Xrotation", "Yrotation")] * (J - 1)), (EndSite(J - 1, [0, 0.01, 0], "tip"),))
    m = Motion(sk, 30.0, np.zeros((2, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (2, J, 1)))
    text = format_bvh(m, precision=3)
    lines = text.split("\n")
    assert lines[1] == "ROOT j0" and sum(ln.strip().startswith("JOINT") for ln in lines) == J - 1
    assert max(len(ln) - len(ln.lstrip("\t")) for ln in lines) == 66  # indentation capped at 64 levels (+2)
    assert len(text) < 8_000_000  # uncapped indentation: ~200 MB of tabs
    # a small deep chain (depth 1000 < the joint limit) round-trips exactly
    small = Motion(Skeleton(sk.names[:1000], sk.parents[:1000], sk.offsets[:1000], sk.channels[:1000]), 30.0,
                   np.zeros((2, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (2, 1000, 1)))
    back = parse_bvh(format_bvh(small), path="deep.bvh", scale=1.0, height_check=False)
    assert back.skeleton.names == small.skeleton.names
    np.testing.assert_array_equal(back.skeleton.parents, small.skeleton.parents)
    f = tmp_path / "deep.bvh"
    f.write_text(text)
    with pytest.raises(MotionFormatError) as e:
        read_bvh(f, scale=1.0, height_check=False)
    assert "more than 1000 joints" in str(e.value) and "deep.bvh" in str(e.value)
    assert lines[e.value.line - 1].strip() == "JOINT j1000"


def test_frame_parser_without_the_jit_equals_the_compiled_one():
    """The frame-table kernel run as plain Python (what ``NUMBA_DISABLE_JIT=1`` runs) reads the
    same numbers: its digit arithmetic on ``uint8`` bytes once wrapped around (``b'0' - 48`` fine,
    ``b' ' - 48`` = 240 instead of -16), so every value after the first separator was garbage and
    real clips lost their flights, silently."""
    from mocomp.io import _bvh_kernels as kern

    if not kern.AVAILABLE:
        pytest.skip("numba not available")
    raw = b"0.5 -12.25 3e-2\n7 +0.125 -1.5E1\n"
    buf = np.frombuffer(raw, dtype=np.uint8)
    want = np.array([[0.5, -12.25, 0.03], [7.0, 0.125, -15.0]])
    for parse in (kern.parse_table, kern.parse_table.py_func):
        out = np.empty((2, 3))
        status, n_slow = parse(buf, 0, out, np.empty((8, 4), dtype=np.int64))
        assert status == kern.OK and n_slow == 0
        np.testing.assert_allclose(out, want, rtol=1e-15)


@pytest.mark.parametrize("mutate, line, words", [
    (lambda L: L[:18] + [L[18] + " 7"] + L[19:], 19, "10 values"),
    (lambda L: L[:19] + ["0 91 0 1 2 3 4 5"] + L[20:], 20, "8 values"),
    (lambda L: L[:20] + ["0 92 0 1 2 abc 4 5 6"] + L[21:], 21, "'abc' is not a number"),
    (lambda L: L[:20], 20, "only 2 frame lines"),
    (lambda L: L[:21] + ["0 93 0 1 2 3 4 5 6"] + L[21:], 22, "4 frame lines follow"),
    (lambda L: L[:19] + ["", "0 91 0 1 2 3 4 5 6 " + "1 " * 600] + L[20:], 21, "longer than 578 bytes"),
])
@pytest.mark.parametrize("ends", ["\n", "\r\n", "\r"])
def test_streamed_frame_block_errors_name_the_same_line(mutate, line, words, ends, monkeypatch):
    """Large frame blocks are searched for their bad line without decoding them whole
    (50 MB of junk after a valid header took 617 MB); same line, same words."""
    text = ends.join(mutate(_lines(GOOD)))
    monkeypatch.setattr(bvh_module, "_STREAM_ERRORS_BYTES", 0)
    with pytest.raises(MotionFormatError) as e:
        parse(text)
    assert e.value.line == line and words in str(e.value), str(e.value)
    if "longer" not in words:  # the in-memory reporter agrees
        monkeypatch.setattr(bvh_module, "_STREAM_ERRORS_BYTES", 1 << 30)
        with pytest.raises(MotionFormatError) as e2:
            parse(text)
        assert (e2.value.line, e2.value.reason) == (e.value.line, e.value.reason)


def test_frame_block_far_larger_than_frames_claim_is_refused_before_parsing():
    L = _lines(GOOD)
    text = "\n".join(L[:21] + ["0 1 2 3 4 5 6 7 8"] * 10_000) + "\n"  # 180 kB for 3 frames
    with pytest.raises(MotionFormatError) as e:
        parse(text)
    assert e.value.line == 17 and "more than Frames: 3 lines of 9 values can hold" in str(e.value)


@pytest.mark.realdata
@pytest.mark.parametrize("path", real_files("**/*.bvh"), ids=lambda p: p.name)
def test_real_bvh_reads_without_a_false_unit_warning(path):
    """Every real BVH clip is a plausible size in its unit: reading it directly warns about no
    standing height. Clips that never stand upright (ASE's crouching shield charge: all-joints
    extent 1.195 m) are measured again from the skeleton's bone lengths before any warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        read_bvh(path)


def test_crouching_clip_height_check_uses_the_skeleton_but_still_flags_a_wrong_unit(real_data_dir):
    path = real_data_dir / "attacks" / "ase_rl_Atk_ShieldCharge.derived.bvh"
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        m = read_bvh(path)  # metres: 1.195 m all-joints extent, 1.61 m stature -> no warning
    from mocomp.body.height import estimate_height
    assert 1.55 < estimate_height(m).value < 1.65
    with pytest.warns(UnitWarning, match=r"standing height 0\.016 m"):
        read_bvh(path, scale="cm")  # the wrong unit is still flagged, on the better estimate
