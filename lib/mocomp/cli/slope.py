"""``mocomp slope IN --degrees 10 -o OUT.bvh``: a motion rotated onto a slope."""
from __future__ import annotations


def register(sub) -> None:
    from ._common import add_load_args, float_in
    from .footplant import add_output_args

    p = sub.add_parser(
        "slope", help="rotate a motion onto a slope (the touch-up paper's walk uphill input)",
        description="Rotate the whole motion rigidly about a horizontal axis through its first ground point, "
                    "perpendicular to its travel, so that the ground it walks on rises by DEG degrees ahead "
                    "(negative: downhill). The body leans back relative to gravity as the paper's input does. "
                    "Ends with the verdict of mocomp.audit on the frames written, against the input (the audit "
                    "assumes a horizontal floor, so it sees the climb).")
    add_load_args(p)
    p.add_argument("--degrees", type=float_in(-90, 90, lo_open=True, hi_open=True, what="slope"), required=True,
                   metavar="DEG", help="slope in degrees, positive uphill")
    add_output_args(p, "the motion on the slope")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..ops import slope
    from ._common import load_from_args
    from .footplant import check_outputs, finish

    out = check_outputs(args)
    m = load_from_args(args)
    r = slope(m, args.degrees)
    print(f"slope {r.degrees:+g} deg about axis ({r.axis[0]:+.3f}, {r.axis[1]:+.3f}, {r.axis[2]:+.3f}) through "
          f"({r.pivot[0]:.3f}, {r.pivot[1]:.3f}, {r.pivot[2]:.3f}) m; root climbs {r.climb:+.3f} m")
    return finish(args, "slope", out, r.motion, m, {"slope": r.to_dict()})
