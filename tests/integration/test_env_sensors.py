"""The sensors an env's observation may add (quadsim.envs.sensors): the checker with each, clear
errors for names it does not know, readings that see the world (the altitude, the red tower) and
are clipped into their Boxes, the same episode from the same seed, the vector env's batches the
same as gymnasium's SyncVectorEnv's, and the PettingZoo fleet's agents with sensors of their own."""

from __future__ import annotations

import re
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import quadsim.envs  # noqa: F401 - registers the envs
from quadsim.envs.sensors import DEPTH_FAR_M, SENSORS

#: facing the red tower, whose face is 5.6 m ahead along x
FACING_TOWER = {"start_xy_m": (0.0, 0.0), "start_yaw_rad": 0.0}


@pytest.mark.parametrize(
    ("env_id", "sensors"),
    [("quadsim/Hover-v0", (name,)) for name in SENSORS] + [("quadsim/TowerVision-v0", ("depth", "range", "scan"))],
)
def test_each_sensor_passes_the_checker(env_id, sensors):
    env = gym.make(env_id, sensors=sensors)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_env(env.unwrapped)
        space = env.observation_space
        assert isinstance(space, gym.spaces.Dict) and set(sensors) <= set(space.spaces)
        assert all(space[name].dtype == np.float32 for name in sensors)
    finally:
        env.close()


@pytest.mark.parametrize(
    ("sensors", "said"),
    [
        (("range", "sonar"), "unknown sensor 'sonar'; the choices are depth, range, scan, scan3d"),
        (("scan", "scan3d"), "one LiDAR, 'scan' (2D) or 'scan3d' (3D), not both"),
        (("range", "range"), "each sensor once"),
        (None, "sensors: a name or names of depth, range, scan, scan3d; got None"),
    ],
)
def test_a_sensor_it_does_not_know_is_one_clear_error(sensors, said):
    with pytest.raises(ValueError, match=re.escape(said)):
        gym.make("quadsim/Hover-v0", sensors=sensors)


def test_readings_see_the_ground_and_the_tower_and_are_clipped_into_their_boxes():
    env = gym.make("quadsim/Hover-v0", sensors=("depth", "range", "scan"))
    try:
        observation, _ = env.reset(seed=3, options=FACING_TOWER)
        assert observation["state"].shape == (15,)
        # on the ground the range finder is below its minimum (-inf): its Box's low
        assert observation["range"][0] == env.observation_space["range"].low[0]
        for _ in range(30):  # climb for 1 s
            observation, *_ = env.step(env.unwrapped.action_of(0.0, 0.0, 1.0, 0.0))
        sim = env.unwrapped.sim
        z = sim.state.position_m[2]
        assert z > 0.5
        assert observation["range"][0] == pytest.approx(z - 0.045, abs=0.1)  # mounted 4.5 cm below base_link
        scan = observation["scan"]
        assert scan[180] == pytest.approx(5.6, abs=0.1)  # beam 180: straight ahead, at the tower's face
        assert scan[0] == 30.0  # straight behind: nothing within range (+inf), the Box's high
        assert env.observation_space["scan"].high[0] == 30.0
        assert sim.state.step - sim.drone.lidar.latest.step < 24  # at most one LiDAR period old (10 Hz)
        assert sim.drone.range_finder.latest.step == sim.state.step  # 60 Hz: taken at the step's last physics step
        depth = observation["depth"]
        assert depth.shape == (48, 64)
        assert depth[24, 32] == pytest.approx(5.5, abs=0.2)  # the tower, a camera's offset nearer
        assert depth[0, 0] == DEPTH_FAR_M  # sky: nothing drawn
        assert env.observation_space.contains(observation)
    finally:
        env.close()


def _episode(env, seed: int) -> list[dict[str, np.ndarray]]:
    observation, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    observations = [observation]
    for _ in range(20):
        observation, *_ = env.step(env.action_space.sample())
        observations.append(observation)
    return observations


def test_the_same_seed_gives_the_same_episode_readings_included():
    env = gym.make("quadsim/Hover-v0", sensors=("depth", "range", "scan3d"))
    try:
        first, again, other = _episode(env, 5), _episode(env, 5), _episode(env, 6)
        for a, b in zip(first, again):
            for key in a:
                np.testing.assert_array_equal(a[key], b[key])
        assert not np.array_equal(first[-1]["scan3d"], other[-1]["scan3d"])  # other noise, other start
    finally:
        env.close()


def test_the_vector_env_batches_them_as_gymnasiums_sync_vector_env_would():
    kwargs = {"num_envs": 2, "sensors": ("range", "scan"), "max_episode_steps": 15}
    ours = gym.make_vec("quadsim/Hover-v0", **kwargs)
    theirs = gym.make_vec("quadsim/Hover-v0", vectorization_mode="sync", **kwargs)
    try:
        assert ours.observation_space == theirs.observation_space
        assert ours.observation_space["scan"].shape == (2, 360)
        results = [(ours.reset(seed=2)[0], theirs.reset(seed=2)[0])]
        ours.action_space.seed(2)
        for _ in range(20):  # past the time limit: an autoreset
            actions = ours.action_space.sample()
            results.append((ours.step(actions)[0], theirs.step(actions)[0]))
        for a, b in results:
            assert a.keys() == b.keys()
            for key in a:
                np.testing.assert_array_equal(a[key], b[key])
    finally:
        ours.close()
        theirs.close()


def test_a_fleets_agents_each_read_their_own_sensors():
    from pettingzoo.test import parallel_api_test, parallel_seed_test

    from quadsim.envs.fleet import HoverFleetEnv

    env = HoverFleetEnv(agents=2, episode_s=1.0, sensors=("range", "scan"))
    try:
        assert env.observation_space("drone_1")["scan"].shape == (360,)
        parallel_api_test(env, num_cycles=40)
        observations, _ = env.reset(seed=4)
        low = env.observation_space("drone_0")["range"].low[0]
        assert all(observations[agent]["range"][0] == low for agent in env.agents)  # on the ground: below the minimum
    finally:
        env.close()
    parallel_seed_test(lambda: HoverFleetEnv(agents=2, episode_s=0.5, sensors="scan"), num_cycles=20)
    with pytest.raises(ValueError, match="'depth' is a single vehicle's"):
        HoverFleetEnv(agents=2, sensors=("depth",))
