"""Headless flights from the command line, as `run` and a display-less `fly` make them: a
script, the commands of a bag, or the Twists live clients publish, flown with the options'
vehicle and outputs, then summarised."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from quadsim.apps.options import (
    MAX_DURATION_S,
    camera_options_given,
    flight_settings,
    live_outputs,
    output_options,
    sim_config,
)
from quadsim.core.types import ZMode
from quadsim.errors import QuadsimError
from quadsim.session.stopping import SignalStop, StopRequested
from quadsim.session.stopping import describe as describe_stop
from quadsim.session.stopping import exit_code as stop_exit_code

if TYPE_CHECKING:
    from quadsim.drivers import InputDriver
    from quadsim.drivers.scripted import Script
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.session.fleet_outputs import FleetRecordedRun
    from quadsim.session.headless import RunSummary
    from quadsim.session.outputs import LiveOutput, OutputOptions, RecordedRun
    from quadsim.session.progress import ProgressBar
    from quadsim.sim.config import SimConfig

#: what `fly` records when there is no display for its window
DEMO_SCENARIO = "figure8"
#: `run --commands-from` flies this long after the last command (the dead-man timeout, and settling)
COMMANDS_TAIL_S = 2.0


def check_z_mode_override(script: Script, z_mode_option: str | None) -> None:
    """A script's own z-mode wins; overriding it is refused where the vehicle could never take
    off, and warned about otherwise."""
    written_for = script.z_mode or ZMode.VELOCITY
    if z_mode_option is None or ZMode(z_mode_option) is written_for:
        return
    wanted = ZMode(z_mode_option)
    climbs = any(seg.twist is not None and seg.twist.linear_z > 0 for seg in script.segments)
    if wanted is ZMode.VELOCITY and not climbs:
        raise QuadsimError(
            f"--z-mode velocity: '{script.name}' is written for height z-mode; read as climb rates its "
            f"linear.z never asks to climb, so the vehicle would never take off (drop --z-mode to fly it as written)"
        )
    print(
        f"quadsim: warning: '{script.name}' is written for {written_for.value} z-mode; "
        f"--z-mode {wanted.value} reads its linear.z differently",
        file=sys.stderr,
    )


def fly_script(args: argparse.Namespace, script_name: str, realtime: bool) -> int:
    """A built-in scenario or a script file, headless."""
    from quadsim.drivers.scripted import ScriptedDriver, load_script

    script = load_script(script_name)
    check_z_mode_override(script, args.z_mode)
    duration = args.duration if args.duration is not None else script.duration_s
    run_info = {"command": "run", "script": script.name, "duration_s": duration, "realtime": realtime}
    flight = HeadlessFlight(args, sim_config(args, script.z_mode), ScriptedDriver(script), run_info)
    return flight.fly(
        f"'{script.name}' for {duration:.1f} s", duration, realtime, f"{Path(script.name).stem}_{args.controller}"
    )


def fly_bag(args: argparse.Namespace, realtime: bool) -> int:
    """The /quad_cmd_twist commands of any MCAP at their log times (`run --commands-from`)."""
    from quadsim.drivers.replay import ReplayDriver
    from quadsim.recording.bag_commands import command_steps, read_bag_commands

    bag = read_bag_commands(args.commands_from)
    duration = args.duration if args.duration is not None else bag.span_ns / 1e9 + COMMANDS_TAIL_S
    if duration > MAX_DURATION_S:  # two commands decades apart: a damaged or crafted clock, not a flight
        raise QuadsimError(
            f"{bag.path}: its commands span {bag.span_ns / 1e9 / 86400:.4g} days, more than a run may fly "
            f"({MAX_DURATION_S / 86400:.0f} days): fly part of it with --duration SECONDS"
        )
    if bag.z_mode is not None and args.z_mode is not None and ZMode(args.z_mode) is not bag.z_mode:
        raise QuadsimError(
            f"--z-mode {args.z_mode}: {bag.path.name} was flown in {bag.z_mode.value} z-mode, which its "
            f"commands' linear.z means (drop --z-mode to fly them as recorded)"
        )
    config = sim_config(args, bag.z_mode)
    if bag.z_switch_steps:
        print(
            f"quadsim: warning: {bag.path.name} switches z-mode during its flight (first at "
            f"{bag.z_switch_steps[0] / config.rates.physics_hz:.2f} s); --commands-from flies all of it in "
            f"{(config.z_mode or ZMode.VELOCITY).value} z-mode, its first: replay {bag.path.name} --resim flies it as recorded",
            file=sys.stderr,
        )
    driver = ReplayDriver(command_steps(bag.commands(), config.rates.physics_hz), str(bag.path), bag.count)
    run_info = {"command": "run", "commands_from": str(bag.path), "duration_s": duration, "realtime": realtime}
    what = f"the {bag.count} commands of {bag.path.name} for {duration:g} s"
    flight = HeadlessFlight(args, config, driver, run_info)
    return flight.fly(what, duration, realtime, f"{bag.path.stem}_{config.controller.value}")


def fly_subscribed(args: argparse.Namespace, command: str) -> int:
    """Fly the Twists Foxglove clients or ROS 2 nodes publish (--input), in real time, until
    Ctrl-C or --duration."""
    from quadsim.drivers.subscribed import SubscribedDriver

    driver = SubscribedDriver(args.input)
    duration = args.duration if args.duration is not None else MAX_DURATION_S
    until = f"for {duration:.1f} s" if args.duration is not None else "until Ctrl-C"
    run_info = {"command": command, "input": args.input, "duration_s": duration, "realtime": True}
    who = "Foxglove clients" if args.input == "foxglove" else "ROS 2 nodes"
    flight = HeadlessFlight(args, sim_config(args, None), driver, run_info, commands=driver)
    what = f"the Twists {who} publish on {driver.topic} {until}"
    return flight.fly(what, duration, True, f"{args.input}_{args.controller}")


class HeadlessFlight:
    """One headless flight of the command line: its outputs checked, flown with a progress bar
    (none when flown live), then its summary and recording printed, and an exit code."""

    def __init__(
        self,
        args: argparse.Namespace,
        config: SimConfig,
        driver: InputDriver,
        run_info: dict,
        commands: SubscribedDriver | None = None,
    ) -> None:
        self.args, self.config, self.driver, self.run_info, self.commands = args, config, driver, run_info, commands
        self.summary: RunSummary | None = None
        self.run: RecordedRun | None = None
        self.sim_time = 0.0
        self.planned_s: float | None = None  # how long the run is to fly
        self.bar: ProgressBar | None = None

    def outputs(self) -> OutputOptions:
        """The recording and cameras, refused where no one would see the frames asked for."""
        args, outputs = self.args, output_options(self.args)
        live_wanted = args.foxglove is not None or args.ros2 or self.commands is not None
        if not outputs.record and outputs.cameras and not live_wanted:  # nobody would see a frame
            asked = camera_options_given(args)
            if asked:
                raise QuadsimError(
                    f"{' and '.join(asked)} with --no-record: nothing would show the frames (record, or serve them "
                    "with --foxglove or --ros2, or leave the camera options out)"
                )
            outputs = replace(outputs, cameras=())
        if self.commands is not None:  # flown live: the flight keeps real time, the cameras drop frames
            outputs = replace(outputs, ordered_delivery=False)
        return outputs

    def fly(self, what: str, duration: float, realtime: bool, label: str) -> int:
        """Fly `duration` seconds of sim time, record it as `label`, print what happened."""
        outputs = self.outputs()
        if not duration > 0:
            raise QuadsimError(f"--duration must be > 0 s, got {duration}")
        live = live_outputs(self.args, self.commands)
        self.planned_s = duration
        try:
            self._fly(outputs, live, what, duration, realtime, label)
        except StopRequested:
            pass  # the summary of what was flown follows; the exit code says why it stopped
        finally:
            if self.bar is not None:
                self.bar.close()
            for output in live:  # closed with the run, or here if the run never started
                output.close()
        return self.report()

    def _fly(
        self, outputs: OutputOptions, live: list[LiveOutput], what: str, duration: float, realtime: bool, label: str
    ) -> None:
        from quadsim.session.headless import run_headless
        from quadsim.session.outputs import RecordedRun
        from quadsim.session.progress import ProgressBar
        from quadsim.sim.simulator import Simulator

        config = self.config
        cams = ", ".join(f"{c.name} {c.width_px}x{c.height_px}@{c.rate_hz}Hz" for c in outputs.cameras) or "none"
        with Simulator(config, self.driver, **flight_settings(self.args)) as sim:
            # said once the world and the vehicle have loaded: a bad file is the only line, not the second
            print(
                f"flying {what}: controller {config.controller.value}, z-mode {(config.z_mode or ZMode.VELOCITY).value}, "
                f"physics {config.rates.physics_hz} Hz, control {config.rates.control_hz} Hz, "
                f"cameras {cams}" + (f", {config.wind.describe()}" if config.wind.enabled else "")
            )
            self.bar = ProgressBar(duration, "sim time") if self.commands is None else None
            try:
                with RecordedRun(sim, sim.description(), outputs, label, self.run_info, live=live) as run:
                    self.run = run
                    if run.path is not None:
                        print(f"recording to {run.path}", flush=True)
                    progress = self.bar.update if self.bar is not None else None
                    self.summary = run_headless(sim, duration, progress=progress, realtime=realtime)
            finally:
                self.sim_time = sim.time_s

    def report(self) -> int:
        """The summary, the recording, and why it stopped; the exit code."""
        if self.summary is not None:
            for line in self.summary.lines():
                print(line)
        return report_end(self.run, self.sim_time, self.planned_s)


def report_end(run: RecordedRun | FleetRecordedRun | None, sim_time: float, planned_s: float | None = None) -> int:
    """The recording's line and why the run stopped (a signal, a recording that failed); the
    exit code. `planned_s`: how long the run was to fly (a signal after the last step came while
    it was finishing)."""
    recorder = run.recorder if run is not None else None
    if recorder is not None:
        if recorder.error:
            print(f"recording       {recorder.error}")
        else:
            size = run.path.stat().st_size / 1e6 if run and run.path and run.path.exists() else 0.0
            print(f"recording       {run.path if run else ''} ({size:.1f} MB, {recorder.message_count} messages)")
    stop = SignalStop.current()
    if stop is not None and stop.signum is not None:
        saved = "; the recording is finished and readable" if recorder is not None and not recorder.error else ""
        when = f"at sim time {sim_time:.2f} s"
        if planned_s is not None and sim_time >= planned_s - 1e-9:
            when = f"while finishing, after all {sim_time:.2f} s were flown"
        print(f"{describe_stop(stop.signum)} {when}{saved}", file=sys.stderr)
        return stop_exit_code(stop.signum)
    if recorder is not None and recorder.error:
        print("quadsim: error: the flight finished but its recording did not (see above)", file=sys.stderr)
        return 1
    return 0
