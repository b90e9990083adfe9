"""``mocomp splice BODY HAND -o OUT.bvh``: splice a hand recording's arm onto a
full-body recording with two-stage banded DTW (dissertation ch. 6)."""
from __future__ import annotations

import argparse
from pathlib import Path


def _match_arg(text: str):
    from ..splice.bands import parse_match

    try:
        return parse_match(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _fraction(text: str) -> float:
    try:
        v = float(text.rstrip("%")) / (100.0 if text.endswith("%") else 1.0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a fraction (e.g. 0.3 or 30%)") from None
    if not 0 < v <= 2:
        raise argparse.ArgumentTypeError(f"band width must be a positive fraction of the body length, got {text}")
    return v


def register(sub) -> None:
    from ._common import add_audit_arg, fps_arg

    p = sub.add_parser(
        "splice", help="splice a hand recording onto a full-body recording (two-stage banded DTW)",
        description="Align the arm of HAND (a separately captured gesture) with the same gesture in BODY using "
                    "the two-stage DTW of Majkowska's dissertation ch. 6 (sign-of-derivative phase matching in a "
                    "band of 30% of BODY's length, then hand-angle refinement in a 10% band), optionally pinned "
                    "by matching points, and write BODY with the arm joints driven by the aligned HAND. Both may "
                    "be files (BVH, ASF/AMC, ...) or clip names; their arm and hand joints are paired by name, by the body "
                    "model's naming conventions and by structure, or by --map. "
                    "A matching point outside the band reshapes the band so the path passes through it "
                    "(Algorithm 1); --strict-points makes that an error instead. The splice measures its own quality on "
                    "the frames written: a frozen or reversed hand (speed far below both inputs' over 0.5 s, or moving "
                    "against BODY's own hand), a warp slope outside 1/3-3x the mean rate, and an eq. 6.9 residual "
                    "above 60 deg after pass 2 are warnings on stderr ('mocomp splice: warning: ...', with body "
                    "frames); for a freeze it suggests two tolerant matching points, verified by splicing again. "
                    "Ends with the verdict of mocomp.audit on the frames written, against BODY.")
    p.add_argument("body", metavar="BODY", help="full-body recording (file or clip name)")
    p.add_argument("hand", metavar="HAND", help="hand/gesture recording (file or clip name)")
    p.add_argument("-o", "--out", required=True, metavar="OUT.bvh", help="output BVH file")
    p.add_argument("--match", type=_match_arg, action="append", default=[], metavar="B:H[~T]",
                   help="matching point: BODY frame B shows HAND frame H (0-based, each file's own frames), "
                        "optionally within T hand frames; repeat for several, in order (strictly increasing in "
                        "both). A point outside the pass-1 band reshapes the band around it (Algorithm 1); exact "
                        "points on every body frame work only if BODY and HAND have the same length")
    p.add_argument("--strict-points", action="store_true",
                   help="reject (exit 2) a matching point outside the pass-1 band, naming the point and the band's "
                        "hand frames at its body frame, instead of reshaping the band")
    p.add_argument("--side", choices=("right", "left", "both"), default="right", help="which arm (default right)")
    p.add_argument("--layer", choices=("arm", "forearm", "hand"), default="arm",
                   help="joints taken from HAND: the whole arm from the clavicle (default), forearm and below, "
                        "or wrist and below")
    p.add_argument("--phase-width", type=_fraction, default=0.30, metavar="F",
                   help="pass-1 band width as a fraction of BODY's length (default 0.30, the paper's 30%%; read as "
                        "the half-width W of eq. 6.3 unless --band-width-kind full)")
    p.add_argument("--refine-width", type=_fraction, default=0.10, metavar="F",
                   help="pass-2 band width as a fraction of BODY's length (default 0.10, the paper's 10%%; same reading)")
    p.add_argument("--band-width-kind", choices=("half", "full"), default="half",
                   help="how the band widths are read: 'half' (default, and every earlier version): W of eq. 6.3, "
                        "the band's extent on each side of the diagonal (a 30%% band then covers about 70-78%% of "
                        "the matrix); 'full': the band's whole width, W = width/2")
    p.add_argument("--subsequence", action="store_true",
                   help="open-begin/open-end alignment: find where in BODY the whole HAND gesture was performed "
                        "(subsequence DTW on the eq. 6.6 sign metric), splice it onto that interval only and report "
                        "the interval; BODY keeps its own arm elsewhere (eased in and out over half the blend window). "
                        "For a short hand clip and a long body take. Matching points must fall inside the interval")
    p.add_argument("--map", metavar="FILE.toml", dest="joint_map",
                   help="joint map for skeletons whose arm/hand joints are named differently: [joints] BODY_JOINT = "
                        "\"HAND_JOINT\" (and keep = [...] for body joints that keep their own rotation), optional "
                        "[arm.body.right] / [arm.hand.left] tables with clavicle, upper, forearm, hand. Without it, "
                        "joints pair by name, by the body model's naming conventions and by skeleton structure; "
                        "the error lists what stays unpaired")
    p.add_argument("--theta", choices=("window", "trunk", "none"), default="window",
                   help="rotation about the vertical before comparing: eq. 6.7 over 5-frame windows (default), "
                        "trunk-heading difference, or none")
    p.add_argument("--metric", choices=("sign", "values"), default="sign",
                   help="pass-1 metric: signs of derivatives (eq. 6.6, default) or their values")
    p.add_argument("--no-refine", action="store_true", help="skip the second (hand-angle) pass")
    p.add_argument("--frame-map", choices=("taut", "median"), default="taut",
                   help="frame correspondence taken from each pass: the least-distorting map through the tube of "
                        "near-optimal alignments (default), or the optimal path's row medians (the paper's, which "
                        "leaves staircases inside phases and holds)")
    p.add_argument("--body-fps", type=fps_arg, metavar="F", help="override BODY's frame rate")
    p.add_argument("--hand-fps", type=fps_arg, metavar="F", help="override HAND's frame rate")
    p.add_argument("--plot", metavar="PNG", help="write the bands, paths and frame map (Figure 6.3 style) to PNG, "
                                                   "with the quality checks' problem stretches shaded and suggested "
                                                   "matching points marked; with --side both, one row per arm")
    p.add_argument("--report", metavar="report.json",
                   help="write the report: per arm the passes, matched interval, phases, quality stretches (frozen or "
                        "reversed hand, warp slope, eq. 6.9 residual) with frames, the verified matching-point "
                        "suggestion, joint pairs, the final frame map; plus the audit of the written frames")
    add_audit_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    import json
    import sys

    from .. import datasets
    from ..io import write_bvh
    from ..splice import SpliceConfig, splice_motions
    from ._common import audit_output, finish_audit

    out = Path(args.out)
    if out.suffix.lower() != ".bvh":
        raise ValueError(f"output {out} must be a .bvh file")
    for f in (out, Path(args.plot) if args.plot else None, Path(args.report) if args.report else None):
        if f is not None and not f.parent.is_dir():
            raise FileNotFoundError(f"output folder {f.parent} does not exist")
    body = datasets.load(args.body, fps=args.body_fps)
    hand = datasets.load(args.hand, fps=args.hand_fps)
    cfg = SpliceConfig(phase_width=args.phase_width, refine_width=args.refine_width, theta=args.theta,
                       metric=args.metric, refine=not args.no_refine, frame_map=args.frame_map,
                       strict_points=args.strict_points, band_width_kind=args.band_width_kind,
                       subsequence=args.subsequence)
    res = splice_motions(body, hand, args.match, side=args.side, layer=args.layer, config=cfg,
                         joint_map=args.joint_map)
    write_bvh(res.motion, out)
    print(f"body {body.n_frames} frames at {body.fps:g} fps, hand {hand.n_frames} frames at {hand.fps:g} fps"
          + (f" (resampled to {res.hand_resampled[1]:g} fps)" if res.hand_resampled else ""))
    print(res.summary())
    print(f"wrote {out}: {', '.join(j for s in res.joints for j in res.joints[s])} from {args.hand}")
    for w in res.warnings():
        print(f"mocomp splice: warning: {w}", file=sys.stderr)
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ..plots.dtw import plot_alignments

        fig = plot_alignments(res.alignments, title=f"{Path(args.body).name} <- {Path(args.hand).name}",
                              quality=res.quality)
        fig.savefig(args.plot, dpi=110)
        plt.close(fig)
        print(f"wrote {args.plot} ({', '.join(res.alignments)} arm{'s' if len(res.alignments) > 1 else ''})")
    if args.report:
        d = res.to_dict()
        d["body"], d["hand"], d["output"] = str(args.body), str(args.hand), str(out)
        Path(args.report).write_text(json.dumps(d, indent=1) + "\n")
        print(f"wrote {args.report}")
    result = None if args.no_audit else audit_output(out, body, input_name=str(args.body))
    finish_audit(args, "splice", result, args.report)
    return 0
