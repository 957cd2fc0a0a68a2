"""quadsim's own step of a vehicle clear of everything (quadsim.physics.free_flight) against
PyBullet's: step by step, over whole flights flown both ways, and what else reads the scene
(contacts, cameras, recordings)."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb
import pytest

from quadsim import Fleet, SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.control.landing import LandingSettings
from quadsim.core.types import Stepping
from quadsim.drivers.scripted import ScriptedDriver, load_script
from quadsim.physics.client import WorldClient
from quadsim.physics.free_flight import free_flight_step
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.sensors.camera import default_cameras
from quadsim.sim.cameras import Cameras
from quadsim.sim.description import RunDescription
from quadsim.sim.fleet import FleetVehicle
from quadsim.sim.loop import StateLog


def _base(physics) -> np.ndarray:
    """The body's base as PyBullet has it: position, orientation, velocity, spin."""
    cid, body = physics.client.posed(), physics.body_id
    position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
    velocity, spin = pb.getBaseVelocity(body, physicsClientId=cid)
    return np.array([*position, *orientation, *velocity, *spin], dtype=float)


def _gap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| per component, a quaternion's sign aside (q and -q are the same turn)."""
    gap = np.abs(a - b)
    gap[3:7] = min(gap[3:7].max(), np.abs(a[3:7] + b[3:7]).max())
    return gap


def test_one_step_is_pybullets_step_through_a_tumble_and_its_limits():
    """From each state of an uncontrolled tumble (uneven rotor forces, 10 s, PyBullet stepping),
    quadsim's step lands where PyBullet's does to within a few units in the last place; and so it
    does where Bullet's limits act: a speed past 100 m/s and a turn of more than pi/4 a step."""
    with Simulator(SimConfig(physics="pybullet")) as sim:
        physics = sim.physics
        physics.place((0.0, 0.0, 200.0))
        hover = sim.vehicle.hover_thrust_per_rotor_n
        forces = (1.3 * hover, 0.7 * hover, 1.25 * hover, 0.8 * hover)
        mass, inertia = physics._mass_kg, physics._inertia
        worst = np.zeros(13)
        turned = 0.0
        for _ in range(2400):
            before = _base(physics)
            assert physics._apply(forces) is False  # PyBullet steps it (physics = "pybullet")
            wrench, at = np.array(physics._wrench, dtype=float), physics._position
            physics.client.step()
            physics._finish_step()
            mine = before.copy()
            free_flight_step(mine, wrench, at, mass, inertia, sim.vehicle.gravity_mps2, physics.dt_s)
            worst = np.maximum(worst, _gap(mine, _base(physics)))
            turned = max(turned, abs(sim.state.roll_pitch_rad()[0]))
        assert turned > 1.5  # it did tumble (past 85 degrees of roll)
        assert worst[0:3].max() < 1e-12 and worst[7:13].max() < 1e-12 and worst[3:7].max() < 1e-14, worst
        # the limits: a state far beyond them, stepped both ways
        body, cid = physics.body_id, physics.client.cid
        pb.resetBaseVelocity(body, (150.0, -150.0, 20.0), (30.0, 0.0, 200.0), physicsClientId=cid)
        physics._read_kinematics()
        before = _base(physics)
        physics._apply(forces)
        wrench, at = np.array(physics._wrench, dtype=float), physics._position
        physics.client.step()
        mine = before.copy()
        free_flight_step(mine, wrench, at, mass, inertia, sim.vehicle.gravity_mps2, physics.dt_s)
        after = _base(physics)
        assert after[7] == 100.0 and after[8] == -100.0  # Bullet clamps each component
        assert _gap(mine, after).max() < 1e-12, _gap(mine, after)


def _fly(physics: str, flight: str) -> tuple[list[tuple[int, tuple[float, ...]]], list[tuple[int, str, str]], int]:
    """A flight flown with `physics`: (step, position and orientation) at the state rate, its
    events, and how many steps PyBullet stepped the world."""
    worlds = {"steps": 0}
    step = WorldClient.step

    def counted(client: WorldClient) -> None:
        worlds["steps"] += 1
        step(client)

    mp = pytest.MonkeyPatch()
    mp.setattr(WorldClient, "step", counted)
    try:
        return (*_flown(physics, flight), worlds["steps"])
    finally:
        mp.undo()


def _flown(physics: str, flight: str) -> tuple[list, list]:
    if flight == "fleet collision":  # two vehicles flown into each other, 3 m apart
        vehicles = [
            FleetVehicle("alpha", start=StartPose(-1.5, 0.0)),
            FleetVehicle("bravo", start=StartPose(1.5, 0.0, math.pi)),
        ]
        logs = {name: StateLog() for name in ("alpha", "bravo")}
        with Fleet(vehicles, SimConfig(z_mode=ZMode.HEIGHT, physics=physics)) as fleet:
            for name, log in logs.items():
                fleet[name].add_sink(log)
                fleet[name].send(Twist(linear_z=-0.5))
            fleet.run_for(3.0)
            for name in logs:
                fleet[name].send(Twist(linear_x=2.0, linear_z=-0.5))
            fleet.run_for(4.0)
            events = [(e.step, name, e.kind.value) for name in logs for e in fleet[name].events]
        states = [(s.step, (*s.position_m, *s.orientation_xyzw)) for log in logs.values() for s in log.states]
        return states, events
    log = StateLog()
    config = SimConfig(physics=physics, z_mode=ZMode.HEIGHT if flight != "tower crash" else ZMode.VELOCITY)
    landing = LandingSettings(hard_landing=flight == "hard landing")
    if flight == "figure-8 in turbulence":
        config = SimConfig(physics=physics, wind=WindSettings(3.0, 45.0, Turbulence.MODERATE), seed=7)
    script = {"take-off and square": "square", "figure-8 in turbulence": "figure8"}.get(flight)
    driver = ScriptedDriver(load_script(script)) if script else None
    with Simulator(config, driver, landing=landing) as sim:
        sim.add_sink(log)
        if flight == "hard landing":
            sim.send(Twist(linear_z=1.0))
            sim.run_for(4.0)
            sim.send(Twist(linear_z=-3.0))
            sim.run_for(4.0)
        elif flight == "tower crash":
            sim.send(Twist(linear_z=1.0))
            sim.run_for(1.5)
            sim.send(Twist(linear_x=4.0))
            sim.run_for(5.0)
        else:
            sim.run_for(60.0 if flight == "take-off and square" else 30.0)
        events = [(e.step, e.kind.value, e.value) for e in sim.events]
    return [(s.step, (*s.position_m, *s.orientation_xyzw)) for s in log.states], events


FLIGHTS = ["take-off and square", "figure-8 in turbulence", "hard landing", "tower crash", "fleet collision"]


@pytest.mark.parametrize("flight", FLIGHTS)
def test_a_flight_flown_both_ways_is_the_same_flight(flight):
    """The same flight with PyBullet stepping every step and with quadsim stepping the vehicle
    while it is clear: the same events at the same steps, every pose within 1e-9 m until a crash
    (contacts are PyBullet's both ways; a collision then magnifies the 1e-15 m between them, to
    3e-9 m in the fleet's), and quadsim's way PyBullet steps the world only near the floor, the
    tower or the other vehicle."""
    (theirs, their_events, their_steps), (ours, our_events, our_steps) = (
        _fly("pybullet", flight),
        _fly("quadsim", flight),
    )
    assert our_events == their_events
    assert [s for s, _ in ours] == [s for s, _ in theirs]
    kinds = {e[2] if flight == "fleet collision" else e[1] for e in our_events}
    crash = min((e[0] for e in our_events if "crash" in e), default=math.inf)

    def gaps(pairs: list) -> tuple[float, float]:
        position = max((math.dist(a[:3], b[:3]) for (_, a), (_, b) in pairs), default=0.0)
        turn = max(
            (min(math.dist(a[3:], b[3:]), math.dist(a[3:], [-q for q in b[3:]])) for (_, a), (_, b) in pairs),
            default=0.0,
        )
        return position, turn

    pairs = list(zip(ours, theirs))
    before = gaps([(a, b) for a, b in pairs if a[0] < crash])
    assert max(before) < 1e-9, before
    after = gaps([(a, b) for a, b in pairs if a[0] >= crash])  # a collision's contacts magnify 1e-15 m
    assert max(after) < 1e-6, after
    steps = ours[-1][0]
    assert their_steps == steps
    assert our_steps < (steps if crash < math.inf else 0.5 * steps), (our_steps, steps)  # quadsim's own steps
    if flight in ("tower crash", "fleet collision"):
        assert "crash" in kinds, our_events
    if flight == "hard landing":
        assert "touchdown" in kinds, our_events


def test_each_way_is_deterministic_to_the_bit():
    """A flight flown twice the same way is the same flight to the bit (quadsim's way too)."""
    assert _flown("quadsim", "figure-8 in turbulence") == _flown("quadsim", "figure-8 in turbulence")


def test_what_reads_the_scene_sees_the_vehicle_where_it_flew():
    """PyBullet's copy of a vehicle quadsim steps is posed when something reads the scene: the
    client id a caller takes, and the cameras rendering in-process, which see the same images
    as with PyBullet stepping."""
    images = {}
    for physics in ("pybullet", "quadsim"):
        with Simulator(SimConfig(physics=physics, z_mode=ZMode.HEIGHT)) as sim:
            with Cameras(sim, default_cameras(96, 72, 10)) as cameras:
                sim.send(Twist(linear_x=0.5, angular_z=0.3))
                sim.run_for(5.0)
                images[physics] = {name: cameras.latest(name).rgb.copy() for name in ("front", "floor")}
            position, orientation = pb.getBasePositionAndOrientation(
                sim.physics.body_id, physicsClientId=sim.physics.client_id
            )
            offset = sim.physics._offset
            assert math.dist(position, sim.state.position_m) == pytest.approx(math.hypot(*offset), abs=1e-12)
            assert orientation == pytest.approx(sim.state.orientation_xyzw, abs=1e-15)
    for name in ("front", "floor"):
        assert images["pybullet"][name].std() > 5.0  # a scene, not a blank image
        assert np.array_equal(images["pybullet"][name], images["quadsim"][name]), name


def test_a_run_records_how_it_was_stepped_and_older_runs_re_fly_with_pybullet():
    """The setting is recorded; a recording made before it existed re-flies with PyBullet's step
    alone, as it was flown; a wrong value is refused with the choices."""
    with Simulator(SimConfig(physics="pybullet")) as sim:
        data = sim.description().to_parameters()
    assert data["config"]["physics"] == "pybullet"
    assert RunDescription.from_parameters(data).config.physics is Stepping.PYBULLET
    del data["config"]["physics"]
    assert RunDescription.from_parameters(data).config.physics is Stepping.PYBULLET
    data["config"]["physics"] = "quadsim"
    assert RunDescription.from_parameters(data).config.physics is Stepping.QUADSIM
    assert SimConfig().physics is Stepping.QUADSIM
    with pytest.raises(Exception, match="'quadsim', 'pybullet'"):
        SimConfig(physics="bullet")


def test_a_body_added_from_outside_mid_flight_is_hit_not_flown_through():
    """Code of the user's own adds a box in the vehicle's path after it has flown clear for a
    while (through `physics.client_id`): the vehicle hits it, as with PyBullet stepping."""
    hits = {}
    for physics in ("quadsim", "pybullet"):
        with Simulator(SimConfig(physics=physics, z_mode=ZMode.HEIGHT)) as sim:
            sim.send(Twist())
            sim.run_for(3.0)  # up at 2 m, clear of everything
            x, y, z = sim.state.position_m
            cid = sim.physics.client_id
            wall = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=(0.1, 2.0, 2.0), physicsClientId=cid)
            pb.createMultiBody(0.0, wall, -1, basePosition=(x + 2.0, y, z), physicsClientId=cid)
            sim.send(Twist(linear_x=2.0))
            sim.run_for(3.0)
            hits[physics] = [(e.step, e.kind.value) for e in sim.events if e.kind.value == "crash"]
            assert sim.state.position_m[0] < x + 2.0, physics  # stopped by the wall, not through it
    assert hits["quadsim"] and hits["quadsim"] == hits["pybullet"], hits


def test_a_vehicle_moved_from_outside_flies_on_from_there():
    """Code of the user's own that moves the vehicle in PyBullet (through `physics.client_id`)
    between steps: the next step starts where it put it, and the flight from there is the same
    whoever steps it."""
    ends = {}
    for physics in ("quadsim", "pybullet"):
        with Simulator(SimConfig(physics=physics, z_mode=ZMode.HEIGHT)) as sim:
            sim.send(Twist())
            sim.run_for(3.0)
            cid, body = sim.physics.client_id, sim.physics.body_id
            pb.resetBasePositionAndOrientation(body, (5.0, -4.0, 3.0), (0.0, 0.0, 0.0, 1.0), physicsClientId=cid)
            sim.step(1)
            assert math.dist(sim.state.position_m, (5.0, -4.0, 3.0)) < 0.05, (physics, sim.state.position_m)
            sim.run_for(2.0)  # the controller flies back to the spot it holds
            ends[physics] = sim.state.position_m
    assert math.dist(ends["quadsim"], ends["pybullet"]) < 1e-9, ends
    assert math.dist(ends["quadsim"], (5.0, -4.0, 3.0)) > 1.0  # it did fly on


def _near_by_every_pair(bodies) -> set:
    """The vehicles another one could reach within two steps, every pair measured (as the
    physics did on every step before it kept a slack)."""
    near = set()
    for i, a in enumerate(bodies):
        for b in bodies[i + 1 :]:
            speeds = sum(map(abs, a._linear_velocity)) + sum(map(abs, b._linear_velocity))
            apart = a.reach_m + b.reach_m + 0.5 + 2.0 * a.dt_s * speeds
            if math.dist(a._position, b._position) <= apart:
                near |= {a, b}
    return near


def test_vehicles_near_each_other_are_found_as_if_every_pair_were_measured_every_step():
    """Two vehicles flown into each other, a third hovering apart until it is put beside one of
    them: on every step the vehicles found near another are those that measuring every pair
    finds, while most steps measure no pair at all (the slack kept from the last measurement)."""
    from quadsim.physics.pybullet_world import _near_others

    vehicles = [
        FleetVehicle("alpha", start=StartPose(-1.5, 0.0)),
        FleetVehicle("bravo", start=StartPose(1.5, 0.0, math.pi)),
        FleetVehicle("charlie", start=StartPose(0.0, 6.0)),
    ]
    with Fleet(vehicles, SimConfig(z_mode=ZMode.HEIGHT)) as fleet:
        client = fleet.client
        for name in fleet:
            fleet[name].send(Twist())
        plan = [(720, None), (960, Twist(linear_x=2.0)), (240, "place"), (240, None)]
        found, measured, steps = [], 0, 0
        for count, what in plan:
            if what == "place":  # beside alpha, wherever alpha went: a jump, not a flight
                x, y, z = fleet["alpha"].physics.pose[0]
                fleet["charlie"].physics.place((x, y + 0.6, z))
                placed_at = len(found)
            elif what is not None:
                fleet["alpha"].send(what)
                fleet["bravo"].send(what)
            for _ in range(count):
                fleet.step(1)
                before = client.apart
                near = _near_others(client)
                measured += client.apart is not before
                steps += 1
                assert near == _near_by_every_pair(client.bodies), fleet.step_count
                found.append(len(near))
        assert max(found[:placed_at]) == 2 and found[placed_at] >= 2, found  # the collision; charlie beside alpha
        assert measured < steps / 2, (measured, steps)  # hovering apart, no pair is measured
        assert any(e.kind.value == "crash" for e in fleet["alpha"].events), fleet["alpha"].events
