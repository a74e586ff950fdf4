"""Camera frames per second at 640x480 in the empty and tunnel worlds: `python bench/bench_camera.py [--frames N]`.

Per world, with the car driving a 1 m/s, 0.2 rad circle (physics steps between frames are not timed):
  draw        scene update + drawing (the sky left out where it is one flat colour), finished (glFinish), not read
              back
  + readback  the same plus reading the pixels back (OffscreenCamera.render)
  full frame  what a 30 Hz tick costs: render, readback, flip to BGR, Gaussian noise, Image + CameraInfo, publish
  finish      the frame's finish alone, on the thread that takes it: flip to BGR, sky, noise (camera_noise.py)
and, for the full frame, the CPU it takes a frame on each thread (Linux: /proc/self/task/*/schedstat): the thread
that takes the frame (pose, finish, publish), the GL thread (MuJoCo's GL calls, Mesa's vertex work and triangle
binning, the pixels' readback) and llvmpipe's rasteriser threads; and how many geoms a frame draws (culling.py).
The OpenGL renderer is printed first: "llvmpipe" is Mesa's software rasteriser (no GPU).
"""

from __future__ import annotations

import argparse
import os
import threading
import time
from collections.abc import Callable

import mujoco

from racecar_sim.drivers import ConstantCommand
from racecar_sim.runtime import Simulator
from racecar_sim.sensors.camera import CameraPublisher


def _fps(sim: Simulator, frames: int, work: Callable[[int], object]) -> float:
    """Frames per wall second of `work(stamp)`, the car moving one camera period between frames."""
    period = 1 / sim.car.camera.spec.rate_hz
    wall = 0.0
    for _ in range(frames):
        sim.run_for(period)
        start = time.perf_counter()
        work(sim.time_ns)
        wall += time.perf_counter() - start
    return frames / wall


def _thread_ns(names: tuple[str, ...]) -> int:
    """CPU nanoseconds so far of this process's threads whose name starts with one of `names` (0 off Linux)."""
    total = 0
    try:
        tasks = os.listdir("/proc/self/task")
    except OSError:
        return 0
    for task in tasks:
        try:
            with open(f"/proc/self/task/{task}/comm") as comm, open(f"/proc/self/task/{task}/schedstat") as stat:
                if comm.read().startswith(names):
                    total += int(stat.read().split()[0])
        except OSError:
            continue  # a thread that ended
    return total


def _cpu(sim: Simulator, frames: int, camera: CameraPublisher) -> dict[str, float]:
    """CPU ms a full frame (camera._tick) on the calling thread, the GL thread and llvmpipe's threads, and the
    geoms drawn a frame."""
    period = 1 / camera.spec.rate_hz
    gl = camera.renderer.gl
    gl_thread = gl.call(threading.get_native_id)
    main = geoms = 0
    gl_before, raster_before = _task_ns(gl_thread), _thread_ns(("llvmpipe",))
    for _ in range(frames):
        sim.run_for(period)
        start = time.thread_time_ns()
        camera._tick(sim.time_ns)
        main += time.thread_time_ns() - start
        assert camera.renderer.target is not None
        geoms += camera.renderer.target.scene.ngeom
    return {
        "cpu main": main / frames / 1e6,
        "cpu GL": (_task_ns(gl_thread) - gl_before) / frames / 1e6,
        "cpu llvmpipe": (_thread_ns(("llvmpipe",)) - raster_before) / frames / 1e6,
        "geoms": geoms / frames,
    }


def _task_ns(tid: int) -> int:
    try:
        with open(f"/proc/self/task/{tid}/schedstat") as stat:
            return int(stat.read().split()[0])
    except OSError:
        return 0


def _draw(camera: CameraPublisher) -> Callable[[int], None]:
    from OpenGL import GL  # bound to the camera's backend by now

    renderer = camera.renderer

    def finish() -> None:
        target = renderer.target
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, target.context)
        mujoco.mjr_render(target.rect, target.scene, target.context)
        GL.glFinish()

    def draw(_: int) -> None:
        mujoco.mjv_updateScene(
            renderer.model,
            renderer.data,
            renderer.option,
            None,
            renderer.camera,
            mujoco.mjtCatBit.mjCAT_STATIC | mujoco.mjtCatBit.mjCAT_DYNAMIC,
            renderer.target.scene,
        )
        renderer.gl.call(finish)

    return draw


def measure(world: str, frames: int) -> tuple[str, dict[str, float]]:
    sim = Simulator(world=world, lidar=False)
    if sim.car.camera is None:
        raise SystemExit("the camera could not start (see the error above)")
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    camera = sim.car.camera
    camera._task.cancel()  # the bench calls the camera itself
    camera.renderer.render()  # warm up: shaders, textures
    rows = {
        "draw": _fps(sim, frames, _draw(camera)),
        "+ readback": _fps(sim, frames, lambda _: camera.renderer.render()),
    }
    sim.subscribe(camera.spec.image_topic, lambda msg: None)
    rows["full frame"] = _fps(sim, frames, camera._tick)
    rows.update(_cpu(sim, frames, camera))
    drawn = camera.renderer.render()  # a GL buffer as the GL thread leaves it; each stamp draws other noise
    rows["finish"] = _fps(sim, frames, lambda stamp: camera._finish(drawn, stamp))
    renderer = camera.gl_renderer
    sim.close()
    return renderer, rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300, help="frames per measurement (default 300)")
    parser.add_argument("--worlds", nargs="+", default=["empty", "tunnel"], help="worlds (default empty tunnel)")
    args = parser.parse_args()
    results = {world: measure(world, args.frames) for world in args.worlds}
    print(f"OpenGL: {next(iter(results.values()))[0]}; 640x480, {args.frames} frames per figure, one run")
    print(
        f"{'world':<8}{'draw fps':>10}{'+ readback fps':>16}{'full frame fps':>16}{'full frame ms':>15}"
        f"{'finish ms':>11}{'CPU ms main / GL / llvmpipe':>29}{'geoms':>7}"
    )
    for world, (_, rows) in results.items():
        print(
            f"{world:<8}{rows['draw']:>10.0f}{rows['+ readback']:>16.0f}{rows['full frame']:>16.0f}"
            f"{1e3 / rows['full frame']:>15.2f}{1e3 / rows['finish']:>11.2f}"
            f"{rows['cpu main']:>13.2f} / {rows['cpu GL']:.2f} / {rows['cpu llvmpipe']:.2f}{rows['geoms']:>7.1f}"
        )


if __name__ == "__main__":
    main()
