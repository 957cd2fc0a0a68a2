"""Re-simulating a fleet's recording: every vehicle's recorded commands flown again together, in
one world on one clock, with the vehicles, controllers and settings the run was made with, and
each vehicle's new flight measured against its recorded one."""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from quadsim.core.types import ZMode
from quadsim.drivers.replay import ReplayDriver
from quadsim.errors import QuadsimError
from quadsim.recording.flight import RecordedFlight
from quadsim.session.fleet_outputs import FleetRecordedRun
from quadsim.session.outputs import OutputOptions
from quadsim.session.resim import (
    ATTITUDE_TOLERANCE_RAD,
    POSITION_TOLERANCE_M,
    ResimReport,
    compare_states,
    flight_settings,
    rebuild_config,
)
from quadsim.sim.fleet import Fleet, FleetVehicle
from quadsim.sim.loop import StateLog


@dataclass(frozen=True)
class FleetResimReport:
    """Each vehicle's report, in the fleet's order."""

    recording: Path
    vehicles: dict[str, ResimReport]
    new_recording: Path | None

    def within(self, position_m: float, attitude_rad: float) -> bool:
        return all(r.within(position_m, attitude_rad) for r in self.vehicles.values())

    @property
    def worst_position_m(self) -> float:
        return max(r.position.max_error for r in self.vehicles.values())

    @property
    def worst_attitude_rad(self) -> float:
        return max(r.attitude.max_error for r in self.vehicles.values())

    def lines(self) -> list[str]:
        states = sum(r.states_compared for r in self.vehicles.values())
        out = [f"re-flew {self.recording}: a fleet of {len(self.vehicles)}, {states} recorded states compared"]
        for name, report in self.vehicles.items():
            out += [f"  {name}:"] + ["  " + line for line in report.lines()[1:]]
        if self.new_recording is not None:
            out.append(f"  new flight recorded to {self.new_recording}")
        return out


def resimulate_fleet(
    flights: dict[str, RecordedFlight],
    out: Path | None = None,
    record: bool = True,
    position_tolerance_m: float = POSITION_TOLERANCE_M,
    attitude_tolerance_rad: float = ATTITUDE_TOLERANCE_RAD,
    progress: Any = None,
) -> FleetResimReport:
    """Fly every vehicle of a fleet's recording again (`flights`, from load_flights); with
    `record`, the new flight is recorded."""
    first = next(iter(flights.values()))
    whole = first.fleet
    if whole is None or not first.vehicle:
        raise QuadsimError(f"{first.path}: not a fleet's recording")
    with tempfile.TemporaryDirectory(prefix="quadsim-resim-") as tmp:
        vehicles, config = _vehicles(flights, Path(tmp))
        fleet_config = replace(whole.config, world=config.world, gui=False)
        try:
            fleet = Fleet(vehicles, fleet_config, texture_required=False, **flight_settings(first))
        except (QuadsimError, ValueError) as exc:
            why = str(exc).replace(f"{tmp}/", "attachment ")
            raise QuadsimError(
                f"{first.path}: cannot rebuild the fleet from its parameters and attachments: {why}"
            ) from None
        with fleet:
            logs = {name: StateLog() for name in flights}
            for name, log in logs.items():
                fleet[name].add_sink(log)
            outputs = OutputOptions(record=record, out=out, cameras=())
            info = {"command": "replay --resim", "source": str(first.path)}
            with FleetRecordedRun(fleet, outputs, f"resim_{first.path.stem}", info) as run:
                t_fly = time.perf_counter()
                _fly(fleet, run, flights, progress)
                stepping_wall_s = time.perf_counter() - t_fly
                new_path = run.path
    hz = fleet_config.rates.physics_hz
    reports = {
        name: compare_states(
            flight, logs[name], hz, None, stepping_wall_s, position_tolerance_m, attitude_tolerance_rad
        )
        for name, flight in flights.items()
    }
    return FleetResimReport(first.path, reports, new_path)


def _vehicles(flights: dict[str, RecordedFlight], folder: Path) -> tuple[list[FleetVehicle], Any]:
    """Each vehicle as it flew, driven by its recorded commands; and the first one's config."""
    vehicles, first_config = [], None
    for name, flight in flights.items():
        config, gains = rebuild_config(flight, folder)
        first_config = first_config or config
        driver = ReplayDriver(sorted(flight.command_steps(), key=lambda c: c[0]), f"{flight.path} ({name})")
        vehicles.append(
            FleetVehicle(
                name,
                start=config.start,
                urdf=config.urdf,
                vehicle_params=config.vehicle_params,
                controller=config.controller,
                z_mode=config.z_mode,
                driver=driver,
                controller_gains=gains,
            )
        )
    return vehicles, first_config


def _fly(fleet: Fleet, run: FleetRecordedRun, flights: dict[str, RecordedFlight], progress: Any) -> None:
    """Step to the last recorded state of any vehicle, switching each vehicle's z-mode where the
    recording did."""
    end_step = max(f.states[-1].step for f in flights.values())
    switches = sorted(
        (step, name, ZMode(value))
        for name, flight in flights.items()
        for step, kind, value in flight.events
        if kind == "z_mode"
    )
    for step, name, mode in [*switches, (end_step, None, None)]:
        while fleet.step_count < min(step, end_step):
            fleet.step(min(2400, min(step, end_step) - fleet.step_count))
            if progress is not None:
                progress(fleet.time_s)
        if name is not None and mode is not None:
            fleet[name].set_z_mode(mode)
            run.fanout.members[list(flights).index(name)].note_event(fleet.step_count, "z_mode", mode.value)
