"""``mocomp blend A B --at A_FRAME:B_FRAME [--window N] -o OUT.bvh``: a transition from A into B."""
from __future__ import annotations

import argparse


def _at(text: str) -> tuple[int, int]:
    parts = text.split(":")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"{text!r} is not A_FRAME:B_FRAME (e.g. 120:30)")
    try:
        a, b = int(parts[0]), int(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not two frame numbers A_FRAME:B_FRAME") from None
    if a < 0 or b < 0:
        raise argparse.ArgumentTypeError(f"frames must be 0 or more, got {text}")
    return a, b


def register(sub) -> None:
    from ._common import fps_arg, int_in
    from .footplant import add_output_args

    p = sub.add_parser(
        "blend", help="blend motion A into motion B over a window (aligned, slerp, feet planted)",
        description="Turn and move B in the ground plane so that at B_FRAME it stands and faces where A does at "
                    "A_FRAME, then play A, a window of N frames centred on those frames in which the joint rotations "
                    "are slerped with an ease curve and the root follows the blended velocity, and the rest of B. "
                    "The feet planted in A (first half of the window) and B (second half) are held by two-bone leg "
                    "IK. Both must have the same skeleton. Ends with the verdict of mocomp.audit on the frames "
                    "written, against A.")
    p.add_argument("motion", metavar="A", help="first motion (file or clip name)")
    p.add_argument("motion_b", metavar="B", help="second motion (file or clip name)")
    p.add_argument("--at", type=_at, metavar="A_FRAME:B_FRAME",
                   help="corresponding frames (0-based), the centre of the window (required; checked after the "
                        "inputs are read, so a bad input file is reported first)")
    p.add_argument("--window", type=int_in(1, 100000), default=10, metavar="N",
                   help="frames of the transition (default 10; at least 2)")
    p.add_argument("--align", choices=("root", "feet"), default="root",
                   help="align B by its root (default) or the centre of its feet")
    p.add_argument("--ease", choices=("smoothstep", "smootherstep", "cosine", "linear"), default="smoothstep",
                   help="weight curve through the window (default smoothstep)")
    p.add_argument("--time-warp", action="store_true",
                   help="move the cadence from A's to B's through the window (step periods from the foot plants)")
    p.add_argument("--no-plant", action="store_true", help="do not hold the supporting feet")
    p.add_argument("--a-fps", type=fps_arg, metavar="F", help="override A's frame rate")
    p.add_argument("--b-fps", type=fps_arg, metavar="F", help="override B's frame rate")
    add_output_args(p, "the transition")
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import datasets
    from ..ops import blend
    from .footplant import check_outputs, finish

    out = check_outputs(args)
    a = datasets.load(args.motion, fps=args.a_fps)
    b = datasets.load(args.motion_b, fps=args.b_fps)
    if args.at is None:
        raise ValueError(f"give the corresponding frames with --at A_FRAME:B_FRAME (A has frames 0-{a.n_frames - 1}, "
                         f"B has frames 0-{b.n_frames - 1})")
    r = blend(a, b, args.at, args.window, by=args.align, ease_kind=args.ease, time_warp=args.time_warp,
              plant=not args.no_plant)
    t = r.transform
    print(f"B turned by {t.to_dict()['yaw_deg']:+.1f} deg and moved by ({t.shift[0]:+.3f}, {t.shift[2]:+.3f}) m; "
          f"window: output frames {r.window[0]}-{r.window[1] - 1} (A {r.a_frames[0]:.6g}-{r.a_frames[-1]:.6g}, "
          f"B {r.b_frames[0]:.6g}-{r.b_frames[-1]:.6g})")
    if r.time_warp:
        print(f"time warp: step periods A {r.time_warp[0]:.1f}, B {r.time_warp[1]:.1f} frames")
    b_, w_, a_ = r.root_step_max
    print(f"largest root travel per frame: before {b_ * 100:.2f} cm, window {w_ * 100:.2f} cm, after {a_ * 100:.2f} cm")
    if r.footplants is not None:
        fp = r.footplants
        print(f"feet: largest slide within plants {fp.slide_before.max() * 100:.2f} -> {fp.slide_after.max() * 100:.2f} cm")
    for n in r.notes:
        print(n)
    fa, fb = blend_frame_maps(r, a.n_frames, b.n_frames)
    if not args.no_audit:
        from ..audit.posejump import pose_jump_audit
        from .footplant import ops_thresholds

        pj, _ = pose_jump_audit(r.motion, b, ops_thresholds(), frame_map=fb)
        if pj is not None:
            mid = (r.window[0] + r.window[1]) // 2
            tail = pj.step_excess[mid:]
            if tail.size:
                k = mid + int(tail.argmax())
                print(f"joint rates against B after the window's middle: largest excess over B's own "
                      f"{float(tail.max()):.1f} rad/s ({pj.joints[pj.step_joint[k]]}, frames {k}-{k + 1}), "
                      f"limit {pj.threshold:g} rad/s")
    return finish(args, "blend", out, r.motion, a, {"blend": r.to_dict()}, against_frame_map=fa)


def blend_frame_maps(r, n_a: int, n_b: int):
    """``(map_a, map_b)``, each ``(T,)``: the (fractional) frame of ``a`` and of ``b`` that each output
    frame of the blend ``r`` plays: ``a``'s frames before the window, ``r.a_frames`` / ``r.b_frames``
    in it, ``b``'s frames after it (one per output frame), each continued at one frame per frame beyond
    the part it plays and clipped to its clip. The audit of the output against ``a`` (pose jumps judged
    as violations) uses ``map_a``: exact up to the window's end; after it the output plays ``b``, so
    there it is compared with ``a``'s continuation (a faster ``b``, a run after a walk, measures up to
    ~16 rad/s above the walk there on the Bandai walk -> run); ``mocomp blend`` prints the same
    measure against ``b`` over its part with ``map_b``."""
    import numpy as np

    T = r.motion.n_frames
    s, e = r.window
    k = np.arange(T, dtype=float)
    ma = k.copy()
    ma[s:e] = r.a_frames
    ma[e:] = r.a_frames[-1] + (k[e:] - e + 1)
    mb = k - s + r.b_frames[0]
    mb[s:e] = r.b_frames
    mb[e:] = r.b_frames[-1] + (k[e:] - e + 1)
    return np.clip(ma, 0.0, n_a - 1.0), np.clip(mb, 0.0, n_b - 1.0)
