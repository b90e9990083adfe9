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

__all__ = ["AttackerOutcome", "attacker_response"]


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
