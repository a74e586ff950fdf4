"""Throughput of the ROS 1 bridge: `python bench/bench_ros_bridge.py [--duration 20] [--repeat 2]`.

The `empty` world, one car driving a 1 m/s, 0.2 rad circle, lidar on, camera off, run as fast as it goes:
first without the bridge (an in-process subscriber on /scan, so the lidar works), then with `RosBridge` on a
roscore started on a free port of 127.0.0.1 and one rospy node (under the ROS interpreter) subscribed to every
topic the sim publishes. Printed: the real-time factor of each, their ratio, the messages per wall second the
bridge serialized and piped to the ROS side, and how many of them the rospy subscriber received. Needs Debian's
ROS 1 packages.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import textwrap
import time

from racecar_sim import Simulator
from racecar_sim.bridges.ros1 import RosBridge, ros_python
from racecar_sim.bridges.ros1.environment import message_path, ros_environment
from racecar_sim.bridges.ros1.master import Master
from racecar_sim.drivers import ConstantCommand

LISTENER = textwrap.dedent("""
    import rospy, threading, time
    counts = {}
    def on_msg(msg, topic):
        counts[topic] = counts.get(topic, 0) + 1
    rospy.init_node("bench_listener")
    subscribed = set()
    def follow():  # subscribe to every topic as it appears
        while not rospy.is_shutdown():
            for topic, _ in rospy.get_published_topics():
                if topic not in subscribed and topic != "/rosout" and topic != "/rosout_agg":
                    subscribed.add(topic)
                    rospy.Subscriber(topic, rospy.AnyMsg, on_msg, topic, queue_size=100)
            time.sleep(0.2)  # wall time: /use_sim_time is set
    threading.Thread(target=follow, daemon=True).start()
    try:
        rospy.spin()
    finally:
        print(sum(counts.values()), len(counts), flush=True)
""")


def sim_with_driver() -> Simulator:
    sim = Simulator(world="empty", lidar=True, camera=False)
    ConstantCommand(sim.bus, sim.scheduler, 1.0, 0.2)
    return sim


def without_bridge(duration: float) -> tuple[float, float]:
    """(real-time factor, bus messages per wall second) with an in-process /scan subscriber."""
    sim = sim_with_driver()
    sim.subscribe("/scan", lambda msg: None)
    start = time.perf_counter()
    sim.run_until(duration)
    wall = time.perf_counter() - start
    total = sum(sim.bus.count(t) for t in sim.bus.topics())
    sim.close()
    return duration / wall, total / wall


def with_bridge(duration: float, master: Master) -> tuple[float, float, int, int]:
    """(real-time factor, messages bridged per wall second, messages the rospy node received, topics)."""
    sim = sim_with_driver()
    bridge = RosBridge(sim, master.uri)
    bridge.start()
    env = ros_environment(master.uri, message_path())
    listener = subprocess.Popen([ros_python(), "-c", LISTENER], env=env, stdout=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # warm up until the listener reads every topic
            sim.run_for(0.05)
            time.sleep(0.05)
            outs = list(bridge._out.values())
            if sim.time > 2.0 and outs and all(o.connections > 0 or o.latched for o in outs if o.ok):
                break
        sent, start_t = bridge.sent, sim.time
        start = time.perf_counter()
        sim.run_until(start_t + duration)
        wall = time.perf_counter() - start
        rate = (bridge.sent - sent) / wall
        time.sleep(1.0)
    finally:
        listener.send_signal(signal.SIGINT)
        out = listener.communicate(timeout=20)[0].split()
        bridge.close()
        sim.close()
    received, topics = (int(out[0]), int(out[1])) if len(out) == 2 else (0, 0)
    return duration / wall, rate, received, topics


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--duration", type=float, default=20.0, help="sim seconds per measurement (default 20)")
    parser.add_argument("--repeat", type=int, default=2, help="measurements; the best is reported (default 2)")
    args = parser.parse_args(argv)
    master = Master(None, ros_environment(None, None), port=None)
    try:
        base = max(without_bridge(args.duration) for _ in range(args.repeat))
        bridged = max(with_bridge(args.duration, master) for _ in range(args.repeat))
    finally:
        master.close()
    print(f"empty world, lidar on, camera off, {args.duration:g} sim s, best of {args.repeat}")
    print(f"without bridge   real-time factor {base[0]:6.1f}x  ({base[1]:.0f} bus messages/s)")
    print(
        f"with --ros       real-time factor {bridged[0]:6.1f}x  (ratio {bridged[0] / base[0]:.2f}); "
        f"{bridged[1]:.0f} messages/s bridged to ROS on {bridged[3]} topics, a rospy subscriber on each "
        f"received {bridged[2]} in all"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
