"""A fleet's scans of one tick in one compiled call (laser_kernel.level_scans), each published at its own tick.

Every car's lidar ticks at the same sim times (40 Hz from the start), from the same state and in the same walls. The
first of them to tick at a time casts the scans of all the lidars that tick with it and are listened to, in one call:
the noise windows, the other cars' poses and the call itself once per tick, not once per car. Each lidar then takes
its own scan at its own tick, in the scheduler's order as before, when nothing the scan depends on has changed since
(the state: qpos and the mocap poses; its seed and noise switch); otherwise, or where the one-call path refuses a scan
(a tilted car, a floor in the band), it casts its own as before. The ranges are level_scan's, the same operations on
the same numbers: a batch changes no value.

Who is in a lidar's batch is worked out again only when the bus's listeners change (Bus.listeners_epoch), a lidar
comes, goes or is rebound (a recompiled model), or one's noise switch or mode changed; a bus whose listeners are
decided by a bridge at any time gets no batches. A batch holds a copy of its lidars' noise tables, stacked (0.5 MB a
Hokuyo), one batch per set of lidars.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from racecar_sim.sensors.shared_pose import SharedPose

if TYPE_CHECKING:
    from racecar_sim.sensors.lidar import LidarPublisher

_LEVEL_SCANS: Callable[..., None] | None = None  # laser_kernel.level_scans, imported at the first batch (numba)
# the arguments of level_scan (LidarPublisher.one_call_args) that level_scans takes as they are: the walls, the fan
_SHARED = range(4, 20)
_FIRSTS, _SECONDS, _OUT, _CAST = 21, 22, 27, 35  # level_scans' arguments set per tick, and its answers
Entry = tuple[int, int, bool, bytes, "np.ndarray | None"]  # stamp, seed, noise, the state, the scan (None: cast alone)


def _level_scans() -> Callable[..., None]:
    global _LEVEL_SCANS
    from racecar_sim.sensors.laser_kernel import level_scans

    _LEVEL_SCANS = level_scans
    return level_scans


class _Batch:
    """The lidars of one batch and level_scans' arguments for them, stacked (their calls' arguments, made once)."""

    def __init__(self, members: list[LidarPublisher], calls: list[list[Any]], epoch: int) -> None:
        self.members, self.epoch = members, epoch
        self.noise = tuple(lidar.noise for lidar in members)
        first = calls[0]
        solids = [call[30:34] for call in calls]
        self.count = first[15]
        self.args: list[Any] = [
            first[0],  # qpos: every lidar's is the same MjData's
            np.array([call[1] for call in calls], np.intp),
            np.array([call[2] for call in calls], np.float64),
            np.array([call[3] for call in calls], np.float64),
            *(first[k] for k in _SHARED),
            np.stack([call[20] for call in calls]),  # the noise tables (read-only once drawn)
            None,  # firsts
            None,  # seconds
            np.array([call[23] for call in calls], np.float64),
            np.array([call[24] for call in calls], np.float64),
            np.array([bool(call[25]) for call in calls], np.bool_),
            np.empty((len(calls), self.count)),  # the true ranges (scratch)
            None,  # out
            first[28],  # the shared pose's geom_xpos, geom_xmat
            first[29],
            np.cumsum([0] + [len(s[0]) for s in solids]).astype(np.intp),
            np.concatenate([s[0] for s in solids]).astype(np.intp),
            np.concatenate([s[1] for s in solids]).astype(np.intp),
            np.concatenate([s[2] for s in solids]).reshape(-1, 3).astype(np.float64),
            np.concatenate([s[3] for s in solids]).astype(np.float64),
            np.zeros(len(calls), np.bool_),  # cast
        ]
        self.any_solids = bool(len(self.args[31]))

    def holds(self, epoch: int | None) -> bool:
        """Whether the batch is still what the lidars ask for: the same listeners, noise switches and mode."""
        return (
            epoch == self.epoch
            and tuple(lidar.noise for lidar in self.members) == self.noise
            and all(lidar.mode == "auto" for lidar in self.members)
        )


class FleetScans:
    """The lidars of one simulation (one live MjData) and the scans cast for them at the present tick; its lidars hold
    it, and its SharedPose only weakly (found by of()), so a simulation dropped without close() is freed."""

    def __init__(self, shared: SharedPose, data: mujoco.MjData) -> None:
        self.shared, self.data = shared, data
        self._mocap = len(data.mocap_pos) > 0
        self.lidars: list[LidarPublisher] = []
        self._ready: dict[LidarPublisher, Entry] = {}  # scans cast for lidars that have not ticked yet
        # the batch each lidar casts when it ticks first (None: none), for the bus's listeners epoch it was made in
        self._batches: dict[LidarPublisher, tuple[int, _Batch | None]] = {}
        self._stacks: dict[tuple[int | bool, ...], _Batch] = {}  # the batches by their lidars (a noise table each)
        self._epoch: int | None = None  # the bus's listeners epoch the batches are for
        self.batches_cast = 0  # level_scans calls
        self.taken = 0  # scans taken from a batch (published without a call of their own)

    @classmethod
    def of(cls, shared: SharedPose, data: mujoco.MjData) -> FleetScans:
        """The scans of every lidar reading the live `data` (posed by `shared`: one per simulation and model)."""
        found = None if shared.fleet_scans is None else shared.fleet_scans()
        if found is None:
            found = cls(shared, data)
            shared.fleet_scans = weakref.ref(found)
        return found

    def join(self, lidar: LidarPublisher) -> None:
        """Cast `lidar`'s scans with the others' from now on."""
        if lidar not in self.lidars:
            self.lidars.append(lidar)
        self.forget()

    def leave(self, lidar: LidarPublisher) -> None:
        """No more scans for `lidar` (it was closed, or rebound to a recompiled model)."""
        if lidar in self.lidars:
            self.lidars.remove(lidar)
        self.forget()

    def forget(self) -> None:
        """Drop every scan cast and every batch (a lidar came or went)."""
        self._ready.clear()
        self._batches.clear()
        self._stacks.clear()

    def _state(self) -> bytes:
        data = self.data
        if not self._mocap:  # no mocap body: qpos is the whole state a scan reads
            return data.qpos.tobytes()
        return data.qpos.tobytes() + data.mocap_pos.tobytes() + data.mocap_quat.tobytes()

    def take(self, lidar: LidarPublisher, stamp_ns: int) -> np.ndarray | None:
        """`lidar`'s scan stamped `stamp_ns` (float32 ranges, noise and all, as lidar.scan gives it), cast in one call
        with the other lidars' of this tick; None where it must cast its own (see the module doc)."""
        if len(self.lidars) < 2:
            return None
        entry = self._ready.pop(lidar, None)
        if entry is None or entry[0] != stamp_ns:
            return self._cast(lidar, stamp_ns)
        if entry[4] is None or entry[1] != lidar.seed or entry[2] != lidar.noise or entry[3] != self._state():
            return None
        self.taken += 1
        return entry[4]

    def warm(self, lidar: LidarPublisher) -> None:
        """Load now what a batch loads on first use (numba's cached level_scans): one batch of every lidar taking the
        one-call path with `lidar`, listened to or not, cast and dropped."""
        batch = self._batch(lidar, 0, heard_only=False) if len(self.lidars) >= 2 else None
        if batch is not None:
            self._run(batch, lidar, 0)
        self.forget()

    def _cast(self, lidar: LidarPublisher, stamp_ns: int) -> np.ndarray | None:
        """The scans stamped `stamp_ns` of the batch `lidar` casts, cast: its own returned, the others' kept."""
        epoch = lidar.bus.listeners_epoch()
        if epoch is None:
            return None
        if epoch != self._epoch:  # listeners came or went: every batch is to be worked out again
            self._batches.clear()
            self._stacks.clear()
            self._epoch = epoch
        planned = self._batches.get(lidar)
        if planned is None or planned[0] != epoch or (planned[1] is not None and not planned[1].holds(epoch)):
            planned = self._batches[lidar] = (epoch, self._batch(lidar, epoch))
        batch = planned[1]
        scan = None if batch is None else self._run(batch, lidar, stamp_ns)
        self.taken += scan is not None
        return scan

    def _batch(self, lidar: LidarPublisher, epoch: int, heard_only: bool = True) -> _Batch | None:
        """The batch of `lidar` and of every lidar that ticks with it, is listened to (`heard_only`) and takes the
        one-call path in the same walls and fan; None when it would hold `lidar` alone."""
        mine = lidar.one_call_args()
        if mine is None:
            return None
        walls, fan, task = mine[10], lidar.fan, lidar.task
        members, calls = [], []
        for other in self.lidars:
            if other is lidar:
                members.append(lidar)
                calls.append(mine)
            elif (
                other.ticks_with(task) and (not heard_only or other.bus.has_listeners(other.topic)) and other.fan == fan
            ):
                call = other.one_call_args()
                if call is not None and call[10] is walls:  # the same walls (and with them their grid)
                    members.append(other)
                    calls.append(call)
        if len(members) < 2:
            return None
        # the same lidars with the same noise switches (their calls change with nothing else but a rebind, which
        # forgets every batch): one stacked batch, whichever of them ticks first
        key = (epoch, *(id(other) for other in members), *(other.noise for other in members))
        batch = self._stacks.get(key)
        if batch is None:
            batch = self._stacks[key] = _Batch(members, calls, epoch)
        return batch

    def _run(self, batch: _Batch, lidar: LidarPublisher, stamp_ns: int) -> np.ndarray | None:
        """Cast `batch`'s scans stamped `stamp_ns`: `lidar`'s returned, the others' kept for their ticks."""
        if batch.any_solids:  # the other cars where they are now
            self.shared.update(self.data)
        members, args = batch.members, batch.args
        offsets = [other.noise_table.offsets(other.seed, stamp_ns) for other in members]
        args[_FIRSTS] = np.array([first for first, _ in offsets], np.intp)
        args[_SECONDS] = np.array([second for _, second in offsets], np.intp)
        out = args[_OUT] = np.empty((len(members), batch.count), np.float32)
        (_LEVEL_SCANS or _level_scans())(*args)
        self.batches_cast += 1
        state = self._state()
        cast = args[_CAST].tolist()
        mine = None
        for i, other in enumerate(members):
            scan = out[i] if cast[i] else None
            if other is lidar:
                mine = scan
            else:
                self._ready[other] = (stamp_ns, other.seed, other.noise, state, scan)
        return mine
