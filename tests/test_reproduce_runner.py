"""``mocomp reproduce`` end to end on small notebooks in real kernels (papermill): a notebook that raises
does not stop the others and is reported with its error; --quick / --data reach the kernels; the figure
is extracted into the report; the baseline check fails naming a row that stopped reproducing."""
from __future__ import annotations

import json

import pytest

from _reproduce_fakes import write_fake_notebooks
from mocomp.cli import main
from mocomp.reproduce import read_results

pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]


def test_failure_path_figures_data_modes_and_baseline(tmp_path, capfd, monkeypatch):
    books = write_fake_notebooks(tmp_path / "nbs")
    data = tmp_path / "some_data"
    data.mkdir()
    monkeypatch.setenv("MOCOMP_DATA_DIR", str(data))   # --quick must hide it from the kernels
    monkeypatch.setenv("MPLBACKEND", "Agg")            # as CI exports: the kernels must still draw inline
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))   # the run-time cache stays in the test
    out, base = tmp_path / "report", tmp_path / "baseline.json"
    rc = main(["reproduce", "-o", str(out), "--notebooks", str(books), "--quick", "--jobs", "2", "--no-progress",
               "--write-baseline", str(base)])
    cap = capfd.readouterr()
    assert rc == 1
    assert "mocomp reproduce: notebook failed: bad.ipynb: RuntimeError: deliberate failure in the second cell" in cap.err
    assert "quiet.ipynb ran but wrote no results file" in cap.err
    # the kernels' own output goes to a log per notebook, not to the console
    assert "kernel process stderr" not in cap.err + cap.out and "IPKernelApp" not in cap.err
    assert "a message on the kernel process stderr" in (out / "notebooks" / "good.kernel.log").read_text()
    assert "Passed unknown parameter" not in cap.err
    times = json.loads((tmp_path / "cache" / "mocomp" / "reproduce_times.json").read_text())
    assert set(times["quick"]) == {"bad.ipynb", "good.ipynb", "quiet.ipynb"}
    assert "3 notebook(s), 1 failed; 4 rows: 2 reproduced, 1 differs, 1 no paper value, 0 failed" in cap.out

    doc = json.loads((out / "results.json").read_text())
    nbs = {b["notebook"]: b for b in doc["notebooks"]}
    assert nbs["bad.ipynb"]["status"] == "failed" and "deliberate failure" in nbs["bad.ipynb"]["error"]
    assert nbs["good.ipynb"]["status"] == nbs["quiet.ipynb"]["status"] == "ok"
    assert doc["run"]["mode"] == "quick" and doc["run"]["versions"]["numpy"]
    # the good notebook ran after the bad one failed (name order, 2 jobs) and its rows are all there
    rows = read_results(out / "notebooks" / "good.results.json")
    assert [r.status for r in rows] == ["reproduced", "no paper value", "differs", "reproduced"]
    assert rows[1].note.split("; ")[0] == "embedded", "--quick left MOCOMP_DATA_DIR set in the kernel"
    assert rows[1].note.split("; ")[1] == "QUICK=True", "--quick did not pass QUICK=True to the notebook"
    # executed notebooks exported (the failed one up to its error), the figure extracted as a PNG
    assert "deliberate failure" in (out / "notebooks" / "bad.html").read_text()
    figs = nbs["good.ipynb"]["figures"]
    assert len(figs) == 1 and (out / figs[0]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (out / "index.html").read_text()
    fig1 = page[page.index('id="acrobatics-fig-1"'):page.index('id="acrobatics-table-9"')]
    assert figs[0] in fig1
    assert "RuntimeError: deliberate failure in the second cell" in page[page.index('id="failed"'):]
    assert json.loads(base.read_text())["modes"]["quick"] == {
        "good.ipynb": ["acrobatics | Fig. 1 | slope of the line", "acrobatics | Table 9 | a bound"]}

    # --data reaches the kernel; the baseline has no "data" section yet, so nothing regresses
    rc = main(["reproduce", "-o", str(tmp_path / "r2"), "--notebooks", str(books), "--only", "good",
               "--data", str(data), "--no-progress", "--check-baseline", str(base)])
    cap = capfd.readouterr()
    assert rc == 0, cap.err
    assert read_results(tmp_path / "r2" / "notebooks" / "good.results.json")[1].note == f"{data.resolve()}; QUICK=False"
    assert "2 reproduced row(s) not in" in cap.out

    # the slope changes: the row that reproduced no longer does -> exit 1 naming it
    write_fake_notebooks(books, slope=2.5)
    rc = main(["reproduce", "-o", str(tmp_path / "r3"), "--notebooks", str(books), "--only", "good.ipynb",
               "--quick", "--no-progress", "--check-baseline", str(base)])
    cap = capfd.readouterr()
    assert rc == 1
    assert ("mocomp reproduce: regressed: acrobatics | Fig. 1 | slope of the line (good.ipynb): was reproduced, "
            "now differs: ours 2.5, paper 2, tolerance 0.01") in cap.err
    assert "Table 9 | a bound" not in cap.err
    assert "baseline regressions" in (tmp_path / "r3" / "index.html").read_text()


def test_cli_errors(tmp_path, capfd):
    books = write_fake_notebooks(tmp_path / "nbs")
    assert main(["reproduce", "-o", str(tmp_path / "r"), "--notebooks", str(books), "--only", "nope"]) == 2
    err = capfd.readouterr().err.strip()
    assert err.startswith("mocomp reproduce: error: --only: no notebook named nope") and "\n" not in err
    assert main(["reproduce", "-o", str(tmp_path / "r"), "--notebooks", str(books), "--data", str(tmp_path / "x")]) == 2
    assert "data folder does not exist" in capfd.readouterr().err
    (tmp_path / "bl.json").write_text("{")
    assert main(["reproduce", "-o", str(tmp_path / "r"), "--notebooks", str(books), "--quick",
                 "--check-baseline", str(tmp_path / "bl.json")]) == 2
    assert "bl.json:1: not valid JSON" in capfd.readouterr().err
    assert not (tmp_path / "r" / "index.html").exists()   # a bad baseline fails before anything runs
    with pytest.raises(SystemExit) as e:
        main(["reproduce", "-o", str(tmp_path / "r"), "--quick", "--data", str(tmp_path)])
    assert e.value.code == 2
