"""Contact: the collision shapes (drops land upright; walls keep the rotors and the front camera
out), crashes as events with their impact speed and what was hit, in the recording, the window
and the API, and --reset-on-crash; vehicles of a fleet that fly into each other, and the contacts
a fleet asks PyBullet for once a step."""

import math

import numpy as np
import pybullet as pb
import pygame
import pytest

from quadsim import Fleet, FleetVehicle, SimConfig, Simulator, StartPose, Twist, ZMode
from quadsim.apps.flight_quality import DROP_HEIGHTS_M, DROP_ROLLS_DEG, drop_grid
from quadsim.apps.window.teleop import TeleopOptions
from quadsim.sensors.camera import RendererKind, default_cameras
from quadsim.sensors.rendering import decode_jpeg
from quadsim.sensors.rig import CameraRig
from quadsim.sim.flight_events import EventKind
from tests.helpers import ROOT
from tests.integration.test_teleop import key, make_app, run_with

HEXA = ROOT / "quadsim" / "assets" / "urdf" / "quadsim_hexa.urdf"
#: the red tower's faces (world x, y ranges) in the default world: 0.8 m square, centred at x = 6
TOWER_X, TOWER_Y = (5.6, 6.4), (-0.4, 0.4)


@pytest.mark.parametrize("urdf", [None, HEXA], ids=["quad", "hexa"])
def test_motors_off_drops_land_upright(urdf):
    grid = drop_grid(SimConfig(urdf=urdf))
    assert set(grid) == {(h, r) for h in DROP_HEIGHTS_M for r in DROP_ROLLS_DEG}
    flipped = sorted(k for k, upright in grid.items() if not upright)
    assert not flipped, f"landed upside down or on a side from (height m, roll deg): {flipped}"


def _inside_tower(x: float, y: float) -> float:
    """How far (m) a point is inside the tower's footprint (negative: outside)."""
    return min(x - TOWER_X[0], TOWER_X[1] - x, y - TOWER_Y[0], TOWER_Y[1] - y)


@pytest.fixture(scope="module")
def tower_push():
    """Climb to 1.5 m and fly into the red tower at 2 m/s, then keep pushing for 3 s. Keeps the
    deepest any rotor disc's rim got, and the front camera while it looks at the wall (within
    45 degrees of it: pitched over further, after the crash, it looks down at the floor and the
    wall is not in its view), and the pose with the camera closest while aloft and looking at
    the wall (pressed against it; later the vehicle slides down it)."""
    deepest = {"rotor": -math.inf, "camera": -math.inf}
    closest = None
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY)) as sim:
        sim.send(Twist(linear_z=1.0))
        sim.run_for(1.5)
        sim.send(Twist(linear_x=2.0))
        # the links where the URDF puts them on base_link (the flight body is one merged body)
        frames = {f.link_name: f for f in sim.vehicle.link_frames}
        rotor_links = [frames[r.link_name] for r in sim.vehicle.rotors]
        camera_link = frames["front_camera_link"]
        for _ in range(6 * 60):
            sim.run_for(1 / 60)
            base = sim.state
            r = np.array(pb.getMatrixFromQuaternion(base.orientation_xyzw)).reshape(3, 3)
            for link in [*rotor_links, camera_link]:
                position = np.array(base.position_m) + r @ np.array(link.position_m)
                m = r @ np.array(link.rotation)
                if link == camera_link:
                    if m[0, 0] < math.cos(math.radians(45.0)):  # not looking at the wall (+x)
                        continue
                    depth = _inside_tower(*position[:2])
                    deepest["camera"] = max(deepest["camera"], depth)
                    s = sim.state
                    if s.position_m[2] > 1.0 and (closest is None or depth > closest[0]):  # against it, aloft
                        closest = (depth, s.position_m, s.orientation_xyzw)
                    continue
                for a in np.linspace(0, 2 * math.pi, 24, endpoint=False):  # the disc's rim, r = 6.5 cm
                    rim = np.array(position) + 0.065 * (m[:, 0] * math.cos(a) + m[:, 1] * math.sin(a))
                    if rim[2] < 3.0:
                        deepest["rotor"] = max(deepest["rotor"], _inside_tower(rim[0], rim[1]))
        events = list(sim.events)
        vehicle, world = sim.vehicle, sim.world
    return deepest, closest, events, vehicle, world


def test_rotors_and_camera_stay_out_of_a_wall(tower_push):
    deepest, _, _, _, _ = tower_push
    assert deepest["rotor"] < 0.0, f"a rotor disc went {deepest['rotor'] * 100:.1f} cm into the tower"
    assert deepest["camera"] < -0.05, f"the front camera came within {-deepest['camera'] * 100:.1f} cm of the tower"


def test_hitting_the_tower_is_a_crash_with_its_speed(tower_push):
    _, _, events, _, _ = tower_push
    crashes = [e for e in events if e.kind is EventKind.CRASH]
    assert crashes, [e.value for e in events]
    first = crashes[0]
    assert first.hit == "red_tower" and 1.5 < first.speed_mps < 2.5
    assert "red_tower" in first.value and "side" in first.value
    assert events[0].kind is EventKind.TAKEOFF
    assert not any(e.kind is EventKind.TOUCHDOWN and e.hit == "red_tower" for e in events)


# --- vehicles that fly into each other ----------------------------------------------------------


def _ramming_pair(reset_on_crash: bool = False) -> Fleet:
    """alpha and bravo 3 m apart, climbed to 1.5 m; alpha then flies at bravo at 3 m/s."""
    fleet = Fleet(
        [FleetVehicle("alpha"), FleetVehicle("bravo", start=StartPose(3.0, 0.0))],
        SimConfig(z_mode=ZMode.VELOCITY),
        reset_on_crash=reset_on_crash,
    )
    for name in fleet:
        fleet[name].send(Twist(linear_z=1.0))
    fleet.run_for(1.5)
    for name in fleet:
        fleet[name].send(Twist())
    fleet["alpha"].send(Twist(linear_x=3.0))
    return fleet


def test_vehicles_that_fly_into_each_other_both_crash_naming_the_other():
    with _ramming_pair() as fleet:
        fleet.run_for(2.0)
        crashes = {n: [e for e in fleet[n].events if e.kind is EventKind.CRASH] for n in fleet}
    assert crashes["alpha"] and crashes["alpha"][0].hit == "bravo", crashes
    assert crashes["bravo"] and crashes["bravo"][0].hit == "alpha", crashes
    assert crashes["alpha"][0].step == crashes["bravo"][0].step
    assert "hit bravo" in crashes["alpha"][0].value and "hit alpha" in crashes["bravo"][0].value


def test_with_reset_on_crash_vehicles_that_collide_both_crash_and_both_go_back():
    """The first vehicle's reset moves it away within the step: the second still has the
    step's contact with it (it was left uncrashed and hit again)."""
    with _ramming_pair(reset_on_crash=True) as fleet:
        fleet.run_for(2.0)
        kinds = {
            n: [(e.kind, e.step) for e in fleet[n].events if e.kind in (EventKind.CRASH, EventKind.RESET)]
            for n in fleet
        }
    crash = kinds["alpha"][0][1]
    assert kinds["alpha"][:2] == [(EventKind.CRASH, crash), (EventKind.RESET, crash)], kinds
    assert kinds["bravo"][:2] == [(EventKind.CRASH, crash), (EventKind.RESET, crash)], kinds


def test_the_contacts_asked_once_a_step_for_the_world_are_each_vehicles_own():
    """A fleet asks PyBullet for the world's contacts once a step and hands each vehicle its
    own: the same points, with the normal turned to point at it, as asking for each vehicle."""
    seen = {"floor": 0, "other vehicle": 0}
    with _ramming_pair() as fleet:  # into bravo, then both down to the floor
        bodies = {fleet[n].physics.body_id: n for n in fleet}
        cid = fleet.client.cid
        for _ in range(3 * 240):
            fleet.step()
            for body in bodies:
                asked = [(p[2], p[7][2]) for p in pb.getContactPoints(body, physicsClientId=cid)]
                assert list(fleet.client.touching(body)) == asked
                for other, _ in asked:
                    seen["other vehicle" if other in bodies else "floor"] += 1
    assert seen["floor"] > 0 and seen["other vehicle"] > 0, seen  # both kinds were compared


def _red_fraction(rgb: np.ndarray) -> float:
    region = rgb.astype(int)
    return float(((region[..., 0] > 120) & (region[..., 1] < 70) & (region[..., 2] < 70)).mean())


def test_front_camera_pressed_against_a_wall_shows_the_wall(tower_push):
    _, (depth, position, orientation), _, vehicle, world = tower_push
    spec = default_cameras()[0]
    rig = CameraRig.standalone(vehicle, world, (spec,), RendererKind.TINY)
    try:
        (frame,) = rig.render(("front",), 0, position, orientation)
        pressed = _red_fraction(decode_jpeg(frame.jpeg))
        # the same pose 10 cm further in (the lens 4 cm behind the wall's face, closer than
        # the near plane): the camera sees through the wall; the check must be able to fail
        through = (position[0] - depth + 0.04, position[1], position[2])
        (frame,) = rig.render(("front",), 0, through, orientation)
        seen_through = _red_fraction(decode_jpeg(frame.jpeg))
    finally:
        rig.close()
    assert pressed > 0.9, f"only {pressed:.0%} of the picture is the wall it is pressed against"
    assert seen_through < 0.5


class _EventSink:
    def __init__(self):
        self.events = []

    def on_command(self, step, twist):
        pass

    def on_state(self, state):
        pass

    def on_event(self, step, kind, value):
        self.events.append((step, kind, value))


class _PlainSink:  # no on_event: still a sink
    def on_command(self, step, twist):
        pass

    def on_state(self, state):
        pass


def test_sinks_and_callbacks_get_the_events_a_gym_env_would_end_on():
    sink, seen = _EventSink(), []
    with Simulator(SimConfig(z_mode=ZMode.VELOCITY, start=StartPose(x_m=4.0))) as sim:
        sim.add_sink(sink)
        sim.add_sink(_PlainSink())
        sim.add_event_callback(seen.append)
        sim.send(Twist(linear_z=1.0))
        sim.run_for(1.5)
        sim.send(Twist(linear_x=2.0))
        while not any(e.kind is EventKind.CRASH for e in seen) and sim.time_s < 5.0:
            sim.run_for(0.1)
        assert seen == sim.events and seen[-1].kind is EventKind.CRASH
        assert [(e.step, e.kind.value, e.value) for e in seen] == sink.events
        assert not sim.reset_on_crash and sim.state.position_m[0] > 5.0  # no reset unless asked
        sim.reset()
        assert sim.events == []


def test_the_window_shows_a_crash_and_resets(tmp_path):
    app = make_app(
        tmp_path,
        options=TeleopOptions(input="keyboard", reset_on_crash=True),
        config=SimConfig(start=StartPose(x_m=4.0)),
    )
    try:
        shown = []
        run_with(app, 30, {0: [lambda: key(pygame.K_w)], 25: [lambda: key(pygame.K_w, False)]})
        assert app._model().phase == "flying"
        for _ in range(120):
            run_with(app, 1, {0: [lambda: key(pygame.K_UP)]} if not shown else {})
            model = app._model()
            if model.flight_alert:
                shown.append(model.flight_event)
                break
        assert shown and shown[0].startswith("CRASH: hit red_tower"), shown
        assert shown[0].endswith("; reset: back at the start after a crash")
        run_with(app, 2)
        assert app._model().phase == "landed" and abs(app.sim.state.position_m[0] - 4.0) < 0.05
    finally:
        app.close()


@pytest.mark.parametrize("urdf", [None, HEXA], ids=["quad", "hexa"])
def test_the_contact_query_is_skipped_only_where_pybullet_finds_no_contact(urdf, monkeypatch):
    """While the vehicle is clear of all the scenery, the loop does not ask PyBullet for its
    contacts, and quadsim steps it itself. Checked against PyBullet itself every step of a
    take-off, a square, a crash into the tower at 4 m/s, a fall from 4 m and a hard landing:
    wherever the query is skipped, PyBullet, with the vehicle posed where it is, finds no point
    of it within its contact distance of any body; and both cases happen. (Flown one step at a
    time: the loop's compiled quiet steps check the same clearance in their own code, and fly the
    same flight to the bit: tests/integration/test_clear_flight.py.)"""
    from quadsim.physics.pybullet_world import PhysicsWorld
    from quadsim.sim.loop import SimLoop

    monkeypatch.setattr(SimLoop, "_quiet_steps", lambda loop, steps: 0)

    clear_of_scenery = PhysicsWorld._clear_of_scenery
    seen = {"skipped": 0, "asked": 0, "wrongly_skipped": 0}

    def checked(self):
        clear = clear_of_scenery(self)
        cid = self.client.posed()
        points = [
            p
            for other in self.landmark_ids.values()
            for p in pb.getClosestPoints(self.body_id, other, 0.02, physicsClientId=cid)
        ]
        seen["skipped" if clear else "asked"] += 1
        seen["wrongly_skipped"] += bool(clear and points)
        return clear

    monkeypatch.setattr(PhysicsWorld, "_clear_of_scenery", checked)
    with Simulator(SimConfig(urdf=urdf, z_mode=ZMode.VELOCITY)) as sim:
        sim.send(Twist(linear_z=1.0))
        sim.run_for(1.5)
        for twist in (Twist(linear_x=1.0), Twist(linear_y=1.0), Twist(linear_x=-1.0), Twist(linear_y=-1.0)):
            sim.send(twist)
            sim.run_for(1.5)
        sim.send(Twist(linear_x=4.0))
        sim.run_for(4.0)
        crashes = [e for e in sim.events if e.kind is EventKind.CRASH]
        sim.physics.place((0.0, 2.0, 4.0))
        sim.send(Twist())
        sim.run_for(3.0)
        sim.send(Twist(linear_z=-3.0))
        sim.run_for(3.0)
        landed = sim.state.position_m[2]
    assert seen["wrongly_skipped"] == 0, seen
    assert seen["skipped"] > 1000 and seen["asked"] > 100, seen
    assert crashes and crashes[0].hit == "red_tower", [e.value for e in crashes]
    assert landed < 0.2
