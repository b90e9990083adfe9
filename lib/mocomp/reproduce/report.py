"""The browsable report of a ``mocomp reproduce`` run: ``index.html``, ``results.json``, ``results.csv``.

One page: the run (data, versions, commit, time, load), a summary table (rows
per status, notebooks run and failed, baseline regressions), the notebooks
(status, time, error, links to their HTML), then per paper and per figure or
table the figures that show it beside the paper-vs-ours rows (paper's value,
ours, difference, tolerance, status, the notebook's note), and each
notebook's remaining figures. Everything linked is relative to the report
folder, so the folder can be moved or served as is.
"""
from __future__ import annotations

import csv
import html
import json
import re
from collections import Counter, defaultdict
from pathlib import Path

from .baseline import row_key
from .figures import figures_for_item
from .results import SCHEMA_VERSION, STATUSES

PAPERS = {
    "acrobatics": "Majkowska & Faloutsos, Flipping with physics (SCA 2007) / Majkowska, dissertation ch. 5 (UCLA 2007)",
    "perception": "Majkowska & Faloutsos, Flipping with physics, section 7 (perception study, Table 2)",
    "splicing": "Majkowska, dissertation ch. 6: hand/body splicing with banded DTW (UCLA 2007)",
    "impact": "Majkowska, dissertation ch. 4: impact response (UCLA 2007)",
    "touchup": "Shin, Kovar & Gleicher, Physical touch-up of human motions (PG 2003)",
    "concatenation": "Shum, Komura & Yadav, Angular momentum guided motion concatenation (CAVW 2009)",
}
STATUS_CLASS = {"reproduced": "ok", "differs": "bad", "no paper value": "info", "failed": "fail"}
CSV_FIELDS = ["paper", "item", "quantity", "comparison", "paper_value", "ours", "difference", "tolerance", "unit",
              "status", "note", "notebook"]
BOUND = {"within": "", "at most": "&le; ", "at least": "&ge; "}


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _num(v, unit: str = "") -> str:
    if v is None:
        return "&ndash;"
    a = abs(v)
    s = f"{v:.3g}" if (a and (a < 1e-3 or a >= 1e5)) else f"{v:.4g}"
    return _e(s + (f" {unit}" if unit else ""))


def _anchor(*parts) -> str:
    return re.sub(r"[^a-z0-9]+", "-", "-".join(parts).lower()).strip("-")


def _item_sort_key(item: str):
    """Figures before tables, then by number ("Fig. 5.10" after "Fig. 5.9")."""
    kind = 0 if item.lower().startswith("fig") else 1 if item.lower().startswith("tab") else 2
    nums = [int(n) if n.isdigit() else ord(n[0]) * 1000 for n in re.findall(r"\d+|[A-Z](?=\.)", item)]
    return (kind, nums, item)


def combined(run: dict, records) -> dict:
    """The machine-readable run: metadata, one entry per notebook, every row (with status)."""
    books = []
    for r in records:
        books.append({"notebook": r.name, "status": r.status, "seconds": round(r.seconds, 3),
                      "export_seconds": round(r.export_seconds, 3), "error": r.error, "failed_cell": r.failed_cell,
                      "results_error": r.results_error, "html": r.html, "executed": r.executed,
                      "results_file": r.results_file, "kernel_log": r.kernel_log, "rows": len(r.rows), "figures": [f.path for f in r.figures]})
    rows = [{**row.to_dict(), "key": row_key(row)} for r in records for row in r.rows]
    return {"schema": SCHEMA_VERSION, "run": run, "summary": summary(records), "notebooks": books, "rows": rows}


def summary(records) -> dict:
    """Counts: rows per status (every status listed, 0 included), notebooks ok / failed."""
    c = Counter(row.status for r in records for row in r.rows)
    return {"rows": {s: c.get(s, 0) for s in STATUSES}, "rows_total": sum(c.values()),
            "notebooks": len(records), "notebooks_ok": sum(r.status == "ok" for r in records),
            "notebooks_failed": sum(r.status != "ok" for r in records),
            "notebooks_without_results": sum(r.status == "ok" and bool(r.results_error) for r in records)}


def write_report(report_dir, run: dict, records) -> Path:
    """Write ``index.html``, ``results.json`` and ``results.csv`` into ``report_dir``; returns the index."""
    report_dir = Path(report_dir)
    doc = combined(run, records)
    (report_dir / "results.json").write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    with open(report_dir / "results.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_FIELDS, extrasaction="ignore")
        w.writeheader()
        for row in doc["rows"]:
            w.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in CSV_FIELDS})
    index = report_dir / "index.html"
    index.write_text(build_index(run, records), encoding="utf-8")
    return index


CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:1.5em auto;max-width:1250px;
 padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.8em}
h3{margin-top:1.4em}table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
td,th{border:1px solid #ddd;padding:.25em .5em;vertical-align:top}th{background:#f4f4f4;text-align:left}
td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.ok{background:#e3f5e1}.bad{background:#fde8c8}.info{background:#e8eef9}.fail{background:#f9d6d6}
.figs{display:flex;flex-wrap:wrap;gap:.8em;margin:.5em 0}.figs figure{margin:0;max-width:600px}
.figs img{max-width:100%;max-height:420px;border:1px solid #ddd}
figcaption{font-size:.8em;color:#555}.note{font-size:.85em;color:#333;max-width:34em}
pre{background:#f7f7f7;padding:.6em;overflow-x:auto;font-size:.8em;max-height:24em}
.meta td:first-child{font-weight:600;white-space:nowrap}
"""


def _status_cell(status: str) -> str:
    return f'<td class="{STATUS_CLASS.get(status, "")}">{_e(status)}</td>'


def _figures_html(figs, caption_prefix: str = "") -> str:
    if not figs:
        return ""
    out = ['<div class="figs">']
    for f in figs:
        cap = f"{caption_prefix}{f.notebook}, cell {f.cell}" + (f": {f.heading}" if f.heading else "")
        out.append(f'<figure><a href="{_e(f.path)}"><img src="{_e(f.path)}" alt="{_e(cap)}"></a>'
                   f"<figcaption>{_e(cap)}</figcaption></figure>")
    out.append("</div>")
    return "\n".join(out)


def _rows_table(rows, html_of) -> str:
    out = ["<table><tr><th>quantity</th><th>paper</th><th>ours</th><th>difference</th><th>tolerance</th>"
           "<th>status</th><th>note</th><th>notebook</th></tr>"]
    for r in rows:
        nb = html_of.get(r.notebook)
        link = f'<a href="{_e(nb)}">{_e(r.notebook)}</a>' if nb else _e(r.notebook or "")
        out.append(f"<tr><td>{_e(r.quantity)}</td><td class=n>"
                   f"{BOUND[r.comparison] if r.paper_value is not None else ''}{_num(r.paper_value, r.unit)}</td>"
                   f"<td class=n>{_num(r.ours, r.unit)}</td><td class=n>{_num(r.difference, r.unit)}</td>"
                   f"<td class=n>{'&plusmn;' if r.comparison == 'within' else ''}{_num(r.tolerance, r.unit)}</td>{_status_cell(r.status)}"
                   f'<td class="note">{_e(r.note)}</td><td>{link}</td></tr>')
    out.append("</table>")
    return "\n".join(out)


def build_index(run: dict, records) -> str:
    """The report page (a string of HTML) for ``run`` (metadata dict) and its notebook records."""
    s = summary(records)
    html_of = {r.name: r.html for r in records if r.html}
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>mocomp reproduce: the papers' figures and tables</title>",
             f"<style>{CSS}</style></head><body>",
             "<h1>mocomp reproduce: the papers' figures and tables, re-run</h1>"]

    # --- run metadata
    v = run.get("versions", {})
    commit = run.get("git_commit", "")
    meta = [("started (UTC)", run.get("started", "")),
            ("run time", f"{run.get('seconds', 0):.1f} s ({run.get('jobs', 1)} notebook(s) at a time)"),
            ("data", run.get("data", "")),
            ("notebooks", run.get("notebook_dir", "") + (f" (only: {', '.join(run['only'])})" if run.get("only") else "")),
            ("mocomp", f"{v.get('mocomp', '')}, commit {commit}" + (" + uncommitted changes" if run.get("git_dirty") else "")),
            ("versions", ", ".join(f"{k} {val}" for k, val in v.items() if k != "mocomp")),
            ("host", f"{run.get('host', '')} ({run.get('cpus', '?')} CPUs), {run.get('platform', '')}"),
            ("load average", "before " + " / ".join(f"{x:.2f}" for x in run.get("load_before", [])) +
             ", after " + " / ".join(f"{x:.2f}" for x in run.get("load_after", [])))]
    parts.append('<table class="meta">' + "".join(f"<tr><td>{_e(k)}</td><td>{_e(val)}</td></tr>" for k, val in meta)
                 + "</table>")
    parts.append('<p>Machine-readable: <a href="results.json">results.json</a> (run, notebooks, rows), '
                 '<a href="results.csv">results.csv</a> (rows).</p>')

    # --- summary
    parts.append('<h2 id="summary">Summary</h2><table id="summary-table"><tr><th>status</th><th>rows</th></tr>')
    for st in STATUSES:
        parts.append(f'<tr>{_status_cell(st)}<td class=n>{s["rows"][st]}</td></tr>')
    parts.append(f'<tr><th>all rows</th><td class=n>{s["rows_total"]}</td></tr>'
                 f'<tr><th>notebooks run / failed</th><td class=n>{s["notebooks"]} / {s["notebooks_failed"]}</td></tr>')
    bl = run.get("baseline")
    if bl:
        cls = "fail" if bl.get("regressions") else "ok"
        parts.append(f'<tr><th>baseline regressions</th><td class="n {cls}">{len(bl.get("regressions", []))}</td></tr>')
    parts.append("</table>")
    parts.append("<p>A row is <b>reproduced</b> when |ours &minus; paper| &le; its stated tolerance (for a paper's bound, "
                 "&le; / &ge; in the paper column: ours on the paper's side of it, give or take the tolerance), <b>differs</b> "
                 "otherwise (the note says why), <b>no paper value</b> when the paper gives no number (the row "
                 "documents what we measured), <b>failed</b> when the notebook could not compute it.</p>")
    if bl:
        parts.append(f"<p>Baseline {_e(bl.get('file', ''))} ({_e(run.get('mode', ''))} mode): "
                     f"{len(bl.get('regressions', []))} regression(s), {len(bl.get('new', []))} reproduced row(s) "
                     "not yet in it.</p>")
        if bl.get("regressions"):
            parts.append('<ul id="regressions">' + "".join(f'<li class="fail">{_e(x)}</li>' for x in bl["regressions"])
                         + "</ul>")

    # --- notebooks
    parts.append('<h2 id="notebooks">Notebooks</h2><table id="notebook-table"><tr><th>notebook</th><th>status</th>'
                 "<th>time</th><th>rows</th><th>figures</th><th>executed</th><th>error</th></tr>")
    for r in records:
        cls = "ok" if r.status == "ok" and not r.results_error else "fail"
        name = f'<a href="{_e(r.html)}">{_e(r.name)}</a>' if r.html else _e(r.name)
        err = _e(r.error) + (f" (In [{r.failed_cell}])" if r.failed_cell is not None else "")
        if r.results_error:
            err += ("<br>" if err else "") + _e(r.results_error)
        results = f'<a href="{_e(r.results_file)}">results</a>' if r.rows else "&ndash;"
        parts.append(f'<tr><td><a href="#nb-{_anchor(r.stem)}">&#8595;</a> {name}</td><td class="{cls}">{_e(r.status)}'
                     f"</td><td class=n>{r.seconds:.1f} s</td><td class=n>{len(r.rows)} ({results})</td>"
                     f"<td class=n>{len(r.figures)}</td><td>"
                     + (f'<a href="{_e(r.executed)}">.ipynb</a>' if r.executed else "")
                     + (f' <a href="{_e(r.kernel_log)}">kernel log</a>' if r.kernel_log else "")
                     + f"</td><td>{err}</td></tr>")
    parts.append("</table>")

    # --- per paper, per item
    by_paper: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for r in records:
        for row in r.rows:
            by_paper[row.paper][row.item].append(row)
    all_figs = [f for r in records for f in r.figures]
    shown = set()
    order = [p for p in PAPERS if p in by_paper] + sorted(p for p in by_paper if p not in PAPERS)
    if order:
        parts.append('<h2 id="papers">Papers</h2><ul>' + "".join(
            f'<li><a href="#paper-{_anchor(p)}">{_e(p)}</a>: {_e(PAPERS.get(p, ""))}</li>' for p in order) + "</ul>")
    for p in order:
        items = by_paper[p]
        c = Counter(row.status for rows in items.values() for row in rows)
        parts.append(f'<h2 id="paper-{_anchor(p)}">{_e(p)}</h2><p>{_e(PAPERS.get(p, ""))}<br>'
                     + ", ".join(f"{c.get(st, 0)} {st}" for st in STATUSES) + "</p>")
        for item in sorted(items, key=_item_sort_key):
            rows = items[item]
            books = {row.notebook for row in rows}
            figs = [f for f in figures_for_item(all_figs, item) if f.notebook in books]
            shown.update(f.path for f in figs)
            parts.append(f'<h3 id="{_anchor(p, item)}">{_e(item)}</h3>')
            parts.append(_figures_html(figs))
            parts.append(_rows_table(rows, html_of))

    # --- failed notebooks: the error in full
    failed = [r for r in records if r.status != "ok"]
    if failed:
        parts.append('<h2 id="failed">Failed notebooks</h2>')
        for r in failed:
            link = f' (<a href="{_e(r.html)}">executed up to the error</a>)' if r.html else ""
            parts.append(f'<h3 class="fail">{_e(r.name)}</h3><p>{_e(r.error)}{link}</p><pre>{_e(r.error_detail)}</pre>')

    # --- every notebook's other figures
    parts.append('<h2 id="figures">Figures by notebook</h2><p>Figures not shown above under a figure or table.</p>')
    for r in records:
        rest = [f for f in r.figures if f.path not in shown]
        link = f'<a href="{_e(r.html)}">{_e(r.name)}</a>' if r.html else _e(r.name)
        parts.append(f'<h3 id="nb-{_anchor(r.stem)}">{link}</h3>')
        parts.append(f"<details><summary>{len(rest)} figure(s)</summary>{_figures_html(rest)}</details>" if rest
                     else "<p>none</p>")
    parts.append("</body></html>")
    return "\n".join(x for x in parts if x)
