"""The live outputs and inputs a command line asks for (--ros2, --input ros2), opened together and
closed with the run. Each bridge module is imported only when asked for."""

from __future__ import annotations

from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from quadsim.recording.contract import TWIST
from quadsim.recording.fanout import TopicConsumer

if TYPE_CHECKING:
    from quadsim.drivers.subscribed import SubscribedDriver


@dataclass
class LiveSetup:
    """What the live options opened: consumers for the fan-out, and the driver fed from outside
    (None: the run's own input flies)."""

    consumers: tuple[TopicConsumer, ...] = ()
    driver: SubscribedDriver | None = None
    stack: ExitStack = field(default_factory=ExitStack)

    def close(self) -> None:
        self.stack.close()

    def __enter__(self) -> LiveSetup:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_live(ros2: bool, input_name: str | None) -> LiveSetup:
    """Open the ROS 2 bridge for `--ros2` (publish) and/or `--input ros2` (take /quad_cmd_twist).

    With ROS 2 input, /quad_cmd_twist is not published back: the user's node is its publisher."""
    setup = LiveSetup()
    ros2_input = input_name == "ros2"
    if not (ros2 or ros2_input):
        return setup
    try:
        from quadsim.drivers.subscribed import SubscribedDriver
        from quadsim.live.ros2 import Ros2Bridge

        bridge = setup.stack.enter_context(Ros2Bridge(exclude=(TWIST.name,) if ros2_input else ()))
        if ros2:
            setup.consumers += (bridge,)
        if ros2_input:
            setup.driver = SubscribedDriver("ros2", TWIST.name)
            bridge.subscribe_twist(setup.driver)
    except BaseException:
        setup.close()
        raise
    return setup
