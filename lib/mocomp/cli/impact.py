"""``mocomp impact --attacker A --victim V -o OUT_DIR``: a motion-captured character hit unexpectedly
(dissertation ch. 4; issue 18)."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path


def _offset(text: str) -> tuple[float, float]:
    import argparse
    import math

    parts = text.split(",")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        vals = ()
    if len(vals) != 2 or not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"expected two numbers X,Z in metres (e.g. 0.9,0.1), got {text!r}")
    return vals


def register(sub) -> None:
    from ._common import add_audit_arg, float_in, int_in

    p = sub.add_parser(
        "impact", help="a character hit unexpectedly: physics burst, library search, active response, blend",
        description="Impact response (Majkowska 2007, ch. 4). Both characters go into one MuJoCo model; the "
                    "first contact is found at the capture rate, the simulation rewinds to the last capture "
                    "frame and runs at 0.5 ms: a naive pass (friction 1.0), the search of the reaction library "
                    "for the clip that continues it (eq. 4.1-4.2, unique frames), an active pass toward the "
                    "found clip with inertia-scaled PD servos (eq. 4.3, friction 0.5, reaction delay 0.1-0.2 s) "
                    "and a final blend that lands exactly on the found clip; the attacker follows the contact "
                    "and blends back to its attack. Writes victim.bvh, attacker.bvh and a stick filmstrip of "
                    "both into OUT_DIR; ends with the verdicts of mocomp.audit on both written files.")
    p.add_argument("--attacker", required=True, metavar="FILE_OR_NAME", help="the attack clip (kick, punch, ...)")
    p.add_argument("--victim", required=True, metavar="FILE_OR_NAME",
                   help="the clip of the character that is hit (standing, walking, running)")
    p.add_argument("--facing", type=float_in(-180.0, 180.0), default=0.0, metavar="DEG",
                   help="the victim's heading relative to facing the attacker, degrees in [-180, 180]: 0 a front "
                        "hit, 90/-90 the attacker on its left/right, 180 a hit in the back (default 0)")
    p.add_argument("--offset", type=_offset, metavar="X,Z",
                   help="the victim's root relative to the attacker's, metres, in the frame of the strike (x "
                        "along it, z to its right); default: straight ahead, 0.25 m inside the strike's reach")
    p.add_argument("--contact-body", metavar="JOINT",
                   help="the attacker's striking joint (right_hand, right_foot, sword, ...; the bodies it "
                        "carries strike too); default: every attacker body")
    p.add_argument("--library", metavar="DIR",
                   help="folder of reaction clips (default: $MOCOMP_DATA_DIR/reactions); clips of another "
                        "skeleton are retargeted by joint names or refused")
    p.add_argument("--cache", metavar="DIR", help="the library index cache folder (default: mocomp's user cache)")
    p.add_argument("--seed", type=int_in(0, 2 ** 31 - 1), default=0, help="seed of the reaction delay draw (default 0)")
    p.add_argument("--delay", type=float_in(0.0, 0.9), metavar="S",
                   help="reaction delay before the active control, s (default: drawn from [0.1, 0.2] with --seed)")
    p.add_argument("--reentry-radius", type=int_in(0, 30), default=0, metavar="FRAMES",
                   help="beyond the paper: re-choose the found clip's frame at the re-entry within FRAMES frames "
                        "against the active simulation's state (default 0: the searched frame, as the paper)")
    p.add_argument("--reentry-by", choices=("eq4.1", "root_height"), default="root_height",
                   help="with --reentry-radius: the frame nearest by eq. 4.1's frame term or by pelvis height "
                        "(default root_height)")
    p.add_argument("-o", "--out", required=True, metavar="OUT_DIR",
                   help="output folder (created if missing): victim.bvh, attacker.bvh, filmstrip.png")
    p.add_argument("--report", metavar="r.json", help="write the evidence (and the audits) as JSON")
    add_audit_arg(p)
    p.set_defaults(func=run)


def _load(spec: str):
    from .. import datasets

    return datasets.load(spec)


def run(args) -> int:
    from ..impact.pipeline import ImpactConfig, impact_response, load_library
    from ..impact.scene import Scenario
    from ..io import write_bvh
    from ._common import audit_output, check_output_path, render_output

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"-o {out}: exists and is not a folder")
    if not out.parent.is_dir():
        raise FileNotFoundError(f"-o {out}: its parent folder {out.parent} does not exist")
    if args.report:
        check_output_path(Path(args.report), "report")
    attacker = _load(args.attacker)
    victim = _load(args.victim)
    lib = args.library
    if lib is None:
        d = os.environ.get("MOCOMP_DATA_DIR")
        if not d:
            raise ValueError("no --library DIR given and $MOCOMP_DATA_DIR is not set")
        lib = str(Path(d) / "reactions")
    if not Path(lib).is_dir():
        raise FileNotFoundError(f"--library {lib}: no such folder")
    scenario = Scenario(args.facing, args.offset, args.contact_body)
    index = load_library(lib, victim.skeleton, cache_dir=args.cache, progress=False)
    print(f"library {lib}: {len(index.clips)} clip(s), {index.n_frames} frames, {index.n_unique} unique at "
          f"T = {index.tolerance:g}" + (f"; refused {len(index.refused)}" if index.refused else ""))
    r = impact_response(attacker, victim, index, scenario, ImpactConfig(seed=args.seed, delay=args.delay,
                                                                   reentry_radius=args.reentry_radius,
                                                                   reentry_by=args.reentry_by))
    d = r.to_dict()
    print(f"first contact at frame {r.first_contact.frame} ({r.first_contact.time:.3f} s); rewind to frame "
          f"{r.first_contact.rewind_frame}; impact at {r.naive.impact_time:.4f} s, contact until "
          f"{r.naive.contact_end:.4f} s; bodies {', '.join('-'.join(p) for p in r.naive.pairs)}; impulse "
          f"{d['impulse_norm_Ns']:.1f} N s")
    s = r.search
    ru = s.runner_up
    print(f"search: {Path(s.clip).name} frame {s.frame} (distance {s.distance:.3f})"
          + (f", runner-up {Path(ru.clip).name} frame {ru.frame} ({ru.distance:.3f})" if ru is not None else "")
          + f"; {r.evidence['search']['query_windows']} query window(s) (match times); frame pairs compared "
            f"{r.evidence['search']['frames_compared']} of {r.evidence['search']['frames_exhaustive']} (exhaustive)")
    ba, bn = r.blend_active, r.blend_naive
    print(f"final-blend correction (planned): root {ba.root_error_m:.3f} m (vertical {ba.root_error_vertical_m:+.3f} m: "
          f"the root is unactuated), joints {ba.joint_error_deg:.1f} deg at re-entry from the active simulation"
          + (f"; from the naive one {bn.root_error_m:.3f} m, {bn.joint_error_deg:.1f} deg" if bn is not None else ""))
    ref = r.evidence.get("reentry_refine")
    if ref is not None:
        print(f"re-entry frame re-chosen by {ref['by']} (beyond the paper): found clip frame {ref['clip_frame_searched']} "
              f"-> {ref['clip_frame_chosen']} (within {ref['radius_frames']} clip frames)")
    if r.naive.strike_end is not None:
        se = r.naive.strike_end
        print(f"strike ended {se['after_impact_s']:.3f} s after the impact by its {se['limit']} limit")
    sep = r.evidence["attacker"].get("separation")
    if sep and sep["frames_shifted"]:
        print(f"attacker kept out of the victim: overlap {-100 * sep['min_gap_before_m']:.1f} cm -> gap "
              f"{100 * sep.get('min_gap_final_m', sep['min_gap_after_m']):.1f} cm, pushed up to {sep['max_shift_m']:.2f} m"
              + (f" (bounded: {sep['max_shift_step_m'] * 100:.1f} cm per frame; residual overlap "
                 f"{100 * sep['residual_overlap_m']:.1f} cm on {sep['frames_overlapping']} frame(s))"
                 if sep.get("frames_overlapping") else ""))
    c = r.evidence["continuity_final"]
    print(f"re-entry at frame {r.frames['reentry']}: root step {c['reentry_root_step_m'] * 100:.1f} cm, joint step "
          f"{c['reentry_joint_step_deg']:.1f} deg (found clip's own max {c['clip_max_root_step_m'] * 100:.1f} cm, "
          f"{c['clip_max_joint_step_deg']:.1f} deg); reaction delay {r.delay:.3f} s")
    warn = {k: v for k, v in d["mujoco_warnings"].items() if v}
    if warn:
        print(f"mocomp impact: warning: MuJoCo warnings {warn}", file=sys.stderr)
    t = r.timings
    print("timings: " + ", ".join(f"{k} {v:.3f} s" for k, v in t.items()) + f"; response {r.response_seconds:.3f} s wall, {r.response_cpu_seconds:.3f} s CPU")
    out.mkdir(exist_ok=True)
    vpath, apath = out / "victim.bvh", out / "attacker.bvh"
    write_bvh(r.victim, vpath)
    write_bvh(r.attacker, apath)
    print(f"wrote {vpath} ({r.victim.n_frames} frames at {r.victim.fps:g} fps), {apath} ({r.attacker.n_frames} frames)")
    try:
        from ..plots.impact import impact_filmstrip

        fig = impact_filmstrip(r.victim, r.attacker, r.frames, title=f"{Path(str(args.attacker)).name} -> "
                                                                      f"{Path(str(args.victim)).name}")
        fig.savefig(out / "filmstrip.png", dpi=90)
        print(f"wrote {out / 'filmstrip.png'}")
    except ImportError as e:                          # matplotlib missing: the BVH files still stand
        print(f"mocomp impact: warning: no filmstrip ({e})", file=sys.stderr)
    results = {}
    if not args.no_audit:
        placed_input = victim
        # the strike's frames are declared as under external force: the audit labels the gravity and
        # angular-momentum findings there "expected" instead of violations
        ext = [tuple(r.frames["external_force"])]
        results["victim"] = audit_output(vpath, placed_input, input_name=str(args.victim), external_force_frames=ext)
        results["attacker"] = audit_output(apath, attacker, input_name=str(args.attacker), external_force_frames=ext)
    if args.report:
        d["outputs"] = {"victim": str(vpath), "attacker": str(apath)}
        d["audit"] = {k: v.to_dict() for k, v in results.items()} if results else None
        d["provenance"] = {"planned": "every key but 'audit' holds the method's model values as it planned them; "
                                      "'audit' holds what mocomp.audit measured on the frames written (read back)",
                           "measured": "audit" if results else None}
        Path(args.report).write_text(json.dumps(d, indent=1, default=_json_default) + "\n")
        print(f"wrote {args.report}")
    try:
        render_output(args, "impact", results.get("victim"))
    finally:
        for name, res in results.items():
            if res.warning:
                print(f"mocomp impact: warning: {name}: {res.warning}", file=sys.stderr)
            print(f"{name} {res.verdict_line}")
    return 0


def _json_default(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
