"""The field model under the message classes: one description of each type's fields, read by every encoder.

A message class holds the fields of its ``.msg`` definition (msgs/definitions), in the same order and under the same
names. ``message_fields`` gives them as ``idl.FieldSpec``: name, element type, array kind (``is_array``, ``size``) and
the class attribute. The ROS 2 CDR encoder and decoder (msgs/cdr.py) compile from this model; the ROS 1 ones
(bridges/ros1/wire.py) compile from it with ROS 1's differences applied in one place there; a ROS 2 bridge reads type
names, field lists and schemas (``idl.schema_text``) off it too.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from racecar_sim.msgs.idl import FieldSpec, get_spec

SCALARS: dict[str, tuple[str, int]] = {
    "bool": ("?", 1), "byte": ("B", 1), "char": ("B", 1),
    "int8": ("b", 1), "uint8": ("B", 1), "int16": ("h", 2), "uint16": ("H", 2),
    "int32": ("i", 4), "uint32": ("I", 4), "int64": ("q", 8), "uint64": ("Q", 8),
    "float32": ("f", 4), "float64": ("d", 8),
}  # fmt: skip
"""Every primitive but ``string``: its ``struct`` format character and size. ROS 2 maps byte and char to uint8."""

DTYPES: dict[str, np.dtype[Any]] = {
    name: np.dtype(np.bool_ if code == "?" else f"<{code}") for name, (code, _) in SCALARS.items()
}
"""The little-endian numpy dtype of each primitive in ``SCALARS``, for numeric arrays."""

FieldsOf = Callable[[str], tuple[FieldSpec, ...]]
"""``fields_of(msgtype)``: the fields of a type in wire order (the model's, or a wire format's layout of it)."""


def message_fields(msgtype: str) -> tuple[FieldSpec, ...]:
    """The fields of a message type (``pkg/msg/Name`` or ``pkg/Name``) in wire order.

    Raises:
        KeyError: No definition of that type is shipped.
    """
    return get_spec(msgtype).fields


def leaves(msgtype: str, fields_of: FieldsOf = message_fields, prefix: str = "") -> Iterator[tuple[str, FieldSpec]]:
    """(dotted attribute path, field) in wire order, nested (non-array) messages flattened into their fields.

    A field that no attribute holds (``attr`` None) is a leaf, under the path its name would have.
    """
    for spec in fields_of(msgtype):
        path = prefix + (spec.name if spec.attr is None else spec.attr)
        if spec.attr is None or spec.is_primitive or spec.is_array:
            yield path, spec
        else:
            yield from leaves(spec.type, fields_of, path + ".")
