"""`quadsim run`: fly a script, a bag's commands, live clients' Twists or a fleet headless, and summarise it.

Its plan is made by quadsim.apps.plans (a RunPlan) and flown by quadsim.apps.flying."""

from __future__ import annotations

import argparse
from pathlib import Path

from quadsim.apps.commands import add_command_parser
from quadsim.apps.flying import HeadlessFlight
from quadsim.apps.options import COMMANDS_TAIL_S, add_duration_option, add_live_options, add_sim_options, program
from quadsim.apps.plans import bag_plan, fleet_plan, script_plan, subscribed_plan
from quadsim.errors import QuadsimError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command_parser(
        sub,
        "run",
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
        metavar="FILE.mcap|BAG",
        help="fly the geometry_msgs/msg/Twist messages on /quad_cmd_twist of any MCAP (a ros2 bag in MCAP "
        "storage, its folder or its .mcap file, or a quadsim recording) at their log times, counted from the "
        "first of them; z-mode: a quadsim recording's, else --z-mode (default velocity)",
    )
    what.add_argument(
        "--fleet",
        type=Path,
        metavar="FILE.toml",
        help="fly a fleet: the vehicles of a fleet file in one world, each with its airframe, start, controller "
        "and input (script:NAME_OR_FILE, ros2, foxglove or idle; ros2 and foxglove take Twists on "
        "/NAME/quad_cmd_twist); every vehicle's topics are recorded under its name (/NAME/quad/odom). Default "
        "duration: the longest script; with a live input, until Ctrl-C. Cameras: each vehicle's own (cameras = "
        "[...] in the file)",
    )
    p.add_argument(
        "--input",
        choices=["script", "foxglove", "ros2"],
        default="script",
        help="script (default): fly --script; foxglove: fly the Twists Foxglove clients publish on /quad_cmd_twist "
        "(the Teleop panel), in real time, until Ctrl-C or --duration (implies --foxglove); ros2: the same with the "
        "geometry_msgs/Twist a ROS 2 node publishes on /quad_cmd_twist (implies --ros2)",
    )
    add_duration_option(
        p,
        "seconds of sim time (default: the script's length, or the commands' span plus "
        f"{COMMANDS_TAIL_S:g} s; beyond it the vehicle holds)",
    )
    p.add_argument("--realtime", action="store_true", help="pace simulation time to the wall clock (as --gui does)")
    add_sim_options(p)
    add_live_options(p)


def main(args: argparse.Namespace) -> int:
    # the command's implementation, loaded when it runs (`--help` stays light)

    if args.fleet is not None:
        if args.input != "script":
            raise QuadsimError(f"--input {args.input} with --fleet: each vehicle's input is in the fleet file")
        return HeadlessFlight(args, fleet_plan(args, "run")).fly()
    inputs = [args.script is not None, args.commands_from is not None, args.input in ("foxglove", "ros2")]
    if sum(inputs) > 1:
        what = f"--input {args.input}" if args.input != "script" else "--input"
        raise QuadsimError(f"--script, --commands-from and {what} each say where commands come from; give one")
    if args.input in ("foxglove", "ros2"):
        return HeadlessFlight(args, subscribed_plan(args, "run")).fly()
    realtime = args.gui or args.realtime
    if args.commands_from is not None:
        return HeadlessFlight(args, bag_plan(args, realtime)).fly()
    if args.script is None:
        raise QuadsimError("say what to fly: --script NAME|FILE, --commands-from FILE.mcap, or --input foxglove|ros2")
    return HeadlessFlight(args, script_plan(args, args.script, realtime)).fly()
