"""Fast paths of the momentum restoration (issue 5 speed goal) against the code they replace.

Each compiled or vectorised path is pinned to a reference: the library's own numpy forward
kinematics, and below, verbatim copies of the upright recovery (:func:`mocomp.edit.seams.
recover_upright`) and foot planting as they were before they were sped up (whole-motion FK
through :class:`~mocomp.core.Motion`, a per-frame loop for the held root shift). The results
must agree to rounding (1e-12), on the arms-twist back flip whose landing the corrections tilt.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from mocomp.core.kinematics import forward_kinematics, forward_kinematics_numpy
from mocomp.core.motion import slerp
from mocomp.core.rotations import quat_apply, quat_multiply
from mocomp.edit import apply_preset, restore_momentum, seams
from mocomp.edit import smooth_direction as sd
from mocomp.ops.ik import descends, leg_chains, two_bone_ik
from mocomp.flips.reposition import ComEvaluator
from mocomp.synth.flights import backflip, sideflip


@functools.lru_cache(maxsize=None)
def case(name):
    r = backflip(jump_height=1.25) if name == "arms-twist" else sideflip(jump_height=1.25)
    ed, _ = apply_preset(r.motion, r.flight, "arms-twist" if name == "arms-twist" else "straight-legs")
    return r, ed


def _random_rotations(shape, seed):
    q = np.random.default_rng(seed).normal(size=shape + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_fk_is_bit_identical_to_numpy_fk(seed):
    m = backflip(jump_height=1.25).motion
    sk = m.skeleton
    rot = m.rotations if seed == 0 else _random_rotations(m.rotations.shape[:2], seed)
    rp = m.root_positions + np.random.default_rng(seed).normal(0, 0.3, m.root_positions.shape) * seed
    P0, G0 = forward_kinematics_numpy(sk.parents, sk.offsets, rp, rot)
    P1, G1 = forward_kinematics(sk.parents, sk.offsets, rp, rot)
    assert np.array_equal(P0, P1) and np.array_equal(G0, G1)
    # the identity pose puts each joint at its parent plus its offset (known answer)
    Pi, Gi = forward_kinematics(sk.parents, sk.offsets, np.zeros((1, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (1, sk.n_joints, 1)))
    for j in range(1, sk.n_joints):
        np.testing.assert_allclose(Pi[0, j], Pi[0, sk.parents[j]] + sk.offsets[j], atol=1e-15)
    assert np.array_equal(Gi[0], np.tile([0.0, 0.0, 0.0, 1.0], (sk.n_joints, 1)))


def test_motion_fk_ranges_and_cache():
    m = backflip(jump_height=1.25).motion.replace()
    P, G = m.fk(frames=slice(40, 90))                      # a range: computed alone, nothing cached
    assert "fk" not in m._cache
    Pr, Gr = m[40:90].fk()
    assert np.array_equal(P, Pr) and np.array_equal(G, Gr)
    Pa, Ga = m.fk(frames=slice(None))                      # the whole motion fills Motion's cache
    assert m._cache["fk"][0] is Pa and not Pa.flags.writeable
    P2, _ = m.fk(frames=slice(40, 90))                     # ranges now read the cache
    assert np.shares_memory(P2, Pa) and np.array_equal(P2, P)
    fresh = m.replace()
    assert np.array_equal(fresh.positions, Pa) and np.array_equal(fresh.global_rotations, Ga)


# ---------------------------------------------------------------- references (pre-speed-up code)
def _plant_feet_reference(motion, start, weights, chains, tol=1e-3):
    parents = motion.skeleton.parents
    for c1 in chains:
        for c2 in chains:
            if c1 is not c2 and descends(parents, c2[0], c1[0]):
                raise ValueError("overlap")
    rot = np.array(motion.rotations)
    P, G = motion.fk()
    solves = 0
    # the horizontal targets by ops.ik's rule (anchors held by the weight, continuous at release)
    from mocomp.ops.ik import plant_targets

    hor = plant_targets(P[start:, [c[2] for c in chains]][..., [0, 2]], np.asarray(weights))
    for c, chain in enumerate(chains):
        a = chain[2]
        tgt = np.array(P[start:, a])
        tgt[:, [0, 2]] = hor[:, c]
        idx = np.flatnonzero(np.linalg.norm(tgt - P[start:, a], axis=1) > tol)
        if idx.size:
            f = start + idx
            # ops.ik's soft reach (SOFT_REACH of the leg's length: the knee never snaps straight)
            from mocomp.ops.ik import SOFT_REACH

            full = (np.linalg.norm(P[f, chain[1]] - P[f, chain[0]], axis=1)
                    + np.linalg.norm(P[f, a] - P[f, chain[1]], axis=1))
            rot[f], _ = two_bone_ik(P[f], G[f], rot[f], parents, chain, tgt[idx], soft_reach=SOFT_REACH * full)
            solves += idx.size
    return motion.replace(rotations=rot), solves


def _recover_upright_reference(motion, first_ground, up_now, seconds, ce, contact=(0.05, 0.12), pivot=None):
    fix = seams.shortest_arc(np.asarray(up_now, dtype=float), np.array([0.0, 1.0, 0.0]))
    n = motion.n_frames - first_ground
    m = max(1, int(round(seconds * motion.fps)))
    s = np.clip(np.arange(1, n + 1) / m, 0.0, 1.0)
    s = s * s * (3 - 2 * s)
    ident = np.broadcast_to([0.0, 0.0, 0.0, 1.0], (n, 4))
    q = slerp(ident, np.broadcast_to(fix, (n, 4)), s)
    c = ce(motion.root_positions[first_ground:first_ground + 1], motion.rotations[first_ground:first_ground + 1])[0]
    if pivot is None:
        low = motion[first_ground:first_ground + 1].positions[0, :, 1].min()
        pivot = np.array([c[0], low, c[2]])
    rp = np.array(motion.root_positions)
    rot = np.array(motion.rotations)
    rp[first_ground:] = pivot + quat_apply(q, rp[first_ground:] - pivot)
    rot[first_ground:, 0] = quat_multiply(q, rot[first_ground:, 0])
    out = motion.replace(root_positions=rp, rotations=rot)
    feet = [j for j, nm in enumerate(motion.skeleton.names) if any(k in nm.lower() for k in ("toe", "foot", "ankle"))]
    after = out[first_ground:].positions[:, feet]
    w = seams._contact_weights(after[..., 1], contact)
    before = motion[first_ground:].positions[:, feet]
    err = before[..., [0, 2]] - after[..., [0, 2]]
    shift = np.zeros((n, 2))
    held = np.zeros(2)
    for i in range(n):
        ws = w[i].sum()
        if ws > 1e-9:
            cw = w[i].max()
            held = cw * (w[i] @ err[i]) / ws + (1.0 - cw) * held
        shift[i] = held
    # the root follows the held shift with bounded acceleration (causal raised-cosine, 0 before touchdown)
    L = int(round(seams.SHIFT_EASE_S * motion.fps))
    h = 1.0 - np.cos(2.0 * np.pi * np.arange(1, L + 1) / (L + 1))
    h /= h.sum()
    shift = np.stack([np.convolve(shift[:, k], h)[:n] for k in range(2)], axis=1)
    rp[first_ground:, 0] += shift[:, 0]
    rp[first_ground:, 2] += shift[:, 1]
    out = motion.replace(root_positions=rp, rotations=rot)
    chains = [ch for ch in leg_chains(motion.skeleton) if ch[2] in feet]
    wa = w[:, [feet.index(ch[2]) for ch in chains]]
    # held ankles let go no faster than over seams.RELEASE_S (d0375af; this reference had not followed it)
    from mocomp.edit.landing import _release_limited

    # ankles the motion moves along the floor are not held (seams._still_weights: known answer below)
    wa = wa * seams._still_weights(before[:, [feet.index(ch[2]) for ch in chains]][..., [0, 2]], motion.fps)
    rate = 1.0 / max(seams.RELEASE_S * motion.fps, 1.0)
    wa = np.stack([_release_limited(wa[:, i], rate) for i in range(wa.shape[1])], axis=1)
    out, solves = _plant_feet_reference(out, first_ground, wa, chains)
    assert solves > 0
    after = out[first_ground:].positions[:, feet]
    return out, seams.stance_slide(after, w)


@pytest.mark.parametrize("name", ["arms-twist", "side-straight-legs"])
def test_upright_recovery_equals_the_reference(name, monkeypatch):
    r, ed = case(name)
    seen = {}
    real = seams.recover_upright

    def spy(*args, **kw):
        seen["args"], seen["kw"] = args, kw
        seen["out"] = real(*args, **kw)
        return seen["out"]

    monkeypatch.setattr(seams, "recover_upright", spy)
    res = restore_momentum(r.body, r.motion, ed, r.flight, L_star=r.L0, stances="as-is")
    assert res.foot_slide is not None and res.landing_tilt_deg > 1.0     # the recovery ran
    motion, fg, up_now, secs, _ = seen["args"]
    pivot = seen["kw"]["pivot"]
    assert pivot[1] == pytest.approx(res.landing.floor, abs=1e-12)       # on the floor (issue 13)
    ref, slide_ref = _recover_upright_reference(motion.replace(), fg, up_now, secs, ComEvaluator(r.body),
                                                pivot=pivot)
    out, slide = seen["out"]
    np.testing.assert_allclose(out.root_positions, ref.root_positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.rotations, ref.rotations, rtol=0, atol=1e-12)
    assert abs(slide - slide_ref) < 1e-12
    # frames before touchdown are left alone, by the recovery and by the landing after it
    assert np.array_equal(res.motion.rotations[:fg], motion.rotations[:fg])
    assert np.array_equal(out.rotations[:fg], motion.rotations[:fg])


def test_held_shift_known_answer():
    # one foot, full contact at frames 0 and 2, none at frame 1, half contact at 3
    w = np.array([[1.0], [0.0], [1.0], [0.5]])
    err = np.array([[[1.0, 2.0]], [[9.0, 9.0]], [[3.0, -1.0]], [[5.0, 5.0]]])
    np.testing.assert_allclose(seams._held_shift(w, err),
                               [[1.0, 2.0], [1.0, 2.0], [3.0, -1.0], [4.0, 2.0]], atol=1e-15)


def test_still_weights_known_answer():
    # one ankle at 120 Hz: still, then 0.35 m/s (half-way through the band), then 1 m/s along x
    fps = 120.0
    v = np.r_[np.zeros(10), np.full(10, 0.35), np.full(10, 1.0)]
    x = np.cumsum(v) / fps
    xz = np.stack([x, np.zeros_like(x)], axis=-1)[:, None]
    w = seams._still_weights(xz, fps)[:, 0]
    assert np.all(w[:9] == 1.0) and np.all(w[21:] == 0.0)
    np.testing.assert_allclose(w[11:19], 0.5, atol=1e-12)                 # smoothstep(0.5) = 0.5
    assert seams._still_weights(xz[:1], fps).shape == (1, 1)


def test_ease_shift_spreads_a_step_with_bounded_speed_and_acceleration():
    # a 7 cm step of the target (a foot re-touching the floor) at frame 10, eased over L = 24 frames
    L, d = 24, 0.07
    target = np.zeros((60, 2))
    target[10:, 0] = d
    target[10:, 1] = -d / 2
    out = seams._ease_shift(target, L)
    assert np.all(out[:10] == 0.0)                                       # causal: nothing before the step
    np.testing.assert_allclose(out[10 + L - 1:], target[10 + L - 1:], atol=1e-15)   # reached after L-1 frames
    v = np.diff(out[:, 0])
    assert np.all(v >= -1e-15) and v.max() <= 2 * d / L * 1.01         # monotone, peak speed 2 d / L per frame
    assert np.abs(np.diff(v)).max() <= 2 * np.pi * d / L ** 2           # acceleration bound
    assert v.max() < d / 3                                                # the raw step moved d in one frame
    # a target that is already constant from before the first frame (0) stays 0; L <= 1 is the identity
    assert np.all(seams._ease_shift(np.zeros((5, 2)), L) == 0.0)
    np.testing.assert_array_equal(seams._ease_shift(target, 1), target)


# ------------------------------------------------- step 1's joint solve: band LU vs sparse LU
def _smooth_corrections_reference(m, I_local, X, Q, t, U, f0: int, init: np.ndarray, sigma: float = 1.5,
                       tol: float = 1e-7, max_iter: int = 20, w1: float = 1.0, w0: float = 0.0) -> sd.SmoothSolve:
    # verbatim pre-speed-up body (sparse KKT, splu)
    from scipy.ndimage import gaussian_filter1d

    from mocomp.edit._kernels import interior_momentum, momentum_blocks, rotate_frames

    n = X.shape[0]
    pivots = np.ascontiguousarray(np.einsum("s,tsk->tk", m, X) / m.sum())
    free = np.arange(f0 + 1, n)             # variables: frames f0+1 .. n-1
    cons = np.arange(f0, n - 1)             # constraints: L at frames f0 .. n-2
    nv, nc = free.size, cons.size
    Uc = U[cons]
    B = sd._basis(Uc)
    # the metric: second differences over frames f0-1 .. n-1 (phi = 0 on frames <= f0)
    D2 = sp.diags([np.ones(n), -2 * np.ones(n), np.ones(n)], [-1, 0, 1], shape=(n, n), format="csr")
    D = sp.kron(D2[np.arange(f0, n - 1)][:, free], sp.identity(3), format="csr")
    D1 = sp.diags([-np.ones(n), np.ones(n)], [0, 1], shape=(n, n), format="csr")
    D1 = sp.kron(D1[np.arange(f0, n - 1)][:, free], sp.identity(3), format="csr")
    DtD = (D.T @ D).tocsc()
    H = DtD + w1 * (D1.T @ D1).tocsc() + (w0 + 1e-10 * DtD.diagonal().max()) * sp.identity(3 * nv, format="csc")
    phi0 = sd.rotvecs_continuous(init)
    phi0[:f0 + 1] = 0.0
    phi = gaussian_filter1d(phi0, sigma, axis=0, mode="nearest") if sigma > 0 else phi0.copy()
    phi[:f0 + 1] = 0.0
    ref = phi[free].ravel().copy()
    # sparsity of the constraint Jacobian: L_f couples frames f-1, f, f+1
    off = np.repeat([-1, 0, 1], nc)
    rows = np.tile(np.arange(nc), 3)
    g = cons[rows] + off
    keep = g >= free[0]
    blk_r, blk_k, blk_g = rows[keep], off[keep] + 1, g[keep]
    ii = np.broadcast_to(2 * blk_r[:, None, None] + np.arange(2)[None, :, None], (blk_r.size, 2, 3)).ravel()
    jj = np.broadcast_to(3 * (blk_g - free[0])[:, None, None] + np.arange(3)[None, None, :],
                         (blk_r.size, 2, 3)).ravel()
    zeros = np.zeros(3 * nv)
    # KKT [[H, A^T], [A, 0]] assembled from fixed index arrays (only A's values change)
    H_coo = H.tocoo()
    K_rows = np.concatenate([H_coo.row, 3 * nv + ii, jj])
    K_cols = np.concatenate([H_coo.col, jj, 3 * nv + ii])
    evals = 0

    def state(ph):
        return rotate_frames(X, Q, pivots, np.ascontiguousarray(sd._exp(ph)))

    def errors(L):
        Lc = L[cons]
        return np.arctan2(np.linalg.norm(np.cross(Lc, Uc), axis=1), np.sum(Lc * Uc, axis=1))

    def residual(L):
        Lc = L[cons]
        return np.einsum("fij,fj->fi", B, Lc / np.linalg.norm(Lc, axis=1, keepdims=True)).ravel()

    Xc, Qc = state(phi)
    L = interior_momentum(m, I_local, Xc, Qc, t)
    evals += 1
    err = errors(L)
    it = 0
    while err.max() > tol and it < max_iter:
        it += 1
        L, Jm, J0, Jp = momentum_blocks(m, I_local, Xc, Qc, t, pivots)
        evals += 1
        Lc = L[cons]
        nL = np.linalg.norm(Lc, axis=1)
        lu = Lc / nL[:, None]
        G = np.einsum("fij,fjk->fik", B, (np.eye(3) - lu[:, :, None] * lu[:, None, :]) / nL[:, None, None])
        Jb = np.stack([Jm[cons], J0[cons], Jp[cons]])                 # (3, nc, 3, 3)
        vals = np.einsum("bij,bjk,bkl->bil", G[blk_r], Jb[blk_k, blk_r], sd._left_jacobian(phi[blk_g]))
        v = vals.ravel()
        K = sp.csc_matrix((np.concatenate([H_coo.data, v, v]), (K_rows, K_cols)), shape=(3 * nv + 2 * nc,) * 2)
        try:
            lu_K = splu(K)
        except RuntimeError:
            break
        x = phi[free].ravel()
        # Newton step onto the linearised constraints, smallest in the second-difference metric
        dx = lu_K.solve(np.concatenate([zeros, -residual(L)]))[:3 * nv]
        if not np.all(np.isfinite(dx)):
            break
        # backtrack on the summed direction error (angles: zero on the target only, not on its antipode)
        alpha, e0 = 1.0, float(err.sum())
        for _ in range(8):
            trial = phi.copy()
            trial[free] = (x + alpha * dx).reshape(nv, 3)
            Xt, Qt = state(trial)
            Lt = interior_momentum(m, I_local, Xt, Qt, t)
            evals += 1
            et = errors(Lt)
            if np.all(np.isfinite(et)) and et.sum() < e0:
                break
            alpha *= 0.5
        else:
            break
        phi, Xc, Qc, L, err = trial, Xt, Qt, Lt, et
    change = D @ (phi[free].ravel() - ref)
    return sd.SmoothSolve(corrections=sd._exp(phi), converged=bool(err.max() <= tol), iterations=it,
                       evaluations=evals, max_error=float(err.max()) if err.size else 0.0,
                       objective_start=float(np.sum((D @ phi0[free].ravel()) ** 2)),
                       objective_end=float(np.sum((D @ phi[free].ravel()) ** 2)),
                       projection=float(np.sqrt(change @ change)))


def _smooth_inputs(name, ease=None):
    """The arguments :func:`mocomp.edit.restore.correct_direction` gives the joint solve."""
    from mocomp.edit._kernels import direction_sweep
    from mocomp.edit.restore import segment_state

    r, ed = case(name)
    if ease is not None:
        ed = apply_preset(r.motion, r.flight, "straight-legs", ease=ease)[0]
    a, b = r.flight
    X, Q = segment_state(r.body, ed[a:b])
    t = np.ascontiguousarray(ed[a:b].times)
    m = np.ascontiguousarray(r.body.masses, dtype=float)
    I_loc = np.ascontiguousarray(r.body.inertias, dtype=float)
    U = np.tile(r.L0 / np.linalg.norm(r.L0), (b - a, 1))
    X0, Q0 = X.copy(), Q.copy()
    corr, _, first, _ = direction_sweep(m, I_loc, X, Q, t, U, 0, b - a, 1e-7, 20)
    return m, I_loc, X0, Q0, t, U, int(first), corr


@pytest.mark.parametrize("name,ease", [("side-straight-legs", None), ("side-straight-legs", 0.2),
                                       ("arms-twist", None)])
def test_band_kkt_solve_equals_the_sparse_lu_reference(name, ease):
    args = _smooth_inputs(name, ease)
    new = sd.smooth_corrections(*args)
    ref = _smooth_corrections_reference(*args)
    assert ref.iterations >= 2 and ref.converged            # a real multi-step projection
    assert new.iterations == ref.iterations and new.evaluations == ref.evaluations
    assert new.converged == ref.converged
    np.testing.assert_allclose(new.corrections, ref.corrections, rtol=0, atol=1e-12)
    for k in ("max_error", "objective_start", "objective_end", "projection"):
        assert abs(getattr(new, k) - getattr(ref, k)) <= 1e-12 * max(1.0, abs(getattr(ref, k))), k


@pytest.mark.parametrize("n,f0,w1,w0", [(12, 1, 1.0, 0.0), (40, 7, 0.3, 0.05), (9, 5, 2.0, 0.0)])
def test_kkt_band_layout_is_the_sparse_kkt_permuted(n, f0, w1, w0):
    """The band triplets rebuild, after un-permuting, exactly the sparse metric H of the
    reference; the permutation is a bijection and every nonzero lies inside the band."""
    perm, lo, up, hr, hc, hv, ii, jj, _ = sd._kkt_layout(n, f0, w1, w0)
    free = np.arange(f0 + 1, n)
    nv, nc = free.size, n - 1 - f0
    assert np.array_equal(np.sort(perm), np.arange(3 * nv + 2 * nc))
    D2 = sp.diags([np.ones(n), -2 * np.ones(n), np.ones(n)], [-1, 0, 1], shape=(n, n), format="csr")
    D = sp.kron(D2[np.arange(f0, n - 1)][:, free], sp.identity(3), format="csr")
    D1 = sp.diags([-np.ones(n), np.ones(n)], [0, 1], shape=(n, n), format="csr")
    D1 = sp.kron(D1[np.arange(f0, n - 1)][:, free], sp.identity(3), format="csr")
    DtD = (D.T @ D).tocsc()
    H = (DtD + w1 * (D1.T @ D1).tocsc() + (w0 + 1e-10 * DtD.diagonal().max())
         * sp.identity(3 * nv, format="csc")).toarray()
    inv = np.argsort(perm)
    Hb = np.zeros((3 * nv, 3 * nv))
    Hb[inv[hr], inv[hc]] = hv
    assert np.array_equal(Hb, H)
    # the second-difference rows helper is D @ x
    x = np.random.default_rng(n).normal(size=(n, 3))
    x[:f0 + 1] = 0.0
    np.testing.assert_allclose(sd._second_diff_rows(x, f0), D @ x[free].ravel(), rtol=0, atol=1e-14)
    assert np.all(np.abs(perm[3 * nv + ii] - perm[jj]) <= min(lo, up))


def test_range_paths_equal_the_sliced_motion():
    """Frame-range L, segment state and root orientation equal those of a sliced / sampled motion."""
    from mocomp.edit.pipeline import _root_orientation_at
    from mocomp.edit.restore import interior_L, segment_state

    r, ed = case("arms-twist")
    a, b = r.flight
    body = r.body
    Xr, Qr = segment_state(body, ed, a, b)
    Xs, Qs = segment_state(body, ed[a:b])
    assert np.array_equal(Xr, Xs) and np.array_equal(Qr, Qs)
    np.testing.assert_array_equal(interior_L(body, ed, a, b), interior_L(body, ed[a:b]))
    for t in (0.0, a / ed.fps, (a + 0.37) / ed.fps, ed.duration):
        want = ed.sample([t]).rotations[0, 0]
        np.testing.assert_allclose(_root_orientation_at(ed, t), want, rtol=0, atol=1e-15)
