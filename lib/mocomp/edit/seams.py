"""Seam blending for motions assembled from pieces of flights (joins, twist variation).

At a seam between a left block (ending at frame ``last_left``) and a right block, the two
sides' poses at the seam instant (``left_ref`` and ``right_ref``, a matched pair found by the
similarity search of App. A) differ a little. :func:`crossfade` turns the left side toward the
right side's pose by ``q^s`` and the right side from the left side's by ``q^(s-1)``, with ``s``
rising smoothly (smoothstep) from 0 to 1 across ``2 w + 2`` frames centred on the seam: every
joint's local rotation (as offsets, so each side keeps its own motion) and the root orientation
about the frame's COM (world frame; after the search matched the rotation about L, its
mismatch is perpendicular to L). Nothing jumps, and the blending rate peaks at the seam.
This is the dissertation's "slerping joint angles over small windows" (section 5.4.2.2) in
an offset form.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion, slerp
from ..core.rotations import quat_apply, quat_inverse, quat_multiply, shortest_arc

__all__ = ["crossfade", "recover_upright", "landing_tilt", "stance_slide"]


def crossfade(rot: np.ndarray, rp: np.ndarray, last_left: int, left_ref: np.ndarray, right_ref: np.ndarray,
              window: int, com_eval) -> float:
    """Blend the seam after frame ``last_left`` in place (``rot (T, J, 4)``, ``rp (T, 3)``).

    ``left_ref`` / ``right_ref`` (``(J, 4)``, root first, as placed in the sequence) are the two
    sides' poses at the same instant. ``com_eval`` gives each frame's COM (the root turns about it).
    Returns the root mismatch, degrees.
    """
    T = rot.shape[0]
    w = max(1, int(window))
    ql = np.asarray(left_ref, dtype=float)
    qr = np.asarray(right_ref, dtype=float)
    sgn = np.where(np.sum(ql * qr, axis=-1) < 0, -1.0, 1.0)[:, None]
    qr = sgn * qr
    off_l = quat_multiply(quat_inverse(ql[1:]), qr[1:])        # joints, local: left -> right
    off_r = quat_inverse(off_l)
    q_rel = quat_multiply(qr[0], quat_inverse(ql[0]))          # root, world: left -> right
    q_rel_inv = quat_inverse(q_rel)
    ident = np.zeros(4)
    ident[3] = 1.0
    span = 2 * w + 2
    lo, hi = max(0, last_left - w), min(T, last_left + 2 + w)
    for i in range(lo, hi):
        x = min(max((i - (last_left - w) + 0.5) / span, 0.0), 1.0)
        sig = x * x * (3 - 2 * x)
        left = i <= last_left
        frac = sig if left else 1.0 - sig
        off = off_l if left else off_r
        rot[i, 1:] = quat_multiply(rot[i, 1:], slerp(np.broadcast_to(ident, off.shape), off, np.full(off.shape[0], frac)))
        qroot = slerp(ident[None], (q_rel if left else q_rel_inv)[None], np.array([frac]))[0]
        c = com_eval(rp[i:i + 1], rot[i:i + 1])[0]
        rot[i, 0] = quat_multiply(qroot, rot[i, 0])
        rp[i] = c + quat_apply(qroot, rp[i] - c)
    return float(np.degrees(2 * np.arccos(min(1.0, abs(float(q_rel[3]))))))


def landing_tilt(q_ref: np.ndarray, q_now: np.ndarray) -> tuple[float, np.ndarray]:
    """Tilt (degrees) of a landing whose root orientation is ``q_now`` where ``q_ref`` was
    intended: the angle by which the body's direction that was vertical in ``q_ref`` is now
    off the vertical (a turn about the vertical is not a tilt). Returns ``(tilt, up_now)``."""
    up = np.array([0.0, 1.0, 0.0])
    body_up = quat_apply(quat_inverse(np.asarray(q_ref, dtype=float)), up)
    up_now = quat_apply(np.asarray(q_now, dtype=float), body_up)
    return float(np.degrees(np.arccos(np.clip(up_now[1], -1.0, 1.0)))), up_now


def _contact_weights(heights: np.ndarray, contact) -> np.ndarray:
    """Smoothstep weight 1 within ``contact[0]`` m of each column's lowest value, 0 above ``contact[1]``."""
    h = heights - heights.min(axis=0)
    x = np.clip((contact[1] - h) / (contact[1] - contact[0]), 0.0, 1.0)
    return x * x * (3 - 2 * x)


def stance_slide(positions: np.ndarray, weights: np.ndarray) -> float:
    """Largest horizontal travel (m) of a joint during one of its contacts (runs of ``weights >=
    0.5``) from where that contact began. ``positions (n, F, 3)``, ``weights (n, F)``."""
    from ..ops.ik import run_starts

    st = run_starts(np.asarray(weights) >= 0.5)
    on = st >= 0
    if not on.any():
        return 0.0
    xz = positions[..., [0, 2]]
    origin = np.take_along_axis(xz, np.maximum(st, 0)[..., None], axis=0)
    return float(np.linalg.norm(xz - origin, axis=-1)[on].max())


#: s: the shortest time over which :func:`recover_upright` lets go of a held ankle
RELEASE_S = 0.2
#: s: the time over which :func:`recover_upright`'s root shift follows a change of its target
#: (:func:`_ease_shift`)
SHIFT_EASE_S = 0.2


def _held_shift(w: np.ndarray, err: np.ndarray) -> np.ndarray:
    """``(n, 2)`` root shift of :func:`recover_upright`: per frame the contact-weighted mean
    ``e = w @ err / sum(w)`` of the feet's horizontal errors ``err (n, F, 2)``, blended by the
    strongest contact ``c = max(w)`` with the previous frame's (``s_i = c e + (1 - c) s_{i-1}``);
    held where no foot touches (``sum(w) <= 1e-9``). The reductions are vectorised, only the
    scalar recurrence runs per frame."""
    n = w.shape[0]
    ws = w.sum(axis=1)
    cw = w.max(axis=1) if w.shape[1] else np.zeros(n)
    touch = ws > 1e-9
    mean = np.zeros((n, 2))
    mean[touch] = np.einsum("if,ifk->ik", w[touch], err[touch]) / ws[touch, None]
    x, z = 0.0, 0.0
    shift = np.empty((n, 2))
    for i, (t, c, m) in enumerate(zip(touch.tolist(), cw.tolist(), mean.tolist())):
        if t:
            x = c * m[0] + (1.0 - c) * x
            z = c * m[1] + (1.0 - c) * z
        shift[i, 0] = x
        shift[i, 1] = z
    return shift


#: m/s: horizontal ankle speeds (before the recovery) below which a foot in the contact band is
#: held by :func:`recover_upright`'s leg IK, and above which it is not (smoothstep between)
STILL_SPEED = (0.2, 0.5)


def _still_weights(xz: np.ndarray, fps: float, speeds: tuple[float, float] = STILL_SPEED) -> np.ndarray:
    """``(n, C)`` weights, 1 where the ankle's horizontal speed (central differences of ``xz (n, C,
    2)``, m, at ``fps``) is below ``speeds[0]``, 0 above ``speeds[1]``, smoothstep between.

    The contact band of :func:`_contact_weights` (within 5-12 cm of a foot's lowest height) also
    takes feet that step low along the floor: on the DeepMimic back flip's landing the ankles travel
    17 cm at up to 1.4 m/s a few cm above their lowest, and holding them where their contact began
    stretched the legs against the stance (a 0.48 m/s COM velocity jump in the audit of the written
    frames of ``edit deepmimic_backflip --preset arms-out``, input 0.33)."""
    xz = np.asarray(xz, dtype=float)
    if xz.shape[0] < 2:
        return np.ones(xz.shape[:2])
    v = np.linalg.norm(np.gradient(xz, axis=0), axis=-1) * fps
    x = np.clip((speeds[1] - v) / (speeds[1] - speeds[0]), 0.0, 1.0)
    return x * x * (3 - 2 * x)


def _ease_shift(shift: np.ndarray, n_ease: int) -> np.ndarray:
    """``shift (n, 2)`` followed with bounded acceleration: the causal convolution with a
    raised-cosine kernel of ``n_ease`` frames (``h_k ~ 1 - cos(2 pi (k + 1) / (n_ease + 1))``,
    summing to 1), the shift before the first frame taken as 0 (the frames before touchdown are
    not shifted). A step ``d`` of the target becomes an S-curve over ``n_ease`` frames whose
    speed starts and ends at 0, peaks at ``2 d / n_ease`` per frame, and whose acceleration stays
    below ``2 pi d / n_ease^2`` per frame^2; a constant target is reached exactly ``n_ease - 1``
    frames after it stops changing. Causal: the root never moves before the feet touch for it.

    The target of :func:`_held_shift` steps by the whole error of a foot when it re-touches the
    floor (synthetic side flip + arms-out: 8 cm within ~8 frames, a 1.06 m/s COM velocity jump in
    the audit of the written frames, input 0.23); followed as is, that step is the jump."""
    shift = np.asarray(shift, dtype=float)
    L = int(n_ease)
    if L <= 1 or shift.shape[0] == 0:
        return shift.copy()
    n = shift.shape[0]
    # the taps that reach a frame of this motion only (a kernel longer than it is cut, not rescaled);
    # sum_{k=1..L} (1 - cos(2 pi k / (L + 1))) = L + 1
    h = (1.0 - np.cos(2.0 * np.pi * np.arange(1, min(L, n) + 1) / (L + 1))) / (L + 1)
    return np.stack([np.convolve(shift[:, k], h)[:n] for k in range(shift.shape[1])], axis=1)


def recover_upright(motion: Motion, first_ground: int, up_now: np.ndarray, seconds: float, ce,
                    pin_feet: bool = True, contact: tuple[float, float] = (0.05, 0.12),
                    pivot=None):
    """Ease the landing tilt out after touchdown: frames from ``first_ground`` turn by a growing
    fraction of the rotation taking ``up_now`` back to vertical, about ``pivot`` (``(3,)`` m;
    default: the ground point under the COM at touchdown, at the lowest joint's height -- which for
    a turned body is not the floor: :func:`mocomp.edit.pipeline.three_steps` gives the point under
    the COM on the floor). ``first_ground`` must be the frame where the body reaches the floor:
    turning it earlier turns it in mid-air (:mod:`mocomp.edit.landing`).

    The rotation alone carries the feet with it, and brings to the floor feet that the tilted
    landing (a join's fully aligned landing part) was moving in the air: on the DeepMimic back
    flip + spin kick join (37.5 deg of tilt) the foot on the ground then slides 13 cm. With
    ``pin_feet``:

    1. a horizontal root translation, eased like the rotation, puts the feet that are on the
       ground back where they were before the recovery (each foot joint -- ``toe``/``foot``/
       ``ankle`` in its name -- weighted by its contact weight: 1 within ``contact[0]`` m of its
       own lowest height after touchdown, 0 above ``contact[1]`` m, smoothstep between; when no
       foot touches, the last translation is held, nothing snaps back);
    2. each leg's ankle is held where its contact began for as long as it lasts, by two-bone IK
       of hip and knee (:func:`mocomp.ops.ik.plant_feet`; the foot keeps its orientation).

    Returns ``(motion, slide)``: ``slide`` (m) is the largest horizontal travel of a foot joint
    during a contact, from where that contact began (:func:`stance_slide`).
    """
    from ..core.kinematics import forward_kinematics
    from ..ops.ik import leg_chains, plant_rotations

    fix = shortest_arc(np.asarray(up_now, dtype=float), np.array([0.0, 1.0, 0.0]))
    n = motion.n_frames - first_ground
    m = max(1, int(round(seconds * motion.fps)))
    s = np.clip(np.arange(1, n + 1) / m, 0.0, 1.0)
    s = s * s * (3 - 2 * s)
    ident = np.broadcast_to([0.0, 0.0, 0.0, 1.0], (n, 4))
    q = slerp(ident, np.broadcast_to(fix, (n, 4)), s)
    c = ce(motion.root_positions[first_ground:first_ground + 1], motion.rotations[first_ground:first_ground + 1])[0]
    if pivot is None:
        low = motion.fk(frames=slice(first_ground, first_ground + 1))[0][0, :, 1].min()
        pivot = np.array([c[0], low, c[2]])
    pivot = np.asarray(pivot, dtype=float)
    rp = np.array(motion.root_positions)
    rot = np.array(motion.rotations)
    rp[first_ground:] = pivot + quat_apply(q, rp[first_ground:] - pivot)
    rot[first_ground:, 0] = quat_multiply(q, rot[first_ground:, 0])
    sk = motion.skeleton
    feet = [j for j, nm in enumerate(sk.names) if any(k in nm.lower() for k in ("toe", "foot", "ankle"))]
    if not feet:
        return motion.replace(root_positions=rp, rotations=rot), 0.0
    # FK of the frames from touchdown only, on the arrays (one motion is built, at the end)
    after = forward_kinematics(sk.parents, sk.offsets, rp[first_ground:], rot[first_ground:])[0][:, feet]
    w = _contact_weights(after[..., 1], contact)
    if pin_feet:
        before = motion.fk(frames=slice(first_ground, None))[0][:, feet]
        err = before[..., [0, 2]] - after[..., [0, 2]]                    # (n, F, 2)
        shift = _ease_shift(_held_shift(w, err), int(round(SHIFT_EASE_S * motion.fps)))
        rp[first_ground:, 0] += shift[:, 0]
        rp[first_ground:, 2] += shift[:, 1]
        chains = [ch for ch in leg_chains(sk) if ch[2] in feet]
        if chains:
            # heights are those after the rotation (the translation is horizontal)
            wa = w[:, [feet.index(ch[2]) for ch in chains]]
            # an ankle the motion itself moves along the floor (a step within the contact band) is
            # not held where its contact began (:func:`_still_weights`)
            wa = wa * _still_weights(before[:, [feet.index(ch[2]) for ch in chains]][..., [0, 2]], motion.fps)
            # a held ankle is let go no faster than over RELEASE_S (as edit.landing's feet): a foot
            # lifting for a hop crosses the contact band within two frames, and the leg snapping back
            # from its held pose moved the COM by a 0.64 m/s velocity jump (DeepMimic side flip + arms-out)
            from .landing import _release_limited

            rate = 1.0 / max(RELEASE_S * motion.fps, 1.0)
            wa = np.stack([_release_limited(wa[:, i], rate) for i in range(wa.shape[1])], axis=1)
            P, G = forward_kinematics(sk.parents, sk.offsets, rp[first_ground:], rot[first_ground:])
            rot, solves = plant_rotations(sk.parents, rot, P, G, first_ground, wa, chains)
            if solves:
                after = forward_kinematics(sk.parents, sk.offsets, rp[first_ground:], rot[first_ground:])[0][:, feet]
                return motion.replace(root_positions=rp, rotations=rot), stance_slide(after, w)
        after[..., 0] += shift[:, None, 0]
        after[..., 2] += shift[:, None, 1]
    return motion.replace(root_positions=rp, rotations=rot), stance_slide(after, w)
