"""Drawing the teleop window: front camera large, floor camera inset, top-down map, HUD, help.

Pure drawing from a ViewModel the app fills each frame; it reads nothing else.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, VehicleState
from quadsim.physics.world_spec import Shape, WorldSpec
from quadsim.sensors.camera import CameraFrame
from quadsim.sensors.rendering import decode_jpeg

BACKGROUND = (24, 26, 30)
PANEL = (0, 0, 0, 150)
TEXT = (235, 235, 235)
WARN = (255, 170, 60)
ALERT = (255, 80, 80)
OK = (120, 220, 120)


@dataclass
class ViewModel:
    state: VehicleState
    command: Twist
    command_held: bool
    armed: bool
    z_mode: str
    controller: str
    input_status: str
    recording_path: str | None
    recording_error: str | None
    paused: bool
    lagging: bool
    fps: float
    real_time_factor: float
    sim_time_s: float
    frames: dict[str, CameraFrame]
    track: list[tuple[float, float]]
    world: WorldSpec
    help_lines: list[str]
    show_help: bool
    notice: str = ""
    warnings: list[str] = field(default_factory=list)
    camera_rates: dict[str, float] = field(default_factory=dict)  # frames/s each camera delivered
    camera_rate_hz: int = 0  # the rate the cameras were asked for
    camera_dropped: int = 0  # captures dropped so far, every render worker busy
    playback: str | None = None  # replay: shown instead of the recording state
    timeline: tuple[float, float, float] | None = None  # replay: (time, start, end) s, drawn as a clickable bar
    phase: str = ""  # landed / flying (empty: not known, as in replay)
    flight_event: str = ""  # the last flight event (take-off, touchdown, landed, crash, reset), while shown
    flight_alert: bool = False  # that event is a crash
    #: a fleet: (name, position, yaw, track) of every other vehicle, drawn on the map
    others: list[tuple[str, tuple[float, float], float, list[tuple[float, float]]]] = field(default_factory=list)
    cameras_of: str = ""  # a fleet: whose cameras are shown
    camera_names: frozenset[str] | None = None  # a fleet: the cameras that vehicle has (None: not said)
    flown_name: str = ""  # a fleet: the vehicle the HUD and the red arrow are (named on the map)
    help_keys: str = "H/F1"  # what shows the help (F1 alone where the layout flies with H)
    no_cameras: str = "cameras off (--cameras none)"  # what the panes say when no camera flies


class TeleopView:
    def __init__(self) -> None:
        self.font = pygame.font.Font(None, 22)
        self.big = pygame.font.Font(None, 34)
        self._decoded: dict[str, tuple[int, pygame.Surface]] = {}
        self._scaled: dict[str, tuple[int, tuple[int, int], pygame.Surface]] = {}

    # --- layout -----------------------------------------------------------------------------

    @staticmethod
    def layout(size: tuple[int, int]) -> dict[str, pygame.Rect]:
        w, h = size
        side = max(200, min(int(w * 0.3), w // 2))
        inset_h = side * 3 // 4
        return {
            "front": pygame.Rect(0, 0, w - side, h),
            "floor": pygame.Rect(w - side, 0, side, inset_h),
            "map": pygame.Rect(w - side, inset_h, side, max(60, h - inset_h)),
            "timeline": pygame.Rect(16, h - 52, max(40, w - side - 32), 14),
        }

    # --- drawing ----------------------------------------------------------------------------

    def draw(self, surface: pygame.Surface, m: ViewModel) -> None:
        surface.fill(BACKGROUND)
        rects = self.layout(surface.get_size())
        whose = f" ({m.cameras_of})" if m.cameras_of else ""
        # a flight asked for no camera at all (--cameras none): no rate, and no recording played
        cameras_off = m.camera_rate_hz == 0 and m.playback is None
        for name in ("front", "floor"):
            absent = m.camera_names is not None and name not in m.camera_names
            if cameras_off:
                empty = m.no_cameras
            elif not absent:
                empty = "no image yet"
            elif m.cameras_of:
                empty = f"{m.cameras_of} has no {name} camera"
            else:
                empty = f"no {name} camera in this recording"
            self._camera(surface, rects[name], m.frames.get(name), f"{name} camera{whose}", empty)
        self._map(surface, rects["map"], m)
        self._hud(surface, rects["front"], m)
        if m.timeline is not None:
            self._timeline(surface, rects["timeline"], *m.timeline)
        if m.show_help:
            self._help(surface, m.help_lines)

    def _image(self, frame: CameraFrame) -> pygame.Surface:
        cached = self._decoded.get(frame.camera)
        if cached is None or cached[0] != frame.step:
            if frame.rgb is not None:
                rgb = frame.rgb
            elif frame.jpeg is not None:
                rgb = decode_jpeg(frame.jpeg)
            else:
                return pygame.Surface((frame.width_px, frame.height_px))
            surf = pygame.image.frombuffer(rgb.tobytes(), (rgb.shape[1], rgb.shape[0]), "RGB")
            self._decoded[frame.camera] = (frame.step, surf)
            return surf
        return cached[1]

    def _camera(
        self, surface: pygame.Surface, rect: pygame.Rect, frame: CameraFrame | None, label: str, empty: str
    ) -> None:
        pygame.draw.rect(surface, (10, 10, 12), rect)
        if frame is not None:
            img = self._image(frame)
            iw, ih = img.get_size()
            k = min(rect.width / iw, rect.height / ih)
            size = (max(1, int(iw * k)), max(1, int(ih * k)))
            cached = self._scaled.get(frame.camera)
            if cached is None or cached[0] != frame.step or cached[1] != size:
                cached = (frame.step, size, pygame.transform.scale(img, size))
                self._scaled[frame.camera] = cached
            surface.blit(cached[2], cached[2].get_rect(center=rect.center))
        else:
            self._text(surface, empty, rect.center, TEXT, center=True)
        pygame.draw.rect(surface, (70, 70, 80), rect, 1)
        self._text(surface, label, (rect.x + 6, rect.bottom - 20), (220, 220, 220), backed=True)

    def _map(self, surface: pygame.Surface, rect: pygame.Rect, m: ViewModel) -> None:
        pygame.draw.rect(surface, (34, 40, 36), rect)
        x0, y0, _ = m.state.position_m
        span_m = 24.0
        k = min(rect.width, rect.height) / span_m

        def px(x: float, y: float) -> tuple[int, int]:  # world x up the screen, world y to the left
            return (int(rect.centerx - (y - y0) * k), int(rect.centery - (x - x0) * k))

        clip = surface.get_clip()
        surface.set_clip(rect)
        for g in range(int(x0 - span_m), int(x0 + span_m) + 1, 2):
            pygame.draw.line(surface, (48, 56, 50), px(g, y0 - span_m), px(g, y0 + span_m))
        for g in range(int(y0 - span_m), int(y0 + span_m) + 1, 2):
            pygame.draw.line(surface, (48, 56, 50), px(x0 - span_m, g), px(x0 + span_m, g))
        for lm in m.world.landmarks:
            color = tuple(int(255 * c) for c in lm.color_rgba[:3])
            cx, cy = px(lm.position_m[0], lm.position_m[1])
            if lm.shape is Shape.BOX:
                w, h = lm.size_m[1] * k, lm.size_m[0] * k
                pygame.draw.rect(surface, color, pygame.Rect(cx - w / 2, cy - h / 2, max(2, w), max(2, h)))
            else:
                pygame.draw.circle(surface, color, (cx, cy), max(2, int(lm.size_m[0] * k)))
        for name, (ox, oy), oyaw, points in m.others:  # a fleet's other vehicles, in blue
            if len(points) > 1:
                pygame.draw.lines(surface, (110, 170, 255), False, [px(x, y) for x, y in points], 1)
            pygame.draw.polygon(surface, (110, 170, 255), _arrow(px, ox, oy, oyaw))
            self._text(surface, name, px(ox + 1.0, oy), (170, 205, 255), center=True, backed=True)
        if len(m.track) > 1:
            pygame.draw.lines(surface, (255, 220, 80), False, [px(x, y) for x, y in m.track], 2)
        pygame.draw.polygon(surface, (255, 70, 70), _arrow(px, x0, y0, m.state.yaw_rad()))
        if m.flown_name:  # each name centred above its arrow, on a dark box: names do not run together
            self._text(surface, m.flown_name, px(x0 + 1.0, y0), (255, 150, 150), center=True, backed=True)
        surface.set_clip(clip)
        pygame.draw.rect(surface, (70, 70, 80), rect, 1)
        self._text(
            surface, f"map  {span_m:.0f} m across, up = world +x", (rect.x + 6, rect.bottom - 20), (200, 200, 200)
        )

    def _hud(self, surface: pygame.Surface, rect: pygame.Rect, m: ViewModel) -> None:
        s, c = m.state, m.command
        vx, vy, vz = s.linear_velocity_mps
        rec = (
            f"REC {os.path.basename(m.recording_path)}"
            if m.recording_path and not m.recording_error
            else ("recording stopped: " + m.recording_error if m.recording_error else "not recording (F5 starts)")
        )
        if m.playback is not None:
            rec = m.playback
        cmd = (
            "holding (no command)"
            if m.command_held
            else (
                f"x {_signed(c.linear_x)}  y {_signed(c.linear_y)} m/s  {_z_text(c, m.z_mode)}  "
                f"yaw {_signed(c.angular_z)} rad/s"
                if m.armed
                else "idle: no command yet"
            )
        )
        lines = [
            (
                f"alt {s.position_m[2]:5.2f} m   speed {math.hypot(vx, vy):4.2f} m/s   climb {_signed(vz)} m/s   "
                f"heading {_signed(math.degrees(s.yaw_rad()), 1):>6} deg",
                TEXT,
            ),
            (f"command  {cmd}", TEXT),
            (
                (f"{m.phase.upper()}   " if m.phase else "")
                + f"z-mode {m.z_mode}   controller {m.controller}   input {m.input_status}",
                TEXT,
            ),
            (rec, ALERT if m.recording_error else (OK if m.recording_path or m.playback else WARN)),
            (
                f"{m.fps:4.1f} fps   {m.real_time_factor:4.2f}x real time   sim {m.sim_time_s:7.2f} s   {m.help_keys}: help",
                TEXT,
            ),
        ]
        if m.camera_rates:
            lines.append(_camera_hud_line(m))
        if m.paused:
            lines.append(("PAUSED (P resumes)", WARN))
        if m.lagging:
            lines.append(("SLOW: this machine cannot keep real time; the simulation runs slower", ALERT))
        lines += [(w, WARN) for w in m.warnings]
        if m.flight_event:
            lines.append((m.flight_event, ALERT if m.flight_alert else OK))
        if m.notice:
            lines.append((m.notice, OK))
        room = rect.width - 24  # a line longer than the HUD goes on below, not over the panes beside it
        lines = [(part, color) for text, color in lines for part in self._wrapped(text, room)]
        height = 8 + 20 * len(lines)
        widest = max(self.font.size(text)[0] for text, _ in lines)
        panel = pygame.Surface((min(rect.width - 12, widest + 14), height), pygame.SRCALPHA)
        panel.fill(PANEL)
        surface.blit(panel, (rect.x + 6, rect.y + 6))
        for i, (text, color) in enumerate(lines):
            self._text(surface, text, (rect.x + 12, rect.y + 10 + 20 * i), color)

    def _wrapped(self, text: str, room: int) -> list[str]:
        """`text` in lines at most `room` pixels wide, broken between words (the later ones indented)."""
        if self.font.size(text)[0] <= room:
            return [text]
        lines, line = [], ""
        for word in text.split(" "):
            trial = f"{line} {word}" if line else word
            if line and self.font.size(trial)[0] > room:
                lines.append(line)
                trial = f"    {word}"
            line = trial
        return [*lines, line]

    def _timeline(self, surface: pygame.Surface, rect: pygame.Rect, t: float, start: float, end: float) -> None:
        pygame.draw.rect(surface, (20, 20, 24), rect.inflate(4, 4))
        done = rect.copy()
        done.width = int(rect.width * ((t - start) / (end - start) if end > start else 0.0))
        pygame.draw.rect(surface, (90, 160, 240), done)
        pygame.draw.rect(surface, (200, 200, 210), rect, 1)
        span = f"{t:6.2f} / {end:.2f} s" if start == 0 else f"{t:6.2f} s ({start:.2f} .. {end:.2f})"
        self._text(surface, span, (rect.x, rect.y - 20), TEXT, backed=True)

    def _help(self, surface: pygame.Surface, lines: list[str]) -> None:
        w, h = surface.get_size()
        panel = pygame.Surface((min(w - 40, 720), 40 + 22 * len(lines)), pygame.SRCALPHA)
        panel.fill((0, 0, 0, 200))
        rect = panel.get_rect(center=(w // 2, h // 2))
        surface.blit(panel, rect)
        self._text(surface, "quadsim keys", (rect.x + 16, rect.y + 10), WARN, font=self.big)
        # the lines are "KEYS" padded to column 11, then what they do: two aligned columns
        rows = [(line[:11].strip(), line[11:], True) if line[10:11] == " " else ("", line, False) for line in lines]
        column = 16 + max((self.font.size(keys)[0] for keys, _, _ in rows), default=0) + 18
        for i, (keys, what, aligned) in enumerate(rows):
            y = rect.y + 40 + 22 * i
            self._text(surface, keys, (rect.x + 16, y), WARN)
            self._text(surface, what, (rect.x + (column if aligned else 16), y), TEXT)

    def _text(
        self,
        surface: pygame.Surface,
        text: str,
        pos: tuple[int, int],
        color,
        center: bool = False,
        font=None,
        backed: bool = False,
    ) -> None:
        """`backed`: on a dark box, readable over a bright camera image (the floor, the sky)."""
        img = (font or self.font).render(text, True, color)
        where = img.get_rect(center=pos) if center else img.get_rect(topleft=pos)
        if backed:
            surface.fill((10, 10, 12), where.inflate(8, 2))
        surface.blit(img, where)


def _z_text(command: Twist, z_mode: str) -> str:
    """linear.z as the HUD says it: a climb rate, or in height z-mode the altitude it wants."""
    if z_mode == "height":
        return f"alt wanted {HEIGHT_MODE_BASE_M + command.linear_z:.2f} m"
    return f"z {_signed(command.linear_z)} m/s"


def _signed(value: float, digits: int = 2) -> str:
    """`value` with its sign, never -0.00 (a value that rounds to zero is +0.00)."""
    return f"{round(value, digits) + 0.0:+.{digits}f}"


def _arrow(px, x: float, y: float, yaw: float) -> list[tuple[int, int]]:
    """A vehicle on the map: an arrow head at (x, y) pointing along its heading."""
    return [
        px(x + 0.9 * math.cos(yaw), y + 0.9 * math.sin(yaw)),
        px(x + 0.5 * math.cos(yaw + 2.5), y + 0.5 * math.sin(yaw + 2.5)),
        px(x + 0.5 * math.cos(yaw - 2.5), y + 0.5 * math.sin(yaw - 2.5)),
    ]


def _camera_hud_line(m: ViewModel) -> tuple[str, tuple[int, int, int]]:
    """The HUD's line of the cameras' achieved rates (and drops), a warning when they fall short."""
    achieved = "  ".join(f"{name} {rate:4.1f}" for name, rate in sorted(m.camera_rates.items()))
    short = bool(m.camera_rate_hz) and min(m.camera_rates.values()) < 0.8 * m.camera_rate_hz
    return (
        f"cameras {achieved} of {m.camera_rate_hz} frames/s"
        + (f", {m.camera_dropped} dropped" if m.camera_dropped else "")
        + ("  (busy: frames dropped" + ("" if m.lagging else " to keep real time") + ")" if short else ""),
        WARN if short else TEXT,
    )
