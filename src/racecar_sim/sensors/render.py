"""Offscreen rendering of one MuJoCo camera into a reused RGB buffer, with the settings that keep software GL fast.

Only the visual geom group is drawn (collision geoms, sites, joints and other decorations are not), with MSAA,
shadows and reflections off: Mesa's llvmpipe renders about ten times faster that way. The skybox stays on: it is
the flat sky colour, drawn last and only where nothing else is, so it costs little.
"""

from __future__ import annotations

from concurrent.futures import Future

import mujoco
import numpy as np

from racecar_sim.core.errors import RenderingError
from racecar_sim.physics.world_geoms import VISUAL_GROUP
from racecar_sim.sensors.gl import HeadlessGL, shared_context

_OFF = (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION, mujoco.mjtRndFlag.mjRND_HAZE)


def visual_only_option() -> mujoco.MjvOption:
    """Scene options that draw the visual geom group and nothing else."""
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[VISUAL_GROUP] = 1
    for groups in (option.sitegroup, option.jointgroup, option.tendongroup, option.actuatorgroup, option.flexgroup,
                   option.skingroup):
        groups[:] = 0
    for flag in (mujoco.mjtVisFlag.mjVIS_RANGEFINDER, mujoco.mjtVisFlag.mjVIS_PERTOBJ, mujoco.mjtVisFlag.mjVIS_TENDON):
        option.flags[flag] = 0
    option.frame = mujoco.mjtFrame.mjFRAME_NONE
    option.label = mujoco.mjtLabel.mjLABEL_NONE
    return option


class GLScene:
    """A MuJoCo scene and its GL objects in the shared headless context, drawn offscreen on the context's thread into
    an RGB buffer (rows bottom-up, GL order) that the next drawing reuses. `fix`: what the one-line RenderingError
    tells the user to do when MuJoCo cannot render in the context."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, gl: HeadlessGL, fix: str) -> None:
        self.gl = gl
        self.scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        self.rect = mujoco.MjrRect(0, 0, width, height)
        self.rgb = np.empty((height, width, 3), dtype=np.uint8)
        try:
            self.context: mujoco.MjrContext | None = gl.call(mujoco.MjrContext, model,
                                                             mujoco.mjtFontScale.mjFONTSCALE_50)
        except mujoco.FatalError as exc:  # e.g. MuJoCo's GL loader bound to another backend earlier in the process
            raise RenderingError(f"MuJoCo cannot render in the {gl.backend} context ({exc}): {fix}") from None

    def draw_later(self) -> Future[np.ndarray]:
        """Draw the scene as it is now posed; the future's result is the RGB buffer."""
        if self.context is None:
            raise RuntimeError("drawing after close()")
        return self.gl.submit(self._draw)

    def _draw(self) -> np.ndarray:
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self.context)
        mujoco.mjr_render(self.rect, self.scene, self.context)
        mujoco.mjr_readPixels(self.rgb, None, self.rect, self.context)
        return self.rgb

    def close(self) -> None:
        """Free the GL objects (the shared context stays). Idempotent."""
        if self.context is not None:
            self.gl.call(self.context.free)
            self.context = None


class OffscreenCamera:
    """Renders the model's camera `camera` at width x height; render() returns bottom-up RGB rows (GL order).

    The scene is posed from its own MjData, whose kinematics are computed from the live qpos at each render:
    after mj_step, MjData's positions describe the start of the last step, one step behind qpos and the stamp.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, camera: str, width: int, height: int,
                 gl: HeadlessGL | None = None) -> None:
        if model.vis.global_.offwidth < width or model.vis.global_.offheight < height:
            raise ValueError(f"the model's offscreen buffer is {model.vis.global_.offwidth}x"
                             f"{model.vis.global_.offheight}, smaller than the {width}x{height} image: "
                             "add the camera with add_camera() before compiling")
        self.gl = gl or shared_context(width, height)
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.camera_name = camera
        self.option = visual_only_option()
        self.width, self.height = width, height
        self.target: GLScene | None = None
        self.rebind(model, data)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Render a recompiled model (a model was spawned or deleted): the GL context stays, the model's meshes and
        textures are uploaded again."""
        self.close()
        self.model, self.data = model, data
        self._pose = mujoco.MjData(model)
        self.camera.fixedcamid = model.camera(self.camera_name).id
        self.target = GLScene(model, self.width, self.height, self.gl, "run with --no-camera")

    def render(self) -> np.ndarray:
        """Render the current state; the returned buffer is reused by the next call."""
        return self.render_later().result()

    def render_later(self) -> Future[np.ndarray]:
        """Pose the scene at the current state now, and draw it on the GL context's thread: the future's result is
        render()'s. Nothing may render or pose this camera again before that result is taken."""
        if self.target is None:
            raise RuntimeError("render() after close()")
        pose = self._pose
        pose.qpos[:] = self.data.qpos
        pose.mocap_pos[:] = self.data.mocap_pos
        pose.mocap_quat[:] = self.data.mocap_quat
        mujoco.mj_kinematics(self.model, pose)
        mujoco.mj_camlight(self.model, pose)
        scene = self.target.scene
        mujoco.mjv_updateScene(self.model, pose, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_STATIC | mujoco.mjtCatBit.mjCAT_DYNAMIC, scene)
        for flag in _OFF:
            scene.flags[flag] = 0
        return self.target.draw_later()

    def close(self) -> None:
        """Free the GL objects of this camera (the shared GL context stays for the next camera)."""
        if self.target is not None:
            self.target.close()
            self.target = None
