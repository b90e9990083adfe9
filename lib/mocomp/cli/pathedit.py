"""``mocomp pathedit IN --curve "x,z;..." | --curve-file F.csv [--turn DEG] -o OUT.bvh``: a motion
moved onto a new ground path."""
from __future__ import annotations


def register(sub) -> None:
    from ._common import add_load_args, float_in
    from .footplant import add_output_args

    p = sub.add_parser(
        "pathedit", help="move a motion onto a new ground path (heading along the tangent, feet planted)",
        description="Replace the motion's ground path (its root track smoothed over 0.5 s) by a curve: a spline "
                    "through the given points (x,z in metres, y-up world), or a polyline with --polyline. The "
                    "motion walks the curve at its own arc length from the curve's first point, facing along the "
                    "tangent, with its sway and bounce kept; the planted feet are held again. Past the curve's end "
                    "it continues straight. --turn DEG alone bends the motion's own path into an arc turning DEG "
                    "(positive: left); with a curve it turns the curve about its first point. A curve whose "
                    "direction reverses on the spot (cusp) is refused. Ends with the verdict of mocomp.audit on "
                    "the frames written, against the input.")
    add_load_args(p)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--curve", metavar='"x,z;x,z;..."', help="points of the new path, metres")
    g.add_argument("--curve-file", metavar="F.csv", help="CSV of x,z rows (optional header x,z)")
    p.add_argument("--turn", type=float_in(-3600, 3600, what="angle"), metavar="DEG",
                   help="arc turning DEG over the motion's path (alone), or the curve turned by DEG")
    p.add_argument("--polyline", action="store_true", help="straight segments between the points (default: spline)")
    p.add_argument("--contacts", metavar="FILE.csv", help="foot plants instead of the detector's (joint,start,stop)")
    add_output_args(p, "the path-edited motion")
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from ..ops.path import PathCurve, motion_path, path_edit
    from ._common import load_from_args
    from .footplant import check_outputs, finish

    out = check_outputs(args)
    m = load_from_args(args)
    if args.curve is None and args.curve_file is None and args.turn is None:
        raise ValueError("give the new path: --curve \"x,z;x,z;...\", --curve-file F.csv or --turn DEG")
    kind = "polyline" if args.polyline else "spline"
    if args.curve is not None:
        curve = PathCurve.parse(args.curve, kind)
    elif args.curve_file is not None:
        curve = PathCurve.read_csv(args.curve_file, kind)
    else:
        path, s, psi = motion_path(m)
        curve = PathCurve.arc(float(s[-1]), np.radians(args.turn), start=path[0], heading=float(psi[0]))
    if args.turn is not None and (args.curve is not None or args.curve_file is not None):
        curve = curve.rotated(args.turn)
    r = path_edit(m, curve, contacts=args.contacts)
    print(f"path {r.path_length:.2f} m onto a {curve.kind} of {r.curve_length:.2f} m; heading changed by "
          f"{np.degrees(r.turn):+.1f} deg (at most {np.degrees(r.heading_rate_max):.0f} deg/s)")
    sb, sa = r.step_before, r.step_after
    if sb.size and sa.size:
        print(f"step length {sb.mean():.3f} -> {sa.mean():.3f} m (mean of {sa.size})")
    if r.footplants is not None:
        fp = r.footplants
        print(f"feet: largest slide within plants {fp.slide_before.max() * 100:.2f} (moved, before planting) -> "
              f"{fp.slide_after.max() * 100:.2f} cm")
    for n in r.notes:
        print(n)
    return finish(args, "pathedit", out, r.motion, m, {"pathedit": r.to_dict()})
