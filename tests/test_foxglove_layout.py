"""Every vehicle visible in every Foxglove app: each vehicle's model as markers in its own frames
(/robot_markers, /NAME/robot_markers), recorded and live, and the layout `quadsim layout` writes
for a recording, a fleet file's live run or one vehicle flown live; checked as ROS 2 readers
decode them, against the current Foxglove app's published layout schema (@foxglove/embed, type-
checked by TypeScript), and in a real Foxglove Studio 1.48 following docs/foxglove.md's steps."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from xml.etree import ElementTree

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from quadsim.recording import scene
from quadsim.recording.contract import typestore
from quadsim.vehicle.params import SHIPPED_VEHICLES
from tests.helpers import foxglove_studio
from tests.test_cli import cli
from tests.test_foxglove import npm_packages

FLEET = """
[[vehicle]]
name = "alpha"
start = [0.0, 0.0, 0.0, 0.0]
input = "script:square"
cameras = ["front"]

[[vehicle]]
name = "bravo"
airframe = "hexa"
start = [0.0, 4.0, 0.0, 90.0]
input = "idle"

[[vehicle]]
name = "charlie"
airframe = "crazyflie"
start = [-4.0, 0.0, 0.0, 0.0]
input = "foxglove"
"""
NAMES = ("alpha", "bravo", "charlie")
AIRFRAMES = {"alpha": "quad", "bravo": "hexa", "charlie": "crazyflie"}


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    """A fleet's recording (2 s), its fleet file beside it."""
    folder = tmp_path_factory.mktemp("fleet")
    (folder / "three.toml").write_text(FLEET.replace('"foxglove"', '"idle"'))
    (folder / "live.toml").write_text(FLEET)
    out = cli("run", "--fleet", str(folder / "three.toml"), "--duration", "2", "--out", str(folder / "three.mcap"))
    assert out.returncode == 0, out.stderr
    return folder / "three.mcap"


def _latched(path: Path) -> dict[str, tuple[int, object, bytes, str]]:
    """topic -> (log time, message decoded by mcap-ros2-support, its CDR, its channel's QoS) of
    each topic that got one message."""
    seen: dict[str, list] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
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


def test_a_urdfs_shapes_sizes_colours_and_meshes_become_markers(tmp_path):
    """Boxes, cylinders (along z) and spheres at their origins, coloured by a named or an inline
    material; a mesh by the URL the description gives it; a shape that cannot be read is left out."""
    (tmp_path / "arm.stl").write_bytes(b"solid arm\nendsolid arm\n")
    urdf = tmp_path / "odd.urdf"
    urdf.write_text(
        '<robot name="odd"><material name="red"><color rgba="1 0 0 1"/></material>'
        '<link name="base_link">'
        '<visual><origin xyz="1 2 3" rpy="0 0 1.5707963267948966"/><geometry><box size="0.1 0.2 0.3"/></geometry>'
        '<material name="red"/></visual>'
        '<visual><geometry><cylinder radius="0.5" length="0.1"/></geometry>'
        '<material name="x"><color rgba="0 1 0 0.5"/></material></visual>'
        '<visual><geometry><box size="0.1 nan 0.3"/></geometry></visual>'
        '<visual><geometry><capsule radius="1" length="2"/></geometry></visual>'
        "</link>"
        '<link name="rotor_1"><collision><geometry><sphere radius="0.25"/></geometry></collision></link>'
        '<link name="arm"><visual><geometry><mesh filename="arm.stl" scale="2 2 2"/></geometry></visual></link>'
        "</robot>"
    )
    box, cylinder, sphere, mesh = scene.robot_markers(urdf, lambda f: f"v/{f}")
    assert (box.type, box.scale, box.color, box.position) == (1, (0.1, 0.2, 0.3), (1.0, 0.0, 0.0, 1.0), (1.0, 2.0, 3.0))
    assert box.orientation == pytest.approx((0.0, 0.0, 2**-0.5, 2**-0.5))
    assert (cylinder.type, cylinder.scale, cylinder.color) == (3, (1.0, 1.0, 0.1), (0.0, 1.0, 0.0, 0.5))
    assert (sphere.type, sphere.scale, sphere.frame_id) == (2, (0.5,) * 3, "v/rotor_1")
    assert (mesh.type, mesh.scale, mesh.frame_id) == (10, (2.0, 2.0, 2.0), "v/arm")
    assert mesh.mesh_resource.startswith("data:model/stl;base64,") and mesh.mesh_use_embedded_materials
    assert [m.id for m in (box, cylinder, sphere, mesh)] == [0, 1, 2, 3]
    (local,) = [m for m in scene.robot_markers(urdf, inline_meshes=False) if m.type == 10]
    assert local.mesh_resource == (tmp_path / "arm.stl").as_uri()  # for RViz, which reads files


def test_a_urdf_with_endless_shapes_sends_a_bounded_message(tmp_path):
    urdf = tmp_path / "many.urdf"
    shapes = '<visual><geometry><box size="1 1 1"/></geometry></visual>' * (scene.MAX_ROBOT_MARKERS + 500)
    urdf.write_text(f'<robot name="many"><link name="base_link">{shapes}</link></robot>')
    assert len(scene.robot_markers(urdf, label="big")) == scene.MAX_ROBOT_MARKERS + 1  # and its name


def _layout(*args: str, cwd: Path) -> tuple[dict, str]:
    out = cli("layout", *args, cwd=cwd)
    assert out.returncode == 0, out.stderr
    written = Path(out.stdout.split("wrote ", 1)[1].split(":", 1)[0])
    return json.loads((cwd / written).read_text()), out.stdout


def _panels(layout: dict, kind: str) -> list[dict]:
    return [config for panel, config in layout["configById"].items() if panel.split("!")[0] == kind]


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


def test_the_layout_of_one_vehicle_flown_live_follows_it(tmp_path):
    layout, _ = _layout(cwd=tmp_path)
    assert (tmp_path / "quadsim.layout.json").is_file()
    (three_dee,) = _panels(layout, "3D")
    assert three_dee["topics"] == {"/robot_markers": {"visible": True}, "/world/markers": {"visible": True}}
    assert three_dee["followTf"] == "base_link" and "frame:rotor_1" in three_dee["transforms"]
    assert [p["cameraTopic"] for p in _panels(layout, "ImageViewPanel")] == [
        "/quad/front_camera/image_raw/compressed",
        "/quad/floor_camera/image_raw/compressed",
    ]
    assert {t["topic"] for t in _panels(layout, "Teleop")} == {"/quad_cmd_twist"}
    layout, _ = _layout("--cameras", "none", "-o", "bare.json", cwd=tmp_path)
    assert not _panels(layout, "ImageViewPanel")


def test_layout_refuses_what_it_cannot_write_in_one_line(tmp_path, fleet):
    for args, words in (
        (("--cameras", "side"), "no camera side"),
        (("-o", "layout.txt"), "a .json file"),
        ((str(tmp_path / "none.mcap"),), "none.mcap"),
        (("-o", str(tmp_path / "no" / "such" / "x.json")), "cannot write"),
    ):
        out = cli("layout", *args, cwd=tmp_path)
        assert out.returncode == 2 and words in out.stderr and "Traceback" not in out.stderr, out.stderr
        assert len(out.stderr.strip().splitlines()) == 1


# --- the current Foxglove app's published layout schema --------------------------------------------

#: the current app's layout schema as its embedding package publishes it (src/layout.generated.ts,
#: generated from the app's JSON schema), and the compiler that checks a layout against it
SCHEMA_PACKAGES = ("@foxglove/embed@0.2.3", "typescript@5.9")
SCHEMA_CACHE = Path.home() / ".cache" / "quadsim-tests" / "foxglove-layout-schema"
#: each panel of a layout (by the type its id names) and the schema type its settings must be;
#: Studio 1.x's image panel is the current app's Image panel after the app migrates it on import
SCHEMA_TYPES = {"3D": "ThreeDeeConfig", "Teleop": "TeleopConfig", "Plot": "PlotConfig", "RosOut": "LogConfig"}


def _schema_modules() -> Path:
    return npm_packages(SCHEMA_CACHE, SCHEMA_PACKAGES, "type-checking a layout against @foxglove/embed's schema")


def _type_check(layout: dict, folder: Path) -> subprocess.CompletedProcess:
    """tsc over a module that declares each panel's settings as its schema type (an object
    literal: a key the schema does not have is an error too)."""
    modules = _schema_modules()
    lines = [f'import type {{ {", ".join(sorted(SCHEMA_TYPES.values()))} }} from "@foxglove/embed";']
    for i, (panel, config) in enumerate(layout["configById"].items()):
        kind = SCHEMA_TYPES.get(panel.split("!")[0])
        if kind is not None:  # a title is the panel's, beside its settings in the schema
            settings = {k: v for k, v in config.items() if k != "foxglovePanelTitle"}
            assert isinstance(config.get("foxglovePanelTitle", ""), str)
            lines.append(f"export const panel{i}: {kind} = {json.dumps(settings)};")
    (folder / "layout.ts").write_text("\n".join(lines) + "\n")
    (folder / "node_modules").unlink(missing_ok=True)
    (folder / "node_modules").symlink_to(modules)
    tsc = modules / "typescript" / "bin" / "tsc"
    args = ["--noEmit", "--strict", "--skipLibCheck", "--module", "nodenext", "--moduleResolution", "nodenext"]
    return subprocess.run(["node", str(tsc), *args, "layout.ts"], capture_output=True, text=True, cwd=folder)


def test_every_layout_matches_the_current_foxglove_apps_layout_schema(fleet, tmp_path):
    layouts = [_layout(str(fleet), "-o", str(tmp_path / "rec.json"), cwd=tmp_path)[0]]
    layouts.append(_layout(str(fleet.parent / "live.toml"), "-o", str(tmp_path / "live.json"), cwd=tmp_path)[0])
    layouts.append(_layout("-o", str(tmp_path / "one.json"), cwd=tmp_path)[0])
    for layout in layouts:
        done = _type_check(layout, tmp_path)
        assert done.returncode == 0, done.stdout + done.stderr
    broken = json.loads(json.dumps(layouts[0]))
    broken["configById"]["3D!quadsim"]["scene"]["transforms"]["axisScale"] = 0.3  # Studio 1.48's name for it
    done = _type_check(broken, tmp_path)
    assert done.returncode != 0 and "axisScale" in done.stdout  # it can fail


# --- a real Foxglove Studio 1.48 ------------------------------------------------------------------


@pytest.mark.slow
def test_studio_148_draws_every_vehicle_of_a_fleet_after_importing_its_layout(tmp_path):
    """docs/foxglove.md's steps in Studio 1.48: open the recording, import the layout quadsim
    wrote for it; the 3D panel draws each vehicle's model (a recording without /NAME/robot_markers
    shows none: Studio 1.48 cannot draw /NAME/robot_description)."""
    try:
        foxglove_studio.studio()
    except foxglove_studio.NoStudio as exc:
        pytest.skip(str(exc))
    (tmp_path / "plain.toml").write_text("[floor]\nsize_m = 40.0\n")
    two = FLEET.split('[[vehicle]]\nname = "charlie"')[0].replace('cameras = ["front"]', "")
    (tmp_path / "two.toml").write_text(two)
    fleet = tmp_path / "two.mcap"
    plain = ("--world", str(tmp_path / "plain.toml"), "--duration", "2", "--out", str(fleet))
    out = cli("run", "--fleet", str(tmp_path / "two.toml"), *plain)
    assert out.returncode == 0, out.stderr
    layout, _ = _layout(str(fleet), cwd=tmp_path)
    layout["configById"]["3D!quadsim"]["transforms"]["frame:world"] = {"visible": False}  # its axes are red and blue
    (tmp_path / "two.layout.json").write_text(json.dumps(layout))
    shot = tmp_path / "shot.png"
    with foxglove_studio.served({"two.mcap": fleet, "two.layout.json": tmp_path / "two.layout.json"}) as url:
        steps = ["open-file=/data/two.mcap", "wait=5", "import-layout=/data/two.layout.json", "sidebar=layouts"]
        foxglove_studio.follow_steps(url, tmp_path / "steps.log", *steps, "wait=6", f"shot={shot}")
    panel = (60, 40, 1000, 900)  # the 3D panel, left of the plot and the log
    assert foxglove_studio.vehicles_drawn(shot, panel) == 2 and foxglove_studio.vehicle_names_drawn(shot, panel) == 2
