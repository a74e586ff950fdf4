"""A car's JointControllerState messages made from MuJoCo's state arrays, where they are packed.

One piece of arithmetic (state_numbers), used where the simulation makes the messages (controller_state.py, on the
live MjData) and where a writer process packs them from the same arrays' bytes, handed over as they are: the numbers
are the same bits either way, and a recorded tick does no per-controller work in the simulation. Light to import: a
writer process unpickles ControllerRows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from racecar_sim.msgs.cdr_layout import CdrLayout

Spec = tuple[int, int, int, int, bool, float, float, float, float]
"""A controller as state_numbers() reads it: qpos, dof, ctrl and integral-state (act, -1: none) addresses, whether it
is a velocity controller, and its gains p, i, d and i_clamp."""


def state_numbers(
    spec: Spec, qpos: Any, qvel: Any, ctrl: Any, act: Any, time_step: float
) -> tuple[float, float, float, float, float, float, float, float, float, float, bool]:
    """A JointControllerState's fields after its header: set point, process value and its rate, error, time step,
    command, the gains p, i, d, the integral clamp, antiwindup; `qpos`, `qvel`, `ctrl`, `act`: MjData's arrays (or
    views of their bytes), read at the spec's addresses as Python floats."""
    q_at, dof, ctrl_at, act_at, velocity, p, i, d, i_clamp = spec
    q, w, set_point = float(qpos[q_at]), float(qvel[dof]), float(ctrl[ctrl_at])
    i_term = 0.0
    if i:
        integral = float(act[act_at])
        i_term = i * (integral - q) if velocity else i * integral
        if velocity and i_clamp:
            i_term = min(max(i_term, -i_clamp), i_clamp)
    if velocity:
        value, value_dot, error = w, 0.0, set_point - w  # ros_control leaves process_value_dot at 0 here
        command = p * error + i_term
    else:
        value, value_dot, error = q, w, set_point - q
        command = p * error - d * w + i_term
    return set_point, value, value_dot, error, time_step, command, p, i, d, i_clamp, False


class ControllerRows:
    """Packs a car's controller states (`layout`: their CdrLayout, stamp first) from rows of ``(controller index,
    tick)``, a tick being ``(sec, nanosec, time step, qpos, qvel, ctrl, act)``, the arrays as their float64 bytes: the
    k-th controller of `specs` (Spec) read from them with state_numbers(). The rows of one tick share its tuple (one
    object to build and to pickle, and its arrays viewed once). Pickles as its layout and specs."""

    def __init__(self, layout: CdrLayout, specs: Sequence[Spec]) -> None:
        self.layout, self.specs = layout, tuple(specs)
        self._last: tuple[Any, tuple[Any, ...]] | None = None  # the last tick, and its stamp, step and array views

    def pack_many(self, rows: Sequence[Sequence[Any]]) -> list[bytes]:
        """The CDR bytes of each row's message."""
        pack, specs, packed = self.layout.pack, self.specs, []
        for index, tick in rows:
            last = self._last
            if last is None or last[0] is not tick:
                sec, nanosec, time_step, *arrays = tick
                views = tuple(memoryview(data).cast("d") for data in arrays)
                last = self._last = (tick, (sec, nanosec, time_step, *views))  # a tick's: once
            sec, nanosec, time_step, qpos, qvel, ctrl, act = last[1]
            packed.append(pack((sec, nanosec, *state_numbers(specs[index], qpos, qvel, ctrl, act, time_step))))
        return packed

    def __reduce__(self) -> tuple[type[ControllerRows], tuple[CdrLayout, tuple[Spec, ...]]]:
        return ControllerRows, (self.layout, self.specs)
