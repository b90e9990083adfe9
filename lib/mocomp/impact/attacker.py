"""The attacker's response (dissertation sec. 4.3.1).

"When the aggressor simply followed the original attack motion sequence it typically lead to
unrealistic collision forces ... first following the simulated motion for a few frames after the
impact and then blending back to the original motion through interpolation lead to a convincing
attack motion."

:func:`attacker_response` takes the attack clip (on the victim's frames) and the attacker as
simulated from the rewind frame: it plays the clip up to the rewind frame, the simulation for
``follow`` s after the impact (at least until the contact ends, at most ``max_follow`` s), then
fades the difference between simulation and clip out over ``blend`` s: the root offset shrinks
linearly to zero and every joint's rotation offset (``clip^-1 sim``, local) is slerped toward the
identity with the same ease-in/out weight the transitions use.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion, concatenate, slerp
from ..core.rotations import quat_identity, quat_inverse, quat_multiply

__all__ = ["AttackerOutcome", "attacker_response", "separate", "body_gap", "body_capsules", "segment_distances"]


@dataclass(frozen=True)
class AttackerOutcome:
    """The attacker's output and its evidence.

    motion: the attacker's output (its clip's frames, the simulated ones, the blend back).
    follow_frames: frames played from the simulation after the rewind frame; blend_frames: frames of
    the blend back; max_deviation_m: largest root distance between simulation and clip while
    followed; max_deviation_deg: largest joint angle between them.
    """

    motion: Motion
    follow_frames: int
    blend_frames: int
    max_deviation_m: float
    max_deviation_deg: float

    def to_dict(self) -> dict:
        return {"follow_frames": self.follow_frames, "blend_frames": self.blend_frames,
                "max_deviation_m": self.max_deviation_m, "max_deviation_deg": self.max_deviation_deg,
                "frames": self.motion.n_frames}


def attacker_response(clip: Motion, sim: Motion, rewind_frame: int, impact_time: float, contact_end: float | None, *,
                      follow: float = 0.1, max_follow: float = 0.3, blend: float = 0.3) -> AttackerOutcome:
    """See the module docstring. ``clip``: the attack on the victim's frames (same fps as ``sim``);
    ``sim``: the simulated attacker from ``rewind_frame``; times in s on the clip's timeline."""
    from .simulate import ease_in_out

    fps = clip.fps
    t0 = rewind_frame / fps
    end_follow = impact_time + follow
    if contact_end is not None:
        end_follow = max(end_follow, contact_end)
    end_follow = min(end_follow, impact_time + max_follow)
    nf = int(np.clip(round((end_follow - t0) * fps), 1, sim.n_frames - 1))
    nb = max(1, int(round(blend * fps)))
    last = min(rewind_frame + nf, clip.n_frames - 1)
    nf = last - rewind_frame
    seg = sim.slice(0, nf + 1)
    ref = clip.slice(rewind_frame, rewind_frame + nf + 1)
    dev_m = float(np.linalg.norm(seg.root_positions - ref.root_positions, axis=1).max())
    from ..core.rotations import quat_angle

    dev_deg = float(np.degrees(quat_angle(quat_multiply(quat_inverse(ref.rotations), seg.rotations)).max()))
    # the offset at the last followed frame, faded out over the blend frames after it
    d_root = seg.root_positions[-1] - ref.root_positions[-1]
    d_rot = quat_multiply(quat_inverse(ref.rotations[-1]), seg.rotations[-1])
    after = clip.slice(last + 1) if last + 1 < clip.n_frames else None
    parts = [clip.slice(0, rewind_frame)] if rewind_frame > 0 else []
    parts.append(seg.replace(source=clip.source))
    if after is not None:
        n = after.n_frames
        k = np.arange(1, n + 1)
        w = 1.0 - ease_in_out(k / nb)                    # 1 -> 0 over the blend, 0 after it
        ident = quat_identity((n, clip.skeleton.n_joints))
        off = slerp(ident, np.broadcast_to(d_rot, ident.shape), np.broadcast_to(w[:, None], ident.shape[:2]))
        rot = quat_multiply(after.rotations, off)
        root = after.root_positions + w[:, None] * d_root
        parts.append(after.replace(root_positions=root, rotations=rot))
    out = concatenate(parts)
    return AttackerOutcome(out, nf, min(nb, 0 if after is None else after.n_frames), dev_m, dev_deg)


#: joints carried as props, not body (ASE's sword and shield): crossing swords is not stepping through
PROPS = ("sword", "shield", "weapon", "prop")


def _radius(name: str) -> float:
    """m: a bone's capsule radius by body part (the scene's rule for skeletons without ASE geoms)."""
    n = name.lower()
    if any(k in n for k in ("hip", "pelvis", "spine", "chest", "torso", "abdomen")):
        return 0.06
    if any(k in n for k in ("thigh", "upleg", "femur")):
        return 0.05
    return 0.04


def body_capsules(motion: Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A (T, S, 3), B (T, S, 3), radius (S,))``: one capsule per bone of ``motion`` (parent joint ->
    joint, and joint -> each end site), bones shorter than 3 cm skipped; the head a capsule of radius
    9.5 cm (the scene's head sphere)."""
    sk = motion.skeleton
    P = motion.positions
    A, B, r = [], [], []
    parents = np.asarray(sk.parents)
    props = {j for j in range(sk.n_joints) if any(w in sk.names[j].lower() for w in PROPS)}
    for j in range(1, sk.n_joints):
        p = int(parents[j])
        if np.linalg.norm(sk.offsets[j]) < 0.03 or j in props or p in props:
            continue
        A.append(P[:, p])
        B.append(P[:, j])
        r.append(_radius(sk.names[p]))
    if sk.end_sites:
        E = motion.end_site_positions()
        for k, e in enumerate(sk.end_sites):
            if np.linalg.norm(e.offset) < 0.03 or e.parent in props:
                continue
            A.append(P[:, e.parent])
            B.append(E[:, k])
            r.append(0.095 if "head" in sk.names[e.parent].lower() else _radius(sk.names[e.parent]))
    return np.stack(A, axis=1), np.stack(B, axis=1), np.asarray(r)


def segment_distances(a0, a1, b0, b1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest points of segments ``a0-a1`` and ``b0-b1`` (arrays ``(..., 3)``, broadcasting): ``(distance,
    point on a, point on b)`` (Ericson, Real-Time Collision Detection, sec. 5.1.9, vectorised)."""
    d1, d2 = a1 - a0, b1 - b0
    r = a0 - b0
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    den = a * e - b * b
    eps = 1e-12
    s = np.where(den > eps, np.clip((b * f - c * e) / np.maximum(den, eps), 0.0, 1.0), 0.0)
    t = (b * s + f) / np.maximum(e, eps)
    s = np.where(t < 0, np.clip(-c / np.maximum(a, eps), 0.0, 1.0), np.where(t > 1, np.clip((b - c) / np.maximum(a, eps), 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    pa = a0 + s[..., None] * d1
    pb = b0 + t[..., None] * d2
    return np.linalg.norm(pa - pb, axis=-1), pa, pb


def body_gap(attacker: Motion, victim: Motion) -> tuple[np.ndarray, np.ndarray]:
    """``(gap (T,) m, push (T, 3))`` over the frames both motions have: the smallest surface distance
    between the two bodies' capsules (:func:`body_capsules`; negative: they overlap by that much) and the
    horizontal unit vector from the victim's root to the attacker's, the way the attacker is pushed out
    (zero where they do not overlap)."""
    n = min(attacker.n_frames, victim.n_frames)
    A0, A1, ra = body_capsules(attacker.slice(0, n))
    B0, B1, rb = body_capsules(victim.slice(0, n))
    d, _, _ = segment_distances(A0[:, :, None], A1[:, :, None], B0[:, None], B1[:, None])
    gap = d - ra[None, :, None] - rb[None, None, :]
    flat = gap.reshape(n, -1)
    k = flat.argmin(axis=1)
    g = flat[np.arange(n), k]
    # away from the victim along the line between the two roots on the ground: the closest points'
    # direction flips from frame to frame where two limbs cross, the roots' line does not
    v = attacker.root_positions[:n] - victim.root_positions[:n]
    v[:, 1] = 0.0
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    push = np.where(norm > 1e-9, v / np.maximum(norm, 1e-9), 0.0)
    push[g >= 0] = 0.0
    return g, push


def _rate_limit(total: np.ndarray, step: float, cap: float | None, start: int) -> np.ndarray:
    """``total`` (T, 3) with its frame-to-frame change at most ``step`` m (a forward slew limit from
    ``start``) and its length at most ``cap`` m."""
    out = np.array(total)
    if cap is not None:
        n = np.linalg.norm(out, axis=1, keepdims=True)
        out = np.where(n > cap, out * (cap / np.maximum(n, 1e-12)), out)
    if step is not None and np.isfinite(step):
        for i in range(max(start, 1), len(out)):
            d = out[i] - out[i - 1]
            dn = float(np.linalg.norm(d))
            if dn > step:
                out[i] = out[i - 1] + d * (step / dn)
    return out


def separate(attacker: Motion, victim: Motion, start: int = 0, *, clearance: float = 0.0, smooth_frames: float = 2.0,
             iterations: int = 30, tolerance: float = 0.005, max_speed: float | None = None,
             max_shift: float | None = None, lead_time: float = 0.2) -> tuple[Motion, dict]:
    """``(attacker, evidence)``: the attacker's root moved horizontally, smoothly in time, so its body
    capsules (:func:`body_capsules`) keep at least ``clearance`` m from the victim's on every frame from
    ``start`` -- it cannot step through the victim after blending back to its clip (the simulation
    keeps them apart only while the strike lasts).

    Per frame the deepest overlap gives the push: its depth, along the horizontal line from the victim's
    root to the attacker's at the first frame of that overlap (one direction per overlap; an overlap
    on frames pushed by an earlier iteration keeps their direction); the pushes are smoothed in time like :func:`~mocomp.impact.blend.floor_lift`
    (a running maximum of the depth, then a Gaussian of ``smooth_frames``) and added to the root;
    repeated (``iterations``) until no frame from ``start`` overlaps by more than ``tolerance`` m.
    Overlaps before ``start`` (the strike, which the simulation resolved with the true geoms) are not
    pushed; the smoothing eases the push in over the few frames before an overlap, so the frames just
    before ``start`` may move. Only the frames both motions have are checked (the attacker's later
    frames keep the last frame's push).

    ``max_speed`` (m/s) and ``max_shift`` (m) bound the push: each iteration's push is spread so it
    changes by at most ``max_speed / fps`` per frame (it starts earlier, at most ``lead_time`` s before
    ``start`` -- the attacker's last followed frames -- and ends later), the summed push is slew-limited to that speed and its length capped at
    ``max_shift``; what the bounds leave is reported as the residual overlap (``residual_overlap_m``,
    ``frames_overlapping``). A running victim's fall carried it through the attacker's place: unbounded,
    the attacker was pushed 1.6 m at up to 12 cm per frame (3.6 m/s), gliding on its feet."""
    from scipy.ndimage import gaussian_filter1d, label, maximum_filter1d

    T = attacker.n_frames
    n = min(T, victim.n_frames)
    rp = np.array(attacker.root_positions)
    total = np.zeros((T, 3))
    cur = attacker
    g0, _ = body_gap(attacker, victim)
    before = float(g0[start:n].min()) if n > start else float("inf")
    r = int(np.ceil(3 * smooth_frames))
    lead = max(0, start - int(round(lead_time * attacker.fps)))   # the bounded push may start this early
    it = 0
    for it in range(1, iterations + 1):
        g, push = body_gap(cur, victim)
        need = np.maximum(clearance - g, 0.0)
        need[:start] = 0.0
        if need.max() <= tolerance:
            it -= 1
            break
        mag = gaussian_filter1d(maximum_filter1d(need, 2 * r + 1, mode="nearest"), smooth_frames, mode="nearest")
        mag = np.maximum(mag, need)                      # never less than a frame needs
        if max_speed is not None:
            # spread: the push rises and falls no faster than max_speed (it starts earlier, from `start` on)
            rs = max_speed / attacker.fps
            mag[:lead] = 0.0                             # no sudden push bled in before the ramp
            for i in range(n - 2, lead - 1, -1):
                mag[i] = max(mag[i], mag[i + 1] - rs)
            for i in range(max(lead, 1), n):
                mag[i] = max(mag[i], mag[i - 1] - rs)
        # the direction of each frame's push, spread to its neighbours the same way (weighted by depth)
        # one direction per overlap (the roots' line at its first frame): the line turns half round
        # while one body passes the other, and a push that turned with it would swing the attacker round
        runs, nrun = label(mag > 1e-9)
        dirs = np.zeros((n, 3))
        for i in range(1, nrun + 1):
            idx = np.nonzero(runs == i)[0]
            first = idx[need[idx] > 0]
            held = total[idx[idx < T]].sum(axis=0)
            if np.linalg.norm(held) > 1e-6:             # frames pushed before keep their way out
                dirs[idx] = held / np.linalg.norm(held)
            elif first.size:
                dirs[idx] = push[first[0]]
        step = dirs * (mag[:, None] + 0.5 * tolerance * (mag[:, None] > 0))
        full = np.zeros((T, 3))
        full[:n] = step
        if T > n:
            full[n:] = step[n - 1]
        new = total + full
        if max_speed is not None or max_shift is not None:
            new = _rate_limit(new, None if max_speed is None else max_speed / attacker.fps, max_shift, lead)
        if np.abs(new - total).max() < 1e-5:             # the bounds allow no more
            total = new
            break
        total = new
        cur = attacker.replace(root_positions=rp + total)
    cur = attacker.replace(root_positions=rp + total)
    g, _ = body_gap(cur, victim)
    after = float(g[start:n].min()) if n > start else float("inf")
    moved = np.linalg.norm(total, axis=1)
    over = g[start:n] < -tolerance
    return cur, {"min_gap_before_m": before, "min_gap_after_m": after, "max_shift_m": float(moved.max()),
                 "frames_shifted": int((moved > 1e-6).sum()), "iterations": it,
                 "max_shift_step_m": float(np.linalg.norm(np.diff(total, axis=0), axis=1).max()) if T > 1 else 0.0,
                 "max_speed_mps": max_speed, "max_shift_limit_m": max_shift,
                 "residual_overlap_m": float(max(-after, 0.0)), "frames_overlapping": int(over.sum())}
