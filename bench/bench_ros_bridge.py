"""Throughput of the ROS 1 bridge: `python bench/bench_ros_bridge.py [--duration 5] [--rounds 8] [--all] [--quick]`.

The `empty` world, one car driving a 1 m/s, 0.2 rad circle, lidar on, camera off, run as fast as it goes (what
`--ros --fast` does). Two such sims live in this process: one without the bridge (in-process subscribers on the
listened topics, so the lidar works), and one with `RosBridge` on a roscore started on a free port of 127.0.0.1 and
one rospy node (under the ROS interpreter) subscribed with the real message classes to /scan, /vesc/odom, /tf and
/clock (`--all`: to every topic the sim publishes, with rospy.AnyMsg). After a warm-up, the two run in turns of
`--duration` sim seconds, `--rounds` times (ABBA order, so drift of the machine's load falls on both alike), and the
ratio of their real-time factors is printed: the figure issue 23 asks to be at least 0.5. Also printed: messages
per wall second the bridge sent to the ROS side, and how many of them the rospy node received. `--quick` checks
that it all runs (1 round of 0.5 s). Needs Debian's ROS 1 packages. `--ros2`: the same figure for the ROS 2 bridge
(bench_ros2_bridge.py: an rclpy node on the same four topics).
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from machine_info import machine_line
from racecar_sim import Simulator
from racecar_sim.bridges.ros1 import RosBridge, ros_python
from racecar_sim.bridges.ros1.environment import message_path, ros_environment
from racecar_sim.bridges.ros1.master import Master
from racecar_sim.drivers import ConstantCommand

TOPICS = {  # what a typical ROS node of the car reads
    "/scan": "sensor_msgs/LaserScan",
    "/vesc/odom": "nav_msgs/Odometry",
    "/tf": "tf2_msgs/TFMessage",
    "/clock": "rosgraph_msgs/Clock",
}
LISTENER = textwrap.dedent("""
    import sys, threading, time
    import rospy, roslib.message
    counts = {}
    def on_msg(msg, topic):
        counts[topic] = counts.get(topic, 0) + 1
    rospy.init_node("bench_listener")
    subscribed = set()
    if sys.argv[1] == "all":  # every topic as it appears
        def follow():
            while not rospy.is_shutdown():
                for topic, _ in rospy.get_published_topics():
                    if topic not in subscribed and topic not in ("/rosout", "/rosout_agg"):
                        subscribed.add(topic)
                        rospy.Subscriber(topic, rospy.AnyMsg, on_msg, topic, queue_size=100)
                time.sleep(0.2)  # wall time: /use_sim_time is set
        threading.Thread(target=follow, daemon=True).start()
    else:
        for item in sys.argv[1:]:
            topic, ros_type = item.split("=")
            rospy.Subscriber(topic, roslib.message.get_message_class(ros_type), on_msg, topic, queue_size=100)
    try:
        rospy.spin()
    finally:
        print(sum(counts.values()), len(counts), flush=True)
""")


def sim_with_driver() -> Simulator:
    sim = Simulator(world="empty", lidar=True, camera=False)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    return sim


class Bridged:
    """The sim with the bridge and the rospy listener, warmed up until the listener reads every topic it asked for."""

    def __init__(self, master: Master, all_topics: bool) -> None:
        self.sim = sim_with_driver()
        self.bridge = RosBridge(self.sim, master.uri)
        self.bridge.start()
        env = ros_environment(master.uri, message_path())
        args = ["all"] if all_topics else [f"{topic}={ros_type}" for topic, ros_type in TOPICS.items()]
        self.listener = subprocess.Popen(
            [ros_python(), "-c", LISTENER, *args], env=env, stdout=subprocess.PIPE, text=True
        )
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # paced, so that the listener connects while little happens
            self.sim.run_for(0.05)
            time.sleep(0.05)
            outs = {topic: out for topic, out in self.bridge._out.items() if out.ok}
            wanted = outs.values() if all_topics else [outs.get(t) for t in TOPICS]
            if self.sim.time > 2.0 and all(o is not None and (o.connections > 0 or o.latched) for o in wanted):
                break
        else:
            self.close()
            raise RuntimeError("the rospy listener did not connect to every topic in 60 s")

    def close(self) -> tuple[int, int]:
        """(messages the listener received, topics it received them on)."""
        time.sleep(1.0)  # what is in flight arrives
        self.listener.send_signal(signal.SIGINT)
        out = self.listener.communicate(timeout=20)[0].split()
        self.bridge.close()
        self.sim.close()
        return (int(out[0]), int(out[1])) if len(out) == 2 else (0, 0)


def replaced_clocks(bridge: RosBridge) -> int:
    """Messages the bridge counted as sent that a newer one replaced in a batch before they went to the ROS side
    (/clock: bridges/ros1/batch.py); 0 for a bridge without batches."""
    return int(getattr(getattr(bridge, "_batch", None), "replaced", 0))


def timed(sim: Simulator, duration: float) -> float:
    """Wall seconds taken by `duration` sim seconds."""
    start = time.perf_counter()
    sim.run_for(duration)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--duration", type=float, default=5.0, help="sim seconds per turn (default 5)")
    parser.add_argument("--rounds", type=int, default=8, help="turns of each sim, in ABBA order (default 8)")
    parser.add_argument("--all", action="store_true", help="subscribe to every topic (rospy.AnyMsg)")
    parser.add_argument("--quick", action="store_true", help="only check that it runs: 1 round of 0.5 s")
    parser.add_argument("--ros2", action="store_true", help="the ROS 2 bridge instead (bench_ros2_bridge.py)")
    args = parser.parse_args(argv)
    print(machine_line(), flush=True)  # absolute figures belong to a machine
    if args.ros2:
        sys.path.insert(0, str(Path(__file__).parent))
        from bench_ros2_bridge import main as ros2_main

        return ros2_main([a for a in (argv if argv is not None else sys.argv[1:]) if a not in ("--ros2", "--all")])
    if args.quick:
        args.duration, args.rounds = 0.5, 1
    master = Master(None, ros_environment(None, None), port=None)
    base = sim_with_driver()
    for topic in TOPICS:
        base.subscribe(topic, lambda msg: None)
    bridged: Bridged | None = None
    try:
        bridged = Bridged(master, args.all)
        timed(base, 1.0)  # warm-up: compiled code, caches
        walls = {"base": 0.0, "bridged": 0.0}
        sent, bus = bridged.bridge.sent, sum(base.bus.count(t) for t in base.bus.topics())
        replaced = replaced_clocks(bridged.bridge)
        for k in range(args.rounds):
            order = ("base", "bridged") if k % 2 == 0 else ("bridged", "base")
            for which in order:
                walls[which] += timed(base if which == "base" else bridged.sim, args.duration)
        sent = bridged.bridge.sent - sent - (replaced_clocks(bridged.bridge) - replaced)
        bus = sum(base.bus.count(t) for t in base.bus.topics()) - bus
    finally:
        total = bridged.bridge.sent - replaced_clocks(bridged.bridge) if bridged is not None else 0
        received, topics = bridged.close() if bridged is not None else (0, 0)
        base.close()
        master.close()
    sim_s = args.duration * args.rounds
    rtf_base, rtf_bridged = sim_s / walls["base"], sim_s / walls["bridged"]
    listened = "every topic (rospy.AnyMsg)" if args.all else ", ".join(TOPICS)
    print(
        f"empty world, lidar on, camera off, {args.rounds} x {args.duration:g} sim s each, interleaved; "
        f"a rospy node subscribed to {listened}"
    )
    print(f"without bridge     real-time factor {rtf_base:6.1f}x  ({bus / walls['base']:.0f} bus messages/s)")
    print(
        f"with --ros --fast  real-time factor {rtf_bridged:6.1f}x  ({sent / walls['bridged']:.0f} messages/s to ROS "
        f"on {topics} topics; the rospy node received {received} of the {total} sent in all)"
    )
    print(f"ratio              {rtf_bridged / rtf_base:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
