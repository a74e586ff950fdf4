"""The cameras' MjrContext begun early on the GL thread (render/offscreen.py: prepare_context while numba loads, each
texture size uploaded once through ctypes first): the camera takes that very context, one that no camera takes is
freed, and the model the camera draws keeps its own settings."""

from __future__ import annotations

import mujoco

from conftest import needs_gl
from racecar_sim.render.gl import shared_context
from racecar_sim.render.offscreen import _contexts, _warm_textures, drop_unclaimed_context, prepare_context

TEXTURED = """<mujoco><visual><quality shadowsize="2048"/></visual>
  <asset><texture name="g" type="2d" builtin="checker" width="16" height="48" rgb1="1 1 1" rgb2="0 0 0"/>
    <texture name="s" type="skybox" builtin="flat" rgb1=".2 .3 .4" width="8" height="8"/>
    <material name="g" texture="g"/></asset>
  <worldbody><geom size="1" material="g"/><camera name="c" pos="0 -3 1" xyaxes="1 0 0 0 .3 1"/></worldbody></mujoco>"""


def _entries(model):
    return [made for made in _contexts._contexts.values() if made.model is model]


@needs_gl
def test_a_prepared_context_is_the_one_a_camera_takes_and_an_unclaimed_one_is_freed():
    gl = shared_context()
    model = mujoco.MjModel.from_xml_string(TEXTURED)
    prepare_context(model)  # the shared context exists: begun at once on its thread
    [made] = _entries(model)
    assert made.users == 0
    taken = _contexts.take(model, gl)
    assert taken is made.context.result() and made.users == 1  # no second context made
    assert taken.shadowSize == 0 and model.vis.quality.shadowsize == 2048  # made from a copy without the map
    drop_unclaimed_context(model)  # taken: kept
    assert _entries(model) == [made]
    _contexts.give_back(model, gl)
    assert _entries(model) == []

    other = mujoco.MjModel.from_xml_string(TEXTURED)
    prepare_context(other)
    [unclaimed] = _entries(other)
    drop_unclaimed_context(other)
    assert _entries(other) == []
    gl.call(lambda: None)  # the thread has run its calls in order: the making, then the freeing
    assert unclaimed.context.done() and unclaimed.context.result().ntexture == 0  # freed (mjr_freeContext)


@needs_gl
def test_the_texture_warm_up_leaves_no_texture_and_no_state_behind():
    from OpenGL import GL  # bound to the context's backend by then

    gl = shared_context()
    model = mujoco.MjModel.from_xml_string(TEXTURED)

    def warm_and_look():
        first = GL.glGenTextures(1)
        GL.glDeleteTextures([first])
        _warm_textures(model)
        last = GL.glGenTextures(1)
        GL.glDeleteTextures([last])
        return {
            "error": GL.glGetError(),
            "left": [name for name in range(int(first), int(last) + 1) if GL.glIsTexture(name)],
            "bound": [GL.glGetIntegerv(GL.GL_TEXTURE_BINDING_2D), GL.glGetIntegerv(GL.GL_TEXTURE_BINDING_CUBE_MAP)],
            "enabled": [bool(GL.glIsEnabled(GL.GL_TEXTURE_2D)), bool(GL.glIsEnabled(GL.GL_TEXTURE_CUBE_MAP))],
            "made": int(last) - int(first) - 1,
        }

    seen = gl.call(warm_and_look)
    assert seen["made"] == 2  # the 2D texture's size and the skybox's
    assert seen["error"] == GL.GL_NO_ERROR
    assert seen["left"] == [] and seen["bound"] == [0, 0] and seen["enabled"] == [False, False]
