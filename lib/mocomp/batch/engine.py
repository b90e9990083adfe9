"""Map a function over many independent items on a Dask cluster: the one mechanism behind
``mocomp batch`` and the many-item loops of the project (``mocomp study render``).

:func:`open_client` starts a :class:`dask.distributed.LocalCluster` (one single-threaded worker
process per core by default) or connects to an existing scheduler (``tcp://HOST:PORT``) - the
same code path after that: :func:`map_items` submits one task per item and yields each item's
:class:`Outcome` as it completes, in completion order:

- a value returned by the function;
- an exception the function raised (``error``, with its traceback text), the item failed;
- a crash of the worker process that ran the item (segfault, ``os.abort``, killed for memory):
  Dask reschedules the task on another worker and, after ``allowed_failures`` such deaths, gives
  up with :class:`distributed.KilledWorker`; the item is reported ``crashed`` and the batch goes on
  (the nanny restarts the dead worker). On a LocalCluster ``allowed_failures`` is set by
  :func:`open_client` (default 1: one retry, so a transient death is retried once); an existing
  cluster uses its scheduler's ``distributed.scheduler.allowed-failures`` (Dask's default 3).

``workers=0`` runs the items one after the other in the calling process with the same outcomes
(no cluster; for small runs and callers that keep state such as open renderers between items).
"""
from __future__ import annotations

import contextlib
import logging
import os
import time
import traceback
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

__all__ = ["Outcome", "open_client", "map_items", "default_workers"]

#: worker deaths a task may be involved in before Dask gives up on it (LocalCluster only)
ALLOWED_FAILURES = 1


@dataclass
class Outcome:
    """What became of one item.

    index: position of the item in the input sequence; item: the item.
    status: ``ok`` (``value`` holds the function's result), ``failed`` (the function raised:
        ``error`` is ``"Type: message"``, ``traceback`` its text, ``exception`` the exception when it
        could be returned) or ``crashed`` (the worker process died running it, ``error`` says so).
    seconds: wall time from submission to completion (queueing included).
    """

    index: int
    item: Any
    status: str
    value: Any = None
    error: str | None = None
    traceback: str | None = None
    exception: BaseException | None = None
    seconds: float = float("nan")


def default_workers() -> int:
    """Worker processes of a LocalCluster by default: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def open_client(workers: int | None = None, scheduler: str | None = None, *,
                allowed_failures: int = ALLOWED_FAILURES, memory_limit: str | None = "auto"):
    """A :class:`dask.distributed.Client`: on ``scheduler`` (an existing cluster) or on a new
    LocalCluster of ``workers`` single-threaded worker processes (default :func:`default_workers`),
    closed on exit. Raises ``OSError`` naming the scheduler when it cannot be reached."""
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise ConnectionError(f"scheduler {scheduler}: cannot connect ({' '.join(str(e).split())})") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise ValueError(f"workers must be at least 1 for a cluster, got {n}")
    # worker-saturation 1.0: a worker holds only the task it runs, so a crash takes no queued item down with it
    with dask.config.set({"distributed.scheduler.allowed-failures": int(allowed_failures),
                          "distributed.scheduler.worker-saturation": 1.0}):
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               memory_limit=memory_limit, silence_logs=logging.CRITICAL)
        client = Client(cluster)
    try:
        yield client
    finally:
        with contextlib.suppress(Exception):
            client.close()
        with contextlib.suppress(Exception):
            cluster.close()


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def _crash_text(exc: BaseException) -> str:
    import re

    m = re.search(r"on (\d+) different workers", str(exc))
    tries = f"{m.group(1)} attempts" if m else "every attempt"
    return (f"the worker process died while running it ({tries}; a segfault or abort, or killed for "
            "memory); Dask gave up on it (KilledWorker)")


def map_items(func: Callable, items: Iterable, *, client=None, workers: int | None = None,
              scheduler: str | None = None, name: str = "item") -> Iterator[Outcome]:
    """Yield the :class:`Outcome` of ``func(item)`` for every item, in completion order.

    client: an open :class:`~dask.distributed.Client` (e.g. from :func:`open_client`); else a
        cluster is opened for this call with ``workers`` / ``scheduler``, and ``workers=0`` runs the
        items in this process, in order.
    func must be importable by the workers (a module-level function) and its items picklable; on
    an existing cluster the workers need the same ``mocomp`` installed and the same paths.
    """
    items = list(items)
    if client is None and scheduler is None and workers == 0:
        yield from _map_local(func, items)
        return
    if client is None:
        with open_client(workers, scheduler) as c:
            yield from _map_dask(func, items, c, name)
        return
    yield from _map_dask(func, items, client, name)


def _map_local(func, items) -> Iterator[Outcome]:
    for i, it in enumerate(items):
        t0 = time.perf_counter()
        try:
            v = func(it)
        except Exception as e:  # noqa: BLE001 - one item's failure is its outcome
            yield Outcome(i, it, "failed", error=_describe(e), traceback=traceback.format_exc(), exception=e,
                          seconds=time.perf_counter() - t0)
        else:
            yield Outcome(i, it, "ok", value=v, seconds=time.perf_counter() - t0)


def _map_dask(func, items, client, name) -> Iterator[Outcome]:
    from dask.distributed import as_completed
    from distributed.scheduler import KilledWorker

    if not items:
        return
    token = uuid.uuid4().hex[:10]
    keys = [f"{name}-{token}-{i}" for i in range(len(items))]
    t0 = time.perf_counter()
    futures = client.map(func, items, key=keys, pure=False, retries=0)
    index = {f.key: i for i, f in enumerate(futures)}
    try:
        # results are fetched as soon as each task ends: a result left in a worker's memory would be lost
        # with the worker when a later item crashes it
        for fut, res in as_completed(futures, with_results=True, raise_errors=False):
            i = index[fut.key]
            dt = time.perf_counter() - t0
            if fut.status == "finished":
                yield Outcome(i, items[i], "ok", value=res, seconds=dt)
                fut.release()
                continue
            # an error comes as the future's exception (``res`` is then Dask's (type, value, traceback))
            exc = fut.exception() if fut.status == "error" else None
            if isinstance(exc, KilledWorker):
                yield Outcome(i, items[i], "crashed", error=_crash_text(exc), exception=exc, seconds=dt)
            else:
                tb = fut.traceback() if fut.status == "error" else None
                yield Outcome(i, items[i], "failed", error=_describe(exc) if exc is not None else
                              f"the task ended with status {fut.status}",
                              traceback="".join(traceback.format_tb(tb)) if tb is not None else None,
                              exception=exc, seconds=dt)
            fut.release()
    finally:
        client.cancel([f for f in futures if not f.done()])
