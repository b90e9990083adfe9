"""The run-time stage's compiled kernels agree with their numpy oracles, which are built from the
core kernel (mocomp.core.rotations); the landing-seam oracle lives here (it has no run-time use)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core.rotations import quat_angle, quat_apply, quat_inverse, quat_multiply, quat_pow, slerp


def ang(a, b):
    return quat_angle(quat_multiply(a, quat_inverse(b)))


def slerp_rows(q0, q1, t):
    """The run-time stage's numpy retiming interpolation: one weight per row, nlerp below 0.1 rad."""
    return slerp(q0, q1, np.asarray(t)[:, None], nlerp_below=0.1)


def _landing_seam_numpy(P, rot: np.ndarray, src: np.ndarray, a: int, g: int, la: int, rb: int,
                        w: int) -> None:
    """The oracle of the compiled landing seam (moved here from mocomp.flips.multiflip): the seam
    f -> g+1 in place on ``rot`` in numpy, half the mismatch on each side with the raised-cosine
    ramp (section 5.4.2.2), the root's part perpendicular to L only (eq. 5.14)."""
    from mocomp.flips.smoothing import compose_root, ramp, shortest_arc

    blk = rot[la:rb]
    idx = np.arange(la, rb)
    left = idx <= a
    wts = ramp(np.abs(idx - a), w)
    ql, qr = rot[a], P.rotations[g]
    sgn = np.where(np.einsum("ji,ji->j", ql, qr) < 0.0, -1.0, 1.0)[:, None]
    mid = ql + sgn * qr
    mid /= np.linalg.norm(mid, axis=-1, keepdims=True)       # slerp at 1/2
    off_l, off_r = quat_multiply(quat_inverse(ql), mid), quat_multiply(quat_inverse(qr), mid)
    bl, br = quat_apply(quat_inverse(rot[a, 0]), P.axis), P.bdir[g]
    bm = bl + br
    bm /= np.linalg.norm(bm)
    arc_l, arc_r = shortest_arc(bl, bm), shortest_arc(br, bm)
    offs = np.where(left[:, None, None], off_l[None], off_r[None])
    blk[:, 1:] = quat_multiply(blk[:, 1:], quat_pow(offs[:, 1:], wts[:, None]))
    bb = quat_apply(quat_inverse(blk[:, 0]), P.axis)
    arcs = np.where(left[:, None], arc_l[None], arc_r[None])
    blk[:, 0] = compose_root(P.theta[src[la:rb]], quat_apply(quat_pow(arcs, wts), bb), P.axis, P.root_ref)


def test_quat_pow_is_slerp_from_identity():
    a = Rotation.random(200, random_state=1).as_quat().reshape(20, 10, 4)
    w = np.random.default_rng(1).uniform(0, 1, (20, 10))
    ident = np.zeros_like(a)
    ident[..., 3] = 1.0
    assert ang(quat_pow(a, w), slerp(ident, a, w)).max() < 1e-10
    # tiny rotations: the power of (almost) the identity
    tiny = np.array([[1e-14, 0, 0, 1.0]])
    assert np.allclose(quat_pow(tiny, np.array([0.5])), [[5e-15, 0, 0, 1.0]])


def test_slerp_rows_is_slerp_within_1e_4_rad():
    rng = np.random.default_rng(3)
    q0 = Rotation.random(300 * 8, random_state=4).as_quat().reshape(300, 8, 4)
    for scale in (0.02, 0.1, 0.6, 2.0):                     # near pairs (nlerp) and far pairs (slerp)
        d = Rotation.from_rotvec(rng.normal(scale=scale, size=(2400, 3))).as_quat().reshape(300, 8, 4)
        q1 = quat_multiply(q0, d)
        q1[::4] *= -1.0                                      # other hemisphere: the short way
        t = rng.uniform(0, 1, 300)
        ref = slerp(q0, q1, np.broadcast_to(t[:, None], (300, 8)))
        out = slerp_rows(q0, q1, t)
        assert ang(out, ref).max() < 1e-4
        np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-12)
    # the end points are exact
    np.testing.assert_allclose(ang(slerp_rows(q0, q1, np.zeros(300)), q0), 0, atol=1e-7)
    np.testing.assert_allclose(ang(slerp_rows(q0, q1, np.ones(300)), q1), 0, atol=1e-7)


def test_compiled_kernels_match_numpy():
    from mocomp.flips import _kernels
    from mocomp.flips.preprocess import prepare

    if not _kernels.AVAILABLE:
        import pytest
        pytest.skip("numba not available")
    rng = np.random.default_rng(7)
    q0 = Rotation.random(120 * 9, random_state=5).as_quat().reshape(120, 9, 4)
    for scale in (0.05, 1.0):
        d = Rotation.from_rotvec(rng.normal(scale=scale, size=(1080, 3))).as_quat().reshape(120, 9, 4)
        q1 = quat_multiply(q0, d)
        q1[::3] *= -1
        t = rng.uniform(0, 1, 120)
        np.testing.assert_allclose(_kernels.slerp_rows_nb(q0, q1, t), slerp_rows(q0, q1, t), atol=1e-12)
    from _flips_data import synthetic

    P = prepare(synthetic("backflip").motion)
    rot = P.rotations[100:180]
    np.testing.assert_allclose(P.com_eval.relative(rot), P.com_eval.relative_numpy(rot), atol=1e-13)


def test_multiflip_same_with_and_without_compiled_kernels(monkeypatch):
    import sys

    from mocomp.flips import _kernels, multiflip, prepare

    if not _kernels.AVAILABLE:
        import pytest
        pytest.skip("numba not available")
    from _flips_data import synthetic

    P = prepare(synthetic("sideflip").motion)
    fast = multiflip(P, flips=3, evaluate=False)
    mod = sys.modules["mocomp.flips.multiflip"]
    monkeypatch.setattr(mod, "KERNELS", False)
    monkeypatch.setattr(_kernels, "AVAILABLE", False)
    slow = multiflip(P, flips=3, evaluate=False)
    assert ang(fast.motion.rotations, slow.motion.rotations).max() < 1e-9
    np.testing.assert_allclose(fast.motion.root_positions, slow.motion.root_positions, atol=1e-9)


def test_compiled_frame_distance_matches_numpy():
    """The landing search's compiled eq. 5.12-5.13 equals :func:`frame_distance` (random pairs,
    including opposite quaternion signs)."""
    from mocomp.flips import prepare
    from mocomp.flips._kernels import AVAILABLE, frame_distance_nb
    from mocomp.flips.similarity import frame_distance

    from _flips_data import synthetic

    if not AVAILABLE:
        pytest.skip("numba not importable")
    P = prepare(synthetic("sideflip").motion)
    rng = np.random.default_rng(0)
    i, j = rng.integers(0, P.motion.n_frames, (2, 300))
    r2 = np.array(P.rotations[j])
    r2[::3] *= -1.0
    D1, p1 = frame_distance(P.rotations[i], r2, P.axis, P.weights)
    D2, p2 = frame_distance_nb(P.rotations[i], r2, P.axis, P.weights)
    np.testing.assert_allclose(D2, D1, atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (p2 - p1))), 0.0, atol=1e-12)
    assert D1.max() > 0.5                       # the pairs are not trivially similar


def test_gathered_slerp_and_fresh_motion_equal_the_checked_path():
    """The retiming slerp reading rows in place equals the gathered one bit for bit and reports
    non-finite results; the run-time stage's unchecked ``Motion`` equals ``Motion.replace``."""
    from mocomp.flips import _kernels, multiflip, prepare
    from mocomp.flips.multiflip import _fresh_motion

    if not _kernels.AVAILABLE:
        pytest.skip("numba not available")
    from _flips_data import synthetic

    P = prepare(synthetic("backflip").motion)
    rot = np.array(P.rotations)
    rng = np.random.default_rng(11)
    i0 = rng.integers(0, rot.shape[0] - 1, 150)
    a = rng.uniform(0, 1, 150)
    out, ok = _kernels.slerp_gather_nb(rot, i0, a)
    assert ok
    np.testing.assert_array_equal(out, _kernels.slerp_rows_nb(rot[i0], rot[i0 + 1], a))
    bad = rot.copy()
    bad[i0[3] + 1, 5] = np.nan
    assert not _kernels.slerp_gather_nb(bad, i0, a)[1]
    with pytest.raises(IndexError):
        _kernels.slerp_gather_nb(rot, np.array([rot.shape[0] - 1]), np.zeros(1))
    res = multiflip(P, flips=2, evaluate=False)
    m = res.motion
    ref = P.motion.replace(root_positions=m.root_positions, rotations=m.rotations, source=m.source)
    np.testing.assert_array_equal(ref.rotations, m.rotations)
    np.testing.assert_array_equal(ref.root_positions, m.root_positions)
    assert m.skeleton is P.motion.skeleton and m.fps == P.motion.fps and m._cache == {}
    assert not m.rotations.flags.writeable and not m.root_positions.flags.writeable
    assert m.positions.shape == (m.n_frames, P.motion.skeleton.n_joints, 3)
    assert "fk" not in P.motion._cache or P.motion._cache["fk"][0].shape[0] == P.motion.n_frames
    fresh = _fresh_motion(P.motion, np.zeros((4, 3)), np.array(rot[:4]), m.source)
    assert fresh.n_frames == 4 and fresh.skeleton is P.motion.skeleton


def test_compiled_landing_search_is_the_array_search():
    """The compiled landing search picks the same pair, with the same mismatch and pair count
    and the same distance (to an ulp), as the candidate-array version (every synthetic flip, 2-4 flips, odd extras)."""
    from mocomp.flips import _kernels, prepare
    from mocomp.flips.sequence import find_landing, loop_count

    if not _kernels.AVAILABLE:
        pytest.skip("numba not available")
    from _flips_data import synthetic

    for name in ("backflip", "frontflip", "sideflip"):
        P = prepare(synthetic(name).motion)
        for extra in (2 * np.pi, 4 * np.pi, 6 * np.pi, 2.6 * np.pi):
            target = P.total_rotation + extra
            copies = loop_count(target, P.theta[P.loop.m] - P.theta[0], P.theta[-1] - P.theta[P.loop.n], P.loop.phi) + 1
            args = (P.rotations, P.theta, P.flight, P.loop, extra, copies, P.axis, P.weights)
            fast = find_landing(*args)
            try:
                _kernels.AVAILABLE = False
                slow = find_landing(*args)
            finally:
                _kernels.AVAILABLE = True
            assert (fast.u, fast.f, fast.copy, fast.g, fast.delta, fast.n_pairs) == \
                (slow.u, slow.f, slow.copy, slow.g, slow.delta, slow.n_pairs), (name, extra)
            assert abs(fast.distance - slow.distance) <= 1e-12          # scalar vs vectorised atan2: an ulp
            assert fast.n_pairs > 1


def test_compiled_landing_seam_and_root_turn_match_numpy():
    """The compiled landing-seam smoothing and the turn of every root about L equal the numpy
    versions to rounding, on the sequences of a double and a triple flip (joined 4 frames off, so
    the synthetic clips' near-perfect joins do not make the correction vanish)."""
    from mocomp.flips import _kernels, multiflip, prepare
    from mocomp.flips.similarity import axis_quat

    if not _kernels.AVAILABLE:
        pytest.skip("numba not available")
    from _flips_data import synthetic

    for name, flips in (("backflip", 2), ("sideflip", 3)):
        P = prepare(synthetic(name).motion)
        seq = multiflip(P, flips=flips, evaluate=False).sequence
        src, w = seq.frames, P.default_window()
        a, g = seq.landing_seam, seq.join.g + 4       # a deliberately poor join: a visible seam correction
        la, rb = max(a - w, 0), min(a + 2 + w, src.size)
        fast, slow = np.array(P.rotations[src]), np.array(P.rotations[src])
        assert _kernels.landing_seam_nb(fast, a, la, rb, w, P.rotations[g], P.bdir[g], P.axis, P.theta, src,
                                        P.root_ref)
        _landing_seam_numpy(P, slow, src, a, g, la, rb, w)
        assert np.abs(fast - slow).max() < 1e-13
        assert np.abs(fast[la:rb] - P.rotations[src[la:rb]]).max() > 1e-3       # the seam did change them
        np.testing.assert_array_equal(fast[:la], slow[:la])
        turned = _kernels.turn_roots_nb(fast.copy(), seq.extra, P.axis)
        ref = quat_multiply(axis_quat(P.axis, seq.extra), fast[:, 0])
        assert np.abs(turned[:, 0] - ref).max() < 1e-14
        np.testing.assert_array_equal(turned[:, 1:], fast[:, 1:])


def test_compiled_landing_seam_speeds_match_numpy(monkeypatch):
    """The compiled eq. 5.22 landing-seam speeds equal the numpy ones to rounding (and differ from 1,
    so the comparison is not vacuous)."""
    import sys

    from mocomp.flips import _kernels, multiflip, prepare

    if not _kernels.AVAILABLE:
        pytest.skip("numba not available")
    from _flips_data import synthetic

    mod = sys.modules["mocomp.flips.multiflip"]
    for name, flips in (("frontflip", 2), ("sideflip", 3)):
        P = prepare(synthetic(name).motion)
        res = multiflip(P, flips=flips, evaluate=False, window=P.default_window() + 1)
        seq, w = res.sequence, P.default_window() + 1
        rot = np.array(P.rotations[seq.frames])
        rot[:, 0] = np.array(res.motion.rotations[0, 0])            # any poses: a seam with real momentum change
        rot[seq.landing_seam - 1:seq.landing_seam + 3] = P.rotations[seq.join.g + 3]
        a = seq.landing_seam
        la, rb = max(a - w, 0), min(a + 2 + w, seq.n_frames)
        fast = mod._seam_speeds(P, seq, rot, w, a + 1, la, rb)
        monkeypatch.setattr(mod, "KERNELS", False)
        slow = mod._seam_speeds(P, seq, rot, w, a + 1, la, rb)
        monkeypatch.setattr(mod, "KERNELS", True)
        assert np.abs(fast - slow).max() < 1e-12
        assert np.abs(fast[la - 1:rb + 1] - 1.0).max() > 1e-3
