"""The message classes, made from their ``.msg`` definitions (msgs/definitions): a message type is its file.

``message_type("pkg/msg/Name")`` builds the class once: a ``@dataclass(eq=False, repr=False, slots=True)`` subclass of
``Message`` with one attribute per field, in wire order, defaulting as ROS 2's Python messages do (0, 0.0, False, "",
a default nested message, an empty list, ``b""`` for byte arrays, a zero numpy array of the field's dtype for numeric
arrays, its fixed size or empty) or to the value the definition gives (``float64 w 1``); the definition's constants
are class attributes. A few types carry methods besides their fields (``Header.at``, ``Time.from_ns``,
``Image.bgr_pixels``): msgs/extras.py holds them, and the class takes them as a base.

A service is its ``.srv`` file: ``service_type("pkg/srv/Name")`` is the rclpy-style class whose ``Request`` and
``Response`` are the message classes of its two parts (``pkg/srv/Name_Request``, made as a message is), named the
rospy way, ``NameRequest`` and ``NameResponse``. Services travel only over the in-process bus (``bus.call``) and the
bridges, never to a recording.

The class belongs to its package's module (``racecar_sim.msgs.sensor_msgs``), which gives it out by name through a
module ``__getattr__`` (``package_getattr``), so it imports, pickles and prints as a hand-written class would. The
static types of the classes are stubs written from the same definitions (msgs/stubs.py, msgs/typed/).
"""

from __future__ import annotations

import ast
import dataclasses
from collections.abc import Callable
from functools import cache, partial
from typing import Any

import numpy as np

from racecar_sim.msgs._base import Message
from racecar_sim.msgs.fields import DTYPES
from racecar_sim.msgs.idl import (
    SERVICE_PARTS,
    FieldSpec,
    MsgSpec,
    available_msgtypes,
    available_srvtypes,
    get_spec,
    is_service_part,
    normalize_msgtype,
)

BYTE_TYPES = frozenset({"uint8", "byte", "char"})
"""Element types whose arrays are ``bytes`` (``Image.data``), as the CDR encoder writes them."""

_FLOATS = frozenset({"float32", "float64"})


def _scalar(type_name: str, text: str | None) -> Any:
    """A primitive's value from its text in a definition (a default or a constant), or its zero."""
    if type_name == "string":
        return "" if text is None else str(ast.literal_eval(text)) if text[:1] in "'\"" else text
    if type_name == "bool":
        return False if text is None else text.strip().lower() in ("true", "1")
    if type_name in _FLOATS:
        return 0.0 if text is None else float(text)
    return 0 if text is None else int(text, 0)


def _zeros(size: int, dtype: np.dtype[Any]) -> np.ndarray:
    return np.zeros(size, dtype=dtype)


def _default(spec: FieldSpec) -> tuple[str, Any]:
    """``("default", value)`` or ``("default_factory", factory)`` for a field."""
    if not spec.is_array:
        if spec.is_primitive:
            return "default", _scalar(spec.type, spec.default)
        return "default_factory", message_type(spec.type)
    if spec.type in BYTE_TYPES:
        return "default", bytes(spec.size or 0)
    if spec.type in DTYPES:
        return "default_factory", partial(_zeros, spec.size or 0, DTYPES[spec.type])
    if spec.size is None:
        return "default_factory", list
    if spec.type == "string":
        return "default_factory", partial(list, [""] * spec.size)
    element = message_type(spec.type)
    return "default_factory", lambda: [element() for _ in range(spec.size or 0)]


def docstring(msg: MsgSpec) -> str:
    """The class's docstring: the definition's leading comment, or the type's name and its fields."""
    lines = msg.text.splitlines()
    comment = []
    for line in lines:
        if not line.startswith("#"):
            break
        comment.append(line.lstrip("#").strip())
    if any(comment):
        return " ".join(c for c in comment if c)
    return f"The ROS message {msg.msgtype}, made from its definition."


def message_type(msgtype: str) -> type[Message]:
    """The class of ``msgtype`` (``pkg/msg/Name`` or ``pkg/Name``, or a service part ``pkg/srv/Name_Request``), made
    from its definition the first time.

    Raises:
        KeyError: No definition of that type is shipped.
    """
    return _made(msgtype if is_service_part(msgtype) else normalize_msgtype(msgtype))


@cache
def _made(msgtype: str) -> type[Message]:
    from racecar_sim.msgs.extras import EXTRAS  # its methods build messages: imported once the package is up

    msg = get_spec(msgtype)
    pkg, _, name = msg.msgtype.split("/")
    fields = [(f.name, Any, dataclasses.field(**dict([_default(f)]))) for f in msg.fields]
    namespace: dict[str, Any] = {"__msgtype__": msg.msgtype, "__doc__": docstring(msg)}
    if is_service_part(msgtype):  # GetModelState_Request: the class GetModelStateRequest of the service
        service, _, part = name.rpartition("_")
        name = service + part
        namespace["__srvtype__"] = f"{pkg}/srv/{service}"
    namespace.update({const: _scalar(type_name, value) for type_name, const, value in msg.constants})
    bases = (EXTRAS[msg.msgtype], Message) if msg.msgtype in EXTRAS else (Message,)
    cls = dataclasses.make_dataclass(name, fields, bases=bases, namespace=namespace, eq=False, repr=False, slots=True)
    cls.__module__ = f"racecar_sim.msgs.{pkg}"
    return cls


@cache
def service_type(srvtype: str) -> type:
    """The service class of ``pkg/srv/Name``, rclpy-style: ``Name.Request`` and ``Name.Response`` are its parts'
    message classes.

    Raises:
        KeyError: No ``.srv`` file of that service is shipped.
    """
    pkg, _, name = srvtype.split("/")
    parts = {part: message_type(f"{srvtype}_{part}") for part in SERVICE_PARTS}
    doc = f"The service {srvtype}, rclpy-style: ``{name}.Request()``, ``{name}.Response()``."
    namespace = {"__srvtype__": srvtype, "__doc__": doc, "__module__": f"racecar_sim.msgs.{pkg}", **parts}
    return type(name, (), namespace)


def package_types(package: str) -> dict[str, str]:
    """The types of a package that has definitions, by class name: messages (``Name`` -> ``pkg/msg/Name``), services
    (``Name`` -> ``pkg/srv/Name``) and their parts (``NameRequest`` -> ``pkg/srv/Name_Request``)."""
    types = {t.rsplit("/", 1)[1]: t for t in available_msgtypes() if t.startswith(f"{package}/msg/")}
    for srvtype in (t for t in available_srvtypes() if t.startswith(f"{package}/srv/")):
        name = srvtype.rsplit("/", 1)[1]
        types[name] = srvtype
        types.update({name + part: f"{srvtype}_{part}" for part in SERVICE_PARTS})
    return types


def package_getattr(module_name: str) -> Callable[[str], type]:
    """The module ``__getattr__`` of ``racecar_sim.msgs.<package>``: a message class by its name, made on first use
    and then kept in the module, so that later lookups are plain attribute reads."""
    import sys

    package = module_name.rsplit(".", 1)[-1]

    def getattr_(name: str) -> type:
        types = package_types(package)
        if name not in types:
            raise AttributeError(
                f"module {module_name!r} has no attribute {name!r} (no {package}/msg/{name}.msg nor a service of it)"
            )
        msgtype = types[name]
        cls = service_type(msgtype) if "/srv/" in msgtype and not is_service_part(msgtype) else message_type(msgtype)
        setattr(sys.modules[module_name], name, cls)
        return cls

    return getattr_
