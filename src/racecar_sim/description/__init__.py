"""The robot description: xacro files (the source of truth), their expansion and the parsed URDF."""

from racecar_sim.description.urdf import Geometry, Inertial, Joint, Link, Robot, Sensor, Transmission, parse_urdf
from racecar_sim.description.vehicle import VehicleGeometry
from racecar_sim.description.xacro_loader import DEFAULT_XACRO, expand_xacro, load_robot, package_path

__all__ = [
    "DEFAULT_XACRO",
    "Geometry",
    "Inertial",
    "Joint",
    "Link",
    "Robot",
    "Sensor",
    "Transmission",
    "VehicleGeometry",
    "expand_xacro",
    "load_robot",
    "package_path",
    "parse_urdf",
]
