"""Imported once by the forkserver of a local batch cluster (``mocomp.batch.engine.WORKER_PRELOAD``):
every ``mocomp`` command imported (the CLI parser built) and the reader and audit called once on an
embedded example clip (:func:`mocomp.batch.runner._warm_up`), so that each worker process forked
from it starts with all of that done instead of doing it itself (~3 s per worker on this host, the
two workers of a 2-core host competing for the cores). A failure here only loses that head start:
the workers then warm up on their own."""
from __future__ import annotations

try:
    from .runner import _warm_up

    _warm_up()
except Exception:  # noqa: BLE001 - never break the forkserver (its workers would not start)
    pass
