"""Transitions: motion ``b`` aligned to motion ``a`` and blended into it over a window (issue 15, item 3).

``blend(a, b, at=(fa, fb), window=N)``: frame ``fa`` of ``a`` corresponds to frame ``fb`` of ``b``
(the centre of the window). ``b`` is first turned about the vertical and moved in the ground plane
so that at ``fb`` it faces and stands where ``a`` does at ``fa`` (:func:`~mocomp.ops.align.align`).
The output plays ``a`` up to the window, then ``N`` frames in which frame ``i`` mixes ``a`` and
``b`` with weight ``w_i = ease(i / (N - 1))`` (0 -> 1), then the rest of ``b``:

* joint rotations (the root's orientation included, so the heading too) by slerp,
  ``q = slerp(q_a, q_b, w)``;
* the root consistently: its horizontal velocity is the blend of the two velocities,
  ``v = (1 - w) v_a + w v_b``, integrated from ``a``'s last frame before the window, so the
  path has no jump and no overshoot; its height is blended directly; the rest of ``b`` follows
  from where the window ends (a horizontal shift of the aligned ``b``);
* optional time warping: with ``time_warp=True`` the two are sampled at rates that move the
  cadence from ``a``'s to ``b``'s through the window (their step periods measured from the foot
  plants), so they stay in phase (Kovar & Gleicher 2003's registration, in its simplest form);
* the supporting feet stay planted: the plants of ``a`` before the window's middle and of ``b``
  from it on are enforced on the result by :func:`~mocomp.ops.footplant.enforce_footplants`.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import Motion, slerp
from ..errors import MotionFormatError
from .align import ALIGN_BY, GroundTransform, align
from .easing import EASE_KINDS, ease

__all__ = ["BlendResult", "blend", "step_period"]


@dataclass(frozen=True, eq=False)
class BlendResult:
    """A transition and its evidence.

    Attributes
    ----------
    motion: the result: ``a[:start]``, the window, the rest of ``b``.
    transform: the :class:`~mocomp.ops.align.GroundTransform` applied to ``b`` before blending.
    window: half-open ``(start, stop)`` output frames of the window.
    a_frames, b_frames: ``(N,)`` the (fractional, with time warping) frames of ``a`` and ``b``
        mixed in the window.
    weights: ``(N,)`` the weight of ``b`` per window frame.
    b_offset: output frame of ``b``'s frame 0 after the window (fractional with time warping).
    shift: ``(3,)`` m, the horizontal shift of the aligned ``b`` after the window (velocity integration).
    time_warp: ``(period_a, period_b)`` frames per step, or ``None``.
    footplants: the :class:`~mocomp.ops.footplant.FootplantResult` of the enforcement (``None`` with
        ``plant=False``).
    root_step_max: ``(before, window, after)`` m per frame: the largest root travel between two
        frames in each part (a root jump shows in the window or at its edges).
    """

    motion: Motion
    transform: GroundTransform
    window: tuple[int, int]
    a_frames: np.ndarray
    b_frames: np.ndarray
    weights: np.ndarray
    b_offset: float
    shift: np.ndarray
    time_warp: tuple | None
    footplants: object | None
    root_step_max: tuple
    seconds: float = 0.0
    notes: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict:
        d = {"transform": self.transform.to_dict(), "window": list(self.window),
             "a_frames": [float(self.a_frames[0]), float(self.a_frames[-1])],
             "b_frames": [float(self.b_frames[0]), float(self.b_frames[-1])],
             "b_offset": self.b_offset, "shift_m": [float(x) for x in self.shift],
             "time_warp_periods": None if self.time_warp is None else list(self.time_warp),
             "root_step_max_m": dict(zip(("before", "window", "after"), map(float, self.root_step_max))),
             "seconds": self.seconds, "notes": list(self.notes)}
        if self.footplants is not None:
            d["footplants"] = self.footplants.to_dict()
        return d


def step_period(motion: Motion) -> float:
    """Frames per step: the median gap between successive plant starts of the ankle points (either
    foot), from the contact detector. Raises :class:`~mocomp.ops.plants.NoContactError` with fewer
    than two plants."""
    from .plants import NoContactError, foot_plants

    pl = foot_plants(motion)
    starts = sorted(a for e in ("foot_l", "foot_r") for a, _ in pl.intervals[e] if a > 0)
    if len(starts) < 2:
        raise NoContactError(f"{motion.source.path or 'the motion'}: fewer than two foot strikes; time warping "
                             "needs the step period of both motions")
    return float(np.median(np.diff(starts)))


def _check_same(a: Motion, b: Motion) -> None:
    sa, sb = a.skeleton, b.skeleton
    if sa.names != sb.names or not np.array_equal(sa.parents, sb.parents):
        only_a = [n for n in sa.names if n not in sb.names]
        only_b = [n for n in sb.names if n not in sa.names]
        raise MotionFormatError(
            "A and B have different skeletons: "
            + (f"joints only in A: {', '.join(only_a[:8])}; " if only_a else "")
            + (f"joints only in B: {', '.join(only_b[:8])}" if only_b else "same joint names, different hierarchy"))
    if not np.allclose(sa.offsets, sb.offsets, atol=1e-3):
        j = int(np.argmax(np.abs(sa.offsets - sb.offsets).max(axis=1)))
        raise MotionFormatError(f"A and B have different bone lengths: joint {sa.names[j]!r} offset "
                                f"{np.round(sa.offsets[j], 4).tolist()} vs {np.round(sb.offsets[j], 4).tolist()} m")


def _window_frames(n: int, centre: int, h: int, size: int, which: str, frames: np.ndarray) -> None:
    lo, hi = float(frames.min()), float(frames.max())
    if lo < -1e-9 or hi > n - 1 + 1e-9:
        raise ValueError(f"a window of {size} frames centred on {which} frame {centre} needs {which} frames "
                         f"{lo:.6g}-{hi:.6g}, but {which} has frames 0-{n - 1}"
                         + (f" (the window is longer than {which})" if size > n else
                            f"; use a window of at most {2 * min(centre, n - 1 - centre) + 1} frames there "
                            f"or another frame"))


def blend(a: Motion, b: Motion, at: tuple[int, int], window: int = 10, *, by: str = "root",
          ease_kind: str = "smoothstep", time_warp: bool = False, plant: bool = True,
          audit: bool = False, transform: GroundTransform | None = None) -> BlendResult:
    """Blend ``b`` into ``a`` (see the module docstring).

    Parameters
    ----------
    at: ``(fa, fb)``: frame ``fa`` of ``a`` corresponds to frame ``fb`` of ``b``; the window is
        centred on them (frames ``fa - N // 2 ... fa - N // 2 + N - 1`` of ``a``, likewise of ``b``).
    window: ``N`` frames, at least 2 (a 1-frame "blend" would be a cut).
    by: alignment reference, ``"root"`` or ``"feet"`` (centre of the ankle points).
    ease_kind: ease curve of the weights (:func:`~mocomp.ops.easing.ease`).
    time_warp: match the cadence through the window (needs foot plants in both).
    plant: enforce the supporting feet on the result.
    audit: with ``plant``, also audit input ``a`` and the result (footplant evidence).
    transform: the :class:`~mocomp.ops.align.GroundTransform` that moves ``b`` into ``a``'s frame,
        given by the caller (e.g. a concatenation's eq. 2 turn and feet-centre translation) instead
        of :func:`~mocomp.ops.align.align` at ``at`` (``by`` is then unused).
    """
    t0 = time.perf_counter()
    window = int(window)
    if window < 2:
        raise ValueError(f"the blend window must be at least 2 frames, got {window} (1 frame would be a cut with "
                         "no transition)")
    if by not in ALIGN_BY:
        raise ValueError(f"by must be one of {', '.join(ALIGN_BY)}, got {by!r}")
    if ease_kind not in EASE_KINDS:
        raise ValueError(f"ease must be one of {', '.join(EASE_KINDS)}, got {ease_kind!r}")
    _check_same(a, b)
    notes = []
    if abs(a.fps - b.fps) > 1e-9:
        b = b.resample(a.fps)
        notes.append(f"B resampled to A's {a.fps:g} fps")
    fa, fb = (int(x) for x in at)
    for f, m, w in ((fa, a, "A"), (fb, b, "B")):
        if not 0 <= f < m.n_frames:
            raise ValueError(f"{w} frame {f} is outside {w}'s frames 0-{m.n_frames - 1}")
    N, h = window, window // 2
    i = np.arange(N)
    w = ease(i / (N - 1), ease_kind)
    periods = None
    if time_warp:
        pa, pb = step_period(a), step_period(b)
        periods = (pa, pb)
        # phase advance per output frame (steps): (1 - w)/pa + w/pb; each clip advances it times its period
        dphi = (1.0 - w) / pa + w / pb
        phi = np.concatenate([[0.0], np.cumsum(dphi[:-1])])
        phi -= phi[h]
        fa_i, fb_i = fa + phi * pa, fb + phi * pb
    else:
        fa_i, fb_i = (fa - h + i).astype(float), (fb - h + i).astype(float)
    _window_frames(a.n_frames, fa, h, N, "A", fa_i)
    _window_frames(b.n_frames, fb, h, N, "B", fb_i)
    if transform is not None and not isinstance(transform, GroundTransform):
        raise TypeError(f"transform must be a GroundTransform, got {type(transform).__name__}")
    tf = align(a, b, fa, fb, by) if transform is None else transform
    off = int(np.floor(fb_i[0] + 1e-9))                 # b's frames from the window on: only they are moved
    b2 = tf.apply(b[off:])
    gb = fb_i - off
    sa = a.sample(fa_i / a.fps) if time_warp else a[int(fa_i[0]):int(fa_i[-1]) + 1]
    sb = b2.sample(gb / b.fps) if time_warp else b2[int(gb[0]):int(gb[-1]) + 1]
    rot = slerp(sa.rotations, sb.rotations, np.broadcast_to(w[:, None], sa.rotations.shape[:2]))
    # root: blended horizontal velocity integrated from a's frame before the window, blended height
    start = int(np.floor(fa_i[0]))
    ra, rb = sa.root_positions, sb.root_positions
    if time_warp:
        va = np.diff(ra, axis=0)
        vb = np.diff(rb, axis=0)
        prev_a = a.sample([max(fa_i[0] - 1.0, 0.0) / a.fps]).root_positions[0] if fa_i[0] >= 1 else ra[0]
        v0 = ra[0] - prev_a
    else:
        va, vb = np.diff(ra, axis=0), np.diff(rb, axis=0)
        v0 = ra[0] - (a.root_positions[start - 1] if start >= 1 else ra[0])
    wv = 0.5 * (w[1:] + w[:-1])
    v = (1.0 - wv)[:, None] * va + wv[:, None] * vb
    root = np.empty((N, 3))
    root[0] = ra[0] if not time_warp or start < 1 else a.root_positions[start - 1] + v0
    root[1:] = root[0] + np.cumsum(v, axis=0)
    root[:, 1] = (1.0 - w) * ra[:, 1] + w * rb[:, 1]
    # the rest of b, shifted horizontally to continue from the window's last root
    if time_warp:
        # after the window b plays at its own rate: frames fb_i[-1] + 1, + 2, ...
        tb = gb[-1] + np.arange(1, int(np.floor(b2.n_frames - 1 - gb[-1] + 1e-9)) + 1)
        rest = b2.sample(tb / b.fps) if tb.size else None
        last_b = b2.sample([gb[-1] / b.fps]).root_positions[0]
    else:
        rest = b2[int(gb[-1]) + 1:] if int(gb[-1]) + 1 < b2.n_frames else None
        last_b = b2.root_positions[int(gb[-1])]
    shift = root[-1] - last_b
    shift[1] = 0.0
    head = a[:start] if start > 0 else None
    parts_rp = ([head.root_positions] if head is not None else []) + [root] + (
        [rest.root_positions + shift] if rest is not None else [])
    parts_rot = ([head.rotations] if head is not None else []) + [rot] + ([rest.rotations] if rest is not None else [])
    out = a.replace(root_positions=np.concatenate(parts_rp), rotations=np.concatenate(parts_rot))
    win = (start, start + N)
    b_offset = float(win[1] - 1 - fb_i[-1])
    fp = None
    if plant:
        from .footplant import enforce_footplants
        from .plants import foot_plants

        la = foot_plants(a, require=False).labels
        lb = foot_plants(b, require=False).labels
        T = out.n_frames
        lab = np.zeros((T, 4), bool)
        lab[:start] = la[:start]
        ia = np.clip(np.rint(fa_i).astype(int), 0, a.n_frames - 1)
        ib = np.clip(np.rint(fb_i).astype(int), 0, b.n_frames - 1)
        lab[start:start + N] = np.where((np.arange(N) < h)[:, None], la[ia], lb[ib])
        if rest is not None:
            jb = np.clip(np.rint(fb_i[-1] + np.arange(1, rest.n_frames + 1)).astype(int), 0, b.n_frames - 1)
            lab[start + N:] = lb[jb]
        pl = foot_plants(out, labels=lab, require=False)
        if pl.labels.any():
            fp = enforce_footplants(out, pl, audit=audit)
            out = fp.motion
        else:
            notes.append("no foot planted in A or B: nothing to enforce")
    steps = np.linalg.norm(np.diff(out.root_positions, axis=0), axis=1)
    parts = (steps[:max(win[0] - 1, 0)], steps[max(win[0] - 1, 0):win[1]], steps[win[1]:])
    rsm = tuple(float(p.max()) if p.size else 0.0 for p in parts)
    return BlendResult(out, tf, win, fa_i, fb_i, w, b_offset, shift, periods, fp, rsm,
                       time.perf_counter() - t0, tuple(notes))
