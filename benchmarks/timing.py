"""Timing helpers shared by the ``bench_*.py`` modules (importable as ``timing``:
the runner puts this folder on ``sys.path``)."""
from __future__ import annotations

import gc
import time
from typing import Any, Callable

__all__ = ["best_of", "result"]


def best_of(fn: Callable[[Any], Any], repeat: int = 5, setup: Callable[[], Any] | None = None,
            ) -> tuple[float, Any]:
    """Minimum wall time of ``fn(setup())`` over ``repeat`` runs, and the last output.

    ``setup`` (untimed) builds a fresh input for each run, e.g. a new Motion whose
    FK cache is empty. The garbage collector is paused while timing, as in
    :mod:`timeit`. The minimum is the least noisy estimate on a shared machine.
    """
    best = float("inf")
    out = None
    for _ in range(max(1, repeat)):
        arg = setup() if setup is not None else None
        gc_was = gc.isenabled()
        gc.disable()
        try:
            t0 = time.perf_counter()
            out = fn(arg)
            dt = time.perf_counter() - t0
        finally:
            if gc_was:
                gc.enable()
        best = min(best, dt)
    return best, out


def result(name: str, ours_s: float, peer: str | None = None, peer_s: float | None = None,
           goal: str | None = None, note: str = "") -> dict:
    """One benchmark row as the runner expects it; ``ratio = peer_s / ours_s``
    (how many times faster ours is; > 1 means faster)."""
    ratio = (peer_s / ours_s) if (peer_s is not None and ours_s > 0) else None
    return {"name": name, "ours_s": ours_s, "peer": peer, "peer_s": peer_s, "ratio": ratio, "goal": goal,
            "note": note}
