"""DriveBatch(lidar_on="device"): the lidar cast by MuJoCo Warp's batched rays (envs/batch_warp.py WarpLidar) against
the host lidar of the same Warp batch, on Warp's CPU device (no GPU needed; skipped without mujoco-warp, the [gpu]
extra, or with RACECAR_SIM_TEST_WARP=0). The one-line errors need nothing but the package.
"""

from __future__ import annotations

import importlib.util
import os

import mujoco
import numpy as np
import pytest

from racecar_sim.core.errors import ConfigError
from racecar_sim.envs.batch import DriveBatch
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.sensors.raycast.fan import Fan, ScanFrame
from racecar_sim.sensors.raycast.mujoco3d import MujocoRays
from racecar_sim.sensors.raycast.scene import subtree_bodies

# Warp casts in float32: the ray origin (a few metres from the world origin) and direction carry ~1e-7 relative
# error each, the hit distance the same, and the published float32 another 6e-8: ~1e-6 m at the lidar's ranges.
# Seen in the tunnel (test below): at most 8.3e-7 of the range (4.8e-6 m). Bound: 1e-5 of the range, and the same beams
# inf (none differ: no beam in these scans grazes an edge closely enough to flip between hit and miss).
RTOL = 1e-5

needs_warp = pytest.mark.skipif(
    importlib.util.find_spec("mujoco_warp") is None or os.environ.get("RACECAR_SIM_TEST_WARP") == "0",
    reason="needs mujoco-warp (the [gpu] extra); RACECAR_SIM_TEST_WARP=0 skips it",
)


def _assert_same_scans(device: np.ndarray, host: np.ndarray, what: str) -> float:
    """The device scans equal the host's within RTOL (inf where inf); the largest relative difference."""
    np.testing.assert_array_equal(np.isfinite(device), np.isfinite(host), err_msg=f"{what}: inf beams differ")
    finite = np.isfinite(host)
    assert finite.sum() > 0.5 * host.size and (~finite).any(), what  # walls seen, and open ends of the tunnel
    a, b = device[finite].astype(np.float64), host[finite].astype(np.float64)
    relative = float((np.abs(a - b) / b).max())
    assert relative <= RTOL, f"{what}: {relative:.2e} of the range"
    return relative


@needs_warp
def test_device_lidar_matches_the_host_lidar():
    """Two Warp batches, same seeds (noise on: the same noise is drawn for the same seed and stamp) and actions, 5
    control steps in the tunnel; episodes of 3 steps, so step 3 resets every world in the step (the reset scan), and
    then one world alone is reset (a scan of some worlds)."""
    host, device = (
        DriveBatch(
            2, world="tunnel", seeds=[3, 4], control_rate=20.0, max_episode_steps=3, device="warp-cpu", threads=1,
            lidar_on=where,
        )
        for where in ("host", "device")
    )  # fmt: skip
    assert host.warp_lidar is None and device.warp_lidar is not None
    host.reset(), device.reset()
    worst = _assert_same_scans(device.scan, host.scan, "reset")
    actions = np.clip(np.cumsum(np.random.default_rng(1).normal(0.3, 0.2, size=(5, 2, 2)), 0), -1, 1)
    for k, action in enumerate(actions):
        (_, _, _, host_truncated, _), (_, _, _, truncated, _) = host.step(action), device.step(action)
        np.testing.assert_array_equal(device.qpos, host.qpos)  # the same physics: only the lidar differs
        np.testing.assert_array_equal(truncated, host_truncated)
        worst = max(worst, _assert_same_scans(device.scan, host.scan, f"step {k}"))
    assert truncated.tolist() == [False, False] and host.steps.tolist() == [2, 2]  # step 3 ended every episode
    mask = np.array([False, True])
    host.reset(options={"reset_mask": mask}), device.reset(options={"reset_mask": mask})
    worst = max(worst, _assert_same_scans(device.scan, host.scan, "reset of world 1"))
    assert worst > 0.0  # float32 casts: not bit for bit
    for batch in (host, device):
        batch.close()


@needs_warp
def test_device_lidar_looks_past_what_is_nearer_than_range_min():
    """With range_min near the median range (half the beams hit nearer), each beam is cast again from range_min on,
    as the CPU's 3-D cast does (MujocoRays, mj_multiRay then mj_ray): the same distances."""
    batch = DriveBatch(1, world="tunnel", device="warp-cpu", lidar_on="device", sensor_noise=False, threads=1)
    batch.reset(seed=0)
    warp_lidar, lidar = batch.warp_lidar, batch.lidar
    assert warp_lidar is not None and lidar is not None
    plain = warp_lidar.ranges()[0]
    ranges = np.unique(plain[np.isfinite(plain)])
    gap = len(ranges) // 2 + int(np.argmax(np.diff(ranges[len(ranges) // 2 :]) > 1e-3))
    range_min = float(ranges[gap : gap + 2].mean())  # 0.5 mm or more from any beam's range: no float32 tie
    warp_lidar.range_min = range_min
    looked_past = warp_lidar.ranges()[0]
    fan = lidar.fan
    fan = Fan(fan.angle_min, fan.increment, fan.count, range_min, fan.range_max)
    data = batch.world_data(0)
    mujoco.mj_kinematics(batch.model, data)
    origin, axes = lidar.mount.pose(data.qpos)
    own = np.flatnonzero(np.isin(batch.model.geom_bodyid, subtree_bodies(batch.model, batch.root_body)))
    expected = MujocoRays(batch.model, data, COLLISION_GROUP, own).cast(ScanFrame(origin, axes, fan))
    np.testing.assert_array_equal(np.isfinite(looked_past), np.isfinite(expected))
    finite = np.isfinite(expected)
    np.testing.assert_allclose(looked_past[finite], expected[finite], rtol=RTOL)
    nearer = plain < range_min
    assert nearer.sum() > 100 and (looked_past[nearer] > range_min).all()
    batch.close()


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"lidar_on": "gpu", "device": "warp-cpu"}, ["lidar_on='gpu'", "host, device"]),
        ({"lidar_on": "device"}, ["lidar_on='device'", "device='cpu'", "warp"]),
    ],
)
def test_lidar_on_bad_value_is_one_line_error(kwargs, words):
    """Refused before anything is built (no Warp needed)."""
    with pytest.raises(ConfigError) as err:
        DriveBatch(2, world="walker", **kwargs)
    message = str(err.value)
    assert "\n" not in message and all(word in message for word in words), message
