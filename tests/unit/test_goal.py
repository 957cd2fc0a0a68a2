"""Goals (quadsim.drivers.goal): what a goal pose means, and what is refused; the pilot's
command toward it, in the heading frame, in both z-modes."""

from __future__ import annotations

import math

import pytest

from quadsim.core.types import HEIGHT_MODE_BASE_M, VehicleState, ZMode
from quadsim.drivers.goal import (
    MAX_GOAL_M,
    TAKEOFF_ALTITUDE_M,
    Goal,
    GoalPilot,
    goal_from_pose,
)
from quadsim.drivers.scripted import ScriptedDriver, parse_script
from quadsim.drivers.subscribed import GOAL_TOPICS, SubscribedDriver
from quadsim.errors import ScriptError
from quadsim.live.foxglove import pose_from_json
from quadsim.recording.contract import GOALS
from quadsim.vehicle.params import CommandLimits

LIMITS = CommandLimits(2.0, 1.5, 1.0, 1.5, 0.3, 50.0)


def _yawed(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def _state(x: float, y: float, z: float, yaw: float, velocity=(0.0, 0.0, 0.0)) -> VehicleState:
    return VehicleState(0, (x, y, z), _yawed(yaw), velocity, (0.0, 0.0, 0.0), (0.0,) * 4, (0.0, 0.0, 9.81))


def test_a_goal_pose_is_a_place_and_a_heading_in_the_world() -> None:
    goal = goal_from_pose("map", (1.0, -2.0, 1.5), _yawed(math.radians(120)))
    assert goal.x == 1.0 and goal.y == -2.0 and goal.z == 1.5
    assert math.degrees(goal.yaw) == pytest.approx(120.0)
    # RViz's 2D Goal Pose and Foxglove's publish pose lie on the ground plane: keep the altitude
    assert goal_from_pose("world", (1.0, 2.0, 0.0), _yawed(0.0)).z is None
    # an unnormalised quaternion is the same heading; a zero one keeps the heading
    assert goal_from_pose("/odom", (0.0, 0.0, 1.0), (0.0, 0.0, 2.0, 2.0)).yaw == pytest.approx(math.pi / 2)
    assert goal_from_pose("", (0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0)).yaw is None


@pytest.mark.parametrize(
    ("frame", "position", "orientation", "said"),
    [
        ("front_camera_optical", (1.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), "world frame"),
        ("bravo/base_link", (1.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), "or in base_link"),
        ("world", (math.nan, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), "finite"),
        ("world", (0.0, math.inf, 1.0), (0.0, 0.0, 0.0, 1.0), "finite"),
        ("world", (0.0, 0.0, 1.0), (0.0, 0.0, math.inf, 1.0), "orientation"),
        ("world", (2 * MAX_GOAL_M, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), "farther"),
    ],
)
def test_what_is_not_a_goal_is_refused_with_its_reason(frame, position, orientation, said) -> None:
    with pytest.raises(ValueError, match=said):
        goal_from_pose(frame, position, orientation)
    driver = SubscribedDriver("ros2")
    assert said in (driver.deliver_goal(frame, position, orientation) or "")
    assert driver.take_goal() is None and (driver.goals_rejected, driver.rejected) == (1, 0)


def test_a_goal_in_the_vehicles_own_frame_is_taken_from_where_it_is_and_its_heading() -> None:
    """What Foxglove's 3D panel sends while it follows the vehicle: its display frame, base_link."""
    goal = goal_from_pose("alpha/base_link", (2.0, 1.0, 0.0), _yawed(math.radians(30)), "alpha/base_link")
    assert goal.relative and goal.z is None
    pilot = GoalPilot(LIMITS)
    # facing +y at (1, 1), 1.5 m up: 2 m ahead and 1 m left is (0, 3), the heading 90 + 30 deg
    flown = pilot.start(goal, _state(1.0, 1.0, 1.5, math.pi / 2), on_ground=False)
    assert flown.x == pytest.approx(0.0) and flown.y == pytest.approx(3.0) and flown.z == pytest.approx(1.5)
    assert math.degrees(flown.yaw) == pytest.approx(120.0) and not flown.relative
    # a height in base_link is over the vehicle's; no orientation keeps its heading
    up = goal_from_pose("base_link", (0.0, 0.0, 0.5), (0.0, 0.0, 0.0, 0.0))
    held = pilot.start(up, _state(1.0, 1.0, 1.5, 0.4), on_ground=False)
    assert held[:3] == (1.0, 1.0, 2.0) and held.yaw == pytest.approx(0.4)


def test_the_newest_goal_delivered_is_taken_once() -> None:
    driver = SubscribedDriver("foxglove")
    assert driver.deliver_goal("world", (1.0, 0.0, 1.0), _yawed(0.0)) is None
    assert driver.deliver_goal("world", (2.0, 0.0, 1.0), _yawed(0.0)) is None
    assert driver.next_poll_step == 0  # ASAP: flown from the next step
    assert driver.take_goal() == Goal(2.0, 0.0, 1.0, 0.0)
    assert driver.take_goal() is None and driver.goals_received == 2
    assert tuple(t.name for t in GOALS) == GOAL_TOPICS


def test_the_pilot_flies_toward_the_goal_in_the_heading_frame() -> None:
    pilot = GoalPilot(LIMITS)
    # facing +y, a goal 1 m along +x is to the right: negative linear.y
    state = _state(0.0, 0.0, 1.0, math.pi / 2)
    flown = pilot.start(Goal(1.0, 0.0, 2.0, math.pi / 2 + 0.2), state, on_ground=False)
    assert flown == Goal(1.0, 0.0, 2.0, math.pi / 2 + 0.2)
    twist = pilot.command(state, ZMode.VELOCITY)
    assert twist.linear_x == pytest.approx(0.0, abs=1e-12) and twist.linear_y < 0.0
    assert twist.linear_z > 0.0 and twist.angular_z > 0.0
    assert not pilot.reached
    # in height z-mode linear.z is the altitude wanted, over its 2 m base
    assert pilot.command(state, ZMode.HEIGHT).linear_z == pytest.approx(2.0 - HEIGHT_MODE_BASE_M)
    # far away, no faster than the cruise speed, whatever the gain
    pilot.start(Goal(500.0, 0.0, 1.0, 0.0), _state(0.0, 0.0, 1.0, 0.0), on_ground=False)
    far = pilot.command(_state(0.0, 0.0, 1.0, 0.0), ZMode.VELOCITY)
    assert math.hypot(far.linear_x, far.linear_y) == pytest.approx(2.0)
    # turning the short way round: from 170 deg to -170 deg is +20 deg
    pilot.start(Goal(0.0, 0.0, 1.0, math.radians(-170)), _state(0.0, 0.0, 1.0, math.radians(170)), on_ground=False)
    assert pilot.command(_state(0.0, 0.0, 1.0, math.radians(170)), ZMode.VELOCITY).angular_z > 0.0


def test_the_pilot_says_reached_only_there_aligned_and_slow() -> None:
    pilot = GoalPilot(LIMITS)
    pilot.start(Goal(1.0, 1.0, 1.0, 0.0), _state(0.0, 0.0, 0.1, 0.0), on_ground=True)
    pilot.command(_state(1.0, 1.0, 1.0, 0.0, velocity=(0.5, 0.0, 0.0)), ZMode.VELOCITY)
    assert not pilot.reached  # still moving
    pilot.command(_state(1.0, 1.0, 1.0, math.radians(5)), ZMode.VELOCITY)
    assert not pilot.reached  # not facing the goal's heading
    pilot.command(_state(1.03, 0.98, 1.01, math.radians(1)), ZMode.VELOCITY)
    assert pilot.reached


def test_an_open_altitude_and_heading_are_taken_where_the_goal_starts() -> None:
    pilot = GoalPilot(LIMITS)
    assert pilot.start(Goal(1.0, 1.0), _state(0.0, 0.0, 0.05, 0.7), on_ground=True) == Goal(
        1.0, 1.0, TAKEOFF_ALTITUDE_M, 0.7
    )
    assert pilot.start(Goal(1.0, 1.0), _state(0.0, 0.0, 3.2, -0.3), on_ground=False).z == pytest.approx(3.2)
    # no lower than the lowest altitude held, no higher than the highest
    assert pilot.start(Goal(1.0, 1.0, 0.0), _state(0.0, 0.0, 1.0, 0.0), on_ground=False).z == LIMITS.min_altitude_m
    assert pilot.start(Goal(1.0, 1.0, 900.0), _state(0.0, 0.0, 1.0, 0.0), on_ground=False).z == LIMITS.max_altitude_m


def test_foxglove_json_goals_are_read_field_by_field() -> None:
    text = b'{"header": {"frame_id": "world"}, "pose": {"position": {"x": 1, "y": -2.5}, "orientation": {"w": 1}}}'
    assert pose_from_json(text) == ("world", (1.0, -2.5, 0.0), (0.0, 0.0, 0.0, 1.0))
    for bad in (b"[]", b'{"pose": {"position": {"x": "far"}}}', b'{"header": {"frame_id": 3}}', b"{"):
        with pytest.raises(ValueError):
            pose_from_json(bad)


#: what Foxglove Studio 1.48's 3D panel sent for "publish pose" (clicks on its ground grid while it
#: followed the vehicle), as the page sent it: JSON on /move_base_simple/goal, schema
#: geometry_msgs/PoseStamped, a ROS 1 style stamp (nsec), the panel's display frame
STUDIO_148_POSE = (
    b'{"header":{"stamp":{"sec":1795872013,"nsec":616000000},"frame_id":"base_link"},"pose":{"position":'
    b'{"x":-0.027825911996732566,"y":2.5810688071896983,"z":0},"orientation":{"x":0,"y":0,'
    b'"z":-0.9058956783665475,"w":0.42350090899171966}}}'
)


def test_studio_148s_publish_pose_is_a_goal_from_where_the_vehicle_is() -> None:
    driver = SubscribedDriver("foxglove")
    assert driver.deliver_goal(*pose_from_json(STUDIO_148_POSE)) is None
    goal = driver.take_goal()
    assert goal is not None and goal.relative and goal.z is None  # on the panel's ground: keep the altitude
    # from the ground at the origin, facing +x: take off to 1 m and fly 2.6 m left, turned to -130 deg
    flown = GoalPilot(LIMITS).start(goal, _state(0.0, 0.0, 0.05, 0.0), on_ground=True)
    assert flown.describe() == "x=-0.03 y=2.58 z=1.00 yaw=-129.9deg"


def test_a_script_goto_line_gives_its_goal_once_when_it_starts() -> None:
    script = parse_script("2.0 linear.z=1\n5.0 goto x=3 y=-1 yaw_deg=90\n1.0 linear.x=1\n")
    assert script.segments[1].goal == Goal(3.0, -1.0, None, math.radians(90))
    assert script.duration_s == 8.0
    driver = ScriptedDriver(script)
    assert driver.poll(0, 0.0) is not None and driver.take_goal() is None
    assert driver.poll(48, 2.0) is None and driver.take_goal() == script.segments[1].goal
    assert driver.poll(60, 2.5) is None and driver.take_goal() is None  # once
    driver.rewind()
    driver.poll(48, 2.0)
    assert driver.take_goal() == script.segments[1].goal  # again after a rewind


@pytest.mark.parametrize(
    ("line", "said"),
    [
        ("3 goto y=1", "needs x= and y="),
        ("3 goto x=1 y=1 w=2", "FIELD one of x, y, z, yaw_deg"),
        ("3 goto x=1 y=1 x=2", "given twice"),
        ("3 goto x=nan y=1", "finite"),
        ("0 goto x=1 y=1", "duration must be > 0"),
        ("3 goto x=1e9 y=1", "farther than"),
    ],
)
def test_a_bad_goto_line_is_refused_naming_the_line(line: str, said: str) -> None:
    with pytest.raises(ScriptError, match=said) as raised:
        parse_script(f"1.0 linear.z=1\n{line}\n")
    assert "line 2" in str(raised.value)
