"""The registry: which node a description's `<sensor type>` and `<plugin filename>` blocks become.

A car's description decides which sensors and plugins it has; this table says how each is built:

  <sensor type="ray"|"gpu_ray">   the laser (gazebo_ros_laser / gazebo_ros_gpu_laser): sensors/lidar.py
  <sensor type="camera">          the camera (gazebo_ros_camera): sensors/camera.py
  <sensor type="depth">           the depth camera (gazebo_ros_openni_kinect): sensors/depth_camera.py
  <sensor type="imu">             the IMU (gazebo_ros_imu_sensor): sensors/imu.py
  libgazebo_ros_control.so        the controllers (gazebo_ros_control): control/ros_control.py
  libgazebo_ros_p3d.so            ground-truth odometry of a link: sensors/ground_truth.py
  libgazebo_ros_imu.so            the IMU model plugin: sensors/imu.py

Each entry has an optional `prepare(spec, block, mount)` that puts what the node needs into the MjSpec before it
is compiled (a MuJoCo camera, a site with its sensors, actuators) and a `build(ctx, block)` that makes the node.
A sensor belongs to a switch ("lidar", "camera", "imu"): `Car(lidar=False)`, `--no-lidar` and the envs' options
turn every sensor of that switch off, here and nowhere else. Modules are imported only when a car has such a block
(the camera's GL bindings load only with a camera). A block the table does not know is a warning naming it and the
file; `register_sensor` and `register_plugin` add a user's own.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import mujoco

from racecar_sim.description.urdf import Plugin, Robot, Sensor
from racecar_sim.nodes import Mount, Node, NodeContext

log = logging.getLogger("racecar_sim")

Block = Sensor | Plugin


@dataclass(frozen=True)
class NodeKind:
    """How one kind of description block becomes a node.

    build(ctx, block): the node (None: it cannot run here, and has said why). prepare(spec, block, mount): its parts
    in the MjSpec, before compiling (or None).
    switch: the sensor switch that turns it off ("" for none). plugins: for a sensor type, the plugin libraries that
    give it its ROS interface (any other inside the block is a warning).
    """

    build: Callable[[NodeContext, Block], Node | None]
    prepare: Callable[[mujoco.MjSpec, Block, Mount], None] | None = None
    switch: str = ""
    plugins: tuple[str, ...] = ()


# --- the built-in kinds: each imports its module only when used -----------------------------------------------
def _laser(ctx: NodeContext, block: Block) -> Node:
    from racecar_sim.sensors.lidar import LidarPublisher

    assert isinstance(block, Sensor)
    return LidarPublisher(ctx, block)


def _prepare_laser(spec: mujoco.MjSpec, block: Block, mount: Mount) -> None:
    from racecar_sim.sensors.laser_spec import LaserSpec

    assert isinstance(block, Sensor)
    LaserSpec.from_sensor(block)  # a malformed block is refused before the model is built


def _camera(ctx: NodeContext, block: Block) -> Node | None:
    from racecar_sim.core.errors import RenderingError
    from racecar_sim.sensors.camera import CameraPublisher

    assert isinstance(block, Sensor)
    try:
        return CameraPublisher(ctx, block)
    except RenderingError as exc:
        log.error("%s; continuing without the camera", exc)
        return None


def _prepare_camera(spec: mujoco.MjSpec, block: Block, mount: Mount) -> None:
    from racecar_sim.sensors.camera import add_camera

    assert isinstance(block, Sensor)
    add_camera(spec, block, mount.names)


def _depth(ctx: NodeContext, block: Block) -> Node | None:
    from racecar_sim.core.errors import RenderingError
    from racecar_sim.sensors.depth_camera import DepthCamera

    assert isinstance(block, Sensor)
    try:
        return DepthCamera(ctx, block)
    except RenderingError as exc:
        log.error("%s; continuing without the depth camera %s", exc, block.name)
        return None


def _prepare_depth(spec: mujoco.MjSpec, block: Block, mount: Mount) -> None:
    from racecar_sim.sensors.depth_camera import prepare_depth_camera

    assert isinstance(block, Sensor)
    prepare_depth_camera(spec, block, mount)


def _imu(ctx: NodeContext, block: Block) -> Node:
    from racecar_sim.sensors.imu import imu_from_plugin, imu_from_sensor

    return imu_from_sensor(ctx, block) if isinstance(block, Sensor) else imu_from_plugin(ctx, block)


def _prepare_imu(spec: mujoco.MjSpec, block: Block, mount: Mount) -> None:
    from racecar_sim.sensors.imu import prepare_imu

    prepare_imu(spec, block, mount)


def _ros_control(ctx: NodeContext, block: Block) -> Node:
    from racecar_sim.control.ros_control import RosControl

    assert isinstance(block, Plugin)
    return RosControl(ctx, block)


def _prepare_ros_control(spec: mujoco.MjSpec, block: Block, mount: Mount) -> None:
    from racecar_sim.control.ros_control import prepare

    assert isinstance(block, Plugin)
    prepare(spec, block, mount)


def _p3d(ctx: NodeContext, block: Block) -> Node:
    from racecar_sim.sensors.ground_truth import GroundTruthOdometry

    assert isinstance(block, Plugin)
    return GroundTruthOdometry(ctx, block)


ROS_CONTROL = "libgazebo_ros_control.so"
LASER = NodeKind(_laser, _prepare_laser, "lidar", ("libgazebo_ros_laser.so", "libgazebo_ros_gpu_laser.so"))
SENSORS: dict[str, NodeKind] = {
    "ray": LASER,
    "gpu_ray": LASER,
    "camera": NodeKind(_camera, _prepare_camera, "camera", ("libgazebo_ros_camera.so",)),
    "depth": NodeKind(_depth, _prepare_depth, "camera", ("libgazebo_ros_openni_kinect.so",)),
    "imu": NodeKind(_imu, _prepare_imu, "imu", ("libgazebo_ros_imu_sensor.so",)),
}
PLUGINS: dict[str, NodeKind] = {
    ROS_CONTROL: NodeKind(_ros_control, _prepare_ros_control),
    "libgazebo_ros_p3d.so": NodeKind(_p3d),
    "libgazebo_ros_imu.so": NodeKind(_imu, _prepare_imu, "imu"),
}
SWITCHES = ("lidar", "camera", "imu")  # the sensor switches of the CLI and the Python API


def register_sensor(sensor_type: str, kind: NodeKind) -> None:
    """Build `kind` for every `<sensor type="sensor_type">` of a description (replacing a built-in one)."""
    SENSORS[sensor_type] = kind


def register_plugin(filename: str, kind: NodeKind) -> None:
    """Build `kind` for every `<plugin filename="filename">` of a description (replacing a built-in one)."""
    PLUGINS[filename] = kind


@dataclass(frozen=True)
class Planned:
    """One block of a description and the kind it becomes."""

    block: Block
    kind: NodeKind


def plan(robot: Robot, off: frozenset[str]) -> tuple[list[Planned], list[Planned]]:
    """The model plugins and the sensors of `robot` that become nodes, in the description's order, without those
    turned off (by switch, sensor type or sensor name). Unknown blocks are warnings naming them and the file; a
    description whose transmissions have no gazebo_ros_control plugin gets it anyway, with a warning (Gazebo would
    start no controller, and the car could not move)."""
    where = robot.source or f"robot {robot.name}"
    plugins: list[Planned] = []
    for plugin in robot.plugins:
        kind = PLUGINS.get(plugin.filename)
        if kind is None:
            log.warning(
                "%s: <plugin name='%s' filename='%s'> is not simulated (racecar-sim knows %s); it is ignored",
                where,
                plugin.name,
                plugin.filename,
                ", ".join(sorted(PLUGINS)),
            )
        elif not _is_off(kind, plugin.name, "", off):
            plugins.append(Planned(plugin, kind))
    if robot.transmissions and not any(p.block.filename == ROS_CONTROL for p in plugins if isinstance(p.block, Plugin)):
        log.warning(
            "%s has no <plugin filename='%s'>: its controllers are started anyway, as racecar.gazebo's "
            "block would start them",
            where,
            ROS_CONTROL,
        )
        implied = Plugin("gazebo_ros_control", ROS_CONTROL, {}, ET.Element("plugin"))
        plugins.insert(0, Planned(implied, PLUGINS[ROS_CONTROL]))
    sensors: list[Planned] = []
    for sensor in robot.sensors:
        kind = SENSORS.get(sensor.type)
        if kind is None:
            log.warning(
                "%s: <sensor type='%s' name='%s'> on link %s is not simulated (racecar-sim knows %s); it is ignored",
                where,
                sensor.type,
                sensor.name,
                sensor.link,
                ", ".join(sorted(SENSORS)),
            )
            continue
        for inner in sensor.plugins:
            if inner.filename not in kind.plugins:
                log.warning(
                    "%s: <sensor name='%s'> has <plugin filename='%s'>, which racecar-sim does not know for a "
                    "%s sensor (it knows %s): the sensor publishes as %s would",
                    where,
                    sensor.name,
                    inner.filename,
                    sensor.type,
                    ", ".join(kind.plugins),
                    kind.plugins[0],
                )
        if not _is_off(kind, sensor.name, sensor.type, off):
            sensors.append(Planned(sensor, kind))
    return plugins, sensors


def _is_off(kind: NodeKind, name: str, sensor_type: str, off: frozenset[str]) -> bool:
    return bool(off) and ((kind.switch and kind.switch in off) or name in off or sensor_type in off)
