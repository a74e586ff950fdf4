"""Every bus topic, live, over the Foxglove WebSocket protocol, as foxglove_bridge serves a ROS 2 graph.

Each topic becomes a channel with message encoding ``cdr`` and a ``ros2msg`` schema (the same text
our MCAP recorder embeds), so Foxglove and Lichtblick decode it as they decode a ROS 2 topic.

foxglove-sdk speaks only the ``foxglove.sdk.v1`` subprotocol and refuses, before any message, a client that
offers only ``foxglove.websocket.v1`` (Lichtblick 1.21 and older, the ``@foxglove/ws-protocol`` client); it
logs just "Dropping client ...: handshake failed". A filter on its logger turns that line into a warning
that names the subprotocol and the clients that speak it.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import foxglove
from foxglove import Channel, Context, Schema
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from racecar_sim.bus import Bus
from racecar_sim.core.errors import ConfigError
from racecar_sim.msgs import msgtype_of, schema_text, serialize

SERVER_NAME = "racecar_sim"
SUBPROTOCOL = "foxglove.sdk.v1"
SDK_SERVER_LOGGER = "foxglove.websocket.server"  # the Rust server's log target, through Python's logging
HANDSHAKE_FAILED = "handshake failed"
HANDSHAKE_HINT = (
    f"this server speaks the {SUBPROTOCOL} WebSocket subprotocol only: a client that offers only "
    "foxglove.websocket.v1 (Lichtblick 1.21 or older) cannot connect; use Foxglove, or Lichtblick "
    "1.22 or newer"
)


class FoxgloveBridge:
    """Serves every bus topic over a foxglove-sdk WebSocket as ROS 2 CDR with ros2msg schemas.

    A topic is advertised on its first message; its messages are serialized only while a client
    subscribes to it. The last message of a latched topic (``/tf_static``) is sent again to each
    client that subscribes to it, as a transient-local publisher does for a late subscriber.
    Log times are ``clock()``, the sim time in nanoseconds.

    Raises:
        ConfigError: The server cannot listen on ``host:port`` (for example the port is in use).
    """

    def __init__(self, bus: Bus, clock: Callable[[], int], port: int = 8765, host: str = "127.0.0.1") -> None:
        if not 0 <= port <= 65535:
            raise ConfigError(f"Foxglove port {port} is not in 0..65535")
        self._bus = bus
        self._clock = clock
        # A context of our own: our channels reach this server only, never another bridge's server
        # nor an MCAP sink someone opened on the SDK's global context.
        self._context = Context()
        self._channels: dict[str, Channel] = {}
        self._schemas: dict[str, Schema] = {}
        self._latched_topics: set[str] = set()
        # Written on the sim's thread, read on the SDK's: channel id -> the channel, CDR of its last message.
        self._latched: dict[int, tuple[Channel, bytes]] = {}
        self._lock = threading.Lock()
        self._now = clock()
        self._closed = False
        _explain_failed_handshakes()
        self._server = _start_server(host, port, self._context, _SubscribeListener(self))
        self.port: int = self._server.port
        for topic, msg in bus.latched_messages().items():
            self._on_message(topic, msg)
        self._untap = bus.tap(self._on_message)

    def _on_message(self, topic: str, msg: Any) -> None:
        """Bus tap, on the sim's thread: advertise the topic if new, send the message if anyone listens."""
        self._now = self._clock()
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._advertise(topic, msg)
        if topic in self._latched_topics:
            data = serialize(msg)
            # Under the lock, so that a client subscribing now cannot get this message after an older one.
            with self._lock:
                self._latched[channel.id()] = (channel, data)
                channel.log(data, log_time=self._now)
        elif channel.has_sinks():
            channel.log(serialize(msg), log_time=self._now)

    def _advertise(self, topic: str, msg: Any) -> Channel:
        msgtype = msgtype_of(msg)
        schema = self._schemas.get(msgtype)
        if schema is None:
            schema = Schema(name=msgtype, encoding="ros2msg", data=schema_text(msgtype).encode())
            self._schemas[msgtype] = schema
        # The bus stores a latched topic's message before calling taps, so this sees the first one too.
        if topic in self._bus.latched_messages():
            self._latched_topics.add(topic)
        channel = Channel(topic, schema=schema, message_encoding="cdr", context=self._context)
        self._channels[topic] = channel
        return channel

    def _resend_latched(self, channel_id: int) -> None:
        """On the SDK's thread when a client subscribes: log the latched topic's last message again.

        foxglove-sdk 0.30.3 registers the subscription before calling the listener, so the message
        reaches the new subscriber (and, as a duplicate, any other subscriber of the topic).
        """
        with self._lock:
            latched = self._latched.get(channel_id)
            if latched is not None and not self._closed:
                channel, data = latched
                channel.log(data, log_time=self._now)

    def close(self) -> None:
        """Stop serving: detach from the bus, unadvertise every channel and stop the server. Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._untap()
        for channel in self._channels.values():
            channel.close()
        self._server.stop()

    def __enter__(self) -> FoxgloveBridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _SubscribeListener(ServerListener):
    """Hands late subscribers their latched message (the SDK's no-op defaults handle every other event)."""

    def __init__(self, bridge: FoxgloveBridge) -> None:
        self._bridge = bridge

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self._bridge._resend_latched(channel.id)


class _HandshakeHint(logging.Filter):
    """Makes the SDK's "Dropping client ...: handshake failed" a one-line warning that says which
    subprotocol the server speaks (the SDK cannot tell us what the client offered)."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message.endswith(HANDSHAKE_FAILED):
            record.msg, record.args = f"Foxglove: {message}: {HANDSHAKE_HINT}", ()
            record.levelno, record.levelname = logging.WARNING, logging.getLevelName(logging.WARNING)
        return True


def _explain_failed_handshakes() -> None:
    """Put the _HandshakeHint filter on the SDK server's logger, once per process."""
    logger = logging.getLogger(SDK_SERVER_LOGGER)
    if not any(isinstance(f, _HandshakeHint) for f in logger.filters):
        logger.addFilter(_HandshakeHint())


def _start_server(host: str, port: int, context: Context, listener: _SubscribeListener) -> WebSocketServer:
    """A fresh server on host:port serving `context`; a bind failure becomes a one-line ConfigError."""
    try:
        return foxglove.start_server(name=SERVER_NAME, host=host, port=port, context=context, server_listener=listener)
    except RuntimeError as exc:
        reason = " ".join(str(exc).removeprefix("FoxgloveError: ").split())
        if "in use" in reason:
            raise ConfigError(
                f"Foxglove port {port} on {host} is already in use (another bridge running?); "
                f"choose another with --foxglove PORT, or 0 for any free port"
            ) from None
        raise ConfigError(f"cannot serve Foxglove on {host}:{port}: {reason}") from None
