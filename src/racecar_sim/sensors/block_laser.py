"""gazebo_ros_block_laser (libgazebo_ros_block_laser.so): a `<sensor type="ray">` block's beams as a
sensor_msgs/PointCloud, as gazebo_plugins/src/gazebo_ros_block_laser.cpp (ROS 1) fills it.

Every beam gives a point, hit or not: its range r (a beam that hits nothing: its full length, range_max; every range
capped at range_max - range_min) along the direction the plugin computes for it. That direction is the plugin's own:
the angles halfway to the next beam (the last beam of a row or column keeps its own), and z pointing down
(x = r cos p cos y, y = r cos p sin y, z = -r sin p). N(0, <gaussianNoise>) is added to x, y and z of a point below
the cap, and to its channel's value; the one channel (unnamed, as the plugin leaves it) holds the beams' intensity
(0 here: no surface declares a retro-reflectance). Topic <topicName> (default /world) under <robotNamespace>, frame
<frameName> (default world), published at the sensor's rate while someone listens.

The beams are cast by the 3-D caster (velodyne.BeamCaster) at every sensor's sampling point, the end of the last step.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.rng import NoiseTable
from racecar_sim.description.urdf import Origin, Sensor
from racecar_sim.msgs.geometry_msgs import Point32
from racecar_sim.msgs.sensor_msgs import ChannelFloat32, PointCloud
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import NodeBase, NodeContext
from racecar_sim.sensors.range_spec import Beams, ray_block
from racecar_sim.sensors.sensor_xml import join_topic, plugin_number
from racecar_sim.sensors.velodyne import BeamCaster

PLUGIN = "libgazebo_ros_block_laser.so"
EPSILON_DIFF = 1e-6  # the plugin's: a range this close to the cap is a beam that hit nothing (no noise)


@dataclass(frozen=True)
class BlockLaserSpec:
    """A block laser: its beams, span, rate, noise, topic and frame."""

    name: str
    link: str
    pose: Origin
    update_rate: float
    horizontal: Beams
    vertical: Beams
    range_min: float
    range_max: float
    gaussian_noise: float
    topic: str
    frame_id: str

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> BlockLaserSpec:
        """Read a ray block holding gazebo_ros_block_laser (DescriptionError naming what is wrong)."""
        where = f"<sensor type='{sensor.type}' name='{sensor.name}'> on link {sensor.link}"
        plugin = next((p for p in sensor.plugins if p.filename == PLUGIN), None)
        if plugin is None:
            raise DescriptionError(f"{where}: no <plugin filename='{PLUGIN}'> inside")
        rate, horizontal, vertical, range_min, range_max = ray_block(sensor, where)
        if rate <= 0:
            raise DescriptionError(f"{where}: <update_rate> must be positive, got {rate:g}")
        params = plugin.params
        noise = plugin_number(params, "gaussianNoise", where, 0.0)
        if noise < 0:
            raise DescriptionError(f"{where}: <gaussianNoise> must not be negative, got {noise:g}")
        return cls(
            sensor.name,
            sensor.link,
            sensor.pose,
            rate,
            horizontal,
            vertical,
            range_min,
            range_max,
            noise,
            join_topic(params.get("robotNamespace", ""), params.get("topicName") or "/world"),
            (params.get("frameName") or "/world").lstrip("/"),
        )


def _angles(beams: Beams) -> tuple[np.ndarray, np.ndarray]:
    """The beams' own angles, and the angles the plugin puts their points at (halfway to the next beam)."""
    index = np.arange(beams.samples)
    own = beams.min_angle + beams.step * index
    shifted = beams.min_angle + beams.step * 0.5 * (index + np.minimum(index + 1, beams.samples - 1))
    return own, shifted


class BlockLaserPublisher(NodeBase):
    """gazebo_ros_block_laser: PointCloud on its topic at the sensor's rate (see the module doc)."""

    def __init__(self, ctx: NodeContext, spec: BlockLaserSpec) -> None:
        names = ctx.names
        self.ctx, self.spec, self.seed = ctx, spec, ctx.seed
        self.topic = names.topic(spec.topic)
        self.frame_id = spec.frame_id if spec.frame_id in ("world", "map") else names.frame(spec.frame_id)
        self.beams = BeamCaster(ctx, spec.pose, "a block laser")
        (yaw, yaw_at), (pitch, pitch_at) = _angles(spec.horizontal), _angles(spec.vertical)
        self._local = _directions(yaw, pitch, 1.0)  # where each beam points (rows of the vertical samples)
        self._placed = _directions(yaw_at, pitch_at, -1.0)  # where the plugin puts its point (z down)
        self.noise = ctx.noise and spec.gaussian_noise > 0
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"block_laser/{spec.name}"), 4 * len(self._local))
        self._task = ctx.timers.every(spec.update_rate, self._tick, f"block laser {spec.name}")

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Cast in a recompiled model (its site's id is bound for the node)."""
        self.beams.rebind(model, data)

    def cloud(self, stamp_ns: int) -> PointCloud:
        """The cloud of a scan taken now, stamped `stamp_ns`."""
        spec = self.spec
        cap = spec.range_max - spec.range_min
        r = self.beams.cast(self._local, spec.range_min, spec.range_max)
        r[~np.isfinite(r)] = spec.range_max  # no hit: the ray's full length
        np.minimum(r, cap, out=r)
        xyz = self._placed * r[:, None]
        intensity = np.zeros(len(r))
        if self.noise:
            unit = self.noise_table.sample(self.seed, stamp_ns).reshape(4, -1)
            hit = np.abs(cap - r) >= EPSILON_DIFF
            xyz[hit] += spec.gaussian_noise * unit[:3, hit].T
            intensity += spec.gaussian_noise * unit[3]
        points = [Point32(x, y, z) for x, y, z in xyz.astype(np.float32).tolist()]
        channel = ChannelFloat32("", intensity.astype(np.float32))
        return PointCloud(Header.at(stamp_ns, self.frame_id), points, [channel])

    def _tick(self, now_ns: int) -> None:
        if self.ctx.bus.has_listeners(self.topic):
            self.ctx.bus.publish(self.topic, self.cloud(now_ns))

    def reset(self, seed: int) -> None:
        """Noise from `seed` from now on."""
        self.seed = seed

    def close(self) -> None:
        """Stop publishing."""
        self._task.cancel()


def _directions(yaw: np.ndarray, pitch: np.ndarray, up: float) -> np.ndarray:
    """Unit directions (rows of pitch, each every yaw; flattened to (n, 3)) with z = up * sin(pitch)."""
    cp, sp = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
    grid = np.stack([cp * np.cos(yaw), cp * np.sin(yaw), np.broadcast_to(up * sp, (len(pitch), len(yaw)))], axis=-1)
    return grid.reshape(-1, 3)
