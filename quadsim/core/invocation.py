"""How the user started quadsim, so that a hint names a command that works where they are.

From a clone, quadsim runs as `.venv/bin/python main.py` and an extra installs into that
environment from the source tree (`.venv/bin/pip install -e '.[ros2]'`); installed, it is the
`quadsim` command and `pip install 'quadsim[ros2]'`. Every hint and help text that names a
command or an extra asks here, whatever layer it lives in: a `pip install 'quadsim[ros2]'`
typed in a clone installs another copy of quadsim from the package index, not the extra.

Plain Python (no third-party import): main.py asks here before quadsim's dependencies are known
to be installed.
"""

from __future__ import annotations

import os
import shlex
import shutil
import sys
from importlib.util import find_spec
from pathlib import Path

#: the clone's own entry script, beside the package folder
CLONE_ENTRY = "main.py"
#: the modules of the runtime dependencies (pyproject.toml's `dependencies`, by import name;
#: tests/unit/test_invocation.py keeps the two lists alike), less those a run does without
#: (OPTIONAL_AT_RUN_TIME)
RUNTIME_MODULES = (
    "pybullet",
    "numpy",
    "mcap",
    "foxglove",
    "websockets",
    "mcap_ros2",
    "rosbags",
    "cv2",
    "pygame",
    *(("tomli",) if sys.version_info < (3, 11) else ()),
)
#: dependencies a run does without: numba (installed where it has wheels; without it the flight
#: core runs as plain Python, the same to the bit: quadsim.core.compiled)
OPTIONAL_AT_RUN_TIME = ("numba",)


def source_tree() -> Path | None:
    """The clone quadsim is imported from (the folder holding pyproject.toml, main.py and the
    package), or None when it is installed from a wheel."""
    root = Path(__file__).resolve().parents[2]
    if (root / "pyproject.toml").is_file() and (root / CLONE_ENTRY).is_file():
        return root
    return None


def _as_typed(path: Path) -> str:
    """`path` as a person would type it here: relative to the current folder when inside it."""
    here = Path.cwd()
    return str(path.relative_to(here) if path.is_relative_to(here) else path)


def python_command() -> str:
    """This interpreter as a person would type it: `.venv/bin/python` in a clone's folder, its
    bare name when that is what the PATH finds, else its full path."""
    executable = Path(sys.executable) if sys.executable else Path("python")
    if not executable.is_absolute():
        return str(executable)
    typed = _as_typed(executable)
    if typed != str(executable):
        return typed if os.sep in typed else f".{os.sep}{typed}"
    found = shutil.which(executable.name)
    try:
        if found is not None and Path(found).samefile(executable):
            return executable.name
    except OSError:
        pass
    return str(executable)


def program() -> str:
    """The command that started quadsim, for help and hints to name: `.venv/bin/python main.py`
    in a clone, `python -m quadsim`, or the installed `quadsim` command."""
    started = Path(sys.argv[0]) if sys.argv and sys.argv[0] else Path()
    if started.name == CLONE_ENTRY:
        return f"{python_command()} {sys.argv[0]}"
    if started.name == "__main__.py" and started.parent.name == "quadsim":
        return "python -m quadsim"
    return "quadsim"


def install_extra(extra: str) -> str:
    """How to install the optional extra `extra` (`ros2`, `gym`...) where quadsim runs: into the
    clone's environment from its source tree, or from the package index."""
    tree = source_tree()
    if tree is None:
        return f"pip install 'quadsim[{extra}]'"
    python = python_command()
    pip = Path(sys.executable).with_name("pip.exe" if sys.platform == "win32" else "pip")
    if os.sep in python and pip.is_file():  # the environment's own pip, spelled as its python is
        installer = str(Path(python).with_name(pip.name))
    else:
        installer = f"{python} -m pip"
    here = _as_typed(tree)
    return f"{installer} install -e '{here}[{extra}]'"


def missing_modules() -> list[str]:
    """The runtime dependencies this interpreter cannot find (found, not imported: a few
    milliseconds where importing them takes a second)."""
    return [name for name in RUNTIME_MODULES if find_spec(name) is None]


def missing_modules_message(missing: list[str]) -> str:
    """One line: this interpreter lacks quadsim's dependencies, and the command that works
    instead (in a clone, its own environment's python, set up first by `make fly`)."""
    named = ", ".join(missing[:3]) + (f" and {len(missing) - 3} more" if len(missing) > 3 else "")
    lacks = f"this Python ({sys.executable or 'python'}) lacks quadsim's dependencies (no {named})"
    tree = source_tree()
    if tree is None:
        return f"{lacks}: install quadsim into it with them (pip install quadsim), or use the environment it is in"
    # the interpreter of the clone's own environment (what `make fly` sets up)
    python = tree / ".venv" / ("Scripts/python.exe" if sys.platform == "win32" else "bin/python")
    typed = _as_typed(python)
    here = tree == Path.cwd()
    make = "make fly" if here else f"make -C {shlex.quote(str(tree))} fly"
    command = " ".join([typed if os.sep in typed else f".{os.sep}{typed}", shlex.join(sys.argv or [CLONE_ENTRY])])
    if sys.executable and Path(sys.executable) == python:  # the clone's own environment, half set up
        return f"{lacks}: '{make}' installs them (or {_as_typed(python.with_name('pip'))} install -e {_as_typed(tree)})"
    if python.exists():
        return f"{lacks}; use the clone's environment: {command}"
    return f"{lacks}; set up the clone's environment with '{make}' (it flies too), then: {command}"
