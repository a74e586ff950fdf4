"""What a loaded world is: static and dynamic bodies with their geoms, lights, physics block and spawn pose."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class WorldGeom:
    """One collision or visual shape. size: box full extents, cylinder (radius, length), sphere (radius,), plane (x, y)."""

    name: str
    kind: str  # box | cylinder | sphere | plane
    size: tuple[float, ...]
    pos: np.ndarray
    quat: np.ndarray  # (w, x, y, z), in the owning body's frame
    collides: bool = True
    mu: float = 1.0
    mu2: float = 1.0
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)


@dataclass
class WorldBody:
    """A model link: static (welded to the world) or free (pushable, with mass)."""

    name: str
    pos: np.ndarray
    quat: np.ndarray
    static: bool = True
    mass: float = 1.0
    inertia: tuple[float, float, float] = (1.0, 1.0, 1.0)
    geoms: list[WorldGeom] = field(default_factory=list)


@dataclass
class Light:
    """A light source; directional lights use `direction`."""

    name: str
    directional: bool
    pos: np.ndarray
    direction: np.ndarray
    diffuse: tuple[float, float, float] = (0.8, 0.8, 0.8)
    cast_shadows: bool = False


@dataclass
class Physics:
    """The world's <physics> block. None = not given (the simulator's preset decides)."""

    max_step_size: float | None = None
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.8)
    iterations: int | None = None


@dataclass(frozen=True)
class Spawn:
    """Where the car starts: position of base_link (z above the ground) and heading."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.05
    yaw: float = 0.0


@dataclass
class World:
    """A loaded world."""

    name: str
    source: str
    bodies: list[WorldBody] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    physics: Physics = field(default_factory=Physics)
    spawn: Spawn = field(default_factory=Spawn)
