"""ROS 2 Python environments from the package index, one per distribution (rclpy, rmw_fastrtps_cpp,
the distribution's default middleware, and the message packages), made once and kept in
~/.cache/quadsim-tests, for the tests and the benchmark to run a real ROS 2 node beside quadsim.

Jazzy (Fast DDS 2) is the oldest supported distribution, Kilted (Fast DDS 3) the newest. Neither
distribution's wheels carry tf2_msgs, so the node sees /tf and /tf_static through the graph
(publisher, type, QoS), not their samples."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

DISTRIBUTIONS = ("jazzy", "kilted")
_PACKAGES = (
    "rclpy",
    "rmw-fastrtps-cpp",
    "geometry-msgs",
    "nav-msgs",
    "sensor-msgs",
    "std-msgs",
    "rosgraph-msgs",
    "visualization-msgs",
    "rcl-interfaces",
)
PEER = Path(__file__).with_name("ros2_peer.py")


def packages(distribution: str = "jazzy") -> tuple[str, ...]:
    """The wheels of `distribution`'s environment."""
    return tuple(f"ros-{distribution}-{name}" for name in _PACKAGES)


def venv_dir(distribution: str = "jazzy") -> Path:
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    return cache / "quadsim-tests" / f"ros2-{distribution}-{tag}"


def ros2_python(distribution: str = "jazzy") -> tuple[Path | None, str]:
    """The Python of `distribution`'s ROS 2 environment (made if missing), or None and why it could
    not be made."""
    folder = venv_dir(distribution)
    python = folder / "bin" / "python"
    ready = folder / ".ready"  # holds the wheels installed: an environment made for fewer is topped up
    wheels = packages(distribution)
    stamp = "\n".join(wheels)
    if python.exists() and ready.exists() and ready.read_text() == stamp:
        return python, ""
    folder.parent.mkdir(parents=True, exist_ok=True)
    try:
        if not python.exists():
            subprocess.run([sys.executable, "-m", "venv", "--clear", str(folder)], check=True, capture_output=True)
        pip = subprocess.run(
            [str(python), "-m", "pip", "install", "--quiet", *wheels],
            capture_output=True,
            text=True,
            timeout=900,
        )
    except (subprocess.SubprocessError, OSError) as e:
        return None, f"could not make a Python environment for the ROS 2 {distribution} wheels: {e}"
    name = distribution.capitalize()
    if pip.returncode != 0:
        tail = (pip.stderr.strip().splitlines() or ["(no output)"])[-1]
        return None, f"the ROS 2 {name} wheels ({', '.join(wheels)}) could not be installed here: {tail}"
    check = subprocess.run(
        [str(python), "-c", "import rclpy, geometry_msgs.msg, visualization_msgs.msg, rcl_interfaces.msg"],
        capture_output=True,
        text=True,
    )
    if check.returncode != 0:
        tail = (check.stderr.strip().splitlines() or ["(no output)"])[-1]
        return None, f"the ROS 2 {name} wheels installed but rclpy does not import here: {tail}"
    ready.write_text(stamp)
    return python, ""


def local_env(domain: int, discovery_range: str | None = "LOCALHOST") -> dict[str, str]:
    """The environment for both sides: a domain of the test's own, discovery as `discovery_range`
    says (None: ROS 2's default, left unset), ROS 2's default middleware."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "RMW_", "CYCLONEDDS_"))}
    env.update(ROS_DOMAIN_ID=str(domain), RMW_IMPLEMENTATION="rmw_fastrtps_cpp", SDL_VIDEODRIVER="dummy")
    env.update(SDL_AUDIODRIVER="dummy")
    if discovery_range is not None:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = discovery_range
    return env


def free_domain(offset: int = 0) -> int:
    """A domain id of this test's own (`offset` apart for cases of the same run): under
    pytest-xdist each worker draws from its own range, so tests running at once never share a
    domain; else one unlikely to be in use by another run on this machine."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if worker.startswith("gw"):
        count = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
        span = max(1, 200 // count)
        return 20 + int(worker[2:]) % count * span + offset % span
    return 20 + (os.getpid() + offset) % 200
