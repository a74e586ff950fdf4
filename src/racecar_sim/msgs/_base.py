"""Shared behaviour of the message dataclasses: value equality and a compact repr."""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

_BYTES_REPR_LIMIT = 32


def _field_equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b))
    return bool(a == b)


class Message:
    """Base of every message class.

    Subclasses are ``@dataclass(eq=False, repr=False, slots=True)`` so that ``==``
    compares numpy array fields element-wise (plain dataclass equality raises on
    arrays) and ``repr`` does not print a megabyte of image bytes.
    """

    __slots__ = ()
    __msgtype__: ClassVar[str]
    # set by @dataclass on every subclass: what makes a message a dataclass instance to the type checker
    __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return all(_field_equal(getattr(self, f.name), getattr(other, f.name)) for f in dataclasses.fields(self))

    __hash__ = None  # type: ignore[assignment]  # mutable value objects

    def __repr__(self) -> str:
        parts = []
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, (bytes, bytearray)) and len(value) > _BYTES_REPR_LIMIT:
                text = f"<{len(value)} bytes>"
            else:
                text = repr(value)
            parts.append(f"{f.name}={text}")
        return f"{type(self).__name__}({', '.join(parts)})"
