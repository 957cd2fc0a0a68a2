"""Hints name a command that works where the user is: `.venv/bin/python main.py` and
`.venv/bin/pip install -e '.[EXTRA]'` in a clone, `quadsim` and `pip install 'quadsim[EXTRA]'`
installed; main.py run by a Python without quadsim's dependencies says in one line what to run."""

from __future__ import annotations

import re
import shutil
import sys
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

from quadsim.apps.cli import main
from quadsim.core import invocation
from quadsim.core.invocation import OPTIONAL_AT_RUN_TIME, RUNTIME_MODULES, install_extra, program
from tests.helpers import ROOT


@pytest.fixture
def clone(tmp_path) -> Path:
    """A copy of the clone's files that matter here: main.py, pyproject.toml and the package."""
    tree = tmp_path / "clone"
    tree.mkdir()
    shutil.copy(ROOT / "main.py", tree)
    shutil.copy(ROOT / "pyproject.toml", tree)
    shutil.copytree(ROOT / "quadsim", tree / "quadsim", ignore=shutil.ignore_patterns("__pycache__"))
    return tree


def test_the_dependency_list_is_pyprojects():
    """RUNTIME_MODULES names a module of every runtime dependency pyproject.toml lists, and no
    other, but those a run does without (OPTIONAL_AT_RUN_TIME)."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    wanted = {
        re.split(r"[<>=;\[ ]", d, maxsplit=1)[0].lower().replace("_", "-")
        for d in declared
        if "python_version < '3.11'" not in d or sys.version_info < (3, 11)
    } - set(OPTIONAL_AT_RUN_TIME)
    assert set(OPTIONAL_AT_RUN_TIME) <= {re.split(r"[<>=;\[ ]", d, maxsplit=1)[0].lower() for d in declared}
    distributions = packages_distributions()
    found = {dist.lower().replace("_", "-") for name in RUNTIME_MODULES for dist in distributions.get(name, [])}
    assert found == wanted


def test_program_and_install_hints_in_a_clone(monkeypatch, tmp_path):
    tree, other = tmp_path / "tree", tmp_path / "other"
    (tree / ".venv" / "bin").mkdir(parents=True)
    other.mkdir()
    for name in ("python", "pip"):
        (tree / ".venv" / "bin" / name).touch()
    monkeypatch.chdir(tree)
    monkeypatch.setattr(invocation, "source_tree", lambda: tree)
    monkeypatch.setattr(sys, "argv", ["main.py", "run"])
    monkeypatch.setattr(sys, "executable", str(tree / ".venv" / "bin" / "python"))
    assert program() == ".venv/bin/python main.py"
    assert install_extra("ros2") == ".venv/bin/pip install -e '.[ros2]'"
    monkeypatch.chdir(other)  # from another folder: paths that work from there
    monkeypatch.setattr(sys, "argv", [str(tree / "main.py"), "run"])
    assert program() == f"{tree}/.venv/bin/python {tree}/main.py"
    assert install_extra("gym") == f"{tree}/.venv/bin/pip install -e '{tree}[gym]'"


def test_program_and_install_hints_installed(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(tmp_path / "bin" / "quadsim"), "run"])
    monkeypatch.setattr(invocation, "source_tree", lambda: None)
    assert program() == "quadsim"
    assert install_extra("ros2") == "pip install 'quadsim[ros2]'"


def test_the_ros2_extra_hint_fits_a_clone(capsys, monkeypatch):
    """`--input ros2` without Cyclone DDS: from a clone, the install command of the clone's
    environment (`pip install 'quadsim[ros2]'` there would fetch another quadsim)."""
    monkeypatch.chdir(ROOT)
    monkeypatch.setitem(sys.modules, "cyclonedds", None)  # as if it were not installed
    monkeypatch.setitem(sys.modules, "cyclonedds.domain", None)
    code = main(["run", "--input", "ros2", "--cameras", "none", "--no-record"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{install_extra('ros2')}" in err and "install -e '.[ros2]'" in err, err
    assert "pip install 'quadsim[ros2]'" not in err
