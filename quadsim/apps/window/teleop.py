"""The teleop window: fly with keyboard or gamepad, see both cameras, a map and a HUD, and get a
recording. `python main.py fly`.

Each frame: handle events (app keys, then the input driver), advance the simulation by what the
pacer says (real time, or slower when the machine cannot keep up, never skipping physics
steps), take the camera frames that are ready, draw. Esc or closing the window finishes the
recording properly.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.apps.outputs import OutputOptions, RecordedRun
from quadsim.apps.window.pacing import FixedStepPacer, RealTimePacer
from quadsim.apps.window.view import TeleopView, ViewModel
from quadsim.core.types import VehicleState, ZMode
from quadsim.drivers.joystick import JoystickDevice, JoystickDriver, JoystickMapping
from quadsim.drivers.keyboard import LAYOUTS, KeyboardDriver
from quadsim.errors import QuadsimError
from quadsim.sensors.camera import CameraFrame
from quadsim.sim.config import SimConfig
from quadsim.sim.simulator import Simulator

APP_KEYS = [
    "Esc        quit (the recording is finished properly)",
    "P          pause / resume",
    "Backspace  reset to the start (a new recording if recording)",
    "Tab        switch z-mode (velocity <-> height)",
    "F5         stop / start a new recording",
    "H, F1      this help",
]


@dataclass(frozen=True)
class TeleopOptions:
    input: str = "auto"  # auto | keyboard | joystick
    keyboard_layout: str = "default"
    joystick_mapping: JoystickMapping = field(default_factory=JoystickMapping)
    window_size: tuple[int, int] = (1280, 720)
    max_fps: int = 60


class _Track:
    """A sink keeping the flown path for the map, at 10 Hz."""

    def __init__(self) -> None:
        self.points: deque[tuple[float, float]] = deque(maxlen=20000)

    def on_command(self, step: int, twist: object) -> None:
        pass

    def on_state(self, state: VehicleState) -> None:
        if state.step % 24 == 0:
            self.points.append(state.position_m[:2])


class TeleopApp:
    def __init__(
        self,
        config: SimConfig,
        outputs: OutputOptions,
        options: TeleopOptions = TeleopOptions(),
        pacer: RealTimePacer | FixedStepPacer | None = None,
        device_factory: Callable[[int], JoystickDevice] | None = None,
    ) -> None:
        if options.keyboard_layout not in LAYOUTS:
            raise QuadsimError(f"unknown keyboard layout {options.keyboard_layout!r}; choose from {', '.join(LAYOUTS)}")
        if options.input not in ("auto", "keyboard", "joystick"):
            raise QuadsimError(f"--input must be auto, keyboard or joystick, got {options.input!r}")
        pygame.display.init()
        pygame.font.init()
        pygame.joystick.init()
        self.screen = pygame.display.set_mode(options.window_size, pygame.RESIZABLE)
        pygame.display.set_caption("quadsim")
        self.options = options
        self.keyboard = KeyboardDriver(LAYOUTS[options.keyboard_layout], z_mode=config.z_mode)
        self.joystick = JoystickDriver(
            options.joystick_mapping,
            config.z_mode,
            **({"device_factory": device_factory} if device_factory is not None else {}),
        )
        use_joystick = options.input == "joystick" or (options.input == "auto" and pygame.joystick.get_count() > 0)
        if use_joystick and device_factory is None and pygame.joystick.get_count() > 0:
            self.joystick.attach(0)
        self.driver = self.joystick if use_joystick else self.keyboard
        self.sim = Simulator(config, self.driver)
        self.track = _Track()
        self.sim.add_sink(self.track)
        self.frames: dict[str, CameraFrame] = {}
        try:
            self.outputs = replace(outputs, ordered_delivery=False)  # show frames as soon as they are ready
            self.session = RecordedRun(
                self.sim, self.outputs, f"fly_{config.controller.value}", {"command": "fly", "input": self.driver.name}
            )
        except BaseException:
            self.sim.close()
            raise
        if self.session.cameras is not None:
            self.session.cameras.sinks.append(self)
        self._hook_joy()
        self.view = TeleopView()
        self.pacer = pacer or RealTimePacer(config.rates.physics_hz)
        self.paused = False
        self.show_help = False
        self.notice = ""
        self._notice_until = 0.0
        self.quit = False
        self.frame_count = 0
        self._frame_walls: deque[tuple[float, int]] = deque(maxlen=60)
        self._help_keys = {pygame.K_F1} | (
            {pygame.K_h} if pygame.K_h not in {b.key for b in self.keyboard.layout.bindings} else set()
        )
        self._clock = pygame.time.Clock()
        self.recordings: list[Path] = [self.session.path] if self.session.path else []

    # --- wiring -----------------------------------------------------------------------------

    def on_camera_frame(self, frame: CameraFrame) -> None:
        self.frames[frame.camera] = frame

    def _hook_joy(self) -> None:
        self.joystick.joy_sinks.clear()
        if self.driver is self.joystick:
            self.joystick.joy_sinks.append(self.session.fanout.on_joy)

    def _say(self, text: str, seconds: float = 3.0) -> None:
        self.notice = text
        self._notice_until = time.monotonic() + seconds

    # --- events -----------------------------------------------------------------------------

    def handle_event(self, event: pygame.event.Event) -> None:
        if event.type in (pygame.QUIT, pygame.WINDOWCLOSE):
            self.quit = True
            return
        if event.type == pygame.KEYDOWN:
            key = event.key
            if key == pygame.K_ESCAPE:
                self.quit = True
                return
            if key in self._help_keys:
                self.show_help = not self.show_help
                return
            if key == pygame.K_p:
                self.paused = not self.paused
                self.pacer.rebase(self.sim.step_count)
                return
            if key == pygame.K_BACKSPACE:
                self.reset()
                return
            if key == pygame.K_TAB:
                self.toggle_z_mode()
                return
            if key == pygame.K_F5:
                self.toggle_recording()
                return
        # both track their device; only the one that is the input driver is polled by the loop
        self.keyboard.handle_event(event)
        self.joystick.handle_event(event)

    def toggle_z_mode(self) -> None:
        new = ZMode.HEIGHT if self.sim.gate.z_mode is ZMode.VELOCITY else ZMode.VELOCITY
        self.sim.set_z_mode(new)
        self.session.note_event(self.sim.step_count, "z_mode", new.value)
        altitude = self.sim.state.position_m[2]
        self.keyboard.set_z_mode(new, altitude)
        self.joystick.set_z_mode(new, altitude)
        self._say(f"z-mode: {new.value}")

    def toggle_recording(self) -> None:
        if self.session.recording:
            self.session.stop_recording()
            self._say(f"recording saved: {self.session.path}")
        else:
            try:
                path = self.session.start_recording()
            except QuadsimError as exc:
                self._say(f"cannot record: {exc}", 6.0)
                return
            self.recordings.append(path)
            self._hook_joy()
            self._say(f"recording to {path}")

    def reset(self) -> None:
        was_recording = self.session.recording
        if was_recording:
            self.session.stop_recording()
        self.sim.reset()
        self.keyboard.reset()
        self.joystick.reset()
        self.track.points.clear()
        self.pacer.rebase(0)
        if was_recording:
            self.recordings.append(self.session.start_recording())
            self._hook_joy()
        self._say("reset to the start")

    # --- the frame loop ---------------------------------------------------------------------

    def frame(self) -> None:
        for event in pygame.event.get():
            self.handle_event(event)
            if self.quit:
                return
        if not self.paused:
            steps = self.pacer.steps_for_frame(self.sim.step_count)
            if steps:
                self.sim.step(steps)
        if self.session.cameras is not None:
            self.session.cameras.poll()
        self.view.draw(self.screen, self._model())
        pygame.display.flip()
        self.frame_count += 1
        self._frame_walls.append((time.perf_counter(), self.sim.step_count))
        if self.options.max_fps and isinstance(self.pacer, RealTimePacer):
            self._clock.tick(self.options.max_fps)

    def _rates(self) -> tuple[float, float]:
        if len(self._frame_walls) < 2:
            return 0.0, 0.0
        (t0, s0), (t1, s1) = self._frame_walls[0], self._frame_walls[-1]
        span = max(t1 - t0, 1e-9)
        return (len(self._frame_walls) - 1) / span, (s1 - s0) / self.sim.config.rates.physics_hz / span

    def _model(self) -> ViewModel:
        gate = self.sim.gate
        active = gate.active(self.sim.step_count)
        fps, rtf = self._rates()
        rec = self.session.recorder
        warnings = []
        if self.driver is self.joystick and self.joystick.device is None:
            warnings.append(self.joystick.status)
        if time.monotonic() > self._notice_until:
            self.notice = ""
        return ViewModel(
            state=self.sim.state,
            command=gate.last_command,
            command_held=active.hold,
            armed=active.armed,
            z_mode=gate.z_mode.value,
            controller=self.sim.config.controller.value,
            input_status=(
                self.joystick.status
                if self.driver is self.joystick
                else f"keyboard ({self.keyboard.layout.name}, speed x{self.keyboard.scale:.2f})"
            ),
            recording_path=str(self.session.path) if self.session.recording else None,
            recording_error=rec.error if rec is not None else None,
            paused=self.paused,
            lagging=self.pacer.lagging,
            fps=fps,
            real_time_factor=rtf,
            sim_time_s=self.sim.time_s,
            frames=self.frames,
            track=list(self.track.points),
            world=self.sim.world,
            help_lines=[*self.keyboard.layout.help_lines(), "", *APP_KEYS],
            show_help=self.show_help,
            notice=self.notice,
            warnings=warnings,
        )

    def run(self, max_frames: int | None = None, before_frame: Callable[[TeleopApp], None] | None = None) -> None:
        """Run frames until quit (or `max_frames`); `before_frame` lets tests post events."""
        while not self.quit and (max_frames is None or self.frame_count < max_frames):
            if before_frame is not None:
                before_frame(self)
            self.frame()

    def close(self) -> None:
        try:
            self.session.close()
        finally:
            self.sim.close()
            pygame.display.quit()

    def __enter__(self) -> TeleopApp:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
