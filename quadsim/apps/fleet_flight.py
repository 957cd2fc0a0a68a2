"""A fleet flown headless from the command line (`run --fleet FILE.toml`): the fleet file's
vehicles in one world, each driven by its input (a script, a ROS 2 node, a Foxglove client, or
nothing), recorded with every vehicle's topics under its name, then summarised vehicle by vehicle."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from quadsim.apps.flying import report_end
from quadsim.apps.options import MAX_DURATION_S, camera_specs, flight_settings, live_outputs, program, sim_config
from quadsim.errors import ConfigError, QuadsimError
from quadsim.session.stopping import StopRequested

if TYPE_CHECKING:
    from quadsim.drivers import InputDriver
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.session.fleet_outputs import FleetRecordedRun
    from quadsim.session.headless import RunSummary
    from quadsim.sim.fleet import Fleet, FleetVehicle
    from quadsim.sim.fleet_file import FleetEntry, FleetFile

#: options that each vehicle of a fleet file says for itself
PER_VEHICLE_OPTIONS = (("vehicle", "--vehicle"), ("urdf", "--urdf"), ("script", "--script"))


def fly_fleet(args: argparse.Namespace, command: str) -> int:
    """Fly the fleet file of --fleet headless for --duration (default: the longest script), or
    until Ctrl-C when a live input drives a vehicle."""
    check_fleet_options(args)
    fleet_file = read_fleet_file(args.fleet)
    for device in ("keyboard", "gamepad"):
        held = fleet_file.held_by(device)
        if held is not None:
            raise ConfigError(
                f"{args.fleet}: vehicle {held.name!r} takes input = {device!r}: a person flies it in the window, "
                f"and `{command}` has none (give it a script, ros2, foxglove or idle)"
            )
    drivers = fleet_drivers(fleet_file)
    live_inputs = [d for d in drivers.values() if _subscribed(d)]
    duration = _duration(args, fleet_file, bool(live_inputs))
    run_info = {"command": command, "fleet": str(args.fleet), "duration_s": duration, "realtime": bool(live_inputs)}
    return FleetFlight(args, fleet_file, drivers, live_inputs, run_info).fly(
        duration, bool(live_inputs) or args.realtime
    )


def read_fleet_file(path: Path) -> FleetFile:
    """The fleet file of --fleet; when it is not there but a shipped example has its name, say
    how to copy that one out."""
    from quadsim.apps.commands.examples import shipped
    from quadsim.sim.fleet_file import load_fleet_file

    if not path.exists() and path.name in shipped():
        raise ConfigError(
            f"fleet file not found: {path} (the example ships with quadsim: {program()} examples --copy . {path.name})"
        )
    return load_fleet_file(path)


def check_fleet_options(args: argparse.Namespace) -> None:
    """Refuse what each vehicle of a fleet file says for itself."""
    for attr, option in PER_VEHICLE_OPTIONS:
        if getattr(args, attr, None) is not None:
            raise QuadsimError(f"{option} with --fleet: the fleet file gives each vehicle its own (drop {option})")
    if args.cameras is not None:
        raise QuadsimError("--cameras with --fleet: each vehicle's cameras are in the fleet file (cameras = [...])")
    if args.renderer != "tiny":
        raise QuadsimError(f"--renderer {args.renderer} with --fleet: a fleet's cameras render in its one world (tiny)")


def fleet_drivers(fleet_file: FleetFile) -> dict[str, InputDriver | None]:
    """What drives each vehicle but those a person flies (keyboard, gamepad: None here)."""
    return {v.name: _driver(v) for v in fleet_file.vehicles}


def fleet_cameras(args: argparse.Namespace, fleet_file: FleetFile) -> dict[str, tuple]:
    """Each vehicle's cameras, at --camera-size and --camera-hz."""
    specs = camera_specs(args)
    return {v.name: tuple(specs[c] for c in v.cameras) for v in fleet_file.vehicles if v.cameras}


def _driver(entry: FleetEntry) -> InputDriver | None:
    """What drives a vehicle: its script, a subscription on its own Twist topic, or nothing."""
    from quadsim.drivers.scripted import ScriptedDriver
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.recording.contract import TWIST, Names

    if entry.script is not None:
        return ScriptedDriver(entry.script)
    if entry.input in ("ros2", "foxglove"):
        return SubscribedDriver(entry.input, Names(entry.name).topic(TWIST).name)
    from quadsim.drivers.programmatic import IdleDriver

    return IdleDriver()  # nothing is sent, unless from Python


def _subscribed(driver: InputDriver | None) -> bool:
    from quadsim.drivers.subscribed import SubscribedDriver

    return isinstance(driver, SubscribedDriver)


def _duration(args: argparse.Namespace, fleet_file: FleetFile, live: bool) -> float:
    if args.duration is not None:
        return float(args.duration)
    if live:
        return MAX_DURATION_S
    longest = fleet_file.longest_script_s
    if longest is None:
        raise QuadsimError(f"{args.fleet}: no vehicle flies a script: say how long to fly with --duration SECONDS")
    return longest


class FleetFlight:
    """One headless fleet flight: built, flown with a progress bar (none when flown live), then
    each vehicle's summary, the recording and an exit code."""

    def __init__(
        self,
        args: argparse.Namespace,
        fleet_file: FleetFile,
        drivers: dict[str, InputDriver | None],
        live_inputs: list[InputDriver | None],
        run_info: dict,
    ) -> None:
        self.args, self.fleet_file, self.drivers, self.run_info = args, fleet_file, drivers, run_info
        self.live_inputs: list[SubscribedDriver] = [d for d in live_inputs if _subscribed(d)]  # type: ignore[misc]
        self.summaries: dict[str, RunSummary] = {}
        self.run: FleetRecordedRun | None = None
        self.sim_time = 0.0
        self.planned_s: float | None = None  # how long the run is to fly

    def vehicles(self) -> list[FleetVehicle]:
        return self.fleet_file.fleet_vehicles(self.drivers)

    def fly(self, duration: float, realtime: bool) -> int:
        from quadsim.session.progress import ProgressBar

        if not duration > 0:
            raise QuadsimError(f"--duration must be > 0 s, got {duration}")
        self.planned_s = duration
        live = live_outputs(self.args, self.live_inputs or None)
        bar = None
        try:
            fleet = self._build()
            with fleet:
                print(self._headline(fleet, duration))
                bar = ProgressBar(duration, "sim time") if not self.live_inputs else None
                self._fly(fleet, live, duration, realtime, bar)
        except StopRequested:
            pass  # the summary of what was flown follows; the exit code says why it stopped
        finally:
            if bar is not None:
                bar.close()
            for output in live:
                output.close()
        return self.report()

    def _build(self) -> Fleet:
        from quadsim.sim.fleet import Fleet

        config = sim_config(self.args, None)
        try:
            return Fleet(self.vehicles(), config, **flight_settings(self.args))
        except ConfigError as exc:  # vehicles too close, a start on a landmark: said with the file
            raise ConfigError(f"{self.args.fleet}: {exc}", f"{self.args.fleet}: {exc.cli_message}") from None

    def _fly(self, fleet: Fleet, live: list, duration: float, realtime: bool, bar: object) -> None:
        from quadsim.apps.options import output_options
        from quadsim.session.fleet_outputs import FleetRecordedRun
        from quadsim.session.headless import run_fleet_headless

        outputs = replace(output_options(self.args), cameras=())
        cameras = fleet_cameras(self.args, self.fleet_file)
        stem = Path(self.args.fleet).stem
        label = stem if "fleet" in stem else f"fleet_{stem}"
        try:
            with FleetRecordedRun(fleet, outputs, label, self.run_info, live=live, cameras=cameras) as run:
                self.run = run
                if run.path is not None:
                    print(f"recording to {run.path}", flush=True)
                progress = getattr(bar, "update", None)
                self.summaries = run_fleet_headless(fleet, duration, progress=progress, realtime=realtime)
        finally:
            self.sim_time = fleet.time_s

    def _headline(self, fleet: Fleet, duration: float) -> str:
        config = fleet.config
        until = f"for {duration:.1f} s" if duration < MAX_DURATION_S else "until Ctrl-C"
        who = ", ".join(f"{v.name} ({v.airframe}, {v.input_text})" for v in self.fleet_file.vehicles)
        seen = ", ".join(f"{v.name} ({', '.join(v.cameras)})" for v in self.fleet_file.vehicles if v.cameras)
        return (
            f"flying a fleet of {len(fleet)} {until}: {who}; physics {config.rates.physics_hz} Hz, "
            f"control {config.rates.control_hz} Hz, cameras {seen or 'none'}"
            + (f", {config.wind.describe()}" if config.wind.enabled else "")
        )

    def report(self) -> int:
        if self.summaries:
            first = next(iter(self.summaries.values()))
            print(f"sim time        {first.sim_time_s:.2f} s")
            print(f"wall time       {first.wall_time_s:.2f} s")
            print(f"real-time factor {first.real_time_factor:.1f}x")
            width = max(len(name) for name in self.summaries)
            for name, summary in self.summaries.items():
                print(f"{name:<{width}}  {_vehicle_line(summary)}")
                for line in summary.lines():
                    if line.startswith(("crash", "live input")):
                        print(f"{name:<{width}}  {line}")  # under its vehicle, named again
        return report_end(self.run, self.sim_time, self.planned_s)


def _vehicle_line(s: RunSummary) -> str:
    from quadsim.session.headless import final_pose_text

    return (
        f"{final_pose_text(s.final_state)}; "
        f"flown {s.distance_m:.2f} m; {s.commands_received} commands; events: {s.events_line()}"
    )
