"""Re-simulation: fly a recording's commands again with the vehicles, controllers and settings it
was made with (from its metadata and attachments), one world and one clock for all of them, and
measure how far each vehicle's new flight is from its recorded one. A recording of one vehicle is
a fleet of one: the same plan, flown by the same Run."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from quadsim.control import Controller, ControllerKind, remake_controller
from quadsim.control.landing import LandingSettings
from quadsim.core.invocation import program
from quadsim.core.kinematics import body_velocity
from quadsim.core.parts import part_class
from quadsim.core.types import LidarMode, VehicleState, ZMode
from quadsim.drivers.replay import ReplayDriver
from quadsim.errors import QuadsimError
from quadsim.physics.wind import WIND_MODEL_METHODS, WindModel
from quadsim.recording.contract import ODOM, POINTS, POSE, RANGE, SCAN, Names, Topic
from quadsim.recording.flight import RecordedFlight
from quadsim.sensors.beams import xyz_points
from quadsim.session.outputs import OutputOptions
from quadsim.session.plan import RunPlan
from quadsim.session.run import Run, to_the_end
from quadsim.sim.config import SimConfig
from quadsim.sim.description import WindModelDescription
from quadsim.sim.fleet import Fleet, FleetVehicle
from quadsim.sim.loop import StateLog
from quadsim.vehicle.params import load_vehicle

if TYPE_CHECKING:
    from quadsim.sim.drone import Drone


@dataclass(frozen=True)
class Deviation:
    """How far one quantity of the new flight is from the recording."""

    topic: str
    quantity: str
    unit: str
    max_error: float
    rms_error: float
    max_at_s: float
    first_beyond_s: float | None  # first time beyond the tolerance, if any


@dataclass(frozen=True)
class VehicleReport:
    """How far one vehicle's new flight is from its recorded one."""

    states_compared: int
    position: Deviation
    attitude: Deviation
    velocity: Deviation
    #: the range finder's and the LiDAR's readings against the recorded ones, each a distance
    #: judged by the position tolerance (None: the vehicle had neither)
    readings: Deviation | None = None

    def within(self, position_m: float, attitude_rad: float) -> bool:
        readings = self.readings is None or self.readings.max_error <= position_m
        return self.position.max_error <= position_m and self.attitude.max_error <= attitude_rad and readings

    def lines(self) -> list[str]:
        out = []
        for d in (self.position, self.attitude, self.velocity, *((self.readings,) if self.readings else ())):
            where = f", first beyond tolerance at t={d.first_beyond_s:.2f} s" if d.first_beyond_s is not None else ""
            out.append(
                f"  {d.topic} {d.quantity}: max {d.max_error:.6g} {d.unit} at t={d.max_at_s:.2f} s, "
                f"RMS {d.rms_error:.6g} {d.unit}{where}"
            )
        return out


@dataclass(frozen=True)
class ResimReport:
    """Each vehicle's report, in the run's order (a run of one vehicle: "" alone)."""

    recording: Path
    vehicles: dict[str, VehicleReport]
    new_recording: Path | None
    sim_time_s: float = 0.0
    stepping_wall_s: float = 0.0  # wall time spent flying (not loading, building or comparing)

    def within(self, position_m: float, attitude_rad: float) -> bool:
        return all(r.within(position_m, attitude_rad) for r in self.vehicles.values())

    @property
    def states_compared(self) -> int:
        return sum(r.states_compared for r in self.vehicles.values())

    @property
    def position(self) -> Deviation:
        """The position deviation of the vehicle that strayed furthest."""
        return max((r.position for r in self.vehicles.values()), key=lambda d: d.max_error)

    @property
    def attitude(self) -> Deviation:
        """The attitude deviation of the vehicle that turned furthest from its recording."""
        return max((r.attitude for r in self.vehicles.values()), key=lambda d: d.max_error)

    @property
    def readings_identical(self) -> bool | None:
        """Whether every ranging reading re-flew to the bit (None: no vehicle had a ranging sensor)."""
        found = [r.readings.max_error == 0.0 for r in self.vehicles.values() if r.readings is not None]
        return all(found) if found else None

    @property
    def fleet_size(self) -> int:
        """How many named vehicles flew (0: a run of one vehicle)."""
        return 0 if "" in self.vehicles else len(self.vehicles)

    def lines(self) -> list[str]:
        fleet = f"a fleet of {self.fleet_size}, " if self.fleet_size else ""
        out = [f"re-flew {self.recording}: {fleet}{self.states_compared} recorded states compared"]
        for name, report in self.vehicles.items():
            out += [f"  {name}:", *("  " + line for line in report.lines())] if name else report.lines()
        if self.new_recording is not None:
            out.append(f"  new flight recorded to {self.new_recording}")
        return out


class NothingFlown(QuadsimError):
    """A whole recording of a run stopped before its first physics step."""


def _plain_name(name: str) -> bool:
    """A file name that stays inside the folder it is written to."""
    return bool(name) and name == Path(name).name and not name.startswith(".") and "\0" not in name


def _damaged(flight: RecordedFlight, lost: str) -> str:
    """Why a damaged recording cannot be re-flown, and whether `recover` can save any of it."""
    then = (
        f"'{program()} recover {flight.path}' saves what is readable"
        if any(flight.topics.values())
        else "no message in it is readable, so there is nothing to recover"
    )
    return (
        f"{flight.path}: damaged: {lost}. The recorded flight is incomplete, so it cannot be re-flown "
        f"faithfully; {then}"
    )


def rebuild_config(flight: RecordedFlight, folder: Path) -> tuple[SimConfig, dict[str, float]]:
    """The run's config and gains, with its files written from the attachments to `folder`;
    refuses a recording that cannot be re-flown faithfully, saying why."""
    d = flight.description
    if d is None:
        if flight.description_error:
            raise QuadsimError(f"{flight.description_error}: it cannot be re-flown")
        raise QuadsimError(f"{flight.path}: not a quadsim recording (no quadsim metadata): it cannot be re-flown")
    lost = flight.lost_for_resim()
    if lost is not None:
        raise QuadsimError(_damaged(flight, lost))
    unreadable = flight.unreadable_for_resim()
    if unreadable is not None:
        raise QuadsimError(f"{flight.path}: {unreadable}, so the flight cannot be re-flown faithfully")
    pose = Names(flight.vehicle).topic(POSE).name
    if not flight.states and not flight.end_ns and not flight.commands:
        raise NothingFlown(f"{flight.path}: nothing was flown (it ended before the first step): nothing to re-fly")
    if not flight.states:
        raise QuadsimError(f"{flight.path}: has no {pose} states to compare with")
    period = d.config.rates.physics_hz // d.config.rates.state_hz
    most = max(d.config.rates.physics_hz, 2 * period)  # one second, or two state periods
    for a, b in zip(flight.states, flight.states[1:]):
        if b.step - a.step > most:
            raise QuadsimError(
                f"{flight.path}: its {pose} states jump from t={a.step / d.config.rates.physics_hz:.2f} s to "
                f"t={b.step / d.config.rates.physics_hz:.2f} s: the flight between cannot be compared"
            )
    if d.start_step:
        raise QuadsimError(
            f"{flight.path}: this recording was started mid-flight (at step {d.start_step}); "
            f"only recordings that start at the beginning of a flight can be re-flown"
        )
    names = {d.vehicle.urdf_file, d.vehicle.params_file}
    odd = [n for n in sorted(names) if not _plain_name(n)]
    if odd:
        raise QuadsimError(f"{flight.path}: the vehicle's file name {odd[0]!r} is not a plain file name")
    missing = [n for n in sorted(names) if n not in flight.attachments]
    if missing:
        raise QuadsimError(f"{flight.path}: attachment(s) {', '.join(missing)} missing: cannot rebuild the vehicle")
    for name, data in flight.attachments.items():
        if _plain_name(name):  # plain file names only, never a path
            try:
                (folder / name).write_bytes(data)
            except OSError as exc:  # a name too long for this file system
                if name in names:
                    raise QuadsimError(f"{flight.path}: cannot write attachment {name!r}: {exc.strerror}") from None
    world_name = d.config.world.name if d.config.world else "default.toml"
    world = folder / world_name if world_name in flight.attachments else None
    config = replace(
        d.config,
        urdf=folder / d.vehicle.urdf_file,
        vehicle_params=folder / d.vehicle.params_file,
        world=world,
        gui=False,
    )
    return config, d.controller.gains


def _angle_between(q1: tuple[float, ...], q2: tuple[float, ...]) -> float:
    """Rotation angle from q1 to q2, exactly 0 for equal quaternions (acos of a dot product
    is not: rounding leaves it near 1e-8)."""
    x1, y1, z1, w1 = q1
    x2, y2, z2, w2 = q2
    # q = conj(q1) * q2
    w = w1 * w2 + x1 * x2 + y1 * y2 + z1 * z2
    x = w1 * x2 - x1 * w2 - y1 * z2 + z1 * y2
    y = w1 * y2 - y1 * w2 - z1 * x2 + x1 * z2
    z = w1 * z2 - z1 * w2 - x1 * y2 + y1 * x2
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


def _deviation(
    topic: str, quantity: str, unit: str, errors: list[tuple[float, float]], tolerance: float | None
) -> Deviation:
    """`tolerance` None: a quantity reported, not judged (the velocity: no tolerance is in m/s)."""
    worst_t, worst = max(errors, key=lambda e: e[1])
    rms = math.sqrt(sum(e * e for _, e in errors) / len(errors))
    beyond = None if tolerance is None else next((t for t, e in errors if e > tolerance), None)
    return Deviation(topic, quantity, unit, worst, rms, worst_t, beyond)


def flight_settings(flight: RecordedFlight) -> dict[str, Any]:
    """The landing settings and reset-on-crash the run was flown with (as the controller's details
    record them; recordings older than those: the defaults)."""
    details = flight.description.controller.details if flight.description is not None else {}
    landing = details.get("landing", {})
    kept: dict[str, Any] = {}
    if isinstance(landing, dict):
        for f in fields(LandingSettings):
            value = landing.get(f.name)
            if isinstance(value, bool) if f.type in (bool, "bool") else _finite(value):
                kept[f.name] = value
    return {"landing": LandingSettings(**kept), "reset_on_crash": details.get("reset_on_crash") is True}


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def resimulate(
    flights: RecordedFlight | Mapping[str, RecordedFlight],
    out: Path | None = None,
    record: bool = True,
    position_tolerance_m: float | None = None,
    attitude_tolerance_rad: float | None = None,
    progress: Callable[[float], None] | None = None,
) -> ResimReport:
    """Fly every vehicle of a recording again, together (`flights`: load_flights' result, or
    the one flight of a run of one vehicle); with `record`, the new flight is recorded (no cameras).
    The tolerances say where each deviation first went beyond them (None: not judged; `check`'s
    are quadsim.apps.regression's)."""
    if isinstance(flights, RecordedFlight):
        if flights.vehicle:
            raise QuadsimError(f"{flights.path}: a fleet's recording: re-fly all its vehicles (load_flights)")
        flights = {"": flights}
    first = next(iter(flights.values()))
    with tempfile.TemporaryDirectory(prefix="quadsim-resim-") as tmp:
        plan = _plan(flights, Path(tmp), OutputOptions(record=record, out=out, cameras=()))
        logs = {name: StateLog() for name in flights}
        with _rebuild(plan, first, tmp) as fleet, Run(plan, fleet) as run:
            for name, log in logs.items():
                fleet[name].add_sink(log)
            readings = {name: ReadingLog(fleet[name]) for name in flights}
            run.fly(progress=progress, stop=to_the_end)
            new_path = run.outputs.path
            stepping_wall_s = run.wall_s
    hz = plan.config.rates.physics_hz
    reports = {
        name: replace(
            compare_states(flight, logs[name], hz, position_tolerance_m, attitude_tolerance_rad),
            readings=readings[name].compared(flight, position_tolerance_m),
        )
        for name, flight in flights.items()
    }
    return ResimReport(first.path, reports, new_path, run.end_step / hz, stepping_wall_s)


def _plan(flights: Mapping[str, RecordedFlight], folder: Path, outputs: OutputOptions) -> RunPlan:
    """The recorded run as a plan: each vehicle as it flew, driven by its recorded commands, its
    z-mode switched where the recording did, flown to the last recorded state of any vehicle."""
    first = next(iter(flights.values()))
    vehicles, switches, config = [], [], None
    for name, flight in flights.items():
        own, gains = rebuild_config(flight, folder)
        config = config or own
        label = f"{flight.path} ({name})" if name else str(flight.path)
        commands = sorted(flight.command_steps(), key=lambda c: c[0])
        # each vehicle's own dead-man timeout (a fleet's Foxglove vehicle had its input's, not the fleet's)
        driver = ReplayDriver(commands, label, command_timeout_s=own.command_timeout_s)
        vehicles.append(
            FleetVehicle(
                name,
                own.start,
                own.urdf,
                own.vehicle_params,
                _controller(flight, own),
                own.z_mode,
                driver,
                gains,
                own.range_finder,
                own.lidar,
            )
        )
        switches += [(step, name, ZMode(value)) for step, kind, value in flight.events if kind == "z_mode"]
    assert config is not None
    if first.fleet is not None:  # what the vehicles share is the fleet's, with the world written out
        config = replace(first.fleet.config, world=config.world, gui=False)
    end_step = max(flight.states[-1].step for flight in flights.values())
    whole = first.fleet if first.fleet is not None else first.description
    return RunPlan(
        config,
        tuple(vehicles),
        duration_s=end_step / config.rates.physics_hz,
        outputs=outputs,
        label=f"resim_{first.path.stem}",
        run_info={"command": "replay --resim", "source": str(first.path)},
        texture_required=False,
        z_switches=tuple(sorted(switches, key=lambda s: s[0])),
        wind=_wind_model(first.path, whole.wind_model if whole is not None else None),
        **flight_settings(first),
    )


def _controller(flight: RecordedFlight, config: SimConfig) -> ControllerKind | Controller:
    """The controller a vehicle flew: its built-in kind, or the user's own made again from its
    class (module:Class), with what it described of itself; one line where it cannot be."""
    recorded = flight.description.controller if flight.description is not None else None
    if recorded is None or recorded.kind is not None:
        return config.controller
    try:
        return remake_controller(
            recorded.import_path, load_vehicle(config.urdf, config.vehicle_params), recorded.details
        )
    except QuadsimError as exc:
        raise QuadsimError(f"{flight.path}: {exc}") from None


def _wind_model(path: Path, recorded: WindModelDescription | None) -> WindModel | None:
    """The run's wind of the user's own made again from its class (module:Class), as
    `Class.from_description(details)` where it has that, else `Class()`; one line where it cannot be."""
    if recorded is None:
        return None
    try:
        cls = part_class(recorded.import_path, "wind model", WIND_MODEL_METHODS)
        make = getattr(cls, "from_description", None)
        try:
            model: WindModel = make(recorded.details) if callable(make) else cls()
        except Exception as exc:  # the user's constructor
            raise QuadsimError(
                f"the wind model {recorded.import_path} could not be made again ({type(exc).__name__}: {str(exc)[:120]})"
            ) from None
    except QuadsimError as exc:
        raise QuadsimError(f"{path}: {exc}") from None
    return model


def _rebuild(plan: RunPlan, first: RecordedFlight, folder: str) -> Fleet:
    """The recorded run's fleet; a file of the recording that does not build is said as the
    recording's (its attachments), not as the temporary folder they were written to."""
    try:
        return Fleet(plan.vehicles, plan.config, plan.landing, plan.reset_on_crash, False, plan.wind)
    except (QuadsimError, ValueError) as exc:
        why = str(exc).replace(f"{folder}/", "attachment ")
        what = "fleet" if first.fleet is not None else "run"
        raise QuadsimError(
            f"{first.path}: cannot rebuild the {what} from its parameters and attachments: {why}"
        ) from None


class ReadingLog:
    """A re-flown vehicle's ranging readings, kept as the recording has them (RecordedFlight.ranging):
    by contract topic, log time ns -> the range or ranges as float32 bytes, a cloud's points."""

    def __init__(self, drone: Drone) -> None:
        self.readings: dict[str, dict[int, bytes]] = {}
        self._ns = drone.loop.rates.physics_hz
        if drone.range_finder is not None:
            drone.range_finder.sinks.append(lambda r: self._keep(RANGE.name, r.step, r.ranges_m))
        lidar = drone.lidar
        if lidar is not None:
            if drone.config.lidar is LidarMode.PLANAR:
                lidar.sinks.append(lambda r: self._keep(SCAN.name, r.step, r.ranges_m))
            else:
                directions = lidar.directions
                lidar.sinks.append(lambda r: self._keep(POINTS.name, r.step, xyz_points(directions, r.ranges_m)))

    def _keep(self, topic: str, step: int, values: np.ndarray) -> None:
        """`values` as the recording carries them: float32 bytes, at the log time of `step`."""
        self.readings.setdefault(topic, {})[step * 1_000_000_000 // self._ns] = values.astype("<f4").tobytes()

    def compared(self, flight: RecordedFlight, tolerance_m: float | None) -> Deviation | None:
        """The recorded readings against these, message by message: the largest difference of a
        range (or a point's coordinate) in m; a reading missing, or finite on one side alone, is
        an infinite one. None: the recording has no ranging readings."""
        if not flight.ranging:
            return None
        names = Names(flight.vehicle)
        errors: list[tuple[float, float]] = []
        for topic, recorded in flight.ranging.items():
            mine = self.readings.get(topic, {})
            errors += [(ns / 1e9, _reading_error(data, mine.get(ns))) for ns, data in recorded]
        topics = ", ".join(names.topic(Topic(t, "")).name for t in flight.ranging)
        return _deviation(topics, "readings", "m", errors, tolerance_m)


def _reading_error(recorded: bytes, again: bytes | None) -> float:
    """The largest difference between two readings' float32 values (0: the same bytes)."""
    if recorded == again:
        return 0.0
    if again is None or len(again) != len(recorded):
        return math.inf
    a, b = np.frombuffer(recorded, "<f4").astype(float), np.frombuffer(again, "<f4").astype(float)
    differ = ~((a == b) | (np.isnan(a) & np.isnan(b)))
    return float(np.abs(a[differ] - b[differ]).max())  # inf where one side is finite and the other not


def compare_states(
    flight: RecordedFlight,
    log: StateLog,
    physics_hz: int,
    position_tolerance_m: float | None,
    attitude_tolerance_rad: float | None,
) -> VehicleReport:
    """The new flight's states against the recorded ones, step by step."""
    new = {s.step: s for s in log.states}
    pos, att, vel = [], [], []
    for rec, rec_body_velocity in zip(flight.states, flight.body_velocities):
        now: VehicleState | None = new.get(rec.step)
        if now is None:
            continue
        t = rec.step / physics_hz
        pos.append((t, math.dist(now.position_m, rec.position_m)))
        att.append((t, _angle_between(now.orientation_xyzw, rec.orientation_xyzw)))
        vel.append(
            (t, math.dist(body_velocity(now.orientation_xyzw, now.linear_velocity_mps), rec_body_velocity))
        )  # as /quad/odom records it
    names = Names(flight.vehicle)
    if not pos:
        raise QuadsimError(f"{flight.path}: its states are not at this simulation's state rate; nothing to compare")
    return VehicleReport(
        len(pos),
        _deviation(names.topic(POSE).name, "position", "m", pos, position_tolerance_m),
        _deviation(names.topic(POSE).name, "attitude", "rad", att, attitude_tolerance_rad),
        _deviation(names.topic(ODOM).name, "velocity", "m/s", vel, None),
    )
