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

log = logging.getLogger("racecar_sim")


def drop_stencil(context: mujoco.MjrContext) -> bool:
    """Make `context`'s offscreen depth-stencil renderbuffer a depth-only one of the same size and precision; on the
    context's GL thread, before it draws. Whether it was changed (False: left as MuJoCo made it)."""
    from OpenGL import GL  # bound to the context's backend: the context was made through mujoco.egl/osmesa

    if context.offSamples or not context.offFBO or not context.offDepthStencil:
        return False  # a multisampled buffer is resolved through a second one: left to MuJoCo
    width, height = context.offWidth, context.offHeight
    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, context.offFBO)
    GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, context.offDepthStencil)
    made = GL.glGetRenderbufferParameteriv(GL.GL_RENDERBUFFER, GL.GL_RENDERBUFFER_INTERNAL_FORMAT)
    if made != GL.GL_DEPTH32F_STENCIL8:
        return False  # another depth precision (another MuJoCo): a depth-only one of it is not worth the check
    try:
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_STENCIL_ATTACHMENT, GL.GL_RENDERBUFFER, 0)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_DEPTH_COMPONENT32F, width, height)
        GL.glFramebufferRenderbuffer(
            GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT, GL.GL_RENDERBUFFER, context.offDepthStencil
        )
        if GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER) == GL.GL_FRAMEBUFFER_COMPLETE:
            return True
    except GL.GLError as exc:
        log.debug("the offscreen depth buffer keeps its stencil: %s", exc)
    GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT, GL.GL_RENDERBUFFER, 0)
    GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_DEPTH32F_STENCIL8, width, height)
    GL.glFramebufferRenderbuffer(
        GL.GL_FRAMEBUFFER, GL.GL_DEPTH_STENCIL_ATTACHMENT, GL.GL_RENDERBUFFER, context.offDepthStencil
    )
    return False
