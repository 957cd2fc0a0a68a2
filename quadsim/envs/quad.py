"""The Gymnasium environments: a Simulator wrapped (not subclassed) as an agent acting at 30 Hz.

Action (both): the Twist, Box(4) = (linear.x, linear.y, linear.z climb rate, angular.z) in the
heading frame, within the vehicle's command limits. It goes through the same command gate as
every driver (clamping, dead-man timeout): the agent is the programmatic driver publishing at
the agent rate, and each env step is 240 / 30 = 8 physics steps.

Termination: leaving the arena (ARENA_HALF_M around the origin, ARENA_TOP_M high), tipping over
(tilt beyond MAX_TILT_DEG; these and the arithmetic in quadsim.envs.hover_numbers), or a crash (the simulator's crash event: a contact other than a
landing, with a wall or the ground at speed or tilted). Truncation: the time limit of the
registration (gymnasium's TimeLimit).

Randomness: `reset(seed=...)` seeds the start pose and the run's seed, from which the wind's
turbulence and the IMU noise derive (`gymnasium.make("quadsim/Hover-v0",
wind=WindSettings(3.0, 90.0, Turbulence.LIGHT))`: a wind for every episode, its gusts drawn
from the episode's seed).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from quadsim.control import Controller
from quadsim.core.compiled import python_of
from quadsim.core.kinematics import body_velocity
from quadsim.core.types import StartPose, Twist, VehicleState, ZMode
from quadsim.envs.hover_numbers import (
    ARENA_HALF_M,
    ARENA_TOP_M,
    HOVER_ROW,
    hover_row,
    outside_arena,
    tipped_over,
)
from quadsim.envs.hover_numbers import hover_reward as _reward_at
from quadsim.envs.sensors import SensorObservation, sensor_names, sim_options
from quadsim.errors import QuadsimError
from quadsim.physics.wind import WindModel, WindSettings
from quadsim.sensors.camera import CameraSpec
from quadsim.sim.cameras import Cameras
from quadsim.sim.config import MAX_SEED, Rates, SimConfig
from quadsim.sim.flight_events import EventKind
from quadsim.sim.simulator import Simulator

AGENT_HZ = 30
HOVER_EPISODE_S = 10
TOWER_EPISODE_S = 20
#: observation bounds for speeds and body rates (a falling or tumbling vehicle stays within them)
MAX_SPEED_MPS = 50.0
MAX_RATE_RADPS = 100.0
#: what render() shows: the front camera, small
VIEW = CameraSpec("front", "front_camera_link", 160, 120, rate_hz=AGENT_HZ)


class QuadEnv(gym.Env):
    """What both environments share: the simulator, the action, termination, rendering."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": AGENT_HZ}  # noqa: RUF012 - gymnasium declares it so

    def __init__(
        self,
        render_mode: str | None = None,
        wind: WindSettings | WindModel | None = None,
        controller: Controller | None = None,
        sensors: Iterable[str] | str = (),
    ) -> None:
        """`wind`: WindSettings, or a wind of your own (a WindModel); `controller`: a controller
        of your own (the Controller protocol) in place of the cascade; `sensors`: what the
        observation adds, of quadsim.envs.sensors.SENSORS ("depth", "range", "scan", "scan3d")."""
        names = sensor_names(sensors)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        config, model = agent_config(wind, names)
        self.sim = Simulator(config, controller=controller, wind=model)
        self.steps_per_action = config.rates.physics_hz // AGENT_HZ
        self._scale = ActionScale(self.sim.vehicle.limits)
        self.action_space: spaces.Box = spaces.Box(-1.0, 1.0, (4,), np.float32)
        self._view: Cameras | None = None
        self._events_before = 0
        #: the sensors the observation adds (None: none)
        self.sensors = SensorObservation(self.sim.drone, names, self.sim) if names else None
        self._setup()

    # --- what the subclasses say ----------------------------------------------------------

    def _setup(self) -> None:
        """The task's own part of the env: its observation space, and what it keeps."""
        raise NotImplementedError

    def _start(self, rng: np.random.Generator) -> tuple[float, float, float]:
        """A random start of an episode: x, y (m) and heading (rad); reset's options
        "start_xy_m" and "start_yaw_rad" choose them instead."""
        raise NotImplementedError

    def _observe(self, state: VehicleState) -> Any:
        raise NotImplementedError

    def _reward(self, state: VehicleState) -> tuple[float, bool]:
        """(reward, task done) for the state after an action."""
        raise NotImplementedError

    # --- the Gymnasium API ----------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        chosen = chosen_start(options)  # refused before anything changes
        super().reset(seed=seed)
        self._check_open()
        x, y, yaw = self._start(self.np_random)
        x, y = chosen.get("start_xy_m", (x, y))
        self.sim.physics.start = StartPose(float(x), float(y), float(chosen.get("start_yaw_rad", yaw)))
        self.sim.reset(seed=int(self.np_random.integers(MAX_SEED)))  # gusts and sensor noise
        self.sim.send(Twist())
        state = self.sim.state
        self._after_reset()
        return self._observe(state), agent_info(state)

    def _after_reset(self) -> None:
        if self._view is not None:
            self._view.capture_now()
        if self.sensors is not None:
            self.sensors.reset()

    def twist_of(self, action: Any) -> np.ndarray:
        """The command an action stands for: forward, left, climb (m/s) and yaw rate (rad/s)."""
        return self._scale.twist_of(action)

    def action_of(self, forward_mps: float, left_mps: float, climb_mps: float, yaw_rate_radps: float) -> np.ndarray:
        """The action that commands these velocities (clipped to the limits): for policies
        written by hand in m/s and rad/s."""
        return self._scale.action_of(forward_mps, left_mps, climb_mps, yaw_rate_radps)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        self._check_open()
        state = self.fly(self._scale.command(action))
        reward, ended = self.judge(state)
        return self._observe(state), reward, ended, False, agent_info(state)

    def fly(self, twist: Twist, taken: int = 0) -> VehicleState:
        """The vehicle flown for one agent step under `twist` (the command an action stands for):
        the state after it. What `step` does before judging it (a vector env does it for each of
        its envs). `taken`: steps of this agent step already flown under `twist`, sent and
        received (a vector env flew them with its other envs)."""
        if not taken:
            self.sim.send(twist)
        self._events_before = len(self.sim.events)
        return self.sim.step(self.steps_per_action - taken)

    def judge(self, state: VehicleState) -> tuple[float, bool]:
        """The reward of the agent step that ended in `state`, and whether the episode ends
        (the task done, a crash during the step, out of the arena, tipped over)."""
        reward, done = self._reward(state)
        crashed = any(e.kind is EventKind.CRASH for e in self.sim.events[self._events_before :])
        failed = crashed or self.out_of_arena(state) or self.tipped_over(state)
        if failed:
            reward -= 10.0
        return reward, done or failed

    def _check_open(self) -> None:
        if self.sim.closed:
            raise gym.error.ClosedEnvironmentError("this environment is closed: make a new one with gymnasium.make")

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        self._check_open()
        if self._view is None:
            self._view = Cameras(self.sim, (VIEW,))
        image = self._view.latest("front")
        assert image is not None  # SYNC cameras always have one
        return image.rgb.copy()  # the caller's to change: the camera's own stays as it was

    def close(self) -> None:
        if self._view is not None:
            self._view.close()
            self._view = None
        if self.sensors is not None:
            self.sensors.close()
        self.sim.close()

    # --- termination ------------------------------------------------------------------------

    @staticmethod
    def out_of_arena(state: VehicleState) -> bool:
        """Beyond ARENA_HALF_M of the origin in x or y, or above ARENA_TOP_M."""
        return bool(_outside(state.position_m))

    @staticmethod
    def tipped_over(state: VehicleState) -> bool:
        """Tilted past MAX_TILT_DEG."""
        return bool(_tipped(*state.roll_pitch_rad()))


class HoverEnv(QuadEnv):
    """quadsim/Hover-v0: take off from a random start and reach and hold a target position.

    Action, Box(4) in [-1, 1]: forward, left, climb and yaw rate as fractions of the command
    limits (QuadEnv.twist_of, action_of). Observation, Box(15) float32, bounded (clipped to the
    bounds): position (3, m, world), velocity (3, m/s, world), roll, pitch,
    yaw (rad), body rates (3, rad/s), target position (3, m, world). Reward per step: minus the
    distance to the target (m) and a little of the speed. Starts on the ground at x and y each
    uniform in [-1, 1] m, any heading; the target's x and y are each uniform in [-2, 2] m, its
    height in [1, 2.5] m; reset's options "start_xy_m" and "start_yaw_rad" choose the start instead.

    With `sensors` (quadsim.envs.sensors), the observation is a Dict: "state", the Box(15), and a
    Box for each sensor."""

    def _setup(self) -> None:
        self._space = hover_observation_space()
        self.observation_space: spaces.Box | spaces.Dict = self._space
        if self.sensors is not None:
            self.observation_space = spaces.Dict({"state": self._space, **self.sensors.spaces()})
        self.target_m = np.zeros(3)

    def _start(self, rng: np.random.Generator) -> tuple[float, float, float]:
        self.target_m = np.array([rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(1.0, 2.5)])
        return rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-math.pi, math.pi)

    def _observe(self, state: VehicleState) -> np.ndarray | dict[str, np.ndarray]:
        return hover_observation(state, self.target_m, self._space, self.sensors)

    def _reward(self, state: VehicleState) -> tuple[float, bool]:
        return hover_reward(state, self.target_m), False


#: what `reset(options=...)` takes
RESET_OPTIONS = ("start_xy_m", "start_yaw_rad")


def chosen_start(options: Any) -> dict[str, Any]:
    """What reset's `options` choose of the start, as floats: "start_xy_m" (two numbers, m) and
    "start_yaw_rad". ValueError for anything else: an unknown option, or a start that is not
    finite numbers within any world."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"reset's options are a dict (of {', '.join(RESET_OPTIONS)}), got {_shown(options)}")
    unknown = sorted(str(key) for key in options if key not in RESET_OPTIONS)
    if unknown:
        raise ValueError(
            f"unknown reset option {', '.join(map(repr, unknown))}: the options are {', '.join(RESET_OPTIONS)}"
        )
    chosen: dict[str, Any] = {}
    if "start_xy_m" in options:
        xy = options["start_xy_m"]
        numbers = np.asarray(xy) if isinstance(xy, (tuple, list, np.ndarray)) else np.array(None)
        if numbers.shape != (2,) or numbers.dtype.kind not in "iuf" or not np.isfinite(numbers).all():
            raise ValueError(f"options['start_xy_m'] is two finite numbers (x, y in m), got {_shown(xy)}")
        chosen["start_xy_m"] = (float(numbers[0]), float(numbers[1]))
    if "start_yaw_rad" in options:
        yaw = options["start_yaw_rad"]
        if (
            isinstance(yaw, bool)
            or not isinstance(yaw, (int, float, np.integer, np.floating))
            or not math.isfinite(yaw)
        ):
            raise ValueError(f"options['start_yaw_rad'] is a finite number (rad), got {_shown(yaw)}")
        chosen["start_yaw_rad"] = float(yaw)
    try:
        x_m, y_m = chosen.get("start_xy_m", (0.0, 0.0))
        StartPose(x_m, y_m, chosen.get("start_yaw_rad", 0.0))
    except QuadsimError as e:  # beyond any world
        raise ValueError(str(e)) from None
    return chosen


def agent_info(state: VehicleState) -> dict[str, Any]:
    """An agent step's info: the simulation step and the position."""
    return {"step": state.step, "position_m": np.array(state.position_m)}


def agent_config(wind: WindSettings | WindModel | None, names: tuple[str, ...]) -> tuple[SimConfig, WindModel | None]:
    """The simulation of an agent's vehicle, with `wind` (WindSettings, or a model of one's own:
    returned beside) and the sensors `names`. Commands are polled at the agent rate: an action
    reaches the gate at its first physics step."""
    settings = wind if isinstance(wind, WindSettings) else WindSettings()
    config = SimConfig(z_mode=ZMode.VELOCITY, rates=Rates(input_hz=AGENT_HZ), wind=settings, **sim_options(names))
    return config, None if wind is None or isinstance(wind, WindSettings) else wind


def _shown(action: Any) -> str:
    """An action as an error shows it: on one line (an array's repr spans lines), short. Made
    only for an error: an array's repr costs about a fifth of the env's whole step."""
    return " ".join(repr(action).split())[:60]


class ActionScale:
    """Actions in [-1, 1] (what learning libraries expect), scaled to the command limits; climb
    and descent have limits of their own, so 1 and -1 are each one's full rate."""

    def __init__(self, limits: Any) -> None:
        v, yaw = limits.max_horizontal_speed_mps, limits.max_yaw_rate_radps
        self._up = np.array([v, v, limits.max_climb_rate_mps, yaw])
        self._down = np.array([v, v, limits.max_descent_rate_mps, yaw])

    def twist_of(self, action: Any, shape: tuple[int, ...] = (4,)) -> np.ndarray:
        """The commands `action` stands for: forward, left, climb (m/s) and yaw rate (rad/s), in
        an array of `shape` (a vector env's actions: (number of envs, 4))."""
        try:
            given = np.asarray(action)
        except (TypeError, ValueError):  # a ragged list
            given = np.array(None)
        if given.shape != shape or given.dtype.kind not in "iuf":  # not None, text, complex or True
            what = "an action is 4 real numbers" if shape == (4,) else f"actions are {shape[0]} rows of 4 real numbers"
            raise ValueError(
                f"{what} in [-1, 1] (forward, left, climb, yaw rate), shape {shape}; got {_shown(action)}"
                + (f" of shape {given.shape}" if given.ndim else "")
            )
        a = given.astype(np.float64)
        if not np.isfinite(a).all():
            raise ValueError(f"an action must be finite numbers (each is clipped to [-1, 1]), got {_shown(action)}")
        a = np.minimum(np.maximum(a, -1.0), 1.0)
        return a * np.where(a >= 0, self._up, self._down)

    def command(self, action: Any) -> Twist:
        return twist_command(self.twist_of(action).tolist())

    def action_of(self, forward_mps: float, left_mps: float, climb_mps: float, yaw_rate_radps: float) -> np.ndarray:
        t = np.array([forward_mps, left_mps, climb_mps, yaw_rate_radps], np.float64)
        if not np.isfinite(t).all():
            raise ValueError(f"velocities must be finite numbers, got {t.tolist()}")
        return np.clip(np.where(t >= 0, t / self._up, t / self._down), -1.0, 1.0).astype(np.float32)


def twist_command(values: list[float]) -> Twist:
    """The Twist of ActionScale.twist_of's four values (forward, left, climb, yaw rate)."""
    forward, left, climb, yaw_rate = values
    return Twist(linear_x=forward, linear_y=left, linear_z=climb, angular_z=yaw_rate)


def hover_observation_space() -> spaces.Box:
    """Box(15): position, velocity, roll, pitch, yaw, body rates, target; bounds past anything an
    episode reaches before it ends (the arena, a tumble), so every observation is inside them
    (observations are clipped to them all the same)."""
    reach, top, speed, rate, pi = ARENA_HALF_M + 10.0, ARENA_TOP_M + 10.0, MAX_SPEED_MPS, MAX_RATE_RADPS, math.pi
    low = [-reach, -reach, -1.0, -speed, -speed, -speed, -pi, -pi, -pi, -rate, -rate, -rate]
    high = [reach, reach, top, speed, speed, speed, pi, pi, pi, rate, rate, rate]
    low += [-ARENA_HALF_M, -ARENA_HALF_M, 0.0]  # the target
    high += [ARENA_HALF_M, ARENA_HALF_M, ARENA_TOP_M]
    return spaces.Box(np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32)


def hover_observation(
    state: VehicleState, target_m: np.ndarray, space: spaces.Box, sensors: SensorObservation | None = None
) -> np.ndarray | dict[str, np.ndarray]:
    """The observation of `state` with the target `target_m`, clipped to `space` (Box(15)); with
    `sensors`, a dict of it ("state") and their readings."""
    observation = hover_observations([hover_observation_row(state, target_m)], space)[0]
    return observation if sensors is None else {"state": observation, **sensors.observe(state)}


def hover_observation_row(state: VehicleState, target_m: Any) -> list[float]:
    """An observation's 15 numbers, before clipping: position, velocity, roll, pitch, yaw, body
    rates, target (quadsim.envs.hover_numbers.hover_row)."""
    row = [0.0] * HOVER_ROW
    _row(
        state.position_m,
        state.orientation_xyzw,
        state.linear_velocity_mps,
        state.angular_velocity_body_rps,
        target_m,
        row,
    )
    return row


def hover_observations(rows: list[list[float]], space: spaces.Box) -> np.ndarray:
    """Observations of several envs at once (one per row of hover_observation_row), as float32
    clipped to `space`."""
    return np.minimum(np.maximum(np.array(rows, np.float32), space.low), space.high)


def hover_reward(state: VehicleState, target_m: Any) -> float:
    """Minus the distance to the target (m) and a little of the speed."""
    return float(_reward(state.position_m, state.linear_velocity_mps, target_m))


# Hover-v0's arithmetic as Python, for one state at a time (a compiled call from Python costs more than the work)
_row = python_of(hover_row)
_reward = python_of(_reward_at)
_outside = python_of(outside_arena)
_tipped = python_of(tipped_over)


class TowerVisionEnv(QuadEnv):
    """quadsim/TowerVision-v0: fly to the red tower, seen through the front camera.

    Observation, Dict: "image" (64 x 64 x 3 uint8, the front camera at the agent's step) and
    "velocity" (3, m/s, in base_link). Reward per step: the metres closed on the tower's face;
    +10 and the end of the episode on stopping within 1.5 m of it. Starts on the ground within
    1 m of the origin, heading within 20 deg of the tower (6 m ahead: in view); reset's options
    "start_xy_m" and "start_yaw_rad" choose them instead. With `sensors` (quadsim.envs.sensors),
    the Dict has a Box for each sensor too."""

    IMAGE = CameraSpec("front", "front_camera_link", 64, 64, rate_hz=AGENT_HZ)

    def _setup(self) -> None:
        self.observation_space = spaces.Dict(
            {
                "image": spaces.Box(0, 255, (64, 64, 3), np.uint8),
                "velocity": spaces.Box(-MAX_SPEED_MPS, MAX_SPEED_MPS, (3,), np.float32),
                **(self.sensors.spaces() if self.sensors is not None else {}),
            }
        )
        tower = next(lm for lm in self.sim.world.landmarks if lm.name == "red_tower")
        self._tower = (tower.position_m, tower.size_m)
        self.cameras = Cameras(self.sim, (self.IMAGE,))
        self._distance_m = 0.0

    def distance_to_tower_m(self, state: VehicleState) -> float:
        (tx, ty, _), (sx, sy, _) = self._tower
        x, y, _ = state.position_m
        return math.hypot(max(abs(x - tx) - sx / 2, 0.0), max(abs(y - ty) - sy / 2, 0.0))

    def _start(self, rng: np.random.Generator) -> tuple[float, float, float]:
        x, y = rng.uniform(-1, 1, 2)
        return x, y, rng.uniform(-math.radians(20), math.radians(20))

    def _after_reset(self) -> None:
        super()._after_reset()
        self.cameras.capture_now()
        self._distance_m = self.distance_to_tower_m(self.sim.state)

    def _observe(self, state: VehicleState) -> dict[str, np.ndarray]:
        image = self.cameras.latest("front")
        assert image is not None and image.step == state.step  # SYNC, captured at the agent rate
        velocity = body_velocity(state.orientation_xyzw, state.linear_velocity_mps)
        clipped = np.clip(np.array(velocity, np.float32), -MAX_SPEED_MPS, MAX_SPEED_MPS)
        observation = {"image": image.rgb, "velocity": clipped}
        return observation if self.sensors is None else {**observation, **self.sensors.observe(state)}

    def _reward(self, state: VehicleState) -> tuple[float, bool]:
        distance = self.distance_to_tower_m(state)
        closed, self._distance_m = self._distance_m - distance, distance
        arrived = distance < 1.5 and math.hypot(*state.linear_velocity_mps) < 0.2
        return closed + (10.0 if arrived else 0.0), arrived

    def close(self) -> None:
        self.cameras.close()
        super().close()
