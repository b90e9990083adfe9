"""``mocomp batch`` (issue 20 section 2): inputs, per-clip command lines, the Dask runs (the whole
shared data folder on 2 workers, a worker-crashing clip, kill -9 of the client then --resume,
1 vs 2 workers)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mocomp.batch import COMMANDS, compare_tables, discover, map_items, read_results, run_batch
from mocomp.batch.clip import CRASH_ENV, ROW_FILE
from mocomp.batch.commands import command_argv

ROOT = Path(__file__).resolve().parents[1]
MOCOMP = str(ROOT / ".venv" / "bin" / "mocomp") if (ROOT / ".venv" / "bin" / "mocomp").exists() else "mocomp"
#: the clip whose "reader" segfaults its worker in the Dask runs below (a real SIGSEGV, see mocomp.batch.clip)
CRASH_CLIP = "ase_rl_Dodgle_Left.derived.bvh"


# ------------------------------------------------------------------ inputs, no cluster
def _tree(tmp_path: Path) -> Path:
    d = tmp_path / "lib"
    (d / "a" / "deep").mkdir(parents=True)
    (d / "skeletons").mkdir()
    (d / ".hidden").mkdir()
    (d / "a" / "x.bvh").write_text("HIERARCHY\n")
    (d / "a" / "deep" / "y.BVH").write_text("HIERARCHY\n")
    (d / "a" / "s.asf").write_text(":version 1.10\n")
    (d / "a" / "m.amc").write_text(":FULLY-SPECIFIED\n")
    (d / "a" / "k.txt").write_text('{"Loop": "none", "Frames": [[0.1]]}')
    (d / "skeletons" / "char.txt").write_text('{"Skeleton": {"Joints": []}}')
    (d / "skeletons" / "LICENSE.txt").write_text("MIT\n")
    (d / "skeletons" / "h.xml").write_text("<mujoco/>")
    (d / "m.c3d").write_bytes(b"\x02P" + b"\0" * 510)
    (d / "MANIFEST.md").write_text("# data\n")
    (d / ".hidden" / "z.bvh").write_text("HIERARCHY\n")
    (d / ".DS_Store").write_bytes(b"\0")
    return d


def test_discover_classifies_every_file_and_gives_reasons(tmp_path):
    d = _tree(tmp_path)
    files = {f.clip: f for f in discover(d)}
    assert list(files) == sorted(files)  # sorted by clip id
    assert set(files) == {"a/x.bvh", "a/deep/y.BVH", "a/s.asf", "a/m.amc", "a/k.txt", "skeletons/char.txt",
                          "skeletons/LICENSE.txt", "skeletons/h.xml", "m.c3d", "MANIFEST.md"}  # hidden: not walked
    motions = {c: f.format for c, f in files.items() if f.is_motion}
    assert motions == {"a/x.bvh": "BVH", "a/deep/y.BVH": "BVH", "a/m.amc": "ASF/AMC", "a/k.txt": "DeepMimic"}
    assert "skeleton" in files["a/s.asf"].skip_reason and ".amc" in files["a/s.asf"].skip_reason
    assert "marker" in files["m.c3d"].skip_reason
    assert "character" in files["skeletons/char.txt"].skip_reason
    assert "not a DeepMimic motion" in files["skeletons/LICENSE.txt"].skip_reason
    assert "not a motion file (.md" in files["MANIFEST.md"].skip_reason
    assert "not a motion file (.xml" in files["skeletons/h.xml"].skip_reason
    assert all(Path(f.path).is_absolute() for f in files.values())


def test_discover_glob_file_and_output_folder(tmp_path):
    d = _tree(tmp_path)
    g = discover(str(d / "a" / "*.bvh"))
    assert [f.clip for f in g] == ["x.bvh"]  # relative to the glob's folder
    assert [f.clip for f in discover(str(d / "**" / "*.bvh"))] == ["a/x.bvh"]  # case-sensitive; not .hidden/
    assert [f.clip for f in discover(d / "a" / "x.bvh")] == ["x.bvh"]
    (d / "out" / "clips").mkdir(parents=True)
    (d / "out" / "clips" / "o.bvh").write_text("HIERARCHY\n")
    assert not any(f.clip.startswith("out/") for f in discover(d, exclude=d / "out"))
    assert any(f.clip.startswith("out/") for f in discover(d))
    with pytest.raises(FileNotFoundError, match="no file matches"):
        discover(str(d / "*.nothing"))
    with pytest.raises(FileNotFoundError, match="no such folder or file"):
        discover(d / "missing")


def test_command_lines_put_every_output_in_the_clip_folder(tmp_path):
    argv, files = command_argv(COMMANDS["edit"], Path("/d/c.bvh"), tmp_path,
                               ["--preset", "arms-out", "--plot", "p.png", "--edited=e.bvh"])
    assert argv == ["/d/c.bvh", "-o", str(tmp_path / "output.bvh"), "--report", str(tmp_path / "report.json"),
                    "--preset", "arms-out", "--plot", str(tmp_path / "p.png"), "--edited", str(tmp_path / "e.bvh")]
    assert files == {"output": "output.bvh", "report": "report.json", "plot": "p.png", "edited": "e.bvh"}
    argv, files = command_argv(COMMANDS["info"], Path("/d/c.bvh"), tmp_path, ["--fps", "60"])
    assert argv == ["/d/c.bvh", "--json", "--fps", "60"]
    argv, _ = command_argv(COMMANDS["render"], Path("/d/c.bvh"), tmp_path, [], "mp4")
    assert argv == ["/d/c.bvh", "-o", str(tmp_path / "render.mp4")]
    with pytest.raises(ValueError, match="--report is set by mocomp batch"):
        command_argv(COMMANDS["audit"], Path("c.bvh"), tmp_path, ["--report", "r.json"])
    with pytest.raises(ValueError, match="give a file name"):
        command_argv(COMMANDS["audit"], Path("c.bvh"), tmp_path, ["--plot", "../p.png"])


@pytest.mark.parametrize("argv, message", [
    (["edit", "{d}", "-o", "{o}"], "options for edit: the following arguments are required: --preset"),
    (["audit", "{d}", "-o", "{o}", "--threshold", "nonsense=1"], "nonsense"),
    (["audit", "{d}/missing", "-o", "{o}"], "no such folder or file"),
    (["audit", "{d}", "-o", "{o}", "--report", "r.json"], "--report is set by mocomp batch"),
    (["render", "{d}", "-o", "{o}", "--output-type", "bvh"], "--output-type bvh: render writes png, mp4, gif"),
    (["audit", "{d}", "-o", "{o}", "--workers", "2", "--scheduler", "tcp://h:1"], "not allowed with argument --workers"),
    (["audit", "{d}", "--workers", "2"], "-o OUT_DIR is required"),
])
def test_bad_batch_command_lines_fail_in_one_line(tmp_path, argv, message):
    d = _tree(tmp_path)
    argv = [a.format(d=d, o=tmp_path / "out") for a in argv]
    r = subprocess.run([MOCOMP, "batch", *argv], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mocomp batch: error: ") and message in lines[0], r.stderr
    assert not (tmp_path / "out" / "clips").exists()


def _square(x):
    if x == 3:
        raise ValueError("three is refused")
    return x * x


def test_map_items_in_process_reports_each_outcome():
    out = sorted(map_items(_square, range(5), workers=0), key=lambda o: o.index)
    assert [o.status for o in out] == ["ok", "ok", "ok", "failed", "ok"]
    assert [o.value for o in out if o.status == "ok"] == [0, 1, 4, 16]
    assert out[3].error == "ValueError: three is refused" and isinstance(out[3].exception, ValueError)
    assert "three is refused" in out[3].traceback


# ------------------------------------------------------------------ Dask runs on the shared data
def _subset(root: Path, dest: Path, folders=("flips/deepmimic_*.txt", "reactions/ase_rl_Dod*", "idle/*",
                                            "skeletons/*", "hands/HDM_dg.asf", "hands/*.c3d")) -> Path:
    """Links to some clips of the data folder, same relative paths (DeepMimic motions find their
    character in skeletons/ as in the data folder)."""
    for pat in folders:
        for p in sorted(root.glob(pat)):
            q = dest / p.relative_to(root)
            q.parent.mkdir(parents=True, exist_ok=True)
            q.symlink_to(p)
    return dest


@pytest.fixture(scope="module")
def whole(real_data_dir, tmp_path_factory):
    """``batch audit`` over the whole shared data folder on 2 workers, one clip crashing its worker."""
    out = tmp_path_factory.mktemp("batch") / "whole"
    old = os.environ.get(CRASH_ENV)
    os.environ[CRASH_ENV] = CRASH_CLIP
    try:
        res = run_batch("audit", real_data_dir, out, workers=2, progress=False)
    finally:
        if old is None:
            os.environ.pop(CRASH_ENV, None)
        else:
            os.environ[CRASH_ENV] = old
    return res


@pytest.mark.realdata
@pytest.mark.slow
def test_whole_data_folder_on_two_workers(whole, real_data_dir):
    from mocomp import datasets
    from mocomp.audit import audit

    t = whole.table
    assert whole.workers == 2 and whole.ran == len(t) - (t["status"] == "skipped").sum()
    every = sorted(p.relative_to(real_data_dir).as_posix() for p in real_data_dir.rglob("*")
                   if p.is_file() and not any(s.startswith(".") for s in p.relative_to(real_data_dir).parts))
    assert t["clip"].tolist() == every  # one row per file, every format
    assert read_results(whole.out_dir)["clip"].tolist() == every
    csv = pd.read_csv(whole.out_dir / "results.csv")
    assert csv["clip"].tolist() == every and csv["status"].tolist() == t["status"].tolist()
    st = t.set_index("clip")["status"]
    fmt = t.set_index("clip")["format"]
    assert {"BVH", "ASF/AMC", "DeepMimic"} <= set(fmt[st != "skipped"])
    for clip in ("MANIFEST.md", "skeletons/ase_amp_humanoid.xml", "hands/HDM_dg.asf",
                 "hands/HDM_dg_06-03_03_120.c3d", "skeletons/deepmimic_humanoid3d_character.txt"):
        assert st[clip] == "skipped", clip
    # the crash: its own row, the batch went on, every other motion audited
    crash = t[t["clip"].str.endswith(CRASH_CLIP)]
    assert crash["status"].tolist() == ["crashed"] and "worker process died" in crash["error"].iloc[0]
    assert (whole.out_dir / "clips" / crash["clip"].iloc[0] / ROW_FILE).is_file()
    ok = t[t["status"] == "ok"]
    assert len(ok) == (st == "ok").sum() >= 70 and (t["status"] == "failed").sum() == 0
    assert set(ok["verdict"]) <= {"pass", "fail"} and ok["violations"].notna().all()
    # known answer: the row holds what mocomp.audit measures on the same clip in this process
    for clip in ("flips/cmu_88_01_backflip.bvh", "jumps/01_01.amc", "flips/deepmimic_backflip.txt"):
        rep = audit(datasets.load(real_data_dir / clip))
        row = ok.set_index("clip").loc[clip]
        assert row["verdict"] == rep.verdict and row["violations"] == len(rep.violations)
        assert row["advisories"] == len(rep.advisories) and row["n_frames"] == rep.n_frames
        assert np.isclose(row["max_com_jump_mps"], rep.to_dict()["measures"]["max_com_jump_mps"], rtol=1e-9)
        saved = json.loads((whole.out_dir / "clips" / clip / "report.json").read_text())
        assert saved["verdict"] == rep.verdict
        assert "verdict" in (whole.out_dir / "clips" / clip / "stdout.txt").read_text()
    assert not list((whole.out_dir / "clips").rglob("*.partial-*"))
    text = "\n".join(whole.summary_lines())
    assert f"{len(ok)} ok, 0 failed, 1 crashed" in text and CRASH_CLIP in text


@pytest.mark.realdata
@pytest.mark.slow
def test_one_worker_gives_the_same_rows_as_two(whole, real_data_dir, tmp_path, monkeypatch):
    monkeypatch.setenv(CRASH_ENV, CRASH_CLIP)
    src = _subset(real_data_dir, tmp_path / "in")
    res = run_batch("audit", src, tmp_path / "one", workers=1, progress=False)
    t = res.table
    assert res.workers == 1 and len(t) == len(discover(src))
    assert set(t["status"]) == {"ok", "skipped", "crashed"}, t.loc[t["status"] == "failed", ["clip", "error"]].to_string()
    ref = whole.table[whole.table["clip"].isin(t["clip"])].reset_index(drop=True)
    assert compare_tables(t, ref) == []
    # the comparison can fail: a changed number is named
    bad = t.copy()
    i = bad.index[bad["status"] == "ok"][0]
    bad.loc[i, "max_com_jump_mps"] *= 1.001
    assert compare_tables(bad, ref) == [f"{bad.loc[i, 'clip']}: max_com_jump_mps: "
                                        f"{bad.loc[i, 'max_com_jump_mps']!r} vs {ref.loc[i, 'max_com_jump_mps']!r}"]


@pytest.mark.realdata
@pytest.mark.slow
def test_kill_minus_9_then_resume_gives_the_uninterrupted_table(whole, real_data_dir, tmp_path):
    src = _subset(real_data_dir, tmp_path / "in", ("reactions/*", "skeletons/*"))
    out = tmp_path / "out"
    env = dict(os.environ, **{CRASH_ENV: CRASH_CLIP})
    proc = subprocess.Popen([MOCOMP, "batch", "audit", str(src), "-o", str(out), "--workers", "2", "--no-progress"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while not list(out.glob("clips/**/" + ROW_FILE)) and time.time() - t0 < 300 and proc.poll() is None:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    n_motions = sum(f.is_motion for f in discover(src))
    done_before = len(list(out.glob("clips/**/" + ROW_FILE)))
    assert 1 <= done_before < n_motions, "the client was not killed mid-batch"
    assert not (out / "results.parquet").exists()
    time.sleep(1.0)  # the orphaned workers exit when their parent is gone
    os.environ[CRASH_ENV] = CRASH_CLIP
    try:
        res = run_batch("audit", src, out, workers=2, resume=True, progress=False)
    finally:
        os.environ.pop(CRASH_ENV, None)
    assert res.resumed >= done_before and res.ran == n_motions - res.resumed
    assert not list(out.rglob("*.partial-*"))
    ref = whole.table[whole.table["clip"].isin(res.table["clip"])].reset_index(drop=True)
    assert len(ref) == len(res.table)
    assert compare_tables(res.table, ref) == []
    assert compare_tables(read_results(out), ref) == []
    # a second --resume runs nothing and keeps the table
    again = run_batch("audit", src, out, workers=2, resume=True, progress=False)
    assert again.ran == 0 and again.resumed == n_motions and again.workers == 0
    assert compare_tables(again.table, ref) == []
    # --resume of a different batch into the same folder is refused
    with pytest.raises(ValueError, match="holds a batch of audit"):
        run_batch("info", src, out, resume=True, progress=False)


@pytest.mark.realdata
@pytest.mark.slow
def test_an_existing_cluster_started_with_dask_scheduler_and_dask_worker(real_data_dir, tmp_path):
    """--scheduler: the cluster of docs/batch.md (`dask scheduler`, `dask worker`), same rows as local."""
    dask_cli = str(Path(MOCOMP).with_name("dask")) if Path(MOCOMP).is_absolute() else "dask"
    sfile = tmp_path / "scheduler.json"
    env = dict(os.environ, DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES="1",
               DASK_DISTRIBUTED__SCHEDULER__WORKER_SATURATION="1.0")
    procs = [subprocess.Popen([dask_cli, "scheduler", "--port", "0", "--no-dashboard", "--scheduler-file", str(sfile)],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        t0 = time.time()
        while not sfile.is_file() and time.time() - t0 < 120:
            time.sleep(0.2)
        address = json.loads(sfile.read_text())["address"]
        procs.append(subprocess.Popen([dask_cli, "worker", address, "--nworkers", "2", "--nthreads", "1",
                                       "--no-dashboard"], env=env, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        src = _subset(real_data_dir, tmp_path / "in", ("flips/*", "skeletons/*"))
        r = subprocess.run([MOCOMP, "batch", "info", str(src), "-o", str(tmp_path / "remote"), "--scheduler", address,
                            "--no-progress"], capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        assert "6 ok, 0 failed, 0 crashed; 5 skipped" in r.stdout
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
    remote = read_results(tmp_path / "remote")
    assert set(remote.loc[remote["status"] == "ok", "worker"].str.split(":").str[1]).isdisjoint({str(os.getpid())})
    local = run_batch("info", src, tmp_path / "local", workers=1, progress=False).table
    assert compare_tables(remote, local) == []
    ok = remote[remote["status"] == "ok"].set_index("clip")
    assert ok.loc["flips/cmu_88_01_backflip.bvh", "fps"] == 60.0  # the known correction of CMU subject 88
    assert ok.loc["flips/deepmimic_backflip.txt", "n_frames"] == 29
