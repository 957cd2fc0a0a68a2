"""Goals: "fly there". A goal pose becomes Twists through the command path a person's take.

A goal comes from RViz's "2D Goal Pose" or Foxglove's "publish pose" (a geometry_msgs/PoseStamped
on /goal_pose or /move_base_simple/goal), from Python (`sim.fly_to(...)`) or from a script's
`goto` line. The flight loop holds at most one goal per vehicle and, at every input tick while it
has one and its driver says nothing, asks `GoalPilot` for the Twist to publish: a proportional
position controller in the heading frame (command semantics: docs/reference/command-semantics.md),
which the gate then clamps to the vehicle's limits like any other command. The first Twist from
the driver (a person's key, a node's message) ends the goal at once. Reaching it (within
REACHED_M and REACHED_RAD, slowed below REACHED_SPEED_MPS) is an event; the pilot goes on holding
the vehicle there until another goal or a Twist comes.

Goals are in the world frame (REP 105's map and odom are the same frame here: quadsim's world has
no drift), their heading the yaw of their orientation; or in the vehicle's own base_link, what
Foxglove's 3D panel sends while it follows the vehicle (its display frame): then they are taken
relative to where the vehicle is and its heading when the goal arrives (roll and pitch left out:
a click on the panel's ground grid is a place at the vehicle's altitude). A 2D goal (z exactly 0,
what both panels send) keeps the altitude the vehicle flies at, or takes off to
TAKEOFF_ALTITUDE_M from the ground.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from quadsim.core.kinematics import clamp, yaw_of
from quadsim.core.types import HEIGHT_MODE_BASE_M, Twist, VehicleState, ZMode
from quadsim.vehicle.params import CommandLimits

#: frames a goal may be given in: all are quadsim's world ("" is what a bare message says)
WORLD_FRAMES = frozenset({"", "world", "map", "odom"})
#: the altitude a 2D goal (z = 0) flies at when the vehicle is on the ground
TAKEOFF_ALTITUDE_M = 1.0
#: reached: this close, this well aligned and this slow (holding it stays well inside 0.1 m, 5 deg)
REACHED_M = 0.05
REACHED_RAD = math.radians(2.0)
REACHED_SPEED_MPS = 0.1
#: the pilot's gains: commanded velocity per metre to go, heading rate per radian to turn
POSITION_GAIN = 1.5
CLIMB_GAIN = 1.5
HEADING_GAIN = 1.5
#: the fastest the pilot asks to fly (the vehicle's own limits may be lower; the gate clamps)
CRUISE_SPEED_MPS = 2.0
#: the largest goal coordinate taken (a goal 10 km away is a typo, not a flight)
MAX_GOAL_M = 10_000.0


def _wrapped(angle: float) -> float:
    """`angle` in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class Goal(NamedTuple):
    """Where to fly, world frame (`relative`: the vehicle's heading frame when it is taken): x, y
    (m), z (m; None: the altitude flown when it arrives), yaw (rad; None: the heading held when it
    arrives)."""

    x: float
    y: float
    z: float | None = None
    yaw: float | None = None
    #: given in the vehicle's heading frame (from base_link), relative to where it is when taken
    relative: bool = False

    def checked(self) -> Goal:
        """The goal with floats, or ValueError naming what is wrong (a coordinate that is not a
        finite number, or farther than MAX_GOAL_M)."""
        for name, value in zip(self._fields[:4], self[:4]):
            if value is None and name in ("z", "yaw"):
                continue  # left open
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"goal {name} must be a number, got {type(value).__name__}: {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"goal {name} must be finite, got {value}")
            if name != "yaw" and abs(value) > MAX_GOAL_M:
                raise ValueError(f"goal {name} = {value} m is farther than {MAX_GOAL_M:g} m")
        x, y, z, yaw = (None if value is None else float(value) for value in self[:4])
        assert x is not None and y is not None  # only z and yaw may be open
        return Goal(x, y, z, yaw, bool(self.relative))

    def describe(self) -> str:
        """For /rosout and a person: x=1.00 y=2.00 z=1.50 yaw=90.0deg."""
        z = "here" if self.z is None else f"{self.z:.2f}"
        yaw = "held" if self.yaw is None else f"{math.degrees(self.yaw):.1f}deg"
        return f"x={self.x:.2f} y={self.y:.2f} z={z} yaw={yaw}"


def goal_from_pose(
    frame_id: str,
    position: tuple[float, float, float],
    orientation_xyzw: tuple[float, float, float, float],
    body_frame: str = "base_link",
) -> Goal:
    """A PoseStamped's goal: in the world, or relative to the vehicle when in its `body_frame`
    (a fleet vehicle's is NAME/base_link). ValueError for another frame, or numbers that are not
    a goal (see Goal.checked); a zero quaternion keeps the heading; z = 0 keeps the altitude."""
    frame = frame_id.lstrip("/")
    if frame not in WORLD_FRAMES and frame != body_frame:
        shown = frame_id if len(frame_id) <= 64 else frame_id[:61] + "..."
        raise ValueError(f"goals are taken in the world frame (world, map or odom) or in {body_frame}, not {shown!r}")
    x, y, z = position
    qx, qy, qz, qw = orientation_xyzw
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not math.isfinite(norm):
        raise ValueError("the goal's orientation is not finite")
    yaw = yaw_of((qx / norm, qy / norm, qz / norm, qw / norm)) if norm > 1e-9 else None
    return Goal(x, y, None if z == 0.0 else z, yaw, relative=frame == body_frame).checked()


class GoalPilot:
    """Turns the goal and the vehicle's state into the Twist to publish (before the gate's clamp)."""

    def __init__(self, limits: CommandLimits) -> None:
        self.limits = limits
        #: the goal flown to, its altitude and heading filled in; None: no goal
        self.goal: Goal | None = None
        self.reached = False

    def start(self, goal: Goal, state: VehicleState, on_ground: bool) -> Goal:
        """Fly to `goal` from `state` (`on_ground`: landed there): its open altitude and heading
        taken from the state. The goal as flown (what events say)."""
        px, py, pz = state.position_m
        heading = state.yaw_rad()
        x, y, z, yaw = goal.x, goal.y, goal.z, goal.yaw
        if goal.relative:  # from the vehicle's heading frame, where it is now
            c, s = math.cos(heading), math.sin(heading)
            x, y = px + c * goal.x - s * goal.y, py + s * goal.x + c * goal.y
            z = None if z is None else pz + z
            yaw = None if yaw is None else _wrapped(heading + yaw)
        if z is None:
            z = TAKEOFF_ALTITUDE_M if on_ground else pz
        z = clamp(z, self.limits.min_altitude_m, self.limits.max_altitude_m)
        self.goal = Goal(x, y, z, heading if yaw is None else yaw)
        self.reached = False
        return self.goal

    def stop(self) -> None:
        self.goal = None
        self.reached = False

    def command(self, state: VehicleState, z_mode: ZMode) -> Twist:
        """The Twist that flies toward the goal from `state`: the horizontal velocity in the
        heading frame, the climb rate (velocity z-mode) or the altitude (height z-mode), the
        heading rate. Sets `reached` once the vehicle is there (see the module's thresholds)."""
        goal = self.goal
        assert goal is not None and goal.z is not None and goal.yaw is not None
        x, y, z = state.position_m
        yaw = state.yaw_rad()
        ex, ey, ez = goal.x - x, goal.y - y, goal.z - z
        eyaw = _wrapped(goal.yaw - yaw)
        c, s = math.cos(yaw), math.sin(yaw)
        vx, vy = POSITION_GAIN * (c * ex + s * ey), POSITION_GAIN * (-s * ex + c * ey)
        speed = math.hypot(vx, vy)
        if speed > CRUISE_SPEED_MPS:
            vx, vy = vx * CRUISE_SPEED_MPS / speed, vy * CRUISE_SPEED_MPS / speed
        vz = CLIMB_GAIN * ez if z_mode is ZMode.VELOCITY else goal.z - HEIGHT_MODE_BASE_M
        if not self.reached:
            moving = math.sqrt(sum(v * v for v in state.linear_velocity_mps))
            self.reached = (
                math.sqrt(ex * ex + ey * ey + ez * ez) <= REACHED_M
                and abs(eyaw) <= REACHED_RAD
                and moving <= REACHED_SPEED_MPS
            )
        return Twist(linear_x=vx, linear_y=vy, linear_z=vz, angular_z=HEADING_GAIN * eyaw)
