"""Worker plugin of ``mocomp batch`` (its own module: it imports ``distributed``, which the rest of
:mod:`mocomp.batch` imports only when a cluster is used)."""
from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin


class WarmUp(WorkerPlugin):
    """Import the commands when a worker starts (also a worker restarted after a crash), so that no
    clip's time holds the imports."""

    name = "mocomp-batch-warm-up"

    def setup(self, worker=None):
        from ..cli import build_parser

        build_parser()
