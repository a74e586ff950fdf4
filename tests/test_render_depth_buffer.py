"""The cameras' offscreen framebuffer keeps MuJoCo's 32-bit float depth without its stencil (render/depth_buffer.py),
and their context has no shadow map (render/offscreen.py): the frames and the depth images are those of MuJoCo's own
context, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import needs_gl, random_car_poses
from racecar_sim import Simulator


def _attachments(context):
    """(depth renderbuffer's internal format, stencil attachment's object type) of the context's offscreen FBO."""
    from OpenGL import GL

    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, context.offFBO)
    GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, context.offDepthStencil)
    depth = GL.glGetRenderbufferParameteriv(GL.GL_RENDERBUFFER, GL.GL_RENDERBUFFER_INTERNAL_FORMAT)
    stencil = GL.glGetFramebufferAttachmentParameteriv(
        GL.GL_FRAMEBUFFER, GL.GL_STENCIL_ATTACHMENT, GL.GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE
    )
    return int(depth), int(stencil)


def _draw_with_mujocos_buffer(model, scene, rect, width, height):
    """The scene drawn by a fresh MjrContext, as MuJoCo makes it: RGBA (GL rows), and colour and depth as
    mjr_readPixels gives them."""
    import mujoco
    from OpenGL import GL

    context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50)
    try:
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, context)
        mujoco.mjr_render(rect, scene, context)
        rgba = np.empty((height, width, 4), dtype=np.uint8)
        GL.glReadPixels(0, 0, width, height, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, rgba)
        rgb = np.empty((height, width, 3), dtype=np.uint8)
        depth = np.empty((height, width), dtype=np.float32)
        mujoco.mjr_readPixels(rgb, depth, rect, context)
        return rgba, rgb, depth, _attachments(context)
    finally:
        context.free()


@needs_gl
@pytest.mark.parametrize("world", ["walker", "tunnel"])
def test_frames_and_depth_are_mujocos_with_the_depth_only_buffer(world):
    from OpenGL import GL

    sim = Simulator(world=world, seed=5, lidar=False, camera=True, sensor_noise=False)
    renderer = sim.car.camera.renderer
    target = renderer.target
    assert target is not None
    gl = renderer.gl
    ours = gl.call(_attachments, target.context)
    assert ours == (GL.GL_DEPTH_COMPONENT32F, GL.GL_NONE), "the cameras' framebuffer still has a stencil"
    assert target.context.shadowSize == 0 == target.context.shadowFBO  # no shadow map: they draw without shadows
    assert sim.model.vis.quality.shadowsize == 4096  # the model's own setting is left as it was
    for k, _ in enumerate(random_car_poses(sim, 6, seed=23)):
        rgba = renderer.render_later().result().copy()
        scene = target.scene  # the scene just drawn
        theirs, _, _, made = gl.call(
            _draw_with_mujocos_buffer, sim.model, scene, target.rect, renderer.width, renderer.height
        )
        assert made == (GL.GL_DEPTH32F_STENCIL8, GL.GL_RENDERBUFFER), "MuJoCo's own buffer is not the one replaced"
        # `theirs` comes from MuJoCo's own context, with its shadow map: the same pixels
        assert np.array_equal(rgba, theirs), f"pose {k}: {(rgba != theirs).any(axis=2).sum()} pixels differ"
        rgb, depth, _, _ = renderer.render_depth_later().result()
        rgb, depth = rgb.copy(), depth.copy()
        _, their_rgb, their_depth, _ = gl.call(
            _draw_with_mujocos_buffer, sim.model, target.scene, target.rect, renderer.width, renderer.height
        )
        assert np.array_equal(rgb, their_rgb) and np.array_equal(depth, their_depth), f"pose {k}: depth differs"
    sim.close()
