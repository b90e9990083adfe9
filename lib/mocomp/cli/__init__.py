"""The ``mocomp`` command line.

Each command lives in its own module under :mod:`mocomp.cli` with a
``register(subparsers)`` function that adds a sub-parser whose ``func(args)``
returns an exit code. Add a module's name to ``COMMAND_MODULES`` to expose it.
Bad input (:class:`~mocomp.errors.MocompError`, ``FileNotFoundError``,
``ValueError`` from argument checks) prints one clear line and exits 2.
"""
from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from ..errors import MocompError

COMMAND_MODULES: list[str] = [
    "info", "convert", "plot",
    "study",
    "splice",
    "flips",
    "demo",
    "edit", "join", "twist",
]


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="mocomp",
        description="Physically based editing of human motion capture (see README.md).",
    )
    parser.add_argument("--version", action="version", version=f"mocomp {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            return int(args.func(args) or 0)
    except (MocompError, FileNotFoundError, ValueError, KeyError) as e:
        msg = str(e).strip().strip('"')
        print(f"mocomp {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
