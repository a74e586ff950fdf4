"""A drive command's recorded messages on the command path, handed to a recorder as rows, in one go per command.

A command passes the relays and both muxes (mux.py) as the very message object, published again on each topic
(input/nav_0, the high-level mux's output, ...), and servo_commands (servo.py) turns it into six Float64 controller
commands. Where each of those topics has its one node of the path as its only subscriber and only taps that take rows
(Bus.sole_taker with rows=True: a recorder) want it, the node hands the message to the next node itself and the
recorder gets the message's numbers instead: a CommandRows gathers them for the whole command (the stamp and the five
drive numbers, shared by the path's topics; the six controller values) and hands them on with publish_cdr_rows() when
the command's first such hop returns: one or two hand-overs where publish() made ~11 (a message serialized and handed
to the writer each), and the writer packs their CDR bytes (msgs.CdrLayout, checked against serialize()). The nodes
decide what they decide either way, on the same message, and the controllers get the same values.

The order and the log times are publish()'s: whatever else is published on the way (a mux's `active`, a topic taken
the old way) goes out after the rows gathered before it (publish() here), and all of a command's messages are
published at one sim time. Anything else listening on a topic (a subscriber, a bridge, a tap taking objects, a
guarded node) makes that hop publish the message as before, from the next command on (ListenerAnswer).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import cache
from typing import Any, TypeVar

from racecar_sim.bus import BusPort, ListenerAnswer, RowPacker
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Float64
from racecar_sim.msgs.cdr_layout import CdrLayout

F = TypeVar("F", bound=Callable[..., Any])
Taker = Callable[[Any], None]

_F32_MAX = 3.4028234663852886e38  # float32's largest: a drive number beyond it goes the old way (serialize() refuses)
_I32, _U32 = 1 << 31, 1 << 32
_MAX_FRAMES = 16  # frame ids with a layout kept: a command of another frame id goes the old way


class Forwarding:
    """The command a node of the command path is handing on right now, having accepted it: the very message object
    (unchanged, as a mux and a relay forward it) that the next nodes get, which need not check it again; and `rows`,
    the CommandRows gathering its recorded messages where it was handed on as rows (else None). The bus is
    synchronous, so this is set only while that node hands it on."""

    msg: AckermannDriveStamped | None = None
    rows: CommandRows | None = None


def joins_command_rows(callback: F) -> F:
    """Mark a node of the command path's subscriber: it publishes only through the CommandRows of the message it gets
    (a hop of the path, servo_commands), so a hop may call it itself and gather its messages as rows."""
    callback.joins_command_rows = True  # type: ignore[attr-defined]
    return callback


@cache
def float64_layout() -> CdrLayout:
    """The CDR layout of a std_msgs/Float64 (a controller command): its one number."""
    layout = CdrLayout.read(Float64(0.0))
    assert layout is not None, "a Float64 is one float64"
    return layout


class CommandRows:
    """The rows of the messages a command path on `bus` publishes for one command, gathered while its nodes hand the
    command on (see the module docstring), and handed to the bus's taps once the first hop returns."""

    def __init__(self, bus: BusPort) -> None:
        self.bus = bus
        self.depth = 0  # hops handing a command on as rows, one inside the other
        self._groups: list[tuple[type, RowPacker, list[str], list[tuple[Any, ...]]]] = []
        self._layouts: dict[str, CdrLayout | None] = {}  # a command's frame id -> its layout (None: the old way)
        self._last: tuple[object, CdrLayout, tuple[Any, ...]] | None = None  # this command's message, layout, row

    def answer(self, topic: str) -> ListenerAnswer[Taker | None]:
        """Whom a hop to `topic` hands a command itself, asked again when the bus's listeners change: its one
        subscriber where that is a node of the path (joins_command_rows) and taps want the topic, each taking rows;
        else None (no tap at all: publish() hands it on as cheaply; a ROS bridge, which decides by itself what it
        wants: publish() as before)."""

        def work() -> Taker | None:
            bus = self.bus
            if bus.listeners_epoch() is None or bus.sole_taker(topic) is not None:
                return None
            taker = bus.sole_taker(topic, rows=True)
            return taker if getattr(taker, "joins_command_rows", False) else None

        return ListenerAnswer(work)

    def forward(self, topic: str, msg: AckermannDriveStamped, answer: ListenerAnswer[Taker | None]) -> None:
        """Publish an accepted command unchanged on `topic`, vouching for it while its subscribers run: handed to the
        topic's node itself, its row gathered, where `answer` (answer(topic)) gives that node and the message has a
        layout; else with publish()."""
        taker = answer(self.bus)
        made = self._row(msg) if taker is not None else None
        if made is None:
            self.publish(topic, msg, forwarded=True)
            return
        self.add(AckermannDriveStamped, made[0], (topic,), (made[1],))
        before = Forwarding.msg, Forwarding.rows
        Forwarding.msg, Forwarding.rows = msg, self
        self.depth += 1
        try:
            taker(msg)  # type: ignore[misc]  # not None here
        finally:
            Forwarding.msg, Forwarding.rows = before
            self.depth -= 1
            if not self.depth:
                self.flush()

    def publish(self, topic: str, msg: Any, forwarded: bool = False) -> None:
        """bus.publish(topic, msg) after the rows gathered so far (they were published before it); what its
        subscribers publish in turn is theirs (a hop among them hands its rows on when it returns). `forwarded`: `msg`
        is an accepted command that its subscribers need not check."""
        self.flush()
        depth, before = self.depth, (Forwarding.msg, Forwarding.rows)
        self.depth = 0
        if forwarded:
            Forwarding.msg, Forwarding.rows = msg, None
        try:
            self.bus.publish(topic, msg)
        finally:
            self.depth = depth
            Forwarding.msg, Forwarding.rows = before

    def add(self, msgtype: type, packer: RowPacker, topics: Sequence[str], rows: Sequence[tuple[Any, ...]]) -> None:
        """Gather messages of class `msgtype` on `topics`, `rows[k]` the numbers `packer` packs `topics[k]`'s from."""
        groups = self._groups
        if groups and groups[-1][0] is msgtype and groups[-1][1] is packer:
            groups[-1][2].extend(topics)
            groups[-1][3].extend(rows)
        else:
            groups.append((msgtype, packer, list(topics), list(rows)))

    def flush(self) -> None:
        """Hand the rows gathered so far to the bus's taps (publish_cdr_rows, which counts them), in order."""
        self._last = None
        if not self._groups:
            return
        groups, self._groups = self._groups, []
        publish_cdr_rows = self.bus.publish_cdr_rows
        for msgtype, packer, topics, rows in groups:
            publish_cdr_rows(msgtype, packer, tuple(topics), rows)

    def _row(self, msg: AckermannDriveStamped) -> tuple[CdrLayout, tuple[Any, ...]] | None:
        """The layout of `msg` and its numbers; None where it has no layout (a frame id not seen before that no layout
        holds, too many frame ids) or a number serialize() would refuse (out of float32's range, a stamp out of its
        fields' range) or might write otherwise (not a plain float)."""
        last = self._last
        if last is not None and last[0] is msg:  # the same command at the next hop
            return last[1], last[2]
        header, drive = msg.header, msg.drive
        stamp, frame_id = header.stamp, header.frame_id
        sec, nanosec = stamp.sec, stamp.nanosec
        if type(drive) is not AckermannDrive or type(frame_id) is not str:
            return None
        a, b, c = drive.steering_angle, drive.steering_angle_velocity, drive.speed
        d, e = drive.acceleration, drive.jerk
        if not (
            type(sec) is int
            and type(nanosec) is int
            and -_I32 <= sec < _I32
            and 0 <= nanosec < _U32
            and type(a) is float
            and type(b) is float
            and type(c) is float
            and type(d) is float
            and type(e) is float
            and -_F32_MAX <= a <= _F32_MAX
            and -_F32_MAX <= b <= _F32_MAX
            and -_F32_MAX <= c <= _F32_MAX
            and -_F32_MAX <= d <= _F32_MAX
            and -_F32_MAX <= e <= _F32_MAX
        ):
            return None
        row = (sec, nanosec, a, b, c, d, e)
        layout = self._layouts.get(frame_id)
        if layout is None:
            if frame_id in self._layouts or len(self._layouts) >= _MAX_FRAMES:
                return None
            made = CdrLayout.of(msg)
            # the row is the layout's numbers in its order (checked once): else this frame id goes the old way
            layout = self._layouts[frame_id] = made[0] if made is not None and tuple(made[1]) == row else None
            if layout is None:
                return None
        self._last = (msg, layout, row)
        return layout, row
