"""The ``mocomp`` command line.

Each command lives in its own module under :mod:`mocomp.cli` with a
``register(subparsers)`` function that adds a sub-parser whose ``func(args)``
returns an exit code. Add a module's name to ``COMMAND_MODULES`` to expose it.
Bad input prints one clear line on stderr and exits 2: argument errors
(``mocomp CMD: error: ... (see mocomp CMD --help)``, from :class:`Parser`, the
class of the main parser and, through ``add_subparsers``, of every command's
and sub-command's parser), :class:`~mocomp.errors.MocompError`, ``ValueError``
from argument checks, and every ``OSError`` (missing input, an output path that
is a directory, a read-only file, a parent that is not a folder), named by the
path and what is wrong.
"""
from __future__ import annotations

import argparse
import importlib
import os
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
    "audit", "render",
    "footplant", "blend", "pathedit", "slope", "concat",
    "touchup", "batch", "impact",
    "impact_index",
    "reproduce",
]


class Parser(argparse.ArgumentParser):
    """``ArgumentParser`` whose errors are one line: ``PROG: error: MESSAGE (see PROG --help)``, exit 2.

    ``add_subparsers`` makes its sub-parsers of the calling parser's class, so
    every command registered under the main parser (and every sub-command of
    those) reports argument errors this way without naming this class.
    """

    def error(self, message: str):  # noqa: D102 (argparse API)
        msg = " ".join(str(message).split())
        self.exit(2, f"{self.prog}: error: {msg} (see {self.prog} --help)\n")

    def parse_args(self, args=None, namespace=None):
        """As ``ArgumentParser.parse_args``, but unrecognised arguments are reported by the
        (sub-)command they were given to (``mocomp info: error: unrecognized arguments: ...``)."""
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            self._leaf(ns).error(f"unrecognized arguments: {' '.join(extras)}")
        return ns

    def _leaf(self, ns) -> argparse.ArgumentParser:
        """The innermost sub-parser the parsed namespace ``ns`` went through."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                child = action.choices.get(getattr(ns, action.dest, None) or "")
                if child is not None:
                    return child._leaf(ns) if isinstance(child, Parser) else child
        return self


def _os_error_text(e: OSError) -> str:
    """One line for an ``OSError``: the path(s) and what is wrong, e.g. ``D.bvh: is a directory``.

    Errors raised with a message of their own (``FileNotFoundError("output folder ... does not
    exist")``, :class:`~mocomp.errors.DataNotFoundError`) keep it.
    """
    if e.strerror is None:
        return str(e) or type(e).__name__
    what = e.strerror[:1].lower() + e.strerror[1:]
    if e.filename is None:
        return what
    paths = str(e.filename) + (f" -> {e.filename2}" if getattr(e, "filename2", None) else "")
    return f"{paths}: {what}"


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = Parser(
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
    except BrokenPipeError:  # stdout closed by the reader (mocomp info ... | head): stop quietly
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 1
    except OSError as e:  # FileNotFoundError, PermissionError, IsADirectoryError, NotADirectoryError, ...
        msg = _os_error_text(e)
        print(f"mocomp {args.command}: error: {' '.join(msg.split())}", file=sys.stderr)
        return 2
    except (MocompError, ValueError, KeyError) as e:
        msg = str(e).strip().strip('"')
        print(f"mocomp {args.command}: error: {' '.join(msg.split())}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
