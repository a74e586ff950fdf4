"""An SDF world written here loads with the right poses, friction and physics; ray casts and contacts confirm it."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import trimesh

from conftest import run_cli_error
from racecar_sim import Simulator
from racecar_sim.core.errors import WorldError
from racecar_sim.physics import COLLISION_GROUP
from racecar_sim.worlds import load_world
from racecar_sim.worlds.sdf import load_sdf

ROOM = 6.0  # inner side of the box room, m, centred on the origin
WALL = 0.2
PILLAR = (1.5, 1.5, 0.25, 1.0)  # x, y, radius, height
MESH_AT, MESH_SIZE = (-1.5, 1.5), (0.4, 0.6, 0.5)
CRATE_AT, CRATE_YAW, CRATE_SIZE = (1.5, -1.5), math.pi / 4, (0.5, 0.5, 0.3)  # included; its own pose is elsewhere
PAD = (-1.5, -1.5, 0.2)  # x, y, mu of a low-friction pad, 1.2 m square, 2 cm tall


def _box(name: str, pose: str, size: str, mu: float | None = None) -> str:
    surface = f"<surface><friction><ode><mu>{mu}</mu><mu2>{mu}</mu2></ode></friction></surface>" if mu else ""
    geometry = f"<geometry><box><size>{size}</size></box></geometry>"
    return (
        f"<link name='{name}'><pose>{pose}</pose><collision name='c'>{geometry}{surface}</collision>"
        f"<visual name='v'>{geometry}</visual></link>"
    )


@pytest.fixture
def world_file(tmp_path):
    """A box room with a pillar, a mesh obstacle, an included crate, a low-friction pad and a sliding block."""
    trimesh.creation.box(MESH_SIZE).export(tmp_path / "obstacle.stl")
    crate = tmp_path / "models" / "crate"
    crate.mkdir(parents=True)
    (crate / "model.sdf").write_text(
        f"<sdf version='1.6'><model name='crate'><static>true</static><pose>9 9 0 0 0 0</pose>"
        f"{_box('body', f'0 0 {CRATE_SIZE[2] / 2} 0 0 0', ' '.join(map(str, CRATE_SIZE)), mu=0.7)}</model></sdf>"
    )
    half = ROOM / 2 + WALL / 2
    span = ROOM + 2 * WALL
    walls = "".join(
        [
            _box("north", f"0 {half} 0.5 0 0 0", f"{span} {WALL} 1"),
            _box("south", f"0 {-half} 0.5 0 0 0", f"{span} {WALL} 1"),
            _box("east", f"{half} 0 0.5 0 0 0", f"{WALL} {span} 1"),
            _box("west", f"{-half} 0 0.5 0 0 0", f"{WALL} {span} 1"),
        ]
    )
    x, y, r, h = PILLAR
    text = f"""<?xml version="1.0"?>
<sdf version="1.7">
  <world name="room">
    <physics type="ode"><max_step_size>0.002</max_step_size><gravity>0 0 -9.8</gravity>
      <ode><solver><iters>40</iters></solver></ode></physics>
    <include><uri>model://sun</uri></include>
    <include><uri>model://ground_plane</uri></include>
    <model name="room"><static>true</static>{walls}</model>
    <model name="pillar"><static>true</static><pose>{x} {y} {h / 2} 0 0 0</pose>
      <link name="link"><collision name="c"><geometry><cylinder><radius>{r}</radius><length>{h}</length></cylinder>
      </geometry></collision></link></model>
    <model name="obstacle"><static>true</static><pose>{MESH_AT[0]} {MESH_AT[1]} {MESH_SIZE[2] / 2} 0 0 0</pose>
      <link name="link"><collision name="c"><geometry><mesh><uri>obstacle.stl</uri></mesh></geometry></collision>
      <visual name="v"><geometry><mesh><uri>obstacle.stl</uri></mesh></geometry></visual></link></model>
    <include><uri>model://crate</uri><name>crate_1</name>
      <pose>{CRATE_AT[0]} {CRATE_AT[1]} 0 0 0 {CRATE_YAW}</pose></include>
    <model name="pad"><static>true</static>
      {_box("link", f"{PAD[0]} {PAD[1]} 0.01 0 0 0", "1.2 1.2 0.02", mu=PAD[2])}</model>
    <model name="block"><pose>{PAD[0] - 0.4} {PAD[1]} 0.07 0 0 0</pose>
      <link name="link"><inertial><mass>2.0</mass><inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.01</izz></inertia>
      </inertial><collision name='c'><geometry><box><size>0.1 0.1 0.1</size></box></geometry></collision>
      </link></model>
  </world>
</sdf>"""
    path = tmp_path / "room.world"
    path.write_text(text)
    return path, tmp_path / "models"


def _ray(model, data, origin, direction) -> float:
    groups = np.zeros(6, np.uint8)
    groups[COLLISION_GROUP] = 1
    d = mujoco.mj_ray(
        model,
        data,
        np.asarray(origin, float),
        np.asarray(direction, float) / np.linalg.norm(direction),
        groups,
        1,
        -1,
        np.array([-1], np.int32),
    )
    return math.inf if d < 0 else d


@pytest.fixture
def sim(world_file):
    path, models = world_file
    sim = Simulator(world=str(path), model_path=[models], spawn=None)
    yield sim
    sim.close()


def test_poses_friction_and_physics_block(world_file):
    path, models = world_file
    world = load_world(str(path), model_path=[models])
    bodies = {b.name: b for b in world.bodies}
    crate = bodies["crate_1::body"]
    assert crate.pos == pytest.approx((*CRATE_AT, CRATE_SIZE[2] / 2)), "the include pose replaces the model's own"
    assert crate.geoms[0].mu == 0.7
    assert bodies["pad::link"].geoms[0].mu == PAD[2]
    assert bodies["block::link"].mass == 2.0 and not bodies["block::link"].static
    assert world.physics.max_step_size == 0.002 and world.physics.iterations == 40
    assert (world.spawn.x, world.spawn.y, world.spawn.yaw) == (0.0, 0.0, 0.0), "SDF files name no spawn: the origin"


def test_ray_casts_find_each_object(sim):
    m, d = sim.model, sim.data
    assert m.opt.timestep == 0.002 and m.opt.iterations == 40
    h = 0.15
    assert _ray(m, d, (0, 0, 0.8), (1, 0, 0)) == pytest.approx(ROOM / 2, abs=1e-6)  # above the car, below the walls
    assert _ray(m, d, (0, 0, 0.8), (0, -1, 0)) == pytest.approx(ROOM / 2, abs=1e-6)
    x, y, r, _ = PILLAR
    assert _ray(m, d, (x - 1, y, h), (1, 0, 0)) == pytest.approx(1 - r, abs=1e-6)
    assert _ray(m, d, (MESH_AT[0] + 1, MESH_AT[1], h), (-1, 0, 0)) == pytest.approx(1 - MESH_SIZE[0] / 2, abs=1e-6)
    assert _ray(m, d, (MESH_AT[0], MESH_AT[1] - 1, h), (0, 1, 0)) == pytest.approx(1 - MESH_SIZE[1] / 2, abs=1e-6)
    # the crate is turned 45 degrees: a ray along its diagonal meets a corner at half the diagonal
    half_diagonal = CRATE_SIZE[0] / math.sqrt(2)
    assert _ray(m, d, (CRATE_AT[0] - 1, CRATE_AT[1], h), (1, 0, 0)) == pytest.approx(1 - half_diagonal, abs=1e-6)
    assert _ray(m, d, (x, y, 1.2), (0, 0, -1)) == pytest.approx(0.2, abs=1e-6), "the pillar is 1 m tall"


@pytest.mark.parametrize(
    "where, top", [(PILLAR[:2], PILLAR[3]), (MESH_AT, MESH_SIZE[2]), (CRATE_AT, CRATE_SIZE[2]), ((0.0, 2.0), 0.0)]
)
def test_a_dropped_ball_lands_on_each_object(world_file, where, top):
    """Contact, not just ray casts: a free ball dropped over an object comes to rest on its top face."""
    path, models = world_file
    world = load_world(str(path), model_path=[models])
    ball = path.parent / "ball.world"
    radius = 0.05
    ball.write_text(
        f"<sdf version='1.6'><world name='b'><model name='ball'><pose>{where[0]} {where[1]} 1.5 0 0 0</pose>"
        f"<link name='l'><inertial><mass>0.1</mass><inertia><ixx>1e-4</ixx><iyy>1e-4</iyy><izz>1e-4</izz>"
        f"</inertia></inertial><collision name='c'><geometry><sphere><radius>{radius}</radius></sphere>"
        f"</geometry></collision></link></model></world></sdf>"
    )
    world.bodies += load_world(str(ball)).bodies
    sim = Simulator(world=world, spawn=None)
    sim.run_until(2.0)
    z = sim.data.xpos[sim.model.body("ball::l").id][2]
    assert z == pytest.approx(top + radius, abs=0.003)


def test_friction_is_the_smaller_of_the_two_surfaces(sim):
    """A block given 1 m/s on the mu 0.2 pad slides v^2 / (2 mu g) before it stops (Coulomb, Gazebo's min rule)."""
    m, d = sim.model, sim.data
    joint = m.joint("block::link::free")
    sim.run_until(0.5)  # settle on the pad
    start = d.qpos[joint.qposadr[0] : joint.qposadr[0] + 3].copy()
    d.qvel[joint.dofadr[0]] = 1.0
    sim.run_for(2.0)
    slid = d.qpos[joint.qposadr[0]] - start[0]
    expected = 1.0 / (2 * PAD[2] * 9.8)
    assert slid == pytest.approx(expected, rel=0.05)


def test_mesh_visual_and_collision_come_from_the_file(world_file):
    path, models = world_file
    world = load_world(str(path), model_path=[models])
    (body,) = [b for b in world.bodies if b.name == "obstacle::link"]
    collision, visual = body.geoms
    assert collision.collides and not visual.collides and collision.kind == visual.kind == "mesh"
    extent = collision.mesh.vertices.max(0) - collision.mesh.vertices.min(0)
    assert extent == pytest.approx(MESH_SIZE)


def test_model_path_comes_from_the_environment_too(world_file, monkeypatch):
    path, models = world_file
    with pytest.raises(WorldError, match="model 'crate' not found"):
        load_world(str(path))
    monkeypatch.setenv("GAZEBO_MODEL_PATH", str(models))
    assert any(b.name == "crate_1::body" for b in load_world(str(path)).bodies)


def test_unsupported_elements_warn_by_name(tmp_path):
    path = tmp_path / "w.world"
    path.write_text(
        "<sdf version='1.6'><world name='w'><model name='m'><static>true</static><link name='l'>"
        "<collision name='c'><geometry><heightmap><uri>h.png</uri></heightmap></geometry></collision>"
        "<sensor name='s'/></link><joint name='j' type='fixed'/></model><foo/>"
        "<physics><ode><constraints><erp>0.5</erp></constraints></ode></physics></world></sdf>"
    )
    with pytest.warns(UserWarning) as record:
        load_sdf(path)
    messages = "\n".join(str(w.message) for w in record)
    assert "<heightmap> in m::l/c <geometry> is not supported" in messages
    assert "<sensor> in link m::l is not supported" in messages
    assert "<joint> in model m is not supported" in messages
    assert "<foo> in world w is not supported" in messages
    assert "ode/constraints/erp>0.5" in messages


BAD_WORLDS = {
    "malformed XML": "<sdf><world name='w'><model>",
    "mesh file": "<sdf version='1.6'><world name='w'><model name='m'><link name='l'><collision name='c'><geometry>"
    "<mesh><uri>missing.stl</uri></mesh></geometry></collision></link></model></world></sdf>",
    "is not 6 finite numbers": "<sdf version='1.6'><world name='w'><model name='m'><pose>0 0 nan 0 0 0</pose>"
    "</model></world></sdf>",
    "model 'nowhere' not found": "<sdf version='1.6'><world name='w'><include><uri>model://nowhere</uri></include>"
    "</world></sdf>",
    "sizes must be positive": "<sdf version='1.6'><world name='w'><model name='m'><link name='l'><collision name='c'>"
    "<geometry><box><size>1 0 1</size></box></geometry></collision></link></model></world></sdf>",
}


@pytest.mark.parametrize("problem", BAD_WORLDS)
def test_bad_world_files_give_one_line_and_exit_code_2(tmp_path, problem):
    path = tmp_path / "bad.world"
    path.write_text(BAD_WORLDS[problem])
    assert problem in run_cli_error(path)


def test_collada_unit_is_honoured(tmp_path):
    """A COLLADA file in inches (<unit meter="0.0254">, like the original cone.dae) is scaled to metres."""
    trimesh.creation.box((10.0, 20.0, 30.0)).export(tmp_path / "inches.dae")
    text = (tmp_path / "inches.dae").read_text()
    (tmp_path / "inches.dae").write_text(text.replace("<asset>", '<asset><unit meter="0.0254" name="inch"/>', 1))
    (tmp_path / "w.world").write_text(
        "<sdf version='1.6'><world name='w'><model name='m'><static>true</static><link name='l'><visual name='v'>"
        "<geometry><mesh><uri>inches.dae</uri><scale>2 1 1</scale></mesh></geometry></visual></link></model>"
        "</world></sdf>"
    )
    (geom,) = load_sdf(tmp_path / "w.world").bodies[0].geoms
    extent = geom.mesh.vertices.max(0) - geom.mesh.vertices.min(0)
    assert extent == pytest.approx((2 * 0.254, 0.508, 0.762))
