"""A ROS 2 Jazzy Python environment from the package index (rclpy, rmw_fastrtps_cpp and the message
packages), made once and kept in ~/.cache/quadsim-tests, for the tests and the benchmark to run a
real ROS 2 node beside quadsim."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

PACKAGES = (
    "ros-jazzy-rclpy",
    "ros-jazzy-rmw-fastrtps-cpp",
    "ros-jazzy-geometry-msgs",
    "ros-jazzy-nav-msgs",
    "ros-jazzy-sensor-msgs",
    "ros-jazzy-rosgraph-msgs",
)
PEER = Path(__file__).with_name("ros2_peer.py")


def venv_dir() -> Path:
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    return cache / "quadsim-tests" / f"ros2-jazzy-{tag}"


def ros2_python() -> tuple[Path | None, str]:
    """The Python of the ROS 2 environment (made if missing), or None and why it could not be made."""
    folder = venv_dir()
    python = folder / "bin" / "python"
    ready = folder / ".ready"
    if ready.exists() and python.exists():
        return python, ""
    folder.parent.mkdir(parents=True, exist_ok=True)
    try:
        subprocess.run([sys.executable, "-m", "venv", "--clear", str(folder)], check=True, capture_output=True)
        pip = subprocess.run(
            [str(python), "-m", "pip", "install", "--quiet", *PACKAGES],
            capture_output=True,
            text=True,
            timeout=900,
        )
    except (subprocess.SubprocessError, OSError) as e:
        return None, f"could not make a Python environment for the ROS 2 wheels: {e}"
    if pip.returncode != 0:
        tail = (pip.stderr.strip().splitlines() or ["(no output)"])[-1]
        return None, f"the ROS 2 Jazzy wheels ({', '.join(PACKAGES)}) could not be installed here: {tail}"
    check = subprocess.run([str(python), "-c", "import rclpy, geometry_msgs.msg"], capture_output=True, text=True)
    if check.returncode != 0:
        tail = (check.stderr.strip().splitlines() or ["(no output)"])[-1]
        return None, f"the ROS 2 Jazzy wheels installed but rclpy does not import here: {tail}"
    ready.touch()
    return python, ""


def local_env(domain: int) -> dict[str, str]:
    """The environment for both sides: discovery on this machine only, a domain of the test's own."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "RMW_", "CYCLONEDDS_"))}
    env.update(
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=str(domain),
        RMW_IMPLEMENTATION="rmw_fastrtps_cpp",
        SDL_VIDEODRIVER="dummy",
        SDL_AUDIODRIVER="dummy",
    )
    return env


def free_domain() -> int:
    """A domain id unlikely to be in use by another test run on this machine."""
    return 100 + os.getpid() % 100
