"""Write ROS packages for tests: a package.xml, and a full description package made from the shipped racecar."""

from __future__ import annotations

from pathlib import Path

import trimesh

from racecar_sim.description import DEFAULT_XACRO

SHIPPED_URDF = DEFAULT_XACRO.parent
SEED_WHEELBASE = "0.325"  # the shipped racecar.xacro's hinge x


def write_package_xml(folder: Path, name: str, export: str = "") -> Path:
    """A minimal format-2 package.xml naming the package, with `export` inside <export>."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "package.xml").write_text(
        f"<?xml version='1.0'?>\n<package format='2'><name>{name}</name><version>1.0.0</version>"
        f"<description>test package</description><maintainer email='t@example.invalid'>t</maintainer>"
        f"<license>BSD</license><export>{export}</export></package>\n"
    )
    return folder


def write_description_package(
    root: Path, name: str, wheelbase: float | None = None, mesh: bool = False, edit: dict[str, str] | None = None
) -> Path:
    """A copy of the shipped racecar description as package `name` under `root`: its own package.xml, its
    xacro files including each other through `$(find name)`; `wheelbase` moves both steering hinges, `mesh`
    adds an STL box (made with trimesh) as a visual and a collision of the chassis through package://name/...,
    and `edit` replaces text in racecar.xacro. Returns the package's racecar.xacro."""
    package = write_package_xml(root / name, name)
    urdf = package / "urdf"
    urdf.mkdir()
    for source in SHIPPED_URDF.iterdir():
        text = source.read_text().replace("$(find racecar_description)", f"$(find {name})")
        (urdf / source.name).write_text(text)
    xacro = urdf / "racecar.xacro"
    text = xacro.read_text()
    if wheelbase is not None:
        for side in ("0.1", "-0.1"):
            old = f'<origin xyz="{SEED_WHEELBASE} {side} 0" rpy="0 1.5708 0"/>'
            assert old in text, "the shipped racecar.xacro moved its steering hinges"
            text = text.replace(old, f'<origin xyz="{wheelbase} {side} 0" rpy="0 1.5708 0"/>')
    if mesh:
        (package / "meshes").mkdir()
        trimesh.creation.box((0.12, 0.08, 0.04)).export(package / "meshes" / "x.stl")
        geometry = f'<geometry><mesh filename="package://{name}/meshes/x.stl"/></geometry>'
        shapes = (
            f'<visual><origin xyz="0.05 0 0.09"/>{geometry}<material name="blue"/></visual>'
            f'<collision><origin xyz="0.05 0 0.09"/>{geometry}</collision>'
        )
        old = '<link name="chassis">'
        assert old in text
        text = text.replace(old, old + shapes, 1)
    for old, new in (edit or {}).items():
        assert old in text, old
        text = text.replace(old, new)
    xacro.write_text(text)
    return xacro
