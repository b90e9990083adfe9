"""The kinematics kernel's two backends: the numpy reference (mocomp.core.rotations,
forward_kinematics_numpy) against scipy, the compiled inline helpers (mocomp.core._compiled)
against the numpy reference, Motion.fk(frames=...), and the MOCOMP_NO_NUMBA switch."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from mocomp import Motion, Skeleton
from mocomp.core import _compiled
from mocomp.core.kinematics import forward_kinematics, forward_kinematics_numpy
from mocomp.core.rotations import (quat_apply, quat_exp, quat_inverse, quat_log, quat_matrix, quat_multiply,
                                   quat_pow, slerp)

needs_numba = pytest.mark.skipif(not _compiled.AVAILABLE, reason="numba disabled or missing")


def _random_quats(rng, n):
    return Rotation.random(n, random_state=rng).as_quat() * rng.choice([-1.0, 1.0], size=(n, 1))


def _random_clip(rng, T=40, J=12):
    parents = np.array([-1] + [int(rng.integers(0, j)) for j in range(1, J)])
    offsets = rng.normal(size=(J, 3)) * 0.2
    rot = _random_quats(rng, T * J).reshape(T, J, 4)
    root = rng.normal(size=(T, 3))
    return parents, offsets, root, rot


# ------------------------------------------------------------------ numpy reference vs scipy
def test_reference_log_exp_pow_matrix_agree_with_scipy():
    rng = np.random.default_rng(1)
    q = _random_quats(rng, 500)
    R = Rotation.from_quat(q)
    np.testing.assert_allclose(quat_log(q), R.as_rotvec(), atol=1e-12)
    rv = rng.normal(size=(500, 3)) * 1.5
    e = quat_exp(rv)
    d = np.abs(np.sum(e * Rotation.from_rotvec(rv).as_quat(), axis=-1))
    np.testing.assert_allclose(d, 1.0, atol=1e-12)
    np.testing.assert_allclose(quat_matrix(q), R.as_matrix(), atol=1e-12)
    t = rng.uniform(0, 1, size=500)
    p = quat_pow(q, t)
    expect = Rotation.from_rotvec(R.as_rotvec() * t[:, None]).as_quat()
    np.testing.assert_allclose(np.abs(np.sum(p * expect, axis=-1)), 1.0, atol=1e-12)
    # tiny rotations: the series branches
    small = quat_exp(np.array([[1e-14, 0.0, 0.0]]))
    np.testing.assert_allclose(small, [[5e-15, 0.0, 0.0, 1.0]], atol=1e-20)
    np.testing.assert_allclose(quat_log(small), [[1e-14, 0.0, 0.0]], atol=1e-22)


def test_reference_product_apply_and_slerp_agree_with_scipy():
    rng = np.random.default_rng(2)
    a, b = _random_quats(rng, 300), _random_quats(rng, 300)
    ab = quat_multiply(a, b)
    ref = (Rotation.from_quat(a) * Rotation.from_quat(b)).as_quat()
    np.testing.assert_allclose(np.abs(np.sum(ab * ref, axis=-1)), 1.0, atol=1e-12)
    v = rng.normal(size=(300, 3))
    np.testing.assert_allclose(quat_apply(a, v), Rotation.from_quat(a).apply(v), atol=1e-12)
    np.testing.assert_allclose(quat_apply(quat_inverse(a), v), Rotation.from_quat(a).inv().apply(v), atol=1e-12)
    t = rng.uniform(size=300)
    s = slerp(a, b, t)
    expect = np.array([Slerp([0, 1], Rotation.from_quat([a[i], b[i]]))([t[i]]).as_quat()[0] for i in range(300)])
    np.testing.assert_allclose(np.abs(np.sum(s * expect, axis=-1)), 1.0, atol=1e-12)
    # the nlerp shortcut for close pairs stays within theta^3 / 12 of slerp
    c = quat_multiply(a, quat_exp(rng.normal(size=(300, 3)) * 0.05))
    fast = slerp(a, c, t, nlerp_below=0.1)
    exact = slerp(a, c, t)
    ang = 2 * np.arctan2(np.linalg.norm(quat_multiply(fast, quat_inverse(exact))[:, :3], axis=1),
                         np.abs(quat_multiply(fast, quat_inverse(exact))[:, 3]))
    theta = np.arccos(np.minimum(np.abs(np.sum(a * c, axis=-1)), 1.0))
    assert np.all(ang <= theta ** 3 / 12 + 1e-15)
    assert ang.max() > 0                                       # the shortcut was taken


def test_numpy_fk_matches_scipy_per_joint_loop():
    rng = np.random.default_rng(3)
    parents, offsets, root, rot = _random_clip(rng)
    P, G = forward_kinematics_numpy(parents, offsets, root, rot)
    for j in range(1, len(parents)):
        p = parents[j]
        Rp = Rotation.from_quat(G[:, p])
        np.testing.assert_allclose(P[:, j], P[:, p] + Rp.apply(offsets[j]), atol=1e-12)
        np.testing.assert_allclose(Rotation.from_quat(G[:, j]).as_matrix(),
                                   (Rp * Rotation.from_quat(rot[:, j])).as_matrix(), atol=1e-12)


# ------------------------------------------------------------------ compiled vs numpy
@needs_numba
def test_compiled_fk_is_bit_identical_to_numpy_reference():
    rng = np.random.default_rng(4)
    parents, offsets, root, rot = _random_clip(rng, T=57, J=31)
    P0, G0 = forward_kinematics_numpy(parents, offsets, root, rot)
    P1, G1 = forward_kinematics(parents, offsets, root, rot)
    np.testing.assert_array_equal(P1, P0)
    np.testing.assert_array_equal(G1, G0)


@needs_numba
def test_inline_helpers_match_numpy_reference():
    njit = _compiled.njit

    @njit
    def run(a, b, v, t, rv, out):
        for i in range(a.shape[0]):
            x = _compiled.qmul(a[i, 0], a[i, 1], a[i, 2], a[i, 3], b[i, 0], b[i, 1], b[i, 2], b[i, 3])
            out[i, 0:4] = x
            r = _compiled.qrot(a[i, 0], a[i, 1], a[i, 2], a[i, 3], v[i, 0], v[i, 1], v[i, 2])
            out[i, 4:7] = r
            lg = _compiled.qlog(a[i, 0], a[i, 1], a[i, 2], a[i, 3])
            out[i, 7:10] = lg
            ex = _compiled.qexp(rv[i, 0], rv[i, 1], rv[i, 2])
            out[i, 10:14] = ex
            pw = _compiled.qpow(a[i, 0], a[i, 1], a[i, 2], a[i, 3], t[i])
            out[i, 14:18] = pw
            s = _compiled.slerp4(a[i, 0], a[i, 1], a[i, 2], a[i, 3], b[i, 0], b[i, 1], b[i, 2], b[i, 3], t[i], 2.0)
            out[i, 18:22] = s[:4]
            R = np.empty((3, 3))
            _compiled.qmat(a[i, 0], a[i, 1], a[i, 2], a[i, 3], R)
            for k in range(9):
                out[i, 22 + k] = R[k // 3, k % 3]
        return out

    rng = np.random.default_rng(5)
    n = 400
    a, b = _random_quats(rng, n), _random_quats(rng, n)
    v, rv, t = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.uniform(size=n)
    out = run(a, b, v, t, rv, np.empty((n, 31)))
    np.testing.assert_array_equal(out[:, 0:4], quat_multiply(a, b))
    np.testing.assert_array_equal(out[:, 4:7], quat_apply(a, v))
    np.testing.assert_allclose(out[:, 7:10], quat_log(a), rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[:, 10:14], quat_exp(rv), rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[:, 14:18], quat_pow(a, t), rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[:, 18:22], slerp(a, b, t), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(out[:, 22:].reshape(n, 3, 3), quat_matrix(a))


# ------------------------------------------------------------------ Motion.fk(frames=...)
def _motion(rng, T=30):
    parents, offsets, root, rot = _random_clip(rng, T=T, J=6)
    sk = Skeleton(tuple(f"j{i}" for i in range(6)), parents, offsets)
    return Motion(sk, 30.0, root, rot)


def test_motion_fk_frames_equals_rows_of_whole_and_caches_only_whole():
    rng = np.random.default_rng(6)
    m = _motion(rng)
    P, G = m.fk(frames=slice(5, 12))
    assert "fk" not in m._cache and P.shape == (7, 6, 3)
    Pw, Gw = _motion(np.random.default_rng(6)).fk()
    np.testing.assert_array_equal(P, Pw[5:12])
    np.testing.assert_array_equal(G, Gw[5:12])
    Pa, _ = m.fk(frames=slice(0, None))                 # the whole clip: cached
    assert "fk" in m._cache and not Pa.flags.writeable
    Pb, _ = m.fk(frames=slice(-3, None))                # then served from the cache
    assert np.shares_memory(Pb, m._cache["fk"][0])
    with pytest.raises(ValueError, match="step 1"):
        m.fk(frames=slice(0, 10, 2))
    with pytest.raises(TypeError, match="slice"):
        m.fk(frames=[1, 2])


# ------------------------------------------------------------------ MOCOMP_NO_NUMBA
def test_no_numba_switch_selects_numpy_and_gives_the_same_fk():
    code = ("import sys, numpy as np\n"
            "from mocomp.core import _compiled\n"
            "from mocomp.datasets import load_example\n"
            "assert not _compiled.AVAILABLE and _compiled.DISABLED\n"
            "m = load_example('backflip').motion\n"
            "np.save(sys.argv[1], m.positions)\n"
            "assert 'numba' not in sys.modules, 'numba imported'\n")
    out = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"fk_nonumba_{os.getpid()}.npy")
    env = dict(os.environ, MOCOMP_NO_NUMBA="1")
    r = subprocess.run([sys.executable, "-c", code, out], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    from mocomp.datasets import load_example

    try:
        np.testing.assert_array_equal(np.load(out), load_example("backflip").motion.positions)
    finally:
        os.remove(out)
