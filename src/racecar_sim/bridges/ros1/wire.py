"""The ROS 1 wire format (what rospy, roscpp and rosbag 1 put on the wire) for the sim's message classes.

The classes in racecar_sim.msgs are ROS 2 shaped; ROS 1 lays the same data out differently: little-endian with
no alignment, a uint32 length before every string and variable-length array, strings without a terminating NUL,
`std_msgs/Header` starting with a uint32 `seq`, `time` as uint32 secs + uint32 nsecs and `duration` as int32 secs
+ int32 nsecs. The layout of each type is the messages' field model (msgs/fields.py, the one msgs/cdr.py compiles
from: the ROS 2 definitions, whose fields are those of ROS 1 in the same order for every type the sim uses) with
these differences applied, all in `fields` below. A service part has no ROS 2 definition: its layout is its half of
the ROS 1 `.srv` shipped in definitions/, parsed into the same model, its fields mapped onto the class's attributes
by name, case-insensitively.

As in msgs/cdr.py the encoder of each type is compiled once into a flat tuple of closures: nested messages
flattened into dotted attribute paths, runs of scalars packed by one precompiled struct, numeric arrays through
numpy. md5sums and message texts are not computed here: rospy takes them from the real genpy classes.
"""

from __future__ import annotations

import dataclasses
import importlib
import re
import struct
from collections.abc import Callable, Iterator
from functools import cache
from importlib import resources
from operator import attrgetter
from typing import Any

import numpy as np

from racecar_sim.msgs.fields import DTYPES, SCALARS, leaves, message_fields
from racecar_sim.msgs.idl import FieldSpec, normalize_msgtype, parse_msg
from racecar_sim.msgs.registry import message_class

TIME = "builtin_interfaces/msg/Time"
DURATION = "builtin_interfaces/msg/Duration"
HEADER = "std_msgs/msg/Header"
SEQ = FieldSpec("seq", "uint32", attr=None)
"""ROS 1's Header.seq, on the wire only: the top-level header's is the publisher's count, any other is 0."""
_SCALARS = {name: code for name, (code, _) in SCALARS.items()} | {"byte": "b"}  # ROS 1's byte is an int8
_DTYPES = DTYPES | {"byte": np.dtype(np.int8)}
_BYTE_ARRAYS = frozenset({"uint8", "char"})
_U32 = struct.Struct("<I")
_TIME_TOKEN = re.compile(r"^(\s*)(time|duration)(?=[\s\[])", re.MULTILINE)


# --- names and classes ------------------------------------------------------------------------------------------
def type_of(cls: type) -> str:
    """The type name of a sim class: `pkg/msg/Name` for a message, `pkg/srv/Name_Request|_Response` for a service
    part."""
    msgtype = getattr(cls, "__msgtype__", None)
    if isinstance(msgtype, str):
        return msgtype
    srvtype = getattr(cls, "__srvtype__", None)
    if isinstance(srvtype, str):
        return f"{srvtype}_{'Request' if cls.__name__.endswith('Request') else 'Response'}"
    raise TypeError(f"not a ROS message class: {cls.__name__}")


def ros1_name(msgtype: str) -> str:
    """`pkg/msg/Name` or `pkg/srv/Name` -> the ROS 1 spelling `pkg/Name`."""
    parts = msgtype.split("/")
    return f"{parts[0]}/{parts[-1]}"


@cache
def sim_class(msgtype: str) -> type:
    """The sim's class of a message type or of a service part (`gazebo_msgs/srv/GetModelState_Request`)."""
    pkg, kind, name = msgtype.split("/") if msgtype.count("/") == 2 else normalize_msgtype(msgtype).split("/")
    if kind != "srv":
        return message_class(f"{pkg}/msg/{name}")
    service, _, part = name.rpartition("_")
    cls = getattr(importlib.import_module(f"racecar_sim.msgs.{pkg}"), f"{service}{part}", None)
    if not isinstance(cls, type):
        raise KeyError(f"no class for service part {msgtype!r}")
    return cls


def service_classes(srvtype: str) -> tuple[type, type]:
    """(request class, response class) of `pkg/srv/Name`."""
    return sim_class(f"{srvtype}_Request"), sim_class(f"{srvtype}_Response")


# --- layouts -----------------------------------------------------------------------------------------------------
def definitions_root() -> Any:
    """The ROS 1 `.msg`/`.srv` files shipped with the bridge (one folder per package)."""
    return resources.files("racecar_sim.bridges.ros1").joinpath("definitions")


@cache
def fields(msgtype: str) -> tuple[FieldSpec, ...]:
    """The ROS 1 layout of a message type or service part: the field model with ROS 1's differences.

    `std_msgs/Header` starts with `SEQ`; ROS 1's time is two uint32 and its duration two int32 (ROS 2's are an
    int32 and a uint32); a service part is laid out from its ROS 1 `.srv`. Every other message has the model's very
    fields: the ROS 1 `.msg` files in definitions/ are genpy's input and hold the same fields (tests check it).
    """
    if "/srv/" in msgtype:
        return _service_part(msgtype)
    model = message_fields(msgtype)
    if msgtype == HEADER:
        return (SEQ, *model)
    if msgtype in (TIME, DURATION):  # ROS 2's are int32 sec + uint32 nanosec
        return tuple(dataclasses.replace(f, type="uint32" if msgtype == TIME else "int32") for f in model)
    return model


def _service_part(msgtype: str) -> tuple[FieldSpec, ...]:
    pkg, _, name = msgtype.split("/")
    service, _, part = name.rpartition("_")
    path = definitions_root().joinpath(pkg, "srv", f"{service}.srv")
    if not path.is_file():
        raise KeyError(f"no ROS 1 definition for service {pkg}/{service}")
    lines = path.read_text(encoding="utf-8").splitlines()
    cut = next(i for i, line in enumerate(lines) if line.strip() == "---")
    text = "\n".join(lines[:cut] if part == "Request" else lines[cut + 1 :])
    # ROS 1's builtin time and duration are builtin_interfaces' Time and Duration in the sim's classes
    text = _TIME_TOKEN.sub(
        lambda m: m[1] + ("builtin_interfaces/Time" if m[2] == "time" else "builtin_interfaces/Duration"), text
    )
    attrs = {f.name.lower(): f.name for f in dataclasses.fields(sim_class(msgtype))}
    specs = parse_msg(text, f"{pkg}/{name}").fields
    return tuple(dataclasses.replace(s, attr=attrs.get(s.name.lower())) for s in specs)


# --- encoding ----------------------------------------------------------------------------------------------------
Op = Callable[[Any, int, list[Any]], None]
"""`op(msg, seq, out)`: append the bytes of one or more fields to `out`; `seq` is the top-level header's."""

_ENCODERS: dict[type, Callable[[Any, int, list[Any]], None]] = {}


def serialize(msg: Any, seq: int = 0) -> bytes:
    """ROS 1 bytes of a message instance (or a service request or response); `seq` goes into its header."""
    out: list[Any] = []
    encoder(type(msg))(msg, seq, out)
    return b"".join(out)


def encoder(cls: type) -> Callable[[Any, int, list[Any]], None]:
    """The compiled encoder of a sim class."""
    try:
        return _ENCODERS[cls]
    except KeyError:
        return _ENCODERS.setdefault(cls, _compile(type_of(cls)))


def _leaves(msgtype: str) -> Iterator[tuple[str, FieldSpec, bool]]:
    """(attribute path, field, whether it is the top-level header's seq) in wire order, nested messages flattened."""
    for path, f in leaves(msgtype, fields):
        if f.attr is None and (f.type not in _SCALARS or f.is_array):
            raise TypeError(f"{msgtype}: the sim's class has no field for ROS 1 field {path} of type {f.type}")
        yield path, f, f.attr is None and path == "header.seq"


@cache
def _compile(msgtype: str) -> Callable[[Any, int, list[Any]], None]:
    ops: list[Op] = []
    run: list[tuple[str | None, str, bool]] = []
    for path, f, is_seq in _leaves(msgtype):
        if f.type in _SCALARS and not f.is_array:
            run.append((None if f.attr is None else path, f.type, is_seq))  # None: on the wire only
            continue
        if run:
            ops.append(_scalar_run(run))
            run = []
        ops.append(_field_op(msgtype, path, f))
    if run:
        ops.append(_scalar_run(run))
    op_tuple = tuple(ops)

    def encode(msg: Any, seq: int, out: list[Any]) -> None:
        for op in op_tuple:
            op(msg, seq, out)

    return encode


def _scalar_run(run: list[tuple[str | None, str, bool]]) -> Op:
    packer = struct.Struct("<" + "".join(_SCALARS[t] for _, t, _ in run))
    paths = [path for path, _, _ in run if path is not None]
    if len(paths) == len(run):
        getter = attrgetter(*paths)
        if len(run) == 1:
            return lambda msg, seq, out: out.append(packer.pack(getter(msg)))
        return lambda msg, seq, out: out.append(packer.pack(*getter(msg)))
    if run[0][2] and len(paths) == len(run) - 1 and paths:  # a header: its seq, then fields of the message
        rest = attrgetter(*paths)
        if len(paths) == 1:
            return lambda msg, seq, out: out.append(packer.pack(seq, rest(msg)))
        return lambda msg, seq, out: out.append(packer.pack(seq, *rest(msg)))
    getters = [
        (lambda msg, seq: seq)
        if is_seq
        else (lambda msg, seq: 0)
        if path is None
        else (lambda msg, seq, g=attrgetter(path): g(msg))
        for path, _, is_seq in run
    ]
    return lambda msg, seq, out: out.append(packer.pack(*[g(msg, seq) for g in getters]))


def _field_op(msgtype: str, path: str, f: FieldSpec) -> Op:
    get = attrgetter(path)
    if not f.is_array:  # a string
        return lambda msg, seq, out: _put_str(get(msg), out)
    prefix: Callable[[int], bytes] = _U32.pack if f.size is None else _no_count
    if f.type in _BYTE_ARRAYS:

        def put_bytes(msg: Any, seq: int, out: list[Any]) -> None:
            data = _as_bytes(get(msg))
            _check(msgtype, path, len(data), f.size)
            out.append(prefix(len(data)))
            out.append(data)

        return put_bytes
    if f.type in _SCALARS:
        dtype = _DTYPES[f.type]

        def put_array(msg: Any, seq: int, out: list[Any]) -> None:
            array = np.ascontiguousarray(get(msg), dtype=dtype).reshape(-1)
            _check(msgtype, path, array.size, f.size)
            out.append(prefix(array.size))
            out.append(array)

        return put_array
    if f.type == "string":

        def put_strings(msg: Any, seq: int, out: list[Any]) -> None:
            items = get(msg)
            _check(msgtype, path, len(items), f.size)
            out.append(prefix(len(items)))
            for item in items:
                _put_str(item, out)

        return put_strings

    def put_messages(msg: Any, seq: int, out: list[Any]) -> None:
        items = get(msg)
        _check(msgtype, path, len(items), f.size)
        out.append(prefix(len(items)))
        last, encode = None, None
        for item in items:  # the items of an array share their class: its encoder looked up once
            if type(item) is not last:
                last = type(item)
                encode = encoder(last)
            encode(item, 0, out)  # type: ignore[misc]

    return put_messages


def _no_count(count: int) -> bytes:
    return b""  # a fixed-size array has no length on the wire


_STRINGS: dict[str, bytes] = {}  # short strings (frame ids, names) with their length before them, as on the wire
_STRINGS_MAX = 4096  # strings kept
_STRING_CACHED = 256  # characters at most of a string kept


def _put_str(value: str, out: list[Any]) -> None:
    framed = _STRINGS.get(value)
    if framed is None:
        data = value.encode()
        framed = _U32.pack(len(data)) + data
        if len(value) <= _STRING_CACHED and len(_STRINGS) < _STRINGS_MAX and type(value) is str:
            _STRINGS[value] = framed
    out.append(framed)


def _as_bytes(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return np.ascontiguousarray(value, dtype=np.uint8).reshape(-1).data.cast("B")
    if isinstance(value, (bytes, bytearray, memoryview)):
        return value
    return bytes(value)


def _check(msgtype: str, path: str, count: int, size: int | None) -> None:
    if size is not None and count != size:
        raise ValueError(f"{msgtype}: field '{path}': expected {size} elements, got {count}")


# --- decoding (commands and service calls from ROS: small, not performance critical) -----------------------------
def deserialize(data: bytes | bytearray | memoryview, msgtype: str | type) -> Any:
    """An instance of the sim's class from ROS 1 bytes; `msgtype` is a type name (`pkg/msg/Name`, `pkg/Name`,
    `pkg/srv/Name_Request`) or the class. The header's seq is dropped (the sim's classes have none)."""
    if isinstance(msgtype, type):
        msgtype = type_of(msgtype)
    elif "/srv/" not in msgtype:
        msgtype = normalize_msgtype(msgtype)
    view = memoryview(data).cast("B")
    try:
        msg, end = _decode(msgtype, view, 0)
    except (struct.error, ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{msgtype}: malformed ROS 1 data ({exc})") from None
    if end != len(view):
        raise ValueError(f"{msgtype}: {len(view) - end} bytes left over after the message")
    return msg


def _decode(msgtype: str, buf: memoryview, pos: int) -> tuple[Any, int]:
    values: dict[str, Any] = {}
    for f in fields(msgtype):
        value, pos = _decode_field(f, buf, pos)
        if f.attr is not None:
            values[f.attr] = value
    return sim_class(msgtype)(**values), pos


def _decode_one(type_name: str, buf: memoryview, pos: int) -> tuple[Any, int]:
    if type_name == "string":
        (length,) = _U32.unpack_from(buf, pos)
        end = pos + 4 + length
        if end > len(buf):
            raise ValueError(f"string of {length} bytes past the end")
        return bytes(buf[pos + 4 : end]).decode(), end
    if type_name in _SCALARS:
        code = _SCALARS[type_name]
        return struct.unpack_from("<" + code, buf, pos)[0], pos + struct.calcsize(code)
    return _decode(type_name, buf, pos)


def _decode_field(f: FieldSpec, buf: memoryview, pos: int) -> tuple[Any, int]:
    if not f.is_array:
        return _decode_one(f.type, buf, pos)
    count = f.size
    if count is None:
        (count,) = _U32.unpack_from(buf, pos)
        pos += 4
    if f.type in _BYTE_ARRAYS:
        if pos + count > len(buf):
            raise ValueError(f"{count} bytes past the end")
        return bytes(buf[pos : pos + count]), pos + count
    if f.type in _SCALARS:
        dtype = _DTYPES[f.type]
        array = np.frombuffer(buf, dtype=dtype, count=count, offset=pos)
        return array.astype(dtype.newbyteorder("=")), pos + count * dtype.itemsize
    items = []
    for _ in range(count):
        item, pos = _decode_one(f.type, buf, pos)
        items.append(item)
    return items, pos
