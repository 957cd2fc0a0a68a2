"""Helpers for recording tests: fly a short scripted flight with recording on."""

import math
from collections.abc import Callable, Sequence
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import Writer

from quadsim import SimConfig, Simulator, StateLog, Twist, ZMode
from quadsim.drivers.scripted import ScriptedDriver, parse_script
from quadsim.sensors.camera import default_cameras
from quadsim.session.outputs import OutputOptions, RecordedRun
from tests.helpers import RECORDINGS

SCRIPT = "z_mode height\n2.0 linear.z=0\n1.0 linear.x=1.0 angular.z=0.5\n"
#: the project's own regression recordings (tools/make_regression_recordings.py), by name: flights
#: a user adds to tests/recordings/ (the docs ask for a folder of their own) change no test's count
SHIPPED_RECORDINGS = [
    RECORDINGS / name
    for name in (
        "climb_cascade.mcap",
        "figure8_seed.mcap",
        "fleet_trio_wind.mcap",
        "keyboard_session_cascade.mcap",
        "square_cascade.mcap",
        "takeoff_moderate_wind_cascade.mcap",
    )
]


def record_flight(path: Path, workers: int = 0, size=(160, 120), cameras=True, script: str = SCRIPT) -> StateLog:
    """`cameras`: front and floor at `size` (True), none (False), or these specs."""
    parsed = parse_script(script, "test")
    specs = (default_cameras(*size, 30) if cameras else ()) if isinstance(cameras, bool) else tuple(cameras)
    log = StateLog()
    with Simulator(SimConfig(z_mode=parsed.z_mode or ZMode.VELOCITY), ScriptedDriver(parsed)) as sim:
        sim.add_sink(log)
        options = OutputOptions(out=path, cameras=specs, render_workers=workers)
        with RecordedRun(sim, options, "test", {"script": "test"}):
            sim.run_for(parsed.duration_s)
    return log


def copy_recording(
    src: Path,
    dst: Path,
    metadata: Callable[[str, dict[str, str]], dict[str, str]] = lambda name, data: data,
    attachment: Callable[[str, bytes], bytes] = lambda name, data: data,
) -> Path:
    """Copy a recording record by record, editing its metadata or attachments on the way
    (a crafted or damaged file, or one whose vehicle file has changed)."""
    with open(src, "rb") as fh:
        reader = make_reader(fh)
        summary, header = reader.get_summary(), reader.get_header()
        assert summary is not None
        with open(dst, "wb") as out:
            w = Writer(out)
            w.start(header.profile, header.library)
            sids = {i: w.register_schema(s.name, s.encoding, s.data) for i, s in summary.schemas.items()}
            cids = {
                i: w.register_channel(c.topic, c.message_encoding, sids[c.schema_id], c.metadata)
                for i, c in summary.channels.items()
            }
            for m in reader.iter_metadata():
                w.add_metadata(m.name, metadata(m.name, dict(m.metadata)))
            for a in reader.iter_attachments():
                w.add_attachment(a.log_time, a.create_time, a.name, a.media_type, attachment(a.name, a.data))
            for _, channel, message in reader.iter_messages():
                w.add_message(cids[channel.id], message.log_time, message.data, message.publish_time, message.sequence)
            w.finish()
    return dst


#: quadsim's default dead-man timeout: a command holds this long when no newer one comes
COMMAND_TIMEOUT_NS = 500_000_000


def commanded_motion(
    commands: Sequence[tuple[int, Twist]], timeout_ns: int = COMMAND_TIMEOUT_NS
) -> tuple[float, float, float, float]:
    """Where velocity-mode commands, as a recording received them, ask the vehicle to go from where
    it started (x, y, z in m, the heading turned in rad): each command holds from its log time
    until the next, or the dead-man timeout (`timeout_ns`: the input's), its linear.x/y along the heading of the moment.
    Measured against what was received, in simulation time, an outcome does not depend on how a
    loaded machine kept a peer's wall-clock pace (the climb a ROS 2 node sent for 2.5 s of wall
    time once reached quadsim as 1.8 s of simulation time)."""
    x = y = z = yaw = 0.0
    ends = [ns for ns, _ in commands[1:]] + [commands[-1][0] + timeout_ns]
    for (ns, t), end in zip(commands, ends, strict=True):
        held_s = min(end - ns, timeout_ns) / 1e9
        c, s = math.cos(yaw), math.sin(yaw)
        x += (c * t.linear_x - s * t.linear_y) * held_s
        y += (s * t.linear_x + c * t.linear_y) * held_s
        z += t.linear_z * held_s
        yaw += t.angular_z * held_s
    return x, y, z, yaw
