"""Gymnasium environments (the `gym` extra): importing this module registers them.

import gymnasium as gym
import quadsim.envs  # registers quadsim/Hover-v0 and quadsim/TowerVision-v0

env = gym.make("quadsim/Hover-v0")
observation, info = env.reset(seed=0)
envs = gym.make_vec("quadsim/Hover-v0", num_envs=16)  # in one process (quadsim.envs.vector)
"""

from __future__ import annotations

from quadsim.core.invocation import install_extra
from quadsim.errors import QuadsimError

try:
    import gymnasium
except ImportError:  # pragma: no cover - depends on what is installed
    raise QuadsimError(
        f"the Gymnasium environments need gymnasium: {install_extra('gym')} (the marl extra for the PettingZoo "
        "fleet env)"
    ) from None

from quadsim.envs.quad import AGENT_HZ, HOVER_EPISODE_S, TOWER_EPISODE_S

ENV_IDS = ("quadsim/Hover-v0", "quadsim/TowerVision-v0")

if "quadsim/Hover-v0" not in gymnasium.registry:
    gymnasium.register(
        "quadsim/Hover-v0",
        entry_point="quadsim.envs.quad:HoverEnv",
        vector_entry_point="quadsim.envs.vector:HoverVectorEnv",
        max_episode_steps=HOVER_EPISODE_S * AGENT_HZ,
    )
    gymnasium.register(
        "quadsim/TowerVision-v0",
        entry_point="quadsim.envs.quad:TowerVisionEnv",
        max_episode_steps=TOWER_EPISODE_S * AGENT_HZ,
    )
