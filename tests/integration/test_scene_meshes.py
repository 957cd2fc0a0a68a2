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
from tests.integration.test_cli_errors import run_cli


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


def _box_ascii_stl(low: tuple[float, float, float], high: tuple[float, float, float], name: str = "runner") -> str:
    """An ASCII STL of a box, its facets counter-clockwise seen from outside (as STL has them)."""
    corner = {
        (i, j, k): (high[0] if i else low[0], high[1] if j else low[1], high[2] if k else low[2])
        for i in (0, 1)
        for j in (0, 1)
        for k in (0, 1)
    }
    faces = [
        [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)],
        [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)],
        [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)],
        [(0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)],
        [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)],
        [(1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1)],
    ]
    lines = [f"solid {name}"]
    for a, b, c, d in faces:
        for triangle in ((a, b, c), (a, c, d)):
            vertices = [f"      vertex {' '.join(f'{v:.6e}' for v in corner[p])}" for p in triangle]
            lines += ["  facet normal 0 0 0", "    outer loop", *vertices, "    endloop", "  endfacet"]
    return "\n".join([*lines, f"endsolid {name}"]) + "\n"


def _sled_vehicle(folder: Path, mesh: str | bytes | None = None, mesh_name: str = "meshes/sled.stl") -> Path:
    """The default airframe on a green sled: two runners 24 cm long, 13 cm below base_link, one ASCII
    STL for both its look and its collision shape, as a CAD export gives it."""
    if mesh is None:
        mesh = _box_ascii_stl((-0.12, 0.04, -0.13), (0.12, 0.07, -0.11))
        mesh += _box_ascii_stl((-0.12, -0.07, -0.13), (0.12, -0.04, -0.11))
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    path = folder / mesh_name
    path.write_bytes(mesh.encode() if isinstance(mesh, str) else mesh)
    part = (
        f'<visual><geometry><mesh filename="{mesh_name}"/></geometry>'
        '<material name="sled_green"><color rgba="0.1 0.9 0.1 1"/></material></visual>'
        f'<collision><geometry><mesh filename="{mesh_name}"/></geometry></collision><visual>'
    )
    urdf = folder / "sled.urdf"
    urdf.write_text(DEFAULT_URDF.read_text().replace("<visual>", part, 1))
    urdf.with_suffix(".params.toml").write_text(DEFAULT_URDF.with_suffix(".params.toml").read_text())
    return urdf


def test_an_ascii_stl_part_is_in_the_physics_and_in_the_cameras(tmp_path: Path) -> None:
    """PyBullet reads binary STL only: the sled was missing from the physics (the vehicle rested on
    its skids, base_link 5 cm up) and from the floor camera. Now it stands on the runners (13 cm)
    and the floor camera, rendered in a worker process as runs render, sees them left and right."""
    import cv2
    import numpy as np

    from quadsim import SimConfig, Simulator
    from quadsim.sim.cameras import CameraMode, Cameras

    urdf = _sled_vehicle(tmp_path / "vehicle")
    with Simulator(SimConfig(urdf=urdf)) as sim, Cameras(sim, mode=CameraMode.PIPELINED, render_workers=1) as cams:
        sim.run_for(0.5)
        cams.wait()
        rest_z = sim.state.position_m[2]
        touching = sim.physics.contacts()
        floor = cams.latest("floor")
    assert rest_z == pytest.approx(0.13, abs=0.005)
    assert [(c.other, round(c.normal_z, 3)) for c in touching] == [("floor", 1.0)]
    assert floor is not None and floor.rgb is not None
    rgb = floor.rgb.astype(int)
    green = (rgb[..., 1] > rgb[..., 0] + 60) & (rgb[..., 1] > rgb[..., 2] + 60)
    cv2.imwrite(str(tmp_path / "floor.png"), cv2.cvtColor(floor.rgb, cv2.COLOR_RGB2BGR))  # to look at
    width = green.shape[1]
    assert green[:, : width // 5].all() and green[:, -width // 5 :].all()  # a runner each side
    assert green[:, width // 3 : 2 * width // 3].mean() == 0.0  # the floor between them
    assert np.all(green.any(axis=1))  # along the whole image: 24 cm of runner


@pytest.mark.parametrize(
    ("mesh", "name", "said"),
    [
        (
            "solid sled\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n"
            "    endloop\n  endfacet\nendsolid sled\n",
            "meshes/sled.stl",
            "line 7: a facet with 2 vertices",
        ),
        (
            "solid sled\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 zero\n",
            "meshes/sled.stl",
            "line 4: a vertex needs three numbers",
        ),
        (
            "solid sled\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 nan\n",
            "meshes/sled.stl",
            "line 4: a vertex that is not a finite number",
        ),
        ("solid sled\n" + "x" * 5000 + "\n", "meshes/sled.stl", "line 2 is longer than 1024 bytes"),
        ("solid sled\nendsolid sled\n", "meshes/sled.stl", "not an ASCII STL with whole facets"),
        (b"\x00" * 84 + b"\x01" * 20, "meshes/sled.stl", "not an STL PyBullet can read"),  # a binary STL cut short
        (b"ply\nformat ascii 1.0\n", "meshes/sled.ply", "PyBullet loads STL, OBJ and COLLADA (.dae) meshes, not .ply"),
    ],
    ids=["two-vertices", "not-a-number", "nan", "long-line", "no-facets", "cut-short", "ply"],
)
def test_a_mesh_pybullet_cannot_load_is_refused_in_one_line_naming_it(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, mesh: str | bytes, name: str, said: str
) -> None:
    urdf = _sled_vehicle(tmp_path / "vehicle", mesh, name)
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--urdf", str(urdf), "--no-record", "--cameras", "none")
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("quadsim: error: ") and said in lines[0] and Path(name).name in lines[0], lines[0]


def test_a_huge_stl_is_refused_before_it_is_read(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """Sizes are read from the file system (sparse files here): nothing of them is read."""
    from quadsim.vehicle import meshes

    urdf = _sled_vehicle(tmp_path / "ascii")
    with (tmp_path / "ascii" / "meshes" / "sled.stl").open("r+b") as fh:
        fh.truncate(meshes.MAX_ASCII_STL_BYTES + 8 * 2**20)  # "solid ..." then zeros
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--urdf", str(urdf), "--no-record", "--cameras", "none")
    assert code == 2 and err.count("\n") == 1 and "an ASCII STL of 40.0 MiB, more than the 32 MiB" in err, err
    triangles = meshes.MAX_STL_TRIANGLES + 1
    binary = tmp_path / "binary"
    urdf = _sled_vehicle(binary, b"huge".ljust(80, b" ") + struct.pack("<I", triangles))
    with (binary / "meshes" / "sled.stl").open("r+b") as fh:
        fh.truncate(84 + 50 * triangles)
    code, _, err = run_cli(capsys, "run", "--script", "hover", "--urdf", str(urdf), "--no-record", "--cameras", "none")
    assert code == 2 and err.count("\n") == 1 and f"{triangles} triangles, more than the" in err, err
