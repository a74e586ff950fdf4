"""--viewer and --foxglove: the live views that `run` and `teleop` share, and real-time pacing (--realtime, --fast).

With a ROS bridge (--ros, --ros2) a run keeps to the wall clock by default, as Gazebo does: ROS nodes see sim time
pass as wall time and keep up with it. --fast lets the sim run ahead of the wall clock instead (ROS nodes then see
sim time jump and drop what their queue_size cannot hold); --realtime paces a run with no bridge.
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from typing import TYPE_CHECKING

from racecar_sim.core.errors import ConfigError
from racecar_sim.core.names import TELEOP

if TYPE_CHECKING:  # the keys' teleop is imported with the viewer that drives it (start-up)
    from racecar_sim.bridges.foxglove.bridge import FoxgloveBridge
    from racecar_sim.control.teleop import KeyboardTeleop
    from racecar_sim.msgs import LaserScan
    from racecar_sim.runtime import Simulator
    from racecar_sim.viz.viewer import CarViewer

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
    p.add_argument(
        "--viewer",
        action="store_true",
        help="open the MuJoCo viewer (needs a display): follows the car, draws the lidar, WASD drives; "
        "with several cars `.` follows the next one",
    )
    p.add_argument(
        "--foxglove",
        nargs="?",
        type=tcp_port,
        const=FOXGLOVE_PORT,
        metavar="PORT",
        help=f"serve every topic to Foxglove / Lichtblick >= 1.22 on ws://127.0.0.1:PORT "
        f"(default port {FOXGLOVE_PORT})",
    )


def add_pacing_arguments(p: argparse.ArgumentParser, paced_by_default: str = "") -> None:
    """--realtime and --fast. `paced_by_default`: when else the command keeps to the wall clock (for the help)."""
    also = f", or {paced_by_default}" if paced_by_default else ""
    p.add_argument(
        "--realtime",
        action="store_true",
        help=f"run no faster than real time (the default with --ros or --ros2{also})",
    )
    p.add_argument(
        "--fast",
        action="store_true",
        help=f"run as fast as it can, even with --ros or --ros2{also}: ROS nodes see sim time jump and drop "
        "what their queue_size cannot hold",
    )


def bridged(args: argparse.Namespace) -> bool:
    """Whether the run has a ROS bridge (--ros or --ros2)."""
    return bool(getattr(args, "ros", False) or getattr(args, "ros2", False))


def paced(args: argparse.Namespace, default: bool = False) -> bool:
    """Whether the run keeps to the wall clock: --realtime, or a ROS bridge (or `default`) without --fast.
    ConfigError for both --realtime and --fast."""
    realtime, fast = getattr(args, "realtime", False), getattr(args, "fast", False)
    if realtime and fast:
        raise ConfigError("--realtime and --fast contradict each other: give one of them")
    return bool(realtime or (not fast and (default or bridged(args))))


class LiveViews:
    """The live views a run asked for; `update()` after each slice of sim time keeps them current.

    The viewer shows every car and follows one, the first at the start; its FOLLOW_KEY (`.`) moves on to the
    next. Its WASD keys go to a KeyboardTeleop on the followed car's teleop input (`teleop` for the first car,
    made here if the caller has none, and one like it for each other car when it is first followed), so they
    outrank that car's driver, as a joystick does on the real car.
    """

    def __init__(
        self,
        sim: Simulator,
        viewer: bool = False,
        foxglove_port: int | None = None,
        teleop: KeyboardTeleop | None = None,
    ) -> None:
        self.sim = sim
        self.teleop = teleop
        self._teleops: dict[int, KeyboardTeleop] = {} if teleop is None else {0: teleop}
        self.following = 0  # index of the car the viewer follows and the keys drive
        self.bridge: FoxgloveBridge | None = None
        self.viewer: CarViewer | None = None
        self._scans: dict[int, LaserScan] = {}
        self._next_sync = 0.0
        if foxglove_port is not None:
            from racecar_sim.bridges.foxglove.bridge import FoxgloveBridge

            self.bridge = FoxgloveBridge(sim.bus, lambda: sim.time_ns, port=foxglove_port)
            print(
                f"racecar-sim: Foxglove WebSocket on ws://127.0.0.1:{self.bridge.port} "
                f"(Foxglove, or Lichtblick >= 1.22: Open connection > Foxglove WebSocket)",
                file=sys.stderr,
            )
        if viewer:
            from racecar_sim.viz.viewer import CarViewer

            roots = [car.names.mj(car.robot.root) for car in sim.cars]
            self.viewer = CarViewer.open(sim.model, sim.data, roots, "--viewer")
            if self.viewer is not None:
                self.teleop = self._teleop(0)
                for index, car in enumerate(sim.cars):
                    if car.lidar is not None:
                        sim.subscribe(car.lidar.topic, functools.partial(self._on_scan, index))

    @property
    def realtime(self) -> bool:
        """Whether a person is watching (the viewer or Foxglove), so sim time should follow the wall clock."""
        return self.viewer is not None or self.bridge is not None

    @property
    def closed(self) -> bool:
        """Whether the person closed the viewer window (the run should end)."""
        return self.viewer is not None and not self.viewer.is_running()

    def _on_scan(self, index: int, msg: LaserScan) -> None:
        self._scans[index] = msg

    def _teleop(self, index: int) -> KeyboardTeleop:
        """The keyboard teleop of car number `index`: on its own teleop input, with the first one's settings."""
        if index not in self._teleops:
            from racecar_sim.control.teleop import KeyboardTeleop

            car, first = self.sim.cars[index], self._teleops.get(0)
            self._teleops[index] = KeyboardTeleop(
                self.sim.bus,
                self.sim.scheduler,
                lambda: self.sim.time_ns,
                speed=None if first is None else first.speed,
                turn=None if first is None else first.turn,
                hold=None if first is None else first.hold_ns / 1e9,
                config=None if first is None else first.config,
                topic=car.topic(TELEOP),
            )
        return self._teleops[index]

    def follow_next(self) -> None:
        """Follow and drive the next car (after the last, the first). A key still held for the car left behind
        ends with a stop command, as releasing it would."""
        if self.viewer is None:
            return
        if self.teleop is not None and self.teleop.active:
            self.teleop.stop()
        self.following = self.viewer.cycle()
        self.teleop = self._teleop(self.following)
        car = self.sim.cars[self.following]
        print(f"racecar-sim: --viewer: following {car.model_name}; WASD drives it", file=sys.stderr)

    def update(self) -> None:
        """Hand the viewer's keys to teleop (FOLLOW_KEY to follow_next()) and redraw it (at most VIEWER_RATE times
        a second)."""
        if self.viewer is None:
            return
        from racecar_sim.viz.viewer import FOLLOW_KEY

        for key in self.viewer.poll_keys():
            if key == FOLLOW_KEY and len(self.sim.cars) > 1:  # with one car it is just another key: stop
                self.follow_next()
            else:
                self.teleop.key(key)  # type: ignore[union-attr]
        now = time.perf_counter()
        if now < self._next_sync:
            return
        self._next_sync = now + 1.0 / VIEWER_RATE
        beams = None
        car, scan = self.sim.cars[self.following], self._scans.get(self.following)
        if scan is not None and car.lidar is not None:
            beams = car.lidar.beam_ends(scan.ranges)
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
