"""ASF/AMC reading: conventions (known answers, an independent matrix FK, the CMU
BVH conversion of the same take), units and gravity on real clips, exact BVH
round trips, and bad input -> MotionFormatError naming file and line."""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from conftest import real_files
from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
from mocomp.errors import MotionFormatError
from mocomp.io import UnitWarning, read_bvh, write_bvh
from mocomp.io.asf_amc import find_asf, parse_amc, parse_asf, read_amc, read_asf

ASF = """# test skeleton
:version 1.10
:name T
:units
  mass 1.0
  length 0.45
  angle deg
:documentation
  two legs would be more human, one is enough here
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name lfemur
     direction 0.34202 -0.939693 0
     length 7
     axis 0 0 20 XYZ
    dof rx ry rz
    limits (-160.0 20.0)
           (-70.0 70.0)
           (-60.0 70.0)
  end
  begin
     id 2
     name ltibia
     direction 0.34202 -0.939693 0
     length 7.5
     axis 0 0 20 XYZ
    dof rx
    limits (-10.0 170.0)
  end
  begin
     id 3
     name lowerback
     direction 0 1 0
     length 6
     axis 0 0 0 XYZ
    dof rz rx
  end
  begin
     id 4
     name head
     direction 0.1 1 0.05
     length 5
     axis 10 -30 45 ZYX
    dof ry rz rx
  end
:hierarchy
  begin
    root lfemur lowerback
    lfemur ltibia
    lowerback head
  end
"""


def amc_text(T: int = 6, seed: int = 0) -> str:
    rng = np.random.default_rng(seed)
    out = ["# generated", ":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(T):
        out.append(str(f + 1))
        out.append("root " + " ".join(f"{v:.5f}" for v in [f * 0.2, 15 + 0.1 * f, -0.3 * f, *rng.uniform(-40, 40, 3)]))
        out.append("lfemur " + " ".join(f"{v:.5f}" for v in rng.uniform(-60, 60, 3)))
        out.append(f"ltibia {rng.uniform(0, 120):.5f}")
        out.append("lowerback " + " ".join(f"{v:.5f}" for v in rng.uniform(-30, 30, 2)))
        out.append("head " + " ".join(f"{v:.5f}" for v in rng.uniform(-30, 30, 3)))
    return "\n".join(out) + "\n"


def asf() -> object:
    return parse_asf(ASF, path="t.asf")


def load(text=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        return parse_amc(amc_text() if text is None else text, asf(), path="t.amc", **kw)


# ------------------------------------------------------------------ ASF facts
def test_asf_fields_units_and_limits():
    a = asf()
    assert a.units == {"mass": 1.0, "length": 0.45, "angle": "deg"}
    assert a.length_scale == pytest.approx(0.0254 / 0.45)
    assert a.root_order == ("TX", "TY", "TZ", "RX", "RY", "RZ") and a.root_axis == "XYZ"
    assert [b.name for b in a.bones] == ["lfemur", "ltibia", "lowerback", "head"]
    assert a.order == ("root", "lfemur", "ltibia", "lowerback", "head")
    head = a.bone("head")
    assert head.axis_order == "ZYX" and head.dof == ("ry", "rz", "rx")
    assert np.linalg.norm(head.direction) == pytest.approx(1.0)  # normalised
    np.testing.assert_allclose(a.bone("lfemur").limits, [[-160, 20], [-70, 70], [-60, 70]])
    lim = a.limits
    assert lim["ltibia"]["rx"] == pytest.approx((np.deg2rad(-10), np.deg2rad(170)))
    assert "lowerback" not in lim  # no limits given
    sk = a.skeleton()
    d = np.array([0.34202, -0.939693, 0])
    np.testing.assert_allclose(sk.offsets[2], 7 * d / np.linalg.norm(d) * a.length_scale, atol=1e-12)
    assert [e.name for e in sk.end_sites] == ["ltibia_end", "head_end"]


def test_known_answer_axis_and_dof():
    """Bone along +x with local frame rotated 90 deg about z (local x = world y):
    rx = 90 deg turns it about world y, so the tip goes from +x to -z."""
    text = """:units
  length 1
  angle deg
:root
  order TX TY TZ RX RY RZ
  axis XYZ
  position 0 0 0
  orientation 0 0 0
:bonedata
  begin
    name arm
    direction 1 0 0
    length 1
    axis 0 0 90 XYZ
    dof rx
  end
  begin
    name hand
    direction 1 0 0
    length 1
    axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root arm
    arm hand
  end
"""
    a = parse_asf(text)
    m = parse_amc("1\nroot 0 0 0 0 0 0\narm 90\n", a, scale=1.0, height_check=False)
    P = m.positions[0]
    np.testing.assert_allclose(P[m.skeleton.index("hand")], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(m.end_site_positions()[0, 0], [0, 0, -2], atol=1e-12)
    # root rotations apply about fixed axes in "order": RX then RY: a point on +y
    m2 = parse_amc("1\nroot 0 0 0 90 90 0\narm 0\n", a, scale=1.0, height_check=False)
    R = Rotation.from_quat(m2.rotations[0, 0])
    np.testing.assert_allclose(R.apply([0, 1, 0]), (Rotation.from_euler("y", 90, degrees=True)
                                                    * Rotation.from_euler("x", 90, degrees=True)).apply([0, 1, 0]),
                               atol=1e-12)


def matrix_fk(a, text: str, scale: float):
    """Independent per-frame reference: 4x4-free matrix recursion from the ASF
    definitions (C from axis, M from dofs about fixed local axes, L = C M C^-1)."""
    frames, cur = [], None
    for line in text.splitlines():
        t = line.split()
        if not t or t[0].startswith((":", "#")):
            continue
        if len(t) == 1 and t[0].isdigit():
            cur = {}
            frames.append(cur)
        else:
            cur[t[0]] = np.array([float(x) for x in t[1:]])
    by = {b.name: b for b in a.bones}
    parent = {c: p for p, cs in a.children.items() for c in cs}
    out = []
    for fr in frames:
        G = {"root": Rotation.from_euler("xyz", np.deg2rad(fr["root"][3:6])).as_matrix()}
        P = {"root": fr["root"][:3] * scale}
        for n in a.order[1:]:
            b = by[n]
            C = Rotation.from_euler(b.axis_order.lower(), np.deg2rad(b.axis)).as_matrix()
            M = np.eye(3)
            for d, v in zip(b.dof, fr.get(n, [])):
                M = Rotation.from_euler(d[1], np.deg2rad(v)).as_matrix() @ M
            p = parent[n]
            G[n] = G[p] @ C @ M @ C.T
            P[n] = P[p] + (G[p] @ (by[p].direction * by[p].length * scale) if p != "root" else 0.0)
        out.append([P[n] for n in a.order])
    return np.array(out)


def test_fk_matches_independent_matrix_implementation():
    text = amc_text(T=8, seed=3)
    m = load(text)
    ref = matrix_fk(asf(), text, asf().length_scale)
    np.testing.assert_allclose(m.positions, ref, atol=1e-12)


def test_synthetic_round_trip_through_bvh(tmp_path):
    m = load(amc_text(T=10, seed=1))
    r = read_bvh(write_bvh(m, tmp_path / "t.bvh"), scale=1.0, height_check=False)
    assert r.skeleton.names == m.skeleton.names
    assert np.abs(r.positions - m.positions).max() < 1e-6
    assert np.abs(r.end_site_positions() - m.end_site_positions()).max() < 1e-6


def test_units_scale_fps_and_notes():
    m = load()
    assert m.source.format == "asf/amc"
    assert m.source.unit_scale == pytest.approx(0.0254 / 0.45) and "length 0.45" in m.source.unit_reason
    assert m.fps == 120.0 and m.source.header_fps is None and any("120 Hz assumed" in n for n in m.source.notes)
    m60 = load(fps=60, scale="inch")
    assert m60.fps == 60 and m60.source.unit_scale == 0.0254
    np.testing.assert_allclose(m60.positions, m.positions * 0.45, atol=1e-12)
    rad = amc_text().replace(":DEGREES", ":RADIANS")
    assert not np.allclose(load(rad).rotations, m.rotations)
    with pytest.warns(UnitWarning, match="outside 1.2-2.2"):
        parse_amc(amc_text(), asf(), path="t.amc", scale="m")


def test_find_asf(tmp_path):
    (tmp_path / "01.asf").write_text(ASF)
    (tmp_path / "01_05.amc").write_text(amc_text())
    assert find_asf(tmp_path / "01_05.amc").name == "01.asf"
    (tmp_path / "HDM_dg.asf").write_text(ASF)
    (tmp_path / "HDM_dg_06-03_03_120.amc").write_text(amc_text())
    assert find_asf(tmp_path / "HDM_dg_06-03_03_120.amc").name == "HDM_dg.asf"
    (tmp_path / "other.amc").write_text(amc_text())
    with pytest.raises(MotionFormatError, match="no ASF skeleton found"):
        find_asf(tmp_path / "other.amc")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        m = read_amc(tmp_path / "other.amc", asf=tmp_path / "01.asf")
    assert m.n_frames == 6


# ------------------------------------------------------------------ real clips
@pytest.mark.realdata
def test_cmu_01_01_matches_cgspeed_bvh(real_data_dir):
    """The cgspeed BVH of the same take: same joint order, same global rotations
    (<= 0.001 deg), same root and same joint positions within 0.05 mm once the
    BVH's offsets are replaced by the ASF's. The BVH drops the length of bones with
    several children (thorax: 116.5 mm, lwrist/rwrist: ~98 mm): its neck,
    clavicles, thumbs and finger bases sit at the start of those bones."""
    m = read_amc(real_data_dir / "jumps" / "01_01.amc")
    b = read_bvh(real_data_dir / "jumps" / "01_01.bvh", scale="cmu")[1:]  # BVH frame 0 is a T-pose
    assert m.n_frames == b.n_frames == 2751
    assert m.skeleton.n_joints == b.skeleton.n_joints == 31
    ang = quat_angle(quat_multiply(quat_inverse(m.global_rotations), b.global_rotations))
    assert np.rad2deg(ang.max()) < 1e-3
    assert np.abs(m.root_positions - b.root_positions).max() < 1e-4
    d = np.linalg.norm(m.positions - b.positions, axis=-1)
    same = [m.skeleton.index(n) for n in ("root", "lfemur", "ltibia", "lfoot", "ltoes", "rfemur", "rtoes",
                                           "lowerback", "upperback", "thorax")]
    assert d[:, same].max() < 5e-5
    assert d[:, m.skeleton.index("lowerneck")].mean() == pytest.approx(2.06391 * 0.0254 / 0.45, rel=1e-3)
    b_asf = b.replace(skeleton=m.skeleton)
    assert np.abs(b_asf.positions - m.positions).max() < 5e-5
    assert np.abs(b_asf.end_site_positions() - m.end_site_positions()).max() < 5e-5


def _flight_gravity(m, clear=0.05, min_s=0.2):
    """g from parabola fits of the mean joint height over the middle 70 % of
    flights (all joints and end sites above floor + clear)."""
    P = np.concatenate([m.positions, m.end_site_positions()], axis=1)
    low = P[..., 1].min(axis=1)
    air = low > np.percentile(low, 2) + clear
    y = m.positions[..., 1].mean(axis=1)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], air.astype(int), [0]])))
    g = []
    for a, e in zip(edges[::2], edges[1::2]):
        if (e - a) / m.fps < min_s:
            continue
        k = int(round(0.15 * (e - a)))
        c = np.polyfit(m.times[a + k:e - k], y[a + k:e - k], 2)
        g.append(-2 * c[0])
    return np.array(g)


@pytest.mark.realdata
def test_cmu_01_01_gravity_and_height(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        m = read_amc(real_data_dir / "jumps" / "01_01.amc")
    g = _flight_gravity(m)
    assert len(g) >= 8  # ten forward hops
    assert 9.0 <= np.median(g) <= 9.6, g
    assert 1.45 < m.skeleton.height() < 1.75


@pytest.mark.realdata
def test_hdm05_and_cmu_11(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        h = read_amc(real_data_dir / "hands" / "HDM_dg_06-03_03_120.amc")  # latin-1 header
        k = read_amc(real_data_dir / "kicks_punches" / "11_01.amc")
    assert (h.n_frames, k.n_frames) == (202, 597)
    assert h.skeleton.n_joints == k.skeleton.n_joints == 31
    a = read_asf(real_data_dir / "hands" / "HDM_dg.asf")
    assert a.units["length"] == 0.45 and len(a.limits) == 28
    # HDM05 "dg" jogs ~4 m in 1.7 s; CMU 11_01 is a kick (little travel)
    assert np.linalg.norm(h.root_positions[-1, [0, 2]] - h.root_positions[0, [0, 2]]) > 3.0
    assert 1.5 < np.percentile(h.positions[..., 1].max(axis=1), 50) < 1.9


@pytest.mark.realdata
@pytest.mark.parametrize("path", real_files("*/*.amc"), ids=lambda p: p.name)
def test_real_amc_round_trip(path, tmp_path):
    m = read_amc(path)
    r = read_bvh(write_bvh(m, tmp_path / (path.stem + ".bvh")), scale=1.0, height_check=False)
    assert r.n_frames == m.n_frames
    assert np.abs(r.positions - m.positions).max() < 1e-6
    assert np.abs(r.end_site_positions() - m.end_site_positions()).max() < 1e-6


# ------------------------------------------------------------------ bad input
def _amc_lines():
    return amc_text(T=3).split("\n")
# lines: 1 comment, 2 :FULLY-SPECIFIED, 3 :DEGREES, 4 "1", 5 root, 6 lfemur, 7 ltibia, 8 lowerback, 9 head,
#        10 "2", 11..15, 16 "3", 17 root, 18 lfemur, 19 ltibia, 20 lowerback, 21 head


@pytest.mark.parametrize("mutate, line, words", [
    (lambda L: L[:6] + ["lknee 10"] + L[7:], 7, "bone 'lknee' is not in the skeleton"),
    (lambda L: L[:6] + ["ltibia 10 20"] + L[7:], 7, "2 values, its ASF dofs ('rx',) need 1"),
    (lambda L: L[:4] + ["root 1 2 3 4 5"] + L[5:], 5, "5 values"),
    (lambda L: L[:12] + ["ltibia abc"] + L[13:], 13, "'abc' is not a number"),
    (lambda L: L[:12] + ["ltibia nan"] + L[13:], 13, "not finite"),
    (lambda L: L[:17] + ["lfemur 1 inf 3"] + L[18:], 18, "not finite"),
    (lambda L: L[:20], 16, "'head' is missing from frame 3 (file truncated?)"),   # truncated
    (lambda L: L[:20] + ["head 1 2"], 21, "2 values"),                           # truncated mid-line
    (lambda L: L[:7] + [L[6]] + L[7:], 8, "appears twice in frame 1"),
    (lambda L: L[:12] + L[13:], 10, "'ltibia' is missing from frame 2"),
    (lambda L: L[:9] + ["3"] + L[10:], 10, "frame number 3 follows frame 1"),
    (lambda L: L[:3], 3, "no frames"),
    (lambda L: L[:3] + ["root 0 0 0 0 0 0"] + L[3:], 4, "data before the first frame"),
    (lambda L: L[:9] + [":DEGREES"] + L[9:], 10, "after the first frame"),
])
def test_bad_amc_names_the_line(mutate, line, words):
    text = "\n".join(mutate(_amc_lines()))
    with pytest.raises(MotionFormatError) as e:
        load(text)
    assert e.value.line == line, str(e.value)
    assert f"t.amc:{line}: " in str(e.value)
    assert words in str(e.value)


def _asf_lines():
    return ASF.split("\n")


@pytest.mark.parametrize("mutate, line, words", [
    (lambda L: [re.sub("name ltibia", "name lfemur", x) for x in L], 27, "duplicate bone name 'lfemur'"),
    (lambda L: [x.replace("lowerback head", "lowerback neck") for x in L], 56, "'neck'"),
    (lambda L: [x.replace("direction 0 1 0", "direction 0 1") for x in L], 39, "direction needs 3 numbers"),
    (lambda L: [x.replace("length 6", "length six") for x in L], 40, "'six' is not a number"),
    (lambda L: [x.replace("dof rz rx", "dof rz rq") for x in L], 42, "dof"),
    (lambda L: [x.replace("axis 10 -30 45 ZYX", "axis 10 -30 45 ZYY") for x in L], 49, "not a permutation"),
    (lambda L: [x for x in L if "(-70.0 70.0)" not in x], 25, "limit pair"),
    (lambda L: L[:30], 30, "no 'end'"),
    (lambda L: L[:51], 51, "no :hierarchy"),
    (lambda L: [x.replace(":bonedata", ":bonedatum") for x in L], 15, "unknown ASF section"),
    (lambda L: [x.replace("lfemur ltibia", "lfemur ltibia head") for x in L], 56, "two parents"),
    (lambda L: [x.replace("    lowerback head", "") for x in L], 44, "not connected to the root"),
])
def test_bad_asf_names_the_line(mutate, line, words):
    text = "\n".join(mutate(_asf_lines()))
    with pytest.raises(MotionFormatError) as e:
        parse_asf(text, path="t.asf")
    assert e.value.line == line, str(e.value)
    assert words in str(e.value)


def test_translation_dofs_below_root_are_refused_unless_zero():
    text = ASF.replace("dof rz rx", "dof rz rx tx")
    a = parse_asf(text, path="t.asf")
    amc = "\n".join(x + (" 0" if x.startswith("lowerback") else "") for x in amc_text().split("\n"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        parse_amc(amc, a)  # all zero: fine
        bad = amc.replace("lowerback", "lowerback", 1)
        bad = re.sub(r"(lowerback \S+ \S+) 0", r"\1 0.5", bad, count=1)
        with pytest.raises(MotionFormatError, match="translation/length dofs"):
            parse_amc(bad, a)


# ------------------------------------------------------------------ property tests
GARBAGE = ["nan", "inf", "-inf", "abc", "1e999", "", "begin", "end", "root", "lfemur", "ltibia", "head", ":bonedata",
           ":hierarchy", "1.2.3", "(", ")", "dof", "limits", "0", "7", "-1", "XYZ", "é", "\x00", "#"]


def _mutate(draw, text: str) -> str:
    lines = text.split("\n")
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "duplicate", "token", "truncate", "swap", "renumber"]))
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "token":
            toks = lines[i].split(" ")
            toks[draw(st.integers(0, max(0, len(toks) - 1)))] = draw(st.sampled_from(GARBAGE))
            lines[i] = " ".join(toks)
        elif kind == "truncate":
            joined = "\n".join(lines)
            lines = joined[:draw(st.integers(0, len(joined)))].split("\n")
        elif kind == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        else:
            lines = [str(draw(st.integers(-1, 9))) if x.strip().isdigit() and k == i else x
                     for k, x in enumerate(lines)]
    return "\n".join(lines)


@st.composite
def mutated_amc(draw):
    return _mutate(draw, amc_text(T=3, seed=draw(st.integers(0, 3))))


@st.composite
def mutated_asf(draw):
    return _mutate(draw, ASF)


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_amc())
def test_mutated_amc_parses_or_raises_motion_format_error(text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            m = parse_amc(text, asf(), path="m.amc")
        except MotionFormatError as e:
            assert e.path == "m.amc"
            event("MotionFormatError")
            return
    event("parsed")
    assert np.all(np.isfinite(m.positions))


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_asf())
def test_mutated_asf_parses_or_raises_motion_format_error(text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            a = parse_asf(text, path="m.asf")
            m = parse_amc(amc_text(T=2), a, path="m.amc")
        except MotionFormatError as e:
            assert e.path in ("m.asf", "m.amc")
            event("MotionFormatError")
            return
    event("parsed")
    assert m.n_frames == 2


# ------------------------------------------------------------------ unicode digits, extreme values (issue 12)
@pytest.mark.parametrize("mutate, line, words", [
    (lambda L: L[:9] + ["²"] + L[10:], 10, "bone '²' is not in the skeleton"),     # str.isdigit('²') is True
    (lambda L: L[:9] + ["٣"] + L[10:], 10, "bone '٣' is not in the skeleton"),     # Arabic-Indic three
    (lambda L: L[:10] + ["root 1e308 15 0 0 0 0"] + L[11:], 11, "root position x = 5.64444e+306 m at frame 1"),
    (lambda L: L[:10] + ["root 1e6 15 0 0 0 0"] + L[11:], 11, "beyond the accepted +-10000 m"),
    (lambda L: L[:11] + ["lfemur 1 1e300 3"] + L[12:], 12, "bone 'lfemur' dof ry: angle 1e+300 deg is beyond"),
])
def test_unicode_frame_numbers_and_extreme_values_name_the_line(mutate, line, words):
    text = "\n".join(mutate(_amc_lines()))
    with pytest.raises(MotionFormatError) as e:
        load(text)
    assert e.value.line == line and f"t.amc:{line}: " in str(e.value) and words in str(e.value), str(e.value)


def test_extreme_bone_length_and_fps_are_refused():
    bad = ASF.replace("length 6", "length 1e300")
    with pytest.raises(MotionFormatError) as e:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            parse_amc(amc_text(), parse_asf(bad, path="t.asf"), path="t.amc")
    assert "t.asf:" in str(e.value) and "bone 'lowerback' is 5.64444e+298 m long after scaling" in str(e.value) and e.value.line == 36, str(e.value)
    with pytest.raises(MotionFormatError, match=r"t.amc: fps argument 20000 Hz is outside the accepted 1-10000 Hz"):
        load(fps=20000)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from(["", "root 1 2", "12", "é ü", "\x85", "\u2028", "a" * 40]), max_size=30),
       st.lists(st.sampled_from(["\n", "\r\n", "\r", "\x0c"]), min_size=1, max_size=30), st.integers(1, 64),
       st.booleans())
def test_file_lines_are_the_lines_of_the_decoded_text(tmp_path_factory, pieces, ends, block, latin1):
    """The block-wise line reader (any block size, CRLF split across blocks, CR-only files)
    gives exactly ``text.splitlines()`` of the whole file."""
    import itertools

    from mocomp.io.asf_amc import _line_blocks

    text = "".join(p + ends[k % len(ends)] for k, p in enumerate(pieces)) + ("tail" if latin1 else "")
    data = text.encode("latin-1", "replace") if latin1 else text.encode("utf-8")
    f = tmp_path_factory.mktemp("lines") / "t.amc"
    f.write_bytes(data)
    got = list(itertools.chain.from_iterable(_line_blocks(open(f, "rb"), f, block=block)))
    expect = data.decode("latin-1" if latin1 else "utf-8").splitlines()
    if latin1:  # per-block decoding: a block that happens to be valid UTF-8 decodes as UTF-8
        assert len(got) == len(expect)
    else:
        assert got == expect


def test_overlong_lines_are_refused(tmp_path):
    from mocomp.io.asf_amc import MAX_LINE_BYTES

    f = tmp_path / "long.amc"
    f.write_bytes(b":DEGREES\n1\n" + b"root " + b"1 " * MAX_LINE_BYTES + b"\n")
    (tmp_path / "s.asf").write_text(ASF)
    with pytest.raises(MotionFormatError, match=r"long.amc:3: line 3 is longer than 65536"):
        read_amc(f, asf=tmp_path / "s.asf")
