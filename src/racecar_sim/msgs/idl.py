"""Parser for the ROS 2 ``.msg`` and ``.srv`` files shipped in ``msgs/definitions``.

A message type is named the ROS 2 way, ``pkg/msg/Name``; ``pkg/Name`` is accepted
everywhere and normalised. A service ``pkg/srv/Name`` is two messages, its parts ``pkg/srv/Name_Request`` and
``pkg/srv/Name_Response`` (the lines before and after the ``---`` of its file). Parsed definitions and schema texts
are cached.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.abc import Traversable

PRIMITIVE_TYPES = frozenset(
    {
        "bool", "byte", "char",
        "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
        "float32", "float64", "string",
    }
)  # fmt: skip

SCHEMA_SEPARATOR = "=" * 80
SERVICE_PARTS = ("Request", "Response")

_ARRAY_RE = re.compile(r"^(?P<base>[^\[\]]+)(?:\[(?P<bound><=)?(?P<size>\d*)\])?$")
_CONSTANT_RE = re.compile(r"^(?P<name>[A-Za-z]\w*)\s*=\s*(?P<value>.*)$")
_NAME_RE = re.compile(r"^[A-Za-z]\w*$")


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """One field of a message definition.

    Attributes:
        name: Field name as in the ``.msg`` file.
        type: A primitive name (``float32``, ``string``) or a full message type
            (``geometry_msgs/msg/Point``).
        is_array: True for ``T[]``, ``T[<=N]`` and ``T[N]``.
        size: ``N`` for a fixed-size array ``T[N]``, otherwise None.
        attr: The message class's attribute that holds the value: ``name`` unless given; None for a field
            that is on a wire only (ROS 1's ``Header.seq``).
        default: The default value's text after the name (``float64 w 1``), or None.
    """

    name: str
    type: str
    is_array: bool = False
    size: int | None = None
    attr: str | None = ""
    default: str | None = None

    def __post_init__(self) -> None:
        if self.attr == "":
            object.__setattr__(self, "attr", self.name)

    @property
    def is_primitive(self) -> bool:
        """Whether the element type is a primitive (not a nested message)."""
        return self.type in PRIMITIVE_TYPES


@dataclass(frozen=True, slots=True)
class MsgSpec:
    """A parsed message definition: its fields in wire order, its constants and its text."""

    msgtype: str
    fields: tuple[FieldSpec, ...]
    constants: tuple[tuple[str, str, str], ...]
    text: str


def normalize_msgtype(msgtype: str) -> str:
    """Return ``pkg/msg/Name`` for ``pkg/msg/Name`` or ``pkg/Name``.

    Raises:
        ValueError: The name has neither form.
    """
    parts = msgtype.split("/")
    if len(parts) == 2 and all(parts):
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 3 and parts[1] == "msg" and parts[0] and parts[2]:
        return msgtype
    raise ValueError(f"not a ROS message type name: {msgtype!r} (expected 'pkg/msg/Name')")


def short_msgtype(msgtype: str) -> str:
    """Return ``pkg/Name``, the spelling used after ``MSG:`` in schema texts."""
    pkg, _, name = normalize_msgtype(msgtype).split("/")
    return f"{pkg}/{name}"


def _resolve_type(base: str, package: str) -> str:
    if base in PRIMITIVE_TYPES:
        return base
    if base.startswith(("string<=", "wstring")):
        if base.startswith("wstring"):
            raise ValueError("wstring is not supported")
        return "string"
    if "/" in base:
        return normalize_msgtype(base)
    if base == "Header":
        return "std_msgs/msg/Header"
    return f"{package}/msg/{base}"


def _strip_comment(line: str) -> str:
    # A string constant may contain '#', so only cut comments outside one.
    head = line.split(None, 1)
    if head and head[0].startswith("string") and "=" in line:
        return line.strip()
    return line.split("#", 1)[0].strip()


def parse_msg(text: str, msgtype: str) -> MsgSpec:
    """Parse ``.msg`` text for ``msgtype``; relative type names resolve within its package.

    Raises:
        ValueError: A line is malformed, naming the type and the line.
    """
    msgtype = msgtype if is_service_part(msgtype) else normalize_msgtype(msgtype)
    package = msgtype.split("/", 1)[0]
    fields: list[FieldSpec] = []
    constants: list[tuple[str, str, str]] = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = _strip_comment(raw)
        if not line:
            continue
        try:
            type_token, rest = line.split(None, 1)
        except ValueError:
            raise ValueError(f"{msgtype} line {lineno}: expected 'TYPE NAME': {raw!r}") from None
        if const := _CONSTANT_RE.match(rest):
            constants.append((type_token, const["name"], const["value"].strip()))
            continue
        name, *default = rest.split(None, 1)  # anything after the name is a default value
        match = _ARRAY_RE.match(type_token)
        if match is None or not _NAME_RE.match(name):
            raise ValueError(f"{msgtype} line {lineno}: cannot parse {raw!r}")
        try:
            resolved = _resolve_type(match["base"], package)
        except ValueError as exc:
            raise ValueError(f"{msgtype} line {lineno}: {exc}") from None
        is_array = match.group(0) != match["base"]
        fixed = is_array and not match["bound"] and match["size"] != ""
        size = int(match["size"]) if fixed else None
        fields.append(FieldSpec(name, resolved, is_array, size, default=default[0].strip() if default else None))
    return MsgSpec(msgtype, tuple(fields), tuple(constants), text.rstrip() + "\n")


def _definitions_root() -> Traversable:
    return resources.files("racecar_sim.msgs").joinpath("definitions")


def is_service_part(msgtype: str) -> bool:
    """Whether ``msgtype`` names a service's request or response (``pkg/srv/Name_Request``)."""
    parts = msgtype.split("/")
    return len(parts) == 3 and parts[1] == "srv" and parts[2].rpartition("_")[2] in SERVICE_PARTS


@cache
def get_spec(msgtype: str) -> MsgSpec:
    """Load and parse the shipped definition of ``msgtype`` (a message, or a service part).

    Raises:
        KeyError: No ``.msg`` (or ``.srv``) file for that type is shipped.
    """
    if is_service_part(msgtype):
        return _service_part(msgtype)
    msgtype = normalize_msgtype(msgtype)
    pkg, _, name = msgtype.split("/")
    path = _definitions_root().joinpath(pkg).joinpath("msg").joinpath(f"{name}.msg")
    if not path.is_file():
        raise KeyError(f"no definition for message type {msgtype!r}")
    return parse_msg(path.read_text(encoding="utf-8"), msgtype)


def _service_part(parttype: str) -> MsgSpec:
    pkg, _, name = parttype.split("/")
    service, _, part = name.rpartition("_")
    path = _definitions_root().joinpath(pkg).joinpath("srv").joinpath(f"{service}.srv")
    if not path.is_file():
        raise KeyError(f"no definition for service {pkg}/srv/{service!r}")
    lines = path.read_text(encoding="utf-8").splitlines()
    cut = next((i for i, line in enumerate(lines) if line.strip() == "---"), None)
    if cut is None:
        raise ValueError(f"{pkg}/srv/{service}: no '---' between the request and the response")
    return parse_msg("\n".join(lines[:cut] if part == "Request" else lines[cut + 1 :]), parttype)


def available_srvtypes() -> tuple[str, ...]:
    """All service types with a shipped ``.srv`` file (``pkg/srv/Name``), sorted."""
    return listed_definitions("srv")


def available_msgtypes() -> tuple[str, ...]:
    """All message types with a shipped ``.msg`` file, sorted."""
    return listed_definitions("msg")


@cache
def listed_definitions(kind: str) -> tuple[str, ...]:
    """The shipped definitions of a kind (``msg`` or ``srv``) as ``pkg/kind/Name``, sorted; read once a process (they
    are the package's own files): a message module's lookups, some thirty as a run starts, would otherwise each list
    every package's folder again (25-40 ms of a walker run's start-up)."""
    found = []
    for pkg_dir in _definitions_root().iterdir():
        kind_dir = pkg_dir.joinpath(kind)
        if pkg_dir.is_dir() and kind_dir.is_dir():
            names = [f.name[: -len(kind) - 1] for f in kind_dir.iterdir() if f.name.endswith(f".{kind}")]
            found += [f"{pkg_dir.name}/{kind}/{name}" for name in names]
    return tuple(sorted(found))


@cache
def dependencies(msgtype: str) -> tuple[str, ...]:
    """Nested message types of ``msgtype``, transitively, each once, depth-first in field order."""
    seen: dict[str, None] = {}

    def visit(current: str) -> None:
        for spec in get_spec(current).fields:
            if not spec.is_primitive and spec.type not in seen:
                seen[spec.type] = None
                visit(spec.type)

    visit(normalize_msgtype(msgtype))
    return tuple(seen)


@cache
def schema_text(msgtype: str) -> str:
    """The MCAP ``ros2msg`` schema: the definition, then each dependency after a separator.

    Each dependency block is a line of 80 ``=``, a line ``MSG: pkg/Name`` and its
    definition, the concatenated form rosbag2, rosbags, mcap-ros2 and Foxglove read.
    """
    parts = [get_spec(msgtype).text]
    for dep in dependencies(msgtype):
        parts.append(f"{SCHEMA_SEPARATOR}\nMSG: {short_msgtype(dep)}\n{get_spec(dep).text}")
    return "".join(parts)
