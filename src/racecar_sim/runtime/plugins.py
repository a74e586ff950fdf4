"""The registry: which node a description's `<sensor>` and `<plugin>` blocks become, keyed as Gazebo keys them.

Gazebo picks a sensor's physics by its type and its ROS interface by the plugin inside it, so a sensor block is keyed
by the pair (sensor type, plugin file); a model plugin by its file alone:

  ray | gpu_ray   + libgazebo_ros_laser.so, libgazebo_ros_gpu_laser.so   laser (LaserScan): sensors/lidar.py
  ray | gpu_ray   + libgazebo_ros_range.so                                range (Range): sensors/range.py
  ray | gpu_ray   + libgazebo_ros_ray_sensor.so (ROS 2)                   laser, range or cloud, by its <output_type>
  ray | gpu_ray   + libgazebo_ros_velodyne_(gpu_)laser.so                 3-D lidar (PointCloud2): sensors/velodyne.py
  ray | gpu_ray   + libgazebo_ros_block_laser.so                          3-D lidar (PointCloud): sensors/block_laser.py
  camera          + libgazebo_ros_camera.so                               camera: sensors/camera.py
  multicamera     + libgazebo_ros_multicamera.so                          stereo pair: sensors/multicamera.py
  depth           + libgazebo_ros_openni_kinect.so                        depth camera: sensors/depth_camera.py
  depth           + libgazebo_ros_camera.so, libgazebo_ros_depth_camera.so (ROS 2)  depth camera
  imu             + libgazebo_ros_imu_sensor.so                           IMU: sensors/imu.py
  contact         + libgazebo_ros_bumper.so                               bumper (ContactsState): sensors/bumper.py
  libgazebo_ros_control.so    the controllers (gazebo_ros_control): control/ros_control.py
  libgazebo_ros_p3d.so        ground-truth odometry of a link: sensors/ground_truth.py
  libgazebo_ros_imu.so        the IMU model plugin: sensors/imu.py
  libhector_gazebo_ros_gps.so hector's GPS (NavSatFix and its velocity): sensors/gps.py

A sensor block with no plugin becomes its type's first kind above. A plugin block in ROS 2's dialect (a `<ros>`
element, `<frame_name>`, ...) takes its topics and frame by ROS 2's rules: sensors/ros2_dialect.py. An unknown pair
is one warning naming the type, the plugin and the file, and the block is left out.

A kind (`NodeKind`) has a name, an optional `parse(block)` that reads the block once into a typed spec (a malformed
block is refused when the car is planned, before the model is built), an optional `prepare(spec, parsed, mount)` that
puts what the node needs into the MjSpec before it is compiled (a MuJoCo camera, a site with its sensors, actuators)
and a `build(ctx, parsed)` that makes the node; both get the spec parse gave. A kind's name and its switch ("lidar",
"camera", "imu") turn it off: `--no-sensor NAME`, `Car(sensors_off=...)`; `Car(lidar=False)` and `--no-lidar` are the
"lidar" switch, `--no-camera` the "camera" one. Modules are imported only when a car has such a block (the camera's
GL bindings load only with a camera). `register_sensor` and `register_plugin` add a user's own kinds.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco

from racecar_sim.core.names import CarNames
from racecar_sim.description.urdf import Plugin, Robot, Sensor
from racecar_sim.nodes import Mount, Node, NodeContext, Parts

log = logging.getLogger("racecar_sim")

Block = Sensor | Plugin


@dataclass(frozen=True)
class NodeKind:
    """How one kind of description block becomes a node.

    name: the kind's own name (laser, range, camera, ...): `--no-sensor NAME` and `Car.has(NAME)` take it.
    parse(block, mount): the block's typed spec, read once when the car is planned (a malformed block is refused then,
    before the model is built) and handed to prepare and build; None: the block itself is the spec.
    parts(parsed, mount): the MuJoCo elements the node reads (nodes/parts.py), declared by name; the car binds their ids
    after every compile and hands them to the node as `ctx.parts` while it is built (None: it reads none).
    refine(parsed): the kind the spec turns out to be, for a plugin whose own parameters choose what it publishes
    (ROS 2's gazebo_ros_ray_sensor: a laser or a ranger by its <output_type>); parse giving None leaves the block out
    (it has said why).
    prepare(spec, parsed, mount): its parts in the MjSpec, before compiling (or None).
    build(ctx, parsed): the node (None: it cannot run here, and has said why).
    switch: the sensor switch that turns it off with others ("lidar", "camera", "imu"; "" for none).
    plugins: for a sensor kind, the plugin libraries that give it its ROS interface: each (sensor type, plugin) pair
    it is registered under maps to it.
    """

    build: Callable[[NodeContext, Any], Node | None]
    prepare: Callable[[mujoco.MjSpec, Any, Mount], None] | None = None
    switch: str = ""
    plugins: tuple[str, ...] = ()
    name: str = ""
    parse: Callable[[Block, Mount], Any] | None = None
    parts: Callable[[Any, Mount], Parts] | None = None
    refine: Callable[[Any], NodeKind] | None = None


# --- the built-in kinds: each imports its module only when used -----------------------------------------------
def _laser(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.lidar import LidarPublisher

    return LidarPublisher(ctx, spec)


def _parse_laser(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.laser_spec import LaserSpec

    assert isinstance(block, Sensor)
    return LaserSpec.from_sensor(block)


def _ray_parts(spec: Any, mount: Mount) -> Parts:
    """A laser's or a ranger's part: the site of its link (the URDF frame its pose is given in)."""
    return Parts.sites(f"ray sensor '{spec.name}'", site=mount.names.mj(spec.link))


def _parse_ray_sensor(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors import ros2_dialect

    assert isinstance(block, Sensor)
    return ros2_dialect.ray_sensor_spec(block, mount.robot)


def _refine_ray_sensor(spec: Any) -> NodeKind:
    from racecar_sim.sensors.laser_spec import LaserSpec
    from racecar_sim.sensors.range_spec import RangeSpec

    return LASER if isinstance(spec, LaserSpec) else RANGE if isinstance(spec, RangeSpec) else RAY_CLOUD


def _ray_cloud(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.ray_cloud import RayCloudPublisher

    return RayCloudPublisher(ctx, spec)


def _velodyne(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.velodyne import VelodynePublisher

    return VelodynePublisher(ctx, spec)


def _parse_velodyne(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.velodyne import VelodyneSpec

    assert isinstance(block, Sensor)
    return VelodyneSpec.from_sensor(block)


def _block_laser(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.block_laser import BlockLaserPublisher

    return BlockLaserPublisher(ctx, spec)


def _parse_block_laser(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.block_laser import BlockLaserSpec

    assert isinstance(block, Sensor)
    return BlockLaserSpec.from_sensor(block)


def _range(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.range import RangePublisher

    return RangePublisher(ctx, spec)


def _parse_range(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.range_spec import RangeSpec

    assert isinstance(block, Sensor)
    return RangeSpec.from_sensor(block)


def _camera(ctx: NodeContext, spec: Any) -> Node | None:
    from racecar_sim.core.errors import RenderingError
    from racecar_sim.sensors.camera import CameraPublisher

    try:
        return CameraPublisher(ctx, spec)
    except RenderingError as exc:
        log.error("%s; continuing without the camera", exc)
        return None


def _prepare_camera(spec: mujoco.MjSpec, camera: Any, mount: Mount) -> None:
    from racecar_sim.sensors.camera import add_camera

    add_camera(spec, camera, mount.names)


def _parse_camera(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.camera_spec import CameraSpec
    from racecar_sim.sensors.sensor_xml import is_ros2

    assert isinstance(block, Sensor)
    if block.plugins and is_ros2(block.plugins[0]):
        from racecar_sim.sensors import ros2_dialect

        return ros2_dialect.camera_spec(block, mount.robot)
    return CameraSpec.from_sensor(block)


def _camera_parts(spec: Any, mount: Mount) -> Parts:
    from racecar_sim.sensors.camera import camera_parts

    return camera_parts(spec, mount.names)


def _multicamera(ctx: NodeContext, specs: Any) -> Node | None:
    from racecar_sim.core.errors import RenderingError
    from racecar_sim.sensors.multicamera import stereo_pair

    try:
        return stereo_pair(ctx, specs)
    except RenderingError as exc:
        log.error("%s; continuing without the stereo camera %s", exc, specs[0].name)
        return None


def _prepare_multicamera(spec: mujoco.MjSpec, specs: Any, mount: Mount) -> None:
    from racecar_sim.sensors.camera import add_camera

    for camera in specs:
        add_camera(spec, camera, mount.names)


def _parse_multicamera(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.multicamera import stereo_specs

    assert isinstance(block, Sensor)
    return stereo_specs(block)


def _multicamera_parts(specs: Any, mount: Mount) -> Parts:
    from racecar_sim.sensors.multicamera import stereo_parts

    return stereo_parts(specs, mount.names)


def _depth(ctx: NodeContext, spec: Any) -> Node | None:
    from racecar_sim.core.errors import RenderingError
    from racecar_sim.sensors.depth_camera import DepthCamera

    try:
        return DepthCamera(ctx, spec)
    except RenderingError as exc:
        log.error("%s; continuing without the depth camera %s", exc, spec.camera.name)
        return None


def _prepare_depth(spec: mujoco.MjSpec, depth: Any, mount: Mount) -> None:
    from racecar_sim.sensors.depth_camera import prepare_depth_camera

    prepare_depth_camera(spec, depth, mount)


def _parse_depth(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.depth_camera import DepthSpec
    from racecar_sim.sensors.sensor_xml import is_ros2

    assert isinstance(block, Sensor)
    if block.plugins and is_ros2(block.plugins[0]):
        from racecar_sim.sensors import ros2_dialect

        return ros2_dialect.depth_spec(block, mount.robot)
    return DepthSpec.from_sensor(block)


def _depth_parts(depth: Any, mount: Mount) -> Parts:
    from racecar_sim.sensors.depth_camera import depth_parts

    return depth_parts(depth, mount.names)


def _imu(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.imu import ImuPublisher

    return ImuPublisher(ctx, spec)


def _parse_imu(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.imu import ImuSpec
    from racecar_sim.sensors.sensor_xml import is_ros2

    if isinstance(block, Sensor) and block.plugins and is_ros2(block.plugins[0]):
        from racecar_sim.sensors import ros2_dialect

        return ros2_dialect.imu_spec(block, mount.robot)
    if isinstance(block, Sensor):
        return ImuSpec.from_sensor(block, mount.names.model)
    return ImuSpec.from_plugin(block, mount.robot)


def _prepare_imu(spec: mujoco.MjSpec, imu: Any, mount: Mount) -> None:
    from racecar_sim.sensors.imu import add_imu_site

    add_imu_site(spec, imu, mount.names)


def _imu_parts(imu: Any, mount: Mount) -> Parts:
    from racecar_sim.sensors.imu import imu_parts

    return imu_parts(imu, mount.names)


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


def _p3d_parts(block: Any, mount: Mount) -> Parts:
    """The site of p3d's <bodyName> link (none for a name that is no link: the node says what is wrong)."""
    body = block.params.get("bodyName", "")
    return Parts.sites(f"p3d '{block.name}'", site=mount.names.mj(body)) if body in mount.robot.links else Parts()


def _bumper(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.bumper import BumperPublisher

    return BumperPublisher(ctx, spec)


def _parse_bumper(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.bumper import BumperSpec

    assert isinstance(block, Sensor)
    return BumperSpec.from_sensor(block, mount.robot)


def _bumper_parts(spec: Any, mount: Mount) -> Parts:
    from racecar_sim.sensors.bumper import bumper_parts

    return bumper_parts(spec, mount)


def _gps(ctx: NodeContext, spec: Any) -> Node:
    from racecar_sim.sensors.gps import GpsPublisher

    return GpsPublisher(ctx, spec)


def _parse_gps(block: Block, mount: Mount) -> Any:
    from racecar_sim.sensors.gps import GpsSpec

    assert isinstance(block, Plugin)
    return GpsSpec.from_plugin(block, mount.robot)


def _gps_parts(spec: Any, mount: Mount) -> Parts:
    from racecar_sim.sensors.gps import gps_parts

    return gps_parts(spec, mount)


ROS_CONTROL = "libgazebo_ros_control.so"
LASER = NodeKind(_laser, None, "lidar", ("libgazebo_ros_laser.so", "libgazebo_ros_gpu_laser.so"), "laser", _parse_laser)
RANGE = NodeKind(_range, None, "", ("libgazebo_ros_range.so",), "range", _parse_range)
CAMERA = NodeKind(
    _camera, _prepare_camera, "camera", ("libgazebo_ros_camera.so",), "camera", _parse_camera, _camera_parts
)
DEPTH = NodeKind(
    _depth, _prepare_depth, "camera", ("libgazebo_ros_openni_kinect.so",), "depth_camera", _parse_depth, _depth_parts
)
MULTICAMERA = NodeKind(
    _multicamera,
    _prepare_multicamera,
    "camera",
    ("libgazebo_ros_multicamera.so",),
    "multicamera",
    _parse_multicamera,
    _multicamera_parts,
)
VELODYNE = NodeKind(
    _velodyne, None, "lidar", ("libgazebo_ros_velodyne_laser.so",), "velodyne", _parse_velodyne, _ray_parts
)
BLOCK_LASER = NodeKind(
    _block_laser, None, "lidar", ("libgazebo_ros_block_laser.so",), "block_laser", _parse_block_laser, _ray_parts
)
RAY_CLOUD = NodeKind(_ray_cloud, None, "lidar", (), "ray_cloud", None, _ray_parts)
"""ROS 2's gazebo_ros_ray_sensor with a point-cloud <output_type> (RAY_SENSOR refines to it)."""
RAY_SENSOR = NodeKind(
    _laser, None, "", ("libgazebo_ros_ray_sensor.so",), "ray_sensor", _parse_ray_sensor, refine=_refine_ray_sensor
)
"""ROS 2's gazebo_ros_ray_sensor: a laser, a ranger or a cloud, as its <output_type> says (LASER, RANGE, RAY_CLOUD)."""
IMU = NodeKind(_imu, _prepare_imu, "imu", ("libgazebo_ros_imu_sensor.so",), "imu", _parse_imu, _imu_parts)
BUMPER = NodeKind(_bumper, None, "", ("libgazebo_ros_bumper.so",), "bumper", _parse_bumper, _bumper_parts)
NO_PLUGIN = ""
"""The plugin of a `<sensor>` block with none inside (Gazebo gives it no ROS interface; it publishes as its type's
first kind here would)."""

SENSORS: dict[tuple[str, str], NodeKind] = {}
"""(sensor type, plugin file) -> kind: Gazebo picks the physics by the type and the ROS interface by the plugin."""
PLUGINS: dict[str, NodeKind] = {
    ROS_CONTROL: NodeKind(_ros_control, _prepare_ros_control, name="ros_control"),
    "libgazebo_ros_p3d.so": NodeKind(_p3d, name="p3d", parts=_p3d_parts),
    "libgazebo_ros_imu.so": NodeKind(_imu, _prepare_imu, "imu", name="imu", parse=_parse_imu, parts=_imu_parts),
    "libhector_gazebo_ros_gps.so": NodeKind(_gps, name="gps", parse=_parse_gps, parts=_gps_parts),
}
"""Model plugins, keyed by their file alone."""


def register_sensor(sensor_type: str, kind: NodeKind, plugin: str | None = None) -> None:
    """Build `kind` for every `<sensor type="sensor_type">` with `<plugin filename="plugin">` inside (replacing a
    built-in one); `plugin` None: under each of the kind's own plugins (a kind with none: a block with no plugin)."""
    for filename in (kind.plugins or (NO_PLUGIN,)) if plugin is None else (plugin,):
        SENSORS[(sensor_type, filename)] = kind


def register_plugin(filename: str, kind: NodeKind) -> None:
    """Build `kind` for every `<plugin filename="filename">` of a description (replacing a built-in one)."""
    PLUGINS[filename] = kind


for _type in ("ray", "gpu_ray"):
    register_sensor(_type, LASER)
    register_sensor(_type, LASER, NO_PLUGIN)
    register_sensor(_type, RANGE)
    register_sensor(_type, RAY_SENSOR)
    register_sensor(_type, VELODYNE)
    register_sensor(_type, VELODYNE, "libgazebo_ros_velodyne_gpu_laser.so")  # the same cloud, from a GPU ray block
    register_sensor(_type, BLOCK_LASER)
for _plugin in ("libgazebo_ros_camera.so", "libgazebo_ros_depth_camera.so"):  # ROS 2: gazebo_ros_camera's depth
    register_sensor("depth", DEPTH, _plugin)
for _kind, _type in ((CAMERA, "camera"), (DEPTH, "depth"), (IMU, "imu")):
    register_sensor(_type, _kind)
    register_sensor(_type, _kind, NO_PLUGIN)
register_sensor("contact", BUMPER)  # a contact sensor or a multicamera with no plugin reaches no topic: unknown
register_sensor("multicamera", MULTICAMERA)


def kinds() -> list[NodeKind]:
    """Every registered kind, sensors then model plugins, each once."""
    found: dict[int, NodeKind] = {}
    for kind in (*SENSORS.values(), RAY_CLOUD, *PLUGINS.values()):  # RAY_CLOUD: reached by refining only
        found.setdefault(id(kind), kind)
    return list(found.values())


def switches() -> list[str]:
    """What `--no-sensor` and `sensors_off` turn off by name, besides a sensor's own name: every switch and every
    kind's name, from the registry."""
    return sorted({k.switch for k in kinds() if k.switch} | {k.name for k in kinds() if k.name})


def sensor_kind(sensor: Sensor) -> NodeKind | None:
    """The kind a `<sensor>` block becomes: by its type and the first plugin inside it (None if unknown)."""
    plugin = sensor.plugins[0].filename if sensor.plugins else NO_PLUGIN
    return SENSORS.get((sensor.type, plugin))


def first_sensor(robot: Robot, kind_name: str) -> Sensor | None:
    """The description's first `<sensor>` block of the kind named `kind_name` ("laser", "camera", ...), or None."""
    return next((s for s in robot.sensors if (k := sensor_kind(s)) is not None and k.name == kind_name), None)


@dataclass(frozen=True)
class Planned:
    """One block of a description, the kind it becomes, its spec (parsed once, here) and its MuJoCo parts."""

    block: Block
    kind: NodeKind
    spec: Any = None
    parts: Parts = field(default_factory=Parts)

    @classmethod
    def of(cls, block: Block, kind: NodeKind, mount: Mount) -> Planned | None:
        """The block planned as `kind` (or the kind its spec refines it to), its spec parsed (DescriptionError for a
        malformed block), its parts declared; None if parse left it out."""
        spec = block if kind.parse is None else kind.parse(block, mount)
        if spec is None:
            return None
        if kind.refine is not None:
            kind = kind.refine(spec)
        return cls(block, kind, spec, Parts() if kind.parts is None else kind.parts(spec, mount))


def plan(robot: Robot, off: frozenset[str], mount: Mount | None = None) -> tuple[list[Planned], list[Planned]]:
    """The model plugins and the sensors of `robot` that become nodes, in the description's order, without those
    turned off (by switch, kind, sensor type or sensor name), each with its spec parsed. Unknown blocks are warnings
    naming them and the file; a description whose transmissions have no gazebo_ros_control plugin gets it anyway,
    with a warning (Gazebo would start no controller, and the car could not move)."""
    where = robot.source or f"robot {robot.name}"
    mount = mount or Mount(robot, CarNames())
    _check_off(robot, off, where)
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
        elif not _is_off(kind, plugin.name, "", off) and (planned := Planned.of(plugin, kind, mount)) is not None:
            plugins.append(planned)
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
        kind = sensor_kind(sensor)
        if kind is None:
            inner = sensor.plugins[0].filename if sensor.plugins else NO_PLUGIN
            known = sorted(f"{t}+{p or 'no plugin'}" for t, p in SENSORS if t == sensor.type)
            log.warning(
                "%s: <sensor type='%s' name='%s'> on link %s with %s is not simulated (racecar-sim knows %s); "
                "it is ignored",
                where,
                sensor.type,
                sensor.name,
                sensor.link,
                f"<plugin filename='{inner}'>" if inner else "no plugin",
                ", ".join(known) if known else f"no {sensor.type} sensor",
            )
            continue
        if _is_off(kind, sensor.name, sensor.type, off):
            continue
        planned = Planned.of(sensor, kind, mount)
        if planned is not None and not _is_off(planned.kind, sensor.name, sensor.type, off):  # by its refined kind too
            sensors.append(planned)
    return plugins, sensors


def _is_off(kind: NodeKind, name: str, sensor_type: str, off: frozenset[str]) -> bool:
    return bool(off) and bool(({kind.switch, kind.name, name, sensor_type} - {""}) & off)


def _check_off(robot: Robot, off: frozenset[str], where: str) -> None:
    """One warning for each name in `off` that turns nothing off: no switch, kind, sensor type or block has it."""
    blocks = {s.name for s in robot.sensors} | {p.name for p in robot.plugins}
    known = set(switches()) | {t for t, _ in SENSORS} | blocks
    for name in sorted(off - known):
        log.warning(
            "%s: --no-sensor %s turns nothing off: it is no sensor or plugin of the description, and no kind or "
            "switch (%s)",
            where,
            name,
            ", ".join(switches()),
        )
