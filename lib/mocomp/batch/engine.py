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

__all__ = ["Outcome", "open_client", "map_items", "default_workers", "chunk_sizes", "run_chunk", "ClientStarter"]

#: worker deaths a task may be involved in before Dask gives up on it (LocalCluster only)
ALLOWED_FAILURES = 1
#: seconds without any worker after which a local cluster's workers are replaced
REVIVE_SECONDS = 15.0
#: seconds between the checks of pending items (complete on disk, the cluster's workers)
SCAN_SECONDS = 5.0
#: how local worker processes start (:func:`open_client`)
START_METHOD = "forkserver"
#: modules the forkserver imports once for every local worker it forks
WORKER_PRELOAD = ("mocomp.batch._preload",)
#: seconds one attempt to fetch a result may block the loop (the loop's checks run in between)
FETCH_POLL_SECONDS = 2.0
#: items per task at most when :func:`map_items` chunks adaptively
MAX_CHUNK = 16


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


def _preload_forkserver() -> None:
    """Have the forkserver import mocomp's commands once (with Dask's own preloads), so that each
    local worker process is forked with them imported instead of importing them itself."""
    import multiprocessing
    import multiprocessing.forkserver as fs

    from distributed.utils import get_mp_context

    with contextlib.suppress(Exception):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import dask

            with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
                get_mp_context()  # Dask's preload list, set once per process
        have = list(getattr(fs._forkserver, "_preload_modules", []) or [])
        want = have + [m for m in WORKER_PRELOAD if m not in have]
        multiprocessing.get_context("forkserver").set_forkserver_preload(want)


@contextlib.contextmanager
def open_client(workers: int | None = None, scheduler: str | None = None, *,
                allowed_failures: int = ALLOWED_FAILURES, memory_limit: str | None = "auto",
                start_method: str = START_METHOD):
    """A :class:`dask.distributed.Client`: on ``scheduler`` (an existing cluster) or on a new
    LocalCluster of ``workers`` single-threaded worker processes (default :func:`default_workers`),
    closed on exit. Raises ``OSError`` naming the scheduler when it cannot be reached.

    start_method: how the local worker processes start: ``"forkserver"`` (default) forks them from
    a server process that imported mocomp's commands once (:data:`WORKER_PRELOAD`), so two
    workers do not each import them on a 2-core host; ``"spawn"`` (Dask's default) starts each
    afresh. The ``MOCOMP_*`` variables of this process are passed to the workers either way."""
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
    cfg = {"distributed.scheduler.allowed-failures": int(allowed_failures),
           "distributed.scheduler.worker-saturation": 1.0}
    if start_method == "forkserver":
        cfg["distributed.worker.multiprocessing-method"] = "forkserver"
        _preload_forkserver()
    with dask.config.set(cfg):
        with warnings.catch_warnings():  # the scheduler's port probing leaves sockets to the collector
            warnings.simplefilter("ignore", ResourceWarning)
            # the project's switches (MOCOMP_*) as the client has them now: a forked worker would
            # otherwise have the forkserver's environment of when it started
            env = {k: v for k, v in os.environ.items() if k.startswith("MOCOMP_")}
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   memory_limit=memory_limit, silence_logs=logging.CRITICAL, env=env)
            client = Client(cluster)
    try:
        yield client
    finally:
        with contextlib.suppress(Exception):
            client.close()
        with contextlib.suppress(Exception):
            cluster.close()


class ClientStarter:
    """:func:`open_client` in a background thread, so that a local cluster's worker processes start
    (and import) while the caller does its own preparation (``mocomp batch``: the inputs classified,
    finished clips read back for ``--resume``).

    ``setup``: a function run on every worker once the cluster is up (``client.run``: imports, the
    first call of the code the items will run). :meth:`get` waits for the client (re-raising an
    error of the start); :meth:`close` closes it (after waiting for a start still under way).
    ``start_seconds``: how long the start took; ``waited_seconds``: how long :meth:`get` waited for it.
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None, setup: Callable | None = None):
        import threading

        self._stack = contextlib.ExitStack()
        self._client = None
        self._error: BaseException | None = None
        self.start_seconds = float("nan")
        self.waited_seconds = 0.0
        self._thread = threading.Thread(target=self._start, args=(workers, scheduler, setup),
                                        name="mocomp-batch-cluster-start", daemon=True)
        self._thread.start()

    def _start(self, workers, scheduler, setup) -> None:
        t0 = time.perf_counter()
        try:
            client = self._stack.enter_context(open_client(workers, scheduler))
            if setup is not None:
                client.run(setup)
            self._client = client
        except BaseException as e:  # noqa: BLE001 - re-raised by get() in the caller's thread
            self._error = e
        self.start_seconds = time.perf_counter() - t0

    def get(self):
        """The client, once started (re-raises the start's error)."""
        t0 = time.perf_counter()
        self._thread.join()
        self.waited_seconds += time.perf_counter() - t0
        if self._error is not None:
            raise self._error
        return self._client

    def close(self) -> None:
        self._thread.join()
        self._stack.close()


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def _crash_text(exc: BaseException) -> str:
    import re

    m = re.search(r"on (\d+) different workers", str(exc))
    tries = f"{m.group(1)} attempts" if m else "every attempt"
    return (f"the worker process died while running it ({tries}; a segfault or abort, or killed for "
            "memory); Dask gave up on it (KilledWorker)")


def chunk_sizes(n: int, workers: int, max_chunk: int = MAX_CHUNK) -> list[int]:
    """Items per task for ``n`` items on ``workers`` workers: guided self-scheduling (Polychronopoulos &
    Kuck 1987), each chunk ``ceil(remaining / (2 * workers))`` items, at most ``max_chunk``, at least 1.

    Early chunks are large (one scheduler round trip, one result message for many items), the last
    ones small (single items), so the workers finish together. Sums to ``n``."""
    if n < 0 or workers < 1 or max_chunk < 1:
        raise ValueError(f"chunk_sizes: n >= 0, workers >= 1 and max_chunk >= 1 needed, got {n}, {workers}, {max_chunk}")
    out, left = [], n
    while left:
        k = max(1, min(max_chunk, -(-left // (2 * workers))))
        out.append(k)
        left -= k
    return out


def run_chunk(func: Callable, items: list, skip: Callable | None = None, keep_values: bool = True) -> list[tuple]:
    """Run ``func`` on each item of a chunk in this process (the task of :func:`map_items` on a worker):
    one ``(status, value, error, traceback, seconds)`` per item, status ``ok``/``failed``/``done``
    (``skip(item)`` true: already complete, not run again when a chunk is retried after a worker
    died in it). A failing item is its row, the chunk goes on; values are dropped unless
    ``keep_values`` (results that live in files)."""
    out = []
    for it in items:
        t0 = time.perf_counter()
        if skip is not None and skip(it):
            out.append(("done", None, None, None, 0.0))
            continue
        try:
            v = func(it)
        except Exception as e:  # noqa: BLE001 - one item's failure is its outcome
            out.append(("failed", None, _describe(e), traceback.format_exc(), time.perf_counter() - t0))
        else:
            out.append(("ok", v if keep_values else None, None, None, time.perf_counter() - t0))
    return out


def map_items(func: Callable, items: Iterable, *, client=None, workers: int | None = None,
              scheduler: str | None = None, name: str = "item", fetch: bool = True,
              fetch_timeout: float = 300.0, done: Callable | None = None,
              stall_seconds: float = 120.0, chunk: int | None = None) -> Iterator[Outcome]:
    """Yield the :class:`Outcome` of ``func(item)`` for every item, in completion order.

    client: an open :class:`~dask.distributed.Client` (e.g. from :func:`open_client`); else a
        cluster is opened for this call with ``workers`` / ``scheduler``, and ``workers=0`` runs the
        items in this process, in order.
    chunk: items per Dask task. ``None`` (default): adaptive, :func:`chunk_sizes` for the item count
        and the cluster's worker threads (large chunks first, single items at the end); ``1``: one
        task per item. A chunk runs its items one after the other on one worker
        (:func:`run_chunk`), so the scheduler round trip and the result message are paid per chunk,
        not per item; its items are reported when the chunk completes. When a worker dies in a chunk,
        Dask retries the chunk (items whose ``done`` is true are not run again); when it gives up
        (``KilledWorker``), the first item not ``done`` is the one that was running: it is reported
        ``crashed`` and the rest are submitted again in new chunks. Without ``done``, every item of
        the chunk is submitted again alone, so only the crashing item ends ``crashed``.
    fetch: bring each result back (``Outcome.value``); ``False`` when the function leaves its result
        in files (``mocomp batch``: row.json): only each item's status comes back, and an item whose
        chunk's statuses were lost with a worker (crashed on a later task before the client read
        them) is reported ``ok`` when ``done`` says it is complete.
    done: ``done(item) -> bool``, whether an item's files say it is complete: an item still pending
        on the scheduler (its result lost with its worker and waiting to be computed again) whose
        ``done`` is true is reported ``ok`` and its task cancelled.
    stall_seconds: on a cluster this call started, the items left are reported ``failed`` when the
        cluster has had no worker for that long (a worker that keeps failing to start).
    func must be importable by the workers (a module-level function) and its items picklable; on
    an existing cluster the workers need the same ``mocomp`` installed and the same paths.
    """
    items = list(items)
    if chunk is not None and int(chunk) < 1:
        raise ValueError(f"chunk must be at least 1 item per task, got {chunk}")
    if client is None and scheduler is None and workers == 0:
        yield from _map_local(func, items)
        return
    if client is None:
        with open_client(workers, scheduler) as c:
            yield from _map_dask(func, items, c, name, fetch, fetch_timeout, done,
                                 stall_seconds if scheduler is None else None, chunk)
        return
    yield from _map_dask(func, items, client, name, fetch, fetch_timeout, done,
                         stall_seconds if getattr(client, "cluster", None) is not None else None, chunk)


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


def _map_dask(func, items, client, name, fetch: bool, fetch_timeout: float, done, stall,
              chunk: int | None = None) -> Iterator[Outcome]:
    from distributed import wait
    from distributed.scheduler import KilledWorker

    if not items:
        return
    token = uuid.uuid4().hex[:10]
    t0 = time.perf_counter()
    pending: dict = {}      # key -> future
    members: dict = {}      # key -> indices of its items
    chunked: set = set()    # keys of the tasks that run a chunk (run_chunk), not func itself
    fetching: dict = {}     # key -> when its result was first asked for
    serial = [0]

    def submit(indices: list[int], size: int | None) -> None:
        """Submit ``indices`` in chunks (``size`` items each; ``None``: adaptive)."""
        if size is None:
            nw = max(1, sum(client.nthreads().values()) if hasattr(client, "nthreads") else 1)
            sizes = chunk_sizes(len(indices), nw)
        else:
            sizes = [size] * (len(indices) // size) + ([len(indices) % size] if len(indices) % size else [])
        groups, j = [], 0
        for k in sizes:
            groups.append(indices[j:j + k])
            j += k
        keys = []
        for g in groups:
            keys.append(f"{name}-{token}-{serial[0]}")
            serial[0] += 1
        if size == 1:
            futs = client.map(func, [items[g[0]] for g in groups], key=keys, pure=False, retries=0)
        else:  # one task per chunk; func and done are module-level functions, pickled by reference
            futs = [client.submit(run_chunk, func, [items[i] for i in g], done, fetch, key=k, pure=False, retries=0)
                    for g, k in zip(groups, keys)]
            chunked.update(keys)
        for g, k, f in zip(groups, keys, futs):
            pending[k] = f
            members[k] = g

    last_scan = last_worker = revived = time.monotonic()

    def crashed(i, exc, dt) -> Outcome:
        return Outcome(i, items[i], "crashed", error=_crash_text(exc), exception=exc, seconds=dt)

    def outcomes(fut) -> list[Outcome]:
        """The outcomes of a finished or errored task (and items submitted again after a crash)."""
        idx = members.pop(fut.key)
        dt = time.perf_counter() - t0
        single = fut.key not in chunked
        if fut.status == "finished":
            try:
                if fetch or not single:
                    first = fetching.setdefault(fut.key, time.monotonic())
                    try:
                        value = fut.result(timeout=max(0.1, min(FETCH_POLL_SECONDS,
                                                                fetch_timeout - (time.monotonic() - first))))
                    except TimeoutError:
                        if time.monotonic() - first < fetch_timeout:
                            # not fetched yet (its worker died with it: Dask computes it again, on a
                            # worker the loop may have to start): back to the pending tasks
                            pending[fut.key], members[fut.key] = fut, idx
                            return []
                        raise
                else:
                    value = None
            except Exception as e:  # noqa: BLE001 - the result was lost with its worker
                # a result lives in its worker's memory until fetched: when a later item crashes that
                # worker first, it is lost (the item's files, if any, are not)
                return [Outcome(i, items[i], "ok", seconds=dt) if done is not None and done(items[i]) else
                        Outcome(i, items[i], "failed", error=f"the item ran but its result was lost: "
                                f"{_describe(e)}", exception=e, seconds=dt) for i in idx]
            if single:
                return [Outcome(idx[0], items[idx[0]], "ok", value=value, seconds=dt)]
            out = []
            for i, (st, v, err, tb, _s) in zip(idx, value):
                out.append(Outcome(i, items[i], "failed", error=err, traceback=tb, seconds=dt) if st == "failed"
                           else Outcome(i, items[i], "ok", value=v, seconds=dt))
            return out
        exc = fut.exception() if fut.status == "error" else None
        if isinstance(exc, KilledWorker):
            if len(idx) == 1:
                return [crashed(idx[0], exc, dt)]
            if done is None:  # which item crashed is unknown: each again on its own
                submit(idx, 1)
                return []
            left = [i for i in idx if not done(items[i])]
            out = [Outcome(i, items[i], "ok", seconds=dt) for i in idx if i not in left]
            if left:  # items of a chunk run in order: the first one not complete was running
                out.append(crashed(left[0], exc, dt))
                if left[1:]:
                    submit(left[1:], None)
            return out
        tb = fut.traceback() if fut.status == "error" else None
        err = _describe(exc) if exc is not None else f"the task ended with status {fut.status}"
        tbt = "".join(traceback.format_tb(tb)) if tb is not None else None
        return [Outcome(i, items[i], "failed", error=err, traceback=tbt, exception=exc, seconds=dt) for i in idx]

    submit(list(range(len(items))), chunk)
    try:
        while pending:
            try:
                finished = wait(list(pending.values()), timeout=2.0, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                finished = set()
            for fut in finished:
                del pending[fut.key]
                done_now = outcomes(fut)
                if fut.key in pending:  # its result is being computed again
                    continue
                chunked.discard(fut.key)
                fetching.pop(fut.key, None)
                fut.release()
                yield from done_now
            now = time.monotonic()
            if now - last_scan < SCAN_SECONDS:
                continue
            last_scan = now
            if done is not None:  # items finished on disk whose result was lost with their worker
                for k in [k for k, f in pending.items() if f.status != "finished"
                          and all(done(items[i]) for i in members[k])]:
                    fut = pending.pop(k)
                    fut.cancel()
                    chunked.discard(k)
                    for i in members.pop(k):
                        yield Outcome(i, items[i], "ok", seconds=time.perf_counter() - t0)
            if stall is not None and pending:
                if client.scheduler_info().get("workers"):
                    last_worker = revived = now
                elif now - last_worker > stall:
                    for k, fut in list(pending.items()):
                        fut.cancel()
                        del pending[k]
                        for i in members.pop(k):
                            yield Outcome(i, items[i], "failed", seconds=time.perf_counter() - t0,
                                          error=f"not run: the cluster has had no worker for {stall:.0f} s (its "
                                                "workers died and could not be started again)")
                elif now - revived > REVIVE_SECONDS and getattr(client, "cluster", None) is not None:
                    # a worker process that dies while its nanny is still starting it is not restarted by
                    # the nanny (Dask 2026.8): replace the local cluster's workers
                    revived = now
                    cluster = client.cluster
                    n = max(1, len(cluster.worker_spec))
                    cluster.scale(0)
                    cluster.scale(n)
    finally:
        client.cancel(list(pending.values()))
