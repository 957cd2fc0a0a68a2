"""The keyboard and joystick drivers on synthetic events: no window, no simulator.

As Gymnasium tests its play loop, events are built with pygame.event.Event and handed to the
driver directly; the joystick's pad is a fake `Pad` (quadsim.drivers.gamepad) handed over by the
driver's pad_opener, read in /joy's convention (stick up and left positive). Each test reads the
Twist the driver would publish and checks fields, signs and sizes. (tests/integration/test_gamepad.py drives
the same driver through real SDL virtual devices.)
"""

import re
from itertools import pairwise

import pygame
import pytest
from pygame.event import Event

from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, ZMode
from quadsim.drivers import ASAP, NEVER
from quadsim.drivers.gamepad import GameControllerPad, PadKind
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
#
# Axes as on /joy from an SDL game controller: 0 leftx, 1 lefty, 2 rightx, 3 righty,
# 4 lefttrigger, 5 righttrigger; stick up and left positive, triggers 0 released, -1 pressed.
LEFTX, LEFTY, RIGHTX, RIGHTY, LEFTTRIGGER, RIGHTTRIGGER = range(6)


class FakePad:
    """A `Pad` whose axes and buttons the test sets, in /joy's order and sign (before the deadzone)."""

    kind = PadKind.GAME_CONTROLLER
    axis_names = GameControllerPad.axis_names

    def __init__(self, name="Fake Pad", instance_id=7, num_buttons=15):
        self.name = name
        self.instance_id = instance_id
        self.axes = [0.0] * len(self.axis_names)
        self.buttons = [0] * num_buttons
        self.closed = False

    def read(self):
        return tuple(self.axes), tuple(self.buttons)

    def held(self, index, value):
        return f"axis {index} held at {value:+.2f}"

    def close(self):
        self.closed = True


def plugged(mapping=JoystickMapping(), z_mode=ZMode.VELOCITY, pad=None, centre=True):
    """A driver with `pad` plugged in as SDL device 3; with `centre`, polled once with the sticks
    centred (step 0, t = 0), as the centring guard wants before a stick moves anything."""
    pad = pad or FakePad()
    opened = []

    def opener(index):
        opened.append(index)
        return pad

    driver = JoystickDriver(mapping, z_mode, pad_opener=opener)
    assert driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=3))
    assert opened == [3] and driver.pad is pad
    if centre:
        assert driver.poll(0, 0.0) == Twist()
    return driver, pad


def test_no_pad_publishes_nothing():
    driver = JoystickDriver(pad_opener=lambda index: FakePad())
    assert driver.pad is None and driver.poll(0, 0.0) is None  # silence, not a zero Twist
    assert driver.status == "no gamepad: plug one in" and driver.warnings() == [driver.status]


def test_a_pad_that_cannot_be_opened_is_not_attached():
    def opener(index):
        raise pygame.error("gone again")

    driver = JoystickDriver(pad_opener=opener)
    assert driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=0))
    assert driver.pad is None and driver.status == "cannot open joystick 0: gone again"
    assert driver.poll(0, 0.0) is None


def test_centred_sticks_give_a_zero_twist():
    driver, pad = plugged(centre=False)
    assert driver.status == "gamepad Fake Pad" and driver.next_poll_step == ASAP
    assert driver.poll(0, 0.0) == Twist()
    assert driver.warnings() == []
    pad.axes = [0.05, -0.08, 0.0, 0.099, 0.0, 0.0]  # a worn stick resting off-centre
    assert driver.poll(1, 0.1) == Twist()


# mode 2 in /joy's sign: axis, value, field index (x, y, z, yaw), expected
MODE_2 = [
    (LEFTY, 1.0, 2, 1.0),  # left stick up: climb at 1 m/s
    (LEFTY, -1.0, 2, -1.0),  # left stick down: descend
    (LEFTX, 1.0, 3, 1.2),  # left stick left: yaw counter-clockwise (+angular.z)
    (LEFTX, -1.0, 3, -1.2),  # left stick right: clockwise
    (RIGHTY, 1.0, 0, 1.5),  # right stick up: forward
    (RIGHTY, -1.0, 0, -1.5),  # right stick down: back
    (RIGHTX, 1.0, 1, 1.5),  # right stick left: +linear.y
    (RIGHTX, -1.0, 1, -1.5),  # right stick right
    (LEFTTRIGGER, -1.0, None, None),  # triggers move nothing
    (RIGHTTRIGGER, -1.0, None, None),
]


@pytest.mark.parametrize(
    ("axis", "value", "field", "expected"),
    MODE_2,
    ids=["climb", "descend", "yaw-left", "yaw-right", "forward", "back", "left", "right", "ltrigger", "rtrigger"],
)
def test_mode_2_each_stick_moves_one_field_with_the_ros_sign(axis, value, field, expected):
    driver, pad = plugged()
    pad.axes[axis] = value
    want = [0.0, 0.0, 0.0, 0.0]
    if field is not None:
        want[field] = expected
    assert fields(driver.poll(1, 0.1)) == pytest.approx(tuple(want))


def test_both_sticks_together_and_the_joy_stream():
    driver, pad = plugged(centre=False)
    seen = []
    driver.joy_sinks.append(lambda step, axes, buttons: seen.append((step, axes, buttons)))
    assert driver.poll(0, 0.0) == Twist()
    pad.axes[LEFTY], pad.axes[LEFTX], pad.axes[RIGHTY], pad.axes[RIGHTX] = 0.55, 0.55, 0.55, -0.55
    pad.axes[RIGHTTRIGGER] = -1.0
    pad.buttons[2] = 1
    # half deflection past the 0.1 deadzone: (0.55 - 0.1) / 0.9 = 0.5 of full scale
    assert fields(driver.poll(4, 0.4)) == pytest.approx((0.75, -0.75, 0.5, 0.6))
    # /joy: every poll, every axis (deadzone applied, the triggers too), every button
    assert [(step, buttons) for step, _, buttons in seen] == [(0, (0,) * 15), (4, (0, 0, 1) + (0,) * 12)]
    assert seen[0][1] == (0.0,) * 6
    assert seen[1][1] == pytest.approx((0.5, 0.5, -0.5, 0.5, 0.0, -1.0))


def test_deadzone_rescaling_is_continuous_monotonic_and_reaches_full_scale():
    mapping = JoystickMapping(deadzone=0.25)
    driver, pad = plugged(mapping)
    values = [i / 1000 for i in range(-1000, 1001)]
    out = []
    for value in values:
        pad.axes[RIGHTY] = value
        out.append(driver.poll(1, 0.1).linear_x / 1.5)
    assert all(o == 0.0 for v, o in zip(values, out) if abs(v) <= 0.25)
    assert out[0] == pytest.approx(-1.0) and out[-1] == pytest.approx(1.0)
    steps = [b - a for a, b in pairwise(out)]
    assert min(steps) >= 0.0  # monotonic
    # continuous: no jump at the deadzone's edge; the slope outside it is 1 / (1 - deadzone)
    assert max(steps) == pytest.approx(0.001 / 0.75, rel=1e-3)
    assert apply_deadzone(0.2500001, 0.25) == pytest.approx(0.0, abs=1e-6)


def test_enable_button_gates_motion_and_turbo_scales_and_enables():
    mapping = JoystickMapping(linear_x=AxisMap(RIGHTY, 1.5, 2.5), enable_button=9, enable_turbo_button=10)
    driver, pad = plugged(mapping)
    pad.axes[RIGHTY] = 1.0  # full forward
    pad.axes[LEFTX] = 1.0  # full yaw left
    assert driver.poll(1, 0.1) == Twist()  # not enabled: no motion at all
    pad.buttons[10] = 1
    assert fields(driver.poll(2, 0.2)) == pytest.approx((2.5, 0.0, 0.0, 2.4))  # turbo alone enables
    pad.buttons[9] = 1
    assert fields(driver.poll(3, 0.3)) == pytest.approx((2.5, 0.0, 0.0, 2.4))  # turbo wins over enable
    pad.buttons[10] = 0
    assert fields(driver.poll(4, 0.4)) == pytest.approx((1.5, 0.0, 0.0, 1.2))
    pad.buttons[9] = 0
    assert driver.poll(5, 0.5) == Twist()  # let go of enable: stop (a published zero, not silence)


def test_buttons_beyond_the_device_count_as_released():
    pad = FakePad(num_buttons=4)
    driver, pad = plugged(JoystickMapping(enable_button=20), pad=pad)
    pad.axes[RIGHTY] = 1.0
    assert driver.poll(1, 0.1) == Twist()  # never enabled
    driver, pad = plugged(JoystickMapping(enable_turbo_button=20), pad=FakePad(num_buttons=4))
    pad.axes[RIGHTY] = 1.0
    assert driver.poll(1, 0.1).linear_x == pytest.approx(1.5)  # never turbo


def test_unplug_goes_silent_and_replug_resumes_once_the_sticks_are_centred():
    first, second = FakePad("first", 7), FakePad("second", 8)
    pads = iter([first, second])
    driver = JoystickDriver(pad_opener=lambda index: next(pads))
    driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=0))
    driver.poll(0, 0.0)
    first.axes[RIGHTY] = 1.0
    assert driver.poll(1, 0.1).linear_x == pytest.approx(1.5)
    # another device going away is not ours
    assert driver.handle_event(Event(pygame.JOYDEVICEREMOVED, instance_id=99))
    assert driver.pad is first and driver.poll(2, 0.2).linear_x == pytest.approx(1.5)
    # ours: closed, and silence (None), so the gate's dead-man timeout holds position
    assert driver.handle_event(Event(pygame.JOYDEVICEREMOVED, instance_id=7))
    assert driver.pad is None and first.closed and "unplugged" in driver.status
    assert driver.poll(3, 0.3) is None
    assert driver.poll(4, 0.4) is None
    # plugged in again with the stick still held: polled at once, but the held stick moves
    # nothing until it has been centred, and the warnings say which
    second.axes[RIGHTY] = 1.0
    second.axes[LEFTY] = 0.08  # resting off-centre but inside the 0.1 deadzone: counts as centred
    assert driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=0))
    assert driver.pad is second and driver.next_poll_step == ASAP and driver.status == "gamepad second"
    assert driver.poll(5, 0.5) == Twist()
    assert driver.warnings() == ["centre the sticks to fly: axis 3 held at +1.00 (forward/back)"]
    second.axes[LEFTX] = 1.0  # a stick seen centred since the re-plug moves at once
    assert fields(driver.poll(6, 0.6)) == pytest.approx((0.0, 0.0, 0.0, 1.2))
    second.axes[LEFTX] = 0.0
    second.axes[RIGHTY] = 0.0
    assert driver.poll(7, 0.7) == Twist() and driver.warnings() == []
    second.axes[RIGHTY] = 1.0
    assert driver.poll(8, 0.8).linear_x == pytest.approx(1.5)
    # a late removal event for the first pad does not unplug the second
    driver.handle_event(Event(pygame.JOYDEVICEREMOVED, instance_id=7))
    assert driver.pad is second and not second.closed


def test_a_pad_gone_before_its_removal_event_goes_silent():
    driver, pad = plugged()

    def gone():
        raise pygame.error("Joystick not initialized")

    pad.read = gone
    assert driver.poll(1, 0.1) is None
    assert driver.pad is None and pad.closed


def test_a_second_pad_does_not_replace_the_first():
    first, second = FakePad("first", 1), FakePad("second", 2)
    pads = iter([first, second])
    opened = []

    def opener(index):
        opened.append(index)
        return next(pads)

    driver = JoystickDriver(pad_opener=opener)
    driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=0))
    driver.handle_event(Event(pygame.JOYDEVICEADDED, device_index=1))
    assert driver.pad is first and opened == [0] and driver.status == "gamepad first"
    driver.poll(0, 0.0)
    first.axes[RIGHTY] = 1.0
    second.axes[RIGHTY] = -1.0
    assert driver.poll(1, 0.1).linear_x == pytest.approx(1.5)
    driver.handle_event(Event(pygame.JOYDEVICEREMOVED, instance_id=2))  # the second going: not ours
    assert driver.pad is first


def test_stick_motion_asks_for_a_poll_at_once():
    driver, pad = plugged()
    assert driver.next_poll_step == NEVER
    for event in (
        Event(pygame.JOYAXISMOTION, instance_id=7, joy=0, axis=RIGHTY, value=-0.5),
        Event(pygame.JOYBUTTONDOWN, instance_id=7, joy=0, button=0),
        Event(pygame.JOYBUTTONUP, instance_id=7, joy=0, button=0),
        Event(pygame.JOYHATMOTION, instance_id=7, joy=0, hat=0, value=(1, 0)),
        Event(pygame.CONTROLLERAXISMOTION, instance_id=7, axis=RIGHTY, value=-16384),
    ):
        assert driver.handle_event(event)
        assert driver.next_poll_step == ASAP
        driver.poll(2, 0.2)
        assert driver.next_poll_step == NEVER
    assert not driver.handle_event(down(pygame.K_UP))  # keys are not the joystick's
    assert driver.next_poll_step == NEVER


def test_height_mode_integrates_the_climb_stick():
    driver, pad = plugged(z_mode=ZMode.HEIGHT, centre=False)
    driver.set_z_mode(ZMode.HEIGHT, altitude_m=2.5)
    assert driver.next_poll_step == ASAP
    assert HEIGHT_MODE_BASE_M + driver.poll(0, 0.0).linear_z == pytest.approx(2.5)  # where it is: no jump
    pad.axes[LEFTY] = 1.0  # left stick full up: 1 m/s for 2 s
    for k in range(1, 21):
        twist = driver.poll(k, 0.1 * k)
    assert twist.linear_z == pytest.approx(0.5 + 2.0)
    pad.axes[LEFTY] = 0.0
    assert driver.poll(21, 3.0).linear_z == pytest.approx(2.5)  # centred: the altitude stays
    pad.axes[LEFTY] = -0.55  # half down past the deadzone: -0.5 m/s for 1 s
    driver.poll(22, 3.0)
    assert driver.poll(23, 4.0).linear_z == pytest.approx(2.0)
    pad.axes[RIGHTY] = 1.0  # the other fields are still velocities
    assert driver.poll(24, 4.0).linear_x == pytest.approx(1.5)
    driver.reset()
    pad.axes[LEFTY] = pad.axes[RIGHTY] = 0.0
    assert driver.poll(25, 5.0) == Twist()


def test_custom_mapping_moves_fields_to_other_axes():
    mapping = JoystickMapping(
        linear_x=AxisMap(LEFTY, 2.0, 4.0),  # forward on the left stick
        linear_y=None,  # no sideways
        linear_z=AxisMap(RIGHTY, -1.0, -2.0),  # climb on the right stick, inverted
        angular_z=AxisMap(9, 1.2, 2.4),  # an axis this pad does not have
        deadzone=0.0,
    )
    driver, pad = plugged(mapping)
    pad.axes[LEFTY] = 0.5
    assert fields(driver.poll(1, 0.1)) == pytest.approx((1.0, 0.0, 0.0, 0.0))
    pad.axes[RIGHTY] = 0.5
    pad.axes[RIGHTX] = pad.axes[LEFTX] = 1.0  # the default sideways and yaw axes: unmapped now
    assert fields(driver.poll(2, 0.2)) == pytest.approx((1.0, 0.0, -0.5, 0.0))
    assert driver.warnings() == ["turn: this pad has no axis 9 (see --joy-map)"]
    assert driver.help_lines()[:2] == [
        "gamepad    forward/back: left stick up/down, climb/descend: right stick up/down",
        "           turn: axis 9",
    ]


# --- the mapping file ---------------------------------------------------------------------


def test_mapping_file_sets_the_fields(tmp_path):
    path = tmp_path / "pad.toml"
    path.write_text(
        "deadzone = 0.2\n"
        "axis_linear.x = 1\nscale_linear.x = 2.0\n"
        "axis_linear.y = -1\n"
        "axis_linear.z = 3\nscale_linear.z = -1.0\nscale_linear_turbo.z = -1.5\n"
        "scale_angular.yaw = 0.5\n"
        "enable_button = 0\nenable_turbo_button = 5\n"
    )
    m = load_mapping(path)
    assert (m.deadzone, m.enable_button, m.enable_turbo_button) == (0.2, 0, 5)
    assert m.linear_x == AxisMap(1, 2.0, 4.0)  # a turbo scale not given is twice the scale
    assert m.linear_y is None  # -1: moves nothing
    assert m.linear_z == AxisMap(3, -1.0, -1.5)
    assert m.angular_z == AxisMap(0, 0.5, 1.0)  # the default axis, the file's scale
    # and the driver flies by it
    driver, pad = plugged(m)
    pad.axes[LEFTY] = 0.6  # (0.6 - 0.2) / 0.8 = half
    pad.axes[RIGHTY] = 1.0
    pad.axes[RIGHTX] = 1.0
    assert driver.poll(1, 0.1) == Twist()  # enable_button not held
    pad.buttons[0] = 1
    assert fields(driver.poll(2, 0.2)) == pytest.approx((1.0, 0.0, -1.0, 0.0))
    pad.buttons[5] = 1
    assert fields(driver.poll(3, 0.3)) == pytest.approx((2.0, 0.0, -1.5, 0.0))


def test_an_empty_mapping_file_is_the_default_mapping(tmp_path):
    path = tmp_path / "pad.toml"
    path.write_text("# nothing changed\n")
    assert load_mapping(path) == JoystickMapping()


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("dead_zone = 0.2\n", "unknown key 'dead_zone' (did you mean 'deadzone'?)"),
        ("forward = { index = 1, scale = -1.0 }\n", "forward belong to the old mapping format"),
        ('deadzone = "big"\n', "deadzone must be a finite number, got 'big'"),
        ("deadzone = nan\n", "deadzone must be a finite number"),
        ("deadzone = 0.95\n", "deadzone must be in [0, 0.9), got 0.95"),
        ("deadzone = -0.1\n", "deadzone must be in [0, 0.9), got -0.1"),
        ('scale_linear.x = "x"\n', "scale_linear.x must be a finite number, got 'x'"),
        ("scale_angular.yaw = true\n", "scale_angular.yaw must be a finite number, got True"),
        ('enable_button = "A"\n', "enable_button must be a whole number >= 0, got 'A'"),
        ("enable_turbo_button = -1\n", "enable_turbo_button must be a whole number >= 0, got -1"),
        ("axis_linear.x = -9\n", "axis_linear.x must be a whole number >= -1, got -9"),
        ("axis_angular.yaw = 1.5\n", "axis_angular.yaw must be a whole number >= -1, got 1.5"),
        ("axis_linear.X = 3\n", "axis_linear.X is not used by quadsim"),
        ("scale_linear.x = 1.0\nscale_linear.xx = 2.0\n", "scale_linear.xx is not used by quadsim"),
        ("scale_linear = 1.5\n", "scale_linear must be a table"),
        ("scale_linear_turbo.x = -3.0\n", "scale_linear_turbo.x = -3.0 and scale_linear.x = 1.5 have opposite signs"),
        (
            "scale_angular.yaw = -1.2\nscale_angular_turbo.yaw = 2.4\n",
            "scale_angular_turbo.yaw = 2.4 and scale_angular.yaw = -1.2 have opposite signs",
        ),
        ("deadzone = [\n", "not valid TOML"),
    ],
    ids=[
        "unknown-key",
        "old-format",
        "deadzone-str",
        "deadzone-nan",
        "deadzone-high",
        "deadzone-negative",
        "scale-str",
        "scale-bool",
        "button-str",
        "button-negative",
        "negative-index",
        "fractional-index",
        "axis-typo",
        "scale-typo",
        "table-not-a-table",
        "turbo-reversed",
        "turbo-reversed-inverted-axis",
        "bad-toml",
    ],
)
def test_mapping_file_errors_name_the_key_and_the_file(tmp_path, text, named):
    path = tmp_path / "pad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=re.escape(named)) as info:
        load_mapping(path)
    assert str(info.value).startswith(f"{path}: ")


def test_missing_mapping_file_is_named(tmp_path):
    path = tmp_path / "nowhere.toml"
    with pytest.raises(ConfigError, match=re.escape(f"joystick mapping file not found: {path}")):
        load_mapping(path)
