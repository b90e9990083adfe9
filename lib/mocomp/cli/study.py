"""``mocomp study ...``: the perception study (stimulus rendering, participant app, analysis).

The work is done by the separate :mod:`study` package (which uses mocomp, not
the other way round); this module only glues its sub-commands into the CLI,
importing them when the ``mocomp`` parser is built. To add a sub-command,
append ``("study.<module>", "<register function>")`` to :data:`SUBCOMMANDS`;
the function receives the ``study`` command's sub-parsers and adds one
sub-parser with ``set_defaults(func=...)``.
"""
from __future__ import annotations

import importlib

#: (module, function) pairs, in the order ``mocomp study --help`` lists them.
SUBCOMMANDS: list[tuple[str, str]] = [
    ("study.render_cli", "register_render"),
    ("study.study_cli", "register_run"),
    ("study.study_cli", "register_withdraw"),
    ("study.study_cli", "register_analyze"),
]


def register(subparsers) -> None:
    p = subparsers.add_parser("study", help="perception study: render stimuli, run participants, analyse",
                              description="The perception study of the flips paper (section 7): "
                                          "`render` stimuli, `run` a participant session, `withdraw` one, `analyze` responses.")
    sub = p.add_subparsers(dest="study_command", metavar="SUBCOMMAND")
    sub.required = True
    for mod, fn in SUBCOMMANDS:
        try:
            module = importlib.import_module(mod)
        except ModuleNotFoundError as e:
            if e.name in (mod, mod.split(".")[0]):  # that sub-command is not installed
                continue
            raise
        getattr(module, fn)(sub)
