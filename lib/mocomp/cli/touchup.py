"""``mocomp touchup IN -o OUT.bvh``: physical touch-up (Shin, Kovar & Gleicher 2003; issue 16)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def register(sub) -> None:
    from ._common import add_load_args, float_in, int_in
    from .footplant import add_output_args

    p = sub.add_parser(
        "touchup", help="add the balance an edit lost: ZMP into the support polygon, flights ballistic",
        description="Physical touch-up (Shin, Kovar & Gleicher 2003). Ground frames: rotate link sets so that the "
                    "ZMP (eq. 4) lands on the support polygon (closed form, eq. 6-7); flight frames: angular "
                    "momentum to the flight's average (eq. 8-9) and the COM onto the g = 9.81 parabola through "
                    "the flight's end points (eq. 10). Per-frame adjustments are damped, smoothed into "
                    "displacement maps and added step by step; the planted feet are held after every step. "
                    "Prints the stages, the planned ZMP distance and flight residuals per step, and ends with "
                    "the verdict of mocomp.audit on the frames written, against the input.")
    add_load_args(p)
    add_output_args(p, "the touched-up motion")
    p.add_argument("--schedule", default=None, metavar="NAME|FILE.toml",
                   help="ground-default, flight-default, uphill (ground-default with its first two steps "
                        "swapped, sec. 4.4), default (ground-default then flight-default; the default), or a TOML "
                        "file of [[step]] tables (stage, s1, s2, s3, sigma frames or sigma_s seconds, rho, "
                        "iterations, kernel)")
    p.add_argument("--contacts", metavar="FILE.csv",
                   help="planted intervals instead of the detector's (joint,start,stop; foot_l, toe_l, foot_r, "
                        "toe_r or the joint such a point rides on; frames 0-based, stop exclusive): they decide "
                        "the ground and flight frames")
    p.add_argument("--masses", default="table", metavar="fit|table|FILE.json",
                   help="segment masses: the body model's table (default); fit: fitted to this clip's ground "
                        "frames (sec. 3.2, eq. 5: for a clip known to be physically correct; the report's "
                        "'masses' then serve as --masses FILE for its edits); or a JSON file {segment: kg} (a "
                        "report with a 'masses' object is accepted)")
    p.add_argument("--iterations", type=int_in(1, 1000), metavar="N",
                   help="iterations of every step (default: the schedule's; ground-default 5, 5, 2 as in sec. 4.3)")
    p.add_argument("--polygon", choices=("contact", "planted"), default="contact",
                   help="support polygon of the touching foot points (the paper's contact region; default) or of "
                        "the planted ones (the audit's ZMP measure: it leaves a landing heel out while it moves)")
    p.add_argument("--max-angle", type=float_in(0, 180, lo_open=True, what="angle in degrees"), default=None,
                   metavar="DEG",
                   help="cap of a ground adjustment's per-frame turn (default 20; eq. 7's clamped frames otherwise "
                        "turn a limb by the angle of farthest reach, up to 90 deg)")
    p.add_argument("--plot", metavar="zmp.png", help="draw the ZMP distance per frame before/after and per iteration")
    p.set_defaults(func=run)


def read_masses(spec: str, body):
    """``table``: ``body`` as it is; a JSON file ``{segment: kg}`` naming every segment."""
    if spec == "table":
        return body
    path = Path(spec)
    if not path.is_file():
        raise FileNotFoundError(f"--masses {spec}: no such file (give 'table' or a JSON file {{segment: kg}})")
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ValueError(f"--masses {path}: not valid JSON: {e}") from e
    if isinstance(d, dict) and "masses" in d and isinstance(d["masses"], dict):
        d = d["masses"]
    if not isinstance(d, dict):
        raise ValueError(f"--masses {path}: expected an object {{segment: kg}}")
    names = list(body.segment_names)
    unknown = sorted(set(d) - set(names))
    missing = [n for n in names if n not in d]
    if unknown or missing:
        raise ValueError(f"--masses {path}: " + "; ".join(
            ([f"unknown segment(s) {', '.join(unknown)}"] if unknown else [])
            + ([f"missing segment(s) {', '.join(missing)}"] if missing else [])) + f" (segments: {', '.join(names)})")
    m = []
    for n in names:
        v = d[n]
        if not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
            raise ValueError(f"--masses {path}: segment {n!r}: mass must be a number >= 0 kg, got {v!r}")
        m.append(float(v))
    if sum(m) <= 0:
        raise ValueError(f"--masses {path}: the masses sum to 0 kg")
    return body.with_masses(np.array(m))


def _cm(x) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{x * 100:.2f} cm"


def run(args) -> int:
    from ..audit import default_body
    from ..ops.footplant import foot_points, plant_slides
    from ..touchup import touchup
    from ._common import check_output_path, load_from_args
    from .footplant import check_outputs, finish

    out = check_outputs(args)
    if args.plot:
        check_output_path(Path(args.plot), "plot")
    if args.contacts and not Path(args.contacts).is_file():
        raise FileNotFoundError(f"contact file {args.contacts} does not exist")
    if args.schedule and args.schedule.endswith(".toml") and not Path(args.schedule).is_file():
        raise FileNotFoundError(f"schedule file {args.schedule} does not exist")
    m = load_from_args(args)
    fit = None
    if args.masses == "fit":
        from ..touchup.masses import fit_masses

        fit = fit_masses(default_body(m), m, contacts=args.contacts)
        body = fit.body
        fd = fit.to_dict()
        print(f"masses fitted on {fit.frames} ground frames (eq. 5, CG, {fit.iterations} iterations): mean ZMP "
              f"outside {_cm(fd['mean_outside_m']['before'])} (table) -> {_cm(fd['mean_outside_m']['after'])}; "
              + ", ".join(f"{k} {fd['masses_kg']['table'][k]:.2f}->{v:.2f}" for k, v in fd["masses_kg"]["fitted"].items())
              + " kg")
    else:
        body = read_masses(args.masses, default_body(m))
    kw = {} if args.max_angle is None else {"max_angle_deg": args.max_angle}
    r = touchup(m, body, args.schedule, contacts=args.contacts, iterations=args.iterations, polygon=args.polygon, **kw)
    st = r.stages
    sd = st.to_dict()
    print(f"stages: {sd['ground_frames']} ground frame(s) in {len(sd['ground'])} run(s) {sd['ground']}; "
          f"flights {sd['flight']}" + ("" if sd["flight"] == sd["flights_adjusted"] else
                                       f" (adjusted: {sd['flights_adjusted']}; a flight at the clip's edge has no "
                                       "end point on the ground)"))
    for e, v in sd["plants"].items():
        print(f"  {e}: {len(v['intervals'])} plant(s) ({v['source']})")
    b = r.before
    print(f"planned ZMP outside the support polygon (ground frames): mean {_cm(b['mean_outside_m'])}, "
          f"max {_cm(b['max_outside_m'])}, {b['frames_outside']}/{b['frames']} frames outside (input)")
    for h in r.history:
        fl = "; ".join(f"flight {f['frames'][0]}-{f['frames'][1]}: COM {f['com_residual_m'] * 1000:.2f} mm off "
                       f"the parabola, |L| varies {f['L_variation'] * 100:.0f}%" for f in (h["flights"] or []))
        print(f"  step {h['step'] + 1}.{h['iteration'] + 1} [{h['label']}]: mean {_cm(h['mean_outside_m'])}, "
              f"max {_cm(h['max_outside_m'])}" + (f"; {fl}" if fl and h["label"].startswith("flight") else ""))
    for f0, f1 in zip(r.before["flights"], r.after["flights"]):
        print(f"planned flight {f0['frames'][0]}-{f0['frames'][1]}: COM off the g = 9.81 parabola "
              f"{f0['com_residual_m'] * 1000:.2f} -> {f1['com_residual_m'] * 1000:.2f} mm; |L| variation "
              f"{f0['L_variation'] * 100:.0f}% -> {f1['L_variation'] * 100:.0f}%")
    ncl = {k: len(v) for k, v in r.clamped.items() if v}
    print("clamped frames (eq. 7, ZMP as close as the rotation reaches): "
          + ("; ".join(f"{k}: {n}" for k, n in ncl.items()) if ncl else "none"))
    ncp = {k: len(v) for k, v in (r.capped or {}).items() if v}
    print("capped frames (per-frame turn cut to the cap): " + ("; ".join(f"{k}: {n}" for k, n in ncp.items()) if ncp else "none"))
    if r.lifted:
        print("legs held by IK (a touching foot point off its input height, a free one below its resting level, "
              "a foot point in a flight below its input height): "
              + "; ".join(f"{side}: {len(v)} frame(s)" for side, v in r.lifted.items()))
    P0, G0 = m.fk()
    P1, G1 = r.motion.fk()
    slide0 = plant_slides(foot_points(P0, G0, st.plants), st.plants)
    slide1 = plant_slides(foot_points(P1, G1, st.plants), st.plants)
    dq = np.abs(np.einsum("tjk,tjk->tj", m.rotations, r.motion.rotations)).clip(0, 1)
    ang = np.degrees(2 * np.arccos(dq))
    print(f"planned foot slide within the plants: {slide0.max() * 100:.2f} -> {slide1.max() * 100:.2f} cm; "
          f"joint-angle change mean {ang.mean():.2f} deg, max {ang.max():.2f} deg; {r.seconds:.3f} s")
    report = {"touchup": r.to_dict(), "masses": dict(zip(body.segment_names, map(float, body.masses))),
              "masses_source": args.masses, "mass_fit": None if fit is None else fit.to_dict(), "polygon": args.polygon,
              "planned_footplant_slide_m": {"before": dict(zip(st.plants.effectors, slide0.tolist())),
                                            "after": dict(zip(st.plants.effectors, slide1.tolist()))},
              "planned_joint_angle_change_deg": {"mean": float(ang.mean()), "max": float(ang.max())}}
    if args.plot:
        from ..plots.touchup import plot_zmp_distance

        plot_zmp_distance(r, args.plot, title=f"{Path(str(args.motion)).name}: ZMP outside the support polygon")
        print(f"wrote {args.plot}")
    return finish(args, "touchup", out, r.motion, m, report)
