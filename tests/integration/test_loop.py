"""The loop owns the step count and the rates; the dead-man timeout applies to scripted input; a
reset goes back to the start, alone and in a fleet; a fleet's vehicles fly on one clock, each as it
would alone."""

import math

import pytest

from quadsim import ConfigError, Fleet, FleetVehicle, Rates, SimConfig, Simulator, StartPose, StateLog, Twist, ZMode
from quadsim.drivers import NEVER
from quadsim.drivers.scripted import ScriptedDriver, load_script, parse_script


def test_rates_must_divide_physics_rate():
    with pytest.raises(ConfigError, match="control_hz=100 Hz does not divide the physics rate 240 Hz"):
        Rates(control_hz=100)
    with pytest.raises(ConfigError, match="state_hz"):
        Rates(state_hz=50)
    with pytest.raises(ConfigError, match="positive whole number"):
        Rates(input_hz=0)


def test_published_states_follow_the_state_rate():
    with Simulator(SimConfig(rates=Rates(state_hz=30))) as sim:
        log = StateLog()
        sim.add_sink(log)
        sim.run_for(1.0)
        assert sim.step_count == 240
        assert [s.step for s in log.states] == list(range(8, 241, 8))


def test_commands_are_stamped_at_the_input_rate():
    script = parse_script("z_mode height\n1.0 linear.z=0\n", "t")
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT), ScriptedDriver(script)) as sim:
        log = StateLog()
        sim.add_sink(log)
        sim.run_for(1.0)
        assert [step for step, _ in log.commands] == list(range(0, 240, 12))


def test_slower_control_rate_still_flies():
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, rates=Rates(control_hz=120))) as sim:
        sim.send(Twist())
        assert sim.run_for(4.0).position_m[2] == pytest.approx(2.0, abs=0.03)


def test_silence_triggers_dead_man_hold():
    # fly forward, then the script goes silent: after the 0.5 s timeout the vehicle stops and holds
    script = parse_script("z_mode height\n4.0 linear.z=0\n2.0 linear.x=1.0\nsilence 6.0\n", "t")
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT), ScriptedDriver(script)) as sim:
        sim.run_for(6.0)
        assert sim.state.linear_velocity_mps[0] > 0.9
        sim.run_for(0.4)  # within the timeout: still flying the last command
        assert sim.state.linear_velocity_mps[0] > 0.9
        sim.run_for(3.0)
        held = sim.state.position_m
        assert abs(sim.state.linear_velocity_mps[0]) < 0.02
        later = sim.run_for(2.6).position_m
        assert abs(later[0] - held[0]) < 0.01 and later[2] == pytest.approx(2.0, abs=0.02)


class _SettableDriver:
    """A driver publishing whatever it is set to, unchecked (as a live bridge might receive)."""

    name = "settable"
    next_poll_step = NEVER
    finished = False

    def __init__(self) -> None:
        self.twist: Twist | None = None

    def poll(self, step: int, time_s: float) -> Twist | None:
        return self.twist

    def describe(self) -> dict:
        return {"name": self.name}


def test_nan_command_keeps_last_good_one_until_the_timeout():
    driver = _SettableDriver()
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT), driver) as sim:
        driver.twist = Twist()
        sim.run_for(4.0)
        driver.twist = Twist(linear_x=1.0)
        sim.run_for(1.5)
        driver.twist = Twist(linear_x=float("nan"))
        state = sim.run_for(0.4)  # rejected: the last good command (1 m/s forward) stands
        assert state.linear_velocity_mps[0] == pytest.approx(1.0, abs=0.05)
        assert sim.gate.rejected_count > 0
        state = sim.run_for(3.0)  # only rejected commands for longer than the timeout: hold
        assert abs(state.linear_velocity_mps[0]) < 0.05


def test_send_checks_its_argument_at_once():
    with Simulator(SimConfig()) as sim:
        with pytest.raises(ValueError, match="linear_x must be finite"):
            sim.send(Twist(linear_x=float("nan")))
        with pytest.raises(TypeError, match=r"takes a quadsim\.Twist"):
            sim.send((1.0, 0.0, 0.0, 0.0, 0.0, 0.0))  # type: ignore[arg-type]
        with pytest.raises(TypeError, match="angular_z must be a number"):
            sim.send(Twist(angular_z="0.5"))  # type: ignore[arg-type]
        assert sim.step(24).position_m[2] < 0.1  # nothing was taken: still on the ground


HEIGHT = SimConfig(z_mode=ZMode.HEIGHT)


@pytest.mark.parametrize("shape", ["alone", "fleet of 2"])
def test_reset_returns_to_start(shape):
    """A reset puts the clock at 0 and the vehicle where it started, and it flies its script
    again the same (in a fleet: the fleet resets, every vehicle with it)."""
    driver = ScriptedDriver(load_script("step_forward"))  # take off for 5 s, then forward at 1 m/s
    if shape == "alone":
        run = Simulator(HEIGHT, driver)
    else:
        run = Fleet([FleetVehicle("alpha", driver=driver), FleetVehicle("bravo", start=StartPose(0.0, 3.0))], HEIGHT)
    with run:
        flown = run if isinstance(run, Simulator) else run["alpha"]
        start = flown.state.position_m
        run.run_for(7.0)
        first = flown.state
        assert first.position_m[0] > 1.0 and first.position_m[2] > 1.5  # up and forward
        run.reset()
        assert run.step_count == 0 and flown.state.position_m == pytest.approx(start)
        assert flown.state.position_m[2] < 0.1
        run.run_for(7.0)
        assert flown.state.position_m == first.position_m


def test_the_state_step_is_always_the_loops_step_count():
    # one clock: every state anyone sees (controller, sinks, taps, the API) carries the loop's count
    from quadsim.physics.pybullet_world import PhysicsWorld

    assert not hasattr(PhysicsWorld, "step")  # nothing outside the loop advances physics
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, rates=Rates(control_hz=120, state_hz=60))) as sim:
        assert not hasattr(sim.physics, "step_count")
        seen_by_controller: list[int] = []
        update = sim.controller.update

        def spying(state, command, dt_s):
            seen_by_controller.append(state.step)
            return update(state, command, dt_s)

        sim.loop.controller.update = spying  # type: ignore[method-assign]
        log = StateLog()
        sim.add_sink(log)
        tapped: list[int] = []
        sim.loop.add_tap(5, lambda s: tapped.append(s.step))
        sim.send(Twist())
        for chunk in (1, 7, 240, 13, 3):
            state = sim.step(chunk)
            assert state.step == sim.step_count == sim.state.step
        total = sim.step_count
        assert total == 264
        assert seen_by_controller == list(range(0, total, 2))  # control at 120 Hz: every 2nd step
        assert [s.step for s in log.states] == list(range(4, total + 1, 4))
        assert tapped == list(range(5, total + 1, 5))
        sim.reset()
        assert sim.step_count == 0 == sim.state.step
        assert sim.step(5).step == 5


def _alone(script: str | None, start: StartPose, seconds: float):
    driver = ScriptedDriver(load_script(script)) if script else None
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, start=start), driver) as sim:
        sim.run_for(seconds)
        return sim.state, [e.kind for e in sim.events]


def test_each_vehicle_of_a_fleet_flies_as_it_would_alone_on_one_clock():
    """A square, a yaw turn and an idle vehicle, in one world: each ends where it ends when it
    flies alone (to the bit: PyBullet solves bodies apart that do not touch), all on one clock."""
    plan = {
        "alpha": ("square", StartPose()),
        "bravo": ("yaw", StartPose(0.0, -4.0)),
        "charlie": (None, StartPose(-3.0, 2.0)),
    }
    vehicles = [
        FleetVehicle(name, start=start, driver=ScriptedDriver(load_script(script)) if script else None)
        for name, (script, start) in plan.items()
    ]
    with Fleet(vehicles, HEIGHT) as fleet:
        fleet.run_for(20.0)
        assert fleet.step_count == 4800 and fleet.time_s == 20.0
        assert [fleet[n].step_count for n in fleet] == [4800] * 3
        flown = {n: (fleet[n].state, [e.kind for e in fleet[n].events]) for n in fleet}
    for name, (script, start) in plan.items():
        state, kinds = _alone(script, start, 20.0)
        assert flown[name][0].position_m == state.position_m, name
        assert flown[name][0].orientation_xyzw == state.orientation_xyzw, name
        assert flown[name][1] == kinds, name
    alpha, bravo, charlie = (flown[n][0] for n in ("alpha", "bravo", "charlie"))
    assert math.dist(alpha.position_m[:2], (0.0, 3.0)) < 0.2  # the square's third corner at 20 s
    assert abs(math.remainder(bravo.yaw_rad() - 6.0, 2 * math.pi)) < 0.1  # turned 6 rad
    assert charlie.position_m[2] < 0.1  # idle: never took off
