"""The teleop window, driven headless (SDL dummy video) with synthetic pygame events, in what only
a fleet has (`fly --fleet`): a fleet watched with no vehicle to fly by hand, a script of another
vehicle flown again after a reset, and a keyboard vehicle in height mode; cameras rendered by worker
processes, as `fly --fleet` renders them.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_teleop.py."""

from __future__ import annotations

import pygame

from quadsim.recording.flight import load_flights
from tests.integration.test_teleop import FLEET, FPS, fleet_app, key, run_with


def test_a_fleet_without_a_keyboard_or_gamepad_vehicle_is_watched_and_says_so(tmp_path):
    """No vehicle takes a hand: the window watches the first, named in the HUD with what flies
    it, its camera panes say whose cameras are missing, and the keys fly nothing."""
    watched = FLEET.replace('input = "keyboard"\ncameras = ["front", "floor"]', 'input = "script:yaw"')
    app = fleet_app(tmp_path, watched, render_workers=2)
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
    app = fleet_app(
        tmp_path, FLEET.replace('input = "script:square"', 'input = "script:short.qscript"'), render_workers=2
    )
    bravo = app.session.fleet["bravo"]
    run_with(app, 3 * FPS)
    assert bravo.driver.finished and bravo.state.position_m[2] > 1.0
    run_with(app, 1, {0: [lambda: key(pygame.K_BACKSPACE)]})
    run_with(app, 2 * FPS)
    assert bravo.state.position_m[2] > 1.0, bravo.state.position_m
    app.close()
    again = load_flights(app.recordings[1])["bravo"]
    assert again.commands and again.commands[0][0] < 0.1  # from the reset's first step on


def test_a_keyboard_vehicle_in_height_mode_is_flown_in_height_mode(tmp_path):
    """The keys read in the z-mode of the vehicle they fly: at rest nothing moves (in velocity
    terms a zero climb would have meant 'hold 2 m' to a height-mode gate), and W climbs.
    (A fleet's only: alone, the window's keyboard in height mode starts from 2 m, not from where
    the vehicle stands, so a tap takes it up to 2 m; tests/integration/test_teleop.py has no
    alone twin of this test for that reason.)"""
    app = fleet_app(
        tmp_path, FLEET.replace('input = "keyboard"', 'input = "keyboard"\nz_mode = "height"'), render_workers=2
    )
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
