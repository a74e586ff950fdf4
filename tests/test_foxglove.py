"""--foxglove: a real Foxglove WebSocket client (the `websockets` package) subscribes and decodes ROS 2 CDR."""

from __future__ import annotations

import json
import logging
import queue
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from racecar_sim import Simulator
from racecar_sim.bridges.foxglove import bridge as foxglove_bridge
from racecar_sim.bridges.foxglove.bridge import FoxgloveBridge
from racecar_sim.bus import Bus
from racecar_sim.core.errors import ConfigError, RacecarSimError
from racecar_sim.msgs import String, deserialize

SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 0x01  # binary opcode: u32 subscription id, u64 log time, payload
UNKNOWN_CHANNEL = "Unknown channel ID: "  # the status message refusing a subscription
TIMEOUT = 60.0  # s of wall time for anything to happen; generous for a 2-core CI machine
SLICE = 0.05  # s of sim time between client polls
UST_10LX_ANGLE_MIN = -2.3561944902  # -135 degrees, as racecar.gazebo declares the Hokuyo


class FoxgloveClient:
    """The part of the Foxglove WebSocket protocol that Foxglove and Lichtblick use to view topics."""

    def __init__(self, port: int, host: str = "127.0.0.1") -> None:
        self.ws = connect(f"ws://{host}:{port}", subprotocols=[SUBPROTOCOL], open_timeout=TIMEOUT, max_size=None)
        self.server_info: dict | None = None
        self.channels: dict[str, dict] = {}  # topic -> its advertisement
        self.messages: dict[str, list[tuple[int, bytes]]] = {}  # topic -> (log time, payload) received
        self._subscriptions: dict[int, str] = {}

    def poll(self, timeout: float = 0.0) -> None:
        """Handle every frame that has arrived, waiting up to `timeout` s for the first."""
        while True:
            try:
                frame = self.ws.recv(timeout=timeout)
            except TimeoutError:
                return
            timeout = 0.0
            if isinstance(frame, str):
                op = json.loads(frame)
                if op["op"] == "serverInfo":
                    self.server_info = op
                elif op["op"] == "advertise":
                    self.channels.update({c["topic"]: c for c in op["channels"]})
                elif op["op"] == "status" and op["message"].startswith(UNKNOWN_CHANNEL):
                    # foxglove-sdk 0.30.3 can send a new channel's advertisement a moment before it
                    # accepts subscriptions to it; a client that subscribes at once is refused. Retry.
                    channel_id = int(op["message"].removeprefix(UNKNOWN_CHANNEL))
                    self.subscribe(*[t for t, c in self.channels.items() if c["id"] == channel_id])
            elif frame[0] == MESSAGE_DATA:
                subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                self.messages[self._subscriptions[subscription]].append((log_time, frame[13:]))

    def subscribe(self, *topics: str) -> None:
        """Subscribe to advertised topics."""
        subscriptions = []
        for topic in topics:
            sub_id = len(self._subscriptions) + 1
            self._subscriptions[sub_id] = topic
            self.messages.setdefault(topic, [])
            subscriptions.append({"id": sub_id, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def __enter__(self) -> FoxgloveClient:
        self.ws.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self.ws.__exit__(*exc)


def until(condition: Callable[[], bool], step: Callable[[], None], what: str) -> None:
    """Call `step` until `condition` holds; fail after TIMEOUT s of wall time."""
    deadline = time.monotonic() + TIMEOUT
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        step()


def check_scan(payload: bytes) -> None:
    """The payload is a Hokuyo UST-10LX LaserScan, decoded by our CDR reader and by rosbags."""
    ours = deserialize(payload, "sensor_msgs/msg/LaserScan")
    theirs = get_typestore(Stores.ROS2_HUMBLE).deserialize_cdr(payload, "sensor_msgs/msg/LaserScan")
    for scan in (ours, theirs):
        assert len(scan.ranges) == 1081
        assert scan.angle_min == pytest.approx(UST_10LX_ANGLE_MIN, abs=1e-6)
        assert scan.header.frame_id == "laser"
        assert scan.range_max == pytest.approx(10.0)
    np.testing.assert_array_equal(np.asarray(ours.ranges), theirs.ranges)


def test_client_subscribes_late_and_decodes_scan_and_tf_static():
    sim = Simulator(world="tunnel", camera=False)
    bridge = FoxgloveBridge(sim.bus, lambda: sim.time_ns, port=0)
    try:
        sim.run_for(0.2)  # /tf_static went out at t = 0, long before the client connects
        with FoxgloveClient(bridge.port) as client:
            late_client_sees_scan_and_tf_static(sim, client)
    finally:
        bridge.close()
        bridge.close()  # idempotent
        sim.close()


def late_client_sees_scan_and_tf_static(sim: Simulator, client: FoxgloveClient) -> None:
    """Topics advertised as ROS 2 types; /scan decodes; /tf_static arrives although published before."""
    wanted = ("/scan", "/tf_static", "/tf", "/vesc/odom")

    def step() -> None:
        sim.run_for(SLICE)
        client.poll()

    until(lambda: all(t in client.channels for t in wanted), step, f"{wanted} to be advertised")
    assert client.server_info is not None and client.server_info["name"] == "racecar_sim"
    for topic, schema in [
        ("/vesc/odom", "nav_msgs/msg/Odometry"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/tf_static", "tf2_msgs/msg/TFMessage"),
        ("/scan", "sensor_msgs/msg/LaserScan"),
    ]:
        channel = client.channels[topic]
        assert (channel["encoding"], channel["schemaEncoding"], channel["schemaName"]) == ("cdr", "ros2msg", schema)
    assert "float32[] ranges" in client.channels["/scan"]["schema"]

    client.subscribe("/scan", "/tf_static")
    until(lambda: client.messages["/scan"] and client.messages["/tf_static"], step, "a /scan and /tf_static")
    log_time, payload = client.messages["/scan"][0]
    check_scan(payload)
    stamp = deserialize(payload, "sensor_msgs/msg/LaserScan").header.stamp
    assert log_time == stamp.sec * 10**9 + stamp.nanosec  # log time is sim time
    static = get_typestore(Stores.ROS2_HUMBLE).deserialize_cdr(
        client.messages["/tf_static"][0][1], "tf2_msgs/msg/TFMessage"
    )
    assert {t.child_frame_id for t in static.transforms} >= {"laser"}


def test_nothing_is_serialized_without_a_subscriber(monkeypatch):
    serialized: list[str] = []
    real = foxglove_bridge.serialize

    def counting(msg: object) -> bytes:
        serialized.append(type(msg).__name__)
        return real(msg)

    monkeypatch.setattr(foxglove_bridge, "serialize", counting)
    sim = Simulator(world="tunnel", camera=False)
    with FoxgloveBridge(sim.bus, lambda: sim.time_ns, port=0):
        sim.run_for(0.5)
    sim.close()
    # Only latched topics (/tf_static, the muxes' active input) are kept serialized for late subscribers.
    assert "LaserScan" not in serialized and "Odometry" not in serialized
    assert set(serialized) <= {"TFMessage", "String"}


def _listening_addresses(port: int) -> set[str]:
    """Local addresses of the sockets listening on `port`, from Linux's /proc/net/tcp and tcp6."""
    addresses = set()
    for name, family in (("tcp", socket.AF_INET), ("tcp6", socket.AF_INET6)):
        path = Path("/proc/net") / name
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            address, hex_port = local.split(":")
            if state != "0A" or int(hex_port, 16) != port:  # 0A: LISTEN
                continue
            raw = bytes.fromhex(address)
            # The kernel prints each 32-bit word in host (little-endian) order.
            raw = b"".join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))
            addresses.add(socket.inet_ntop(family, raw))
    return addresses


def _accepts(host: str, port: int) -> bool:
    try:
        socket.create_connection((host, port), timeout=5).close()
        return True
    except OSError:
        return False


def test_server_listens_on_loopback_only():
    with socket.create_server(("0.0.0.0", 0)) as control:
        # The probe tells the two apart: 127.0.0.2 is loopback too, but only a wildcard bind answers on it.
        assert _accepts("127.0.0.2", control.getsockname()[1])
        with FoxgloveBridge(Bus(), lambda: 0, port=0) as bridge:
            assert _accepts("127.0.0.1", bridge.port)
            assert not _accepts("127.0.0.2", bridge.port)
            assert _listening_addresses(bridge.port) == {"127.0.0.1"}


def test_port_in_use_is_a_one_line_config_error():
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        with pytest.raises(ConfigError) as raised:
            FoxgloveBridge(Bus(), lambda: 0, port=port)
    message = str(raised.value)
    assert isinstance(raised.value, RacecarSimError)
    assert str(port) in message and "in use" in message and "\n" not in message


def test_bridges_in_one_process_are_independent():
    bus_a, bus_b = Bus(), Bus()
    with FoxgloveBridge(bus_a, lambda: 0, port=0) as a, FoxgloveBridge(bus_b, lambda: 0, port=0) as b:
        bus_a.publish("/only_a", String(data="a"))
        bus_b.publish("/only_b", String(data="b"))
        with FoxgloveClient(b.port) as client:
            until(lambda: "/only_b" in client.channels, lambda: client.poll(1.0), "/only_b to be advertised")
            assert "/only_a" not in client.channels
        assert a.port != b.port


def test_a_foxglove_websocket_v1_client_is_told_which_subprotocol_to_speak(caplog):
    """Lichtblick <= 1.21 (and @foxglove/ws-protocol) offers only foxglove.websocket.v1: refused, with a hint."""
    caplog.set_level(logging.WARNING)
    with FoxgloveBridge(Bus(), lambda: 0, port=0) as bridge:
        with pytest.raises(InvalidStatus) as refused:
            connect(f"ws://127.0.0.1:{bridge.port}", subprotocols=["foxglove.websocket.v1"], open_timeout=TIMEOUT)
        assert refused.value.response.status_code == 400
        until(
            lambda: any("handshake failed" in r.getMessage() for r in caplog.records),
            lambda: time.sleep(0.05),
            "the SDK to log the failed handshake",
        )
    [record] = [r for r in caplog.records if "handshake failed" in r.getMessage()]
    message = record.getMessage()
    assert record.levelno == logging.WARNING and "\n" not in message
    assert SUBPROTOCOL in message and "foxglove.websocket.v1" in message and "Lichtblick 1.22 or newer" in message
    with FoxgloveBridge(Bus(), lambda: 0, port=0) as bridge, FoxgloveClient(bridge.port) as client:
        until(lambda: client.server_info is not None, lambda: client.poll(1.0), "serverInfo")  # still one filter
    assert len(logging.getLogger(foxglove_bridge.SDK_SERVER_LOGGER).filters) == 1


def test_cli_run_serves_scan_until_sigterm(tmp_path):
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "racecar_sim",
            "run",
            "--world",
            "empty",
            "--no-camera",
            "--duration",
            "20",
            "--realtime",
            "--foxglove",
            "0",
            "--out",
            str(tmp_path),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: queue.Queue[str] = queue.Queue()
    stderr: list[str] = []

    def read_stderr() -> None:
        for line in proc.stderr:  # type: ignore[union-attr]
            stderr.append(line)
            lines.put(line)

    reader = threading.Thread(target=read_stderr, daemon=True)
    reader.start()
    try:
        port = None
        deadline = time.monotonic() + TIMEOUT
        while port is None:
            assert time.monotonic() < deadline and proc.poll() is None, "no Foxglove line:\n" + "".join(stderr)
            try:
                found = re.search(r"Foxglove WebSocket on ws://127\.0\.0\.1:(\d+)", lines.get(timeout=1))
            except queue.Empty:
                continue
            port = int(found.group(1)) if found else None
        with FoxgloveClient(port) as client:
            until(lambda: "/scan" in client.channels, lambda: client.poll(1.0), "/scan to be advertised")
            client.subscribe("/scan")
            until(lambda: bool(client.messages["/scan"]), lambda: client.poll(1.0), "a /scan message")
            check_scan(client.messages["/scan"][0][1])
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=TIMEOUT)
        reader.join(timeout=TIMEOUT)
        assert "Traceback" not in "".join(stderr), "".join(stderr)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
