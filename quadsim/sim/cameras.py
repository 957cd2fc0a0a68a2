"""Camera images for code: the onboard cameras of a Simulator as numpy arrays, synchronous or pipelined.

    from quadsim import Cameras, Simulator, SimConfig
    with Simulator(SimConfig()) as sim, Cameras(sim, depth=True) as cameras:
        sim.step(8)
        image = cameras.latest("front")   # CameraImage: rgb (H x W x 3 uint8), step, info, depth_m

Each camera is captured at its own rate (CameraSpec.rate_hz) after the physics step that makes
its capture step (a loop tap, as recordings do). Two modes:
- SYNC: rendered in the simulator's own PyBullet client before `step()` returns. The image of
  step n is the same every run: what tests and learning use. Costs the render time per frame on
  the stepping thread.
- PIPELINED: rendered by worker processes on the other cores while the simulation steps on;
  `latest()` gives the newest frame that has arrived, which is a few captures old (its `step`
  says which). A capture that finds every worker busy is dropped.
A recording of the run (`quadsim.record(sim, path, cameras)`) records the same frames.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from quadsim.errors import ConfigError, QuadsimError
from quadsim.sensors.camera import CameraFrame, CameraInfo, CameraSpec, ImageKind, RendererKind, default_cameras
from quadsim.sensors.images import depth_metres_from_image
from quadsim.sensors.pipeline import CameraPipeline
from quadsim.sim.simulator import Simulator


class CameraMode(enum.Enum):
    SYNC = "sync"  # rendered in the simulator's client before step() returns: deterministic
    PIPELINED = "pipelined"  # rendered by worker processes: the newest frame that has arrived


@dataclass(frozen=True)
class CameraImage:
    """One camera image, captured at simulation step `step`."""

    camera: str
    step: int
    time_s: float  # step / physics rate
    rgb: np.ndarray  # height x width x 3, uint8, row 0 at the top (the optical frame's -y)
    info: CameraInfo
    depth_m: np.ndarray | None = None  # height x width float32 along the optical axis; inf: nothing drawn
    segmentation: np.ndarray | None = None  # height x width int32: an index into Cameras.segment_names


class Cameras:
    """The onboard cameras of `sim`, as arrays. Use as a context manager, or call `close()`."""

    def __init__(
        self,
        sim: Simulator,
        specs: tuple[CameraSpec, ...] | None = None,
        mode: CameraMode = CameraMode.SYNC,
        depth: bool = False,
        segmentation: bool = False,
        renderer: RendererKind = RendererKind.TINY,
        render_workers: int = 2,
    ) -> None:
        """`specs`: which cameras and how (default: front and floor, 320x240 at 30 Hz).
        `depth`, `segmentation`: also render those. `render_workers`: worker processes in
        PIPELINED mode (at least 1)."""
        if not isinstance(mode, CameraMode):
            raise ConfigError(f"mode must be a CameraMode (SYNC or PIPELINED), got {mode!r}")
        if mode is CameraMode.PIPELINED and render_workers < 1:
            raise ConfigError("PIPELINED cameras need at least one render worker")
        self.specs = default_cameras() if specs is None else tuple(specs)
        if not self.specs:
            raise ConfigError("Cameras needs at least one camera")
        self.mode = mode
        self._sim = sim
        self._physics_hz = sim.config.rates.physics_hz
        self._infos = {spec.name: spec.camera_info() for spec in self.specs}
        self._encodings = {spec.name: spec.depth for spec in self.specs}
        self._latest: dict[str, CameraFrame] = {}
        #: what each value of a segmentation mask is: the floor, each landmark, then the vehicle
        self.segment_names: tuple[str, ...] = ("floor", *(lm.name for lm in sim.world.landmarks), "vehicle")
        self.pipeline = CameraPipeline(
            sim.vehicle,
            sim.world,
            self._physics_hz,
            self.specs,
            renderer,
            workers=0 if mode is CameraMode.SYNC else render_workers,
            ordered_delivery=False,  # the newest frame as soon as it is there
            scene_client=sim.scene_client,
            worker_niceness=0,  # code waits for these frames: no lower priority
        )
        asked = {ImageKind.RGB: True, ImageKind.DEPTH: depth, ImageKind.SEGMENTATION: segmentation}
        self.pipeline.want(*(kind for kind, wanted in asked.items() if wanted))
        self.pipeline.sinks.append(self)
        sim.add_tap(self.pipeline.tap_interval_steps, self.pipeline.capture)
        self._closed = False
        self.capture_now()

    def capture_now(self) -> None:
        """Capture every camera at the simulator's current step, due or not, and forget older
        frames (after `sim.reset()`). SYNC: the images are there when this returns."""
        self.pipeline.drain()  # frames of the steps before, in flight
        self._latest.clear()
        self.pipeline.capture_all(self._sim.state)

    def on_camera_frame(self, frame: CameraFrame) -> None:
        """The pipeline's sink: keep the newest frame of each camera."""
        kept = self._latest.get(frame.camera)
        if kept is None or frame.step >= kept.step:
            self._latest[frame.camera] = frame

    def latest(self, camera: str = "front") -> CameraImage | None:
        """The newest image of `camera` (None while a PIPELINED camera has delivered none yet)."""
        if camera not in self._infos:
            raise QuadsimError(f"no camera {camera!r}; there are: {', '.join(self._infos)}")
        if self.mode is CameraMode.PIPELINED:
            self.pipeline.poll()
        frame = self._latest.get(camera)
        if frame is None:
            return None
        if frame.rgb is None:  # pragma: no cover - the pipeline always renders RGB for us
            raise QuadsimError(f"the {camera} frame carries no RGB image")
        seg = frame.segmentation
        if seg is not None:
            seg = seg.copy()  # PyBullet's body ids: the floor first, then the landmarks, then the vehicle
            seg[seg >= len(self.segment_names)] = -1
        depth_m = frame.depth_m
        if depth_m is None and frame.depth_pixels is not None:  # the camera records depth: the same, in metres
            depth_m = depth_metres_from_image(frame.depth_pixels, self._encodings[camera])
        return CameraImage(
            frame.camera, frame.step, frame.step / self._physics_hz, frame.rgb, self._infos[camera], depth_m, seg
        )

    def wait(self) -> None:
        """PIPELINED: wait for every frame being rendered (they become the latest)."""
        self.pipeline.drain()

    def frame_age_steps(self, camera: str = "front") -> int | None:
        """How many physics steps the newest image of `camera` is behind the simulator (0 in SYNC)."""
        image = self.latest(camera)
        return None if image is None else self._sim.step_count - image.step

    @property
    def frames_dropped(self) -> int:
        """Captures skipped because every render worker was busy (PIPELINED)."""
        return sum(self.pipeline.frames_dropped.values())

    def close(self) -> None:
        """Stop capturing and stop the render workers."""
        if self._closed:
            return
        self._closed = True
        self._sim.remove_tap(self.pipeline.capture)
        self.pipeline.close()

    def __enter__(self) -> Cameras:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
