"""DeepMimic motion + character files: skeleton and body facts (45 kg), solid
inertias against Monte Carlo integration, FK against an independent chain,
timing (uniform and resampled key frames), real-clip facts (flight gravity,
root rotation), BVH round trips, and bad input."""
from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from conftest import real_files
from mocomp.core.rotations import quat_angle, quat_apply, quat_inverse, quat_multiply
from mocomp.errors import MotionFormatError
from mocomp.io import UnitWarning, read_bvh, write_bvh
from mocomp.io.deepmimic import (find_character, parse_deepmimic, read_deepmimic, read_deepmimic_body,
                                 read_deepmimic_character, solid_inertia)


def _joint(i, name, jtype, parent, x=0.0, y=0.0, z=0.0, **kw):
    d = {"ID": i, "Name": name, "Type": jtype, "Parent": parent, "AttachX": x, "AttachY": y, "AttachZ": z,
         "AttachThetaX": 0, "AttachThetaY": 0, "AttachThetaZ": 0}
    d.update(kw)
    return d


def _body(i, name, shape, mass, x=0.0, y=0.0, z=0.0, p=(0.1, 0.1, 0.1), **kw):
    d = {"ID": i, "Name": name, "Shape": shape, "Mass": mass, "AttachX": x, "AttachY": y, "AttachZ": z,
         "AttachThetaX": 0, "AttachThetaY": 0, "AttachThetaZ": 0, "Param0": p[0], "Param1": p[1], "Param2": p[2]}
    d.update(kw)
    return d


def small_character(tmp_path, theta=(0.0, 0.0, 0.0)):
    """root -> spine (spherical) -> head (fixed); root -> hip (spherical) -> knee (revolute) -> foot."""
    joints = [_joint(0, "root", "none", -1), _joint(1, "spine", "spherical", 0, y=0.3),
              _joint(2, "head", "fixed", 1, y=0.4), _joint(3, "hip", "spherical", 0, z=0.1, y=-0.05),
              _joint(4, "knee", "revolute", 3, y=-0.45), _joint(5, "foot", "spherical", 4, y=-0.45)]
    bodies = [_body(0, "root", "sphere", 10, y=0.05, p=(0.3, 0, 0)),
              _body(1, "spine", "box", 20, y=0.2, p=(0.3, 0.4, 0.2),
                    AttachThetaX=theta[0], AttachThetaY=theta[1], AttachThetaZ=theta[2]),
              _body(2, "head", "sphere", 5, y=0.15, p=(0.2, 0, 0)),
              _body(3, "hip", "capsule", 8, y=-0.22, p=(0.12, 0.3, 0)),
              _body(4, "knee", "cylinder", 4, y=-0.22, p=(0.1, 0.35, 0)),
              _body(5, "foot", "box", 1, x=0.05, y=-0.03, p=(0.2, 0.06, 0.1))]
    f = tmp_path / "character.txt"
    f.write_text(json.dumps({"Skeleton": {"Joints": joints}, "BodyDefs": bodies}, indent=1))
    return f


def motion_doc(T=5, dt=0.05, seed=0, dts=None):
    rng = np.random.default_rng(seed)
    frames = []
    for k in range(T):
        q = Rotation.random(4, random_state=seed * 100 + k).as_quat()[:, [3, 0, 1, 2]]  # w, x, y, z
        # dt, root pos, root quat, spine quat, (head fixed), hip quat, knee angle, foot quat
        fr = [dts[k] if dts is not None else (dt if k < T - 1 else 0.0), 0.1 * k, 0.9, 0.0, *q[0], *q[1], *q[2],
              float(rng.uniform(-1.5, 0)), *q[3]]
        frames.append(fr)
    return {"Loop": "none", "Frames": frames}


def write_motion(tmp_path, doc, name="m.txt"):
    f = tmp_path / name
    f.write_text("{\n\"Loop\": \"none\",\n\"Frames\":\n[\n" +
                 ",\n".join(json.dumps(fr) for fr in doc["Frames"]) + "\n]\n}\n")
    return f


def quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitWarning)
        return fn(*a, **k)


# ------------------------------------------------------------------ solids
def _monte_carlo_inertia(inside, half_extent, mass, n=400_000, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.uniform(-1, 1, (n, 3)) * half_extent
    p = p[inside(p)]
    r2 = np.sum(p * p, axis=1)
    return mass * (np.eye(3) * r2.mean() - (p[:, :, None] * p[:, None, :]).mean(axis=0))


@pytest.mark.parametrize("shape, params, inside, half", [
    ("sphere", (0.3, 0, 0), lambda p: np.sum(p ** 2, 1) <= 0.15 ** 2, [0.15] * 3),
    ("box", (0.3, 0.1, 0.2), lambda p: np.ones(len(p), bool), [0.15, 0.05, 0.1]),
    ("cylinder", (0.2, 0.5, 0), lambda p: p[:, 0] ** 2 + p[:, 2] ** 2 <= 0.1 ** 2, [0.1, 0.25, 0.1]),
    ("capsule", (0.2, 0.3, 0),
     lambda p: p[:, 0] ** 2 + p[:, 2] ** 2 + np.maximum(np.abs(p[:, 1]) - 0.15, 0) ** 2 <= 0.1 ** 2,
     [0.1, 0.25, 0.1]),
])
def test_solid_inertia_matches_monte_carlo(shape, params, inside, half):
    I = solid_inertia(shape, 3.0, params)
    ref = _monte_carlo_inertia(inside, np.array(half), 3.0)
    np.testing.assert_allclose(np.diag(I), np.diag(ref), rtol=0.01)
    assert np.abs(ref - np.diag(np.diag(ref))).max() < 0.01 * np.diag(ref).max()


def test_capsule_limits():
    np.testing.assert_allclose(solid_inertia("capsule", 2.0, (0.4, 0.0)), solid_inertia("sphere", 2.0, (0.4,)))
    thin = solid_inertia("capsule", 2.0, (1e-6, 1.0))
    assert thin[0, 0] == pytest.approx(2.0 / 12, rel=1e-5) and thin[1, 1] < 1e-12
    with pytest.raises(ValueError, match="unknown shape"):
        solid_inertia("torus", 1, (1, 1, 1))


# ------------------------------------------------------------------ character + body
def test_small_character_and_body(tmp_path):
    f = small_character(tmp_path, theta=(0.3, -0.2, 0.5))
    ch = read_deepmimic_character(f)
    assert ch.skeleton.names == ("root", "spine", "head", "hip", "knee", "foot")
    assert ch.joint_types == ("none", "spherical", "fixed", "spherical", "revolute", "spherical")
    assert ch.n_params == 7 + 4 + 0 + 4 + 1 + 4
    assert ch.skeleton.channels[4] == ("Zrotation",) and ch.skeleton.channels[2] == ()
    body = read_deepmimic_body(f)
    assert body.total_mass == 48.0
    assert body.segment_names == ("root", "spine", "head", "hip", "knee", "foot")
    np.testing.assert_allclose(body.local_coms[5], [0.05, -0.03, 0])
    R = Rotation.from_euler("xyz", [0.3, -0.2, 0.5]).as_matrix()
    np.testing.assert_allclose(body.inertias[1], R @ solid_inertia("box", 20, (0.3, 0.4, 0.2)) @ R.T, atol=1e-15)
    # leaf joints with an off-centre body get an end site at the body centre
    assert [e.name for e in ch.skeleton.end_sites] == ["head_end", "foot_end"]


def test_fk_matches_independent_chain(tmp_path):
    ch = read_deepmimic_character(small_character(tmp_path))
    doc = motion_doc(T=4)
    m = quiet(parse_deepmimic, json.dumps(doc), ch, fps=None)
    F = np.array(doc["Frames"])
    for k in range(4):
        q = lambda a: Rotation.from_quat(np.roll(F[k, a:a + 4], -1))  # noqa: E731  (w,x,y,z) -> scipy
        R_root, R_hip = q(4), q(12)
        R_knee = Rotation.from_rotvec([0, 0, F[k, 16]])
        root = F[k, 1:4]
        hip = root + R_root.apply([0, -0.05, 0.1])
        knee = hip + (R_root * R_hip).apply([0, -0.45, 0])
        foot = knee + (R_root * R_hip * R_knee).apply([0, -0.45, 0])
        np.testing.assert_allclose(m.positions[k, 5], foot, atol=1e-12)


def test_uniform_and_resampled_timing(tmp_path):
    ch = read_deepmimic_character(small_character(tmp_path))
    m = quiet(parse_deepmimic, json.dumps(motion_doc(T=5, dt=0.05)), ch)
    assert m.n_frames == 5 and m.fps == pytest.approx(20.0) and m.source.header_fps == pytest.approx(20.0)
    assert not any("not uniformly spaced" in n for n in m.source.notes)
    # non-uniform keys: dt 0.1, 0.2, 0.1 -> keys at 0, 0.1, 0.3, 0.4 s; resampled at 10 fps (the most common dt)
    doc = motion_doc(T=4, dts=[0.1, 0.2, 0.1, 0.0])
    r = quiet(parse_deepmimic, json.dumps(doc), ch)
    assert r.fps == pytest.approx(10.0) and r.n_frames == 5
    assert any("resampled 4 keys" in n for n in r.source.notes)
    keys = quiet(parse_deepmimic, json.dumps(motion_doc(T=4, dts=[0.1, 0.1, 0.1, 0.0])), ch)
    np.testing.assert_allclose(r.positions[[0, 1, 3, 4]], keys.positions, atol=1e-12)  # at the key times
    np.testing.assert_allclose(r.root_positions[2], 0.5 * (keys.root_positions[1] + keys.root_positions[2]))
    mid = keys.replace(fps=5.0).sample([0.3])  # halfway between keys 1 and 2 (slerp)
    np.testing.assert_allclose(r.positions[2], mid.positions[0], atol=1e-12)


def test_scale_and_height_warning(tmp_path):
    ch = read_deepmimic_character(small_character(tmp_path))
    with pytest.warns(UnitWarning):
        m = parse_deepmimic(json.dumps(motion_doc()), ch, scale=10.0)
    assert m.source.unit_scale == 10.0


# ------------------------------------------------------------------ bad input
def test_bad_motion_files_name_the_line(tmp_path):
    ch = read_deepmimic_character(small_character(tmp_path))
    doc = motion_doc(T=4)

    def expect(frames_or_text, words, line=None):
        if isinstance(frames_or_text, str):
            f = tmp_path / "bad.txt"
            f.write_text(frames_or_text)
        else:
            f = write_motion(tmp_path, {"Frames": frames_or_text}, "bad.txt")
        with pytest.raises(MotionFormatError) as e:
            quiet(read_deepmimic, f, character=ch)
        assert words in str(e.value), str(e.value)
        assert str(f) in str(e.value)
        if line is not None:
            assert e.value.line == line, str(e.value)

    fr = [list(x) for x in doc["Frames"]]
    # frames start on lines 5, 6, 7, 8 of write_motion's layout
    expect([fr[0], fr[1][:-1], fr[2], fr[3]], "frame 1 has 20 values", 6)
    expect([fr[0], fr[1], fr[2] + [1.0], fr[3]], "frame 2 has 22 values", 7)
    expect([fr[0], fr[1], fr[2], fr[3][:5] + ["x"] + fr[3][6:]], "frame 3 value 5 ('x') is not a number", 8)
    expect([fr[0], fr[1][:3] + [None] + fr[1][4:], fr[2], fr[3]], "is not a number", 6)
    lines = write_motion(tmp_path, {"Frames": fr}).read_text().split("\n")
    lines[6] = lines[6].replace(json.dumps(fr[2][16]), "NaN")  # the knee angle of frame 2
    expect("\n".join(lines), "frame 2 value 16 is nan (not finite)", 7)
    expect([fr[0], [-0.1] + fr[1][1:], fr[2], fr[3]], "dt = -0.1", 6)
    zero_q = [fr[0], fr[1][:4] + [0, 0, 0, 0] + fr[1][8:], fr[2], fr[3]]
    expect(zero_q, "quaternion of joint 'root' is zero", 6)
    expect([], "zero frames")
    expect('{"Loop": "wrap"}', "needs a 'Frames' list", 1)
    expect('{"Loop": "wrap",\n "Frames": [[0.1, 2,,]]}', "not valid JSON", 2)
    with pytest.raises(MotionFormatError, match="cannot read"):
        read_deepmimic(tmp_path / "missing.txt", character=ch)


def test_bad_character_files(tmp_path):
    good = json.loads(small_character(tmp_path).read_text())

    def expect(mod, words):
        d = json.loads(json.dumps(good))
        mod(d)
        f = tmp_path / "c.txt"
        f.write_text(json.dumps(d, indent=1))
        with pytest.raises(MotionFormatError) as e:
            read_deepmimic_character(f)
        assert words in str(e.value), str(e.value)
        assert e.value.line is not None

    expect(lambda d: d["Skeleton"]["Joints"][4].update(Type="planar"), "type 'planar'")
    expect(lambda d: d["Skeleton"]["Joints"][1].update(Parent=3), "parents precede children")
    expect(lambda d: d["Skeleton"]["Joints"][2].update(Name="spine"), "duplicate joint name 'spine'")
    expect(lambda d: d["Skeleton"]["Joints"][2].update(AttachY="high"), "is not a finite number")
    expect(lambda d: d["BodyDefs"][2].update(ID=9), "not a joint ID")
    d = json.loads(json.dumps(good))
    d["BodyDefs"][3]["Mass"] = -1
    (tmp_path / "neg.txt").write_text(json.dumps(d))
    with pytest.raises(MotionFormatError, match="negative mass"):
        read_deepmimic_body(tmp_path / "neg.txt")


def test_find_character(tmp_path):
    (tmp_path / "skeletons").mkdir()
    (tmp_path / "flips").mkdir()
    c = small_character(tmp_path / "skeletons")
    f = write_motion(tmp_path / "flips", motion_doc())
    assert find_character(f) == c.resolve()
    assert quiet(read_deepmimic, f).n_frames == 5
    lone = tmp_path / "a" / "b" / "lone"  # no character beside it, nor one or two levels up
    lone.mkdir(parents=True)
    g = write_motion(lone, motion_doc())
    with pytest.raises(MotionFormatError, match="no DeepMimic character file"):
        find_character(g)


# ------------------------------------------------------------------ real files
@pytest.fixture(scope="module")
def character(real_data_dir):
    return real_data_dir / "skeletons" / "deepmimic_humanoid3d_character.txt"


@pytest.mark.realdata
def test_real_character_mass_and_skeleton(character):
    ch = read_deepmimic_character(character)
    assert ch.skeleton.n_joints == 15 and ch.n_params == 43
    assert ch.joint_types.count("revolute") == 4 and ch.joint_types.count("fixed") == 2
    body = read_deepmimic_body(character)
    assert body.total_mass == pytest.approx(45.0)  # MANIFEST: total 45 kg
    assert body.masses[body.segment("chest")] == 14.0
    np.testing.assert_allclose(body.local_coms[body.segment("right_ankle")], [0.045, -0.0225, 0.0])
    assert np.all(np.linalg.eigvalsh(body.inertias) > 0)


@pytest.mark.realdata
def test_real_backflip_facts(real_data_dir, character):
    """MANIFEST: 29 keys at 16 Hz, COM flight fit g = 9.5 m/s^2, ~420 deg of root rotation."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        m = read_deepmimic(real_data_dir / "flips" / "deepmimic_backflip.txt", character=character)
    assert m.n_frames == 29 and m.fps == 16.0 and m.duration == pytest.approx(1.75)
    body = read_deepmimic_body(character, m.skeleton)
    P, G = m.fk()
    seg = body.segment_joint
    com = np.einsum("s,tsi->ti", body.masses, P[:, seg] + quat_apply(G[:, seg], body.local_coms[None])) / 45.0
    t, y = m.times[11:19], com[11:19, 1]  # the flight
    assert 9.0 < -2 * np.polyfit(t, y, 2)[0] < 10.0
    q = m.rotations[:, 0]
    total = np.rad2deg(quat_angle(quat_multiply(q[1:], quat_inverse(q[:-1]))).sum())
    assert total == pytest.approx(420, abs=5)
    assert any("normalised" in n for n in m.source.notes)


@pytest.mark.realdata
def test_real_timing(real_data_dir, character):
    cart = read_deepmimic(real_data_dir / "cartwheels" / "deepmimic_cartwheel.txt", character=character)
    assert cart.n_frames == 164 and cart.fps == pytest.approx(1 / 0.016666)
    roll = read_deepmimic(real_data_dir / "jumps" / "deepmimic_roll.txt", character=character)
    assert any("not uniformly spaced" in n for n in roll.source.notes)
    assert roll.fps == pytest.approx(1 / 0.016666)
    assert roll.duration == pytest.approx(119 * 0.016666 + 0.032666, abs=1 / roll.fps)


@pytest.mark.realdata
@pytest.mark.parametrize("path", [p for p in real_files("*/deepmimic_*.txt") if p.parent.name != "skeletons"],
                         ids=lambda p: p.name)
def test_real_deepmimic_round_trip(path, tmp_path, character):
    m = read_deepmimic(path, character=character)
    r = read_bvh(write_bvh(m, tmp_path / (path.stem + ".bvh")), scale=1.0, height_check=False)
    idx = [r.skeleton.index(n) for n in m.skeleton.names]
    assert np.abs(r.positions[:, idx] - m.positions).max() < 1e-6
    assert np.abs(r.end_site_positions() - m.end_site_positions()).max() < 1e-6


# ------------------------------------------------------------------ property test
_TOKEN = re.compile(r'-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?|"[^"]*"|[\[\]{},:]')
_GARBAGE = ["NaN", "Infinity", "-Infinity", '"x"', "null", "[]", "{}", "1e999", "", ",", "]", "[", "0", "-1", "true"]


@st.composite
def mutated_deepmimic(draw):
    """A valid motion or character file with 1-3 token replacements, truncations or line edits."""
    which = draw(st.sampled_from(["motion", "character"]))
    text = _PROPERTY_TEXTS[which]
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["token", "truncate", "delete", "duplicate"]))
        toks = list(_TOKEN.finditer(text))
        if kind == "token" and toks:
            m = toks[draw(st.integers(0, len(toks) - 1))]
            text = text[:m.start()] + draw(st.sampled_from(_GARBAGE)) + text[m.end():]
        elif kind == "truncate":
            text = text[:draw(st.integers(0, len(text)))]
        else:
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            lines[i:i + 1] = [] if kind == "delete" else [lines[i], lines[i]]
            text = "\n".join(lines)
    return which, text


def _property_texts():
    import tempfile
    from pathlib import Path
    with tempfile.TemporaryDirectory() as d:
        char = small_character(Path(d))
        return {"character": char.read_text(), "motion": write_motion(Path(d), motion_doc(T=4)).read_text(),
                "parsed_character": read_deepmimic_character(char)}


_PROPERTY_TEXTS = _property_texts()


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(mutated_deepmimic())
def test_mutated_deepmimic_parses_or_raises_motion_format_error(tmp_path, case):
    """Mutated DeepMimic motion/character JSON either loads or raises MotionFormatError, never another exception."""
    which, text = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if which == "motion":
                m = parse_deepmimic(text, _PROPERTY_TEXTS["parsed_character"], path="m.txt")
                assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.root_positions))
            else:
                f = tmp_path / "c.txt"
                f.write_text(text)
                read_deepmimic_character(f)
                body = read_deepmimic_body(f)
                assert np.all(body.masses >= 0)
        except MotionFormatError as e:
            assert e.path is not None
            event("MotionFormatError")
            return
    event("parsed")


# ------------------------------------------------------------------ corrupt numbers and sizes (issue 12)
def test_corrupt_dt_is_refused_before_resampling(tmp_path, monkeypatch):
    """One key frame with dt = 1e4 s made the resampler allocate 160,000 frames (1e6 s: GiBs)."""
    ch = read_deepmimic_character(small_character(tmp_path))
    for bad_dt in (1e4, 1e6, 11.0):
        dts = [0.05, bad_dt, 0.05, 0.0]
        f = write_motion(tmp_path, motion_doc(T=4, dts=dts), "dt.txt")
        with pytest.raises(MotionFormatError, match=re.escape(f"frame 1 has duration dt = {bad_dt:g} s (more than "
                                                              "the 10 s")) as e:
            quiet(read_deepmimic, f, character=ch)
        assert e.value.line == 6 and "dt.txt" in str(e.value)
    # a long but plausible hold (9 s) still resamples, to the frame count it should
    m = quiet(read_deepmimic, write_motion(tmp_path, motion_doc(T=4, dts=[0.05, 9.0, 0.05, 0.0])), character=ch)
    assert m.fps == pytest.approx(20.0) and m.n_frames == int(np.floor(9.1 * 20 + 1e-9)) + 1
    # a resampling that would exceed the frame limit is refused before allocating
    import mocomp.io.deepmimic as dm

    monkeypatch.setattr(dm, "MAX_FRAMES", 50_000)
    f = write_motion(tmp_path, motion_doc(T=4, dts=[0.05, 9.0, 0.05, 0.0]), "many.txt")
    with pytest.raises(MotionFormatError, match=r"at 10000 fps would make 91001 frames \(more than the 50,000"):
        quiet(read_deepmimic, f, character=ch, fps=10000)
    monkeypatch.undo()
    with pytest.raises(MotionFormatError, match=r"key-frame rate 1/dt 1e\+06 Hz is outside the accepted 1-10000 Hz"):
        quiet(read_deepmimic, write_motion(tmp_path, motion_doc(T=4, dt=1e-6), "fast.txt"), character=ch)
    with pytest.raises(MotionFormatError, match="fps argument 0 Hz"):
        quiet(read_deepmimic, write_motion(tmp_path, motion_doc(T=4)), character=ch, fps=0)


def test_json_nesting_huge_integers_and_extreme_values_are_motion_format_errors(tmp_path):
    ch = read_deepmimic_character(small_character(tmp_path))
    fr = [list(x) for x in motion_doc(T=4)["Frames"]]
    good = write_motion(tmp_path, {"Frames": fr}, "g.txt").read_text()
    lines = good.split("\n")
    cases = {
        "nested": ("{\"Frames\": " + "[" * 100_000, "nested too deeply", None),
        "int400": ("\n".join(lines[:6] + [lines[6].replace(json.dumps(fr[2][2]), str(10 ** 400), 1)] + lines[7:]),
                   "frame 2 value 2 is inf (not finite)", 7),
        "int5001": ("\n".join(lines[:5] + [lines[5].replace(json.dumps(fr[1][1]), "1" * 5001, 1)] + lines[6:]),
                    "frame 1 value 1 is inf (not finite)", 6),
        "root_far": ("\n".join(lines[:7] + [lines[7].replace(json.dumps(fr[3][1]), "-1e308", 1)] + lines[8:]),
                     "frame 3: root position x = -1e+308 m is beyond the accepted +-10000 m", 8),
    }
    for name, (text, words, line) in cases.items():
        f = tmp_path / f"{name}.txt"
        f.write_text(text)
        with pytest.raises(MotionFormatError) as e:
            quiet(read_deepmimic, f, character=ch)
        assert words in str(e.value) and f"{name}.txt" in str(e.value), (name, str(e.value))
        if line is not None:
            assert e.value.line == line, (name, str(e.value))
        with pytest.raises(MotionFormatError):  # the text parser too
            quiet(parse_deepmimic, text, ch, path=f"{name}.txt")
    # character files: huge ints, deep nesting, extreme attach offsets
    cf = small_character(tmp_path)
    ctext = cf.read_text()
    for name, text, words in (
            ("c_int", ctext.replace('"Parent": 0', '"Parent": ' + "9" * 5001, 1), "field 'Parent'"),
            ("c_nest", '{"Skeleton": ' + "[" * 100_000, "nested too deeply"),
            ("c_far", ctext.replace('"AttachY": 0.3', '"AttachY": 1e300', 1), "beyond the accepted")):
        f = tmp_path / f"{name}.txt"
        f.write_text(text)
        with pytest.raises(MotionFormatError) as e:
            read_deepmimic_character(f)
        assert words in str(e.value) and f"{name}.txt" in str(e.value), (name, str(e.value))
