"""``mocomp study render SPEC -o DIR``: render a stimulus set and write its manifest.

:func:`register_render` adds the ``render`` sub-command to the ``study``
command's sub-parsers (``lib/mocomp/cli/study.py`` calls it).
"""
from __future__ import annotations

import argparse
import sys

__all__ = ["register_render", "run_render"]


def register_render(subparsers) -> argparse.ArgumentParser:
    from mocomp.cli._common import int_in

    p = subparsers.add_parser(
        "render", help="render a stimulus specification (videos, posters, manifest.csv)",
        description="Render every stimulus of a specification (e.g. stimuli/paper_table2.toml) headless "
                    "(VTK EGL/OSMesa) as H.264 MP4 + poster PNG, and write DIR/manifest.csv with the "
                    "nominal and the measured (achieved) error of each stimulus, and the verdict and counts of "
                    "mocomp.audit on each stimulus' motion against its unperturbed source (audit_* columns; "
                    "the summary ends with them, and a warning names unperturbed stimuli with violations "
                    "their source lacks). Stimuli whose content hash is unchanged are not rendered again.")
    p.add_argument("spec", help="stimulus specification (.toml or .json)")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--force", action="store_true", help="re-render every stimulus")
    p.add_argument("--skip-missing-data", action="store_true",
                   help="drop bases whose real clips are missing (MOCOMP_DATA_DIR unset) instead of failing")
    p.add_argument("--only", nargs="+", metavar="ID", help="render only these stimulus ids (previews)")
    p.add_argument("--backend", choices=("egl", "osmesa"), default=None,
                   help="VTK offscreen window (default: $VTK_DEFAULT_OPENGL_WINDOW or EGL)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int_in(0, 512), default=0, metavar="N",
                   help="render on a local Dask cluster of N worker processes, as mocomp batch does (default 0: "
                        "in this process)")
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="render on an existing Dask cluster (its workers must see the output folder)")
    p.set_defaults(func=run_render)
    return p


def run_render(args) -> int:
    from mocomp.plots.render3d import configure_offscreen

    from .render import render_stimulus_set

    configure_offscreen(args.backend)
    rep = render_stimulus_set(args.spec, args.out, force=args.force, skip_missing_data=args.skip_missing_data,
                              only=args.only, progress=not args.no_progress, workers=args.workers,
                              scheduler=args.scheduler)
    for n in rep.notes:
        print(f"note: {n}", file=sys.stderr)
    m = rep.manifest
    print(f"{len(m)} stimuli -> {rep.manifest_path} ({len(rep.rendered)} rendered, {len(rep.skipped)} unchanged); "
          f"{rep.frames} frames in {rep.render_seconds:.1f} s"
          + (f" = {rep.frames_per_second:.1f} frames/s" if rep.frames else "")
          + f"; total {rep.seconds:.1f} s")
    _print_audit(m)
    pert = m[m["perturbation"] != "none"]
    if len(pert):
        dev = (pert["achieved_error"] - pert["nominal_level"]).abs()
        worst = pert.loc[dev.idxmax()]
        unit = "deg" if worst.get("level_unit") == "deg" else "%"
        print(f"achieved vs nominal error: median |difference| {dev.median():.2f} points, "
              f"largest {dev.max():.2f} ({worst['stimulus_id']}: nominal {worst['nominal_level']:g}{unit}, "
              f"achieved {worst['achieved_error']:.2f}{unit})")
        _print_cues(m)
    return 0


def _print_cues(m) -> None:
    """The confounds besides the nominal error, measured (manifest ``cue_*`` columns): the largest change
    of flight time, jump height and take-off angle, and the range of rotation-speed ratios at touchdown."""
    if "cue_flight_change_s" not in m.columns:
        return
    for pert, g in m[m["perturbation"] != "none"].groupby("perturbation", sort=False):
        def mx(c):
            v = g[c].abs().max()
            return float("nan") if v != v else float(v)
        print(f"  cues {pert}: |flight time change| <= {mx('cue_flight_change_s'):.3f} s, |apex change| <= "
              f"{mx('cue_apex_change_m'):.3f} m, |take-off angle change| <= {mx('cue_takeoff_angle_change_deg'):.2f} "
              f"deg, landing rotation ratio {g['cue_landing_rotation_ratio'].min():.2f}-"
              f"{g['cue_landing_rotation_ratio'].max():.2f}")


def _print_audit(m) -> None:
    """The audit's part of the summary: verdicts of the stimuli against their sources, the new
    violations per perturbation, and a warning naming unperturbed stimuli with new violations (an
    unperturbed stimulus should be as physical as its source; a perturbed one is meant not to be)."""
    from collections import Counter

    n_fail = int((m["audit_verdict"] == "fail").sum())
    n_pass = int((m["audit_verdict"] == "pass").sum())
    print(f"audit (each stimulus against its unperturbed source): {n_pass} pass, {n_fail} fail"
          + (f", {len(m) - n_pass - n_fail} not audited (see the notes)" if n_pass + n_fail < len(m) else ""))
    m = m[m["audit_verdict"].isin(("pass", "fail"))]
    m = m.assign(audit_new_violations=m["audit_new_violations"].astype(float))
    for pert, g in m.groupby("perturbation", sort=False):
        checks: Counter = Counter()
        for text in g["audit_new_checks"].fillna(""):
            for item in filter(None, str(text).split(";")):
                k, _, v = item.partition(":")
                checks[k] += int(v)
        with_new = int((g["audit_new_violations"] > 0).sum())
        print(f"  {pert}: {with_new} of {len(g)} with violations new or worse than their source"
              + (f" ({', '.join(f'{k} {v}' for k, v in checks.items())})" if checks else ""))
    bad = m[(m["perturbation"] == "none") & (m["audit_new_violations"] > 0)]
    if len(bad):
        names = "; ".join(f"{r.stimulus_id} ({r.audit_new_checks})" for r in bad.itertuples())
        print(f"mocomp study render: warning: {len(bad)} unperturbed stimulus(es) with violations their source "
              f"lacks: {names}", file=sys.stderr)
