"""The ROS 2 dialect of gazebo_ros plugin blocks (gazebo_ros_pkgs for ROS 2, as a Humble user's description writes
them): where each plugin's topics go and what frame it stamps.

A plugin block is read in this dialect when it has a `<ros>` element or one of the ROS 2 plugins' own parameters
(`<frame_name>`, `<output_type>`, `<camera_name>`); else it is read as ROS 1's. As gazebo_ros/src/node.cpp builds the
node of a plugin: its name is the plugin's `name`, its namespace `<ros><namespace>` ("/" when absent), its remapping
rules `<ros><remapping>from:=to</remapping>` (and the same in `<ros><argument>`). A topic is resolved as rcl
resolves it: `~/out` is under the node (/<namespace>/<name>/out), a relative name under the namespace, an absolute one
as it is, and then a rule whose `from` resolves to the same name gives its `to` (resolved the same way).
The frame (gazebo_ros::SensorFrameID): `<frame_name>`, else the link the sensor is attached to in Gazebo, which is
the link it was lumped into when fixed joints lead to it from its own link.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from racecar_sim.description.urdf import Plugin, Robot, Sensor
from racecar_sim.sensors.camera_spec import CameraSpec
from racecar_sim.sensors.imu import ImuSpec
from racecar_sim.sensors.laser_spec import LaserSpec
from racecar_sim.sensors.range_spec import RangeSpec
from racecar_sim.sensors.ray_block import RayBlock
from racecar_sim.sensors.ray_cloud import RayCloudSpec
from racecar_sim.sensors.sensor_xml import plugin_number

RAY_SENSOR = "libgazebo_ros_ray_sensor.so"
IMU_SENSOR = "libgazebo_ros_imu_sensor.so"
CAMERA = "libgazebo_ros_camera.so"
DEPTH_CAMERA = "libgazebo_ros_depth_camera.so"
if TYPE_CHECKING:
    from racecar_sim.sensors.depth_camera import DepthSpec
log = logging.getLogger("racecar_sim")


@dataclass(frozen=True)
class Ros2Node:
    """The rclcpp node gazebo_ros makes for one plugin: its name, namespace and remapping rules."""

    name: str
    namespace: str
    remaps: tuple[tuple[str, str], ...]

    @classmethod
    def of(cls, plugin: Plugin) -> Ros2Node:
        """The node of a plugin block (see the module doc)."""
        ros = plugin.element.find("ros")
        namespace, remaps = "/", []
        if ros is not None:
            namespace = (ros.findtext("namespace") or "/").strip() or "/"
            for el in (*ros.findall("remapping"), *ros.findall("argument")):
                rule = (el.text or "").strip()
                if ":=" not in rule:
                    continue  # --ros-args, -r: the flags around a rule
                source, target = (part.strip() for part in rule.split(":=", 1))
                if source == "__ns":
                    namespace = target
                elif not source.startswith("__"):
                    remaps.append((source, target))
        if not namespace.startswith("/"):
            namespace = "/" + namespace
        return cls(plugin.name, namespace.rstrip("/") or "/", tuple(remaps))

    def expand(self, name: str) -> str:
        """A topic name made absolute: `~` under the node, a relative name under the namespace."""
        base = self.namespace.rstrip("/")
        if name == "~" or name.startswith("~/"):
            name = f"{base}/{self.name}{name[1:]}"
        elif not name.startswith("/"):
            name = f"{base}/{name}"
        return "/" + "/".join(part for part in name.split("/") if part)

    def topic(self, name: str) -> str:
        """Where a publisher the plugin creates as `name` publishes: expanded, then remapped by the first rule that
        matches it."""
        expanded = self.expand(name)
        for source, target in self.remaps:
            if self.expand(source) == expanded:
                return self.expand(target)
        return expanded


def lumped_link(robot: Robot, link: str) -> str:
    """The link Gazebo attaches `link`'s sensors to: `link` itself, or the one it is lumped into over fixed joints."""
    parents = {j.child: j for j in robot.joints.values()}
    while link in parents and parents[link].type == "fixed":
        link = parents[link].parent
    return link


def frame_of(plugin: Plugin, sensor: Sensor, robot: Robot) -> str:
    """gazebo_ros::SensorFrameID: `<frame_name>`, else the link the sensor is attached to in Gazebo."""
    return plugin.params.get("frame_name") or lumped_link(robot, sensor.link)


# --- the ROS 2 plugins' specs: each the ROS 1 kind's spec, with the ROS 2 plugin's topics, frame and parameters -----
def ray_sensor_spec(sensor: Sensor, robot: Robot) -> LaserSpec | RangeSpec | RayCloudSpec | None:
    """gazebo_ros_ray_sensor on `~/out`: a laser (`<output_type>sensor_msgs/LaserScan`), a ranger
    (`sensor_msgs/Range`) or a point cloud (`sensor_msgs/PointCloud2`, the default, or `sensor_msgs/PointCloud`);
    None (after a warning naming the block) for any other output type."""
    plugin = next(p for p in sensor.plugins if p.filename == RAY_SENSOR)
    node, frame = Ros2Node.of(plugin), frame_of(plugin, sensor, robot)
    output = plugin.params.get("output_type") or "sensor_msgs/PointCloud2"  # the plugin's default
    if output == "sensor_msgs/LaserScan":
        laser = LaserSpec.from_sensor(sensor)
        return dataclasses.replace(laser, topic=node.topic("~/out"), frame_id=frame)
    if output == "sensor_msgs/Range":
        return RangeSpec.from_ros2(sensor, node.topic("~/out"), frame, plugin.params.get("radiation_type", "infrared"))
    if output in ("sensor_msgs/PointCloud2", "sensor_msgs/PointCloud"):
        where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
        min_intensity = plugin_number(plugin.params, "min_intensity", where, 0.0)
        return RayCloudSpec(RayBlock.from_sensor(sensor), node.topic("~/out"), frame, output, min_intensity)
    log.warning(
        "%s: <sensor name='%s'> with %s gives <output_type> %s, which is none of sensor_msgs/LaserScan, "
        "PointCloud2, PointCloud and Range; the sensor is left out",
        robot.source or robot.name,
        sensor.name,
        RAY_SENSOR,
        output,
    )
    return None


def imu_spec(sensor: Sensor, robot: Robot) -> ImuSpec:
    """gazebo_ros_imu_sensor (ROS 2): sensor_msgs/Imu on `~/out`, at the sensor's rate, with the sensor's own noise."""
    plugin = next(p for p in sensor.plugins if p.filename == IMU_SENSOR)
    spec = ImuSpec.from_sdf(sensor)
    return dataclasses.replace(spec, topic=Ros2Node.of(plugin).topic("~/out"), frame_id=frame_of(plugin, sensor, robot))


def _camera(sensor: Sensor, plugin: Plugin, robot: Robot, default_format: str | None = None) -> CameraSpec:
    """gazebo_ros_camera's colour image: `<camera_name>/image_raw` and `<camera_name>/camera_info` under the node's
    namespace, `<camera_name>` defaulting to the sensor's name; `<focal_length>`, `<cx>`, `<cy>`, `<hack_baseline>`."""
    node, params = Ros2Node.of(plugin), plugin.params
    name = params.get("camera_name") or sensor.name
    where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
    spec = CameraSpec.from_sensor(sensor, default_format=default_format)
    cx = plugin_number(params, "cx", where, (spec.width + 1) / 2.0)
    return dataclasses.replace(
        spec,
        image_topic=node.topic(f"{name}/image_raw"),
        info_topic=node.topic(f"{name}/camera_info"),
        frame_id=frame_of(plugin, sensor, robot),
        focal_length=plugin_number(params, "focal_length", where, 0.0) or spec.fx,
        cx=cx,
        cy=plugin_number(params, "cy", where, (spec.height + 1) / 2.0),
        cx_prime=cx,
        baseline=plugin_number(params, "hack_baseline", where, 0.0),
    )


def camera_spec(sensor: Sensor, robot: Robot) -> CameraSpec:
    """gazebo_ros_camera on a `<sensor type="camera">`."""
    plugin = next(p for p in sensor.plugins if p.filename == CAMERA)
    return _camera(sensor, plugin, robot)


def depth_spec(sensor: Sensor, robot: Robot) -> DepthSpec:
    """gazebo_ros_camera on a `<sensor type="depth">` (libgazebo_ros_depth_camera.so is read the same way): besides
    the colour image, `<camera_name>/depth/image_raw`, `<camera_name>/depth/camera_info` and `<camera_name>/points`,
    the cloud cut at `<min_depth>` (default 0.4 m) and `<max_depth>` (default: none)."""
    from racecar_sim.sensors.depth_camera import DepthSpec  # the renderer's module: only with a depth camera

    plugin = next(p for p in sensor.plugins if p.filename in (CAMERA, DEPTH_CAMERA))
    node, params = Ros2Node.of(plugin), plugin.params
    name = params.get("camera_name") or sensor.name
    where = f"<sensor type='depth' name='{sensor.name}'> on link {sensor.link}"
    near, far = plugin_number(params, "min_depth", where, 0.4), plugin_number(params, "max_depth", where, math.inf)
    return DepthSpec(
        _camera(sensor, plugin, robot, default_format="R8G8B8"),
        node.topic(f"{name}/depth/image_raw"),
        node.topic(f"{name}/depth/camera_info"),
        node.topic(f"{name}/points"),
        near,
        far,
    )
