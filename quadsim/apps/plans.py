"""What the command line asks to fly, as a run's plan: a script, the commands of a bag, the Twists
live clients publish, or a fleet file's vehicles (each with its own input and cameras). Each is
checked before anything flies; `run`, `fly` and `sweep` fly the plans made here."""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, replace
from pathlib import Path

from quadsim.apps.options import (
    CAMERA_IMAGE_OPTIONS,
    COMMANDS_TAIL_S,
    MAX_DURATION_S,
    camera_options_given,
    camera_specs,
    flight_settings,
    live_topic,
    option_value,
    output_options,
    program,
    sim_config,
)
from quadsim.assets import shipped_examples
from quadsim.core.types import ZMode
from quadsim.drivers import InputDriver
from quadsim.drivers.programmatic import IdleDriver
from quadsim.drivers.replay import ReplayDriver
from quadsim.drivers.scripted import Script, ScriptedDriver, load_script
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.errors import ConfigError, QuadsimError
from quadsim.recording.bag_commands import command_steps, read_bag_commands
from quadsim.recording.contract import BODY_FRAME, GOALS, TWIST, Names
from quadsim.sensors.camera import with_images
from quadsim.session.plan import RunPlan
from quadsim.sim.config import SimConfig
from quadsim.sim.fleet_file import FleetEntry, FleetFile, load_fleet_file

#: options that each vehicle of a fleet file says for itself
PER_VEHICLE_OPTIONS = (("vehicle", "--vehicle"), ("urdf", "--urdf"), ("script", "--script"))


@dataclass(frozen=True)
class Planned:
    """A plan and how the command line says it: `what` flies ("'square' for 27.0 s"), the
    drivers the live bridges feed, and whether it keeps to the wall clock."""

    plan: RunPlan
    what: str
    live_inputs: tuple[SubscribedDriver, ...] = ()
    realtime: bool = False
    source: Path | None = None  # the fleet file it comes from: what a vehicle's error names


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


def _duration(args: argparse.Namespace, default_s: float) -> float:
    duration = float(args.duration) if args.duration is not None else default_s
    if not duration > 0:
        raise QuadsimError(f"--duration must be > 0 s, got {duration}")
    return duration


def _alone(
    args: argparse.Namespace,
    config: SimConfig,
    driver: InputDriver,
    duration: float,
    label: str,
    info: dict[str, str],
    realtime: bool,
    live: bool = False,
) -> RunPlan:
    """A run of one vehicle flown by `driver` (a `live` input's: fed by a bridge), with the
    options' recording, cameras and flight settings; `info` is recorded with the duration and
    whether the run keeps to the wall clock. The cameras are refused where no one would see the
    frames asked for; flown in real time, they drop frames rather than hold the flight back (a run
    that is not real-time keeps every frame)."""
    outputs = output_options(args)
    live_wanted = args.foxglove is not None or args.ros2 or live
    if not outputs.record and outputs.cameras and not live_wanted:  # nobody would see a frame
        asked = camera_options_given(args)
        if asked:
            raise QuadsimError(
                f"{' and '.join(asked)} with --no-record: nothing would show the frames (record, or serve them "
                "with --foxglove or --ros2, or leave the camera options out)"
            )
        outputs = replace(outputs, cameras=())
    return RunPlan.alone(
        config,
        driver,
        duration_s=duration,
        outputs=replace(outputs, ordered_delivery=False) if realtime else outputs,
        label=label,
        run_info={**info, "duration_s": duration, "realtime": realtime},
        **flight_settings(args),
    )


def script_plan(args: argparse.Namespace, script_name: str, realtime: bool, command: str = "run") -> Planned:
    """A built-in scenario or a script file."""
    script = load_script(script_name)
    check_z_mode_override(script, args.z_mode)
    duration = _duration(args, script.duration_s)
    config = sim_config(args, script.z_mode)
    label, info = f"{Path(script.name).stem}_{args.controller}", {"command": command, "script": script.name}
    plan = _alone(args, config, ScriptedDriver(script), duration, label, info, realtime)
    return Planned(plan, f"'{script.name}' for {duration:.1f} s", realtime=realtime)


def bag_plan(args: argparse.Namespace, realtime: bool) -> Planned:
    """The /quad_cmd_twist commands of any MCAP at their log times (`run --commands-from`)."""
    bag = read_bag_commands(args.commands_from)
    duration = args.duration if args.duration is not None else bag.span_ns / 1e9 + COMMANDS_TAIL_S
    if duration > MAX_DURATION_S:  # two commands decades apart: a damaged or crafted clock, not a flight
        raise QuadsimError(
            f"{bag.path}: its commands span {bag.span_ns / 1e9 / 86400:.4g} days, more than a run may fly "
            f"({MAX_DURATION_S / 86400:.0f} days): fly part of it with --duration SECONDS"
        )
    duration = _duration(args, duration)
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
    label, info = f"{bag.path.stem}_{config.controller.value}", {"command": "run", "commands_from": str(bag.path)}
    plan = _alone(args, config, driver, duration, label, info, realtime)
    return Planned(plan, f"the {bag.count} commands of {bag.path.name} for {duration:g} s", realtime=realtime)


def subscribed_plan(args: argparse.Namespace, command: str) -> Planned:
    """The Twists Foxglove clients or ROS 2 nodes publish (--input), in real time, until Ctrl-C
    or --duration."""
    driver = SubscribedDriver(args.input, command_timeout_s=args.live_timeout)
    duration = _duration(args, MAX_DURATION_S)
    until = f"for {duration:.1f} s" if args.duration is not None else "until Ctrl-C"
    who = "Foxglove clients" if args.input == "foxglove" else "ROS 2 nodes"
    label, info = f"{args.input}_{args.controller}", {"command": command, "input": args.input}
    plan = _alone(args, sim_config(args, None), driver, duration, label, info, realtime=True, live=True)
    return Planned(plan, f"the Twists {who} publish on {live_topic(args, driver)} {until}", (driver,), realtime=True)


# --- fleets -----------------------------------------------------------------------------------


def read_fleet_file(path: Path) -> FleetFile:
    """The fleet file of --fleet; when it is not there but a shipped example has its name, say
    how to copy that one out."""
    if not path.exists() and path.name in shipped_examples():
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
    for option, key in CAMERA_IMAGE_OPTIONS.items():
        if option_value(args, option) is not None:
            raise QuadsimError(f"{option} with --fleet: each vehicle's images are in the fleet file ({key} = [...])")
    if args.renderer != "tiny":
        raise QuadsimError(f"--renderer {args.renderer} with --fleet: a fleet's cameras render in its one world (tiny)")


def fleet_drivers(fleet_file: FleetFile, live_timeout_s: float | None = None) -> dict[str, InputDriver | None]:
    """What drives each vehicle (those a person flies: nothing, until the window says); a live
    input holds after `live_timeout_s` without a Twist (None: its own default)."""
    return {v.name: _driver(v, live_timeout_s) for v in fleet_file.vehicles}


def fleet_cameras(args: argparse.Namespace, fleet_file: FleetFile) -> dict[str, tuple]:
    """Each vehicle's cameras, at --camera-size and --camera-hz, with the depth, segmentation and
    depth colour-map images its entry asks for."""
    specs = camera_specs(args)
    where = ("depth", "segmentation", "depth_colormap")
    return {
        v.name: with_images(tuple(specs[c] for c in v.cameras), v.depth, v.segmentation, v.depth_colormap, where)
        for v in fleet_file.vehicles
        if v.cameras
    }


def _driver(entry: FleetEntry, live_timeout_s: float | None = None) -> InputDriver | None:
    """What drives a vehicle: its script, a subscription on its own Twist topic, or nothing (a
    person's vehicle until the window gives it the keyboard or the pad)."""
    if entry.script is not None:
        return ScriptedDriver(entry.script)
    if entry.input in ("ros2", "foxglove"):
        names = Names(entry.name)
        goals = tuple(names.topic(goal).name for goal in GOALS)
        return SubscribedDriver(entry.input, names.topic(TWIST).name, live_timeout_s, goals, names.frame(BODY_FRAME))
    return IdleDriver()  # nothing is sent, unless from Python


def fleet_label(fleet_file: FleetFile) -> str:
    """What a fleet file's recordings are named after."""
    stem = fleet_file.path.stem
    return stem if "fleet" in stem else f"fleet_{stem}"


def fleet_plan(args: argparse.Namespace, command: str) -> Planned:
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
    drivers = fleet_drivers(fleet_file, args.live_timeout)
    live_inputs = tuple(d for d in drivers.values() if isinstance(d, SubscribedDriver))
    if args.duration is not None or live_inputs:
        duration = _duration(args, MAX_DURATION_S)
    elif fleet_file.longest_script_s is None:
        raise QuadsimError(f"{args.fleet}: no vehicle flies a script: say how long to fly with --duration SECONDS")
    else:
        duration = fleet_file.longest_script_s
    realtime = bool(live_inputs) or args.realtime
    outputs = replace(output_options(args), cameras=(), ordered_delivery=not realtime)
    plan = RunPlan(
        sim_config(args, None),
        tuple(fleet_file.fleet_vehicles(drivers)),
        duration_s=duration,
        outputs=outputs,
        cameras=fleet_cameras(args, fleet_file),
        label=fleet_label(fleet_file),
        run_info={"command": command, "fleet": str(args.fleet), "duration_s": duration, "realtime": bool(live_inputs)},
        **flight_settings(args),
    )
    until = f"for {duration:.1f} s" if duration < MAX_DURATION_S else "until Ctrl-C"
    who = ", ".join(f"{v.name} ({v.airframe}, {v.input_text})" for v in fleet_file.vehicles)
    return Planned(plan, f"a fleet of {len(fleet_file.vehicles)} {until}: {who}", live_inputs, realtime, args.fleet)
