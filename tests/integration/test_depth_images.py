"""A recorded run with depth and segmentation images (their conventions alone:
tests/unit/test_depth_images.py): every new message decodes with rosbags and mcap-ros2-support,
the depth is the known distance to the red tower and to the floor, its colour map shows that
depth in turbo, the labels name the tower's pixels, a render worker gives the bytes this process
gives, and `check` re-flies the run."""

import json

import numpy as np
import pygame
import pytest
from rosbags.typesys import Stores, get_typestore

from quadsim import Cameras, SimConfig, Simulator, Twist, ZMode, record
from quadsim.apps.replay_export import mp4_paths
from quadsim.apps.window.replay import ReplayApp
from quadsim.apps.window.teleop import TeleopOptions
from quadsim.recording.flight import load_flight
from quadsim.recording.info import read_info
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.images import depth_colour_mapped, depth_metres_from_image, image_pixels
from quadsim.sensors.rendering import decode_jpeg
from quadsim.session.resim import resimulate
from tests.helpers.mcap import decoded_recording
from tests.helpers.recording import record_flight
from tests.integration.test_cli import cli
from tests.integration.test_teleop import key, make_app, run_with

HOVER = "z_mode height\n2.5 linear.z=0\n"  # climbs to 2 m and holds
FRONT = CameraSpec(
    "front", "front_camera_link", 160, 120, rate_hz=10, depth="32FC1", segmentation=True, depth_colormap=True
)
FLOOR = CameraSpec("floor", "floor_camera_link", 160, 120, rate_hz=10, near_m=0.01, depth="16UC1")
NEW_TOPICS = {
    "/quad/front_camera/depth/image_raw": "sensor_msgs/msg/Image",
    "/quad/front_camera/depth/camera_info": "sensor_msgs/msg/CameraInfo",
    "/quad/front_camera/depth/colormap/compressed": "sensor_msgs/msg/CompressedImage",
    "/quad/front_camera/segmentation/image_raw": "sensor_msgs/msg/Image",
    "/quad/floor_camera/depth/image_raw": "sensor_msgs/msg/Image",
    "/quad/floor_camera/depth/camera_info": "sensor_msgs/msg/CameraInfo",
    "/world/segmentation_labels": "std_msgs/msg/String",
}
#: the red tower's face toward the start, and the cameras' places on the body (quadsim_x.urdf)
TOWER_FACE_X_M, FRONT_CAMERA_X_M, FLOOR_CAMERA_Z_M = 5.6, 0.108, -0.034


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("depth")
    paths = {workers: folder / f"workers{workers}.mcap" for workers in (0, 1)}
    for workers, path in paths.items():
        record_flight(path, workers=workers, cameras=(FRONT, FLOOR), script=HOVER)
    return paths


def _pixels(msg) -> np.ndarray:
    return image_pixels(msg.encoding, msg.height, msg.width, msg.step, bool(msg.is_bigendian), bytes(msg.data))


def test_every_new_message_decodes_with_both_readers_on_the_cameras_frame(recorded):
    topics, _, _ = decoded_recording(recorded[0])  # mcap-ros2-support
    for topic in NEW_TOPICS:
        assert topics.get(topic), topic
    assert len(topics["/quad/front_camera/depth/image_raw"]) == len(topics["/quad/front_camera/image_raw/compressed"])
    colormap = topics["/quad/front_camera/depth/colormap/compressed"]
    assert [ns for ns, _ in colormap] == [ns for ns, _ in topics["/quad/front_camera/depth/image_raw"]]
    for topic in (t for t, type_name in NEW_TOPICS.items() if type_name.endswith("Image")):
        for ns, msg in topics[topic]:
            assert msg.header.frame_id == topic.split("/")[2] + "_optical"  # front_camera_optical
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == ns
            if topic.endswith("/compressed"):
                assert msg.format == "jpeg" and decode_jpeg(bytes(msg.data)).shape == (120, 160, 3)
            else:
                assert (msg.width, msg.height, msg.is_bigendian) == (160, 120, 0)
    encodings = {t: topics[t][0][1].encoding for t in NEW_TOPICS if t.endswith("image_raw")}
    assert encodings == {
        "/quad/front_camera/depth/image_raw": "32FC1",
        "/quad/front_camera/segmentation/image_raw": "mono8",
        "/quad/floor_camera/depth/image_raw": "16UC1",
    }
    _, info = topics["/quad/front_camera/depth/camera_info"][0]
    assert tuple(info.k) == pytest.approx(FRONT.k_matrix()) and info.header.frame_id == "front_camera_optical"
    # rosbags reads the same bytes as a ROS 2 node would
    from rosbags.highlevel import AnyReader

    with AnyReader([recorded[0]], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        wanted = [c for c in reader.connections if c.topic in NEW_TOPICS]
        assert {c.topic: c.msgtype for c in wanted} == NEW_TOPICS
        counts = dict.fromkeys(NEW_TOPICS, 0)
        for connection, _, raw in reader.messages(connections=wanted):
            msg = reader.deserialize(raw, connection.msgtype)
            counts[connection.topic] += 1
            if connection.msgtype == "sensor_msgs/msg/Image":
                assert _pixels(msg).shape == (120, 160)
    assert counts == {t: len(topics[t]) for t in NEW_TOPICS}


def test_depth_is_the_distance_to_the_tower_and_to_the_floor(recorded):
    topics, _, _ = decoded_recording(recorded[0])
    poses = dict(topics["/quad/pose"])
    ns, front = topics["/quad/front_camera/depth/image_raw"][-1]
    x_m = poses[ns].pose.position.x
    depth = depth_metres_from_image(_pixels(front), front.encoding)
    centre = depth[59:61, 79:81]  # the four pixels about the optical axis
    assert centre == pytest.approx(TOWER_FACE_X_M - FRONT_CAMERA_X_M - x_m, abs=0.02)
    assert np.isposinf(depth[0]).all()  # the sky: no return, +inf (REP 118)
    ns, floor = topics["/quad/floor_camera/depth/image_raw"][-1]
    z_m = poses[ns].pose.position.z
    assert z_m > 1.9  # hovering
    below = depth_metres_from_image(_pixels(floor), "16UC1")[59:61, 79:81]
    assert below == pytest.approx(z_m + FLOOR_CAMERA_Z_M, abs=0.01)


def test_the_depth_colour_map_shows_the_recorded_depth_in_turbo(recorded):
    """The colour map of a frame is depth_colour_mapped of that frame's depth: at the tower (red,
    near), on the floor below it, and black in the sky (no depth), within JPEG's error."""
    topics, _, _ = decoded_recording(recorded[0])
    ns, depth_msg = topics["/quad/front_camera/depth/image_raw"][-1]
    colormap_ns, colormap = topics["/quad/front_camera/depth/colormap/compressed"][-1]
    assert colormap_ns == ns
    expected = depth_colour_mapped(depth_metres_from_image(_pixels(depth_msg), "32FC1")).astype(int)
    shown = decode_jpeg(bytes(colormap.data)).astype(int)
    for row, column in ((60, 80), (110, 20)):  # the tower; the floor in front of the vehicle
        assert np.abs(shown[row, column] - expected[row, column]).max() <= 16, (row, column)
    red, green, blue = shown[60, 80]
    assert green > 200 and green > red and green > blue  # the tower, 5.4 m away: turbo's green
    assert shown[67, 20, 2] > shown[115, 20, 2] + 60  # the floor toward the horizon: bluer (farther)
    assert shown[:10].max() <= 16  # the sky: black


def test_the_layout_of_a_recording_with_a_depth_colour_map_shows_it_beside_its_camera(recorded, tmp_path):
    done = cli("layout", str(recorded[0]), "-o", str(tmp_path / "depth.json"))
    assert done.returncode == 0, done.stderr
    panels = json.loads((tmp_path / "depth.json").read_text())["configById"]
    images = [config for panel, config in panels.items() if panel.startswith("ImageViewPanel!")]
    assert [p["cameraTopic"] for p in images] == [
        "/quad/front_camera/image_raw/compressed",
        "/quad/front_camera/depth/colormap/compressed",
        "/quad/floor_camera/image_raw/compressed",  # its depth is not colour-mapped: Studio 1.x shows it grey
    ]
    assert images[1]["foxglovePanelTitle"] == "front depth (turbo, log 0.2-50 m, black: none)"
    assert "foxglovePanelTitle" not in images[0]


def test_the_legend_names_the_towers_pixels(recorded):
    topics, _, _ = decoded_recording(recorded[0])
    (_, legend_msg), *more = topics["/world/segmentation_labels"]
    assert not more  # latched: once
    legend = json.loads(legend_msg.data)
    assert legend[:3] == ["nothing", "floor", "red_tower"] and legend[-1] == "vehicle"
    _, seg = topics["/quad/front_camera/segmentation/image_raw"][-1]
    labels = _pixels(seg)
    _, depth_msg = topics["/quad/front_camera/depth/image_raw"][-1]
    depth = depth_metres_from_image(_pixels(depth_msg), "32FC1")
    tower = labels == legend.index("red_tower")
    assert tower[60, 80] and 150 < tower.sum() < 2000  # the middle of the image, a narrow column
    assert np.isposinf(depth[labels == 0]).all() and np.isfinite(depth[labels != 0]).all()
    assert set(np.unique(labels)) == {0, 1, legend.index("red_tower")}  # sky, floor, tower


def test_a_render_worker_gives_the_same_images(recorded):
    images = []
    for path in recorded.values():
        topics, _, _ = decoded_recording(path)
        images.append(
            {
                t: [(ns, bytes(m.data)) for ns, m in topics[t]]
                for t in NEW_TOPICS
                if "image_raw" in t or "/colormap/" in t
            }
        )
    assert images[0] == images[1]


def test_the_run_description_keeps_each_cameras_images_and_info_says_them(recorded):
    cameras = load_flight(recorded[0]).description.cameras
    assert cameras == (FRONT, FLOOR)  # read back from the metadata, field for field
    lines = read_info(recorded[0]).lines()
    assert (
        "  camera front: 160x120 @ 10 Hz, vertical FOV 60.0 deg, JPEG quality 85, depth 32FC1 colour-mapped, segmentation"
        in lines
    )
    assert "  camera floor: 160x120 @ 10 Hz, vertical FOV 60.0 deg, JPEG quality 85, depth 16UC1" in lines


def test_python_cameras_with_depth_record_it_as_the_code_saw_it(tmp_path):
    small = CameraSpec("front", "front_camera_link", 64, 48, rate_hz=30, depth="32FC1")
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim, Cameras(sim, (small,)) as cameras:
        with record(sim, tmp_path / "api.mcap", cameras):
            sim.send(Twist(linear_z=1.0))
            sim.step(80)
            seen = cameras.latest("front")
    assert seen.depth_m is not None and seen.segmentation is None  # the spec asked for depth alone
    topics, _, _ = decoded_recording(tmp_path / "api.mcap")
    assert "/quad/front_camera/segmentation/image_raw" not in topics
    ns, last = topics["/quad/front_camera/depth/image_raw"][-1]
    assert round(ns * 240 / 1e9) == seen.step == 80
    assert np.array_equal(_pixels(last), seen.depth_m)  # the very array the code got, bit for bit


def test_check_re_flies_it(recorded):
    report = resimulate(load_flight(recorded[0]), record=False)
    assert report.states_compared > 100 and report.position.max_error == 0.0 and report.attitude.max_error == 0.0


def test_replay_shows_the_depth_colour_mapped_and_v_switches_back(recorded):
    flight = load_flight(recorded[0], depth=True)
    assert {cam: len(frames) for cam, frames in flight.frames.items()} == dict.fromkeys(
        ("front", "front_depth", "floor", "floor_depth"), 25
    )
    assert set(mp4_paths(recorded[0].parent / "videos", flight)) == set(flight.frames)  # exported too
    depth = decode_jpeg(flight.frames["front_depth"][-1][1])
    assert depth[5].max() < 30  # the sky: no depth, black
    tower, floor_near = depth[60, 80].astype(int), depth[115, 80].astype(int)
    assert tower.sum() > 200 and abs(tower - floor_near).sum() > 60  # nearer is another colour
    app = ReplayApp(flight, (640, 360), frame_s=0.1)
    try:
        app.run(max_frames=30)
        assert {cam: f.camera for cam, f in app.model().frames.items()} == {
            "front": "front_depth",
            "floor": "floor_depth",
        }
        pygame.image.save(app.screen, "/tmp/quadsim_replay_depth_test.png")
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_v, mod=0, unicode="v"))
        app.run(max_frames=31)
        assert {f.camera for f in app.model().frames.values()} == {"front", "floor"}
    finally:
        app.close()
    assert set(load_flight(recorded[0]).frames) == {"front", "floor"}  # loaded only when asked for


def test_replay_depth_on_the_command_line_lists_and_exports_the_depth_streams(recorded, tmp_path):
    done = cli("replay", "--headless", "--depth", "--mp4", str(tmp_path / "videos"), str(recorded[0]))
    assert done.returncode == 0, done.stderr
    assert "camera      front_depth: 25 frames" in done.stdout and "camera      floor_depth: 25 frames" in done.stdout
    assert sorted(p.name for p in (tmp_path / "videos").iterdir()) == [
        f"workers0_{cam}.mp4" for cam in ("floor", "floor_depth", "front", "front_depth")
    ]


FLEET = """
[[vehicle]]
name = "alpha"
start = [0.0, 0.0, 0.0, 0.0]
input = "idle"
cameras = ["front"]
depth = ["front:32FC1"]
segmentation = ["front"]

[[vehicle]]
name = "bravo"
airframe = "hexa"
start = [2.0, 0.0, 0.0, 0.0]
input = "idle"
cameras = ["front", "floor"]
depth = ["floor"]
depth_colormap = ["floor"]
"""


def test_a_fleet_files_vehicles_choose_their_images_and_the_legend_names_each_vehicle(tmp_path):
    (tmp_path / "fleet.toml").write_text(FLEET)
    out = tmp_path / "fleet.mcap"
    done = cli(
        "run", "--fleet", str(tmp_path / "fleet.toml"), "--duration", "0.2", "--render-workers", "0", "--out", str(out)
    )
    assert done.returncode == 0, done.stderr
    topics, _, _ = decoded_recording(out)
    assert sorted(t for t in topics if "/depth/" in t or "segmentation" in t) == [
        "/alpha/quad/front_camera/depth/camera_info",
        "/alpha/quad/front_camera/depth/image_raw",
        "/alpha/quad/front_camera/segmentation/image_raw",
        "/bravo/quad/floor_camera/depth/camera_info",
        "/bravo/quad/floor_camera/depth/colormap/compressed",
        "/bravo/quad/floor_camera/depth/image_raw",
        "/world/segmentation_labels",
    ]
    legend = json.loads(topics["/world/segmentation_labels"][0][1].data)
    assert legend[-2:] == ["alpha", "bravo"]
    _, seg = topics["/alpha/quad/front_camera/segmentation/image_raw"][-1]
    assert seg.header.frame_id == "alpha/front_camera_optical"
    labels = _pixels(seg)
    assert (labels == legend.index("bravo")).sum() > 50  # alpha sees bravo 2 m ahead, by its name
    assert not (labels == legend.index("alpha")).any()  # and not itself
    _, depth = topics["/bravo/quad/floor_camera/depth/image_raw"][-1]
    assert depth.encoding == "16UC1" and depth.header.frame_id == "bravo/floor_camera_optical"
    done = cli("layout", str(tmp_path / "fleet.toml"))  # for its live run: the colour map too
    assert done.returncode == 0, done.stderr
    panels = json.loads((tmp_path / "fleet.layout.json").read_text())["configById"]
    assert [c["cameraTopic"] for p, c in panels.items() if p.startswith("ImageViewPanel!")] == [
        "/alpha/quad/front_camera/image_raw/compressed",
        "/bravo/quad/front_camera/image_raw/compressed",
        "/bravo/quad/floor_camera/image_raw/compressed",
        "/bravo/quad/floor_camera/depth/colormap/compressed",
    ]


def test_v_in_the_flying_window_shows_the_depth_of_the_cameras_that_have_it(tmp_path):
    front = CameraSpec("front", "front_camera_link", 160, 120, depth="16UC1")
    floor = CameraSpec("floor", "floor_camera_link", 160, 120, near_m=0.01)
    app = make_app(tmp_path, cameras=(front, floor), options=TeleopOptions(window_size=(640, 360)))
    try:
        run_with(app, 10)
        assert {cam: f.camera for cam, f in app._model().frames.items()} == {"front": "front", "floor": "floor"}
        run_with(app, 10, {0: [lambda: key(pygame.K_v)]})
        shown = app._model().frames
        assert {cam: f.camera for cam, f in shown.items()} == {"front": "front_depth", "floor": "floor"}
        depth = shown["front"].rgb
        # the sky beside the tower (landed, it reaches the top of the image): no depth, black
        assert depth.shape == (120, 160, 3) and depth[5, :40].max() == 0
        assert depth[60, 80].sum() > 200  # the tower, in colour
        pygame.image.save(app.screen, "/tmp/quadsim_fly_depth_test.png")
        run_with(app, 2, {0: [lambda: key(pygame.K_v)]})
        assert app._model().frames["front"].camera == "front"
    finally:
        app.close()
