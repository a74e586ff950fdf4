"""An IMU from the description: `<sensor type="imu">` with gazebo_ros_imu_sensor, or the gazebo_ros_imu model plugin.

sensor_msgs/Imu as Gazebo's plugins fill it: the orientation of the sensor in the world (REP 145), the angular velocity
and the linear acceleration in the sensor frame - the proper acceleration, so a car at rest reads +9.81 m/s^2 up -
with each component's Gaussian noise (gaussianNoise: the same stddev on all ten numbers, as the plugins add it, plus
the sensor's own per-axis <noise>) and the covariance diagonals set to its variance. MuJoCo measures them: a site at
the sensor's pose carries an accelerometer, a gyro and a frame quaternion, read at every sensor's sampling point: the
end of the last physics step (sensors/shared_pose.py, `forward`). Noise depends only on (seed, stamp).

Names, as the plugins derive them:
  gazebo_ros_imu_sensor   topic <robotNamespace>/<topicName> (default namespace: the model's name; topic imu_data),
                          frame <frameName> (required), rate min(<update_rate>, <updateRateHZ> (default 1 Hz))
  gazebo_ros_imu          topic /<topicName> (default <bodyName>), frame <frameName> (default <bodyName>),
                          rate <updateRate> (0: every physics step)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from racecar_sim.core.errors import DescriptionError
from racecar_sim.core.names import CarNames
from racecar_sim.core.rng import NoiseTable
from racecar_sim.core.transforms import quat_from_rpy, quat_mul
from racecar_sim.description.urdf import Origin, Plugin, Robot, Sensor
from racecar_sim.msgs import Header, Imu, Quaternion, Vector3
from racecar_sim.nodes import NodeBase, NodeContext, Parts
from racecar_sim.sensors.sensor_xml import join_topic, plugin_number, sensor_number
from racecar_sim.sensors.shared_pose import SharedPose

SENSOR_PLUGIN = "libgazebo_ros_imu_sensor.so"
MODEL_PLUGIN = "libgazebo_ros_imu.so"
COMPONENTS = 10  # orientation (4), angular velocity (3), linear acceleration (3)


@dataclass(frozen=True)
class ImuSpec:
    """Where the IMU sits (a pose in a link's frame), what it publishes, how often and with what noise."""

    name: str
    link: str
    pose: Origin
    rate_hz: float
    topic: str
    frame_id: str
    noise_mean: tuple[float, ...]  # per component: orientation x y z w, angular velocity x y z, acceleration x y z
    noise_stddev: tuple[float, ...]
    gaussian_noise: float  # the plugin's: its square is the covariance diagonal
    rpy_offset: tuple[float, float, float]

    @property
    def site(self) -> str:
        """The MuJoCo site (car-relative name) carrying the IMU's sensors."""
        return f"{self.link}/imu/{self.name}"

    @classmethod
    def from_sensor(cls, sensor: Sensor, model_name: str) -> ImuSpec:
        """A `<sensor type="imu">` block and its gazebo_ros_imu_sensor plugin."""
        where = f"<sensor type='imu' name='{sensor.name}'> on link {sensor.link}"
        plugin = next((p for p in sensor.plugins if p.filename == SENSOR_PLUGIN), None)
        params = plugin.params if plugin is not None else {}
        namespace = params.get("robotNamespace", f"/{model_name}")
        topic = join_topic(namespace, params.get("topicName") or "imu_data")
        frame = params.get("frameName", "")
        if plugin is not None and not frame:
            raise DescriptionError(f"{where}: {SENSOR_PLUGIN} needs <frameName> (the plugin does not load without it)")
        rates = [r for r in (sensor.update_rate, plugin_number(params, "updateRateHZ", where, 1.0)) if r > 0]
        if not rates:
            raise DescriptionError(f"{where}: <update_rate> and <updateRateHZ> are 0: give the IMU a rate")
        gaussian = plugin_number(params, "gaussianNoise", where, 0.0)
        mean, stddev = _sensor_noise(sensor, where)
        return cls._checked(
            sensor.name,
            sensor.link,
            sensor.pose,
            min(rates),
            topic,
            frame or sensor.link,
            mean,
            stddev,
            gaussian,
            _offset(params, where),
            where,
        )

    @classmethod
    def from_sdf(cls, sensor: Sensor) -> ImuSpec:
        """A `<sensor type="imu">` block by its SDF alone: its rate (0: every physics step) and per-axis noise; the
        topic and frame are the plugin's to give (ROS 2's gazebo_ros_imu_sensor: sensors/ros2_dialect.py)."""
        where = f"<sensor type='imu' name='{sensor.name}'> on link {sensor.link}"
        mean, stddev = _sensor_noise(sensor, where)
        zero = (0.0, 0.0, 0.0)
        return cls._checked(
            sensor.name, sensor.link, sensor.pose, sensor.update_rate, "", sensor.link, mean, stddev, 0.0, zero, where
        )

    @classmethod
    def from_plugin(cls, plugin: Plugin, robot: Robot) -> ImuSpec:
        """A gazebo_ros_imu model plugin: the IMU at the origin of the link <bodyName>."""
        params = plugin.params
        where = f"<plugin name='{plugin.name}' filename='{MODEL_PLUGIN}'>"
        body = params.get("bodyName", "")
        if body not in robot.links:
            raise DescriptionError(f"{where}: <bodyName> '{body}' is not a link of {robot.name}")
        rate = plugin_number(params, "updateRate", where, 0.0)
        gaussian = plugin_number(params, "gaussianNoise", where, 0.0)
        topic = join_topic(params.get("robotNamespace", ""), params.get("topicName") or body)
        zeros = (0.0,) * COMPONENTS
        return cls._checked(
            plugin.name or body,
            body,
            Origin(),
            rate,
            topic,
            params.get("frameName") or body,
            zeros,
            zeros,
            gaussian,
            _offset(params, where),
            where,
        )

    @classmethod
    def _checked(
        cls,
        name: str,
        link: str,
        pose: Origin,
        rate: float,
        topic: str,
        frame: str,
        mean: tuple[float, ...],
        stddev: tuple[float, ...],
        gaussian: float,
        rpy_offset: tuple[float, float, float],
        where: str,
    ) -> ImuSpec:
        if rate < 0:
            raise DescriptionError(f"{where}: the update rate must not be negative, got {rate:g}")
        if gaussian < 0 or min(stddev) < 0:
            raise DescriptionError(f"{where}: a noise stddev must not be negative")
        combined = tuple(math.hypot(s, gaussian) for s in stddev)
        return cls(name, link, pose, rate, topic, frame, mean, combined, gaussian, rpy_offset)

    def with_names(self, names: CarNames) -> ImuSpec:
        """The spec with the car's names (topic under its namespace, frame with its tf_prefix)."""
        return ImuSpec(
            self.name,
            self.link,
            self.pose,
            self.rate_hz,
            names.topic(self.topic),
            names.frame(self.frame_id),
            self.noise_mean,
            self.noise_stddev,
            self.gaussian_noise,
            self.rpy_offset,
        )


def _offset(params: dict[str, str], where: str) -> tuple[float, float, float]:
    text = params.get("rpyOffset", "0 0 0")
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise DescriptionError(f"{where}: <rpyOffset> '{text}' is not 3 numbers")
    return values


def _sensor_noise(sensor: Sensor, where: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The per-axis <noise> of SDF's <imu> block (angular_velocity and linear_acceleration, x y z); none for the
    orientation, which Gazebo's IMU reports exact."""
    mean, stddev = [0.0] * COMPONENTS, [0.0] * COMPONENTS
    imu = sensor.element.find("imu")
    if imu is not None:
        for first, group in ((4, "angular_velocity"), (7, "linear_acceleration")):
            for k, axis in enumerate("xyz"):
                noise = imu.find(f"{group}/{axis}/noise")
                if noise is not None and (noise.get("type") or noise.findtext("type") or "gaussian") != "none":
                    mean[first + k] = sensor_number(noise, "mean", where, default=0.0)
                    stddev[first + k] = sensor_number(noise, "stddev", where, default=0.0)
    return tuple(mean), tuple(stddev)


def add_imu_site(spec: mujoco.MjSpec, imu: ImuSpec, names: CarNames) -> None:
    """Put the IMU's site and its accelerometer, gyro and frame quaternion into the MjSpec (before compiling)."""
    body = spec.body(names.mj(imu.link))
    if body is None:
        raise DescriptionError(f"IMU '{imu.name}': link {imu.link} is not in the model")
    site = names.mj(imu.site)
    body.add_site(name=site, pos=list(imu.pose.xyz), quat=list(quat_from_rpy(imu.pose.rpy)), size=[0.005] * 3, group=4)
    for kind, suffix in (
        (mujoco.mjtSensor.mjSENS_FRAMEQUAT, "quat"),
        (mujoco.mjtSensor.mjSENS_GYRO, "gyro"),
        (mujoco.mjtSensor.mjSENS_ACCELEROMETER, "accel"),
    ):
        spec.add_sensor(name=f"{site}/{suffix}", type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site)


_READINGS = (("quat", "quat"), ("gyro", "gyro"), ("accel", "accel"))


def imu_parts(imu: ImuSpec, names: CarNames) -> Parts:
    """The IMU's MuJoCo sensors (frame quaternion, gyro, accelerometer) by role, as add_imu_site names them."""
    site = names.mj(imu.site)
    sensor = mujoco.mjtObj.mjOBJ_SENSOR
    return Parts(f"IMU '{imu.name}'", **{role: (sensor, f"{site}/{suffix}") for role, suffix in _READINGS})


class ImuPublisher(NodeBase):
    """gazebo_ros_imu_sensor / gazebo_ros_imu: sensor_msgs/Imu at the IMU's rate, only while someone listens."""

    def __init__(self, ctx: NodeContext, imu: ImuSpec) -> None:
        self.ctx, self.spec = ctx, imu.with_names(ctx.names)
        self.seed = ctx.seed
        self.noise = ctx.noise and any(s > 0 or m != 0 for s, m in zip(self.spec.noise_stddev, self.spec.noise_mean))
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"imu/{imu.name}"), COMPONENTS)
        self._stddev = np.array(self.spec.noise_stddev)
        self._mean = np.array(self.spec.noise_mean)
        self._offset = quat_from_rpy(self.spec.rpy_offset)
        variance = self.spec.gaussian_noise**2
        self._covariance = np.diag([variance] * 3).reshape(-1)
        self._covariance.flags.writeable = False
        # its MuJoCo sensors, bound by the car (or here, for an IMU built on its own)
        self.parts = ctx.parts if ctx.parts.declares("gyro") else imu_parts(imu, ctx.names).bind(ctx.model)
        self._owns_parts = self.parts is not ctx.parts
        self._adr = self._addresses()
        rate = self.spec.rate_hz if self.spec.rate_hz > 0 else 1e9 / ctx.timers.step_ns
        self._task = ctx.timers.every(rate, self._tick, f"imu {self.spec.name}")

    def _addresses(self) -> tuple[int, int, int]:
        return self.parts.adr("quat"), self.parts.adr("gyro"), self.parts.adr("accel")

    def _tick(self, now_ns: int) -> None:
        if self.ctx.bus.has_listeners(self.spec.topic):
            self.ctx.bus.publish(self.spec.topic, self.measure(now_ns))

    def measure(self, stamp_ns: int) -> Imu:
        """The IMU's reading now, stamped `stamp_ns` (with that stamp's noise)."""
        data = SharedPose.of(self.ctx.model, self.ctx.data).forward(self.ctx.data).sensordata
        q, g, a = self._adr
        quat = quat_mul(self._offset, data[q : q + 4])  # (w, x, y, z)
        values = np.array([quat[1], quat[2], quat[3], quat[0], *data[g : g + 3], *data[a : a + 3]])
        if self.noise:
            values += self._mean + self._stddev * self.noise_table.sample(self.seed, stamp_ns)
        cov = self._covariance
        return Imu(
            Header.at(stamp_ns, self.spec.frame_id),
            Quaternion(*(float(v) for v in values[:4])),
            cov,
            Vector3(*(float(v) for v in values[4:7])),
            cov,
            Vector3(*(float(v) for v in values[7:])),
            cov,
        )

    def reset(self, seed: int) -> None:
        self.seed = seed

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if self._owns_parts:
            self.parts.bind(model)
        self._adr = self._addresses()

    def close(self) -> None:
        self._task.cancel()
