"""Playback of a recording in the teleop window: both cameras, the map with the whole track, the
HUD from the recorded state; play/pause, seek (arrow keys, or a click on the timeline), speed
0.25x to 16x, frame by frame, loop. `python main.py replay FILE.mcap`.

As in the teleop window, a window destroyed from outside or a lost X connection ends playback
(x11_guard): the display is touched no more, and `display_lost` says why."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.apps.flight_plot import recorded_world
from quadsim.apps.window.display import Window
from quadsim.apps.window.view import TeleopView, ViewModel
from quadsim.core.kinematics import clamp
from quadsim.core.types import Twist, VehicleState
from quadsim.live.playback import RecordingFeed
from quadsim.physics.world_spec import FloorSpec, WorldSpec
from quadsim.recording.flight import DEPTH_SUFFIX, NS, RecordedFlight
from quadsim.sensors.camera import CameraFrame
from quadsim.session.pacing import FixedStepPacer, FrameCap, Pacer, RealTimePacer, collect_start_up_garbage

SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
SEEK_S = 5.0
KEYS = [
    "Space      play / pause",
    "Left/Right seek 5 s back / ahead (or click the timeline)",
    "Up/Down    faster / slower (0.25x to 16x)",
    ". ,        one state forward / back (pauses)",
    "L          loop on / off",
    "Home/End   start / end",
    "C          a fleet: follow the next vehicle (its HUD and cameras)",
    "V          depth images in place of the cameras' (replay --depth) on / off",
    "H, F1      this help;  Esc quit",
]


#: what the HUD shows of a recording that holds no state
_NO_STATE = VehicleState(0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3, (0.0,) * 4, (0.0,) * 3)


class ReplayApp(Window):
    def __init__(
        self,
        flight: RecordedFlight,
        window_size: tuple[int, int] = (1280, 720),
        speed: float = 1.0,
        loop: bool = False,
        frame_s: float | None = None,
        feed: RecordingFeed | None = None,
        others: dict[str, RecordedFlight] | None = None,
    ) -> None:
        """`frame_s`: advance playback by this much per frame instead of by the wall clock (tests);
        `feed`: handed the recorded messages as playback passes them (replay --foxglove);
        `others`: a fleet's other vehicles, by name, drawn on the map."""
        super().__init__(window_size, f"quadsim replay: {flight.path.name}", self._say_lost)
        self.flight = flight
        #: the world the recording was flown in, or an empty one
        self.world = recorded_world(flight) or WorldSpec(Path("none.toml"), FloorSpec(80.0, None, 4.0, 0.9), ())
        self.view = TeleopView()
        #: where the file starts: later than 0 for one recorded from part-way (F5, a reset)
        self.start_ns = flight.start_ns
        self.t_ns = self.start_ns
        self.end_ns = max(flight.end_ns, flight.state_ns[-1] if flight.state_ns else 0)
        self.playing = True
        self.speed = min(SPEEDS, key=lambda s: abs(s - speed))
        self.loop = loop
        #: the cameras' depth images (colour-mapped) in place of their images, where loaded (--depth)
        self.show_depth = True
        #: how far playback moves each frame: the wall clock (times the speed), or `frame_s` (tests)
        self.pacer: Pacer = FixedStepPacer(NS, frame_s) if frame_s is not None else RealTimePacer(NS, speed=self.speed)
        self._paced_from: int | None = None  # where playback stood after the last paced frame
        self._frame_s = frame_s
        self.feed = feed
        collect_start_up_garbage()  # the flight just read: a full collection of it now, not while it plays
        self._track = [s.position_m[:2] for s in flight.states[::6]]
        self.others = {name: (f, [s.position_m[:2] for s in f.states[::6]]) for name, f in (others or {}).items()}
        self._walls: list[float] = []
        self._frame_cap = FrameCap(60)
        #: the keys (KEYS) and what they do
        self._keys: dict[int, Callable[[], None]] = {
            pygame.K_ESCAPE: self.stop,
            pygame.K_SPACE: self.toggle_play,
            pygame.K_LEFT: lambda: self.seek(self.t_ns / NS - SEEK_S),
            pygame.K_RIGHT: lambda: self.seek(self.t_ns / NS + SEEK_S),
            pygame.K_UP: lambda: self.faster(+1),
            pygame.K_DOWN: lambda: self.faster(-1),
            pygame.K_PERIOD: lambda: self.step_state(+1),
            pygame.K_COMMA: lambda: self.step_state(-1),
            pygame.K_l: lambda: setattr(self, "loop", not self.loop),
            pygame.K_HOME: lambda: self.seek(self.start_ns / NS),
            pygame.K_END: lambda: self.seek(self.end_ns / NS),
            pygame.K_h: self.toggle_help,
            pygame.K_F1: self.toggle_help,
            pygame.K_c: self.follow_next,
            pygame.K_v: self.toggle_depth,
        }

    @staticmethod
    def _say_lost(reason: str) -> None:
        print(f"the window's display was lost ({reason})", file=sys.stderr)

    # --- control ----------------------------------------------------------------------------

    def seek(self, t_s: float) -> None:
        self.t_ns = int(clamp(t_s * NS, self.start_ns, self.end_ns))

    def step_state(self, direction: int) -> None:
        self.playing = False
        ns = self.flight.state_ns
        if not ns:
            return
        from bisect import bisect_left, bisect_right

        if direction > 0:
            i = bisect_right(ns, self.t_ns)
            self.t_ns = ns[min(i, len(ns) - 1)]
        else:
            i = bisect_left(ns, self.t_ns) - 1
            self.t_ns = ns[max(i, 0)]

    def handle_event(self, event: pygame.event.Event) -> None:
        if event.type in (pygame.QUIT, pygame.WINDOWCLOSE):
            self.stop()
        elif event.type == pygame.KEYDOWN:
            action = self._keys.get(event.key)
            if action is not None:
                action()
        elif event.type == pygame.MOUSEBUTTONDOWN and event.button == 1:
            bar = self.view.layout(self.screen.get_size())["timeline"].inflate(0, 16)
            if bar.collidepoint(event.pos):
                part = (event.pos[0] - bar.x) / bar.width
                self.seek((self.start_ns + part * (self.end_ns - self.start_ns)) / NS)

    def toggle_play(self) -> None:
        """Play or pause; played at the end, from the start."""
        self.playing = not self.playing
        if self.playing and self.t_ns >= self.end_ns:
            self.t_ns = self.start_ns

    def faster(self, by: int) -> None:
        """`by` steps up SPEEDS (down, when negative), within it."""
        i = SPEEDS.index(self.speed) + by
        self.speed = SPEEDS[min(max(i, 0), len(SPEEDS) - 1)]

    def toggle_depth(self) -> None:
        """Depth images in place of the camera images, or back (only what replay --depth loaded)."""
        if not any(cam.endswith(DEPTH_SUFFIX) for cam in self.flight.frames):
            self._say("no depth images loaded: replay --depth FILE shows a recording's depth images")
            return
        self.show_depth = not self.show_depth
        self._say("depth images shown" if self.show_depth else "camera images shown")

    def follow_next(self) -> None:
        """A fleet's recording: follow the next vehicle in the fleet's order (the HUD, the
        cameras and the map's highlight are then its own)."""
        if not self.others:
            self._say("one vehicle in this recording: nothing else to follow")
            return
        order = [name for name, _ in self.flight.fleet.fleet] if self.flight.fleet is not None else []
        names = [n for n in order if n == self.flight.vehicle or n in self.others] or [
            self.flight.vehicle,
            *self.others,
        ]
        name = names[(names.index(self.flight.vehicle) + 1) % len(names)]
        now_followed = self.others.pop(name)
        self.others[self.flight.vehicle] = (self.flight, self._track)
        self.flight, self._track = now_followed
        self.others = {n: self.others[n] for n in names if n in self.others}  # in the fleet's order
        self.end_ns = max(self.end_ns, self.flight.end_ns)
        self._say(f"following {name}" + ("" if self.flight.frames else " (it recorded no cameras)"))

    # --- frames -----------------------------------------------------------------------------

    def frame(self) -> None:
        events = pygame.event.get()
        if self._display_gone():
            return
        for event in events:
            self.handle_event(event)
        now = time.perf_counter()
        if self.playing:
            if self.t_ns != self._paced_from or self.speed != self.pacer.speed:  # moved, paused or sped up
                self.pacer.rebase(self.t_ns, self.speed)
            self.t_ns += self.pacer.steps_for_frame(self.t_ns)
            if self.t_ns >= self.end_ns:
                if self.loop:
                    self.t_ns = self.start_ns
                    self.pacer.rebase(self.start_ns, self.speed)
                else:
                    self.t_ns = self.end_ns
                    self.playing = False
        self._paced_from = self.t_ns if self.playing else None
        if self.feed is not None:
            self.feed.play_to(self.t_ns)
        self.view.draw(self.screen, self.model())
        pygame.display.flip()
        if self._display_gone():
            return
        self.frame_count += 1
        self._walls = ([*self._walls, now])[-30:]
        if self._frame_s is None:
            self._frame_cap.wait()

    def model(self) -> ViewModel:
        f, t = self.flight, self.t_ns
        # before its first state (a file started part-way begins a few ms before one): that state
        state = f.state_at(t) or (f.states[0] if f.states else _NO_STATE)
        command = f.command_at(t)
        frames = {}
        for cam in f.frames:
            if cam.endswith(DEPTH_SUFFIX):
                continue
            shown = cam + DEPTH_SUFFIX if self.show_depth and cam + DEPTH_SUFFIX in f.frames else cam
            got = f.frame_at(shown, t)
            if got is not None:
                frames[cam] = CameraFrame(shown, got[0], got[1], 0, 0)
        d = f.description
        state_word = "PLAYING" if self.playing else "paused"
        warnings = [] if f.states else ["this file has no /quad/pose: nothing to show on the map or HUD"]
        with_cameras = [name for name, (other, _) in self.others.items() if other.frames]
        if not f.frames and with_cameras:
            warnings.append(f"{', '.join(with_cameras)} recorded cameras: C follows the next vehicle")
        if self.notice and time.monotonic() < self._notice_until:
            warnings.append(self.notice)
        return ViewModel(
            state=state,
            command=command or Twist(),
            command_held=False,
            armed=command is not None,
            z_mode=zm.value if (zm := f.z_mode_at(t)) is not None else "?",
            controller=d.controller.name if d else "?",
            input_status=f"replay: flown with the {d.driver_name} input" if d else "replay: flown by another program",
            recording_path=None,
            recording_error=None,
            paused=False,
            lagging=False,
            fps=(len(self._walls) - 1) / (self._walls[-1] - self._walls[0])
            if len(self._walls) > 1 and self._walls[-1] > self._walls[0]
            else 0.0,
            real_time_factor=self.speed if self.playing else 0.0,
            sim_time_s=t / NS,
            frames=frames,
            track=self._track,
            world=self.world,
            help_lines=KEYS,
            show_help=self.show_help,
            warnings=warnings,
            playback=f"{state_word} {self.speed:g}x{'  loop' if self.loop else ''}   {f.path.name}",
            timeline=(t / NS, self.start_ns / NS, self.end_ns / NS),
            others=[
                (name, s.position_m[:2], s.yaw_rad(), track)
                for name, (other, track) in self.others.items()
                if (s := other.state_at(t)) is not None
            ],
            cameras_of=f.vehicle,
            camera_names=frozenset(f.frames),
            flown_name=f.vehicle if self.others else "",
        )
