"""The package as a user installs it: build the wheel, install it into a fresh virtual environment
in a temporary folder, and from another working directory fly a scenario with cameras and
recording, read it back with `info` and re-fly it with `check`, using only what was installed.

Slow-ish (about 30 s: the dependencies are installed from pip's index or cache), and part of the
normal test command, so CI checks that the package works outside the repo, assets included."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import pytest

import quadsim
from tests.helpers import ROOT, default_core

CAMERA_TOPICS = [
    "/quad/front_camera/image_raw/compressed",
    "/quad/front_camera/camera_info",
    "/quad/floor_camera/image_raw/compressed",
    "/quad/floor_camera/camera_info",
]
ASSETS = [
    "quadsim/assets/urdf/quadsim_x.urdf",
    "quadsim/assets/urdf/quadsim_x.params.toml",
    "quadsim/assets/worlds/default.toml",
    "quadsim/assets/textures/floor_tile.png",
    "quadsim/assets/scenarios/square.qscript",
]

pytestmark = pytest.mark.slow


@dataclass
class Installed:
    wheel: Path
    venv: Path
    work: Path  # the working directory of every command: outside the repo
    data: Path  # XDG_DATA_HOME of the commands
    env: dict[str, str]

    def run(self, *args: str, timeout_s: float = 120) -> subprocess.CompletedProcess:
        return subprocess.run(
            list(args), cwd=self.work, env=self.env, capture_output=True, text=True, timeout=timeout_s
        )

    def quadsim(self, *args: str) -> subprocess.CompletedProcess:
        return self.run(str(self.venv / "bin" / "quadsim"), *args)

    def python(self, *args: str) -> subprocess.CompletedProcess:
        return self.run(str(self.venv / "bin" / "python"), *args)


def check(done: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert done.returncode == 0, f"{done.args} exited {done.returncode}:\n{done.stdout}\n{done.stderr}"
    return done


def pip_can_target_another_python() -> bool:
    """pip 22.3 and later install into another interpreter with --python (no pip in the new venv)."""
    try:
        major, minor = (int(p) for p in metadata.version("pip").split(".")[:2])
    except (metadata.PackageNotFoundError, ValueError):
        return False
    return (major, minor) >= (22, 3)


def build_wheel(into: Path) -> Path:
    """Build from a copy of the sources, so nothing (build/, *.egg-info) is written into the repo
    and no stale build/ folder can slip old modules into the wheel."""
    src = into / "src"
    shutil.copytree(ROOT / "quadsim", src / "quadsim", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    dist = into / "dist"
    check(
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pip",
                "wheel",
                "--no-deps",
                "--no-build-isolation",
                "-q",
                "-w",
                str(dist),
                str(src),
            ],
            capture_output=True,
            text=True,
            timeout=300,
        )
    )
    (wheel,) = dist.glob("quadsim-*.whl")
    return wheel


def install(wheel: Path, venv: Path) -> None:
    """A fresh venv holding the wheel and its dependencies (from pip's index and cache)."""
    options = ["install", "-q", "--prefer-binary", "--no-compile", str(wheel)]
    if pip_can_target_another_python():
        check(
            subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], capture_output=True, text=True)
        )
        command = [sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), *options]
    else:
        check(subprocess.run([sys.executable, "-m", "venv", str(venv)], capture_output=True, text=True))
        command = [str(venv / "bin" / "python"), "-m", "pip", *options]
    check(subprocess.run(command, capture_output=True, text=True, timeout=900))


def clean_env(venv: Path, data: Path) -> dict[str, str]:
    """The environment of a user who activated the venv: nothing points at the repo, and the
    flight core is chosen as a user's is (compiled: the wheel installs numba)."""
    env = {
        k: v
        for k, v in default_core(os.environ).items()
        if not k.startswith("PYTHON") and k not in ("VIRTUAL_ENV", "QUADSIM_RECORDINGS")
    }
    env.update(
        PATH=os.pathsep.join([str(venv / "bin"), env.get("PATH", "/usr/bin:/bin")]),
        VIRTUAL_ENV=str(venv),
        XDG_DATA_HOME=str(data),
        SDL_VIDEODRIVER="dummy",
        SDL_AUDIODRIVER="dummy",
        PYGAME_HIDE_SUPPORT_PROMPT="1",
    )
    return env


@pytest.fixture(scope="module")
def installed() -> Iterator[Installed]:
    if sys.platform == "win32":
        pytest.skip("the venv layout below is the POSIX one")
    # not tmp_path: pytest keeps old ones, and a venv with pybullet and OpenCV is ~600 MB
    with tempfile.TemporaryDirectory(prefix="quadsim-wheel-") as tmp:
        base = Path(tmp).resolve()
        assert not base.is_relative_to(ROOT), "the temporary folder must be outside the repo"
        wheel = build_wheel(base)
        venv = base / "venv"
        install(wheel, venv)
        work, data = base / "work", base / "data"
        work.mkdir()
        yield Installed(wheel, venv, work, data, clean_env(venv, data))


def test_the_wheel_ships_the_assets_and_only_the_package(installed):
    with zipfile.ZipFile(installed.wheel) as wheel:
        names = wheel.namelist()
    missing = [a for a in ASSETS if a not in names]
    assert not missing, f"the wheel lacks {missing}"
    tops = {n.split("/")[0] for n in names}
    assert tops == {"quadsim", f"quadsim-{quadsim.__version__}.dist-info"}, tops


def test_the_installed_package_is_the_one_used(installed):
    probe = (
        "import json, sys, quadsim\n"
        "from quadsim.assets import asset_path\n"
        "from quadsim.recording.paths import default_recordings_dir\n"
        "from quadsim.sensors.pipeline import _worker_env\n"
        "print(json.dumps({'file': quadsim.__file__, 'version': quadsim.__version__, 'path': sys.path,"
        " 'urdf': str(asset_path('urdf', 'quadsim_x.urdf')), 'urdf_exists': asset_path('urdf', 'quadsim_x.urdf').is_file(),"
        " 'worker_path': _worker_env()['PYTHONPATH'], 'recordings': str(default_recordings_dir())}))"
    )
    found = json.loads(check(installed.python("-c", probe)).stdout)
    venv = installed.venv
    assert Path(found["file"]).resolve().is_relative_to(venv), found["file"]
    assert found["version"] == quadsim.__version__
    assert found["urdf_exists"] and Path(found["urdf"]).resolve().is_relative_to(venv)
    leaks = [p for p in found["path"] if p and Path(p).resolve().is_relative_to(ROOT)]
    assert not leaks, f"the repo is on sys.path: {leaks}"
    # the render workers import quadsim from the same place
    assert all(Path(p).resolve().is_relative_to(venv) for p in found["worker_path"].split(os.pathsep)), found
    # an installed package records to the user's data folder, not the current directory
    assert Path(found["recordings"]) == installed.data / "quadsim" / "recordings"


def test_fly_info_check_from_the_installed_wheel(installed):
    out = installed.work / "flight.mcap"
    run = check(
        installed.quadsim(
            "run", "--script", "square", "--duration", "4", "--camera-size", "160x120", "--out", out.name
        )  # default cameras, both, through the default render workers
    )
    assert "cameras front 160x120@30Hz, floor 160x120@30Hz" in run.stdout
    assert "sim time        4.00 s" in run.stdout
    assert out.is_file() and out.stat().st_size > 100_000

    info = check(installed.quadsim("info", out.name)).stdout
    topics = {line.split()[0]: line.split() for line in info.splitlines() if line.startswith("  /")}
    for topic in CAMERA_TOPICS:
        assert topic in topics, f"{topic} not in:\n{info}"
        assert int(topics[topic][2]) == 120, topics[topic]  # 4 s at 30 Hz
    assert int(topics["/quad_cmd_twist"][2]) == 80  # 4 s at 20 Hz
    assert f"written by  quadsim {quadsim.__version__}" in info
    assert "attachments quadsim_x.urdf, quadsim_x.params.toml, default.toml" in info
    # the run's parameters, read back from the recording's metadata
    parameters = info.split("run parameters", 1)[1]
    for word in ("cascade", "height", "square", "240 Hz", "20 Hz", "front", "floor", "160x120"):
        assert word in parameters, f"{word!r} not among the run parameters:\n{parameters}"

    refly = check(installed.quadsim("check", out.name)).stdout
    assert "1 of 1 recordings re-fly" in refly and refly.startswith("ok "), refly

    assert check(installed.python("-m", "quadsim", "--version")).stdout.strip() == f"quadsim {quadsim.__version__}"


def test_without_out_the_recording_goes_to_the_user_data_folder(installed):
    before = set(installed.work.iterdir())
    check(installed.quadsim("run", "--script", "hover", "--duration", "1", "--cameras", "none"))
    assert set(installed.work.iterdir()) == before  # nothing written into the current directory
    (recording,) = (installed.data / "quadsim" / "recordings").glob("*_hover_cascade.mcap")
    assert recording.stat().st_size > 0


def test_help_speaks_of_the_command_the_user_typed(installed):
    """The installed `quadsim` names itself, never the clone's main.py or its files."""
    for args in (["--help"], ["run", "--help"], ["sweep", "--help"]):
        text = check(installed.quadsim(*args)).stdout
        assert "main.py" not in text and "examples/" not in text and "README" not in text, (args, text)
    assert "Run 'quadsim COMMAND --help'" in check(installed.quadsim("--help")).stdout
    assert check(installed.quadsim("run", "--help")).stdout.startswith("usage: quadsim run")
    as_module = check(installed.python("-m", "quadsim", "--help")).stdout
    assert "Run 'python -m quadsim COMMAND --help'" in as_module


def test_the_examples_ship_in_the_wheel_and_copy_out(installed):
    listed = check(installed.quadsim("examples")).stdout
    assert [line.split()[0] for line in listed.splitlines()] == [
        "fleet.toml",
        "fly_to_tower.py",
        "own_controller.py",
        "stop_before_tower.py",
        "sweep_controllers.toml",
        "sweep_wind.toml",
    ]
    check(installed.quadsim("examples", "--copy", "mine"))
    for name in ("fleet.toml", "fly_to_tower.py", "sweep_wind.toml"):
        assert (installed.work / "mine" / name).read_bytes() == (ROOT / "examples" / name).read_bytes()
    fleet = check(installed.quadsim("run", "--fleet", "mine/fleet.toml", "--duration", "3", "--no-record")).stdout
    assert "flying a fleet of 4 for 3.0 s" in fleet and [line.split()[0] for line in fleet.splitlines()][-4:] == [
        "alpha",
        "bravo",
        "charlie",
        "delta",
    ]
    again = installed.quadsim("examples", "--copy", "mine")
    assert again.returncode == 2 and "exists: nothing was copied" in again.stderr


def test_your_own_controller_flies_from_the_copied_example_and_check_flies_it_again(installed):
    """As the docs say: the example flies the square with its own controller and records it;
    `check` makes the controller again from its class when its module is on the Python path, and
    says in one line why it cannot when it is not."""
    check(installed.quadsim("examples", "--copy", "own", "own_controller.py"))
    own = installed.work / "own"
    flew = subprocess.run(
        [str(installed.venv / "bin" / "python"), "own_controller.py"],
        cwd=own,
        env=installed.env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert flew.returncode == 0 and "flew the square with SmallAngleController" in flew.stdout, flew.stderr
    recording = str(own / "own_controller.mcap")
    on_path = installed.run(
        "env", f"PYTHONPATH={own}", str(installed.venv / "bin" / "quadsim"), "check", recording, timeout_s=300
    )
    assert on_path.returncode == 0 and "flies again identically" in on_path.stdout, on_path.stdout + on_path.stderr
    off_path = installed.quadsim("check", recording)
    assert off_path.returncode == 2 and "own_controller:SmallAngleController does not import here" in off_path.stdout
