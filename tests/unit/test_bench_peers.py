"""The peers' bench stays optional: a missing peer is one line, the timing loop counts resets, and a
failing child is reported, not raised past the bench. Nothing here installs or runs a peer."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from quadsim.apps.bench.peers import PYFLYT, not_installed_line, peer_python, step_randomly


class ThreeStepEnv(gym.Env):
    """Every episode ends after three steps."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.count = 0
        return np.zeros(1, np.float32), {}

    def step(self, action):
        self.count += 1
        return np.zeros(1, np.float32), 0.0, self.count == 3, False, {}


def test_a_missing_peer_is_one_install_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(PYFLYT.python_env_var, raising=False)
    monkeypatch.setattr("importlib.util.find_spec", lambda name: None)
    assert peer_python(PYFLYT) is None
    line = not_installed_line(PYFLYT)
    assert line.startswith("PyFlyt: not installed (pip install PyFlyt")
    assert "\n" not in line


def test_the_environment_variable_names_the_peer_interpreter(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(PYFLYT.python_env_var, "/opt/pyflyt/bin/python")
    assert peer_python(PYFLYT) == "/opt/pyflyt/bin/python"


def test_the_timing_loop_resets_ended_episodes() -> None:
    times = step_randomly(ThreeStepEnv(), 10)
    assert (times.steps, times.resets) == (10, 3)
    assert 0.0 <= times.reset_s < times.elapsed_s  # consistency (a part within its whole), not a bound
    assert times.stepping_steps_per_s >= times.steps_per_s > 0
