"""The default world is the original racecar.world; the SDF loader names what it cannot use."""

from __future__ import annotations

import pytest

from racecar_sim.core.errors import WorldError
from racecar_sim.worlds import load_world
from racecar_sim.worlds.sdf import load_sdf


def test_empty_world_is_the_original_racecar_world():
    world = load_world("empty")
    (ground,) = world.bodies
    collision = next(g for g in ground.geoms if g.collides)
    assert (collision.kind, collision.size, collision.mu, collision.mu2) == ("plane", (150.0, 150.0), 100.0, 50.0)
    assert [light.name for light in world.lights] == ["sun"]
    assert world.physics.max_step_size is None and world.physics.gravity == (0.0, 0.0, -9.8)
    assert (world.spawn.x, world.spawn.y, world.spawn.z, world.spawn.yaw) == (0.0, 0.0, 0.05, 0.0)


def test_unsupported_elements_warn_by_name(tmp_path):
    path = tmp_path / "w.world"
    path.write_text("<sdf version='1.6'><world name='w'><model name='m'><static>true</static><link name='l'>"
                    "<collision name='c'><geometry><mesh><uri>x.stl</uri></mesh></geometry></collision></link>"
                    "</model><foo/></world></sdf>")
    with pytest.warns(UserWarning) as record:
        load_sdf(path)
    messages = [str(w.message) for w in record]
    assert any("<mesh> in m::l/c <geometry> is not supported" in m for m in messages)
    assert any("<foo> is not supported" in m for m in messages)


def test_malformed_world_names_the_file(tmp_path):
    path = tmp_path / "bad.world"
    path.write_text("<sdf><world name='w'><model>")
    with pytest.raises(WorldError, match="bad.world: malformed XML"):
        load_sdf(path)
    with pytest.raises(WorldError, match="no such world"):
        load_world(str(tmp_path / "missing.world"))
