"""The teleop window, driven headless (SDL dummy video) with synthetic pygame events: flying one
vehicle (`fly`) or one vehicle of a fleet among the others (`fly --fleet`).

Its integration tests (several layers, in-process or one process started); the others are in tests/e2e/test_teleop.py."""

import math
import re
from pathlib import Path

import pygame
import pytest
from mcap.reader import make_reader

from quadsim import SimConfig, ZMode
from quadsim.apps.plans import fleet_drivers
from quadsim.apps.replay_export import summary_lines
from quadsim.apps.window.teleop import FleetSetup, TeleopApp, TeleopOptions
from quadsim.recording.flight import load_flight, load_flights
from quadsim.sensors.camera import default_cameras
from quadsim.session.outputs import OutputOptions
from quadsim.session.pacing import FixedStepPacer
from quadsim.session.resim import resimulate
from quadsim.sim.fleet_file import load_fleet_file
from tests.helpers.fleets import WINDOW_FLEET, fleet_toml, under, vehicle
from tests.helpers.mcap import topic_messages

FPS = 30  # each frame advances 1/30 s of simulation time


def make_app(tmp_path: Path, cameras=(), options=TeleopOptions(), config=SimConfig(), **kw) -> TeleopApp:
    return TeleopApp(
        config,
        OutputOptions(out=tmp_path, cameras=cameras, render_workers=0),
        options,
        pacer=FixedStepPacer(240, 1 / FPS),
        **kw,
    )


FLEET = WINDOW_FLEET  # alpha by the keyboard (front and floor cameras), bravo on the square (front), charlie idle


def fleet_app(tmp_path: Path, text: str = FLEET, input: str = "keyboard", render_workers: int = 0) -> TeleopApp:
    """The window as `fly --fleet` opens it for the fleet file `text` (`input`: the device of its
    first keyboard or gamepad vehicle, as fly --fleet sets it); its cameras rendered in this
    process (as make_app's) or by `render_workers` worker processes."""
    (tmp_path / "three.toml").write_text(text)
    fleet_file = load_fleet_file(tmp_path / "three.toml")
    specs = {c.name: c for c in default_cameras(160, 120, 30)}
    cameras = {v.name: tuple(specs[c] for c in v.cameras) for v in fleet_file.vehicles if v.cameras}
    return TeleopApp(
        SimConfig(),
        OutputOptions(out=tmp_path, cameras=(), render_workers=render_workers),
        TeleopOptions(input=input),
        pacer=FixedStepPacer(240, 1 / FPS),
        fleet=FleetSetup(fleet_file, fleet_drivers(fleet_file), cameras),
    )


#: the window of each shape of run: one vehicle flown by the keyboard (no cameras), or FLEET's
APPS = {"alone": make_app, "fleet of 3": fleet_app}
#: each vehicle's cameras in each shape's window
CAMERAS = {"alone": {"": set()}, "fleet of 3": {"alpha": {"front", "floor"}, "bravo": {"front"}, "charlie": set()}}


def post(kind, **fields):
    pygame.event.post(pygame.event.Event(kind, **fields))


def key(k, down=True):
    post(pygame.KEYDOWN if down else pygame.KEYUP, key=k, mod=0, unicode="", scancode=0)


def run_with(app: TeleopApp, frames: int, schedule: dict[int, list] | None = None) -> None:
    """Run `frames` frames; schedule[frame] = [callables posting events before that frame]."""
    start = app.frame_count

    def before(a):
        for action in (schedule or {}).get(a.frame_count - start, []):
            action()

    app.run(max_frames=start + frames, before_frame=before)


def twist_messages(path: Path):
    return topic_messages(path, "/quad_cmd_twist")


@pytest.mark.parametrize("shape", list(APPS))
def test_keys_fly_where_they_say_and_are_recorded(shape, tmp_path):
    """The keys fly the vehicle flown, and only it: it is recorded under its names, its commands
    at the input rate, and the recording re-flies at 0. In a fleet the others fly meanwhile, the
    map shows them with their tracks, and C shows each camera'd vehicle's cameras in turn."""
    app = APPS[shape](tmp_path)
    names = list(app.session.fleet)
    flown, others, cameras = names[0], names[1:], CAMERAS[shape]
    assert list(cameras) == names
    run_with(
        app,
        180,
        {
            0: [lambda: key(pygame.K_w)],
            60: [lambda: key(pygame.K_w, False)],  # climb 2 s
            75: [lambda: key(pygame.K_UP)],
            135: [lambda: key(pygame.K_UP, False)],  # forward 2 s
        },
    )
    x, y, z = app.sim.state.position_m
    assert app.sim is app.session.fleet[flown]
    assert 1.3 < z < 1.8  # 2 s at 0.8 m/s
    assert x > 1.2 and abs(y) < 0.05
    lines = app.final_lines()  # what `fly` prints at the end, as `run` says it
    if others:  # a fleet's: a line each
        assert [line.split()[0] for line in lines] == names and "script square" in lines[1]
        assert f"final x={x:+.2f}" in lines[0] and "1 takeoff" in lines[0] and "; flown " in lines[0]
    else:
        said = "\n".join(lines)
        assert f"final pose      x={x:+.3f} m" in said and "distance flown  " in said
        assert "flight events   1 takeoff" in said
    model = app._model()
    assert [name for name, *_ in model.others] == others and model.cameras_of == flown
    for name, position, _, points in model.others:  # each other vehicle, and its track, for the map
        assert math.dist(position, app.session.fleet[name].state.position_m[:2]) < 1e-9 and len(points) > 10
    if others:  # meanwhile: bravo its square (6 s: take-off, then forward), charlie idle
        bravo = app.session.fleet["bravo"].state.position_m
        assert bravo[2] > 1.5 and bravo[0] > 0.5, bravo
        assert app.session.fleet["charlie"].state.position_m[2] < 0.1
    assert set(app.frames) == cameras[flown]
    shown = [n for n in names if cameras[n]]  # C: the next vehicle with cameras, and round again
    for name in [*shown[1:], *shown[:1]]:
        first = {camera: frame.step for camera, frame in app.frames.items()}
        run_with(app, 3, {0: [lambda: key(pygame.K_c)]})
        assert app.fleet.shown == name and app._model().cameras_of == name
        run_with(app, 6)
        assert set(app.frames) == cameras[name] and all(f.step > first.get(c, -1) for c, f in app.frames.items())
    app.view.draw(app.screen, app._model())  # the map with the others draws
    flown_s = app.sim.time_s
    app.close()
    path = app.recordings[0]
    msgs = topic_messages(path, under(flown, "quad_cmd_twist"))
    forward = [d.linear.x for t, d in msgs if 3.0 < t < 4.4]
    assert forward and all(v == pytest.approx(1.0) for v in forward)
    climbing = [d.linear.z for t, d in msgs if 0.2 < t < 1.9]
    assert climbing and all(v == pytest.approx(0.8) for v in climbing)
    assert all(d.linear.x == 0.0 for t, d in msgs if t > 4.6)  # released: that motion stops
    # published at the fixed 20 Hz whether or not anything changes, plus at each change
    assert 20 * flown_s <= len(msgs) <= 20 * flown_s + 6
    flights = load_flights(path)
    assert list(flights) == names
    assert any(t.linear_z > 0.5 for _, t in flights[flown].commands)  # the keyboard's climb, under its name
    for name in names:  # each vehicle's cameras, under its name
        assert set(flights[name].frames) == cameras[name] and all(flights[name].frames.values())
    again = resimulate(flights, record=False)  # as `check --tolerance-m 0 --tolerance-rad 0` re-flies it
    assert again.position.max_error == 0.0 and again.attitude.max_error == 0.0
    assert again.fleet_size == (len(names) if others else 0) and again.states_compared >= 6 * 60 * len(names)


def test_releasing_a_key_stops_the_motion(tmp_path):
    app = make_app(tmp_path, config=SimConfig(z_mode=ZMode.HEIGHT))
    run_with(app, 200, {60: [lambda: key(pygame.K_LEFT)], 120: [lambda: key(pygame.K_LEFT, False)]})
    assert app.sim.state.position_m[1] > 1.0  # flew left
    assert abs(app.sim.state.linear_velocity_mps[1]) < 0.05  # and stopped
    app.close()


def test_focus_loss_clears_held_keys(tmp_path):
    app = make_app(tmp_path, config=SimConfig(z_mode=ZMode.HEIGHT))
    run_with(app, 120, {60: [lambda: key(pygame.K_UP)], 80: [lambda: post(pygame.WINDOWFOCUSLOST)]})
    assert app.keyboard.held == set()
    assert app.sim.gate.last_command.linear_x == 0.0
    assert abs(app.sim.state.linear_velocity_mps[0]) < 0.1
    app.close()


def test_window_close_finishes_a_readable_recording(tmp_path):
    app = make_app(tmp_path)
    run_with(app, 1000, {10: [lambda: key(pygame.K_w)], 40: [lambda: post(pygame.QUIT)]})
    assert app.quit and app.frame_count == 40
    app.close()
    with open(app.recordings[0], "rb") as fh:
        summary = make_reader(fh).get_summary()
    counts = {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}
    assert counts["/quad/pose"] == 40 * 8 // 4 and counts["/quad_cmd_twist"] > 20


def test_escape_quits(tmp_path):
    app = make_app(tmp_path)
    run_with(app, 100, {5: [lambda: key(pygame.K_ESCAPE)]})
    assert app.quit and app.frame_count == 5
    app.close()


def test_pause_reset_zmode_and_recording_keys(tmp_path):
    app = make_app(tmp_path)
    run_with(app, 60, {0: [lambda: key(pygame.K_w)]})
    t = app.sim.time_s
    run_with(app, 10, {0: [lambda: key(pygame.K_p)]})
    assert app.paused and app.sim.time_s == t  # paused: no sim time passes
    run_with(app, 10, {0: [lambda: key(pygame.K_p), lambda: key(pygame.K_w, False)]})
    assert not app.paused and app.sim.time_s > t
    altitude = app.sim.state.position_m[2]
    run_with(app, 60, {0: [lambda: key(pygame.K_TAB)]})  # to height mode: holds where it is
    assert app.sim.gate.z_mode is ZMode.HEIGHT
    assert app.sim.state.position_m[2] == pytest.approx(altitude, abs=0.1)
    stopped_at = app.sim.time_s
    run_with(app, 2, {0: [lambda: key(pygame.K_F5)]})  # stop recording
    assert not app.session.outputs.recording
    started_at = app.sim.time_s
    run_with(app, 2, {0: [lambda: key(pygame.K_F5)]})  # a new one
    assert app.session.outputs.recording and len(app.recordings) == 2
    reset_at = app.sim.time_s
    run_with(app, 2, {0: [lambda: key(pygame.K_BACKSPACE)]})  # reset: back to start, new file
    assert app.sim.state.position_m[2] < 0.1 and len(app.recordings) == 3
    closed_at = app.sim.time_s
    app.close()
    for path in app.recordings:
        with open(path, "rb") as fh:
            assert make_reader(fh).get_summary() is not None
    # each file's /rosout says when its recording started and stopped, and what happened between
    first, second, third = ([(round(t, 6), m.msg) for t, m in rosout(path)] for path in app.recordings)
    assert first[0] == (0.0, "recording: started") and first[-1] == (round(stopped_at, 6), "recording: stopped")
    assert [msg for _, msg in first] == [
        "recording: started",
        "takeoff: climbing from the ground",
        "z_mode: height",
        "recording: stopped",
    ]
    assert second == [(round(started_at, 6), "recording: started"), (round(reset_at, 6), "recording: stopped")]
    # its summary gives the time it spans, and from when to when (as `info` does)
    summary = summary_lines(load_flight(app.recordings[1]))[1]
    assert summary == f"duration    {reset_at - started_at:.2f} s ({started_at:.2f} .. {reset_at:.2f} s)", summary
    assert summary_lines(load_flight(app.recordings[0]))[1] == f"duration    {stopped_at:.2f} s"
    assert third == [
        (0.0, "recording: started"),
        (0.0, "takeoff: climbing from the ground"),  # after the reset, from the ground again
        (round(closed_at, 6), "recording: stopped"),
    ]


@pytest.mark.parametrize("shape", list(APPS))
def test_backspace_resets_every_vehicle_and_starts_a_new_recording(shape, tmp_path):
    """Backspace: every vehicle back at its start on a clock started again (not the time flown,
    which the summary keeps counting), and a new recording from the reset on."""
    app = APPS[shape](tmp_path)
    names = list(app.session.fleet)
    run_with(app, 90, {0: [lambda: key(pygame.K_w)], 60: [lambda: key(pygame.K_w, False)]})
    assert app.sim.state.position_m[2] > 1.0
    if "bravo" in names:  # on its square meanwhile
        assert app.session.fleet["bravo"].state.position_m[2] > 0.5
    run_with(app, 1, {0: [lambda: key(pygame.K_BACKSPACE)]})
    for name in names:
        assert app.session.fleet[name].state.position_m[2] < 0.2, name
    assert app.session.fleet.step_count < 20
    assert app.flown_s > 1.3  # the clock started again; the time flown did not
    lines = app.final_lines()
    if len(names) > 1:
        assert [line.split()[0] for line in lines] == names and "script square" in lines[1]
    else:
        assert lines[0].startswith("final pose ") and "distance flown" in lines[1]
    app.close()
    assert len(app.recordings) == 2  # a new recording from the reset on


def rosout(path: Path):
    return topic_messages(path, "/rosout")


def test_speed_keys_and_teleop_twist_layout(tmp_path):
    app = make_app(
        tmp_path, options=TeleopOptions(keyboard_layout="teleop_twist_keyboard"), config=SimConfig(z_mode=ZMode.HEIGHT)
    )
    run_with(app, 40, {5: [lambda: key(pygame.K_q)], 10: [lambda: key(pygame.K_i)]})
    assert app.sim.gate.last_command.linear_x == pytest.approx(1.1)
    run_with(app, 5, {0: [lambda: key(pygame.K_k)]})  # k: stop
    assert app.sim.gate.last_command.linear_x == 0.0
    # H strafes in this layout: the HUD, the help and the terminal name F1 alone (they said H/F1)
    assert app.help_keys == "F1" and app._help_lines()[-1] == "F1         this help"
    assert all(not line.startswith("H, F1") for line in app._help_lines())
    app.close()


def test_the_hud_wraps_a_long_line_within_its_box_and_says_no_negative_zero(tmp_path):
    """At 800x600 long HUD lines ran over the floor camera's pane and off the window's edge;
    a vehicle at rest said 'climb -0.00 m/s'."""
    from quadsim.apps.window.view import _signed

    app = make_app(tmp_path, options=TeleopOptions(window_size=(800, 600)))
    run_with(app, 5)
    app._say("a notice long enough to run past the HUD's right edge at this size of window, " * 2)
    run_with(app, 1)
    hud = app.view.layout(app.screen.get_size())["front"]
    pixels = pygame.surfarray.array3d(app.screen).swapaxes(0, 1)
    floor = app.view.layout(app.screen.get_size())["floor"]
    green = (pixels[..., 1] > 180) & (pixels[..., 0] < 150)  # the notice's colour (OK)
    assert green[:, : hud.right].any() and not green[floor.top : floor.bottom, floor.left :].any()
    assert [_signed(-0.001), _signed(-0.04, 1), _signed(-1.5)] == ["+0.00", "+0.0", "-1.50"]
    app.close()


def test_window_shows_both_cameras_map_and_hud(tmp_path):
    from quadsim.sensors.camera import default_cameras

    app = make_app(tmp_path, cameras=default_cameras(), options=TeleopOptions(window_size=(960, 540)))
    run_with(app, 90, {0: [lambda: key(pygame.K_w)], 45: [lambda: key(pygame.K_w, False)]})
    pygame.image.save(app.screen, str(tmp_path / "window.png"))
    pixels = pygame.surfarray.array3d(app.screen).swapaxes(0, 1)
    rects = app.view.layout(app.screen.get_size())
    for name in ("front", "floor"):
        r = rects[name]
        region = pixels[r.top + 30 : r.bottom - 30, r.left + 10 : r.right - 10]
        assert region.std() > 20, f"{name} camera area is flat"
    m = rects["map"]
    colours = {tuple(c) for c in pixels[m.top : m.bottom, m.left : m.right].reshape(-1, 3)}
    assert (255, 70, 70) in colours  # the vehicle's arrow
    assert (216, 30, 25) in colours and (38, 76, 216) in colours  # the red tower, the blue block
    front = rects["front"]
    column = pixels[front.top : front.centery, front.centerx + 150].astype(int)  # above the horizon
    blue = (column[:, 2] > column[:, 0] + 40) & (column[:, 2] > 150)
    assert blue.sum() > 20  # the front camera's blue sky, below the HUD
    assert set(app.frames) == {"front", "floor"}
    # paused, the cameras deliver nothing and the HUD says nothing of their rate (it used to say
    # the machine was busy); resumed, they are counted afresh
    wall = [1000.0]  # the HUD's wall clock, moved by hand: whatever the machine's load
    app.wall_clock = lambda: wall[0]
    run_with(app, 2, {0: [lambda: key(pygame.K_p)]})
    assert app.paused and app.camera_rates() == {} and not app._model().camera_rates
    run_with(app, 2, {0: [lambda: key(pygame.K_p)]})
    wall[0] += 0.4
    assert not app.paused and app.camera_rates() == {}  # not yet counted for half a second
    wall[0] += 0.2
    assert set(app.camera_rates()) <= {"front", "floor"}  # counted from then on
    # the window resizes
    app.screen = pygame.display.set_mode((640, 480), pygame.RESIZABLE)
    run_with(app, 2)
    assert app.view.layout(app.screen.get_size())["front"].width < 640
    app.close()


def test_without_cameras_the_panes_say_the_cameras_are_off(tmp_path, monkeypatch):
    """--cameras none: the camera panes say so (they said "no image yet", as if one would come)."""
    from quadsim.apps.window.view import TeleopView

    said: dict[str, str] = {}
    draw_camera = TeleopView._camera

    def spy(self, surface, rect, frame, title, empty):
        said[title] = empty
        return draw_camera(self, surface, rect, frame, title, empty)

    monkeypatch.setattr(TeleopView, "_camera", spy)
    app = make_app(tmp_path, cameras=())
    run_with(app, 2)
    app.close()
    assert said == {"front camera": "cameras off (--cameras none)", "floor camera": "cameras off (--cameras none)"}
    # a fleet whose file gives no vehicle cameras: no option was given, so none is named
    said.clear()
    app = fleet_app(tmp_path, fleet_toml(vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="keyboard")))
    run_with(app, 2)
    app.close()
    assert set(said.values()) == {"no vehicle of this fleet has cameras"}, said


def test_input_foxglove_flies_the_delivered_twists_and_ignores_the_keyboard(tmp_path: Path) -> None:
    from quadsim.drivers.subscribed import SubscribedDriver

    commands = SubscribedDriver("foxglove")
    app = make_app(tmp_path, options=TeleopOptions(input="foxglove"), commands=commands)
    try:
        assert app.driver is commands
        for _ in range(60):  # 2 s: forward and up, as a Teleop panel publishing at 20 Hz (one per frame here)
            commands.deliver((1.0, 0.0, 0.5), 0.0)
            run_with(app, 1, {0: [lambda: key(pygame.K_DOWN)]})  # a held back key flies nothing
        x, _, z = app.sim.state.position_m
        assert x > 1.0 and z > 0.5
        assert "foxglove" in app._model().input_status
    finally:
        app.close()


def test_slow_is_said_only_while_the_flight_is_behind_real_time(tmp_path, monkeypatch):
    """The pacer holds its 'behind' flag a while after a hiccup; the HUD said SLOW beside 1.00x."""
    app = make_app(tmp_path)
    run_with(app, 2)
    app.pacer.lagging = True
    monkeypatch.setattr(app, "_rates", lambda: (60.0, 1.0))
    assert not app._model().lagging
    monkeypatch.setattr(app, "_rates", lambda: (60.0, 0.6))
    assert app._model().lagging
    app.close()


def test_the_window_says_what_it_is_doing_before_it_flies(tmp_path, monkeypatch, capsys):
    """Before the run opens (the world, the cameras' workers, a first compile: seconds on a busy
    machine), the window shows what it is doing, not black, and the terminal says the slow parts."""
    import numpy as np

    import quadsim.apps.window.teleop as teleop
    from quadsim.sensors.camera import default_cameras

    seen: list[np.ndarray] = []
    real_run = teleop.Run

    def run_seen(plan, say):
        seen.append(pygame.surfarray.array3d(pygame.display.get_surface()).copy())
        said: list[str] = []
        run = real_run(plan, say=lambda note: (said.append(note), say(note)))
        seen.append(pygame.surfarray.array3d(pygame.display.get_surface()).copy())
        assert said == ["starting 2 cameras"]  # the compile is cached: the cameras are the slow part
        return run

    monkeypatch.setattr(teleop, "Run", run_seen)
    app = make_app(tmp_path, cameras=default_cameras())
    app.close()
    before, after = seen
    assert (before.max(axis=2) > 200).sum() > 500  # light text on the dark start-up screen
    assert (after.max(axis=2) > 200).sum() > (before.max(axis=2) > 200).sum()  # and a line more: the cameras
    assert "quadsim: starting 2 cameras..." in capsys.readouterr().err


def test_a_reset_is_not_counted_as_distance_flown():
    """The odometer of a run's summary adds up the path, not the jump back to the start."""
    from quadsim.core.types import VehicleState
    from quadsim.session.summary import Odometer

    class Still:  # what the odometer asks of its vehicle
        step_count, events = 0, []

    odometer = Odometer(Still())  # type: ignore[arg-type]
    zero = (0.0, 0.0, 0.0)
    for step, x in ((4, 0.0), (8, 3.0), (4, 0.0), (8, 1.0)):  # 3 m out, reset to the start, 1 m
        odometer.on_state(VehicleState(step, (x, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0), zero, zero, (0.0,) * 4, zero))
    assert odometer.distance_m == 4.0


def test_the_start_up_lines_are_not_drawn_on_a_lost_display():
    """A window killed while quadsim starts: its start-up lines are not drawn on the lost display
    (the frame loop then ends the run), as nothing touches a display once it is lost."""
    from types import SimpleNamespace

    from quadsim.apps.window.display import show_starting

    pygame.display.init()
    pygame.font.init()
    try:
        screen = pygame.display.set_mode((160, 120))
        show_starting(screen, ["quadsim is starting"], SimpleNamespace(lost=True))  # type: ignore[arg-type]
        assert screen.get_at((0, 0))[:3] == (0, 0, 0)
        show_starting(screen, ["quadsim is starting"], SimpleNamespace(lost=False))  # type: ignore[arg-type]
        assert screen.get_at((0, 0))[:3] == (18, 20, 26)
    finally:
        pygame.display.quit()


def test_the_camera_rates_after_a_reset_count_every_frame_over_every_second_flown(tmp_path):
    """After Backspace the summary divided every frame of the session by the time since the reset:
    'front 272.5 of 30 Hz'."""
    from quadsim.sensors.camera import default_cameras

    app = make_app(tmp_path, cameras=default_cameras(160, 120, 30))
    run_with(app, 60, {30: [lambda: key(pygame.K_BACKSPACE)]})  # 1 s before the reset, 1 s after
    line = app.session.summaries()[""].cameras
    app.close()
    rates = [float(r) for r in re.findall(r"(\d+\.\d) of 30 Hz", line)]
    assert len(rates) == 2 and all(25.0 < r <= 31.0 for r in rates), line
