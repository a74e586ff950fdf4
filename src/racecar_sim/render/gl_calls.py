"""The few OpenGL calls racecar-sim makes itself, through ctypes from the library PyOpenGL's platform already loaded.

MuJoCo draws; racecar-sim only reads pixels, clears the stencil, reshapes the depth buffer and asks the renderer's
name (render/offscreen.py, depth_buffer.py, gl.py). `from OpenGL import GL` for those builds PyOpenGL's wrappers of
every GL function: 0.1-0.2 s of the camera's start, on the GL thread but holding the GIL that the build needs. These
are the same C functions, called on the same arguments: the same pixels. As PyOpenGL does by default, every call is
followed by glGetError, and an error raises GLError.

Call them on the thread where the context is current (HeadlessGL's), after `mujoco.egl` or `mujoco.osmesa` made it:
that import loaded PyOpenGL's platform, which names the library (libOpenGL for EGL, libOSMesa for OSMesa).
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

import numpy as np

# the enums used (GL/glext.h)
GL_RENDERER = 0x1F01
GL_STENCIL_BUFFER_BIT = 0x00000400
GL_RGBA = 0x1908
GL_UNSIGNED_BYTE = 0x1401
GL_FRAMEBUFFER = 0x8D40
GL_RENDERBUFFER = 0x8D41
GL_RENDERBUFFER_INTERNAL_FORMAT = 0x8D44
GL_DEPTH_ATTACHMENT = 0x8D00
GL_DEPTH_STENCIL_ATTACHMENT = 0x821A
GL_DEPTH32F_STENCIL8 = 0x8CAD
GL_DEPTH_COMPONENT32F = 0x8CAC
GL_FRAMEBUFFER_COMPLETE = 0x8CD5
GL_RGB = 0x1907
GL_SRGB8 = 0x8C41
GL_SRGB8_ALPHA8 = 0x8C43
GL_TEXTURE0 = 0x84C0
GL_TEXTURE_2D = 0x0DE1
GL_TEXTURE_CUBE_MAP = 0x8513
GL_TEXTURE_CUBE_MAP_POSITIVE_X = 0x8515
GL_TEXTURE_MIN_FILTER = 0x2801
GL_LINEAR_MIPMAP_LINEAR = 0x2703

_uint, _int, _sizei, _void_p = ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_void_p
# name: (result type, argument types)
_SIGNATURES: dict[str, tuple[Any, list[Any]]] = {
    "glGetError": (_uint, []),
    "glGetString": (ctypes.c_char_p, [_uint]),
    "glClear": (None, [_uint]),
    "glReadPixels": (None, [_int, _int, _sizei, _sizei, _uint, _uint, _void_p]),
    "glBindFramebuffer": (None, [_uint, _uint]),
    "glBindRenderbuffer": (None, [_uint, _uint]),
    "glGetRenderbufferParameteriv": (None, [_uint, _uint, ctypes.POINTER(_int)]),
    "glFramebufferRenderbuffer": (None, [_uint, _uint, _uint, _uint]),
    "glRenderbufferStorage": (None, [_uint, _uint, _sizei, _sizei]),
    "glCheckFramebufferStatus": (_uint, [_uint]),
    "glGenTextures": (None, [_sizei, ctypes.POINTER(_uint)]),
    "glDeleteTextures": (None, [_sizei, ctypes.POINTER(_uint)]),
    "glActiveTexture": (None, [_uint]),
    "glEnable": (None, [_uint]),
    "glDisable": (None, [_uint]),
    "glBindTexture": (None, [_uint, _uint]),
    "glTexParameteri": (None, [_uint, _uint, _int]),
    "glTexImage2D": (None, [_uint, _int, _int, _sizei, _sizei, _int, _uint, _uint, _void_p]),
    "glGenerateMipmap": (None, [_uint]),
    "glFinish": (None, []),
}


class GLError(RuntimeError):
    """A GL call left an error (glGetError's code)."""


@functools.cache
def _function(name: str) -> Any:
    """The C function `name` of the platform's GL library (or, where that does not export it, the address the
    platform's GetProcAddress gives), typed."""
    from OpenGL import platform  # loaded with the backend (mujoco.egl / mujoco.osmesa): no new import

    restype, argtypes = _SIGNATURES[name]
    library = platform.PLATFORM.GL
    try:
        fn = getattr(library, name)
    except AttributeError:
        address = platform.PLATFORM.getExtensionProcedure(name.encode())
        if not address:
            raise GLError(f"{name}: not in the GL library") from None
        fn = ctypes.CFUNCTYPE(restype, *argtypes)(address)
    fn.restype, fn.argtypes = restype, argtypes
    return fn


def _call(name: str, *args: Any) -> Any:
    result = _function(name)(*args)
    error = _function("glGetError")()
    if error:
        raise GLError(f"{name}: GL error 0x{error:04x}")
    return result


def renderer() -> str:
    """GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" for Mesa's software rasteriser."""
    name = _call("glGetString", GL_RENDERER)
    return name.decode() if name else "unknown"


def clear(mask: int) -> None:
    _call("glClear", mask)


def read_rgba(x: int, y: int, width: int, height: int, out: np.ndarray) -> np.ndarray:
    """glReadPixels of RGBA bytes into `out` (C-contiguous uint8, height x width x 4); returns `out`."""
    if out.dtype != np.uint8 or not out.flags.c_contiguous or out.size < width * height * 4:
        raise ValueError(f"read_rgba needs a C-contiguous uint8 array of {height}x{width}x4, not {out.shape}")
    _call("glReadPixels", x, y, width, height, GL_RGBA, GL_UNSIGNED_BYTE, out.ctypes.data)
    return out


def bind_framebuffer(target: int, framebuffer: int) -> None:
    _call("glBindFramebuffer", target, framebuffer)


def bind_renderbuffer(target: int, renderbuffer: int) -> None:
    _call("glBindRenderbuffer", target, renderbuffer)


def renderbuffer_parameter(target: int, name: int) -> int:
    value = _int(0)
    _call("glGetRenderbufferParameteriv", target, name, ctypes.byref(value))
    return value.value


def framebuffer_renderbuffer(target: int, attachment: int, renderbuffer_target: int, renderbuffer: int) -> None:
    _call("glFramebufferRenderbuffer", target, attachment, renderbuffer_target, renderbuffer)


def renderbuffer_storage(target: int, internal_format: int, width: int, height: int) -> None:
    _call("glRenderbufferStorage", target, internal_format, width, height)


def check_framebuffer_status(target: int) -> int:
    result: int = _call("glCheckFramebufferStatus", target)
    return result


def mipmapped_texture(target: int, internal_format: int, width: int, height: int, channels: int) -> None:
    """Upload a texture of zeros of this kind and size as MuJoCo's mjr_uploadTexture does (a cube map: six faces
    of width x width), generate its mipmaps, and delete it: the GL state is left as it was (texture unit 0 active,
    nothing bound, the target disabled)."""
    name = _uint(0)
    _call("glGenTextures", 1, ctypes.byref(name))
    try:
        _call("glActiveTexture", GL_TEXTURE0)
        _call("glEnable", target)
        _call("glBindTexture", target, name.value)
        _call("glTexParameteri", target, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR)
        pixel_format = GL_RGBA if channels == 4 else GL_RGB
        zeros = np.zeros(width * max(height, width) * channels, np.uint8)
        faces = [GL_TEXTURE_2D] if target == GL_TEXTURE_2D else [GL_TEXTURE_CUBE_MAP_POSITIVE_X + i for i in range(6)]
        for face in faces:
            _call("glTexImage2D", face, 0, internal_format, width, height, 0, pixel_format, GL_UNSIGNED_BYTE,
                  zeros.ctypes.data)  # fmt: skip
        _call("glGenerateMipmap", target)
        _call("glFinish")
    finally:
        _call("glBindTexture", target, 0)
        _call("glDisable", target)
        _call("glDeleteTextures", 1, ctypes.byref(name))
