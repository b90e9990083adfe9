"""``mocomp demo``: the main job on the embedded default data.

The synthetic (physically exact) single back somersault becomes a double back
somersault (flips paper, Fig. 4a): BVH, a filmstrip and the physics report.
"""
from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "demo", help="embedded synthetic back flip -> double back flip (BVH, filmstrip, physics report)",
        description="Run the flagship method on the embedded default data: the synthetic single back "
                    "somersault (generated, physically exact) becomes a double back somersault that "
                    "conserves angular momentum. Writes backflip_x2.bvh (and the original), a "
                    "filmstrip PNG, momentum.png and report.json to the output folder and prints the "
                    "physics report.")
    p.add_argument("-o", "--out", default="demo-out", help="output folder (default: demo-out)")
    p.add_argument("--flips", type=int, default=2, help="number of somersaults to make (default 2)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..flips import demo

    if args.flips < 2:
        raise ValueError(f"--flips must be at least 2 (the demo's input is a single flip and the result has "
                         f"--flips somersaults in total), got {args.flips}")
    demo(args.out, flips=args.flips)
    return 0
