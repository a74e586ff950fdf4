"""`racecar-sim run`: drive the car with a constant command, optionally record, print a summary."""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from pathlib import Path

from tqdm import tqdm

from racecar_sim.cli.args import add_sensor_arguments, add_world_arguments, finite_float, positive_float, sensor_options
from racecar_sim.control.profiles import profile_names
from racecar_sim.core.transforms import yaw_of
from racecar_sim.drivers import ConstantCommand
from racecar_sim.msgs import Odometry
from racecar_sim.physics import preset_names
from racecar_sim.runtime import Simulator

PROGRESS_MIN_DURATION = 5.0  # s of sim time; shorter runs finish before a bar is worth drawing
CHUNK = 0.1  # s of sim time between progress updates and real-time sleeps


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="drive the car with a constant command and print a summary")
    add_world_arguments(p)
    p.add_argument("--duration", type=positive_float, default=10.0, help="sim seconds to run (default 10)")
    p.add_argument("--speed", type=finite_float, default=1.0, help="commanded speed, m/s (default 1.0)")
    p.add_argument("--steering", type=finite_float, default=0.0, help="commanded steering angle, rad (default 0)")
    p.add_argument("--rate", type=positive_float, default=20.0, help="command rate on the navigation input, Hz")
    p.add_argument("--profile", default="seed", choices=profile_names(), help="driving profile (default seed)")
    p.add_argument("--physics", default="default", choices=preset_names(), help="physics preset (default: default)")
    p.add_argument("--odometry", default="original", choices=["original", "ros"],
                   help="original: map->odom as the 2017 sim; ros: odom->base_link, body twist")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--record", metavar="FILE.mcap", help="record every topic to an MCAP file")
    add_sensor_arguments(p)
    p.add_argument("--realtime", action="store_true", help="run no faster than real time")


class _Trip:
    """Distance and last pose, from /vesc/odom."""

    def __init__(self) -> None:
        self.distance = 0.0
        self.last: Odometry | None = None

    def __call__(self, msg: Odometry) -> None:
        if self.last is not None:
            a, b = self.last.pose.pose.position, msg.pose.pose.position
            self.distance += math.hypot(b.x - a.x, b.y - a.y)
        self.last = msg


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt  # unwinds through the recorder's close, like Ctrl-C


def main(args: argparse.Namespace) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    with Simulator(world=args.world, profile=args.profile, seed=args.seed, physics=args.physics, spawn=args.spawn,
                   odometry=args.odometry, model_path=args.model_path, wall_height=args.wall_height,
                   **sensor_options(args)) as sim:
        if args.record:
            Path(args.record).parent.mkdir(parents=True, exist_ok=True)
        recorder = sim.record(args.record) if args.record else None
        ConstantCommand(sim.bus, sim.scheduler, args.speed, args.steering, args.rate)
        trip = _Trip()
        sim.subscribe("/vesc/odom", trip)
        bar = tqdm(total=round(args.duration, 3), unit="sim s", disable=args.duration < PROGRESS_MIN_DURATION or None,
                   bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]", file=sys.stderr)
        start = time.perf_counter()
        while sim.time < args.duration - 1e-9:
            sim.run_until(min(sim.time + CHUNK, args.duration))
            bar.update(round(sim.time - bar.n, 3))
            if args.realtime:
                time.sleep(max(0.0, sim.time - (time.perf_counter() - start)))
        wall = time.perf_counter() - start
        bar.close()
    _summary(args, sim, trip, wall, recorder)
    return 0


def _summary(args: argparse.Namespace, sim: Simulator, trip: _Trip, wall: float, recorder: object) -> None:
    pose = trip.last.pose.pose if trip.last else None
    print(f"world {sim.world.name}, profile {sim.profile.name}, physics {sim.preset.name} "
          f"(step {sim.model.opt.timestep * 1e3:g} ms), seed {sim.seed}")
    print(f"sim time        {sim.time:.2f} s")
    print(f"distance        {trip.distance:.3f} m")
    if pose is not None:
        q = pose.orientation
        yaw = yaw_of((q.w, q.x, q.y, q.z))
        print(f"final pose      x {pose.position.x:.3f} m, y {pose.position.y:.3f} m, yaw {yaw:.3f} rad")
    print(f"real-time factor {sim.time / wall:.1f}x")
    if recorder is not None:
        total = sum(recorder.message_count.values())  # type: ignore[attr-defined]
        print(f"recorded        {total} messages on {len(recorder.message_count)} topics to {args.record}")  # type: ignore[attr-defined]
