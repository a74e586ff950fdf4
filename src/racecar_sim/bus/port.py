"""What a node needs of the bus, as a protocol: the Bus itself, and a car's scoped view of it, both provide it."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from racecar_sim.bus.bus import FedRows, RowPacker


class BusPort(Protocol):
    """Publish (message objects, or CDR bytes for a recorder alone), subscribe, count unheard messages, offer and call
    services."""

    def publish(self, topic: str, msg: Any) -> None: ...

    def subscribe(
        self,
        topic: str,
        callback: Callable[[Any], None],
        msgtype: type | None = None,
        feeds: Mapping[str, type] | None = None,
    ) -> Any: ...

    def has_listeners(self, topic: str) -> bool: ...

    def listeners_epoch(self) -> int | None: ...

    def tally(self, topic: str, msgtype: type) -> None: ...

    def sole_taker(self, topic: str, rows: bool = False) -> Callable[[Any], None] | None: ...

    def delivered(self, topics: Sequence[str], msgtype: type) -> None: ...

    def sole_feeder(self, topic: str) -> Callable[[Any], None] | None: ...

    def publish_fed_rows(
        self, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[Any], fed: Sequence[FedRows]
    ) -> None: ...

    def cdr_only(self, topic: str) -> bool: ...

    def publish_cdr(self, topic: str, msgtype: type, data: bytes) -> None: ...

    def publish_cdr_rows(
        self, msgtype: type, packer: RowPacker, topics: tuple[str, ...], rows: list[tuple[Any, ...]]
    ) -> None: ...

    def latch(self, topic: str) -> None: ...

    def advertise_service(self, name: str, handler: Callable[[Any], Any]) -> None: ...

    def call(self, name: str, request: Any) -> Any: ...
