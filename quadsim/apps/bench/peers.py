"""The peers' hover envs (PyFlyt, gym-pybullet-drones) stepped like quadsim's, each in its own process.

Both peers are optional and never dependencies: a peer is measured with this interpreter when it
imports here, or with the interpreter named by its environment variable (PyFlyt pins numpy<2,
which quadsim's OpenCV cannot load beside, so it usually lives in a venv of its own); otherwise the
bench says it is not installed. The child is this file run as a script: it imports only the
standard library at module level, so any interpreter that has the peer (and gymnasium) runs it,
and the peers' prints and PyBullet connections stay out of the bench's process.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Any

#: prefixes the child's one result line (the peers print their own [INFO] lines to stdout)
RESULT_TAG = "QUADSIM_PEER_RESULT "
CHILD_TIMEOUT_S = 300.0


@dataclass(frozen=True)
class Peer:
    """A peer's hover env: how to find it, install it and name it."""

    key: str
    name: str
    module: str  # the import name
    distribution: str  # the installed distribution, for its version
    env_name: str
    default_agent_hz: int
    install_hint: str
    python_env_var: str  # names an interpreter that has the peer installed


PYFLYT = Peer(
    key="pyflyt",
    name="PyFlyt",
    module="PyFlyt",
    distribution="PyFlyt",
    env_name="PyFlyt/QuadX-Hover-v4",
    default_agent_hz=40,
    install_hint="pip install PyFlyt",
    python_env_var="QUADSIM_BENCH_PYFLYT_PYTHON",
)
GYM_PYBULLET_DRONES = Peer(
    key="gym-pybullet-drones",
    name="gym-pybullet-drones",
    module="gym_pybullet_drones",
    distribution="gym-pybullet-drones",
    env_name="HoverAviary",
    default_agent_hz=30,
    install_hint="pip install from a checkout of github.com/utiasDSL/gym-pybullet-drones",
    python_env_var="QUADSIM_BENCH_GPD_PYTHON",
)
PEERS = (PYFLYT, GYM_PYBULLET_DRONES)


@dataclass(frozen=True)
class PeerResult:
    """One measurement: env steps per second at an agent rate, random actions, one env."""

    peer: Peer
    version: str
    agent_hz: int
    physics_hz: int
    steps: int
    resets: int
    steps_per_s: float  # resets included
    stepping_steps_per_s: float  # the time spent in reset() left out

    @property
    def sim_s_per_wall_s(self) -> float:
        return self.steps_per_s / self.agent_hz


def peer_python(peer: Peer) -> str | None:
    """The interpreter to measure `peer` with: its environment variable's, else this one if the
    peer imports here, else None (not installed)."""
    named = os.environ.get(peer.python_env_var)
    if named:
        return named
    return sys.executable if importlib.util.find_spec(peer.module) is not None else None


def not_installed_line(peer: Peer) -> str:
    return f"{peer.name}: not installed ({peer.install_hint}, or {peer.python_env_var}=<a python that has it>)"


def measure_peer(peer: Peer, python: str, agent_hz: int, steps: int = 300) -> PeerResult:
    """Run the child with `python` and read its result line; RuntimeError with the child's last
    words when it fails."""
    command = [python, os.path.abspath(__file__), peer.key, str(agent_hz), str(steps)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=CHILD_TIMEOUT_S, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith(RESULT_TAG)]
    if done.returncode != 0 or not lines:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"{peer.name} measurement failed (exit {done.returncode}): {tail}")
    return PeerResult(peer=peer, **json.loads(lines[-1][len(RESULT_TAG) :]))


@dataclass(frozen=True)
class SteppingTimes:
    """What `step_randomly` measured: wall time in all, the part spent in reset(), resets."""

    steps: int
    elapsed_s: float
    reset_s: float
    resets: int

    @property
    def steps_per_s(self) -> float:
        return self.steps / self.elapsed_s

    @property
    def stepping_steps_per_s(self) -> float:
        return self.steps / (self.elapsed_s - self.reset_s)


def step_randomly(env: Any, steps: int) -> SteppingTimes:
    """Step a Gymnasium env with seeded random actions for `steps` steps after a seeded reset,
    resetting when an episode ends: the one loop that quadsim's envs and the peers' are timed by."""
    env.reset(seed=0)
    env.action_space.seed(0)
    resets, reset_s = 0, 0.0
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            reset_start = time.perf_counter()
            env.reset()
            reset_s += time.perf_counter() - reset_start
            resets += 1
    return SteppingTimes(steps, time.perf_counter() - start, reset_s, resets)


# --- the child: runs in the peer's interpreter -------------------------------------------------


def _make_env(peer: Peer, agent_hz: int) -> tuple[Any, int]:
    """(the peer's hover env at `agent_hz`, its physics rate in Hz), no GUI, no recording."""
    if peer is PYFLYT:
        gym = importlib.import_module("gymnasium")
        importlib.import_module("PyFlyt.gym_envs")  # registers the PyFlyt/ envs
        env = gym.make(peer.env_name, agent_hz=agent_hz)
        return env, 240  # PyFlyt's Aviary runs at 240 Hz (its physics_hz default, "not recommended to be changed")
    envs = importlib.import_module("gym_pybullet_drones.envs")
    env = envs.HoverAviary(ctrl_freq=agent_hz, gui=False, record=False)
    return env, int(env.PYB_FREQ)


def _child(peer_key: str, agent_hz: int, steps: int) -> None:
    """Time the peer's env with `step_randomly`; print the result line."""
    peer = next(p for p in PEERS if p.key == peer_key)
    env, physics_hz = _make_env(peer, agent_hz)
    times = step_randomly(env, steps)
    env.close()
    found = {
        "version": importlib.metadata.version(peer.distribution),
        "agent_hz": agent_hz,
        "physics_hz": physics_hz,
        "steps": steps,
        "resets": times.resets,
        "steps_per_s": times.steps_per_s,
        "stepping_steps_per_s": times.stepping_steps_per_s,
    }
    print(RESULT_TAG + json.dumps(found), flush=True)


if __name__ == "__main__":
    _child(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]))
