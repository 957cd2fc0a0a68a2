"""The range finder and the LiDAR, in-process: their beams against the default world's floor and
red tower, REP 117 out of range, the vehicle's own body unseen, the noise seeded; the geometry of
beams and frames. A recorded run with them: tests/integration/test_ranging.py."""

import math
from dataclasses import replace

import numpy as np
import pytest

from quadsim import SimConfig, Simulator, Twist
from quadsim.core.kinematics import matrix_from_quaternion, rotate
from quadsim.core.types import LidarMode
from quadsim.physics.pybullet_quiet import pb
from quadsim.sensors import ranging
from quadsim.sensors.beams import beam_directions, frame_rotation, scan_ranges
from quadsim.vehicle.params import LidarParams

#: the red tower's face toward the start pose (default world: a 0.8 m box centred at x = 6)
TOWER_FACE_X_M = 5.6
LEVEL = (0.0, 0.0, 0.0, 1.0)


@pytest.fixture(scope="module")
def sim():
    with Simulator(SimConfig(range_finder=True, lidar=LidarMode.PLANAR, sensor_noise=False)) as sim:
        yield sim


def _at(sim, position_m, orientation=LEVEL):
    """The vehicle's state as if it were at `position_m` (the sensors cast from there; the body stays put)."""
    return sim.drone.state._replace(position_m=position_m, orientation_xyzw=orientation)


@pytest.mark.parametrize("height_m", [0.5, 2.0, 7.5])
def test_a_beam_down_over_the_floor_reads_the_height(sim, height_m):
    finder = sim.drone.range_finder
    mount_z = sim.drone.vehicle.range_finder.position_m[2]
    reading = finder.measure(_at(sim, (20.0, -20.0, height_m)))  # clear of every landmark
    assert reading.ranges_m[0] == pytest.approx(height_m + mount_z, abs=1e-5)


def test_a_tilted_vehicle_reads_the_slant_range():
    with Simulator(SimConfig(range_finder=True, sensor_noise=False)) as sim:
        roll = math.radians(20.0)
        q = (math.sin(roll / 2), 0.0, 0.0, math.cos(roll / 2))
        reading = sim.drone.range_finder.measure(_at(sim, (20.0, -20.0, 2.0), q))
        mount = rotate(matrix_from_quaternion(q), sim.drone.vehicle.range_finder.position_m)
        assert reading.ranges_m[0] == pytest.approx((2.0 + mount[2]) / math.cos(roll), abs=1e-5)


def test_out_of_range_is_plus_or_minus_infinity_rep_117(sim):
    params = sim.drone.vehicle.range_finder
    finder = sim.drone.range_finder
    assert finder.measure(_at(sim, (20.0, -20.0, params.max_range_m + 1.0))).ranges_m[0] == math.inf  # no return
    low = params.min_range_m / 2 - params.position_m[2]  # the sensor half its minimum range above the floor
    assert finder.measure(_at(sim, (20.0, -20.0, low))).ranges_m[0] == -math.inf  # too close
    assert list(scan_ranges(np.array([0.01, 1.0, 50.0, math.inf]), 0.5, 0.1, 10.0)) == [
        -math.inf,
        1.5,
        math.inf,
        math.inf,
    ]


def test_the_2d_scan_reads_the_red_tower_ahead_and_its_width(sim):
    lidar = sim.drone.lidar
    scan = lidar.measure(_at(sim, (0.0, 0.0, 1.5)))
    p = sim.drone.vehicle.lidar
    angles = -math.pi + np.arange(p.samples) * 2 * math.pi / p.samples
    ahead = int(np.argmin(np.abs(angles)))
    assert scan.ranges_m[ahead] == pytest.approx(TOWER_FACE_X_M, abs=1e-5)
    # the face is 0.8 m wide: beams within atan(0.4 / 5.6) of ahead meet it at 5.6 / cos(angle), the others miss it
    hits = np.abs(angles) < math.atan2(0.4, TOWER_FACE_X_M) - 0.002
    assert np.allclose(scan.ranges_m[hits], TOWER_FACE_X_M / np.cos(angles[hits]), atol=1e-4)
    beside = (np.abs(angles) > math.atan2(0.4, TOWER_FACE_X_M) + 0.002) & (np.abs(angles) < 0.3)
    assert np.all(scan.ranges_m[beside] > 10.0)


def test_the_vehicles_own_body_is_unseen_where_a_ray_meets_it():
    """The 3D LiDAR's lowest ring passes through the quad's rotor discs: PyBullet's ray meets the
    vehicle's body there, the sensor reads the floor beyond."""
    with Simulator(SimConfig(lidar=LidarMode.SPATIAL, sensor_noise=False)) as sim:
        drone, p = sim.drone, sim.drone.vehicle.lidar
        state = drone.state  # resting on the floor
        scan = drone.lidar.measure(state)
        origin = np.asarray(state.position_m) + np.asarray(p.position_m)
        lowest = drone.lidar.directions[: p.samples]  # the first ring, 15 deg down
        raw = pb.rayTestBatch(
            np.repeat([origin], p.samples, axis=0),
            origin + lowest * p.max_range_m,
            physicsClientId=sim.scene_client.posed(),
        )
        assert sum(r[0] == drone.physics.body_id for r in raw) >= 4  # the plain cast meets its own rotors
        floor = origin[2] / math.sin(p.vertical_fov_rad / 2)  # every beam of the ring meets the floor there
        assert np.allclose(scan.ranges_m[: p.samples], floor, atol=1e-4)


def test_the_noise_is_seeded_and_starts_again_on_reset():
    def readings(seed, count=5):
        with Simulator(SimConfig(range_finder=True, lidar=LidarMode.PLANAR, seed=seed)) as sim:
            state = _at(sim, (20.0, -20.0, 2.0))
            out = [
                (
                    sim.drone.range_finder.measure(state).ranges_m.tobytes(),
                    sim.drone.lidar.measure(state).ranges_m.tobytes(),
                )
                for _ in range(count)
            ]
            sim.reset()
            again = sim.drone.range_finder.measure(state).ranges_m.tobytes()
        return out, again

    first, again = readings(7)
    assert (first, again) == readings(7)
    assert again == first[0][0]  # reset: the stream from its start
    other, _ = readings(8)
    assert all(a[0] != b[0] and a[1] != b[1] for a, b in zip(first, other))
    ranges = np.frombuffer(b"".join(r for r, _ in first), dtype=np.float32)
    assert len(set(ranges.tolist())) == len(ranges)  # each reading has its own draw
    assert np.abs(ranges - (2.0 - 0.045)).max() < 5 * 0.02


def test_beams_and_frames():
    p = replace(LidarParams(), samples=8, channels=3, vertical_fov_rad=math.radians(30))
    planar, spatial = beam_directions(p, LidarMode.PLANAR), beam_directions(p, LidarMode.SPATIAL)
    assert planar.shape == (8, 3) and spatial.shape == (24, 3)
    assert np.allclose(np.linalg.norm(spatial, axis=1), 1.0)
    assert (
        np.allclose(planar[0], (-1, 0, 0)) and np.allclose(planar[4], (1, 0, 0)) and np.allclose(planar[6], (0, 1, 0))
    )
    assert np.allclose(np.degrees(np.arcsin(spatial[::8, 2])), [-15, 0, 15])  # rings lowest first
    for direction in [(0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.6, 0.8)]:
        x_axis = rotate(matrix_from_quaternion(frame_rotation(direction)), (1.0, 0.0, 0.0))
        assert np.allclose(x_axis, direction)  # a Range's beam is its frame's x axis


def test_a_rate_that_does_not_divide_the_physics_rate_is_refused(tmp_path):
    from quadsim.errors import ConfigError
    from quadsim.vehicle.params import DEFAULT_URDF, default_params_path

    params = tmp_path / "quad.params.toml"
    params.write_text(default_params_path(DEFAULT_URDF).read_text() + "\n[range]\nrate_hz = 50\n")
    with pytest.raises(ConfigError, match=r"\[range\] rate_hz = 50 does not divide the physics rate 240"):
        Simulator(SimConfig(urdf=DEFAULT_URDF, vehicle_params=params, range_finder=True))
    assert ranging.RangingSensor is not None


def test_the_api_pages_example():
    """docs/reference/api.md: the newest readings of a climbing vehicle's sensors."""
    with Simulator(SimConfig(range_finder=True, lidar=LidarMode.PLANAR)) as sim:
        sim.send(Twist(linear_z=1.0))
        sim.run_for(2.0)
        height = sim.drone.range_finder.latest.ranges_m[0]
        scan = sim.drone.lidar.latest.ranges_m
        z = sim.state.position_m[2]
        assert height == pytest.approx(z + sim.drone.vehicle.range_finder.position_m[2], abs=0.1)
        assert scan[len(scan) // 2] == pytest.approx(TOWER_FACE_X_M - sim.state.position_m[0], abs=0.1)
        assert sim.drone.lidar.latest.step == sim.step_count  # 2 s: a scan's step


def test_each_airframes_tables_and_bad_ones(tmp_path):
    from quadsim.errors import ConfigError
    from quadsim.vehicle.params import SHIPPED_VEHICLES, RadiationType, default_params_path, load_vehicle

    quad, crazyflie = load_vehicle(SHIPPED_VEHICLES["quad"]), load_vehicle(SHIPPED_VEHICLES["crazyflie"])
    assert quad.range_finder.max_range_m == 12.0 and quad.lidar.channels == 16  # the defaults: no tables
    assert (crazyflie.range_finder.rate_hz, crazyflie.range_finder.max_range_m, crazyflie.lidar.max_range_m) == (
        40,
        4.0,
        8.0,
    )
    assert crazyflie.range_finder.radiation_type is RadiationType.INFRARED
    base = default_params_path(SHIPPED_VEHICLES["quad"]).read_text()
    for table, words in (
        ('[range]\nradiation_type = "sonar"\n', "radiation_type must be"),
        ("[range]\nradiation_type = [1, 2]\n", r"radiation_type must be .* got \[1, 2\]"),
        ("[range]\ndirection = [0, 0, 0]\n", "direction must not be zero"),
        ("[range]\nmin_range_m = 5.0\nmax_range_m = 1.0\n", "min_range_m must be below max_range_m"),
        ("[lidar]\nsamples = 4096\nchannels = 8\n", "over 16384 rays"),
        ("[lidar]\nchannels = 2.5\n", "channels must be a whole number"),
        ("[lidar]\nbeams = 3\n", "beams"),
    ):
        params = tmp_path / "quad.params.toml"
        params.write_text(base + "\n" + table)
        with pytest.raises(ConfigError, match=words):
            load_vehicle(SHIPPED_VEHICLES["quad"], params)
