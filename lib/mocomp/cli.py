"""Command-line entry point ``mocomp`` (filled in by the CLI module)."""
import sys


def main(argv=None) -> int:
    print("mocomp: CLI under construction", file=sys.stderr)
    return 2
