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

from quadsim.live import FOXGLOVE_DEFAULT_ENDPOINT
from quadsim.recording.contract import TWIST

if TYPE_CHECKING:
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.session.outputs import LiveOutput

#: the inputs a live bridge provides (SubscribedDriver names)
LIVE_INPUTS = ("foxglove", "ros2")


def open_live_outputs(
    foxglove: str | None,
    ros2: bool,
    commands: SubscribedDriver | None = None,
    ros_namespace: str = "",
    ros_remaps: Sequence[str] = (),
) -> list[LiveOutput]:
    """Open the bridges: a Foxglove server at `foxglove` (HOST:PORT) or when it is the input, a
    ROS 2 bridge with `ros2` or when it is the input (its node in `ros_namespace`, its topics
    remapped by `ros_remaps`, FROM:=TO); `commands` is fed by the bridge it names."""
    outputs: list[LiveOutput] = []
    source = commands.name if commands is not None else None
    try:
        if foxglove is not None or source == "foxglove":
            from quadsim.live.foxglove import FoxgloveBridge, parse_endpoint

            host, port = parse_endpoint(foxglove or FOXGLOVE_DEFAULT_ENDPOINT)
            bridge = FoxgloveBridge(host, port, commands if source == "foxglove" else None)
            takes = f"; it takes Twists on {TWIST.name} (Teleop panel)" if source == "foxglove" else ""
            print(f"Foxglove: serving {bridge.url} (Open connection -> Foxglove WebSocket){takes}", flush=True)
            if bridge.exposed:  # said as the ROS 2 bridge says an unlimited discovery range
                can = "watch this run and fly the vehicle" if source == "foxglove" else "watch this run"
                print(
                    f"quadsim: warning: Foxglove: {bridge.host} is not loopback: anyone who can reach port "
                    f"{bridge.port} can {can}",
                    file=sys.stderr,
                    flush=True,
                )
            outputs.append(bridge)
        if ros2 or source == "ros2":
            from quadsim.live.ros2 import Ros2Bridge

            exclude = (TWIST.name,) if source == "ros2" else ()
            ros2_bridge = Ros2Bridge(exclude, namespace=ros_namespace, remaps=ros_remaps)
            outputs.append(ros2_bridge)
            if source == "ros2":
                assert commands is not None
                ros2_bridge.subscribe_twist(commands)
            for line, warning in ros2_bridge.startup_lines(takes_twist=source == "ros2"):
                print(f"quadsim: warning: {line}" if warning else line, file=sys.stderr if warning else sys.stdout)
            sys.stdout.flush()
    except BaseException:
        for output in outputs:
            output.close()
        raise
    return outputs
