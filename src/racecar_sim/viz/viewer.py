"""--viewer: MuJoCo's own viewer window on a running sim, following a car and drawing its lidar beams.

The window shows every car of the model (they are all in it); the camera follows one of them, the first at the
start, and follow() / cycle() (the FOLLOW_KEY, `.`, in the window) move it to another.

The window shows a private copy of the model and data, refreshed by each sync(). Whatever a person does in it
(its Reset button, the physics panel, joint sliders, Ctrl-drag perturbations) changes only that copy, so a run
with a window gives the same messages as one without.

Keys: MuJoCo's viewer passes only presses to us (no auto-repeat), so poll_keys() repeats a key itself while
GLFW reports it held. MuJoCo also acts on some letters itself, panels hidden or not: W wireframe, S shadows,
A auto-connect, D static bodies, X textures. Those are driving keys here, so their flags are put back at once
(option flags, in the key callback, before the next frame; render flags at the next sync(), so a frame or two
may show them).
Other MuJoCo shortcuts keep working (Tab panels, F1 help, C contacts, ...), and also stop the car.
FOLLOW_KEY is none of MuJoCo's shortcuts (not a flag's letter, not one of its own keys such as [ ] - =), and it is
not repeated while held.
"""

from __future__ import annotations

import copy
import logging
import math
import os
import queue
import re
import sys
import threading
import time
import warnings
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

log = logging.getLogger("racecar_sim")

OPEN_TIMEOUT = 60.0  # s for the window to come up: software GL on a busy machine can take a while
KEY_REPEAT = 0.1  # s between repeats of a held key; teleop keeps a command for 0.6 s after each key event
MAX_BEAMS = 120  # lidar beams drawn per frame, of up to 1081: each costs a draw call, software GL feels it
BEAM_WIDTH = 1.0  # px
BEAM_RGBA = np.array([1.0, 0.2, 0.1, 1.0], np.float32)  # opaque: measured faster than translucent on llvmpipe
CAMERA_DISTANCE = 2.5  # m from the car
CAMERA_ELEVATION = -25.0  # degrees, looking down
DRIVE_KEYS = "WASDX"
FOLLOW_KEY = "."  # follow the next car; GLFW_KEY_PERIOD is the character's code
# (index, default) of the flags MuJoCo toggles on a driving key; the strings are (name, default, shortcut)
_RND_FLAGS = [(i, int(s[1])) for i, s in enumerate(mujoco.mjRNDSTRING) if s[2] and s[2] in DRIVE_KEYS]
_VIS_FLAGS = [(i, int(s[1])) for i, s in enumerate(mujoco.mjVISSTRING) if s[2] and s[2] in DRIVE_KEYS]


class CarViewer:
    """The MuJoCo viewer in passive mode (our loop owns time), following a car and drawing the lidar beams.

    root_body: the MuJoCo body of the car to follow, or of each car in order (`car.names.mj(car.robot.root)`);
    the first is followed until follow() or cycle().
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, root_body: str | Sequence[str]) -> None:
        """Use open(): this only prepares the private copy the window will show."""
        self.source = data
        self.model = copy.copy(model)  # the viewer's panels write into mjModel.opt / .vis in passive mode
        self.data = mujoco.MjData(self.model)
        mujoco.mj_copyData(self.data, self.model, data)
        names = [root_body] if isinstance(root_body, str) else list(root_body)
        self.roots: list[int] = [self.model.body(name).id for name in names]
        self.following = 0
        self.handle: Any = None  # mujoco.viewer.Handle once the window is up
        self._thread: threading.Thread | None = None  # the viewer's own thread (window, events, rendering)
        self._keys: queue.SimpleQueue[int] = queue.SimpleQueue()
        self._window: Any = None  # the GLFW window, for the held-key state
        self._held: int | None = None
        self._next_repeat = 0.0

    @property
    def root(self) -> int:
        """The body id of the car the camera follows."""
        return self.roots[self.following]

    @classmethod
    def open(
        cls, model: mujoco.MjModel, data: mujoco.MjData, root_body: str | Sequence[str], asked_by: str = "the viewer"
    ) -> CarViewer | None:
        """The window, or None (with one warning line naming why) when there is no usable display. `asked_by`: what
        asked for it, as the user wrote it (`--viewer` on the CLI, `render_mode='human'` from Python), for the
        warning."""
        viewer = cls(model, data, root_body)
        problem = _display_problem()
        if problem is None:
            viewer.handle, viewer._thread, problem = _launch(viewer.model, viewer.data, viewer._on_key)
        if problem is not None:
            log.warning("%s: %s; continuing headless", asked_by, problem)
            return None
        viewer._setup_scene()
        return viewer

    def _setup_scene(self) -> None:
        with self.handle.lock():
            self._aim(self.handle.cam)
            scene = self.handle.user_scn
            for i in range(min(MAX_BEAMS, scene.maxgeom)):
                mujoco.mjv_initGeom(
                    scene.geoms[i], mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), np.eye(3).ravel(), BEAM_RGBA
                )
            scene.ngeom = 0

    def _aim(self, cam: Any) -> None:
        """Put the tracking camera behind the followed car, at the start distance and elevation."""
        xmat = self.data.xmat[self.root]
        cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        cam.trackbodyid = self.root
        cam.distance, cam.elevation = CAMERA_DISTANCE, CAMERA_ELEVATION
        cam.azimuth = math.degrees(math.atan2(xmat[3], xmat[0]))  # from behind the car
        cam.lookat[:] = self.data.subtree_com[self.root]

    def follow(self, index: int) -> None:
        """Follow car number `index` (0 for the first; wraps round), from behind it."""
        self.following = index % len(self.roots)
        if self.handle is not None:
            mujoco.mj_copyData(self.data, self.model, self.source)
            with self.handle.lock():
                self._aim(self.handle.cam)

    def cycle(self) -> int:
        """Follow the next car (after the last, the first again); returns its index."""
        self.follow(self.following + 1)
        return self.following

    def _on_key(self, key: int) -> None:
        """MuJoCo's key callback: on the viewer's thread, inside its event handling (under the viewer lock)."""
        if self._window is None:
            import glfw

            self._window = glfw.get_current_context()
        if self.handle is not None:
            for i, default in _VIS_FLAGS:
                self.handle.opt.flags[i] = default
        self._keys.put(key)

    def sync(self, beams: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Show the sim's current state, keep the camera on the car and draw `beams` = (origin (3,), ends (N, 3)),
        world coordinates; on the main thread, a few dozen times a second at most."""
        if not self.is_running():
            return
        mujoco.mj_copyData(self.data, self.model, self.source)
        with self.handle.lock():
            cam = self.handle.cam
            cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING  # Esc or a double-click would switch it away
            cam.trackbodyid = self.root
            self._draw_beams(beams)
        self.handle.sync()
        with self.handle.lock():
            flags = self.handle.user_scn.flags
            toggled = [(i, default) for i, default in _RND_FLAGS if flags[i] != default]
            for i, default in toggled:
                flags[i] = default  # a change in user_scn.flags reaches the viewer's scene at its next sync
        if toggled:
            self.handle.sync()

    def _draw_beams(self, beams: tuple[np.ndarray, np.ndarray] | None) -> None:
        scene = self.handle.user_scn
        if beams is None or len(beams[1]) == 0:
            scene.ngeom = 0
            return
        origin = np.asarray(beams[0], np.float64)
        ends = np.asarray(beams[1], np.float64)
        ends = ends[:: max(1, math.ceil(len(ends) / MAX_BEAMS))]
        n = min(len(ends), MAX_BEAMS, scene.maxgeom)
        for i in range(n):
            mujoco.mjv_connector(scene.geoms[i], mujoco.mjtGeom.mjGEOM_LINE, BEAM_WIDTH, origin, ends[i])
        scene.ngeom = n

    def poll_keys(self) -> list[str]:
        """Keys pressed in the window since the last call, lower case, plus repeats of a key still held."""
        now = time.perf_counter()
        keys = []
        while True:
            try:
                code = self._keys.get_nowait()
            except queue.Empty:
                break
            if 32 <= code < 127:  # printable; Esc, Tab, arrows, F-keys stay MuJoCo's
                keys.append(chr(code).lower())
                if chr(code) != FOLLOW_KEY:  # one car per press
                    self._held, self._next_repeat = code, now + KEY_REPEAT
        if self._held is not None and now >= self._next_repeat:
            if self._is_down(self._held):
                keys.append(chr(self._held).lower())
                self._next_repeat = now + KEY_REPEAT
            else:
                self._held = None
        return keys

    def _is_down(self, code: int) -> bool:
        """Whether GLFW has `code` held in our window. glfwGetKey only reads the window's key array; the lock
        keeps the window alive meanwhile (MuJoCo destroys it only after taking the lock to exit)."""
        if self._window is None or self.handle is None:
            return False
        import glfw

        with self.handle.lock():
            if not self.handle.is_running():
                return False
            try:
                return glfw.get_key(self._window, code) == glfw.PRESS
            except Exception:
                return False

    def is_running(self) -> bool:
        """False once the person closed the window (or after close())."""
        return self.handle is not None and self.handle.is_running()

    def close(self) -> None:
        """Close the window and wait for the viewer's thread to finish with it; idempotent."""
        handle, self.handle = self.handle, None
        if handle is not None:
            handle.close()
        # the thread destroys the window after close() returns; exiting meanwhile can crash in GLFW (mujoco#790)
        if self._thread is not None:
            self._thread.join(timeout=10.0)
            self._thread = None


def _display_problem() -> str | None:
    """Why there is surely no display to open a window on, or None."""
    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        return "no display (DISPLAY is not set)"
    return None


def _launch(model: mujoco.MjModel, data: mujoco.MjData, on_key: Any) -> tuple[Any, threading.Thread | None, str | None]:
    """(mujoco.viewer.Handle, the viewer's thread, None), or (None, None, why not).

    The known failures (no X server, no GLX) are found first by _glfw_problem(): in MuJoCo's viewer thread
    they end the process. launch_passive() then opens the window on a thread of its own and waits for it
    without a timeout, forever if that thread raises; so it runs on a helper thread, the viewer thread's
    exception is caught from threading.excepthook, and we give up after OPEN_TIMEOUT.
    """
    try:
        import glfw
        import mujoco.viewer
    except Exception as exc:
        return None, None, f"the MuJoCo viewer cannot load ({_one_line(exc)})"
    # on a thread of its own: probed on the main thread, where the camera's EGL context is current, the probe
    # window made the viewer's glXMakeCurrent fail later (X error BadAccess, which ends the process)
    probe: list[str | None] = []
    thread = threading.Thread(target=lambda: probe.append(_glfw_problem(glfw)), name="racecar-viewer-probe")
    thread.start()
    thread.join()
    problem = probe[0] if probe else "the display check failed"
    if problem is not None:
        return None, None, problem

    outcome: queue.SimpleQueue[Any] = queue.SimpleQueue()
    guard = threading.Lock()
    abandoned = False

    def opener() -> None:
        try:
            handle = mujoco.viewer.launch_passive(
                model, data, key_callback=on_key, show_left_ui=False, show_right_ui=False
            )
        except Exception as exc:
            outcome.put(exc)
            return
        with guard:
            if abandoned:
                handle.close()
            else:
                outcome.put(handle)

    previous_hook = threading.excepthook

    def hook(args: threading.ExceptHookArgs) -> None:
        if args.thread is not None and args.thread.name.endswith("(_launch_internal)"):
            outcome.put(args.exc_value)  # the viewer thread died opening the window
        else:
            previous_hook(args)

    threading.excepthook = hook
    before = set(threading.enumerate())
    try:
        threading.Thread(target=opener, name="racecar-viewer-open", daemon=True).start()
        try:
            result = outcome.get(timeout=OPEN_TIMEOUT)
        except queue.Empty:
            with guard:
                abandoned = True
            return None, None, f"the window did not open within {OPEN_TIMEOUT:g} s"
    finally:
        threading.excepthook = previous_hook
    if isinstance(result, BaseException):
        return None, None, f"could not open the window ({_one_line(result)})"
    return result, _viewer_thread(before), None


def _viewer_thread(before: set[threading.Thread]) -> threading.Thread | None:
    """The thread launch_passive() started (named after its target, mujoco.viewer._launch_internal)."""
    new = [t for t in threading.enumerate() if t not in before and t.name.endswith("(_launch_internal)")]
    return new[0] if new else None


def _glfw_problem(glfw: Any) -> str | None:
    """Initialise GLFW and make a hidden window like the viewer's, here, where a failure has a reason we can
    print; None when both work. MuJoCo's viewer thread would fail with 'ERROR: could not create window' and end
    the whole process (exit code 1), e.g. on an X server without GLX. The viewer reuses this initialisation."""
    problem = None
    failure: str | None = None  # what an exception from GLFW said, after its warnings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # pyGLFW reports GLFW's errors as warnings
        try:
            if not glfw.init():
                problem = "no display"
            else:
                glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
                glfw.window_hint(glfw.SAMPLES, 4)  # as the viewer asks
                window = glfw.create_window(64, 64, "racecar-sim", None, None)
                glfw.default_window_hints()
                if window:
                    glfw.destroy_window(window)
                else:
                    problem = "no OpenGL window on this display"
        except Exception as exc:
            failure = str(exc)
            problem = problem or "no display"
    if problem is None:
        return None
    texts = [str(w.message) for w in caught] + ([] if failure is None else [failure])
    reasons = [_glfw_text(text) for text in texts] or ["no reason given"]
    return f"{problem} (GLFW: {'; '.join(reasons)})"


def _glfw_text(text: str) -> str:
    """pyGLFW's "(65550) b'X11: Failed to open display :99'" as "X11: Failed to open display :99"."""
    match = re.fullmatch(r"\(\d+\) b?['\"](.*)['\"]", text.strip())
    return match.group(1) if match else _one_line(text)


def _one_line(exc: object) -> str:
    text = " ".join(str(exc).split())
    return text or type(exc).__name__
