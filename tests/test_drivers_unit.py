"""The keyboard and joystick drivers on synthetic events: no window, no simulator.

As Gymnasium tests its play loop, events are built with pygame.event.Event and handed to the
driver directly; the joystick is a fake device object made by the driver's device factory.
Each test reads the Twist the driver would publish and checks fields, signs and sizes.
"""

import pygame
import pytest
from pygame.event import Event

from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, ZMode
from quadsim.drivers import ASAP, NEVER
from quadsim.drivers.keyboard import DEFAULT_LAYOUT, TELEOP_TWIST_LAYOUT, KeyboardDriver, Speeds

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
