"""Argument helpers shared by the ``mocomp`` commands: option types that reject what a
command cannot use (NaN, infinities, values out of the option's range) at parse time, with
one line naming the option (argparse prefixes ``argument --OPTION:``), the loading options,
output-path checks and the flight plausibility check."""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from ..io.units import UNITS


def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return v


def finite_float(text: str) -> float:
    """A finite number (NaN and +-inf refused)."""
    return _number(text)


def positive_float(text: str) -> float:
    """A finite number above 0."""
    v = _number(text)
    if not v > 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return v


def float_in(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, hi_open: bool = False,
             what: str = "number"):
    """Type function: a finite number in ``[lo, hi]`` (open ends with ``lo_open`` / ``hi_open``;
    ``None`` = unbounded)."""
    def parse(text: str) -> float:
        v = _number(text)
        bad = ((lo is not None and (v <= lo if lo_open else v < lo))
               or (hi is not None and (v >= hi if hi_open else v > hi)))
        if bad:
            rng = []
            if lo is not None:
                rng.append(f"{'above' if lo_open else 'at least'} {lo:g}")
            if hi is not None:
                rng.append(f"{'below' if hi_open else 'at most'} {hi:g}")
            raise argparse.ArgumentTypeError(f"must be a {what} {' and '.join(rng)}, got {text}")
        return v

    return parse


def int_in(lo: int | None = None, hi: int | None = None):
    """Type function: an integer in ``[lo, hi]`` (``None`` = unbounded)."""
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            rng = " and ".join(([f"at least {lo}"] if lo is not None else []) +
                               ([f"at most {hi}"] if hi is not None else []))
            raise argparse.ArgumentTypeError(f"must be an integer {rng}, got {text}")
        return v

    return parse


def scale_arg(text: str):
    """``--scale`` value: metres per file unit (a number) or a unit name."""
    if text in UNITS or text == "auto":
        return text
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is neither a number (metres per file unit) nor a unit ({', '.join(sorted(UNITS))})") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"scale must be a positive number, got {text}")
    return v


def fps_arg(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a frame rate (Hz)") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"frame rate must be positive, got {text}")
    return v


def render_output_arg(text: str) -> Path:
    """An output of :func:`mocomp.plots.render_audit.render_with_audit` (``mocomp render -o``, every
    command's ``--render``): a ``.mp4``, ``.gif`` or ``.png`` file in an existing, writable folder,
    checked at parse time (before a command does its work)."""
    from ..plots.render_audit import output_kind

    out = Path(text)
    try:
        output_kind(out)
        check_output_path(out, "render output")
    except (ValueError, OSError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return out


def frames_arg(text: str) -> tuple[int | None, int | None]:
    """``A:B``: a half-open frame range (``A:`` / ``:B`` leave an end open); checked against the
    motion's frame count when it is loaded (:func:`mocomp.plots.render_audit.resolve_frames`)."""
    from ..plots.render_audit import parse_frames

    try:
        a, b = parse_frames(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    if a is not None and b is not None and b - a < 2:
        raise argparse.ArgumentTypeError(f"frames {text}: the range must hold at least 2 frames (A < B - 1)")
    return a, b


def size_arg(text: str) -> tuple[int, int]:
    """``WxH``: an image size in pixels, even numbers in [16, 8192] (H.264 needs even sizes)."""
    w, sep, h = text.lower().partition("x")
    if not sep or not w.isdigit() or not h.isdigit():
        raise argparse.ArgumentTypeError(f"size {text!r} must be WIDTHxHEIGHT in pixels, e.g. 640x480")
    w, h = int(w), int(h)
    if not all(16 <= v <= 8192 and v % 2 == 0 for v in (w, h)):
        raise argparse.ArgumentTypeError(f"size {text}: width and height must be even numbers in [16, 8192]")
    return w, h


def check_output_path(out: Path, what: str = "output") -> Path:
    """Fail early, with one clear line, when ``out`` cannot be written as a file.

    Raises ``IsADirectoryError`` when ``out`` is a folder, ``NotADirectoryError`` when
    its parent is a file, ``FileNotFoundError`` when the parent folder is missing and
    ``PermissionError`` when an existing ``out`` or its folder is not writable (for the
    current user; root may write anyway, and then the write itself reports any error).
    Each message names the path and what is wrong; ``mocomp`` prints it and exits 2.
    """
    out = Path(out)
    if out.is_dir():
        raise IsADirectoryError(f"{what} {out} is a directory, not a file")
    parent = out.parent
    if parent.exists() and not parent.is_dir():
        raise NotADirectoryError(f"{what} folder {parent} is a file, not a directory")
    if not parent.is_dir():
        raise FileNotFoundError(f"{what} folder {parent} does not exist")
    if out.exists() and not os.access(out, os.W_OK):
        raise PermissionError(f"{what} {out} is read-only")
    if not out.exists() and not os.access(parent, os.W_OK | os.X_OK):
        raise PermissionError(f"{what} folder {parent} is not writable")
    return out


def gravity_arg(text: str):
    """``--gravity``: ``standard``, ``clip`` or a number of m/s^2 in [0.5, 100]
    (:func:`mocomp.dynamics.constants.resolve_gravity`, which the methods apply)."""
    from ..dynamics.constants import GRAVITY_CHOICES, resolve_gravity

    key = text.strip().lower()
    if key in GRAVITY_CHOICES:
        return key
    try:
        return resolve_gravity(finite_float(text))[0]
    except (ValueError, argparse.ArgumentTypeError) as exc:
        raise argparse.ArgumentTypeError(f"expected standard, clip or a number of m/s^2 in [0.5, 100], got {text!r}"
                                         ) from exc


def add_gravity_arg(p: argparse.ArgumentParser, what: str = "the input flight") -> None:
    """``--gravity standard|clip|G`` of the commands that generate a flight (issue #13 section 3)."""
    p.add_argument("--gravity", type=gravity_arg, default="standard", metavar="standard|clip|G",
                   help="gravity the generated flight falls with: standard (9.81 m/s^2, default), clip (the "
                        f"gravity fitted to {what}, the paper's choice, which carries a frame-rate or unit error "
                        "of the clip into the output) or G in m/s^2; the fitted value is reported either way")


def add_load_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("motion", metavar="FILE_OR_NAME",
                   help="a motion file (BVH, ASF/AMC, DeepMimic), an embedded example name or a real clip name "
                        "(file stem or CMU trial id, looked up in $MOCOMP_DATA_DIR); see mocomp.datasets.list()")
    p.add_argument("--scale", type=scale_arg, metavar="S|UNIT",
                   help="metres per file length unit, or a unit (" + ", ".join(sorted(UNITS)) +
                        "); default: the source's known unit, else guessed from body height")
    p.add_argument("--fps", type=fps_arg, metavar="F",
                   help="frame rate to use instead of the file header's (some clips have wrong headers)")
    p.add_argument("--raw", action="store_true",
                   help="do not apply the known per-clip corrections (true frame rate, unit, T-pose frame)")


def load_from_args(args):
    """The motion named by ``args.motion`` with the ``--scale/--fps/--raw`` options."""
    from .. import datasets

    return datasets.load(args.motion, fps=args.fps, scale=args.scale, raw=args.raw)


def check_flight(prep, args, command: str, *, override: str = "--flight START STOP",
                 fps_hint: str = "--fps F", explicit: bool | None = None) -> None:
    """Refuse an implausible detected flight of ``prep`` (a prepared clip), or warn on stderr
    (``mocomp COMMAND: warning: ...``, one line) about an implausible flight the user gave with
    ``--flight`` (:mod:`mocomp.flips.plausibility`: duration, fitted gravity against its band)."""
    from ..flips.plausibility import check_prepared, enforce_flight

    if explicit is None:
        explicit = getattr(args, "flight", None) is not None
    warning = enforce_flight(check_prepared(prep), prep.name, explicit=explicit, override=override,
                             fps_hint=fps_hint)
    if warning:
        print(f"mocomp {command}: warning: {' '.join(warning.split())}", file=sys.stderr)


# ------------------------------------------------------------------ the audit of a command's output
#: what the ``provenance`` key of a command's JSON report says about its other keys
PLANNED_NOTE = ("every key but 'audit' and 'provenance' holds the method's model values as it planned them; "
                "'audit' holds what mocomp.audit measured on the frames written (read back from the output "
                "file) against the input")


def add_audit_arg(p: argparse.ArgumentParser) -> None:
    """``--no-audit``: skip the audit of the written motion (issue #13 section 2); ``--render FILE``:
    draw the written motion with its audit, beside the input (issue #13 section 4; :func:`finish_audit`)."""
    p.add_argument("--no-audit", action="store_true",
                   help="do not audit the written motion (by default the summary ends with the verdict of "
                        "mocomp.audit on the frames written, against the input; for speed-sensitive batch use)")
    p.add_argument("--render", type=render_output_arg, metavar="FILE",
                   help="also draw the written motion with its audit (as mocomp render): .mp4, .gif or .png "
                        "(phase filmstrip), beside the input (with --no-audit: the written motion alone)")


def _by_check(findings) -> dict[str, int]:
    out: dict[str, int] = {}
    for f in findings:
        out[f.check] = out.get(f.check, 0) + 1
    return out


def _counts_text(counts: dict[str, int]) -> str:
    return ", ".join(f"{k} {v}" for k, v in counts.items())


#: a violation the input also has (same check, same place) counts as worse when it is larger by more than
#: this fraction of its threshold: the tolerance :class:`mocomp.audit.AuditComparison` uses for its measures
WORSE_FRACTION = 0.25


def new_violations(report, inputs=()) -> tuple[tuple[object, object], ...]:
    """The violations of the audited output that its input does not have, as ``(finding, matched)``
    pairs in the output's frame order.

    The inputs are ``report.against`` and the further :class:`~mocomp.audit.AuditReport` ``inputs``.
    Frames are not comparable across an edit (retiming moves them), so a violation is matched by its
    check and place (``Finding.where``: effector, joint, flight or event, e.g. ``"take-off of flight
    1"``). It is new when no input has a violation of that check at that place (``matched`` is
    ``None``), and worse when the largest such one (``matched``) is smaller by more than
    :data:`WORSE_FRACTION` of the threshold.
    """
    refs = [r for r in ((report.against,) + tuple(inputs)) if r is not None]
    best: dict[tuple[str, str], object] = {}
    for r in refs:
        for f in r.violations:
            k = (f.check, f.where)
            if k not in best or f.size > best[k].size:
                best[k] = f
    cmp = getattr(report, "comparison", None)
    out = []
    for f in report.violations:
        # the input's flight numbering (flights paired by time, not index: mocomp.audit.pairing)
        m = best.get((f.check, cmp.place_in_other(f.where) if cmp is not None else f.where))
        if m is None or f.size - m.size > WORSE_FRACTION * f.threshold:
            out.append((f, m))
    return tuple(out)


@dataclass(frozen=True)
class OutputAudit:
    """The audit of a motion a command wrote, against its input(s).

    report: :class:`~mocomp.audit.AuditReport` of the motion read back from ``path``, with
        ``against`` (and ``comparison``) the first input's audit.
    others: audits of further inputs (``mocomp join``'s landing motion).
    new: ``(finding, matched input finding or None)`` for each violation the input(s) lack or have
        smaller (:func:`new_violations`).
    verdict_line: the last line a command prints.
    warning: the one-line warning (without the ``mocomp CMD: warning:`` prefix) when ``new``
        is non-empty, else ``None``.
    path: the audited file; motion: the motion read back from it (what was audited);
    input_motion, input_name: the (first) input it was audited against (``--render`` draws both).
    """

    report: object
    others: tuple
    new: tuple
    verdict_line: str
    warning: str | None
    path: Path | None = None
    motion: object = None
    input_motion: object = None
    input_name: str = "input"

    def to_dict(self) -> dict:
        d = self.report.to_dict()
        d["new_violations"] = [dict(f.to_dict(), input_size=None if m is None else float(m.size))
                               for f, m in self.new]
        if self.others:
            d["other_inputs"] = [{"name": o.name, "verdict": o.verdict, "violations": len(o.violations),
                                  "by_check": _by_check(o.violations)} for o in self.others]
        return d


def audit_output(path, input_motion, *, body=None, name: str | None = None, input_name: str = "input",
                 other_inputs=(), external_force_frames=None, thresholds=None,
                 against_frame_map=None) -> OutputAudit:
    """Audit the motion a command wrote to the BVH file ``path`` (read back: physics is measured on
    the frames a command writes) against ``input_motion`` with :func:`mocomp.audit.audit` and its
    default :class:`~mocomp.audit.AuditThresholds`; ``other_inputs`` are ``(name, Motion)`` pairs
    of further inputs whose violations also count as the input's (``mocomp join``);
    ``external_force_frames``: frames under a declared external force, passed to the audit (``mocomp impact``);
    ``thresholds``: :class:`~mocomp.audit.AuditThresholds` instead of the defaults (the editing-primitive
    commands judge pose jumps as violations); ``against_frame_map``: the input frame of each written frame
    for the audit's pose-jump check (default: matched by time).

    The verdict line reads ``audit: FAIL, 2 violation(s) (com_velocity_jump 2), 1 advisory; input:
    PASS, 0 violation(s); new or worse: com_velocity_jump 2; worse than the input on 3 measure(s): ...``
    (the measures of :class:`~mocomp.audit.AuditComparison`).
    """
    from ..audit import audit
    from ..io.bvh import read_bvh

    path = Path(path)
    written = read_bvh(path, scale=1.0)           # the commands write BVH in metres (write_bvh's default)
    label = name or str(path)
    kw = {} if external_force_frames is None else {"external_force_frames": external_force_frames}
    if thresholds is not None:
        kw["thresholds"] = thresholds
    if against_frame_map is not None:
        kw["against_frame_map"] = against_frame_map
    rep = audit(written, body, against=input_motion, name=label, against_name=input_name, **kw)
    others = tuple(audit(m, name=n, **({} if thresholds is None else {"thresholds": thresholds}))
                   for n, m in other_inputs)
    new = new_violations(rep, others)

    def state(r) -> str:
        c = _by_check(r.violations)
        return f"{r.verdict.upper()}, {len(r.violations)} violation(s)" + (f" ({_counts_text(c)})" if c else "")

    inputs = [rep.against] + list(others)
    in_text = "; ".join(f"{'input' if len(inputs) == 1 else r.name}: {state(r)}" for r in inputs)
    worse = rep.comparison.worse if rep.comparison is not None else ()
    worse = tuple(k for k in worse if k != "violations")
    counts = _by_check(f for f, _ in new)
    line = (f"audit: {state(rep)}, {len(rep.advisories)} advisory; {in_text}; "
            + (f"new or worse: {_counts_text(counts)}" if new else "no new or worse violations")
            + (f"; worse than the input on {len(worse)} measure(s): {', '.join(worse)}" if worse else ""))
    warning = None
    if new:
        items = [f"{f.check} at {f.where}, {f.frames_text()} ({f.size:.3g} {f.unit}, limit {f.threshold:.3g}"
                 + ("" if m is None else f"; input {m.size:.3g}") + ")" for f, m in new]
        warning = (f"the output {label} has {len(new)} violation(s) new or worse than "
                   f"{'its inputs' if others else 'its input'}: " + "; ".join(items))
    return OutputAudit(rep, others, new, line, warning, path, written, input_motion, input_name)


#: when this module was imported (the command line is parsed after it): files a command wrote into an
#: output folder are those modified since
_STARTED = time.time()


def _written_motion_file(args) -> Path | None:
    """The motion file a command wrote when it was not audited (``--no-audit``): its ``--output``
    (``-o``) BVH file, or, for a command whose ``-o`` is a folder (``mocomp demo``), the one BVH file
    written into it during this run that is not a copy of the input (``*_original.bvh``)."""
    out = getattr(args, "output", None) or getattr(args, "out", None)
    if out is None:
        return None
    out = Path(out)
    if out.is_file():
        return out
    if out.is_dir():
        new = sorted(f for f in out.glob("*.bvh") if f.stat().st_mtime >= _STARTED - 1.0
                     and not f.stem.endswith("_original"))
        if len(new) == 1:
            return new[0]
    return None


def render_output(args, command: str, result: "OutputAudit | None") -> None:
    """``--render FILE``: draw the written motion with its audit beside the input
    (:func:`mocomp.plots.render_audit.render_with_audit`, reusing ``result``'s audits), or, with
    ``--no-audit`` (``result`` ``None``), the written motion alone; prints one ``wrote`` line."""
    from ..plots.render_audit import render_with_audit

    target = getattr(args, "render", None)
    if target is None:
        return
    if result is not None:
        res = render_with_audit(result.motion, target, against=result.input_motion,
                                name=Path(result.path).name if result.path else "output",
                                against_name=Path(str(result.input_name)).name,
                                reports=(result.report, result.report.against))
    else:
        src = _written_motion_file(args)
        if src is None:
            print(f"mocomp {command}: warning: --render {target}: cannot tell which file this run wrote; "
                  f"draw it with: mocomp render FILE -o {target}", file=sys.stderr)
            return
        from ..io.bvh import read_bvh

        res = render_with_audit(read_bvh(src, scale=1.0), target, name=src.name)
    print(res.summary())


def finish_audit(args, command: str, result: "OutputAudit | None", report_path=None) -> None:
    """Print the audit's warning (stderr, ``mocomp COMMAND: warning: ...``) and its verdict line
    (stdout, the command's last line), and add ``audit`` and ``provenance`` to the JSON report at
    ``report_path`` (the method's keys stay as they are: they are its planned values). With
    ``result`` ``None`` (``--no-audit``) only the report's provenance says that no audit ran.
    With ``--render FILE`` (:func:`add_audit_arg`) the written motion is drawn first
    (:func:`render_output`); if drawing fails the verdict is still printed before the error."""
    import json

    if report_path is not None:
        p = Path(report_path)
        d = json.loads(p.read_text())
        if not isinstance(d, dict):
            d = {"planned": d}
        d["provenance"] = {"planned": PLANNED_NOTE if result is not None else
                           "every key but 'provenance' holds the method's model values as it planned them; "
                           "no audit ran (--no-audit)",
                           "measured": "audit" if result is not None else None}
        d["audit"] = result.to_dict() if result is not None else None
        p.write_text(json.dumps(d, indent=1) + "\n")
    try:
        render_output(args, command, result)
    finally:
        if result is not None:
            if result.warning:
                print(f"mocomp {command}: warning: {result.warning}", file=sys.stderr)
            print(result.verdict_line)
