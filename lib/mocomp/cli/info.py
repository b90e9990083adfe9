"""``mocomp info FILE_OR_NAME``: joints, frames, fps, duration, units, height (and how it was estimated), root travel."""
from __future__ import annotations

import json


def register(sub) -> None:
    from ._common import add_load_args

    p = sub.add_parser(
        "info", help="summarise a motion: joints, frames, fps, duration, units, height, root travel",
        description="Summarise a motion file or named clip: joints, frames, frame rate (used, and where it comes "
                    "from: the header, the key-frame times, the generator), duration, the length unit applied and "
                    "why, standing height, root travel and the fastest joint. Implausible heights or speeds point "
                    "at a wrong unit or frame rate.")
    add_load_args(p)
    p.add_argument("--json", action="store_true", help="print the summary as JSON (all joint names included)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..io.summary import summarize
    from ._common import load_from_args

    m = load_from_args(args)
    s = summarize(m, name=str(args.motion))
    if args.json:
        print(json.dumps(s.to_dict(), indent=2))
    else:
        print(s.to_text())
    return 0
