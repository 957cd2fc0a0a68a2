"""A fleet flown from a fleet file, as a user runs it (`run --fleet`, `check`, `replay --resim`):
each vehicle's outcome read back from its own topics with an independent decoder
(mcap-ros2-support), the shared topics once, crashes on both vehicles, and re-flights at zero."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from quadsim.recording.flight import load_flight, load_flights
from tests.helpers.fleets import fleet_toml, vehicle
from tests.integration.test_cli import cli

FLEET = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:square"),
    vehicle("bravo", (0.0, 4.0, 0.0, 90.0), airframe="hexa", input="script:yaw"),
    vehicle("charlie", (-4.0, 0.0, 0.0, 0.0), airframe="crazyflie", input="idle"),
)


def _decoded(path: Path) -> tuple[dict[str, list], dict[str, dict[str, str]], list[str]]:
    """topic -> [(log time, message)], the metadata records, the attachment names."""
    topics: dict[str, list] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            topics.setdefault(channel.topic, []).append((message.log_time, decoded))
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = [a.name for a in reader.iter_attachments()]
    return topics, metadata, attachments


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


@pytest.fixture(scope="module")
def fleet_recording(tmp_path_factory) -> tuple[Path, str]:
    folder = tmp_path_factory.mktemp("fleet")
    (folder / "three.toml").write_text(FLEET)
    out = cli("run", "--fleet", str(folder / "three.toml"), "--out", str(folder / "three.mcap"))
    assert out.returncode == 0, out.stderr
    return folder / "three.mcap", out.stdout


def test_a_fleet_file_flies_each_vehicle_and_records_it_under_its_name(fleet_recording):
    path, stdout = fleet_recording
    assert "flying a fleet of 3 for 27.0 s: alpha (quad, script square), bravo (hexa, script yaw), charlie" in stdout
    assert [line.split()[0] for line in stdout.splitlines() if "final x=" in line] == ["alpha", "bravo", "charlie"]
    topics, metadata, attachments = _decoded(path)
    for name in ("alpha", "bravo", "charlie"):
        for topic in ("quad/pose", "quad/odom", "quad/imu", "quad/rotor_thrusts", "robot_description"):
            assert f"/{name}/{topic}" in topics, (name, topic)
    assert "/alpha/quad_cmd_twist" in topics and "/bravo/quad_cmd_twist" in topics
    assert "/charlie/quad_cmd_twist" not in topics  # idle: nothing was sent
    assert not {"/quad/pose", "/quad_cmd_twist", "/robot_description"} & set(topics)  # only a fleet's names
    assert [len(topics[t]) for t in ("/tf_static", "/world/markers")] == [1, 1]  # shared, once
    # alpha: the 3 m square, back over its start at 2 m
    poses = [m.pose.position for _, m in topics["/alpha/quad/pose"]]
    path_m = sum(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z)) for a, b in itertools.pairwise(poses))
    assert 13.0 < path_m < 16.0 and math.dist((poses[-1].x, poses[-1].y), (0.0, 0.0)) < 0.2, path_m
    assert abs(poses[-1].z - 2.0) < 0.1 and max(p.x for p in poses) > 2.8 and max(p.y for p in poses) > 2.8
    # bravo: turned 6 rad from 90 deg where it stands
    last = topics["/bravo/quad/pose"][-1][1].pose
    assert math.dist((last.position.x, last.position.y), (0.0, 4.0)) < 0.1
    assert abs(math.remainder(_yaw(last.orientation) - (math.pi / 2 + 6.0), 2 * math.pi)) < 0.1
    assert len(topics["/bravo/quad/rotor_thrusts"][-1][1].data) == 6  # a hexa
    # charlie: idle on the floor, its rotors still
    assert max(m.pose.position.z for _, m in topics["/charlie/quad/pose"]) < 0.1
    assert sum(topics["/charlie/quad/rotor_thrusts"][-1][1].data) == 0.0
    # frames under each name, in one TF tree rooted at world
    children = {t.child_frame_id for _, m in topics["/tf"] for t in m.transforms}
    assert children == {"alpha/base_link", "bravo/base_link", "charlie/base_link"}
    assert {t.header.frame_id for _, m in topics["/tf"] for t in m.transforms} == {"world"}
    static = topics["/tf_static"][0][1].transforms
    assert {t.header.frame_id for t in static} == {"alpha/base_link", "bravo/base_link", "charlie/base_link"}
    assert sum(t.child_frame_id.startswith("bravo/rotor") for t in static) == 6
    odom = topics["/bravo/quad/odom"][0][1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("world", "bravo/base_link")
    assert topics["/charlie/quad/imu"][0][1].header.frame_id == "charlie/base_link"
    assert "crazyflie" in topics["/charlie/robot_description"][0][1].data
    # the run: a fleet's parameters, every airframe's files attached once
    params = json.loads(metadata["quadsim"]["parameters"])
    assert params["schema_version"] == 3 and [v["name"] for v in params["fleet"]] == ["alpha", "bravo", "charlie"]
    assert sorted(attachments) == sorted(set(attachments)) and len(attachments) == 7
    takeoffs = [m.msg for _, m in topics["/rosout"] if "takeoff" in m.msg]
    assert {m.name for _, m in topics["/rosout"] if "takeoff" in m.msg} == {"alpha.quadsim", "bravo.quadsim"}
    assert len(takeoffs) == 2


def test_a_fleet_recording_reads_back_vehicle_by_vehicle(fleet_recording):
    """(Re-flown at 0 m by check and replay --resim as every run is: tests/e2e/test_one_path.py.)"""
    path, _ = fleet_recording
    flights = load_flights(path)
    assert list(flights) == ["alpha", "bravo", "charlie"]
    assert flights["bravo"].description.vehicle.rotor_count == 6 and flights["bravo"].vehicle == "bravo"
    assert len(flights["alpha"].commands) == 540 and flights["charlie"].commands == []
    assert load_flight(path).vehicle == "alpha" and load_flight(path, "charlie").states[-1].position_m[2] < 0.1
    with pytest.raises(Exception, match=r"no vehicle named 'zulu'.*alpha, bravo, charlie"):
        load_flight(path, "zulu")
    info = cli("info", str(path)).stdout
    assert "a fleet of 3 vehicles:" in info and "bravo: quadsim_hexa (6 rotors" in info


def test_a_changed_vehicle_in_a_fleet_fails_check_naming_it(fleet_recording, tmp_path):
    """check fails a fleet one of whose airframes changed (bravo's, the hexa: more rotor drag),
    and the report shows which vehicle strayed and which did not."""
    from tests.e2e.test_replay import _with_changed_attachment

    path, _ = fleet_recording
    changed = tmp_path / "changed.mcap"
    _with_changed_attachment(
        path,
        changed,
        "quadsim_hexa.params.toml",
        lambda d: d.replace(b"rotor_drag_ns_per_m_rad = 1.7e-4", b"rotor_drag_ns_per_m_rad = 6.0e-4"),
    )
    out = cli("check", str(changed), "--tolerance-m", "1e-6", "--tolerance-rad", "1e-6")
    assert out.returncode == 1, out.stdout + out.stderr
    assert f"FAIL  {changed} (a fleet of 3)" in out.stdout
    report = out.stdout.split("bravo:")[1]
    assert "/bravo/quad/pose position: max" in report and "first beyond tolerance at t=" in report
    assert "/alpha/quad/pose position: max 0 m" in out.stdout  # the others fly as recorded


def test_c_in_the_replay_window_follows_each_vehicle_in_turn(fleet_recording):
    """The replay window of a fleet's recording: C follows the next vehicle (its HUD's state and
    cameras, the others on the map), in the fleet's order and round again."""
    import pygame

    from quadsim.apps.window.replay import ReplayApp

    path, _ = fleet_recording
    flights = load_flights(path)
    others = {n: f for n, f in flights.items() if n != "alpha"}
    with ReplayApp(flights["alpha"], (640, 360), frame_s=0.1, others=others) as app:
        app.seek(12.0)
        followed = []
        for _ in range(3):
            model = app.model()
            followed.append(model.cameras_of)
            expected = flights[model.cameras_of].state_at(app.t_ns)
            assert model.state == expected and [n for n, *_ in model.others] == sorted(
                set(flights) - {model.cameras_of}
            )
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_c, mod=0, unicode="c", scancode=0))
            app.run(max_frames=app.frame_count + 1)
        assert followed == ["alpha", "bravo", "charlie"] and app.model().cameras_of == "alpha"
        assert "following alpha (it recorded no cameras)" in app.model().warnings
