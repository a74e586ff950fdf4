"""The offscreen framebuffer's depth without a stencil: MuJoCo's depth precision, half the memory.

MuJoCo gives its offscreen framebuffer a 32-bit float depth with an 8-bit stencil (GL_DEPTH32F_STENCIL8), and uses
the stencil only to draw reflections, which the cameras turn off. Mesa's llvmpipe stores that format as 8 bytes a
pixel: every frame clears and depth-tests 2.4 MB at 640x480. The same 32-bit float depth alone (GL_DEPTH_COMPONENT32F)
is 4 bytes a pixel, and the depth tests compare the same values, so every pixel drawn is the same: 1.7 to 1.4 ms a
frame. Where the GL refuses the change, MuJoCo's buffer is put back as it was.
"""

from __future__ import annotations

import logging

import mujoco

from racecar_sim.render import gl_calls as gl

log = logging.getLogger("racecar_sim")


def drop_stencil(context: mujoco.MjrContext) -> bool:
    """Make `context`'s offscreen depth-stencil renderbuffer a depth-only one of the same size and precision; on the
    context's GL thread, before it draws. Whether it was changed (False: left as MuJoCo made it)."""
    if context.offSamples or not context.offFBO or not context.offDepthStencil:
        return False  # a multisampled buffer is resolved through a second one: left to MuJoCo
    width, height = context.offWidth, context.offHeight
    gl.bind_framebuffer(gl.GL_FRAMEBUFFER, context.offFBO)
    gl.bind_renderbuffer(gl.GL_RENDERBUFFER, context.offDepthStencil)
    made = gl.renderbuffer_parameter(gl.GL_RENDERBUFFER, gl.GL_RENDERBUFFER_INTERNAL_FORMAT)
    if made != gl.GL_DEPTH32F_STENCIL8:
        return False  # another depth precision (another MuJoCo): a depth-only one of it is not worth the check
    try:
        gl.framebuffer_renderbuffer(gl.GL_FRAMEBUFFER, gl.GL_DEPTH_STENCIL_ATTACHMENT, gl.GL_RENDERBUFFER, 0)
        gl.renderbuffer_storage(gl.GL_RENDERBUFFER, gl.GL_DEPTH_COMPONENT32F, width, height)
        gl.framebuffer_renderbuffer(
            gl.GL_FRAMEBUFFER, gl.GL_DEPTH_ATTACHMENT, gl.GL_RENDERBUFFER, context.offDepthStencil
        )
        if gl.check_framebuffer_status(gl.GL_FRAMEBUFFER) == gl.GL_FRAMEBUFFER_COMPLETE:
            return True
    except gl.GLError as exc:
        log.debug("the offscreen depth buffer keeps its stencil: %s", exc)
    gl.framebuffer_renderbuffer(gl.GL_FRAMEBUFFER, gl.GL_DEPTH_ATTACHMENT, gl.GL_RENDERBUFFER, 0)
    gl.renderbuffer_storage(gl.GL_RENDERBUFFER, gl.GL_DEPTH32F_STENCIL8, width, height)
    gl.framebuffer_renderbuffer(
        gl.GL_FRAMEBUFFER, gl.GL_DEPTH_STENCIL_ATTACHMENT, gl.GL_RENDERBUFFER, context.offDepthStencil
    )
    return False


def keeps_stencil(context: mujoco.MjrContext) -> bool:
    """Whether `context`'s offscreen depth buffer has a stencil (False after drop_stencil changed it); on the
    context's GL thread."""
    if context.offSamples or not context.offFBO or not context.offDepthStencil:
        return True  # left to MuJoCo: assume it has one
    gl.bind_renderbuffer(gl.GL_RENDERBUFFER, context.offDepthStencil)
    return gl.renderbuffer_parameter(gl.GL_RENDERBUFFER, gl.GL_RENDERBUFFER_INTERNAL_FORMAT) != gl.GL_DEPTH_COMPONENT32F
