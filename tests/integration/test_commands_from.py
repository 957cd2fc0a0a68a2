"""`run --commands-from FILE.mcap` flies the /quad_cmd_twist of a bag quadsim did not write (rosbags'
rosbag2 writer, MCAP storage, as `ros2 bag record -s mcap` makes them) at its log times, records
the flight, and refuses what it cannot fly with one line."""

from __future__ import annotations

import datetime
import math
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from quadsim.recording.reader import RecordingReader
from tests.helpers import ROOT
from tests.integration.test_cli_errors import assert_one_line_error, run_cli

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
#: a bag's log times are wall-clock times: the flight counts from its first command
BAG_START_NS = 1_700_000_000_123_000_000
PERIOD_NS = 50_000_000  # 20 Hz, as teleop_twist_joy publishes


def _twist(x: float = 0.0, z: float = 0.0):
    vec = T["geometry_msgs/msg/Vector3"]
    return T["geometry_msgs/msg/Twist"](linear=vec(x=x, y=0.0, z=z), angular=vec(x=0.0, y=0.0, z=0.0))


def _bag(folder: Path, topic: str, type_name: str, messages: list) -> Path:
    """A rosbag2 bag in MCAP storage; the path of its .mcap file."""
    with Writer(folder, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection(topic, type_name, typestore=TS)
        for ns, msg in messages:
            writer.write(connection, ns, TS.serialize_cdr(msg, type_name))
    (mcap,) = folder.glob("*.mcap")
    return mcap


def test_a_ros2_bags_commands_fly_the_vehicle_where_they_say(tmp_path):
    # 4 s climbing at 0.5 m/s, then 3 s forward at 1 m/s, then nothing (the dead-man holds)
    commands = [_twist(z=0.5)] * 80 + [_twist(x=1.0)] * 60
    bag = _bag(
        tmp_path / "teleop_session",
        "/quad_cmd_twist",
        "geometry_msgs/msg/Twist",
        [(BAG_START_NS + i * PERIOD_NS, t) for i, t in enumerate(commands)],
    )
    out = tmp_path / "flown.mcap"
    result = subprocess.run(
        [sys.executable, str(ROOT / "main.py"), "run", "--commands-from", str(bag), "--cameras", "none", "--out", out],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    assert "flying the 140 commands of teleop_session.mcap for 8.95 s" in result.stdout
    with RecordingReader(out) as flown:
        recorded = list(flown.commands())
        poses = list(flown.poses())
        assert flown.description is not None and flown.description.driver["source"] == str(bag)
    # every command, at its log time from the first (50 ms = 12 physics steps: exact)
    assert [(ns, (t.linear_x, t.linear_z)) for ns, t in recorded] == [
        (i * PERIOD_NS, (c.linear.x, c.linear.z)) for i, c in enumerate(commands)
    ]
    assert poses[-1][0] == pytest.approx(8.95e9, abs=1e7)  # the span of the commands plus 2 s
    z_at_4s = next(p for ns, p, _ in poses if ns >= 4_000_000_000)[2]
    assert z_at_4s == pytest.approx(2.0, abs=0.25)  # 4 s at 0.5 m/s
    x, y, z = poses[-1][1]
    assert x == pytest.approx(3.0, abs=0.5) and abs(y) < 0.1 and z == pytest.approx(2.0, abs=0.25)
    assert math.isclose(x, poses[-20][1][0], abs_tol=0.02)  # holding still once the commands stopped


def test_errors_are_one_line(tmp_path, capsys):
    quick = ["--cameras", "none", "--no-record"]
    code, _, err = run_cli(capsys, "run", "--commands-from", str(tmp_path / "nope.mcap"), *quick)
    assert_one_line_error(code, err, "nope.mcap", "no such file")

    text = tmp_path / "notes.mcap"
    text.write_text("not a bag\n")
    code, _, err = run_cli(capsys, "run", "--commands-from", str(text), *quick)
    assert_one_line_error(code, err, "notes.mcap", "not an MCAP file")

    chatter = _bag(
        tmp_path / "chatter", "/chatter", "std_msgs/msg/String", [(BAG_START_NS, T["std_msgs/msg/String"](data="hi"))]
    )
    code, _, err = run_cli(capsys, "run", "--commands-from", str(chatter), *quick)
    assert_one_line_error(code, err, "no /quad_cmd_twist channel", "its topics: /chatter")

    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="")
    stamped = T["geometry_msgs/msg/TwistStamped"](header=header, twist=_twist(x=1.0))
    wrong = _bag(tmp_path / "stamped", "/quad_cmd_twist", "geometry_msgs/msg/TwistStamped", [(BAG_START_NS, stamped)])
    code, _, err = run_cli(capsys, "run", "--commands-from", str(wrong), *quick)
    assert_one_line_error(
        code, err, "/quad_cmd_twist carries geometry_msgs/msg/TwistStamped, not geometry_msgs/msg/Twist"
    )

    code, _, err = run_cli(capsys, "run", "--commands-from", str(wrong), "--script", "hover", *quick)
    assert code == 2 and "not allowed with argument" in err


def test_a_quadsim_recordings_commands_fly_the_same_flight_in_its_z_mode(tmp_path, capsys):
    """A recording flown in height z-mode: its commands, flown again, give the same poses."""
    from tests.helpers.recording import record_flight

    first = tmp_path / "first.mcap"
    record_flight(first, cameras=False)  # height z-mode: 2 s hover at 2 m, 1 s forward and turning
    again = tmp_path / "again.mcap"
    code, out, err = run_cli(capsys, "run", "--commands-from", str(first), "--cameras", "none", "--out", str(again))
    assert code == 0, err
    assert "z-mode height" in out
    with RecordingReader(first) as a, RecordingReader(again) as b:
        original, flown = list(a.poses()), list(b.poses())
    assert len(flown) > len(original)  # 2 s more
    assert flown[: len(original)] == original
    # its commands mean height z-mode: flying them in velocity z-mode is refused (it was done,
    # silently, and the vehicle never left the ground)
    code, _, err = run_cli(capsys, "run", "--commands-from", str(first), "--z-mode", "velocity", "--no-record")
    assert_one_line_error(code, err, "--z-mode velocity: first.mcap was flown in height z-mode")


def test_a_recording_that_switches_z_mode_is_flown_in_its_first_with_a_warning(capsys):
    recording = ROOT / "tests" / "recordings" / "keyboard_session_cascade.mcap"  # Tab at 6 s
    code, out, err = run_cli(capsys, "run", "--commands-from", str(recording), "--cameras", "none", "--no-record")
    assert code == 0 and "z-mode velocity" in out
    assert "switches z-mode during its flight (first at 6.00 s)" in err and "--resim flies it as recorded" in err


def test_a_bags_folder_flies_its_one_mcap_file(tmp_path, capsys):
    """`ros2 bag record -s mcap` writes a folder: given the folder, its .mcap file is flown."""
    bag = _bag(
        tmp_path / "session",
        "/quad_cmd_twist",
        "geometry_msgs/msg/Twist",
        [(BAG_START_NS + i * PERIOD_NS, _twist(z=0.5)) for i in range(40)],
    )
    code, out, err = run_cli(capsys, "run", "--commands-from", str(bag.parent), "--cameras", "none", "--no-record")
    assert code == 0, err
    assert f"flying the 40 commands of {bag.name}" in out
    code, out, err = run_cli(capsys, "info", str(bag.parent))  # its log time is the wall clock, not ours
    assert code == 0, err
    start = datetime.datetime.fromtimestamp(BAG_START_NS // 10**9, datetime.timezone.utc)
    assert f"duration    1.95 s of log time (from {start:%Y-%m-%d %H:%M:%S} UTC)" in out
    (tmp_path / "empty").mkdir()
    code, _, err = run_cli(capsys, "run", "--commands-from", str(tmp_path / "empty"), "--no-record")
    assert_one_line_error(code, err, "a folder with no .mcap file in it")
    (bag.parent / "session_1.mcap").write_bytes(bag.read_bytes())
    code, _, err = run_cli(capsys, "run", "--commands-from", str(bag.parent), "--no-record")
    assert_one_line_error(code, err, "a folder of 2 .mcap files", "give the one you mean")


def test_every_command_that_reads_a_recording_takes_a_bags_folder(tmp_path, capsys):
    """info, replay and recover take a `ros2 bag record -s mcap` folder as run --commands-from does
    (they said "not a file")."""
    folder = tmp_path / "session"
    folder.mkdir()
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    recording = folder / "session_0.mcap"
    recording.write_bytes((ROOT / "tests" / "recordings" / "square_cascade.mcap").read_bytes())
    code, out, err = run_cli(capsys, "info", str(folder))
    assert code == 0, err
    assert out.startswith(f"file        {recording}") and "/quad/pose" in out
    code, out, err = run_cli(capsys, "replay", "--headless", "--speed", "16", str(folder))
    assert code == 0, err
    assert f"recording   {recording}" in out and "540 on /quad_cmd_twist" in out
    code, out, err = run_cli(capsys, "recover", str(folder))
    assert code == 0, err  # beside the folder: a second .mcap in it would make the folder ambiguous
    assert f"{recording} was complete" in out and (tmp_path / "session.recovered.mcap").is_file()
    assert sorted(p.name for p in folder.iterdir()) == ["metadata.yaml", "session_0.mcap"]
    (folder / "session_1.mcap").write_bytes(recording.read_bytes())
    code, _, err = run_cli(capsys, "info", str(folder))  # two .mcap files: which one is meant?
    assert_one_line_error(code, err, "a folder of 2 .mcap files", "give the one you mean")


# --- hostile bags ---------------------------------------------------------------------------------


def _raw_bag(path: Path, times_ns: list[int] | range, payload: bytes | None = None) -> Path:
    """A bag of Twists at `times_ns`, written straight with the mcap library (fast for millions)."""
    from mcap.writer import Writer as McapWriter

    data = payload if payload is not None else TS.serialize_cdr(_twist(x=0.5), "geometry_msgs/msg/Twist")
    schema_text = "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"
    schema_text += "=" * 80 + "\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
    with open(path, "wb") as fh:
        writer = McapWriter(fh)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema("geometry_msgs/msg/Twist", "ros2msg", schema_text.encode())
        channel = writer.register_channel("/quad_cmd_twist", "cdr", schema)
        for i, ns in enumerate(times_ns):
            writer.add_message(channel, log_time=ns, publish_time=ns, data=data, sequence=i % 2**32)
        writer.finish()
    return path


def test_commands_centuries_apart_are_refused_and_flown_in_part_with_duration(tmp_path, capsys):
    bag = _raw_bag(tmp_path / "apart.mcap", [0, 2**63 - 1])
    quick = ["--cameras", "none", "--no-record"]
    code, _, err = run_cli(capsys, "run", "--commands-from", str(bag), *quick)
    assert_one_line_error(code, err, "its commands span 1.068e+05 days", "--duration")
    code, out, err = run_cli(capsys, "run", "--commands-from", str(bag), "--duration", "3", *quick)
    assert code == 0, err
    assert "flying the 2 commands of apart.mcap for 3 s" in out


def test_a_gap_longer_than_the_dead_man_timeout_is_flown_as_silence(tmp_path, capsys):
    """Climb 2 s, then nothing for 6 s, then forward 2 s: the vehicle holds through the gap."""
    climb = [_twist(z=1.0)] * 40
    forward = [_twist(x=1.0)] * 40
    messages = [(BAG_START_NS + i * PERIOD_NS, t) for i, t in enumerate(climb)]
    messages += [(BAG_START_NS + 8_000_000_000 + i * PERIOD_NS, t) for i, t in enumerate(forward)]
    bag = _bag(tmp_path / "gap", "/quad_cmd_twist", "geometry_msgs/msg/Twist", messages)
    out = tmp_path / "flown.mcap"
    code, _, err = run_cli(capsys, "run", "--commands-from", str(bag), "--cameras", "none", "--out", str(out))
    assert code == 0, err
    with RecordingReader(out) as flown:
        poses = [(ns / 1e9, p) for ns, p, _ in flown.poses()]
    at = {round(t, 2): p for t, p in poses}
    held = [p for t, p in poses if 3.5 <= t <= 7.9]
    assert max(p[2] for p in held) - min(p[2] for p in held) < 0.05  # altitude held through the gap
    assert all(math.dist(p[:2], held[0][:2]) < 0.05 for p in held)
    assert at[10.0][0] - at[8.0][0] > 1.2  # forward once the commands came back


def test_non_finite_commands_in_a_bag_are_rejected_and_counted(tmp_path, capsys):
    nan = b"\x00\x01\x00\x00" + struct.pack("<6d", math.nan, 0.0, math.inf, 0.0, 0.0, 0.0)
    bag = _raw_bag(tmp_path / "nan.mcap", range(0, 1_000_000_000, 50_000_000), payload=nan)
    code, out, err = run_cli(capsys, "run", "--commands-from", str(bag), "--cameras", "none", "--no-record")
    assert code == 0, err
    assert "20 rejected (not finite)" in out
