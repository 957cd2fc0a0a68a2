"""`import quadsim` is light: no pybullet, no pygame, no recording or image libraries, and it
leaves the process's stdout and stderr alone. Each check runs in a fresh interpreter, since this
test process has long since imported everything."""

from __future__ import annotations

import json
import subprocess
import sys
from typing import Any

import pytest

HEAVY = ("pybullet", "pygame", "rosbags", "mcap", "cv2", "numba")

#: modules that must stay pure numeric / data code, with what they may not load
LIGHT_MODULES = [
    "quadsim.core.types",
    "quadsim.vehicle.mixer",
    "quadsim.control.cascade",
    "quadsim.control.seed",
    "quadsim.control.gate",
    "quadsim.sensors.camera",
]

PUBLIC_API = [
    "Simulator",
    "SimConfig",
    "Twist",
    "ZMode",
    "VehicleState",
    "StartPose",
    "Rates",
    "StateLog",
    "ControllerKind",
    "ConfigError",
    "QuadsimError",
    "ScriptError",
    "WindSettings",
    "Turbulence",
]


def run_python(code: str) -> Any:
    """Run code in a fresh interpreter; it prints one JSON line last."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def loaded_after(statement: str) -> list[str]:
    code = f"import json, sys\n{statement}\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    return run_python(code)


def test_import_quadsim_loads_no_heavy_library():
    assert loaded_after("import quadsim; quadsim.__version__") == []


@pytest.mark.parametrize("module", LIGHT_MODULES)
def test_data_and_control_modules_load_neither_pybullet_nor_pygame(module):
    loaded = loaded_after(f"import {module}")
    assert "pybullet" not in loaded and "pygame" not in loaded, f"{module} loads {loaded}"


def test_the_command_line_loads_numba_only_for_what_flies():
    """numba (the fast extra) takes a fifth of a second to import: the command line's help and the
    commands that read recordings do without it."""
    assert loaded_after("import quadsim.apps.cli") == []


def test_the_public_api_is_there_on_first_use():
    names = ", ".join(PUBLIC_API)
    code = (
        "import json, quadsim\n"
        f"from quadsim import {names}\n"
        "print(json.dumps({'all': sorted(quadsim.__all__), 'dir': sorted(dir(quadsim)),"
        f" 'modules': {{n: obj.__module__ for n, obj in zip({PUBLIC_API!r}, [{names}])}}}}))"
    )
    found = run_python(code)
    assert set(PUBLIC_API) <= set(found["all"]) and set(PUBLIC_API) <= set(found["dir"])
    assert all(module.startswith("quadsim.") for module in found["modules"].values()), found["modules"]


def test_an_unknown_name_is_an_attribute_error():
    found = run_python(
        "import json, quadsim\n"
        "try:\n    quadsim.NoSuchThing\nexcept AttributeError as exc:\n    print(json.dumps(str(exc)))"
    )
    assert "NoSuchThing" in found


def test_import_quadsim_leaves_stdout_and_stderr_alone():
    """Nothing redirects fds 1 and 2 (not even for a moment: os.dup2 is watched), the same open
    files are there after the import, and the import writes nothing to them."""
    code = (
        "import json, os\n"
        "def ids():\n"
        "    return [(s.st_dev, s.st_ino, s.st_mode) for s in (os.fstat(1), os.fstat(2))]\n"
        "redirected = []\n"
        "real_dup2 = os.dup2\n"
        "def dup2(fd, fd2, *args, **kwargs):\n"
        "    redirected.append(fd2)\n"
        "    return real_dup2(fd, fd2, *args, **kwargs)\n"
        "os.dup2 = dup2\n"
        "before = ids()\n"
        "import quadsim\n"
        "quadsim.__version__\n"
        "after = ids()\n"
        "print(json.dumps({'before': before, 'after': after, 'redirected': redirected}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    lines = done.stdout.strip().splitlines()
    assert len(lines) == 1, f"import quadsim printed: {lines[:-1]}"
    found = json.loads(lines[0])
    assert found["redirected"] == []
    assert found["before"] == found["after"]
