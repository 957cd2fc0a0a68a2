"""A PettingZoo environment (the `marl` extra): a fleet hovering, each vehicle an agent.

    from quadsim.envs.fleet import HoverFleetEnv
    env = HoverFleetEnv(agents=3)
    observations, infos = env.reset(seed=0)
    while env.agents:
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)

A `ParallelEnv`: every agent acts at once, at 30 Hz, on one fleet (quadsim.Fleet: one world, one
clock; the vehicles collide). Each agent is the task of quadsim/Hover-v0: its action, Box(4) in
[-1, 1], is forward, left, climb and yaw rate as fractions of its command limits; its observation
is Hover-v0's, Box(15) (position, velocity, attitude, body rates, its own target); its reward is
minus its distance to its target and a little of its speed. An agent is terminated (-10) when it
crashes (into the ground, a landmark or another vehicle: both are), leaves the arena or tips over,
and truncated after `episode_s`. A finished agent leaves `agents`; its vehicle holds its last
command. Starts are on a line `spacing_m` apart, x and y each within 0.5 m of its slot; each
target's x and y are each within 1 m of its start's, its height 1 to 2.5 m.

With `sensors` (quadsim.envs.sensors: "range", "scan" or "scan3d"; "depth" is a single
vehicle's), each agent's observation is a Dict, as Hover-v0's: "state", the Box(15), and a Box
for each of its own vehicle's sensors (whose beams see the other vehicles).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from quadsim.control import Controller
from quadsim.core.invocation import install_extra
from quadsim.core.types import StartPose, Twist
from quadsim.envs.quad import (
    AGENT_HZ,
    HOVER_EPISODE_S,
    ActionScale,
    QuadEnv,
    agent_config,
    agent_info,
    hover_observation,
    hover_observation_space,
    hover_reward,
)
from quadsim.envs.sensors import SensorObservation, sensor_names
from quadsim.errors import QuadsimError
from quadsim.physics.wind import WindModel, WindSettings
from quadsim.sim.config import MAX_SEED
from quadsim.sim.fleet import Fleet, FleetVehicle
from quadsim.sim.flight_events import EventKind

try:
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError:  # pragma: no cover - depends on what is installed
    raise QuadsimError(f"the fleet environment needs PettingZoo: {install_extra('marl')}") from None


class HoverFleetEnv(ParallelEnv):
    """Each agent takes off and reaches and holds its own target, among the others (see the module)."""

    metadata = {"name": "quadsim_hover_fleet_v0", "render_modes": [], "render_fps": AGENT_HZ}  # noqa: RUF012

    def __init__(
        self,
        agents: int = 3,
        spacing_m: float = 2.0,
        episode_s: float = HOVER_EPISODE_S,
        wind: WindSettings | WindModel | None = None,
        controllers: Sequence[Controller] | None = None,
        sensors: Iterable[str] | str = (),
        render_mode: str | None = None,
    ) -> None:
        """`wind`: WindSettings, or a wind of your own (a WindModel) for every agent;
        `controllers`: a controller of your own for each agent, in order (one object each);
        `sensors`: what each agent's observation adds (see the module); `render_mode`: None (the
        fleet does not render: record it, or watch it in `quadsim fly --fleet`)."""
        if render_mode is not None:
            raise ValueError(f"the fleet environment does not render (render_mode=None), got {render_mode!r}")
        names = sensor_names(sensors, cameras=False)
        if not 1 <= agents <= 100:
            raise ValueError(f"agents must be within 1..100, got {agents}")
        if spacing_m < 1.5:
            raise ValueError(f"spacing_m must be at least 1.5 (starts within 0.5 m of their slots), got {spacing_m}")
        self.possible_agents = [f"drone_{i}" for i in range(agents)]
        self.agents: list[str] = []
        self.render_mode = None
        self._slots = [(spacing_m * (i - (agents - 1) / 2), 0.0) for i in range(agents)]
        if controllers is not None and len(controllers) != agents:
            raise ValueError(f"controllers: one for each of the {agents} agents, got {len(controllers)}")
        config, model = agent_config(wind, names)
        own = list(controllers) if controllers is not None else [None] * agents
        self.fleet = Fleet(
            [
                FleetVehicle(name, start=StartPose(x, y), controller=controller)
                for name, (x, y), controller in zip(self.possible_agents, self._slots, own)
            ],
            config,
            wind=model,
        )
        self.steps_per_action = config.rates.physics_hz // AGENT_HZ
        self.max_cycles = round(episode_s * AGENT_HZ)
        self._scale = {name: ActionScale(self.fleet[name].vehicle.limits) for name in self.possible_agents}
        self._space = hover_observation_space()
        #: each agent's sensors (none without `sensors`)
        self.sensors = {name: SensorObservation(self.fleet[name], names) for name in self.possible_agents if names}
        self._observation_spaces: dict[str, spaces.Box | spaces.Dict] = {
            name: spaces.Dict({"state": hover_observation_space(), **self.sensors[name].spaces()})
            if names
            else hover_observation_space()
            for name in self.possible_agents
        }
        self._action_spaces = {name: spaces.Box(-1.0, 1.0, (4,), np.float32) for name in self.possible_agents}
        self.targets_m = {name: np.zeros(3) for name in self.possible_agents}
        self._cycles = 0
        self._rng = np.random.default_rng()

    def observation_space(self, agent: str) -> spaces.Box | spaces.Dict:
        return self._observation_spaces[agent]  # the same object each time, as PettingZoo asks

    def action_space(self, agent: str) -> spaces.Box:
        return self._action_spaces[agent]

    def action_of(self, agent: str, forward_mps: float, left_mps: float, climb_mps: float, yaw_rate_radps: float):
        """The action that commands these velocities for `agent` (see quadsim/Hover-v0)."""
        return self._scale[agent].action_of(forward_mps, left_mps, climb_mps, yaw_rate_radps)

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        self._check_open()
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        rng = self._rng
        for name, (x, y) in zip(self.possible_agents, self._slots):
            sx, sy = x + rng.uniform(-0.5, 0.5), y + rng.uniform(-0.5, 0.5)
            self.fleet[name].physics.start = StartPose(float(sx), float(sy), float(rng.uniform(-np.pi, np.pi)))
            self.targets_m[name] = np.array([sx + rng.uniform(-1, 1), sy + rng.uniform(-1, 1), rng.uniform(1.0, 2.5)])
        self.fleet.reset(seed=int(rng.integers(MAX_SEED)))
        for name in self.possible_agents:
            self.fleet[name].send(Twist())
        for sensors in self.sensors.values():
            sensors.reset()
        self.agents = list(self.possible_agents)
        self._cycles = 0
        return {a: self._observe(a) for a in self.agents}, {a: agent_info(self.fleet[a].state) for a in self.agents}

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """Each agent in `actions` takes its action (all or none: one that is not an action
        raises before any is sent); a live agent left out keeps its last command."""
        self._check_open()
        commands = {
            agent: self._scale[agent].command(action) for agent, action in actions.items() if agent in self.agents
        }
        for agent, command in commands.items():
            self.fleet[agent].send(command)
        events_before = {a: len(self.fleet[a].events) for a in self.agents}
        self.fleet.step(self.steps_per_action)
        self._cycles += 1
        observations, rewards, terminations, truncations, infos = {}, {}, {}, {}, {}
        for agent in self.agents:
            state = self.fleet[agent].state
            crashed = any(e.kind is EventKind.CRASH for e in self.fleet[agent].events[events_before[agent] :])
            failed = crashed or QuadEnv.out_of_arena(state) or QuadEnv.tipped_over(state)
            observations[agent] = self._observe(agent)
            rewards[agent] = hover_reward(state, self.targets_m[agent]) - (10.0 if failed else 0.0)
            terminations[agent] = failed
            truncations[agent] = self._cycles >= self.max_cycles
            infos[agent] = agent_info(state)
        self.agents = [a for a in self.agents if not (terminations[a] or truncations[a])]
        return observations, rewards, terminations, truncations, infos

    def _observe(self, agent: str) -> np.ndarray | dict[str, np.ndarray]:
        return hover_observation(self.fleet[agent].state, self.targets_m[agent], self._space, self.sensors.get(agent))

    def render(self) -> None:
        return None

    def _check_open(self) -> None:
        if self.fleet.closed:
            raise QuadsimError("this environment is closed: make a new HoverFleetEnv")

    def close(self) -> None:
        self.fleet.close()


def parallel_env(**kwargs: Any) -> HoverFleetEnv:
    """PettingZoo's conventional constructor."""
    return HoverFleetEnv(**kwargs)
