"""Write the built-in worlds' models (SDF, meshes, textures) from the facts of original_stack.md §3.3-3.4.

The original meshes are not licensed, so each model is rebuilt here from the published numbers:
    python tools/make_world_models.py          # rewrites src/racecar_sim/worlds/data/models/*
The output is committed; this script is how it was made. It needs trimesh and (for the AR tags) OpenCV.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

MODELS = Path(__file__).resolve().parents[1] / "src" / "racecar_sim" / "worlds" / "data" / "models"

# MIT_Tunnel (Building 32-081): wall name, length, link pose x, y, yaw in the model frame. §3.4.
TUNNEL_WALLS = [
    ("Wall_10", 32.6917, -19.1952, 15.5558, -0.001042),
    ("Wall_12", 8.5, -2.92483, 11.3639, -1.5708),
    ("Wall_15", 18.75, 6.37517, 7.18889, 0.0),
    ("Wall_17", 4.75, 15.0799, 4.96726, -1.8326),
    ("Wall_18", 2.75, 13.1846, 2.74563, 3.14159),
    ("Wall_19", 2.75, 10.9654, 1.82639, -2.35619),
    ("Wall_2", 24.25, -52.25, -18.2689, 0.0),
    ("Wall_20", 2.25, 10.0461, -0.142849, -1.5708),
    ("Wall_22", 5.08891, 8.53852, -3.14869, -2.22749),
    ("Wall_23", 1.75, 6.23091, -5.10454, 3.14159),
    ("Wall_24", 2.59216, 4.6163, -6.01417, -2.30114),
    ("Wall_26", 3.0, 3.80168, -8.34882, -1.5708),
    ("Wall_27", 2.5, 2.62668, -9.77382, 3.14159),
    ("Wall_28", 4.15096, 0.152007, -11.2946, -2.27796),
    ("Wall_29", 5.87777, -1.14312, -15.679, -1.56921),
    ("Wall_30", 65.5, 31.5103, -18.5427, 0.0),
    ("Wall_32", 4.75, 64.1853, -20.8427, -1.5708),
    ("Wall_34", 5.0, -64.3, -20.6939, -1.5708),
    ("Wall_35", 128.75, 1e-06, -23.1189, 0.0),
    ("Wall_37", 4.75, -37.9, 23.0811, 0.0),
    ("Wall_41", 31.75, -35.4175, -2.72616, 1.5708),
    ("Wall_43", 30.0, -20.4925, 13.0738, 0.0),
    ("Wall_44", 8.75, -5.56745, 8.77384, -1.5708),
    ("Wall_45", 13.75, 1.23255, 4.47384, 0.0),
    ("Wall_46", 2.25, 8.03255, 3.42384, -1.5708),
    ("Wall_47", 15.8243, 2.89068, -3.54071, -2.28642),
    ("Wall_5", 41.5, -40.2, 2.40609, 1.5708),
    ("Wall_50", 1.0, -2.6617, -9.34526, 2.87979),
    ("Wall_51", 1.75, -3.47221, -9.92808, -2.0944),
    ("Wall_52", 1.5, -3.39492, -11.0982, -0.785398),
    ("Wall_53", 0.75, -3.12975, -11.7876, -2.35619),
    ("Wall_54", 0.75, -3.64188, -11.9998, 3.14159),
    ("Wall_55", 7.13355, -5.21192, -15.2524, -1.94306),
    ("Wall_57", 29.0, -20.9925, -18.5262, 0.0),
    ("Wall_9", 7.75, -35.4657, 19.3427, -1.5708),
]
TUNNEL_GREY = {"Wall_19", "Wall_20", "Wall_26", "Wall_32", "Wall_50", "Wall_54"}
TUNNEL_THICKNESS, TUNNEL_HEIGHT = 0.15, 2.5

# parking_1: box name, size (world x, y, z), world centre, placed by the include pose (-1.2, 0.25, yaw -1.57).
PARKING_POSE = (-1.2, 0.25, -1.57)
PARKING_BOXES = [
    ("wall", (10.97, 0.35, 2.0), (3.305, 4.45, 1.015), "Gazebo/Grey"),
    ("parked_block_1", (0.60, 0.27, 0.30), (2.42, 3.985, 0.153), "Gazebo/Blue"),
    ("parked_block_2", (0.60, 0.27, 0.30), (4.00, 3.99, 0.173), "Gazebo/Blue"),
    ("parking_pad", (0.76, 0.45, 0.01), (3.22, 4.045, 0.010), "Gazebo/Yellow"),
]

# cone: a 0.15 x 0.15 x 0.005 base plate and a tapered body 0.12 wide, 0.17 m tall; orange; SDF default inertia.
CONE_BASE, CONE_HEIGHT, CONE_BOTTOM_RADIUS, CONE_TOP_RADIUS = (0.15, 0.15, 0.005), 0.17, 0.06, 0.012
CONE_ORANGE = "1 0.2 0 1"

# walker_racecourse: a closed course in the original's footprint (x -22 ... 14, y -14 ... 17), driven anticlockwise.
# Road at z -0.142 (an outer floor rim at -0.5), walls from the road to +0.575 (0.717 m); start line and markers
# where the original has them. The centre line and width are ours: the original mesh is not licensed.
WALKER_CENTRE = [
    (-6.0, 0.3),
    (7.2, 0.3),
    (7.2, 6.0),
    (4.0, 9.0),
    (4.0, 13.2),
    (-19.5, 13.2),
    (-19.5, -11.5),
    (-9.0, -11.5),
    (-9.0, -3.0),
]
WALKER_WIDTH, WALKER_ROAD_Z, WALKER_RIM_Z, WALKER_WALL_TOP, WALKER_WALL = 2.1, -0.142, -0.5, 0.575, 0.15
WALKER_START_LINE = ((1.81, 2.11), (-0.75, 1.35))  # x range, y range (the road's width)
# coloured markers (0.8 x 0.4 m, on the walls' inner faces) near where the original has them
WALKER_MARKERS = [
    ("Gazebo/Blue", (8.239, 0.8), 0.0),
    ("Gazebo/Yellow", (3.6, 14.239), math.pi / 2),
    ("Gazebo/Red", (-7.4, 14.239), math.pi / 2),
    ("Gazebo/Purple", (-7.961, -10.8), 0.0),
]

# ar_tags/markerN: a 0.001 x 0.05 x 0.05 tag standing on the ground, facing +-x; visual only.
AR_MARKERS, AR_SIZE = 18, 0.05


def _sdf(root_child: ET.Element) -> ET.ElementTree:
    sdf = ET.Element("sdf", version="1.6")
    sdf.append(root_child)
    ET.indent(sdf, "  ")
    return ET.ElementTree(sdf)


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrs: str) -> ET.Element:
    el = ET.SubElement(parent, tag, attrs)
    if text is not None:
        el.text = text
    return el


def _fmt(*values: float) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def _box_link(model: ET.Element, name: str, pose: tuple, size: tuple, material: str, collide: bool = True) -> None:
    link = _sub(model, "link", name=name)
    _sub(link, "pose", _fmt(*pose))
    kinds = ("collision", "visual") if collide else ("visual",)
    for kind in kinds:
        shape = _sub(link, kind, name=kind)
        _sub(_sub(_sub(shape, "geometry"), "box"), "size", _fmt(*size))
        if kind == "visual":
            _sub(_sub(_sub(shape, "material"), "script"), "name", material)


def _write_model(name: str, model: ET.Element, description: str) -> Path:
    folder = MODELS / name
    folder.mkdir(parents=True, exist_ok=True)
    _sdf(model).write(folder / "model.sdf", xml_declaration=True, encoding="utf-8")
    config = ET.Element("model")
    _sub(config, "name", name.split("/")[-1])
    _sub(config, "version", "1.0")
    _sub(config, "sdf", "model.sdf", version="1.6")
    _sub(config, "description", description)
    ET.indent(config, "  ")
    ET.ElementTree(config).write(folder / "model.config", xml_declaration=True, encoding="utf-8")
    return folder


def mit_tunnel() -> None:
    model = ET.Element("model", name="MIT_Tunnel")
    _sub(model, "static", "true")
    _sub(model, "pose", _fmt(3.61177, 6.74312, 0, 0, 0, 0))  # replaced by the world's include pose, as in Gazebo
    for name, length, x, y, yaw in TUNNEL_WALLS:
        material = "Gazebo/Grey" if name in TUNNEL_GREY else "Gazebo/CeilingTiled"
        link = _sub(model, "link", name=name)
        _sub(link, "pose", _fmt(x, y, 0, 0, 0, yaw))
        for kind in ("collision", "visual"):
            shape = _sub(link, kind, name=f"{name}_{kind.title()}")
            _sub(shape, "pose", _fmt(0, 0, TUNNEL_HEIGHT / 2, 0, 0, 0))
            _sub(_sub(_sub(shape, "geometry"), "box"), "size", _fmt(length, TUNNEL_THICKNESS, TUNNEL_HEIGHT))
            if kind == "visual":
                _sub(_sub(_sub(shape, "material"), "script"), "name", material)
    _write_model("MIT_Tunnel", model, "Building 32-081, the MIT basement tunnel: 35 walls, 0.15 m thick, 2.5 m tall")


def parking_1() -> None:
    px, py, yaw = PARKING_POSE
    c, s = math.cos(yaw), math.sin(yaw)
    model = ET.Element("model", name="parking_1")
    _sub(model, "static", "true")
    for name, size, (wx, wy, wz), material in PARKING_BOXES:
        dx, dy = wx - px, wy - py
        local = (c * dx + s * dy, -s * dx + c * dy, wz)  # inverse of the include pose's rotation
        local_size = (size[1], size[0], size[2])  # the include yaw turns the model's y onto the world's x
        _box_link(model, name, (*local, 0, 0, 0), local_size, material)
    _write_model("parking_1", model, "A parallel-parking slot: a wall, two parked blocks 0.98 m apart, the pad")


def cone() -> None:
    folder = MODELS / "cone" / "meshes"
    folder.mkdir(parents=True, exist_ok=True)
    body = trimesh.creation.cylinder(radius=CONE_BOTTOM_RADIUS, height=CONE_HEIGHT - CONE_BASE[2], sections=24)
    top = body.vertices[:, 2] > 0
    body.vertices[top, :2] *= CONE_TOP_RADIUS / CONE_BOTTOM_RADIUS
    body.vertices[:, 2] += (CONE_HEIGHT - CONE_BASE[2]) / 2 + CONE_BASE[2]
    body.export(folder / "cone_body.obj", include_normals=False, include_texture=False)
    model = ET.Element("model", name="cone")  # not static, no <inertial>: 1 kg and unit inertia, pushable
    link = _sub(model, "link", name="link")
    for kind in ("collision", "visual"):
        base = _sub(link, kind, name=f"base_{kind}")
        _sub(base, "pose", _fmt(0, 0, CONE_BASE[2] / 2, 0, 0, 0))
        _sub(_sub(_sub(base, "geometry"), "box"), "size", _fmt(*CONE_BASE))
        shape = _sub(link, kind, name=f"body_{kind}")
        _sub(_sub(_sub(shape, "geometry"), "mesh"), "uri", "model://cone/meshes/cone_body.obj")
        for el in (base, shape):
            if kind == "visual":
                material = _sub(el, "material")
                _sub(material, "ambient", CONE_ORANGE)
                _sub(material, "diffuse", CONE_ORANGE)
                _sub(material, "specular", "0.1 0.1 0.1 1")
    _write_model("cone", model, "A traffic cone: 0.15 m base plate, tapered body 0.17 m tall")


def ar_markers() -> None:
    import cv2  # only needed to draw the tags

    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    for n in range(AR_MARKERS):
        folder = MODELS / "ar_tags" / f"marker{n}"
        (folder / "materials").mkdir(parents=True, exist_ok=True)
        cells = 8  # 4 x 4 bits, a black border and a white quiet zone of one cell each
        marker = cv2.aruco.generateImageMarker(dictionary, n, 6 * 16)
        image = np.full((cells * 16, cells * 16), 255, np.uint8)
        image[16:-16, 16:-16] = marker
        cv2.imwrite(str(folder / "materials" / f"marker{n}.png"), image)
        model = ET.Element("model", name=f"marker{n}")
        _sub(model, "static", "true")
        link = _sub(model, "link", name="link")
        visual = _sub(link, "visual", name="tag")
        _sub(visual, "pose", _fmt(0, 0, AR_SIZE / 2, 0, 0, 0))
        _sub(_sub(_sub(visual, "geometry"), "box"), "size", _fmt(0.001, AR_SIZE, AR_SIZE))
        _sub(_sub(_sub(_sub(visual, "material"), "pbr"), "metal"), "albedo_map", f"materials/marker{n}.png")
        _write_model(f"ar_tags/marker{n}", model, f"ArUco DICT_4X4_50 id {n} on a 5 cm tag (visual only)")


def walker_racecourse() -> None:
    from racecar_sim.worlds.walls import border_walls, offset_polyline

    folder = MODELS / "walker_racecourse" / "materials"
    folder.mkdir(parents=True, exist_ok=True)
    centre = np.array(WALKER_CENTRE)
    model = ET.Element("model", name="walker_racecourse")
    _sub(model, "static", "true")
    lo = centre.min(0) - WALKER_WIDTH / 2 - WALKER_WALL
    hi = centre.max(0) + WALKER_WIDTH / 2 + WALKER_WALL
    for name, margin, top, material in (
        ("floor", 0.0, WALKER_ROAD_Z, "Gazebo/DarkGrey"),
        ("floor_rim", 1.5, WALKER_RIM_Z, "Gazebo/Grey"),
    ):
        size = (*(hi - lo + 2 * margin), 0.2)
        _box_link(model, name, (*(lo + hi) / 2, top - 0.1, 0, 0, 0), size, material)
    height = WALKER_WALL_TOP - WALKER_ROAD_Z
    for side in ("left", "right"):
        border = offset_polyline(centre, WALKER_WIDTH / 2, side, closed=True)
        walls = [g for g in border_walls(border, True, side, WALKER_WALL, height, WALKER_ROAD_Z) if g.collides]
        for i, wall in enumerate(walls):
            yaw = 2 * math.atan2(wall.quat[3], wall.quat[0])
            _box_link(model, f"wall_{side}_{i}", (*wall.pos, 0, 0, yaw), wall.size, "Gazebo/White")
    # the checkered start line: one thin box whose top face carries a 2 x 14 checker
    (x0, x1), (y0, y1) = WALKER_START_LINE
    cells = np.indices((14, 2)).sum(0) % 2
    image = np.kron(cells, np.ones((16, 16))).astype(np.uint8) * 255
    Image.fromarray(image).save(folder / "checker.png")
    link = _sub(model, "link", name="start_line")
    _sub(link, "pose", _fmt((x0 + x1) / 2, (y0 + y1) / 2, WALKER_ROAD_Z + 0.001, 0, 0, 0))
    visual = _sub(link, "visual", name="checker")
    _sub(_sub(_sub(visual, "geometry"), "box"), "size", _fmt(x1 - x0, y1 - y0, 0.002))
    _sub(_sub(_sub(_sub(visual, "material"), "pbr"), "metal"), "albedo_map", "materials/checker.png")
    for i, (material, (x, y), yaw) in enumerate(WALKER_MARKERS):
        _box_link(
            model, f"marker_{i}", (x, y, WALKER_ROAD_Z + 0.3, 0, 0, yaw), (0.02, 0.8, 0.4), material, collide=False
        )
    _write_model("walker_racecourse", model, "A closed racecourse: 0.72 m walls, a checkered start line, markers")


if __name__ == "__main__":
    mit_tunnel()
    parking_1()
    cone()
    ar_markers()
    walker_racecourse()
