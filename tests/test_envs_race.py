"""The PettingZoo race env: API conformance, cars seeing each other, and car-car collisions ending episodes."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs import RaceEnv, parallel_env, race_env
from racecar_sim.envs.race import CAR_SPACING

with warnings.catch_warnings():  # pettingzoo.test imports its classic envs through their deprecated creation API
    warnings.filterwarnings("ignore", "The old environment creation API has been deprecated", DeprecationWarning)
    from pettingzoo.test import parallel_api_test

STOP = np.array([0.0, 0.0], np.float32)
FULL = np.array([1.0, 0.0], np.float32)
FRONT = 540  # the beam straight ahead of 1081 over +-135 deg


def test_parallel_api() -> None:
    env = parallel_env(num_cars=2, max_cycles=25)
    parallel_api_test(env, num_cycles=30)
    env.close()
    assert race_env is parallel_env


def test_each_agent_has_its_own_spaces_and_its_lidar_sees_the_others() -> None:
    env = RaceEnv(num_cars=2, sensor_noise=False)  # walker: car1 at the spawn, car2 1.5 m behind it
    obs, infos = env.reset(seed=0)
    assert env.agents == ["car1", "car2"] and set(obs) == set(infos) == {"car1", "car2"}
    assert env.observation_space("car2")["scan"].shape == (1081,)
    ahead1, ahead2 = obs["car1"]["scan"][FRONT], obs["car2"]["scan"][FRONT]
    assert ahead1 > 7.0  # car1 looks down the straight to the wall at x = 8.3
    assert ahead2 < CAR_SPACING  # car2 sees car1's tail
    env.close()


def run_into_car1(collision: str) -> tuple[dict, dict, list[str]]:
    """car2 drives into the stopped car1 ahead of it; car3, further back, stands still."""
    env = RaceEnv(num_cars=3, collision=collision)
    env.reset(seed=1)
    for _ in range(100):
        _, _, terminations, _, infos = env.step({"car1": STOP, "car2": FULL, "car3": STOP})
        if any(info["cars_touched"] for info in infos.values()):
            break
    agents = list(env.agents)
    env.close()
    return terminations, infos, agents


def test_a_collision_ends_the_episode_of_the_cars_involved() -> None:
    terminations, infos, agents = run_into_car1("involved")
    assert terminations == {"car1": True, "car2": True, "car3": False}
    assert infos["car2"]["crash"] == "car" and infos["car2"]["cars_touched"] == ["car1"]
    assert infos["car1"]["cars_touched"] == ["car2"]
    assert agents == ["car3"]


def test_collision_all_ends_every_episode_and_none_ends_none() -> None:
    terminations, _, agents = run_into_car1("all")
    assert all(terminations.values()) and agents == []
    terminations, infos, agents = run_into_car1("none")
    assert not any(terminations.values()) and agents == ["car1", "car2", "car3"]
    assert infos["car2"]["cars_touched"] == ["car1"]


def test_same_seed_same_race() -> None:
    traces = []
    for _ in range(2):
        env = RaceEnv(num_cars=2)
        obs, _ = env.reset(seed=4)
        trace = [obs]
        rng = np.random.default_rng(0)
        for _ in range(40):
            trace.append(env.step({a: rng.uniform(0.0, 1.0, 2).astype(np.float32) for a in env.agents})[0])
        traces.append(trace)
        env.close()
    for a, b in zip(*traces):
        assert a.keys() == b.keys()
        for agent in a:
            assert all(np.array_equal(a[agent][k], b[agent][k]) for k in a[agent])


def test_bad_settings_are_one_line_errors() -> None:
    with pytest.raises(ConfigError, match="collision"):
        RaceEnv(collision="sometimes")
    with pytest.raises(ConfigError, match="num_cars"):
        RaceEnv(num_cars=0)
