"""The committed baseline of reproduced rows (docs/reproduce_baseline.json, read by
``mocomp reproduce --check-baseline`` in CI) and the results file every notebook writes."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from mocomp.reproduce import ResultRow, read_results, write_results
from mocomp.reproduce.baseline import read_baseline
from mocomp.reproduce.results import ResultsFileError

ROOT = Path(__file__).resolve().parents[1]


def test_committed_baseline_matches_the_notebooks():
    """docs/reproduce_baseline.json names only notebooks that exist and rows whose keys are well formed."""
    root = Path(__file__).resolve().parents[1]
    doc = read_baseline(root / "docs" / "reproduce_baseline.json")
    books = {p.name for p in (root / "notebooks").glob("*.ipynb")}
    assert doc["modes"].get("quick") and doc["modes"].get("data")
    for mode, section in doc["modes"].items():
        assert set(section) <= books, f"{mode}: baseline names notebooks that do not exist"
        for keys in section.values():
            assert all(k.count(" | ") >= 2 for k in keys)


def test_every_notebook_writes_results_from_its_parameters():
    """Every notebook takes ``results_path`` in its parameters cell and ends by writing its rows there
    (so ``mocomp reproduce`` and the baseline see it); notebooks added later must follow."""
    for nb_path in sorted((ROOT / "notebooks").glob("*.ipynb")):
        nb = json.loads(nb_path.read_text())
        code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
        assert "results_path" in code[0], f"{nb_path.name}: no results_path in the parameters cell"
        assert "write_results(" in code[-1] and "results_path" in code[-1], \
            f"{nb_path.name}: the last code cell does not write_results(..., results_path, ...)"


def test_results_round_trip_and_errors(tmp_path):
    rows = [ResultRow("acrobatics", "Fig. 5.5", "after", 20.0, 0.7, 0.0, unit="%", comparison="at most"),
            ResultRow("acrobatics", "Table C.1", "head", 7.5, 6.94, 1.0, unit="%", notebook="other.ipynb")]
    p = write_results(rows, tmp_path / "sub" / "r.json", notebook="nb.ipynb")
    back = read_results(p)
    assert [r.notebook for r in back] == ["nb.ipynb", "other.ipynb"]
    assert back[0] == ResultRow(**{**rows[0].__dict__, "notebook": "nb.ipynb"}) and back[0].status == "reproduced"
    doc = json.loads(p.read_text())
    doc["rows"][1]["tolerance"] = -1
    p.write_text(json.dumps(doc))
    with pytest.raises(ResultsFileError, match=r"r.json: row 1: .*tolerance must be finite and >= 0"):
        read_results(p)
    del doc["rows"][0]["ours"]
    p.write_text(json.dumps(doc))
    with pytest.raises(ResultsFileError, match=r"row 0 lacks field\(s\) \['ours'\]"):
        read_results(p)
    with pytest.raises(ResultsFileError, match="row 0 is a tuple"):
        write_results([("a", "b")], tmp_path / "x.json")
    with pytest.raises(ResultsFileError, match="use None"):
        ResultRow("a", "b", "c", 1.0, float("nan"), 0.1)
