"""mocomp.reproduce without kernels: row comparisons, figure/item matching, the index builder on fake
records, the combined results files and the baseline check."""
from __future__ import annotations

import csv
import json
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest

from mocomp.reproduce import ResultRow
from mocomp.reproduce.baseline import check_baseline, read_baseline, row_key, write_baseline
from mocomp.reproduce.figures import Figure, figures_for_item, mentions, normalise_label
from mocomp.reproduce.report import build_index, summary, write_report
from mocomp.reproduce.results import ResultsFileError
from mocomp.reproduce.runner import NotebookRun, discover

PNG_1x1 = bytes.fromhex("89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c4890000000d4944415478da6360"
                        "f8cfc0f01f0005000201e2a1d5c80000000049454e44ae426082")


def test_one_sided_comparisons():
    at_most = ResultRow("p", "Fig. 3", "after", paper_value=20.0, ours=0.7, tolerance=0.0, comparison="at most")
    assert at_most.status == "reproduced"
    assert ResultRow("p", "Fig. 3", "after", 20.0, 20.5, 0.0, comparison="at most").status == "differs"
    assert ResultRow("p", "Fig. 3", "after", 20.0, 20.5, 1.0, comparison="at most").status == "reproduced"
    assert ResultRow("p", "Fig. 3", "before", 50.0, 27.9, 0.0, comparison="at least").status == "differs"
    assert ResultRow("p", "Fig. 3", "before", 50.0, 209.0, 0.0, comparison="at least").status == "reproduced"
    # a two-sided row far below the paper's value differs, the same row "at most" reproduces
    assert ResultRow("p", "T", "q", 10.95, 0.12, 0.0).status == "differs"
    with pytest.raises(ResultsFileError, match="comparison"):
        ResultRow("p", "T", "q", 1.0, 1.0, 0.0, comparison="about")


def test_label_matching():
    assert normalise_label("Figure 5.5") == normalise_label("Fig 5.5") == normalise_label("fig. 5.5") == "fig. 5.5"
    ctx = normalise_label("Figure 5.5 (flips paper Figure 3): magnitude error")
    assert mentions(ctx, "Fig. 5.5") and mentions(ctx, "Fig. 3")
    assert not mentions(ctx, "Fig. 5.4") and not mentions(ctx, "Fig. 5") and not mentions(ctx, "Table 5.5")
    assert not mentions(normalise_label("Figure 5.55"), "Fig. 5.5")
    assert mentions(normalise_label("Table 6.2 / 6.3 style: our sequences"), "Table 6.3")
    assert mentions(normalise_label("## 2. beside the dissertation's Table C.1"), "Table C.1")
    assert not mentions(normalise_label("Table C.2"), "Table C.1")
    assert mentions(normalise_label("Figures 5.9-5.10: straight legs"), "Fig. 5.10")
    assert mentions(normalise_label("The double flip (Fig. 4a / Fig. 5.6)"), "Fig. 4a")
    assert not mentions(normalise_label("The double flip (Fig. 4a)"), "Fig. 4c")
    assert not mentions(normalise_label("Fig. 6.3"), "Sec. 4.3 (flight physics)")
    figs = [Figure("a.png", "x.ipynb", 1, "Figure 6.4: signs", normalise_label("Figure 6.4: signs\nplot()")),
            Figure("b.png", "x.ipynb", 2, "Figure 6.3 (a)", normalise_label("Figure 6.3 (a)"))]
    assert [f.path for f in figures_for_item(figs, "Fig. 6.3")] == ["b.png"]


def _fake_records(tmp: Path) -> list[NotebookRun]:
    (tmp / "figures" / "good").mkdir(parents=True)
    (tmp / "notebooks").mkdir()
    for name in ("cell004_0.png", "cell009_0.png"):
        (tmp / "figures" / "good" / name).write_bytes(PNG_1x1)
    for name in ("good.html", "bad.html", "good.ipynb", "good.results.json"):
        (tmp / "notebooks" / name).write_text("<html></html>")
    good = NotebookRun("good.ipynb", status="ok", seconds=3.25, html="notebooks/good.html",
                       executed="notebooks/good.ipynb", results_file="notebooks/good.results.json")
    good.rows = [ResultRow("acrobatics", "Fig. 1", "slope", 2.0, 2.001, 0.01, notebook="good.ipynb"),
                 ResultRow("acrobatics", "Table 9", "cell <x>", 1.0, 1.5, 0.1, note="reason & why", notebook="good.ipynb"),
                 ResultRow("acrobatics", "Table 9", "bound", 20.0, 3.0, 0.0, comparison="at most", notebook="good.ipynb"),
                 ResultRow("perception", "Fig. 2", "qualitative", None, 4.0, 0.0, notebook="good.ipynb"),
                 ResultRow("splicing", "Fig. 7", "not computed", 1.0, None, 0.1, notebook="good.ipynb")]
    good.figures = [Figure("figures/good/cell004_0.png", "good.ipynb", 4, "Figure 1: a line", normalise_label("Figure 1: a line")),
                    Figure("figures/good/cell009_0.png", "good.ipynb", 9, "Other", normalise_label("Other"))]
    bad = NotebookRun("bad.ipynb", status="failed", seconds=1.5, html="notebooks/bad.html", error="RuntimeError: boom <here>",
                      error_detail="Traceback ...\nRuntimeError: boom <here>", failed_cell=2)
    return [bad, good]


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.hrefs, self.srcs, self.ids = [], [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "a" and "href" in a:
            self.hrefs.append(a["href"])
        if tag == "img":
            self.srcs.append(a["src"])
        if "id" in a:
            self.ids.add(a["id"])


def test_index_on_fake_records(tmp_path):
    records = _fake_records(tmp_path)
    run = {"started": "2026-12-02T12:00:00+00:00", "seconds": 4.75, "mode": "quick", "data": "embedded data only",
           "notebook_dir": "/x/notebooks", "jobs": 2, "only": [], "versions": {"mocomp": "0.1.0", "python": "3.11.7",
           "numpy": "2.4.6", "mujoco": "3.3.0"}, "git_commit": "abc123", "git_dirty": True, "host": "h", "cpus": 2,
           "platform": "Linux", "load_before": [1.0, 2.0, 3.0], "load_after": [4.0, 5.0, 6.0]}
    s = summary(records)
    assert s["rows"] == {"reproduced": 2, "differs": 1, "no paper value": 1, "failed": 1}
    assert (s["notebooks"], s["notebooks_failed"]) == (2, 1)
    index = write_report(tmp_path, run, records)
    page = index.read_text()
    # summary table: every status with its count
    summ = page[page.index('id="summary-table"'):]
    summ = summ[:summ.index("</table>")]
    for status, n in s["rows"].items():
        assert re.search(rf">{status}</td><td class=n>{n}</td>", summ), status
    # versions, commit, data, run time, load
    for text in ("python 3.11.7", "numpy 2.4.6", "mujoco 3.3.0", "commit abc123 + uncommitted changes",
                 "embedded data only", "4.8 s", "before 1.00 / 2.00 / 3.00"):
        assert text in page, text
    # the failed notebook: marked, with its (escaped) error and failing cell
    assert "RuntimeError: boom &lt;here&gt; (In [2])" in page and 'id="failed"' in page
    # escaping of quantities and notes; the bound shown as such
    assert "cell &lt;x&gt;" in page and "reason &amp; why" in page and "&le; 20" in page
    # the figure named by its item sits in that item's section, the other under its notebook
    sec = page[page.index('id="acrobatics-fig-1"'):page.index('id="acrobatics-table-9"')]
    assert "figures/good/cell004_0.png" in sec and "cell009_0.png" not in sec
    assert "cell009_0.png" in page[page.index('id="figures"'):]
    # papers in their fixed order; every link and image resolves to a file or an anchor on the page
    assert page.index('id="paper-acrobatics"') < page.index('id="paper-perception"') < page.index('id="paper-splicing"')
    p = _Links()
    p.feed(page)
    assert p.srcs and p.hrefs
    for ref in p.srcs + p.hrefs:
        if ref.startswith("#"):
            assert ref[1:] in p.ids, ref
        else:
            assert (tmp_path / ref).is_file(), ref
    # combined results: JSON with run + notebooks + rows (status and key), CSV with the rows
    doc = json.loads((tmp_path / "results.json").read_text())
    assert doc["run"]["git_commit"] == "abc123" and [b["notebook"] for b in doc["notebooks"]] == ["bad.ipynb", "good.ipynb"]
    assert [r["status"] for r in doc["rows"]] == ["reproduced", "differs", "reproduced", "no paper value", "failed"]
    assert doc["rows"][0]["key"] == "acrobatics | Fig. 1 | slope"
    with open(tmp_path / "results.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 5 and rows[1]["status"] == "differs" and float(rows[1]["difference"]) == pytest.approx(0.5)
    assert rows[4]["ours"] == "" and rows[2]["comparison"] == "at most"


def test_index_without_rows_or_figures(tmp_path):
    rec = NotebookRun("x.ipynb", status="ok", seconds=0.1, results_error="x.ipynb ran but wrote no results file")
    page = build_index({"seconds": 0.1}, [rec])
    assert "wrote no results file" in page and "<h2 id=\"papers\">" not in page
    assert summary([rec])["notebooks_without_results"] == 1


def test_baseline_check_names_each_regression(tmp_path):
    records = _fake_records(tmp_path)
    good = records[1]
    path = write_baseline(tmp_path / "baseline.json", "quick", records)
    doc = read_baseline(path)
    # reproduced rows only; the failed notebook gets no entry
    assert doc["modes"]["quick"] == {"good.ipynb": ["acrobatics | Fig. 1 | slope", "acrobatics | Table 9 | bound"]}
    assert check_baseline(doc, "quick", records, complete=True) == ([], [])
    # another mode is not checked against this one
    assert check_baseline(doc, "data", records, complete=True) == ([], [row_key(good.rows[0]), row_key(good.rows[2])])
    # the slope now differs, the bound row disappears
    good.rows = [ResultRow("acrobatics", "Fig. 1", "slope", 2.0, 2.5, 0.01, notebook="good.ipynb"), good.rows[1]]
    reg, new = check_baseline(doc, "quick", records, complete=True)
    assert [(r.key, r.now) for r in reg] == [("acrobatics | Fig. 1 | slope", "differs"),
                                             ("acrobatics | Table 9 | bound", "missing")]
    assert "ours 2.5, paper 2, tolerance 0.01" in reg[0].line() and new == []
    # the notebook fails: every baseline row of it is named with the error
    good.status, good.error, good.rows = "failed", "ValueError: broken", []
    reg, _ = check_baseline(doc, "quick", records, complete=True)
    assert {r.now for r in reg} == {"notebook failed"} and len(reg) == 2 and "ValueError: broken" in reg[0].line()
    # the notebook is gone: a regression in a complete run, not checked with --only
    reg, _ = check_baseline(doc, "quick", [records[0]], complete=True)
    assert {r.now for r in reg} == {"notebook missing"}
    assert check_baseline(doc, "quick", [records[0]], complete=False) == ([], [])
    # writing again after a failure keeps the failed notebook's entry
    write_baseline(path, "quick", records)
    assert read_baseline(path)["modes"]["quick"]["good.ipynb"] == doc["modes"]["quick"]["good.ipynb"]


def test_baseline_file_errors(tmp_path):
    p = tmp_path / "b.json"
    p.write_text("{ nope")
    with pytest.raises(ResultsFileError, match=r"b.json:1: not valid JSON"):
        read_baseline(p)
    p.write_text(json.dumps({"modes": {"full": {}}}))
    with pytest.raises(ResultsFileError, match="modes"):
        read_baseline(p)
    p.write_text(json.dumps({"modes": {"quick": {"a.ipynb": "key"}}}))
    with pytest.raises(ResultsFileError, match="modes.quick"):
        read_baseline(p)


def test_discover(tmp_path):
    for n in ("b.ipynb", "a.ipynb", ".hidden.ipynb", "notes.txt"):
        (tmp_path / n).write_text("{}")
    assert [p.name for p in discover(tmp_path)] == ["a.ipynb", "b.ipynb"]
    assert [p.name for p in discover(tmp_path, ["b", "a.ipynb"])] == ["a.ipynb", "b.ipynb"]
    with pytest.raises(ValueError, match=r"no notebook named zz .*have: a, b"):
        discover(tmp_path, ["zz"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="no notebooks"):
        discover(tmp_path / "empty")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        discover(tmp_path / "missing")


def test_longest_first_from_the_last_run(tmp_path, monkeypatch):
    from mocomp.reproduce.runner import _longest_first, _remember_times

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    books = [tmp_path / f"{n}.ipynb" for n in ("a", "b", "c", "d")]
    assert _longest_first(books, tmp_path / "none.json", "quick") == books  # never timed: name order
    _remember_times([NotebookRun("a.ipynb", seconds=5), NotebookRun("b.ipynb", seconds=50),
                     NotebookRun("c.ipynb", seconds=20)], "quick")
    # the slowest first; a notebook never timed (d) goes first, it may be the longest
    assert [p.stem for p in _longest_first(books, tmp_path / "none.json", "quick")] == ["d", "b", "c", "a"]
    assert _longest_first(books, tmp_path / "none.json", "data") == books  # times are per data mode
    # a previous report in the output folder wins over the cache
    (tmp_path / "results.json").write_text(json.dumps({"notebooks": [{"notebook": "a.ipynb", "seconds": 99},
                                                                     {"notebook": "d.ipynb", "seconds": 1}]}))
    # (b and c untimed there: first, by name)
    assert [p.stem for p in _longest_first(books, tmp_path / "results.json", "quick")] == ["b", "c", "a", "d"]


def test_first_run_on_a_machine_starts_the_longest_notebooks_first(tmp_path, monkeypatch):
    """No previous report, no time cache (a fresh clone in CI): the shipped times order the project's
    notebooks, longest first; a notebook they do not know still goes first."""
    from mocomp.reproduce.runner import DEFAULT_SECONDS, _longest_first, default_notebook_dir

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "empty_cache"))
    real = sorted(default_notebook_dir().glob("*.ipynb"))
    assert {p.name for p in real} == set(DEFAULT_SECONDS)  # every notebook of the project has a time
    books = [tmp_path / n for n in ("mass_tables.ipynb", "momentum_errors.ipynb", "new_one.ipynb",
                                    "touchup.ipynb", "perception_study.ipynb")]
    order = [p.stem for p in _longest_first(books, tmp_path / "none.json", "quick")]
    assert order == ["new_one", "momentum_errors", "perception_study", "touchup", "mass_tables"]
