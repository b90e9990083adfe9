"""``mocomp twist INPUT --degrees 270``: a twist jump with another amount of rotation
(dissertation section 5.6, Fig. 5.7)."""
from __future__ import annotations

import argparse
import json
import math

from ._common import add_audit_arg, finite_float, float_in


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "twist", help="turn a twist jump into one with more (or less) rotation",
        description="Make a twist jump of another angle from one twist jump (Majkowska 2007, section 5.6, "
                    "Fig. 5.7): repeat (or cut) a self-looping fragment of the flight rotated about L, keep L "
                    "constant over the new flight, retime by k* and reposition the centre of mass. Take-off "
                    "speed, rotation rate and jump height grow with the angle. Prints the reachable range when "
                    "the angle is out of it. Ends with the verdict of mocomp.audit on the frames written, "
                    "against the input.")
    p.add_argument("input", metavar="INPUT", help="twist jump: motion file or clip/example name (e.g. twist180)")
    p.add_argument("--degrees", type=finite_float, required=True, help="total rotation of the new jump, degrees")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="new motion (BVH)")
    p.add_argument("--report", metavar="report.json", help="write the report as JSON")
    p.add_argument("--max-k", type=float_in(1.0, lo_open=True), default=1.5,
                   help="largest uniform speed-up (and 1/x slow-down) of the take-off accepted, above 1 "
                        "(default 1.5)")
    p.add_argument("--flight", type=int, nargs=2, metavar=("START", "STOP"), default=None,
                   help="flight frames [START, STOP) instead of detecting them. A detected flight shorter than "
                        "0.25 s or whose centre-of-mass parabola gives a gravity outside 7.0-13.7 m/s^2 is refused; "
                        "a flight given here is measured the same way but only warned about")
    add_audit_arg(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..edit.twist import prepare_twist, reachable_range, twist_jump
    from ..io.bvh import write_bvh
    from ._common import audit_output, check_flight, finish_audit
    from .edit import check_output

    out = check_output(args.output)
    P = prepare_twist(args.input, flight=tuple(args.flight) if args.flight else None)
    check_flight(P, args, "twist")
    lo, hi = reachable_range(P, args.max_k)
    print(f"{P.name}: {abs(math.degrees(P.total_rotation)):.0f} deg twist jump, flight frames "
          f"{P.flight[0]}-{P.flight[1] - 1}; reachable about {lo:.0f}-{hi:.0f} deg")
    res = twist_jump(args.input, args.degrees, prepared=P, max_k=args.max_k)
    write_bvh(res.motion, out)
    print("planned (the method's model values; the audit line at the end measures the frames written):")
    print(res.summary())
    print(f"wrote {out} ({res.motion.n_frames} frames at {res.motion.fps:g} Hz)")
    if args.report:
        with open(args.report, "w") as fh:
            json.dump(res.report(), fh, indent=1)
        print(f"wrote {args.report}")
    result = None if args.no_audit else audit_output(out, P.motion, input_name=str(args.input))
    finish_audit(args, "twist", result, args.report)
    return 0
