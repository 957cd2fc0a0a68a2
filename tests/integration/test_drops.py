"""Motors-off drops: every hard impact is reported once, with its kind and its impact speed, however
soon after the vehicle left the floor; how each airframe rebounds and where it comes to rest."""

import math

import numpy as np
import pytest

from quadsim import SimConfig, Simulator
from quadsim.core.kinematics import matrix_from_rpy, quaternion_from_matrix
from quadsim.physics.pybullet_quiet import pb
from quadsim.physics.pybullet_world import Contact
from quadsim.sim.flight_events import CRASH_SPEED_MPS, TILT_UP_Z, ContactMonitor, EventKind
from quadsim.vehicle.params import SHIPPED_VEHICLES, VehicleParams

#: released at rest from these heights of base_link (m); the lowest only for upright attitudes
#: (a frame tilted further would start inside the floor), where it is a touchdown
HEIGHTS_M = (0.15, 0.3, 0.5, 1.0, 2.0, 4.0)
#: (roll, pitch) in degrees
ATTITUDES_DEG = {"level": (0.0, 0.0), "roll20": (20.0, 0.0), "roll60": (60.0, 0.0), "nose_down": (0.0, 90.0)}
ATTITUDES_DEG["inverted"] = (180.0, 0.0)


def _reference_impact_mps(vehicle: VehicleParams, rotation, gap_m: float, dt_s: float = 1e-4) -> float:
    """The speed of a fall through `gap_m` at a constant attitude, the rotors stopped: gravity and
    the parameter file's body drag along the body axes (RK4), apart from the simulator's code."""
    r = np.array(rotation)
    linear = np.array(vehicle.aero.body_drag_linear_ns_per_m)
    quadratic = np.array(vehicle.aero.body_drag_quadratic_ns2_per_m2)
    gravity = np.array([0.0, 0.0, -vehicle.gravity_mps2])

    def accel(v):
        vb = r.T @ v
        return r @ (-(linear + quadratic * np.abs(vb)) * vb) / vehicle.mass_kg + gravity

    v, fallen = np.zeros(3), 0.0
    while fallen < gap_m:
        k1 = accel(v)
        k2 = accel(v + dt_s / 2 * k1)
        k3 = accel(v + dt_s / 2 * k2)
        k4 = accel(v + dt_s * k3)
        fallen -= dt_s * (v[2] + dt_s / 6 * (k1[2] + k2[2] + k3[2]))
        v = v + dt_s / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return float(np.linalg.norm(v))


def _place(sim: Simulator, height_m: float, roll_deg: float, pitch_deg: float):
    """Back at the start, then released at rest at `height_m`, motors off; the rotation and the
    gap between the vehicle's collision shapes and the floor."""
    sim.reset()
    rotation = matrix_from_rpy(math.radians(roll_deg), math.radians(pitch_deg), 0.0)
    physics = sim.physics
    physics.place((0.0, 0.0, height_m), quaternion_from_matrix(rotation))
    floor = physics.landmark_ids["floor"]
    points = pb.getClosestPoints(physics.body_id, floor, 10.0, physicsClientId=physics.client_id)
    return rotation, min(p[8] for p in points)


@pytest.mark.parametrize("airframe", ["quad", "crazyflie"])
@pytest.mark.parametrize("attitude", list(ATTITUDES_DEG))
def test_every_drop_gives_one_event_of_its_kind_at_its_impact_speed(airframe, attitude):
    """Placed (the documented way to set up a drop) and released: one event each, a crash when
    the impact is faster than 2 m/s or the frame is tilted over 45 degrees, else a touchdown, at
    the speed a fall through that gap with that drag reaches (within 5 %: contacts are found up
    to a step before the touch). A 0.5 or 1 m drop hit in 0.3 or 0.45 s, within half a second of
    leaving the floor it had rested on, and was taken for a bounce of that contact: no event."""
    roll, pitch = ATTITUDES_DEG[attitude]
    upright = math.cos(math.radians(roll)) * math.cos(math.radians(pitch)) >= TILT_UP_Z
    seen = []
    with Simulator(SimConfig(urdf=SHIPPED_VEHICLES[airframe])) as sim:
        for height in HEIGHTS_M if upright else HEIGHTS_M[1:]:
            rotation, gap = _place(sim, height, roll, pitch)
            expected = _reference_impact_mps(sim.vehicle, rotation, gap)
            sim.run_for(4.0)
            events = [(e.kind, e.speed_mps, e.hit) for e in sim.events]
            seen.append((height, round(expected, 2), [(k.value, round(s or 0.0, 2)) for k, s, _ in events]))
            assert len(events) == 1, seen
            (kind, speed, hit), crash = events[0], not upright or expected > CRASH_SPEED_MPS
            assert abs(expected - CRASH_SPEED_MPS) > 0.05 * CRASH_SPEED_MPS, "an ambiguous drop: choose another height"
            assert hit == "floor" and kind is (EventKind.CRASH if crash else EventKind.TOUCHDOWN), seen
            assert speed == pytest.approx(expected, rel=0.05), seen
    assert any(h == 4.0 for h, _, _ in seen)


def test_a_bounce_is_the_same_contact_and_a_harder_hit_soon_after_is_news():
    """The contact monitor on its own, fed a step's contacts by hand: a crash, a rebound that
    comes back slower within its hop (no event), then a hit faster than both soon after (news);
    a vehicle put in the air and falling onto the floor it rested on half a second earlier."""
    floor = (Contact("floor", 1.0),)
    monitor = ContactMonitor(240)
    events = []
    monitor.update(1, (), (0.0, 0.0, 0.0), 1.0)  # placed in the air at rest: the floor is left at 0 m/s
    events += monitor.update(72, floor, (0.0, 0.0, -3.0), 1.0)  # 0.3 s later, a 3 m/s hit
    assert [(e.kind, e.speed_mps) for e in events] == [(EventKind.CRASH, 3.0)]
    monitor.update(73, (), (0.0, 0.0, 0.6), 1.0)  # rebounds at 0.6 m/s
    assert monitor.update(110, floor, (0.0, 0.0, -0.6), 1.0) == []  # lands from the hop: a bounce
    monitor.update(111, (), (0.0, 0.0, 0.2), 1.0)
    late = monitor.update(150, floor, (0.0, 0.0, -3.6), 1.0)  # thrown down harder than it hit
    assert [(e.kind, e.speed_mps) for e in late] == [(EventKind.CRASH, 3.6)]
    monitor.update(151, (), (0.0, 0.0, 0.2), 1.0)  # a hop at 0.2 m/s lasts 0.04 s
    assert monitor.update(151 + 125, floor, (0.0, 0.0, -0.5), 1.0) == []  # within 0.5 s and the hop
    monitor.update(277, (), (0.0, 0.0, 0.2), 1.0)
    assert [e.kind for e in monitor.update(277 + 131, floor, (0.0, 0.0, -0.5), 1.0)] == [EventKind.TOUCHDOWN]


@pytest.mark.parametrize(
    "airframe,height_m,rebound",
    [("crazyflie", 1.0, 0.18), ("crazyflie", 2.0, 0.2), ("quad", 1.0, 0.03), ("quad", 2.0, 0.17)],
)
def test_a_level_drop_rebounds_as_the_parameter_file_says(airframe, height_m, rebound):
    """What each parameter file's [contact] says a level drop does: the Crazyflie's centre of mass
    leaves the floor at about 0.2 of its impact speed (restitution 0.2; with none, on its feet, it
    stopped dead in one step); quadsim_x's (restitution 0) only as much as the contact solver
    pushes it out of the floor."""
    with Simulator(SimConfig(urdf=SHIPPED_VEHICLES[airframe])) as sim:
        _place(sim, height_m, 0.0, 0.0)
        body, cid = sim.physics.body_id, sim.physics.client_id
        vz = []
        for _ in range(int(1.2 * 240)):
            sim.step(1)
            vz.append(pb.getBaseVelocity(body, physicsClientId=cid)[0][2])
    hit = min(range(len(vz)), key=vz.__getitem__)
    assert max(vz[hit : hit + 24]) / -vz[hit] == pytest.approx(rebound, abs=0.02)


@pytest.mark.parametrize("roll_deg", [10.0, 20.0, 30.0, 60.0, 90.0])
def test_the_crazyflie_comes_to_rest_flat_not_on_its_side(roll_deg):
    """Dropped from 2 m at a roll, motors off, it ends on its feet or on its back: on its side it
    touches the floor with two propeller discs only, above its centre of mass, and topples (a
    single collision box stood on its 20 mm edge after a 2 m drop at 20 degrees)."""
    with Simulator(SimConfig(urdf=SHIPPED_VEHICLES["crazyflie"])) as sim:
        _place(sim, 2.0, roll_deg, 0.0)
        state = sim.run_for(4.0)
    x, y, _, _ = state.orientation_xyzw
    assert abs(1.0 - 2.0 * (x * x + y * y)) > 0.95, state.orientation_xyzw
    assert state.position_m[2] < 0.016  # on its feet (0.015) or its back (0.013), not on an edge
    assert max(abs(v) for v in state.linear_velocity_mps) < 1e-3
