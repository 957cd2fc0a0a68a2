"""Fleet files: what they may say, and one line naming the file, the vehicle and the key when
they say it wrong."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from quadsim.control import ControllerKind
from quadsim.core.types import LidarMode, ZMode
from quadsim.errors import ConfigError
from quadsim.sim.fleet_file import load_fleet_file
from quadsim.vehicle.params import SHIPPED_VEHICLES


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "fleet.toml"
    path.write_text(text)
    return path


def test_a_fleet_file_reads_every_key(tmp_path):
    (tmp_path / "mine.qscript").write_text("z_mode height\n2.0 linear.z=1.0\n1.0 angular.z=0.5\n")
    path = _write(
        tmp_path,
        """
[[vehicle]]
name = "alpha"
airframe = "quad"
start = [1.0, -2.0, 0.0, 90.0]
input = "script:square"

[[vehicle]]
name = "bravo_2"
airframe = "hexa"
start = [0, 4, 0, 0]
input = "script:mine.qscript"
controller = "seed"
z_mode = "velocity"
gains = { yaw_p = 2.5 }
cameras = ["floor", "front"]

[[vehicle]]
name = "charlie"
airframe = "crazyflie"
start = [-4.0, 0.0, 0.0, 0.0]
input = "ros2"
range = true
lidar = "3d"

[[vehicle]]
name = "delta"
start = [4.0, 0.0, 0.0, 0.0]
""",
    )
    fleet = load_fleet_file(path)
    alpha, bravo, charlie, delta = fleet.vehicles
    assert (alpha.name, alpha.urdf, alpha.input, alpha.script.name) == (
        "alpha",
        SHIPPED_VEHICLES["quad"],
        "script",
        "square",
    )
    assert (alpha.start.x_m, alpha.start.y_m) == (1.0, -2.0) and math.isclose(alpha.start.yaw_rad, math.pi / 2)
    assert bravo.urdf == SHIPPED_VEHICLES["hexa"] and bravo.controller is ControllerKind.SEED
    assert bravo.z_mode is ZMode.VELOCITY and bravo.gains == {"yaw_p": 2.5}
    assert bravo.cameras == ("floor", "front") and alpha.cameras == ()
    assert bravo.script.duration_s == 3.0 and str(tmp_path) in bravo.script.name  # beside the fleet file
    assert (charlie.input, charlie.script, charlie.urdf) == ("ros2", None, SHIPPED_VEHICLES["crazyflie"])
    assert (delta.input, delta.airframe, delta.controller) == ("idle", "quad", ControllerKind.CASCADE)
    assert fleet.held_by("keyboard") is None
    assert (charlie.range_finder, charlie.lidar, delta.range_finder, delta.lidar) == (
        True,
        LidarMode.SPATIAL,
        None,
        None,
    )
    made = charlie.fleet_vehicle(None)
    assert (made.range_finder, made.lidar) == (True, LidarMode.SPATIAL)


VEHICLE = '[[vehicle]]\nname = "{name}"\nstart = [{x}, 0, 0, 0]\n'


@pytest.mark.parametrize(
    "body, words",
    [
        (
            VEHICLE.format(name="alpha", x=0) + VEHICLE.format(name="alpha", x=3),
            ["vehicle 2 ('alpha'): name", "another vehicle is named 'alpha'"],
        ),
        (
            VEHICLE.format(name="alpha", x=0) + VEHICLE.format(name="bravo", x=0),
            ["vehicle 'bravo': start", "where 'alpha' starts"],
        ),
        (VEHICLE.format(name="alpha", x=0).replace("[[vehicle]]", "[vehicle]"), ["write [[vehicle]]"]),
        (
            VEHICLE.format(name="alpha", x=0) + "gains = { velocity_p_xy_per_s = -2.0 }\n",
            ["vehicle 'alpha'", "gains: velocity_p_xy_per_s = -2.0", "expected a number >= 0"],
        ),
        (
            VEHICLE.format(name="alpha", x=0)
            + 'input = "keyboard"\n'
            + VEHICLE.format(name="bravo", x=3)
            + 'input = "keyboard"\n',
            ["'alpha' and 'bravo'", "input = 'keyboard'"],
        ),
        (VEHICLE.format(name="alpha", x=0) + 'airframe = "blimp"\n', ["vehicle 'alpha'", "airframe 'blimp'", "quad"]),
        (VEHICLE.format(name="alpha", x=0) + 'airframe = "gone.urdf"\n', ["vehicle 'alpha'", "airframe", "no URDF"]),
        (VEHICLE.format(name="alpha", x=0) + 'colour = "red"\n', ["vehicle 'alpha'", "unknown key 'colour'"]),
        (VEHICLE.format(name="Alpha", x=0), ["vehicle 1", "name 'Alpha'", "ROS name segment"]),
        ("[[vehicle]]\nstart = [0, 0, 0, 0]\n", ["vehicle 1", "name missing"]),
        (VEHICLE.format(name="alpha", x=0) + 'input = "joystick"\n', ["vehicle 'alpha'", "input 'joystick'"]),
        (VEHICLE.format(name="alpha", x=0) + 'input = "script:nope"\n', ["vehicle 'alpha'", "unknown scenario 'nope'"]),
        ('[[vehicle]]\nname = "alpha"\nstart = [0, 0, 2, 0]\n', ["vehicle 'alpha'", "start", "on the floor"]),
        ('[[vehicle]]\nname = "alpha"\nstart = [0, 0]\n', ["vehicle 'alpha'", "start", "four numbers"]),
        ('[[vehicle]]\nname = "alpha"\nstart = [1e9, 0, 0, 0]\n', ["vehicle 'alpha'", "start", "from the origin"]),
        (VEHICLE.format(name="alpha", x=0) + 'controller = "pid"\n', ["vehicle 'alpha'", "controller 'pid'"]),
        (VEHICLE.format(name="alpha", x=0) + "gains = { kp_magic = 1 }\n", ["vehicle 'alpha'", "no gain 'kp_magic'"]),
        (VEHICLE.format(name="alpha", x=0) + 'z_mode = "up"\n', ["vehicle 'alpha'", "z_mode 'up'"]),
        ("seed = 3\n" + VEHICLE.format(name="alpha", x=0), ["unknown key 'seed'"]),
        (VEHICLE.format(name="alpha", x=0) + 'cameras = ["rear"]\n', ["vehicle 'alpha'", "unknown camera 'rear'"]),
        (VEHICLE.format(name="alpha", x=0) + 'cameras = "front"\n', ["vehicle 'alpha'", "cameras: expected a list"]),
        (
            VEHICLE.format(name="alpha", x=0) + 'cameras = ["front"]\ndepth = ["floor"]\n',
            ["vehicle 'alpha'", "depth: 'floor' is not a camera of this run (front)"],
        ),
        (
            VEHICLE.format(name="alpha", x=0) + 'cameras = ["front"]\ndepth = ["front:8UC1"]\n',
            ["vehicle 'alpha'", "depth encoding '8UC1'"],
        ),
        (VEHICLE.format(name="alpha", x=0) + 'segmentation = "front"\n', ["vehicle 'alpha'", "segmentation: expected"]),
        (
            VEHICLE.format(name="alpha", x=0) + 'cameras = ["front"]\ndepth_colormap = ["front"]\n',
            ["vehicle 'alpha'", "depth_colormap: front has no depth image to colour-map (name it in", ": depth too)"],
        ),
        ("", ["no [[vehicle]] tables"]),
        (VEHICLE.format(name="alpha", x=0) + 'lidar = "4d"\n', ["vehicle 'alpha'", "lidar '4d'", "2d, 3d"]),
        (VEHICLE.format(name="alpha", x=0) + "range = 1\n", ["vehicle 'alpha'", "range: expected true or false"]),
    ],
)
def test_a_bad_fleet_file_is_one_line_naming_the_file_vehicle_and_key(tmp_path, body, words):
    path = _write(tmp_path, body)
    with pytest.raises(ConfigError) as info:
        load_fleet_file(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message
    for word in words:
        assert word in message, message
