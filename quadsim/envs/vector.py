"""quadsim/Hover-v0 as a Gymnasium vector env in one process: `gymnasium.make_vec` builds it.

    envs = gymnasium.make_vec("quadsim/Hover-v0", num_envs=16)
    observations, infos = envs.reset(seed=0)
    observations, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())

Each of its envs is a HoverEnv (quadsim.envs.quad), and env i flies exactly as
`gymnasium.make("quadsim/Hover-v0")` reset with seed + i would, step for step and bit for bit
(what gymnasium's SyncVectorEnv over those envs gives: tests/integration/test_envs_vector.py).
An env whose vehicle flies clear of everything is stepped with the others in one compiled call:
their states stay in rows of one array between steps (quadsim.sim.clear_flight.QuietApart), and
their observations, rewards and ends come from those rows in one more call
(quadsim.envs.hover_numbers.hover_batch), with no Python object per env. An env near the floor
or anything else, or starting an episode, is flown and judged by HoverEnv's own methods, and
joins the others once it is clear. `envs` gives each env brought up to date. Everything runs on
this process's core (`vectorization_mode="async"` spreads envs over processes instead).

With `sensors` (quadsim.envs.sensors), each env's observation is HoverEnv's Dict and the
batch is a dict of arrays, one row per env (gymnasium.vector.utils.batch_space).

Autoreset is Gymnasium's next-step mode: an env that ended is reset at the next `step`, whose
action it ignores, giving its first observation with reward 0.
"""

from __future__ import annotations

from collections.abc import Iterable
from copy import deepcopy
from typing import Any

import numpy as np
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, create_empty_array

from quadsim.control import Controller
from quadsim.core.compiled import specialize
from quadsim.core.types import VehicleState
from quadsim.envs.hover_numbers import hover_batch
from quadsim.envs.quad import (
    AGENT_HZ,
    HOVER_EPISODE_S,
    HoverEnv,
    hover_observation_row,
    hover_observations,
    twist_command,
)
from quadsim.physics.wind import WindSettings
from quadsim.sim.clear_flight import NOW_KINEMATICS, QuietApart


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
        for name, value in (("num_envs", num_envs), ("max_episode_steps", max_episode_steps)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be a whole number of at least 1, got {value!r}")
        if render_mode is not None:
            raise ValueError("the vector env does not render: gymnasium.make one env with render_mode='rgb_array'")
        if controller is not None or (wind is not None and not isinstance(wind, WindSettings)):
            what = "a controller" if controller is not None else "a wind model"
            raise ValueError(f"{what} of your own flies one vehicle: give it to gymnasium.make for one env")
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self._envs: list[HoverEnv] = []
        try:
            for _ in range(num_envs):
                self._envs.append(HoverEnv(wind=wind, sensors=sensors))
        except BaseException:
            self.close()
            raise
        first = self._envs[0]
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._scale = first._scale
        self._elapsed = np.zeros(num_envs, np.int64)
        self._reset_once = False  # step() before the first reset() is an error, as for any env
        self._ended = np.zeros(num_envs, np.bool_)
        #: with sensors, a dict of arrays (HoverEnv's Dict, batched); reset and step hand out copies
        self._with_sensors = first.sensors is not None
        self._observations: Any = create_empty_array(self.single_observation_space, num_envs, np.zeros)
        self._space = first._space
        self._steps = first.steps_per_action
        #: the envs flying clear, flown together (none with sensors: theirs read the world)
        self._quiet = None if self._with_sensors else QuietApart([env.sim.loop for env in self._envs], self._steps)
        self._targets = np.zeros((num_envs, 3))
        if self._quiet is not None:
            space = self._space
            self._bounds = (space.low, space.high)
            self._judge_together: Any = specialize(
                hover_batch, self._quiet.rows, 0, self._targets, self._ended, *self._bounds,
                self._observations, np.zeros(num_envs), self._ended,
            )  # fmt: skip

    @property
    def envs(self) -> list[HoverEnv]:
        """Each env, brought up to date (one flown with the others is behind until then)."""
        if self._quiet is not None:
            for i in range(self.num_envs):
                self._quiet.leave(i)
        return self._envs

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
        if mask is not None and not mask.any():
            raise ValueError("options['reset_mask'] resets none of the envs: mark at least one True")
        if mask is not None and not self._reset_once and not mask.all():
            raise ValueError("the first reset() resets every env: leave out options['reset_mask']")
        self._reset_once = True
        infos = self._infos()
        for i, env in enumerate(self._envs):
            if mask is None or mask[i]:
                self._reset(i, seeds[i], options)
                self._info(infos, i, env.sim.state)
        return deepcopy(self._observations), infos

    def _reset(self, i: int, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        env = self._envs[i]
        if self._quiet is not None:
            self._quiet.leave(i)
        self._put(i, env.reset(seed=seed, options=options)[0])
        self._targets[i] = env.target_m
        self._elapsed[i] = 0
        self._ended[i] = False

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        n, envs, quiet = self.num_envs, self._envs, self._quiet
        envs[0]._check_open()  # (the envs close together)
        if not self._reset_once:
            raise ResetNeeded("call reset() before step()")
        commands = self._scale.twist_of(actions, (n, 4))
        rewards = np.zeros(n)
        terminations = np.zeros(n, np.bool_)
        # the envs flying clear, together: flown, observed and judged from their rows
        together = np.zeros(n, np.bool_)
        if quiet is not None and quiet.inside.any():
            together = quiet.fly(commands) == self._steps
            self._judge_together(
                quiet.rows,
                NOW_KINEMATICS,
                self._targets,
                together,
                *self._bounds,
                self._observations,
                rewards,
                terminations,
            )
        infos = self._infos(every=True)
        self._elapsed += 1
        rows, flown = [], []
        for i in np.flatnonzero(~together).tolist():
            env = envs[i]
            if self._ended[i]:  # next-step autoreset: this step's action is ignored (and its count 0)
                self._reset(i)
                self._info(infos, i, env.sim.state)
                continue
            taken = 0
            if quiet is not None and quiet.inside[i]:
                taken = int(quiet.flown[i])  # steps of this one flown together before its clearance ended
                quiet.leave(i)
            state = env.fly(twist_command(commands[i].tolist()), taken)
            rewards[i], terminations[i] = env.judge(state)
            self._info(infos, i, state)
            if self._with_sensors:
                self._put(i, env._observe(state))
            else:
                rows.append(hover_observation_row(state, env.target_m))
                flown.append(i)
        if rows:
            self._observations[flown] = hover_observations(rows, self._space)
        truncations = self._elapsed >= self.max_episode_steps  # as gymnasium's TimeLimit
        self._ended = terminations | truncations
        if quiet is not None:
            if self._ended.any():
                for i in np.flatnonzero(self._ended & quiet.inside).tolist():  # reset at the next step
                    quiet.leave(i)
            for i in flown:  # flown in Python this step: with the others from the next, if clear
                if not self._ended[i]:
                    quiet.enter(i)
        return deepcopy(self._observations), rewards, terminations, truncations, infos

    def _put(self, i: int, observation: Any) -> None:
        """Env i's observation into its row of the batch."""
        if self._with_sensors:
            for key, value in observation.items():
                self._observations[key][i] = value
        else:
            self._observations[i] = observation

    def _infos(self, every: bool = False) -> dict[str, Any]:
        """What each env's info says (its step and position), as Gymnasium's vector envs give
        infos: an array per key and a mask of the envs that gave it. `every`: every env gives one
        (a step), those flown together from their rows here, the others' added by `_info`."""
        n, quiet = self.num_envs, self._quiet
        if every and quiet is not None:
            steps, positions = quiet.counts.copy(), quiet.rows[:, NOW_KINEMATICS : NOW_KINEMATICS + 3].copy()
        else:
            steps, positions = np.zeros(n, np.int64), np.zeros((n, 3))
        given = np.full(n, every)
        return {"step": steps, "_step": given, "position_m": positions, "_position_m": given.copy()}

    @staticmethod
    def _info(infos: dict[str, Any], i: int, state: VehicleState) -> None:
        """Env i's step and position, from its state, into `infos`."""
        infos["step"][i], infos["position_m"][i] = state.step, state.position_m
        infos["_step"][i] = infos["_position_m"][i] = True

    def close_extras(self, **kwargs: Any) -> None:
        for env in self._envs:
            env.close()
