"""The keyboard and joystick drivers on synthetic events: no window, no simulator.

As Gymnasium tests its play loop, events are built with pygame.event.Event and handed to the
driver directly; the joystick is a fake device object made by the driver's device factory.
Each test reads the Twist the driver would publish and checks fields, signs and sizes.
"""

from itertools import pairwise

import pygame
import pytest
from pygame.event import Event

from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, ZMode
from quadsim.drivers import ASAP, NEVER
from quadsim.drivers.joystick import AxisMap, JoystickDriver, JoystickMapping, apply_deadzone, load_mapping
from quadsim.drivers.keyboard import DEFAULT_LAYOUT, TELEOP_TWIST_LAYOUT, KeyboardDriver, Speeds
from quadsim.errors import ConfigError

SPEEDS = Speeds(linear_mps=1.0, climb_mps=0.8, yaw_radps=1.0)


def down(key):
    return Event(pygame.KEYDOWN, key=key, mod=0, unicode="", scancode=0)


def up(key):
    return Event(pygame.KEYUP, key=key, mod=0, unicode="", scancode=0)


def press(driver, *keys):
    for key in keys:
        assert driver.handle_event(down(key)), pygame.key.name(key)


def release(driver, *keys):
    for key in keys:
        assert driver.handle_event(up(key))


def fields(t: Twist):
    """The four fields a Twist command means something in: x forward, y left, z, yaw rate."""
    return (t.linear_x, t.linear_y, t.linear_z, t.angular_z)


# === keyboard ===============================================================================


@pytest.fixture
def keys():
    return KeyboardDriver(DEFAULT_LAYOUT, SPEEDS)


def test_no_keys_no_motion(keys):
    assert keys.poll(0, 0.0) == Twist()


@pytest.mark.parametrize(
    ("key", "expected"),
    [
        (pygame.K_UP, (1.0, 0.0, 0.0, 0.0)),
        (pygame.K_DOWN, (-1.0, 0.0, 0.0, 0.0)),
        (pygame.K_LEFT, (0.0, 1.0, 0.0, 0.0)),
        (pygame.K_RIGHT, (0.0, -1.0, 0.0, 0.0)),
        (pygame.K_w, (0.0, 0.0, 0.8, 0.0)),
        (pygame.K_s, (0.0, 0.0, -0.8, 0.0)),
        (pygame.K_a, (0.0, 0.0, 0.0, 1.0)),  # turn left = counter-clockwise = +angular.z
        (pygame.K_d, (0.0, 0.0, 0.0, -1.0)),
    ],
    ids=lambda v: pygame.key.name(v) if isinstance(v, int) else None,
)
def test_default_layout_each_key(keys, key, expected):
    press(keys, key)
    assert fields(keys.poll(1, 0.1)) == pytest.approx(expected)


def test_held_keys_combine_and_release_stops_only_that_motion(keys):
    press(keys, pygame.K_UP, pygame.K_LEFT, pygame.K_a)
    assert fields(keys.poll(1, 0.1)) == pytest.approx((1.0, 1.0, 0.0, 1.0))
    release(keys, pygame.K_UP)
    assert fields(keys.poll(2, 0.2)) == pytest.approx((0.0, 1.0, 0.0, 1.0))
    release(keys, pygame.K_a)
    assert fields(keys.poll(3, 0.3)) == pytest.approx((0.0, 1.0, 0.0, 0.0))
    release(keys, pygame.K_LEFT)
    assert keys.poll(4, 0.4) == Twist()


def test_opposite_keys_cancel(keys):
    press(keys, pygame.K_UP, pygame.K_DOWN, pygame.K_w)
    assert fields(keys.poll(1, 0.1)) == pytest.approx((0.0, 0.0, 0.8, 0.0))
    release(keys, pygame.K_DOWN)
    assert fields(keys.poll(2, 0.2)) == pytest.approx((1.0, 0.0, 0.8, 0.0))


def test_unbound_keys_are_not_the_drivers(keys):
    assert not keys.handle_event(down(pygame.K_F5))
    assert not keys.handle_event(up(pygame.K_UP))  # a KEYUP for a key it never saw go down
    assert not keys.handle_event(Event(pygame.MOUSEMOTION, pos=(1, 2), rel=(0, 0), buttons=(0, 0, 0)))
    assert keys.next_poll_step == NEVER and keys.poll(1, 0.1) == Twist()


def test_focus_loss_clears_held_keys(keys):
    press(keys, pygame.K_UP, pygame.K_a)
    keys.poll(1, 0.1)
    assert keys.handle_event(Event(pygame.WINDOWFOCUSLOST))
    assert keys.next_poll_step == ASAP  # the stop goes out at once
    assert keys.poll(2, 0.2) == Twist()
    # the KEYUPs never come (the window had lost focus); a later KEYUP is harmless
    release_ignored = keys.handle_event(up(pygame.K_UP))
    assert not release_ignored and keys.poll(3, 0.3) == Twist()


def test_pygame1_style_input_focus_loss_clears_but_mouse_leaving_does_not(keys):
    press(keys, pygame.K_UP)
    keys.handle_event(Event(pygame.ACTIVEEVENT, gain=0, state=1))  # the mouse left the window
    assert fields(keys.poll(1, 0.1)) == pytest.approx((1.0, 0.0, 0.0, 0.0))
    keys.handle_event(Event(pygame.ACTIVEEVENT, gain=0, state=2))  # keyboard focus lost
    assert keys.poll(2, 0.2) == Twist()


def test_stop_key_zeroes_while_held(keys):
    press(keys, pygame.K_UP, pygame.K_w, pygame.K_SPACE)
    assert keys.poll(1, 0.1) == Twist()
    release(keys, pygame.K_SPACE)
    assert fields(keys.poll(2, 0.2)) == pytest.approx((1.0, 0.0, 0.8, 0.0))


def test_speed_keys_scale_every_axis_ten_percent_a_press(keys):
    press(keys, pygame.K_UP, pygame.K_LEFT, pygame.K_w, pygame.K_a)
    for _ in range(3):
        press(keys, pygame.K_EQUALS)
    assert fields(keys.poll(1, 0.1)) == pytest.approx(tuple(v * 1.1**3 for v in (1.0, 1.0, 0.8, 1.0)))
    press(keys, pygame.K_MINUS)
    assert fields(keys.poll(2, 0.2)) == pytest.approx(tuple(v * 1.1**2 for v in (1.0, 1.0, 0.8, 1.0)))
    # speed keys are not motion: releasing them changes nothing
    release_handled = keys.handle_event(up(pygame.K_MINUS))
    assert not release_handled
    assert keys.poll(3, 0.3).linear_x == pytest.approx(1.1**2)


def test_speed_scale_is_bounded(keys):
    press(keys, pygame.K_UP)
    for _ in range(100):
        press(keys, pygame.K_KP_PLUS)
    assert keys.poll(1, 0.1).linear_x == pytest.approx(5.0)
    for _ in range(200):
        press(keys, pygame.K_KP_MINUS)
    assert keys.poll(2, 0.2).linear_x == pytest.approx(0.1)


# teleop_twist_keyboard's moveBindings: key -> (x, y, z, th), each times speed (linear) or turn
TELEOP_BINDINGS = {
    pygame.K_i: (1, 0, 0, 0),
    pygame.K_o: (1, 0, 0, -1),
    pygame.K_j: (0, 0, 0, 1),
    pygame.K_l: (0, 0, 0, -1),
    pygame.K_u: (1, 0, 0, 1),
    pygame.K_COMMA: (-1, 0, 0, 0),
    pygame.K_PERIOD: (-1, 0, 0, 1),
    pygame.K_m: (-1, 0, 0, -1),
    pygame.K_t: (0, 0, 1, 0),
    pygame.K_b: (0, 0, -1, 0),
}


@pytest.mark.parametrize("key", list(TELEOP_BINDINGS), ids=lambda k: pygame.key.name(k))
def test_teleop_twist_keyboard_layout(key):
    driver = KeyboardDriver(TELEOP_TWIST_LAYOUT, Speeds(linear_mps=0.5, climb_mps=0.5, yaw_radps=1.0))
    press(driver, key)
    x, y, z, th = TELEOP_BINDINGS[key]
    assert fields(driver.poll(1, 0.1)) == pytest.approx((0.5 * x, 0.5 * y, 0.5 * z, 1.0 * th))


def test_teleop_twist_keyboard_k_stops_and_q_z_scale():
    driver = KeyboardDriver(TELEOP_TWIST_LAYOUT, SPEEDS)
    press(driver, pygame.K_u)  # forward and turning left
    press(driver, pygame.K_q, pygame.K_q)
    assert fields(driver.poll(1, 0.1)) == pytest.approx((1.21, 0.0, 0.0, 1.21))
    press(driver, pygame.K_z)
    assert fields(driver.poll(2, 0.2)) == pytest.approx((1.1, 0.0, 0.0, 1.1))
    press(driver, pygame.K_k)
    assert driver.poll(3, 0.3) == Twist()


def test_next_poll_step_asap_on_a_change_and_back_after_poll(keys):
    assert keys.next_poll_step == NEVER  # nothing to say until a key changes
    press(keys, pygame.K_UP)
    assert keys.next_poll_step == ASAP
    keys.poll(1, 0.1)
    assert keys.next_poll_step == NEVER
    keys.handle_event(down(pygame.K_F5))  # not the driver's: no extra poll
    assert keys.next_poll_step == NEVER
    press(keys, pygame.K_EQUALS)  # a speed change is a change of the command
    assert keys.next_poll_step == ASAP
    keys.poll(2, 0.2)
    release(keys, pygame.K_UP)
    assert keys.next_poll_step == ASAP
    keys.poll(3, 0.3)
    keys.handle_event(Event(pygame.WINDOWFOCUSLOST))  # nothing held: nothing changes
    assert keys.next_poll_step == NEVER


def test_height_mode_integrates_climb_keys_into_an_altitude_offset():
    driver = KeyboardDriver(DEFAULT_LAYOUT, SPEEDS, z_mode=ZMode.HEIGHT)
    driver.set_z_mode(ZMode.HEIGHT, altitude_m=3.0)  # switched to height mode at 3 m
    assert driver.next_poll_step == ASAP
    # the altitude wanted (2.0 + linear.z) is where the vehicle is: no jump
    assert HEIGHT_MODE_BASE_M + driver.poll(0, 0.0).linear_z == pytest.approx(3.0)
    press(driver, pygame.K_w)
    driver.poll(1, 0.0)  # the loop polls at once after a change
    for k in range(1, 6):  # W held for 0.5 s, polled at 10 Hz
        twist = driver.poll(k, 0.1 * k)
    assert twist.linear_z == pytest.approx(1.0 + 0.8 * 0.5)
    release(driver, pygame.K_w)
    driver.poll(6, 0.5)
    assert driver.poll(7, 1.5).linear_z == pytest.approx(1.4)  # released: the altitude stays
    press(driver, pygame.K_s)
    driver.poll(8, 1.5)
    assert driver.poll(9, 1.75).linear_z == pytest.approx(1.4 - 0.8 * 0.25)
    # horizontal keys are still velocities
    press(driver, pygame.K_UP)
    assert driver.poll(10, 1.75).linear_x == pytest.approx(1.0)
    driver.reset()
    assert driver.poll(11, 2.0) == Twist()


# === joystick ===============================================================================


class FakePad:
    """What the driver reads from pygame.joystick.Joystick, set by the test."""

    def __init__(self, name="Fake Pad", instance_id=7, num_axes=6, num_buttons=11):
        self.name = name
        self.instance_id = instance_id
        self.axes = [0.0] * num_axes
        self.buttons = [0] * num_buttons

    def get_name(self):
        return self.name

    def get_instance_id(self):
        return self.instance_id

    def get_numaxes(self):
        return len(self.axes)

    def get_axis(self, i):
        return self.axes[i]

    def get_numbuttons(self):
        return len(self.buttons)

    def get_button(self, i):
        return self.buttons[i]


def plugged(mapping=JoystickMapping(), z_mode=ZMode.VELOCITY, pad=None):
    pad = pad or FakePad()
    made = []

    def factory(index):
        made.append(index)
        return pad

    driver = JoystickDriver(mapping, z_mode, device_factory=factory)
    assert driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=3))
    assert made == [3] and driver.device is pad
    return driver, pad


def test_no_device_publishes_nothing():
    driver = JoystickDriver(device_factory=lambda i: FakePad())
    assert driver.poll(0, 0.0) is None
    assert driver.status == "no joystick"


def test_centred_sticks_give_a_zero_twist():
    driver, pad = plugged()
    assert "Fake Pad" in driver.status and driver.next_poll_step == ASAP
    assert driver.poll(0, 0.0) == Twist()
    pad.axes = [0.05, -0.08, 0.0, 0.099, -0.02, 0.0]  # a worn stick resting off-centre
    assert driver.poll(1, 0.1) == Twist()


# mode 2, SDL numbering (stick up and left are negative): axis, raw value, field index, value
MODE_2 = [
    (1, -1.0, 2, 1.0),  # left stick up: climb at climb_mps
    (1, 1.0, 2, -1.0),  # left stick down: descend
    (0, -1.0, 3, 1.2),  # left stick left: yaw counter-clockwise (+angular.z)
    (0, 1.0, 3, -1.2),  # left stick right: clockwise
    (4, -1.0, 0, 1.5),  # right stick up: forward
    (4, 1.0, 0, -1.5),  # right stick down: back
    (3, -1.0, 1, 1.5),  # right stick left: +linear.y
    (3, 1.0, 1, -1.5),  # right stick right
]


@pytest.mark.parametrize(
    ("axis", "raw", "field", "value"),
    MODE_2,
    ids=["climb", "descend", "yaw-left", "yaw-right", "forward", "back", "left", "right"],
)
def test_mode_2_each_stick_moves_one_field_with_the_ros_sign(axis, raw, field, value):
    driver, pad = plugged()
    pad.axes[axis] = raw
    expected = [0.0, 0.0, 0.0, 0.0]
    expected[field] = value
    assert fields(driver.poll(1, 0.1)) == pytest.approx(tuple(expected))


def test_both_sticks_together_and_the_joy_stream():
    driver, pad = plugged()
    seen = []
    driver.joy_sinks.append(lambda step, axes, buttons: seen.append((step, axes, buttons)))
    pad.axes[1], pad.axes[0], pad.axes[4], pad.axes[3] = -0.55, -0.55, -0.55, 0.55
    pad.buttons[2] = 1
    # half deflection past the 0.1 deadzone: (0.55 - 0.1) / 0.9 = 0.5 of full scale
    assert fields(driver.poll(4, 0.4)) == pytest.approx((0.75, -0.75, 0.5, 0.6))
    assert seen == [(4, (-0.55, -0.55, 0.0, 0.55, -0.55, 0.0), (0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0))]


def test_deadzone_rescaling_is_continuous_monotonic_and_reaches_full_scale():
    mapping = JoystickMapping(deadzone=0.25)
    driver, pad = plugged(mapping)
    raws = [i / 1000 for i in range(-1000, 1001)]
    out = []
    for raw in raws:
        pad.axes[4] = -raw  # right stick, "up" is -raw
        out.append(driver.poll(1, 0.1).linear_x / mapping.linear_mps)
    for raw, value in zip(raws, out):
        if abs(raw) <= 0.25:
            assert value == 0.0
    assert out[0] == pytest.approx(-1.0) and out[-1] == pytest.approx(1.0)
    steps = [b - a for a, b in pairwise(out)]
    assert min(steps) >= 0.0  # monotonic
    # continuous: no jump at the deadzone's edge; the slope outside it is 1 / (1 - deadzone)
    assert max(steps) == pytest.approx(0.001 / 0.75, rel=1e-3)
    assert apply_deadzone(0.2500001, 0.25) == pytest.approx(0.0, abs=1e-6)


def test_enable_button_gates_motion_and_turbo_scales():
    driver, pad = plugged(JoystickMapping(enable_button=4, turbo_button=5, turbo_factor=2.5))
    pad.axes[4] = -1.0  # full forward
    pad.axes[0] = -1.0  # full yaw left
    assert driver.poll(1, 0.1) == Twist()  # not enabled: no motion at all
    pad.buttons[5] = 1
    assert driver.poll(2, 0.2) == Twist()  # turbo alone does not enable
    pad.buttons[4] = 1
    assert fields(driver.poll(3, 0.3)) == pytest.approx((1.5 * 2.5, 0.0, 0.0, 1.2 * 2.5))
    pad.buttons[5] = 0
    assert fields(driver.poll(4, 0.4)) == pytest.approx((1.5, 0.0, 0.0, 1.2))
    pad.buttons[4] = 0
    assert driver.poll(5, 0.5) == Twist()  # let go of enable: stop (a published zero, not silence)


def test_buttons_beyond_the_device_count_as_released():
    driver, pad = plugged(JoystickMapping(enable_button=20), pad=FakePad(num_buttons=4))
    pad.axes[4] = -1.0
    assert driver.poll(1, 0.1) == Twist()


def test_unplug_goes_silent_and_replug_resumes():
    driver, pad = plugged()
    pad.axes[4] = -1.0
    assert driver.poll(1, 0.1).linear_x == pytest.approx(1.5)
    # another device going away is not ours
    assert driver.handle_event(Event(pygame.JOYDEVICEREMOVED, instance_id=99))
    assert driver.poll(2, 0.2).linear_x == pytest.approx(1.5)
    # ours: silence (None), so the gate's dead-man timeout holds position
    assert driver.handle_event(Event(pygame.JOYDEVICEREMOVED, instance_id=pad.instance_id))
    assert driver.device is None and "unplugged" in driver.status
    assert driver.poll(3, 0.3) is None
    assert driver.poll(4, 0.4) is None
    # plugged in again: polled at once, flying resumes with the sticks as they are
    assert driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=0))
    assert driver.next_poll_step == ASAP and "Fake Pad" in driver.status
    assert driver.poll(5, 0.5).linear_x == pytest.approx(1.5)


def test_a_second_pad_does_not_replace_the_first():
    first, second = FakePad("first", 1), FakePad("second", 2)
    pads = iter([first, second])
    driver = JoystickDriver(device_factory=lambda index: next(pads))
    driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=0))
    driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=1))
    assert driver.device is first
    first.axes[4] = -1.0
    assert driver.poll(1, 0.1).linear_x == pytest.approx(1.5)


def test_stick_motion_asks_for_a_poll_at_once():
    driver, pad = plugged()
    driver.poll(1, 0.1)
    assert driver.next_poll_step == NEVER
    for event in (
        Event(pygame.JOYAXISMOTION, instance_id=7, axis=4, value=-0.5),
        Event(pygame.JOYBUTTONDOWN, instance_id=7, button=0),
        Event(pygame.JOYBUTTONUP, instance_id=7, button=0),
    ):
        assert driver.handle_event(event)
        assert driver.next_poll_step == ASAP
        driver.poll(2, 0.2)
        assert driver.next_poll_step == NEVER
    assert not driver.handle_event(down(pygame.K_UP))  # keys are not the joystick's


def test_height_mode_integrates_the_climb_stick():
    driver, pad = plugged(z_mode=ZMode.HEIGHT)
    driver.set_z_mode(ZMode.HEIGHT, altitude_m=2.5)
    assert driver.poll(0, 0.0).linear_z == pytest.approx(0.5)  # where it is: 2.0 + 0.5
    pad.axes[1] = -1.0  # left stick full up, 1 m/s for 2 s
    for k in range(1, 21):
        twist = driver.poll(k, 0.1 * k)
    assert twist.linear_z == pytest.approx(0.5 + 2.0)
    pad.axes[1] = 0.0
    assert driver.poll(21, 3.0).linear_z == pytest.approx(2.5)  # centred: stays


def test_custom_mapping_moves_fields_to_other_axes():
    mapping = JoystickMapping(forward=AxisMap(1, -1.0), up=AxisMap(4, -1.0), linear_mps=2.0, deadzone=0.0)
    driver, pad = plugged(mapping)
    pad.axes[1] = -0.5
    assert fields(driver.poll(1, 0.1)) == pytest.approx((1.0, 0.0, 0.0, 0.0))


# --- the mapping file ---------------------------------------------------------------------


def test_mapping_file_sets_the_fields(tmp_path):
    path = tmp_path / "pad.toml"
    path.write_text(
        "deadzone = 0.2\nlinear_mps = 2.0\nforward = { index = 1, scale = -1.0 }\n"
        "enable_button = 0\nturbo_button = 3\nturbo_factor = 3.0\n"
    )
    m = load_mapping(path)
    assert (m.deadzone, m.linear_mps, m.forward, m.enable_button, m.turbo_button, m.turbo_factor) == (
        0.2,
        2.0,
        AxisMap(1, -1.0),
        0,
        3,
        3.0,
    )
    assert m.left == JoystickMapping().left  # what the file does not name stays the default


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("dead_zone = 0.2\n", "dead_zone"),
        ("forward = 4\n", "forward"),
        ("yaw = { scale = -1.0 }\n", "yaw"),
        ("deadzone = 0.95\n", "deadzone"),
        ("deadzone = -0.1\n", "deadzone"),
        ("deadzone = [\n", "not valid TOML"),
    ],
    ids=["unknown-key", "axis-not-a-table", "axis-without-index", "deadzone-high", "deadzone-negative", "bad-toml"],
)
def test_mapping_file_errors_name_the_key(tmp_path, text, named):
    path = tmp_path / "pad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=named) as info:
        load_mapping(path)
    assert str(path) in str(info.value)


def test_missing_mapping_file_is_named(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_mapping(tmp_path / "nowhere.toml")


@pytest.mark.xfail(
    strict=True,
    reason="defect: load_mapping does not check value types or ranges; these give a TypeError or "
    "ValueError traceback, or are accepted and fail (or misbehave) at the first poll",
)
@pytest.mark.parametrize(
    ("text", "named"),
    [
        ('deadzone = "big"\n', "deadzone"),  # TypeError from the range check
        ('forward = { index = 4, scale = "x" }\n', "forward"),  # ValueError from float()
        ('linear_mps = "fast"\n', "linear_mps"),  # accepted; the first poll multiplies a string
        ('enable_button = "A"\n', "enable_button"),  # accepted; the first poll compares str < int
        ("forward = { index = -9 }\n", "forward"),  # accepted; reads axes[-9]
        ("forward = { index = 1, scal = -1.0 }\n", "scal"),  # typo accepted: scale silently +1
        ("turbo_factor = -2.0\n", "turbo_factor"),  # accepted: turbo flies backwards
    ],
    ids=["deadzone-str", "scale-str", "speed-str", "button-str", "negative-index", "axis-typo", "negative-turbo"],
)
def test_mapping_file_bad_values_are_config_errors(tmp_path, text, named):
    path = tmp_path / "pad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=named):
        load_mapping(path)
