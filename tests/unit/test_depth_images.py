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
    where = ("--camera-depth", "--camera-segmentation")
    chosen = with_images((front, floor), ["front", "floor:32FC1"], ["front"], where)
    assert [(s.depth, s.segmentation) for s in chosen] == [("16UC1", True), ("32FC1", False)]
    assert with_images((front,), [], [], where) == (front,)
    for depth, segmentation, says in [
        (["rear"], [], "--camera-depth: 'rear' is not a camera of this run \\(front\\)"),
        (["front:8UC1"], [], "depth encoding '8UC1': choose 32FC1 or 16UC1"),
        (["front", "front:32FC1"], [], "front is named twice"),
        ([], ["front:mono8"], "--camera-segmentation: 'front:mono8': a segmentation image has no encoding"),
    ]:
        with pytest.raises(ConfigError, match=says):
            with_images((front,), depth, segmentation, where)
    with pytest.raises(ConfigError, match="depth encoding"):
        CameraSpec("front", "front_camera_link", depth="32FC2")
