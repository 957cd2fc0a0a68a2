"""quadsim/Hover-v0 as a Gymnasium vector env in one process: `gymnasium.make_vec` builds it.

    envs = gymnasium.make_vec("quadsim/Hover-v0", num_envs=16)
    observations, infos = envs.reset(seed=0)
    observations, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())

Each of its envs is a HoverEnv (quadsim.envs.quad), flown and judged by HoverEnv's own methods,
so env i flies exactly as `gymnasium.make("quadsim/Hover-v0")` reset with seed + i would, step
for step and bit for bit (what gymnasium's SyncVectorEnv over those envs gives:
tests/integration/test_envs_vector.py). What it saves is the rest: one call for all the actions' scaling,
no wrappers around each env, the observations and infos gathered into arrays once. Most of an
env step is its vehicle's flight, compiled where the vehicle is clear of everything
(quadsim.sim.clear_flight); the envs are stepped one after another on this process's core
(`vectorization_mode="async"` spreads envs over processes instead).

With `sensors` (quadsim.envs.sensors), each env's observation is HoverEnv's Dict and the
batch is a dict of arrays, one row per env (gymnasium.vector.utils.batch_space).

Autoreset is Gymnasium's next-step mode: an env that ended is reset at the next `step`, whose
action it ignores, giving its first observation with reward 0.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, create_empty_array

from quadsim.control import Controller
from quadsim.core.types import VehicleState
from quadsim.envs.quad import (
    AGENT_HZ,
    HOVER_EPISODE_S,
    HoverEnv,
    hover_observation_row,
    hover_observations,
    twist_command,
)
from quadsim.physics.wind import WindSettings


class HoverVectorEnv(VectorEnv):
    """`num_envs` HoverEnvs stepped together (see the module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}  # noqa: RUF012 - gymnasium's

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int = HOVER_EPISODE_S * AGENT_HZ,
        wind: WindSettings | None = None,
        controller: Controller | None = None,
        render_mode: str | None = None,
        sensors: Iterable[str] | str = (),
    ) -> None:
        """`max_episode_steps`: each env's episode is truncated after this many steps (Hover-v0's
        time limit by default); `wind`: WindSettings for every env (each env's gusts from its
        own seed); `sensors`: what each observation adds (HoverEnv's). A controller or a wind
        model of one's own is one object flying one vehicle: give them to `gymnasium.make` for
        one env."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a whole number of at least 1, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError("the vector env does not render: gymnasium.make one env with render_mode='rgb_array'")
        if controller is not None or (wind is not None and not isinstance(wind, WindSettings)):
            what = "a controller" if controller is not None else "a wind model"
            raise ValueError(f"{what} of your own flies one vehicle: give it to gymnasium.make for one env")
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.envs: list[HoverEnv] = []
        try:
            for _ in range(num_envs):
                self.envs.append(HoverEnv(wind=wind, sensors=sensors))
        except BaseException:
            self.close()
            raise
        first = self.envs[0]
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._scale = first._scale
        self._elapsed = np.zeros(num_envs, np.int64)
        self._ended = np.zeros(num_envs, np.bool_)
        #: with sensors, a dict of arrays (HoverEnv's Dict, batched)
        self._with_sensors = first.sensors is not None
        self._observations: Any = create_empty_array(self.single_observation_space, num_envs, np.zeros)
        self._space = first._space

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Every env reset (seed: env i gets seed + i, or the i-th of a list); with
        options["reset_mask"], only the envs it marks."""
        super().reset(seed=seed if isinstance(seed, int) else None)
        n = self.num_envs
        seeds: list[int | None] = (
            [None] * n if seed is None else [seed + i for i in range(n)] if isinstance(seed, int) else list(seed)
        )
        if len(seeds) != n:
            raise ValueError(f"a list of seeds needs one for each of the {n} envs, got {len(seeds)}")
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if mask is not None and (not isinstance(mask, np.ndarray) or mask.shape != (n,) or mask.dtype != np.bool_):
            raise ValueError(f"options['reset_mask'] must be a numpy array of {n} booleans")
        states: list[VehicleState | None] = [None] * n
        for i, env in enumerate(self.envs):
            if mask is None or mask[i]:
                self._put(i, env.reset(seed=seeds[i], options=options)[0])
                states[i] = env.sim.state
                self._elapsed[i] = 0
                self._ended[i] = False
        return self._batch(), self._infos(states)

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n = self.num_envs
        commands = self._scale.twist_of(actions, (n, 4)).tolist()
        rewards = np.zeros(n)
        terminations = np.zeros(n, np.bool_)
        states: list[VehicleState | None] = [None] * n
        rows, flown = [], []
        for i, env in enumerate(self.envs):
            env._check_open()
            if self._ended[i]:  # next-step autoreset: this step's action is ignored
                self._put(i, env.reset()[0])
                self._elapsed[i] = 0
                states[i] = env.sim.state
            else:
                state = states[i] = env.fly(twist_command(commands[i]))
                rewards[i], terminations[i] = env.judge(state)
                if self._with_sensors:
                    self._put(i, env._observe(state))
                else:
                    rows.append(hover_observation_row(state, env.target_m))
                    flown.append(i)
                self._elapsed[i] += 1
        if rows:
            self._observations[flown] = hover_observations(rows, self._space)
        truncations = self._elapsed >= self.max_episode_steps  # as gymnasium's TimeLimit
        self._ended = terminations | truncations
        return self._batch(), rewards, terminations, truncations, self._infos(states)

    def _put(self, i: int, observation: Any) -> None:
        """Env i's observation into its row of the batch."""
        if self._with_sensors:
            for key, value in observation.items():
                self._observations[key][i] = value
        else:
            self._observations[i] = observation

    def _batch(self) -> Any:
        """A copy of the batch of observations (the caller may keep it)."""
        if self._with_sensors:
            return {key: value.copy() for key, value in self._observations.items()}
        return self._observations.copy()

    def _infos(self, states: list[VehicleState | None]) -> dict[str, Any]:
        """What each env's info says (its step and position), as Gymnasium's vector envs give
        infos: an array per key and a mask of the envs that gave it."""
        given = np.array([state is not None for state in states])
        steps = np.array([0 if state is None else state.step for state in states])
        positions = np.array([(0.0, 0.0, 0.0) if state is None else state.position_m for state in states])
        return {"step": steps, "_step": given, "position_m": positions, "_position_m": given.copy()}

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()
