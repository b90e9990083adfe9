"""``mocomp.batch.engine``: adaptive chunks (several items per Dask task), a worker crash inside a
chunk, and the fresh-worker recovery of a local cluster left without workers (forced)."""
from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from mocomp.batch import engine
from mocomp.batch.engine import chunk_sizes, map_items, open_client, run_chunk


# module-level: the workers import them by reference
def _marked(item):
    """Square ``item[0]``; leave a marker file (the item's "outputs") in ``item[1]``; item 3 of a
    ``crash`` run segfaults its worker (a real SIGSEGV), item 5 raises."""
    i, d, crash = item
    if crash and i == 3:
        import faulthandler

        faulthandler.disable()
        faulthandler._sigsegv()  # a real SIGSEGV, as from a reader's C extension
    if i == 5:
        raise ValueError("five is refused")
    Path(d, f"{i}.done").write_text(str(os.getpid()))
    return i * i


def _is_done(item) -> bool:
    i, d, _ = item
    return Path(d, f"{i}.done").is_file()


def _pid(_item) -> int:
    return os.getpid()


@pytest.mark.parametrize("n,w", [(0, 1), (1, 1), (7, 2), (80, 1), (80, 2), (2605, 2), (3, 8)])
def test_chunk_sizes_cover_every_item_large_first_single_last(n, w):
    s = chunk_sizes(n, w)
    assert sum(s) == n and all(1 <= k <= engine.MAX_CHUNK for k in s)
    assert s == sorted(s, reverse=True)  # guided: never a larger chunk after a smaller one
    if n >= 2 * w:
        assert s[-1] == 1
    if n > 2 * w * engine.MAX_CHUNK:
        assert len(s) < n / 4  # far fewer tasks than items
    # known answer: 80 clips on 2 workers
    if (n, w) == (80, 2):
        assert s == [16, 16, 12, 9, 7, 5, 4, 3, 2, 2, 1, 1, 1, 1]


def test_chunk_sizes_refuse_nonsense():
    with pytest.raises(ValueError, match="workers >= 1"):
        chunk_sizes(5, 0)


def test_run_chunk_keeps_going_after_a_failing_item_and_skips_done_items(tmp_path):
    items = [(i, str(tmp_path), False) for i in range(7)]
    Path(tmp_path, "1.done").write_text("x")  # item 1 complete already: not run again
    out = run_chunk(_marked, items, skip=_is_done)
    assert [o[0] for o in out] == ["ok", "done", "ok", "ok", "ok", "failed", "ok"]
    assert [o[1] for o in out] == [0, None, 4, 9, 16, None, 36]
    assert out[5][2] == "ValueError: five is refused" and "five is refused" in out[5][3]
    assert Path(tmp_path, "1.done").read_text() == "x"
    assert [o[1] for o in run_chunk(_marked, items[:3], keep_values=False)] == [None] * 3


@pytest.mark.slow
def test_chunks_on_a_cluster_give_each_items_outcome(tmp_path):
    items = [(i, str(tmp_path), False) for i in range(40)]
    with open_client(1) as c:
        out = sorted(map_items(_marked, items, client=c), key=lambda o: o.index)
        pids = {o.value for o in map_items(_pid, range(40), client=c)}
        one = sorted(map_items(_marked, items[:6], client=c, chunk=1), key=lambda o: o.index)
    assert [o.status for o in out] == ["ok"] * 5 + ["failed"] + ["ok"] * 34
    assert [o.value for o in out if o.status == "ok"] == [i * i for i in range(40) if i != 5]
    assert out[5].error == "ValueError: five is refused" and "five is refused" in out[5].traceback
    assert len(pids) == 1 and os.getpid() not in pids  # one worker process, not this one
    assert [o.status for o in one] == ["ok"] * 5 + ["failed"] and one[5].error == "ValueError: five is refused"


@pytest.mark.slow
@pytest.mark.parametrize("with_done", [True, False])
def test_a_crash_inside_a_chunk_is_that_items_row_only(tmp_path, with_done):
    """Item 3 segfaults its worker: Dask retries its chunk, gives up (KilledWorker); with ``done`` the
    first item not complete is the crashed one and the rest are submitted again; without, every item
    of the chunk runs again alone. Either way: 3 crashed, 5 failed, the others ok with their values."""
    items = [(i, str(tmp_path), True) for i in range(12)]
    out = sorted(map_items(_marked, items, workers=1, chunk=6, done=_is_done if with_done else None),
                 key=lambda o: o.index)
    assert [o.index for o in out] == list(range(12))
    st = [o.status for o in out]
    assert st[3] == "crashed" and "worker process died" in out[3].error
    assert st[5] == "failed" and out[5].error == "ValueError: five is refused"
    assert all(s == "ok" for i, s in enumerate(st) if i not in (3, 5)), st
    if not with_done:  # values come back for every ok item
        assert [o.value for o in out if o.status == "ok"] == [i * i for i in range(12) if i not in (3, 5)]
    assert sorted(int(p.stem) for p in tmp_path.glob("*.done")) == [i for i in range(12) if i not in (3, 5)]


@pytest.mark.slow
def test_fresh_workers_replace_a_local_cluster_left_without_any(tmp_path, monkeypatch):
    """The recovery path: a local cluster whose workers are all gone (as when a worker dies while its
    nanny is still starting it, which Dask does not restart) gets fresh ones after REVIVE_SECONDS,
    and every item then runs."""
    monkeypatch.setattr(engine, "REVIVE_SECONDS", 1.0)
    monkeypatch.setattr(engine, "SCAN_SECONDS", 0.5)
    with open_client(1) as c:
        old = set(c.run(os.getpid).values())
        c.cluster.scale(0)
        t0 = time.time()
        while c.scheduler_info()["workers"] and time.time() - t0 < 60:
            time.sleep(0.1)
        assert not c.scheduler_info()["workers"], "the workers did not go"
        out = list(map_items(_pid, range(6), client=c, stall_seconds=120.0))
        assert [o.status for o in out] == ["ok"] * 6
        assert len(c.cluster.worker_spec) == 1  # scaled back to one worker
    pids = {o.value for o in out}
    assert len(pids) == 1 and pids.isdisjoint(old)  # run by the fresh worker


@pytest.mark.slow
def test_items_fail_with_the_reason_when_no_worker_can_be_started(monkeypatch):
    """The end of the recovery path: when fresh workers do not come either, the items left are
    failed rows after ``stall_seconds`` (never a hung batch)."""
    monkeypatch.setattr(engine, "REVIVE_SECONDS", 0.5)
    monkeypatch.setattr(engine, "SCAN_SECONDS", 0.3)
    with open_client(1) as c:
        c.cluster.scale(0)
        t0 = time.time()
        while c.scheduler_info()["workers"] and time.time() - t0 < 60:
            time.sleep(0.1)
        calls = []
        monkeypatch.setattr(type(c.cluster), "scale", lambda self, n=0, **kw: calls.append(n))
        t0 = time.time()
        out = list(map_items(_pid, range(4), client=c, stall_seconds=3.0))
        dt = time.time() - t0
        monkeypatch.undo()
    assert [o.status for o in out] == ["failed"] * 4
    assert all("no worker for 3 s" in o.error for o in out)
    assert calls and calls[:2] == [0, 1]  # the fresh workers were asked for (scale 0, then 1)
    assert 3.0 <= dt < 60
