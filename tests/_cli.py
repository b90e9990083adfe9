"""Running ``mocomp`` in-process in the tests."""
from __future__ import annotations

from mocomp.cli import main


def exit_code(argv) -> int:
    """``mocomp ARGV``'s exit status, whether ``main`` returns it or argparse raises ``SystemExit``."""
    try:
        return main(argv)
    except SystemExit as e:
        return e.code
