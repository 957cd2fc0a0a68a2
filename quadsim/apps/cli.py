"""The command-line interface: `python main.py COMMAND --help` (or the `quadsim` script)."""

from __future__ import annotations

import argparse
import errno
import logging
import math
import os
import re
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from quadsim import __version__
from quadsim.apps.stopping import SignalStop, StopRequested, stop_requested
from quadsim.apps.stopping import describe as describe_stop
from quadsim.apps.stopping import exit_code as stop_exit_code
from quadsim.control import ControllerKind
from quadsim.core.types import StartPose, ZMode
from quadsim.errors import QuadsimError
from quadsim.live import FOXGLOVE_DEFAULT_ENDPOINT
from quadsim.physics.wind import Turbulence, wind_from_text
from quadsim.recording.paths import ENV_VAR as RECORDINGS_ENV_VAR
from quadsim.recording.paths import default_recordings_dir
from quadsim.sensors.camera import RendererKind
from quadsim.sim.config import MAX_SEED, Rates
from quadsim.vehicle.params import DEFAULT_VEHICLE, SHIPPED_VEHICLES

if TYPE_CHECKING:
    from quadsim.apps.outputs import LiveOutput, OutputOptions
    from quadsim.drivers import InputDriver
    from quadsim.drivers.scripted import Script
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.sim.config import SimConfig

DEMO_SCENARIO = "figure8"


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (and exit code 2), like every other error here."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _number(low: float, high: float, what: str = "a number") -> Callable[[str], float]:
    """An argparse type: a finite float within [low, high]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not math.isfinite(value) or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"expected {what} within {low:g}..{high:g}, got {text}")
        return value

    return parse


def _whole(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: an integer within [low, high]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"expected a whole number within {low}..{high}, got {value}")
        return value

    return parse


#: sim time a single run may cover: a week (a longer run is surely a typo)
MAX_DURATION_S = 7 * 24 * 3600.0


def _recordings_default(below: str = "") -> str:
    """The default recordings folder (or `below` it) for a help text, and how to change it."""
    folder = str(default_recordings_dir() / below if below else default_recordings_dir())
    return f"{folder.replace('%', '%%')}; set {RECORDINGS_ENV_VAR} to change it"  # argparse %-formats help


def _add_sim_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("simulation")
    g.add_argument(
        "--controller",
        choices=[c.value for c in ControllerKind],
        default=ControllerKind.CASCADE.value,
        help="cascade (default): velocity->attitude->rate; seed: port of the original V-REP controller",
    )
    g.add_argument(
        "--z-mode",
        choices=[z.value for z in ZMode],
        default=None,
        help="how linear.z is read: velocity = climb rate m/s; height = altitude 2.0+z m "
        "(default: what the script says, else velocity)",
    )
    v = g.add_mutually_exclusive_group()
    v.add_argument(
        "--vehicle",
        choices=list(SHIPPED_VEHICLES),
        default=None,
        help="a shipped airframe: quad (1 kg X quadrotor), hexa (hexacopter) or crazyflie (a 27 g "
        f"Crazyflie 2.x sized quadrotor); default {DEFAULT_VEHICLE}",
    )
    v.add_argument(
        "--urdf",
        type=Path,
        default=None,
        metavar="FILE.urdf",
        help="any vehicle URDF, with its NAME.params.toml beside it (instead of --vehicle)",
    )
    g.add_argument("--world", type=Path, default=None, help="world file (default: assets/worlds/default.toml)")
    g.add_argument("--physics-hz", type=_whole(1, 100_000), default=240, help="physics rate (default 240)")
    g.add_argument(
        "--control-hz",
        type=_whole(1, 100_000),
        default=240,
        help="controller rate; must divide the physics rate (default 240)",
    )
    g.add_argument(
        "--state-hz",
        type=_whole(1, 100_000),
        default=60,
        help="state publishing rate; must divide the physics rate (default 60)",
    )
    g.add_argument(
        "--input-hz", type=_whole(1, 100_000), default=20, help="command publishing rate of the driver (default 20)"
    )
    g.add_argument(
        "--timeout",
        type=_number(1e-3, 3600.0, "seconds"),
        default=0.5,
        metavar="S",
        help="dead-man timeout: hold position after S seconds without a command (default 0.5)",
    )
    g.add_argument(
        "--hard-landing",
        action="store_true",
        help="do not slow descents near the ground (default: touchdown at about 0.3 m/s whatever the descent "
        "commanded)",
    )
    g.add_argument(
        "--reset-on-crash",
        action="store_true",
        help="after a crash (a wall, the ground at speed or tilted) put the vehicle back at the start pose, "
        "landed; the clock, the commands and the recording go on",
    )
    g.add_argument("--gui", action="store_true", help="also open PyBullet's own 3D window (needs a display)")
    w = p.add_argument_group("wind, noise and randomness")
    w.add_argument(
        "--wind",
        default=None,
        metavar="SPEED,FROM",
        help="a constant wind of SPEED m/s blowing FROM a direction in degrees, meteorological style: "
        "clockwise from north, north being the world's +y and east its +x (REP 103). 3,90 is 3 m/s from "
        "the east, the air moving toward -x (default: no wind)",
    )
    w.add_argument(
        "--turbulence",
        choices=[t.value for t in Turbulence],
        default=None,
        help="Dryden turbulence on top of the wind, with the MIL-F-8785C low-altitude intensities "
        "(15, 30, 45 knots at 20 ft): light, moderate or severe (default: none)",
    )
    w.add_argument(
        "--no-sensor-noise",
        action="store_true",
        help="publish the true IMU values on /quad/imu (default: with the MEMS noise and bias random "
        "walk of the vehicle's parameter file; /quad/odom and /quad/pose are always ground truth)",
    )
    w.add_argument(
        "--seed",
        type=_whole(0, MAX_SEED),
        default=0,
        metavar="N",
        help="the run's random seed: turbulence and sensor noise derive from it, and it is recorded, "
        "so a run re-flies bit for bit (default 0)",
    )
    o = p.add_argument_group("recording and cameras")
    o.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR|FILE",
        help="where the MCAP recording goes: a folder (a dated name is made) or a .mcap file "
        f"(default: {_recordings_default()})",
    )
    o.add_argument("--no-record", action="store_true", help="do not record")
    o.add_argument(
        "--cameras",
        default=None,
        metavar="LIST",
        help="onboard cameras to render: front,floor (default), front, floor or none",
    )
    o.add_argument("--camera-size", default=None, metavar="WxH", help="image size of each camera (default 320x240)")
    o.add_argument(
        "--camera-hz",
        type=_whole(1, 1000),
        default=None,
        help="frame rate of each camera; must divide the physics rate (default 30)",
    )
    o.add_argument(
        "--renderer",
        choices=[r.value for r in RendererKind],
        default=RendererKind.TINY.value,
        help="tiny: PyBullet's CPU TinyRenderer (default); egl: PyBullet's EGL plugin, where a driver exists",
    )
    o.add_argument(
        "--render-workers",
        type=_whole(0, 16),
        default=2,
        metavar="N",
        help="render processes, so rendering uses other cores while physics steps (default 2; 0 = in-process)",
    )


def _add_live_options(p: argparse.ArgumentParser, what: str = "the run") -> None:
    g = p.add_argument_group("live")
    g.add_argument(
        "--foxglove",
        nargs="?",
        const=FOXGLOVE_DEFAULT_ENDPOINT,
        default=None,
        metavar="HOST:PORT",
        help=f"serve {what} live to Foxglove (a Foxglove WebSocket server: every topic of the recording, "
        f"latched ones included) on HOST:PORT (default {FOXGLOVE_DEFAULT_ENDPOINT}: this machine only; "
        "0.0.0.0:8765 for the network). In the Foxglove app: Open connection -> Foxglove WebSocket -> ws://HOST:PORT",
    )
    g.add_argument(
        "--ros2",
        action="store_true",
        help=f"join a ROS 2 graph (ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE) and publish {what} live: every "
        "topic of the recording with its QoS, plus /clock for use_sim_time; needs pip install 'quadsim[ros2]' "
        "(Cyclone DDS; no ROS installation)",
    )
    g.add_argument(
        "--ros-namespace",
        default="",
        metavar="NS",
        help="with --ros2 or --input ros2: the ROS 2 node quadsim is (/quadsim) lives in namespace NS and its topics "
        "too (/NS/quad/odom; /clock, /tf, /tf_static and /rosout stay global, as ROS 2 nodes name them), like "
        "--ros-args -r __ns:=NS",
    )
    g.add_argument(
        "--ros-remap",
        action="append",
        default=[],
        metavar="FROM:=TO",
        help="with --ros2 or --input ros2: rename a topic, like --ros-args -r FROM:=TO; e.g. "
        "/quad_cmd_twist:=/cmd_vel lets teleop_twist_keyboard fly it unchanged (repeatable)",
    )


def _live_outputs(args: argparse.Namespace, commands: SubscribedDriver | None = None) -> list[LiveOutput]:
    """The live bridges the options ask for (--foxglove, --ros2, and the one an input comes from)."""
    from quadsim.apps.live import open_live_outputs

    return open_live_outputs(
        getattr(args, "foxglove", None),
        getattr(args, "ros2", False),
        commands,
        getattr(args, "ros_namespace", ""),
        getattr(args, "ros_remap", []),
    )


def _config(args: argparse.Namespace, script_z_mode: ZMode | None):
    from quadsim.sim.config import SimConfig

    z_mode = ZMode(args.z_mode) if args.z_mode else (script_z_mode or ZMode.VELOCITY)
    rates = Rates(
        physics_hz=args.physics_hz, control_hz=args.control_hz, state_hz=args.state_hz, input_hz=args.input_hz
    )
    urdf = SHIPPED_VEHICLES[args.vehicle] if args.vehicle else args.urdf  # neither: the default vehicle
    return SimConfig(
        urdf=urdf,
        world=args.world,
        controller=ControllerKind(args.controller),
        z_mode=z_mode,
        rates=rates,
        command_timeout_s=args.timeout,
        start=StartPose(),
        gui=args.gui,
        wind=wind_from_text(args.wind, args.turbulence),
        sensor_noise=not args.no_sensor_noise,
        seed=args.seed,
    )


def _flight_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The Simulator's landing and crash settings from --hard-landing and --reset-on-crash."""
    from quadsim.control.landing import LandingSettings

    return {"landing": LandingSettings(hard_landing=args.hard_landing), "reset_on_crash": args.reset_on_crash}


DEFAULT_CAMERAS, DEFAULT_CAMERA_SIZE, DEFAULT_CAMERA_HZ = "front,floor", "320x240", 30


def _camera_options_given(args: argparse.Namespace) -> list[str]:
    """The camera options the user typed that ask for frames (`--cameras none` asks for none)."""
    given = [] if args.cameras in (None, "none") else ["--cameras"]
    return given + [
        name
        for name, value in (("--camera-size", args.camera_size), ("--camera-hz", args.camera_hz))
        if value is not None
    ]


def _outputs(args: argparse.Namespace):
    from quadsim.apps.outputs import OutputOptions
    from quadsim.sensors.camera import CameraSpec, default_cameras

    size = args.camera_size if args.camera_size is not None else DEFAULT_CAMERA_SIZE
    try:
        width, height = (int(v) for v in size.lower().split("x"))
    except ValueError:
        raise QuadsimError(f"--camera-size must look like 320x240, got {size!r}") from None
    wanted = [c.strip() for c in (args.cameras or DEFAULT_CAMERAS).split(",") if c.strip()]
    hz = args.camera_hz if args.camera_hz is not None else DEFAULT_CAMERA_HZ
    available = {c.name: c for c in default_cameras(width, height, hz)}
    if wanted == ["none"]:
        wanted = []
    unknown = [c for c in wanted if c not in available]
    if unknown:
        raise QuadsimError(f"--cameras: unknown camera {unknown[0]!r}; choose from front, floor or none")
    if args.render_workers < 0:
        raise QuadsimError("--render-workers must be 0 or more")
    cameras: tuple[CameraSpec, ...] = tuple(available[c] for c in wanted)
    return OutputOptions(
        record=not args.no_record,
        out=args.out,
        cameras=cameras,
        renderer=RendererKind(args.renderer),
        render_workers=args.render_workers,
    )


def _check_z_mode_override(script: Script, z_mode_option: str | None) -> None:
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


def _fly_script(args: argparse.Namespace, script_name: str, realtime: bool) -> int:
    from quadsim.drivers.scripted import ScriptedDriver, load_script

    script = load_script(script_name)
    _check_z_mode_override(script, args.z_mode)
    duration = args.duration if args.duration is not None else script.duration_s
    run_info = {"command": "run", "script": script.name, "duration_s": duration, "realtime": realtime}
    return _fly_headless(
        args,
        _config(args, script.z_mode),
        ScriptedDriver(script),
        f"'{script.name}' for {duration:.1f} s",
        duration,
        realtime,
        f"{Path(script.name).stem}_{args.controller}",
        run_info,
    )


#: `run --commands-from` flies this long after the last command (the dead-man timeout, and settling)
COMMANDS_TAIL_S = 2.0


def _fly_bag(args: argparse.Namespace, realtime: bool) -> int:
    from quadsim.drivers.replay import ReplayDriver
    from quadsim.recording.bag_commands import command_steps, read_bag_commands

    bag = read_bag_commands(args.commands_from)
    duration = args.duration if args.duration is not None else bag.span_ns / 1e9 + COMMANDS_TAIL_S
    if duration > MAX_DURATION_S:  # two commands decades apart: a damaged or crafted clock, not a flight
        raise QuadsimError(
            f"{bag.path}: its commands span {bag.span_ns / 1e9 / 86400:.4g} days, more than a run may fly "
            f"({MAX_DURATION_S / 86400:.0f} days): fly part of it with --duration SECONDS"
        )
    config = _config(args, bag.z_mode)
    driver = ReplayDriver(command_steps(bag.commands(), config.rates.physics_hz), str(bag.path), bag.count)
    run_info = {"command": "run", "commands_from": str(bag.path), "duration_s": duration, "realtime": realtime}
    what = f"the {bag.count} commands of {bag.path.name} for {duration:.1f} s"
    return _fly_headless(
        args, config, driver, what, duration, realtime, f"{bag.path.stem}_{config.controller.value}", run_info
    )


def _fly_subscribed(args: argparse.Namespace, command: str) -> int:
    """Fly the Twists Foxglove clients or ROS 2 nodes publish (--input), in real time, until
    Ctrl-C or --duration."""
    from quadsim.drivers.subscribed import SubscribedDriver

    driver = SubscribedDriver(args.input)
    duration = args.duration if args.duration is not None else MAX_DURATION_S
    until = f"for {duration:.1f} s" if args.duration is not None else "until Ctrl-C"
    run_info = {"command": command, "input": args.input, "duration_s": duration, "realtime": True}
    who = "Foxglove clients" if args.input == "foxglove" else "ROS 2 nodes"
    return _fly_headless(
        args,
        _config(args, None),
        driver,
        f"the Twists {who} publish on {driver.topic} {until}",
        duration,
        True,
        f"{args.input}_{args.controller}",
        run_info,
        commands=driver,
    )


def _fly_headless(
    args: argparse.Namespace,
    config: SimConfig,
    driver: InputDriver,
    what: str,
    duration: float,
    realtime: bool,
    label: str,
    run_info: dict,
    commands: SubscribedDriver | None = None,
) -> int:
    from quadsim.apps.headless import run_headless
    from quadsim.apps.outputs import RecordedRun
    from quadsim.apps.progress import ProgressBar
    from quadsim.sim.simulator import Simulator

    outputs: OutputOptions = _outputs(args)
    live_wanted = args.foxglove is not None or args.ros2 or commands is not None
    if not outputs.record and outputs.cameras and not live_wanted:  # nobody would see a frame
        asked = _camera_options_given(args)
        if asked:
            raise QuadsimError(
                f"{' and '.join(asked)} with --no-record: nothing would show the frames (record, or serve them "
                "with --foxglove or --ros2, or leave the camera options out)"
            )
        outputs = replace(outputs, cameras=())
    if commands is not None:  # flown live: the flight keeps real time, the cameras drop frames (as the window)
        outputs = replace(outputs, ordered_delivery=False)
    if not duration > 0:
        raise QuadsimError(f"--duration must be > 0 s, got {duration}")
    cams = ", ".join(f"{c.name} {c.width_px}x{c.height_px}@{c.rate_hz}Hz" for c in outputs.cameras) or "none"
    live = _live_outputs(args, commands)
    bar: ProgressBar | None = None
    summary, run, sim_time = None, None, 0.0
    try:
        with Simulator(config, driver, **_flight_settings(args)) as sim:
            # said once the world and the vehicle have loaded: a bad file is the only line, not the second
            print(
                f"flying {what}: controller {config.controller.value}, z-mode {(config.z_mode or ZMode.VELOCITY).value}, "
                f"physics {config.rates.physics_hz} Hz, control {config.rates.control_hz} Hz, "
                f"cameras {cams}" + (f", {config.wind.describe()}" if config.wind.enabled else "")
            )
            bar = ProgressBar(duration, "sim time") if commands is None else None
            try:
                with RecordedRun(sim, sim.description(), outputs, label, run_info, live=live) as run:
                    if run.path is not None:
                        print(f"recording to {run.path}", flush=True)
                    summary = run_headless(
                        sim, duration, progress=bar.update if bar is not None else None, realtime=realtime
                    )
            finally:
                sim_time = sim.time_s
    except StopRequested:
        pass  # the summary of what was flown follows; the exit code says why it stopped
    finally:
        if bar is not None:
            bar.close()
        for output in live:  # closed with the run, or here if the run never started
            output.close()
    if summary is not None:
        for line in summary.lines():
            print(line)
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
        print(f"{describe_stop(stop.signum)} at sim time {sim_time:.2f} s{saved}", file=sys.stderr)
        return stop_exit_code(stop.signum)
    if recorder is not None and recorder.error:
        print("quadsim: error: the flight finished but its recording did not (see above)", file=sys.stderr)
        return 1
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    inputs = [args.script is not None, args.commands_from is not None, args.input in ("foxglove", "ros2")]
    if sum(inputs) > 1:
        what = f"--input {args.input}" if args.input != "script" else "--input"
        raise QuadsimError(f"--script, --commands-from and {what} each say where commands come from; give one")
    if args.input in ("foxglove", "ros2"):
        return _fly_subscribed(args, "run")
    realtime = args.gui or args.realtime
    if args.commands_from is not None:
        return _fly_bag(args, realtime)
    if args.script is None:
        raise QuadsimError("say what to fly: --script NAME|FILE, --commands-from FILE.mcap, or --input foxglove|ros2")
    return _fly_script(args, args.script, realtime)


def has_display() -> bool:
    if os.environ.get("SDL_VIDEODRIVER") in ("dummy", "offscreen"):
        return False
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True  # macOS and Windows always have a desktop


def _window_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise QuadsimError(f"--window must look like 1280x720, got {text!r}") from None
    if not (320 <= width <= 16384 and 240 <= height <= 16384):
        raise QuadsimError(f"--window {text}: the size must be within 320x240 .. 16384x16384")
    return width, height


def cmd_fly(args: argparse.Namespace) -> int:
    if args.gui and not has_display():
        raise QuadsimError("--gui needs a display (DISPLAY is not set); run without --gui")
    if not has_display() and args.input in ("foxglove", "ros2"):
        who = "Foxglove clients" if args.input == "foxglove" else "ROS 2 nodes"
        print(f"No display found: flying headless, in real time, what {who} publish.")
        args.gui = False
        return _fly_subscribed(args, "fly")
    if not has_display():
        print(
            f"No display found: the teleop window cannot open. Recording the scripted demo '{DEMO_SCENARIO}' "
            f"headless instead. (Headless flights: {program()} run --script NAME; list them with: "
            f"{program()} scenarios)"
        )
        args.gui = False
        return _fly_script(args, DEMO_SCENARIO, realtime=False)
    from quadsim.apps.window.teleop import TeleopApp, TeleopOptions
    from quadsim.drivers.joystick import JoystickMapping, load_mapping

    width, height = _window_size(args.window)
    options = TeleopOptions(
        input=args.input,
        keyboard_layout=args.keys,
        joystick_mapping=load_mapping(args.joy_map) if args.joy_map else JoystickMapping(),
        window_size=(width, height),
        **_flight_settings(args),
    )
    config = _config(args, None)
    outputs = _outputs(args)
    commands = None
    if args.input in ("foxglove", "ros2"):
        from quadsim.drivers.subscribed import SubscribedDriver

        commands = SubscribedDriver(args.input)
    live = _live_outputs(args, commands)
    flown, recordings, lost = 0.0, [], None
    try:
        with TeleopApp(config, outputs, options, live=live, commands=commands) as app:
            print(f"flying with {app.driver.name}; press H or F1 in the window for the keys, Esc to quit")
            try:
                app.run(stop=stop_requested)  # a signal ends the window loop at its next frame
            finally:
                flown, recordings = app.sim.time_s, app.recordings
        lost = app.display_lost  # the window was destroyed from outside or its X connection lost
    except StopRequested:
        pass
    finally:
        for output in live:  # closed with the run, or here if the window never opened
            output.close()
    print(f"flew {flown:.1f} s of simulation time")
    for path in recordings:
        print(f"recording       {path}")
    if lost is not None:
        from quadsim.apps.window.x11_guard import EXIT_DISPLAY_LOST

        finished = "; the recording is finished" if recordings else ""
        print(f"the window's display was lost ({lost}){finished}", file=sys.stderr)
        return EXIT_DISPLAY_LOST
    stop = SignalStop.current()
    if stop is not None and stop.signum is not None:
        print(f"{describe_stop(stop.signum)}; the recording is finished and readable", file=sys.stderr)
        return stop_exit_code(stop.signum)
    return 0


def cmd_scenarios(args: argparse.Namespace) -> int:
    from quadsim.drivers.scripted import builtin_scenarios, load_script

    for name, summary in builtin_scenarios().items():
        script = load_script(name)
        print(f"{name:14s} {script.duration_s:5.1f} s  {summary}")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    from quadsim.apps.evaluate import MANOEUVRE_TARGETS, PHYSICS_TARGETS, SCENARIO_METRICS, TARGETS, evaluate

    controllers = [ControllerKind(c) for c in args.controller] if args.controller else list(ControllerKind)
    results = {c: evaluate(controller=c) for c in controllers}
    details = {"max_tilt_deg", "min_z_m", "max_z_m", "rate_mean_radps", "peak_mps"}
    details |= {"landed", "final_z_m", "drops", "heading_rate_radps", "bank_deg"}
    rows = [(s, m) for s, metrics in results[controllers[0]].items() for m in metrics if m not in details]
    targets = {(s, m): "< " + format(bound, "g") for s, m, bound in (*TARGETS, *MANOEUVRE_TARGETS)}
    targets.update({(s, m): f"{low:g} .. {high:g}" if low else f"< {high:g}" for s, m, low, high in PHYSICS_TARGETS})
    header = "| scenario | metric | target (cascade) | " + " | ".join(c.value for c in controllers) + " |"
    print(header)
    print("|" + "---|" * (3 + len(controllers)))
    for s, m in rows:
        cells = " | ".join(f"{results[c][s][m]:.3f}" for c in controllers)
        print(f"| {s} | {m} | {targets.get((s, m), '')} | {cells} |")
    print(
        "| "
        + " | ".join(
            ["all scenarios", "max tilt (deg)", ""]
            + [f"{max(results[c][s]['max_tilt_deg'] for s in SCENARIO_METRICS):.1f}" for c in controllers]
        )
        + " |"
    )
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from quadsim.recording.info import read_info

    info = read_info(args.file)
    for line in info.lines():
        print(line)
    if info.damage:
        raise QuadsimError(info.damage_report)
    missing = info.missing_topics()
    if missing:
        raise QuadsimError(f"{args.file}: not a quadsim recording: missing topics {', '.join(missing)}")
    return 0


def cmd_recover(args: argparse.Namespace) -> int:
    from quadsim.recording.contract import CORE_TOPICS
    from quadsim.recording.salvage import recover

    result = recover(args.file, args.output, CORE_TOPICS)
    t0, t1 = result.span_s
    if result.was_complete:
        print(f"{args.file} was complete; its {result.messages} messages were copied to {result.path}")
        return 0
    print(
        f"recovered {result.messages} messages on {result.topics} topics from {result.chunks} intact chunks, "
        f"covering {t0:.2f} .. {t1:.2f} s of simulation time, with {result.metadata} metadata records and "
        f"{result.attachments} attachments"
    )
    lost = [d for d in result.damage if d.loses != "nothing"]
    print("what was lost: " + ("nothing (only indexes or fields around the data were damaged)" if not lost else ""))
    for d in result.damage:
        print(f"  {d.describe()}")
    print(f"written to {result.path}")
    return 0


PLOT_SUFFIXES = (".png", ".jpg", ".jpeg", ".pdf", ".svg")


def _check_output_file(option: str, path: Path, suffixes: tuple[str, ...]) -> None:
    """Refuse an output file that cannot be written, before any work is done."""
    if path.is_dir():
        raise QuadsimError(f"{option} {path}: is a folder; give a file name ending in {', '.join(suffixes)}")
    if path.suffix.lower() not in suffixes:
        raise QuadsimError(
            f"{option} {path}: unknown image type {path.suffix or '(none)'!r}; use {', '.join(suffixes)}"
        )
    _check_output_dir(option, path.parent, create=False)
    if len(path.name.encode()) > 255:
        raise QuadsimError(f"{option}: the file name is too long ({len(path.name.encode())} bytes; at most 255)")


def _check_output_dir(option: str, folder: Path, create: bool = True) -> None:
    try:
        if create:
            folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise QuadsimError(f"{option} {folder}: cannot create the folder ({exc.strerror})") from None
    if not folder.is_dir():
        raise QuadsimError(f"{option} {folder}: no such folder")
    if not os.access(folder, os.W_OK):
        raise QuadsimError(f"{option} {folder}: permission denied")


def cmd_replay(args: argparse.Namespace) -> int:
    from quadsim.recording.flight import load_flight

    width, height = _window_size(args.window)
    if args.plot is not None:
        _check_output_file("--plot", args.plot, PLOT_SUFFIXES)
    if args.mp4 is not None:
        _check_output_dir("--mp4", args.mp4)
    if (args.foxglove is not None or args.ros2) and args.resim:
        option = "--foxglove" if args.foxglove is not None else "--ros2"
        raise QuadsimError(f"{option} plays the recording as it is; with --resim nothing would be played (drop one)")
    flight = load_flight(args.file)
    if args.resim:
        from quadsim.apps.progress import ProgressBar
        from quadsim.apps.resim import resimulate

        bar = ProgressBar(flight.duration_s, "re-flying")
        report = resimulate(flight, out=args.out, record=not args.no_record, progress=bar.update)
        bar.close()
        for line in report.lines():
            print(line)
        _warn(flight.warnings(), args.file)
        return 0
    _warn(flight.warnings(), args.file)
    headless = args.headless or args.mp4 is not None or args.plot is not None
    if not headless and not has_display():
        print(
            "No display found: printing the summary instead (use --headless, --mp4 DIR or --plot FILE.png "
            "for pictures, or --resim to fly it again)."
        )
        headless = True
    if headless:
        from quadsim.apps.flight_plot import export_plot
        from quadsim.apps.replay_export import export_mp4, summary_lines

        for line in summary_lines(flight):
            print(line)
        if args.mp4 is not None:
            from quadsim.apps.progress import ProgressBar

            bar = ProgressBar(sum(len(frames) for frames in flight.frames.values()), "encoding video", unit="frames")
            videos = export_mp4(flight, args.mp4, progress=lambda done, _: bar.update(done), stop=stop_requested)
            bar.close()
            for video in videos:
                print(video.line())
            stop = SignalStop.current()
            if stop is not None and stop.signum is not None and any(v.frames < v.of for v in videos):
                print(
                    f"{describe_stop(stop.signum)}; each video is whole and ends where the encoding stopped",
                    file=sys.stderr,
                )
                return stop_exit_code(stop.signum)
        if args.plot is not None:
            print(f"plot        {export_plot(flight, args.plot)}")
        if args.foxglove is not None or args.ros2:
            return _replay_live(args)
        return 0
    from quadsim.apps.window.replay import ReplayApp

    live = _live_outputs(args)
    try:
        feed = _feed(args.file, live)
        with ReplayApp(flight, (width, height), speed=args.speed, loop=args.loop, feed=feed) as app:
            print("replaying; press H or F1 in the window for the keys, Esc to quit")
            app.run(stop=stop_requested)  # a signal ends the playback at its next frame
    finally:
        for output in live:
            output.close()
    if app.display_lost is not None:
        from quadsim.apps.window.x11_guard import EXIT_DISPLAY_LOST

        print(f"the window's display was lost ({app.display_lost})", file=sys.stderr)
        return EXIT_DISPLAY_LOST
    stop = SignalStop.current()
    if stop is not None and stop.signum is not None:
        print(describe_stop(stop.signum), file=sys.stderr)
        return stop_exit_code(stop.signum)
    return 0


def _feed(path: Path, live: list[LiveOutput]):
    if not live:
        return None
    from quadsim.live.playback import RecordingFeed

    return RecordingFeed(path, live)


def _replay_live(args: argparse.Namespace) -> int:
    """replay --foxglove/--ros2 with no window: play the recording live in real time (times
    --speed), once or --loop, until its end or Ctrl-C."""
    import time

    live = _live_outputs(args)
    try:
        feed = _feed(args.file, live)
        assert feed is not None
        print(
            f"playing {len(feed.messages)} messages on {len(feed.topics)} topics ({feed.end_ns / 1e9:.1f} s) "
            f"at {args.speed:g}x{', looping' if args.loop else ''}; Ctrl-C stops",
            flush=True,
        )
        t0 = time.monotonic()
        while not stop_requested():
            t_ns = int((time.monotonic() - t0) * args.speed * 1e9)
            if t_ns > feed.end_ns:
                feed.play_to(feed.end_ns)
                if not args.loop:
                    break
                t0, t_ns = time.monotonic(), 0
            feed.play_to(t_ns)
            time.sleep(0.01)
    finally:
        for output in live:
            output.close()
    print(f"played {feed.played} messages")
    stop = SignalStop.current()
    if stop is not None and stop.signum is not None:
        print(describe_stop(stop.signum), file=sys.stderr)
        return stop_exit_code(stop.signum)
    return 0


def _warn(lines: list[str], path: Path, most: int = 8) -> None:
    """What was skipped in a damaged or odd file, on stderr (the command goes on)."""
    for line in lines[:most]:
        print(f"quadsim: warning: {path}: {line}", file=sys.stderr)
    if len(lines) > most:
        print(f"quadsim: warning: {path}: and {len(lines) - most} more (see 'quadsim info')", file=sys.stderr)


def cmd_check(args: argparse.Namespace) -> int:
    from quadsim.apps.check import CheckOutcome, CheckTask, check_one, recordings_in
    from quadsim.apps.sweep.backends import RAY_MISSING, default_jobs, ray_available, run_tasks

    files = recordings_in(args.paths)
    jobs = args.jobs if args.jobs is not None else 1
    if not 1 <= jobs <= 1024:
        raise QuadsimError(f"--jobs must be from 1 to 1024, got {jobs}")
    use_ray = args.ray is not None
    if use_ray and not ray_available():
        raise QuadsimError(RAY_MISSING)
    tasks = [CheckTask(path, args.tolerance_m, args.tolerance_rad) for path in files]
    if use_ray and args.jobs is None:
        jobs = default_jobs()
    # results come in completion order; the report keeps the order of the files
    outcomes: dict[Path, CheckOutcome] = {}
    shown = 0
    for outcome in run_tasks(check_one, tasks, jobs, None if args.ray in (None, "local") else args.ray, use_ray):
        outcomes[outcome.path] = outcome
        while shown < len(files) and files[shown] in outcomes:
            for line in outcomes[files[shown]].lines:
                print(line, flush=True)
            shown += 1
    failed = sum(o.status == "changed" for o in outcomes.values())
    unusable = sum(o.status == "unusable" for o in outcomes.values())
    total = len(files)
    not_checked = total - len(outcomes)
    print(
        f"{total - failed - unusable - not_checked} of {total} recordings re-fly within {args.tolerance_m:g} m and "
        f"{args.tolerance_rad:g} rad"
        + (f"; {failed} changed" if failed else "")
        + (f"; {unusable} unusable" if unusable else "")
        + (f"; {not_checked} not checked (stopped)" if not_checked else "")
    )
    return 2 if unusable else (1 if failed else 0)


#: `bench --section NAME`: (module, function, what it measures), run in this order by `all`
BENCH_SECTIONS: dict[str, tuple[str, str, str]] = {
    "flight": ("quadsim.apps.bench", "run_flight_core_bench", "the flight core"),
    "recording": ("quadsim.apps.bench", "run_recording_bench", "cameras and recording"),
    "window": ("quadsim.apps.bench", "run_interactive_bench", "the teleop window headless"),
    "autonomy": ("quadsim.apps.bench_autonomy", "run_autonomy_bench", "camera images in code, the Gymnasium envs"),
    "replay": ("quadsim.apps.bench", "run_replay_bench", "playback and re-simulation"),
    "live": ("quadsim.apps.bench", "run_live_bench", "Foxglove streaming"),
    "ros2": ("quadsim.apps.bench", "run_ros2_bench", "the ROS 2 bridge beside a real rclpy node"),
    "sweep": ("quadsim.apps.sweep.bench", "run_sweep_bench", "a 64-run sweep on 1 worker, every core and Ray"),
}


def cmd_bench(args: argparse.Namespace) -> int:
    import importlib

    for name, (module, function, _) in BENCH_SECTIONS.items():
        if args.section in ("all", name):
            run = getattr(importlib.import_module(module), function)
            if name == "flight":
                run(steps=args.steps, repeats=args.repeats)
            else:
                run()
    return 0


def program() -> str:
    """How the user started quadsim, for help and hints to name: `python main.py` in a clone,
    `python -m quadsim`, or the installed `quadsim` command."""
    started = Path(sys.argv[0]) if sys.argv and sys.argv[0] else Path()
    if started.name == "main.py":
        return "python main.py"
    if started.name == "__main__.py" and started.parent.name == "quadsim":
        return "python -m quadsim"
    return "quadsim"


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog=program(),
        description="Quadrotor teleop simulator: PyBullet physics flying Twist commands (/quad_cmd_twist semantics).",
        epilog=f"Run '{program()} COMMAND --help' for each command's options.",
    )
    parser.add_argument("--version", action="version", version=f"quadsim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log more")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser(
        "run",
        help="fly a scripted flight headless, as fast as possible, and summarise it",
        description="Fly a built-in scenario, a script file or the /quad_cmd_twist commands of any MCAP "
        "headless as fast as the machine allows, showing progress, then print sim time, wall time, "
        "real-time factor, final pose and distance flown. Script format: one segment a line, "
        "'DURATION_S FIELD=VALUE...' (fields linear.x linear.y linear.z angular.z), 'silence DURATION_S', "
        "an optional first line 'z_mode height'.",
    )
    what = p.add_mutually_exclusive_group()
    what.add_argument(
        "--script",
        default=None,
        metavar="NAME|FILE",
        help=f"a built-in scenario ({program()} scenarios lists them) or a script file",
    )
    what.add_argument(
        "--commands-from",
        type=Path,
        metavar="FILE.mcap",
        help="fly the geometry_msgs/msg/Twist messages on /quad_cmd_twist of any MCAP (a ros2 bag in MCAP "
        "storage, a quadsim recording) at their log times, counted from the first of them; z-mode: a quadsim "
        "recording's, else --z-mode (default velocity)",
    )
    p.add_argument(
        "--input",
        choices=["script", "foxglove", "ros2"],
        default="script",
        help="script (default): fly --script; foxglove: fly the Twists Foxglove clients publish on /quad_cmd_twist "
        "(the Teleop panel), in real time, until Ctrl-C or --duration (implies --foxglove); ros2: the same with the "
        "geometry_msgs/Twist a ROS 2 node publishes on /quad_cmd_twist (implies --ros2)",
    )
    p.add_argument(
        "--duration",
        type=_number(1e-3, MAX_DURATION_S, "seconds"),
        default=None,
        metavar="S",
        help="seconds of sim time (default: the script's length, or the commands' span plus "
        f"{COMMANDS_TAIL_S:g} s; beyond it the vehicle holds)",
    )
    p.add_argument("--realtime", action="store_true", help="pace simulation time to the wall clock (as --gui does)")
    _add_sim_options(p)
    _add_live_options(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "fly",
        aliases=["demo"],
        help="fly with keyboard or gamepad in a window (no display: a demo)",
        description="Open the teleop window: fly with the keyboard or a gamepad, see the front and floor "
        "cameras, a map and a HUD; the flight is recorded. With no display, record the "
        "scripted demo flight headless instead, and say so.",
    )
    p.add_argument(
        "--duration",
        type=_number(1e-3, MAX_DURATION_S, "seconds"),
        default=None,
        metavar="S",
        help="seconds of sim time for the demo flown when there is no display",
    )
    t = p.add_argument_group("teleop window")
    t.add_argument(
        "--input",
        choices=["auto", "keyboard", "joystick", "foxglove", "ros2"],
        default="auto",
        help="auto (default): a gamepad if one is plugged in, else the keyboard until one is plugged in; "
        "joystick: wait for a gamepad even if none is plugged in; foxglove: the Twists Foxglove clients publish "
        "on /quad_cmd_twist (the Teleop panel), served as --foxglove says; ros2: the geometry_msgs/Twist a ROS 2 "
        "node publishes on /quad_cmd_twist (implies --ros2); with no display, these two fly headless in real time",
    )
    t.add_argument(
        "--keys",
        choices=["default", "teleop_twist_keyboard"],
        default="default",
        help="keyboard layout: default (arrows move, W/S climb, A/D yaw, Space stop) or "
        "teleop_twist_keyboard (i/,/j/l, u/o/m/., t/b, k stop, q/z speed)",
    )
    t.add_argument(
        "--joy-map",
        type=Path,
        default=None,
        metavar="FILE.toml",
        help="gamepad mapping file in teleop_twist_joy's names (axis_linear.x, scale_linear.x, enable_button, "
        "deadzone), axes numbered and signed as on /joy (stick up and left positive)",
    )
    t.add_argument("--window", default="1280x720", metavar="WxH", help="initial window size (default 1280x720)")
    _add_sim_options(p)
    _add_live_options(p)
    p.set_defaults(func=cmd_fly)

    p = sub.add_parser("scenarios", help="list the built-in scripted scenarios")
    p.set_defaults(func=cmd_scenarios)

    p = sub.add_parser(
        "evaluate",
        help="fly the scenarios with each controller and print the flight-quality table",
        description="Fly every measured scenario and print its metrics as a Markdown table.",
    )
    p.add_argument(
        "--controller",
        action="append",
        choices=[c.value for c in ControllerKind],
        help="only this controller (repeatable; default: all)",
    )
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser(
        "info",
        help="describe a recording: duration, topics, rates, run parameters",
        description="Describe an MCAP recording. On a damaged file, say what is wrong and how much "
        "is readable (exit code 2).",
    )
    p.add_argument("file", type=Path, metavar="FILE.mcap")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser(
        "recover",
        help="salvage a recording cut short (killed process, power loss)",
        description="Read every complete chunk of a damaged or cut-short MCAP file and write its "
        "messages, schemas, metadata and attachments to a new, valid, indexed MCAP.",
    )
    p.add_argument("file", type=Path, metavar="DAMAGED.mcap")
    p.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        metavar="OUT.mcap",
        help="where to write (default: DAMAGED.recovered.mcap beside the input)",
    )
    p.set_defaults(func=cmd_recover)

    p = sub.add_parser(
        "replay",
        help="play a recording back (window, or --headless summary, MP4, plot), or fly it again (--resim)",
        description="Play a recording back in the teleop window (both cameras, the map with the whole "
        "track, the HUD; Space play/pause, arrows seek and speed, click the timeline). "
        "--headless prints a summary and can export MP4 videos and a plot. --resim rebuilds "
        "the vehicle, controller and settings from the recording, flies its commands again, "
        "records the new flight and reports how far it is from the recorded one.",
    )
    p.add_argument("file", type=Path, metavar="FILE.mcap")
    p.add_argument("--headless", action="store_true", help="no window: print a summary")
    p.add_argument("--mp4", type=Path, default=None, metavar="DIR", help="export each camera stream to DIR as MP4")
    p.add_argument(
        "--plot",
        type=Path,
        default=None,
        metavar="FILE.png",
        help="draw the track and the commands against the state to a PNG",
    )
    p.add_argument("--resim", action="store_true", help="fly the recorded commands again and compare")
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR|FILE",
        help=f"with --resim: where the new flight is recorded (default: {_recordings_default()})",
    )
    p.add_argument("--no-record", action="store_true", help="with --resim: do not record the new flight")
    p.add_argument(
        "--speed",
        type=_number(0.25, 16.0, "a speed factor"),
        default=1.0,
        help="playback speed, 0.25 to 16 (default 1)",
    )
    p.add_argument("--loop", action="store_true", help="start again at the end")
    p.add_argument("--window", default="1280x720", metavar="WxH", help="initial window size")
    _add_live_options(p, "the recorded messages, as they are played (put FILE first),")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser(
        "check",
        help="re-fly recordings as regression tests (exit 1 when one changed)",
        description="Fly each recording's commands again and compare with what it recorded. Exit code "
        "0 when every recording re-flies within the tolerances, 1 when one no longer does "
        "(with a report: which topic, when, how far), 2 when a file cannot be used.",
    )
    p.add_argument("paths", type=Path, nargs="+", metavar="DIR|FILE", help="recordings, or folders of them")
    from quadsim.apps.check import DEFAULT_TOLERANCE_M, DEFAULT_TOLERANCE_RAD

    p.add_argument(
        "--tolerance-m",
        type=_number(0.0, 1e6, "metres"),
        default=DEFAULT_TOLERANCE_M,
        help=f"position tolerance (default {DEFAULT_TOLERANCE_M:g} m)",
    )
    p.add_argument(
        "--tolerance-rad",
        type=_number(0.0, math.pi, "radians"),
        default=DEFAULT_TOLERANCE_RAD,
        help=f"attitude tolerance (default {DEFAULT_TOLERANCE_RAD:g} rad)",
    )
    from quadsim.apps.sweep.command import add_parallel_arguments
    from quadsim.apps.sweep.command import add_parser as add_sweep_parser

    add_parallel_arguments(
        p, "re-fly N recordings at once in worker processes (default 1; the report stays in file order)"
    )
    p.set_defaults(func=cmd_check)
    add_sweep_parser(sub, _recordings_default("sweeps/NAME"))
    from quadsim.apps.examples import add_parser as add_examples_parser

    add_examples_parser(sub)

    p = sub.add_parser(
        "bench",
        help="measure speed against a bare-PyBullet baseline run in the same process",
        description="Benchmark. Every figure is given as steps/s, real-time factor and a ratio to a "
        "baseline measured in the same run; best of --repeats.",
    )
    p.add_argument(
        "--steps",
        type=_whole(1, 10_000_000),
        default=24000,
        help="physics steps per timed run (default 24000 = 100 s sim)",
    )
    p.add_argument(
        "--repeats", type=_whole(1, 100), default=3, help="timed runs per figure; the best is kept (default 3)"
    )
    p.add_argument(
        "--section",
        choices=["all", *BENCH_SECTIONS],
        default="all",
        help="; ".join(f"{name}: {what}" for name, (_, _, what) in BENCH_SECTIONS.items()) + " (default: all)",
    )
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    """The command line. SIGINT and SIGTERM stop any command cleanly (exit 130 and 143)."""
    with SignalStop() as stop:
        try:
            code = _main(argv)
        except StopRequested as exc:  # a second signal: stopped at once
            print(f"quadsim: {describe_stop(exc.signum)}", file=sys.stderr)
            code = 0  # the exit code below says why
        except Exception as exc:
            if stop.signum is None:
                raise
            # what a forced stop broke on its way out (an import cut short, a closed pipe)
            print(f"quadsim: {describe_stop(stop.signum)} ({type(exc).__name__} on the way out)", file=sys.stderr)
            code = 0
        if stop.signum is not None and code != stop_exit_code(stop.signum):
            # stopped by a signal, whatever else happened on the way out: the exit code says so
            if code == 0:  # it came after the command had said its last word
                print(
                    f"quadsim: {describe_stop(stop.signum)} once the command had finished: nothing was cut short",
                    file=sys.stderr,
                )
            elif code != 1:
                print(f"quadsim: {describe_stop(stop.signum)}", file=sys.stderr)
            return stop_exit_code(stop.signum)
        return code


#: options whose value may start with a minus sign (argparse would read `--wind -5,90` as two options)
_SIGNED_VALUE_OPTIONS = ("--wind",)
_SIGNED_VALUE = re.compile(r"-[0-9.][0-9.,eE+-]*")


def _normalise_argv(argv: list[str]) -> list[str]:
    """What argparse would misread, said the way it reads it: `--wind -5,90` as `--wind=-5,90` (a
    negative speed is a value, not an option), and `--foxglove FILE.mcap` as `--foxglove` at its
    default endpoint followed by the file (`replay --foxglove FILE` took the file for HOST:PORT)."""
    out: list[str] = []
    for arg in argv:
        if out and out[-1] in _SIGNED_VALUE_OPTIONS and _SIGNED_VALUE.fullmatch(arg):
            out[-1] = f"{out[-1]}={arg}"
            continue
        if out and out[-1] == "--foxglove" and arg.lower().endswith(".mcap"):
            out[-1] = f"--foxglove={FOXGLOVE_DEFAULT_ENDPOINT}"
        out.append(arg)
    return out


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(_normalise_argv(list(sys.argv[1:] if argv is None else argv)))
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.WARNING, format="quadsim: %(levelname)s: %(message)s"
    )
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        code = int(args.func(args))
        sys.stdout.flush()  # inside the try: a closed pipe shows here, not at interpreter exit
        return code
    except QuadsimError as exc:
        print(f"quadsim: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader went away (`quadsim info X | head`): stop quietly, as Unix tools do
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            print(f"quadsim: error: the disk is full ({exc.filename or 'writing'})", file=sys.stderr)
            return 2
        raise
