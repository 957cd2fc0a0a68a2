"""The subscribed driver (ROS 2 / Foxglove input): each message once, the newest wins, bad ones
kept out, and with no messages the gate's dead-man timeout holds the vehicle."""

from __future__ import annotations

import math
import threading

from quadsim import SimConfig, Simulator
from quadsim.core.types import Twist
from quadsim.drivers import ASAP, NEVER
from quadsim.drivers.subscribed import SubscribedDriver


def test_each_message_is_published_once_and_the_newest_wins() -> None:
    d = SubscribedDriver("ros2")
    assert d.poll(0, 0.0) is None and d.next_poll_step == NEVER
    assert d.deliver((1.0, 0.0, 0.0), 0.0)
    assert d.next_poll_step == ASAP
    assert d.deliver((0.5, 0.25, -0.1), 0.3)
    # the yaw rate lands in angular_z (it was once built positionally into angular_x)
    assert d.poll(1, 0.0) == Twist(linear_x=0.5, linear_y=0.25, linear_z=-0.1, angular_z=0.3)
    assert d.poll(2, 0.0) is None and d.next_poll_step == NEVER
    assert (d.received, d.dropped, d.rejected) == (2, 1, 0)


def test_malformed_messages_are_rejected() -> None:
    d = SubscribedDriver("foxglove")
    assert not d.deliver((math.nan, 0.0, 0.0), 0.0)
    assert not d.deliver((1.0, 0.0), 0.0)  # type: ignore[arg-type]
    assert not d.deliver(("fast", 0.0, 0.0), 0.0)  # type: ignore[arg-type]
    assert d.poll(0, 0.0) is None and d.rejected == 3


def test_messages_from_another_thread_fly_and_silence_holds() -> None:
    driver = SubscribedDriver("ros2")
    sim = Simulator(SimConfig(), driver)
    start = sim.state.position_m

    def publisher() -> None:
        # 2 s of 1 m/s forward, climbing (forward alone on the ground stays landed), at 20 Hz of
        # simulation time, handed over by a thread
        for _ in range(40):
            driver.deliver((1.0, 0.0, 0.5), 0.0)
            done.wait()
            done.clear()

    done = threading.Event()
    t = threading.Thread(target=publisher)
    t.start()
    hz = sim.config.rates.physics_hz
    for _ in range(40):
        while driver.next_poll_step != ASAP:
            pass
        sim.step(hz // 20)
        done.set()
    t.join()
    moved = sim.state.position_m[0] - start[0]
    assert moved > 0.8, moved
    sim.step(hz * 3)  # nothing more arrives: the dead-man timeout brings it to a hold
    v = sim.state.linear_velocity_mps
    assert math.hypot(v[0], v[1]) < 0.1, v
    assert sim.gate.last_receive_step is not None
    sim.close()


def test_the_run_summary_says_what_arrived_live() -> None:
    """NaN Twists stop at the driver and a 1e308 one is clamped: the summary counts both (it said
    '0 rejected' after NaNs had arrived), and a live line says what the wire brought."""
    from quadsim.session.plan import RunPlan
    from quadsim.session.run import Run

    d = SubscribedDriver("ros2")
    with Simulator(SimConfig(), driver=d) as sim:
        for linear in [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (1e308, 0.0, 0.0), (0.5, 0.0, 0.0), (0.0, 0.5, 0.0)]:
            d.deliver(linear, 0.0)
            if linear[0] != 0.5:  # the 0.5 forward is superseded by the 0.5 left before a step takes it
                sim.step(5)
        with Run(RunPlan.alone(sim.config, d, duration_s=0.5), fleet=sim) as run:
            summary = run.fly()[""]
    lines = "\n".join(summary.lines())
    assert "2 rejected (not finite), 1 clamped to the limits" in lines, lines
    assert "live input      5 arrived on /quad_cmd_twist from ros2: 2 rejected (not finite), 1 superseded" in lines
    assert sim.gate.last_command.linear_y == 0.5


def test_each_live_input_holds_after_its_own_timeout_which_the_run_records() -> None:
    """A Foxglove input holds 0.2 s after its last Twist (the Teleop panel sends nothing on
    release); a ROS 2 input keeps the run's; either can be set. The vehicle's config, which the
    recording keeps, says the one its gate used."""
    cases = [
        (SubscribedDriver("foxglove"), SimConfig(), 0.2),
        (SubscribedDriver("ros2"), SimConfig(), 0.5),
        (SubscribedDriver("ros2"), SimConfig(command_timeout_s=0.8), 0.8),
        (SubscribedDriver("foxglove", command_timeout_s=0.3), SimConfig(command_timeout_s=0.8), 0.3),
    ]
    for driver, config, timeout_s in cases:
        with Simulator(config, driver) as sim:
            assert sim.config.command_timeout_s == timeout_s, driver.name
            assert sim.gate.timeout_steps == round(timeout_s * 240)
            assert sim.describe()["config"]["command_timeout_s"] == timeout_s


def test_a_released_command_holds_after_the_foxglove_timeout() -> None:
    """The last Twist acts for 0.2 s (48 steps at 240 Hz), then the gate holds."""
    driver = SubscribedDriver("foxglove")
    with Simulator(SimConfig(), driver) as sim:
        driver.deliver((0.0, 0.0, 1.0), 0.0)
        sim.run_for(1.0 / 240)
        sent = sim.step_count - 1
        sim.run_for(0.19)
        assert not sim.gate.active(sim.step_count).hold
        sim.run_for(0.02)
        assert sim.gate.active(sim.step_count).hold and sim.step_count - sent > 48
