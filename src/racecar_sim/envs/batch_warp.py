"""The GPU path of DriveBatch: MuJoCo Warp (`pip install racecar-sim[gpu]`: mujoco-warp, warp-lang) on a CUDA GPU.

Only the availability check is here so far: DriveBatch(device="warp") says in one line what is missing. The
CPU path (threads over MuJoCo) always works.
"""

from __future__ import annotations

from racecar_sim.core.errors import ConfigError

GPU_HINT = "install the [gpu] extra (pip install 'racecar-sim[gpu]': mujoco-warp, warp-lang) on a machine with a CUDA GPU"


def require_warp() -> None:
    """Raise ConfigError (one line) unless mujoco_warp imports and warp sees a CUDA device."""
    try:
        import mujoco_warp  # noqa: F401
        import warp
    except ImportError:
        raise ConfigError(f"DriveBatch device='warp' needs MuJoCo Warp: {GPU_HINT}") from None
    warp.init()
    if not warp.get_cuda_device_count():
        raise ConfigError(f"DriveBatch device='warp' needs a CUDA GPU (warp sees none): {GPU_HINT}, or use "
                          "device='cpu'")
    raise ConfigError("DriveBatch device='warp': the MuJoCo Warp stepping is not implemented yet; use device='cpu'")
