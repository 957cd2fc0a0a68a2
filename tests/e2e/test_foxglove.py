"""The Foxglove bridge, from outside: quadsim runs as its own process with --foxglove, and an
independent WebSocket client (tests/helpers/foxglove_client.py, another process, written from the
protocol's spec) watches it and flies it; a real Foxglove Studio 1.48 (tests/helpers/foxglove_studio.py)
publishes a goal from its 3D panel as a person would."""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.helpers import HELPERS, ROOT, foxglove_studio
from tests.helpers import proc as procfs
from tests.helpers.fleets import fleet_toml, vehicle
from tests.helpers.foxglove_hostile_client import CONNECTIONS
from tests.helpers.mcap import topic_messages
from tests.helpers.recording import commanded_motion

CLIENT = HELPERS / "foxglove_client.py"
ENV = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy", "PYTHONUNBUFFERED": "1"}
OLD_NAME = ("--subprotocol", "foxglove.websocket.v1")
NEW_NAME = ("--subprotocol", "foxglove.sdk.v1")
IMAGES = ("/quad/front_camera/image_raw/compressed", "/quad/floor_camera/image_raw/compressed")
#: the front camera's depth colour-mapped for people (--camera-depth-colormap)
COLORMAP = "/quad/front_camera/depth/colormap/compressed"
DEPTH_AND_LABELS = {
    "/quad/front_camera/depth/image_raw": "16UC1",
    "/quad/front_camera/segmentation/image_raw": "mono8",
}


def _quadsim(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, str(ROOT / "main.py"), *args],
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _serving_line(proc: subprocess.Popen) -> str:
    """The line in which quadsim says where it serves (it chose the port: --foxglove 127.0.0.1:0)."""
    assert proc.stdout is not None
    for _ in range(20):
        line = proc.stdout.readline()
        if re.search(r"serving ws://\S+", line):
            return line
    raise AssertionError("quadsim never said where it serves")


def _served_url(proc: subprocess.Popen) -> str:
    """The ws:// address quadsim says it serves."""
    found = re.search(r"serving (ws://\S+)", _serving_line(proc))
    assert found is not None
    return found.group(1)


def _client(url: str, *args: str) -> dict:
    out = subprocess.run(
        [sys.executable, str(CLIENT), url, *args], env=ENV, capture_output=True, text=True, timeout=60, check=True
    )
    return json.loads(out.stdout)


def _joined_late(url: str, seconds: float = 1.0) -> None:
    """Once this returns, the run has flown `seconds` of simulated time since it began serving: a
    first client watches them (its durations are simulated time), then leaves."""
    _client(url, "--listen-s", str(seconds))


def _ended_by_ctrl_c(proc: subprocess.Popen) -> tuple[str, str]:
    """Ctrl-C to a run whose clients are done (its duration is long: however slow a busy machine
    starts the clients, the run is still on while they fly), as a user ends it: its output."""
    proc.send_signal(signal.SIGINT)
    return proc.communicate(timeout=60)


def _x_at(odom: list, ns: int) -> float:
    return [x for t, x, _, _ in odom if t <= ns][-1]


def test_a_client_watches_every_topic_and_flies_it_with_twists(tmp_path: Path) -> None:
    proc = _quadsim(
        *("run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--duration", "60", "--out", str(tmp_path)),
        *("--camera-depth", "front", "--camera-segmentation", "front", "--camera-depth-colormap", "front"),
        *("--range", "--lidar", "2d"),
    )
    try:
        url = _served_url(proc)
        _joined_late(url)  # latched topics must still reach the clients that join now
        # forward and up at 1 m/s and 0.5 m/s for 2 s, in JSON as the Foxglove app sends it, then
        # silence; under the protocol's original name, as Foxglove Studio 1.x and Lichtblick <= 1.21 offer
        flown = _client(
            url, *("--listen-s", "4", "--publish", "json", "--twist", "1,0,0.5,0", "--publish-s", "2"), *OLD_NAME
        )
        # a second client, later still, under foxglove-sdk's name as current apps offer: CDR Twists, left (y) for 1 s
        left = _client(
            url, *("--listen-s", "1.5", "--publish", "cdr", "--twist", "0,1,0,0", "--publish-s", "1"), *NEW_NAME
        )
        out, err = _ended_by_ctrl_c(proc)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert flown["subprotocol"] == "foxglove.websocket.v1" and left["subprotocol"] == "foxglove.sdk.v1"
    assert "clientPublish" in flown["serverInfo"]["capabilities"]
    assert set(flown["serverInfo"]["supportedEncodings"]) >= {"json", "cdr"}
    assert flown["serverInfo"]["metadata"]["ROS_DISTRO"] == "jazzy"  # a ROS 2 source: the 3D panel can publish
    topics = flown["topics"]
    expected = {"/quad_cmd_twist", "/quad/pose", "/quad/odom", "/quad/imu", "/quad/rotor_thrusts", "/tf", "/tf_static"}
    expected |= {"/robot_description", "/robot_markers", "/world/markers"}
    expected |= {*IMAGES, "/quad/front_camera/camera_info", "/quad/floor_camera/camera_info"}
    expected |= {*DEPTH_AND_LABELS, "/quad/front_camera/depth/camera_info", "/world/segmentation_labels", COLORMAP}
    expected |= {"/quad/range", "/quad/scan"}
    assert expected <= set(topics), sorted(set(expected) - set(topics))
    assert flown["undecodable"] == 0
    for name, entry in topics.items():
        assert entry["encoding"] == "cdr" and entry["schemaEncoding"] == "ros2msg", name
    for name in (*IMAGES, COLORMAP):  # real JPEGs of the scene, not black frames
        image = topics[name]["last"]
        assert image["format"] == "jpeg" and image["shape"] == [240, 320, 3] and image["mean"] > 20.0, name
    for name, encoding in DEPTH_AND_LABELS.items():  # rendered with the front image, on its frame
        image = topics[name]["last"]
        assert image == {"encoding": encoding, "shape": [240, 320], "frame": "front_camera_optical"}, name
    for report in (flown, left):  # latched, though both joined after it was published
        children = report["topics"]["/tf_static"]["first"]["children"]
        assert {"front_camera_optical", "floor_camera_optical", "rotor_1", "front_camera_link"} <= set(children)
        assert {"range_finder_link", "lidar_link"} <= set(children)
    ranged, scanned = topics["/quad/range"], topics["/quad/scan"]  # at their rates, decoded by their schemas
    assert ranged["count"] >= 60 and ranged["last"]["frame"] == "range_finder_link"
    assert ranged["last"]["range"] > 0.5 and ranged["last"]["variance"] > 0  # up in the air: the height
    assert scanned["count"] >= 10 and scanned["last"] == {
        "frame": "lidar_link",
        "beams": 360,
        "returns": scanned["last"]["returns"],
    }
    assert scanned["last"]["returns"] > 0  # the landmarks around
    odom = flown["odom"]
    stop_ns = odom[0][0] + 2_000_000_000
    assert _x_at(odom, stop_ns) > 1.0  # x forward -> position x grew
    assert odom[-1][3] > 0.5  # and it climbed
    # silence: the dead-man timeout holds it (what it still travels is the braking after 0.5 s)
    assert abs(odom[-1][1] - _x_at(odom, stop_ns + 1_000_000_000)) < 0.1
    # the CDR client's y command moved it left (about 0.6 m on a quiet machine; beside two CPU hogs a
    # starved client's Twists can come further apart than the input's 0.2 s hold: 0.24 m was seen)
    assert left["odom"][-1][2] - left["odom"][0][2] > 0.1
    # the summary says what arrived over the wire, and that nothing was refused
    assert re.search(r"live input      \d+ arrived on /quad_cmd_twist from foxglove: 0 rejected", out), out
    assert "0 rejected (not finite), 0 clamped to the limits" in out, out
    recordings = list(tmp_path.glob("*.mcap"))
    assert len(recordings) == 1  # recorded as every run is


def _at_goal(report: dict, x: float, y: float, z: float, yaw_deg: float) -> None:
    """The client's last odometry is within 0.1 m and 5 deg of the goal."""
    _, px, py, pz = report["odom"][-1]
    turn = (math.degrees(report["yaw"]) - yaw_deg + 180.0) % 360.0 - 180.0
    assert math.dist((px, py, pz), (x, y, z)) < 0.1 and abs(turn) < 5.0, (px, py, pz, math.degrees(report["yaw"]))


def test_the_3d_panels_publish_pose_flies_the_vehicle_there_in_either_encoding(tmp_path: Path) -> None:
    proc = _quadsim(
        "run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--duration", "60", "--cameras", "none",
        "--out", str(tmp_path / "goals.mcap"),
    )  # fmt: skip
    try:
        serving = _serving_line(proc)
        url = serving.split("serving ")[1].split()[0]
        # on the ground plane of the panel following the vehicle (its display frame base_link), in
        # JSON under Studio 1.x's protocol name: lift off to 1 m and fly there, facing +y
        first = _client(
            url, *("--listen-s", "8", "--goal", "2,-1.5,0,90", "--goal-frame", "base_link", "--start-s", "0.2"),
            *OLD_NAME,
        )  # fmt: skip
        # a goal in a camera's frame is refused, to that client
        refused = _client(
            url, *("--listen-s", "0.5", "--goal", "1,1,1,0", "--goal-frame", "front_camera_optical"), *NEW_NAME
        )
        # in CDR, on /goal_pose, with an altitude
        second = _client(
            url, *("--listen-s", "8", "--goal=-1,0.5,1.6,-45", "--goal-encoding", "cdr"),
            *("--goal-topic", "/goal_pose"), *NEW_NAME,
        )  # fmt: skip
        out, err = _ended_by_ctrl_c(proc)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    _at_goal(first, 2.0, -1.5, 1.0, 90.0)
    said = refused.get("status", [])
    assert any("world frame" in s and "'front_camera_optical'" in s for s in said), said
    _at_goal(second, -1.0, 0.5, 1.6, -45.0)
    assert "and goals on /move_base_simple/goal (3D panel, publish pose)" in serving, serving
    logs = [text for _, msg in topic_messages(tmp_path / "goals.mcap", "/rosout") for text in [msg.msg]]
    reached = [text for text in logs if text.startswith("goal_reached")]
    assert reached == [
        "goal_reached: at x=2.00 y=-1.50 z=1.00 yaw=90.0deg",
        "goal_reached: at x=-1.00 y=0.50 z=1.60 yaw=-45.0deg",
    ]


@pytest.mark.slow
def test_studio_148s_publish_pose_flies_the_vehicle_to_the_place_clicked(tmp_path: Path) -> None:
    """docs/foxglove.md's "Fly there" in a real Foxglove Studio 1.48, connected live with quadsim's
    layout imported: the 3D panel's publish button -> "Publish pose", a click on the ground and one
    toward a heading. Studio sends it in JSON in the panel's display frame, base_link; the vehicle
    takes off and flies there (the place is the click's: the goal event names it in the world)."""
    try:
        foxglove_studio.studio()
    except foxglove_studio.NoStudio as exc:
        pytest.skip(str(exc))
    layout, shot, recording = tmp_path / "quadsim.layout.json", tmp_path / "flown.png", tmp_path / "studio.mcap"
    written = _quadsim("layout", "--cameras", "none", "-o", str(layout))
    assert written.communicate(timeout=60) and written.returncode == 0
    proc = _quadsim(
        "run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--cameras", "none", "--duration", "600",
        "--out", str(recording),
    )  # fmt: skip
    try:
        url = _served_url(proc)
        with foxglove_studio.served({"quadsim.layout.json": layout}) as studio:
            steps = [f"connect={url}", "import-layout=/data/quadsim.layout.json", "sidebar=layouts"]
            # up and left of the vehicle, then toward the lower left: 2.6 m away, facing about -130 deg
            steps += ["publish-pose=0.2,0.35,0.1,0.5", "see=goal_reached", f"shot={shot}"]
            foxglove_studio.follow_steps(studio, tmp_path / "steps.log", *steps)
        out, err = _ended_by_ctrl_c(proc)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "1 goal, 0 refused" in out, out
    logs = [msg.msg for _, msg in topic_messages(recording, "/rosout")]
    (goal,) = [text.split("goal: flying to ")[1] for text in logs if text.startswith("goal:")]
    assert f"goal_reached: at {goal}" in logs, logs
    found = re.fullmatch(r"x=(\S+) y=(\S+) z=(\S+) yaw=(\S+)deg", goal)
    assert found is not None, goal
    x, y, z, yaw_deg = map(float, found.groups())
    odom = [msg.pose.pose for _, msg in topic_messages(recording, "/quad/odom")]
    start, end = odom[0].position, odom[-1].position
    assert math.dist((start.x, start.y), (x, y)) > 1.0 and z == 1.0  # clicked away from it, at the take-off altitude
    q = odom[-1].orientation
    turn = (math.degrees(_yaw((q.x, q.y, q.z, q.w))) - yaw_deg + 180.0) % 360.0 - 180.0
    assert math.dist((end.x, end.y, end.z), (x, y, z)) < 0.1 and abs(turn) < 5.0, (end, turn)


def test_replay_streams_the_recorded_messages_as_they_are_played(tmp_path: Path) -> None:
    recording = tmp_path / "hover.mcap"
    fly = ["run", "--script", "hover", "--duration", "6", "--cameras", "none", "--out", str(recording)]
    subprocess.run(
        [sys.executable, str(ROOT / "main.py"), *fly],
        cwd=ROOT,
        env=ENV,
        check=True,
        capture_output=True,
    )
    proc = _quadsim("replay", str(recording), "--headless", "--foxglove", "127.0.0.1:0")
    try:
        url = _served_url(proc)
        watched = _client(url, "--listen-s", "2")
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert watched["topics"]["/tf_static"]["count"] >= 1  # latched: sent when the client subscribed
    odom = watched["odom"]
    assert len(odom) > 30  # 60 Hz states, as they are played
    assert [t for t, *_ in odom] == sorted(t for t, *_ in odom)
    assert abs(odom[-1][3] - 2.0) < 0.1  # the recorded hover, at 2 m
    assert re.search(r"played \d+ messages", out)


NODE_CLIENT = HELPERS / "foxglove_node_client.js"
#: the npm packages tests/helpers/foxglove_node_client.js needs, ws-protocol at the version JavaScript apps ship
NODE_PACKAGES = (
    "@foxglove/ws-protocol@0.8",
    "ws@8",
    "@foxglove/rosmsg@5",
    "@foxglove/rosmsg2-serialization@3",
    "jpeg-js@0.4",
)
NODE_CACHE = Path.home() / ".cache" / "quadsim-tests" / "foxglove-node"


def _node_modules() -> Path:
    """The npm client's packages (see npm_packages)."""
    return npm_packages(NODE_CACHE, NODE_PACKAGES, "the @foxglove/ws-protocol client")


def npm_packages(cache: Path, packages: tuple[str, ...], what: str) -> Path:
    """`packages` installed once into `cache` (its node_modules folder); skip (saying why) where
    node or npm is missing or the registry cannot be reached."""
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        pytest.skip(f"node and npm are needed for {what}")
    modules = cache / "node_modules"
    stamp = cache / ".installed"
    if stamp.exists() and stamp.read_text() == " ".join(packages):
        return modules
    cache.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        [npm, "install", "--no-audit", "--no-fund", "--prefix", str(cache), *packages],
        capture_output=True,
        text=True,
        timeout=600,
    )
    if done.returncode != 0:
        pytest.skip(f"npm could not install {' '.join(packages)}: {done.stderr.strip().splitlines()[-1:]}")
    stamp.write_text(" ".join(packages))
    return modules


def test_the_npm_ws_protocol_client_watches_and_flies_with_its_default_subprotocol() -> None:
    """The client JavaScript apps build on (as Foxglove Studio 1.x and Lichtblick did), with the
    name it offers by default: it decodes odometry and a camera frame and its Twists fly."""
    modules = _node_modules()
    proc = _quadsim("run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--duration", "9", "--no-record")
    try:
        url = _served_url(proc)
        done = subprocess.run(
            # backwards and up for 3 s (it starts landed: 1.5 m up asked, half of it is plenty on a busy machine)
            ["node", str(NODE_CLIENT), url, "4.5", "3", "-1,0,0.5,0"],
            env={**ENV, "NODE_PATH": str(modules)},
            capture_output=True,
            text=True,
            timeout=60,
        )
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert proc.returncode == 0, err
    assert report["subprotocol"] == "foxglove.websocket.v1" and "error" not in report, report
    assert "clientPublish" in report["serverInfo"]["capabilities"]
    assert report["undecodable"] == 0 and report["published"] > 20 and report["status"] == []
    image = report["image"]
    assert image["format"] == "jpeg" and (image["width"], image["height"]) == (320, 240) and image["mean"] > 20.0
    odom = report["odom"]
    assert len(odom) > 50
    # 3 s of backwards-and-up in simulated time (the client's clock is the odometry's)
    dx, dy, dz = (odom[-1][i] - odom[0][i] for i in (1, 2, 3))
    assert dx < -1.5 and dz > 0.8, (dx, dz)  # backwards: x fell, and it climbed
    assert abs(dy) < 0.2 and abs(dy) < abs(dx) / 3, (dx, dy)  # not sideways


HOSTILE_CLIENT = HELPERS / "foxglove_hostile_client.py"


def _rss_mb(pid: int) -> float:
    rss = procfs.status(pid).get("VmRSS")  # "1234 kB"
    return int(rss.split()[0]) / 1024 if rss else 0.0


def _hostile_run(
    workdir: Path, hostile_name: str = "foxglove.websocket.v1", legit_name: str = "foxglove.sdk.v1"
) -> dict:
    """quadsim flown by a legitimate client while a hostile one sends its cases (both separate
    processes): the server's RSS (baseline and peak), its stderr, both clients' reports."""
    reports = {name: (workdir / f"{name}.json").open("w+") for name in ("legit", "hostile", "stderr")}
    run = ("run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--no-record", "--duration", "40")
    proc = subprocess.Popen(  # stderr to a file: a server that floods it must not block on a pipe
        [sys.executable, str(ROOT / "main.py"), *run, "--cameras", "none"],  # the case is the server, not frames
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=reports["stderr"],
        text=True,
    )
    peak = 0.0
    try:
        url = _served_url(proc)
        _joined_late(url)  # running: the baseline is a serving flight's
        baseline = _rss_mb(proc.pid)
        flags = ("--listen-s", "14", "--publish", "json", "--twist", "0.3,0,0.2,0", "--publish-s", "14")
        clients = [
            subprocess.Popen(
                [sys.executable, str(CLIENT), url, "--subprotocol", legit_name, *flags],
                env=ENV,
                stdout=reports["legit"],
            ),
            subprocess.Popen(
                [sys.executable, str(HOSTILE_CLIENT), url, "--subprotocol", hostile_name],
                env=ENV,
                stdout=reports["hostile"],
            ),
        ]
        while any(c.poll() is None for c in clients):
            peak = max(peak, _rss_mb(proc.pid))
            time.sleep(0.1)
        after = _rss_mb(proc.pid)
        proc.send_signal(signal.SIGINT)  # Ctrl-C: the run ends as a user ends it
        out, _ = proc.communicate(timeout=60)
    finally:
        proc.kill()
        for c in locals().get("clients", []):
            c.kill()
    result: dict = {"rss_mb": {"baseline": round(baseline), "peak": round(peak), "after": round(after)}}
    for f in reports.values():
        f.close()
    for name in ("legit", "hostile"):
        result[name] = json.loads((workdir / f"{name}.json").read_text())
    err = (workdir / "stderr.json").read_bytes()
    return {**result, "stderr_bytes": len(err), "stderr": err[-2000:].decode(errors="replace"), "stdout": out}


@pytest.mark.slow
def test_hostile_clients_neither_grow_nor_flood_the_server(tmp_path: Path) -> None:
    """The cases measured in issue 17 (5 MB topic names, a 400-digit number, a 100,000-deep
    array, floods), sent from another process while a legitimate client flies: the server's
    memory and log stay bounded, each problem goes to the hostile client alone, the flight goes on."""
    run = _hostile_run(tmp_path)
    rss, hostile, legit = run["rss_mb"], run["hostile"], run["legit"]
    assert rss["peak"] - rss["baseline"] < 40, rss  # it was +330 MB before
    assert run["stderr_bytes"] < 1500, run["stderr"]  # a few rate-limited lines, no tracebacks
    assert "Traceback" not in run["stderr"] and "Callback failed" not in run["stderr"]
    # the legitimate client heard none of it, was never dropped, and flew all along
    assert legit.get("status") is None and not legit.get("closed"), legit.get("status")
    odom = legit["odom"]
    assert odom[-1][1] - odom[0][1] > 2.0 and odom[-1][3] > 1.0  # 0.3 m/s forward, 0.2 m/s up for 14 s
    # a frame over the limit closes that connection before it is read (1009: message too big)
    assert hostile["closed"]["huge_topic_names"] == 1009
    said = hostile["status"]
    assert "not a Twist (a number too large for a float64)" in said["400_digit_number"][0]
    assert "not a Twist (nested too deeply)" in said["100000_deep_array"][0]
    assert "not a Twist" in said["flood_bad_twists"][0]
    assert "quadsim takes only geometry_msgs/msg/Twist" in said["many_channels"][0]
    assert all(len(m) <= 300 for m in said["many_channels"])  # client-chosen names come back cut short
    assert "not JSON" in said["flood_bad_json_ops"][0]
    assert "has not advertised" in said["flood_unadvertised_data"][0]
    # the SDK's own answer to a bad request, once a second at most too (it answered each, and logged each)
    assert "Unknown channel ID" in said["flood_requests_the_sdk_answers"][0]
    assert "panel_topics" not in said  # the 3D panel's topics are taken quietly
    for case, messages in said.items():  # rate-limited: one a second at most
        assert len(messages) <= hostile["seconds"][case] + 1, (case, len(messages))
    assert hostile["status_bytes"] < 20_000
    # at most 16 clients at once: the rest are refused with 503. (15 of the hostile client's while
    # the legitimate one flies; on a loaded machine it may have ended its 14 s first, so 16: the
    # exact count is tests/e2e/test_foxglove_front.py's, where no clock decides it)
    connections = hostile["connections"]
    assert connections["held"] in (15, 16) and connections["refused"] == [503] * (CONNECTIONS - connections["held"])
    assert re.search(r"commands\s+\d+ received", run["stdout"])


def test_serving_beyond_loopback_says_who_can_fly_and_the_subprotocol_is_the_clients_choice() -> None:
    proc = _quadsim(
        *("run", "--input", "foxglove", "--foxglove", "0.0.0.0:0", "--duration", "3", "--cameras", "none"),
        "--no-record",
    )
    try:
        url = _served_url(proc).replace("0.0.0.0", "127.0.0.1")
        from websockets.exceptions import InvalidStatus
        from websockets.sync.client import connect

        with pytest.raises(InvalidStatus) as refused:  # as foxglove-sdk answers a name it does not speak
            connect(url, subprotocols=["foxglove.websocket.v2"]).close()
        assert refused.value.response.status_code == 400
        for offered in (["foxglove.websocket.v1", "foxglove.sdk.v1"], ["foxglove.sdk.v1", "foxglove.websocket.v1"]):
            with connect(url, subprotocols=offered) as ws:  # the client's first choice
                assert ws.subprotocol == offered[0]
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1, err
    assert warnings[0].startswith("quadsim: warning: Foxglove: ")
    assert "0.0.0.0 is not loopback" in warnings[0] and "watch this run and fly the vehicle" in warnings[0]


@pytest.mark.slow
@pytest.mark.parametrize("ending", ["sigint", "duration"])
def test_a_client_that_stops_reading_does_not_hold_up_or_spoil_the_end_of_the_run(ending: str) -> None:
    """A client that connects and then never reads (its socket full of camera frames) cannot
    answer the closing handshake: the run still ends within seconds, with no traceback and no
    "Task was destroyed" from handlers left pending at exit (seen in CI, 4 kB of both)."""
    duration = "8" if ending == "duration" else "60"
    proc = _quadsim("run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--no-record", "--duration", duration)
    stuck = socket.socket()
    try:
        host, port = _served_url(proc).removeprefix("ws://").rstrip("/").rsplit(":", 1)
        stuck.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # fills at once
        stuck.connect((host, int(port)))
        stuck.sendall(
            (
                f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
            ).encode()
        )
        assert stuck.recv(64).startswith(b"HTTP/1.1 101"), "the handshake was refused"
        # never read again: the advertisements, latched messages and frames pile up while another
        # client watches 3 s of the flight
        _joined_late(f"ws://{host}:{port}", 3.0)
        if ending == "sigint":
            proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)  # a stuck client must not hold the end up: this fails
    finally:
        proc.kill()
        stuck.close()
    assert proc.returncode == (130 if ending == "sigint" else 0), err
    assert "Traceback" not in err and "Task was destroyed" not in err and "ERROR" not in err, err
    assert len(err) < 300, err


FLEET = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:square"),
    vehicle("bravo", (0.0, -4.0, 0.0, 0.0), input="foxglove"),
)


def test_a_client_flies_one_vehicle_of_a_fleet_on_its_topic_while_a_script_flies_another(tmp_path: Path) -> None:
    """The Teleop panel's way (JSON Twists) on /bravo/quad_cmd_twist: climb, left, then forward
    while turning; alpha flies its square meanwhile. A client publishing on /quad_cmd_twist is told
    which topics take Twists. Both vehicles' topics reach the client; outcomes from the recording."""
    (tmp_path / "pair.toml").write_text(FLEET)
    recording = tmp_path / "pair.mcap"
    proc = _quadsim(
        "run",
        "--fleet",
        str(tmp_path / "pair.toml"),
        "--foxglove",
        "127.0.0.1:0",
        "--duration",
        "60",
        "--out",
        str(recording),
    )
    try:
        url = _served_url(proc)
        _joined_late(url)  # the latched topics must still come to the client that joins now
        program = json.dumps(
            [[2.0, {"linear_z": 1.0}], [1.5, {"linear_y": 1.0}], [2.0, {"linear_x": 1.0, "angular_z": 0.5}]]
        )
        flown = _client(
            url,
            "--listen-s",
            "6.5",
            "--publish",
            "json",
            "--topic",
            "/bravo/quad_cmd_twist",
            "--program",
            program,
            *OLD_NAME,
        )
        wrong = _client(url, "--listen-s", "1", "--publish", "cdr", "--twist", "1,0,0,0", "--publish-s", "0.5")
        out, err = _ended_by_ctrl_c(proc)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    topics = flown["topics"]
    assert {"/alpha/quad/odom", "/bravo/quad/odom", "/alpha/robot_description", "/bravo/robot_description"} <= set(
        topics
    )
    assert topics["/bravo/quad/odom"]["last"]["child"] == "bravo/base_link"
    for name in ("alpha", "bravo"):  # each vehicle's model, drawn in its own frames (latched: got on joining)
        model = topics[f"/{name}/robot_markers"]["last"]
        assert model["markers"] > 5 and all(f.startswith(f"{name}/") for f in model["frames"]), model
    children = topics["/tf_static"]["first"]["children"]
    assert any(c.startswith("alpha/rotor") for c in children) and any(c.startswith("bravo/rotor") for c in children)
    assert any("takes only geometry_msgs/msg/Twist on /bravo/quad_cmd_twist" in s for s in wrong.get("status", []))
    assert re.search(r"live input      \d+ arrived on /bravo/quad_cmd_twist from foxglove: 0 rejected", out), out
    from quadsim.recording.reader import RecordingReader

    with RecordingReader(recording) as reader:
        received = list(reader.commands("bravo"))
        commands = {(t.linear_x, t.linear_y, t.linear_z, t.angular_z) for _, t in received}
        bravo = [(p, q) for _, p, q in reader.poses("bravo")]
        alpha = [p for _, p, _ in reader.poses("alpha")]
    assert {(0.0, 0.0, 1.0, 0.0), (0.0, 1.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.5)} <= commands  # every field it set
    (x, y, z), (qx, qy, qz, qw) = bravo[-1]
    assert z > 1.0 and x > 0.8 and y > -2.9, (x, y, z)  # climbed, went left, then forward while turning left
    turn = commanded_motion(received, FOXGLOVE_HOLD_NS)[3]  # bravo holds a Foxglove input's 0.2 s after the last
    turned = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    assert turned > 0.3 and abs(turned - turn) < 0.25, (turned, turn)  # about 1 rad, as received
    assert max(p[0] for p in alpha) > 2.5  # alpha's square went on all the while
    # bravo's own dead-man timeout (its input's, not the fleet's 0.5 s) is recorded, so check re-flies both
    checked = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(recording)], env=ENV, capture_output=True, text=True
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr


#: how long a Foxglove input holds its last Twist (drivers/subscribed.py)
FOXGLOVE_HOLD_NS = 200_000_000


def _yaw(q: tuple[float, float, float, float]) -> float:
    x, y, z, w = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


@pytest.mark.parametrize(("hold_s", "option"), [(0.2, ()), (0.4, ("--live-timeout", "0.4"))], ids=["default", "0.4"])
def test_a_released_teleop_button_stops_the_turn_within_the_inputs_hold(
    hold_s: float, option: tuple[str, ...], tmp_path: Path
) -> None:
    """Foxglove's Teleop panel sends nothing when a button is released. A client climbs, then turns
    at 0.5 rad/s for 4 s and goes quiet, connected: the turn stops (yaw rate under a tenth of the
    command) within the hold and 0.25 s (the yaw loop's own settling) of its last Twist, and the
    yaw flown is the yaw pressed (the span of Twists received, plus one 20 Hz period) plus what the
    hold adds; the hold is said at start-up and recorded, so `check` re-flies it. Issue 32
    measured 129 degrees for a 115 degree press with the 0.5 s the input had."""
    recording = tmp_path / "release.mcap"
    proc = _quadsim(
        "run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--duration", "60", "--cameras", "none",
        "--out", str(recording), *option,
    )  # fmt: skip
    try:
        serving = _serving_line(proc)
        url = re.search(r"serving (ws://\S+)", serving).group(1)  # type: ignore[union-attr]
        program = json.dumps([[2.0, {"linear_z": 1.0}], [4.0, {"angular_z": 0.5}]])
        _client(url, "--listen-s", "8", "--publish", "json", "--program", program)
        out, err = _ended_by_ctrl_c(proc)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert serving.rstrip().endswith(
        f"it takes Twists on /quad_cmd_twist (Teleop panel, holding {hold_s:g} s after the last) and goals on "
        "/move_base_simple/goal (3D panel, publish pose)"
    )
    from quadsim.recording.reader import RecordingReader

    with RecordingReader(recording) as reader:
        turning = [ns for ns, twist in reader.commands() if twist.angular_z == 0.5]
        poses = [(ns, _yaw(q)) for ns, _, q in reader.poses()]
        assert reader.description is not None and reader.description.config.command_timeout_s == hold_s
    first, last = turning[0], turning[-1]
    pressed = 0.5 * ((last - first) / 1e9 + 0.05)  # about 4 s of a 20 Hz button
    after = [p for p in poses if p[0] >= first]
    flown = sum(math.remainder(b - a, math.tau) for (_, a), (_, b) in itertools.pairwise(after))
    held = 0.5 * (hold_s - 0.05)  # the last Twist acts for the hold, not one period
    assert abs(flown - pressed - held) < 0.05, (math.degrees(flown), math.degrees(pressed))
    rates = [(b, (yb - ya) / ((b - a) / 1e9)) for (a, ya), (b, yb) in itertools.pairwise(poses)]
    stopped = next(ns for ns, rate in rates if ns > last and abs(rate) < 0.05)
    assert (stopped - last) / 1e9 <= hold_s + 0.25, (stopped - last) / 1e9  # the yaw loop's own 0.22 s, after the hold
    checked = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "check", str(recording)], env=ENV, capture_output=True, text=True
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr
