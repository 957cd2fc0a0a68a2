"""The Gymnasium environments (quadsim.envs): the checker, seeded resets, a hand-written policy
that solves Hover, the tower in TowerVision's images, vector envs, and the missing-extra message.

Its e2e tests (real processes, signals, windows or peers); the others are in tests/integration/test_envs.py."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from tests.integration.test_envs import _p_policy


def test_make_vec_steps_two_envs_in_processes():
    envs = gym.make_vec("quadsim/Hover-v0", num_envs=2, vectorization_mode="async")
    scale = gym.make("quadsim/Hover-v0").unwrapped  # its action_of, for the policy's m/s
    try:
        observations, _ = envs.reset(seed=3)
        assert observations.shape == (2, 15)
        assert not np.array_equal(observations[0], observations[1])  # each env its own seed
        for _ in range(30):
            observations, rewards, terminated, truncated, _ = envs.step(
                np.array([scale.action_of(*_p_policy(o)) for o in observations])
            )
        assert rewards.shape == (2,) and not terminated.any()
        assert (observations[:, 2] > 0.5).all()  # both took off
    finally:
        envs.close()
        scale.close()
