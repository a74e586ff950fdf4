"""What a bridge calls its topics and frames on the other side: a topic map, applied at the bridge's edge only.

The bus keeps the sim's own names (and so does every recording); a bridge asks its map, for each topic, the name
it has on ROS (`ros_name`, None: not bridged) and, for a topic from ROS, the bus topic it enters on (`sim_name`,
None: not taken). Messages cross through `to_ros` / `from_ros`, which rename TF frames (header.frame_id,
child_frame_id, every transform of a TFMessage) in a copy: the message on the bus is never changed, because the
recorder and every other tap hold the same object.

`IDENTITY` keeps every name (the default of every bridge); bridges/f1tenth.py is the F1TENTH map
(`--topic-map f1tenth`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from racecar_sim.bus import BusPort
from racecar_sim.core.errors import ConfigError
from racecar_sim.msgs.fields import message_fields

if TYPE_CHECKING:
    from racecar_sim.runtime import Simulator

FRAME_FIELDS = ("frame_id", "child_frame_id")  # the fields that name a TF frame, wherever they are nested


class TopicMap(Protocol):
    """Topic and frame names on the bridged side."""

    name: str

    def ros_name(self, sim_topic: str) -> str | None:
        """The topic's name on ROS, or None to leave it unbridged."""
        ...

    def sim_name(self, ros_topic: str) -> str | None:
        """The bus topic a message from ROS on `ros_topic` is published on, or None if the sim does not take it."""
        ...

    def to_ros(self, sim_topic: str, msg: Any) -> Any:
        """The message as ROS sees it (frames renamed): `msg` itself when nothing changes, else a copy."""
        ...

    def from_ros(self, sim_topic: str, msg: Any) -> Any:
        """A message from ROS as the bus takes it (frames named back): `msg` itself when nothing changes."""
        ...

    def qos_name(self, ros_topic: str) -> str | None:
        """The QoS profile (bridges/ros2/qos.py's name) the imitated stack publishes `ros_topic` with, or None for
        the sim's own choice."""
        ...


class IdentityMap:
    """Every topic and frame keeps its sim name."""

    name = "identity"

    def ros_name(self, sim_topic: str) -> str | None:
        """The same name."""
        return sim_topic

    def sim_name(self, ros_topic: str) -> str | None:
        """The same name."""
        return ros_topic

    def to_ros(self, sim_topic: str, msg: Any) -> Any:
        """The message itself."""
        return msg

    def from_ros(self, sim_topic: str, msg: Any) -> Any:
        """The message itself."""
        return msg

    def qos_name(self, ros_topic: str) -> str | None:
        """The sim's own choice."""
        return None


IDENTITY: TopicMap = IdentityMap()
TOPIC_MAPS = ("identity", "f1tenth")  # what --topic-map takes


def make_topic_map(name: str, sim: Simulator) -> TopicMap:
    """The topic map called `name` for `sim` (one of TOPIC_MAPS); "f1tenth" also starts its world nodes on the bus
    (/map, /initialpose: bridges/f1tenth)."""
    if name == "identity":
        return IDENTITY
    if name == "f1tenth":
        from racecar_sim.bridges.f1tenth import F1tenthInterface

        return F1tenthInterface(sim)
    raise ConfigError(f"--topic-map {name!r} is not one of {', '.join(TOPIC_MAPS)}")


class MappedBus:
    """The bus as a bridge shows it under `topic_map`, without a bridge: publish and subscribe by the names on ROS,
    with frames renamed both ways, in-process (a node written against F1TENTH's names, or a test of the map)."""

    def __init__(self, bus: BusPort, topic_map: TopicMap) -> None:
        self.bus, self.topic_map = bus, topic_map

    def publish(self, ros_topic: str, msg: Any) -> None:
        """Publish as a ROS node would on `ros_topic`: on the bus topic it enters on (nothing if the sim takes none)."""
        sim_topic = self.topic_map.sim_name(ros_topic)
        if sim_topic is not None:
            self.bus.publish(sim_topic, self.topic_map.from_ros(sim_topic, msg))

    def subscribe(self, ros_topic: str, callback: Callable[[Any], None]) -> Any:
        """Call `callback(msg)` with each message a ROS subscriber of `ros_topic` would get (None if none would)."""
        sim_topic = self.topic_map.sim_name(ros_topic)
        if sim_topic is None or self.topic_map.ros_name(sim_topic) != ros_topic:
            return None
        to_ros = self.topic_map.to_ros
        return self.bus.subscribe(sim_topic, lambda msg: callback(to_ros(sim_topic, msg)))


_FRAME_PATHS: dict[str, tuple[tuple[str, bool], ...]] = {}  # msgtype -> (attribute, is an array) that may name a frame


def _frame_paths(msgtype: str) -> tuple[tuple[str, bool], ...]:
    """The attributes of a message type that name a frame, or hold messages (one or an array) that may (the field
    model of msgs/fields.py; a type without a definition has none)."""
    paths = _FRAME_PATHS.get(msgtype)
    if paths is None:
        _FRAME_PATHS[msgtype] = ()  # no type holds itself; this also ends the recursion
        try:
            specs = message_fields(msgtype)
        except KeyError:
            specs = ()
        paths = tuple(
            (spec.attr, spec.is_array)
            for spec in specs
            if spec.attr is not None
            and (
                (spec.name in FRAME_FIELDS and spec.type == "string" and not spec.is_array)
                or (not spec.is_primitive and _frame_paths(spec.type))
            )
        )
        _FRAME_PATHS[msgtype] = paths
    return paths


def rename_frames(msg: Any, rename: Callable[[str], str]) -> Any:
    """`msg` with every TF frame name (header.frame_id, child_frame_id, nested and in arrays) passed through
    `rename`: the message itself when no name changes, else a copy along the changed paths (the rest is shared)."""
    msgtype = getattr(msg, "__msgtype__", None)
    if not isinstance(msgtype, str):
        return msg
    changes: dict[str, Any] = {}
    for attr, is_array in _frame_paths(msgtype):
        value = getattr(msg, attr)
        new: Any
        if isinstance(value, str):
            new = rename(value)
            if new == value:
                continue
        elif is_array:
            items = [rename_frames(item, rename) for item in value]
            if all(a is b for a, b in zip(items, value)):
                continue
            new = items
        else:
            new = rename_frames(value, rename)
            if new is value:
                continue
        changes[attr] = new
    return dataclasses.replace(msg, **changes) if changes else msg
