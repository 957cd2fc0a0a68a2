"""`quadsim fly`: the teleop window, flown with the keyboard, a gamepad or live clients; with no
display, a headless demo (or the live clients' Twists, headless)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.apps.flying import HeadlessFlight
from quadsim.apps.options import (
    DEMO_SCENARIO,
    add_duration_option,
    add_live_options,
    add_sim_options,
    flight_settings,
    has_display,
    live_outputs,
    output_options,
    program,
    sim_config,
    stopped_by_signal,
    window_size,
)
from quadsim.apps.plans import (
    check_fleet_options,
    fleet_cameras,
    fleet_drivers,
    read_fleet_file,
    script_plan,
    subscribed_plan,
)
from quadsim.apps.window.teleop import FleetSetup, TeleopApp, TeleopOptions
from quadsim.apps.window.x11_guard import EXIT_DISPLAY_LOST
from quadsim.drivers.joystick import JoystickMapping, load_mapping
from quadsim.drivers.subscribed import SubscribedDriver
from quadsim.errors import QuadsimError
from quadsim.session.stopping import StopRequested, stop_requested


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "fly",
        description="Open the teleop window: fly with the keyboard or a gamepad, see the front and floor "
        "cameras, a map and a HUD; the flight is recorded. With no display, record the "
        "scripted demo flight headless instead, and say so.",
    )
    add_duration_option(
        p,
        f"seconds of sim time for the demo flown when there is no display (default: the {DEMO_SCENARIO} script's length)",
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
    t.add_argument(
        "--fleet",
        type=Path,
        metavar="FILE.toml",
        help="fly one vehicle of a fleet file among the others: the first whose input is keyboard or gamepad "
        "(with none, the window watches the first); the others fly their scripts, ROS 2 or Foxglove inputs; the "
        "map shows every vehicle, C cycles whose cameras are shown; recorded as run --fleet records",
    )
    add_sim_options(p)
    add_live_options(p)


def main(args: argparse.Namespace) -> int:
    # the command's implementation, loaded when it runs (`--help` stays light)

    if args.fleet is not None:
        return _fly_fleet(args)
    if args.gui and not has_display():
        raise QuadsimError("--gui needs a display (DISPLAY is not set); run without --gui")
    if not has_display() and args.input in ("foxglove", "ros2"):
        who = "Foxglove clients" if args.input == "foxglove" else "ROS 2 nodes"
        print(f"No display found: flying headless, in real time, what {who} publish.")
        args.gui = False
        return HeadlessFlight(args, subscribed_plan(args, "fly")).fly()
    if not has_display() and args.out is not None and args.out.suffix == ".mcap":  # named for a flight by hand
        raise QuadsimError(
            f"no display: the teleop window cannot open, and {args.out} would hold the scripted demo instead of "
            f"a flight by hand; record a scripted flight there with: {program()} run --script NAME --out {args.out}"
        )
    if not has_display():
        cameras = (
            ""
            if args.cameras == "none"
            else " (with both cameras: a minute or so on a busy machine; --cameras none flies it in seconds)"
        )
        print(
            f"No display found: the teleop window cannot open. {'Flying' if args.no_record else 'Recording'} the "
            f"scripted demo '{DEMO_SCENARIO}' headless instead{cameras}. (Headless flights: {program()} run --script NAME; list them with: "
            f"{program()} scenarios)"
        )
        args.gui = False
        return HeadlessFlight(args, script_plan(args, DEMO_SCENARIO, realtime=False)).fly()
    return _fly_window(args)


def _fly_window(
    args: argparse.Namespace, fleet: FleetSetup | None = None, fleet_inputs: Sequence[SubscribedDriver] = ()
) -> int:
    """The teleop window, until Esc, a signal or a lost display; with `fleet` (a FleetSetup),
    flying one vehicle of it, and `fleet_inputs` fed by the live bridges."""

    width, height = window_size(args.window)
    options = TeleopOptions(
        input=args.input,
        keyboard_layout=args.keys,
        joystick_mapping=load_mapping(args.joy_map) if args.joy_map else JoystickMapping(),
        window_size=(width, height),
        **flight_settings(args),
    )
    config, outputs, commands = sim_config(args, None), output_options(args), None
    if args.input in ("foxglove", "ros2"):
        commands = SubscribedDriver(args.input, command_timeout_s=args.live_timeout)
    live = live_outputs(args, fleet_inputs or commands)
    flown, recordings, lost, finals = 0.0, [], None, []
    try:
        with TeleopApp(config, outputs, options, live=live, commands=commands, fleet=fleet) as app:
            if app.fleet is not None and not app.fleet.by_hand:
                print(
                    f"watching {app.fleet.flown} of the fleet: no vehicle takes the keyboard or a gamepad (give one "
                    'input = "keyboard" to fly it); C cycles the cameras, Esc quits'
                )
            else:
                what = f"{app.fleet.flown} of the fleet " if app.fleet is not None else ""
                keys = app.help_keys.replace("/", " or ")
                print(f"flying {what}with {app.driver.name}; press {keys} in the window for the keys, Esc to quit")
            try:
                app.run(stop=stop_requested)  # a signal ends the window loop at its next frame
            finally:
                flown, recordings, finals = app.flown_s, app.recordings, app.final_lines()
        lost = app.display_lost  # the window was destroyed from outside or its X connection lost
    except StopRequested:
        pass
    finally:
        for output in live:  # closed with the run, or here if the window never opened
            output.close()
    return _report(flown, recordings, lost, finals)


def _fly_fleet(args: argparse.Namespace) -> int:
    """`fly --fleet`: the window flies the fleet file's keyboard or gamepad vehicle among the others."""

    if not has_display():
        raise QuadsimError(
            f"fly --fleet needs a display for its window (DISPLAY is not set); {program()} run --fleet flies a "
            "fleet headless (its vehicles on scripts, ROS 2, Foxglove or idle)"
        )
    if args.input != "auto":
        raise QuadsimError(f"--input {args.input} with --fleet: each vehicle's input is in the fleet file")
    check_fleet_options(args)
    fleet_file = read_fleet_file(args.fleet)
    hands = fleet_file.held
    args.input = "joystick" if hands and hands[0].input == "gamepad" else "keyboard"
    drivers = fleet_drivers(fleet_file, args.live_timeout)
    setup = FleetSetup(fleet_file, drivers, fleet_cameras(args, fleet_file))
    return _fly_window(args, setup, [d for d in drivers.values() if isinstance(d, SubscribedDriver)])


def _report(flown: float, recordings: list, lost: str | None, finals: Sequence[str] = ()) -> int:
    print(f"flew {flown:.1f} s of simulation time")
    for line in finals:  # where it ended, how far it flew, its events (a fleet's vehicle by vehicle)
        print(line)
    for path in recordings:
        print(f"recording       {path}")
    if lost is not None:
        finished = "; the recording is finished" if recordings else ""
        print(f"the window's display was lost ({lost}){finished}", file=sys.stderr)
        return EXIT_DISPLAY_LOST
    return stopped_by_signal("; the recording is finished and readable" if recordings else "") or 0
