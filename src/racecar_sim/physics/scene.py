"""The scene: a world and its cars as one MjSpec, the model compiled from it, its data, and the map walls held near
the movers. Its whole lifecycle - build, compile, recompile after a model is spawned or deleted at run time, and the
near-wall slots refitted each time - lives here; nothing else touches the MjSpec.

    scene = Scene(world, preset, near_walls=True, name="racecar")
    scene.add(lambda spec: add_car(spec, ...))      # each car puts itself in (bodies, actuators, sensor sites)
    scene.compile(blame=car.xacro)                  # the model and data; WorldError/ConfigError in one line
    model, data = scene.recompile()                 # after spec edits: a new model and data keeping the state
    scene.install(model, data)                      # go on with them
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.time import NS_PER_S, to_ns
from racecar_sim.physics.builder import fit_near_walls, friction_min_rule, world_spec
from racecar_sim.physics.contact_solver import choose_contact_solver
from racecar_sim.physics.near_walls import NearWalls
from racecar_sim.physics.near_walls import drop as drop_held_walls
from racecar_sim.physics.presets import PhysicsPreset
from racecar_sim.physics.world_geoms import add_world, mujoco_rejected
from racecar_sim.worlds import World
from racecar_sim.worlds.world import WorldBody


class Scene:
    """The MjSpec of a world and its cars, the compiled model and data, and the map walls near the movers."""

    def __init__(self, world: World, preset: PhysicsPreset, near_walls: bool = True, name: str = "") -> None:
        self.world, self.preset = world, preset
        self.spec = world_spec(world, preset, near_walls)
        self.spec.modelname = name or world.name or "world"
        self._model: mujoco.MjModel | None = None
        self._data: mujoco.MjData | None = None
        self.near_walls: NearWalls | None = None
        self.qpos0 = np.zeros(0)

    def add(self, part: Callable[[mujoco.MjSpec], None]) -> None:
        """Let `part` put itself into the spec (before compile(), or before a recompile())."""
        part(self.spec)

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled model."""
        if self._model is None:
            raise RuntimeError("the scene is not compiled yet")
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        """The model's data: the state of the simulation."""
        if self._data is None:
            raise RuntimeError("the scene is not compiled yet")
        return self._data

    @property
    def step_ns(self) -> int:
        """The physics step in whole nanoseconds."""
        return to_ns(self.model.opt.timestep)

    def compile(self, blame: str | Path) -> None:
        """Compile the spec (with the friction ranking of every geom, and the near-wall slots the movers need) into the
        model and its data, forwarded. MuJoCo's refusal is one line naming the world's model at fault, or else
        `blame` (the first car's description)."""
        friction_min_rule(self.spec)  # once for every car: once per car costs N^2 (every geom of the cars before)
        try:
            model = self.spec.compile()
            if fit_near_walls(self.spec, model):
                model = self.spec.compile()
        except ValueError as exc:
            raise mujoco_rejected(exc, self.world, blame) from None
        choose_contact_solver(model)
        step = model.opt.timestep
        if abs(to_ns(step) / NS_PER_S - step) > 1e-15:
            raise ConfigError(f"physics step {step} s is not a whole number of nanoseconds")
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        self._model, self._data = model, data
        self.near_walls = NearWalls.of(model, data)  # placed before the spawn checks, which look at them
        self.qpos0 = data.qpos.copy()

    def recompile(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """Recompile the spec after a change (a model spawned or deleted) into a new model and data that keep the state
        of everything that stays (MjSpec.recompile maps it by name); nothing is installed yet."""
        try:
            model, data = self.spec.recompile(self.model, self.data)
            if fit_near_walls(self.spec, model):  # a car or free body more: more near-wall slots
                model, data = self.spec.recompile(model, data)
        except ValueError as exc:
            raise ConfigError(f"MuJoCo rejected the changed model: {' '.join(str(exc).split())}") from None
        choose_contact_solver(model)  # the spec's options came back with the model: a car more may cross the bound
        mujoco.mj_forward(model, data)
        return model, data

    def install(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Go on with a recompiled model and data (reset() then puts every model in it back at its initial pose)."""
        self._model, self._data = model, data
        self.qpos0 = model.qpos0.copy()
        if self.near_walls is not None:
            self.near_walls.rebind(model, data)

    def attach_bodies(self, bodies: list[WorldBody], prefix: str) -> None:
        """Add world bodies to the scene's MjSpec with the world loader's own code: built in a spec of their own, then
        attached. Meshes, textures and materials keep `prefix` (unique per spawn), bodies, geoms and joints get their
        Gazebo names back; the friction rule is applied again over every geom."""
        child = mujoco.MjSpec()
        child.compiler.degree = self.spec.compiler.degree
        child.compiler.inertiafromgeom = self.spec.compiler.inertiafromgeom
        child.compiler.autolimits = self.spec.compiler.autolimits
        add_world(child, World("spawn", "", bodies=bodies))
        self.spec.attach(child, frame=self.spec.worldbody.add_frame(), prefix=prefix)
        for element in [*self.spec.bodies, *self.spec.geoms, *self.spec.joints, *self.spec.sites, *self.spec.lights]:
            if element.name.startswith(prefix):
                element.name = element.name[len(prefix) :]
        sky = self.spec.texture(f"{prefix}sky")  # the loader's skybox: the scene has its own
        if sky is not None:
            self.spec.delete(sky)
        friction_min_rule(self.spec)

    def remove_bodies(self, bodies: list[WorldBody]) -> None:
        """Delete world bodies from the scene's MjSpec: a free one as a body, a static one as its geoms."""
        for body in bodies:
            if not body.static and self.spec.body(body.name) is not None:
                self.spec.delete(self.spec.body(body.name))
        for body in bodies:
            if body.static:
                drop_held_walls(self.spec, body.name)  # a map's walls kept as data (physics.near_walls)
        names = {geom.name for body in bodies if body.static for geom in body.geoms}
        for geom in [g for g in self.spec.geoms if g.name in names]:
            self.spec.delete(geom)

    def refresh_near_walls(self) -> float | None:
        """Place the map walls within reach of each mover again (after they moved by hand, or on the timer); the sim
        seconds until they must be looked at again, or None for a world without held walls."""
        if self.near_walls is None:
            return None
        return self.near_walls.refresh()
