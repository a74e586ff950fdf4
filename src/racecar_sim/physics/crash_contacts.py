"""Crashes in MuJoCo's contact list: a car touching a wall, an obstacle or another car.

A contact of a car's geom with anything not of that car is a crash, except a wheel resting on a surface: a wheel geom
against a geom that belongs to no car, whose contact normal is within 45 degrees of vertical (the ground, a floor box,
a ramp). Read at event rate, never per physics step.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
import numpy.typing as npt

SUPPORT_NORMAL_Z = 0.7071  # |n_z| above this: a wheel standing on the surface, not driving into it
_FEW = 64  # contacts up to which a Python loop beats numpy's per-call overhead (a car's 4 wheels on the floor: 4x)


class CrashContacts:
    """Which car touches what: `touching(data)` lists (car index, other car index or -1, geom id of what was hit)."""

    def __init__(self, model: mujoco.MjModel, roots: Sequence[int], wheel_bodies: Sequence[int]) -> None:
        self.rebind(model, roots, wheel_bodies)

    def rebind(self, model: mujoco.MjModel, roots: Sequence[int], wheel_bodies: Sequence[int]) -> None:
        """Map the geoms of a (recompiled) model to the cars, given by their root bodies in order, and their wheels."""
        car_of_root = np.full(model.nbody, -1, np.int64)
        for index, body in enumerate(roots):
            car_of_root[body] = index
        self.car_of_geom: npt.NDArray[np.int64] = car_of_root[model.body_rootid[model.geom_bodyid]]
        wheel = np.zeros(model.nbody, bool)
        wheel[list(wheel_bodies)] = True
        self._wheel_geom: npt.NDArray[np.bool_] = wheel[model.geom_bodyid]
        # the same tables as Python lists, for the few contacts of most calls: numpy costs more on a handful
        self._owner_list: list[int] = self.car_of_geom.tolist()
        self._wheel_list: list[bool] = self._wheel_geom.tolist()
        # the last contacts that were no crash (their geom pairs' bytes), and which of them are a wheel on a surface:
        # the same pairs again are no crash as long as those wheels' normals stay within 45 degrees of vertical
        self._quiet: tuple[bytes, npt.NDArray[np.intp] | slice | None] | None = None
        # views of MuJoCo's contact array by contact count: the geom pairs and the normals' z of the first ncon
        # contacts of _live_data (see _views), made once per count
        self._live_data: mujoco.MjData | None = None
        self._live: dict[int, tuple[npt.NDArray[np.int32], npt.NDArray[np.float64]]] = {}

    def touching(self, data: mujoco.MjData) -> set[tuple[int, int, int]]:
        """(car, other car or -1, geom of the other side) for every crash contact now; a car-car contact once, with
        the lower index first."""
        n = data.ncon
        if n == 0:
            return set()
        if data is not self._live_data:  # another MjData (a recompiled model): views of its own
            self._live_data, self._live = data, {}
        live = self._live.get(n)
        if live is None:
            live = self._live[n] = _views(data)
        pairs, normals_z = live
        key = pairs.tobytes()
        quiet = self._quiet
        if quiet is not None and quiet[0] == key:  # most looks: the wheels on the floor as at the last one
            rows = quiet[1]
            if rows is None:
                return set()
            # every resting wheel's normal within 45 degrees of vertical: most often all point up, seen in one min()
            # (Python's, on a list: numpy's reduction costs microseconds of wrapping on a few numbers; the sum is
            # NaN where a normal is, which Python's min() may pass over)
            # (all n rows, the usual case: the view itself holds exactly them, without a view of it made)
            normal_z = (normals_z if type(rows) is slice else normals_z[rows]).tolist()
            total = sum(normal_z)
            if total == total and (
                min(normal_z) > SUPPORT_NORMAL_Z or all(abs(z) > SUPPORT_NORMAL_Z for z in normal_z)
            ):
                return set()
        resting: list[int] = []  # the wheels on a surface among them (their normals decide)
        found = (
            self._touching_few(pairs, normals_z, resting)
            if n <= _FEW
            else self._touching_many(pairs, normals_z, resting)
        )
        self._quiet = None if found else (key, _rows(resting, n))
        return found

    def _touching_many(
        self, geoms: npt.NDArray[np.int32], normals_z: npt.NDArray[np.float64], resting: list[int]
    ) -> set[tuple[int, int, int]]:
        """touching() for many contacts, with numpy; the wheels on a surface (whatever their normals) into
        `resting`."""
        owner = self.car_of_geom[geoms]
        first, second = owner[:, 0], owner[:, 1]
        touching = first != second  # a car and something not of it (the world is -1 on both sides of its own)
        if not touching.any():
            return set()
        wheel = self._wheel_geom[geoms]
        on_surface = (wheel[:, 0] & (second < 0)) | (wheel[:, 1] & (first < 0))
        resting.extend(np.flatnonzero(on_surface).tolist())
        crash = touching & ~(on_surface & (np.abs(normals_z) > SUPPORT_NORMAL_Z))
        found: set[tuple[int, int, int]] = set()
        for index in np.flatnonzero(crash):
            found.add(_crash(int(first[index]), int(second[index]), int(geoms[index, 0]), int(geoms[index, 1])))
        return found

    def _touching_few(
        self, geoms: npt.NDArray[np.int32], normals_z: npt.NDArray[np.float64], resting: list[int]
    ) -> set[tuple[int, int, int]]:
        """touching() for a few contacts, element by element: the same tests on the same numbers (a Python float is
        the float64 numpy compares), the normals read only when a wheel may rest on a surface (those into
        `resting`)."""
        owner, wheel = self._owner_list, self._wheel_list
        found: set[tuple[int, int, int]] = set()
        normal_z: list[float] | None = None
        for index, (ga, gb) in enumerate(geoms.tolist()):
            a, b = owner[ga], owner[gb]
            if a == b:  # within one car, or the world against itself
                continue
            if (wheel[ga] and b < 0) or (wheel[gb] and a < 0):
                resting.append(index)
                if normal_z is None:
                    normal_z = normals_z.tolist()
                if abs(normal_z[index]) > SUPPORT_NORMAL_Z:  # a wheel resting on the ground, a floor, a ramp
                    continue
            found.add(_crash(a, b, ga, gb))
        return found


def _views(data: mujoco.MjData) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.float64]]:
    """The geom pairs (ncon, 2) and the normals' z (ncon,) of `data`'s contacts, as views of MuJoCo's contact array
    that stay live: MuJoCo keeps an MjData's contacts at the start of its arena (mj_clearEfc sets d->contact =
    d->arena at every step), so these views read every later step's first ncon contacts, without data.contact making
    its wrapper again (microseconds at every look, with the caches MuJoCo's stepping left cold)."""
    contact = data.contact
    return contact.geom, contact.frame[:, 2]


def _rows(resting: list[int], n: int) -> npt.NDArray[np.intp] | slice | None:
    """The resting wheels' contact rows as the next look reads their normals: None for none, a slice for all n (a view,
    not a copy), else their indices."""
    if not resting:
        return None
    if len(resting) == n:  # the rows are increasing and distinct: all of 0..n-1
        return slice(0, n)
    return np.array(resting, np.intp)


def _crash(a: int, b: int, ga: int, gb: int) -> tuple[int, int, int]:
    """A crash contact between geoms ga (of car a, -1: none) and gb (of car b) as touching() lists it."""
    if a >= 0 and b >= 0:
        return (a, b, gb) if a < b else (b, a, ga)
    return (a, -1, gb) if a >= 0 else (b, -1, ga)
