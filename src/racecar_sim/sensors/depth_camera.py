"""A depth camera from the description: `<sensor type="depth">` with gazebo_ros_openni_kinect.

At the sensor's rate, while someone listens, it renders its MuJoCo camera once and publishes what the Kinect plugin
does, under <cameraName>:
  <imageTopicName> (image_raw)                 sensor_msgs/Image, the colour image (the sensor's format)
  <cameraInfoTopicName> (camera_info)           sensor_msgs/CameraInfo of both images
  <depthImageTopicName> (depth/image_raw)       sensor_msgs/Image 32FC1, metres along the optical axis (z-depth)
  <depthImageCameraInfoTopicName> (depth/camera_info)
  <pointCloudTopicName> (points)                sensor_msgs/PointCloud2 x y z float32 in the optical convention
                                                (x right, y down, z ahead) of <frameName>
Depths outside [<pointCloudCutoff>, <pointCloudCutoffMax>] (0.4 and 5 m by default) are not points; in the depth image
they are -inf (nearer) and +inf (farther), as REP 117 reports ranges out of reach (Gazebo writes NaN there), so no NaN
reaches a topic. The depth is exact (no noise); the colour image gets the sensor's pixel noise as the camera's does.
"""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import Future
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.names import CarNames
from racecar_sim.core.transforms import quat_from_rpy, quat_mul
from racecar_sim.description.urdf import Sensor
from racecar_sim.msgs import Header, Image, PointCloud2, PointField
from racecar_sim.nodes import Mount, NodeBase, NodeContext, Parts
from racecar_sim.render.offscreen import OffscreenCamera
from racecar_sim.sensors.camera import LOOK_ALONG_X, camera_parts
from racecar_sim.sensors.camera_spec import CameraSpec
from racecar_sim.sensors.sensor_xml import plugin_number

KINECT_PLUGIN = "libgazebo_ros_openni_kinect.so"
_XYZ = [
    PointField("x", 0, PointField.FLOAT32, 1),
    PointField("y", 4, PointField.FLOAT32, 1),
    PointField("z", 8, PointField.FLOAT32, 1),
]


@dataclass(frozen=True)
class DepthSpec:
    """The colour camera's spec (optics, image, colour topics) plus the depth topics and the cloud's cut-offs."""

    camera: CameraSpec
    depth_topic: str
    depth_info_topic: str
    points_topic: str
    cutoff: float
    cutoff_max: float

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> DepthSpec:
        """Read a `<sensor type="depth">` block and its gazebo_ros_openni_kinect plugin."""
        where = f"<sensor type='depth' name='{sensor.name}'> on link {sensor.link}"
        camera = CameraSpec.from_sensor(sensor, default_format="R8G8B8")
        plugin = next((p for p in sensor.plugins if p.filename == KINECT_PLUGIN), None)
        params = plugin.params if plugin is not None else {}
        namespace = params.get("cameraName", sensor.name)

        def topic(tag: str, default: str) -> str:
            name = params.get(tag) or default
            return name if name.startswith("/") else _join(namespace, name)

        cutoff = plugin_number(params, "pointCloudCutoff", where, 0.4)
        cutoff_max = plugin_number(params, "pointCloudCutoffMax", where, 5.0)
        if not 0 <= cutoff < cutoff_max:
            raise DescriptionError(
                f"{where}: <pointCloudCutoff> {cutoff:g} must be >= 0 and below <pointCloudCutoffMax> {cutoff_max:g}"
            )
        return cls(
            camera,
            topic("depthImageTopicName", "depth/image_raw"),
            topic("depthImageCameraInfoTopicName", "depth/camera_info"),
            topic("pointCloudTopicName", "points"),
            cutoff,
            cutoff_max,
        )

    def with_names(self, names: CarNames) -> DepthSpec:
        """The spec with the car's names (topics under its namespace, frame with its tf_prefix, MuJoCo names)."""
        cam = self.camera
        camera = dataclasses.replace(
            cam,
            name=names.mj(cam.name),
            link=names.mj(cam.link),
            image_topic=names.topic(cam.image_topic),
            info_topic=names.topic(cam.info_topic),
            frame_id=names.frame(cam.frame_id),
        )
        return dataclasses.replace(
            self,
            camera=camera,
            depth_topic=names.topic(self.depth_topic),
            depth_info_topic=names.topic(self.depth_info_topic),
            points_topic=names.topic(self.points_topic),
        )


def _join(namespace: str, topic: str) -> str:
    return "/" + "/".join(part for part in (*namespace.split("/"), *topic.split("/")) if part)


def prepare_depth_camera(spec: mujoco.MjSpec, sensor: Sensor | DepthSpec, mount: Mount) -> None:
    """Before compiling: a MuJoCo camera at the sensor's pose, and an offscreen buffer as large as its image."""
    parsed = sensor if isinstance(sensor, DepthSpec) else DepthSpec.from_sensor(sensor)
    cam = parsed.with_names(mount.names).camera
    body = spec.body(cam.link)
    if body is None:
        raise DescriptionError(f"depth sensor '{parsed.camera.name}': link {cam.link} is not in the model")
    quat = quat_mul(quat_from_rpy(cam.pose.rpy), LOOK_ALONG_X)
    body.add_camera(name=cam.name, pos=list(cam.pose.xyz), quat=list(quat), fovy=math.degrees(cam.fovy))
    buffer = spec.visual.global_
    buffer.offwidth, buffer.offheight = max(buffer.offwidth, cam.width), max(buffer.offheight, cam.height)


def depth_parts(depth: DepthSpec, names: CarNames = CarNames()) -> Parts:
    """A depth camera node's part: the MuJoCo camera prepare_depth_camera puts in, as `camera`."""
    return camera_parts(depth.camera, names)


class DepthCamera(NodeBase):
    """gazebo_ros_openni_kinect: colour image, depth image, their camera infos and a point cloud, while heard."""

    def __init__(self, ctx: NodeContext, sensor: Sensor | DepthSpec) -> None:
        self.ctx = ctx
        parsed = sensor if isinstance(sensor, DepthSpec) else DepthSpec.from_sensor(sensor)  # the registry parsed it
        self.spec = parsed.with_names(ctx.names)
        cam = self.spec.camera
        # its MuJoCo camera, bound by the car (or here, for a depth camera built on its own)
        declared = ctx.parts.declares("camera")
        self.parts = ctx.parts if declared else depth_parts(parsed, ctx.names).bind(ctx.model)
        self._owns_parts = not declared
        self.renderer = OffscreenCamera(ctx.model, ctx.data, self.parts["camera"], cam.width, cam.height)
        self.frames_rendered = 0
        rows, cols = np.mgrid[0 : cam.height, 0 : cam.width]
        # per pixel, the tangents of the ray's angles off the optical axis (pinhole model of the rendered image)
        self._tan_x = ((cols + 0.5 - cam.width / 2.0) / cam.fx).astype(np.float32)
        self._tan_y = ((rows + 0.5 - cam.height / 2.0) / cam.fx).astype(np.float32)
        self._task = ctx.timers.every(cam.rate_hz, self._tick, f"openni_kinect {parsed.camera.name}")

    def _topics(self) -> tuple[str, ...]:
        s = self.spec
        return s.camera.image_topic, s.camera.info_topic, s.depth_topic, s.depth_info_topic, s.points_topic

    def _tick(self, now_ns: int) -> None:
        bus = self.ctx.bus
        if not any(bus.has_listeners(topic) for topic in self._topics()):
            return
        rgb, depth = self.capture()
        self._publish(now_ns, rgb, depth)

    def capture(self) -> tuple[np.ndarray, np.ndarray]:
        """Render now: the colour image (height, width, 3) uint8 in the sensor's encoding, top row first, and the
        z-depth (height, width) float32 in metres (+inf where nothing is within the far clip)."""
        self.frames_rendered += 1
        cam = self.spec.camera
        model = self.ctx.model
        near, far = model.vis.map.znear, model.vis.map.zfar
        model.vis.map.znear, model.vis.map.zfar = cam.near / model.stat.extent, cam.far / model.stat.extent
        try:
            drawn: Future[tuple[np.ndarray, np.ndarray, float, float]] = self.renderer.render_depth_later()
        finally:  # the clip planes are the model's: the colour camera keeps its own
            model.vis.map.znear, model.vis.map.zfar = near, far
        rgb_gl, depth_gl, z_near, z_far = drawn.result()
        rgb = np.ascontiguousarray(rgb_gl[::-1])
        if cam.encoding == "bgr8":
            rgb = np.ascontiguousarray(rgb[:, :, ::-1])
        buffer = depth_gl[::-1].astype(np.float64)
        with np.errstate(divide="ignore"):
            depth = z_near / (1.0 - buffer * (1.0 - z_near / z_far))  # the depth buffer's z back to metres
        depth[buffer >= 1.0] = np.inf  # the far plane: nothing there
        return rgb, depth.astype(np.float32)

    def _publish(self, stamp_ns: int, rgb: np.ndarray, depth: np.ndarray) -> None:
        spec, bus, cam = self.spec, self.ctx.bus, self.spec.camera
        header = Header.at(stamp_ns, cam.frame_id)
        info = cam.camera_info(stamp_ns)
        bus.publish(cam.image_topic, Image(header, cam.height, cam.width, cam.encoding, 0, cam.step, rgb.reshape(-1)))
        bus.publish(cam.info_topic, info)
        image = np.where(depth < spec.cutoff, -np.inf, np.where(depth > spec.cutoff_max, np.inf, depth))
        bus.publish(
            spec.depth_topic,
            Image(
                Header.at(stamp_ns, cam.frame_id),
                cam.height,
                cam.width,
                "32FC1",
                0,
                4 * cam.width,
                image.astype("<f4").tobytes(),
            ),
        )
        bus.publish(spec.depth_info_topic, cam.camera_info(stamp_ns))
        if bus.has_listeners(spec.points_topic):
            bus.publish(spec.points_topic, self.cloud(stamp_ns, depth))

    def cloud(self, stamp_ns: int, depth: np.ndarray) -> PointCloud2:
        """The points (x right, y down, z ahead, metres) of the depths within the cut-offs, as one row."""
        spec = self.spec
        keep = (depth >= spec.cutoff) & (depth <= spec.cutoff_max)
        z = depth[keep]
        points = np.stack([self._tan_x[keep] * z, self._tan_y[keep] * z, z], axis=1).astype("<f4")
        return PointCloud2(
            Header.at(stamp_ns, spec.camera.frame_id),
            1,
            len(points),
            list(_XYZ),
            False,
            12,
            12 * len(points),
            points.tobytes(),
            True,
        )

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if self._owns_parts:
            self.parts.bind(model)
        self.renderer.rebind(model, data, self.parts["camera"])

    def close(self) -> None:
        self._task.cancel()
        self.renderer.close()
