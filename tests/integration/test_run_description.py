"""The typed run description: written to a recording, read back equal; bad values refused with
the field named; every reader (info, resim/check) goes through it.

Its integration tests (several layers, in-process or one process started); the others are in tests/unit/test_run_description.py."""

from __future__ import annotations

import copy
import json

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from quadsim import ControllerKind, Rates, SimConfig, Simulator, StartPose, ZMode
from quadsim.errors import QuadsimError
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.recording.flight import load_flight
from quadsim.recording.info import read_info
from quadsim.sensors.camera import default_cameras
from quadsim.session.resim import resimulate
from quadsim.sim.description import SCHEMA_VERSION, DescriptionError, RunDescription
from tests.helpers.recording import record_flight


@pytest.fixture(scope="module")
def description() -> RunDescription:
    config = SimConfig(
        controller=ControllerKind.SEED,
        z_mode=ZMode.HEIGHT,
        rates=Rates(physics_hz=480, control_hz=240, state_hz=60, input_hz=20),
        command_timeout_s=0.75,
        start=StartPose(1.5, -2.0, 0.3),
        wind=WindSettings(4.5, 225.0, Turbulence.SEVERE),
        sensor_noise=False,
        seed=2**40 + 3,
    )
    with Simulator(config) as sim:
        return sim.description().with_outputs(default_cameras(160, 120, 30), 0, {"command": "run", "script": "x"})


def _round_trip(d: RunDescription) -> RunDescription:
    return RunDescription.from_parameters(json.loads(json.dumps(d.to_parameters())))


def test_it_reads_back_what_it_wrote(description):
    back = _round_trip(description)
    assert back == description
    assert back.config.rates.physics_hz == 480 and back.config.start == StartPose(1.5, -2.0, 0.3)
    assert back.controller.kind is ControllerKind.SEED and back.controller.gains == description.controller.gains
    assert [c.name for c in back.cameras] == ["front", "floor"] and back.cameras[0].width_px == 160
    assert back.extra == {"command": "run", "script": "x"}
    assert back.vehicle.rotor_count == 4 and back.vehicle.urdf_file == "quadsim_x.urdf"
    assert back.schema_version == SCHEMA_VERSION
    assert back.config.wind == WindSettings(4.5, 225.0, Turbulence.SEVERE)
    assert back.config.seed == 2**40 + 3 and back.config.sensor_noise is False


def test_a_version_1_description_had_no_wind_and_no_sensor_noise(description):
    data = description.to_parameters()
    data["schema_version"] = 1
    for key in ("wind", "sensor_noise", "seed"):
        del data["config"][key]
    back = RunDescription.from_parameters(data)
    assert back.config.wind == WindSettings() and not back.config.wind.enabled
    assert back.config.sensor_noise is False and back.config.seed == 0


@pytest.mark.parametrize(
    ("path", "value", "named"),
    [
        (("config", "rates", "physics_hz"), "abc", "parameters.config.rates.physics_hz"),
        (("config", "rates", "physics_hz"), 250, "parameters.config.rates"),  # 60 Hz does not divide 250
        (("config", "z_mode"), "sideways", "parameters.config.z_mode"),
        (("config", "command_timeout_s"), float("nan"), "parameters.config.command_timeout_s"),
        (("config", "start", "x_m"), "0", "parameters.config.start.x_m"),
        (("config", "urdf"), 5, "parameters.config.urdf"),
        (("config", "seed"), -1, "parameters.config.seed"),
        (("config", "seed"), 1.5, "parameters.config.seed"),
        (("config", "wind", "turbulence"), "gale", "parameters.config.wind.turbulence"),
        (("config", "wind", "speed_mps"), -3, "parameters.config.wind.speed_mps"),
        (("config", "sensor_noise"), "yes", "parameters.config.sensor_noise"),
        (("controller", "name"), "pid", "parameters.controller.name"),
        (("controller", "gains", "p"), [1], "parameters.controller.gains.p"),
        (("vehicle", "mass_kg"), -1, "parameters.vehicle.mass_kg"),
        (("cameras",), {"a": 1}, "parameters.cameras"),
        (("schema_version",), 99, "newer quadsim"),
        (("start_step",), -3, "parameters.start_step"),
    ],
)
def test_a_bad_value_is_refused_naming_the_field(description, path, value, named):
    params = copy.deepcopy(description.to_parameters())
    node = params
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    with pytest.raises(DescriptionError, match=named.replace(".", r"\.")):
        RunDescription.from_parameters(json.loads(json.dumps(params)))


def test_a_missing_section_is_named(description):
    params = description.to_parameters()
    del params["config"]
    with pytest.raises(DescriptionError, match=r"parameters\.config: missing"):
        RunDescription.from_parameters(params)
    with pytest.raises(DescriptionError, match="expected an object"):
        RunDescription.from_parameters(["not", "an", "object"])


def test_a_bad_camera_is_refused(description):
    params = description.to_parameters()
    params["cameras"][1]["width_px"] = 100000
    with pytest.raises(DescriptionError, match=r"parameters\.cameras\[1\]"):
        RunDescription.from_parameters(params)


def _with_parameters(src, dst, text: str) -> None:
    """Copy a recording, replacing its run parameters by `text`."""
    with open(src, "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        messages = list(reader.iter_messages())
        metadata = list(reader.iter_metadata())
        attachments = list(reader.iter_attachments())
    with open(dst, "wb") as out:
        w = Writer(out)
        w.start(profile="ros2", library="test")
        schema_ids = {s.id: w.register_schema(s.name, s.encoding, s.data) for s in summary.schemas.values()}
        channel_ids = {
            c.id: w.register_channel(c.topic, c.message_encoding, schema_ids[c.schema_id], c.metadata)
            for c in summary.channels.values()
        }
        for m in metadata:
            data = dict(m.metadata)
            if m.name == "quadsim":
                data["parameters"] = text
            w.add_metadata(m.name, data)
        for a in attachments:
            w.add_attachment(a.log_time, a.create_time, a.name, a.media_type, a.data)
        for _, channel, message in messages:
            w.add_message(channel_ids[channel.id], message.log_time, message.data, message.publish_time)
        w.finish()


def test_readers_go_through_it(tmp_path):
    src = tmp_path / "good.mcap"
    record_flight(src, cameras=False)
    good = load_flight(src)
    assert good.description is not None and good.description.controller.kind is ControllerKind.CASCADE

    params = good.description.to_parameters()
    params["config"]["rates"]["physics_hz"] = "fast"
    bad = tmp_path / "bad.mcap"
    _with_parameters(src, bad, json.dumps(params))
    info = read_info(bad)
    text = "\n".join(info.lines())
    assert "run parameters: unreadable" in text and "parameters.config.rates.physics_hz" in text
    flight = load_flight(bad)
    assert flight.description is None and flight.states  # playback still shows what is there
    with pytest.raises(QuadsimError, match=r"physics_hz.*cannot be re-flown"):
        resimulate(flight, record=False)

    garbled = tmp_path / "garbled.mcap"
    _with_parameters(src, garbled, "{not json")
    assert "not valid JSON" in "\n".join(read_info(garbled).lines())
