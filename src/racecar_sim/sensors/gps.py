"""hector's GPS (libhector_gazebo_ros_gps.so): sensor_msgs/NavSatFix and its velocity from a link's pose.

As hector_gazebo_plugins/src/gazebo_ros_gps.cpp computes them (ROS 1, noetic): the world is north-west-up at the
reference (x north when <referenceHeading> is 0 degrees), so

  latitude  = lat0 + ( cos(h) x + sin(h) y) / R_north * 180/pi
  longitude = lon0 - (-sin(h) x + cos(h) y) / R_east  * 180/pi
  altitude  = alt0 + z

with the WGS 84 radii at the reference latitude (R_north the meridian's, R_east the parallel's), and the velocity
(geometry_msgs/Vector3Stamped) turned by the same heading. Parameters and defaults: <robotNamespace> "", <bodyName>
the model's first link, <frameId> /world, <topicName> fix, <velocityTopicName> fix_velocity, <referenceLatitude>
49.9, <referenceLongitude> 8.9, <referenceHeading> 0 (degrees), <referenceAltitude> 0, <status> 0 (STATUS_FIX),
<service> 0, <updateRate> 4 Hz (0: every physics step). The error model's <offset>, <gaussianNoise> and <scaleError>
(and their velocity* forms), one number or three, apply; its slow <drift> is not simulated (a warning says so), and
the covariance diagonal is drift^2 + gaussianNoise^2 as the plugin sets it.

Sampling point: every sensor's, the end of the last physics step (sensors/shared_pose.py, `forward`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.rng import NoiseTable
from racecar_sim.description.urdf import Plugin, Robot
from racecar_sim.msgs.geometry_msgs import Vector3, Vector3Stamped
from racecar_sim.msgs.sensor_msgs import NavSatFix, NavSatStatus
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import Mount, NodeBase, NodeContext, Parts
from racecar_sim.sensors.sensor_xml import join_topic, plugin_number
from racecar_sim.sensors.shared_pose import SharedPose

PLUGIN = "libhector_gazebo_ros_gps.so"
EQUATORIAL_RADIUS = 6378137.0  # WGS 84
FLATTENING = 1.0 / 298.257223563
ECCENTRICITY2 = 2 * FLATTENING - FLATTENING * FLATTENING
_SITE = int(mujoco.mjtObj.mjOBJ_SITE)
log = logging.getLogger("racecar_sim")


@dataclass(frozen=True)
class ErrorModel:
    """hector's SensorModel3 without its drift: reading = true * scale_error + offset + N(0, gaussian_noise)."""

    offset: tuple[float, float, float]
    gaussian_noise: tuple[float, float, float]
    scale_error: tuple[float, float, float]
    drift: tuple[float, float, float]

    @classmethod
    def from_params(cls, params: dict[str, str], prefix: str, where: str) -> ErrorModel:
        """The model of the parameters `<offset>`, ... (prefix "") or `<velocityOffset>`, ... (prefix "velocity")."""

        def tag(name: str) -> str:
            return prefix + name[0].upper() + name[1:] if prefix else name

        model = cls(
            _vector(params, tag("offset"), where, 0.0),
            _vector(params, tag("gaussianNoise"), where, 0.0),
            _vector(params, tag("scaleError"), where, 1.0),
            _vector(params, tag("drift"), where, 0.0),
        )
        if any(v < 0 for v in model.gaussian_noise):
            raise DescriptionError(f"{where}: <{tag('gaussianNoise')}> must not be negative")
        if any(model.drift):
            log.warning("%s: <%s> (a slow random walk) is not simulated; the reading has no drift", where, tag("drift"))
        return model

    @property
    def variances(self) -> tuple[float, float, float]:
        """The covariance diagonal the plugin publishes: drift^2 + gaussianNoise^2 per axis."""
        return tuple(d * d + g * g for d, g in zip(self.drift, self.gaussian_noise))  # type: ignore[return-value]


def _vector(params: dict[str, str], tag: str, where: str, default: float) -> tuple[float, float, float]:
    text = params.get(tag, "").strip()
    if not text:
        return (default, default, default)
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) == 1:
        values *= 3
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise DescriptionError(f"{where}: <{tag}> '{text}' is not one number or three")
    return (values[0], values[1], values[2])


@dataclass(frozen=True)
class GpsSpec:
    """One hector GPS plugin block, read (see the module doc for the parameters)."""

    name: str
    link: str
    rate_hz: float
    frame_id: str
    fix_topic: str
    velocity_topic: str
    latitude: float  # degrees
    longitude: float
    heading: float  # rad
    altitude: float  # m
    status: int
    service: int
    position: ErrorModel
    velocity: ErrorModel

    @classmethod
    def from_plugin(cls, plugin: Plugin, robot: Robot) -> GpsSpec:
        """Read a `<plugin filename="libhector_gazebo_ros_gps.so">` block (DescriptionError naming what is wrong)."""
        params = plugin.params
        where = f"<plugin name='{plugin.name}' filename='{PLUGIN}'> in {robot.source or robot.name}"
        link = params.get("bodyName") or robot.root
        if link not in robot.links:
            raise DescriptionError(f"{where}: <bodyName> '{link}' is not a link of {robot.name}")
        rate = plugin_number(params, "updateRate", where, 4.0)
        if rate < 0:
            raise DescriptionError(f"{where}: <updateRate> must not be negative, got {rate:g}")
        latitude = plugin_number(params, "referenceLatitude", where, 49.9)
        if not -90 < latitude < 90:
            raise DescriptionError(f"{where}: <referenceLatitude> {latitude:g} is not between -90 and 90 degrees")
        namespace = params.get("robotNamespace", "")
        return cls(
            plugin.name or link,
            link,
            rate,
            params.get("frameId") or "/world",
            join_topic(namespace, params.get("topicName") or "fix"),
            join_topic(namespace, params.get("velocityTopicName") or "fix_velocity"),
            latitude,
            plugin_number(params, "referenceLongitude", where, 8.9),
            math.radians(plugin_number(params, "referenceHeading", where, 0.0)),
            plugin_number(params, "referenceAltitude", where, 0.0),
            int(plugin_number(params, "status", where, NavSatStatus.STATUS_FIX)),
            int(plugin_number(params, "service", where, 0)),
            ErrorModel.from_params(params, "", where),
            ErrorModel.from_params(params, "velocity", where),
        )

    @property
    def radii(self) -> tuple[float, float]:
        """(north, east): the WGS 84 meridian and parallel radii (m per rad) at the reference latitude."""
        sin_lat = math.sin(math.radians(self.latitude))
        temp = 1.0 / (1.0 - ECCENTRICITY2 * sin_lat * sin_lat)
        prime_vertical = EQUATORIAL_RADIUS * math.sqrt(temp)
        return prime_vertical * (1 - ECCENTRICITY2) * temp, prime_vertical * math.cos(math.radians(self.latitude))


def gps_parts(spec: GpsSpec, mount: Mount) -> Parts:
    """The GPS's part: the site of its link."""
    return Parts.sites(f"GPS '{spec.name}'", site=mount.names.mj(spec.link))


class GpsPublisher(NodeBase):
    """hector's GPS: NavSatFix on its fix topic and Vector3Stamped on its velocity topic, at its rate."""

    def __init__(self, ctx: NodeContext, spec: GpsSpec) -> None:
        names = ctx.names
        self.ctx, self.spec, self.seed = ctx, spec, ctx.seed
        self.fix_topic, self.velocity_topic = names.topic(spec.fix_topic), names.topic(spec.velocity_topic)
        self.parts = ctx.parts  # its link's site, bound by the car
        self._north, self._east = spec.radii
        self._cos, self._sin = math.cos(spec.heading), math.sin(spec.heading)
        self.noise = ctx.noise and any(spec.position.gaussian_noise + spec.velocity.gaussian_noise)
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"gps/{spec.name}"), 6)
        px, py, pz = spec.position.variances
        self._covariance = np.diag([px, py, pz]).reshape(-1)  # the plugin's x, y, z order
        self._covariance.flags.writeable = False
        self._vel = np.zeros(6)
        rate = spec.rate_hz if spec.rate_hz > 0 else 1e9 / ctx.timers.step_ns
        self._task = ctx.timers.every(rate, self._tick, f"gps {spec.name}")

    def _tick(self, now_ns: int) -> None:
        bus = self.ctx.bus
        if bus.has_listeners(self.fix_topic) or bus.has_listeners(self.velocity_topic):
            fix, velocity = self.measure(now_ns)
            bus.publish(self.fix_topic, fix)
            bus.publish(self.velocity_topic, velocity)

    def true_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The link's world position (m) and linear velocity (m/s) at the sampling point."""
        model = self.ctx.model
        data = SharedPose.of(model, self.ctx.data).forward(self.ctx.data)
        site = self.parts["site"]
        mujoco.mj_objectVelocity(model, data, _SITE, site, self._vel, 0)
        return data.site_xpos[site].copy(), self._vel[3:].copy()

    def measure(self, stamp_ns: int) -> tuple[NavSatFix, Vector3Stamped]:
        """The fix and the velocity now, stamped `stamp_ns` (with that stamp's noise)."""
        spec = self.spec
        position, velocity = self.true_state()
        position = position * spec.position.scale_error + spec.position.offset
        velocity = velocity * spec.velocity.scale_error + spec.velocity.offset
        if self.noise:
            unit = self.noise_table.sample(self.seed, stamp_ns)
            position += np.array(spec.position.gaussian_noise) * unit[:3]
            velocity += np.array(spec.velocity.gaussian_noise) * unit[3:]
        c, s = self._cos, self._sin
        x, y, z = (float(v) for v in position)
        header = Header.at(stamp_ns, spec.frame_id)
        fix = NavSatFix(
            header,
            NavSatStatus(spec.status, spec.service),
            spec.latitude + (c * x + s * y) / self._north * 180.0 / math.pi,
            spec.longitude - (-s * x + c * y) / self._east * 180.0 / math.pi,
            spec.altitude + z,
            self._covariance,
            NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN,
        )
        vx, vy, vz = (float(v) for v in velocity)
        return fix, Vector3Stamped(header, Vector3(c * vx + s * vy, -s * vx + c * vy, vz))

    def reset(self, seed: int) -> None:
        """Noise from `seed` from now on."""
        self.seed = seed

    def close(self) -> None:
        """Stop publishing."""
        self._task.cancel()
