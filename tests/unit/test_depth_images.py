"""Depth and segmentation images as the contract carries them (quadsim.sensors.images): REP 118's
conventions for each encoding, label ids, reading a message's pixels back (bounded), and the
choice of images per camera as the command line and fleet files give it."""

import numpy as np
import pytest

from quadsim.errors import ConfigError
from quadsim.physics.world_spec import DEFAULT_WORLD, load_world
from quadsim.sensors.camera import CameraSpec, default_cameras, with_images
from quadsim.sensors.images import (
    LabelMap,
    depth_image,
    depth_metres_from_image,
    image_pixels,
    label_encoding,
    segment_names,
)

DEPTH_M = np.array([[0.05, 1.2344, 1.2346], [65.535, 65.6, np.inf]], np.float32)


def test_32fc1_is_metres_with_inf_where_nothing_was_drawn():
    pixels = depth_image(DEPTH_M, "32FC1")
    assert pixels.dtype == np.float32 and np.array_equal(pixels, DEPTH_M)
    assert np.isposinf(pixels[1, 2])  # REP 118: +inf, no return (beyond the far clip)
    assert np.array_equal(depth_metres_from_image(pixels, "32FC1"), DEPTH_M)


def test_16uc1_is_rounded_millimetres_with_0_for_no_depth():
    pixels = depth_image(DEPTH_M, "16UC1")
    assert pixels.dtype == np.uint16
    # rounded to the nearest mm; beyond 65.535 m and nothing drawn: 0, REP 118's "no depth"
    assert pixels.tolist() == [[50, 1234, 1235], [65535, 0, 0]]
    back = depth_metres_from_image(pixels, "16UC1")
    assert back[0, 1] == pytest.approx(1.234) and np.isinf(back[1, 1]) and np.isinf(back[1, 2])
    with pytest.raises(ValueError, match="no depth encoding"):
        depth_image(DEPTH_M, "8UC1")


def test_labels_name_the_floor_the_landmarks_and_each_vehicle():
    world = load_world(DEFAULT_WORLD)
    assert segment_names(world, [""]) == ("nothing", "floor", *(lm.name for lm in world.landmarks), "vehicle")
    assert segment_names(world, ["alpha", "bravo"])[-2:] == ("alpha", "bravo")
    # PyBullet body ids in label order -> label ids; -1 (nothing drawn) and unknown ids -> 0
    labels = LabelMap((3, 0, 7)).apply(np.array([[-1, 3, 0], [7, 5, 99]], np.int32))
    assert labels.dtype == np.uint8 and labels.tolist() == [[0, 1, 2], [3, 0, 0]]
    assert label_encoding(256) == "mono8" and label_encoding(257) == "16UC1"
    assert LabelMap(tuple(range(300))).apply(np.array([[299]], np.int32)).tolist() == [[300]]


def test_image_pixels_reads_rows_with_padding_in_either_byte_order():
    values = np.array([[1.5, -2.0], [np.inf, 0.25]], np.float32)
    big = b"".join(row.astype(">f4").tobytes() + b"\0\0\0\0" for row in values)  # step 12: padded rows
    assert np.array_equal(image_pixels("32FC1", 2, 2, 12, True, big), values)
    little = np.array([[1, 65535]], np.uint16).tobytes()
    assert image_pixels("16UC1", 1, 2, 4, False, little).tolist() == [[1, 65535]]


@pytest.mark.parametrize(
    ("encoding", "height", "width", "step", "data", "says"),
    [
        ("rgb8", 1, 1, 3, b"abc", "not one quadsim reads"),
        ("mono8", 1, 4, 2, b"ab", "step 2"),  # a step shorter than a row
        ("mono8", 100_000, 1, 1, b"a", "not a size"),  # hostile: would be a huge array
        ("16UC1", 2, 2, 4, b"abcd", "4 bytes of data"),  # cut short
    ],
)
def test_image_pixels_refuses_what_does_not_add_up(encoding, height, width, step, data, says):
    with pytest.raises(ValueError, match=says):
        image_pixels(encoding, height, width, step, False, data)


def test_images_are_chosen_per_camera_by_name_with_an_optional_encoding():
    front, floor = default_cameras()
    where = ("--camera-depth", "--camera-segmentation", "--camera-depth-colormap")
    chosen = with_images((front, floor), ["front", "floor:32FC1"], ["front"], ["floor"], where)
    assert [(s.depth, s.segmentation, s.depth_colormap) for s in chosen] == [
        ("16UC1", True, False),
        ("32FC1", False, True),
    ]
    assert with_images((front,), [], [], [], where) == (front,)
    for depth, segmentation, colormap, says in [
        (["rear"], [], [], "--camera-depth: 'rear' is not a camera of this run \\(front\\)"),
        (["front:8UC1"], [], [], "depth encoding '8UC1': choose 32FC1 or 16UC1"),
        (["front", "front:32FC1"], [], [], "front is named twice"),
        ([], ["front:mono8"], [], "--camera-segmentation: 'front:mono8': a segmentation image has no encoding"),
        (
            [],
            [],
            ["front"],
            "--camera-depth-colormap: front has no depth image to colour-map \\(name it in --camera-depth",
        ),
        (["front"], [], ["front:jet"], "--camera-depth-colormap: 'front:jet': a depth colormap image has no encoding"),
    ]:
        with pytest.raises(ConfigError, match=says):
            with_images((front,), depth, segmentation, colormap, where)
    with pytest.raises(ConfigError, match="depth encoding"):
        CameraSpec("front", "front_camera_link", depth="32FC2")
    with pytest.raises(ConfigError, match="camera front: a depth colour map needs the camera's depth image"):
        CameraSpec("front", "front_camera_link", depth_colormap=True)


def test_16uc1_depth_is_colour_mapped_from_a_table_with_the_very_colours_of_the_map():
    from quadsim.sensors.images import depth_colormap_rgb, depth_colour_mapped

    mm = np.array([[0, 1, 200, 1234, 5500], [20_000, 50_000, 50_001, 65_535, 7]], np.uint16)
    rgb = depth_colormap_rgb(mm, "16UC1")
    assert rgb.shape == (2, 5, 3) and rgb.flags.c_contiguous
    assert np.array_equal(rgb, depth_colour_mapped(depth_metres_from_image(mm, "16UC1")))
    assert rgb[0, 0].tolist() == [0, 0, 0]  # no depth: black
    metres = depth_metres_from_image(mm, "16UC1")
    assert np.array_equal(depth_colormap_rgb(metres, "32FC1"), rgb)


def test_the_command_line_names_the_cameras_whose_depth_is_colour_mapped():
    from argparse import Namespace

    from quadsim.apps.options import camera_images

    def chosen(depth, colormap):
        args = Namespace(camera_depth=depth, camera_segmentation=None, camera_depth_colormap=colormap)
        return [(s.depth, s.depth_colormap) for s in camera_images(args, default_cameras())]

    assert chosen("front:32FC1,floor", " front ") == [("32FC1", True), ("16UC1", False)]
    with pytest.raises(ConfigError) as refused:
        chosen("front", "front,floor")
    assert str(refused.value) == (
        "--camera-depth-colormap: floor has no depth image to colour-map (name it in --camera-depth too)"
    )


def test_the_depth_colour_map_is_a_jpeg_of_the_same_frame_in_turbo_with_its_stamp_and_frame():
    """--camera-depth-colormap: the depth image's frame colour-mapped (turbo, log 0.2-50 m) as a
    JPEG at the camera's quality on .../depth/colormap/compressed, stamped and framed as the
    depth image; made in the fan-out unless the render worker made it already."""
    from quadsim.recording.contract import typestore
    from quadsim.recording.fanout import TopicFanout
    from quadsim.sensors.camera import CameraFrame
    from quadsim.sensors.images import depth_colour_mapped
    from quadsim.sensors.rendering import decode_jpeg
    from quadsim.vehicle.params import CameraMount

    class Consumer:
        def __init__(self) -> None:
            self.messages: list = []

        def add_topic(self, topic) -> None:
            pass

        def on_messages(self, messages) -> None:
            self.messages += messages

        def on_event(self, *args) -> None:
            pass

    spec = CameraSpec("front", "front_camera_link", 64, 48, depth="16UC1", depth_colormap=True, jpeg_quality=90)
    mount = CameraMount("front_camera_link", (0.1, 0.0, 0.0), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
    fanout, consumer = TopicFanout(240), Consumer()
    producer = fanout.add_vehicle(cameras=[(spec, mount)])
    fanout.add_consumer(consumer)
    consumer.messages.clear()
    mm = np.full((48, 64), 20_000, np.uint16)  # 20 m away, with a tower 1.5 m away in the middle
    mm[12:36, 16:48] = 1500
    mm[:4] = 0  # no depth at the top: black
    producer.on_camera_frame(CameraFrame("front", 24, b"\xff\xd8rgb", 64, 48, depth_pixels=mm))
    producer.on_camera_frame(
        CameraFrame("front", 48, b"\xff\xd8rgb", 64, 48, depth_pixels=mm, depth_colormap_jpeg=b"w")
    )
    names = [topic.name for topic, _, _ in consumer.messages]
    colormap = "/quad/front_camera/depth/colormap/compressed"
    assert (
        names[:4]
        == [
            "/quad/front_camera/image_raw/compressed",
            "/quad/front_camera/camera_info",
            "/quad/front_camera/depth/image_raw",
            "/quad/front_camera/depth/camera_info",
        ]
        and names[4] == colormap
    )
    (topic, ns, data), depth = consumer.messages[4], consumer.messages[2]
    assert topic.type_name == "sensor_msgs/msg/CompressedImage" and ns == depth[1] == 100_000_000
    message = typestore().deserialize_cdr(data, topic.type_name)
    depth_message = typestore().deserialize_cdr(depth[2], "sensor_msgs/msg/Image")
    assert message.format == "jpeg" and message.header == depth_message.header
    assert message.header.frame_id == "front_camera_optical"
    rgb = decode_jpeg(bytes(message.data)).astype(int)
    expected = depth_colour_mapped(np.array([[1.5, 20.0]], np.float32)).astype(int)
    assert np.abs(rgb[24, 32] - expected[0, 0]).max() <= 12  # the tower: its turbo colour, within JPEG's error
    assert np.abs(rgb[44, 4] - expected[0, 1]).max() <= 12  # beyond it
    assert rgb[1, 32].max() <= 12  # no depth: black
    assert bytes(typestore().deserialize_cdr(consumer.messages[-1][2], topic.type_name).data) == b"w"  # the worker's
