"""Every input path flies every Twist field: the same program (climb, forward, sideways, turn, each
alone, with pauses between) through a script, the Python API, the keyboard, a virtual SDL pad, a
ROS 2 bag, a ROS 2 node in another process (Jazzy and Kilted) and a Foxglove client in another
process (both subprotocol names), in velocity mode; and an altitude through each in height mode.

Each flight is judged from its recording alone, the same way for every path: the field commanded
holds its value in its own field of /quad_cmd_twist with every other field zero, and the vehicle
does what it says (velocity in the heading frame, the climb rate, the heading turned = rate x time,
the altitude held)."""

from __future__ import annotations

import bisect
import json
import math
import subprocess
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pygame
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from quadsim import SimConfig, Simulator, Twist, ZMode, record
from quadsim.apps.window.teleop import TeleopOptions
from quadsim.drivers.joystick import apply_deadzone
from quadsim.recording.reader import RecordingReader
from tests.e2e.test_foxglove import ENV, _client, _quadsim, _served_url
from tests.e2e.test_ros2 import _beside_peer
from tests.helpers import ROOT
from tests.helpers.cli import run_main
from tests.helpers.ros2_env import free_domain, local_env, ros2_python
from tests.helpers.sdl_virtual import LEFTX, LEFTY, RIGHTX, RIGHTY
from tests.integration.test_gamepad import pads  # noqa: F401 (the fixture)
from tests.integration.test_teleop import FPS, key, make_app, run_with

FIELDS = ("linear_x", "linear_y", "linear_z", "angular_x", "angular_y", "angular_z")
FLOWN = ("linear_x", "linear_y", "linear_z", "angular_z")
SEGMENT_S, PAUSE_S = 2.0, 1.0
#: velocity mode: (field, value) flown alone for SEGMENT_S, then a zero Twist for PAUSE_S
#: (values of both signs, none equal to another, so a field landing in another's place shows)
VELOCITY = (("linear_z", 1.0), ("linear_x", 0.9), ("linear_y", -0.7), ("angular_z", -0.8))
#: height mode: linear.z is the altitude wanted above 2 m; held long enough to get there from the ground
HEIGHT = (("linear_z", 0.5),)
HEIGHT_HOLD_S = 5.0
HEIGHT_BASE_M = 2.0


def program(mode: ZMode) -> list[tuple[float, dict[str, float]]]:
    """The phases every path flies: (seconds, the fields of its Twist)."""
    if mode is ZMode.HEIGHT:
        return [(HEIGHT_HOLD_S, dict(HEIGHT))]
    phases: list[tuple[float, dict[str, float]]] = [(0.5, {})]
    for field, value in VELOCITY:
        phases += [(SEGMENT_S, {field: value}), (PAUSE_S, {})]
    return phases


def program_s(mode: ZMode) -> float:
    return sum(seconds for seconds, _ in program(mode))


# --- the judge: one recording, the values each field was meant to carry -------------------------


@dataclass
class Segment:
    field: str | None  # the one field commanded non-zero (None: all zero)
    start_ns: int
    end_ns: int  # when the next different command came
    values: list[float]


def _yaw(q: tuple[float, float, float, float]) -> float:
    x, y, z, w = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _segments(commands: list[tuple[int, Twist]]) -> list[Segment]:
    segments: list[Segment] = []
    for ns, twist in commands:
        active = [f for f in FIELDS if getattr(twist, f) != 0.0]
        assert len(active) <= 1, f"a Twist at {ns / 1e9:.2f} s carries {active}: only one field was commanded"
        field = active[0] if active else None
        if segments and segments[-1].field == field:
            segments[-1].values.append(getattr(twist, field) if field else 0.0)
        else:
            if segments:
                segments[-1].end_ns = ns
            segments.append(Segment(field, ns, ns, [getattr(twist, field) if field else 0.0]))
    if segments:
        segments[-1].end_ns = commands[-1][0] + 50_000_000
    return segments


class Track:
    """The recorded pose, unwrapped heading, looked up by time."""

    def __init__(self, poses: list[tuple[int, tuple[float, float, float], tuple[float, float, float, float]]]):
        self.ns = [ns for ns, _, _ in poses]
        self.pos = [p for _, p, _ in poses]
        yaws = [_yaw(q) for _, _, q in poses]
        self.yaw = yaws[:1]
        for a in yaws[1:]:
            prev = self.yaw[-1]
            self.yaw.append(prev + (a - prev + math.pi) % (2 * math.pi) - math.pi)

    def index(self, ns: int) -> int:
        return min(bisect.bisect_left(self.ns, ns), len(self.ns) - 1)

    def velocity_heading_frame(self, t0_ns: int, t1_ns: int) -> tuple[float, float, float]:
        """Mean velocity from t0 to t1 in the heading frame at t0 (forward, left, up), m/s."""
        i, j = self.index(t0_ns), self.index(t1_ns)
        dt = (self.ns[j] - self.ns[i]) / 1e9
        (x0, y0, z0), (x1, y1, z1) = self.pos[i], self.pos[j]
        c, s = math.cos(self.yaw[i]), math.sin(self.yaw[i])
        dx, dy = x1 - x0, y1 - y0
        return (c * dx + s * dy) / dt, (-s * dx + c * dy) / dt, (z1 - z0) / dt


def judge(recording: Path, expected: dict[str, float], mode: ZMode) -> dict[str, float]:
    """The recording holds each expected field alone at its value, and the vehicle answered it;
    returns what was measured per field over what was commanded (1.0 is exact)."""
    measured: dict[str, float] = {}
    with RecordingReader(recording) as reader:
        commands = list(reader.commands())
        track = Track(list(reader.poses()))
    assert commands, "nothing on /quad_cmd_twist"
    segments = _segments(commands)
    for field, value in expected.items():
        held = [s for s in segments if s.field == field]
        assert held, f"{field} was never commanded alone; recorded fields: {sorted({s.field or '-' for s in segments})}"
        seg = max(held, key=lambda s: s.end_ns - s.start_ns)
        duration_s = (seg.end_ns - seg.start_ns) / 1e9
        if mode is ZMode.HEIGHT:  # held at the value, or (keys, sticks) moved there and held
            assert seg.values[-1] == pytest.approx(value, rel=1e-4), (field, value, seg.values[-5:])
            assert all(0 < v / value <= 1 + 1e-4 for v in seg.values), (field, value, seg.values[:5])
            altitude = track.pos[track.index(seg.end_ns)][2]
            assert altitude == pytest.approx(HEIGHT_BASE_M + value, abs=0.15), (field, value, altitude)
            measured[field] = (altitude - HEIGHT_BASE_M) / value
            continue
        # the pad's 16-bit axes give the value to 1e-4
        assert all(v == pytest.approx(value, rel=1e-4) for v in seg.values), (field, value, seg.values[:5])
        assert duration_s >= SEGMENT_S * 0.8, (field, duration_s)
        if field == "angular_z":  # from the turn's start to a pause after it: lag in, lag out
            i, j = track.index(seg.start_ns), track.index(seg.end_ns + int(0.8e9))
            turned = track.yaw[j] - track.yaw[i]
            assert turned == pytest.approx(value * duration_s, rel=0.10), (turned, value, duration_s)
            assert math.dist(track.pos[i], track.pos[j]) < 0.3  # turned in place
            measured[field] = turned / (value * duration_s)
            continue
        # velocity over the segment's second half, once the vehicle has answered
        fwd, left, up = track.velocity_heading_frame(seg.start_ns + int(duration_s / 2 * 1e9), seg.end_ns)
        got = {"linear_x": fwd, "linear_y": left, "linear_z": up}
        assert got[field] == pytest.approx(value, rel=0.15), (field, value, got)
        for other, v in got.items():
            if other != field:
                assert abs(v) < 0.15 * abs(value) + 0.05, (field, value, got)
        measured[field] = got[field] / value
    return measured


# --- the paths ----------------------------------------------------------------------------------

Flown = tuple[Path, dict[str, float]]


def _expected(mode: ZMode) -> dict[str, float]:
    return dict(HEIGHT if mode is ZMode.HEIGHT else VELOCITY)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    done = run_main(*args, cwd=ROOT, env=ENV, timeout=300)
    assert done.returncode == 0, done.stderr
    return done


def fly_script(tmp_path: Path, mode: ZMode) -> Flown:
    lines = [f"z_mode {mode.value}"]
    lines += [
        f"{s} " + " ".join(f"{f.replace('_', '.', 1)}={v}" for f, v in fields.items()) for s, fields in program(mode)
    ]
    script = tmp_path / "program.txt"
    script.write_text("\n".join(lines) + "\n")
    out = tmp_path / "flight.mcap"
    _cli("run", "--script", str(script), "--cameras", "none", "--out", str(out))
    return out, _expected(mode)


def fly_api(tmp_path: Path, mode: ZMode) -> Flown:
    out = tmp_path / "flight.mcap"
    with Simulator(SimConfig(z_mode=mode)) as sim, record(sim, out):
        for seconds, fields in program(mode):
            sim.send(Twist(**fields))
            sim.run_for(seconds)
    return out, _expected(mode)


def fly_bag(tmp_path: Path, mode: ZMode) -> Flown:
    store = get_typestore(Stores.ROS2_HUMBLE)
    vec, twist = store.types["geometry_msgs/msg/Vector3"], store.types["geometry_msgs/msg/Twist"]
    period_ns, ns = 50_000_000, 1_700_000_000_000_000_000
    with Writer(tmp_path / "bag", version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/quad_cmd_twist", "geometry_msgs/msg/Twist", typestore=store)
        for seconds, fields in program(mode):
            for _ in range(round(seconds * 1e9 / period_ns)):
                g = {f: fields.get(f, 0.0) for f in FIELDS}
                msg = twist(
                    linear=vec(x=g["linear_x"], y=g["linear_y"], z=g["linear_z"]),
                    angular=vec(x=g["angular_x"], y=g["angular_y"], z=g["angular_z"]),
                )
                writer.write(conn, ns, store.serialize_cdr(msg, "geometry_msgs/msg/Twist"))
                ns += period_ns
    (bag,) = (tmp_path / "bag").glob("*.mcap")
    out = tmp_path / "flight.mcap"
    _cli("run", "--commands-from", str(bag), "--z-mode", mode.value, "--cameras", "none", "--out", str(out))
    return out, _expected(mode)


#: the keyboard's speeds at scale 1 (drivers/keyboard.py's defaults) and its keys, by field and sign
KEY_SPEED = {"linear_x": 1.0, "linear_y": 1.0, "linear_z": 0.8, "angular_z": 1.0}
KEYS = {
    ("linear_x", 1): pygame.K_UP,
    ("linear_y", -1): pygame.K_RIGHT,
    ("linear_z", 1): pygame.K_w,
    ("angular_z", -1): pygame.K_d,
}


def fly_keyboard(tmp_path: Path, mode: ZMode) -> Flown:
    app = make_app(tmp_path, config=SimConfig(z_mode=mode))
    expected: dict[str, float] = {}
    if mode is ZMode.HEIGHT:  # W moves the altitude wanted at the climb speed while held
        frames = round(HEIGHT[0][1] / KEY_SPEED["linear_z"] * FPS)
        run_with(app, frames, {0: [lambda: key(pygame.K_w)], frames - 1: [lambda: key(pygame.K_w, False)]})
        run_with(app, round(HEIGHT_HOLD_S * FPS))
        expected["linear_z"] = app.sim.gate.last_command.linear_z  # the frames held, at the frame rate
        assert expected["linear_z"] == pytest.approx(HEIGHT[0][1], abs=0.1)
    else:
        run_with(app, round(0.5 * FPS))
        for field, value in VELOCITY:
            k = KEYS[(field, 1 if value > 0 else -1)]
            frames = round(SEGMENT_S * FPS)
            run_with(app, frames, {0: [lambda k=k: key(k)], frames - 1: [lambda k=k: key(k, False)]})
            run_with(app, round(PAUSE_S * FPS))
            expected[field] = math.copysign(KEY_SPEED[field], value)
    app.close()
    return app.recordings[0], expected


#: a pad's full-stick speeds (drivers/joystick.py's defaults), its sticks by field (SDL's sign: up and left negative)
PAD_SPEED = {"linear_x": 1.5, "linear_y": 1.5, "linear_z": 1.0, "angular_z": 1.2}
STICKS = {"linear_x": RIGHTY, "linear_y": RIGHTX, "linear_z": LEFTY, "angular_z": LEFTX}
DEFLECTION = 0.6


def fly_pad(tmp_path: Path, mode: ZMode, plug: Callable) -> Flown:
    pad = plug(game_controller=True)
    app = make_app(tmp_path, options=TeleopOptions(input="joystick"), config=SimConfig(z_mode=mode))
    run_with(app, round(0.5 * FPS))
    expected: dict[str, float] = {}
    if mode is ZMode.HEIGHT:  # the left stick moves the altitude wanted at the climb speed while held
        frames = round(HEIGHT[0][1] / PAD_SPEED["linear_z"] * FPS)
        pad.set_axis(LEFTY, -1.0)
        run_with(app, frames)
        pad.set_axis(LEFTY, 0.0)
        run_with(app, round(HEIGHT_HOLD_S * FPS))
        expected["linear_z"] = app.sim.gate.last_command.linear_z
        assert expected["linear_z"] == pytest.approx(HEIGHT[0][1], abs=0.05)
    else:
        for field, value in VELOCITY:
            stick = -DEFLECTION * math.copysign(1.0, value)  # SDL: up and left are negative
            pad.set_axis(STICKS[field], stick)
            run_with(app, round(SEGMENT_S * FPS))
            pad.set_axis(STICKS[field], 0.0)
            run_with(app, round(PAUSE_S * FPS))
            expected[field] = math.copysign(apply_deadzone(DEFLECTION, 0.1) * PAD_SPEED[field], value)
    app.close()
    return app.recordings[0], expected


def fly_ros2(tmp_path: Path, mode: ZMode, distribution: str) -> Flown:
    python, why = ros2_python(distribution)
    if python is None:
        pytest.skip(why)
    env = local_env(free_domain(20 + (distribution == "kilted") * 2 + (mode is ZMode.HEIGHT)), "LOCALHOST")
    out = tmp_path / "flight.mcap"
    args = ["run", "--input", "ros2", "--z-mode", mode.value, "--cameras", "none", "--out", str(out)]
    args += ["--duration", f"{program_s(mode) + 6:.0f}"]
    _, report = _beside_peer(python, args, tmp_path, env, program=json.dumps(program(mode)))
    assert report["sent"], "the node never saw quadsim"
    return out, _expected(mode)


def fly_foxglove(tmp_path: Path, mode: ZMode, subprotocol: str) -> Flown:
    out = tmp_path / "flight.mcap"
    args = ["run", "--input", "foxglove", "--foxglove", "127.0.0.1:0", "--z-mode", mode.value, "--cameras", "none"]
    sim = _quadsim(*args, "--duration", f"{program_s(mode) + 5:.0f}", "--out", str(out))
    try:
        flies = ["--publish", "cdr", "--program", json.dumps(program(mode)), "--start-s", "0.5"]
        client = _client(
            _served_url(sim), "--subprotocol", subprotocol, *flies, "--listen-s", f"{program_s(mode) + 1:.1f}"
        )
        _, err = sim.communicate(timeout=60)
    finally:
        sim.kill()
    assert client["subprotocol"] == subprotocol
    assert sim.returncode == 0, err
    return out, _expected(mode)


# --- the matrix ---------------------------------------------------------------------------------

PATHS = ["script", "api", "keyboard", "pad", "bag", "ros2-jazzy", "ros2-kilted", "foxglove-sdk", "foxglove-websocket"]
#: height mode once per kind of path (the newest distribution, the current subprotocol name)
HEIGHT_PATHS = ["script", "api", "keyboard", "pad", "bag", "ros2-kilted", "foxglove-sdk"]
CASES = [(p, ZMode.VELOCITY) for p in PATHS] + [(p, ZMode.HEIGHT) for p in HEIGHT_PATHS]


@pytest.mark.parametrize(("path", "mode"), CASES, ids=[f"{p}-{m.value}" for p, m in CASES])
def test_every_path_flies_every_field(path: str, mode: ZMode, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    kind, _, variant = path.partition("-")
    if kind == "script":
        flown = fly_script(tmp_path, mode)
    elif kind == "api":
        flown = fly_api(tmp_path, mode)
    elif kind == "bag":
        flown = fly_bag(tmp_path, mode)
    elif kind == "keyboard":
        flown = fly_keyboard(tmp_path, mode)
    elif kind == "pad":
        flown = fly_pad(tmp_path, mode, request.getfixturevalue("pads"))
    elif kind == "ros2":
        flown = fly_ros2(tmp_path, mode, variant)
    else:
        flown = fly_foxglove(tmp_path, mode, f"foxglove.{variant}.v1")
    measured = judge(*flown, mode)
    print(path, mode.value, {f: round(r, 3) for f, r in measured.items()})
