"""Throughput of the ROS 2 bridge: `python bench/bench_ros2_bridge.py [--duration 5] [--rounds 4] [--quick]` (also
`python bench/bench_ros_bridge.py --ros2 ...`).

As bench_ros_bridge.py measures ROS 1: the `empty` world, one car driving a 1 m/s, 0.2 rad circle, lidar on, camera
off, run as fast as it goes (no pacing). Two such sims live in this process: one without the bridge (in-process
subscribers on the same topics, so the lidar works), and one with `Ros2Bridge` and one rclpy node (a process of the
ROS 2 Python) subscribed with the real message classes to /scan (sensor data QoS), /vesc/odom, /tf (depth 100) and
/clock (best effort, depth 1). After a warm-up, the two run in turns of `--duration` sim seconds, `--rounds` times
(ABBA order), and the ratio of their real-time factors is printed: the figure issue 23 asks to be at least 0.5. Also
printed: messages per wall second the bridge sent, and how many the rclpy node received. Needs a ROS 2 Python (the
[ros2] extra, a sourced ROS 2, or $RACECAR_SIM_ROS2_PYTHON); the discovery stays on 127.0.0.1, in the domain
$ROS_DOMAIN_ID (set one nobody else uses).
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import textwrap
import time

from machine_info import machine_line
from racecar_sim import Simulator
from racecar_sim.bridges.ros2 import Ros2Bridge, Ros2Unavailable, ros2_environment
from racecar_sim.bridges.ros2.environment import ros2_python
from racecar_sim.drivers import ConstantCommand

TOPICS = {  # what a typical ROS 2 node of the car reads
    "/scan": "sensor_msgs.msg:LaserScan",
    "/vesc/odom": "nav_msgs.msg:Odometry",
    "/tf": "tf2_msgs.msg:TFMessage",
    "/clock": "rosgraph_msgs.msg:Clock",
}
LISTENER = textwrap.dedent("""
    import importlib, sys, rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    profiles = {"/scan": qos_profile_sensor_data, "/tf": QoSProfile(depth=100),
                "/clock": QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)}
    rclpy.init()
    node = Node("bench_listener")
    counts = {}
    def on_msg(msg, topic):
        counts[topic] = counts.get(topic, 0) + 1
    for item in sys.argv[1:]:
        topic, spec = item.split("=")
        module, name = spec.split(":")
        cls = getattr(importlib.import_module(module), name)
        node.create_subscription(cls, topic, lambda m, t=topic: on_msg(m, t), profiles.get(topic, QoSProfile(depth=10)))
    try:  # as a ROS 2 node runs: rclpy.spin until Ctrl-C (SIGINT)
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    print(sum(counts.values()), len(counts), flush=True)
""")


def sim_with_driver() -> Simulator:
    sim = Simulator(world="empty", lidar=True, camera=False)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    return sim


class Bridged:
    """The sim with the bridge and the rclpy listener, warmed up until the listener reads every topic."""

    def __init__(self) -> None:
        self.sim = sim_with_driver()
        self.bridge = Ros2Bridge(self.sim)
        self.bridge.start()
        env = ros2_environment(self.bridge.ros, self.bridge.types)
        args = [f"{topic}={spec}" for topic, spec in TOPICS.items()]
        self.listener = subprocess.Popen(
            [self.bridge.ros.python, "-c", LISTENER, *args], env=env, stdout=subprocess.PIPE, text=True
        )
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # paced, so that the listener connects while little happens
            self.sim.run_for(0.05)
            time.sleep(0.05)
            outs = [self.bridge._out.get(t) for t in TOPICS]
            if self.sim.time > 2.0 and all(o is not None and o.connections > 0 for o in outs):
                break
        else:
            self.close()
            raise RuntimeError("the rclpy listener did not match every topic in 60 s")

    def close(self) -> tuple[int, int]:
        """(messages the listener received, topics it received them on)."""
        time.sleep(1.0)  # what is in flight arrives
        self.listener.send_signal(signal.SIGINT)
        out = self.listener.communicate(timeout=20)[0].split()
        self.bridge.close()
        self.sim.close()
        return (int(out[0]), int(out[1])) if len(out) == 2 else (0, 0)


def timed(sim: Simulator, duration: float) -> float:
    """Wall seconds taken by `duration` sim seconds."""
    start = time.perf_counter()
    sim.run_for(duration)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n", 1)[0])
    parser.add_argument("--duration", type=float, default=5.0, help="sim seconds per turn (default 5)")
    parser.add_argument("--rounds", type=int, default=4, help="turns of each sim, in ABBA order (default 4)")
    parser.add_argument("--quick", action="store_true", help="only check that it runs: 1 round of 0.5 s")
    args = parser.parse_args(argv)
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    if args.quick:
        args.duration, args.rounds = 0.5, 1
    try:
        ros2_python()
    except Ros2Unavailable as exc:
        parser.exit(2, f"{parser.prog}: {exc}\n")
    base = sim_with_driver()
    for topic in TOPICS:
        base.subscribe(topic, lambda msg: None)
    bridged: Bridged | None = None
    try:
        bridged = Bridged()
        timed(base, 1.0)  # warm-up: compiled code, caches
        walls = {"base": 0.0, "bridged": 0.0}
        sent, bus = bridged.bridge.sent, sum(base.bus.count(t) for t in base.bus.topics())
        for k in range(args.rounds):
            order = ("base", "bridged") if k % 2 == 0 else ("bridged", "base")
            for which in order:
                walls[which] += timed(base if which == "base" else bridged.sim, args.duration)
        sent = bridged.bridge.sent - sent
        bus = sum(base.bus.count(t) for t in base.bus.topics()) - bus
    finally:
        total = bridged.bridge.sent if bridged is not None else 0
        received, topics = bridged.close() if bridged is not None else (0, 0)
        base.close()
    sim_s = args.duration * args.rounds
    rtf_base, rtf_bridged = sim_s / walls["base"], sim_s / walls["bridged"]
    print(
        f"empty world, lidar on, camera off, {args.rounds} x {args.duration:g} sim s each, interleaved; "
        f"an rclpy node subscribed to {', '.join(TOPICS)}"
    )
    print(f"without bridge   real-time factor {rtf_base:6.1f}x  ({bus / walls['base']:.0f} bus messages/s)")
    print(
        f"with --ros2      real-time factor {rtf_bridged:6.1f}x  ({sent / walls['bridged']:.0f} messages/s to ROS 2 "
        f"on {topics} topics; the rclpy node received {received} of the {total} sent in all)"
    )
    print(f"ratio            {rtf_bridged / rtf_base:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
