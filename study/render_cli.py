"""``mocomp study render SPEC -o DIR``: render a stimulus set and write its manifest.

:func:`register_render` adds the ``render`` sub-command to the ``study``
command's sub-parsers (``lib/mocomp/cli/study.py`` calls it).
"""
from __future__ import annotations

import argparse
import sys

__all__ = ["register_render", "run_render"]


def register_render(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "render", help="render a stimulus specification (videos, posters, manifest.csv)",
        description="Render every stimulus of a specification (e.g. stimuli/paper_table2.toml) headless "
                    "(VTK EGL/OSMesa) as H.264 MP4 + poster PNG, and write DIR/manifest.csv with the "
                    "nominal and the measured (achieved) error of each stimulus. Stimuli whose content "
                    "hash is unchanged are not rendered again.")
    p.add_argument("spec", help="stimulus specification (.toml or .json)")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--force", action="store_true", help="re-render every stimulus")
    p.add_argument("--skip-missing-data", action="store_true",
                   help="drop bases whose real clips are missing (MOCOMP_DATA_DIR unset) instead of failing")
    p.add_argument("--only", nargs="+", metavar="ID", help="render only these stimulus ids (previews)")
    p.add_argument("--backend", choices=("egl", "osmesa"), default=None,
                   help="VTK offscreen window (default: $VTK_DEFAULT_OPENGL_WINDOW or EGL)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run_render)
    return p


def run_render(args) -> int:
    from mocomp.plots.render3d import configure_offscreen

    from .render import render_stimulus_set

    configure_offscreen(args.backend)
    rep = render_stimulus_set(args.spec, args.out, force=args.force, skip_missing_data=args.skip_missing_data,
                              only=args.only, progress=not args.no_progress)
    for n in rep.notes:
        print(f"note: {n}", file=sys.stderr)
    m = rep.manifest
    print(f"{len(m)} stimuli -> {rep.manifest_path} ({len(rep.rendered)} rendered, {len(rep.skipped)} unchanged); "
          f"{rep.frames} frames in {rep.render_seconds:.1f} s"
          + (f" = {rep.frames_per_second:.1f} frames/s" if rep.frames else "")
          + f"; total {rep.seconds:.1f} s")
    pert = m[m["perturbation"] != "none"]
    if len(pert):
        dev = (pert["achieved_error"] - pert["nominal_level"]).abs()
        worst = pert.loc[dev.idxmax()]
        print(f"achieved vs nominal error: median |difference| {dev.median():.2f} points, "
              f"largest {dev.max():.2f} ({worst['stimulus_id']}: nominal {worst['nominal_level']:g}%, "
              f"achieved {worst['achieved_error']:.2f}%)")
    return 0
