"""A headless OpenGL context for the camera: EGL or OSMesa, made by MuJoCo's own `mujoco.egl` / `mujoco.osmesa`.

MUJOCO_GL=egl or osmesa picks the backend; otherwise (unset, glfw, ...) EGL is tried, then OSMesa.

PyOpenGL binds itself to one platform, read from PYOPENGL_PLATFORM, the first time it is imported, and
`mujoco.egl` / `mujoco.osmesa` refuse to load under another one. `import mujoco` imports the MUJOCO_GL backend
(and so PyOpenGL) when MUJOCO_GL is egl or osmesa, and nothing of PyOpenGL otherwise; so either PyOpenGL is
already bound to the backend MUJOCO_GL names, or it is not imported yet and setting PYOPENGL_PLATFORM just before
we import a backend is early enough. A failed attempt drops the PyOpenGL modules it imported, so that the next
backend binds PyOpenGL afresh. If other code imported PyOpenGL first, its platform is the only one that can work.

Nothing here runs on import: `guard_mujoco_import` is called where racecar-sim is about to import MuJoCo for the
first time (`racecar_sim.Simulator` / `Car` on first use, the CLI after its subcommand's import, a camera's context),
and the CLI imports its subcommand inside `mujoco_gl_disabled`.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import importlib
import os
import queue
import sys
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TypeVar

from racecar_sim.core.errors import RenderingError
from racecar_sim.render.egl_probe import egl_problem

T = TypeVar("T")
BACKENDS = ("egl", "osmesa")
LABELS = {"egl": "EGL", "osmesa": "OSMesa"}
PACKAGES = {"egl": "libegl1 libgl1-mesa-dri", "osmesa": "libosmesa6"}
_SONAMES = {"egl": ("libEGL.so.1", "libEGL.so"), "osmesa": ("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so")}

__all__ = [
    "BACKENDS",
    "HeadlessGL",
    "RenderingError",
    "create_context",
    "guard_mujoco_import",
    "library_present",
    "mujoco_gl_disabled",
    "shared_context",
    "start_shared_context",
    "when_shared_context",
]


@dataclass
class HeadlessGL:
    """An OpenGL context with no window, current on a thread of its own: every mjr_* call goes through call() or
    submit(), so the GL work of a frame may overlap the physics on the main thread (MuJoCo's calls release the
    GIL), and any thread may ask for a frame."""

    backend: str  # egl | osmesa
    context: Any  # mujoco.egl.GLContext or mujoco.osmesa.GLContext
    renderer: str  # GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" for Mesa's software rasteriser
    thread: GLThread  # the context is current on it

    def submit(self, fn: Callable[..., T], *args: Any) -> Future[T]:
        """Run fn(*args) on the context's thread; its result (or error) comes with the future."""
        return self.thread.submit(fn, *args)

    def call(self, fn: Callable[..., T], *args: Any) -> T:
        """Run fn(*args) on the context's thread and return its result."""
        return self.thread.submit(fn, *args).result()

    def free(self) -> None:
        """Destroy the context and stop its thread."""
        try:
            self.call(self.context.free)
        finally:
            self.thread.stop()


class GLThread:
    """One daemon thread running submitted calls in order (a GL context stays current on the thread that made it).

    Not a ThreadPoolExecutor: that refuses work once the interpreter starts exiting, and the context is freed by an
    atexit hook, through this thread."""

    def __init__(self) -> None:
        self._jobs: queue.SimpleQueue[tuple[Callable[..., Any], tuple[Any, ...], Future[Any]] | None] = (
            queue.SimpleQueue()
        )
        threading.Thread(target=self._run, name="racecar-sim GL", daemon=True).start()

    def submit(self, fn: Callable[..., T], *args: Any) -> Future[T]:
        future: Future[T] = Future()
        self._jobs.put((fn, args, future))
        return future

    def stop(self) -> None:
        self._jobs.put(None)

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            fn, args, future = job
            try:
                future.set_result(fn(*args))
            except BaseException as exc:
                future.set_exception(exc)


_OFF = ("disable", "disabled", "off", "false", "0")
_shared: HeadlessGL | None = None
_shared_error: str | None = None
_starting: Future[HeadlessGL] | None = None  # start_shared_context()'s, until shared_context() takes it
_unclaimed: HeadlessGL | None = None  # what it made, until shared_context() takes it
_requested_before_import: str | None = None


def guard_mujoco_import() -> None:
    """Import mujoco safely when MUJOCO_GL names a backend whose library is missing; call before mujoco's import.

    mujoco imports that backend as it is imported itself, and without its library (no libOSMesa for osmesa, no
    libEGL for egl) PyOpenGL fails with an AttributeError that mujoco does not catch: the whole package would not
    import. Then mujoco is imported with MUJOCO_GL=disable instead, MUJOCO_GL is put back, and the camera later
    reports the missing library as a RenderingError.
    """
    global _requested_before_import
    requested = os.environ.get("MUJOCO_GL", "").strip().lower()
    if requested not in BACKENDS or "mujoco" in sys.modules or library_present(requested):
        return
    _requested_before_import = requested
    with mujoco_gl_disabled():
        importlib.import_module("mujoco")


@contextmanager
def mujoco_gl_disabled() -> Iterator[None]:
    """Inside, importing mujoco leaves out mujoco's own GL backend (MUJOCO_GL=disable, put back on the way out).

    For a process whose only OpenGL is this module's context and the viewer's own glfw (the CLI): mujoco's
    GLContext / Renderer go unused, and leaving them out saves the GLFW or PyOpenGL load (~60 ms of start-up)
    and the failure of a MUJOCO_GL backend without its library. A no-op once mujoco is imported.
    """
    if "mujoco" in sys.modules:
        yield
        return
    previous = os.environ.get("MUJOCO_GL")
    os.environ["MUJOCO_GL"] = "disable"
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop("MUJOCO_GL", None)
        else:
            os.environ["MUJOCO_GL"] = previous


_START_WAIT_S = 30.0  # the longest an exit waits for a context being made (it takes 0.1-1 s)


def start_shared_context(width: int = 640, height: int = 480) -> None:
    """Begin making the process's headless context (shared_context's) now, on a thread of its own, so that the
    driver's loading and EGL's set-up (C, without the GIL) overlap what the caller does meanwhile; shared_context()
    takes it, or its error. Nothing happens where the context exists, has failed, or is being made."""
    global _starting
    if _shared is not None or _shared_error is not None or _starting is not None:
        return
    starting: Future[HeadlessGL] = Future()

    def make() -> None:
        try:
            made = create_context(width, height)
        except BaseException as exc:
            starting.set_exception(exc)
            return
        global _unclaimed
        _unclaimed = made  # freed at exit by _settle_start where a build failed before its camera took it
        starting.set_result(made)

    _starting = starting
    # a process that exits while the driver is still being set up (a build that failed at once) would tear the
    # driver's globals down under the thread making the context: glibc then aborts ("double free")
    atexit.register(_settle_start, starting)
    threading.Thread(target=make, name="racecar-sim GL start", daemon=True).start()


def _settle_start(starting: Future[HeadlessGL]) -> None:
    """At exit: wait for start_shared_context()'s thread to finish making the context, then free it if no camera
    took it."""
    with contextlib.suppress(TimeoutError):
        starting.exception(timeout=_START_WAIT_S)
    _free_unclaimed()


def when_shared_context(fn: Callable[[HeadlessGL], object]) -> None:
    """Call fn(context) with the process's headless context once it is made: now where it is, or on the thread that
    start_shared_context() began; never where none is made or being made, or where making it failed. For work to
    hand to the context's thread early (fn must not wait for it)."""
    made = _shared or _unclaimed
    if made is not None:
        fn(made)
    elif _starting is not None:
        _starting.add_done_callback(lambda done: None if done.exception() is not None else fn(done.result()))


def shared_context(width: int = 640, height: int = 480) -> HeadlessGL:
    """The process's headless context, created on first use (or by start_shared_context) and kept; every camera
    renders through it.

    Creating a context costs 0.1-1 s, so cameras share one (each has its own MjrContext in it). A failure is
    remembered too, and raised again as the same one-line RenderingError without a second attempt.
    """
    global _shared, _shared_error, _starting, _unclaimed
    if _shared is None:
        if _shared_error is not None:
            raise RenderingError(_shared_error)
        try:
            if _starting is not None:
                starting, _starting = _starting, None
                _shared = starting.result()
                _unclaimed = None  # freed by _free_shared from now on
            else:
                _shared = create_context(width, height)
        except RenderingError as exc:
            _shared_error = str(exc)
            raise
        atexit.register(_free_shared)  # while Python still runs: OSMesa's own __del__ fails at interpreter exit
    return _shared


def _free_unclaimed() -> None:
    global _unclaimed
    if _unclaimed is not None:
        made, _unclaimed = _unclaimed, None
        made.free()


def _free_shared() -> None:
    global _shared
    if _shared is not None:
        _shared.free()
        _shared = None


def create_context(width: int = 640, height: int = 480) -> HeadlessGL:
    """A new context on the first backend that works; RenderingError (one line) if none does.

    width, height: size of OSMesa's default framebuffer (MuJoCo renders into its own offscreen buffer).
    """
    guard_mujoco_import()  # the backend's import below imports mujoco itself when nothing has yet
    requested = _requested_before_import or os.environ.get("MUJOCO_GL", "").strip().lower()
    if requested in _OFF:
        raise RenderingError(
            f"MUJOCO_GL={requested} switches OpenGL off: unset it (or set egl or osmesa), or run with --no-camera"
        )
    if requested in BACKENDS:
        candidates = [requested]
    else:
        bound = _pyopengl_platform()
        if bound and bound not in BACKENDS:
            raise RenderingError(
                f"PyOpenGL was imported for the {bound} platform before the camera could choose: "
                "set PYOPENGL_PLATFORM=egl (or osmesa), or run with --no-camera"
            )
        candidates = [bound] if bound else list(BACKENDS)
        requested = ""
    thread = GLThread()
    reasons: dict[str, str] = {}
    for backend in candidates:
        try:
            context, renderer = thread.submit(_open, backend, width, height).result()
            return HeadlessGL(backend, context, renderer, thread)
        except Exception as exc:
            reasons[backend] = _reason(backend, exc)
    thread.stop()
    raise RenderingError(_message(reasons, requested))


def _open(backend: str, width: int, height: int) -> tuple[Any, str]:
    """A context of `backend`, current on the calling thread, and its GL_RENDERER."""
    bound = _pyopengl_platform()
    if bound is not None and bound != backend:
        raise RuntimeError(f"PyOpenGL was already imported for the {bound} platform")
    fresh = bound is None
    if fresh and backend == "egl":
        problem = egl_problem()  # a failed attempt through PyOpenGL would leave OSMesa unusable to MuJoCo
        if problem:
            raise RuntimeError(problem)
    previous = os.environ.get("PYOPENGL_PLATFORM")
    os.environ["PYOPENGL_PLATFORM"] = backend
    try:
        module = importlib.import_module(f"mujoco.{backend}")
        context = module.GLContext(width, height)
        context.make_current()
        return context, _renderer_string()
    except Exception:
        if fresh:
            _forget_pyopengl()
            if previous is None:
                os.environ.pop("PYOPENGL_PLATFORM", None)
            else:
                os.environ["PYOPENGL_PLATFORM"] = previous
        raise


def _pyopengl_platform() -> str | None:
    """The platform PyOpenGL is already bound to (egl, osmesa, or another name), or None if not yet imported."""
    platform = sys.modules.get("OpenGL.platform")
    if platform is None or getattr(platform, "PLATFORM", None) is None:
        return None
    name = type(platform.PLATFORM).__name__
    return name.removesuffix("Platform").lower()  # EGLPlatform, OSMesaPlatform, GLXPlatform, ...


def _forget_pyopengl() -> None:
    """Drop the PyOpenGL modules a failed attempt imported, so that the next one re-reads PYOPENGL_PLATFORM."""
    for name in list(sys.modules):
        if name == "OpenGL" or name.startswith(("OpenGL.", "mujoco.egl", "mujoco.osmesa")):
            del sys.modules[name]


def library_present(backend: str) -> bool:
    """Whether the backend's library (libEGL or libOSMesa) loads; loaded RTLD_LOCAL, so MuJoCo does not see it."""
    for soname in _SONAMES[backend]:
        try:
            ctypes.CDLL(soname, mode=ctypes.RTLD_LOCAL)
            return True
        except OSError:
            continue
    return False


def _renderer_string() -> str:
    from racecar_sim.render import gl_calls  # not PyOpenGL's GL module: 0.1-0.2 s of imports holding the GIL

    try:
        return gl_calls.renderer()
    except Exception:
        return "unknown"


def _reason(backend: str, exc: Exception) -> str:
    if backend in BACKENDS and not library_present(backend):
        return f"{_SONAMES[backend][0]} not found"
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text.split(". ")[0][:120]


def _message(reasons: dict[str, str], requested: str) -> str:
    tried = "; ".join(f"{LABELS.get(b, b)}: {why}" for b, why in reasons.items())
    backends = [b for b in reasons if b in PACKAGES] or list(BACKENDS)
    packages = " or ".join(f"{PACKAGES[b]} ({LABELS[b]})" for b in backends)
    other = f", or unset MUJOCO_GL to try {LABELS[BACKENDS[requested == 'egl']]} too" if requested else ""
    return f"no headless OpenGL for the camera ({tried}): apt-get install {packages}{other}, or run with --no-camera"
