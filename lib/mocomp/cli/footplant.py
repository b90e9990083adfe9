"""``mocomp footplant IN -o OUT.bvh [--contacts FILE.csv]``: hold the planted feet still (issue 15)."""
from __future__ import annotations

import json
from pathlib import Path


def add_output_args(p, what: str) -> None:
    """``-o OUT.bvh``, ``--report r.json`` and ``--no-audit`` (shared by the editing-primitive commands)."""
    from ._common import add_audit_arg

    p.add_argument("-o", "--out", required=True, metavar="OUT.bvh", help=f"output BVH file ({what})")
    p.add_argument("--report", metavar="r.json", help="write the evidence (and the audit) as JSON")
    add_audit_arg(p)


def check_outputs(args) -> Path:
    from ._common import check_output_path

    out = Path(args.out)
    if out.suffix.lower() != ".bvh":
        raise ValueError(f"output {out} must be a .bvh file")
    check_output_path(out)
    if args.report:
        check_output_path(Path(args.report), "report")
    return out


#: the editing primitives keep their input's timing, so a joint turning much faster than the input's
#: own joint is a defect of the edit (leg IK snapping a knee), not an intended change: their output
#: audits judge pose jumps (``mocomp.audit.posejump``) as violations
POSE_JUMP_THRESHOLDS = {"pose_jump_is_violation": True}


def ops_thresholds():
    """The :class:`~mocomp.audit.AuditThresholds` of the editing-primitive commands' output audits: the
    defaults with ``pose_jump_is_violation=True`` (:data:`POSE_JUMP_THRESHOLDS`)."""
    from ..audit import AuditThresholds

    return AuditThresholds(**POSE_JUMP_THRESHOLDS)


def pose_jump_line(report) -> str | None:
    """``joint rates: largest excess over the input's own 3.5 rad/s (RightKnee, frames 93-94), limit 20
    rad/s, 0 jump step(s) (violations)``: the audit's ``max_joint_speed_excess`` measure, or ``None``
    when the report has no pose-jump comparison (skeletons without common joints)."""
    pj = getattr(report, "pose_jumps", None)
    if pj is None:
        return None
    return (f"joint rates: largest excess over the input's own {pj.max_excess:.1f} rad/s ({pj.joint}, frames "
            f"{pj.frame}-{pj.frame + 1}: {pj.rate:.1f} vs {pj.reference:.1f} rad/s), limit {pj.threshold:g} rad/s, "
            f"{pj.n_jumps} jump step(s) (judged as violations)")


def finish(args, command: str, out: Path, motion, input_motion, report: dict, *, against_frame_map=None) -> int:
    """Write the motion, the report, and end with the audit of the written file against the input,
    pose jumps judged as violations (:func:`ops_thresholds`); ``against_frame_map``: the input frame of
    each written frame when they are not matched by time (``mocomp blend``)."""
    from ..io import write_bvh
    from ._common import audit_output, finish_audit

    write_bvh(motion, out)
    print(f"wrote {out} ({motion.n_frames} frames at {motion.fps:g} fps)")
    if args.report:
        Path(args.report).write_text(json.dumps(report, indent=1) + "\n")
    result = None
    if not args.no_audit:
        result = audit_output(out, input_motion, input_name=str(args.motion), thresholds=ops_thresholds(),
                              against_frame_map=against_frame_map)
        line = pose_jump_line(result.report)
        if line:
            print(line)
    finish_audit(args, command, result, args.report)
    return 0


def register(sub) -> None:
    from ._common import add_load_args, int_in

    p = sub.add_parser(
        "footplant", help="hold the planted feet still (two-bone leg IK, faded in and out)",
        description="Find the planted frames of each foot (ankle point and toe tip) with the project's contact "
                    "detector, or take them from --contacts, hold each planted point at its mean position on its "
                    "support level, and move the legs there by analytic two-bone IK (hip fixed, knee kept in the "
                    "leg's plane, reach clamped: a foot out of reach is lifted, never slid), fading each correction "
                    "in and out. Prints the foot slide within the plants before and after; ends with the verdict "
                    "of mocomp.audit on the frames written, against the input.")
    add_load_args(p)
    add_output_args(p, "the motion with its feet planted")
    p.add_argument("--contacts", metavar="FILE.csv",
                   help="planted intervals instead of the detector's for the points named: a CSV with the header "
                        "joint,start,stop and one interval a row; joint is foot_l, toe_l, foot_r, toe_r or the joint "
                        "such a point rides on; frames 0-based, stop exclusive")
    p.add_argument("--blend", type=int_in(0, 10000), metavar="N",
                   help="frames over which each correction fades in and out (default 0.1 s)")
    p.add_argument("--height", choices=("level", "hold", "keep"), default="level",
                   help="planted heights: lowest point of each plant on the support level (default), on the level "
                        "throughout, or unchanged")
    p.add_argument("--passes", type=int_in(1, 20), default=2, metavar="N",
                   help="enforcement passes: after each, the contact detector runs on the result and the frames it "
                        "finds planted that were not held are added (default 2; each further pass costs a detection "
                        "and a partial re-solve)")
    p.add_argument("--max-passes", type=int_in(1, 20), default=6, metavar="N",
                   help="where the last re-detection adds more than 2%% of the planted frames (the detector on the "
                        "result disagrees with the input's, as on raw CMU clips whose toes sink through the floor), "
                        "passes go on up to N in all until the feet slide under 1 cm within the contacts the "
                        "detector finds on the result, and the pass that slides least is kept (default 6; "
                        "--max-passes equal to --passes or less turns this off)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..ops import enforce_footplants
    from ._common import load_from_args

    out = check_outputs(args)
    m = load_from_args(args)
    if args.contacts and not Path(args.contacts).is_file():
        raise FileNotFoundError(f"contact file {args.contacts} does not exist")
    r = enforce_footplants(m, contacts=args.contacts, blend=args.blend, height=args.height, passes=args.passes,
                           max_passes=args.max_passes, audit=False)
    for e, b, a in zip(r.plants.effectors, r.slide_before, r.slide_after):
        n = len(r.plants.intervals[e])
        print(f"{e}: {n} plant(s) ({r.plants.source[e]}), largest slide {b * 100:.2f} -> {a * 100:.2f} cm")
    print(f"legs solved on {r.changed_frames} of {m.n_frames} frames, blend {r.blend_frames} frames; "
          f"largest joint rate {r.joint_speed_before:.1f} -> {r.joint_speed_after:.1f} rad/s")
    for n in r.notes:
        print(n)
    return finish(args, "footplant", out, r.motion, m, {"footplant": r.to_dict()})
