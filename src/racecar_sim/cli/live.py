"""--viewer and --foxglove: the live views that `run` and `teleop` share, and real-time pacing."""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING

from racecar_sim.control.teleop import KeyboardTeleop
from racecar_sim.msgs import LaserScan

if TYPE_CHECKING:
    from racecar_sim.live.foxglove_bridge import FoxgloveBridge
    from racecar_sim.live.viewer import CarViewer
    from racecar_sim.runtime import Simulator

FOXGLOVE_PORT = 8765  # foxglove_bridge's default
VIEWER_RATE = 60.0  # Hz of wall time between viewer syncs


def tcp_port(text: str) -> int:
    """A TCP port number, 0 (any free port) to 65535."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a port number") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port {port} is not in 0..65535")
    return port


def add_live_arguments(p: argparse.ArgumentParser) -> None:
    """--viewer and --foxglove [PORT]."""
    p.add_argument("--viewer", action="store_true",
                   help="open the MuJoCo viewer (needs a display): follows the car, draws the lidar, WASD drives")
    p.add_argument("--foxglove", nargs="?", type=tcp_port, const=FOXGLOVE_PORT, metavar="PORT",
                   help=f"serve every topic to Foxglove / Lichtblick >= 1.22 on ws://127.0.0.1:PORT "
                        f"(default port {FOXGLOVE_PORT})")


class LiveViews:
    """The live views a run asked for; `update()` after each slice of sim time keeps them current.

    The viewer's WASD keys go to a KeyboardTeleop on the mux's teleop input (made here if the caller
    has none), so they outrank any driver, as a joystick does on the real car.
    """

    def __init__(self, sim: Simulator, viewer: bool = False, foxglove_port: int | None = None,
                 teleop: KeyboardTeleop | None = None) -> None:
        self.sim = sim
        self.teleop = teleop
        self.bridge: FoxgloveBridge | None = None
        self.viewer: CarViewer | None = None
        self._scan: LaserScan | None = None
        self._next_sync = 0.0
        if foxglove_port is not None:
            from racecar_sim.live.foxglove_bridge import FoxgloveBridge

            self.bridge = FoxgloveBridge(sim.bus, lambda: sim.time_ns, port=foxglove_port)
            print(f"racecar-sim: Foxglove WebSocket on ws://127.0.0.1:{self.bridge.port} "
                  f"(Foxglove, or Lichtblick >= 1.22: Open connection > Foxglove WebSocket)", file=sys.stderr)
        if viewer:
            from racecar_sim.live.viewer import CarViewer

            self.viewer = CarViewer.open(sim.model, sim.data, sim.robot.root)
            if self.viewer is not None:
                if self.teleop is None:
                    self.teleop = KeyboardTeleop(sim.bus, sim.scheduler, lambda: sim.time_ns)
                if sim.lidar is not None:
                    sim.subscribe(sim.lidar.topic, self._on_scan)

    @property
    def realtime(self) -> bool:
        """Whether a person is watching (the viewer or Foxglove), so sim time should follow the wall clock."""
        return self.viewer is not None or self.bridge is not None

    @property
    def closed(self) -> bool:
        """Whether the person closed the viewer window (the run should end)."""
        return self.viewer is not None and not self.viewer.is_running()

    def _on_scan(self, msg: LaserScan) -> None:
        self._scan = msg

    def update(self) -> None:
        """Hand the viewer's keys to teleop and redraw it (at most VIEWER_RATE times a second)."""
        if self.viewer is None:
            return
        for key in self.viewer.poll_keys():
            self.teleop.key(key)  # type: ignore[union-attr]
        now = time.perf_counter()
        if now < self._next_sync:
            return
        self._next_sync = now + 1.0 / VIEWER_RATE
        beams = None
        if self._scan is not None and self.sim.lidar is not None:
            beams = self.sim.lidar.beam_ends(self._scan.ranges)
        self.viewer.sync(beams)

    def close(self) -> None:
        """Close the viewer window and stop the WebSocket server."""
        if self.viewer is not None:
            self.viewer.close()
            self.viewer = None
        if self.bridge is not None:
            self.bridge.close()
            self.bridge = None

    def __enter__(self) -> LiveViews:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RealTimePacer:
    """Keeps sim time at or behind the wall clock: `wait(sim_time)` sleeps until the wall catches up."""

    def __init__(self, max_lag: float = 0.25) -> None:
        self.max_lag = max_lag
        self._start = time.perf_counter()
        self._offset = 0.0

    def wait(self, sim_time: float) -> None:
        """Sleep until `sim_time` has passed on the wall clock; when the sim falls behind by more than
        `max_lag`, forget the debt rather than racing to catch up."""
        wall = time.perf_counter() - self._start + self._offset
        if wall - sim_time > self.max_lag:
            self._offset -= wall - sim_time
            return
        if sim_time > wall:
            time.sleep(sim_time - wall)
