"""``mocomp flips``: a multi-flip jump from a single flip (flips paper, section 5)."""
from __future__ import annotations

import argparse
import math

from ._common import add_audit_arg, add_gravity_arg, finite_float, fps_arg, positive_float


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "flips", help="turn a single flip into a double, triple, ... flip (momentum-conserving)",
        description="Make an N-somersault jump from a single flip (Majkowska & Faloutsos 2007): detect the "
                    "flight, estimate the mass distribution, repeat a self-looping fragment rotated about the "
                    "angular momentum, retime (k = k* by default: continuous at take-off) and reposition the centre of "
                    "mass on a parabola falling with g = 9.81 m/s^2. Prints the physics report (the model's planned "
                    "values), then what mocomp.audit measures on the frames written (the physics of the output), "
                    "ending with its verdict against the input.")
    p.add_argument("input", metavar="INPUT", help="motion file (BVH, ASF/AMC, DeepMimic) or a dataset name "
                                                  "(e.g. backflip, 88_01)")
    p.add_argument("--flips", type=int, default=2, help="total number of somersaults (default 2)")
    k = p.add_mutually_exclusive_group()
    k.add_argument("--k-ratio", type=finite_float, default=None,
                   help="retiming factor as a fraction of k* (default 1: k = k*, the one factor whose flight leaves "
                        "with the velocity the retimed take-off reaches). 0.7 is the paper's aesthetic choice (higher, "
                        "slower flips): its flight needs about twice the take-off speed, so the centre-of-mass "
                        "velocity jumps at take-off and landing (the audit reports it) unless --takeoff repair")
    k.add_argument("--k", type=finite_float, default=None, help="explicit retiming factor (>1 = faster)")
    p.add_argument("--height-change", type=finite_float, default=0.0, metavar="DY",
                   help="change of the landing level in metres (negative = land lower)")
    p.add_argument("--takeoff-height-change", type=finite_float, default=0.0, metavar="DY0",
                   help="change of the take-off level in metres (positive = take off from higher up; App. B)")
    p.add_argument("--takeoff", choices=("smooth", "as-is", "repair"), default="smooth",
                   help="smooth (default, beyond the paper): the flight is played k times faster, so its stances would "
                        "push and land with k^2 times the captured acceleration; the frames next to the take-off and "
                        "the landing keep the captured acceleration and the rest is made up by a longer push and a "
                        "deeper give (root displacement map, feet held by the leg IK, ground force bounded), kept only "
                        "where the measured velocity jump falls. as-is: the paper's method (the stances retimed as "
                        "they are). repair (beyond the paper): also remove a k != k* take-off jump: reshape the last "
                        "ground frames before take-off and the first after landing (root displacement map, feet held "
                        "by the leg IK, vertical ground force within 0.1-8 body weights, knees no tighter than the "
                        "clip's tuck) so the centre of mass reaches the new flight's velocity without a jump; refused "
                        "with the frames and the force needed when the stance cannot do it")
    p.add_argument("--landing", choices=("auto", "as-is"), default="auto",
                   help="auto (default, beyond the paper): when the input flight is not ballistic (a DeepMimic "
                        "clip's take-off velocity differs from its ballistic fit's), the landing stance is decelerated "
                        "smoothly from the new flight's arrival velocity, feet held by leg IK, keeping the input's own "
                        "landing impact (as mocomp edit --landing auto); as-is: the paper's (the stance retimed and "
                        "moved rigidly). Not used with --takeoff repair, which repairs the landing itself")
    add_gravity_arg(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="where to write the new motion (BVH)")
    p.add_argument("--report", metavar="report.json", help="also write the physics report as JSON")
    p.add_argument("--fps", type=fps_arg, default=None, help="frame rate to use instead of the file's")
    p.add_argument("--fix-timing", action="store_true",
                   help="relabel the frame rate when the flight's gravity fit shows it is wrong")
    p.add_argument("--flight", type=int, nargs=2, metavar=("START", "STOP"), default=None,
                   help="flight frames [START, STOP) instead of detecting them. A detected flight shorter than "
                        "0.25 s or whose centre-of-mass parabola gives a gravity outside 7.0-13.7 m/s^2 (after "
                        "--fix-timing) is refused; a flight given here is measured the same way but only warned "
                        "about")
    p.add_argument("--total-mass", type=positive_float, default=70.0,
                   help="body mass in kg for the prior (default 70)")
    p.add_argument("--no-mass-estimate", action="store_true", help="keep the table's mass distribution")
    p.add_argument("--joint-flights", action="store_true",
                   help="estimate the masses from every flight of the clip jointly (e.g. hops beside the flip)")
    p.add_argument("--shape", choices=("ellipsoid", "cuboid"), default="ellipsoid",
                   help="segment solids for the inertias (flips paper: ellipsoids; dissertation eq. 5.3: cuboids)")
    p.add_argument("--no-seam-retime", action="store_true",
                   help="uniform retiming only (no eq. 5.22 non-uniform retiming across the seams)")
    p.add_argument("--filmstrip", metavar="PNG", help="also draw the original and the result side by side")
    add_audit_arg(p)
    p.set_defaults(func=run)


#: Python-API hints in library error messages and the CLI option (or command) that does the same
_CLI_HINTS = (
    ("give the flight frames explicitly (flight=(start, stop))", "give the flight frames explicitly "
     "(--flight START STOP)"),
    ("or skip estimation and keep the table prior", "or skip estimation and keep the table prior "
     "(--no-mass-estimate)"),
    ("(for small rotations such as twist jumps lower min_angle, e.g. prepare(..., loop_options="
     "{'min_angle': radians}))", "(for a twist jump use mocomp twist)"),
)


def cli_wording(message: str) -> str:
    """``message`` with the Python-API hints of :data:`_CLI_HINTS` replaced by the CLI's options."""
    for api, cli in _CLI_HINTS:
        message = message.replace(api, cli)
    return message


def run(args: argparse.Namespace) -> int:
    from ..errors import MocompError

    try:
        return _run(args)
    except (MocompError, ValueError) as exc:
        text = str(exc)
        new = cli_wording(text)
        if new != text:
            exc.args = (new,) + tuple(exc.args[1:])
        raise


def _run(args: argparse.Namespace) -> int:
    from ..flips import multiflip, prepare
    from ..io.bvh import write_bvh
    from ._common import audit_output, check_flight, finish_audit

    if args.flips < 2:
        raise ValueError(f"--flips must be at least 2 (the input is one flip), got {args.flips}")
    if args.k is not None and not (math.isfinite(args.k) and args.k > 0):
        raise ValueError(f"--k must be a positive number, got {args.k}")
    if args.k_ratio is not None and not (math.isfinite(args.k_ratio) and args.k_ratio > 0):
        raise ValueError(f"--k-ratio must be a positive number, got {args.k_ratio}")
    prep = prepare(args.input, fps=args.fps, fix_timing=args.fix_timing, total_mass=args.total_mass,
                   flight=tuple(args.flight) if args.flight else None,
                   estimate="auto" if not args.no_mass_estimate else False,
                   joint_flights=args.joint_flights, shape=args.shape)
    check_flight(prep, args, "flips", fps_hint="--fix-timing, or --fps F")
    res = multiflip(prep, flips=args.flips, k=args.k, k_ratio=args.k_ratio, height_change=args.height_change,
                    takeoff_height_change=args.takeoff_height_change, seam_retime=not args.no_seam_retime,
                    gravity=args.gravity, takeoff=args.takeoff, landing=args.landing)
    out = write_bvh(res.motion, args.output)
    print(prep.summary())
    print("planned (the method's model values; the audit line at the end measures the frames written):")
    print(res.report)
    print(f"wrote {out} ({res.motion.n_frames} frames at {res.motion.fps:g} Hz)")
    if args.report:
        res.report.to_json(args.report)
        print(f"wrote {args.report}")
    if args.filmstrip:
        import matplotlib

        matplotlib.use("Agg")
        from ..plots.flips import filmstrip

        kind, _ = filmstrip(res, path=args.filmstrip)
        print(f"wrote {args.filmstrip} ({kind})")
    result = None if args.no_audit else audit_output(out, prep.motion, input_name=str(args.input))
    if result is not None:
        for line in measured_lines(result.report):
            print(line)
    finish_audit(args, "flips", result, args.report)
    return 0


def measured_lines(report) -> list[str]:
    """The physics of the output as :mod:`mocomp.audit` measured it on the frames written (against the
    input): COM velocity jumps at take-off and landing, and per flight the fitted gravity with its
    interval and the |L| variation. These, not the planned values above them, are the output's physics."""
    A = report.against

    def both(key, unit, fmt="{:.2f}"):
        def one(r):
            try:
                v = r.measure(key)
            except (KeyError, ValueError):
                return "-"
            return "-" if v is None or v != v else fmt.format(v)
        return f"{one(report)} {unit}" + (f" (input {one(A)})" if A is not None else "")

    lines = ["measured (mocomp.audit on the frames written; these are the output's physics): COM velocity jump at "
             f"take-off {both('takeoff_jump_mps', 'm/s')}, at landing {both('landing_jump_mps', 'm/s')}, elsewhere "
             f"{both('max_com_jump_mps', 'm/s')}"]
    for i, f in enumerate(report.flights, 1):
        if f.fit is None:
            continue
        lines.append(f"  flight {i} (frames {f.frames[0]}-{f.frames[1] - 1}, {f.duration:.3f} s): falls with "
                     f"g = {f.fit.g:.2f} m/s^2 (95% interval {f.fit.g_low:.2f}-{f.fit.g_high:.2f}), |L| varies "
                     f"{100 * f.L_magnitude:.1f}%")
    return lines
