"""``mocomp join A B``: the take-off of flight A joined in mid-air with the landing of flight B
(flips paper section 6, Fig. 4c; dissertation Fig. 5.8)."""
from __future__ import annotations

import argparse
import json

from ._common import add_audit_arg, float_in


def register(subparsers) -> None:
    from .edit import add_restore_args

    p = subparsers.add_parser(
        "join", help="join the take-off of one flight with the landing of another in mid-air",
        description="Join two ballistic motions of the same skeleton in mid-flight (Majkowska & Faloutsos "
                    "2007, section 6): turn B so the angular momenta point the same way (about the vertical, "
                    "and fully if needed, which tilts its landing), retime so |L| matches, find the most "
                    "similar pair of flight frames (App. A), blend, then restore |L| by non-uniform retiming, "
                    "retime by k* and reposition the centre of mass on the gravity parabola. "
                    "Limitation: at the seam the two bodies are oriented differently about an axis "
                    "perpendicular to L (a back flip vs a side flip: 60-100 deg); blending that away turns L "
                    "off its direction over the transition (0.6 rad synthetic, 1.2-1.3 rad DeepMimic joins), "
                    "and --direction-step, which removes it, tilts the landing instead (18-130 deg). The "
                    "summary and report give the seam evidence (direction error at the seam, |L| error, COM "
                    "velocity jumps at take-off and landing against the inputs' own) and list the bounds "
                    "exceeded as notes (the model's planned values); the output ends with the verdict of mocomp.audit on "
                    "the frames written, against both inputs. A join whose frames the audit finds worse than its "
                    "inputs (violations they do not have: L turning at the seam, COM velocity jumps, feet below the "
                    "floor, ...) is not physically valid and is refused (exit 2, naming the findings); --force "
                    "writes it anyway, with the warning.")
    p.add_argument("takeoff", metavar="A", help="motion whose take-off is used (file or clip name)")
    p.add_argument("landing", metavar="B", help="motion whose landing is used (file or clip name)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="joined motion (BVH)")
    p.add_argument("--report", metavar="report.json", help="write the report (alignment, seam, errors)")
    p.add_argument("--match", choices=("takeoff", "landing", "mean"), default="takeoff",
                   help="which |L| both parts are retimed to (default: A's)")
    p.add_argument("--max-tilt", type=float_in(0.0, 180.0), default=45.0, metavar="DEG",
                   help="largest landing tilt accepted for a full alignment of L (default 45)")
    p.add_argument("--no-full-alignment", action="store_true",
                   help="refuse flights whose L differ after the turn about the vertical")
    p.add_argument("--direction-step", action="store_true",
                   help="also restore L's direction across the transition (eq. 5.21; turns the landing)")
    p.add_argument("--no-upright", action="store_true", help="keep a tilted landing instead of easing it out")
    for role, letter in (("takeoff", "A"), ("landing", "B")):
        p.add_argument(f"--{role}-flight", type=int, nargs=2, metavar=("START", "STOP"), default=None,
                       help=f"{letter}'s flight frames [START, STOP) instead of detecting them. A detected flight "
                            "shorter than 0.25 s or whose centre-of-mass parabola gives a gravity outside "
                            "7.0-13.7 m/s^2 is refused; a flight given here is measured the same way but only "
                            "noted")
    add_restore_args(p)
    p.add_argument("--force", action="store_true",
                   help="write the joined motion even when the audit of its frames finds violations its inputs do "
                        "not have (by default such a join is refused: it is not physically valid)")
    add_audit_arg(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import os

    from ..edit.join import join_flights, load_part
    from ..errors import ImplausibleFlightError, JoinError
    from ._common import audit_output, finish_audit
    from .edit import check_output, write_motion

    out = check_output(args.output)
    if args.no_audit and not args.force:
        raise JoinError("--no-audit skips the audit of the joined frames that decides whether the join is physically "
                        "valid; add --force to write it unchecked")
    flights = tuple(None if f is None else tuple(f) for f in (args.takeoff_flight, args.landing_flight))
    try:
        res = join_flights(args.takeoff, args.landing, flights=flights, match=args.match,
                           full_alignment=not args.no_full_alignment, max_tilt_deg=args.max_tilt,
                           k_ratio=args.k_ratio, k=args.k, takeoff_height=args.takeoff_height,
                           upright=not args.no_upright, direction_step=args.direction_step,
                           gravity=args.gravity)
    except ImplausibleFlightError as e:         # the Python API's override hint -> the CLI option
        if e.check is not None and e.source in ("takeoff", "landing"):
            name = args.takeoff if e.source == "takeoff" else args.landing
            e.args = (e.check.describe(str(name), override=f"--{e.source}-flight START STOP",
                                       fps_hint="convert it first: mocomp convert IN OUT.bvh --fps F"),)
        raise
    print("planned (the method's model values; the audit line at the end measures the frames written):")
    print(res.summary())
    # the frames are written next to the output first and audited there (read back): a join whose
    # frames are worse than its inputs is refused unless --force
    tmp = out.with_name(f".{out.stem}.{os.getpid()}.partial.bvh")
    result = None
    try:
        widened = write_motion(res.motion, tmp)
        if not args.no_audit:
            # against the inputs as the join used them (key-framed clips resampled, as load_part does)
            result = audit_output(tmp, load_part(args.takeoff)[0], name=str(out), input_name=str(args.takeoff),
                                  other_inputs=((str(args.landing), load_part(args.landing)[0]),))
            if result.new and not args.force:
                raise JoinError(f"the joined motion is not physically valid, so {out} was not written: "
                                f"{result.warning}; --force writes it anyway")
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            tmp.unlink()
    print(f"wrote {out} ({res.motion.n_frames} frames at {res.motion.fps:g} Hz)"
          + (f"; {', '.join(widened)} written with three rotation channels (turned off their hinge)" if widened else ""))
    if args.report:
        d = res.report()
        d["refusal"] = {"refused_without_force": bool(result is not None and result.new), "forced": bool(args.force),
                        "rule": "refused when the audit of the joined frames finds violations (by check and place) "
                                "that neither input has, or has smaller (mocomp audit's new-or-worse rule)"}
        with open(args.report, "w") as fh:
            json.dump(d, fh, indent=1)
        print(f"wrote {args.report}")
    finish_audit(args, "join", result, args.report)
    return 0
