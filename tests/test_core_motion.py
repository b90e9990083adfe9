"""The Motion value: validation, slicing, sampling, retiming, concatenation, mirroring, rigid moves."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from mocomp.core import EndSite, Motion, Skeleton, SourceInfo, concatenate
from mocomp.errors import MotionFormatError

NAMES = ("Hips", "Spine", "Head", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot",
         "LeftArm", "LeftHand", "RightArm", "RightHand")
PARENTS = (-1, 0, 1, 0, 3, 4, 0, 6, 7, 1, 9, 1, 11)


def make_skeleton(asymmetric: bool = False, ends: str = "all") -> Skeleton:
    off = np.array([
        [0.0, 0.95, 0.0], [0.0, 0.25, 0.0], [0.0, 0.3, 0.02],
        [0.1, 0.0, 0.0], [0.0, -0.45, 0.0], [0.0, -0.42, 0.0],
        [-0.1, 0.0, 0.0], [0.0, -0.45, 0.0], [0.0, -0.42, 0.0],
        [0.18, 0.2, 0.0], [0.5, 0.0, 0.0],
        [-0.18, 0.2, 0.0], [-0.5, 0.0, 0.0],
    ])
    if asymmetric:
        off[7] = [0.01, -0.47, 0.02]  # right shin longer and tilted
        off[10] = [0.48, 0.01, -0.01]
    end_sites = {
        "all": (EndSite(2, [0, 0.15, 0], "Head_end"), EndSite(5, [0, -0.05, 0.12], "LeftFoot_end"),
                EndSite(8, [0, -0.05, 0.12], "RightFoot_end"), EndSite(10, [0.08, 0, 0], "LeftHand_end"),
                EndSite(12, [-0.09, 0.01, 0], "RightHand_end")),
        "head": (EndSite(2, [0, 0.15, 0], "Head_end"),),
        "left_only": (EndSite(2, [0, 0.15, 0], "Head_end"), EndSite(5, [0.02, -0.05, 0.12], "LeftFoot_end")),
    }[ends]
    return Skeleton(NAMES, PARENTS, off, end_sites=end_sites)


def make_motion(T: int = 40, fps: float = 30.0, seed: int = 0, sk: Skeleton | None = None) -> Motion:
    """Smooth random motion: each joint rotates at its own constant angular velocity."""
    rng = np.random.default_rng(seed)
    sk = sk or make_skeleton()
    J = sk.n_joints
    t = np.arange(T) / fps
    w = rng.normal(size=(J, 3)) * 1.5
    r0 = Rotation.random(J, random_state=seed)
    rot = np.empty((T, J, 4))
    for j in range(J):
        rot[:, j] = (Rotation.from_rotvec(np.outer(t, w[j])) * r0[j]).as_quat()
    root = np.column_stack([0.8 * t, 0.95 + 0.05 * np.sin(4 * t), -0.3 * t])
    return Motion(sk, fps, root, rot, source=SourceInfo(format="synthetic"))


def same_rotation(q1, q2, atol=1e-12):
    q1, q2 = np.broadcast_arrays(np.asarray(q1, float), np.asarray(q2, float))
    d = np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))
    return bool(np.all(d < atol))


# ------------------------------------------------------------------ validation
def test_valid_motion_basic_facts():
    m = make_motion(T=31, fps=30)
    assert m.n_frames == len(m) == 31
    assert m.duration == pytest.approx(1.0)
    np.testing.assert_allclose(m.times, np.arange(31) / 30)
    assert m.dt == pytest.approx(1 / 30)
    assert m.positions.shape == (31, 13, 3) and m.global_rotations.shape == (31, 13, 4)
    assert "13 joints" in repr(m)


@pytest.mark.parametrize("root,rot,match", [
    (np.zeros((5, 2)), np.zeros((5, 13, 4)), r"root_positions must have shape \(T, 3\)"),
    (np.zeros(5), np.zeros((5, 13, 4)), r"root_positions must have shape"),
    (np.zeros((5, 3)), np.zeros((5, 12, 4)), r"rotations must have shape \(5, 13, 4\)"),
    (np.zeros((5, 3)), np.zeros((4, 13, 4)), r"rotations must have shape \(5, 13, 4\)"),
    (np.zeros((5, 3)), np.zeros((5, 13, 3)), r"rotations must have shape"),
    (np.zeros((0, 3)), np.zeros((0, 13, 4)), "at least one frame"),
])
def test_shape_errors(root, rot, match):
    with pytest.raises(MotionFormatError, match=match):
        Motion(make_skeleton(), 30, root, rot)


def _ident(T=5, J=13):
    return np.tile([0.0, 0.0, 0.0, 1.0], (T, J, 1))


def test_non_finite_and_zero_quaternion_errors():
    sk = make_skeleton()
    root = np.zeros((5, 3))
    root[3, 1] = np.nan
    with pytest.raises(MotionFormatError, match="root_positions has a non-finite value at frame 3"):
        Motion(sk, 30, root, _ident())
    rot = _ident()
    rot[2, 4, 0] = np.inf
    with pytest.raises(MotionFormatError, match="rotations has a non-finite value at frame 2"):
        Motion(sk, 30, np.zeros((5, 3)), rot)
    rot = _ident()
    rot[4, 7] = 0.0
    with pytest.raises(MotionFormatError, match="'RightLeg' at frame 4 is a zero quaternion"):
        Motion(sk, 30, np.zeros((5, 3)), rot)


@pytest.mark.parametrize("fps", [0, -30, np.nan, np.inf, None, "fast"])
def test_fps_errors(fps):
    with pytest.raises(MotionFormatError, match="fps must be a positive finite number"):
        Motion(make_skeleton(), fps, np.zeros((5, 3)), _ident())


def test_normalises_copies_and_freezes_inputs():
    rot = _ident() * 3.0
    root = np.zeros((5, 3))
    m = Motion(make_skeleton(), 30, root, rot)
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0)
    rot[0, 0] = [1, 0, 0, 0]
    root[0] = 5.0
    assert same_rotation(m.rotations[0, 0], [0, 0, 0, 1]) and np.all(m.root_positions == 0)
    with pytest.raises(ValueError):
        m.rotations[0, 0, 0] = 1.0
    with pytest.raises(ValueError):
        m.root_positions[0, 0] = 1.0
    assert isinstance(Motion(make_skeleton(), np.int64(24), root, rot).fps, float)


# ------------------------------------------------------------------- slicing
def test_slicing_frames_and_step():
    m = make_motion(T=40, fps=30)
    s = m[10:25]
    assert s.n_frames == 15 and s.fps == 30
    np.testing.assert_array_equal(s.rotations, m.rotations[10:25])
    np.testing.assert_allclose(s.positions, m.positions[10:25], atol=1e-15)
    s2 = m[::2]
    assert s2.fps == 15 and s2.n_frames == 20
    np.testing.assert_allclose(s2.positions, m.positions[::2], atol=1e-15)
    np.testing.assert_array_equal(m[5].root_positions, m.root_positions[5:6])
    np.testing.assert_array_equal(m[-1].root_positions, m.root_positions[-1:])
    np.testing.assert_array_equal(m[-3].root_positions, m.root_positions[-3:-2])
    np.testing.assert_array_equal(m.slice(3, 7).rotations, m.rotations[3:7])
    assert m[30:].n_frames == 10


def test_slicing_errors():
    m = make_motion(T=10)
    with pytest.raises(MotionFormatError, match="empty frame slice"):
        m[8:3]
    with pytest.raises(MotionFormatError, match="empty frame slice"):
        m[20]
    with pytest.raises(ValueError, match="positive step"):
        m[::-1]
    with pytest.raises(TypeError):
        m[[1, 2]]


# ------------------------------------------------------------------ sampling
def test_sample_at_frame_times_reproduces_frames_exactly():
    for fps in (30.0, 120.0, 59.94, 7.0):
        m = make_motion(T=97, fps=fps, seed=3)
        s = m.sample(m.times)
        np.testing.assert_array_equal(s.rotations, m.rotations)
        np.testing.assert_array_equal(s.root_positions, m.root_positions)
        np.testing.assert_array_equal(s.positions, m.positions)


def test_sample_between_frames_matches_scipy_slerp_and_linear_root():
    m = make_motion(T=30, fps=30, seed=4)
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0, m.duration, 50))
    s = m.sample(t)
    assert s.n_frames == 50 and s.fps == m.fps
    for j in range(m.skeleton.n_joints):
        ref = Slerp(m.times, Rotation.from_quat(m.rotations[:, j]))(t).as_quat()
        assert same_rotation(s.rotations[:, j], ref, atol=1e-10), j
    for k in range(3):
        np.testing.assert_allclose(s.root_positions[:, k], np.interp(t, m.times, m.root_positions[:, k]), atol=1e-14)
    assert m.sample([0.5 / 30], fps=99).fps == 99


def test_sample_errors():
    m = make_motion(T=31, fps=30)
    for bad in ([-0.01], [1.0 + 1e-6], [np.nan], []):
        with pytest.raises(ValueError):
            m.sample(bad)
    m.sample([0.0, 1.0 + 1e-12])  # rounding at the end is tolerated


def test_resample_keeps_duration_and_frames():
    m = make_motion(T=31, fps=30, seed=5)
    up = m.resample(60)
    assert up.fps == 60 and up.n_frames == 61 and up.duration == pytest.approx(m.duration)
    np.testing.assert_array_equal(up.rotations[::2], m.rotations)
    np.testing.assert_array_equal(up.root_positions[::2], m.root_positions)
    down = m.resample(10)
    assert down.n_frames == 11
    np.testing.assert_array_equal(down.rotations, m.rotations[::3])
    odd = m.resample(24)  # 1 s at 24 fps: 25 frames, last frame at t = 1 s
    assert odd.n_frames == 25
    np.testing.assert_allclose(odd.positions[-1], m.positions[-1], atol=1e-12)


# ------------------------------------------------------------------ retiming
def _constant_velocity_motion(T=121, fps=120.0):
    """Root moves at (1.5, 0, -0.5) m/s; joint 3 spins about y at 2 rad/s; others still."""
    sk = make_skeleton()
    t = np.arange(T) / fps
    root = np.column_stack([1.5 * t, np.full(T, 0.9), -0.5 * t])
    rot = _ident(T)
    rot[:, 3] = Rotation.from_rotvec(np.outer(2.0 * t, [0, 1, 0])).as_quat()
    return Motion(sk, fps, root, rot)


@pytest.mark.parametrize("speed,frames", [(2.0, 61), (0.5, 241), (1.0, 121), (1.5, 81)])
def test_retime_scales_velocity_and_duration(speed, frames):
    m = _constant_velocity_motion()
    r = m.retime(speed)
    assert r.fps == m.fps and r.n_frames == frames
    assert r.duration == pytest.approx(m.duration / speed, abs=1e-12)
    v = np.diff(r.root_positions, axis=0) * r.fps
    np.testing.assert_allclose(v, np.broadcast_to(speed * np.array([1.5, 0, -0.5]), v.shape), atol=1e-9)
    ang = Rotation.from_quat(r.rotations[:, 3]).as_rotvec()[:, 1]
    np.testing.assert_allclose(ang, 2.0 * speed * r.times, atol=1e-9)
    np.testing.assert_allclose(r.positions[-1], m.positions[-1], atol=1e-9)  # same end pose


def test_retime_other_fps_and_errors():
    m = _constant_velocity_motion()
    r = m.retime(2.0, fps=60)
    assert r.fps == 60 and r.n_frames == 31 and r.duration == pytest.approx(0.5)
    for bad in (0, -1, np.nan, np.inf):
        with pytest.raises(ValueError, match="retiming speed"):
            m.retime(bad)


def test_with_fps_relabels_and_notes():
    m = make_motion(T=20, fps=120)
    h = m.with_fps(60)
    assert h.fps == 60 and h.duration == pytest.approx(2 * m.duration)
    np.testing.assert_array_equal(h.rotations, m.rotations)
    assert "fps set to 60" in h.source.notes[-1]


# ------------------------------------------------------------- concatenation
def test_concatenate():
    m = make_motion(T=20)
    c = concatenate([m[:8], m[8:15], m[15:]])
    np.testing.assert_array_equal(c.rotations, m.rotations)
    np.testing.assert_allclose(c.positions, m.positions, atol=1e-15)
    assert concatenate([m]).n_frames == 20


def test_concatenate_errors():
    m = make_motion(T=20)
    with pytest.raises(ValueError, match="at least one motion"):
        concatenate([])
    with pytest.raises(MotionFormatError, match="motion 1 has a different skeleton"):
        concatenate([m, make_motion(T=5, sk=make_skeleton(asymmetric=True))])
    with pytest.raises(MotionFormatError, match="motion 2 runs at 60 fps, motion 0 at 30 fps"):
        concatenate([m, m, m.with_fps(60)])


# ------------------------------------------------------------------ mirroring
@pytest.mark.parametrize("ends", ["all", "head", "left_only"])
@pytest.mark.parametrize("asymmetric", [False, True])
@pytest.mark.parametrize("axis", [0, 2])
def test_mirrored_is_reflection_with_swapped_labels(ends, asymmetric, axis):
    m = make_motion(T=25, seed=7, sk=make_skeleton(asymmetric=asymmetric, ends=ends))
    mm = m.mirrored(axis=axis)
    S = np.ones(3)
    S[axis] = -1
    mp = m.skeleton.mirror_map()
    assert [m.skeleton.names[k] for k in mp[3:9]] == ["RightUpLeg", "RightLeg", "RightFoot", "LeftUpLeg",
                                                      "LeftLeg", "LeftFoot"]
    np.testing.assert_allclose(mm.positions, m.positions[:, mp] * S, atol=1e-12)
    # end sites: each named end site lands on the reflection of its counterpart
    E, Em = m.end_site_positions(), mm.end_site_positions()
    names = [e.name for e in m.skeleton.end_sites]
    assert [e.name for e in mm.skeleton.end_sites] == names
    for k, n in enumerate(names):
        partner = n.replace("Left", "Right") if "Left" in n else n.replace("Right", "Left")
        k2 = names.index(partner) if partner in names else k
        np.testing.assert_allclose(Em[:, k], E[:, k2] * S, atol=1e-12)
    if axis == 0:  # the skeleton is left/right symmetric about x unless made asymmetric
        assert (mm.skeleton == m.skeleton) != asymmetric


@pytest.mark.parametrize("asymmetric", [False, True])
def test_mirrored_twice_is_identity(asymmetric):
    m = make_motion(T=25, seed=8, sk=make_skeleton(asymmetric=asymmetric, ends="left_only"))
    mm = m.mirrored().mirrored()
    assert mm.skeleton == m.skeleton
    assert [(e.parent, e.name) for e in mm.skeleton.end_sites] == [(e.parent, e.name) for e in m.skeleton.end_sites]
    np.testing.assert_allclose([e.offset for e in mm.skeleton.end_sites], [e.offset for e in m.skeleton.end_sites])
    np.testing.assert_array_equal(mm.rotations, m.rotations)
    np.testing.assert_array_equal(mm.root_positions, m.root_positions)
    np.testing.assert_allclose(mm.end_site_positions(), m.end_site_positions(), atol=1e-12)


def test_mirrored_turn_direction_flips():
    """A root yaw to the left becomes a yaw to the right."""
    m = _constant_velocity_motion().replace(
        rotations=np.broadcast_to(Rotation.from_euler("y", 30, degrees=True).as_quat(), (121, 13, 4)))
    yaw = Rotation.from_quat(m.mirrored().rotations[:, 0]).as_euler("YXZ", degrees=True)[:, 0]
    np.testing.assert_allclose(yaw, -30.0, atol=1e-12)


# ---------------------------------------------------------------- rigid moves
def test_translated_and_rotated():
    m = make_motion(T=15, seed=9)
    d = np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(m.translated(d).positions, m.positions + d, atol=1e-14)
    np.testing.assert_allclose(m.translated(d).end_site_positions(), m.end_site_positions() + d, atol=1e-14)
    R = Rotation.from_euler("xyz", [20, -70, 35], degrees=True)
    c = np.array([0.3, 0.0, -1.2])
    r = m.rotated(R.as_quat(), center=c)
    P = np.array(m.positions).reshape(-1, 3)  # writable copy: scipy's apply rejects read-only arrays
    np.testing.assert_allclose(r.positions.reshape(-1, 3), c + R.apply(P - c), atol=1e-13)
    for j in range(m.skeleton.n_joints):
        ref = (R * Rotation.from_quat(m.global_rotations[:, j])).as_quat()
        assert same_rotation(r.global_rotations[:, j], ref)
    # per-frame rotations about the origin
    Rs = Rotation.from_rotvec(np.outer(np.linspace(0, 3, 15), [0, 1, 0]))
    r2 = m.rotated(Rs.as_quat())
    for t in (0, 7, 14):
        np.testing.assert_allclose(r2.positions[t], Rs[t].apply(np.array(m.positions[t])), atol=1e-13)
    # inputs untouched, distances between joints kept
    np.testing.assert_allclose(np.linalg.norm(r.positions[:, 5] - r.positions[:, 10], axis=-1),
                               np.linalg.norm(m.positions[:, 5] - m.positions[:, 10], axis=-1), atol=1e-13)


def test_replace_and_continuous():
    m = make_motion(T=20, seed=10)
    _ = m.positions
    moved = m.replace(root_positions=m.root_positions + 1.0)
    np.testing.assert_allclose(moved.positions, m.positions + 1.0, atol=1e-14)  # cache not shared
    signs = np.where(np.random.default_rng(1).uniform(size=(20, 13)) < 0.5, -1.0, 1.0)
    flipped = m.replace(rotations=m.rotations * signs[..., None])
    c = flipped.continuous()
    assert np.all(np.sum(c.rotations[1:] * c.rotations[:-1], axis=-1) > 0)
    np.testing.assert_allclose(c.positions, m.positions, atol=1e-13)


@pytest.mark.parametrize("name", ["01_01", "131_03", "sfu_0005_JumpRope001", "bandai2_walk_normal_001",
                                  "deepmimic_backflip", "mass_backflip", "01_01.amc"])
def test_mirrored_real_skeletons(name, real_data_dir):
    """Real rigs: left/right pairs are found, the pairing respects the tree, and mirroring is exact."""
    import warnings

    from mocomp import datasets

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name)[:150]
    mp = m.skeleton.mirror_map()
    par = m.skeleton.parents
    np.testing.assert_array_equal(mp[mp], np.arange(len(mp)))
    assert all(par[mp[j]] == mp[par[j]] for j in range(1, len(mp)))
    assert (mp != np.arange(len(mp))).sum() >= 8  # at least the two arms and legs pair up
    mm = m.mirrored()
    np.testing.assert_allclose(mm.positions, m.positions[:, mp] * [-1, 1, 1], atol=1e-12)
    np.testing.assert_allclose(mm.mirrored().positions, m.positions, atol=1e-12)


def test_replace_trusted_keeps_skeleton_and_takes_a_derived_fk():
    """``Motion.replace_trusted``: the arrays as given (frozen), the source kept by default, and an
    ``fk`` given by the caller is what ``fk()`` returns; a wrong FK shape is refused."""
    from mocomp import datasets

    m = datasets.load_example("jump").motion
    rp = np.array(m.root_positions) + np.array([0.5, 0.0, 0.0])
    rot = np.array(m.rotations)
    P, G = m.fk()
    P2, G2 = P + np.array([0.5, 0.0, 0.0]), np.array(G)
    out = m.replace_trusted(rp, rot, fk=(P2, G2))
    assert out.source == m.source and out.skeleton is m.skeleton
    assert not out.root_positions.flags.writeable and not P2.flags.writeable
    assert out.fk()[0] is P2
    fresh = out.replace()
    np.testing.assert_allclose(fresh.fk()[0], P2, atol=1e-12)       # the derived FK is the true one
    with pytest.raises(ValueError, match="fk shapes"):
        m.replace_trusted(rp, rot, fk=(P2[:, :-1], G2))
