"""render_mode="rgb_array": a chase camera behind and above a car, rendered offscreen (EGL or OSMesa)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from racecar_sim.core.errors import RenderingError
from racecar_sim.sensors.gl import shared_context
from racecar_sim.sensors.render import visual_only_option

DISTANCE = 2.5  # m behind the car
ELEVATION = -20.0  # deg, looking down
WIDTH, HEIGHT = 640, 480  # MuJoCo's default offscreen buffer


class ChaseCamera:
    """Renders the scene from behind the body `body` (its heading followed); frame() returns (H, W, 3) RGB."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, body: int) -> None:
        self.width = min(WIDTH, model.vis.global_.offwidth)
        self.height = min(HEIGHT, model.vis.global_.offheight)
        self.gl = shared_context(self.width, self.height)  # RenderingError (one line) without headless GL
        self.model, self.data, self.body = model, data, body
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.distance, self.camera.elevation = DISTANCE, ELEVATION
        self.option = visual_only_option()
        self.scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        self.rect = mujoco.MjrRect(0, 0, self.width, self.height)
        self.rgb = np.empty((self.height, self.width, 3), np.uint8)
        try:
            self.context: mujoco.MjrContext | None = self.gl.call(mujoco.MjrContext, model,
                                                                  mujoco.mjtFontScale.mjFONTSCALE_50)
        except mujoco.FatalError as exc:
            raise RenderingError(f"render_mode='rgb_array': MuJoCo cannot render in the {self.gl.backend} context "
                                 f"({exc}): use render_mode=None") from None

    def frame(self) -> np.ndarray:
        """The current state seen from behind the car: a new (height, width, 3) uint8 RGB array, top row first."""
        if self.context is None:
            raise RuntimeError("frame() after close()")
        pos = self.data.xpos[self.body]
        rot = self.data.xmat[self.body].reshape(3, 3)
        self.camera.lookat[:] = pos + np.array([0.0, 0.0, 0.2])
        self.camera.azimuth = math.degrees(math.atan2(rot[1, 0], rot[0, 0]))
        mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        return self.gl.call(self._draw)[::-1].copy()

    def _draw(self) -> np.ndarray:
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self.context)
        mujoco.mjr_render(self.rect, self.scene, self.context)
        mujoco.mjr_readPixels(self.rgb, None, self.rect, self.context)
        return self.rgb

    def close(self) -> None:
        """Free the GL objects (the shared context stays)."""
        if self.context is not None:
            self.gl.call(self.context.free)
            self.context = None

