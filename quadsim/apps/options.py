"""Option groups several commands share, declared once, and what they turn into: the
simulation options into a SimConfig, the recording options into OutputOptions, the live options
into open bridges. Also the small things every command's options need: bounded number types,
the program's own name for hints, output paths checked before any work is done, and how a command
that a signal stopped says so."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.control import ControllerKind
from quadsim.core.invocation import program
from quadsim.core.types import LidarMode, StartPose, Stepping, ZMode
from quadsim.errors import QuadsimError
from quadsim.live import FOXGLOVE_DEFAULT_ENDPOINT
from quadsim.physics.wind import Turbulence, wind_from_text
from quadsim.recording.paths import ENV_VAR as RECORDINGS_ENV_VAR
from quadsim.recording.paths import default_recordings_dir
from quadsim.sensors.camera import RendererKind
from quadsim.session.stopping import SignalStop
from quadsim.session.stopping import describe as describe_stop
from quadsim.session.stopping import exit_code as stop_exit_code
from quadsim.sim.config import MAX_PHYSICS_HZ, MAX_SEED, Rates, divisors_shown
from quadsim.vehicle.params import DEFAULT_VEHICLE, SHIPPED_VEHICLES

if TYPE_CHECKING:
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.sensors.camera import CameraSpec
    from quadsim.session.outputs import LiveOutput, OutputOptions
    from quadsim.sim.config import SimConfig

#: sim time a single run may cover: a week (a longer run is surely a typo)
MAX_DURATION_S = 7 * 24 * 3600.0
#: what `fly` records when there is no display for its window
DEMO_SCENARIO = "figure8"
#: `run --commands-from` flies this long after the last command (the dead-man timeout, and settling)
COMMANDS_TAIL_S = 2.0
DEFAULT_CAMERAS, DEFAULT_CAMERA_SIZE, DEFAULT_CAMERA_HZ = "front,floor", "320x240", 30
PLOT_SUFFIXES = (".png", ".jpg", ".jpeg", ".pdf", ".svg")
#: the camera options that add images to the cameras, and the key a fleet file's vehicle says each with
CAMERA_IMAGE_OPTIONS = {
    "--camera-depth": "depth",
    "--camera-depth-colormap": "depth_colormap",
    "--camera-segmentation": "segmentation",
}


def number(low: float, high: float, what: str = "a number") -> Callable[[str], float]:
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


def whole(low: int, high: int) -> Callable[[str], int]:
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


def recordings_default(below: str = "") -> str:
    """The default recordings folder (or `below` it) for a help text, and how to change it."""
    folder = str(default_recordings_dir() / below if below else default_recordings_dir())
    return f"{folder.replace('%', '%%')}; set {RECORDINGS_ENV_VAR} to change it"  # argparse %-formats help


def has_display() -> bool:
    if os.environ.get("SDL_VIDEODRIVER") in ("dummy", "offscreen"):
        return False
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True  # macOS and Windows always have a desktop


def option_value(args: argparse.Namespace, option: str) -> Any:
    """What `option` (--camera-hz) was given as (args.camera_hz)."""
    return getattr(args, option.lstrip("-").replace("-", "_"))


def _size(option: str, text: str, example: str) -> tuple[int, int]:
    """A WxH size option's width and height."""
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise QuadsimError(f"{option} must look like {example}, got {text!r}") from None
    return width, height


def window_size(text: str) -> tuple[int, int]:
    """--window WxH, within what a screen can hold."""
    width, height = _size("--window", text, "1280x720")
    if not (320 <= width <= 16384 and 240 <= height <= 16384):
        raise QuadsimError(f"--window {text}: the size must be within 320x240 .. 16384x16384")
    return width, height


def add_duration_option(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--duration", type=number(1e-3, MAX_DURATION_S, "seconds"), default=None, metavar="S", help=help)


def add_sim_options(p: argparse.ArgumentParser) -> None:
    """The options of a flight: simulation, wind and noise, recording and cameras (`run`, `fly`)."""
    _add_vehicle_options(p.add_argument_group("simulation"))
    _add_wind_options(p.add_argument_group("wind, noise and randomness"))
    _add_recording_options(p.add_argument_group("recording and cameras"))


def _add_vehicle_options(g: argparse._ArgumentGroup) -> None:
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
    _add_rate_options(g)
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


def _add_rate_options(g: argparse._ArgumentGroup) -> None:
    """--physics-hz and the rates that must divide it, each defaulting to Rates()'s; --timeout."""
    defaults = Rates()
    for name, what in (
        ("physics_hz", "physics rate"),
        ("control_hz", "controller rate; must divide the physics rate"),
        ("state_hz", "state publishing rate; must divide the physics rate"),
        ("input_hz", "command publishing rate of the driver"),
    ):
        default = getattr(defaults, name)
        g.add_argument(
            "--" + name.replace("_", "-"),
            type=whole(1, MAX_PHYSICS_HZ),
            default=default,
            help=f"{what} (default {default})",
        )
    g.add_argument(
        "--timeout",
        type=number(1e-3, 3600.0, "seconds"),
        default=0.5,
        metavar="S",
        help="dead-man timeout: hold position after S seconds without a command (default 0.5; a live input's "
        "is --live-timeout's)",
    )


def _add_wind_options(w: argparse._ArgumentGroup) -> None:
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
        "--range",
        action="store_true",
        help="a range finder on /quad/range (sensor_msgs/Range; REP 117: -inf too close, +inf no return), "
        "its rate, beam, range and noise from the vehicle's parameter file [range] (down from under the body)",
    )
    w.add_argument(
        "--lidar",
        choices=[m.value for m in LidarMode],
        default=None,
        help="a LiDAR from ray casts, its rate, rays, range and noise from the vehicle's parameter file [lidar]: "
        "2d, one ring on /quad/scan (sensor_msgs/LaserScan); 3d, its rings as points on /quad/points "
        "(sensor_msgs/PointCloud2), in its frame lidar_link (default: none)",
    )
    w.add_argument(
        "--seed",
        type=whole(0, MAX_SEED),
        default=0,
        metavar="N",
        help="the run's random seed: turbulence and sensor noise derive from it, and it is recorded, "
        "so a run re-flies bit for bit (default 0)",
    )
    w.add_argument(
        "--physics",
        choices=[s.value for s in Stepping],
        default=Stepping.QUADSIM.value,
        help="who steps a vehicle while it touches nothing: quadsim (its own compiled copy of PyBullet's "
        "step, about twice as fast; PyBullet steps it near anything it could touch) or pybullet (PyBullet "
        "every step, to check against) (default quadsim; recorded with the run)",
    )


def _add_recording_options(o: argparse._ArgumentGroup) -> None:
    o.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR|FILE",
        help="where the MCAP recording goes: a folder (a dated name is made) or a .mcap file (in the window, "
        f"later recordings are FILE-2.mcap, FILE-3.mcap...) (default: {recordings_default()})",
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
        type=whole(1, 1000),
        default=None,
        help="frame rate of each camera; must divide the physics rate (default 30)",
    )
    o.add_argument(
        "--camera-depth",
        default=None,
        metavar="LIST",
        help="cameras that also publish a depth image (REP 118), each NAME or NAME:ENCODING: 16UC1 "
        "millimetres (default) or 32FC1 metres, e.g. front or front:32FC1,floor",
    )
    o.add_argument(
        "--camera-depth-colormap",
        default=None,
        metavar="LIST",
        help="cameras of --camera-depth that also publish their depth colour-mapped for people, a JPEG on "
        ".../depth/colormap/compressed (turbo, log scale 0.2-50 m, black: no depth), e.g. front",
    )
    o.add_argument(
        "--camera-segmentation",
        default=None,
        metavar="LIST",
        help="cameras that also publish a segmentation image (label ids, legend on /world/segmentation_labels), "
        "e.g. front",
    )
    o.add_argument(
        "--renderer",
        choices=[r.value for r in RendererKind],
        default=RendererKind.TINY.value,
        help="tiny: PyBullet's CPU TinyRenderer (default); egl: PyBullet's EGL plugin, where a driver exists",
    )
    o.add_argument(
        "--render-workers",
        type=whole(0, 16),
        default=2,
        metavar="N",
        help="render processes, so rendering uses other cores while physics steps (default 2; 0 = in-process)",
    )


def add_live_options(p: argparse.ArgumentParser, what: str = "the run", flown: bool = True) -> None:
    """--foxglove, --ros2 and the ROS 2 naming options (`run`, `fly`; `replay`, which flies
    nothing: `flown` False)."""
    when = "with --ros2 (or --input ros2, or a ros2 vehicle of a fleet)" if flown else "with --ros2"
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
        "topic of the recording with its QoS, plus /clock for use_sim_time; needs the ros2 extra "
        "(Cyclone DDS; no ROS installation)",
    )
    if flown:
        g.add_argument(
            "--live-timeout",
            type=number(1e-3, 3600.0, "seconds"),
            default=None,
            metavar="S",
            help="dead-man timeout of a live input (--input foxglove or ros2, a fleet vehicle's foxglove or ros2): "
            "hold position after S seconds without a Twist (default 0.2 for Foxglove, whose Teleop panel sends "
            "nothing when a button is released; --timeout, 0.5, for ROS 2); recorded with the run",
        )
    g.add_argument(
        "--ros-namespace",
        default="",
        metavar="NS",
        help=f"{when}: the ROS 2 node quadsim is (/quadsim) lives in namespace NS and its topics "
        "too (/NS/quad/odom; /clock, /tf, /tf_static and /rosout stay global, as ROS 2 nodes name them), like "
        "--ros-args -r __ns:=NS",
    )
    g.add_argument(
        "--ros-remap",
        action="append",
        default=[],
        metavar="FROM:=TO",
        help=f"{when}: rename a topic, like --ros-args -r FROM:=TO (matched as ROS 2 does: under --ros-namespace NS "
        "a relative FROM, or /NS/..., names quadsim's topics); e.g. "
        + (
            "/quad_cmd_twist:=/cmd_vel lets teleop_twist_keyboard fly it unchanged (repeatable)"
            if flown
            else "/quad/odom:=/odom (repeatable)"
        ),
    )


def add_parallel_options(p: argparse.ArgumentParser, jobs_help: str) -> None:
    """--jobs N and --ray [ADDRESS], as `sweep` and `check` take them."""
    p.add_argument("--jobs", type=int, default=None, metavar="N", help=jobs_help)
    p.add_argument(
        "--ray",
        nargs="?",
        const="local",
        default=None,
        metavar="ADDRESS",
        help="run as Ray tasks: on a local Ray instance (no ADDRESS), or on a cluster "
        "(auto, ray://HOST:10001); needs the ray extra",
    )


def live_topic(args: argparse.Namespace, driver: SubscribedDriver) -> str:
    """The topic a live input's Twists come on, named as its bridge will subscribe to it: on a ROS 2
    graph in --ros-namespace and remapped by --ros-remap (the rules checked here, before anything
    starts), as the bridge's start-up line and the summary name it."""
    if driver.name != "ros2":
        return driver.topic
    from quadsim.live.ros2 import graph_names, graph_topic

    return graph_topic(driver.topic, *graph_names(getattr(args, "ros_namespace", ""), getattr(args, "ros_remap", [])))


def live_outputs(
    args: argparse.Namespace, commands: SubscribedDriver | Sequence[SubscribedDriver] | None = None
) -> list[LiveOutput]:
    """The live bridges the options ask for (--foxglove, --ros2, and the one an input comes from)."""
    from quadsim.session.live import open_live_outputs

    if getattr(args, "live_timeout", None) is not None and not commands:  # nothing would take it
        raise QuadsimError("--live-timeout is for a live input: fly with --input foxglove or ros2 (or a fleet's)")

    return open_live_outputs(
        getattr(args, "foxglove", None),
        getattr(args, "ros2", False),
        commands,
        getattr(args, "ros_namespace", ""),
        getattr(args, "ros_remap", []),
    )


def _check_rates_divide(args: argparse.Namespace) -> None:
    """Each rate must divide the physics rate: said with the options' names, and, when the rate at
    fault is a default the user never typed, that it is one (--physics-hz 241 alone blamed
    control_hz=240)."""
    defaults = Rates()
    physics = args.physics_hz  # each rate option is a whole number from 1 to MAX_PHYSICS_HZ
    for name in ("control_hz", "state_hz", "input_hz"):
        value = getattr(args, name)
        if physics % value == 0:
            continue
        option = "--" + name.replace("_", "-")
        default = " (its default)" if value == getattr(defaults, name) else ""
        raise QuadsimError(
            f"{option} {value}{default} does not divide --physics-hz {physics}: give {option} as a divisor of "
            f"{physics} ({divisors_shown(physics)})"
        )


def sim_config(args: argparse.Namespace, script_z_mode: ZMode | None) -> SimConfig:
    """The simulation options as a SimConfig; a script's own z-mode unless --z-mode says otherwise."""
    from quadsim.sim.config import SimConfig

    z_mode = ZMode(args.z_mode) if args.z_mode else (script_z_mode or ZMode.VELOCITY)
    _check_rates_divide(args)
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
        physics=args.physics,
        range_finder=args.range,
        lidar=args.lidar,
    )


def flight_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The Simulator's landing and crash settings from --hard-landing and --reset-on-crash."""
    from quadsim.control.landing import LandingSettings

    return {"landing": LandingSettings(hard_landing=args.hard_landing), "reset_on_crash": args.reset_on_crash}


def camera_options_given(args: argparse.Namespace) -> list[str]:
    """The camera options the user typed that ask for frames (`--cameras none` asks for none)."""
    given = [] if args.cameras in (None, "none") else ["--cameras"]
    options = ("--camera-size", "--camera-hz", *CAMERA_IMAGE_OPTIONS)
    return given + [option for option in options if option_value(args, option) is not None]


def camera_specs(args: argparse.Namespace) -> dict[str, CameraSpec]:
    """The onboard cameras by name, at --camera-size and --camera-hz."""
    from quadsim.sensors.camera import default_cameras

    size = args.camera_size if args.camera_size is not None else DEFAULT_CAMERA_SIZE
    width, height = _size("--camera-size", size, "320x240")
    hz = args.camera_hz if args.camera_hz is not None else DEFAULT_CAMERA_HZ
    return {c.name: c for c in default_cameras(width, height, hz)}


def camera_images(args: argparse.Namespace, cameras: tuple[CameraSpec, ...]) -> tuple[CameraSpec, ...]:
    """`cameras` with the images of --camera-depth, --camera-segmentation and --camera-depth-colormap."""
    from quadsim.sensors.camera import with_images

    def items(value: str | None) -> list[str]:
        return [item.strip() for item in (value or "").split(",") if item.strip()]

    where = ("--camera-depth", "--camera-segmentation", "--camera-depth-colormap")
    depth, segmentation = items(args.camera_depth), items(args.camera_segmentation)
    return with_images(cameras, depth, segmentation, items(args.camera_depth_colormap), where)


def output_options(args: argparse.Namespace) -> OutputOptions:
    """The recording and camera options as OutputOptions, each checked."""
    from quadsim.session.outputs import OutputOptions

    wanted = [c.strip() for c in (DEFAULT_CAMERAS if args.cameras is None else args.cameras).split(",") if c.strip()]
    available = camera_specs(args)
    if args.cameras is not None and not wanted:
        raise QuadsimError("--cameras: say which: front, floor, front,floor or none")
    if wanted == ["none"]:
        wanted = []
    unknown = [c for c in wanted if c not in available]
    if unknown:
        raise QuadsimError(f"--cameras: unknown camera {unknown[0]!r}; choose from front, floor or none")
    twice = [c for i, c in enumerate(wanted) if c in wanted[:i]]
    if twice:
        raise QuadsimError(f"--cameras: {twice[0]} is named twice")
    physics_hz = getattr(args, "physics_hz", None)
    hz = available[wanted[0]].rate_hz if wanted else None
    if hz is not None and physics_hz and physics_hz % hz:  # said before the flight starts
        rates = [str(r) for r in range(min(physics_hz, 60), 0, -1) if physics_hz % r == 0][:4]
        raise QuadsimError(
            f"--camera-hz {hz}: does not divide the physics rate {physics_hz} Hz; choose a rate that does "
            f"({', '.join(rates)}, ...)"
        )
    if args.render_workers < 0:
        raise QuadsimError("--render-workers must be 0 or more")
    cameras = camera_images(args, tuple(available[c] for c in wanted))
    out = args.out
    if not args.no_record and out is not None and out.suffix == ".mcap" and _exists(out):  # before any work
        raise QuadsimError(f"{out} already exists; choose another --out (nothing is overwritten)")
    return OutputOptions(
        record=not args.no_record,
        out=args.out,
        cameras=cameras,
        renderer=RendererKind(args.renderer),
        render_workers=args.render_workers,
    )


def _exists(path: Path) -> bool:
    """Whether `path` exists (a name the system cannot take, too long for one: not; said later)."""
    try:
        return path.exists()
    except OSError:
        return False


def check_output_file(option: str, path: Path, suffixes: tuple[str, ...]) -> None:
    """Refuse an output file that cannot be written, before any work is done."""
    if path.is_dir():
        raise QuadsimError(f"{option} {path}: is a folder; give a file name ending in {', '.join(suffixes)}")
    if path.suffix.lower() not in suffixes:
        raise QuadsimError(
            f"{option} {path}: unknown image type {path.suffix or '(none)'!r}; use {', '.join(suffixes)}"
        )
    check_output_dir(option, path.parent, create=False)
    if path.exists():
        raise QuadsimError(f"{path} already exists; choose another {option} (nothing is overwritten)")
    if len(path.name.encode()) > 255:
        raise QuadsimError(f"{option}: the file name is too long ({len(path.name.encode())} bytes; at most 255)")


def check_output_dir(option: str, folder: Path, create: bool = True) -> None:
    """Refuse an output folder that cannot be made or written, before any work is done."""
    try:
        if create:
            folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise QuadsimError(f"{option} {folder}: cannot create the folder ({exc.strerror})") from None
    if not folder.is_dir():
        raise QuadsimError(f"{option} {folder}: no such folder")
    if not os.access(folder, os.W_OK):
        raise QuadsimError(f"{option} {folder}: permission denied")


def stopped_by_signal(said: str = "") -> int | None:
    """When a signal (SIGINT, SIGTERM, SIGHUP) stopped the command: say so on stderr (`said`
    follows the signal's name) and return its exit code (130, 143, 129); None when no signal came."""
    stop = SignalStop.current()
    if stop is None or stop.signum is None:
        return None
    print(f"{describe_stop(stop.signum)}{said}", file=sys.stderr)
    return stop_exit_code(stop.signum)


def warn(lines: list[str], path: Path, most: int = 8) -> None:
    """What was skipped in a damaged or odd file, on stderr (the command goes on)."""
    for line in lines[:most]:
        print(f"quadsim: warning: {path}: {line}", file=sys.stderr)
    if len(lines) > most:
        print(f"quadsim: warning: {path}: and {len(lines) - most} more (see '{program()} info')", file=sys.stderr)
