"""A URDF of one's own with mesh files: the recording and the Foxglove server carry each mesh inline
as a data: URL with its media type (what browser apps can fetch; a file:// URL is out of their
reach), the ROS 2 bridge names the files (what RViz reads), and a mesh too large to inline stays a
file:// URL with one warning."""

from __future__ import annotations

import base64
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from quadsim.recording import scene
from quadsim.recording.contract import ROBOT_DESCRIPTION
from quadsim.recording.reader import RecordingReader
from quadsim.vehicle.params import DEFAULT_URDF
from tests.test_cli_errors import run_cli


def _cube_stl(half_m: float = 0.05) -> bytes:
    """A binary STL of a cube: 12 triangles."""
    h = half_m
    corners = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1)]
    faces += [(2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    body = b"".join(
        struct.pack("<3f", 0.0, 0.0, 0.0) + b"".join(struct.pack("<3f", *corners[i]) for i in f) + b"\0\0"
        for f in faces
    )
    return b"quadsim test cube".ljust(80, b" ") + struct.pack("<I", len(faces)) + body


def _vehicle_with_mesh(folder: Path, mesh_name: str = "meshes/body.stl", mesh: bytes | None = None) -> Path:
    """The default airframe with a mesh drawn on its body, files beside it as a user keeps them."""
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    (folder / mesh_name).write_bytes(_cube_stl() if mesh is None else mesh)
    urdf = folder / "mine.urdf"
    text = DEFAULT_URDF.read_text()
    visual = f'<visual><geometry><mesh filename="{mesh_name}"/></geometry></visual><visual>'
    urdf.write_text(text.replace("<visual>", visual, 1))
    urdf.with_suffix(".params.toml").write_text(DEFAULT_URDF.with_suffix(".params.toml").read_text())
    return urdf


def _mesh_urls(description: str) -> list[str]:
    return [m.get("filename", "") for m in ET.fromstring(description).iter("mesh")]


def test_a_recording_carries_the_mesh_inline(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    urdf = _vehicle_with_mesh(tmp_path / "vehicle")
    out = tmp_path / "flight.mcap"
    code, _, err = run_cli(
        capsys,
        "run",
        "--script",
        "hover",
        "--urdf",
        str(urdf),
        "--duration",
        "0.5",
        "--cameras",
        "none",
        "--out",
        str(out),
    )
    assert code == 0, err
    with RecordingReader(out) as reader:
        ((_, msg),) = list(reader.messages(ROBOT_DESCRIPTION.name))
    (url,) = _mesh_urls(msg.data)
    prefix = "data:model/stl;base64,"
    assert url.startswith(prefix)
    assert base64.b64decode(url[len(prefix) :]) == (tmp_path / "vehicle" / "meshes" / "body.stl").read_bytes()


def test_the_ros2_bridge_names_the_file_and_big_or_unknown_meshes_stay_files(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    urdf = _vehicle_with_mesh(tmp_path)
    mesh = tmp_path / "meshes" / "body.stl"
    (local,) = _mesh_urls(scene.robot_description(urdf, inline_meshes=False))
    assert local == mesh.resolve().as_uri()

    monkeypatch.setattr(scene, "MAX_INLINE_MESH_BYTES", mesh.stat().st_size - 1)
    (url,) = _mesh_urls(scene.robot_description(urdf))
    assert url == mesh.resolve().as_uri()
    assert "body.stl (0.0 MB) stays a file:// URL" in caplog.text

    ply = _vehicle_with_mesh(tmp_path / "ply", "meshes/body.ply", b"ply\n")
    (url,) = _mesh_urls(scene.robot_description(ply))
    assert url.startswith("file://") and "only .stl, .obj, .dae, .glb are inlined" in caplog.text


def test_each_consumer_gets_the_urls_it_can_read(tmp_path: Path) -> None:
    from quadsim.recording.fanout import TopicFanout
    from quadsim.vehicle.params import load_vehicle

    fanout = TopicFanout(240)
    fanout.add_vehicle(vehicle=load_vehicle(_vehicle_with_mesh(tmp_path)))
    got: dict[str, str] = {}

    class Consumer:
        def __init__(self, name: str, local: bool) -> None:
            self.name, self.reads_local_files = name, local

        def add_topic(self, topic: object) -> None:
            pass

        def on_messages(self, messages: list) -> None:
            for topic, _, data in messages:
                if topic == ROBOT_DESCRIPTION:
                    got[self.name] = _mesh_urls(bytes(data[8:]).rstrip(b"\0").decode())[0]

        def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
            pass

    fanout.add_consumer(Consumer("recorder", False))
    fanout.add_consumer(Consumer("rviz", True))
    assert got["recorder"].startswith("data:model/stl;base64,") and got["rviz"].startswith("file:///")


def test_the_floor_mesh_cache_makes_no_home_folder(tmp_path, monkeypatch):
    """The floor's OBJ goes to the user's cache; with no home folder none is made (it made
    /nonexistent/.cache as root) and the floor is built in memory."""
    from quadsim.physics import scene

    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "gone"))
    assert scene._floor_obj(*scene._floor_mesh(8.0, 1.0)) is None
    assert not (tmp_path / "gone").exists()
    monkeypatch.setenv("HOME", str(tmp_path))
    made = scene._floor_obj(*scene._floor_mesh(8.0, 1.0))
    assert made is not None and made.parent == tmp_path / ".cache" / "quadsim" and made.stat().st_size > 100
