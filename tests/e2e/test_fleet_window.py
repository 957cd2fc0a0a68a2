"""`fly --fleet`: the teleop window flies one vehicle of a fleet among the others (SDL dummy
video, synthetic key events; tests/e2e/test_window_x11.py has the real window)."""

from __future__ import annotations

import math
from pathlib import Path

import pygame

from quadsim import SimConfig
from quadsim.apps.plans import fleet_drivers
from quadsim.apps.window.teleop import FleetSetup, TeleopApp, TeleopOptions
from quadsim.recording.flight import load_flights
from quadsim.sensors.camera import default_cameras
from quadsim.session.outputs import OutputOptions
from quadsim.session.pacing import FixedStepPacer
from quadsim.sim.fleet_file import load_fleet_file
from tests.helpers.fleets import fleet_toml, vehicle
from tests.integration.test_cli import cli
from tests.integration.test_teleop import FPS, key, run_with

FLEET = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="keyboard", cameras=["front", "floor"]),
    vehicle("bravo", (0.0, -4.0, 0.0, 0.0), input="script:square", cameras=["front"]),
    vehicle("charlie", (-4.0, 0.0, 0.0, 0.0)),
)


def fleet_app(tmp_path: Path, text: str = FLEET, input: str = "keyboard") -> TeleopApp:
    """The window as `fly --fleet` opens it for the fleet file `text` (`input`: the device of its
    first keyboard or gamepad vehicle, as fly --fleet sets it)."""
    (tmp_path / "three.toml").write_text(text)
    fleet_file = load_fleet_file(tmp_path / "three.toml")
    specs = {c.name: c for c in default_cameras(160, 120, 30)}
    cameras = {v.name: tuple(specs[c] for c in v.cameras) for v in fleet_file.vehicles if v.cameras}
    return TeleopApp(
        SimConfig(),
        OutputOptions(out=tmp_path, cameras=()),
        TeleopOptions(input=input),
        pacer=FixedStepPacer(240, 1 / FPS),
        fleet=FleetSetup(fleet_file, fleet_drivers(fleet_file), cameras),
    )


def test_the_keyboard_flies_its_vehicle_the_map_shows_the_others_and_c_cycles_the_cameras(tmp_path):
    app = fleet_app(tmp_path)
    assert app.fleet is not None and app.fleet.flown == "alpha" and app.fleet.shown == "alpha"
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
    alpha = app.sim.state.position_m
    assert 1.3 < alpha[2] < 1.8 and alpha[0] > 1.2, alpha  # the keys flew alpha
    bravo = app.session.fleet["bravo"].state.position_m
    assert bravo[2] > 1.5 and bravo[0] > 0.5, bravo  # its square, meanwhile (6 s: take-off, then forward)
    assert app.session.fleet["charlie"].state.position_m[2] < 0.1  # idle
    model = app._model()
    assert [name for name, *_ in model.others] == ["bravo", "charlie"] and model.cameras_of == "alpha"
    (_, position, _, points) = model.others[0]
    assert math.dist(position, bravo[:2]) < 1e-9 and len(points) > 10  # bravo's track, for the map
    assert set(app.frames) == {"front", "floor"}
    first = app.frames["front"].step
    run_with(app, 3, {0: [lambda: key(pygame.K_c)]})
    assert app.fleet.shown == "bravo" and app._model().cameras_of == "bravo"
    run_with(app, 6)
    assert set(app.frames) == {"front"} and app.frames["front"].step > first  # bravo has only a front camera
    run_with(app, 3, {0: [lambda: key(pygame.K_c)]})
    assert app.fleet.shown == "alpha"  # and round again
    app.view.draw(app.screen, app._model())  # the map with the others draws
    app.close()
    flights = load_flights(app.recordings[0])
    assert list(flights) == ["alpha", "bravo", "charlie"]
    assert any(t.linear_z > 0.5 for _, t in flights["alpha"].commands)  # the keyboard's climb, under alpha
    assert {len(f) for f in flights["alpha"].frames.values()} and set(flights["bravo"].frames) == {"front"}
    out = cli("check", str(app.recordings[0]), "--tolerance-m", "0", "--tolerance-rad", "0")
    assert out.returncode == 0 and "(a fleet of 3)" in out.stdout, out.stdout + out.stderr


def test_backspace_resets_the_whole_fleet(tmp_path):
    app = fleet_app(tmp_path)
    run_with(app, 90, {0: [lambda: key(pygame.K_w)], 60: [lambda: key(pygame.K_w, False)]})
    assert app.sim.state.position_m[2] > 1.0 and app.session.fleet["bravo"].state.position_m[2] > 0.5
    run_with(app, 1, {0: [lambda: key(pygame.K_BACKSPACE)]})
    for name in ("alpha", "bravo"):
        assert app.session.fleet[name].state.position_m[2] < 0.2, name
    assert app.session.fleet.step_count < 20
    assert app.flown_s > 1.3  # the clock started again; the time flown did not
    lines = app.final_lines()
    assert [line.split()[0] for line in lines] == ["alpha", "bravo", "charlie"] and "script square" in lines[1]
    app.close()
    assert len(app.recordings) == 2  # a new recording from the reset on


def test_a_keyboard_vehicle_in_height_mode_is_flown_in_height_mode(tmp_path):
    """The keys read in the z-mode of the vehicle they fly: at rest nothing moves (in velocity
    terms a zero climb would have meant 'hold 2 m' to a height-mode gate), and W climbs."""
    app = fleet_app(tmp_path, FLEET.replace('input = "keyboard"', 'input = "keyboard"\nz_mode = "height"'))
    assert app.sim.gate.z_mode.value == "height" and app.keyboard.z_mode.value == "height"
    run_with(app, 60, {0: [lambda: key(pygame.K_UP)], 2: [lambda: key(pygame.K_UP, False)]})
    assert app.sim.state.position_m[2] < 0.1, app.sim.state.position_m  # a tap forward: still on the ground
    run_with(app, 90, {0: [lambda: key(pygame.K_w)], 45: [lambda: key(pygame.K_w, False)]})
    assert app.sim.state.position_m[2] > 0.5, app.sim.state.position_m
    run_with(
        app,
        60,
        {0: [lambda: key(pygame.K_BACKSPACE)], 2: [lambda: key(pygame.K_UP)], 4: [lambda: key(pygame.K_UP, False)]},
    )
    assert app.sim.state.position_m[2] < 0.1, app.sim.state.position_m  # after a reset as at the start
    app.close()


def test_a_fleet_without_a_keyboard_or_gamepad_vehicle_is_watched_and_says_so(tmp_path):
    """No vehicle takes a hand: the window watches the first, named in the HUD with what flies
    it, its camera panes say whose cameras are missing, and the keys fly nothing."""
    watched = FLEET.replace('input = "keyboard"\ncameras = ["front", "floor"]', 'input = "script:yaw"')
    app = fleet_app(tmp_path, watched)
    assert app.fleet is not None and not app.fleet.by_hand and app.fleet.flown == "alpha"
    assert app._input_status() == "watching alpha (script yaw); the keys fly nothing"
    run_with(app, 60, {0: [lambda: key(pygame.K_UP)], 50: [lambda: key(pygame.K_UP, False)]})
    model = app._model()
    assert model.cameras_of == "bravo" and model.camera_names == frozenset({"front"})  # the only camera'd one
    x, y, _ = app.sim.state.position_m
    assert abs(x) < 0.05 and abs(y) < 0.05  # the arrow key moved nothing: alpha turns on the spot
    app.close()
    flights = load_flights(app.recordings[0])
    assert flights["charlie"].description is not None and flights["charlie"].description.driver_name == "idle"


def test_backspace_plays_a_finished_script_again_from_its_start(tmp_path):
    """A script that had ended before the reset flies again after it (the clock starts at 0,
    and so does the script), and its commands are in the new recording."""
    (tmp_path / "short.qscript").write_text("z_mode height\n1.0 linear.z=0\n")
    app = fleet_app(tmp_path, FLEET.replace('input = "script:square"', 'input = "script:short.qscript"'))
    bravo = app.session.fleet["bravo"]
    run_with(app, 3 * FPS)
    assert bravo.driver.finished and bravo.state.position_m[2] > 1.0
    run_with(app, 1, {0: [lambda: key(pygame.K_BACKSPACE)]})
    run_with(app, 2 * FPS)
    assert bravo.state.position_m[2] > 1.0, bravo.state.position_m
    app.close()
    again = load_flights(app.recordings[1])["bravo"]
    assert again.commands and again.commands[0][0] < 0.1  # from the reset's first step on


def test_a_z_mode_switch_in_the_window_is_recorded_under_the_vehicle_flown(tmp_path):
    """Tab switches the flown vehicle's z-mode: the recording keeps the switch under its name, so
    the fleet re-flies to zero (it was a run event, and alpha's height commands re-flew as climbs)."""
    app = fleet_app(tmp_path)
    run_with(
        app,
        200,
        {
            0: [lambda: key(pygame.K_w)],
            40: [lambda: key(pygame.K_w, False)],
            60: [lambda: key(pygame.K_TAB)],  # height mode at the altitude reached
            80: [lambda: key(pygame.K_w)],
            120: [lambda: key(pygame.K_w, False)],
        },
    )
    assert app.sim.gate.z_mode.value == "height"
    app.close()
    flights = load_flights(app.recordings[0])
    assert [v for _, kind, v in flights["alpha"].events if kind == "z_mode"] == ["height"]
    assert not [v for _, kind, v in flights["bravo"].events if kind == "z_mode"]
    out = cli("check", str(app.recordings[0]), "--tolerance-m", "0", "--tolerance-rad", "0")
    assert out.returncode == 0 and "(a fleet of 3)" in out.stdout, out.stdout + out.stderr
