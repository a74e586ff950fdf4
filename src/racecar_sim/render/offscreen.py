"""Offscreen rendering of one MuJoCo camera into a reused buffer, with the settings that keep software GL fast.

Only the visual geom group is drawn (collision geoms, sites, joints and other decorations are not), with MSAA,
shadows and reflections off: Mesa's llvmpipe renders about ten times faster that way.

The sky: MuJoCo draws its skybox last, a cube-mapped cylinder wherever nothing else is, and llvmpipe pays for the
cube map on every one of those pixels (about 2.5 ms of a 5.5 ms frame in walker, where a quarter of the image is
sky). When the skybox is one colour and nothing drawn is translucent (`flat_sky`), the camera draws without it
and reads RGBA instead: MuJoCo clears to alpha 0 and every opaque geom writes alpha 1, so the sky is exactly the
pixels left at alpha 0, and painting them the sky's colour gives the skybox's image bit for bit.

A fleet's cameras: every camera of one model draws with the same MjrContext (its meshes, textures and offscreen
framebuffer, made once), one after the other on the GL thread, each reading its image into its own buffer before the
next draws. Drawing each camera into a framebuffer of its own cost 60 % more a camera with four cars (4.6 ms against
2.8 ms a frame): llvmpipe's caches go cold switching between four framebuffers of 2.4 MB each. The images are the
same bit for bit: the same drawing into the same-sized buffer at the same place.
"""

from __future__ import annotations

import copy
import logging
import threading
from concurrent.futures import Future
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import RenderingError
from racecar_sim.physics.world_geoms import VISUAL_GROUP
from racecar_sim.render import gl_calls
from racecar_sim.render.culling import FrustumCuller
from racecar_sim.render.depth_buffer import drop_stencil, keeps_stencil
from racecar_sim.render.gl import HeadlessGL, shared_context, when_shared_context

log = logging.getLogger("racecar_sim")
_OFF = (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION, mujoco.mjtRndFlag.mjRND_HAZE)
_SKYBOX = mujoco.mjtRndFlag.mjRND_SKYBOX


def visual_only_option() -> mujoco.MjvOption:
    """Scene options that draw the visual geom group and nothing else."""
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[VISUAL_GROUP] = 1
    for groups in (
        option.sitegroup,
        option.jointgroup,
        option.tendongroup,
        option.actuatorgroup,
        option.flexgroup,
        option.skingroup,
    ):
        groups[:] = 0
    for flag in (mujoco.mjtVisFlag.mjVIS_RANGEFINDER, mujoco.mjtVisFlag.mjVIS_PERTOBJ, mujoco.mjtVisFlag.mjVIS_TENDON):
        option.flags[flag] = 0
    option.frame = mujoco.mjtFrame.mjFRAME_NONE
    option.label = mujoco.mjtLabel.mjLABEL_NONE
    return option


def flat_sky(model: mujoco.MjModel) -> np.ndarray | None:
    """The one RGB colour (uint8) MuJoCo's skybox paints, or None when the skybox must be drawn: the model has no
    skybox, or the first one (the one MuJoCo draws) is not a single colour, or something in the visual group is
    translucent (blending over the cleared background would differ from blending over the sky)."""
    skyboxes = np.flatnonzero(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)
    if skyboxes.size == 0:
        return None
    tex = int(skyboxes[0])
    channels = int(model.tex_nchannel[tex])
    size = int(model.tex_width[tex]) * int(model.tex_height[tex]) * channels
    texels = model.tex_data[model.tex_adr[tex] : model.tex_adr[tex] + size].reshape(-1, channels)
    if channels < 3 or not (texels == texels[0]).all():
        return None
    visual = model.geom_group == VISUAL_GROUP
    materials = model.geom_matid[visual]
    if (model.geom_rgba[visual, 3] < 1).any() or (model.mat_rgba[materials[materials >= 0], 3] < 1).any():
        return None
    sky: np.ndarray = texels[0, :3].astype(np.uint8)
    return sky


def _make_context(model: mujoco.MjModel, shadows: bool) -> mujoco.MjrContext:
    """The model's MjrContext, on the GL thread; without `shadows`, without the shadow map: MuJoCo makes a
    shadowsize² depth texture (4096² by default) that scenes drawn with mjRND_SHADOW off never touch, and
    llvmpipe takes ~0.1 s to allocate and set it up (0.2 s of a camera's start the first time). Made from a copy
    whose shadowsize is 0: MjrContext releases the GIL while it uploads, so the live model is never changed."""
    if not shadows:
        model = copy.copy(model)
        model.vis.quality.shadowsize = 0
    _warm_textures(model)
    context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50)
    drop_stencil(context)
    return context


@dataclass
class _Made:
    """A model's MjrContext in a HeadlessGL: being made or made, on the context's thread, and how many GLScenes use
    it (the model is kept while it is counted, so its id is not reused meanwhile)."""

    model: mujoco.MjModel
    gl: HeadlessGL
    context: Future[mujoco.MjrContext]
    users: int = 0


def _warm_textures(model: mujoco.MjModel) -> None:
    """Upload and mipmap, once, a texture of each kind and size of the model's, through ctypes (gl_calls), before
    MjrContext uploads the real ones.

    Mesa's llvmpipe spends 0.2-0.5 s on the first upload of a texture of a given size in a process (the second is
    milliseconds), and MjrContext holds the GIL all that time: a camera's start would wait that long for Python
    on its other threads. A ctypes call lets go of the GIL, so done here that time overlaps the build (numba's load)
    instead. The textures are zeros, deleted at once: MjrContext then makes and draws with its own as always."""
    kinds: set[tuple[int, int, int, int, int]] = set()
    srgb = getattr(getattr(mujoco, "mjtColorSpace", None), "mjCOLORSPACE_SRGB", None)
    for tex in range(model.ntex):
        channels, width, height = int(model.tex_nchannel[tex]), int(model.tex_width[tex]), int(model.tex_height[tex])
        if channels not in (3, 4):
            continue  # MuJoCo's classic renderer skips them too
        if model.tex_type[tex] != mujoco.mjtTexture.mjTEXTURE_2D:
            kinds.add((gl_calls.GL_TEXTURE_CUBE_MAP, gl_calls.GL_RGB, width, width, 3))  # six faces of width²
            continue
        is_srgb = srgb is not None and int(model.tex_colorspace[tex]) == int(srgb)
        internal = {
            (4, False): gl_calls.GL_RGBA,
            (4, True): gl_calls.GL_SRGB8_ALPHA8,
            (3, False): gl_calls.GL_RGB,
            (3, True): gl_calls.GL_SRGB8,
        }[(channels, is_srgb)]
        kinds.add((gl_calls.GL_TEXTURE_2D, internal, width, height, channels))
    for kind in sorted(kinds):
        try:
            gl_calls.mipmapped_texture(*kind)
        except gl_calls.GLError as exc:  # only time is at stake: MjrContext uploads as always
            log.debug("no texture warm-up: %s", exc)
            return


class _SharedContexts:
    """The MjrContext of each model in a HeadlessGL, with or without the shadow map, made on the context's thread by
    the first GLScene of that model that asks for it, or earlier by prepare(), and freed with the last GLScene
    (counted); freed on the context's thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._contexts: dict[tuple[int, int, bool], _Made] = {}  # by (gl, model, shadows)

    def prepare(self, model: mujoco.MjModel, gl: HeadlessGL, shadows: bool = False) -> None:
        """Begin making the model's MjrContext on the context's thread now, for the GLScene that takes it later (the
        first in a context costs 0.2-0.3 s of llvmpipe's set-up, in C without the GIL: the caller goes on meanwhile).
        One nobody takes is freed by drop_unclaimed()."""
        key = (id(gl), id(model), shadows)
        with self._lock:
            if key not in self._contexts:
                self._contexts[key] = _Made(model, gl, gl.submit(_make_context, model, shadows))

    def take(self, model: mujoco.MjModel, gl: HeadlessGL, shadows: bool = False) -> mujoco.MjrContext:
        key = (id(gl), id(model), shadows)
        with self._lock:
            made = self._contexts.get(key)
            if made is None:
                made = self._contexts[key] = _Made(model, gl, gl.submit(_make_context, model, shadows))
            made.users += 1
        try:
            return made.context.result()
        except BaseException:
            with self._lock:  # not made: the next GLScene tries again
                if self._contexts.get(key) is made:
                    del self._contexts[key]
            raise

    def give_back(self, model: mujoco.MjModel, gl: HeadlessGL, shadows: bool = False) -> None:
        key = (id(gl), id(model), shadows)
        with self._lock:
            made = self._contexts[key]
            made.users -= 1
            if made.users > 0:
                return
            del self._contexts[key]
        gl.call(made.context.result().free)

    def drop_unclaimed(self, model: mujoco.MjModel) -> None:
        """Free the model's MjrContexts that prepare() began and no GLScene took (a build that failed, a camera that
        was not made)."""
        with self._lock:
            keys = [key for key, made in self._contexts.items() if made.model is model and made.users == 0]
            dropped = [self._contexts.pop(key) for key in keys]
        for made in dropped:
            made.gl.submit(_free_made, made.context)  # after its making: the thread runs its calls in order


def _free_made(context: Future[mujoco.MjrContext]) -> None:
    """Free a made MjrContext, on the context's thread (a failed one: nothing to free)."""
    if context.exception() is None:
        context.result().free()


_contexts = _SharedContexts()


def prepare_context(model: mujoco.MjModel) -> None:
    """Begin making the MjrContext the model's cameras will draw with, on the shared headless context's thread once
    that is made (start_shared_context), so that llvmpipe's first upload overlaps the rest of the build; nothing
    where no context is being made. drop_unclaimed_context(model) frees it if no camera takes it."""
    when_shared_context(lambda gl: _contexts.prepare(model, gl))


def drop_unclaimed_context(model: mujoco.MjModel) -> None:
    """Free what prepare_context(model) made and no camera took."""
    _contexts.drop_unclaimed(model)


class GLScene:
    """A MuJoCo scene and its GL objects in the shared headless context, drawn offscreen on the context's thread into
    an RGB buffer (rows bottom-up, GL order) that the next drawing reuses. `fix`: what the one-line RenderingError
    tells the user to do when MuJoCo cannot render in the context. draw_later() reads RGB (the skybox drawn);
    draw_rgba_later() reads RGBA, without the skybox where `sky` (flat_sky) is its colour. `shadows`: whether its
    scenes may be drawn with mjRND_SHADOW on (the cameras turn it off: their context has no shadow map).

    Two MjvScenes take turns (flip()), each with its own RGBA buffer: the next frame is posed into one while the GL
    thread still draws the other, so the GL thread goes from one frame to the next without waiting for the simulation
    to take the first, and a frame's pixels stay in its buffer until that scene is drawn again."""

    def __init__(
        self, model: mujoco.MjModel, width: int, height: int, gl: HeadlessGL, fix: str, shadows: bool = False
    ) -> None:
        self.gl = gl
        self.shadows = shadows
        self.scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        self.culler = FrustumCuller(self.scene, width, height)
        self.rect = mujoco.MjrRect(0, 0, width, height)
        self.rgb = np.empty((height, width, 3), dtype=np.uint8)
        self.rgba = np.empty((height, width, 4), dtype=np.uint8)
        self._spare: tuple[mujoco.MjvScene, FrustumCuller, np.ndarray] | None = None  # made by the first flip()
        self.depth: np.ndarray | None = None  # made by the first depth drawing
        self.sky = flat_sky(model)
        self.model = model
        try:
            self.context: mujoco.MjrContext | None = _contexts.take(model, gl, shadows)  # shared by the model's cameras
        except mujoco.FatalError as exc:  # e.g. MuJoCo's GL loader bound to another backend earlier in the process
            raise RenderingError(f"MuJoCo cannot render in the {gl.backend} context ({exc}): {fix}") from None
        self._stencil = gl.call(keeps_stencil, self.context)  # a stencil to clear before each drawing

    def flip(self) -> mujoco.MjvScene:
        """Make the other scene `scene` (with its `culler` and `rgba` buffer), to be posed while a drawing of this one
        may be in flight; returns it."""
        if self._spare is None:
            model, (height, width) = self.model, self.rgba.shape[:2]
            spare = mujoco.MjvScene(model, maxgeom=self.scene.maxgeom)
            self._spare = (spare, FrustumCuller(spare, width, height), np.empty_like(self.rgba))
        (self.scene, self.culler, self.rgba), self._spare = self._spare, (self.scene, self.culler, self.rgba)
        return self.scene

    def draw_later(self) -> Future[np.ndarray]:
        """Draw the scene as it is now posed; the future's result is the RGB buffer."""
        if self.context is None:
            raise RuntimeError("drawing after close()")
        return self.gl.submit(self._draw, self.scene)

    def draw_rgba_later(self) -> Future[np.ndarray]:
        """Draw the scene as it is now posed, the skybox left out where `sky` is set (its pixels then keep alpha 0);
        the future's result is the RGBA buffer."""
        if self.context is None:
            raise RuntimeError("drawing after close()")
        return self.gl.submit(self._draw_rgba, self.scene, self.rgba)

    def draw_depth_later(self) -> Future[tuple[np.ndarray, np.ndarray, float, float]]:
        """Draw the scene as it is now posed (the skybox drawn); the future's result is the RGB buffer, the depth
        buffer (float32 in [0, 1], GL rows) and the near and far clip distances in metres it was drawn with."""
        if self.context is None:
            raise RuntimeError("drawing after close()")
        near, far = self.scene.camera[0].frustum_near, self.scene.camera[0].frustum_far
        return self.gl.submit(self._draw_depth, self.scene, near, far)

    def _draw_depth(
        self, scene: mujoco.MjvScene, near: float, far: float
    ) -> tuple[np.ndarray, np.ndarray, float, float]:
        if self.depth is None:
            self.depth = np.empty(self.rgb.shape[:2], dtype=np.float32)
        scene.flags[_SKYBOX] = 1
        self._start_drawing()
        mujoco.mjr_render(self.rect, scene, self.context)
        mujoco.mjr_readPixels(self.rgb, self.depth, self.rect, self.context)
        return self.rgb, self.depth, near, far

    def _draw(self, scene: mujoco.MjvScene) -> np.ndarray:
        scene.flags[_SKYBOX] = 1
        self._start_drawing()
        mujoco.mjr_render(self.rect, scene, self.context)
        mujoco.mjr_readPixels(self.rgb, None, self.rect, self.context)
        return self.rgb

    def _start_drawing(self) -> None:
        """Bind the offscreen framebuffer and clear its stencil, where it kept one (depth_buffer.drop_stencil was
        refused). MuJoCo clears colour and depth but not the stencil, which it uses only for reflections (off here);
        llvmpipe keeps depth and stencil in one 64-bit word, and clearing the depth alone is a read-modify-write of
        every word. Cleared before mjr_render draws anything, the two clears merge into one plain fill: 0.13 ms less
        a 640x480 frame, the same pixels. Without a stencil (drop_stencil) nothing is cleared: two GL calls less."""
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self.context)
        if self._stencil:
            gl_calls.clear(gl_calls.GL_STENCIL_BUFFER_BIT)

    def _draw_rgba(self, scene: mujoco.MjvScene, rgba: np.ndarray) -> np.ndarray:
        scene.flags[_SKYBOX] = self.sky is None
        self._start_drawing()
        mujoco.mjr_render(self.rect, scene, self.context)
        return gl_calls.read_rgba(0, 0, self.rect.width, self.rect.height, rgba)

    def close(self) -> None:
        """Free the GL objects once no other camera of the model draws with them (the shared GL context stays).
        Idempotent."""
        if self.context is not None:
            self.context = None
            _contexts.give_back(self.model, self.gl, self.shadows)


class OffscreenCamera:
    """Renders the model's camera of id `camera` (bound by its node: nodes/parts.py) at width x height; render() returns
    bottom-up RGBA rows (GL order) in
    which the pixels of alpha 0 are the sky, to be painted `sky` when that is not None (GLScene.draw_rgba_later).

    The scene is posed from its own MjData, whose kinematics are computed from the live qpos at each render:
    after mj_step, MjData's positions describe the start of the last step, one step behind qpos and the stamp.
    The geoms that cannot reach the image are left out of the drawing (`cull`, culling.py): the same image, sooner.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        camera: int,
        width: int,
        height: int,
        gl: HeadlessGL | None = None,
    ) -> None:
        if model.vis.global_.offwidth < width or model.vis.global_.offheight < height:
            raise ValueError(
                f"the model's offscreen buffer is {model.vis.global_.offwidth}x"
                f"{model.vis.global_.offheight}, smaller than the {width}x{height} image: "
                "add the camera with add_camera() before compiling"
            )
        self.gl = gl or shared_context(width, height)
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.option = visual_only_option()
        self.cull = True
        self.width, self.height = width, height
        self.target: GLScene | None = None
        self.rebind(model, data, camera)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData, camera: int) -> None:
        """Render a recompiled model (a model was spawned or deleted) from its camera `camera` (its id there): the GL
        context stays, the model's meshes and textures are uploaded again."""
        if not 0 <= camera < model.ncam:
            raise ValueError(f"camera id {camera} is not one of the model's {model.ncam} cameras")
        self.close()
        self.model, self.data = model, data
        self._pose = pose = mujoco.MjData(model)
        # (posed, live) pairs of array views, made once: an MjData's arrays stay where they are for its lifetime
        self._copies = (
            (pose.qpos, data.qpos),
            (pose.mocap_pos, data.mocap_pos),
            (pose.mocap_quat, data.mocap_quat),
        )
        self.camera.fixedcamid = camera
        self.target = GLScene(model, self.width, self.height, self.gl, "run with --no-camera")

    @property
    def sky(self) -> np.ndarray | None:
        """The RGB colour of the pixels render() leaves at alpha 0, or None when it drew the skybox itself."""
        return self.target.sky if self.target is not None else None

    def render(self) -> np.ndarray:
        """Render the current state; the returned buffer is reused by the next call."""
        return self.render_later().result()

    def render_later(self) -> Future[np.ndarray]:
        """Pose the scene at the current state now, and draw it on the GL context's thread: the future's result is
        render()'s buffer. The scenes take turns: one more render may be asked while this one is in flight (the
        camera asks for the next frame before it takes this one); the one after that draws into this buffer again."""
        self._pose_scene()
        assert self.target is not None
        return self.target.draw_rgba_later()

    def _pose_scene(self) -> None:
        if self.target is None:
            raise RuntimeError("render() after close()")
        pose = self._pose
        for posed, live in self._copies:
            posed[:] = live
        mujoco.mj_kinematics(self.model, pose)
        mujoco.mj_camlight(self.model, pose)
        scene = self.target.flip()  # the previous frame's scene may still be drawing
        mujoco.mjv_updateScene(
            self.model,
            pose,
            self.option,
            None,
            self.camera,
            mujoco.mjtCatBit.mjCAT_STATIC | mujoco.mjtCatBit.mjCAT_DYNAMIC,
            scene,
        )
        flags = scene.flags
        for flag in _OFF:
            flags[flag] = 0
        if self.cull:
            self.target.culler.cull()

    def render_depth_later(self) -> Future[tuple[np.ndarray, np.ndarray, float, float]]:
        """As render_later(), drawing the skybox and reading colour and depth: GLScene.draw_depth_later()'s result."""
        self._pose_scene()
        assert self.target is not None
        return self.target.draw_depth_later()

    def close(self) -> None:
        """Free the GL objects of this camera (the shared GL context stays for the next camera)."""
        if self.target is not None:
            self.target.close()
            self.target = None
