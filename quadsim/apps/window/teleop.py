"""The teleop window: fly with keyboard or gamepad, see both cameras, a map and a HUD, and get a
recording. `python main.py fly`.

Each frame: handle events (app keys, then the input drivers), advance the simulation by what the
pacer says (real time, or slower when the machine cannot keep up, never skipping physics
steps), take the camera frames that are ready, draw. Esc or closing the window finishes the
recording properly.

On X11 a window destroyed from outside or a lost X connection ends the loop too (x11_guard):
from then on nothing touches the display; `close` finishes the recording and leaves the display
alone, and `display_lost` says what happened (the command line then ends the process with
x11_guard.end_process, since SDL's own teardown would hang on the dead connection).

Input: the keyboard or a gamepad. With --input auto a gamepad flies if one is plugged in at the
start, and one plugged in later takes over from the keyboard; every plug and unplug is said in
the HUD and recorded as an "input" event. Flight events (take-off, touchdown, landed, crash, reset)
come from the simulator to the HUD, as they go to the recording's /rosout.
"""

from __future__ import annotations

import os
import sys
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.apps.window.depth_view import DepthView
from quadsim.apps.window.display import Window, show_starting
from quadsim.apps.window.vehicles import WindowVehicles
from quadsim.apps.window.view import TeleopView, ViewModel
from quadsim.control.landing import LandingSettings
from quadsim.core.types import Twist, VehicleState, ZMode
from quadsim.drivers import ASAP
from quadsim.drivers.gamepad import Pad
from quadsim.drivers.joystick import JoystickDriver, JoystickMapping
from quadsim.drivers.keyboard import LAYOUTS, KeyboardDriver
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.errors import QuadsimError
from quadsim.recording.fanout import WARNING_EVENTS
from quadsim.sensors.camera import CameraFrame, CameraSpec
from quadsim.sensors.pipeline import CameraPipeline
from quadsim.session.outputs import LiveOutput, OutputOptions
from quadsim.session.pacing import FixedStepPacer, FrameCap, RealTimePacer, collect_start_up_garbage
from quadsim.session.plan import RunPlan
from quadsim.session.run import Run
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet_file import FleetFile

#: wall time over which the HUD's frame rate and real-time factor are measured
RATE_WINDOW_S = 1.0
#: wall time over which each camera's delivered frame rate is counted
CAMERA_RATE_WINDOW_S = 2.0
#: the HUD says the machine cannot keep real time only while the measured factor is below this
SLOW_BELOW = 0.97
CAMERA_RATE_MIN_WINDOW_S = 0.5  # a camera's rate is not shown until it has been counted this long

APP_KEYS = [
    "Esc        quit (the recording is finished properly)",
    "P          pause / resume",
    "Backspace  reset to the start (a new recording if recording)",
    "Tab        switch z-mode (velocity <-> height)",
    "F5         stop / start a new recording",
    "C          a fleet: show the next vehicle's cameras",
    "V          depth images in place of the cameras' (--camera-depth) on / off",
    "H, F1      this help",
]
#: APP_KEYS' help line where the layout flies with H (teleop_twist_keyboard strafes with it)
F1_HELP = "F1         this help"


@dataclass(frozen=True)
class FleetSetup:
    """A fleet to fly in the window: its file, what drives the vehicles not flown by hand, and
    each vehicle's cameras."""

    file: FleetFile
    drivers: dict[str, Any]
    cameras: dict[str, tuple[CameraSpec, ...]]


@dataclass(frozen=True)
class TeleopOptions:
    input: str = (
        "auto"  # auto | keyboard | joystick | foxglove | ros2 (the last two: the `commands` given to TeleopApp)
    )
    keyboard_layout: str = "default"
    joystick_mapping: JoystickMapping = field(default_factory=JoystickMapping)
    window_size: tuple[int, int] = (1280, 720)
    max_fps: int = 60
    landing: LandingSettings = field(default_factory=LandingSettings)  # hard landings allowed or not
    reset_on_crash: bool = False  # a crash puts the vehicle back at the start pose


class _FlightNotices:
    """A sink keeping the last flight event (take-off, touchdown, landed, crash, reset) for the HUD,
    shown for a few seconds (a crash for longer)."""

    def __init__(self) -> None:
        self.text = ""
        self.alert = False
        self._until = 0.0

    def on_command(self, step: int, twist: object) -> None:
        pass

    def on_state(self, state: VehicleState) -> None:
        pass

    def on_event(self, step: int, kind: str, value: str) -> None:
        if kind == "reset" and self.alert and time.monotonic() < self._until:
            self.text += f"; {kind}: {value}"  # the crash stays on screen, with what followed
            return
        self.alert = kind in WARNING_EVENTS
        self.text = f"{kind.upper() if self.alert else kind}: {value}"
        self._until = time.monotonic() + (8.0 if self.alert else 4.0)

    def current(self) -> tuple[str, bool]:
        if time.monotonic() > self._until:
            self.text, self.alert = "", False
        return self.text, self.alert


class _ActiveInput:
    """The simulator's input driver: whichever of the keyboard and the gamepad flies now (with
    --input auto a gamepad plugged in later takes over from the keyboard)."""

    def __init__(self, driver: KeyboardDriver | JoystickDriver | SubscribedDriver) -> None:
        self.driver = driver
        self.name = driver.name

    def use(self, driver: KeyboardDriver | JoystickDriver | SubscribedDriver) -> None:
        self.driver = driver
        self.name = driver.name
        driver.next_poll_step = ASAP  # its command replaces the other's at once

    @property
    def next_poll_step(self) -> int:
        return self.driver.next_poll_step

    @next_poll_step.setter
    def next_poll_step(self, step: int) -> None:
        self.driver.next_poll_step = step

    def poll(self, step: int, time_s: float) -> Twist | None:
        return self.driver.poll(step, time_s)

    @property
    def finished(self) -> bool:
        return False

    def describe(self) -> dict[str, Any]:
        return self.driver.describe()


def _check_options(options: TeleopOptions, commands: SubscribedDriver | None) -> None:
    """A layout and an input the window knows, and the live driver exactly when flown live."""
    if options.keyboard_layout not in LAYOUTS:
        raise QuadsimError(f"unknown keyboard layout {options.keyboard_layout!r}; choose from {', '.join(LAYOUTS)}")
    if options.input not in ("auto", "keyboard", "joystick", "foxglove", "ros2"):
        raise QuadsimError(f"--input must be auto, keyboard, joystick, foxglove or ros2, got {options.input!r}")
    if (options.input in ("foxglove", "ros2")) != (commands is not None):
        raise ValueError(f"--input {options.input} flies the `commands` driver, and only it does")


class TeleopApp(Window):
    def __init__(
        self,
        config: SimConfig,
        outputs: OutputOptions,
        options: TeleopOptions = TeleopOptions(),
        pacer: RealTimePacer | FixedStepPacer | None = None,
        live: Sequence[LiveOutput] = (),
        commands: SubscribedDriver | None = None,
        fleet: FleetSetup | None = None,
    ) -> None:
        """`live`: bridges fed for the whole run; `commands`: what flies with --input foxglove;
        `fleet`: fly one vehicle of a fleet file among the others (fly --fleet)."""
        _check_options(options, commands)
        pygame.joystick.init()
        super().__init__(options.window_size, "quadsim", self._finish_after_fatal_loss)
        try:
            self._start(options, config, outputs, pacer, live, commands, fleet)
        except BaseException:
            if self._x11 is not None and not self._x11.lost:
                self._x11.uninstall()  # the caller closes the display
            raise

    def _start(
        self,
        options: TeleopOptions,
        config: SimConfig,
        outputs: OutputOptions,
        pacer: RealTimePacer | FixedStepPacer | None,
        live: Sequence[LiveOutput],
        commands: SubscribedDriver | None,
        fleet: FleetSetup | None,
    ) -> None:
        """Everything the window needs to fly, built while it says so (show_starting)."""
        self.options = options
        z_mode = config.z_mode or ZMode.VELOCITY
        self.keyboard = KeyboardDriver(LAYOUTS[options.keyboard_layout], z_mode=z_mode)
        self.joystick = JoystickDriver(options.joystick_mapping, z_mode)
        if options.input in ("auto", "joystick"):
            self.joystick.attach_first()
        use_joystick = options.input == "joystick" or (options.input == "auto" and self.joystick.pad is not None)
        self.input = _ActiveInput(commands or (self.joystick if use_joystick else self.keyboard))
        #: the device a second person flies a fleet's other held vehicle with (or None)
        self.second_hand = self._second_hand(fleet)
        #: who flies what: the vehicle flown by hand ("" for a run of one vehicle), the second person's
        self.crew = WindowVehicles(fleet.file if fleet is not None else None, self.second_hand is not None)
        self.outputs = replace(outputs, ordered_delivery=False)  # show frames as soon as they are ready
        try:
            plan = self._plan(config, live, fleet)
            said = ["quadsim is starting", "loading the world and the vehicles"]
            show_starting(self.screen, said, self._x11)

            def say(note: str) -> None:  # a slow part starts: on the screen, and in the terminal
                said.append(note)
                show_starting(self.screen, said, self._x11)
                print(f"quadsim: {note}...", file=sys.stderr, flush=True)

            self.session = Run(plan, say=say)
        except BaseException:
            self.joystick.close()
            raise
        #: the vehicle the window flies (or watches)
        self.sim = self.session.fleet[self.crew.flown]
        if fleet is not None:
            self._match_z_modes()
        self.crew.attach(self.session.fleet, self.session.outputs.pipelines)
        self.track = self.crew.tracks[self.crew.flown]
        self.flight_notices = _FlightNotices()
        self.sim.add_sink(self.flight_notices)
        self.frames: dict[str, CameraFrame] = {}
        self.crew.show(self.crew.shown, self)
        self._hook_joy()
        collect_start_up_garbage()
        self._init_window_state(pacer or RealTimePacer(config.rates.physics_hz))
        self.session.paced = isinstance(self.pacer, RealTimePacer)  # its cameras drop frames rather than wait
        self.recordings: list[Path] = [self.session.outputs.path] if self.session.outputs.path else []

    @property
    def fleet(self) -> WindowVehicles | None:
        """A fleet's vehicles in the window (None: a run of one vehicle)."""
        return self.crew if self.crew.is_fleet else None

    def _plan(self, config: SimConfig, live: Sequence[LiveOutput], fleet: FleetSetup | None) -> RunPlan:
        """The run the window flies: the input driver flying the flown vehicle (and a second
        person's device the other held one), every other vehicle flown by its own input."""
        settings: dict[str, Any] = {"landing": self.options.landing, "reset_on_crash": self.options.reset_on_crash}
        if fleet is None:
            info = {"command": "fly", "input": self.driver.name}
            return RunPlan.alone(
                config,
                self.input,
                outputs=self.outputs,
                label=f"fly_{config.controller.value}",
                run_info=info,
                live=tuple(live),
                **settings,
            )
        by_hand: dict[str, Any] = {self.crew.flown: self.input} if self.crew.by_hand else {}
        if self.crew.second is not None:
            by_hand[self.crew.second] = self.second_hand
        info = {"command": "fly", "fleet": str(fleet.file.path), "input": self.driver.name}
        return RunPlan(
            config,
            tuple(fleet.file.fleet_vehicles({**fleet.drivers, **by_hand})),
            outputs=replace(self.outputs, cameras=()),
            cameras=fleet.cameras,
            label=f"fly_{fleet.file.path.stem}",
            run_info=info,
            live=tuple(live),
            **settings,
        )

    def _second_hand(self, fleet: FleetSetup | None) -> KeyboardDriver | JoystickDriver | None:
        """A fleet with a keyboard vehicle and a gamepad vehicle: the device of the one the
        window does not fly (the pad is attached for it)."""
        hands = fleet.file.held if fleet is not None else ()
        if len(hands) < 2:
            return None
        if hands[1].input == "gamepad":
            self.joystick.attach_first()
            return self.joystick
        return self.keyboard

    def _match_z_modes(self) -> None:
        """Each hand's device reads its sticks or keys in the z-mode of the vehicle it flies."""
        for driver in (self.keyboard, self.joystick):
            second = self.crew.second if driver is self.second_hand else None
            drone = self.session.fleet[second or self.crew.flown]
            driver.set_z_mode(drone.gate.z_mode, drone.state.position_m[2])

    def _pipelines(self) -> list[CameraPipeline]:
        return list(self.session.outputs.pipelines.values())

    def _init_window_state(self, pacer: RealTimePacer | FixedStepPacer) -> None:
        """What the window shows and counts, before its first frame."""
        self.view = TeleopView()
        #: the depth of the cameras that have it, colour-mapped in place of their images (V)
        self.depth_view = DepthView()
        self.pacer = pacer
        self.paused = False
        self._frame_walls: deque[tuple[float, int]] = deque()  # (wall s, step) of the last second
        self._camera_walls: dict[str, deque[float]] = {}  # wall times of the frames that came in
        #: the wall clock the HUD's rates are measured by (a test gives its own)
        self.wall_clock: Callable[[], float] = time.perf_counter
        self._camera_rates_from = self.wall_clock()  # since when they are counted
        help_keys = [pygame.K_F1] + (
            [pygame.K_h] if pygame.K_h not in {b.key for b in self.keyboard.layout.bindings} else []
        )
        #: what shows the help, as the HUD and the terminal say it
        self.help_keys = "H/F1" if pygame.K_h in help_keys else "F1"
        #: the window's own keys (APP_KEYS) and what they do; the others go to the input devices
        self._app_keys: dict[int, Callable[[], None]] = {
            pygame.K_ESCAPE: self.stop,
            **dict.fromkeys(help_keys, self.toggle_help),
            pygame.K_p: self.toggle_pause,
            pygame.K_BACKSPACE: self.reset,
            pygame.K_TAB: self.toggle_z_mode,
            pygame.K_F5: self.toggle_recording,
            pygame.K_v: self.toggle_depth,
        }
        if self.fleet is not None:
            self._app_keys[pygame.K_c] = self.next_cameras
        self._frame_cap = FrameCap(self.options.max_fps) if self.options.max_fps else None

    # --- wiring -----------------------------------------------------------------------------

    def on_camera_frame(self, frame: CameraFrame) -> None:
        self.frames[frame.camera] = frame
        walls = self._camera_walls.setdefault(frame.camera, deque())
        walls.append(self.wall_clock())

    @property
    def driver(self) -> KeyboardDriver | JoystickDriver | SubscribedDriver:
        """The input driver flying now."""
        return self.input.driver

    def _hook_joy(self) -> None:
        """The pad's axes and buttons go to /joy of the vehicle it flies (a fleet's: /NAME/joy)."""
        self.joystick.joy_sinks.clear()
        if self.driver is self.joystick or self.second_hand is self.joystick:
            name = self.crew.second if self.second_hand is self.joystick else None
            self.joystick.joy_sinks.append(self.session.outputs.topics[name or self.crew.flown].on_joy)

    def _finish_after_fatal_loss(self, reason: str) -> None:
        """With a libX11 older than 1.7 the process ends inside the X call that met the loss:
        finish the recording and say what `fly` says after a loss, from there (during start-up,
        before there is a run: only that the display was lost)."""
        if getattr(self, "recordings", None) is None:
            print(f"the window's display was lost ({reason}) while quadsim was starting", file=sys.stderr)
            return
        self.session.outputs.close()
        print(f"flew {self.sim.time_s:.1f} s of simulation time")
        for path in self.recordings:
            print(f"recording       {path}")
        print(f"the window's display was lost ({reason}); the recording is finished", file=sys.stderr)

    def _record_event(self, kind: str, value: str) -> None:
        """The one place the window's events reach the recording (input device changes)."""
        self.session.outputs.note_event(self.sim.step_count, kind, value)

    # --- events -----------------------------------------------------------------------------

    def handle_event(self, event: pygame.event.Event) -> None:
        if event.type in (pygame.QUIT, pygame.WINDOWCLOSE):
            self.stop()
            return
        action = self._app_keys.get(event.key) if event.type == pygame.KEYDOWN else None
        if action is not None:
            action()
            return
        # both track their device; only the one that is the input driver is polled by the loop
        self.keyboard.handle_event(event)
        if self.options.input in ("auto", "joystick") or self.second_hand is self.joystick:
            before = self.joystick.pad
            self.joystick.handle_event(event)
            if self.joystick.pad is not before:
                self._pad_changed(before)

    def toggle_pause(self) -> None:
        self.paused = not self.paused
        self.pacer.rebase(self.sim.step_count)
        self._restart_camera_rates()

    def toggle_depth(self) -> None:
        """The cameras' depth images (colour-mapped) in place of their images, or back."""
        if not any(spec.depth for p in self._pipelines() for spec in p.specs):
            self._say("no camera with depth: fly with --camera-depth front (or a fleet file's depth = [...])")
            return
        self.depth_view.shown = not self.depth_view.shown
        self._say("depth images shown" if self.depth_view.shown else "camera images shown")

    def _help_lines(self) -> list[str]:
        """The flying keys (or the gamepad's sticks) of the vehicle flown, then the window's own
        keys (a watched fleet: the window's keys only, since nothing is flown)."""
        app_keys = APP_KEYS if self.help_keys == "H/F1" else [*APP_KEYS[:-1], F1_HELP]
        if self.fleet is not None and not self.fleet.by_hand:
            return app_keys
        flying = self.joystick.help_lines() if self.driver is self.joystick else self.keyboard.layout.help_lines()
        return [*flying, "", *app_keys]

    def _input_status(self) -> str:
        driver = self.driver
        if self.fleet is not None and not self.fleet.by_hand:
            return f"watching {self.fleet.flown} ({self.fleet.inputs[self.fleet.flown]}); the keys fly nothing"
        if driver is self.joystick:
            status = self.joystick.status
        elif isinstance(driver, SubscribedDriver):
            status = f"{driver.name}: Twists on {driver.heard_on} ({driver.received} received)"
        else:
            status = f"keyboard ({self.keyboard.layout.name}, speed x{self.keyboard.scale:.2f})"
        if self.fleet is not None:
            status = f"{self.fleet.flown}: {status}"
        if self.fleet is not None and self.fleet.second is not None:
            status += (
                f"; {'the gamepad' if self.second_hand is self.joystick else 'the keyboard'} flies {self.fleet.second}"
            )
        return status

    def _pad_changed(self, before: Pad | None) -> None:
        """A gamepad appeared or went: switch to it (--input auto), say so, and record it."""
        pad = self.joystick.pad
        if self.fleet is not None and self.second_hand is self.joystick:  # it flies the other vehicle
            if pad is not None:
                self._hook_joy()
                self._record_event("input", f"gamepad plugged in: {pad.name}; it flies {self.fleet.second}")
                self._say(f"gamepad plugged in: {pad.name} flies {self.fleet.second}", 6.0)
            elif before is not None:
                self._record_event("input", f"gamepad unplugged: {before.name}; {self.fleet.second} holds position")
            return
        if pad is not None:
            what = f"{pad.name} ({pad.kind.value})"
            if self.driver is not self.joystick:
                self.keyboard.clear()
                self.input.use(self.joystick)
                self._hook_joy()
                self._record_event("input", f"gamepad plugged in: {what}; it flies instead of the keyboard")
                self._say(f"gamepad plugged in: {what} flies now", 6.0)
            else:
                self._record_event("input", f"gamepad plugged in: {what}")
                self._say(f"gamepad plugged in: {what}", 6.0)
        elif before is not None and self.driver is self.joystick:
            self._record_event("input", f"gamepad unplugged: {before.name}; holding position")

    def toggle_z_mode(self) -> None:
        new = ZMode.HEIGHT if self.sim.gate.z_mode is ZMode.VELOCITY else ZMode.VELOCITY
        self.session.switch_z_mode(self.crew.flown, new)  # recorded under the vehicle, as a re-flight switches it
        altitude = self.sim.state.position_m[2]
        for driver in (self.keyboard, self.joystick):
            if driver is not self.second_hand:  # the other person's vehicle keeps its z-mode
                driver.set_z_mode(new, altitude)
        self._say(f"z-mode: {new.value}")

    def next_cameras(self) -> None:
        """A fleet: show the next vehicle's cameras (those that have some)."""
        name = self.crew.next_cameras()
        if name is None:
            self._say("no vehicle of this fleet has cameras")
            return
        self.crew.show(name, self)
        self.frames.clear()
        self._restart_camera_rates()
        self._say(f"cameras: {name}'s")

    def toggle_recording(self) -> None:
        outputs = self.session.outputs
        if outputs.recording:
            outputs.stop_recording()
            self._say(f"recording saved: {outputs.path}")
        else:
            try:
                path = outputs.start_recording()
            except QuadsimError as exc:
                self._say(f"cannot record: {exc.cli_message}", 6.0)
                return
            self.recordings.append(path)
            self._hook_joy()
            self._say(f"recording to {path}")

    @property
    def flown_s(self) -> float:
        """Simulation time flown in this window, over every reset (each starts the clock again)."""
        return self.session.flown_s

    def final_lines(self) -> list[str]:
        """What the window flew, as `run` says it: where the vehicle ended, how far it flew, its
        commands and flight events; a fleet's vehicles one line each, with what flew them."""
        summaries = self.session.summaries()
        if self.fleet is None:
            return summaries[""].where_lines()
        width = max(len(name) for name in summaries)
        return [
            f"{name:<{width}}  {summary.vehicle_line()}; {self.crew.inputs[name]}"
            for name, summary in summaries.items()
        ]

    def reset(self) -> None:
        outputs = self.session.outputs
        was_recording = outputs.recording
        if was_recording:
            outputs.stop_recording()
        self.session.reset()
        for track in self.crew.tracks.values():
            track.points.clear()
        self.keyboard.reset()
        self.joystick.reset()
        if self.fleet is not None:  # as at the start: each device reads in its vehicle's z-mode, from where it is
            self._match_z_modes()
        self.pacer.rebase(0)
        self._frame_walls.clear()  # rates restart with the clock (no negative real-time factor)
        if was_recording:
            self.recordings.append(outputs.start_recording())
            self._hook_joy()
        self._say("reset to the start")

    # --- the frame loop ---------------------------------------------------------------------

    def frame(self) -> None:
        events = pygame.event.get()
        if self._display_gone():
            return
        for event in events:
            self.handle_event(event)
            if self.quit:
                return
        if not self.paused:
            steps = self.pacer.steps_for_frame(self.sim.step_count)
            if steps:
                self.session.step(steps)
        self.session.outputs.poll()  # the frames that are in (and /rosout told of dropped ones)
        self.view.draw(self.screen, self._model())
        pygame.display.flip()
        if self._display_gone():
            return
        self.frame_count += 1
        now = self.wall_clock()
        self._frame_walls.append((now, self.sim.step_count))
        while len(self._frame_walls) > 2 and now - self._frame_walls[0][0] > RATE_WINDOW_S:
            self._frame_walls.popleft()
        if self._frame_cap is not None and isinstance(self.pacer, RealTimePacer):
            self._frame_cap.wait()

    def _rates(self) -> tuple[float, float]:
        """Frames per second and sim seconds per wall second, over the last second of wall time
        (not the last N frames: at 4 frames/s those would span many seconds)."""
        if len(self._frame_walls) < 2:
            return 0.0, 0.0
        (t0, s0), (t1, s1) = self._frame_walls[0], self._frame_walls[-1]
        span = max(t1 - t0, 1e-9)
        return (len(self._frame_walls) - 1) / span, max(0, s1 - s0) / self.sim.config.rates.physics_hz / span

    def _restart_camera_rates(self) -> None:
        """Count the cameras' frames afresh (after a pause, or another vehicle's cameras)."""
        self._camera_walls.clear()
        self._camera_rates_from = self.wall_clock()

    def camera_rates(self) -> dict[str, float]:
        """Frames per second each camera actually delivered over the last two seconds (none while
        paused, or in the first half second after a pause or a switch of cameras: not measured)."""
        now = self.wall_clock()
        window = min(CAMERA_RATE_WINDOW_S, now - self._camera_rates_from)
        if self.paused or window < CAMERA_RATE_MIN_WINDOW_S:
            return {}
        rates = {}
        for name, walls in self._camera_walls.items():
            while walls and now - walls[0] > window:
                walls.popleft()
            rates[name] = len(walls) / window
        return rates

    def _model(self) -> ViewModel:
        gate = self.sim.gate
        active = gate.active(self.sim.step_count)
        fps, rtf = self._rates()
        rec = self.session.outputs.recorder
        warnings = self.joystick.warnings() if self.driver is self.joystick else []
        if time.monotonic() > self._notice_until:
            self.notice = ""
        flight_event, flight_alert = self.flight_notices.current()
        return ViewModel(
            state=self.sim.state,
            command=gate.last_command,
            command_held=active.hold,
            armed=active.armed,
            z_mode=gate.z_mode.value,
            controller=self.sim.config.controller.value,
            phase=self.sim.phase.value,
            flight_event=flight_event,
            flight_alert=flight_alert,
            input_status=self._input_status(),
            recording_path=str(self.session.outputs.path) if self.session.outputs.recording else None,
            recording_error=rec.error if rec is not None else None,
            paused=self.paused,
            # behind real time just now, and still behind over the last second (a hiccup the pacer
            # holds its flag for, once caught up, said SLOW beside 1.00x real time)
            lagging=self.pacer.lagging and not self.paused and rtf < SLOW_BELOW,
            fps=fps,
            real_time_factor=rtf,
            sim_time_s=self.sim.time_s,
            frames=self.depth_view.frames(self.frames),
            track=list(self.track.points),
            world=self.sim.world,
            help_lines=self._help_lines(),
            help_keys=self.help_keys,
            no_cameras="no vehicle of this fleet has cameras" if self.fleet is not None else ViewModel.no_cameras,
            show_help=self.show_help,
            notice=self.notice,
            warnings=warnings,
            camera_rates=self.camera_rates() if self._pipelines() else {},
            camera_rate_hz=max((c.rate_hz for p in self._pipelines() for c in p.specs), default=0),
            camera_dropped=sum(sum(p.frames_dropped.values()) for p in self._pipelines()),
            others=self.fleet.others() if self.fleet is not None else [],
            cameras_of=(self.fleet.shown or self.fleet.flown) if self.fleet is not None else "",
            camera_names=self.fleet.camera_names() if self.fleet is not None else None,
            flown_name=self.fleet.flown if self.fleet is not None else "",
        )

    def close(self) -> None:
        try:
            self.session.close()
        finally:
            self.joystick.close()
            super().close()
