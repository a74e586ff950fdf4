"""The static types of the message and service classes, written from the definitions into msgs/typed/ (``.pyi`` stubs).

The classes themselves are made at run time (msgs/generate.py); the package modules import these stubs for the type
checker only. A definition without a stub still works (its class is typed ``Any``); ``python -m
racecar_sim.msgs.stubs`` rewrites the stubs after a definition is added or changed, and tests/test_msgs_cdr.py checks
that every stub is what the definitions give.
"""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

from racecar_sim.msgs.extras import EXTRAS
from racecar_sim.msgs.generate import BYTE_TYPES, docstring
from racecar_sim.msgs.idl import SERVICE_PARTS, FieldSpec, available_msgtypes, available_srvtypes, get_spec

TYPED_DIR = Path(__file__).with_name("typed")
"""Where the stubs live: one ``<package>.pyi`` per package, and ``__init__.pyi`` re-exporting every class."""

_PYTHON = {"bool": "bool", "string": "str", "float32": "float", "float64": "float"}
_NUMPY = {"bool": "np.bool_", "float32": "np.float32", "float64": "np.float64"}
_HEADER = "# Written by `python -m racecar_sim.msgs.stubs` from msgs/definitions: do not edit.\n"


def _annotation(spec: FieldSpec, package: str, imports: dict[str, set[str]]) -> str:
    if spec.is_primitive and spec.type != "string" and spec.is_array:
        if spec.type in BYTE_TYPES:
            return "bytes | npt.NDArray[np.uint8]"
        return f"npt.NDArray[{_NUMPY.get(spec.type, 'np.' + spec.type)}]"
    if spec.is_primitive:
        element = _PYTHON.get(spec.type, "int")
    else:
        pkg, _, element = spec.type.split("/")
        if pkg != package:
            imports.setdefault(f"racecar_sim.msgs.typed.{pkg}", set()).add(element)
    return f"list[{element}]" if spec.is_array else element


def _doc(text: str) -> list[str]:
    return textwrap.wrap(f'"""{text}"""', 116, initial_indent="    ", subsequent_indent="    ")


def _service_stub(srvtype: str) -> str:
    name = srvtype.rsplit("/", 1)[1]
    lines = [
        f"class {name}:",
        *_doc(f"The service {srvtype}, rclpy-style: ``{name}.Request()``, ``{name}.Response()``."),
    ]
    lines += ["", "    __srvtype__: ClassVar[str]"] + [f"    {part} = {name}{part}" for part in SERVICE_PARTS]
    return "\n".join(lines) + "\n"


def package_stub(package: str) -> str:
    """The ``.pyi`` text of one package's message classes, and of its services and their parts."""
    imports: dict[str, set[str]] = {"racecar_sim.msgs._base": {"Message"}}
    classes = []
    services = [t for t in available_srvtypes() if t.startswith(f"{package}/srv/")]
    parts = [f"{srvtype}_{part}" for srvtype in services for part in SERVICE_PARTS]
    for msgtype in [t for t in available_msgtypes() if t.startswith(f"{package}/msg/")] + parts:
        msg = get_spec(msgtype)
        name = msgtype.rsplit("/", 1)[1].replace("_", "")
        bases = "Message"
        if msgtype in EXTRAS:
            extra = EXTRAS[msgtype].__name__
            imports.setdefault("racecar_sim.msgs.extras", set()).add(extra)
            bases = f"{extra}, Message"
        lines = [f"class {name}({bases}):", *_doc(docstring(msg)), "", "    __msgtype__: ClassVar[str]"]
        if "/srv/" in msgtype:
            lines.append("    __srvtype__: ClassVar[str]")
        lines += [f"    {const}: ClassVar[{_PYTHON.get(t, 'int')}]" for t, const, _ in msg.constants]
        annotations = [(f.name, _annotation(f, package, imports)) for f in msg.fields]
        lines += [f"    {field}: {annotation}" for field, annotation in annotations]
        if annotations:  # one parameter a line, as ruff formats a signature too long for one
            lines += ["    def __init__(", "        self,"]
            lines += [f"        {field}: {annotation} = ...," for field, annotation in annotations]
            lines.append("    ) -> None: ...")
        else:
            lines.append("    def __init__(self) -> None: ...")
        classes.append("\n".join(lines) + "\n")
    body = "\n".join(classes + [_service_stub(srvtype) for srvtype in services])
    head = ["from typing import ClassVar", ""]
    if "np." in body:
        head += ["import numpy as np", *(["import numpy.typing as npt"] if "npt." in body else []), ""]
    head += [
        f"from {module} import {', '.join(sorted(names, key=str.lower))}" for module, names in sorted(imports.items())
    ]
    return _HEADER + "\n".join(head) + "\n\n" + body


def index_stub() -> str:
    """The ``__init__.pyi`` text: every class, re-exported."""
    lines = []
    for msgtype in sorted(available_msgtypes(), key=str.lower):  # in the order ruff's isort keeps
        pkg, _, name = msgtype.split("/")
        lines.append(f"from racecar_sim.msgs.typed.{pkg} import {name} as {name}")
    return _HEADER + "\n".join(lines) + "\n"


def stubs() -> dict[str, str]:
    """File name -> text of every stub."""
    packages = sorted({t.split("/", 1)[0] for t in (*available_msgtypes(), *available_srvtypes())})
    return {"__init__.pyi": index_stub(), **{f"{p}.pyi": package_stub(p) for p in packages}}


def main() -> None:
    """Write the stubs into msgs/typed/."""
    TYPED_DIR.mkdir(exist_ok=True)
    for name, text in stubs().items():
        (TYPED_DIR / name).write_text(text, encoding="utf-8")
        sys.stdout.write(f"wrote {TYPED_DIR / name}\n")


if __name__ == "__main__":
    main()
