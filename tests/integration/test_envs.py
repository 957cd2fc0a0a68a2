"""The Gymnasium environments (quadsim.envs): the checker, seeded resets, a hand-written policy
that solves Hover, the tower in TowerVision's images, vector envs, and the missing-extra message;
and the PettingZoo fleet environment (quadsim.envs.fleet): PettingZoo's own API and seed tests,
agents that reach their targets under a hand-written policy, and a collision that ends both agents."""

from __future__ import annotations

import math
import subprocess
import sys
import warnings
from typing import TYPE_CHECKING

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import quadsim.envs
from quadsim.core.invocation import install_extra
from quadsim.envs.quad import AGENT_HZ, HOVER_EPISODE_S
from quadsim.errors import QuadsimError

if TYPE_CHECKING:
    from quadsim.envs.fleet import HoverFleetEnv


@pytest.mark.parametrize("env_id", quadsim.envs.ENV_IDS)
def test_every_env_passes_the_checker(env_id):
    """With no warning at all: actions in [-1, 1], bounded observations (what Stable-Baselines3's
    checker also asks)."""
    env = gym.make(env_id, render_mode="rgb_array")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_env(env.unwrapped, skip_render_check=False)
        env.reset(seed=0)
        frame = env.render()
        assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8
        assert env.spec.max_episode_steps is not None  # truncation on a time limit
    finally:
        env.close()


def _p_policy(observation: np.ndarray) -> tuple[float, float, float, float]:
    """Fly toward the target: world velocity proportional to the error, turned into the heading
    frame (m/s and rad/s: the env's action_of makes them an action)."""
    position, yaw, target = observation[0:3], observation[8], observation[12:15]
    error = target - position
    vx, vy = np.clip(1.0 * error[:2], -1.5, 1.5)
    c, s = math.cos(yaw), math.sin(yaw)
    return (c * vx + s * vy, -s * vx + c * vy, float(np.clip(1.5 * error[2], -1.0, 1.0)), 0.0)


def test_seeded_resets_are_reproducible_and_a_p_controller_solves_hover():
    env = gym.make("quadsim/Hover-v0")
    try:
        runs = []
        for seed in (7, 7, 8):
            observation, _ = env.reset(seed=seed)
            observations = [observation]
            for _ in range(HOVER_EPISODE_S * AGENT_HZ):
                observation, _, terminated, truncated, _ = env.step(env.unwrapped.action_of(*_p_policy(observation)))
                observations.append(observation)
                if terminated or truncated:
                    break
            runs.append(np.array(observations))
        same, again, other = runs
        assert np.array_equal(same, again)  # the same seed: the same start, target and flight
        assert not np.array_equal(same[0], other[0])  # another seed: another start
        for run in (same, other):
            assert len(run) == HOVER_EPISODE_S * AGENT_HZ + 1  # ended by the time limit, not a failure
            final = run[-1]
            assert np.linalg.norm(final[12:15] - final[0:3]) < 0.05  # reached and holding the target
            assert np.linalg.norm(final[3:6]) < 0.05
    finally:
        env.close()


def test_the_seed_draws_the_gusts_and_a_crash_ends_the_episode():
    from quadsim.physics.wind import Turbulence, WindSettings

    env = gym.make("quadsim/Hover-v0", wind=WindSettings(3.0, 90.0, Turbulence.MODERATE))
    try:
        flights, winds = [], []
        for seed in (5, 5, 6):
            observation, _ = env.reset(seed=seed)
            for _ in range(AGENT_HZ):  # take off
                observation, *_ = env.step(env.unwrapped.action_of(0.0, 0.0, 1.0, 0.0))
            gusts = []
            for _ in range(2 * AGENT_HZ):  # hold still: only the wind moves it
                observation, *_ = env.step(np.zeros(4, np.float32))
                gusts.append(env.unwrapped.sim.state.wind_mps)
            flights.append(observation)
            winds.append(np.array(gusts))
        assert np.array_equal(flights[0], flights[1])  # the same seed, the same start and gusts
        assert np.array_equal(winds[0], winds[1])
        assert np.abs(winds[0] - winds[2]).max() > 0.1  # another seed, other gusts
        assert np.linalg.norm(flights[0][3:6]) > 0.01  # the gusts move it

        # fly into the red tower (6 m ahead of the origin, 3 m tall): the crash ends the episode
        observation, _ = env.reset(seed=1)
        for _ in range(AGENT_HZ):  # up to about 1.5 m
            observation, *_ = env.step(env.unwrapped.action_of(0.0, 0.0, 1.5, 0.0))
        terminated, reward = False, 0.0
        for _ in range(5 * AGENT_HZ):
            yaw, (x, y) = observation[8], observation[0:2]
            wx, wy = 6.0 - x, 0.0 - y
            d = math.hypot(wx, wy)
            c, sn = math.cos(yaw), math.sin(yaw)
            action = env.unwrapped.action_of(4.0 * (c * wx + sn * wy) / d, 4.0 * (-sn * wx + c * wy) / d, 0.0, 0.0)
            observation, reward, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
        assert terminated and reward < -5.0
        events = env.unwrapped.sim.events
        assert any(e.kind.value == "crash" and e.hit == "red_tower" for e in events), events
        assert abs(observation[0] - 6.0) < 1.5  # it ended at the tower, not out of the arena
    finally:
        env.close()


def test_tower_vision_images_show_the_tower_when_facing_it():
    env = gym.make("quadsim/TowerVision-v0")
    try:
        red_fraction = {}
        for yaw in (0.0, math.pi):
            observation, _ = env.reset(seed=1, options={"start_yaw_rad": yaw})
            for _ in range(45):  # climb for 1.5 s
                observation, *_ = env.step(env.unwrapped.action_of(0.0, 0.0, 1.0, 0.0))
            image = observation["image"].astype(int)
            red = (image[:, :, 0] > 120) & (image[:, :, 0] > 2 * image[:, :, 1]) & (image[:, :, 0] > 2 * image[:, :, 2])
            red_fraction[yaw] = red.mean()
            if yaw == 0.0:
                columns = np.nonzero(red.any(axis=0))[0]
                assert 20 < columns.mean() < 44  # near the middle of the 64-pixel image
        assert red_fraction[0.0] > 0.04 and red_fraction[math.pi] < 0.01  # the floor has red specks
        # flying straight at it ends the episode with the reward for arriving, before touching it
        observation, _ = env.reset(seed=1, options={"start_xy_m": (0.0, 0.0), "start_yaw_rad": 0.0})
        unwrapped = env.unwrapped
        start_m = unwrapped.distance_to_tower_m(unwrapped.sim.state)
        total, terminated = 0.0, False
        for _ in range(20 * AGENT_HZ):
            distance = unwrapped.distance_to_tower_m(unwrapped.sim.state)
            forward = 0.0 if distance < 1.2 else 1.0
            climb = 1.5 - unwrapped.sim.state.position_m[2]
            observation, reward, terminated, truncated, _ = env.step(env.unwrapped.action_of(forward, 0, climb, 0))
            total += reward
            if terminated or truncated:
                break
        assert terminated and 0.5 < unwrapped.distance_to_tower_m(unwrapped.sim.state) < 1.5
        assert total == pytest.approx(start_m - unwrapped.distance_to_tower_m(unwrapped.sim.state) + 10.0, abs=1e-6)
    finally:
        env.close()


def test_without_gymnasium_the_message_says_what_to_install():
    code = "import sys; sys.modules['gymnasium'] = None\nimport quadsim.envs"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode != 0
    assert install_extra("gym") in result.stderr.strip().splitlines()[-1]  # (here, in the same folder)


def test_actions_are_fractions_of_the_command_limits():
    env = gym.make("quadsim/Hover-v0")
    try:
        unwrapped = env.unwrapped
        limits = unwrapped.sim.vehicle.limits
        assert env.action_space.low.tolist() == [-1.0] * 4 and env.action_space.high.tolist() == [1.0] * 4
        full = unwrapped.twist_of([1.0, -1.0, 1.0, -1.0])
        assert full.tolist() == pytest.approx(
            [
                limits.max_horizontal_speed_mps,
                -limits.max_horizontal_speed_mps,
                limits.max_climb_rate_mps,
                -limits.max_yaw_rate_radps,
            ]
        )
        assert unwrapped.twist_of([0, 0, -1.0, 0])[2] == pytest.approx(-limits.max_descent_rate_mps)
        assert unwrapped.action_of(*unwrapped.twist_of([0.3, -0.2, 0.5, -0.7])).tolist() == pytest.approx(
            [0.3, -0.2, 0.5, -0.7]
        )
        env.reset(seed=0)
        for _ in range(AGENT_HZ):
            env.step(np.array([0.0, 0.0, 0.5, 0.0], np.float32))  # half the climb limit, for 1 s
        climb = unwrapped.sim.gate.last_command.linear_z
        assert climb == pytest.approx(0.5 * limits.max_climb_rate_mps)
    finally:
        env.close()


def test_a_wrong_action_is_one_clear_error_and_a_closed_env_says_so():
    """np.zeros(3) raised numpy's broadcasting error, np.zeros((2, 4)) an IndexError, the scalar 1
    flew full forward, left, climb and yaw, inf was clipped while NaN raised about linear_x, and a
    step after close() raised PyBullet's 'Not connected to physics server'."""
    env = gym.make("quadsim/Hover-v0")
    env.reset(seed=0)
    for bad, said in (
        (np.zeros(3), r"shape \(4,\); got array\(\[0., 0., 0.\]\) of shape \(3,\)"),
        (np.zeros((2, 4)), r"got array\(\[\[0., 0., 0., 0.\], \[0., 0., 0., 0.\]\]\) of shape \(2, 4\)"),
        (np.array([1j, 0, 0, 0]), r"4 real numbers"),
        ([True, False, False, False], r"4 real numbers"),
        ([[0, 0], [0]], r"4 real numbers"),
        (1, r"shape \(4,\); got 1$"),
        (None, r"shape \(4,\); got None$"),
        ("up", r"shape \(4,\); got 'up'$"),
        ([math.inf, 0, 0, 0], r"must be finite numbers \(each is clipped to \[-1, 1\]\), got \[inf, 0, 0, 0\]"),
        ([0, math.nan, 0, 0], r"must be finite numbers"),
    ):
        with pytest.raises(ValueError, match=said):
            env.step(bad)
    step = env.unwrapped.sim.step_count
    env.step([0.0, 0.0, 2.0, 0.0])  # beyond the box is clipped to its edge, as before
    assert env.unwrapped.sim.gate.last_command.linear_z == env.unwrapped.sim.vehicle.limits.max_climb_rate_mps
    assert env.unwrapped.sim.step_count == step + env.unwrapped.steps_per_action  # the refused ones never flew
    env.close()
    drawn = gym.make("quadsim/Hover-v0", render_mode="rgb_array")
    drawn.reset(seed=0)
    assert drawn.render().shape[2] == 3
    drawn.close()
    for again in (lambda: env.step(np.zeros(4)), lambda: env.reset(seed=1), drawn.render):
        with pytest.raises(gym.error.ClosedEnvironmentError, match="this environment is closed"):
            again()


def test_a_bad_reset_option_is_one_clear_error_and_leaves_the_env_as_a_fresh_one():
    """A NaN start was taken: observations and rewards were NaN for the whole episode, which never
    ended, and later seeded episodes no longer matched a fresh env's (PyBullet kept the NaN)."""
    env, fresh = gym.make("quadsim/Hover-v0"), gym.make("quadsim/Hover-v0")
    env.reset(seed=0)  # (gymnasium's checker wants a first reset that returns)
    for bad, said in (
        ({"start_xy_m": (math.nan, 0.0)}, r"options\['start_xy_m'\] is two finite numbers .*got \(nan, 0.0\)"),
        ({"start_xy_m": (0.0, math.inf)}, r"two finite numbers"),
        ({"start_xy_m": (0.0, 0.0, 1.0)}, r"two finite numbers"),
        ({"start_xy_m": 1.0}, r"two finite numbers .*got 1.0$"),
        ({"start_xy_m": ("a", "b")}, r"two finite numbers"),
        ({"start_yaw_rad": math.nan}, r"options\['start_yaw_rad'\] is a finite number \(rad\), got nan"),
        ({"start_yaw_rad": "north"}, r"start_yaw_rad"),
        ({"start_xy_m": (2e4, 0.0)}, r"start pose x_m = 20000 is beyond 10000 from the origin"),
        ({"start_xy": (3.0, 3.0)}, r"unknown reset option 'start_xy': the options are start_xy_m, start_yaw_rad"),
        ([("start_xy_m", (0, 0))], r"reset's options are a dict"),
    ):
        with pytest.raises(ValueError, match=said):
            env.reset(seed=0, options=bad)
    observation, _ = env.reset(seed=0, options={"start_xy_m": np.array([0.5, -0.5]), "start_yaw_rad": np.float32(1)})
    assert observation[:2] == pytest.approx([0.5, -0.5], abs=1e-6)
    assert env.unwrapped.action_of(0.0, 0.0, 0.0, 0.0).tolist() == [0.0] * 4
    with pytest.raises(ValueError, match="velocities must be finite numbers"):
        env.unwrapped.action_of(math.nan, 0.0, 0.0, 0.0)
    runs = []
    for e in (env, fresh):  # the refused resets left nothing behind
        e.reset(seed=3)
        runs.append([e.step(np.array([0.3, -0.2, 1.0, 0.1], np.float32))[0] for _ in range(40)])
    assert np.array_equal(runs[0], runs[1])
    env.close()
    fresh.close()


def test_an_env_cannot_be_copied_nor_pickled_and_a_forgotten_one_lets_go_of_its_world():
    """deepcopy gave a second env flying the first one's PyBullet body; pickle failed on a numba
    closure; an env dropped without close() kept its PyBullet client for the life of the process."""
    import copy
    import gc
    import pickle

    import pybullet as pb

    from quadsim.envs.fleet import HoverFleetEnv

    def connected() -> int:
        return sum(pb.isConnected(physicsClientId=cid) for cid in range(1000))

    gc.collect()  # what other tests left
    before = connected()
    for make in (
        lambda: gym.make("quadsim/Hover-v0"),
        lambda: gym.make_vec("quadsim/Hover-v0", num_envs=2),
        lambda: HoverFleetEnv(agents=2),
    ):
        env = make()
        env.reset(seed=0)
        for copier in (copy.deepcopy, pickle.dumps):
            with pytest.raises(TypeError, match="cannot be copied or pickled: it flies bodies in a PyBullet world"):
                copier(env)
        del env
    gc.collect()
    assert connected() == before


class _Shown(list):
    """An action that counts how often it is shown (its repr)."""

    shown = 0

    def __repr__(self) -> str:
        type(self).shown += 1
        return super().__repr__()


def test_a_good_action_is_never_formatted_for_an_error_it_does_not_raise():
    """Formatting the action for the error message on every step (an array's repr) cost the
    env about a fifth of its step time."""
    env = gym.make("quadsim/Hover-v0")
    env.reset(seed=0)
    env.step(_Shown([0.5, 0.0, 0.2, 0.0]))
    assert _Shown.shown == 0
    with pytest.raises(ValueError, match=r"got \[0.5, 0.0\]"):
        env.step(_Shown([0.5, 0.0]))
    assert _Shown.shown == 1
    env.close()


def test_make_finds_the_environments_without_an_import():
    """Gymnasium's "module:id" form imports quadsim.envs itself (Gymnasium 1.x dropped plugin
    entry points), in a fresh interpreter that never imported quadsim."""
    code = (
        "import gymnasium as gym, sys\n"
        "env = gym.make('quadsim.envs:quadsim/Hover-v0')\n"
        "print(env.spec.id, env.observation_space.shape)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "quadsim/Hover-v0 (15,)"


# --- the PettingZoo fleet environment (the marl extra) --------------------------------------------


def test_pettingzoos_api_and_seed_tests_pass():
    from pettingzoo.test import parallel_api_test, parallel_seed_test

    from quadsim.envs.fleet import HoverFleetEnv

    env = HoverFleetEnv(agents=3, episode_s=3.0)
    parallel_api_test(env, num_cycles=200)
    env.close()
    parallel_seed_test(lambda: HoverFleetEnv(agents=2, episode_s=2.0), num_cycles=60)


def _toward(env: HoverFleetEnv, agent: str, observation: np.ndarray) -> np.ndarray:
    """Velocity toward the target, in the heading frame (a hand-written policy)."""
    position, yaw, target = observation[0:3], observation[8], observation[12:15]
    dx, dy, dz = (target - position) * 1.2
    forward = math.cos(yaw) * dx + math.sin(yaw) * dy
    left = -math.sin(yaw) * dx + math.cos(yaw) * dy
    return env.action_of(agent, forward, left, dz, 0.0)


def test_each_agent_reaches_its_own_target_among_the_others():
    from quadsim.envs.fleet import HoverFleetEnv

    env = HoverFleetEnv(agents=4, episode_s=8.0)
    observations, infos = env.reset(seed=3)
    assert set(observations) == set(env.possible_agents) and env.agents == env.possible_agents
    targets = {a: o[12:15].copy() for a, o in observations.items()}
    assert len({tuple(t) for t in targets.values()}) == 4  # each its own
    total = dict.fromkeys(env.agents, 0.0)
    while env.agents:
        actions = {a: _toward(env, a, observations[a]) for a in env.agents}
        observations, rewards, terminations, truncations, _ = env.step(actions)
        for agent, reward in rewards.items():
            total[agent] += reward
        assert not any(terminations.values()), terminations
    assert all(truncations.values())  # the time limit ended every agent, nothing else
    for agent, observation in observations.items():
        assert np.linalg.norm(observation[0:3] - targets[agent]) < 0.3, agent
        assert total[agent] > -8.0 * 30 * 1.5, (agent, total[agent])  # it closed in early
    env.close()


def test_two_agents_flown_into_each_other_are_both_terminated():
    from quadsim.envs.fleet import HoverFleetEnv

    env = HoverFleetEnv(agents=2, spacing_m=1.5, episode_s=10.0)
    observations, _ = env.reset(seed=1)
    left, right = env.possible_agents
    for _ in range(60):  # up to about 1.5 m
        observations, *_ = env.step({a: env.action_of(a, 0.0, 0.0, 1.0, 0.0) for a in env.agents})
    ended: dict[str, float] = {}
    for _ in range(120):  # then straight at each other, at up to 3 m/s
        actions = {}
        for agent in env.agents:
            other = right if agent == left else left
            me, them, yaw = observations[agent][0:2], env.fleet[other].state.position_m[:2], observations[agent][8]
            dx, dy = (np.asarray(them) - me) * 3.0
            actions[agent] = env.action_of(
                agent, math.cos(yaw) * dx + math.sin(yaw) * dy, -math.sin(yaw) * dx + math.cos(yaw) * dy, 0.0, 0.0
            )
        observations, rewards, terminations, _, _ = env.step(actions)
        ended |= {a: rewards[a] for a, done in terminations.items() if done}
        if not env.agents:
            break
    assert set(ended) == {left, right}, ended
    assert all(r < -10.0 for r in ended.values())
    crashes = {a: [e for e in env.fleet[a].events if e.kind.value == "crash"] for a in (left, right)}
    assert crashes[left][0].hit == right and crashes[right][0].hit == left
    env.close()


def test_a_fleet_step_with_one_bad_action_sends_none_and_a_closed_fleet_says_so():
    """The agents before the bad one got their new command, though the step raised."""
    from quadsim.envs.fleet import HoverFleetEnv

    with pytest.raises(ValueError, match="does not render"):
        HoverFleetEnv(agents=1, render_mode="rgb_array")
    env = HoverFleetEnv(agents=2, render_mode=None)
    env.reset(seed=1)
    first, second = env.possible_agents
    with pytest.raises(ValueError, match="must be finite numbers"):
        env.step({first: np.array([0, 0, 1, 0], np.float32), second: np.array([math.nan, 0, 0, 0], np.float32)})
    for _ in range(20):
        env.step({})
    assert env.fleet[first].state.position_m[2] < 0.1  # still on the ground: it never took the climb
    env.close()
    for again in (lambda: env.step({}), lambda: env.reset(seed=1)):
        with pytest.raises(QuadsimError, match="this environment is closed: make a new HoverFleetEnv"):
            again()
