"""The benchmark runner's mechanics (goal checks, discovery, errors, JSON); no speed asserted here."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def runner():
    spec = importlib.util.spec_from_file_location("bench_runner", ROOT / "benchmarks" / "run.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("row,expected", [
    ({"ours_s": 0.04, "goal": "ours_s <= 0.05"}, True),
    ({"ours_s": 0.06, "goal": "ours_s <= 0.05"}, False),
    ({"ours_s": 0.05, "goal": "ours_s<0.05"}, False),
    ({"ratio": 12.0, "goal": "ratio >= 10"}, True),
    ({"ratio": 9.9, "goal": "ratio >= 10"}, False),
    ({"ratio": None, "goal": "ratio >= 10"}, False),
    ({"peer_s": 2.0, "goal": "peer_s > 1e0"}, True),
    ({"ours_s": 1.0, "goal": None}, None),
    ({"ours_s": 1.0, "goal": "anything", "passed": True}, True),
])
def test_check_goal(runner, row, expected):
    assert runner.check_goal(row) is expected


def test_bad_goal_is_an_error(runner):
    with pytest.raises(ValueError, match="not '<field> <op> <number>'"):
        runner.check_goal({"name": "x", "goal": "fast enough"})


def test_run_all_table_and_errors(runner, tmp_path, capsys):
    good = tmp_path / "bench_good.py"
    good.write_text(
        "from timing import result\n"
        "def run(quick):\n"
        "    return [result('a', 0.01, 'peer x', 0.2, goal='ratio >= 10', note='n1'),\n"
        "            result('b', 0.2, goal='ours_s <= 0.1'),\n"
        "            {'name': 'c', 'ours_s': 0.5, 'peer': 'p', 'peer_s': 1.0}]\n")
    bad = tmp_path / "bench_bad.py"
    bad.write_text("def run(quick):\n    raise RuntimeError('boom')\n")
    rows = runner.run_all([good, bad], quick=True)
    assert [r["name"] for r in rows] == ["a", "b", "c", "bad"]
    assert rows[0]["ratio"] == pytest.approx(20.0) and rows[0]["passed"] is True
    assert rows[1]["passed"] is False
    assert rows[2]["ratio"] == pytest.approx(2.0) and rows[2]["passed"] is None  # ratio filled in by the runner
    assert rows[3]["error"] == "RuntimeError: boom" and rows[3]["passed"] is False
    table = runner.format_table(rows)
    assert "20.0x" in table and "PASS" in table and "FAIL" in table and "ERROR" in table and "a: n1" in table


def test_discover_only_and_main_json(runner, tmp_path, monkeypatch, capsys):
    files = runner.discover()
    assert (ROOT / "benchmarks" / "bench_fk.py") in files
    assert runner.discover(["bench_fk"]) == runner.discover(["fk"]) == [ROOT / "benchmarks" / "bench_fk.py"]
    with pytest.raises(SystemExit, match="no benchmark named nosuch"):
        runner.discover(["nosuch"])
    # main() on a stand-in module directory: JSON written, exit status from the goals
    (tmp_path / "bench_one.py").write_text(
        "def run(quick):\n    return [{'name': 'x', 'ours_s': 0.5 if quick else 2.0, 'goal': 'ours_s <= 1'}]\n")
    (tmp_path / "timing.py").write_text("")
    monkeypatch.setattr(runner, "HERE", tmp_path)
    out = tmp_path / "r.json"
    assert runner.main(["--quick", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["quick"] is True and doc["results"][0]["passed"] is True and doc["machine"]["cpus"] >= 1
    speed = doc["machine"]["host_speed"]   # reference workloads: runs on different hosts/days compare
    assert set(speed) == {"python_loop_s", "numpy_s"} and all(0 < v < 60 for v in speed.values())
    assert runner.main([]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_benchmark_docs_from_json(tmp_path):
    """scripts/write_benchmark_docs.py: the Markdown table is generated from the JSON alone."""
    spec = importlib.util.spec_from_file_location("bench_docs", ROOT / "scripts" / "write_benchmark_docs.py")
    docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(docs)
    doc = {"created": "2026-01-01T00:00:00+00:00", "quick": False, "data_dir": "set",
           "machine": {"cpus": 2, "python": "3.11", "numpy": "2.0", "platform": "linux", "processor": "x86_64",
                       "load_before": [3.5, 3.2, 3.1], "load_after": [3.0, 3.1, 3.1]},
           "results": [
               {"module": "fk", "name": "fk 31j", "ours_s": 0.0105, "peer": "bvhio | x", "peer_s": 1.81,
                "ratio": 172.4, "goal": "ours_s <= 0.05", "note": "max diff 6.6e-07 m", "passed": True},
               {"module": "io", "name": "AMC read", "ours_s": 0.071, "peer": None, "peer_s": None, "ratio": None,
                "goal": None, "note": None, "passed": None},
               {"module": "x", "name": "slow", "ours_s": 2e-5, "peer": None, "peer_s": None, "ratio": None,
                "goal": "ours_s <= 1e-6", "note": None, "passed": False},
               {"module": "bad", "name": "bad", "ours_s": None, "peer": None, "peer_s": None, "ratio": None,
                "goal": None, "note": None, "passed": False, "error": "RuntimeError: boom"}]}
    md = docs.render_markdown(doc)
    lines = md.splitlines()
    table = [ln for ln in lines if ln.startswith("| ") and not ln.startswith(("| module", "| ---"))]
    assert len(table) == 4
    assert table[0] == ("| fk | fk 31j | 10.5 ms | bvhio \\| x | 1.81 s | 172.4x | ours_s <= 0.05 | PASS |")
    assert "| 20 µs |" in table[2] and table[2].endswith("| FAIL |") and table[3].endswith("| ERROR |")
    assert "Goals: 1 of 3 pass." in md and "before the run 3.50 / 3.20 / 3.10" in md
    assert "- **bad**: RuntimeError: boom" in md
    assert "Host speed" not in md   # older JSON without the reference workloads
    doc_speed = dict(doc, machine=dict(doc["machine"], host_speed={"python_loop_s": 0.1234, "numpy_s": 0.3456}))
    md_speed = docs.render_markdown(doc_speed)
    assert "2,000,000-step pure-Python loop 123 ms" in md_speed and "100,000 doubles 346 ms" in md_speed
    src = tmp_path / "in.json"
    src.write_text(json.dumps(doc))
    out = tmp_path / "docs"
    assert docs.main(["--from-json", str(src), "--out", str(out)]) == 1   # a goal fails
    assert (out / "benchmarks.md").read_text() == md
    assert json.loads((out / "benchmarks.json").read_text()) == doc
