"""DriveBatch as a Gymnasium VectorEnv: make_vec gives it, and it keeps the vector-env contract as Gymnasium's own
SyncVectorEnv of N DriveEnvs (same seeds and actions) keeps it - same spaces, first observations, rewards, flags and
infos, through crashes, truncations and SAME_STEP autoresets, compared with Gymnasium's data_equivalence as its own
vector tests (tests/vector/test_autoreset_mode.py) compare them."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from racecar_sim.core.errors import ConfigError, WorldError
from racecar_sim.envs import DRIVE_CAMERA_ID, DRIVE_ID, MAX_EPISODE_STEPS
from racecar_sim.envs.batch import DriveBatch
from racecar_sim.envs.drive import DriveEnv

N = 3
STEPS = 30  # the episode step limit in these tests (1.5 s)


def pair(**kwargs):
    """(Gymnasium's SyncVectorEnv of N DriveEnvs with SAME_STEP autoreset, the batch from make_vec), same keywords."""
    sync = gym.make_vec(
        DRIVE_ID,
        num_envs=N,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP},
        **kwargs,
    )
    batch = gym.make_vec(DRIVE_ID, num_envs=N, vectorization_mode="vector_entry_point", **kwargs)
    return sync, batch


def equivalent(a: tuple, b: tuple) -> list[str]:
    """The parts of two reset() / step() results that differ (data_equivalence, exact)."""
    names = ("obs", "info") if len(a) == 2 else ("obs", "reward", "terminated", "truncated", "info")
    return [name for name, x, y in zip(names, a, b) if not data_equivalence(x, y, exact=True)]


def test_make_vec_gives_the_batch() -> None:
    for mode in ("vector_entry_point", None):  # Gymnasium's default mode for an id with a vector entry point
        envs = gym.make_vec(DRIVE_ID, num_envs=4, vectorization_mode=mode, world="empty", time_limit=2.0)
        try:
            assert isinstance(envs, DriveBatch) and isinstance(envs, VectorEnv)
            assert envs.num_envs == 4 and envs.spec.id == DRIVE_ID
            assert envs.max_episode_steps == MAX_EPISODE_STEPS and envs.time_limit_ns == 2_000_000_000
            assert envs.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
            single = DriveEnv(world="empty")
            assert envs.single_observation_space == single.observation_space
            assert envs.single_action_space == single.action_space
            assert envs.observation_space == batch_space(single.observation_space, 4)
            assert envs.action_space == gym.spaces.Box(-1.0, 1.0, (4, 2), np.float32)
            single.close()
            obs, _ = envs.reset(seed=0)
            assert envs.observation_space.contains(obs)
        finally:
            envs.close()
    camera = gym.make_vec(DRIVE_CAMERA_ID, num_envs=2)  # no vector entry point: Gymnasium vectorises DriveEnv
    assert isinstance(camera, gym.vector.SyncVectorEnv)
    camera.close()


def test_the_batch_keeps_the_contract_of_sync_vector_env() -> None:
    """World 0 drives into a wall (terminated after 23 steps, three times), world 1 drives on to the step limit
    (truncated), world 2 drives at random; 70 steps: each step's observations, rewards, flags and infos (final_obs,
    final_info and their masks included) are those of Gymnasium's SyncVectorEnv, exactly."""
    sync, batch = pair(world="walker", max_episode_steps=STEPS)
    try:
        assert sync.metadata["autoreset_mode"] == batch.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
        assert sync.single_observation_space == batch.single_observation_space
        assert sync.single_action_space == batch.single_action_space
        assert sync.observation_space == batch.observation_space and sync.action_space == batch.action_space
        first = sync.reset(seed=11), batch.reset(seed=11)
        assert equivalent(*first) == []
        assert set(first[1][1]) == {"progress", "_progress", "crash", "_crash", "time", "_time"}
        rng = np.random.default_rng(0)
        ends = {"terminated": 0, "truncated": 0}
        for k in range(70):
            actions = np.array([[1.0, 1.0], [0.6, 0.0], rng.uniform(-1, 1, 2)], np.float32)
            a, b = sync.step(actions), batch.step(actions)
            assert equivalent(a, b) == [], f"step {k}"
            obs, _, terminated, truncated, infos = b
            ends["terminated"] += int(terminated.sum())
            ends["truncated"] += int(truncated.sum())
            if terminated.any() or truncated.any():
                done = terminated | truncated
                assert list(infos["_final_obs"]) == list(done) == list(infos["_final_info"])
                for i in np.flatnonzero(done):
                    assert infos["final_obs"][i] in batch.single_observation_space
                    assert obs["speed"][i, 0] == 0.0 and infos["time"][i] == 0.0  # the new episode's first
                if terminated[0]:
                    assert infos["final_info"]["crash"][0] == "wall"
        assert ends["terminated"] >= 3 and ends["truncated"] >= 2
    finally:
        sync.close()
        batch.close()


def test_reset_options_seeds_and_partial_resets_as_sync_vector_env() -> None:
    """reset(seed=list), a reset without a seed (each world's seed drawn from its generator), options reset_mask and
    spawn: the same as SyncVectorEnv after each, and five steps on."""
    sync, batch = pair(world="walker", max_episode_steps=STEPS)
    actions = np.array([[1.0, 0.3], [0.6, 0.0], [0.2, -0.5]], np.float32)

    def both(call):
        a, b = call(sync), call(batch)
        assert equivalent(a, b) == []
        at_reset = batch.qpos[:, batch.root_qpos : batch.root_qpos + 2].copy()
        for k in range(5):
            assert equivalent(sync.step(actions), batch.step(actions)) == [], f"step {k}"
        return b, at_reset

    try:
        both(lambda e: e.reset(seed=[5, 9, 7]))
        both(lambda e: e.reset())
        (_, infos), _ = both(lambda e: e.reset(options={"reset_mask": np.array([False, True, False])}))
        assert list(infos["_time"]) == [False, True, False]
        _, at_reset = both(lambda e: e.reset(seed=3, options={"spawn": (1.0, 0.2, 0.3)}))
        np.testing.assert_allclose(at_reset, [[1.0, 0.2]] * N, atol=1e-6)
    finally:
        sync.close()
        batch.close()


def test_old_keywords_and_first_reset_seeds() -> None:
    """num_worlds= and reset(seeds=) (the old names) still work; constructor seeds seed the first reset only."""
    batch = DriveBatch(num_worlds=2, world="empty", seeds=[4, 6])
    try:
        assert batch.num_envs == batch.num_worlds == 2
        batch.reset()
        assert list(batch.seeds) == [4, 6]
        batch.reset(seeds=8)
        assert list(batch.seeds) == [8, 9]
        batch.reset()  # drawn from the generators the last reset seeded, as DriveEnv.reset() draws them
        env = DriveEnv(world="empty")
        env.reset(seed=8)
        env.reset()
        assert batch.seeds[0] == env.sim.seed
        env.close()
    finally:
        batch.close()


def test_time_limit_truncates_as_drive_env() -> None:
    batch = DriveBatch(2, world="empty", time_limit=0.5, seeds=0)
    try:
        batch.reset()
        ends = [bool(batch.step(np.ones((2, 2)) * [1.0, 0.0])[3][0]) for _ in range(10)]
        assert ends == [False] * 9 + [True]  # 10 steps of 50 ms, as test_envs_gym's DriveEnv
    finally:
        batch.close()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"camera": True}, "DriveBatch has no camera"),
        ({"render_mode": "rgb_array"}, "DriveBatch renders nothing"),
        ({"time_limit": -1.0}, "time_limit must be a positive number"),
        ({"max_episode_steps": 0}, "max_episode_steps must be a whole number >= 1"),
        ({"num_worlds": 3}, "num_envs=2 and num_worlds=3 differ"),
        ({"max_speed": 0.0}, "max_speed must be a positive number"),
    ],
)
def test_bad_keywords_are_one_line_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ConfigError) as err:
        DriveBatch(2, world="empty", **kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_bad_reset_options_are_one_line_errors() -> None:
    batch = DriveBatch(2, world="empty", seeds=0)
    try:
        batch.reset()
        for options, message in [
            ({"reset_mask": [True, False]}, "reset_mask must be a numpy bool array of shape (2,)"),
            ({"reset_mask": np.zeros(2, bool)}, "with a True"),
            ({"world": "walker"}, "a batch steps one world ('empty')"),
            ({"spawn": (math.nan, 0.0, 0.0)}, "x must be a finite number"),
        ]:
            with pytest.raises(ConfigError) as err:
                batch.reset(options=options)
            assert message in str(err.value) and "\n" not in str(err.value)
        with pytest.raises(ConfigError, match="give seed= .* not both"):
            batch.reset(seed=1, seeds=1)
        with pytest.raises(WorldError, match="no ground under it"):
            batch.reset(options={"spawn": (500.0, 0.0, 0.0)})
        obs, _ = batch.reset(options={"world": "empty"})  # its own world: fine
        assert obs["speed"].shape == (2, 1)
    finally:
        batch.close()
