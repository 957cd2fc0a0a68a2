"""A fleet file (TOML): the vehicles of a fleet, each with its airframe, start pose, input and
controller.

    [[vehicle]]
    name = "alpha"                # a ROS name segment, [a-z][a-z0-9_]*: its topics are /alpha/...
    airframe = "quad"             # quad | hexa | crazyflie | a URDF path (relative to this file)
    start = [0.0, 0.0, 0.0, 0.0]  # x, y, z (m), yaw (deg); vehicles start on the floor (z = 0)
    input = "script:square"       # keyboard | gamepad | script:NAME_OR_FILE | ros2 | foxglove | idle
    controller = "cascade"        # cascade (default) | seed
    z_mode = "velocity"           # optional: velocity | height (default: the script's, else velocity)
    gains = { velocity_p_xy_per_s = 2.0 }  # optional: replaces the named gains of its controller
    cameras = ["front", "floor"]  # optional: the onboard cameras it records (default: none)
    depth = ["front"]             # optional: those that also record depth, NAME or NAME:32FC1 (16UC1 mm default)
    segmentation = ["front"]      # optional: those that also record a segmentation image
    depth_colormap = ["front"]    # optional: of the depth ones, those that also record it colour-mapped (JPEG)
    range = true                  # optional: a range finder on /alpha/quad/range (default: --range's)
    lidar = "2d"                  # optional: a LiDAR, 2d (/alpha/quad/scan) or 3d (/alpha/quad/points)

A bad file is refused with one line naming the file, the vehicle and the key. The inputs are
read here (a script's text is loaded, so a missing script is said before anything flies); what
drives each vehicle is made by the app that flies the fleet.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from quadsim.control import ControllerKind, gains_type
from quadsim.control.gains import gain_problem
from quadsim.core.toml_files import read_toml, refuse_unknown_keys
from quadsim.core.types import LidarMode, StartPose, ZMode
from quadsim.drivers import InputDriver
from quadsim.drivers.scripted import Script, load_script
from quadsim.errors import ConfigError, QuadsimError
from quadsim.sensors.camera import default_cameras, with_images
from quadsim.sim.description import MAX_FLEET, VEHICLE_NAME, VEHICLE_NAME_NEEDED
from quadsim.sim.fleet import FleetVehicle
from quadsim.vehicle.params import SHIPPED_VEHICLES

#: the keys a vehicle may have
VEHICLE_KEYS = (
    "name",
    "airframe",
    "start",
    "input",
    "controller",
    "z_mode",
    "gains",
    "cameras",
    "depth",
    "segmentation",
    "depth_colormap",
    "range",
    "lidar",
)
#: the onboard cameras a vehicle may record
CAMERAS = ("front", "floor")
#: the inputs a vehicle may be flown by (script:NAME_OR_FILE besides)
INPUTS = ("keyboard", "gamepad", "ros2", "foxglove", "idle")
#: inputs a person holds: at most one vehicle each
HELD_INPUTS = ("keyboard", "gamepad")
#: how far a start may be from the origin (the default world's floor is 40 m across)
MAX_START_M = 1000.0


@dataclass(frozen=True)
class FleetEntry:
    """One vehicle of a fleet file, checked."""

    name: str
    airframe: str  # as written: a shipped name or a path
    urdf: Path
    start: StartPose
    input: str  # keyboard, gamepad, ros2, foxglove, idle or script
    script: Script | None = None  # the script's text, loaded, for input "script:..."
    controller: ControllerKind = ControllerKind.CASCADE
    z_mode: ZMode | None = None
    gains: dict[str, float] = field(default_factory=dict)
    cameras: tuple[str, ...] = ()  # names of the onboard cameras it records
    depth: tuple[str, ...] = ()  # of those, the ones that record depth: NAME or NAME:ENCODING
    segmentation: tuple[str, ...] = ()  # of those, the ones that record a segmentation image
    depth_colormap: tuple[str, ...] = ()  # of the depth ones, those that record it colour-mapped too
    range_finder: bool | None = None  # None: as the command line says
    lidar: LidarMode | None = None  # None: as the command line says

    @property
    def input_text(self) -> str:
        """What flies it, as a person reads it: "script square", "ros2", "idle", "keyboard"..."""
        return f"script {self.script.name}" if self.script is not None else self.input

    def fleet_vehicle(self, driver: InputDriver | None) -> FleetVehicle:
        """This vehicle of a Fleet, flown by `driver` (its z-mode: its own, else its script's)."""
        return FleetVehicle(
            self.name,
            start=self.start,
            urdf=self.urdf,
            controller=self.controller,
            z_mode=self.z_mode or (self.script.z_mode if self.script is not None else None),
            driver=driver,
            controller_gains=self.gains or None,
            range_finder=self.range_finder,
            lidar=self.lidar,
        )


@dataclass(frozen=True)
class FleetFile:
    path: Path
    vehicles: tuple[FleetEntry, ...]

    def held_by(self, device: str) -> FleetEntry | None:
        """The vehicle flown by `device` (keyboard, gamepad), if any."""
        return next((v for v in self.vehicles if v.input == device), None)

    @property
    def held(self) -> tuple[FleetEntry, ...]:
        """The vehicles a person flies (keyboard, gamepad), in the file's order: one per device."""
        return tuple(v for v in self.vehicles if v.input in HELD_INPUTS)

    @property
    def longest_script_s(self) -> float | None:
        """How long its longest script lasts (None: no vehicle flies one)."""
        return max((v.script.duration_s for v in self.vehicles if v.script is not None), default=None)

    def fleet_vehicles(self, drivers: Mapping[str, InputDriver | None]) -> list[FleetVehicle]:
        """Its vehicles for a Fleet, each flown by its driver in `drivers` (none given: None)."""
        return [v.fleet_vehicle(drivers.get(v.name)) for v in self.vehicles]


def load_fleet_file(path: Path) -> FleetFile:
    """Read and check a fleet file; ConfigError naming the file, vehicle and key."""
    table = read_toml(path, "fleet file")
    refuse_unknown_keys(
        table, ("vehicle",), str(path), top_level=True, otherwise="a fleet file lists [[vehicle]] tables"
    )
    raw = table.get("vehicle")
    if isinstance(raw, dict):  # [vehicle], one table, where [[vehicle]] makes a list of them
        raise ConfigError(f"{path}: [vehicle] is one table: write [[vehicle]] (double brackets) before each vehicle")
    if not isinstance(raw, list) or not raw or not all(isinstance(v, dict) for v in raw):
        raise ConfigError(f"{path}: no [[vehicle]] tables: a fleet file lists at least one vehicle")
    if len(raw) > MAX_FLEET:
        raise ConfigError(f"{path}: {len(raw)} vehicles; at most {MAX_FLEET} fly in one world")
    entries: list[FleetEntry] = []
    for index, data in enumerate(raw):
        entry = _entry(path, index, data)
        if any(e.name == entry.name for e in entries):
            raise ConfigError(
                f"{path}: vehicle {index + 1} ({entry.name!r}): name: another vehicle is named {entry.name!r}; "
                "each name must be unique"
            )
        entries.append(entry)
    for device in HELD_INPUTS:
        holders = [e.name for e in entries if e.input == device]
        if len(holders) > 1:
            raise ConfigError(
                f"{path}: vehicles {holders[0]!r} and {holders[1]!r} both take input = {device!r}: one "
                f"{device} flies one vehicle"
            )
    _check_apart(path, entries)
    return FleetFile(path, tuple(entries))


def _entry(path: Path, index: int, data: dict[str, Any]) -> FleetEntry:
    name = data.get("name")
    if not isinstance(name, str) or not VEHICLE_NAME.fullmatch(name):
        shown = f"{name!r}"[:40] if name is not None else "missing"
        raise ConfigError(f"{path}: vehicle {index + 1}: name {shown}: {VEHICLE_NAME_NEEDED}")
    where = f"{path}: vehicle {name!r}"
    refuse_unknown_keys(data, VEHICLE_KEYS, where)
    input_name, script = _input(path, where, data.get("input", "idle"))
    controller = _choice(where, "controller", data.get("controller", "cascade"), ControllerKind)
    z_mode = _choice(where, "z_mode", data["z_mode"], ZMode) if "z_mode" in data else None
    cameras = _cameras(where, data.get("cameras", []))
    depth, segmentation, depth_colormap = _images(where, data, cameras)
    return FleetEntry(
        name=name,
        airframe=str(data.get("airframe", "quad")),
        urdf=_airframe(path, where, data.get("airframe", "quad")),
        start=_start(where, data.get("start", [0.0, 0.0, 0.0, 0.0])),
        input=input_name,
        script=script,
        controller=controller,
        z_mode=z_mode,
        gains=_gains(where, controller, data.get("gains", {})),
        cameras=cameras,
        depth=depth,
        segmentation=segmentation,
        depth_colormap=depth_colormap,
        range_finder=_flag(where, "range", data.get("range")),
        lidar=_choice(where, "lidar", data["lidar"], LidarMode) if "lidar" in data else None,
    )


def _images(where: str, data: Mapping[str, Any], cameras: tuple[str, ...]) -> tuple[tuple[str, ...], ...]:
    """The vehicle's `depth`, `segmentation` and `depth_colormap` lists, checked against its cameras."""
    lists = []
    for key in ("depth", "segmentation", "depth_colormap"):
        value = data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{where}: {key}: expected a list of camera names, got {value!r:.40}")
        lists.append(tuple(value))
    specs = tuple(spec for spec in default_cameras() if spec.name in cameras)
    with_images(
        specs, lists[0], lists[1], lists[2], (f"{where}: depth", f"{where}: segmentation", f"{where}: depth_colormap")
    )
    return tuple(lists)


def _flag(where: str, key: str, value: Any) -> bool | None:
    if value is not None and not isinstance(value, bool):
        raise ConfigError(f"{where}: {key}: expected true or false, got {value!r:.40}")
    return value


def _cameras(where: str, value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{where}: cameras: expected a list of names ({', '.join(CAMERAS)}), got {value!r:.40}")
    unknown = [v for v in value if v not in CAMERAS]
    if unknown:
        raise ConfigError(f"{where}: cameras: unknown camera {unknown[0]!r:.40}; choose from {', '.join(CAMERAS)}")
    if len(set(value)) != len(value):
        raise ConfigError(f"{where}: cameras: {value} names a camera twice")
    return tuple(value)


def _airframe(path: Path, where: str, value: Any) -> Path:
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{where}: airframe: expected a name or a URDF path, got {value!r:.40}")
    if value in SHIPPED_VEHICLES:
        return SHIPPED_VEHICLES[value]
    if not value.endswith(".urdf"):
        raise ConfigError(
            f"{where}: airframe {value!r:.60}: not a shipped airframe ({', '.join(SHIPPED_VEHICLES)}) nor a .urdf path"
        )
    urdf = (path.parent / value).resolve()
    if not urdf.is_file():
        raise ConfigError(f"{where}: airframe: no URDF at {urdf}")
    return urdf


def _start(where: str, value: Any) -> StartPose:
    if (
        not isinstance(value, list)
        or len(value) != 4
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        raise ConfigError(f"{where}: start: expected [x, y, z, yaw_deg], four numbers, got {value!r:.60}")
    x, y, z, yaw_deg = (float(v) for v in value)
    if z != 0.0:
        raise ConfigError(f"{where}: start: z = {z:g}: vehicles start on the floor (z = 0)")
    if max(abs(x), abs(y)) > MAX_START_M:
        raise ConfigError(f"{where}: start: ({x:g}, {y:g}) is more than {MAX_START_M:g} m from the origin")
    return StartPose(x, y, math.radians(yaw_deg))


def _input(path: Path, where: str, value: Any) -> tuple[str, Script | None]:
    if isinstance(value, str) and value.startswith("script:"):
        name = value.removeprefix("script:")
        local = path.parent / name
        try:
            return "script", load_script(str(local) if local.suffix and local.is_file() else name)
        except QuadsimError as exc:
            raise ConfigError(f"{where}: input {value!r:.60}: {exc}") from None
    if value not in INPUTS:
        raise ConfigError(f"{where}: input {value!r:.60}: expected one of {', '.join(INPUTS)} or script:NAME_OR_FILE")
    return str(value), None


def _choice(where: str, key: str, value: Any, enum_type: Any) -> Any:
    try:
        return enum_type(value)
    except (ValueError, TypeError):
        allowed = ", ".join(str(m.value) for m in enum_type)
        raise ConfigError(f"{where}: {key} {value!r:.40}: expected one of {allowed}") from None


def _gains(where: str, controller: ControllerKind, value: Any) -> dict[str, float]:
    if not isinstance(value, dict):
        raise ConfigError(f"{where}: gains: expected a table of names and numbers, got {value!r:.40}")
    known = {f.name for f in fields(gains_type(controller))}
    for key, number in value.items():
        if key not in known:
            raise ConfigError(f"{where}: gains: {controller.value} has no gain {key!r:.40}")
        problem = gain_problem(gains_type(controller), number)
        if problem is not None:
            raise ConfigError(f"{where}: gains: {key} = {number!r:.40}: {problem}")
    return {key: float(number) for key, number in value.items()}


def _check_apart(path: Path, entries: list[FleetEntry]) -> None:
    """Two vehicles on the same spot, said with the file (the fleet checks their reach when built)."""
    for i, a in enumerate(entries):
        for b in entries[i + 1 :]:
            if math.dist((a.start.x_m, a.start.y_m), (b.start.x_m, b.start.y_m)) < 0.05:
                raise ConfigError(
                    f"{path}: vehicle {b.name!r}: start: ({b.start.x_m:g}, {b.start.y_m:g}) is where {a.name!r} "
                    "starts; give each vehicle its own spot"
                )
