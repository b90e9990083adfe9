"""The figures of an executed notebook, taken from its outputs (no notebook change needed).

Every ``image/png`` output is written to a PNG file and remembered with the
heading it sits under and the source of the cell that drew it, so the report
can put a figure beside the paper-vs-ours rows of the figure or table it shows
(:func:`figures_for_item`: the item's label, e.g. "Fig. 5.5" or "Table C.1",
named in the heading or the cell).
"""
from __future__ import annotations

import base64
import re
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Figure:
    """One PNG output of a notebook.

    path:     the PNG file, relative to the report folder
    notebook: the notebook's file name
    cell:     index of the code cell's position in the notebook (0-based, all cells)
    heading:  the last markdown heading above the cell ("" if none)
    context:  heading + cell source, normalised (what item labels are matched against)
    """

    path: str
    notebook: str
    cell: int
    heading: str
    context: str


_HEADING = re.compile(r"^\s{0,3}#{1,6}\s+(.*\S)\s*$", re.M)


def normalise_label(text: str) -> str:
    """Lower case, "Figure"/"Fig" -> "fig.", "Tab."/"Table" -> "table", single spaces.

    So "Figure 5.5", "Fig 5.5" and "fig. 5.5" compare equal.
    """
    t = text.lower()
    t = re.sub(r"\bfigures?\b\.?|\bfigs?\b\.?", "fig. ", t)
    t = re.sub(r"\btables?\b\.?|\btab\b\.?", "table ", t)
    t = t.replace("–", "-").replace("—", "-")
    return " ".join(t.split())


_TOKEN = r"(?<![\w.])(?:[a-z]\.)?\d+(?:\.\d+)*[a-z]?(?!\w)"
_RUN = re.compile(r"(fig\.|table)\s*(" + _TOKEN + r"(?:\s*(?:-|/|,|and|&)\s*(?:fig\.\s*|table\s*)?" + _TOKEN + r")*)")


def _label_numbers(label: str) -> tuple[str, list[str]] | None:
    """("fig.", ["5.4"]) for "Fig. 5.4", ("table", ["c.1"]) for "Table C.1"; None when the
    label is not a numbered figure or table ("Sec. 4.3 (flight physics)")."""
    m = re.match(r"(fig\.|table)\s*(.+)$", normalise_label(label))
    if not m:
        return None
    nums = re.findall(_TOKEN, m.group(2))
    return (m.group(1), nums[:1]) if nums else None


def mentions(context: str, label: str) -> bool:
    """Does ``context`` (normalised) name the figure/table ``label``?

    "Fig. 5.5" matches "fig. 5.5 (flips paper fig. 3)"; a number must match whole
    ("fig. 5.5" is not "fig. 5.55" nor "fig. 5"); lists and ranges after one kind
    word count ("tables 6.2 / 6.3", "figs. 5.9-5.10"). A label that is not a
    numbered figure or table matches when its normalised text occurs in ``context``.
    """
    parsed = _label_numbers(label)
    if parsed is None:
        return normalise_label(label) in context
    kind, nums = parsed
    for m in _RUN.finditer(context):
        if m.group(1) == kind and set(nums) & set(re.findall(_TOKEN, m.group(2))):
            return True
    return False


def extract_figures(nb, notebook: str, out_dir: Path, rel_to: Path) -> list[Figure]:
    """Write every PNG output of the executed notebook ``nb`` (nbformat node) to ``out_dir``.

    File names are ``cellNNN_K.png`` (cell index, output number within the cell).
    Returns the figures in notebook order, paths relative to ``rel_to``.
    """
    out_dir = Path(out_dir)
    figs: list[Figure] = []
    heading = ""
    for ci, cell in enumerate(nb.cells):
        if cell.cell_type == "markdown":
            hs = _HEADING.findall(cell.source)
            if hs:
                heading = hs[-1]
            continue
        if cell.cell_type != "code":
            continue
        k = 0
        for out in cell.get("outputs", []):
            data = out.get("data") or {}
            png = data.get("image/png")
            if not png:
                continue
            out_dir.mkdir(parents=True, exist_ok=True)
            p = out_dir / f"cell{ci:03d}_{k}.png"
            p.write_bytes(base64.b64decode(png if isinstance(png, str) else "".join(png)))
            k += 1
            figs.append(Figure(path=p.relative_to(rel_to).as_posix(), notebook=notebook, cell=ci, heading=heading,
                               context=normalise_label(heading + "\n" + cell.source)))
    return figs


def figures_for_item(figures, item: str) -> list[Figure]:
    """The figures whose heading or cell names ``item`` ("Fig. 5.5", "Table C.1")."""
    return [f for f in figures if mentions(f.context, item)]
