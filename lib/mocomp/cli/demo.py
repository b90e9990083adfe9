"""``mocomp demo``: the main job on the embedded default data.

The synthetic (physically exact) single back somersault becomes a double back
somersault (flips paper, Fig. 4a): BVH, a filmstrip and the physics report.
"""
from __future__ import annotations


from ._common import add_audit_arg, positive_float


def register(sub) -> None:
    p = sub.add_parser(
        "demo", help="embedded synthetic back flip -> double back flip (BVH, filmstrip, physics report)",
        description="Run the flagship method on the embedded default data: the synthetic single back "
                    "somersault (generated, physically exact) becomes a double back somersault that "
                    "conserves angular momentum, at the paper's take-off speed k = 0.7 k* with the take-off and landing "
                    "stances reshaped so the centre of mass has no velocity jump (--takeoff repair); the flight "
                    "falls at g = 9.81 m/s^2. Writes backflip_x2.bvh (and the original), a "
                    "filmstrip PNG, momentum.png and report.json to the output folder and prints the "
                    "physics report (the model's planned values), ending with the verdict of mocomp.audit on "
                    "the frames written, against the single flip.")
    p.add_argument("-o", "--out", default="demo-out", help="output folder (default: demo-out)")
    p.add_argument("--flips", type=int, default=2, help="number of somersaults to make (default 2)")
    p.add_argument("--k-ratio", type=positive_float, default=None,
                   help="retiming factor as a fraction of k* (default 0.7, the paper's; 1 = k*, continuous without "
                        "reshaping the stances)")
    p.add_argument("--takeoff", choices=("as-is", "repair"), default=None,
                   help="repair (default): reshape the take-off and landing stances so the COM reaches the new "
                        "flight's velocity smoothly; as-is: the paper's method alone (a COM velocity jump at "
                        "k < k*, which the audit reports). With neither option given and a stance that cannot "
                        "take the repair (e.g. --flips 3), the demo says so and uses k = k* as is")
    add_audit_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..flips import demo

    if args.flips < 2:
        raise ValueError(f"--flips must be at least 2 (the demo's input is a single flip and the result has "
                         f"--flips somersaults in total), got {args.flips}")
    d = demo(args.out, flips=args.flips, k_ratio=args.k_ratio, takeoff=args.takeoff)
    result = None
    if not args.no_audit:
        from ..io.bvh import read_bvh
        from ._common import audit_output

        original = read_bvh(d["paths"]["original_bvh"], scale=1.0)
        result = audit_output(d["paths"]["bvh"], original, input_name=str(d["paths"]["original_bvh"]))
    from ._common import finish_audit

    finish_audit(args, "demo", result, d["paths"]["report"])
    return 0
