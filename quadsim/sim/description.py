"""The run's typed description: everything a run was made with, written to a recording's
metadata and read back from it with validation.

One description serves every output (recorder, live bridges, the window) and every reader
(`info`, `replay`, `replay --resim`, `check`): nobody digs through nested dicts. A value that is
missing, of the wrong type or absurd in a recording is refused with a `QuadsimError` naming the
field (`parameters.config.rates.physics_hz: expected a positive whole number, got 'abc'`).

The JSON layout (`to_parameters`) is the one recordings have always carried, plus
`schema_version`; files without it are version 1. Version 2 adds the run's wind, sensor noise
and seed (`config.wind`, `config.sensor_noise`, `config.seed`); a version 1 file had no wind and
no sensor noise. Version 3 is a fleet's (`fleet`: each vehicle's name and own description; the
top-level `config` is the fleet's, with the run's seed and the first vehicle's z-mode, and
`vehicle`, `controller` and `driver` are the first vehicle's); a run of one vehicle is still
written as version 2. A description reads back equal to itself.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from quadsim.control import ControllerKind
from quadsim.core.parts import IMPORT_PATH, import_path
from quadsim.core.types import LidarMode, StartPose, Stepping, ZMode
from quadsim.errors import QuadsimError
from quadsim.physics.wind import Turbulence, WindSettings
from quadsim.physics.world_spec import WorldSpec
from quadsim.sensors.camera import CameraSpec
from quadsim.sim.config import MAX_SEED, Rates, SimConfig
from quadsim.vehicle.params import VehicleParams

#: the layout version of the parameters this code writes for one vehicle, and for a fleet
SCHEMA_VERSION = 2
FLEET_SCHEMA_VERSION = 3


class DescriptionError(QuadsimError):
    """A recording's parameters are missing, malformed or from an unknown layout."""


@dataclass(frozen=True)
class VehicleDescription:
    """The vehicle a run flew: its files (attached to the recording) and headline figures."""

    name: str
    urdf_file: str  # file name of the URDF, as attached to the recording
    params_file: str  # file name of the parameter file, as attached
    mass_kg: float
    rotor_count: int
    details: dict[str, Any] = field(default_factory=dict, compare=False)  # VehicleParams.to_dict(), for people


@dataclass(frozen=True)
class ControllerDescription:
    """The controller a vehicle flew: a shipped kind with its gains, or a user's own (its class's
    import path, module:Class, `kind` None)."""

    kind: ControllerKind | None
    gains: dict[str, float]
    details: dict[str, Any] = field(default_factory=dict, compare=False)  # the controller's describe()
    import_path: str = ""

    @property
    def name(self) -> str:
        """What flew, as a person reads it: "cascade", or "own (mypackage.control:MyController)"."""
        return self.kind.value if self.kind is not None else f"own ({self.import_path})"


@dataclass(frozen=True)
class WindModelDescription:
    """A wind model of the user's own a run flew in: its class (module:Class) and its settings."""

    import_path: str
    details: dict[str, Any] = field(default_factory=dict, compare=False)  # its describe(), if it has one

    @classmethod
    def of(cls, model: object) -> WindModelDescription:
        describe = getattr(model, "describe", None)
        return cls(import_path(model), dict(describe()) if callable(describe) else {})


@dataclass(frozen=True)
class RunDescription:
    """Everything a run was made with. Built by `Simulator.description()`, completed by the
    outputs (`with_outputs`), and read back from recordings by `from_parameters`."""

    config: SimConfig
    vehicle: VehicleDescription
    controller: ControllerDescription
    driver: dict[str, Any]  # the driver's definition (a script's text, a replay's source...)
    cameras: tuple[CameraSpec, ...] = ()
    start_step: int = 0  # the loop's step when recording began (0: from the start of the run)
    extra: dict[str, Any] = field(default_factory=dict)  # what the app adds: command, script, duration
    schema_version: int = SCHEMA_VERSION
    #: the loaded models, for outputs of a live run (cameras render them, the recorder attaches
    #: their files); None in a description read back from a recording
    vehicle_model: VehicleParams | None = field(default=None, compare=False, repr=False)
    world_model: WorldSpec | None = field(default=None, compare=False, repr=False)
    #: a fleet's vehicles: (name, that vehicle's own description), in the fleet's order; empty
    #: for a run of one vehicle
    fleet: tuple[tuple[str, RunDescription], ...] = ()
    #: the run's wind of the user's own (None: the config's wind)
    wind_model: WindModelDescription | None = None

    @property
    def z_mode(self) -> ZMode:
        """How linear.z was read when the run started."""
        return self.config.z_mode or ZMode.VELOCITY

    @property
    def driver_name(self) -> str:
        return str(self.driver.get("name", "?"))

    def with_outputs(
        self, cameras: tuple[CameraSpec, ...], start_step: int, extra: dict[str, Any] | None = None
    ) -> RunDescription:
        """The same run, with what its outputs add."""
        return replace(self, cameras=cameras, start_step=start_step, extra={**self.extra, **(extra or {})})

    # --- writing ----------------------------------------------------------------------------

    def to_parameters(self) -> dict[str, Any]:
        """Plain JSON-able data, the layout recordings carry in their `quadsim` metadata."""
        params = {
            **self.extra,
            "schema_version": FLEET_SCHEMA_VERSION if self.fleet else self.schema_version,
            **self._own_parameters(),
            "start_step": self.start_step,
        }
        if self.fleet:
            params["fleet"] = [{"name": name, **d._own_parameters()} for name, d in self.fleet]
        if self.wind_model is not None:
            params["wind_model"] = {"import_path": self.wind_model.import_path, "details": self.wind_model.details}
        return params

    def _own_parameters(self) -> dict[str, Any]:
        """One vehicle's part: its config, vehicle, controller, driver and cameras."""
        vehicle = {
            **self.vehicle.details,
            "name": self.vehicle.name,
            "urdf": self.vehicle.urdf_file,
            "params": self.vehicle.params_file,
            "mass_kg": self.vehicle.mass_kg,
        }
        c = self.controller
        own = {"name": "own", "import_path": c.import_path}  # its describe() is its own business
        controller = {**c.details, **({"name": c.kind.value, "gains": dict(c.gains)} if c.kind is not None else own)}
        return {
            "config": self.config.to_dict(),
            "vehicle": vehicle,
            "controller": controller,
            "driver": dict(self.driver),
            "cameras": [c.to_dict() for c in self.cameras],
        }

    # --- reading ----------------------------------------------------------------------------

    @classmethod
    def from_parameters(cls, params: Any) -> RunDescription:
        """Validate and type a recording's parameters; raises DescriptionError naming the field."""
        p = _Fields(params, "parameters")
        version = p.integer("schema_version", default=1, low=1)
        if version > FLEET_SCHEMA_VERSION:
            raise DescriptionError(
                f"parameters.schema_version {version}: written by a newer quadsim (this one reads up to "
                f"{FLEET_SCHEMA_VERSION}); upgrade quadsim to read it"
            )
        start_step = p.integer("start_step", default=0, low=0)
        own = cls._own_from(p, version, start_step)
        fleet = _fleet(p, version, start_step) if version >= FLEET_SCHEMA_VERSION else ()
        known = {"schema_version", "start_step", "fleet", "wind_model", *own._own_parameters()}  # the rest is extra
        return replace(
            own,
            extra={k: v for k, v in p.data.items() if k not in known},
            schema_version=version,
            fleet=fleet,
            wind_model=_wind_model(p),
        )

    @classmethod
    def _own_from(cls, p: _Fields, version: int, start_step: int) -> RunDescription:
        """One vehicle's part (config, vehicle, controller, driver, cameras) from `p`."""
        config = _config(p.section("config"), version)
        vehicle = _vehicle(p.section("vehicle"))
        c = p.section("controller")
        if "import_path" in c.data:  # a controller of the user's own: its class, made again by a re-flight
            controller = ControllerDescription(None, {}, dict(c.data), c.import_path())
        else:
            gains_f = c.section("gains", optional=True)
            gains = {key: gains_f.number(key) for key in gains_f.data}
            controller = ControllerDescription(c.choice("name", ControllerKind), gains, dict(c.data))
        driver = p.section("driver", optional=True)
        cameras = p.raw("cameras", default=[])
        if not isinstance(cameras, list):
            raise DescriptionError(f"{p.where}.cameras: expected a list, got {type(cameras).__name__}")
        specs = tuple(_camera(cam, f"{p.where}.cameras[{i}]") for i, cam in enumerate(cameras))
        return cls(
            config=config,
            vehicle=vehicle,
            controller=controller,
            driver=dict(driver.data),
            cameras=specs,
            start_step=start_step,
            schema_version=version,
        )


#: a vehicle's name in a fleet is a ROS name segment: it goes in front of its topics (/alpha/quad/odom)
VEHICLE_NAME = re.compile(r"[a-z][a-z0-9_]{0,62}")
#: what a fleet file or a Fleet says of a name that is not one
VEHICLE_NAME_NEEDED = (
    "a ROS name segment is needed (a lowercase letter, then lowercase letters, digits or _; at most 63)"
)
#: at most this many vehicles fly in one world (and are read from a recording's fleet)
MAX_FLEET = 100


def _fleet(p: _Fields, version: int, start_step: int) -> tuple[tuple[str, RunDescription], ...]:
    """parameters.fleet: each vehicle's name and own description."""
    entries = p.raw("fleet")
    if not isinstance(entries, list) or not 1 <= len(entries) <= MAX_FLEET:
        raise DescriptionError(f"parameters.fleet: expected a list of 1 to {MAX_FLEET} vehicles, got {entries!r:.60}")
    out: list[tuple[str, RunDescription]] = []
    for i, entry in enumerate(entries):
        f = _Fields(entry, f"parameters.fleet[{i}]")
        name = f.text("name")
        if not VEHICLE_NAME.fullmatch(name) or name in dict(out):
            raise DescriptionError(f"{f.where}.name: {name!r:.60} is not a unique ROS name segment")
        out.append((name, RunDescription._own_from(f, version, start_step)))
    return tuple(out)


def _wind_model(p: _Fields) -> WindModelDescription | None:
    """parameters.wind_model: a wind of the user's own, named by its class (module:Class)."""
    if p.raw("wind_model") is None:
        return None
    w = p.section("wind_model")
    return WindModelDescription(w.import_path(), dict(w.section("details", optional=True).data))


# --- validation helpers ---------------------------------------------------------------------


def _config(cfg: _Fields, version: int) -> SimConfig:
    """parameters.config: the SimConfig the run was flown with (sensor noise on from schema 2)."""
    rates_f = cfg.section("rates")
    rates_kw = {f.name: rates_f.integer(f.name, low=1, high=1_000_000) for f in fields(Rates)}
    start_f = cfg.section("start", optional=True)
    wind_f = cfg.section("wind", optional=True)
    turbulence = wind_f.raw("turbulence")
    wind = _build(
        WindSettings,
        {
            "speed_mps": wind_f.number("speed_mps", default=0.0, low=0.0, high=1e3),
            "from_deg": wind_f.number("from_deg", default=0.0),
            "turbulence": None if turbulence is None else wind_f.choice("turbulence", Turbulence),
        },
        wind_f.where,
    )
    noise = cfg.raw("sensor_noise", default=version >= 2)
    ranging = cfg.raw("range_finder", default=False)  # a recording made before the range finder had none
    for key, value in (("sensor_noise", noise), ("range_finder", ranging)):
        if not isinstance(value, bool):
            raise DescriptionError(f"{cfg.where}.{key}: expected true or false, got {value!r:.40}")
    return SimConfig(
        urdf=cfg.path("urdf"),
        vehicle_params=cfg.path("vehicle_params"),
        world=cfg.path("world"),
        controller=cfg.choice("controller", ControllerKind),
        z_mode=cfg.choice("z_mode", ZMode),
        rates=_build(Rates, rates_kw, rates_f.where),
        command_timeout_s=cfg.number("command_timeout_s", optional=True, low=1e-6, high=1e9),
        start=StartPose(
            start_f.number("x_m", default=0.0),
            start_f.number("y_m", default=0.0),
            start_f.number("yaw_rad", default=0.0),
        ),
        wind=wind,
        sensor_noise=noise,
        seed=cfg.integer("seed", default=0, low=0, high=MAX_SEED),
        # a recording made before quadsim had its own step was flown by PyBullet's alone
        physics=cfg.choice("physics", Stepping) if cfg.raw("physics") is not None else Stepping.PYBULLET,
        range_finder=ranging,
        lidar=cfg.choice("lidar", LidarMode) if cfg.raw("lidar") is not None else None,
    )


def _vehicle(v: _Fields) -> VehicleDescription:
    """parameters.vehicle: the airframe, named by its files."""
    rotors = v.raw("rotors", default=[])
    return VehicleDescription(
        name=v.text("name"),
        urdf_file=Path(v.text("urdf")).name,
        params_file=Path(v.text("params")).name,
        mass_kg=v.number("mass_kg", low=1e-6, high=1e6),
        rotor_count=len(rotors) if isinstance(rotors, list) else 0,
        details=dict(v.data),
    )


def _build(cls: Any, kwargs: dict[str, Any], where: str) -> Any:
    try:
        return cls(**kwargs)
    except QuadsimError as exc:
        raise DescriptionError(f"{where}: {exc}") from None


def _camera(data: Any, where: str) -> CameraSpec:
    f = _Fields(data, where)
    readers: dict[str, Callable[[str], Any]] = {"int": f.integer, "float": f.number, "bool": f.flag}  # else text
    kwargs = {s.name: readers.get(str(s.type), f.text)(s.name) for s in fields(CameraSpec) if s.name in f.data}
    for required in ("name", "link_name"):
        if required not in kwargs:
            raise DescriptionError(f"{where}.{required}: missing")
    spec: CameraSpec = _build(CameraSpec, kwargs, where)
    return spec


class _Fields:
    """Typed access to one JSON object, with errors that name the field's path."""

    def __init__(self, data: Any, where: str) -> None:
        if not isinstance(data, dict):
            raise DescriptionError(f"{where}: expected an object, got {type(data).__name__}")
        self.data: dict[str, Any] = data
        self.where = where

    def _missing(self, key: str) -> DescriptionError:
        return DescriptionError(f"{self.where}.{key}: missing")

    def _wrong(self, key: str, expected: str, value: Any) -> DescriptionError:
        shown = repr(value)
        if len(shown) > 60:
            shown = shown[:57] + "..."
        return DescriptionError(f"{self.where}.{key}: expected {expected}, got {shown}")

    def raw(self, key: str, default: Any = None) -> Any:
        return self.data.get(key, default)

    def section(self, key: str, optional: bool = False) -> _Fields:
        value = self.data.get(key)
        if value is None:
            if optional:
                return _Fields({}, f"{self.where}.{key}")
            raise self._missing(key)
        if not isinstance(value, dict):
            raise self._wrong(key, "an object", value)
        return _Fields(value, f"{self.where}.{key}")

    def text(self, key: str) -> str:
        value = self.data.get(key)
        if value is None:
            raise self._missing(key)
        if not isinstance(value, str) or len(value) > 4096:
            raise self._wrong(key, "a string", value)
        return value

    def import_path(self) -> str:
        """`import_path`: a class of the user's own, module:Class."""
        path = self.text("import_path")
        if not IMPORT_PATH.fullmatch(path):
            raise DescriptionError(f"{self.where}.import_path: {path[:80]!r} is not module:Class")
        return path

    def path(self, key: str) -> Path | None:
        value = self.data.get(key)
        if value is None:
            return None
        if not isinstance(value, str) or not value or "\0" in value or len(value) > 4096:
            raise self._wrong(key, "a file path", value)
        return Path(value)

    def number(
        self,
        key: str,
        default: float | None = None,
        optional: bool = False,
        low: float = -math.inf,
        high: float = math.inf,
    ) -> Any:
        value = self.data.get(key)
        if value is None:
            if optional:
                return None
            if default is not None:
                return default
            raise self._missing(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self._wrong(key, "a finite number", value)
        if not low <= value <= high:
            raise self._wrong(key, f"a number within [{low:g}, {high:g}]", value)
        return float(value)

    def integer(self, key: str, default: int | None = None, low: int = 0, high: int = 2**62) -> int:
        value = self.data.get(key)
        if value is None:
            if default is not None:
                return default
            raise self._missing(key)
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise self._wrong(key, f"a whole number within [{low}, {high}]", value)
        return value

    def flag(self, key: str) -> bool:
        value = self.data.get(key)
        if not isinstance(value, bool):
            raise self._wrong(key, "true or false", value)
        return value

    def choice(self, key: str, enum_type: Any) -> Any:
        value = self.data.get(key)
        if value is None:
            raise self._missing(key)
        try:
            return enum_type(value)
        except (ValueError, TypeError):
            allowed = ", ".join(str(m.value) for m in enum_type)
            raise self._wrong(key, f"one of {allowed}", value) from None
