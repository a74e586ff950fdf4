"""Parse an expanded URDF, with its <gazebo> extension tags and <transmission> blocks, into plain data."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Literal, overload

from racecar_sim.core.errors import DescriptionError

Vec3 = tuple[float, float, float]
RGBA = tuple[float, float, float, float]
ZERO: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Origin:
    """A URDF <origin>: translation and fixed-axis roll-pitch-yaw."""

    xyz: Vec3 = ZERO
    rpy: Vec3 = ZERO


@dataclass(frozen=True)
class Geometry:
    """A URDF <geometry>: kind is box, cylinder, sphere or mesh."""

    kind: str
    size: Vec3 = ZERO  # box: full extents; cylinder: (radius, length, 0); sphere: (radius, 0, 0)
    filename: str = ""
    scale: Vec3 = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class Shape:
    """A <visual> or <collision> element of a link."""

    geometry: Geometry
    origin: Origin = Origin()
    rgba: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class Inertial:
    """Mass, centre of mass and inertia tensor (ixx, iyy, izz, ixy, ixz, iyz) of a link."""

    mass: float
    origin: Origin
    inertia: tuple[float, float, float, float, float, float]


@dataclass
class Surface:
    """The contact parameters a <gazebo reference="link"> block gives (None = not given)."""

    mu1: float | None = None
    mu2: float | None = None
    kp: float | None = None
    kd: float | None = None
    fdir1: Vec3 | None = None
    material: str | None = None


@dataclass
class Plugin:
    """A Gazebo <plugin> block: its name, the library it loads (`libgazebo_ros_imu.so`), its parameters (child tag ->
    text) and the full XML. `link` is the link of the <gazebo reference> block it sits in (None: a model plugin)."""

    name: str
    filename: str
    params: dict[str, str]
    element: ET.Element = field(repr=False)
    link: str | None = None

    @classmethod
    def of(cls, el: ET.Element, link: str | None = None) -> Plugin:
        """The plugin of a <plugin> element."""
        params = {c.tag: (c.text or "").strip() for c in el if isinstance(c.tag, str)}
        return cls(el.get("name", ""), el.get("filename", "").strip(), params, el, link)


@dataclass
class Sensor:
    """A Gazebo <sensor> block attached to a link; `element` keeps the full XML for the sensor's own parser."""

    name: str
    type: str
    link: str
    pose: Origin
    update_rate: float
    element: ET.Element = field(repr=False)

    @property
    def plugins(self) -> list[Plugin]:
        """The <plugin> blocks inside the sensor (the ROS interface: gazebo_ros_laser, gazebo_ros_camera, ...)."""
        return [Plugin.of(el, self.link) for el in self.element.findall("plugin")]


@dataclass
class Link:
    """A URDF link."""

    name: str
    inertial: Inertial | None = None
    visuals: list[Shape] = field(default_factory=list)
    collisions: list[Shape] = field(default_factory=list)
    surface: Surface = field(default_factory=Surface)


@dataclass(frozen=True)
class Limit:
    """A URDF joint <limit>."""

    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0


@dataclass(frozen=True)
class Joint:
    """A URDF joint: fixed, continuous, revolute or prismatic."""

    name: str
    type: str
    parent: str
    child: str
    origin: Origin = Origin()
    axis: Vec3 = (1.0, 0.0, 0.0)
    limit: Limit | None = None

    @property
    def moves(self) -> bool:
        return self.type != "fixed"


@dataclass(frozen=True)
class Transmission:
    """A <transmission> block: which joint an actuator drives, through which hardware interface."""

    name: str
    joint: str
    actuator: str
    hardware_interface: str
    reduction: float


@dataclass
class Robot:
    """A whole robot description: links, joints, transmissions, gazebo sensors and model plugins (in file order)."""

    name: str
    links: dict[str, Link]
    joints: dict[str, Joint]
    transmissions: list[Transmission]
    sensors: list[Sensor]
    plugins: list[Plugin]
    urdf: str = field(repr=False, default="")
    materials: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    source: str = ""  # the file it was read from (errors name it; relative mesh paths start from its folder)

    @property
    def root(self) -> str:
        children = {j.child for j in self.joints.values()}
        roots = [name for name in self.links if name not in children]
        return roots[0]

    def joint_to(self, link: str) -> Joint | None:
        """The joint whose child is `link` (None for the root)."""
        for joint in self.joints.values():
            if joint.child == link:
                return joint
        return None

    def sensor(self, kind: str) -> Sensor | None:
        """The first Gazebo sensor of this type (ray, camera), or None if it is disabled."""
        return next((s for s in self.sensors if s.type == kind), None)


@overload
def _floats(text: str | None, n: Literal[1], where: str, default: tuple[float] | None = None) -> tuple[float]: ...
@overload
def _floats(text: str | None, n: Literal[3], where: str, default: Vec3 | None = None) -> Vec3: ...
@overload
def _floats(text: str | None, n: Literal[4], where: str, default: RGBA | None = None) -> RGBA: ...
@overload
def _floats(
    text: str | None, n: Literal[6], where: str, default: tuple[float, float, float, float, float, float] | None = None
) -> tuple[float, float, float, float, float, float]: ...
def _floats(text: str | None, n: int, where: str, default: tuple[float, ...] | None = None) -> tuple[float, ...]:
    """`n` numbers (the length of the tuple returned: 1, 3, 4 or 6), or `default` where `text` is None."""
    if text is None:
        if default is None:
            raise DescriptionError(f"{where}: missing value")
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise DescriptionError(f"{where}: '{text}' is not {n} numbers") from None
    if len(values) != n:
        raise DescriptionError(f"{where}: '{text}' is not {n} numbers")
    return values


def _origin(el: ET.Element | None, where: str) -> Origin:
    if el is None:
        return Origin()
    return Origin(
        _floats(el.get("xyz"), 3, f"{where} origin xyz", ZERO),
        _floats(el.get("rpy"), 3, f"{where} origin rpy", ZERO),
    )


def _geometry(el: ET.Element | None, where: str) -> Geometry:
    if el is None or len(el) == 0:
        raise DescriptionError(f"{where}: <geometry> is missing or empty")
    g = next(child for child in el if isinstance(child.tag, str))
    if g.tag == "box":
        return Geometry("box", _floats(g.get("size"), 3, f"{where} box size"))
    if g.tag == "cylinder":
        r, length = _floats(g.get("radius"), 1, f"{where} radius")[0], _floats(g.get("length"), 1, f"{where} length")[0]
        return Geometry("cylinder", (r, length, 0.0))
    if g.tag == "sphere":
        return Geometry("sphere", (_floats(g.get("radius"), 1, f"{where} radius")[0], 0.0, 0.0))
    if g.tag == "mesh":
        scale = _floats(g.get("scale"), 3, f"{where} mesh scale", (1.0, 1.0, 1.0))
        return Geometry("mesh", filename=g.get("filename", ""), scale=scale)
    raise DescriptionError(f"{where}: unsupported geometry <{g.tag}>")


def _rgba(el: ET.Element | None, materials: dict[str, RGBA]) -> RGBA | None:
    if el is None:
        return None
    color = el.find("color")
    if color is not None:
        return _color(el, color)
    return materials.get(el.get("name", ""))


def _color(el: ET.Element, color: ET.Element) -> RGBA:
    """The rgba of a <material> element `el` with a <color> child."""
    return _floats(color.get("rgba"), 4, f"material {el.get('name')} rgba")


def _tag_value(el: ET.Element, tag: str) -> str | None:
    """Gazebo tags come both as <mu1>1.0</mu1> and <mu1 value="1.0"/>."""
    child = el.find(tag)
    if child is None:
        return None
    return child.get("value", child.text)


def _surface(el: ET.Element, surface: Surface, where: str) -> None:
    for name in ("mu1", "mu2", "kp", "kd"):
        text = _tag_value(el, name)
        if text is not None:
            setattr(surface, name, _floats(text, 1, f"{where} <{name}>")[0])
    fdir = _tag_value(el, "fdir1")
    if fdir is not None:
        surface.fdir1 = _floats(fdir, 3, f"{where} <fdir1>")
    material = _tag_value(el, "material")
    if material is not None:
        surface.material = material.strip()


def _sensor(el: ET.Element, link: str, where: str) -> Sensor:
    name = el.get("name", "")
    pose = _floats(el.findtext("pose"), 6, f"{where} sensor {name} <pose>", (0.0,) * 6)
    rate = _floats(el.findtext("update_rate"), 1, f"{where} sensor {name} <update_rate>", (0.0,))[0]
    return Sensor(name, el.get("type", ""), link, Origin(pose[:3], pose[3:]), rate, el)


def parse_urdf(text: str, source: str = "<urdf>") -> Robot:
    """Parse URDF text; errors name `source` and the offending element."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise DescriptionError(f"{source}: malformed XML: {exc}") from None
    if root.tag != "robot":
        raise DescriptionError(f"{source}: root element is <{root.tag}>, expected <robot>")

    materials = {
        m.get("name", ""): _color(m, color) for m in root.findall("material") if (color := m.find("color")) is not None
    }
    links: dict[str, Link] = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise DescriptionError(f"{source}: a <link> has no name")
        where = f"{source}: link {name}"
        link = Link(name)
        inertial = el.find("inertial")
        if inertial is not None:
            mass_el, inertia_el = inertial.find("mass"), inertial.find("inertia")
            if mass_el is None or inertia_el is None:
                raise DescriptionError(f"{where}: <inertial> needs <mass> and <inertia>")
            mass = _floats(mass_el.get("value"), 1, f"{where} mass")[0]
            if mass <= 0 or mass != mass:
                raise DescriptionError(f"{where}: mass {mass} must be positive")
            ixx, iyy, izz, ixy, ixz, iyz = (
                _floats(inertia_el.get(k), 1, f"{where} inertia {k}", (0.0,))[0]
                for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
            )
            link.inertial = Inertial(mass, _origin(inertial.find("origin"), where), (ixx, iyy, izz, ixy, ixz, iyz))
        for vis in el.findall("visual"):
            link.visuals.append(
                Shape(
                    _geometry(vis.find("geometry"), f"{where} visual"),
                    _origin(vis.find("origin"), where),
                    _rgba(vis.find("material"), materials),
                )
            )
        for col in el.findall("collision"):
            link.collisions.append(
                Shape(_geometry(col.find("geometry"), f"{where} collision"), _origin(col.find("origin"), where))
            )
        links[name] = link

    joints: dict[str, Joint] = {}
    for el in root.findall("joint"):
        name, kind = el.get("name", ""), el.get("type", "")
        where = f"{source}: joint {name}"
        if kind not in ("fixed", "continuous", "revolute", "prismatic"):
            raise DescriptionError(f"{where}: unsupported joint type '{kind}'")
        parent, child = el.find("parent"), el.find("child")
        if parent is None or child is None:
            raise DescriptionError(f"{where}: needs <parent> and <child>")
        for end in (parent.get("link"), child.get("link")):
            if end not in links:
                raise DescriptionError(f"{where}: link '{end}' is not defined")
        axis_el = el.find("axis")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else None, 3, f"{where} axis", (1.0, 0.0, 0.0))
        limit_el = el.find("limit")
        limit = None
        if limit_el is not None:
            limit = Limit(
                *(
                    _floats(limit_el.get(k), 1, f"{where} limit {k}", (0.0,))[0]
                    for k in ("lower", "upper", "effort", "velocity")
                )
            )
        elif kind in ("revolute", "prismatic"):
            raise DescriptionError(f"{where}: a {kind} joint needs a <limit>")
        joints[name] = Joint(
            name, kind, parent.get("link", ""), child.get("link", ""), _origin(el.find("origin"), where), axis, limit
        )

    transmissions = []
    for el in root.findall("transmission"):
        joint_el, actuator_el = el.find("joint"), el.find("actuator")
        where = f"{source}: transmission {el.get('name')}"
        if joint_el is None or actuator_el is None:
            raise DescriptionError(f"{where}: needs <joint> and <actuator>")
        if joint_el.get("name") not in joints:
            raise DescriptionError(f"{where}: joint '{joint_el.get('name')}' is not defined")
        reduction = _floats(actuator_el.findtext("mechanicalReduction"), 1, f"{where} mechanicalReduction", (1.0,))[0]
        interface = (joint_el.findtext("hardwareInterface") or "").strip()
        transmissions.append(
            Transmission(
                el.get("name", ""), joint_el.get("name", ""), actuator_el.get("name", ""), interface, reduction
            )
        )

    sensors: list[Sensor] = []
    plugins: list[Plugin] = []
    for el in root.findall("gazebo"):
        ref = el.get("reference")
        if ref is None:
            plugins += [Plugin.of(plugin) for plugin in el.findall("plugin")]
            continue
        if ref not in links:
            raise DescriptionError(f"{source}: <gazebo reference='{ref}'> names no link")
        _surface(el, links[ref].surface, f"{source}: gazebo {ref}")
        sensors += [_sensor(s, ref, f"{source}: gazebo {ref}") for s in el.findall("sensor")]
        plugins += [Plugin.of(plugin, ref) for plugin in el.findall("plugin")]

    robot = Robot(
        root.get("name", ""),
        links,
        joints,
        transmissions,
        sensors,
        plugins,
        text,
        materials,
        source,
    )
    roots = [n for n in links if robot.joint_to(n) is None]
    if len(roots) != 1:
        raise DescriptionError(f"{source}: the links form {len(roots)} trees ({', '.join(roots)}), expected one")
    return robot
