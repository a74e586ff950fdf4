"""`--topic-map` (run, teleop, launch): the names a ROS bridge gives the sim's topics and frames on ROS.

`--topic-map f1tenth` gives f1tenth_gym_ros's (bridges/f1tenth): /scan, /ego_racecar/odom, /drive, /map,
/initialpose, frames map -> ego_racecar/base_link, opponents as /opp_racecar/odom, /opp_drive, /opp_scan. It applies
to the bridges only (--ros, --ros2): the bus and the recording keep the sim's names. With it, `run` leaves the ego car
to /drive (no driver of the sim drives it), and gives the opponents the run's --driver only when one is given.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from racecar_sim.bridges.topic_map import IDENTITY, TOPIC_MAPS, TopicMap, make_topic_map
from racecar_sim.core.errors import ConfigError

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

F1TENTH = "f1tenth"
_BUILT = "_topic_map_built"  # the map made for the run (its world nodes are started once, whichever bridges use it)


def add_topic_map_argument(parser: argparse.ArgumentParser) -> None:
    """--topic-map NAME."""
    parser.add_argument(
        "--topic-map",
        choices=TOPIC_MAPS,
        help="with --ros or --ros2: the names on ROS. f1tenth: f1tenth_gym_ros's topics and frames (/scan, /drive, "
        "/ego_racecar/odom, /map, /initialpose, opponents as /opp_racecar/odom, /opp_drive, /opp_scan); the "
        "recording keeps the sim's names",
    )


def check_topic_map(args: argparse.Namespace) -> None:
    """ConfigError (one line, exit code 2) for --topic-map without a bridge to apply it to."""
    name = getattr(args, "topic_map", None)
    if name is not None and not (getattr(args, "ros", False) or getattr(args, "ros2", False)):
        raise ConfigError(f"--topic-map {name} names the topics on ROS: give it with --ros or --ros2")


def topic_map_of(args: argparse.Namespace, sim: Simulator) -> TopicMap:
    """The run's topic map (IDENTITY without --topic-map), made once per run: every bridge of the run shares it."""
    name = getattr(args, "topic_map", None)
    if name is None:
        return IDENTITY
    built: TopicMap | None = getattr(args, _BUILT, None)
    if built is None:
        built = make_topic_map(name, sim)
        setattr(args, _BUILT, built)
    return built


def sim_drives(args: argparse.Namespace, index: int, driver_given: bool) -> bool:
    """Whether `run`'s driver drives car `index`: under --topic-map f1tenth the ego car (0) is driven by /drive and
    the opponents by /opp_drive unless --driver was given."""
    if getattr(args, "topic_map", None) != F1TENTH:
        return True
    return index > 0 and driver_given
