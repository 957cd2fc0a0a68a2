"""The subscribed driver: Twists that arrive from outside the loop (a ROS 2 subscription, a
Foxglove client publishing on /quad_cmd_twist), handed in from any thread.

Like a ROS subscriber feeding the original's controller: a message that arrived since the last
poll is published once; no message, no command, so the gate's dead-man timeout holds the vehicle
when the publisher stops ("if this message is not present the quadcopter won't move").

That timeout is the input's own where its clients call for it: Foxglove's Teleop panel publishes
while a button is held and sends nothing when it is released (no zero Twist), so the last command
flies on until the timeout; the run's 0.5 s turned a 4 s press at 0.5 rad/s 129 degrees instead
of 115. A Foxglove input holds after 0.2 s without a message (four periods of the panel at the
20 Hz the docs ask for: shorter, and a stall of the simulation or of the client that delays a
message that long would already stop the vehicle mid-press); a ROS 2 input keeps the run's
timeout (nodes such as teleop_twist_keyboard send a zero Twist to stop). --live-timeout sets either.

Goals (geometry_msgs/PoseStamped on GOAL_TOPICS under the vehicle's names: RViz's "2D Goal Pose",
Foxglove's "publish pose") arrive the same way, `deliver_goal`; the flight loop takes the newest
(`take_goal`) and flies it until a Twist comes (quadsim.drivers.goal).
"""

from __future__ import annotations

import math
import threading
from typing import Any

from quadsim.core.types import Twist
from quadsim.drivers import ASAP, NEVER
from quadsim.drivers.goal import Goal, goal_from_pose

#: the topics a live input takes goals on (a fleet vehicle's: under its name): RViz 2's "2D Goal
#: Pose" and Nav2 publish /goal_pose; Foxglove's 3D panel and RViz 1 /move_base_simple/goal
GOAL_TOPICS = ("/goal_pose", "/move_base_simple/goal")

#: the dead-man timeout of a live input whose clients send nothing on release, by input name (the
#: rest keep the run's): a released Teleop button stops the vehicle within about 0.2 s
RELEASE_TIMEOUT_S = {"foxglove": 0.2}


class SubscribedDriver:
    """Publishes each Twist `deliver`ed since the previous poll (the newest, if several came).

    `deliver` may be called from any thread; it sets `next_poll_step` to ASAP so the loop takes
    the command at its next step instead of waiting for the next input tick. `received` counts
    what arrived, `dropped` what was superseded before a poll and `rejected` what was malformed
    (goals: `goals_received`, `goals_rejected`).
    """

    next_poll_step = NEVER
    finished = False  # a live input never runs out
    #: `next_poll_step` changes from another thread, at any moment: the loop looks at it every step
    polled_anytime = True

    def __init__(
        self,
        name: str,
        topic: str = "/quad_cmd_twist",
        command_timeout_s: float | None = None,
        goal_topics: tuple[str, ...] = GOAL_TOPICS,
        body_frame: str = "base_link",
    ) -> None:
        """`command_timeout_s`: hold after this long without a message (None: the input's own,
        RELEASE_TIMEOUT_S, else the run's); `goal_topics`: where it takes goals (the contract's
        names of GOAL_TOPICS, under the vehicle's name in a fleet); `body_frame`: the vehicle's
        base_link as TF names it (NAME/base_link in a fleet), a frame goals may come in."""
        self.name = name
        self.command_timeout_s = command_timeout_s if command_timeout_s is not None else RELEASE_TIMEOUT_S.get(name)
        #: the contract's name of the topic (what the recording keeps the commands on)
        self.topic = topic
        #: the name it has where the Twists come from: on a ROS 2 graph, in the bridge's namespace and
        #: remapped (--ros-namespace, --ros-remap), as the bridge subscribes to it; what lines say
        self.heard_on = topic
        self.goal_topics = goal_topics
        self.body_frame = body_frame
        self.goals_received = 0
        self.goals_rejected = 0
        self._goal: Goal | None = None
        self.received = 0
        self.dropped = 0
        self.rejected = 0
        self._lock = threading.Lock()
        self._pending: Twist | None = None

    def deliver(self, linear: tuple[float, float, float], angular_z: float) -> bool:
        """A message arrived: linear x, y, z and angular z of a geometry_msgs/Twist (angular x
        and y are not part of the command). Returns False, and keeps nothing, for a message
        with a field that is not a finite number."""
        try:
            twist = Twist(
                linear_x=float(linear[0]),
                linear_y=float(linear[1]),
                linear_z=float(linear[2]),
                angular_z=float(angular_z),
            )
        except (TypeError, ValueError, IndexError):
            twist = None
        with self._lock:
            if twist is None or not all(math.isfinite(v) for v in twist):
                self.rejected += 1
                return False
            self.received += 1
            if self._pending is not None:
                self.dropped += 1
            self._pending = twist
            self.next_poll_step = ASAP
        return True

    def deliver_goal(
        self,
        frame_id: str,
        position: tuple[float, float, float],
        orientation_xyzw: tuple[float, float, float, float],
    ) -> str | None:
        """A goal pose arrived (a PoseStamped's frame, position and orientation): flown from the
        next step. None, or why it is not a goal (it is then ignored)."""
        try:
            goal = goal_from_pose(frame_id, position, orientation_xyzw, self.body_frame)
        except (TypeError, ValueError) as exc:
            with self._lock:
                self.goals_rejected += 1
            return str(exc)
        with self._lock:
            self.goals_received += 1
            self._goal = goal
            self.next_poll_step = ASAP
        return None

    def take_goal(self) -> Goal | None:
        """The newest goal delivered since the last call (the loop's, at a poll), or None."""
        with self._lock:
            goal, self._goal = self._goal, None
        return goal

    def poll(self, step: int, time_s: float) -> Twist | None:
        with self._lock:
            twist, self._pending = self._pending, None
            self.next_poll_step = NEVER
        return twist

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "topic": self.topic}
