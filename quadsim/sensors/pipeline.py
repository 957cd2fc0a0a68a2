"""The camera pipeline: captures the onboard cameras at their rates and hands frames to sinks.

Two back-ends with the same output:
- in-process: render in the physics client at capture time (simple; one core);
- workers: a pool of render processes, each with its own PyBullet client holding the same
  scene, so rendering and JPEG encoding run on the other core while physics keeps stepping.
  Jobs go round-robin; results come back in capture order. With `ordered_delivery` (headless
  runs), frame j is handed on just after job j + in_flight is submitted, and the rest at the
  end, so a recording's message order does not depend on timing; in_flight is as many captures
  as fit in ORDERED_LAG_S of simulated time (at most two per worker; none for cameras slower than
  4 Hz: each frame is waited for as soon as it is asked for). Without it (the window),
  frames are handed on as soon as they are ready, and a capture that finds every worker busy
  is dropped: the person flying comes first, the cameras take what is left of the machine
  (the workers also run at a lower priority then).
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import socket
import subprocess
import sys
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Protocol

import quadsim
from quadsim.core.types import VehicleState
from quadsim.errors import ConfigError, QuadsimError
from quadsim.physics.client import WorldClient
from quadsim.physics.world_spec import WorldSpec
from quadsim.sensors.camera import CameraFrame, CameraSpec, ImageKind, RendererKind
from quadsim.sensors.rig import JPEG_ONLY, CameraRig
from quadsim.vehicle.params import VehicleParams

#: how much lower the render workers' priority is when a window is in front of a person
WINDOW_WORKER_NICENESS = 10
#: with ordered delivery, how far (simulated time) a frame may be handed on after its capture:
#: the recorder holds the run's other messages back until the frames of their time are in (to
#: write them in log-time order), so this bounds what a killed run loses on top of the open chunk
ORDERED_LAG_S = 0.25


class FrameSink(Protocol):
    def on_camera_frame(self, frame: CameraFrame) -> None:
        """A rendered frame, stamped with its capture step."""


def _exit_status(proc: subprocess.Popen) -> str:
    code = proc.poll()
    if code is None:
        return "still running"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _worker_env() -> dict[str, str]:
    """The workers import quadsim the way this process did, wherever it was found."""
    env = dict(os.environ)
    package_root = os.path.dirname(os.path.dirname(os.path.abspath(quadsim.__file__)))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    return env


@dataclass(frozen=True)
class Companions:
    """The other bodies of the scene that move (a fleet's other vehicles): their airframes, and
    where each is now (called at every capture). Render workers hold them too and put them there
    before rendering; in-process rendering in the physics client sees them already."""

    vehicles: tuple[VehicleParams, ...]
    poses: Callable[[], tuple[tuple[tuple[float, float, float], tuple[float, float, float, float]], ...]]
    #: the rendering vehicle's place in the fleet among them (segmentation labels go in fleet order)
    own_index: int = 0


class CameraAccount:
    """What one camera gave in a run: frames delivered, captures dropped, frames late (handed on
    more than LATE_S of simulation time after their capture), and the median age of the last
    frames (`median_age_s`)."""

    #: a frame handed on later than this after its capture is late (real-time runs)
    LATE_S = 0.25

    def __init__(self, physics_hz: int) -> None:
        self.physics_hz = physics_hz
        self.delivered = 0
        self.dropped = 0
        self.late = 0
        self._ages: deque[int] = deque(maxlen=1000)  # in steps, of the last frames

    def delivered_at(self, age_steps: int, late: bool) -> None:
        """A frame handed on `age_steps` after its capture (`late`: count it late if it is)."""
        self.delivered += 1
        self._ages.append(age_steps)
        if late and age_steps > self.LATE_S * self.physics_hz:
            self.late += 1

    @property
    def median_age_s(self) -> float:
        ages = sorted(self._ages)
        return ages[len(ages) // 2] / self.physics_hz if ages else 0.0


def _steps_between_frames(specs: tuple[CameraSpec, ...], physics_hz: int) -> dict[str, int]:
    """Each camera's physics steps between two frames (its rate must divide the physics rate)."""
    for spec in specs:
        if physics_hz % spec.rate_hz:
            raise ConfigError(
                f"camera {spec.name}: rate {spec.rate_hz} Hz does not divide the physics rate {physics_hz} Hz"
            )
    return {spec.name: physics_hz // spec.rate_hz for spec in specs}


class CameraPipeline:
    """Renders `specs` of `vehicle` in `world`; it knows nothing of the simulator.

    The owner registers `capture` as a loop tap every `tap_interval_steps` physics steps. With
    `workers=0`, frames are rendered in `scene_client`, a PyBullet client that already holds
    the scene (the physics world's); otherwise in worker processes building their own.
    """

    def __init__(
        self,
        vehicle: VehicleParams,
        world: WorldSpec,
        physics_hz: int,
        specs: tuple[CameraSpec, ...],
        renderer: RendererKind = RendererKind.TINY,
        workers: int = 2,
        ordered_delivery: bool = True,
        worker_start_timeout_s: float = 60.0,
        scene_client: WorldClient | None = None,
        worker_niceness: int | None = None,
        companions: Companions | None = None,
    ) -> None:
        """`worker_niceness`: how much lower the workers run (default: WINDOW_WORKER_NICENESS
        without ordered delivery, where a person flies, else 0)."""
        if len({s.name for s in specs}) != len(specs):
            raise ConfigError("camera names must be unique")
        self.specs = specs
        self.renderer = renderer
        self.sinks: list[FrameSink] = []
        self.kinds: frozenset[ImageKind] = JPEG_ONLY
        self._every = _steps_between_frames(specs, physics_hz)
        #: physics steps between two calls of `capture` the pipeline needs
        self.tap_interval_steps = math.gcd(*self._every.values()) if specs else 1
        self._ordered = ordered_delivery
        self._niceness = (
            (0 if ordered_delivery else WINDOW_WORKER_NICENESS) if worker_niceness is None else worker_niceness
        )
        self._result_timeout_s = worker_start_timeout_s
        self._seq = 0
        self._pending: deque[tuple[int, int]] = deque()  # (seq, worker index)
        self._procs: list = []
        self._conns: list = []
        self._rig: CameraRig | None = None
        #: what each camera gave (CameraAccount): frames delivered, captures dropped (unordered
        #: mode only: the workers were busy), frames late (unordered: older than LATE_S when
        #: handed on), and how old they were
        self.accounts: dict[str, CameraAccount] = {spec.name: CameraAccount(physics_hz) for spec in specs}
        self._newest_step = 0  # the step of the newest capture: "now", for a frame's age
        self._companions = companions if companions is not None else Companions((), tuple)  # none: no other body moves
        if not specs:
            return
        for spec in specs:
            vehicle.camera_mount(spec.link_name)  # a clear error for an unknown link, here
        if workers <= 0:
            if scene_client is None or renderer is RendererKind.EGL:
                # the EGL plugin draws only what is created after it is loaded: a client of its own
                self._rig = CameraRig.standalone(vehicle, world, specs, renderer)
            else:
                self._rig = CameraRig(vehicle, specs, renderer, scene_client.cid, None, scene=scene_client)
        else:
            self._start_workers(vehicle, world, workers, worker_start_timeout_s)
        most = 2 * max(1, workers)
        captures_per_s = physics_hz / min(self._every.values())  # at least: the fastest camera's rate
        self._in_flight = min(most, int(ORDERED_LAG_S * captures_per_s)) if ordered_delivery else most

    def want(self, *kinds: ImageKind) -> None:
        """Frames captured from now on also carry `kinds` (frames in flight do not)."""
        self.kinds = self.kinds.union(kinds)

    # --- workers ----------------------------------------------------------------------------

    def _start_workers(self, v: VehicleParams, world: WorldSpec, count: int, timeout_s: float) -> None:
        settings = {
            "urdf": str(v.urdf_path),
            "params": str(v.params_path),
            "world": str(world.path),
            "specs": self.specs,
            "renderer": self.renderer.value,
            "niceness": self._niceness,
            "companions": [(str(c.urdf_path), str(c.params_path)) for c in self._companions.vehicles],
            "own_index": self._companions.own_index,
        }
        try:
            for _ in range(count):
                # a socket pair per worker, inherited by it: nothing on disk to leave behind, and
                # the worker sees end-of-file (and exits) whenever this process goes away
                ours, theirs = socket.socketpair()
                try:
                    proc = subprocess.Popen(
                        [sys.executable, "-m", "quadsim.sensors.render_worker", str(theirs.fileno())],
                        pass_fds=(theirs.fileno(),),
                        stdin=subprocess.DEVNULL,
                        env=_worker_env(),
                        # a session of its own: Ctrl-C and signals to this process group are for
                        # this process to act on (it stops the workers when it is done with them)
                        start_new_session=True,
                    )
                finally:
                    theirs.close()
                self._procs.append(proc)
                conn = Connection(ours.detach())
                self._conns.append(conn)
                try:
                    conn.send(settings)
                except OSError:  # BrokenPipeError, ConnectionResetError: it is gone already
                    raise QuadsimError(f"a render worker exited during start-up ({_exit_status(proc)})") from None
            for proc, conn in zip(self._procs, self._conns):
                if not conn.poll(timeout_s):
                    raise QuadsimError(f"a render worker did not get ready within {timeout_s:.0f} s")
                try:
                    msg = conn.recv()
                except (EOFError, OSError):
                    raise QuadsimError(f"a render worker exited during start-up ({_exit_status(proc)})") from None
                if msg[0] == "error":
                    raise QuadsimError(f"render worker failed to start: {msg[1]}")
        except BaseException:
            self.close()
            raise

    def _receive_oldest(self) -> None:
        seq, index = self._pending[0]  # popped only once its answer is in: an interrupted
        conn = self._conns[index]  # wait leaves the queue as it was
        try:
            if not conn.poll(self._result_timeout_s):
                raise QuadsimError(f"a render worker gave no frame within {self._result_timeout_s:.0f} s")
            msg = conn.recv()
        except (EOFError, OSError):
            raise QuadsimError(f"a render worker exited unexpectedly ({_exit_status(self._procs[index])})") from None
        self._pending.popleft()
        if msg[0] == "error":
            raise QuadsimError(f"render worker failed: {msg[1]}")
        got_seq, frames = msg
        if got_seq != seq:  # cannot happen with one pipe per worker answering in order
            raise QuadsimError(f"render worker answered job {got_seq} for job {seq}")
        self._deliver(frames)

    # --- capture and delivery ---------------------------------------------------------------

    def capture(self, state: VehicleState) -> None:
        """Render the cameras due at `state.step` (a loop tap)."""
        step = state.step
        self._submit(tuple(s.name for s in self.specs if step % self._every[s.name] == 0), state)

    def capture_all(self, state: VehicleState) -> None:
        """Render every camera at `state`, due or not (a first image, or one after a reset)."""
        self._submit(tuple(s.name for s in self.specs), state)

    @property
    def frames_dropped(self) -> dict[str, int]:
        """Each camera's captures dropped because every render worker was busy."""
        return {name: a.dropped for name, a in self.accounts.items() if a.dropped}

    def _submit(self, names: tuple[str, ...], state: VehicleState) -> None:
        if not names:
            return
        step = state.step
        self._newest_step = max(self._newest_step, step)
        if self._rig is not None:
            self._deliver(self._rig.render(names, step, state.position_m, state.orientation_xyzw, self.kinds))
            return
        if not self._ordered:
            self.poll()
            if len(self._pending) >= self._in_flight:
                # the workers are behind (a busy machine): drop this capture rather than make
                # the window and the flight wait; what is recorded are the frames rendered
                for name in names:
                    self.accounts[name].dropped += 1
                return
        index = self._seq % len(self._conns)
        job = (self._seq, step, names, state.position_m, state.orientation_xyzw, self.kinds, self._companions.poses())
        self._conns[index].send(job)
        self._pending.append((self._seq, index))
        self._seq += 1
        if self._ordered:  # the oldest frame, at a fixed point: in_flight captures after its own
            while len(self._pending) > self._in_flight:
                self._receive_oldest()

    def poll(self) -> None:
        """Hand on every frame that is ready, without waiting (for live viewers). Ordered, the
        frames come at their fixed points instead: nothing to do."""
        if self._ordered:
            return
        while self._pending and self._conns[self._pending[0][1]].poll():
            self._receive_oldest()

    def drain(self) -> None:
        """Wait for every frame still being rendered and hand it on."""
        while self._pending:
            self._receive_oldest()

    def _deliver(self, frames: list[CameraFrame]) -> None:
        for frame in frames:
            account = self.accounts.get(frame.camera)
            if account is not None:
                account.delivered_at(self._newest_step - frame.step, late=not self._ordered)
            for sink in self.sinks:
                sink.on_camera_frame(frame)

    def close(self) -> None:
        """Stop the workers (pending frames are dropped: call drain() first to keep them)."""
        for conn in self._conns:
            with contextlib.suppress(OSError):  # BrokenPipeError too: it is gone already
                conn.send(None)
        for proc in self._procs:
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for conn in self._conns:
            conn.close()
        self._procs, self._conns = [], []
        self._pending.clear()
        if self._rig is not None:
            self._rig.close()  # disconnects only a client of its own
            self._rig = None
