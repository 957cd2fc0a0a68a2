"""The live bridges a command line asks for (--foxglove, --ros2, --input foxglove|ros2), opened
together; they are fed by the run's topic fan-out and closed with the run. Each bridge's module
(foxglove-sdk, Cyclone DDS) is imported only when asked for.

An input from a bridge implies that bridge: `--input foxglove` serves Foxglove, `--input ros2`
joins the ROS 2 graph and publishes there too (all but /quad_cmd_twist, which the user's node
publishes)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from quadsim.errors import QuadsimError
from quadsim.live import FOXGLOVE_DEFAULT_ENDPOINT

if TYPE_CHECKING:
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.session.outputs import LiveOutput


def open_live_outputs(
    foxglove: str | None,
    ros2: bool,
    commands: SubscribedDriver | Sequence[SubscribedDriver] | None = None,
    ros_namespace: str = "",
    ros_remaps: Sequence[str] = (),
) -> list[LiveOutput]:
    """Open the bridges: a Foxglove server at `foxglove` (HOST:PORT) or when it is an input, a
    ROS 2 bridge with `ros2` or when it is an input (its node in `ros_namespace`, its topics
    remapped by `ros_remaps`, FROM:=TO); each driver of `commands` (one, or a fleet's, each on
    its vehicle's topic) is fed by the bridge it names."""
    outputs: list[LiveOutput] = []
    drivers = [] if commands is None else [commands] if not isinstance(commands, Sequence) else list(commands)
    from_foxglove = [d for d in drivers if d.name == "foxglove"]
    from_ros2 = [d for d in drivers if d.name == "ros2"]
    if (ros_namespace or ros_remaps) and not (ros2 or from_ros2):  # nothing would take them
        option = "--ros-namespace" if ros_namespace else "--ros-remap"
        raise QuadsimError(f"{option} is for the ROS 2 bridge: add --ros2 (or fly with --input ros2)")
    try:
        if foxglove is not None or from_foxglove:
            outputs.append(_open_foxglove(foxglove or FOXGLOVE_DEFAULT_ENDPOINT, from_foxglove))
        if ros2 or from_ros2:
            from quadsim.live.ros2 import Ros2Bridge

            exclude = tuple(d.topic for d in from_ros2)  # the user's nodes publish those
            ros2_bridge = Ros2Bridge(exclude, namespace=ros_namespace, remaps=ros_remaps)
            outputs.append(ros2_bridge)
            for driver in from_ros2:
                ros2_bridge.subscribe_twist(driver)
                ros2_bridge.subscribe_goals(driver, _say_goal_publishers)
            goals = [topic for d in from_ros2 for topic in d.goal_topics]
            for line, warning in ros2_bridge.startup_lines([d.topic for d in from_ros2], goals):
                print(f"quadsim: warning: {line}" if warning else line, file=sys.stderr if warning else sys.stdout)
            sys.stdout.flush()
    except BaseException:
        for output in outputs:
            output.close()
        raise
    return outputs


def _open_foxglove(endpoint: str, from_foxglove: list[SubscribedDriver]) -> LiveOutput:
    """The Foxglove server at `endpoint` (HOST:PORT), feeding `from_foxglove`; what it serves and
    takes said on stdout, and a warning when it is reachable beyond this machine."""
    from quadsim.live.foxglove import FoxgloveBridge, parse_endpoint

    host, port = parse_endpoint(endpoint)
    bridge = FoxgloveBridge(host, port, from_foxglove)
    topics = " and ".join(d.topic for d in from_foxglove)
    holds = {d.command_timeout_s for d in from_foxglove if d.command_timeout_s is not None}
    held = f", holding {min(holds):g} s after the last" if len(holds) == 1 else ""
    takes = (
        f"; it takes Twists on {topics} (Teleop panel{held}) and goals on /move_base_simple/goal "
        "(3D panel, publish pose)" + (" under each name" if len(from_foxglove) > 1 else "")
        if from_foxglove
        else ""
    )
    print(f"Foxglove: serving {bridge.url} (Open connection -> Foxglove WebSocket){takes}", flush=True)
    if bridge.exposed:  # said as the ROS 2 bridge says an unlimited discovery range
        can = "watch this run and fly the vehicle" if from_foxglove else "watch this run"
        print(
            f"quadsim: warning: Foxglove: {bridge.host} is not loopback: anyone who can reach port "
            f"{bridge.port} can {can}",
            file=sys.stderr,
            flush=True,
        )
    return bridge


def _say_goal_publishers(topic: str, count: int) -> None:
    """A node's goal publisher was heard (or went): from then on a goal it sends arrives (one sent
    before can be lost, as DDS gives a volatile reader only what is written after the match)."""
    print(f"ROS 2: {count} goal publisher{'s' * (count != 1)} heard on {topic}", flush=True)
