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

from mocomp.core.kinematics import forward_kinematics
from mocomp.core.motion import slerp
from mocomp.core.rotations import quat_apply, quat_multiply
from mocomp.edit import apply_preset, restore_momentum, seams
from mocomp.edit._kernels import fk_arrays, motion_fk
from mocomp.edit.legs import _descends, leg_chains, run_starts, two_bone_ik
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
    P0, G0 = forward_kinematics(sk.parents, sk.offsets, rp, rot)
    P1, G1 = fk_arrays(sk, rp, rot)
    assert np.array_equal(P0, P1) and np.array_equal(G0, G1)
    # the identity pose puts each joint at its parent plus its offset (known answer)
    Pi, Gi = fk_arrays(sk, np.zeros((1, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (1, sk.n_joints, 1)))
    for j in range(1, sk.n_joints):
        np.testing.assert_allclose(Pi[0, j], Pi[0, sk.parents[j]] + sk.offsets[j], atol=1e-15)
    assert np.array_equal(Gi[0], np.tile([0.0, 0.0, 0.0, 1.0], (sk.n_joints, 1)))


def test_motion_fk_ranges_and_cache():
    m = backflip(jump_height=1.25).motion.replace()
    P, G = motion_fk(m, 40, 90)                            # a range: computed alone, nothing cached
    assert "fk" not in m._cache
    Pr, Gr = m[40:90].fk()
    assert np.array_equal(P, Pr) and np.array_equal(G, Gr)
    Pa, Ga = motion_fk(m)                                  # the whole motion fills Motion's cache
    assert m._cache["fk"][0] is Pa and not Pa.flags.writeable
    P2, _ = motion_fk(m, 40, 90)                           # ranges now read the cache
    assert np.shares_memory(P2, Pa) and np.array_equal(P2, P)
    fresh = m.replace()
    assert np.array_equal(fresh.positions, Pa) and np.array_equal(fresh.global_rotations, Ga)


# ---------------------------------------------------------------- references (pre-speed-up code)
def _plant_feet_reference(motion, start, weights, chains, tol=1e-3):
    parents = motion.skeleton.parents
    for c1 in chains:
        for c2 in chains:
            if c1 is not c2 and _descends(parents, c2[0], c1[0]):
                raise ValueError("overlap")
    rot = np.array(motion.rotations)
    P, G = motion.fk()
    solves = 0
    starts = run_starts(np.asarray(weights) >= 0.5)
    for c, chain in enumerate(chains):
        a = chain[2]
        tgt = np.array(P[start:, a])
        on = starts[:, c] >= 0
        plant = tgt[np.maximum(starts[:, c], 0)][:, [0, 2]]
        blend = np.where(on, weights[:, c], 0.0)[:, None]
        tgt[:, [0, 2]] += blend * (plant - tgt[:, [0, 2]])
        idx = np.flatnonzero(np.linalg.norm(tgt - P[start:, a], axis=1) > tol)
        if idx.size:
            f = start + idx
            rot[f], _ = two_bone_ik(P[f], G[f], rot[f], parents, chain, tgt[idx])
            solves += idx.size
    return motion.replace(rotations=rot), solves


def _recover_upright_reference(motion, first_ground, up_now, seconds, ce, contact=(0.05, 0.12)):
    fix = seams._shortest_arc(np.asarray(up_now, dtype=float), np.array([0.0, 1.0, 0.0]))
    n = motion.n_frames - first_ground
    m = max(1, int(round(seconds * motion.fps)))
    s = np.clip(np.arange(1, n + 1) / m, 0.0, 1.0)
    s = s * s * (3 - 2 * s)
    ident = np.broadcast_to([0.0, 0.0, 0.0, 1.0], (n, 4))
    q = slerp(ident, np.broadcast_to(fix, (n, 4)), s)
    c = ce(motion.root_positions[first_ground:first_ground + 1], motion.rotations[first_ground:first_ground + 1])[0]
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
    rp[first_ground:, 0] += shift[:, 0]
    rp[first_ground:, 2] += shift[:, 1]
    out = motion.replace(root_positions=rp, rotations=rot)
    chains = [ch for ch in leg_chains(motion.skeleton) if ch[2] in feet]
    wa = w[:, [feet.index(ch[2]) for ch in chains]]
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
        seen["args"] = args
        return real(*args, **kw)

    monkeypatch.setattr(seams, "recover_upright", spy)
    res = restore_momentum(r.body, r.motion, ed, r.flight, L_star=r.L0)
    assert res.foot_slide is not None and res.landing_tilt_deg > 1.0     # the recovery ran
    motion, fg, up_now, secs, _ = seen["args"]
    ref, slide_ref = _recover_upright_reference(motion.replace(), fg, up_now, secs, ComEvaluator(r.body))
    np.testing.assert_allclose(res.motion.root_positions, ref.root_positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.motion.rotations, ref.rotations, rtol=0, atol=1e-12)
    assert abs(res.foot_slide - slide_ref) < 1e-12
    # frames before touchdown are left alone
    assert np.array_equal(res.motion.rotations[:fg], motion.rotations[:fg])


def test_held_shift_known_answer():
    # one foot, full contact at frames 0 and 2, none at frame 1, half contact at 3
    w = np.array([[1.0], [0.0], [1.0], [0.5]])
    err = np.array([[[1.0, 2.0]], [[9.0, 9.0]], [[3.0, -1.0]], [[5.0, 5.0]]])
    np.testing.assert_allclose(seams._held_shift(w, err),
                               [[1.0, 2.0], [1.0, 2.0], [3.0, -1.0], [4.0, 2.0]], atol=1e-15)
