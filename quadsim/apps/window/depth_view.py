"""The cameras' depth images in the flying window: colour-mapped in place of their images, on request (V)."""

from __future__ import annotations

import numpy as np

from quadsim.sensors.camera import CameraFrame
from quadsim.sensors.images import depth_colormap_rgb

#: what a camera's depth images are called among the frames the view draws (its cache is by name)
SUFFIX = "_depth"


class DepthView:
    """Swaps each frame that carries its camera's depth (a camera with --camera-depth) for that
    depth colour-mapped, while `shown`; each frame is colour-mapped once, however often drawn."""

    def __init__(self) -> None:
        self.shown = False
        #: by camera: the frame last mapped (compared by identity: in a fleet, C shows another
        #: vehicle's frame of the same camera and step) and what it was mapped to
        self._mapped: dict[str, tuple[CameraFrame, CameraFrame]] = {}

    def frames(self, frames: dict[str, CameraFrame]) -> dict[str, CameraFrame]:
        """`frames` as the window shows them: by camera, each one's depth where shown and there."""
        if not self.shown:
            return frames
        out = {}
        for camera, frame in frames.items():
            pixels = frame.depth_pixels
            if pixels is None:
                out[camera] = frame
                continue
            kept = self._mapped.get(camera)
            if kept is None or kept[0] is not frame:
                rgb = depth_colormap_rgb(pixels, "16UC1" if pixels.dtype == np.uint16 else "32FC1")
                kept = (frame, CameraFrame(camera + SUFFIX, frame.step, None, frame.width_px, frame.height_px, rgb))
                self._mapped[camera] = kept
            out[camera] = kept[1]
        return out
