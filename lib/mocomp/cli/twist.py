"""``mocomp twist INPUT --degrees 270``: a twist jump with another amount of rotation
(dissertation section 5.6, Fig. 5.7)."""
from __future__ import annotations

import argparse
import json
import math

from ._common import add_audit_arg, finite_float, float_in


def register(subparsers) -> None:
    from ._common import add_gravity_arg

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
    p.add_argument("--min-angle", type=float_in(0.0, 180.0, lo_open=True), default=20.0, metavar="DEG",
                   help="smallest rotation about L of the self-looping flight fragment that is repeated to add "
                        "rotation (default 20 deg; lower it for a jump that turns little in the air)")
    p.add_argument("--flight", type=int, nargs=2, metavar=("START", "STOP"), default=None,
                   help="flight frames [START, STOP) instead of detecting them. A detected flight shorter than "
                        "0.25 s or whose centre-of-mass parabola gives a gravity outside 7.0-13.7 m/s^2 is refused; "
                        "a flight given here is measured the same way but only warned about")
    add_gravity_arg(p)
    add_audit_arg(p)
    p.set_defaults(func=run)


#: Python-API hints in library error messages and the ``mocomp twist`` option that does the same
#: (as :data:`mocomp.cli.flips._CLI_HINTS` does for ``mocomp flips``)
_TWIST_HINTS = (
    ("this clip is not a flip (for small rotations such as twist jumps lower min_angle, e.g. prepare(..., "
     "loop_options={'min_angle': radians}))",
     "no fragment of this flight turns that much to be repeated (lower --min-angle DEG; a jump that hardly "
     "turns in the air cannot be made to turn more)"),
    ("give the flight frames explicitly (flight=(start, stop))", "give the flight frames explicitly "
     "(--flight START STOP)"),
)


def run(args: argparse.Namespace) -> int:
    from ..errors import MocompError

    try:
        return _run(args)
    except (MocompError, ValueError) as exc:
        text = str(exc)
        new = text
        for api, cli in _TWIST_HINTS:
            new = new.replace(api, cli)
        if new != text:
            exc.args = (new,) + tuple(exc.args[1:])
        raise


def _run(args: argparse.Namespace) -> int:
    from ..edit.twist import prepare_twist, reachable_range, twist_jump
    from ._common import audit_output, check_flight, finish_audit
    from .edit import check_output, write_motion

    out = check_output(args.output)
    P = prepare_twist(args.input, min_angle_deg=args.min_angle, flight=tuple(args.flight) if args.flight else None)
    check_flight(P, args, "twist")
    lo, hi = reachable_range(P, args.max_k)
    print(f"{P.name}: {abs(math.degrees(P.total_rotation)):.0f} deg twist jump, flight frames "
          f"{P.flight[0]}-{P.flight[1] - 1}; reachable about {lo:.0f}-{hi:.0f} deg")
    res = twist_jump(args.input, args.degrees, prepared=P, max_k=args.max_k, gravity=args.gravity)
    widened = write_motion(res.motion, out)
    print("planned (the method's model values; the audit line at the end measures the frames written):")
    print(res.summary())
    print(f"wrote {out} ({res.motion.n_frames} frames at {res.motion.fps:g} Hz)"
          + (f"; {', '.join(widened)} written with three rotation channels (turned off their hinge)" if widened else ""))
    if args.report:
        with open(args.report, "w") as fh:
            json.dump(res.report(), fh, indent=1)
        print(f"wrote {args.report}")
    result = None if args.no_audit else audit_output(out, P.motion, input_name=str(args.input))
    finish_audit(args, "twist", result, args.report)
    return 0
