"""``mocomp audit FILE_OR_NAME [--against ORIGINAL] [--report r.json] [--plot audit.png]``: the
physical validity of a motion, measured from its frames only (:func:`mocomp.audit.audit`)."""
from __future__ import annotations

import json
from pathlib import Path

_IMAGE_TYPES = ("png", "pdf", "svg", "jpg", "jpeg")


def register(sub) -> None:
    from ._common import add_load_args, int_in

    p = sub.add_parser(
        "audit", help="measure a motion's physical validity from its frames (penetration, slide, momentum "
                      "jumps, ballistic fits, L spread, ZMP, kinematic sanity)",
        description="Audit a motion from its frames alone, with no knowledge of the method that made it: phases "
                    "and contacts (the project's detector), floor penetration and foot slide per contact, COM "
                    "velocity / linear momentum jumps at every frame (take-off and landing singled out), per "
                    "flight the ballistic fit (fitted g with its 95%% interval, the residual to a g = 9.81 "
                    "parabola), the spread of the direction of L and the variation of |L|, the take-off angle, "
                    "per ground stage the ZMP distance outside the support polygon (touch-up paper eq. 4), and "
                    "bone lengths, joint rotation rates and jumps between frames. Each finding states its "
                    "frames, size and the threshold it exceeds (defaults: mocomp.audit.AuditThresholds; change "
                    "them with --threshold NAME=VALUE). With --against the same measures of the original are "
                    "shown beside the audited motion's, flagged where it is worse (flights paired by time, "
                    "spurious one- or two-frame airborne runs left out), and each joint's rotation rate is "
                    "compared with the original's own on the corresponding frames (pose jumps). "
                    "--external-force A:B declares frames under an external force (a hit).")
    add_load_args(p)
    p.add_argument("--against", metavar="ORIGINAL",
                   help="the motion this one was made from (file or name, loaded with the same options): each "
                        "measure of both side by side")
    p.add_argument("--report", metavar="r.json", help="write the full report as JSON")
    p.add_argument("--plot", metavar="audit.png",
                   help="write a figure: COM height with the ballistic fits, COM velocity with the jumps, "
                        "lowest body point with the penetration, ZMP distance outside the support polygon")
    p.add_argument("--threshold", action="append", default=[], metavar="NAME=VALUE",
                   help="change one threshold of mocomp.audit.AuditThresholds (repeatable), e.g. "
                        "--threshold penetration=0.03 --threshold floor_y=0.0")
    p.add_argument("--external-force", action="append", default=[], metavar="A:B",
                   help="frames A to B-1 of the audited motion are under an external force (a hit, a push; "
                        "repeatable, or A:B,C:D): airborne frames there are 'forced', not free flight, so they are "
                        "not judged against ballistic gravity or L conservation, and findings of the force-dependent "
                        "checks there are reported as expected, not as violations")
    p.add_argument("--max-findings", type=int_in(0), default=20, metavar="N",
                   help="findings listed in the summary (all are in the JSON report; default 20)")
    p.add_argument("--strict", action="store_true", help="exit with status 1 when the verdict is fail")
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import datasets
    from ..audit import AuditThresholds, audit
    from ._common import check_output_path, load_from_args

    from ..audit.force import parse_frame_ranges

    th = AuditThresholds.from_strings(args.threshold)
    forced = parse_frame_ranges(args.external_force) or None
    report_path = check_output_path(Path(args.report), "report") if args.report else None
    plot_path = None
    if args.plot:
        plot_path = check_output_path(Path(args.plot), "plot")
        if plot_path.suffix.lower().lstrip(".") not in _IMAGE_TYPES:
            raise ValueError(f"plot {plot_path}: unknown image type {plot_path.suffix!r}; use .png, .pdf or .svg")
    m = load_from_args(args)
    other = None
    if args.against is not None:
        other = datasets.load(args.against, fps=args.fps, scale=args.scale, raw=args.raw)
    rep = audit(m, thresholds=th, against=other, name=str(args.motion), against_name=args.against,
                external_force_frames=forced)
    print("\n".join(rep.summary_lines(max_findings=args.max_findings)))
    if report_path is not None:
        report_path.write_text(json.dumps(rep.to_dict(), indent=2) + "\n")
        print(f"wrote {report_path}")
    if plot_path is not None:
        import matplotlib

        matplotlib.use("Agg")
        from ..plots.audit import plot_audit

        fig = plot_audit(rep, against=getattr(rep, "against", None))
        fig.savefig(plot_path, dpi=110)
        print(f"wrote {plot_path}")
    return 1 if (args.strict and rep.verdict == "fail") else 0
