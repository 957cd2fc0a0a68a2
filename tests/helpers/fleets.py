"""Fleet files as the tests write them: `fleet_toml(vehicle(...), ...)`; the shapes of a run the
tests fly with `run` (alone, a fleet of three), and a vehicle's topic and frame names in each. Not
a test module."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple


def vehicle(
    name: str,
    start: Sequence[float],
    *,
    airframe: str | None = None,
    input: str | None = None,
    cameras: Sequence[str] | None = None,
) -> str:
    """One [[vehicle]] table: its name, airframe, start pose (x, y, z in m, heading in deg), input
    and cameras, in that order; a key left None is not written (the fleet file's default)."""
    lines = ["[[vehicle]]", f"name = {json.dumps(name)}"]
    if airframe is not None:
        lines.append(f"airframe = {json.dumps(airframe)}")
    lines.append(f"start = [{', '.join(repr(float(v)) for v in start)}]")
    if input is not None:
        lines.append(f"input = {json.dumps(input)}")
    if cameras is not None:
        lines.append(f"cameras = {json.dumps(list(cameras))}")
    return "\n".join(lines) + "\n"


def fleet_toml(*vehicles: str) -> str:
    """A fleet file of `vehicles` (vehicle()'s tables), a blank line before each."""
    return "".join(f"\n{table}" for table in vehicles)


#: a fleet of two before the default world's red tower, climbing (script:takeoff): alpha with a 2D
#: LiDAR, a range finder and the front camera's depth colour-mapped, bravo with a 3D LiDAR
SCANS_FLEET = """
[[vehicle]]
name = "alpha"
start = [1.5, -1.0, 0.0, 0.0]
input = "script:takeoff"
range = true
lidar = "2d"
cameras = ["front"]
depth = ["front"]
depth_colormap = ["front"]

[[vehicle]]
name = "bravo"
airframe = "hexa"
start = [1.5, 1.0, 0.0, 0.0]
input = "script:takeoff"
lidar = "3d"
"""


def under(name: str, topic: str) -> str:
    """A vehicle's topic: /NAME/TOPIC in a fleet, /TOPIC for a vehicle flying alone (name "")."""
    return f"/{name}/{topic}" if name else f"/{topic}"


def frame(name: str, frame_id: str) -> str:
    """A vehicle's TF frame: NAME/FRAME in a fleet, FRAME for a vehicle flying alone (name "")."""
    return f"{name}/{frame_id}" if name else frame_id


class Flier(NamedTuple):
    """One vehicle of a run as a test flies it: its name ("" alone), airframe, start pose (x, y,
    z in m, heading in deg) and input."""

    name: str
    airframe: str
    start: tuple[float, float, float, float]
    input: str


#: the shapes of a run the tests fly with `run`, by id: each its vehicles. Alone, the square
#: (`run --script square --cameras none`); a fleet of three (`run --fleet`): the square on a
#: quadrotor, a turn on the spot on a hexacopter, an idle Crazyflie
RUNS: dict[str, tuple[Flier, ...]] = {
    "alone": (Flier("", "quad", (0.0, 0.0, 0.0, 0.0), "script:square"),),
    "fleet of 3": (
        Flier("alpha", "quad", (0.0, 0.0, 0.0, 0.0), "script:square"),
        Flier("bravo", "hexa", (0.0, 4.0, 0.0, 90.0), "script:yaw"),
        Flier("charlie", "crazyflie", (-4.0, 0.0, 0.0, 0.0), "idle"),
    ),
}


#: a fleet of one (`run --fleet`): the square, as the run alone flies it, under a name
FLEET_OF_ONE = (Flier("alpha", "quad", (0.0, 0.0, 0.0, 0.0), "script:square"),)


def run_args(shape: str | tuple[Flier, ...], folder: Path) -> tuple[str, ...]:
    """`run` and its arguments for a run of `shape` (RUNS' id, or the vehicles themselves); a
    fleet's file is written into `folder`."""
    fliers = RUNS[shape] if isinstance(shape, str) else shape
    if fliers[0].name == "":
        return ("run", "--script", fliers[0].input.removeprefix("script:"), "--cameras", "none")
    text = fleet_toml(
        *(
            vehicle(f.name, f.start, airframe=None if f.airframe == "quad" else f.airframe, input=f.input)
            for f in fliers
        )
    )
    (folder / "fleet.toml").write_text(text)
    return ("run", "--fleet", str(folder / "fleet.toml"))


#: a fleet to fly in the window (`fly --fleet`): alpha by the keyboard, with two cameras; bravo on
#: the square, with its front camera; charlie idle
WINDOW_FLEET = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="keyboard", cameras=["front", "floor"]),
    vehicle("bravo", (0.0, -4.0, 0.0, 0.0), input="script:square", cameras=["front"]),
    vehicle("charlie", (-4.0, 0.0, 0.0, 0.0)),
)
