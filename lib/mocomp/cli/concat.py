"""``mocomp concat A B [C ...] -o OUT.bvh``: dynamic motions chained by their angular momentum
(Shum, Komura & Yadav 2009; issue 17)."""
from __future__ import annotations

import argparse
import json
import string
from pathlib import Path


def _phases(text: str) -> tuple[str, tuple[int, int]]:
    """``A:a0,a1`` -> ``("A", (a0, a1))``."""
    name, sep, rng = text.partition(":")
    parts = rng.split(",")
    if not sep or len(name) != 1 or name.upper() not in string.ascii_uppercase or len(parts) != 2:
        raise argparse.ArgumentTypeError(f"{text!r} is not MOTION:START,STOP (e.g. A:40,95; motions A, B, C, ... "
                                         "in the order given)")
    try:
        a, b = int(parts[0]), int(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: START and STOP must be frame numbers") from None
    if not 0 <= a < b:
        raise argparse.ArgumentTypeError(f"{text!r}: need 0 <= START < STOP (main phase frames, STOP exclusive)")
    return name.upper(), (a, b)


def _fps(text: str) -> tuple[str, float]:
    """``A:60`` -> ``("A", 60.0)``."""
    name, sep, val = text.partition(":")
    try:
        f = float(val)
    except ValueError:
        f = float("nan")
    if not sep or len(name) != 1 or name.upper() not in string.ascii_uppercase or not 0 < f < 10000:
        raise argparse.ArgumentTypeError(f"{text!r} is not MOTION:FPS (e.g. A:60 for a CMU clip whose header says "
                                         "120 Hz; motions A, B, C, ... in the order given)")
    return name.upper(), f


def _rules(text: str) -> list[str]:
    rules = [r.strip() for r in text.split(",")]
    bad = [r for r in rules if r not in ("forward", "reverse", "auto")]
    if bad or not rules:
        raise argparse.ArgumentTypeError(f"{text!r}: each rule must be forward, reverse or auto (one for all joints "
                                         "or a comma-separated list, one per joint)")
    return rules


def register(sub) -> None:
    from ._common import add_audit_arg, float_in

    p = sub.add_parser(
        "concat", help="chain dynamic motions by their angular momentum (forward / reverse rule)",
        description="Concatenate full-body motions (kicks, punches, flips, cartwheels) the way people chain them "
                    "(Shum, Komura & Yadav 2009): the angular momentum of each motion (eq. 1) splits it into "
                    "preparatory, main and posterior phases; the forward rule keeps the momentum of the first main "
                    "phase up to start the second, the reverse rule uses the end of the first to wind up the second "
                    "(auto: by the sign of the main phases' mean-L dot product, with the reason); B is turned about "
                    "the vertical in closed form (eq. 2) and moved so the centres of the feet coincide; the offset T "
                    "and blending centre f_T minimise F = F_dm + F_inertia + F_time (eq. 3-7) over the blendable "
                    "periods; the motions are blended linearly (eq. 8, slerp) over a window traced from f_T, the "
                    "blended period re-timed (eq. 9) and the supporting feet held (mocomp.ops). With more than two "
                    "motions each joint is chosen by its own rule. The per-joint values are the method's planned "
                    "ones (labelled planned); the summary ends with what mocomp.audit measured on the file written, "
                    "read back (foot slide and floor penetration beside the inputs' own, per joint over its blended "
                    "period) and its verdict against the inputs.")
    p.add_argument("motions", nargs="+", metavar="MOTION",
                   help="two or more motions (files or clip names), in order; FILE@K takes the K-th single strike "
                        "(punch, kick, slash; 1-based) found in a clip holding several (by the speed peaks of the hands "
                        "and toes, mocomp.concat.find_actions), FILE@START:STOP a frame range (STOP exclusive)")
    p.add_argument("-o", "--out", required=True, metavar="OUT.bvh", help="output BVH file (the chained motion)")
    p.add_argument("--report", metavar="r.json", help="write the planned values (and the audit) as JSON")
    p.add_argument("--rule", type=_rules, default=["auto"], metavar="forward|reverse|auto",
                   help="transition rule (default auto); one for every joint or a comma-separated list, one per joint")
    p.add_argument("--phases", type=_phases, nargs="+", default=[], metavar="X:START,STOP",
                   help="main-phase borders by hand, e.g. A:40,95 B:12,60 (motions A, B, C, ... in the order given; "
                        "frames 0-based, STOP exclusive); default: detected from the peak of |L|")
    p.add_argument("--fps", type=_fps, nargs="+", default=[], metavar="X:FPS",
                   help="override a motion's frame rate, e.g. A:60 B:60 (CMU subjects 88 and 90 are really 60 Hz)")
    p.add_argument("--L", dest="kind", choices=("paper", "full"), default="paper",
                   help="angular momentum: paper (eq. 1, the segments' orbital momentum about the COM; default) or "
                        "full (with the segments' own spin)")
    p.add_argument("--max-f", type=float_in(0.0, 1e12), metavar="F",
                   help="reject a timing whose F exceeds this (default (1.5 x the larger main-phase peak |L|)^2)")
    p.add_argument("--window-threshold", type=float_in(0.0, 1e12), metavar="DL2",
                   help="trace the blend window while ||L1 - L2||^2 stays below this (default (0.5 x the main "
                        "phases' mean |L|)^2)")
    p.add_argument("--max-facing", type=float_in(0.0, 180.0), default=45.0, metavar="DEG",
                   help="largest difference of the two bodies' ground-projected facing (default 45; see --facing-at)")
    p.add_argument("--facing-at", choices=("t_m", "f_T"), default="t_m",
                   help="where the facing check compares the bodies: at their main phases' reference frames after "
                        "the eq. 2 turn (t_m, default) or at the blending centre (f_T: offsets failing it are left out "
                        "of the timing search)")
    p.add_argument("--min-level", type=float_in(0.0, 1e6), default=None, metavar="L",
                   help="kg m^2/s: a motion whose |L| never exceeds this has no main phase (default 4; the Bandai "
                        "punches peak at 3-4)")
    p.add_argument("--no-com-smooth", action="store_true",
                   help="leave the COM velocity steps at the blended period's edges (the paper's eq. 9 alone)")
    p.add_argument("--on-facing", choices=("reject", "constrain"), default="reject",
                   help="when eq. 2's turn leaves the bodies facing more than --max-facing apart at their main phases: "
                        "reject (default, the paper's) or constrain eq. 2 to the turns within the limit (noted)")
    p.add_argument("--no-time-scale", action="store_true", help="leave out eq. 9's time scaling of the blend")
    p.add_argument("--no-plant", action="store_true", help="do not hold the supporting feet")
    p.add_argument("--baseline", choices=("motion-graph",),
                   help="also make the Motion-Graph transition between the same motions (Kovar et al. 2002's "
                        "point-cloud criterion, blended the same way), write it beside OUT as OUT.motion-graph.bvh "
                        "and compare: durations and the lowest |L| between the main phases, both measured")
    p.add_argument("--plot", metavar="L.png", help="plot |L| of the inputs (placed at their offsets) and of the output")
    add_audit_arg(p)
    p.set_defaults(func=run)


def _print_joint(k: int, na: str, nb: str, r) -> None:
    d = r.to_dict()
    ph = d["phases"]
    print(f"joint {k + 1}: {na} -> {nb}")
    for w, n in (("A", na), ("B", nb)):
        x = ph[w]
        print(f"  phases of {n} ({x['borders']}): preparatory {x['preparatory'][0]}-{x['preparatory'][1]}, main "
              f"{x['main'][0]}-{x['main'][1]} (t_m {x['t_m']}), posterior {x['posterior'][0]}-{x['posterior'][1]}")
    print(f"  rule: {r.rule.rule} ({r.rule.reason})")
    print(f"  planned alignment (eq. 2): B turned by {d['alignment']['yaw_deg']:+.1f} deg, moved by "
          f"({r.transform.shift[0]:+.3f}, {r.transform.shift[2]:+.3f}) m; facing at {d['facing_check']['at']} differs by "
          f"{d['facing_check']['difference_deg']:.1f} deg (limit {d['facing_check']['limit_deg']:.0f})")
    bp = d["blendable_periods"]
    print(f"  blendable periods ({bp['case']}): A {bp['A'][0]}-{bp['A'][1]}, B {bp['B'][0]}-{bp['B'][1]}; "
          + "; ".join(bp["notes"]))
    t = d["timing"]
    o, ru = t["optimum"], t["runner_up"]
    print(f"  planned timing (eq. 3-7, {t['offsets_scanned']} offsets): T = {o['T']}, f_T = {o['f_T']}, F = {o['F']:.4g} "
          f"(F_dm {o['F_dm']:.4g} + F_inertia {o['F_inertia']:.4g} + F_time {o['F_time']:.4g}; limit {t['max_F']:.4g})"
          + ("" if ru is None else f"; runner-up T = {ru['T']}: F = {ru['F']:.4g} (F_dm {ru['F_dm']:.4g} + F_inertia "
                                   f"{ru['F_inertia']:.4g} + F_time {ru['F_time']:.4g})"))
    w = d["blend_window"]
    ts = d["time_scaling"]
    print(f"  planned blend (eq. 8): A frames {w['f_i0']}-{w['f_if']} with B frames {w['B_frames'][0]}-{w['B_frames'][1]} "
          f"({w['frames']} frames); eq. 9 scale s = {ts['s']:.3f} -> {ts['window_frames_after']} frames")
    if r.footplants is not None:
        fp = r.footplants
        print(f"  planned feet (ops.enforce_footplants, on the plants it held): largest slide within them "
              f"{fp.slide_before.max() * 100:.2f} -> {fp.slide_after.max() * 100:.2f} cm (measured values: after the "
              "file is written)")
    for n in r.notes:
        print(f"  note: {n}")


def _plot(path, inputs, offsets, out, tracks_fn, baseline=None) -> None:
    """|L| of each input placed at its offset (``offsets``: output frames, at the output's rate; after
    the eq. 9 retiming the blended stretch itself is slower, so the inputs line up before and after it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(9, 3.5))
    for (name, m), off in zip(inputs, offsets):
        L = tracks_fn(m).magnitude
        ax.plot(np.arange(len(L)) / m.fps + off / out.fps, L, lw=1, alpha=0.6,
                label=f"{Path(name).name} (planned offset)")
    Lo = tracks_fn(out).magnitude
    ax.plot(np.arange(len(Lo)) / out.fps, Lo, "k", lw=1.6, label="ours (measured)")
    if baseline is not None:
        Lb = tracks_fn(baseline).magnitude
        ax.plot(np.arange(len(Lb)) / baseline.fps, Lb, "g:", lw=1.6, label="Motion Graph (measured)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("|L| (kg m$^2$/s)")
    ax.legend(fontsize=7)
    ax.set_title("angular momentum (eq. 1) of the inputs and of the concatenation(s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args) -> int:
    import numpy as np

    from .. import datasets
    from ..concat import ConcatError, concatenate, momentum_track
    from ..io import write_bvh
    from ..io.bvh import read_bvh
    from ._common import audit_output, check_output_path, finish_audit
    from .footplant import check_outputs

    out = check_outputs(args)
    if args.plot:
        check_output_path(Path(args.plot), "plot")
    names = list(args.motions)
    fps = dict(args.fps)
    from ..concat.actions import parse_selection, select

    motions = []
    for k, n in zip(string.ascii_uppercase, names):                       # bad files first
        path, which, frames = parse_selection(n)
        m, what = select(datasets.load(path, fps=fps.get(k)), path, which, frames)
        if which is not None or frames is not None:
            print(f"{k}: {n}: {what}")
        motions.append(m)
    for k in fps:
        if k not in string.ascii_uppercase[:len(names)]:
            raise ValueError(f"--fps {k}:{fps[k]:g}: there are only motions A-{string.ascii_uppercase[len(names) - 1]}")
    if len(names) < 2:
        raise ValueError(f"give at least two motions to concatenate (got {len(names)})")
    if len(names) > 26:
        raise ValueError(f"at most 26 motions (A-Z), got {len(names)}")
    n_j = len(names) - 1
    rules = args.rule if len(args.rule) == n_j else (args.rule * n_j if len(args.rule) == 1 else None)
    if rules is None:
        raise ValueError(f"--rule lists {len(args.rule)} rules for {n_j} joint(s): give one, or one per joint")
    letters = string.ascii_uppercase[:len(names)]
    borders = {}
    for k, rng in args.phases:
        if k not in letters:
            raise ValueError(f"--phases {k}:{rng[0]},{rng[1]}: there are only motions {letters[0]}-{letters[-1]}")
        borders[k] = rng
    for k, (n, m) in zip(letters, zip(names, motions)):
        if k in borders and borders[k][1] > m.n_frames:
            raise ValueError(f"--phases {k}:{borders[k][0]},{borders[k][1]}: {n} has only {m.n_frames} frames")
    acc, acc_borders, acc_tm = motions[0], borders.get("A"), None
    joints, offsets = [], [0]               # offsets: the output frame of each input's frame 0
    for j in range(n_j):
        b = motions[j + 1]
        try:
            r = concatenate(acc, b, rule=rules[j], borders_a=acc_borders, t_m_a=acc_tm,
                            borders_b=borders.get(letters[j + 1]), kind=args.kind, max_F=args.max_f,
                            window_threshold=args.window_threshold, max_facing=np.radians(args.max_facing),
                            facing_at=args.facing_at, plant=not args.no_plant, time_scale=not args.no_time_scale,
                            com_smooth=not args.no_com_smooth, on_facing=args.on_facing,
                            **({} if args.min_level is None else {"min_level": args.min_level}))
        except ConcatError as e:
            if n_j == 1:
                raise
            raise ConcatError(f"joint {j + 1} ({'the chain so far' if j else names[0]} -> {names[j + 1]}): {e}") from None
        _print_joint(j, "the chain so far" if j else names[0], names[j + 1], r)
        joints.append(r)
        # B's frame g is the output frame g + T + the frames eq. 9 added after the window
        sh = r.frame_shift
        offsets.append(sh)
        acc_borders, acc_tm = r.next_main_phase()
        acc = r.motion
    total_in = sum(m.n_frames / m.fps for m in motions)
    base, base_rows, peaks, base_peaks = None, [], [], []
    for j, r in enumerate(joints):
        peaks.append((r.phases[0].t_m, r.phases[1].t_m + offsets[j + 1]))
    if args.baseline:
        from ..concat import Phases, motion_graph_concatenate

        acc_b, ph_a = motions[0], joints[0].phases[0]
        for j, r in enumerate(joints):
            res = motion_graph_concatenate(acc_b, motions[j + 1], (ph_a, r.phases[1]), r.baseline_window,
                                           plant=not args.no_plant)
            sh = res.transition.i - res.transition.j
            base_peaks.append((ph_a.t_m, r.phases[1].t_m + sh))
            m2 = r.phases[1]
            ph_a = Phases(res.motion.n_frames, m2.t_m + sh, (m2.main[0] + sh, m2.main[1] + sh), True)
            base_rows.append(res.to_dict())
            acc_b = res.motion
        base = acc_b
    write_bvh(acc, out)
    print(f"wrote {out} ({acc.n_frames} frames at {acc.fps:g} fps, {acc.n_frames / acc.fps:.2f} s; the inputs played "
          f"one after the other last {total_in:.2f} s)")
    track = lambda m: momentum_track(m, kind=args.kind)                      # noqa: E731
    comparison = None
    if base is not None:
        bpath = out.with_name(out.stem + ".motion-graph.bvh")
        check_output_path(bpath, "baseline")
        write_bvh(base, bpath)
        Lo, Lb = track(read_bvh(out, scale=1.0)).magnitude, track(read_bvh(bpath, scale=1.0)).magnitude
        lows = [float(Lo[p:q + 1].min()) for p, q in peaks]
        blows = [float(Lb[p:q + 1].min()) for p, q in base_peaks]
        level = [r.L_reference for r in joints]
        comparison = {"ours_s": acc.n_frames / acc.fps, "motion_graph_s": base.n_frames / base.fps,
                      "lowest_L_between_main_phases": {"ours": lows, "motion_graph": blows, "main_level": level},
                      "measured_on": "the BVH files written, read back", "motion_graph": base_rows}
        print(f"wrote {bpath} (Motion-Graph baseline: {base.n_frames} frames, {base.n_frames / base.fps:.2f} s)")
        for k, (lo, blo, lv) in enumerate(zip(lows, blows, level)):
            t = base_rows[k]
            print(f"joint {k + 1}: lowest |L| between the main phases (measured): ours {lo:.2f} ({lo / lv:.0%} of the "
                  f"main level {lv:.2f}), Motion Graph {blo:.2f} ({blo / lv:.0%}; transition A frame {t['A_frame']} -> "
                  f"B frame {t['B_frame']}, point-cloud distance {t['point_cloud_distance_m2']:.4g} m^2)")
    if args.plot:
        _plot(args.plot, list(zip(names, motions)), offsets, acc, track, base)
        print(f"wrote {args.plot}")
    result = None if args.no_audit else audit_output(out, motions[0], input_name=names[0],
                                                      other_inputs=tuple(zip(names[1:], motions[1:])))
    measured = None
    if result is not None:
        measured = measured_feet(result.report, [result.report.against, *result.others], joints)
        _print_measured(out, names, measured)
    if args.report:
        rep = {"inputs": names, "joints": [r.to_dict() for r in joints],
               "output": {"frames": acc.n_frames, "fps": acc.fps, "duration_s": acc.n_frames / acc.fps,
                          "inputs_back_to_back_s": total_in}}
        if comparison is not None:
            rep["baseline"] = comparison
        if measured is not None:
            rep["measured"] = measured
        Path(args.report).write_text(json.dumps(rep, indent=1, default=float) + "\n")
    finish_audit(args, "concat", result, args.report)
    return 0


def measured_feet(report, input_reports, joints) -> dict:
    """What :func:`mocomp.audit.audit` measured on the file written (``report``) against the inputs'
    own audits: the largest foot slide within the contacts it detects (overall and, per joint, over
    the contacts that overlap the joint's blended period in the output), the deepest floor
    penetration; ``joints``: the :class:`~mocomp.concat.ConcatResult` of each joint (their output
    windows are frames of the final output: a later joint only changes frames after its own window)."""
    from ..ops.evidence import foot_slide

    feet = [c for c in report.contacts if not c.effector.startswith("hand")]
    per = []
    for r in joints:
        u0, u1 = r.output_window
        near = [c for c in feet if c.frames[0] <= u1 and c.frames[1] > u0]
        worst = max(near, key=lambda c: c.slide, default=None)
        per.append({"output_window": [int(u0), int(u1)], "contacts": len(near),
                    "max_foot_slide_m": 0.0 if worst is None else float(worst.slide),
                    "where": None if worst is None else {"effector": worst.effector, "frames": list(worst.frames)}})
    return {"measured_on": "the BVH file written, read back (mocomp.audit)",
            "max_foot_slide_m": foot_slide(report), "inputs_max_foot_slide_m": [foot_slide(x) for x in input_reports],
            "max_penetration_m": float(report.measure("max_penetration_m")),
            "inputs_max_penetration_m": [float(x.measure("max_penetration_m")) for x in input_reports],
            "joints": per}


def _print_measured(out, names, m: dict) -> None:
    ins = ", ".join(f"{Path(n).name} {v * 100:.2f}" for n, v in zip(names, m["inputs_max_foot_slide_m"]))
    pen = ", ".join(f"{v * 100:.2f}" for v in m["inputs_max_penetration_m"])
    print(f"measured on {out} read back (mocomp.audit): largest foot slide within the contacts it finds "
          f"{m['max_foot_slide_m'] * 100:.2f} cm (inputs' own: {ins} cm); deepest floor penetration "
          f"{m['max_penetration_m'] * 100:.2f} cm (inputs: {pen} cm)")
    for k, j in enumerate(m["joints"]):
        w = j["where"]
        print(f"  joint {k + 1}: contacts over the blended period (output frames {j['output_window'][0]}-"
              f"{j['output_window'][1]}): " + ("none" if w is None else
              f"{j['contacts']}, largest slide {j['max_foot_slide_m'] * 100:.2f} cm ({w['effector']} frames "
              f"{w['frames'][0]}-{w['frames'][1] - 1})"))
