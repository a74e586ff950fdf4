"""`racecar-sim describe`: the expanded URDF, or a table of links, joints and key dimensions."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from racecar_sim.cli.args import xacro_arg
from racecar_sim.control.profiles import load_profile, profile_names
from racecar_sim.description import DEFAULT_XACRO, VehicleGeometry, load_robot
from racecar_sim.description.urdf import Robot


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("describe", help="print the robot description (a table, or --urdf for the expanded URDF)")
    p.add_argument("--urdf", action="store_true", help="print the expanded URDF instead of the table")
    p.add_argument("--profile", default="seed", choices=profile_names(), help="driving profile (sets xacro arguments)")
    p.add_argument(
        "--xacro", default=str(DEFAULT_XACRO), help="xacro or URDF file (default: the shipped racecar.xacro)"
    )
    p.add_argument(
        "--arg",
        dest="xacro_args",
        type=xacro_arg,
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="xacro argument, repeatable",
    )


def columns(header: Sequence[str], rows: Sequence[Sequence[str]], right: Sequence[int] = ()) -> list[str]:
    """Rows under a header, each column as wide as its widest cell (two spaces between), the columns in `right`
    right-aligned; the last column is not padded."""
    widths = [max(len(row[i]) for row in (header, *rows)) for i in range(len(header))]

    def line(cells: Sequence[str]) -> str:
        padded = [c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True))]
        return "  ".join(padded).rstrip()

    return [line(header), *map(line, rows)]


def table(robot: Robot) -> str:
    """A plain-text table of the robot: links, joints, limits and derived dimensions."""
    lines = [
        f"robot {robot.name}: {len(robot.links)} links, {len(robot.joints)} joints, "
        f"{len(robot.transmissions)} transmissions",
        "",
    ]
    link_rows = []
    for link in robot.links.values():
        mass = f"{link.inertial.mass:.5g}" if link.inertial else "-"
        shapes = ", ".join(
            f"{c.geometry.kind} {' '.join(f'{v:g}' for v in c.geometry.size if v)}" for c in link.collisions
        )
        link_rows.append((link.name, mass, shapes or "-"))
    lines += columns(("LINK", "MASS (kg)", "COLLISION"), link_rows, right=(1,))
    joint_rows = []
    for j in robot.joints.values():
        limits = "-"
        if j.limit:
            bounds = f"[{j.limit.lower:g}, {j.limit.upper:g}] rad, " if j.type == "revolute" else ""
            limits = f"{bounds}effort {j.limit.effort:g} N m, velocity {j.limit.velocity:g} rad/s"
        joint_rows.append((j.name, j.type, f"{j.parent} -> {j.child}", limits))
    lines += ["", *columns(("JOINT", "TYPE", "PARENT -> CHILD", "LIMITS"), joint_rows)]
    g = VehicleGeometry.from_robot(robot)
    lines += [
        "",
        f"wheelbase {g.wheelbase:.4f} m   kingpin track {g.kingpin_track:.4f} m   tyre track {g.tyre_track:.4f} m",
        f"wheel radius {g.wheel_radius:g} m   width {g.wheel_width:g} m   total mass {g.total_mass:.5f} kg",
    ]
    for s in robot.sensors:
        lines.append(f"sensor {s.name} ({s.type}) on {s.link}, {s.update_rate:g} Hz")
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    xacro_args = {**load_profile(args.profile).xacro_args, **dict(args.xacro_args)}
    robot = load_robot(args.xacro, xacro_args)
    print(robot.urdf if args.urdf else table(robot))
    return 0
