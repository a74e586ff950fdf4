"""--viewer: the MuJoCo window on a virtual X display (Xvfb), driven with WASD through xdotool; without a display,
one warning line and a headless run; and the window beside the camera's offscreen EGL/OSMesa rendering.

The X tests skip where Xvfb or xdotool is missing (.ci/run installs them). Waits are generous and nothing asserts
on durations: CI is a 2-core machine rendering with software GL.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import select
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

WAIT = 60.0  # s for Xvfb to start and for the viewer window to appear
HAVE_X = bool(shutil.which("Xvfb") and shutil.which("xdotool"))
needs_x = pytest.mark.skipif(not HAVE_X, reason="needs Xvfb and xdotool (apt-get install xvfb xdotool)")
NO_DISPLAY_LINE = "racecar-sim: --viewer: no display (DISPLAY is not set); continuing headless"


@contextlib.contextmanager
def xvfb(*options: str):
    """A fresh Xvfb server on a display number it picks itself (-displayfd); killed on exit. Tried again when
    the display it names does not answer (Xvfbs starting at the same moment can trip over each other)."""
    for _ in range(3):
        server, name = _start_xvfb(options)
        try:
            if name is not None:
                yield name
                return
        finally:
            server.terminate()
            try:
                server.wait(timeout=10)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
    pytest.fail(f"could not start Xvfb {' '.join(options)}")


def _start_xvfb(options: tuple[str, ...]) -> tuple[subprocess.Popen, str | None]:
    """The server and its display name, or None for the name when it did not come up and answer."""
    read_end, write_end = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_end), "-screen", "0", "1280x1024x24", "-nolisten", "tcp", *options],
        pass_fds=(write_end,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write_end)
    try:
        number = _read_line(read_end, WAIT)
    finally:
        os.close(read_end)
    if not number.isdigit():
        return server, None
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and server.poll() is None:
        if xdotool(f":{number}", "getdisplaygeometry").returncode == 0:
            return server, f":{number}"
        time.sleep(0.5)
    return server, None


@pytest.fixture(scope="module")
def display():
    """An X display for the module's tests."""
    if not HAVE_X:
        pytest.skip("needs Xvfb and xdotool (apt-get install xvfb xdotool)")
    with xvfb() as name:
        yield name


def _read_line(fd: int, timeout: float) -> str:
    """The first line written to `fd` ('' if none came before the timeout or the writer closed it)."""
    deadline, data = time.monotonic() + timeout, b""
    while b"\n" not in data:
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        chunk = os.read(fd, 64) if ready else b""
        if not chunk:
            break
        data += chunk
    return data.decode(errors="replace").strip()


def x_env(display: str | None) -> dict[str, str]:
    """The environment with DISPLAY set to `display` (removed if None) and no Wayland display."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    if display is not None:
        env["DISPLAY"] = display
    return env


def xdotool(display: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["xdotool", *args], env=x_env(display), capture_output=True, text=True, timeout=30)


def find_window(display: str, proc: subprocess.Popen, stderr: Path) -> str:
    """The MuJoCo window's id, once it shows the model ("MuJoCo : <model>" is set after loading)."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"the sim exited ({proc.returncode}) before its window appeared: {stderr.read_text()}")
        found = xdotool(display, "search", "--name", "^MuJoCo : ").stdout.split()
        if found:
            return found[0]
        time.sleep(0.5)
    pytest.fail(f"no MuJoCo window within {WAIT:g} s: {stderr.read_text()}")


def hold(display: str, window: str, key: str, seconds: float) -> None:
    """Press `key` in the window, keep it down for `seconds`, release it."""
    assert xdotool(display, "keydown", "--window", window, key).returncode == 0
    time.sleep(seconds)
    assert xdotool(display, "keyup", "--window", window, key).returncode == 0


def window_colours(display: str, window: str) -> int:
    """How many distinct colours the window shows right now."""
    from PIL import ImageGrab

    geometry = dict(
        line.split("=", 1) for line in xdotool(display, "getwindowgeometry", "--shell", window).stdout.split()
    )
    x, y, w, h = (int(geometry[k]) for k in ("X", "Y", "WIDTH", "HEIGHT"))
    image = ImageGrab.grab(bbox=(x, y, x + w, y + h), xdisplay=display)
    return len(image.getcolors(maxcolors=1 << 24) or ())


def odometry(path: Path) -> list[tuple[float, float, float]]:
    """(x, y, yaw) of every /vesc/odom message in an MCAP, in order."""
    poses = []
    with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        connections = [c for c in reader.connections if c.topic == "/vesc/odom"]
        for connection, _, raw in reader.messages(connections=connections):
            pose = reader.deserialize(raw, connection.msgtype).pose.pose
            q = pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            poses.append((pose.position.x, pose.position.y, yaw))
    return poses


@needs_x
def test_wasd_in_the_viewer_drives_the_car(display, tmp_path):
    out, stderr = tmp_path / "drive.mcap", tmp_path / "stderr.txt"
    with stderr.open("w") as err:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "racecar_sim",
                "teleop",
                "--world",
                "empty",
                "--viewer",
                "--no-camera",
                "--duration",
                "12",
                "--record",
                str(out),
            ],
            env=x_env(display),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        try:
            window = find_window(display, proc, stderr)
            hold(display, window, "w", 3.0)
            colours = window_colours(display, window)
            hold(display, window, "a", 2.0)
            proc.wait(timeout=300)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    assert proc.returncode == 0, stderr.read_text()
    assert colours > 50, f"the window looks blank ({colours} colours)"
    poses = odometry(out)
    forward = next((p for p in poses if p[0] > 0.3), None)
    assert forward is not None, f"w did not drive the car 0.3 m forward: last pose {poses[-1]}"
    assert abs(forward[1]) < 0.05 and abs(forward[2]) < 0.05, f"w did not drive straight: {forward}"
    x, y, yaw = poses[-1]
    assert yaw > forward[2] + 0.2 and y > 0.05, f"a did not turn the car left: last pose {poses[-1]}"


def run_headless(tmp_path: Path, display: str | None) -> list[str]:
    """`racecar-sim run --viewer` on `display`: it must finish (exit code 0) without a window; its stderr lines
    about the viewer."""
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "run",
            "--world",
            "empty",
            "--no-camera",
            "--duration",
            "2",
            "--viewer",
            "--out",
            str(tmp_path),
        ],
        env=x_env(display),
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr and "ERROR" not in result.stderr, result.stderr
    return [line for line in result.stderr.splitlines() if "viewer" in line.lower() or "glfw" in line.lower()]


def test_viewer_without_a_display_runs_headless(tmp_path):
    assert run_headless(tmp_path, None) == [NO_DISPLAY_LINE]


def test_viewer_on_a_display_nobody_serves_runs_headless(tmp_path):
    taken = {p.name[1:] for p in Path("/tmp/.X11-unix").glob("X*")} if Path("/tmp/.X11-unix").is_dir() else set()
    lines = run_headless(tmp_path, f":{next(n for n in range(987, 2000) if str(n) not in taken)}")
    assert len(lines) == 1, lines
    assert lines[0].startswith("racecar-sim: --viewer: no display (GLFW: ") and lines[0].endswith(
        "; continuing headless"
    ), lines


@needs_x
def test_viewer_on_a_display_without_glx_runs_headless(tmp_path):
    """MuJoCo's viewer thread would end the process ('ERROR: could not create window', exit code 1)."""
    with xvfb("-extension", "GLX") as no_glx:
        lines = run_headless(tmp_path, no_glx)
    assert len(lines) == 1, lines
    assert lines[0].startswith("racecar-sim: --viewer: no OpenGL window on this display (GLFW: "), lines


CAMERA_AND_VIEWER = """
import hashlib, json, os
from racecar_sim import Simulator
from racecar_sim.drivers import ConstantCommand
from racecar_sim.viz.viewer import CarViewer

sim = Simulator(world="walker", camera=True)
frames, variety = [], []

def on_image(msg):
    frames.append(hashlib.sha256(bytes(msg.data)).hexdigest())
    variety.append(len(set(bytes(msg.data)[::101])))

sim.subscribe("/camera/zed/rgb/image_rect_color", on_image)
viewer = CarViewer.open(sim.model, sim.data, sim.car.robot.root) if sim.car.camera else None
colours = 0
for lap in range(2):  # the second lap makes a new camera (reset) while the window is open
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.3)
    for _ in range(30):
        sim.run_for(1 / 30)
        if viewer:
            viewer.sync(None)
    if lap == 0:
        sim.reset()
if viewer:
    from PIL import ImageGrab
    colours = len(ImageGrab.grab(xdisplay=os.environ["DISPLAY"]).getcolors(maxcolors=1 << 24) or ())
    viewer.close()
print(json.dumps({"camera": sim.car.camera is not None, "viewer": viewer is not None, "frames": frames,
                  "variety": min(variety or [0]), "colours": colours}))
"""


def run_camera_script(display: str | None) -> dict:
    result = subprocess.run(
        [sys.executable, "-c", CAMERA_AND_VIEWER], env=x_env(display), capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


@needs_x
def test_camera_and_viewer_share_the_process(display):
    """The window (GLX) and the camera's headless context (EGL or OSMesa) coexist: the camera's images are
    bit-identical with the window open, also for a camera made after the window opened."""
    with_window = run_camera_script(display)
    if not with_window["camera"]:
        pytest.skip("no headless OpenGL for the camera here")
    assert with_window["viewer"], "the viewer did not open beside the camera"
    assert with_window["colours"] > 50, f"the window looks blank ({with_window['colours']} colours)"
    assert with_window["variety"] > 20, "the camera images look blank"
    headless = run_camera_script(None)
    assert not headless["viewer"]
    assert len(with_window["frames"]) >= 50  # 2 s at 30 Hz
    assert with_window["frames"] == headless["frames"]
