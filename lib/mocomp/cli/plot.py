"""``mocomp plot FILE_OR_NAME -o out.png``: root trajectory and joint-speed overview."""
from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    from ._common import add_load_args

    p = sub.add_parser(
        "plot", help="plot the root trajectory (top/side views) and a joint-speed heat map",
        description="Write an overview figure of a motion: the root path seen from above and from the side "
                    "(height against distance along the main travel direction, with the lowest joint for the "
                    "floor), and every joint's speed over time as a heat map.")
    add_load_args(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="image file to write (.png, .pdf, .svg, ...)")
    p.add_argument("--dpi", type=int, default=120, help="resolution for raster images (default 120)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..plots.motion import motion_overview
    from ._common import check_output_path, load_from_args

    out = check_output_path(Path(args.output))
    if out.suffix.lower().lstrip(".") not in ("png", "pdf", "svg", "jpg", "jpeg", "eps", "ps", "tif", "tiff", "webp"):
        raise ValueError(f"output {out}: unknown image type {out.suffix!r}; use .png, .pdf or .svg")
    if not 10 <= args.dpi <= 1200:
        raise ValueError(f"--dpi must be 10-1200, got {args.dpi}")
    m = load_from_args(args)
    fig = motion_overview(m, title=f"{args.motion}: {m.n_frames} frames at {m.fps:g} fps")
    fig.savefig(out, dpi=args.dpi)
    print(f"wrote {out}")
    return 0
