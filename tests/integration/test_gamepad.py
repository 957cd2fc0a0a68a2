"""Gamepads through SDL's real device path: virtual devices plugged into pygame's own SDL library
(tests/helpers/sdl_virtual.py), flying the real TeleopApp headless, checked by where the vehicle went and
what the recording holds."""

import math

import pygame
import pytest

from quadsim import ConfigError, SimConfig, ZMode
from quadsim.apps.window.teleop import TeleopOptions
from quadsim.drivers.gamepad import PadKind
from quadsim.drivers.joystick import JoystickMapping, apply_deadzone, load_mapping
from quadsim.recording.reader import RecordingReader
from tests.helpers import ROOT
from tests.helpers.fleets import fleet_toml, vehicle
from tests.helpers.mcap import topic_messages
from tests.helpers.sdl_virtual import LEFTX, LEFTY, RIGHTX, RIGHTY, SDL_HAT_LEFT, SDL_HAT_UP, VirtualPad, sdl
from tests.integration.test_teleop import FPS, key, make_app, run_with


@pytest.fixture
def pads():
    """Plug virtual pads with `pads(...)` (VirtualPad's arguments); all are unplugged afterwards."""
    pygame.joystick.init()
    try:
        sdl().allow_background_events()
    except OSError as exc:
        pytest.skip(f"pygame's SDL library cannot be loaded through ctypes: {exc}")
    made = []

    def plug(**kw):
        pad = VirtualPad(**kw)
        made.append(pad)
        return pad

    def clear_events():  # the queue needs the video subsystem, which each app shuts on closing
        pygame.display.init()
        pygame.event.clear()

    clear_events()
    yield plug
    for pad in made:
        pad.unplug()
    clear_events()
    pygame.display.quit()


def where(app):
    s = app.sim.state
    return (*s.position_m, s.yaw_rad())


def in_heading_frame(before, after):
    """Displacement from `before` to `after` in the heading frame of `before` (x forward, y left)."""
    dx, dy = after[0] - before[0], after[1] - before[1]
    c, s = math.cos(before[3]), math.sin(before[3])
    return c * dx + s * dy, -s * dx + c * dy, after[2] - before[2]


def hold(app, pad, axes: dict[int, float], seconds: float, then_centre=True):
    """Hold the sticks at `axes` (SDL's sign) for `seconds`, then let them spring back."""
    for axis, value in axes.items():
        pad.set_axis(axis, value)
    run_with(app, round(seconds * FPS))
    if then_centre:
        for axis in axes:
            pad.set_axis(axis, 0.0)
        run_with(app, 2)


def read_topic(path, topic):
    return topic_messages(path, topic)


def events(path):
    with RecordingReader(path) as rec:
        return rec.events


# --- a pad SDL knows: the game-controller layer -------------------------------------------------


def test_game_controller_at_rest_moves_nothing(tmp_path, pads):
    """Sticks centred and triggers released (-1, as SDL reports them) command zero: the pad that
    used to fly off at full speed the moment it was detected."""
    pad = pads(game_controller=True)
    app = make_app(tmp_path)
    assert app.driver is app.joystick and app.joystick.pad.kind is PadKind.GAME_CONTROLLER
    raw = pygame.joystick.Joystick(pad.device_index())  # what the old driver read: raw axes 4 and 5
    assert raw.get_axis(4) < -0.99 and raw.get_axis(5) < -0.99  # the triggers rest at -1
    start = where(app)
    run_with(app, 2 * FPS)
    c = app.sim.gate.last_command
    assert (c.linear_x, c.linear_y, c.linear_z, c.angular_z) == (0.0, 0.0, 0.0, 0.0)
    assert all(abs(a - b) < 0.01 for a, b in zip(where(app), start))
    assert app.joystick.warnings() == []
    app.close()


@pytest.mark.parametrize("game_controller", [True, False], ids=["game_controller", "plain_joystick"])
def test_each_stick_moves_the_vehicle_the_right_way(tmp_path, pads, game_controller):
    """Mode 2: left stick up climbs, left stick left turns left (+yaw); right stick up flies
    forward (+x in the heading frame), right stick left flies left (+y). A plain joystick (no SDL
    mapping) is read raw with the same default axes (0/1 left stick, 2/3 right stick)."""
    if game_controller:
        pad = pads(game_controller=True)
    else:
        pad = pads(game_controller=False, naxes=4, nbuttons=8, nhats=1)
    app = make_app(tmp_path, options=TeleopOptions(input="joystick"))
    kind = PadKind.GAME_CONTROLLER if game_controller else PadKind.JOYSTICK
    assert app.joystick.pad is not None and app.joystick.pad.kind is kind
    run_with(app, 5)

    p0 = where(app)
    hold(app, pad, {LEFTY: -1.0}, 1.5)  # left stick up: climb at 1 m/s
    p1 = where(app)
    assert 1.0 < p1[2] - p0[2] < 1.7 and abs(p1[0] - p0[0]) < 0.1 and abs(p1[1] - p0[1]) < 0.1

    hold(app, pad, {RIGHTY: -0.6}, 1.5)  # right stick up: forward
    p2 = where(app)
    fwd, left, up = in_heading_frame(p1, p2)
    assert fwd > 0.8 and abs(left) < 0.15 and abs(up) < 0.15

    run_with(app, FPS)
    p3 = where(app)
    hold(app, pad, {RIGHTX: -0.6}, 1.5)  # right stick left: fly left
    p4 = where(app)
    fwd, left, up = in_heading_frame(p3, p4)
    assert left > 0.8 and abs(fwd) < 0.15 and abs(up) < 0.15

    run_with(app, FPS)
    p5 = where(app)
    hold(app, pad, {LEFTX: -1.0}, 1.0)  # left stick left: turn counter-clockwise
    p6 = where(app)
    assert 0.6 < p6[3] - p5[3] < 1.6
    assert math.dist(p5[:3], p6[:3]) < 0.3

    run_with(app, FPS)
    p7 = where(app)
    hold(app, pad, {RIGHTY: -0.6}, 1.5)  # forward again: along the new heading, not world x
    fwd, left, up = in_heading_frame(p7, where(app))
    assert fwd > 0.8 and abs(left) < 0.2
    assert where(app)[1] - p7[1] > 0.5  # turned ~60-90 deg left, forward now has a +y part

    hold(app, pad, {LEFTY: 1.0}, 0.5)  # left stick down: descend
    assert where(app)[2] < p7[2] - 0.3
    app.close()

    # /joy in the recording: the ROS joy convention, stick up and left positive
    joy = read_topic(app.recordings[0], "/joy")
    twist = read_topic(app.recordings[0], "/quad_cmd_twist")
    naxes = 6 if game_controller else 4 + 2  # a raw joystick's hat is two more axes, as joy_node has it
    assert joy and all(len(m.axes) == naxes for _, m in joy)
    climbing = [m for t, m in joy if 0.4 < t - 5 / FPS < 1.3]
    assert climbing and all(m.axes[1] == pytest.approx(1.0) for m in climbing)
    forward = [(t, m) for t, m in joy if m.axes[3] > 0.1]
    assert forward and all(m.axes[3] == pytest.approx(apply_deadzone(0.6, 0.1), abs=1e-3) for _, m in forward)
    # a teleop_twist_joy config (axis_linear.x: 3, scale_linear.x: 1.5) replaying /joy flies forward too
    by_time = dict(twist)
    replayed = [(by_time[t].linear.x, m.axes[3] * 1.5) for t, m in forward if t in by_time]
    assert replayed and all(ours == pytest.approx(theirs, rel=1e-5) for ours, theirs in replayed)
    if game_controller:
        assert all(m.axes[4] == 0.0 and m.axes[5] == 0.0 for _, m in joy)  # released triggers: 0 in ROS
        assert all(len(m.buttons) == 21 for _, m in joy)


def test_a_raw_joysticks_hat_is_published_as_two_axes(tmp_path, pads):
    pad = pads(game_controller=False, naxes=4, nbuttons=8, nhats=1)
    app = make_app(tmp_path, options=TeleopOptions(input="joystick"))
    pad.set_hat(0, SDL_HAT_LEFT | SDL_HAT_UP)
    pad.set_button(2, True)
    run_with(app, 10)
    app.close()
    last = read_topic(app.recordings[0], "/joy")[-1][1]
    assert list(last.axes) == [0.0, 0.0, 0.0, 0.0, 1.0, 1.0]  # hat left and up: both positive
    assert list(last.buttons) == [0, 0, 1, 0, 0, 0, 0, 0]


# --- the centring guard --------------------------------------------------------------------------


def test_a_stick_held_when_the_pad_appears_moves_nothing_until_centred(tmp_path, pads):
    app = make_app(tmp_path, options=TeleopOptions(input="joystick", window_size=(960, 540)))
    assert app.joystick.pad is None and any("plug one in" in w for w in app._model().warnings)
    run_with(app, 5)
    # plugged in with the left stick held up (climb) and the right stick pushed forward
    pad = pads(game_controller=True, axes={LEFTY: -0.8, RIGHTY: -1.0})
    run_with(app, 2 * FPS)
    assert app.joystick.pad is not None
    assert app.sim.state.position_m[2] < 0.05 and abs(app.sim.state.position_m[0]) < 0.01  # still on the ground
    c = app.sim.gate.last_command
    assert c.linear_z == 0.0 and c.linear_x == 0.0
    warning = app._model().warnings[0]
    assert warning.startswith("centre the sticks to fly")
    assert warning == (
        "centre the sticks to fly: right stick held up (forward/back), left stick held up (climb/descend)"
    )
    pygame.image.save(app.screen, str(tmp_path / "centre_the_sticks.png"))
    # let the left stick go back to the centre: it works from then on; the right one still does not
    pad.set_axis(LEFTY, 0.0)
    run_with(app, 3)
    assert app._model().warnings[0] == "centre the sticks to fly: right stick held up (forward/back)"
    hold(app, pad, {LEFTY: -0.8}, 1.5, then_centre=False)
    assert app.sim.state.position_m[2] > 0.8
    assert abs(app.sim.state.position_m[0]) < 0.1  # the right stick, never centred, still moves nothing
    pad.set_axis(RIGHTY, 0.0)
    pad.set_axis(LEFTY, 0.0)
    run_with(app, 3)
    assert app.joystick.warnings() == []
    hold(app, pad, {RIGHTY: -1.0}, 1.0)
    assert app.sim.state.position_m[0] > 0.8
    app.close()


def test_unplug_holds_position_and_replug_resumes(tmp_path, pads):
    pad = pads(game_controller=True)
    app = make_app(tmp_path)
    run_with(app, 5)
    hold(app, pad, {LEFTY: -1.0}, 1.5)
    pad.set_axis(RIGHTY, -1.0)  # full forward ...
    run_with(app, FPS)
    assert app.sim.state.linear_velocity_mps[0] > 1.0
    pad.unplug()  # ... and the cable comes out mid-flight
    run_with(app, 2 * FPS)
    assert app.joystick.pad is None and app.sim.gate.active(app.sim.step_count).hold
    assert any("unplugged" in w and "holding position" in w for w in app._model().warnings)
    held = where(app)
    run_with(app, FPS)
    assert math.dist(held[:3], where(app)[:3]) < 0.05  # holding where it is
    assert abs(app.sim.state.linear_velocity_mps[0]) < 0.05
    # plugged in again, the stick still pushed forward: nothing moves until it is centred
    pad.plug(axes={RIGHTY: -1.0})
    run_with(app, FPS)
    assert app.joystick.pad is not None and not app.sim.gate.active(app.sim.step_count).hold
    assert math.dist(held[:3], where(app)[:3]) < 0.05
    pad.set_axis(RIGHTY, 0.0)
    run_with(app, 3)
    hold(app, pad, {RIGHTY: -1.0}, 1.0)
    assert where(app)[0] - held[0] > 0.8  # flying again
    app.close()
    kinds = [(kind, value) for _, kind, value in events(app.recordings[0])]
    assert ("input", "gamepad unplugged: Virtual Controller; holding position") in kinds
    assert ("input", "gamepad plugged in: Virtual Controller (SDL game controller)") in kinds
    # /rosout carries each at the step it happened
    rosout = [(t, m.msg) for t, m in read_topic(app.recordings[0], "/rosout")]
    for step, kind, value in events(app.recordings[0]):
        assert (step * 1_000_000_000 // 240 / 1e9, f"{kind}: {value}") in rosout
    unplugged = [t for t, msg in rosout if "unplugged" in msg]
    plugged = [t for t, msg in rosout if "plugged in" in msg]
    assert len(unplugged) == 1 and unplugged[0] < plugged[-1]


# --- --input auto --------------------------------------------------------------------------------


def test_auto_switches_to_a_pad_plugged_in_after_start(tmp_path, pads):
    app = make_app(tmp_path)  # --input auto, no pad yet: the keyboard flies
    assert app.driver is app.keyboard
    run_with(app, 45, {0: [lambda: key(pygame.K_w)], 30: [lambda: key(pygame.K_w, False)]})  # climb 1 s
    altitude = app.sim.state.position_m[2]
    assert altitude > 0.5
    pad = pads(game_controller=True)
    run_with(app, 3)
    assert app.driver is app.joystick and app.joystick.pad is not None
    model = app._model()
    assert "gamepad plugged in: Virtual Controller (SDL game controller) flies now" in model.notice
    assert model.input_status == "gamepad Virtual Controller"
    hold(app, pad, {RIGHTY: -1.0}, 1.0)
    x, _, z = app.sim.state.position_m
    assert x > 0.8 and abs(z - altitude) < 0.2
    app.close()
    path = app.recordings[0]
    (step, kind, value), *_ = [e for e in events(path) if e[1] == "input"]
    assert value == "gamepad plugged in: Virtual Controller (SDL game controller); it flies instead of the keyboard"
    assert 45 * 8 <= step <= 48 * 8
    # and /rosout says so at that time, after "recording started" at 0 (Foxglove's Log panel shows them)
    rosout = [(t, m.msg) for t, m in read_topic(path, "/rosout")]
    assert rosout[0] == (0.0, "recording: started") and rosout[-1][1] == "recording: stopped"
    assert (step * 1_000_000_000 // 240 / 1e9, f"input: {value}") in rosout
    joy = read_topic(path, "/joy")
    assert joy and joy[0][0] >= step / 240 and any(m.axes[3] == 1.0 for _, m in joy)  # stick up: +1


def test_keyboard_input_ignores_pads(tmp_path, pads):
    pads(game_controller=True, axes={RIGHTY: -1.0})
    app = make_app(tmp_path, options=TeleopOptions(input="keyboard"))
    run_with(app, 10)
    assert app.driver is app.keyboard and app.joystick.pad is None
    app.close()


# --- buttons and the mapping --------------------------------------------------------------------


def test_enable_and_turbo_buttons_gate_motion(tmp_path, pads):
    pad = pads(game_controller=True)
    mapping = JoystickMapping(enable_button=9, enable_turbo_button=10)  # leftshoulder, rightshoulder
    app = make_app(tmp_path, options=TeleopOptions(input="joystick", joystick_mapping=mapping))
    run_with(app, 3)
    pad.set_axis(RIGHTY, -1.0)
    run_with(app, 10)
    assert app.sim.gate.last_command.linear_x == 0.0  # not enabled: no motion
    pad.set_button(9, True)
    run_with(app, 10)
    assert app.sim.gate.last_command.linear_x == pytest.approx(1.5)
    pad.set_button(9, False)
    pad.set_button(10, True)
    run_with(app, 10)
    assert app.sim.gate.last_command.linear_x == pytest.approx(3.0)  # turbo (it enables too, as in teleop_twist_joy)
    app.close()


def test_deadzone_is_rescaled_and_continuous():
    assert apply_deadzone(0.09, 0.1) == 0.0
    assert apply_deadzone(0.1001, 0.1) == pytest.approx(0.0, abs=1e-3)
    assert apply_deadzone(0.55, 0.1) == pytest.approx(0.5)
    assert apply_deadzone(-1.0, 0.1) == -1.0


def test_mapping_file_uses_teleop_twist_joy_names_and_joy_axes(tmp_path):
    good = tmp_path / "pad.toml"
    good.write_text(
        "deadzone = 0.2\n"
        "axis_linear.x = 1\nscale_linear.x = 2.0\n"
        "axis_linear.y = -1\n"
        "scale_angular.yaw = 0.5\n"
        "scale_angular_turbo.yaw = 0.7\n"
        "enable_button = 0\nenable_turbo_button = 5\n"
    )
    m = load_mapping(good)
    assert m.deadzone == 0.2 and m.enable_button == 0 and m.enable_turbo_button == 5
    assert (m.linear_x.index, m.linear_x.scale, m.linear_x.scale_turbo) == (1, 2.0, 4.0)
    assert m.linear_y is None  # -1: not used
    assert (m.angular_z.index, m.angular_z.scale, m.angular_z.scale_turbo) == (0, 0.5, 0.7)
    assert m.linear_z == JoystickMapping().linear_z  # not given: the default
    for text, message in (
        ("dead_zone = 0.2\n", "unknown key"),
        ("forward = { index = 4, scale = -1.0 }\n", "old mapping format"),
        ("axis_linear.w = 3\n", "axis_linear.w is not used"),
        ("axis_linear.x = 1.5\n", "axis_linear.x must be a whole number"),
        ('scale_linear.x = "fast"\n', "scale_linear.x must be a finite number"),
        ("scale_linear.x = nan\n", "scale_linear.x must be a finite number"),
        ("deadzone = 0.95\n", "deadzone must be in"),
        ("enable_button = -2\n", "enable_button must be a whole number >= 0"),
        ("axis_linear = 3\n", "axis_linear must be a table"),
    ):
        bad = tmp_path / "bad.toml"
        bad.write_text(text)
        with pytest.raises(ConfigError, match=message):
            load_mapping(bad)


def test_height_mode_left_stick_moves_the_altitude_wanted(tmp_path, pads):
    pad = pads(game_controller=True)
    app = make_app(tmp_path, options=TeleopOptions(input="joystick"), config=SimConfig(z_mode=ZMode.HEIGHT))
    run_with(app, 3 * FPS)
    base = app.sim.state.position_m[2]
    hold(app, pad, {LEFTY: -1.0}, 1.0)  # 1 s at 1 m/s: the altitude wanted rises by 1 m
    run_with(app, 2 * FPS)
    assert app.sim.state.position_m[2] - base == pytest.approx(1.0, abs=0.15)
    app.close()


def test_a_raw_axis_resting_at_one_end_never_moves_the_vehicle(tmp_path, pads):
    """A joystick SDL has no mapping for, whose axis 3 (forward by default) is really a trigger
    resting at one end: it is never seen centred, so it moves nothing, and the HUD says which."""
    pads(game_controller=False, naxes=6, nbuttons=10, axes={3: -1.0})
    app = make_app(tmp_path)
    assert app.driver is app.joystick and app.joystick.pad.kind is PadKind.JOYSTICK
    run_with(app, 2 * FPS)
    assert abs(app.sim.state.position_m[0]) < 0.01 and app.sim.gate.last_command.linear_x == 0.0
    assert app._model().warnings == ["centre the sticks to fly: axis 3 held at +1.00 (forward/back)"]
    assert app._model().input_status == "joystick Virtual Joystick (raw axes, see --joy-map)"
    app.close()


def test_the_docs_mapping_example_is_the_default_mapping_plus_buttons(tmp_path):
    teleop_page = (ROOT / "docs" / "teleop.md").read_text()
    block = teleop_page.split("write a mapping file", 1)[1].split("```toml\n", 1)[1].split("```", 1)[0]
    (tmp_path / "pad.toml").write_text(block)
    assert load_mapping(tmp_path / "pad.toml") == JoystickMapping(enable_button=9, enable_turbo_button=10)


TWO_HANDS = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="keyboard"),
    vehicle("bravo", (0.0, -4.0, 0.0, 0.0), input="gamepad"),
    vehicle("charlie", (-4.0, 0.0, 0.0, 0.0), input="script:hover"),
)


def test_a_fleet_with_a_keyboard_and_a_gamepad_vehicle_is_flown_by_two_people(tmp_path, pads):
    """fly --fleet: the keyboard flies alpha and a real (virtual) SDL pad flies bravo at the same
    time, each only its own vehicle; bravo's pad is recorded on /bravo/joy; a pad pulled out holds
    bravo where it is."""
    from tests.integration.test_teleop import fleet_app

    pad = pads(game_controller=True)
    app = fleet_app(tmp_path, TWO_HANDS)
    assert app.fleet is not None and (app.fleet.flown, app.fleet.second) == ("alpha", "bravo")
    assert app.driver is app.keyboard and app.second_hand is app.joystick and app.joystick.pad is not None
    assert "the gamepad flies bravo" in app._input_status()
    bravo = app.session.fleet["bravo"]
    run_with(app, 5)
    hold(app, pad, {LEFTY: -1.0}, 1.5)  # left stick up: bravo climbs, alpha stays down
    assert bravo.state.position_m[2] > 1.0 and app.sim.state.position_m[2] < 0.1
    pad.set_axis(RIGHTY, -0.6)  # bravo forward while the keyboard climbs alpha
    run_with(app, 45, {0: [lambda: key(pygame.K_w)], 40: [lambda: key(pygame.K_w, False)]})
    pad.set_axis(RIGHTY, 0.0)
    run_with(app, FPS)
    (ax, ay, az), (bx, by, bz) = app.sim.state.position_m, bravo.state.position_m
    assert az > 0.8 and abs(ax) < 0.1 and abs(ay) < 0.1, (ax, ay, az)  # W climbed alpha only
    assert bx > 0.8 and abs(by + 4.0) < 0.2 and bz > 1.0, (bx, by, bz)  # the stick flew bravo forward
    pad.unplug()
    run_with(app, FPS)
    held = bravo.state.position_m
    run_with(app, FPS)
    assert math.dist(held, bravo.state.position_m) < 0.1  # unplugged: bravo holds position
    app.close()
    joy = read_topic(app.recordings[0], "/bravo/joy")
    assert joy and any(m.axes[1] > 0.9 for _, m in joy)  # the left stick held up (+1 in Joy), under bravo's name
    assert read_topic(app.recordings[0], "/alpha/joy") == []
    with RecordingReader(app.recordings[0]) as rec:
        assert any("gamepad unplugged" in value and "bravo holds position" in value for _, _, value in rec.events)
