"""The Hokuyo: gazebo_ros_laser's sensor_msgs/LaserScan on /scan, from racecar.gazebo's <sensor type="ray">.

Per beam, Gazebo 7's rule: nothing within range_max gives +inf; otherwise the true range plus N(mean,
stddev) noise, clamped to [range_min, range_max]. Rays start at range_min, so nearer objects are not seen.
The car never sees itself. The scan is cast only when someone listens (as gazebo_ros_laser does), but the
schedule is kept, and a scan's noise depends only on (seed, stamp): skipping scans changes no other.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from racecar_sim.core.names import CarNames
from racecar_sim.core.rng import NoiseTable
from racecar_sim.core.transforms import quat_from_rpy, quat_to_matrix
from racecar_sim.description.urdf import Sensor
from racecar_sim.msgs import Header, LaserScan
from racecar_sim.nodes import NodeBase, NodeContext, Parts
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.sensors.fleet_scans import FleetScans
from racecar_sim.sensors.laser_mount import LaserMount
from racecar_sim.sensors.laser_spec import LaserSpec
from racecar_sim.sensors.raycast import Fan, RayCaster
from racecar_sim.sensors.raycast.scene import Solids
from racecar_sim.sensors.shared_pose import SharedPose

if TYPE_CHECKING:
    from racecar_sim.sensors.raycast.grid import FlatWalls

NOISE_STREAM = "scan"
ORIGINAL_TOPIC = "/scan"  # the laser on it keeps the original noise stream, `scan` (runs stay bit-identical)
_LEVEL_SCAN: Callable[..., bool] | None = None  # laser_kernel.level_scan, imported at the first scan (numba)
_FIRST, _SECOND, _OUT = 21, 22, 27  # the scan's own arguments of level_scan (LidarPublisher._one_call)
_NO_SOLIDS = Solids(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros((0, 3)), np.zeros(0))


def _level_scan() -> Callable[..., bool]:
    """laser_kernel.level_scan, imported once (with numba) by the first scan that takes it."""
    global _LEVEL_SCAN
    from racecar_sim.sensors.laser_kernel import level_scan

    _LEVEL_SCAN = level_scan
    return level_scan


def named_laser_spec(sensor: Sensor | LaserSpec, names: CarNames = CarNames()) -> LaserSpec:
    """A ray sensor block (or its spec, parsed already) with the car's names (link, topic, frame)."""
    spec = sensor if isinstance(sensor, LaserSpec) else LaserSpec.from_sensor(sensor)
    return dataclasses.replace(
        spec, link=names.mj(spec.link), topic=names.topic(spec.topic), frame_id=names.frame(spec.frame_id)
    )


class LidarPublisher(NodeBase):
    """gazebo_ros_laser: LaserScan at the sensor's rate (40 Hz), frame `laser`, sim-time stamps, for one
    `<sensor type="ray">` block of the description (a car may have several, each on its own topic), given parsed
    (the registry's spec) or as the block.

    The context's `noise=False` publishes the true ranges (still clamped and +inf past range_max). `mode` "3d" makes
    every scan a MuJoCo 3-D cast (the reference; "auto" gives the same ranges, faster).
    """

    def __init__(self, ctx: NodeContext, sensor: Sensor | LaserSpec, mode: str = "auto") -> None:
        names, model, data = ctx.names, ctx.model, ctx.data
        robot = ctx.need_robot("a laser")
        own = sensor if isinstance(sensor, LaserSpec) else LaserSpec.from_sensor(sensor)  # the registry parsed it
        self.spec = spec = named_laser_spec(own, names)
        self.noise_stream = ctx.noise_stream(NOISE_STREAM if own.topic == ORIGINAL_TOPIC else NOISE_STREAM + own.topic)
        self.bus, self.model, self.data, self.seed, self.mode = ctx.bus, model, data, ctx.seed, mode
        noise = ctx.noise
        self.topic = spec.topic  # gazebo_ros_laser's <topicName>: /scan
        self.noise = noise and spec.noisy
        self.noise_table = NoiseTable.shared(self.noise_stream, spec.samples)
        self._no_intensities = np.zeros(spec.samples, np.float32)
        self._no_intensities.flags.writeable = False  # one array shared by every scan message
        # a scan message's fields from angle_min to range_max, the same in every scan
        self._fields = (spec.min_angle, spec.max_angle, spec.angle_increment, 0.0, 0.0, spec.range_min, spec.range_max)
        self._ranges = np.empty(spec.samples)  # level_scan's true ranges (scratch)
        self._misses = np.full(spec.samples, np.inf, np.float32)  # a scan that hits nothing
        self._root = names.mj(robot.root)
        # the site of its link, bound by the car (or here, for a laser built on its own)
        self.parts = ctx.parts if ctx.parts.declares("site") else self._own_parts().bind(model)
        self._owns_parts = self.parts is not ctx.parts
        self._site = self.parts["site"]
        self._offset = np.array(spec.pose.xyz, dtype=float)
        self._turn = quat_to_matrix(quat_from_rpy(spec.pose.rpy))
        # Scans are cast in an MjData posed from the live qpos: after mj_step the live positions describe the start
        # of the last step, and the simulation's own data stays untouched. Every lidar of the simulation shares it
        # (posed once per tick for the whole fleet).
        self._shared = SharedPose.of(model, data)
        self._pose = self._shared.pose
        self.mount = LaserMount.of(model, self._site, self._offset, self._turn)
        self.fan = Fan(spec.min_angle, spec.angle_increment, spec.samples, spec.range_min, spec.range_max)
        self.caster = RayCaster(
            model, self._pose, self.fan, model.body(self._root).id, COLLISION_GROUP, pose_bodies=self._pose_bodies
        )
        self._args_key: tuple[object, ...] | None = None  # _one_call's: the ids of the objects its arguments come from
        self._args_owners: tuple[object, ...] = ()  # and those objects, held so that their ids are not reused
        self._args: list[Any] = []
        self.scans_cast = 0
        self.one_call_scans = 0  # scans answered by the one compiled call (laser_kernel.level_scan)
        self.beams_3d = 0  # beams cast in 3-D by MuJoCo, over every scan
        self.task = ctx.timers.every(spec.update_rate, self._tick, "hokuyo")
        self._fleet = FleetScans.of(self._shared, data)  # the scans of one tick cast in one call for every lidar
        self._fleet.join(self)

    def _own_parts(self) -> Parts:
        return Parts.sites(f"ray sensor '{self.spec.name}'", site=self.spec.link)

    def rebind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Scan a recompiled model (a model was spawned or deleted): same node, schedule and noise; the caster
        slices the new world again."""
        self.model, self.data = model, data
        if self._owns_parts:
            self.parts.bind(model)
        self._site = self.parts["site"]
        self._shared = SharedPose.of(model, data)
        self._pose = self._shared.pose
        self.mount = LaserMount.of(model, self._site, self._offset, self._turn)
        self.caster.rebind(model, self._pose, model.body(self._root).id)
        self._fleet.leave(self)
        self._fleet = FleetScans.of(self._shared, data)
        self._fleet.join(self)

    def _tick(self, now_ns: int) -> None:
        if not self.bus.has_listeners(self.topic):
            return
        spec = self.spec
        ranges = self._fleet.take(self, now_ns) if self.mode == "auto" else None
        if ranges is None:
            ranges = self.scan(now_ns)
        else:  # cast in one call with the fleet's other scans of this tick
            self.scans_cast += 1
            self.one_call_scans += 1
            self.caster.last_3d_beams = 0
        self.bus.publish(
            self.topic, LaserScan(Header.at(now_ns, spec.frame_id), *self._fields, ranges, self._no_intensities)
        )

    def ray_origin(self) -> tuple[np.ndarray, np.ndarray]:
        """World position of the ray origin and the sensor's axes (world from sensor, 3x3) at the current
        qpos (from the chassis' pose in qpos when the laser is welded to it; else by kinematics)."""
        if self.mount is not None:
            return self.mount.pose(self.data.qpos)
        self._pose_bodies()
        site_rotation = self._pose.site_xmat[self._site].reshape(3, 3)
        return self._pose.site_xpos[self._site] + site_rotation @ self._offset, site_rotation @ self._turn

    def _pose_bodies(self) -> None:
        """Pose every body of the shared MjData the caster reads at the live qpos (only when a cast needs body
        poses: moving geoms, 3-D casts; once per tick for every lidar of the simulation)."""
        self._shared.update(self.data)

    def true_ranges(self) -> np.ndarray:
        """Noise-free distances (float64, m) from the ray origin: inf where nothing is within range."""
        self.scans_cast += 1
        ranges = self.caster.cast(*self.ray_origin(), mode=self.mode)
        self.beams_3d += self.caster.last_3d_beams
        return ranges

    def scan(self, stamp_ns: int) -> np.ndarray:
        """The ranges (float32) of a scan taken now and stamped `stamp_ns`, with that stamp's noise."""
        spec = self.spec
        mount = self.mount
        if mount is not None and self.caster.floors_only is not None and self.mode == "auto":
            origin, axes = mount.pose_lists(self.data.qpos)
            if self.caster.misses_everything(origin[2], axes):  # nothing to see (a lone car in an empty world)
                self.scans_cast += 1
                self.caster.last_3d_beams = 0
                return self._misses.copy()  # no echo, with noise or without: inf
        # the common case in one compiled call (laser_kernel.level_scan), else the steps below
        if mount is not None and self.mode == "auto" and (walls := self.caster.level_walls()) is not None:
            solids = self.caster.solids or _NO_SOLIDS
            if len(solids):  # the other cars where they are now
                self._pose_bodies()
            args = self._one_call(walls, solids, mount)
            args[_FIRST], args[_SECOND] = self.noise_table.offsets(self.seed, stamp_ns)
            out = args[_OUT] = np.empty(self.fan.count, np.float32)
            if (_LEVEL_SCAN or _level_scan())(*args):
                self.scans_cast += 1
                self.one_call_scans += 1
                self.caster.last_3d_beams = 0
                return out
        ranges = self.true_ranges()
        if self.caster.compiled:  # numba is loaded for this world's walls: the rule in one compiled pass
            return self._published(ranges, stamp_ns)
        hit = np.isfinite(ranges)
        if self.noise:
            ranges += self.scan_noise(self.noise_table.sample(self.seed, stamp_ns))
        ranges = np.where(hit, np.clip(ranges, spec.range_min, spec.range_max), np.inf)
        return ranges.astype(np.float32)

    def ticks_with(self, task: object) -> bool:
        """Whether this lidar's ticks fall when those of `task` (another lidar's) do: the same period from the same
        start."""
        mine = self.task
        return mine is task or (
            not getattr(mine, "cancelled", True)
            and getattr(mine, "period_ns", None) is not None
            and getattr(mine, "period_ns", None) == getattr(task, "period_ns", None)
            and getattr(mine, "start_ns", None) == getattr(task, "start_ns", None)
        )

    def one_call_args(self) -> list[Any] | None:
        """The arguments of the one compiled call (laser_kernel.level_scan; its scan's own ones unset), or None where
        no scan of this lidar takes that path now (a mount without a free body, mode 3d, a world that is not walls)."""
        if self.mount is None or self.mode != "auto" or (walls := self.caster.level_walls()) is None:
            return None
        return self._one_call(walls, self.caster.solids or _NO_SOLIDS, self.mount)

    def _one_call(self, walls: FlatWalls, solids: Solids, mount: LaserMount) -> list[Any]:
        """level_scan's arguments but the scan's own (the noise windows, `out`: set by the caller), made again only
        when one of the objects they come from changed (a rebind, the noise switched): a scan then reads no
        attribute of them, and no MjData array view is made per scan."""
        key = (id(walls), id(solids), id(mount), id(self.data), id(self._pose), id(self.fan), id(self.spec), self.noise)
        if key != self._args_key:
            from racecar_sim.sensors.raycast.fan import MAX_TILT_COS

            fan, spec, pose = self.fan, self.spec, self._pose
            self._args = [
                self.data.qpos,
                mount.qpos_adr,
                mount.local_origin,
                mount.local_axes,
                walls.size,
                walls.x0,
                walls.y0,
                walls.ids,
                walls.outside,
                walls.starts,
                walls.table,
                walls.floors,
                MAX_TILT_COS,
                fan.angle_min,
                fan.inverse_step,
                fan.count,
                fan.turn,
                fan.range_min,
                fan.range_max,
                fan.directions,
                self.noise_table.values,
                0,  # first
                0,  # second
                spec.noise_stddev,
                spec.noise_mean,
                self.noise,
                self._ranges,
                None,  # out
                pose.geom_xpos,
                pose.geom_xmat,
                solids.ids,
                solids.types,
                solids.sizes,
                solids.rbound,
            ]
            self._args_key = key
            self._args_owners = (walls, solids, mount, self.data, self._pose, self.fan, self.spec)
        return self._args

    def warm(self) -> None:
        """Load now what a scan loads on first use (numba's cached kernels, a map's flat walls): one scan cast at the
        present pose and dropped, its counts put back (the simulator's build calls it: a one-time cost of the start,
        not of the first tick)."""
        counts = self.scans_cast, self.one_call_scans, self.beams_3d, self.caster.last_3d_beams
        self.scan(0)
        self._fleet.warm(self)  # and the fleet's one call for the scans of a tick
        if self.caster.compiled:  # and the general path's kernels, for a scan the one call refuses (a tilted car)
            self._published(self.true_ranges(), 0)
        self.scans_cast, self.one_call_scans, self.beams_3d, self.caster.last_3d_beams = counts

    def _published(self, ranges: np.ndarray, stamp_ns: int) -> np.ndarray:
        """The published ranges (float32) of true ranges (float64, inf: no hit) of a scan stamped `stamp_ns`: noise,
        clamp and float32 in one compiled pass (laser_kernel.published_scan)."""
        from racecar_sim.sensors.laser_kernel import published_scan

        spec = self.spec
        first, second = self.noise_table.offsets(self.seed, stamp_ns)
        out = np.empty(len(ranges), np.float32)
        published_scan(
            ranges,
            self.noise_table.values,
            first,
            second,
            spec.noise_stddev,
            spec.noise_mean,
            self.noise,
            spec.range_min,
            spec.range_max,
            out,
        )
        return out

    def publish(self, ranges: np.ndarray, seeds: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
        """The published ranges (float32, N x beams) of true ranges (float64, N x beams, inf: no hit) of scans
        stamped `stamps_ns` in runs seeded `seeds`: scan()'s rule, compiled (laser_kernel.py), for many at once."""
        from racecar_sim.sensors.laser_kernel import published_scans

        first, second = self.noise_table.offsets(seeds.astype(np.uint64), stamps_ns.astype(np.uint64))
        out = np.empty(ranges.shape, np.float32)
        spec = self.spec
        published_scans(
            ranges,
            self.noise_table.values,
            first.astype(np.intp),
            second.astype(np.intp),
            spec.noise_stddev,
            spec.noise_mean,
            self.noise,
            spec.range_min,
            spec.range_max,
            out,
        )
        return out

    def scan_noise(self, unit: np.ndarray) -> np.ndarray:
        """The sensor's N(mean, stddev) noise from unit normals (in place; any shape)."""
        unit *= self.spec.noise_stddev
        unit += self.spec.noise_mean
        return unit

    def beam_ends(self, ranges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ray origin (3,) and the world end points (N, 3) of a scan's finite beams, at the current pose."""
        origin, axes = self.ray_origin()
        ranges = np.asarray(ranges, np.float64)
        angles = self.spec.min_angle + self.spec.angle_increment * np.arange(len(ranges))
        hit = np.isfinite(ranges)
        r, a = ranges[hit], angles[hit]
        local = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)], axis=1)
        return origin.copy(), origin + local @ axes.T

    def reset(self, seed: int) -> None:
        """Noise from `seed` from now on (a scan's noise depends only on the seed and its stamp)."""
        self.seed = seed

    def close(self) -> None:
        """Stop publishing."""
        self.task.cancel()
        self._fleet.leave(self)
