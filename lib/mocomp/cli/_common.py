"""Argument helpers shared by the ``mocomp`` commands: option types that reject what a
command cannot use (NaN, infinities, values out of the option's range) at parse time, with
one line naming the option (argparse prefixes ``argument --OPTION:``), the loading options,
output-path checks and the flight plausibility check."""
from __future__ import annotations

import argparse
import math
import os
import sys
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
