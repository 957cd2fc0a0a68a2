"""Hints name a command that works where the user is: `.venv/bin/python main.py` and
`.venv/bin/pip install -e '.[EXTRA]'` in a clone, `quadsim` and `pip install 'quadsim[EXTRA]'`
installed; main.py run by a Python without quadsim's dependencies says in one line what to run."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

from quadsim.apps.cli import main
from quadsim.core import invocation
from quadsim.core.invocation import RUNTIME_MODULES, install_extra, program
from tests.helpers import ROOT


def _bare_python(folder: Path) -> Path:
    """A Python with nothing installed: a fresh virtual environment without even pip."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(folder)], check=True)
    return folder / "bin" / "python"


@pytest.fixture
def clone(tmp_path) -> Path:
    """A copy of the clone's files that matter here: main.py, pyproject.toml and the package."""
    tree = tmp_path / "clone"
    tree.mkdir()
    shutil.copy(ROOT / "main.py", tree)
    shutil.copy(ROOT / "pyproject.toml", tree)
    shutil.copytree(ROOT / "quadsim", tree / "quadsim", ignore=shutil.ignore_patterns("__pycache__"))
    return tree


def _one_line(result: subprocess.CompletedProcess) -> str:
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert result.stdout == ""
    return lines[0]


def test_main_py_without_the_dependencies_says_to_set_up_the_clone(clone, tmp_path):
    """No .venv yet (a fresh clone, `python3 main.py run ...`): `make fly` sets it up, then the
    environment's python runs what was asked."""
    python = _bare_python(tmp_path / "bare")
    result = subprocess.run(
        [str(python), "main.py", "run", "--script", "square"], capture_output=True, text=True, cwd=clone
    )
    line = _one_line(result)
    assert line.startswith("quadsim: error: this Python") and "lacks quadsim's dependencies (no pybullet" in line
    assert "'make fly'" in line and line.endswith("then: .venv/bin/python main.py run --script square")


def test_main_py_in_an_isolated_python_says_it_too(clone):
    """`python3 -S -I main.py`: no site-packages, and no script folder on sys.path (-I)."""
    result = subprocess.run(
        [sys.executable, "-S", "-I", "main.py", "check", "recordings/"], capture_output=True, text=True, cwd=clone
    )
    line = _one_line(result)
    assert "lacks quadsim's dependencies" in line and line.endswith(".venv/bin/python main.py check recordings/")


def test_main_py_without_the_dependencies_names_the_clones_environment(clone, tmp_path):
    """A .venv there (set up before, the user typed python3): the command with its python."""
    _bare_python(clone / ".venv")
    python = _bare_python(tmp_path / "bare")
    result = subprocess.run(
        [str(python), "main.py", "fly", "--cameras", "none"], capture_output=True, text=True, cwd=clone
    )
    line = _one_line(result)
    assert line.endswith("use the clone's environment: .venv/bin/python main.py fly --cameras none"), line
    # from another folder, the paths that work from there
    elsewhere = subprocess.run(
        [str(python), str(clone / "main.py"), "info", "x.mcap"], capture_output=True, text=True, cwd=tmp_path
    )
    assert _one_line(elsewhere).endswith(f"environment: clone/.venv/bin/python {clone}/main.py info x.mcap")


def test_the_dependency_list_is_pyprojects():
    """RUNTIME_MODULES names a module of every runtime dependency pyproject.toml lists, and no other."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    wanted = {
        re.split(r"[<>=;\[ ]", d, maxsplit=1)[0].lower().replace("_", "-")
        for d in declared
        if "python_version < '3.11'" not in d or sys.version_info < (3, 11)
    }
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


def test_the_recover_hint_names_the_command_that_started_it(tmp_path):
    """`info` of a cut-short file, from a clone: run recover as main.py, not as `quadsim`."""
    data = (ROOT / "tests" / "recordings" / "square_cascade.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "info", str(cut)], capture_output=True, text=True, cwd=ROOT
    )
    line = _one_line(result)
    assert re.search(rf"Run '\S*python\S* {re.escape(str(ROOT / 'main.py'))} recover {re.escape(str(cut))}'", line), (
        line
    )
    assert "'quadsim recover" not in line
