"""`/racecar/<controller>/state` (control_msgs/JointControllerState) of the running joint controllers.

ros_controllers' effort controllers publish their state from the 1 kHz update loop on every 10th update, i.e. at
100 Hz. Here the loop runs inside MuJoCo, so a 100 Hz task reads what the loop works with from MjData - the held
command (ctrl), the joint's position and velocity, the integral states (act) - and computes what the controller
outputs for the next step, exactly as the actuator will (control/controllers.py):

  JointVelocityController   command = p (w_cmd - w) + I,   I = clamp(i (act - q), +-i_clamp) (the I-term actuator)
  JointPositionController   command = p (q_cmd - q) - d w + i act   (act: MuJoCo's PID integral, clamped by imax)

Like ros_control, `command` is the PID output before the joint's effort limit (+-10 N m), which the hardware layer
(DefaultRobotHWSim, here the actuator's forcerange) applies; /racecar/joint_states carries the applied effort.
A stopped controller is not updated, so it publishes nothing; nothing is computed for a topic nobody listens to.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np

from racecar_sim.bus import BusPort, ListenerAnswer
from racecar_sim.control.controller_rows import ControllerRows, Spec, state_numbers
from racecar_sim.control.controllers import VELOCITY, ControllerConfig, JointController
from racecar_sim.control.fleet_ticks import FleetTick, FleetTicks
from racecar_sim.core.names import CarNames
from racecar_sim.core.time import NS_PER_S
from racecar_sim.msgs import Header, JointControllerState
from racecar_sim.msgs.cdr_layout import CdrLayout
from racecar_sim.nodes import Timers
from racecar_sim.physics.state import CarState

STATE_RATE = 100.0  # Hz: every 10th update of ros_control's 1 kHz loop

_FLEETS = FleetTicks()  # the controller-state publishers of each live MjData (a fleet's: see _tick_together)


class _Listening(NamedTuple):
    """Who listens to the state topics: per controller (anyone, only a recorder: its bytes), whether only a recorder
    takes every one, and whether anyone takes any."""

    heard: list[tuple[bool, bool]]
    all_direct: bool
    any_heard: bool


@dataclass
class _Controller:
    """One controller's state topic and its joint's addresses (kept up to date by CarState)."""

    config: JointController
    topic: str
    qpos: np.ndarray
    dof: np.ndarray
    # the addresses message() reads, as plain ints, and the model they were looked up in (None: not yet)
    model: object = None
    addresses: tuple[int, int, int, int] = (0, 0, 0, -1)  # qpos, dof, ctrl, act (-1: no integral state read)


class ControllerStatePublisher:
    """Publishes each running joint controller's JointControllerState at 100 Hz of sim time, while someone listens."""

    def __init__(
        self,
        bus: BusPort,
        scheduler: Timers,
        state: CarState,
        config: ControllerConfig,
        running: Callable[[str], bool],
        names: CarNames = CarNames(),
        running_names: AbstractSet[str] | None = None,
    ) -> None:
        self.bus, self.state, self.running = bus, state, running
        self._running_names = running_names  # the running controllers' names, kept up to date by their manager
        self.controllers = [
            _Controller(c, names.topic(f"{c.namespace}/{c.name}/state"), *state.joint_indices([c.joint]))
            for c in config.controllers
        ]
        # the MjData whose arrays these views are, and the views (MjData makes a new view object at every access)
        self._views: tuple[object, np.ndarray, np.ndarray, np.ndarray, np.ndarray] = (None, *(np.zeros(0),) * 4)
        self._layout: CdrLayout | None | Literal[False] = False  # read off the first message (None: none holds it)
        # kept while the bus's listeners stay the same: twelve questions fewer per tick
        self._listening = ListenerAnswer(self._ask_listening)
        # the model and the data it was made for, what packs the rows, views of the spans of MjData's arrays they
        # carry (_rows_packer) and the controllers' indices
        self._rows: tuple[object, object, ControllerRows, tuple[np.ndarray, ...], range] | None = None
        # the same for the cars whose states it hands over with its own (_publish_rows), their topics in order
        self._fleet_rows: (
            tuple[
                object,
                object,
                list[ControllerStatePublisher],
                ControllerRows,
                tuple[np.ndarray, ...],
                tuple[str, ...],
                range,
            ]
            | None
        ) = None
        self._topics = tuple(c.topic for c in self.controllers)
        self._names = tuple(c.config.name for c in self.controllers)
        self._name_set = frozenset(self._names)
        self._ticks = FleetTick(_FLEETS, self, STATE_RATE, scheduler.step_ns)
        scheduler.every(STATE_RATE, self.publish, "controller_state", unheard=self._unheard)

    def reset(self) -> None:
        """Sim time went back to 0: the ticks it was published at are forgotten (the fleet's too: it ticks afresh)."""
        self._ticks.reset()

    def _ask_listening(self) -> _Listening:
        """Who listens to the state topics, asked of the bus."""
        bus = self.bus
        heard = []
        for c in self.controllers:
            listened = bus.has_listeners(c.topic)  # asked first: the cheaper question, and mostly no
            heard.append((listened, listened and bus.cdr_only(c.topic)))
        return _Listening(
            heard, bool(heard) and all(alone for _, alone in heard), any(listened for listened, _ in heard)
        )

    def _unheard(self, _now_ns: int) -> bool:
        """Nobody listens to any state topic: then there is nothing to do."""
        return not self._listening(self.bus).any_heard

    def publish(self, now_ns: int) -> None:
        """The task at each tick: the states, published now, with the fleet's or on its own."""
        if self._ticks.published(now_ns):
            return  # published at this tick with the fleet's first car
        if not self._tick_together(now_ns):
            self._publish_own(now_ns)

    def _tick_together(self, now_ns: int) -> bool:
        """Where other cars of this MjData tick now as it does (control/fleet_ticks.py), publish all their states now,
        in the cars' order, and return True; their own tasks at this time then do nothing. Where only a recorder takes
        every one of their states, they go in one hand-over: MuJoCo's arrays once and a row per controller, not one
        hand-over per car (_publish_rows); otherwise each car publishes its own in turn, as on its own."""
        ticking: list[ControllerStatePublisher] = self._ticks.ticking(now_ns)
        if not ticking:
            return False
        rows: list[ControllerStatePublisher] = []
        for car in ticking:
            listening = car._listening(car.bus)
            if not listening.any_heard:
                continue
            if not (listening.all_direct and car._layout and car._all_running()):
                for each in ticking:  # someone takes messages: each car publishes its own, in turn
                    each._publish_own(now_ns)
                return True
            rows.append(car)
        if len(rows) == 1:
            rows[0]._publish_own(now_ns)
        elif rows:
            self._publish_rows(rows, now_ns)
        return True

    def _publish_rows(self, cars: list[ControllerStatePublisher], now_ns: int) -> None:
        """_publish_arrays() of several cars of one MjData in one hand-over: a row per controller, every row sharing
        the tick (the span of qpos, qvel, ctrl and act that all their controllers read)."""
        state = self.state
        model, data = state.model, state.data
        made = self._fleet_rows
        if made is None or made[0] is not model or made[1] is not data or made[2] != cars:
            layout = cars[0]._layout
            assert layout and all(car._layout and car._layout.packs_as(layout) for car in cars)
            packer, spans = _rows_packer(layout, [car._spec(c) for car in cars for c in car.controllers])
            views = tuple(array[a:b] for array, (a, b) in zip((data.qpos, data.qvel, data.ctrl, data.act), spans))
            topics = tuple(topic for car in cars for topic in car._topics)
            made = self._fleet_rows = (model, data, list(cars), packer, views, topics, range(len(topics)))
        _, _, _, packer, (qpos, qvel, ctrl, act), topics, indices = made
        sec, nanosec = divmod(now_ns, NS_PER_S)
        tick = (sec, nanosec, float(model.opt.timestep), qpos.tobytes(), qvel.tobytes(), ctrl.tobytes(), act.tobytes())
        self.bus.publish_cdr_rows(JointControllerState, packer, topics, [(index, tick) for index in indices])

    def _publish_own(self, now_ns: int) -> None:
        """Its own states, now, as a car on its own publishes them."""
        bus = self.bus
        listening = self._listening(bus)
        if not listening.any_heard:  # a tick the physics stopped at for another task: nothing to do
            return
        if listening.all_direct and self._layout and self._all_running():
            # the usual tick of a recorded run: every state, in one hand-over of MuJoCo's arrays (the writer reads the
            # numbers off them)
            self._publish_arrays(self._layout, now_ns)
            return
        time_step = None
        direct: list[_Controller] = []  # those only a recorder takes (bytes), in a row: read and handed over together
        heard = listening.heard
        for index, c in enumerate(self.controllers):
            listened, bytes_alone = heard[index]
            if listened and self.running(c.config.name):
                if time_step is None:
                    time_step = float(self.state.model.opt.timestep)
                if self._layout and bytes_alone:
                    direct.append(c)
                    continue
                if direct:  # those before it first: the messages keep their order
                    self._publish_bytes(direct, now_ns, time_step)
                    direct = []
                msg = self._message(c, now_ns, time_step)
                if self._layout is False:  # the first message: its shape is every message's (frame id "")
                    self._layout = CdrLayout.read(msg)
                bus.publish(c.topic, msg)
                heard = self._listening(bus).heard  # its subscribers may have changed who listens
        if direct:
            self._publish_bytes(direct, now_ns, time_step)  # type: ignore[arg-type]  # set with the first one

    def _all_running(self) -> bool:
        """Whether every controller is running: one set look-up where the manager keeps their names."""
        if self._running_names is not None:
            return self._running_names >= self._name_set
        return all(map(self.running, self._names))

    def _publish_bytes(
        self,
        controllers: Sequence[_Controller],
        now_ns: int,
        time_step: float,
        topics: tuple[str, ...] | None = None,
    ) -> None:
        """The states of `controllers` (on `topics`, their topics), which only a recorder takes, in one hand-over of
        their numbers and their layout (the recorder packs them into their CDR bytes)."""
        assert self._layout, "bytes only once the first message gave the layout"
        rows = self._numbers_of(controllers, time_step, divmod(now_ns, NS_PER_S))
        if topics is None:
            topics = tuple(c.topic for c in controllers)
        self.bus.publish_cdr_rows(JointControllerState, self._layout, topics, rows)

    def _publish_arrays(self, layout: CdrLayout, now_ns: int) -> None:
        """Every controller's state, which only a recorder takes, as one row each sharing the tick: the car's part of
        MjData's qpos, qvel, ctrl and act (their bytes, read through views kept with the MjData) for a ControllerRows
        to pack (made again when the model or the data is)."""
        state = self.state
        model, data = state.model, state.data
        made = self._rows
        if made is None or made[0] is not model or made[1] is not data:
            packer, spans = _rows_packer(layout, [self._spec(c) for c in self.controllers])
            views = tuple(array[a:b] for array, (a, b) in zip((data.qpos, data.qvel, data.ctrl, data.act), spans))
            made = self._rows = (model, data, packer, views, range(len(self.controllers)))
        _, _, packer, (qpos, qvel, ctrl, act), indices = made
        sec, nanosec = divmod(now_ns, NS_PER_S)
        tick = (sec, nanosec, float(model.opt.timestep), qpos.tobytes(), qvel.tobytes(), ctrl.tobytes(), act.tobytes())
        self.bus.publish_cdr_rows(JointControllerState, packer, self._topics, [(index, tick) for index in indices])

    def _spec(self, c: _Controller) -> Spec:
        """What state_numbers() reads of a controller in the current model."""
        g = c.config.gains
        qpos, dof, ctrl, act = self._addresses(c) if c.model is not self.state.model else c.addresses
        if g.i and act < 0:  # the gain was 0 when the addresses were looked up
            c.model = None
            qpos, dof, ctrl, act = self._addresses(c)
        return (qpos, dof, ctrl, act, c.config.type == VELOCITY, g.p, g.i, g.d, g.i_clamp)

    def message(self, c: _Controller, now_ns: int) -> JointControllerState:
        """The state message of one controller now."""
        return self._message(c, now_ns, float(self.state.model.opt.timestep))

    def _addresses(self, c: _Controller) -> tuple[int, int, int, int]:
        """qpos, dof, ctrl and integral-state (act, -1 for none) addresses of a controller in the current model."""
        state, name = self.state, c.config.name
        model = state.model
        if c.model is not model:
            act = -1
            if c.config.gains.i:  # the integral state: of the velocity I-term actuator (the last id), else of the PID
                integral = state.actuator_ids(name)[-1]
                act = int(model.actuator_actadr[integral] + model.actuator_actnum[integral] - 1)
            c.addresses = (int(c.qpos[0]), int(c.dof[0]), state.actuator_ctrl(name)[0], act)
            c.model = model
        return c.addresses

    def _message(self, c: _Controller, now_ns: int, time_step: float) -> JointControllerState:
        return JointControllerState(Header.at(now_ns), *self._numbers(c, time_step))

    def _numbers(
        self, c: _Controller, time_step: float
    ) -> tuple[float, float, float, float, float, float, float, float, float, float, bool]:
        """The message's fields after its header: set point, process value and its rate, error, time step, command,
        the gains p, i, d, the integral clamp, antiwindup."""
        return self._numbers_of((c,), time_step)[0]  # type: ignore[return-value]  # an empty head: the fields alone

    def _numbers_of(
        self, controllers: Sequence[_Controller], time_step: float, head: tuple[int, ...] = ()
    ) -> list[tuple[int | float | bool, ...]]:
        """_numbers() of each controller, in order, each after `head` (a stamp's sec and nanosec): one call for a
        car's controllers."""
        state = self.state
        data, qpos_, qvel, ctrl_, act_ = self._views
        if data is not state.data:
            data = state.data
            self._views = data, qpos_, qvel, ctrl_, act_ = data, data.qpos, data.qvel, data.ctrl, data.act
        return [(*head, *state_numbers(self._spec(c), qpos_, qvel, ctrl_, act_, time_step)) for c in controllers]


def _rows_packer(layout: CdrLayout, specs: Sequence[Spec]) -> tuple[ControllerRows, tuple[tuple[int, int], ...]]:
    """What packs the controllers' rows (`specs`: theirs, in order), and the spans of qpos, qvel, ctrl and act their
    addresses lie in (a row carries only those: a fleet's car hands over its own part); the packer's addresses count
    from each span's start."""
    spans: list[tuple[int, int]] = []
    for column in range(4):
        used = [int(spec[column]) for spec in specs if spec[column] >= 0]  # act: -1 where no integral is read
        spans.append((min(used), max(used) + 1) if used else (0, 0))
    (q0, _), (v0, _), (c0, _), (a0, _) = spans
    relative: list[Spec] = [
        (q - q0, v - v0, c - c0, a - a0 if a >= 0 else -1, velocity, p, i, d, clamp)
        for q, v, c, a, velocity, p, i, d, clamp in specs
    ]
    return ControllerRows(layout, relative), tuple(spans)
