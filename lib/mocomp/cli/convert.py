"""``mocomp convert IN OUT.bvh``: any readable motion to BVH, with unit and frame-rate overrides."""
from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    from ._common import add_load_args, scale_arg

    p = sub.add_parser(
        "convert", help="convert any readable motion (or named clip) to BVH",
        description="Read a motion (BVH, ASF/AMC, DeepMimic, an embedded example or a named real clip) and write "
                    "it as BVH. --scale/--fps override the input's length unit and frame rate (some real clips "
                    "have wrong frame-rate headers); --out-scale sets the output file's length unit.")
    add_load_args(p)
    p.add_argument("out", metavar="OUT", help="output BVH file (.bvh)")
    p.add_argument("--out-scale", type=scale_arg, default=1.0, metavar="S|UNIT",
                   help="metres per output file unit, or a unit name (default 1: metres)")
    p.add_argument("--precision", type=int, default=8, metavar="N",
                   help="decimals written per value (default 8: round trips within 1e-6 m)")
    p.add_argument("--drop-static-root", action="store_true",
                   help="do not write back the static root joint that loading removed (Bandai's joint_Root "
                        "above Hips); by default the output keeps the input's hierarchy and channel layout")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..io import UNITS, write_bvh
    from ._common import check_output_path, load_from_args

    out = Path(args.out)
    if out.suffix.lower() != ".bvh":
        raise ValueError(f"output {out} must be a .bvh file (BVH is the only output format)")
    check_output_path(out)
    if args.out_scale == "auto":
        raise ValueError("--out-scale needs a number or a unit name, not 'auto'")
    if not 1 <= args.precision <= 15:
        raise ValueError(f"--precision must be 1-15 decimals, got {args.precision}")
    scale = UNITS[args.out_scale] if isinstance(args.out_scale, str) else float(args.out_scale)
    m = load_from_args(args)
    write_bvh(m, out, scale=scale, precision=args.precision, restore_root=not args.drop_static_root)
    print(f"wrote {out}: {m.skeleton.n_joints} joints, {m.n_frames} frames at {m.fps:g} fps, "
          f"{scale:g} m per file unit")
    return 0
