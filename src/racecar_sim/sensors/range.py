"""gazebo_ros_range: one sensor_msgs/Range per update of a `<sensor type="ray">` block, the nearest of its beams.

The plugin's rule (gazebo_plugins/src/gazebo_ros_range.cpp): the range is the least distance over every beam of the
sensor (horizontal x vertical samples); a beam that hits nothing within range_max counts as range_max (the plugin reads
the ray shape, whose length is its full span when it hits nothing), so nothing in the cone gives exactly range_max.
A range below range_max gets N(0, gaussianNoise) and is capped at range_max; min_range, max_range, field_of_view and
radiation_type are the block's. Beams start at range_min (nearer objects are not seen).

Beam (h, v) points along (cos h cos v, sin h cos v, sin v) in the sensor frame, as Gazebo's ray shape lays them out.
A column of beams (one h, every v) lies in a plane, so it is cast as one fan of the lidar's caster (sensors/raycast):
the same world the lidar sees, map walls and other cars included; a single row at v = 0 is one level fan.

Sampling point: every sensor's, the end of the last physics step (the live qpos, posed in the simulation's shared copy,
sensors/shared_pose.py). Its link's site is bound for it (nodes/parts.py).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from racecar_sim.core.rng import NoiseTable
from racecar_sim.core.transforms import quat_from_rpy, quat_to_matrix
from racecar_sim.msgs.sensor_msgs import Range
from racecar_sim.msgs.std_msgs import Header
from racecar_sim.nodes import NodeBase, NodeContext, Parts
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.sensors.range_spec import RangeSpec
from racecar_sim.sensors.raycast import Fan, RayCaster
from racecar_sim.sensors.shared_pose import SharedPose

_UPRIGHT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # a fan's plane turned to hold the z axis


def _yaw(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class RangePublisher(NodeBase):
    """gazebo_ros_range for one ranger of the description: Range on its topic at its rate, sim-time stamps.

    The context's `noise=False` publishes the true range.
    """

    def __init__(self, ctx: NodeContext, spec: RangeSpec) -> None:
        names = ctx.names
        self.robot = ctx.need_robot("a range sensor")
        self.spec = spec
        self.topic = names.topic(spec.topic)
        self.frame_id = names.frame(spec.frame_id) if spec.frame_id != "world" else spec.frame_id
        self.bus, self.seed = ctx.bus, ctx.seed
        self.noise = ctx.noise and spec.gaussian_noise > 0
        self.noise_table = NoiseTable.shared(ctx.noise_stream(f"range/{spec.name}"), 1)
        self._root = names.mj(self.robot.root)
        self._offset = np.array(spec.pose.xyz, dtype=float)
        self._turn = quat_to_matrix(quat_from_rpy(spec.pose.rpy))
        ray = spec.ray
        h, v = ray.horizontal, ray.vertical
        self._level = v.samples == 1 and v.min_angle == 0.0  # one level row: a single fan over h
        if self._level:
            self._fan = Fan(h.min_angle, h.step, h.samples, ray.range_min, ray.range_max)
            self._columns = [np.eye(3)]
        else:
            self._fan = Fan(v.min_angle, v.step, v.samples, ray.range_min, ray.range_max)
            self._columns = [_yaw(h.min_angle + h.step * i) @ _UPRIGHT for i in range(h.samples)]
        self.caster: RayCaster | None = None
        # the site of its link, bound by the car (or here, for a ranger built on its own)
        own = Parts.sites(f"ray sensor '{spec.name}'", site=names.mj(spec.link))
        self.parts = ctx.parts if ctx.parts.declares("site") else own.bind(ctx.model)
        self._owns_parts = self.parts is not ctx.parts
        self.rebind(ctx.model, ctx.data)
        rate = ray.update_rate if ray.update_rate > 0 else 1e9 / ctx.timers.step_ns  # 0: every physics step
        self._task = ctx.timers.every(rate, self._tick, f"range {spec.name}")

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Cast in a recompiled model: the site's new id, the caster's world sliced again."""
        self.model, self.data = model, data
        if self._owns_parts:
            self.parts.bind(model)
        self._site = self.parts["site"]
        self._shared = SharedPose.of(model, data)
        own = model.body(self._root).id
        if self.caster is not None:
            self.caster.rebind(model, self._shared.pose, own)
        else:
            self.caster = RayCaster(model, self._shared.pose, self._fan, own, COLLISION_GROUP, pose_bodies=self._pose)

    def _pose(self) -> None:
        self._shared.update(self.data)

    def ray_origin(self) -> tuple[np.ndarray, np.ndarray]:
        """World position of the ray origin and the sensor's axes (world from sensor, 3x3) at the live qpos."""
        pose = self._shared.update(self.data)
        rotation = pose.site_xmat[self._site].reshape(3, 3)
        return pose.site_xpos[self._site] + rotation @ self._offset, rotation @ self._turn

    def true_range(self) -> float:
        """The nearest beam's distance (m) now; if no beam hits anything within range_max, what the plugin then
        publishes (`spec.nothing_seen`: range_max for ROS 1's gazebo_ros_range, FLT_MAX for ROS 2's ray sensor)."""
        origin, axes = self.ray_origin()
        assert self.caster is not None
        nearest = math.inf
        for column in self._columns:
            nearest = min(nearest, float(self.caster.cast(origin, axes @ column).min(initial=math.inf)))
        return nearest if nearest <= self.spec.ray.range_max else self.spec.nothing_seen

    def reading(self, stamp_ns: int) -> float:
        """The published range of a reading taken now and stamped `stamp_ns` (with that stamp's noise)."""
        value = self.true_range()
        range_max = self.spec.ray.range_max
        if self.noise and value < range_max:
            value = min(value + self.spec.gaussian_noise * float(self.noise_table.sample(self.seed, stamp_ns)[0]),
                        range_max)  # fmt: skip
        return value

    def _tick(self, now_ns: int) -> None:
        if not self.bus.has_listeners(self.topic):
            return
        spec = self.spec
        self.bus.publish(
            self.topic,
            Range(
                Header.at(now_ns, self.frame_id),
                spec.radiation_type,
                spec.field_of_view,
                spec.ray.range_min,
                spec.ray.range_max,
                self.reading(now_ns),
                spec.gaussian_noise**2 if self.noise else 0.0,
            ),
        )

    def reset(self, seed: int) -> None:
        """Noise from `seed` from now on."""
        self.seed = seed

    def close(self) -> None:
        """Stop publishing."""
        self._task.cancel()
