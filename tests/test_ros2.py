"""quadsim on a real ROS 2 graph: a separate process running rclpy with ROS 2's default middleware
(rmw_fastrtps_cpp, the ROS 2 Jazzy wheels in an environment of its own) flies quadsim with Twist
messages and reads its odometry, a camera and /clock; discovery stays on this machine."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from quadsim.recording.reader import RecordingReader
from tests.ros2_env import PEER, free_domain, local_env, ros2_python

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ros2_peer_python() -> Path:
    python, why = ros2_python()
    if python is None:
        pytest.skip(why)
    return python


def _beside_peer(python: Path, quadsim_args: list[str], folder: Path) -> tuple[subprocess.CompletedProcess[str], dict]:
    """Run quadsim with `quadsim_args` while the ROS 2 peer flies (it starts publishing once /clock
    comes); return quadsim's outcome and the peer's report."""
    env = local_env(free_domain())
    report_path = folder / "peer.json"
    peer = subprocess.Popen(
        [str(python), str(PEER), "fly", str(report_path)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        sim = subprocess.run(
            [sys.executable, str(ROOT / "main.py"), *quadsim_args], env=env, capture_output=True, text=True, timeout=120
        )
        peer_out, _ = peer.communicate(timeout=120)
    finally:
        peer.kill()
    assert sim.returncode == 0, sim.stderr
    assert peer.returncode == 0, peer_out
    return sim, json.loads(report_path.read_text())


@pytest.fixture(scope="module")
def ros2_flight(ros2_peer_python: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, dict]:
    """A run flown by the ROS 2 peer: (its recording, quadsim's output, the peer's report)."""
    folder = tmp_path_factory.mktemp("ros2_flight")
    recording = folder / "flight.mcap"
    args = ["run", "--input", "ros2", "--ros2", "--duration", "9", "--cameras", "front", "--camera-size", "160x120"]
    sim, report = _beside_peer(ros2_peer_python, [*args, "--out", str(recording)], folder)
    return recording, sim.stdout, report


def _odometry_as_recorded(report: dict, recording: Path) -> None:
    with RecordingReader(recording) as reader:
        odoms = {ns: msg for ns, msg in reader.messages("/quad/odom")}
    assert len(report["odoms"]) == 50
    for odom in report["odoms"]:
        recorded = odoms[odom["ns"]].pose.pose.position
        assert (odom["x"], odom["y"], odom["z"]) == (recorded.x, recorded.y, recorded.z)
        assert odom["frame"] == "world"


def test_a_ros2_node_flies_quadsim_and_reads_what_it_publishes(ros2_flight: tuple[Path, str, dict]) -> None:
    recording, stdout, report = ros2_flight

    # it flew where the commands said: 2.5 s climbing at 1 m/s, then 2.5 s forward at 1 m/s, then held
    with RecordingReader(recording) as reader:
        poses = list(reader.poses())
        assert sum(1 for _ in reader.commands()) >= 80  # the node's 20 Hz Twists, as the controller got them
    x, y, z = poses[-1][1]
    assert 2.0 < x < 3.5 and abs(y) < 0.2 and 1.8 < z < 3.2, poses[-1]
    assert "flying the Twists ROS 2 nodes publish on /quad_cmd_twist for 9.0 s" in stdout

    # the node got odometry equal to quadsim's, stamped as recorded
    assert report["odom_count"] > 100
    _odometry_as_recorded(report, recording)
    assert report["odom_last"]["x"] > 2.0

    # a JPEG that decodes to the camera's size
    assert report["image_count"] > 20 and report["image_format"] == "jpeg"
    image = cv2.imdecode(np.frombuffer(bytes.fromhex(report["image_hex"]), np.uint8), cv2.IMREAD_COLOR)
    assert image is not None and image.shape == (120, 160, 3)

    # /clock advanced with simulation time
    first, last = report["clock_ns"]
    assert report["clock_count"] > 100 and last - first > 4_000_000_000


def test_replay_publishes_the_recording_as_it_plays(
    ros2_peer_python: Path, ros2_flight: tuple[Path, str, dict], tmp_path: Path
) -> None:
    recording = ros2_flight[0]
    sim, report = _beside_peer(
        ros2_peer_python, ["replay", "--headless", "--ros2", "--speed", "2", str(recording)], tmp_path
    )
    assert "ROS 2: publishing on domain" in sim.stdout
    _odometry_as_recorded(report, recording)  # the recorded bytes, as they were
    assert report["image_count"] > 20
    first, last = report["clock_ns"]
    assert last - first > 4_000_000_000  # /clock follows the playback (twice as fast as the wall clock)


def test_without_cyclonedds_a_one_line_message_says_how_to_install(tmp_path: Path) -> None:
    blocker = tmp_path / "cyclonedds"
    blocker.mkdir()
    (blocker / "__init__.py").write_text("raise ImportError('blocked for the test')\n")
    env = local_env(free_domain())
    env["PYTHONPATH"] = str(tmp_path)
    sim = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "run", "--script", "hover", "--ros2", "--no-record"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert sim.returncode != 0
    assert sim.stderr.strip().splitlines() == [
        "quadsim: error: --ros2 and --input ros2 need Eclipse Cyclone DDS for Python: pip install 'quadsim[ros2]'"
    ]
