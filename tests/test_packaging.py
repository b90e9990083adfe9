"""Packaging facts that no conda client can check here: environment.yml mirrors pyproject."""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def _name(req: str) -> str:
    return re.split(r"[<>=!~\[; ]", req.strip(), maxsplit=1)[0].lower().replace("_", "-")


def _env_names() -> set[str]:
    env = yaml.safe_load((ROOT / "environment.yml").read_text())
    names = set()
    for dep in env["dependencies"]:
        if isinstance(dep, dict):
            names |= {_name(d) for d in dep.get("pip", []) if not d.startswith("-")}
        else:
            names.add(_name(dep))
    return names


def test_environment_yml_lists_every_runtime_and_test_dependency():
    proj = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = {_name(r) for r in proj["dependencies"]}
    for extra in proj.get("optional-dependencies", {}).values():
        wanted |= {_name(r) for r in extra}
    missing = sorted(wanted - _env_names())
    assert not missing, f"environment.yml lacks {missing}"


def test_environment_yml_uses_conda_forge():
    env = yaml.safe_load((ROOT / "environment.yml").read_text())
    assert env["channels"][0] == "conda-forge"


def test_name_parser_strips_versions_and_extras():
    assert _name("dtw-python>=1.5") == "dtw-python"
    assert _name("jupyterlab_widgets>=3") == "jupyterlab-widgets"
    assert _name("foo[bar]==1; python_version<'4'") == "foo"


def test_property_tests_are_derandomized_under_ci():
    """CI runs the hypothesis tests reproducibly (conftest's 'ci' profile): no flaky CI."""
    from hypothesis import settings

    from conftest import IN_CI

    ci = settings.get_profile("ci")
    assert ci.derandomize and ci.database is None
    if IN_CI:
        assert settings.default.derandomize and settings.default.database is None


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert block, "README.md must open with a ```bash block of set-up commands"
    return [ln.strip() for ln in block.group(1).splitlines() if ln.strip()]


def test_ci_runs_the_readme_test_command():
    """.ci/run installs the README's test extra and runs the README's own pytest invocation."""
    setup, tests = _readme_commands()[:2]
    assert "mocomp demo" in setup
    install = re.search(r"pip install -q -e (\S+)", tests)
    pytest_cmd = re.search(r"(python -m pytest.*)$", tests)
    assert install and pytest_cmd, tests
    ci = (ROOT / ".ci" / "run").read_text()
    ci_lines = [ln.strip() for ln in ci.splitlines() if not ln.lstrip().startswith("#")]
    assert any(f"pip install -q -e {install.group(1)}" in ln for ln in ci_lines), \
        f".ci/run does not install {install.group(1)} as the README does"
    assert pytest_cmd.group(1).removeprefix(".venv/bin/") in ci_lines, \
        f".ci/run does not run the README's '{pytest_cmd.group(1)}'"


def test_notebooks_are_committed_without_outputs():
    """DESIGN.md: notebooks are committed without outputs (CI executes them; figures the README shows
    are written by scripts/write_readme_figures.py). A notebook saved after running fails here."""
    import json

    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    assert notebooks
    for nb_path in notebooks:
        nb = json.loads(nb_path.read_text())
        for i, cell in enumerate(nb["cells"]):
            if cell["cell_type"] != "code":
                continue
            assert not cell.get("outputs") and cell.get("execution_count") is None, (
                f"{nb_path.name}: code cell {i} has outputs or an execution count; clear them before committing")
        code = [c for c in nb["cells"] if c["cell_type"] == "code"]
        assert "parameters" in code[0]["metadata"].get("tags", []), f"{nb_path.name}: first code cell not tagged"
