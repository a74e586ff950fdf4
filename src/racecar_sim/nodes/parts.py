"""A node's MuJoCo parts: the elements it reads (sites, MuJoCo sensors, bodies, cameras), declared by name and bound to
ids by the framework after every compile (compare dm_control's ``physics.bind``), so that no node looks an id up.

A sensor kind declares its parts from its spec (runtime/plugins.py, `NodeKind.parts`); the car binds them once the
model is compiled and again after every recompile (a model spawned or deleted), before the nodes' `rebind` hooks run,
and hands them to the node as `NodeContext.parts` while it is built. A node reads ``parts["site"]`` (an id) or
``parts.adr("gyro")`` (a MuJoCo sensor's first address in ``sensordata``) whenever it needs them.
"""

from __future__ import annotations

import mujoco

from racecar_sim.core.errors import DescriptionError

_KINDS = {
    mujoco.mjtObj.mjOBJ_SITE: "site",
    mujoco.mjtObj.mjOBJ_SENSOR: "sensor",
    mujoco.mjtObj.mjOBJ_BODY: "body",
    mujoco.mjtObj.mjOBJ_CAMERA: "camera",
    mujoco.mjtObj.mjOBJ_GEOM: "geom",
}


class Parts:
    """Named MuJoCo elements by role (``site``, ``gyro``, ...): declared with their MuJoCo names, bound to ids."""

    def __init__(self, owner: str = "", **wanted: tuple[mujoco.mjtObj, str]) -> None:
        self.owner = owner
        self.wanted = dict(wanted)
        self._ids: dict[str, int] = {}
        self._model: mujoco.MjModel | None = None

    @classmethod
    def sites(cls, owner: str, **names: str) -> Parts:
        """Parts that are all sites: role -> MuJoCo site name."""
        return cls(owner, **{role: (mujoco.mjtObj.mjOBJ_SITE, name) for role, name in names.items()})

    @classmethod
    def cameras(cls, owner: str, **names: str) -> Parts:
        """Parts that are all cameras: role -> MuJoCo camera name."""
        return cls(owner, **{role: (mujoco.mjtObj.mjOBJ_CAMERA, name) for role, name in names.items()})

    def declares(self, role: str) -> bool:
        """Whether a part of that role is declared."""
        return role in self.wanted

    def bind(self, model: mujoco.MjModel) -> Parts:
        """Look every declared part up in a compiled model (DescriptionError naming a missing one); returns self."""
        ids = {}
        for role, (kind, name) in self.wanted.items():
            found = int(mujoco.mj_name2id(model, kind, name))
            if found < 0:
                what = _KINDS.get(kind, str(kind))
                raise DescriptionError(f"{self.owner or 'a node'}: its {what} '{name}' is not in the model")
            ids[role] = found
        self._ids, self._model = ids, model
        return self

    def __getitem__(self, role: str) -> int:
        try:
            return self._ids[role]
        except KeyError:
            state = "declared but not bound yet" if role in self.wanted else "not declared"
            raise KeyError(f"{self.owner or 'a node'}: part {role!r} is {state}") from None

    def adr(self, role: str) -> int:
        """The first ``sensordata`` address of the MuJoCo sensor bound to `role`."""
        assert self._model is not None, "bind() first"
        return int(self._model.sensor_adr[self[role]])
