"""Depth and segmentation images as the recording contract carries them: REP 118's depth encodings,
segmentation label ids and their legend, and the way back from a message's bytes to an array.

Depth is the distance along the optical axis (z of the optical frame), as REP 118 has it:
- `32FC1`: metres, float32; +inf where nothing was drawn (beyond the far clip: no return), NaN
  for an invalid pixel (the renderer gives none);
- `16UC1`: millimetres, uint16; 0 where there is no depth (nothing drawn, or beyond 65.535 m).

A segmentation image holds one label id per pixel: 0 where nothing was drawn (the sky), then the
floor, each landmark of the world file in its order, and each vehicle of the run in its order
(`segment_names` is the legend). `mono8` while there are at most 256 labels, else `16UC1`.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import numpy as np

from quadsim.physics.world_spec import WorldSpec

#: the label of a pixel where nothing was drawn
NOTHING = "nothing"
#: the name of a vehicle flying alone (it has no name of its own) in the legend
ALONE = "vehicle"
#: the largest depth a 16UC1 pixel holds, in mm
MAX_16UC1_MM = 65535
#: the largest image a message may describe when read back (hostile files): 4096 x 4096 x 4 bytes
MAX_IMAGE_BYTES = 4096 * 4096 * 4
#: the depth colour map's scale (depth_colour_mapped): turbo on a log scale, red at NEAR, blue at FAR
COLORMAP_NEAR_M = 0.2
COLORMAP_FAR_M = 50.0
#: the pixel type of each image encoding the contract uses (NumPy's, its byte order the message's)
PIXEL_TYPES = {"32FC1": "f4", "16UC1": "u2", "mono8": "u1"}


def depth_image(depth_m: np.ndarray, encoding: str) -> np.ndarray:
    """Depth in metres (float32, inf where nothing was drawn) as a contract image's pixels."""
    if encoding == "32FC1":
        return depth_m.astype(np.float32, copy=False)
    if encoding != "16UC1":
        raise ValueError(f"no depth encoding {encoding!r}")
    with np.errstate(invalid="ignore", over="ignore"):
        mm = np.rint(depth_m * np.float32(1000.0))
    mm[~(mm <= MAX_16UC1_MM)] = 0  # inf, NaN and beyond the range: no depth
    return mm.astype(np.uint16)


def depth_metres_from_image(pixels: np.ndarray, encoding: str) -> np.ndarray:
    """A depth image's pixels back to metres (float32; inf where it holds no depth)."""
    if encoding == "32FC1":
        return pixels.astype(np.float32, copy=False)
    metres = pixels.astype(np.float32) / np.float32(1000.0)
    metres[pixels == 0] = np.inf
    return metres


def segment_names(world: WorldSpec, vehicles: Sequence[str]) -> tuple[str, ...]:
    """The legend: label id i is the body named names[i] (the vehicles by name, in run order)."""
    return (NOTHING, "floor", *(lm.name for lm in world.landmarks), *(name or ALONE for name in vehicles))


def label_encoding(count: int) -> str:
    """The image encoding of `count` labels."""
    return "mono8" if count <= 256 else "16UC1"


class LabelMap:
    """PyBullet body ids -> label ids: the bodies given in label order (the floor, the landmarks,
    the vehicles), label 1 first."""

    def __init__(self, bodies_in_label_order: Sequence[int]) -> None:
        count = len(bodies_in_label_order) + 1
        dtype = np.uint8 if label_encoding(count) == "mono8" else np.uint16
        # index 0 is the mask's -1 (nothing drawn): the lookup is indexed by body id + 1
        lookup = np.zeros(max(bodies_in_label_order, default=0) + 2, dtype)
        for label, body in enumerate(bodies_in_label_order, start=1):
            lookup[body + 1] = label
        self._lookup = lookup

    def apply(self, mask: np.ndarray) -> np.ndarray:
        """A segmentation mask (PyBullet body ids, -1 for none) as label ids; a body it does not
        know (none in a scene quadsim built) is 0."""
        index = mask + 1
        index[(index < 0) | (index >= len(self._lookup))] = 0
        return self._lookup[index]


def image_pixels(encoding: str, height: int, width: int, step: int, is_bigendian: bool, data: bytes) -> np.ndarray:
    """A sensor_msgs/msg/Image's data as a height x width array (one channel, native byte order),
    checked against its fields; ValueError for an encoding the contract does not use, or a size
    that does not add up (a damaged or hostile file)."""
    kind = PIXEL_TYPES.get(encoding)
    if kind is None:
        raise ValueError(f"image encoding {encoding!r:.20} is not one quadsim reads (32FC1, 16UC1, mono8)")
    dtype = np.dtype(("<" if not is_bigendian else ">") + kind)
    size = dtype.itemsize
    if not (0 < height <= 4096 and 0 < width <= 4096) or step < width * size or step * height > MAX_IMAGE_BYTES:
        raise ValueError(f"image of {width}x{height} pixels, step {step}: not a size quadsim reads")
    if len(data) < step * height:
        raise ValueError(f"image of {width}x{height} pixels, step {step}: {len(data)} bytes of data")
    rows = np.frombuffer(data, np.uint8, step * height).reshape(height, step)[:, : width * size]
    return np.ascontiguousarray(rows).view(dtype).reshape(height, width).astype(dtype.newbyteorder("="))


def depth_colormap_jpeg(pixels: np.ndarray, encoding: str, quality: int) -> bytes:
    """A depth image's pixels (in its contract `encoding`) colour-mapped for people
    (`depth_colormap_rgb`) as a JPEG of `quality`."""
    from quadsim.sensors.rendering import encode_jpeg

    return encode_jpeg(depth_colormap_rgb(pixels, encoding), quality)


def depth_colormap_rgb(pixels: np.ndarray, encoding: str) -> np.ndarray:
    """A depth image's pixels (in its contract `encoding`) as `depth_colour_mapped` shows them
    (turbo, log scale 0.2 m to 50 m, black where there is no depth). 16UC1 takes each pixel's
    colour from a table of every millimetre: the same colours, in a sixth of the time."""
    if encoding != "16UC1":
        return depth_colour_mapped(depth_metres_from_image(pixels, encoding))
    import cv2

    rgba = _colour_of_each_mm()[pixels].view(np.uint8).reshape(*pixels.shape, 4)
    return cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)


@cache
def _colour_of_each_mm() -> np.ndarray:
    """depth_colour_mapped of every 16UC1 value, one RGBA colour packed in a uint32 each."""
    mm = np.arange(MAX_16UC1_MM + 1, dtype=np.uint16).reshape(1, -1)
    rgba = np.zeros((MAX_16UC1_MM + 1, 4), np.uint8)
    rgba[:, :3] = depth_colour_mapped(depth_metres_from_image(mm, "16UC1"))[0]
    return rgba.view(np.uint32).ravel()


def depth_colour_mapped(
    depth_m: np.ndarray, near_m: float = COLORMAP_NEAR_M, far_m: float = COLORMAP_FAR_M
) -> np.ndarray:
    """Depth in metres as an RGB image for people (height x width x 3 uint8): the turbo colour
    map on a log scale, red near `near_m`, blue toward `far_m`; black where there is no depth."""
    import cv2  # only the viewers need it

    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.log(np.clip(depth_m, near_m, far_m) / near_m) / np.log(far_m / near_m)
    index = (255.0 - np.nan_to_num(scale, nan=1.0) * 255.0).astype(np.uint8)
    rgb = cv2.cvtColor(cv2.applyColorMap(index, cv2.COLORMAP_TURBO), cv2.COLOR_BGR2RGB)
    rgb[~np.isfinite(depth_m)] = 0
    return rgb
