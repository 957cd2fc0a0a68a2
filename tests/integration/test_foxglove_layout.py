"""Every vehicle visible in every Foxglove app.

Its integration tests (several layers, in-process or one process started); the others are in tests/e2e/test_foxglove_layout.py."""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree

from quadsim.recording.contract import typestore
from quadsim.vehicle.params import SHIPPED_VEHICLES
from tests.e2e.test_foxglove_layout import (
    _layout,
    _panels,
    fleet,  # noqa: F401 (a fixture)
)
from tests.helpers.mcap import decoded_messages

NAMES = ("alpha", "bravo", "charlie")


AIRFRAMES = {"alpha": "quad", "bravo": "hexa", "charlie": "crazyflie"}


def _latched(path: Path) -> dict[str, tuple[int, object, bytes, str]]:
    """topic -> (log time, message decoded by mcap-ros2-support, its CDR, its channel's QoS) of
    each topic that got one message."""
    seen: dict[str, list] = {}
    for channel, message, decoded in decoded_messages(path):
        qos = channel.metadata.get("offered_qos_profiles", "")
        seen.setdefault(channel.topic, []).append((message.log_time, decoded, message.data, qos))
    return {topic: messages[0] for topic, messages in seen.items() if len(messages) == 1}


def _shapes(urdf: Path) -> int:
    """The shapes a viewer draws of a URDF: each link's visuals, else its collision shapes."""
    links = ElementTree.parse(urdf).getroot().iter("link")
    return sum(len(link.findall("visual")) or len(link.findall("collision")) for link in links)


def test_each_vehicles_model_is_recorded_as_markers_in_its_own_frames(fleet):
    """Both mcap-ros2-support and rosbags decode them; each shape of the URDF is one marker, in the
    frame of its link under the vehicle's name (which /tf_static places), locked to it; the
    vehicle's name floats over it; latched."""
    latched = _latched(fleet)
    static = latched["/tf_static"][1].transforms
    placed = {t.child_frame_id for t in static} | {f"{name}/base_link" for name in NAMES}
    for name in NAMES:
        log_time, markers, data, qos = latched[f"/{name}/robot_markers"]
        again = typestore().deserialize_cdr(data, "visualization_msgs/msg/MarkerArray")
        assert [m.header.frame_id for m in again.markers] == [m.header.frame_id for m in markers.markers]
        *shapes, label = markers.markers
        assert len(shapes) == _shapes(SHIPPED_VEHICLES[AIRFRAMES[name]]) > 5
        assert {m.header.frame_id for m in shapes} <= placed
        assert all(m.header.frame_id.startswith(f"{name}/") and m.frame_locked for m in markers.markers)
        assert {m.type for m in shapes} <= {1, 2, 3} and {m.ns for m in shapes} == {"robot"}
        assert (label.type, label.text, label.header.frame_id) == (9, name, f"{name}/base_link")
        assert all(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == log_time for m in markers.markers)
        assert "durability: 1" in qos  # transient local: a late joiner gets it
    assert "/robot_markers" not in latched  # a fleet's vehicles have only their own


def _placed(tree) -> list[str]:
    """The panels the layout's tree places."""
    if isinstance(tree, str):
        return [tree]
    return _placed(tree["first"]) + _placed(tree["second"])


def test_the_layout_of_a_fleets_recording_turns_on_every_vehicles_model(fleet):
    layout, said = _layout(str(fleet), cwd=fleet.parent)
    assert (fleet.parent / "three.layout.json").is_file() and "Import from file" in said
    assert sorted(_placed(layout["layout"])) == sorted(layout["configById"])
    (three_dee,) = _panels(layout, "3D")
    assert three_dee["topics"] == {
        "/alpha/robot_markers": {"visible": True},
        "/bravo/robot_markers": {"visible": True},
        "/charlie/robot_markers": {"visible": True},
        "/world/markers": {"visible": True},
    }
    assert three_dee["followTf"] == "world" and three_dee["cameraState"]["targetOffset"][:2] == [-2.0, 2.0]
    hidden = set(three_dee["transforms"])
    assert {"frame:alpha/base_link", "frame:bravo/rotor_6", "frame:alpha/front_camera_optical"} <= hidden
    assert all(v == {"visible": False} for v in three_dee["transforms"].values())
    assert [p["cameraTopic"] for p in _panels(layout, "ImageViewPanel")] == [
        "/alpha/quad/front_camera/image_raw/compressed"
    ]
    (plot,) = _panels(layout, "Plot")
    assert [p["value"] for p in plot["paths"]] == [f"/{n}/quad/pose.pose.position.z" for n in NAMES]
    assert not _panels(layout, "Teleop")  # a recording is not flown
    assert _panels(layout, "RosOut") == [
        {"searchTerms": [], "minLogLevel": 1, "preload": False, "topicToRender": "/rosout"}
    ]


def test_the_layout_of_a_live_fleet_has_teleop_on_each_foxglove_vehicles_topic(fleet):
    layout, _ = _layout(str(fleet.parent / "live.toml"), "-o", "live.json", cwd=fleet.parent)
    teleops = _panels(layout, "Teleop")
    assert [t["topic"] for t in teleops] == ["/charlie/quad_cmd_twist"] * 2
    assert [t["foxglovePanelTitle"] for t in teleops] == [
        "charlie: forward, back, turn",
        "charlie: climb, descend, sideways",
    ]
    buttons = {(b["field"], b["value"]) for t in teleops for k, b in t.items() if k.endswith("Button")}
    assert {("linear-x", 1.0), ("linear-x", -1.0), ("linear-z", 1.0), ("linear-z", -1.0)} <= buttons
    assert {("angular-z", 0.5), ("angular-z", -0.5), ("linear-y", 1.0), ("linear-y", -1.0)} <= buttons
    assert set(_panels(layout, "3D")[0]["topics"]) == {f"/{n}/robot_markers" for n in NAMES} | {"/world/markers"}
