"""The data dictionaries match the files exactly: every column written is documented, and
every documented column is written (stimuli/README.md for manifest.csv; study/DATA_DICTIONARY.md
for responses.csv, plan.csv and the analysis CSVs)."""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _table_columns(md: str, heading: str) -> list[str]:
    """Backticked names in the first cell of each row of the first table under ``heading``."""
    part = md.split(heading, 1)[1]
    rows = []
    started = False
    for line in part.splitlines():
        if line.startswith("|"):
            started = True
            first = line.split("|")[1]
            rows += re.findall(r"`([A-Za-z_0-9]+)`", first)
        elif started:
            break
    return rows


def _bullet_columns(md: str, file: str) -> list[str]:
    """Backticked column names in the bullet that starts with ``file``."""
    m = re.search(r"^- `" + re.escape(file) + r"`(.*?)(?=^- |\Z)", md, re.S | re.M)
    assert m, file
    text = m.group(1).split(":", 1)[1]
    text = re.sub(r"`(--[a-z-]+|[a-z]+ == \"[a-z]+\"|incorrect ~ [^`]*)`", "", text)  # options, formulas
    names = re.findall(r"`([A-Za-z_0-9]+)`", text)
    values = {"group", "pooled", "probit", "logit", "Intercept", "cluster", "model"}  # values quoted in the text, not columns
    return [n for n in names if n not in values or n == "group"]


def test_manifest_columns_match_the_readme():
    from study.render import EXTRA_COLUMNS, MANIFEST_COLUMNS

    doc = _table_columns((ROOT / "stimuli" / "README.md").read_text(), "## Manifest columns")
    assert sorted(doc) == sorted(MANIFEST_COLUMNS + EXTRA_COLUMNS)
    assert len(doc) == len(set(doc))


@pytest.fixture(scope="module")
def session_files(tmp_path_factory):
    from study.analysis import analyze
    from study.design import DesignConfig
    from study.observers import Observer, Psychometric, simulate_cohort
    from study.placeholders import make_placeholder_set

    root = tmp_path_factory.mktemp("dict")
    stim = make_placeholder_set(root / "s", {("takeoff", "increase"): (20, 40)}, base_clips=("a", "b"), n_frames=3)
    folders = simulate_cohort(stim, Observer({("takeoff", "increase"): Psychometric(25, 2)}), root / "data", n=3,
                              design=DesignConfig(groups={"takeoff": ("takeoff",)}, n_attention=1))
    analyze(root / "data", root / "rep", n_boot=20, figures=False)
    return folders[0], root / "rep"


def test_responses_and_plan_columns_match_the_dictionary(session_files):
    folder, _ = session_files
    md = (ROOT / "study" / "DATA_DICTIONARY.md").read_text()
    written = list(pd.read_csv(folder / "responses.csv", nrows=0).columns)
    assert _table_columns(md, "## responses.csv") == written  # same names, same order
    from study.session import RESPONSE_COLUMNS

    assert written == list(RESPONSE_COLUMNS)
    plan = list(pd.read_csv(folder / "plan.csv", nrows=0).columns)
    assert sorted(_table_columns(md, "## plan.csv")) == sorted(plan)


@pytest.mark.parametrize("name", ["conditions.csv", "participants_condition.csv", "psychometric.csv",
                                  "mixed_model.csv", "observer_model.csv", "trials.csv", "attention.csv"])
def test_analysis_outputs_match_the_dictionary(session_files, name):
    _, rep = session_files
    md = (ROOT / "study" / "DATA_DICTIONARY.md").read_text()
    doc = _bullet_columns(md, name)
    written = list(pd.read_csv(rep / name, nrows=0).columns)
    assert sorted(set(doc)) == sorted(written), (sorted(set(doc) - set(written)), sorted(set(written) - set(doc)))
