"""``mocomp render FILE [--against OTHER] -o out.mp4|out.gif|strip.png [--frames A:B]
[--camera side|front|top|follow]``: a motion drawn with what :func:`mocomp.audit.audit` measured on its
frames (:func:`mocomp.plots.render_audit.render_with_audit`), side by side with another."""
from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> None:
    from ..plots.render_audit import CAMERAS
    from ._common import add_load_args, frames_arg, size_arg

    p = sub.add_parser(
        "render", help="draw a motion with its audit (penetration, contacts, COM path, ballistic fits, time bar): "
                       "MP4, GIF or a phase filmstrip PNG, side by side with another",
        description="Render a motion offscreen (VTK EGL/OSMesa, no display) with the findings of mocomp.audit "
                    "drawn: the audit's floor on the ground plane (translucent, so what goes below it shows), "
                    "body parts more than the penetration threshold below the floor in red with their depth, a "
                    "green disc under each planted contact, the COM path with each flight's ballistic fit (blue) "
                    "and red rings at COM velocity jumps, and a time bar with the phases (flights blue) and the "
                    "violations (red) and advisories (orange) over their frames. A .png output is a filmstrip "
                    "whose poses are chosen by phase (take-off, apex and landing of each flight with poses "
                    "between them, the deepest crouch of each ground stage, first and last frame), never by "
                    "uniform time. With --against the other motion is drawn beside it (below it in a filmstrip), "
                    "at the same times, with the same camera.")
    add_load_args(p)
    p.add_argument("--against", metavar="OTHER",
                   help="a second motion (file or name, loaded with the same options) drawn beside the first, "
                        "e.g. the input of an edit")
    p.add_argument("-o", "--output", required=True, metavar="OUT.mp4|OUT.gif|STRIP.png",
                   help="what to write, by extension: .mp4 (H.264 video; at most 60 frames/s: every k-th frame of "
                        "a faster clip), .gif (animated, at most 25 frames/s) or .png (phase filmstrip)")
    p.add_argument("--frames", type=frames_arg, metavar="A:B",
                   help="only frames A to B-1 of FILE (half-open like a Python slice; A: or :B leave an end open); "
                        "OTHER is shown over the same times. The audit always measures the whole motion")
    p.add_argument("--camera", choices=CAMERAS, default="side",
                   help="side: along the flights' mean angular momentum (the somersault axis) or across the travel; "
                        "front: facing the travel; top: from above; follow: the side view moving with the root "
                        "(default: side)")
    p.add_argument("--size", type=size_arg, default=(640, 480), metavar="WxH",
                   help="size of the 3-D view of one motion in pixels (even numbers; default 640x480; a filmstrip "
                        "tile is 3/8 x 2/3 of it)")
    p.add_argument("--threshold", action="append", default=[], metavar="NAME=VALUE",
                   help="change one threshold of mocomp.audit.AuditThresholds (repeatable), as in mocomp audit, "
                        "e.g. --threshold penetration=0.03")
    p.add_argument("--backend", choices=("egl", "osmesa"), default=None,
                   help="VTK offscreen window (default: $VTK_DEFAULT_OPENGL_WINDOW or EGL)")
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import datasets
    from ..audit import AuditThresholds, audit
    from ..plots.render3d import RenderStyle
    from ..plots.render_audit import render_with_audit
    from ._common import load_from_args, render_output_arg

    try:                    # checked before anything is loaded (the same check as every command's --render)
        out = render_output_arg(args.output)
    except argparse.ArgumentTypeError as e:
        raise ValueError(str(e)) from None
    th = AuditThresholds.from_strings(args.threshold)
    w, h = args.size
    style = RenderStyle(width=w, height=h, backend=args.backend)
    m = load_from_args(args)
    other = None
    if args.against is not None:
        other = datasets.load(args.against, fps=args.fps, scale=args.scale, raw=args.raw)
    rep = audit(m, thresholds=th, against=other, name=str(args.motion), against_name=args.against)
    res = render_with_audit(m, out, against=other, name=Path(str(args.motion)).name,
                            against_name=None if other is None else Path(str(args.against)).name,
                            frames=args.frames, camera=args.camera, style=style,
                            reports=(rep,) if other is None else (rep, rep.against))
    print(res.summary())
    for r in res.reports:
        print(f"audit of {r.name}: {r.verdict.upper()}, {len(r.violations)} violation(s), "
              f"{len(r.advisories)} advisory" + "".join(f"; {f.check} ({f.where}) {f.frames_text()}"
                                                         for f in r.violations[:6])
              + ("; ..." if len(r.violations) > 6 else ""))
    return 0
