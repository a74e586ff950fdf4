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
