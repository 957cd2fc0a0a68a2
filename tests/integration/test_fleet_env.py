"""The PettingZoo fleet environment: PettingZoo's own API and seed tests, agents that reach their
targets under a hand-written policy, and a collision that ends both agents."""

from __future__ import annotations

import math

import numpy as np
from pettingzoo.test import parallel_api_test, parallel_seed_test

from quadsim.envs.fleet import HoverFleetEnv


def test_pettingzoos_api_and_seed_tests_pass():
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
