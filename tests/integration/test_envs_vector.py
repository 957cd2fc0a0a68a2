"""quadsim/Hover-v0's vector env (quadsim.envs.vector) against gymnasium's own SyncVectorEnv over
the same envs: the same observations, rewards, ends and infos, bit for bit, through episodes that
end (crashes, the time limit), next-step autoresets, seeds given as a number, a list or not at
all, and partial resets; and what it refuses."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import quadsim.envs  # noqa: F401 - registers the envs
from quadsim.envs.vector import HoverVectorEnv
from quadsim.physics.wind import Turbulence, WindSettings


def _pair(num_envs: int, **kwargs):
    ours = gym.make_vec("quadsim/Hover-v0", num_envs=num_envs, **kwargs)
    theirs = gym.make_vec("quadsim/Hover-v0", num_envs=num_envs, vectorization_mode="sync", **kwargs)
    return ours, theirs


def _same(ours, theirs) -> None:
    for a, b in zip(ours[:-1], theirs[:-1]):
        np.testing.assert_array_equal(a, b)
    for key in ("step", "position_m"):
        mask = theirs[-1][f"_{key}"]
        np.testing.assert_array_equal(ours[-1][f"_{key}"], mask)
        np.testing.assert_array_equal(ours[-1][key][mask], theirs[-1][key][mask])


def test_make_vec_builds_it_and_each_env_flies_as_gymnasiums_sync_vector_env_would():
    """Four envs, 600 steps: two flown out of the arena at full speed (their episodes end), two
    wandering until a short time limit truncates theirs: everything the same, to the bit."""
    ours, theirs = _pair(4, max_episode_steps=200)
    try:
        assert isinstance(ours.unwrapped, HoverVectorEnv)
        assert ours.observation_space == theirs.observation_space and ours.action_space == theirs.action_space
        _same(ours.reset(seed=7), theirs.reset(seed=7))
        rng = np.random.default_rng(5)
        ends = truncated = 0
        for step in range(600):
            actions = np.clip(rng.normal([0.0, 0.0, 0.6 if step % 90 < 40 else -0.8, 0.0], 0.7, (4, 4)), -1, 1)
            actions[:2] = (1.0, 0.2, 0.4, 0.0)  # straight out of the arena
            result, reference = ours.step(actions.astype(np.float32)), theirs.step(actions.astype(np.float32))
            _same(result, reference)
            ends += int(result[2].sum())
            truncated += int(result[3].sum())
        assert ends >= 1 and truncated >= 1, (ends, truncated)  # both kinds of end, and the resets after them
    finally:
        ours.close()
        theirs.close()


def test_envs_flying_clear_are_flown_together_and_agree_to_the_bit_as_they_join_and_leave():
    """Five envs climb clear of everything and are flown together from their rows, through
    clearances measured again and IMU sample blocks drawn anew in flight; they fly faster than
    the command limit allows (the gate clamps it), dive back to the floor (each leaves the
    rows, PyBullet takes it), take off again, and their episodes run out while they fly
    together. At every step everything is what gymnasium's SyncVectorEnv gives, and each env,
    brought up to date, is in the state its SyncVectorEnv twin is in: pose, command, clamp
    count, IMU noise."""
    ours, theirs = _pair(5, max_episode_steps=260)
    quiet = ours.unwrapped._quiet
    resumed = 0
    resume = quiet._resume

    def counted(i):
        nonlocal resumed
        resumed += 1
        return resume(i)

    quiet._resume = counted
    try:
        _same(ours.reset(seed=21), theirs.reset(seed=21))
        rng = np.random.default_rng(8)
        together = left = 0
        for step in range(560):
            phase = step % 280
            if phase < 150:  # up, turning, a little drift
                base = [0.15, -0.1, 0.5, 0.3]
            elif phase < 190:  # faster than the limit: both axes at full (the gate scales them down)
                base = [1.0, 1.0, 0.0, -1.0]
            else:  # down to the floor, then off again
                base = [0.0, 0.0, -1.0 if phase < 250 else 0.8, 0.0]
            actions = np.clip(base + rng.normal(0.0, 0.05, (5, 4)), -1, 1).astype(np.float32)
            inside_before = quiet.inside.copy()
            result = ours.step(actions)
            _same(result, theirs.step(actions))
            together += int((inside_before & (quiet.flown == 8)).sum())
            left += int((inside_before & ~quiet.inside).sum())
            if step in (140, 170, 400):  # each env brought up to date is its twin
                for mine, twin in zip(ours.unwrapped.envs, theirs.envs):
                    a, b = mine.unwrapped.sim, twin.unwrapped.sim
                    assert a.state == b.state and a.loop.step_count == b.loop.step_count
                    assert a.gate.last_command == b.gate.last_command
                    assert a.gate.last_receive_step == b.gate.last_receive_step
                    assert a.gate.clamped_count == b.gate.clamped_count
                    ours_walk, their_walk = a.loop.imu.walk, b.loop.imu.walk
                    assert ours_walk[1:] == their_walk[1:]
                    np.testing.assert_array_equal(ours_walk[0], their_walk[0])
        assert together > 5 * 300, together  # most agent steps flown together
        assert left >= 10, left  # down to the floor, and the episodes' ends
        assert resumed >= 10, resumed  # clearances and IMU blocks renewed in flight
        assert sum(e.unwrapped.sim.gate.clamped_count for e in theirs.envs) > 0  # the gate clamped
    finally:
        ours.close()
        theirs.close()


def test_an_env_switched_to_height_z_mode_is_flown_on_its_own_and_still_as_its_twin():
    """The rows check commands against a climb rate's limits: an env whose z reads a height
    (set through `envs`) leaves them, and flies as gymnasium's SyncVectorEnv's env does."""
    ours, theirs = _pair(2)
    try:
        _same(ours.reset(seed=3), theirs.reset(seed=3))
        climb = np.tile(np.array([0.0, 0.0, 0.5, 0.0], np.float32), (2, 1))
        for _ in range(60):
            _same(ours.step(climb), theirs.step(climb))
        quiet = ours.unwrapped._quiet
        assert quiet.inside.all()
        for envs in (ours.unwrapped.envs, theirs.envs):
            envs[0].unwrapped.sim.set_z_mode("height")
        for _ in range(30):  # a climb command read as an altitude wanted: it comes down
            _same(ours.step(climb), theirs.step(climb))
            assert not quiet.inside[0] and quiet.inside[1]
    finally:
        ours.close()
        theirs.close()


def test_seeds_as_a_list_or_none_and_a_partial_reset():
    ours, theirs = _pair(3)
    try:
        mixed, reference = ours.reset(seed=[11, None, 13])[0], theirs.reset(seed=[11, None, 13])[0]
        np.testing.assert_array_equal(mixed[[0, 2]], reference[[0, 2]])  # None: a start drawn anew
        ours.reset(seed=[1, 2, 3])
        theirs.reset(seed=[1, 2, 3])
        actions = np.tile(np.array([0.3, 0.0, 0.5, 0.2], np.float32), (3, 1))
        for _ in range(20):
            _same(ours.step(actions), theirs.step(actions))
        mask = np.array([False, True, False])
        _same(ours.reset(options={"reset_mask": mask}), theirs.reset(options={"reset_mask": mask.copy()}))
        for _ in range(20):
            _same(ours.step(actions), theirs.step(actions))
        first, _ = ours.reset(seed=4)
        again, _ = ours.reset(seed=4)
        np.testing.assert_array_equal(first, again)
    finally:
        ours.close()
        theirs.close()


def test_a_wind_for_every_env_each_with_its_own_gusts():
    wind = WindSettings(3.0, 90.0, Turbulence.MODERATE)
    ours, theirs = _pair(2, wind=wind)
    try:
        _same(ours.reset(seed=2), theirs.reset(seed=2))
        actions = np.tile(np.array([0.0, 0.0, 0.6, 0.0], np.float32), (2, 1))
        for _ in range(60):
            result = ours.step(actions)
            _same(result, theirs.step(actions))
        assert not np.array_equal(result[0][0, :3], result[0][1, :3])
    finally:
        ours.close()
        theirs.close()


@pytest.mark.parametrize(
    ("kwargs", "said"),
    [
        ({"num_envs": 0}, "num_envs must be a whole number of at least 1"),
        ({"num_envs": 2, "max_episode_steps": 0}, "max_episode_steps must be a whole number of at least 1, got 0"),
        ({"num_envs": 2, "max_episode_steps": 1.5}, "max_episode_steps must be a whole number"),
        ({"num_envs": 2, "render_mode": "rgb_array"}, "does not render"),
        ({"num_envs": 2, "controller": object()}, "a controller of your own flies one vehicle"),
    ],
)
def test_what_it_refuses_is_said_in_one_line(kwargs, said):
    with pytest.raises(ValueError, match=said):
        HoverVectorEnv(**kwargs)


def test_actions_of_the_wrong_shape_or_not_finite_are_refused():
    envs = HoverVectorEnv(2)
    try:
        with pytest.raises(gym.error.ResetNeeded, match="call reset"):  # it flew from the origin
            envs.step(np.zeros((2, 4), np.float32))
        with pytest.raises(ValueError, match="the first reset\\(\\) resets every env"):
            envs.reset(seed=0, options={"reset_mask": np.array([True, False])})
        envs.reset(seed=0)
        with pytest.raises(ValueError, match="resets none of the envs"):
            envs.reset(options={"reset_mask": np.zeros(2, np.bool_)})
        with pytest.raises(ValueError, match="options\\['start_xy_m'\\] is two finite numbers"):
            envs.reset(options={"start_xy_m": (math.nan, 0.0)})
        with pytest.raises(ValueError, match=r"actions are 2 rows of 4 real numbers .* shape \(2, 4\)"):
            envs.step(np.zeros(4, np.float32))
        with pytest.raises(ValueError, match="finite"):
            envs.step(np.array([[0, 0, 0, 0], [0, math.nan, 0, 0]], np.float32))
        observations, *_ = envs.step(np.zeros((2, 4), np.float32))  # and it still steps
        assert observations.shape == (2, 15)
    finally:
        envs.close()
