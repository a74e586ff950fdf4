"""The Simulator: a world, the car, the nodes of the original stack on one bus, and a sim clock.

Physics runs inside MuJoCo for as many steps as fit before the next event (a sensor sample, a node's
timer, a mux timeout); Python runs only at those events.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco

from racecar_sim.bus import Bus, Subscription
from racecar_sim.control.commands import ControllerCommands
from racecar_sim.control.controllers import add_actuators, load_controller_config
from racecar_sim.control.mux import CommandChain
from racecar_sim.control.profiles import load_profile
from racecar_sim.control.servo import ServoCommands
from racecar_sim.core.errors import ConfigError, PhysicsError
from racecar_sim.core.rng import check_seed
from racecar_sim.core.time import NS_PER_S, ceil_to_step, to_ns
from racecar_sim.description import DEFAULT_XACRO, load_robot, package_path
from racecar_sim.msgs import Clock, Time
from racecar_sim.physics import build_spec, check_spawn, load_preset, route_mujoco_warnings
from racecar_sim.physics.state import CarState
from racecar_sim.core.scheduler import Scheduler
from racecar_sim.sensors.joint_states import JointStatePublisher
from racecar_sim.sensors.odometry import OdometryPublisher
from racecar_sim.sensors.robot_state import RobotStatePublisher
from racecar_sim.worlds import DEFAULT_WALL_HEIGHT, Spawn, World, load_world

if TYPE_CHECKING:
    from racecar_sim.recording import McapRecorder
    from racecar_sim.sensors.camera import CameraPublisher
    from racecar_sim.sensors.lidar import LidarPublisher

log = logging.getLogger("racecar_sim")
_DIVERGENCE_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                        mujoco.mjtWarning.mjWARN_BADQACC)
CLOCK_RATE = 100.0  # gazebo_ros publishes /clock at pub_clock_frequency, 100 Hz by default


class Simulator:
    """One simulated RACECAR in one world.

    >>> sim = Simulator(world="empty", profile="seed", seed=0)
    >>> sim.publish("/vesc/ackermann_cmd_mux/input/navigation", AckermannDriveStamped(drive=AckermannDrive(speed=1.0)))
    >>> sim.run_until(2.0)

    Every topic of the original is on `sim.bus` under its original name. Same world, profile, seed and
    inputs give bit-identical messages.
    """

    def __init__(self, world: str | World = "empty", profile: str = "seed", seed: int = 0, physics: str = "default",
                 spawn: Spawn | None = None, odometry: str = "original", xacro: str | Path = DEFAULT_XACRO,
                 xacro_args: Mapping[str, str] | None = None, controllers: str | Path | None = None,
                 model_path: list[str | Path] | None = None, wall_height: float = DEFAULT_WALL_HEIGHT,
                 lidar: bool = True, camera: bool = True, sensor_noise: bool = True) -> None:
        self.seed = check_seed(seed)
        self.controllers_file = Path(controllers or package_path("racecar_control") / "config" / "racecar_control.yaml")
        self.sensor_noise = sensor_noise
        self.profile = load_profile(profile)
        self.robot = load_robot(xacro, {**self.profile.xacro_args, **(xacro_args or {})})
        if isinstance(world, World):
            self.world = world
        else:
            self.world = load_world(world, spawn, [Path(p) for p in model_path or []], wall_height)
        if spawn is not None:
            self.world.spawn = spawn
        self.preset = load_preset(physics)
        route_mujoco_warnings()
        self.controllers = load_controller_config(self.controllers_file, self.robot)
        spec = build_spec(self.robot, self.world, self.preset)
        add_actuators(spec, self.controllers, self.robot)
        self._lidar_on = lidar and self.robot.sensor("ray") is not None
        self._camera_on = camera and self.robot.sensor("camera") is not None
        if self._camera_on:
            from racecar_sim.sensors.camera import add_camera  # GL bindings load only when a camera is wanted

            add_camera(spec, self.robot)
        try:
            self.model = spec.compile()
        except ValueError as exc:
            raise ConfigError(f"MuJoCo rejected the model built from {xacro}: {exc}") from None
        self.data = mujoco.MjData(self.model)
        self.step_ns = to_ns(self.model.opt.timestep)
        if abs(self.step_ns / NS_PER_S - self.model.opt.timestep) > 1e-15:
            raise ConfigError(f"physics step {self.model.opt.timestep} s is not a whole number of nanoseconds")
        mujoco.mj_forward(self.model, self.data)
        check_spawn(self.model, self.data, self.world, self.robot)  # WorldError: inside an obstacle, no ground
        self._qpos0 = self.data.qpos.copy()
        self._odometry_mode = odometry
        self._user_subscriptions: list[tuple[str, Callable[[Any], None]]] = []
        self._recorders: list[McapRecorder] = []
        self.lidar: LidarPublisher | None = None
        self.camera: CameraPublisher | None = None
        self._setup()

    def _setup(self) -> None:
        """(Re)create the clock, bus, scheduler and every node of the original stack."""
        self.time_ns = 0
        self.bus = Bus()
        self.scheduler = Scheduler(self.step_ns)
        self.state = CarState(self.model, self.data, self.robot.root)
        self._divergence: str | None = None
        now = lambda: self.time_ns  # noqa: E731
        for recorder in self._recorders:
            self._attach_recorder(recorder)
        self.scheduler.every(CLOCK_RATE, lambda t: self.bus.publish("/clock", Clock(Time.from_ns(t))), "clock")
        self.commands = ControllerCommands(self.bus, self.state, self.controllers, self.robot, now)
        self.chain = CommandChain(self.bus, self.scheduler, now)
        self.servo = ServoCommands(self.bus, self.robot, self.controllers, self.profile.servo, self.chain.output_topic,
                                   self.profile.wheel_rate_per_speed, now)
        joints = [c.joint for c in self.controllers.controllers]
        self.joint_states = JointStatePublisher(self.bus, self.scheduler, self.state, joints,
                                                self.controllers.joint_state_rate)
        self.robot_state = RobotStatePublisher(self.bus, self.robot)
        self.odometry = OdometryPublisher(self.bus, self.scheduler, self.state, self._odometry_mode)
        self._setup_sensors()
        for topic, callback in self._user_subscriptions:
            self.bus.subscribe(topic, callback)

    def _setup_sensors(self) -> None:
        """The Hokuyo and the ZED, as racecar.gazebo declares them (and unless switched off)."""
        if self._lidar_on:
            from racecar_sim.sensors.lidar import LidarPublisher

            self.lidar = LidarPublisher(self.bus, self.scheduler, self.model, self.data, self.robot, self.seed,
                                        noise=self.sensor_noise)
        if self._camera_on:
            from racecar_sim.sensors.camera import CameraPublisher, RenderingError

            if self.camera is not None:
                self.camera.close()  # reset(): one GL context at a time
            try:
                self.camera = CameraPublisher(self.bus, self.scheduler, self.model, self.data, self.robot, self.seed,
                                              noise=self.sensor_noise)
            except RenderingError as exc:
                log.error("%s; continuing without the camera", exc)
                self._camera_on, self.camera = False, None

    # --- the public API -------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Sim time in seconds."""
        return self.time_ns / NS_PER_S

    def publish(self, topic: str, msg: Any) -> None:
        """Publish on the bus now (at the current sim time)."""
        self.bus.publish(topic, msg)

    def subscribe(self, topic: str, callback: Callable[[Any], None]) -> Subscription:
        """Call `callback(msg)` for every message on `topic`; kept across reset()."""
        self._user_subscriptions.append((topic, callback))
        return self.bus.subscribe(topic, callback)

    def run_until(self, t: float) -> None:
        """Advance sim time to `t` seconds (rounded up to a physics step), firing every event on the way."""
        end = ceil_to_step(to_ns(t), self.step_ns)
        if self._divergence is not None:
            raise PhysicsError(self._divergence)
        while self.time_ns < end:
            due = self.scheduler.next_time()
            target = end if due is None else max(min(due, end), self.time_ns)
            if target > self.time_ns:
                mujoco.mj_step(self.model, self.data, nstep=(target - self.time_ns) // self.step_ns)
                self.time_ns = target
                self._check_physics()
            self.scheduler.run_due(self.time_ns)

    def run_for(self, duration: float) -> None:
        """Advance sim time by `duration` seconds."""
        self.run_until(self.time + duration)

    def reset(self) -> None:
        """Back to t = 0 with the car at its spawn pose; user subscriptions and recorders stay attached."""
        self.state.reset(self._qpos0)
        self._setup()

    def record(self, path: str | Path) -> McapRecorder:
        """Record every bus topic to an MCAP file (ROS 2 CDR, log time = sim time) until close()."""
        from racecar_sim.recording import McapRecorder  # mcap is imported only when a run records

        recorder = McapRecorder(path)
        self._recorders.append(recorder)
        self._attach_recorder(recorder)
        for topic, msg in self.bus.latched_messages().items():
            recorder.write(topic, msg, self.time_ns)
        return recorder

    def close(self) -> None:
        """Finish every recording (writes the MCAP footers) and free the camera's GL context."""
        for recorder in self._recorders:
            recorder.close()
        self._recorders.clear()
        if self.camera is not None:
            self.camera.close()
            self.camera = None

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- internals --------------------------------------------------------------------------------
    def _attach_recorder(self, recorder: McapRecorder) -> None:
        self.bus.tap(lambda topic, msg: recorder.write(topic, msg, self.time_ns))

    def _check_physics(self) -> None:
        """Stop at the first sign of divergence, before any node publishes the broken state.

        MuJoCo flags NaN or huge positions, velocities and accelerations in its warning counters; with its
        auto-reset off (physics.builder) the state stays as it diverged instead of silently jumping back.
        """
        fired = [(kind, self.data.warning[kind].lastinfo) for kind in _DIVERGENCE_WARNINGS
                 if self.data.warning[kind].number]
        if not fired:
            return
        kind, index = fired[0]
        if kind == mujoco.mjtWarning.mjWARN_BADQPOS:  # a qpos index: the joint whose coordinates start at or before it
            jid = int((self.model.jnt_qposadr <= index).nonzero()[0][-1])
        else:  # a dof index
            jid = int(self.model.dof_jntid[min(index, self.model.nv - 1)])
        joint = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_JOINT, jid) or "root"
        self._divergence = (f"the physics diverged before t = {self.time:.3f} s (NaN or huge value at joint "
                            f"'{joint}'); the run stops. Check the controller gains in {self.controllers_file}, the "
                            f"physics step ({self.model.opt.timestep:g} s) and the world's <physics> block")
        raise PhysicsError(self._divergence)
