"""The CDR bytes of messages that differ only in their numbers, packed straight from those numbers.

A publisher whose only taker is a recorder (Bus.cdr_only) need not make message objects: its messages keep one shape
(the same frame ids and names, the same array lengths) and only their numbers change. :meth:`CdrLayout.of` reads that
shape off one message: its strings, sequence lengths and padding become fixed bytes, and its numbers the fields of
one ``struct`` format. ``layout.pack(numbers)`` then gives the bytes ``serialize()`` gives a message of that shape
with those numbers, in one ``struct.pack``. A layout is only made after it packed the sample's own numbers into the
sample's ``serialize()`` bytes, so it can never write other bytes than the message objects would.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from racecar_sim.msgs.cdr import CDR_LE_HEADER, serialize
from racecar_sim.msgs.fields import SCALARS, message_fields
from racecar_sim.msgs.registry import msgtype_of

_U32 = struct.Struct("<I")
_BYTE_TYPES = frozenset({"uint8", "byte", "char"})
_NOT_NUMBER_CODES = str.maketrans("", "", "0123456789s")  # a format's literals ("12s") left out


class _Unsupported(Exception):
    """A field a layout does not hold (a byte array, a wire-only field): the message goes the object way."""


class _Shape:
    """What walking a message gives: the struct format (literals as ``Ns``), the literals, the numbers."""

    def __init__(self) -> None:
        self.fmt: list[str] = []
        self.literals: list[tuple[int, bytes]] = []  # (index among the numbers it goes before, bytes)
        self.numbers: list[Any] = []
        self.pos = 0  # the body's offset (alignment counts from after the encapsulation header)

    def literal(self, data: bytes) -> None:
        self.pos += len(data)
        if self.literals and self.literals[-1][0] == len(self.numbers):  # right after another literal: one
            index, before = self.literals.pop()
            self.fmt.pop()
            data = before + data
        self.literals.append((len(self.numbers), data))
        self.fmt.append(f"{len(data)}s")

    def number(self, type_name: str, value: Any) -> None:
        code, size = SCALARS[type_name]
        pad = -self.pos % size
        if pad:  # padding is fixed bytes too: a run of numbers between two literals lies end to end
            self.literal(b"\0" * pad)
        self.fmt.append(code)
        self.numbers.append(value)
        self.pos += size

    def length(self, count: int) -> None:
        self.literal(b"\0" * (-self.pos & 3) + _U32.pack(count))

    def string(self, value: str) -> None:
        data = value.encode()
        self.literal(b"\0" * (-self.pos & 3) + _U32.pack(len(data) + 1) + data + b"\0")

    def message(self, msgtype: str, msg: Any) -> None:
        for spec in message_fields(msgtype):
            if spec.attr is None:
                raise _Unsupported(spec.name)
            value = getattr(msg, spec.attr)
            if not spec.is_array:
                if spec.type == "string":
                    self.string(value)
                elif spec.type in SCALARS:
                    self.number(spec.type, value)
                else:
                    self.message(spec.type, value)
                continue
            if spec.type in _BYTE_TYPES:
                raise _Unsupported(spec.name)
            items = list(value)
            if spec.size is None:
                self.length(len(items))
            if spec.type == "string":
                for item in items:
                    self.string(item)
            elif spec.type in SCALARS:
                for item in items:  # an empty sequence is not aligned (as serialize() writes it)
                    self.number(spec.type, item.item() if hasattr(item, "item") else item)
            else:
                for item in items:
                    self.message(spec.type, item)


class CdrLayout:
    """The CDR bytes of messages of one shape, packed from their numbers; see the module docstring.

    `pack(numbers)`: the serialized message (encapsulation header included) whose numeric fields are `numbers`, in
    wire order (nested messages' fields in turn, array elements one after the other).
    """

    def __init__(self, msgtype: str, fmt: str, literals: list[tuple[int, bytes]], count: int) -> None:
        self.msgtype = msgtype
        self.count = count  # how many numbers a message has
        self._struct = struct.Struct(fmt)
        self._recipe = (msgtype, fmt, literals, count)
        self.pack: Callable[[Sequence[Any]], bytes]
        self.pack_many: Callable[[Sequence[Sequence[Any]]], list[bytes]]  # pack() of each, in one call
        self.pack, self.pack_many = self._packer(literals, count)
        # all numbers float64: each literal, then the numbers up to the next one (pack_doubles)
        self._doubles = fmt.lstrip("<").translate(_NOT_NUMBER_CODES) == "d" * count
        ends = [at for at, _ in literals[1:]] + [count]
        self._segments = [(data, at, end) for (at, data), end in zip(literals, ends)]

    def _packer(
        self, literals: list[tuple[int, bytes]], count: int
    ) -> tuple[Callable[[Sequence[Any]], bytes], Callable[[Sequence[Sequence[Any]]], list[bytes]]]:
        """One function that hands the struct the literals and the slices of numbers between them, in order; and one
        that does so for each of several messages' numbers."""
        names: dict[str, Any] = {"_pack": self._struct.pack}
        args, start = [], 0
        for index, (at, data) in enumerate(literals):
            if at > start:
                args.append(f"*v[{start}:{at}]")
            names[f"_l{index}"] = data
            args.append(f"_l{index}")
            start = at
        if count > start:
            args.append(f"*v[{start}:]" if start else "*v")
        call = f"_pack({', '.join(args)})"
        source = f"def pack(v):\n    return {call}\ndef pack_many(rows):\n    return [{call} for v in rows]"
        exec(compile(source, f"<cdr layout of {self.msgtype}>", "exec"), names)  # made from the field model
        return names["pack"], names["pack_many"]

    def __reduce__(self) -> tuple[type[CdrLayout], tuple[str, str, list[tuple[int, bytes]], int]]:
        """Pickled as what makes it (its packing functions are made again): a writer process packs with it."""
        return CdrLayout, self._recipe

    def packs_as(self, other: CdrLayout) -> bool:
        """Whether `other` packs every message's numbers into the same bytes (it was made from the same shape)."""
        return self._recipe == other._recipe

    def pack_doubles(self, numbers: np.ndarray) -> bytes:
        """pack() of a float64 array, its runs copied as they are: for a layout whose numbers are all float64
        (poses, twists); pack() for any other."""
        if not self._doubles or numbers.size != self.count:
            return self.pack(numbers.tolist())
        numbers = numbers.astype("<f8", copy=False)
        return b"".join(part for data, start, end in self._segments for part in (data, numbers[start:end].tobytes()))

    @classmethod
    def read(cls, msg: Any) -> CdrLayout | None:
        """of(msg)'s layout alone: what a publisher reads off its first message for the ones after it."""
        made = cls.of(msg)
        return None if made is None else made[0]

    @classmethod
    def of(cls, msg: Any) -> tuple[CdrLayout, list[Any]] | None:
        """The layout of `msg`'s shape and `msg`'s numbers; None where a field is not one a layout holds (a byte
        array) or the packed sample would differ from ``serialize(msg)``."""
        msgtype = msgtype_of(msg)
        shape = _Shape()
        shape.literal(CDR_LE_HEADER)
        shape.pos = 0
        try:
            shape.message(msgtype, msg)
        except (_Unsupported, AttributeError, TypeError):
            return None
        layout = cls(msgtype, "<" + "".join(shape.fmt), shape.literals, len(shape.numbers))
        try:
            same = layout.pack(shape.numbers) == serialize(msg)
        except (struct.error, TypeError, ValueError, OverflowError):
            same = False
        return (layout, shape.numbers) if same else None


class FilledLayout:
    """Messages of one all-float64 layout whose numbers are a template's, some replaced from arrays: the poses and
    twists of the moving links in /gazebo/link_states and model_states, where the rest never changes.

    A row is a tuple of float64 arrays' bytes (C order); `fills` says, for each, which numbers it replaces:
    ``(target, which, source)``, the template's numbers at the flat indices `target` become the flat elements `source`
    of the row's array `which`. `derive` (None: the row's own arrays): what makes those arrays of a row, e.g.
    LinkArrays.derive (the links' poses and twists from MuJoCo's state arrays, handed over as they are).
    ``pack_many(rows)`` packs each row's numbers with ``layout.pack_doubles`` (the same bytes as ``pack``). Pickles as
    what makes it: a writer process packs with it, so the main thread hands over a few arrays' bytes instead of
    packing the message.
    """

    def __init__(
        self,
        layout: CdrLayout,
        template: np.ndarray,
        fills: Sequence[tuple[np.ndarray, int, np.ndarray]],
        derive: Callable[[Sequence[bytes]], Sequence[np.ndarray]] | None = None,
    ) -> None:
        self.layout, self.template, self.fills = layout, np.asarray(template, "<f8"), tuple(fills)
        self.derive = derive
        self._plan: tuple[tuple[int, ...], bytes, int, int, np.ndarray, np.ndarray] | None = None  # _plan_for()

    def pack_many(self, rows: Sequence[Sequence[bytes]]) -> list[bytes]:
        """The CDR bytes of each row's message: the template's bytes, the fills' numbers put in place as float64."""
        packed = []
        derive = self.derive
        for row in rows:
            if derive is None:
                arrays: Sequence[np.ndarray] = [np.frombuffer(data, "<f8") for data in row]
            else:
                arrays = derive(row)
            sizes = tuple(array.size for array in arrays)
            plan = self._plan if self._plan is not None and self._plan[0] == sizes else self._plan_for(sizes)
            _, template, start, count, targets, sources = plan
            if not count:  # a layout whose numbers do not all lie on one 8-byte grid: the numbers packed
                packed.append(self._packed(arrays))
                continue
            message = bytearray(template)
            np.frombuffer(message, "<f8", count, start)[targets] = np.concatenate([a.ravel() for a in arrays])[sources]
            packed.append(bytes(message))
        return packed

    def _packed(self, arrays: Sequence[np.ndarray]) -> bytes:
        numbers = self.template.copy()
        flat = [np.ravel(array) for array in arrays]
        for target, which, source in self.fills:
            numbers[target] = flat[which][source]
        return self.layout.pack_doubles(numbers)

    def _plan_for(self, sizes: tuple[int, ...]) -> tuple[tuple[int, ...], bytes, int, int, np.ndarray, np.ndarray]:
        """pack_many()'s recipe for rows whose arrays have `sizes` numbers: the template's bytes, the float64 grid its
        numbers lie on (its first byte and length; 0 long where they do not all lie on one), and for each number
        filled in, its place on that grid and in the row's arrays joined (the last fill of a number wins, as in
        _packed())."""
        layout = self.layout
        template = layout.pack_doubles(self.template)
        offsets = np.empty(layout.count, np.int64)  # each number's first byte in the message
        at = 0
        for data, first, end in layout._segments:
            at += len(data)
            offsets[first:end] = at + 8 * np.arange(end - first)
            at += 8 * (end - first)
        filled: dict[int, int] = {}
        bases = np.cumsum((0, *sizes[:-1]))
        for target, which, source in self.fills:
            filled.update(zip(np.ravel(target).tolist(), (bases[which] + np.ravel(source)).tolist()))
        targets, sources = np.array(list(filled), np.int64), np.array(list(filled.values()), np.int64)
        places = offsets[targets]
        start = int(offsets[0] % 8) if layout.count else 0
        count = 0
        if (
            layout._doubles
            and len(template) == at
            and self.template.size == layout.count
            and np.all(places % 8 == start)
        ):
            count = (len(template) - start) // 8
        self._plan = (sizes, template, start, count, (places - start) // 8, sources)
        return self._plan

    def __reduce__(self) -> tuple[type[FilledLayout], tuple[Any, ...]]:
        return FilledLayout, (self.layout, self.template, self.fills, self.derive)


class PackersByRow:
    """Packs rows ``(k, row)`` each with the k-th of `packers` (each has pack_many, as a CdrLayout): a fleet's /tf
    messages, a packer per car, in one hand-over (control/joint_state_controller.py). Pickles as its packers; light to
    import, as a writer process unpickles it."""

    def __init__(self, packers: tuple[Any, ...]) -> None:
        self.packers = packers

    def pack_many(self, rows: Sequence[Sequence[Any]]) -> list[bytes]:
        """The CDR bytes of each row's message, packed by its packer."""
        packers = self.packers
        return [packers[k].pack_many((row,))[0] for k, row in rows]

    def __reduce__(self) -> tuple[type[PackersByRow], tuple[tuple[Any, ...]]]:
        return PackersByRow, (self.packers,)
