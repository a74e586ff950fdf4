"""Ask whether headless EGL works before trying it for real, leaving no trace in the process if it does not.

Why: MuJoCo's GL loader looks for `eglGetProcAddress` among the process's global symbols first, and loads its
function table once per process. PyOpenGL loads libEGL with RTLD_GLOBAL, so a failed EGL attempt through it
would make a later OSMesa context unusable to MuJoCo ("gladLoadGL error"). This probe loads libEGL with
RTLD_LOCAL through ctypes, so its symbols stay out of MuJoCo's sight.
"""

from __future__ import annotations

import ctypes

_PLATFORM_DEVICE = 0x313F  # EGL_PLATFORM_DEVICE_EXT
_OPENGL_API = 0x30A2  # EGL_OPENGL_API
_CONFIG = (
    0x3024,
    8,
    0x3023,
    8,
    0x3022,
    8,
    0x3025,
    24,  # red, green, blue, depth sizes
    0x3033,
    0x0001,  # surface type: pbuffer
    0x3040,
    0x0008,  # renderable type: OpenGL
    0x3038,
)  # EGL_NONE
_VP = ctypes.c_void_p


def egl_problem() -> str | None:
    """None if some EGL device gives an OpenGL context; otherwise a short reason."""
    try:
        egl = ctypes.CDLL("libEGL.so.1", mode=ctypes.RTLD_LOCAL)
    except OSError:
        return "libEGL.so.1 not found"
    egl.eglGetProcAddress.restype, egl.eglGetProcAddress.argtypes = _VP, [ctypes.c_char_p]
    query = egl.eglGetProcAddress(b"eglQueryDevicesEXT")
    get_display = egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
    if not query or not get_display:
        return "EGL lacks the device extensions needed without a display"
    devices, count = (_VP * 16)(), ctypes.c_int(0)
    query_devices = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, ctypes.POINTER(_VP), ctypes.POINTER(ctypes.c_int))
    if not query_devices(query)(16, devices, ctypes.byref(count)) or count.value == 0:
        return "no EGL device (is libgl1-mesa-dri installed?)"
    platform_display = ctypes.CFUNCTYPE(_VP, ctypes.c_uint, _VP, _VP)(get_display)
    for device in devices[: count.value]:
        display = platform_display(_PLATFORM_DEVICE, device, None)
        if display and _context_works(egl, display):
            return None
    return "no EGL device gives an OpenGL context (is libgl1-mesa-dri installed?)"


def _context_works(egl: ctypes.CDLL, display: int) -> bool:
    for fn, restype, argtypes in (
        ("eglInitialize", ctypes.c_uint, [_VP, _VP, _VP]),
        ("eglTerminate", ctypes.c_uint, [_VP]),
        ("eglBindAPI", ctypes.c_uint, [ctypes.c_uint]),
        ("eglChooseConfig", ctypes.c_uint, [_VP, _VP, _VP, ctypes.c_int, _VP]),
        ("eglCreateContext", _VP, [_VP, _VP, _VP, _VP]),
        ("eglDestroyContext", ctypes.c_uint, [_VP, _VP]),
    ):
        getattr(egl, fn).restype, getattr(egl, fn).argtypes = restype, argtypes
    if not egl.eglInitialize(display, None, None):
        return False
    try:
        attributes = (ctypes.c_int * len(_CONFIG))(*_CONFIG)
        config, found = _VP(), ctypes.c_int(0)
        chosen = egl.eglChooseConfig(display, attributes, ctypes.byref(config), 1, ctypes.byref(found))
        if not chosen or not found.value:
            return False
        if not egl.eglBindAPI(_OPENGL_API):
            return False
        context = egl.eglCreateContext(display, config, None, None)
        if not context:
            return False
        egl.eglDestroyContext(display, context)
        return True
    finally:
        egl.eglTerminate(display)
