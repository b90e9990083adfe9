"""The README's figures are rebuilt from embedded data by scripts/write_readme_figures.py."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PNG = b"\x89PNG\r\n\x1a\n"


def _script():
    spec = importlib.util.spec_from_file_location("readme_figures", ROOT / "scripts" / "write_readme_figures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_every_figure_the_readme_shows_is_committed_and_rebuilt_by_the_script(tmp_path):
    shown = re.findall(r"\]\((docs/figures/[^)]+\.png)\)", (ROOT / "README.md").read_text())
    assert shown, "the README shows no figure from docs/figures"
    assert _script().main(["--out", str(tmp_path)]) == 0
    for rel in shown:
        committed = ROOT / rel
        rebuilt = tmp_path / committed.name
        assert committed.read_bytes()[:8] == PNG, f"{rel} is not a PNG"
        assert rebuilt.read_bytes()[:8] == PNG, f"the script did not write {committed.name}"
        assert rebuilt.stat().st_size > 10_000, f"{committed.name} is suspiciously small"
