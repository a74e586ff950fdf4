"""The event loop: sim time advanced by MuJoCo for as many steps as fit before the next event, Python only at events.

Between two events (a sensor sample, a node's timer, a mux timeout) the physics runs inside mj_step(nstep=N); at each
event the scheduler fires the tasks due. What the loop owns besides: pausing (/gazebo/pause_physics: sim time stands
still), deferring what must not happen while tasks fire (a reset asked for from a callback), and stopping at the first
sign of divergence, before any node publishes the broken state.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import mujoco

from racecar_sim.core.errors import PhysicsError
from racecar_sim.core.time import NS_PER_S, ceil_to_step, to_ns
from racecar_sim.physics.scene import Scene
from racecar_sim.runtime.scheduler import Scheduler

log = logging.getLogger("racecar_sim")
_DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)
_BADQPOS, _BADQVEL, _BADQACC = (int(kind) for kind in _DIVERGENCE_WARNINGS)  # plain ints index numpy fastest


class EventLoop:
    """Sim time, its scheduler, and the stepping between events.

    `after_physics()` (or None) runs after each stretch of physics, before the tasks due then (the crash check);
    `stop_at_every_task` makes every task a stop (a task nobody hears is otherwise done without one): a fleet's
    contacts are looked at as often as its nodes run.
    `advice`: what the divergence error tells the user to check (the controller file, the step, the world).
    """

    def __init__(self, scene: Scene, advice: Callable[[], str]) -> None:
        self.scene = scene
        self.scheduler = Scheduler(scene.step_ns)
        self.step_ns = scene.step_ns
        self.time_ns = 0
        self.after_physics: Callable[[], None] | None = None
        self.stop_at_every_task = False
        self._advice = advice
        self._divergence: str | None = None
        self._deferred: list[Callable[[], None]] = []
        self.in_event = False
        self.paused = False

    @property
    def time(self) -> float:
        """Sim time in seconds."""
        return self.time_ns / NS_PER_S

    @property
    def paused(self) -> bool:
        """Whether the physics is paused: sim time stands still until unpaused."""
        return self._paused

    @paused.setter
    def paused(self, value: bool) -> None:
        self._paused, self._pause_told = bool(value), False

    def defer(self, action: Callable[[], None]) -> None:
        """Run `action()` once the event being handled is over (at once outside of run_until)."""
        if self.in_event:
            self._deferred.append(action)
        else:
            action()

    def restart(self) -> None:
        """Sim time back to 0: every periodic task starts over, one-shots are dropped, a divergence is forgotten."""
        self.time_ns = 0
        self._divergence = None
        self.scheduler.reset()

    def run_until(self, t: float) -> None:
        """Advance sim time to `t` seconds (rounded up to a physics step), firing every event on the way; while paused,
        return at once (logging it once per pause). PhysicsError once the physics diverged."""
        end = ceil_to_step(to_ns(t), self.step_ns)
        if self._divergence is not None:
            raise PhysicsError(self._divergence)
        if self._paused:
            if not self._pause_told and self.time_ns < end:
                log.warning(
                    "the physics is paused (/gazebo/pause_physics): sim time stays at %.3f s until "
                    "/gazebo/unpause_physics",
                    self.time,
                )
                self._pause_told = True
            return
        scheduler, step, scene = self.scheduler, mujoco.mj_step, self.scene
        counted = scene.data
        warnings = counted.warning.number  # a live view of MuJoCo's warning counters (of `counted`)
        while self.time_ns < end and not self._paused:
            # tasks whose messages nobody would receive run without a stop, unless every task must be one
            due = scheduler.next_time(None if self.stop_at_every_task else end)
            target = end if due is None else max(min(due, end), self.time_ns)
            if target > self.time_ns:
                data = scene.data  # a model spawned or deleted in an event replaces it
                # nstep passed by position: a keyword costs the binding's parsing at every stop
                step(scene.model, data, (target - self.time_ns) // self.step_ns)
                self.time_ns = target
                if data is not counted:
                    counted, warnings = data, data.warning.number
                if warnings[_BADQPOS] or warnings[_BADQVEL] or warnings[_BADQACC]:
                    self._check_physics()
                if self.after_physics is not None:
                    self.after_physics()
            self.in_event = True
            try:
                scheduler.run_due(self.time_ns)
            finally:
                self.in_event = False
            while self._deferred:
                self._deferred.pop(0)()

    def _check_physics(self) -> None:
        """Stop at the first sign of divergence, naming the time and the joint. MuJoCo flags NaN or huge positions,
        velocities and accelerations in its warning counters; with its auto-reset off (physics.builder) the state
        stays as it diverged instead of silently jumping back."""
        model, data = self.scene.model, self.scene.data
        fired = [(kind, data.warning[kind].lastinfo) for kind in _DIVERGENCE_WARNINGS if data.warning[kind].number]
        if not fired:
            return
        kind, index = fired[0]
        if kind == mujoco.mjtWarning.mjWARN_BADQPOS:  # a qpos index: the joint whose coordinates start at or before it
            jid = int((model.jnt_qposadr <= index).nonzero()[0][-1])
        else:  # a dof index
            jid = int(model.dof_jntid[min(index, model.nv - 1)])
        joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, jid) or "root"
        self._divergence = (
            f"the physics diverged before t = {self.time:.3f} s (NaN or huge value at joint "
            f"'{joint}'); the run stops. {self._advice()}"
        )
        raise PhysicsError(self._divergence)
