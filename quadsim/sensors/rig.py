"""A camera rig: renders the onboard cameras for a body pose, in one client, into what was asked
(JPEG, RGB array, depth in metres, segmentation: ImageKind).

Used in-process (rendering in the physics client) and inside each render worker process (in a
client of its own holding the same scene).
"""

from __future__ import annotations

import numpy as np

from quadsim.errors import ConfigError
from quadsim.physics.client import WorldClient
from quadsim.physics.pybullet_quiet import c_output_silenced, pb
from quadsim.physics.scene import build_world, load_vehicle_body
from quadsim.physics.world_spec import WorldSpec
from quadsim.sensors.camera import CameraFrame, CameraSpec, ImageKind, RendererKind, camera_pose
from quadsim.sensors.images import LabelMap, depth_colormap_jpeg, depth_image
from quadsim.sensors.rendering import (
    Atmosphere,
    depth_metres,
    enable_egl,
    encode_jpeg,
    is_blank,
    projection_matrix,
    render_raw,
)
from quadsim.vehicle.params import VehicleParams

#: what a frame carries unless asked otherwise: what recordings and the window need
JPEG_ONLY = frozenset({ImageKind.JPEG})


class CameraRig:
    def __init__(
        self,
        vehicle: VehicleParams,
        specs: tuple[CameraSpec, ...],
        renderer: RendererKind,
        cid: int,
        body_id: int | None,
        companion_ids: tuple[int, ...] = (),
        scene: WorldClient | None = None,
        labelled_bodies: tuple[int, ...] = (),
    ) -> None:
        """Render in client `cid`. With `body_id`, the rig moves that body to each pose it is
        given (a client of its own), and the `companion_ids` (a fleet's other vehicles) to theirs;
        without, the bodies are where physics put them: `scene`, the physics world's client, is
        asked to pose them before each render (quadsim.physics.client.WorldClient.posed).
        `labelled_bodies`: the body ids in segmentation label order (quadsim.sensors.images; with
        `scene`, its bodies in the order they were made)."""
        self.specs = {s.name: s for s in specs}
        self._mounts = {s.name: vehicle.camera_mount(s.link_name) for s in specs}
        self._projections = {s.name: projection_matrix(s) for s in specs}
        self._atmospheres = {s.name: Atmosphere(s) for s in specs}
        # TinyRenderer always draws; a hardware/EGL renderer may silently draw nothing
        self._checked: set[str] = set(self.specs) if renderer is RendererKind.TINY else set()
        self._renderer = renderer
        self._cid = cid
        self._body = body_id
        self._companions = companion_ids
        self._scene = scene
        self._labelled = labelled_bodies
        self._labels: LabelMap | None = None

    @classmethod
    def standalone(
        cls,
        vehicle: VehicleParams,
        world: WorldSpec,
        specs: tuple[CameraSpec, ...],
        renderer: RendererKind,
        companions: tuple[VehicleParams, ...] = (),
        own_index: int = 0,
    ) -> CameraRig:
        """A rig with a DIRECT client of its own holding the world, the vehicle and its
        `companions` (a fleet's other vehicles, in the fleet's order; no physics). `own_index`:
        the vehicle's place among all of them (its segmentation label comes in that order)."""
        cid = pb.connect(pb.DIRECT)
        if renderer is RendererKind.EGL:
            enable_egl(cid)
        scenery = tuple(build_world(world, cid, collisions=False).values())
        body = load_vehicle_body(vehicle, cid, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        far = tuple(
            load_vehicle_body(v, cid, (0.0, 0.0, -100.0 - i), (0.0, 0.0, 0.0, 1.0)) for i, v in enumerate(companions)
        )
        vehicles = (*far[:own_index], body, *far[own_index:])
        return cls(vehicle, specs, renderer, cid, body, far, labelled_bodies=scenery + vehicles)

    def render(
        self,
        names: tuple[str, ...],
        step: int,
        position: tuple[float, float, float],
        orientation: tuple[float, float, float, float],
        kinds: frozenset[ImageKind] = JPEG_ONLY,
        companion_poses: tuple[tuple[tuple[float, float, float], tuple[float, float, float, float]], ...] = (),
    ) -> list[CameraFrame]:
        if self._scene is not None:
            self._scene.posed()
        if self._body is not None:
            pb.resetBasePositionAndOrientation(self._body, position, orientation, physicsClientId=self._cid)
        for companion, (at, facing) in zip(self._companions, companion_poses):
            pb.resetBasePositionAndOrientation(companion, at, facing, physicsClientId=self._cid)
        frames = []
        for name in names:
            spec = self.specs[name]
            pose = camera_pose(self._mounts[name], position, orientation)
            segmentation = spec.segmentation or ImageKind.SEGMENTATION in kinds
            rgb, depth, mask = render_raw(spec, pose, self._cid, self._renderer, self._projections[name], segmentation)
            if name not in self._checked:
                self._check_not_blank(name, rgb, depth)
            rgb = self._atmospheres[name].apply(rgb, depth, pose)
            metres = depth_metres(spec, depth) if spec.depth or ImageKind.DEPTH in kinds else None
            pixels = depth_image(metres, spec.depth) if spec.depth and metres is not None else None
            jpeg = ImageKind.JPEG in kinds  # for a recording or live viewers: the depth colour map too
            frames.append(
                CameraFrame(
                    name,
                    step,
                    encode_jpeg(rgb, spec.jpeg_quality) if jpeg else None,
                    spec.width_px,
                    spec.height_px,
                    rgb if ImageKind.RGB in kinds else None,
                    metres if ImageKind.DEPTH in kinds else None,
                    mask if ImageKind.SEGMENTATION in kinds else None,
                    pixels,
                    self._label_map().apply(mask) if spec.segmentation and mask is not None else None,
                    depth_colormap_jpeg(pixels, spec.depth, spec.jpeg_quality)
                    if jpeg and spec.depth_colormap and pixels is not None
                    else None,
                )
            )
        return frames

    def _label_map(self) -> LabelMap:
        """Body ids -> segmentation labels, made at the first segmented frame (the scene's
        vehicles are all there by then)."""
        if self._labels is None:
            bodies = self._labelled or (tuple(self._scene.body_names) if self._scene is not None else ())
            self._labels = LabelMap(bodies)
        return self._labels

    def _check_not_blank(self, name: str, rgb: np.ndarray, depth: np.ndarray) -> None:
        """A renderer that draws nothing (an EGL driver that is not really there) leaves one flat
        colour and no depth; refuse it rather than record blank frames. The first frame of each
        camera is checked, before the sky is painted in (at the start pose a camera sees the
        floor, so a real image always has depth somewhere)."""
        self._checked.add(name)
        if is_blank(rgb, depth):
            raise ConfigError(
                f"the {self._renderer.value} renderer drew nothing in the {name} camera image "
                f"(no EGL driver that can render here?): use --renderer tiny"
            )

    def close(self) -> None:
        if self._body is not None:  # the client is ours
            with c_output_silenced():  # the EGL plugin says goodbye on stdout
                pb.disconnect(physicsClientId=self._cid)
