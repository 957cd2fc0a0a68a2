"""The loop's quiet steps in one compiled call (quadsim.sim.clear_flight): every flight flown with
them is the flight flown one step at a time, to the bit, whatever ends a run of quiet steps (a
poll, a published state, a tap, the dead-man firing, a replayed command, the clearance running
out, the ceiling, a landing); and they are taken where they apply."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import quadsim.envs  # noqa: F401 - registers the envs
from quadsim import Fleet, SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.control.landing import LandingSettings
from quadsim.drivers.replay import ReplayDriver
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.sim.config import Rates
from quadsim.sim.fleet import FleetVehicle
from quadsim.sim.loop import SimLoop, StateLog
from quadsim.vehicle.params import SHIPPED_VEHICLES


class _Windows:
    """Counts the steps the loop flew in compiled runs of quiet steps; or turns them off."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, on: bool) -> None:
        self.steps = 0
        fly = SimLoop._fly_quiet_steps

        def counted(loop: SimLoop, quiet: int) -> int:
            flown = fly(loop, quiet)
            self.steps += flown
            return flown

        monkeypatch.setattr(SimLoop, "_fly_quiet_steps", counted)
        if not on:
            monkeypatch.setattr(SimLoop, "_quiet_steps", lambda loop, steps: 0)


def _square(sim: Simulator) -> None:
    sim.run_for(60.0)


def _sparse_commands() -> ReplayDriver:
    """A climb to 3 m, then commands far apart: the dead-man's hold fires between them, within
    what would be a quiet run."""
    climb = [(5 + 23 * i, Twist(linear_z=1.0)) for i in range(32)]
    twists = (Twist(linear_x=1.5, angular_z=0.8), Twist(linear_y=-1.0), Twist(linear_z=-0.4), Twist(linear_z=0.5))
    return ReplayDriver(climb + [(751 + 251 * i, twists[i % 4]) for i in range(12)])


def _ceiling_and_landing(sim: Simulator) -> None:
    sim.send(Twist(linear_z=3.0))  # up to the ceiling (max_altitude_m 50 m), slowed below it
    sim.run_for(24.0)
    assert sim.state.position_m[2] > 49.0, sim.state
    sim.send(Twist(linear_z=-2.0, linear_x=0.5))  # down, slowed near the ground, landed
    sim.run_for(40.0)
    assert sim.events[-1].kind.value == "landed", sim.events


def _replayed(sim: Simulator) -> None:
    sim.run_for(20.0)


def _imu_unseen_then_read(sim: Simulator) -> None:
    """No sink for 20 s (the IMU noise walks in the compiled steps, 60 Hz samples across the
    block of 256 drawn at a time), then a sink: its readings carry the biases walked meanwhile."""
    log = sim.drone.loop.sinks.pop()
    sim.send(Twist(linear_z=1.0))
    sim.run_for(3.0)
    sim.send(Twist(linear_x=1.0, angular_z=0.4))
    sim.run_for(17.0)
    sim.add_sink(log)
    sim.run_for(5.0)


def _odd_taps(sim: Simulator) -> None:
    seen: list[int] = []
    sim.add_tap(7, lambda state: seen.append(state.step))
    sim.send(Twist(linear_z=1.0, angular_z=0.5))
    sim.run_for(3.0)
    sim.send(Twist(linear_x=2.0))
    sim.run_for(3.0)
    assert seen == list(range(7, sim.drone.step_count + 1, 7)), seen[:5]


def _replay_driver() -> ReplayDriver:
    """Commands at steps no input tick falls on (a replay polls at each command's own step)."""
    commands = [(7 + 37 * i, Twist(linear_z=1.0)) for i in range(20)]
    commands += [(800 + 37 * i, Twist(linear_x=math.sin(i), linear_y=math.cos(i), angular_z=0.3)) for i in range(80)]
    return ReplayDriver(commands)


FLIGHTS = {
    "square script, height mode": (
        SimConfig(z_mode=ZMode.HEIGHT),
        lambda: ScriptedDriver(load_script("square")),
        _square,
    ),
    "figure-8, no IMU noise": (
        SimConfig(z_mode=ZMode.HEIGHT, sensor_noise=False),
        lambda: ScriptedDriver(load_script("figure8")),
        _square,
    ),
    "dead-man firing": (SimConfig(z_mode=ZMode.VELOCITY, command_timeout_s=0.3), _sparse_commands, _replayed),
    "ceiling and landing": (SimConfig(z_mode=ZMode.VELOCITY), None, _ceiling_and_landing),
    "replayed commands": (SimConfig(z_mode=ZMode.VELOCITY, rates=Rates(input_hz=30)), _replay_driver, _replayed),
    "taps every 7 steps": (SimConfig(z_mode=ZMode.VELOCITY), None, _odd_taps),
    "IMU noise unseen, then read": (SimConfig(z_mode=ZMode.VELOCITY), None, _imu_unseen_then_read),
    "in a wind (not quiet)": (
        SimConfig(z_mode=ZMode.HEIGHT, wind=WindSettings(3.0, 45.0, Turbulence.MODERATE), seed=7),
        lambda: ScriptedDriver(load_script("figure8")),
        _square,
    ),
}


def _fly(name: str, monkeypatch: pytest.MonkeyPatch, windows: bool) -> tuple[list, list, int]:
    config, driver, flight = FLIGHTS[name]
    counted = _Windows(monkeypatch, windows)
    log = StateLog()
    with Simulator(config, driver() if driver else None, landing=LandingSettings()) as sim:
        sim.add_sink(log)
        flight(sim)
        events = [(e.step, e.kind.value, e.value) for e in sim.events]
        log.states.append(sim.state)
    monkeypatch.undo()
    return log.states, events, counted.steps


@pytest.mark.parametrize("name", list(FLIGHTS))
def test_a_flight_with_quiet_steps_compiled_is_the_same_flight_to_the_bit(name, monkeypatch):
    """States (pose, velocities, rotor thrusts, specific force, IMU noise), commands and events
    the same with the compiled runs of quiet steps as one step at a time; and the runs were
    taken (most steps of a flight clear of everything, none in a wind)."""
    states, events, compiled = _fly(name, monkeypatch, True)
    reference, reference_events, none = _fly(name, monkeypatch, False)
    assert none == 0
    assert events == reference_events
    assert len(states) == len(reference) > 100
    for ours, theirs in zip(states, reference):
        assert ours == theirs, (ours.step, ours, theirs)
    assert (states[-2].imu is None) == (name == "figure-8, no IMU noise")  # the noise is in what was compared
    steps = states[-1].step
    if name == "in a wind (not quiet)":
        assert compiled == 0
    else:
        assert compiled > steps / 3, (compiled, steps)


def test_hover_episodes_with_resets_are_the_same_to_the_bit(monkeypatch):
    """quadsim/Hover-v0 with random actions across resets and crashes: the same observations,
    rewards and ends both ways, the compiled runs taking most steps."""

    def episodes(windows: bool) -> tuple[list, int]:
        counted = _Windows(monkeypatch, windows)
        env = gym.make("quadsim/Hover-v0")
        rng = np.random.default_rng(3)
        out = []
        observation, _ = env.reset(seed=11)
        for _ in range(700):
            action = np.clip(rng.normal(0.2, 0.6, 4), -1, 1).astype(np.float32)
            observation, reward, terminated, truncated, _ = env.step(action)
            out.append((observation.tobytes(), reward, terminated, truncated))
            if terminated or truncated:
                observation, _ = env.reset()
        env.close()
        monkeypatch.undo()
        return out, counted.steps

    ours, compiled = episodes(True)
    theirs, none = episodes(False)
    assert none == 0 and compiled > 700 * 8 / 3, compiled
    assert ours == theirs
    assert sum(end for *_, end, _ in ours) + sum(trunc for *_, trunc in ours) >= 1  # an episode ended


def test_a_vehicle_placed_near_the_scenery_mid_flight_leaves_the_compiled_steps(monkeypatch):
    """Put beside the tower while flying: the clearance kept no longer holds, the loop steps it
    one step at a time (PyBullet's), and it touches the tower as it would have."""
    counted = _Windows(monkeypatch, True)
    with Simulator(SimConfig(z_mode=ZMode.HEIGHT, start=StartPose(-8.0, 0.0))) as sim:
        sim.send(Twist())
        sim.run_for(4.0)
        quiet_before = counted.steps
        tower = next(lm for lm in sim.world.landmarks if lm.name == "red_tower")
        (tx, ty, _), (sx, _, _) = tower.position_m, tower.size_m
        sim.physics.place((tx - sx / 2 - 0.3, ty, 2.0))
        sim.send(Twist(linear_x=1.0))
        sim.run_for(2.0)
        assert quiet_before > 240 * 4 / 3
        assert any(e.hit == "red_tower" for e in sim.events), sim.events


def _fleet_flight(monkeypatch: pytest.MonkeyPatch, together: bool, flight: str) -> tuple[list, list, int]:
    """A fleet flown with its quiet steps in one compiled call for all (or one step at a time)."""
    from quadsim.sim.clear_flight import QuietFleet

    flown_together = {"steps": 0}
    fly = QuietFleet.fly

    def counted(quiet: QuietFleet, steps: int) -> int:
        steps = fly(quiet, steps) if together else 0
        flown_together["steps"] += steps
        return steps

    monkeypatch.setattr(QuietFleet, "fly", counted)
    if flight == "mixed airframes":
        vehicles = [
            FleetVehicle("quad", start=StartPose(-3.0, 0.0)),
            FleetVehicle("cf", start=StartPose(0.0, 3.0), urdf=SHIPPED_VEHICLES["crazyflie"]),
            FleetVehicle("hexa", start=StartPose(3.0, 0.0), urdf=SHIPPED_VEHICLES["hexa"]),
        ]
    else:
        vehicles = [
            FleetVehicle(f"v{i}", start=StartPose(-12.0 + 1.5 * (i % 3), 6.0 + 1.5 * (i // 3))) for i in range(5)
        ]
        vehicles += [
            FleetVehicle("alpha", start=StartPose(-1.5, 0.0)),
            FleetVehicle("bravo", start=StartPose(1.5, 0.0, math.pi)),
        ]
    logs = {v.name: StateLog() for v in vehicles}
    with Fleet(vehicles, SimConfig(z_mode=ZMode.HEIGHT)) as fleet:
        names = list(fleet)
        for name in names:
            fleet[name].send(Twist(linear_z=0.5 if flight == "mixed airframes" else 0.0))
        fleet.run_for(6.0)  # no sink: the IMU noise walks in the compiled steps
        for name, log in logs.items():
            fleet[name].add_sink(log)
        if flight == "mixed airframes":
            for i, name in enumerate(names):
                fleet[name].send(Twist(linear_x=1.0 + 0.5 * i, angular_z=0.4, linear_z=-0.3))
            fleet.run_for(8.0)
        else:
            fleet["alpha"].send(Twist(linear_x=2.0))  # into bravo
            fleet["bravo"].send(Twist(linear_x=2.0))
            fleet.run_for(3.0)
            x, y, z = fleet["v1"].physics.pose[0]
            fleet["v0"].physics.place((x - 0.3, y, z))  # put against v1: their rotors touch
            fleet.run_for(3.0)
        events = [(e.step, name, e.kind.value, e.hit) for name in names for e in fleet[name].events]
        states = [s for log in logs.values() for s in log.states] + [fleet[name].state for name in names]
    monkeypatch.undo()
    return states, events, flown_together["steps"]


@pytest.mark.parametrize("flight", ["a collision and a vehicle put beside another", "mixed airframes"])
def test_a_fleet_flown_together_in_one_compiled_call_is_the_same_fleet_to_the_bit(flight, monkeypatch):
    """A fleet's quiet steps (every vehicle clear of the scenery and of the others) in one call
    for all: the same states (IMU readings included: the noise walked unseen for 6 s first),
    the same events at the same steps, as one step at a time; most steps taken that way."""
    states, events, together = _fleet_flight(monkeypatch, True, flight)
    reference, reference_events, none = _fleet_flight(monkeypatch, False, flight)
    assert none == 0 and together > 240 * 6 / 2, together
    assert events == reference_events
    assert len(states) == len(reference) > 500
    for ours, theirs in zip(states, reference):
        assert ours == theirs, (ours.step, ours, theirs)
    if flight != "mixed airframes":
        assert {(name, kind) for _, name, kind, _ in events} >= {("alpha", "crash"), ("bravo", "crash")}
        assert any(kind == "crash" and name in ("v0", "v1") for _, name, kind, _ in events), events
