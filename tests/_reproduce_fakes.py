"""Small notebooks for the ``mocomp reproduce`` tests: one that draws a figure and writes rows, one that
raises, one that runs but writes no results. Each takes seconds in a kernel."""
from __future__ import annotations

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook


def _params(extra: str = "") -> object:
    c = new_code_cell('results_path = "results.json"\n' + extra)
    c.metadata["tags"] = ["parameters"]
    return c


GOOD_ROWS = '''
from mocomp.reproduce import ResultRow, write_results
write_results([
    ResultRow("acrobatics", "Fig. 1", "slope of the line", paper_value=2.0, ours=SLOPE, tolerance=0.01),
    ResultRow("acrobatics", "Fig. 1", "data source", paper_value=None, ours=float(len(DATA_SOURCE)), tolerance=0.0,
              note=f"{DATA_SOURCE}; QUICK={QUICK}"),
    ResultRow("acrobatics", "Table 9", "a cell that differs", paper_value=1.0, ours=1.5, tolerance=0.1,
              note="reason <b>escaped</b>"),
    ResultRow("acrobatics", "Table 9", "a bound", paper_value=20.0, ours=3.0, tolerance=0.0, comparison="at most"),
], results_path, notebook="good.ipynb")
'''


def write_fake_notebooks(folder: Path, slope: float = 2.0) -> Path:
    """good.ipynb (a figure under "## Figure 1", 4 rows), bad.ipynb (raises), quiet.ipynb (no results)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    good = new_notebook(cells=[
        new_markdown_cell("# A fake notebook"),
        _params(f"SLOPE = {slope!r}\nQUICK = None  # mocomp reproduce passes True (--quick) or False"),
        new_code_cell("import os\nimport matplotlib.pyplot as plt\n"
                      "DATA_SOURCE = os.environ.get('MOCOMP_DATA_DIR') or 'embedded'"),
        new_markdown_cell("## Figure 1: a line of slope 2"),
        new_code_cell("fig, ax = plt.subplots(figsize=(3, 2))\nax.plot([0, 1], [0, SLOPE])\nplt.show()\n"
                      "os.write(2, b'a message on the kernel process stderr\\n')"),
        new_code_cell(GOOD_ROWS),
    ])
    bad = new_notebook(cells=[
        _params(),
        new_code_cell("x = 1"),
        new_code_cell("raise RuntimeError('deliberate failure in the second cell')"),
        new_code_cell("print('never reached')"),
    ])
    quiet = new_notebook(cells=[_params(), new_code_cell("print('no results written')")])
    for name, nb in (("good", good), ("bad", bad), ("quiet", quiet)):
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        nbformat.write(nb, folder / f"{name}.ipynb")
    return folder
