"""ROS 2 CDR (little-endian XCDR1, as rosbag2 and rosbags write it) for the message classes.

The encoder of each type is compiled once from the field model (msgs/fields.py) into a
flat tuple of small closures ("ops"). Nested message fields are flattened into dotted
attribute paths, consecutive scalar fields become one precompiled ``struct`` per
alignment state, and numeric arrays go out through numpy without per-element Python work.
Alignment is counted from the end of the 4-byte encapsulation header.
"""

from __future__ import annotations

import keyword
import struct
from collections.abc import Callable
from functools import cache, lru_cache, partial
from itertools import chain
from operator import attrgetter
from typing import Any

import numpy as np

from racecar_sim.msgs.fields import DTYPES, SCALARS, leaves, message_fields
from racecar_sim.msgs.idl import FieldSpec, normalize_msgtype
from racecar_sim.msgs.registry import message_class, msgtype_of

CDR_LE_HEADER = b"\x00\x01\x00\x00"

_BYTE_TYPES = frozenset({"uint8", "byte", "char"})
_U32 = struct.Struct("<I")
_PAD = tuple(b"\0" * n for n in range(8))

Encoder = Callable[[Any, list[Any], int], int]
"""``encode(msg, out, pos) -> pos``: append byte chunks to ``out``; ``pos`` is the body offset."""

_ENCODERS: dict[type, Encoder] = {}


def serialize(msg: object) -> bytes:
    """Serialize a message instance to CDR bytes, encapsulation header included.

    Raises:
        TypeError: A field has the wrong type (the message names type and field).
        ValueError: A value is out of range or a fixed-size array has the wrong length.
    """
    try:
        encode = _ENCODERS[type(msg)]
    except KeyError:
        if isinstance(msg, type):
            raise TypeError(f"serialize() needs a message instance, got the class {msg.__name__}") from None
        encode = _ENCODERS.setdefault(type(msg), _encoder(msgtype_of(msg)))
    out: list[Any] = [CDR_LE_HEADER]
    encode(msg, out, 0)
    return b"".join(out)


def _error(kind: type[Exception], msgtype: str, path: str, detail: str) -> Exception:
    return kind(f"{msgtype}: field '{path}': {detail}")


@cache
def _encoder(msgtype: str) -> Encoder:
    msgtype = normalize_msgtype(msgtype)
    steps: list[tuple[Encoder, list[tuple[str, str]] | str]] = []  # each op, and its scalar run or field path
    run: list[tuple[str, str]] = []
    for path, spec in leaves(msgtype):
        if not spec.is_array and spec.type in SCALARS:
            run.append((path, spec.type))
            continue
        if run:
            steps.append((_scalar_run_op(msgtype, run), run))
            run = []
        steps.append((_field_op(msgtype, path, spec), path))
    if run:
        steps.append((_scalar_run_op(msgtype, run), run))
    op_tuple = tuple(op for op, _ in steps)

    def encode(msg: Any, out: list[Any], pos: int) -> int:
        for op in op_tuple:
            pos = op(msg, out, pos)
        return pos

    return _compiled(msgtype, steps, encode) or encode


def _compiled(
    msgtype: str, steps: list[tuple[Encoder, list[tuple[str, str]] | str]], checked: Encoder
) -> Encoder | None:
    """The encoder as one Python function: each scalar run one precompiled struct's pack() of the attributes read
    inline (its op where it is not kept), the other fields by their ops. It writes what the ops write (the same
    structs, the same kept strings). Where it meets anything the ops would refuse or diagnose (a missing attribute,
    a value struct refuses), it drops what it appended and hands the message to `checked`, the ops one by one, which
    encode it or raise their one-line error. None where a path is no Python attribute chain."""
    names: dict[str, Any] = {
        "_checked": checked,
        "_errors": (struct.error, TypeError, AttributeError, OverflowError),
        "_ndarray": np.ndarray,
        "_PAD": _PAD,
        "_U32": _U32,
    }
    lines = ["def encode(msg, out, pos):", "    start, count = pos, len(out)", "    try:"]
    for index, (op, what) in enumerate(steps):
        if isinstance(what, list):  # a scalar run: its structs by start alignment, as _scalar_run_op keeps them
            paths = [path for path, _ in what]
            if not all(_attribute_chain(path) for path in paths):
                return None
            names[f"_run{index}"] = op.structs  # type: ignore[attr-defined]
            values = ", ".join(f"msg.{path}" for path in paths)
            lines += [
                f"        packer = _run{index}[pos & 7]",
                f"        out.append(packer.pack({values}))",
                "        pos += packer.size",
            ]
        elif hasattr(op, "kept"):  # a string: its kept encodings by start alignment, as _string_op keeps them
            if not _attribute_chain(what):
                return None
            names[f"_kept{index}"], names[f"_op{index}"] = op.kept, op
            lines += [
                f"        data = _kept{index}[pos & 3].get(msg.{what})",
                "        if data is None:",  # not kept (yet): the op encodes it (and keeps it), or says what is wrong
                f"            pos = _op{index}(msg, out, pos)",
                "        else:",
                "            out.append(data)",
                "            pos += len(data)",
            ]
        elif hasattr(op, "numeric") and _attribute_chain(what):
            names[f"_op{index}"], names[f"_dtype{index}"] = op, op.numeric[0]
            lines += _numeric_array_lines(index, what, *op.numeric)
        else:
            names[f"_op{index}"] = op
            lines.append(f"        pos = _op{index}(msg, out, pos)")
    lines += [
        "    except _errors:",
        "        del out[count:]",
        "        return _checked(msg, out, start)",
        "    return pos",
    ]
    exec(
        compile("\n".join(lines), f"<cdr encoder of {msgtype}>", "exec"), names
    )  # the source is made from the field model
    encode: Encoder = names["encode"]
    return encode


def _numeric_array_lines(index: int, path: str, dtype: np.dtype[Any], itemsize: int, size: int | None) -> list[str]:
    """The compiled encoder's lines for a numeric array field: a 1-D C-ordered ndarray of the field's dtype (and
    length, for a fixed-size array) goes out as it is, with the prefix and padding _numeric_array_op writes; any other
    value goes to that op (_op<index>), which converts it or says what is wrong."""
    fits = f"type(value) is _ndarray and value.dtype is _dtype{index} and value.ndim == 1 and value.flags.c_contiguous"
    if size is not None:
        pad = f"_PAD[-pos % {itemsize}]" if size else 'b""'
        return [
            f"        value = msg.{path}",
            f"        if {fits} and len(value) == {size}:",
            f"            out.append({pad})",
            "            out.append(value)",
            f"            pos += len(out[-2]) + {size * itemsize}",
            "        else:",
            f"            pos = _op{index}(msg, out, pos)",
        ]
    return [
        f"        value = msg.{path}",
        f"        if {fits}:",
        "            count = len(value)",
        "            align = -pos & 3",
        "            pos += align + 4",
        f"            pad = -pos % {itemsize} if count else 0",
        "            out.append(_PAD[align] + _U32.pack(count) + _PAD[pad])",
        "            out.append(value)",
        f"            pos += pad + count * {itemsize}",
        "        else:",
        f"            pos = _op{index}(msg, out, pos)",
    ]


def _attribute_chain(path: str) -> bool:
    """Whether `msg.<path>` is Python for the dotted attribute path (never a keyword, never anything but names)."""
    return all(part.isidentifier() and not keyword.iskeyword(part) for part in path.split("."))


def _field_op(msgtype: str, path: str, spec: FieldSpec) -> Encoder:
    if not spec.is_array:
        return _string_op(msgtype, path)
    if spec.type in _BYTE_TYPES:
        return _bytes_op(msgtype, path, spec.size)
    if spec.type in SCALARS:
        return _numeric_array_op(msgtype, path, spec.type, spec.size)
    if spec.type == "string":
        return _string_array_op(msgtype, path, spec.size)
    return _message_array_op(msgtype, path, spec.type, spec.size)


def _run_struct(types: list[str], start: int) -> struct.Struct:
    fmt, pos = "<", start
    for name in types:
        code, size = SCALARS[name]
        pad = -pos % size
        fmt += "x" * pad + code
        pos += pad + size
    return struct.Struct(fmt)


def _scalar_run_op(msgtype: str, run: list[tuple[str, str]]) -> Encoder:
    paths = [p for p, _ in run]
    types = [t for _, t in run]
    getter = attrgetter(*paths)
    # The padding inside the run depends only on the start offset modulo 8.
    structs = tuple(_run_struct(types, start) for start in range(8))
    single = len(run) == 1

    def op(msg: Any, out: list[Any], pos: int) -> int:
        packer = structs[pos & 7]
        try:
            out.append(packer.pack(getter(msg)) if single else packer.pack(*getter(msg)))
        except (struct.error, TypeError, AttributeError, OverflowError):
            raise _diagnose_scalars(msgtype, msg, run) from None
        return pos + packer.size

    op.structs = structs  # type: ignore[attr-defined]  # what the compiled encoder packs with (_compiled)
    return op


def _diagnose_scalars(msgtype: str, msg: Any, run: list[tuple[str, str]]) -> Exception:
    for path, type_name in run:
        try:
            value = attrgetter(path)(msg)
        except AttributeError:
            return _error(TypeError, msgtype, path, f"missing on {type(msg).__name__}")
        code = SCALARS[type_name][0]
        try:
            struct.pack("<" + code, value)
        except (struct.error, TypeError, OverflowError) as exc:
            # A number of the right kind failed on range; anything else is a type error.
            right_kind = (int, np.integer) if code not in "fd" else (int, float, np.number)
            kind = ValueError if isinstance(value, right_kind) else TypeError
            return _error(kind, msgtype, path, f"cannot encode {value!r} as {type_name} ({exc})")
    return _error(TypeError, msgtype, ", ".join(p for p, _ in run), "cannot encode")


def _get(msgtype: str, path: str) -> Callable[[Any], Any]:
    getter = attrgetter(path)

    def get(msg: Any) -> Any:
        try:
            return getter(msg)
        except AttributeError:
            raise _error(TypeError, msgtype, path, f"missing on {type(msg).__name__}") from None

    return get


def _encode_str(msgtype: str, path: str, value: Any, out: list[Any], pos: int) -> int:
    if not isinstance(value, str):
        raise _error(TypeError, msgtype, path, f"expected str, got {type(value).__name__}")
    data = value.encode()
    pad = -pos & 3
    out.append(_PAD[pad] + _U32.pack(len(data) + 1) + data + b"\0")
    return pos + pad + 5 + len(data)


_STRINGS_KEPT = 64  # encodings one string field keeps (frame ids, names); more distinct values start it over
_STRING_KEPT_LENGTH = 256  # longer strings (a robot description) are encoded every time


def _string_op(msgtype: str, path: str) -> Encoder:
    get = _get(msgtype, path)
    # Encodings of the values this field had, per start alignment: frame ids and names repeat in every message.
    # A str equal to a kept one encodes to the same bytes; dict reads and writes are whole under the GIL.
    kept: tuple[dict[Any, bytes], ...] = ({}, {}, {}, {})

    def op(msg: Any, out: list[Any], pos: int) -> int:
        value = get(msg)
        cache = kept[pos & 3]
        try:
            data = cache.get(value)
        except TypeError:  # unhashable: not a str, _encode_str says so
            data = None
        if data is not None:
            out.append(data)
            return pos + len(data)
        end = _encode_str(msgtype, path, value, out, pos)
        if len(value) <= _STRING_KEPT_LENGTH:
            if len(cache) >= _STRINGS_KEPT:
                cache.clear()
            cache[value] = out[-1]
        return end

    op.kept = kept  # type: ignore[attr-defined]  # what the compiled encoder looks up (_compiled)
    return op


def _length_prefix(pos: int, count: int, size: int | None) -> tuple[bytes, int]:
    """Alignment and uint32 count of a sequence (nothing for a fixed-size array)."""
    if size is not None:
        return b"", pos
    pad = -pos & 3
    return _PAD[pad] + _U32.pack(count), pos + pad + 4


def _check_size(msgtype: str, path: str, count: int, size: int | None) -> None:
    if size is not None and count != size:
        raise _error(ValueError, msgtype, path, f"expected {size} elements, got {count}")


def _as_bytes(msgtype: str, path: str, value: Any) -> Any:
    """A contiguous byte buffer for a ``uint8[]`` field, without copying when possible."""
    if isinstance(value, (bytes, bytearray)):
        return value
    if isinstance(value, np.ndarray):
        if value.dtype != np.uint8:
            raise _error(TypeError, msgtype, path, f"expected uint8 data, got dtype {value.dtype}")
        return np.ascontiguousarray(value).reshape(-1)
    if isinstance(value, memoryview):
        return value if value.c_contiguous else value.tobytes()
    if isinstance(value, (list, tuple)):
        try:
            return bytes(value)
        except (TypeError, ValueError) as exc:
            raise _error(ValueError, msgtype, path, str(exc)) from None
    raise _error(TypeError, msgtype, path, f"expected bytes-like, got {type(value).__name__}")


def _bytes_op(msgtype: str, path: str, size: int | None) -> Encoder:
    get = _get(msgtype, path)

    def op(msg: Any, out: list[Any], pos: int) -> int:
        data = _as_bytes(msgtype, path, get(msg))
        count = data.nbytes if isinstance(data, (np.ndarray, memoryview)) else len(data)
        _check_size(msgtype, path, count, size)
        prefix, pos = _length_prefix(pos, count, size)
        out.append(prefix)
        out.append(data)
        return pos + count

    return op


def _as_array(msgtype: str, path: str, value: Any, dtype: np.dtype[Any]) -> np.ndarray:
    if type(value) is not np.ndarray and (value is None or isinstance(value, (str, bytes)) or np.ndim(value) == 0):
        raise _error(TypeError, msgtype, path, f"expected an array, got {type(value).__name__}")
    try:
        array = np.ascontiguousarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise _error(TypeError, msgtype, path, f"cannot convert to {dtype}: {exc}") from None
    return array if array.ndim == 1 else array.reshape(-1)


def _numeric_array_op(msgtype: str, path: str, type_name: str, size: int | None) -> Encoder:
    get = _get(msgtype, path)
    dtype = DTYPES[type_name]
    itemsize = dtype.itemsize

    def op(msg: Any, out: list[Any], pos: int) -> int:
        array = _as_array(msgtype, path, get(msg), dtype)
        count = array.size
        if size is None:  # _length_prefix(), written out: a joint state or a scan has several of these per message
            align = -pos & 3
            prefix = _PAD[align] + _U32.pack(count)
            pos += align + 4
        else:
            _check_size(msgtype, path, count, size)
            prefix = b""
        pad = -pos % itemsize if count else 0  # rosbags does not align an empty sequence
        out.append(prefix + _PAD[pad])
        out.append(array)
        return pos + pad + count * itemsize

    op.numeric = (dtype, itemsize, size)  # type: ignore[attr-defined]  # what the compiled encoder inlines (_compiled)
    return op


def _sequence(msgtype: str, path: str, value: Any, size: int | None) -> Any:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise _error(TypeError, msgtype, path, f"expected a list, got {type(value).__name__}")
    _check_size(msgtype, path, len(value), size)
    return value


def _string_array_op(msgtype: str, path: str, size: int | None) -> Encoder:
    get = _get(msgtype, path)
    # The last encoding, reused while the strings and the start's alignment repeat: name lists (links, joints)
    # go out unchanged at 50-100 Hz. Equal tuples of str encode to equal bytes. One tuple, read and replaced whole,
    # so that threads serializing at once never mix two encodings.
    last: list[tuple[tuple[Any, ...], int, bytes, int]] = [((), -1, b"", 0)]  # strings, start % 4, bytes, length

    def op(msg: Any, out: list[Any], pos: int) -> int:
        items = _sequence(msgtype, path, get(msg), size)
        key = tuple(items)
        names, align, data, length = last[0]
        try:
            same = pos & 3 == align and key == names
        except (TypeError, ValueError):  # a non-str item compared with a name (numpy's ambiguous truth value)
            same = False
        if same:
            out.append(data)
            return pos + length
        start, chunks = pos, []
        prefix, pos = _length_prefix(pos, len(items), size)
        chunks.append(prefix)
        for index, item in enumerate(items):
            pos = _encode_str(msgtype, f"{path}[{index}]", item, chunks, pos)
        data = b"".join(chunks)
        last[0] = (key, start & 3, data, pos - start)
        out.append(data)
        return pos

    return op


def _uniform_leaves(element_type: str) -> tuple[tuple[str, ...], str] | None:
    """The leaf paths of a message type whose leaves are all scalars of one numeric type (Pose, Twist, Point: all
    float64), and that type; None otherwise. Such elements lie end to end with no padding between them."""
    found = list(leaves(element_type))
    types = {spec.type for _, spec in found}
    if not found or len(types) != 1 or any(spec.is_array for _, spec in found):
        return None
    (type_name,) = types
    if type_name not in SCALARS or type_name == "bool":
        return None
    return tuple(path for path, _ in found), type_name


def _flattener(paths: tuple[str, ...]) -> Callable[[Any], Any]:
    """`flatten(items)`: every item's numbers at `paths`, item after item, in one sequence. Compiled into one loop
    that reads each nested message once (a Pose's position, then its x, y, z) where the paths are attribute chains;
    else attrgetter's."""
    if not all(_attribute_chain(path) for path in paths):
        getter = attrgetter(*paths)
        return (lambda items: chain.from_iterable(map(getter, items))) if len(paths) > 1 else partial(map, getter)
    names: dict[str, str] = {}  # a nested message's path -> its local
    lines = ["def flatten(items):", "    out = []", "    for item in items:"]

    def local(path: str) -> str:  # the local holding the nested message at `path` ("": the item), read once
        if not path:
            return "item"
        if path not in names:
            parent, _, attr = path.rpartition(".")
            owner = local(parent)
            names[path] = f"v{len(names)}"
            lines.append(f"        {names[path]} = {owner}.{attr}")
        return names[path]

    values = []
    for path in paths:
        parent, _, leaf = path.rpartition(".")
        values.append(f"{local(parent)}.{leaf}")
    lines += [f"        out += ({', '.join(values)},)", "    return out"]
    namespace: dict[str, Any] = {}
    exec(compile("\n".join(lines), f"<cdr flattener of {', '.join(paths)}>", "exec"), namespace)
    flatten: Callable[[Any], Any] = namespace["flatten"]
    return flatten


@lru_cache(maxsize=256)  # a few array lengths repeat (links, models); a PoseArray of any length must not pile up
def _packer(code: str, count: int) -> struct.Struct:
    return struct.Struct(f"<{count}{code}")


def _message_array_op(msgtype: str, path: str, element_type: str, size: int | None) -> Encoder:
    get = _get(msgtype, path)
    encode = _encoder(element_type)
    uniform = _uniform_leaves(element_type)

    def one_by_one(items: Any, out: list[Any], pos: int) -> int:
        for index, item in enumerate(items):
            try:
                pos = encode(item, out, pos)
            except (TypeError, ValueError) as exc:
                raise _error(type(exc), msgtype, f"{path}[{index}]", str(exc)) from None
        return pos

    if uniform is None:

        def op(msg: Any, out: list[Any], pos: int) -> int:
            items = _sequence(msgtype, path, get(msg), size)
            prefix, pos = _length_prefix(pos, len(items), size)
            out.append(prefix)
            return one_by_one(items, out, pos)

        return op

    paths, type_name = uniform
    code, width = SCALARS[type_name]
    flatten, per_item = _flattener(paths), len(paths)
    packers: dict[int, struct.Struct] = {}  # by element count

    def op_uniform(msg: Any, out: list[Any], pos: int) -> int:
        # every element's numbers in one struct.pack; whatever it refuses is diagnosed element by element
        items = get(msg)
        count = len(items) if type(items) is list else -1  # a list of any length: _sequence() would pass it
        if count < 0 or size is not None:
            items = _sequence(msgtype, path, items, size)
            count = len(items)
            prefix, pos = _length_prefix(pos, count, size)
        else:  # _length_prefix() of a sequence, inline
            pad = -pos & 3
            prefix, pos = _PAD[pad] + _U32.pack(count), pos + pad + 4
        if not count:
            out.append(prefix)
            return pos
        try:
            packer = packers.get(count) or _packer(code, count * per_item)
            data = packer.pack(*flatten(items))
        except (struct.error, TypeError, AttributeError, OverflowError):
            out.append(prefix)
            return one_by_one(items, out, pos)
        if len(packers) < 4:  # the lengths this field has had (links, models): no shared cache to ask
            packers[count] = packer
        pad = -pos % width
        out.append(prefix + _PAD[pad])
        out.append(data)
        return pos + pad + len(data)

    return op_uniform


# --- decoding (straightforward, not performance critical) -----------------------------


def deserialize(data: bytes | bytearray | memoryview, msgtype: str) -> Any:
    """Decode CDR bytes (with encapsulation header) into an instance of ``msgtype``'s class.

    Raises:
        ValueError: The data is not little-endian CDR or is truncated.
        KeyError: There is no message class for ``msgtype``.
    """
    view = memoryview(data).cast("B")
    msgtype = normalize_msgtype(msgtype)
    if len(view) < 4 or bytes(view[:2]) != CDR_LE_HEADER[:2]:
        raise ValueError(f"{msgtype}: not little-endian CDR (header {bytes(view[:4])!r})")
    message, _ = _decode(msgtype, view[4:], 0)
    return message


def _decode(msgtype: str, buf: memoryview, pos: int) -> tuple[Any, int]:
    values: dict[str, Any] = {}
    for spec in message_fields(msgtype):
        try:
            value, pos = _decode_field(spec, buf, pos)
        except (struct.error, ValueError, UnicodeDecodeError) as exc:
            detail = f"malformed CDR data ({exc})"
            raise ValueError(f"{msgtype}: field '{spec.name}': {detail}") from None
        if spec.attr is not None:
            values[spec.attr] = value
    return message_class(msgtype)(**values), pos


def _decode_scalar(type_name: str, buf: memoryview, pos: int) -> tuple[Any, int]:
    if type_name == "string":
        pos += -pos & 3
        (length,) = _U32.unpack_from(buf, pos)
        end = pos + 4 + length
        if length < 1 or end > len(buf):
            raise ValueError(f"bad string length {length}")
        return bytes(buf[pos + 4 : end - 1]).decode(), end
    code, size = SCALARS[type_name]
    pos += -pos % size
    return struct.unpack_from("<" + code, buf, pos)[0], pos + size


def _decode_field(spec: FieldSpec, buf: memoryview, pos: int) -> tuple[Any, int]:
    if not spec.is_array:
        if spec.is_primitive:
            return _decode_scalar(spec.type, buf, pos)
        return _decode(spec.type, buf, pos)
    count = spec.size
    if count is None:
        pos += -pos & 3
        (count,) = _U32.unpack_from(buf, pos)
        pos += 4
    if spec.type in _BYTE_TYPES:
        if pos + count > len(buf):
            raise ValueError(f"{count} bytes past the end of the data")
        return bytes(buf[pos : pos + count]), pos + count
    if spec.type in SCALARS:
        dtype = DTYPES[spec.type]
        if count:
            pos += -pos % dtype.itemsize
        array = np.frombuffer(buf, dtype=dtype, count=count, offset=pos)
        return array.astype(dtype.newbyteorder("=")), pos + count * dtype.itemsize
    items = []
    for _ in range(count):
        if spec.type == "string":
            item, pos = _decode_scalar("string", buf, pos)
        else:
            item, pos = _decode(spec.type, buf, pos)
        items.append(item)
    return items, pos
