"""render_mode="rgb_array": a chase camera behind and above a car, rendered offscreen (EGL or OSMesa)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from racecar_sim.render.gl import shared_context
from racecar_sim.render.offscreen import GLScene, visual_only_option

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
        fix = "use render_mode=None (not 'rgb_array')"
        self.target = GLScene(model, self.width, self.height, self.gl, fix, shadows=True)  # drawn with MuJoCo's flags

    def frame(self) -> np.ndarray:
        """The current state seen from behind the car: a new (height, width, 3) uint8 RGB array, top row first."""
        pos = self.data.xpos[self.body]
        rot = self.data.xmat[self.body].reshape(3, 3)
        self.camera.lookat[:] = pos + np.array([0.0, 0.0, 0.2])
        self.camera.azimuth = math.degrees(math.atan2(rot[1, 0], rot[0, 0]))
        mujoco.mjv_updateScene(
            self.model, self.data, self.option, None, self.camera, mujoco.mjtCatBit.mjCAT_ALL, self.target.scene
        )
        return self.target.draw_later().result()[::-1].copy()

    def close(self) -> None:
        """Free the GL objects (the shared context stays)."""
        self.target.close()
