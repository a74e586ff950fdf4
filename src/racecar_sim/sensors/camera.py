"""The ZED camera (left lens): gazebo_ros_camera on MuJoCo offscreen rendering.

Two steps, because the Simulator compiles the model before nodes exist:
  add_camera(spec, sensor)   puts a MuJoCo camera on the camera link of the MjSpec, before compiling;
  CameraPublisher(ctx, sensor)  renders it at the sensor's rate and publishes Image + CameraInfo, stamped in sim time.

Rendering happens only when someone listens (gazebo_ros_camera renders only for subscribers); the schedule is
kept regardless, and the noise of a frame depends only on (seed, stamp), so skipping frames changes no other.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from concurrent.futures import Future

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError, RenderingError
from racecar_sim.core.names import CarNames
from racecar_sim.core.rng import NoiseTable
from racecar_sim.core.time import NS_PER_S
from racecar_sim.core.transforms import quat_from_rpy, quat_mul
from racecar_sim.description.urdf import Robot, Sensor
from racecar_sim.msgs import CameraInfo, Header, Image
from racecar_sim.msgs.cdr_layout import CdrLayout
from racecar_sim.nodes import NodeBase, NodeContext, Parts
from racecar_sim.render.offscreen import OffscreenCamera
from racecar_sim.sensors.camera_spec import CameraSpec

__all__ = [
    "CameraPublisher",
    "CameraSpec",
    "RenderingError",
    "add_camera",
    "add_noise",
    "camera_parts",
    "camera_spec",
    "set_clip",
]

NOISE_STREAM = "camera"
ORIGINAL_TOPIC = "/camera/zed/rgb/image_rect_color"  # its camera keeps the original noise stream, `camera`
_NO_NOISE = np.zeros(1, dtype=np.float32)  # the noise table finish_frame gets when there is no noise
_NO_SKY = np.zeros(3, dtype=np.uint8)  # the sky finish_frame gets when the skybox was drawn
# A MuJoCo camera looks along its -z with +y up; Gazebo's looks along the link's +x with +z up. This rotation
# takes the camera axes to the link's: x_cam = -y_link, y_cam = +z_link, z_cam = -x_link.
LOOK_ALONG_X = np.array([0.5, 0.5, -0.5, -0.5])


def camera_spec(robot: Robot, names: CarNames = CarNames()) -> CameraSpec:
    """The robot's first camera sensor block, parsed, with the car's names (MuJoCo camera and link, topics, frame);
    DescriptionError if it has none."""
    sensor = robot.sensor("camera")
    if sensor is None:
        raise DescriptionError(f'robot {robot.name} has no <sensor type="camera"> (is DISABLE_GAZEBO_CAMERA set?)')
    return named_camera_spec(sensor, names)


def named_camera_spec(sensor: Sensor | CameraSpec, names: CarNames = CarNames()) -> CameraSpec:
    """A camera sensor block (or its spec, parsed already) with the car's names."""
    spec = sensor if isinstance(sensor, CameraSpec) else CameraSpec.from_sensor(sensor)
    return dataclasses.replace(
        spec,
        name=names.mj(spec.name),
        link=names.mj(spec.link),
        image_topic=names.topic(spec.image_topic),
        info_topic=names.topic(spec.info_topic),
        frame_id=names.frame(spec.frame_id),
    )


def add_camera(spec: mujoco.MjSpec, sensor: Sensor | CameraSpec, names: CarNames = CarNames()) -> None:
    """Add a camera sensor block's MuJoCo camera to `spec` (before compiling): on its link's body, at the sensor pose,
    with the sensor's vertical field of view, and an offscreen buffer large enough for its image."""
    cam = named_camera_spec(sensor, names)
    body = spec.body(cam.link)
    if body is None:
        raise DescriptionError(f"camera sensor '{cam.name}': link {cam.link} is not in the model")
    quat = quat_mul(quat_from_rpy(cam.pose.rpy), LOOK_ALONG_X)
    body.add_camera(name=cam.name, pos=list(cam.pose.xyz), quat=list(quat), fovy=math.degrees(cam.fovy))
    buffer = spec.visual.global_
    buffer.offwidth, buffer.offheight = max(buffer.offwidth, cam.width), max(buffer.offheight, cam.height)
    spec.visual.quality.offsamples = 0  # software GL: MSAA would double the cost of a frame


def camera_parts(spec: CameraSpec, names: CarNames = CarNames(), role: str = "camera") -> Parts:
    """A camera node's part: the MuJoCo camera add_camera puts in (the spec's, before the car's names), as `role`."""
    return Parts.cameras(f"camera sensor '{spec.name}'", **{role: names.mj(spec.name)})


def set_clip(model: mujoco.MjModel, near: float, far: float) -> None:
    """Clip planes in metres: MuJoCo stores them as multiples of the model's extent."""
    model.vis.map.znear = near / model.stat.extent
    model.vis.map.zfar = far / model.stat.extent


def add_noise(pixels: np.ndarray, unit_noise: np.ndarray, mean: float, stddev: float) -> np.ndarray:
    """Gazebo's camera noise: one N(mean, stddev) sample per pixel (colour units, 0-255) added to every channel,
    then rounded and clamped to 0-255 - the float-colour shader's result written to an 8-bit image. (Frames are
    finished by camera_noise.finish_frame, which computes the same values compiled.)

    `unit_noise`: (height * width,) float32 standard normals, one per pixel, row by row; it is overwritten.
    Returns a new (height, width, 3) uint8 array.
    """
    height, width, channels = pixels.shape
    noise = unit_noise
    noise *= stddev
    if mean:
        noise += mean
    np.clip(noise, -255.0, 255.0, out=noise)  # beyond that the clamp saturates anyway; keeps int16 safe
    np.rint(noise, out=noise)
    counts = noise.astype(np.int16)
    out = pixels.reshape(height * width, channels).astype(np.int16)
    for channel in range(channels):  # a strided add per channel: far cheaper than broadcasting a length-3 axis
        out[:, channel] += counts
    np.clip(out, 0, 255, out=out)
    return out.astype(np.uint8).reshape(height, width, channels)


class CameraPublisher(NodeBase):
    """gazebo_ros_camera: Image and CameraInfo at the sensor's rate (30 Hz), frame camera_link, sim-time stamps, for
    one `<sensor type="camera">` block of the description.

    Raises RenderingError (one line) at construction when no headless OpenGL context can be made.
    Attributes: `spec` (the parsed sensor block), `noise` (whether frames get the sensor's noise),
    `frames_rendered` (how many frames were drawn: none while nobody listens).
    """

    def __init__(self, ctx: NodeContext, sensor: Sensor | CameraSpec, part: str = "camera") -> None:
        model, data, noise = ctx.model, ctx.data, ctx.noise
        own = sensor if isinstance(sensor, CameraSpec) else CameraSpec.from_sensor(sensor)  # the registry parsed it
        self.spec = named_camera_spec(own, ctx.names)
        own_topic = own.image_topic
        self.noise_stream = ctx.noise_stream(NOISE_STREAM if own_topic == ORIGINAL_TOPIC else NOISE_STREAM + own_topic)
        # its MuJoCo camera (`part` of ctx.parts), bound by the car (or here, for a camera built on its own)
        self.part = part
        declared = ctx.parts.declares(part)
        self.parts = ctx.parts if declared else camera_parts(own, ctx.names, part).bind(model)
        self._owns_parts = not declared
        self.bus, self.seed = ctx.bus, ctx.seed
        self._stream_key = zlib.crc32(self.noise_stream.encode()) << 32  # mixed into the seed: cars differ
        self.noise = noise and (self.spec.noise_stddev > 0 or self.spec.noise_mean != 0)
        set_clip(model, self.spec.near, self.spec.far)
        self.renderer = OffscreenCamera(model, data, self.parts[part], self.spec.width, self.spec.height)
        self.frames_rendered = 0
        self._ahead = False
        self._table: NoiseTable | None = None  # the noise table, kept from the first noisy frame
        # the CDR layout of this camera's CameraInfo and the numbers after its stamp, read off the first one
        self._info_layout: tuple[CdrLayout, list[object]] | None = None
        # (stamp, drawing, its finished frame or None): the frame drawn ahead, not yet published
        self._pending: tuple[int, Future[np.ndarray], np.ndarray | None] | None = None
        self._prepare()
        self._task = ctx.timers.every(self.spec.rate_hz, self._tick, "gazebo_ros_camera")

    def _prepare(self) -> None:
        """Load the compiled frame finishing and draw the noise table now, with the rest of the start-up, rather
        than with the first frame in the middle of a run."""
        from racecar_sim.sensors.camera_noise import finish_frame

        self._finish_frame = finish_frame  # kept: an import at every frame costs microseconds of import machinery
        if self.noise:
            self._noise_table  # noqa: B018 - drawn here
        finish_frame(
            np.zeros((1, 1, 4), dtype=np.uint8),
            _NO_SKY,
            False,
            _NO_NOISE,
            0,
            0,
            np.float32(0.0),
            np.float32(0.0),
            True,
            np.zeros((1, 1, 3), dtype=np.uint8),
        )

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Render a recompiled model (a model was spawned or deleted): same node, schedule and noise."""
        self.flush()
        set_clip(model, self.spec.near, self.spec.far)
        if self._owns_parts:
            self.parts.bind(model)
        self.renderer.rebind(model, data, self.parts[self.part])

    def _tick(self, now_ns: int) -> None:
        spec = self.spec
        heard = self.bus.has_listeners(spec.image_topic) or self.bus.has_listeners(spec.info_topic)
        if self._ahead:
            # this tick's frame is asked for before the last one is waited for: the GL thread goes on to it without a
            # pause while the last frame is published
            last, self._pending = self._pending, (now_ns, self._capture_later(), None) if heard else None
            if last is not None:  # render-ahead: the frame drawn since the last tick goes out now
                self._publish_drawn(*last)
        elif heard:
            self._publish(now_ns, self.capture(now_ns))

    def render_ahead(self, on: bool = True) -> None:
        """Draw each frame on the GL thread while the simulation goes on, and publish it at the next frame's tick
        (33 ms of sim time later at 30 Hz), stamped with the time it shows, as Gazebo's camera, rendering on its own
        thread, publishes after the fact. The same frames, a period later; flush() publishes the last one."""
        if not on:
            self.flush()
        self._ahead = on

    def flush(self) -> None:
        """Publish the frame being drawn ahead, if any (stamped with its own time), now."""
        if self._pending is not None:
            last, self._pending = self._pending, None
            self._publish_drawn(*last)

    def _publish_drawn(self, stamp_ns: int, drawn: Future[np.ndarray], frame: np.ndarray | None) -> None:
        self._publish(stamp_ns, frame if frame is not None else self._finish(drawn.result(), stamp_ns))

    def drop_pending(self) -> None:
        """Forget the frame being drawn ahead, unpublished (sim time went back: a reset)."""
        if self._pending is not None:
            self._pending[1].result()  # let the GL thread finish with this camera's buffers
            self._pending = None

    def _publish(self, stamp_ns: int, pixels: np.ndarray) -> None:
        spec = self.spec
        self.bus.publish(spec.image_topic, self._image(stamp_ns, pixels))
        if self._info_layout is not None and self.bus.cdr_only(spec.info_topic):
            # only a recorder takes it: its bytes, the stamp packed into those of the first (all else is the same)
            layout, rest = self._info_layout
            self.bus.publish_cdr(spec.info_topic, CameraInfo, layout.pack([*divmod(stamp_ns, NS_PER_S), *rest]))
            return
        info = spec.camera_info(stamp_ns)
        if self._info_layout is None:
            made = CdrLayout.of(info)
            if made is not None and made[1][:2] == [info.header.stamp.sec, info.header.stamp.nanosec]:
                self._info_layout = made[0], made[1][2:]
        self.bus.publish(spec.info_topic, info)

    def _image(self, stamp_ns: int, pixels: np.ndarray) -> Image:
        spec = self.spec
        return Image(
            Header.at(stamp_ns, spec.frame_id), spec.height, spec.width, spec.encoding, 0, spec.step, pixels.reshape(-1)
        )

    def frame(self, stamp_ns: int) -> Image:
        """The Image of the current state, stamped `stamp_ns` (with that stamp's noise), drawn now and not published."""
        return self._image(stamp_ns, self.capture(stamp_ns))

    def capture(self, stamp_ns: int) -> np.ndarray:
        """Render the current state: a new (height, width, 3) uint8 array in the spec's encoding, top row first,
        with the noise of the frame stamped `stamp_ns`."""
        if self._pending is not None and self._pending[2] is None:  # finished now: its buffer is drawn into next
            stamp, drawn, _ = self._pending
            self._pending = (stamp, drawn, self._finish(drawn.result(), stamp))
        return self._finish(self._capture_later().result(), stamp_ns)

    def _capture_later(self) -> Future[np.ndarray]:
        """The scene posed now, drawn on the GL thread: the future's result is the GL buffer (RGBA, rows bottom-up)."""
        self.frames_rendered += 1
        return self.renderer.render_later()

    def _finish(self, gl_rgba: np.ndarray, stamp_ns: int) -> np.ndarray:
        """The frame from its GL buffer: flipped, the sky painted, the noise of `stamp_ns` added. It runs on the
        thread that takes the frame (compiled, without the GIL), not on the GL thread, which meanwhile draws the
        next frame into the other scene's buffer."""
        spec = self.spec
        sky = self.renderer.sky
        pixels = np.empty((spec.height, spec.width, 3), dtype=np.uint8)  # the message keeps its own pixels
        table, first, second = _NO_NOISE, 0, 0
        if self.noise:
            noise = self._table = self._table or self._noise_table
            table = noise.values
            first, second = noise.offsets(self.seed ^ self._stream_key, stamp_ns)
        self._finish_frame(
            gl_rgba,
            _NO_SKY if sky is None else sky,
            sky is not None,
            table,
            first,
            second,
            np.float32(255.0 * spec.noise_stddev if self.noise else 0.0),
            np.float32(255.0 * spec.noise_mean if self.noise else 0.0),
            spec.encoding == "bgr8",
            pixels,
        )
        return pixels

    @property
    def _noise_table(self) -> NoiseTable:
        # drawn once per process (~0.1 s, 18 MB: by _prepare at start-up), shared by every camera of this size
        return NoiseTable.shared(NOISE_STREAM, self.spec.height * self.spec.width, np.float32)

    @property
    def gl_renderer(self) -> str:
        """The OpenGL renderer drawing the images (e.g. llvmpipe: Mesa's software rasteriser)."""
        return f"{self.renderer.gl.backend}: {self.renderer.gl.renderer}"

    def reset(self, seed: int) -> None:
        """Noise from `seed`; a frame drawn ahead of the reset shows the old episode and is dropped."""
        self.seed = seed
        self.drop_pending()

    def close(self) -> None:
        """Stop publishing and free this camera's GL objects (a frame drawn ahead is dropped)."""
        self._task.cancel()
        self.drop_pending()
        self.renderer.close()
