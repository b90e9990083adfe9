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
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

__all__ = ["Outcome", "open_client", "map_items", "default_workers"]

#: worker deaths a task may be involved in before Dask gives up on it (LocalCluster only)
ALLOWED_FAILURES = 1
#: seconds without any worker after which a local cluster's workers are replaced
REVIVE_SECONDS = 15.0


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
        with warnings.catch_warnings():  # the scheduler's port probing leaves sockets to the collector
            warnings.simplefilter("ignore", ResourceWarning)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
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
              scheduler: str | None = None, name: str = "item", fetch: bool = True,
              fetch_timeout: float = 300.0, done: Callable | None = None,
              stall_seconds: float = 120.0) -> Iterator[Outcome]:
    """Yield the :class:`Outcome` of ``func(item)`` for every item, in completion order.

    client: an open :class:`~dask.distributed.Client` (e.g. from :func:`open_client`); else a
        cluster is opened for this call with ``workers`` / ``scheduler``, and ``workers=0`` runs the
        items in this process, in order.
    fetch: bring each result back (``Outcome.value``); ``False`` when the function leaves its result
        in files (``mocomp batch``: row.json), so no result can be lost with a worker that crashes on a
        later item before the client fetched it.
    done: ``done(item) -> bool``, whether an item's files say it is complete: an item still pending
        on the scheduler (its result lost with its worker and waiting to be computed again) whose
        ``done`` is true is reported ``ok`` and its task cancelled.
    stall_seconds: on a cluster this call started, the items left are reported ``failed`` when the
        cluster has had no worker for that long (a worker that keeps failing to start).
    func must be importable by the workers (a module-level function) and its items picklable; on
    an existing cluster the workers need the same ``mocomp`` installed and the same paths.
    """
    items = list(items)
    if client is None and scheduler is None and workers == 0:
        yield from _map_local(func, items)
        return
    if client is None:
        with open_client(workers, scheduler) as c:
            yield from _map_dask(func, items, c, name, fetch, fetch_timeout, done,
                                 stall_seconds if scheduler is None else None)
        return
    yield from _map_dask(func, items, client, name, fetch, fetch_timeout, done,
                         stall_seconds if getattr(client, "cluster", None) is not None else None)


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


def _map_dask(func, items, client, name, fetch: bool, fetch_timeout: float, done, stall) -> Iterator[Outcome]:
    from distributed import wait
    from distributed.scheduler import KilledWorker

    if not items:
        return
    token = uuid.uuid4().hex[:10]
    keys = [f"{name}-{token}-{i}" for i in range(len(items))]
    t0 = time.perf_counter()
    pending = {f.key: f for f in client.map(func, items, key=keys, pure=False, retries=0)}
    index = {k: i for i, k in enumerate(keys)}
    last_scan = last_worker = revived = time.monotonic()

    def outcome(fut) -> Outcome:
        i = index[fut.key]
        dt = time.perf_counter() - t0
        if fut.status == "finished":
            value = None
            if fetch:
                # a result lives in its worker's memory until fetched: when a later item crashes that
                # worker first, it is lost (the item's files, if any, are not)
                try:
                    value = fut.result(timeout=fetch_timeout)
                except Exception as e:  # noqa: BLE001
                    return Outcome(i, items[i], "failed", error=f"the item ran but its result was lost: "
                                   f"{_describe(e)}", exception=e, seconds=dt)
            return Outcome(i, items[i], "ok", value=value, seconds=dt)
        exc = fut.exception() if fut.status == "error" else None
        if isinstance(exc, KilledWorker):
            return Outcome(i, items[i], "crashed", error=_crash_text(exc), exception=exc, seconds=dt)
        tb = fut.traceback() if fut.status == "error" else None
        return Outcome(i, items[i], "failed", error=_describe(exc) if exc is not None else
                       f"the task ended with status {fut.status}",
                       traceback="".join(traceback.format_tb(tb)) if tb is not None else None,
                       exception=exc, seconds=dt)

    try:
        while pending:
            try:
                finished = wait(list(pending.values()), timeout=2.0, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                finished = set()
            for fut in finished:
                o = outcome(fut)
                del pending[fut.key]
                fut.release()
                yield o
            now = time.monotonic()
            if now - last_scan < 5.0:
                continue
            last_scan = now
            if done is not None:  # items finished on disk whose result was lost with their worker
                for k in [k for k, f in pending.items() if f.status != "finished" and done(items[index[k]])]:
                    fut = pending.pop(k)
                    fut.cancel()
                    yield Outcome(index[k], items[index[k]], "ok", seconds=time.perf_counter() - t0)
            if stall is not None and pending:
                if client.scheduler_info().get("workers"):
                    last_worker = revived = now
                elif now - revived > REVIVE_SECONDS and getattr(client, "cluster", None) is not None:
                    # a worker process that dies while its nanny is still starting it is not restarted by
                    # the nanny (Dask 2026.8): replace the local cluster's workers
                    revived = now
                    cluster = client.cluster
                    n = max(1, len(cluster.worker_spec))
                    cluster.scale(0)
                    cluster.scale(n)
                elif now - last_worker > stall:
                    for k, fut in list(pending.items()):
                        fut.cancel()
                        del pending[k]
                        yield Outcome(index[k], items[index[k]], "failed", seconds=time.perf_counter() - t0,
                                      error=f"not run: the cluster has had no worker for {stall:.0f} s (its "
                                            "workers died and could not be started again)")
    finally:
        client.cancel(list(pending.values()))
