"""ros_control's controller_manager for one car: list, load, unload, start, stop and switch its controllers.

The controllers are the entries of the car's controller YAML (racecar_control.yaml: the "parameter server"): the
joint controllers, realised as MuJoCo actuators (control/controllers.py), and joint_state_controller, the
/racecar/joint_states publisher. At start-up they are loaded and started as racecar_control.launch's spawner does
(the joint controllers in the YAML's order, then joint_state_controller), and reset() goes back to that.

Semantics follow ros_control (noetic controller_manager.cpp, ros_controllers' effort_controllers):
  * load_controller: only a name the YAML defines, not already loaded; it comes up "initialized" (loaded, not running).
  * unload_controller: only a loaded controller that is not running.
  * switch_controller: stops, then starts, at once (the simulated hardware switches interfaces immediately, so
    start_asap and timeout change nothing). STRICT fails the whole switch - and changes nothing - on an unknown
    name, on stopping a controller that is not running or on starting one that is; BEST_EFFORT (and 0, with a
    warning) skips those. Like ros_control, BEST_EFFORT still calls starting() on a listed controller that already
    runs (a velocity controller's command goes back to 0). Two running controllers may not claim the same joint.
  * starting(): a JointVelocityController's command goes to 0, a JointPositionController's to the joint's current
    position (within the joint's limits), and the PID integral to 0.
  * A controller that is not running applies zero effort: its actuators' gains are zeroed in the MjModel
    (CarState.enable_actuator) and put back when it starts; commands sent meanwhile are dropped at starting().
    (gazebo_ros_control's DefaultRobotHWSim would keep applying the last effort command of a stopped controller.)
  * A stopped joint_state_controller publishes no /racecar/joint_states.

The services are on the bus under the original names, `/racecar/controller_manager/<service>` (under the car's
namespace in a fleet), with controller_manager_msgs-shaped requests and responses.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from racecar_sim.bus import BusPort
from racecar_sim.control.controller_state import ControllerStatePublisher
from racecar_sim.control.controllers import JOINT_STATE, POSITION, VELOCITY, ControllerConfig, JointController
from racecar_sim.core.names import CarNames
from racecar_sim.description.urdf import Robot
from racecar_sim.msgs import ControllerState, HardwareInterfaceResources
from racecar_sim.msgs.controller_manager_msgs import (
    ListControllersRequest,
    ListControllersResponse,
    ListControllerTypesRequest,
    ListControllerTypesResponse,
    LoadControllerRequest,
    LoadControllerResponse,
    SwitchControllerRequest,
    SwitchControllerResponse,
    UnloadControllerRequest,
    UnloadControllerResponse,
)
from racecar_sim.nodes import Timers
from racecar_sim.physics.state import CarState

if TYPE_CHECKING:
    from racecar_sim.control.joint_state_controller import JointStatePublisher

log = logging.getLogger("racecar_sim.controller_manager")

BEST_EFFORT = SwitchControllerRequest.BEST_EFFORT
STRICT = SwitchControllerRequest.STRICT
JOINT_STATE_CONTROLLER = "joint_state_controller"
INITIALIZED, RUNNING, STOPPED = "initialized", "running", "stopped"
EFFORT_INTERFACE = "hardware_interface::EffortJointInterface"
JOINT_STATE_INTERFACE = "hardware_interface::JointStateInterface"
BASE_CLASS = "controller_interface::ControllerBase"


@dataclass
class _Loaded:
    name: str
    type: str
    joint: str | None  # None: joint_state_controller, which claims nothing
    state: str = INITIALIZED


class _Muted:
    """What a stopped joint_state_controller's publisher publishes to: nothing goes out (its timer keeps ticking)."""

    def publish(self, topic: str, msg: Any) -> None:
        pass

    def has_listeners(self, topic: str) -> bool:
        return False

    def tally(self, topic: str, msgtype: type) -> None:
        pass

    def listeners_epoch(self) -> int | None:
        return None  # has_listeners() is asked every time


class ControllerManager:
    """The controller_manager of one car (ros_control's, under `<namespace>/controller_manager`)."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        state: CarState,
        config: ControllerConfig,
        robot: Robot,
        joint_states: JointStatePublisher,
        names: CarNames = CarNames(),
    ) -> None:
        self.bus, self.state, self.config, self.joint_states = bus, state, config, joint_states
        self.namespace = names.topic(f"{config.namespace}/controller_manager")
        self._params: dict[str, JointController | None] = {c.name: c for c in config.controllers}
        self._params[JOINT_STATE_CONTROLLER] = None
        self._limits: dict[str, tuple[float, float]] = {}
        self._qpos: dict[str, np.ndarray] = {}  # CarState keeps these up to date if the model is recompiled
        for c in config.controllers:
            joint = robot.joints[c.joint]
            if c.type == POSITION and joint.type in ("revolute", "prismatic") and joint.limit is not None:
                self._limits[c.name] = (joint.limit.lower, joint.limit.upper)  # enforceJointLimits() at starting()
            self._qpos[c.name] = state.joint_indices([c.joint])[0]
        self._loaded: dict[str, _Loaded] = {}
        self._running: set[str] = set()  # the running controllers' names, kept by _apply (is_running of each, at once)
        self.reset()
        self.state_publisher = ControllerStatePublisher(
            bus, scheduler, state, config, self.is_running, names, running_names=self._running
        )
        for service, handler in (
            ("list_controllers", self._list_srv),
            ("list_controller_types", self._types_srv),
            ("load_controller", self._load_srv),
            ("unload_controller", self._unload_srv),
            ("switch_controller", self._switch_srv),
        ):
            bus.advertise_service(f"{self.namespace}/{service}", handler)

    # --- the Python API -----------------------------------------------------------------------------
    def list_controllers(self) -> list[ControllerState]:
        """The loaded controllers in the order they were loaded: name, state, type and claimed joints."""
        return [ControllerState(c.name, c.state, c.type, [self._resources(c)]) for c in self._loaded.values()]

    def list_controller_types(self) -> list[str]:
        """The controller types this manager can load."""
        return sorted({VELOCITY, POSITION, JOINT_STATE})

    def controller_state(self, name: str) -> str | None:
        """The state list_controllers reports (initialized, running or stopped); None if `name` is not loaded."""
        c = self._loaded.get(name)
        return c.state if c else None

    def is_running(self, name: str) -> bool:
        """Whether `name` is loaded and running (applies effort, publishes its state)."""
        c = self._loaded.get(name)
        return c is not None and c.state == RUNNING

    def load_controller(self, name: str) -> bool:
        """Load a controller the car's controller YAML defines; it is not started."""
        if name in self._loaded:
            log.error("A controller named '%s' was already loaded inside the controller manager", name)
            return False
        if name not in self._params:
            log.error(
                "Could not load controller '%s' because the type was not specified. Is it in the controller "
                "configuration (namespace: '%s')?",
                name,
                self.config.namespace,
            )
            return False
        c = self._params[name]
        self._loaded[name] = _Loaded(name, JOINT_STATE if c is None else c.type, None if c is None else c.joint)
        self._apply(self._loaded[name])
        return True

    def unload_controller(self, name: str) -> bool:
        """Unload a controller that is loaded and not running."""
        c = self._loaded.get(name)
        if c is None:
            log.error("Could not unload controller with name '%s' because no controller with this name exists", name)
            return False
        if c.state == RUNNING:
            log.error("Could not unload controller with name '%s' because it is still running", name)
            return False
        del self._loaded[name]
        self._running.discard(name)
        return True

    def switch_controller(
        self,
        start_controllers: list[str] | tuple[str, ...] = (),
        stop_controllers: list[str] | tuple[str, ...] = (),
        strictness: int = BEST_EFFORT,
        start_asap: bool = False,
        timeout: float = 0.0,
    ) -> bool:
        """Stop `stop_controllers`, then start `start_controllers`, now (before the next physics step)."""
        del start_asap, timeout  # the simulated hardware switches at once
        if strictness == 0:
            log.warning(
                "To switch controllers you need to specify a strictness level of STRICT (%d) or BEST_EFFORT "
                "(%d). Defaulting to BEST_EFFORT.",
                STRICT,
                BEST_EFFORT,
            )
            strictness = BEST_EFFORT
        strict = strictness == STRICT
        requests: dict[str, list[_Loaded]] = {"stop": [], "start": []}
        for verb, wanted in (("stop", stop_controllers), ("start", start_controllers)):
            for name in wanted:
                if name in self._loaded:
                    requests[verb].append(self._loaded[name])
                elif strict:
                    log.error(
                        "Could not %s controller with name '%s' because no controller with this name exists", verb, name
                    )
                    return False
        stopping, starting = {c.name for c in requests["stop"]}, {c.name for c in requests["start"]}
        after: list[_Loaded] = []
        for c in self._loaded.values():
            running, in_stop, in_start = c.state == RUNNING, c.name in stopping, c.name in starting
            if not running and in_stop:
                if strict:
                    log.error("Could not stop controller '%s' since it is not running", c.name)
                    return False
                in_stop = False
            if running and not in_stop and in_start:
                if strict:
                    log.error("Controller '%s' is already running", c.name)
                    return False
                in_start = False
            if in_start or (running and not in_stop):
                after.append(c)
        claimed: dict[str, str] = {}
        for c in after:
            if c.joint is not None and claimed.setdefault(c.joint, c.name) != c.name:
                log.error(
                    "Could not switch controllers, due to resource conflict: %s and %s both claim %s",
                    claimed[c.joint],
                    c.name,
                    c.joint,
                )
                return False
        for c in requests["stop"]:
            if c.state == RUNNING:
                self._set_state(c, STOPPED)
        for c in requests["start"]:
            self._set_state(c, RUNNING)
        return True

    def start(self, *names: str) -> bool:
        """Start controllers (STRICT switch)."""
        return self.switch_controller(start_controllers=list(names), strictness=STRICT)

    def stop(self, *names: str) -> bool:
        """Stop controllers (STRICT switch): an effort controller's joint gets no effort until it starts again."""
        return self.switch_controller(stop_controllers=list(names), strictness=STRICT)

    def reset(self) -> None:
        """Back to what the spawner leaves: every controller of the YAML loaded, in its order, then all started in
        one STRICT switch (which fails, leaving them all stopped, if two of them claim the same joint)."""
        self._loaded = {}
        self._running.clear()
        for name in self._params:
            self.load_controller(name)
        if not self.switch_controller(list(self._loaded), [], STRICT):
            log.error("Failed to start controllers: %s", ", ".join(self._loaded))

    # --- internals --------------------------------------------------------------------------------
    def _set_state(self, c: _Loaded, state: str) -> None:
        c.state = state
        if state == RUNNING:
            self._starting(c)
        self._apply(c)

    def _apply(self, c: _Loaded) -> None:
        """Make the hardware follow the controller's state: effort only from a running controller."""
        running = c.state == RUNNING
        if running:
            self._running.add(c.name)
        else:
            self._running.discard(c.name)
        if c.joint is None:
            self.joint_states.bus = self.bus if running else _Muted()
        else:
            self.state.enable_actuator(c.name, running)

    def _starting(self, c: _Loaded) -> None:
        """ros_controllers' starting(): reset the held command and the PID."""
        if c.joint is None:
            return
        data, model = self.state.data, self.state.model
        q = float(data.qpos[self._qpos[c.name][0]])
        if c.type == VELOCITY:
            command = 0.0
        else:
            lo, hi = self._limits.get(c.name, (-float("inf"), float("inf")))
            command = min(max(q, lo), hi)
        self.state.set_command(c.name, command)
        # PID reset, the I-term back to 0: the position PID integrates the error in its (last) activation -> 0; the
        # velocity I-term actuator integrates the command, force = i (act - q) -> act = q
        main, *i_term = self.state.actuator_ids(c.name)
        for i, value in [(main, 0.0)] + [(i, q) for i in i_term]:
            if model.actuator_actnum[i]:
                data.act[model.actuator_actadr[i] + model.actuator_actnum[i] - 1] = value

    def _resources(self, c: _Loaded) -> HardwareInterfaceResources:
        if c.joint is None:
            return HardwareInterfaceResources(JOINT_STATE_INTERFACE, [])
        return HardwareInterfaceResources(EFFORT_INTERFACE, [c.joint])

    # --- the services ----------------------------------------------------------------------------------
    def _list_srv(self, request: ListControllersRequest) -> ListControllersResponse:
        return ListControllersResponse(self.list_controllers())

    def _types_srv(self, request: ListControllerTypesRequest) -> ListControllerTypesResponse:
        types = self.list_controller_types()
        return ListControllerTypesResponse(types, [BASE_CLASS] * len(types))

    def _load_srv(self, request: LoadControllerRequest) -> LoadControllerResponse:
        return LoadControllerResponse(self.load_controller(request.name))

    def _unload_srv(self, request: UnloadControllerRequest) -> UnloadControllerResponse:
        return UnloadControllerResponse(self.unload_controller(request.name))

    def _switch_srv(self, request: SwitchControllerRequest) -> SwitchControllerResponse:
        return SwitchControllerResponse(
            self.switch_controller(
                request.start_controllers,
                request.stop_controllers,
                request.strictness,
                request.start_asap,
                request.timeout,
            )
        )
