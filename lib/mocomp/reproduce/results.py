"""The machine-readable paper-vs-ours rows every notebook writes (``results.json``).

A row compares one number of a paper (a figure's value, a table cell) with the
number the notebook measured.  Its status is decided here, once, so the report,
CI and the notebooks agree:

* ``reproduced``: ``|ours - paper_value| <= tolerance`` (``comparison="within"``,
  the default); for a paper's one-sided claim ("20 % or less", "over 50 %")
  ``comparison="at most"``: ``ours <= paper_value + tolerance``, ``"at least"``:
  ``ours >= paper_value - tolerance``;
* ``differs``: outside the tolerance (the ``note`` says why, when known);
* ``no paper value``: the paper gives no number (a qualitative figure): the
  row documents what we measured;
* ``failed``: the notebook could not compute the value (``ours`` is None).

The tolerance is absolute, in the quantity's own unit, and must be stated
explicitly: there is no default, so every "reproduced" is a claim with a bound.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ..errors import MocompError

SCHEMA_VERSION = 1
STATUSES = ("reproduced", "differs", "no paper value", "failed")
COMPARISONS = ("within", "at most", "at least")


class ResultsFileError(MocompError, ValueError):
    """A ``results.json`` file is malformed (names the file and the row)."""


@dataclass(frozen=True)
class ResultRow:
    """One compared number.

    paper:       short key of the paper ("acrobatics", "perception", "touchup",
                 "concatenation", "impact", "splicing")
    item:        the figure or table, as the paper names it ("Table 2", "Fig. 8")
    quantity:    what is compared, in words ("R^2 of the mass fit, subject 88")
    paper_value: the paper's number, or None when it gives none
    ours:        our number, or None when it could not be computed
    tolerance:   absolute tolerance, same unit as the values (>= 0)
    unit:        the values' unit ("m/s", "%", "" for dimensionless)
    note:        why it differs / how it was measured / what data was used
    notebook:    the notebook that wrote the row (stamped by write_results)
    comparison:  "within" (two-sided, the default), "at most" or "at least": the
                 paper's value is a bound ("20 % or less" is paper_value=20,
                 comparison="at most")
    """

    paper: str
    item: str
    quantity: str
    paper_value: float | None
    ours: float | None
    tolerance: float
    unit: str = ""
    note: str = ""
    notebook: str = field(default="")
    comparison: str = "within"

    def __post_init__(self):
        if self.comparison not in COMPARISONS:
            raise ResultsFileError(f"ResultRow {self.item!r}/{self.quantity!r}: comparison must be one of "
                                   f"{COMPARISONS}, got {self.comparison!r}")
        for name in ("paper", "item", "quantity"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name).strip():
                raise ResultsFileError(f"ResultRow.{name} must be a non-empty string")
        for name in ("paper_value", "ours"):
            v = getattr(self, name)
            if v is not None:
                v = float(v)
                if not math.isfinite(v):
                    raise ResultsFileError(
                        f"ResultRow {self.item!r}/{self.quantity!r}: {name} is {v}; "
                        "use None for a value that could not be computed")
                object.__setattr__(self, name, v)
        tol = float(self.tolerance)
        if not math.isfinite(tol) or tol < 0:
            raise ResultsFileError(
                f"ResultRow {self.item!r}/{self.quantity!r}: tolerance must be finite and >= 0, got {tol}")
        object.__setattr__(self, "tolerance", tol)

    @property
    def difference(self) -> float | None:
        if self.ours is None or self.paper_value is None:
            return None
        return self.ours - self.paper_value

    @property
    def status(self) -> str:
        if self.ours is None:
            return "failed"
        if self.paper_value is None:
            return "no paper value"
        d = self.difference
        ok = {"within": abs(d) <= self.tolerance, "at most": d <= self.tolerance,
              "at least": d >= -self.tolerance}[self.comparison]
        return "reproduced" if ok else "differs"

    def to_dict(self) -> dict:
        d = asdict(self)
        d["difference"] = self.difference
        d["status"] = self.status
        return d


def write_results(rows, path: str | Path = "results.json", notebook: str = "") -> Path:
    """Write ``rows`` (ResultRow) to ``path`` as JSON, atomically; returns the path.

    ``notebook`` (the notebook's file name) is stamped on rows that lack one.
    """
    path = Path(path)
    out = []
    for i, r in enumerate(rows):
        if not isinstance(r, ResultRow):
            raise ResultsFileError(f"{path}: row {i} is a {type(r).__name__}, not a ResultRow")
        if notebook and not r.notebook:
            r = ResultRow(**{**asdict(r), "notebook": notebook})
        out.append(r.to_dict())
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps({"schema": SCHEMA_VERSION, "rows": out}, indent=1))
    tmp.replace(path)
    return path


def read_results(path: str | Path) -> list[ResultRow]:
    """Read a ``results.json``; a malformed file raises naming the file and row."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise
    except json.JSONDecodeError as e:
        raise ResultsFileError(f"{path}:{e.lineno}: not valid JSON ({e.msg})") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("rows"), list):
        raise ResultsFileError(f"{path}: expected an object with a 'rows' list")
    rows = []
    keys = {f for f in ResultRow.__dataclass_fields__}
    for i, d in enumerate(doc["rows"]):
        if not isinstance(d, dict):
            raise ResultsFileError(f"{path}: row {i} is not an object")
        missing = {"paper", "item", "quantity", "paper_value", "ours", "tolerance"} - d.keys()
        if missing:
            raise ResultsFileError(f"{path}: row {i} lacks field(s) {sorted(missing)}")
        try:
            rows.append(ResultRow(**{k: v for k, v in d.items() if k in keys}))
        except (TypeError, ValueError) as e:
            raise ResultsFileError(f"{path}: row {i}: {e}") from None
    return rows
