"""Follow the gap: a driver written to the node contract (docs/drivers.md, "Your own driver"; this file is its code)."""

import numpy as np

from racecar_sim import Simulator
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header, LaserScan
from racecar_sim.nodes import NodeBase, NodeContext


class FollowTheGap(NodeBase):
    """Steer toward the most open direction ahead, clear of the nearest wall; slow down near a wall in front."""

    def __init__(self, ctx: NodeContext, speed: float = 2.0, slow_speed: float = 1.0, bubble: float = 0.5) -> None:
        self.bus, self.speed, self.slow_speed, self.bubble = ctx.bus, speed, slow_speed, bubble
        self.command_topic = ctx.topic("/vesc/ackermann_cmd_mux/input/navigation")  # /car2/... in a fleet
        self.frame = ctx.names.frame("base_link")
        ctx.bus.subscribe(ctx.topic("/scan"), self.on_scan)

    def on_scan(self, scan: LaserScan) -> None:
        ranges = np.nan_to_num(np.asarray(scan.ranges), posinf=scan.range_max)
        angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
        ahead = np.abs(angles) < np.pi / 2
        ranges, angles = ranges[ahead], angles[ahead]
        near = np.argmin(ranges)  # directions passing within `bubble` m of the nearest point are closed
        width = np.arcsin(min(1.0, self.bubble / max(ranges[near], 1e-3)))
        free = np.where(np.abs(angles - angles[near]) < width, 0.0, ranges)
        openness = np.convolve(free, np.ones(61) / 61, mode="same")  # gaps ~15 degrees wide
        steering = float(np.clip(angles[np.argmax(openness)], -0.34, 0.34))
        speed = self.speed if ranges[np.abs(angles) < 0.2].min() > 3.0 else self.slow_speed
        command = AckermannDrive(steering_angle=steering, speed=speed)
        stamp = Header.at(scan.header.stamp.to_ns(), self.frame)
        self.bus.publish(self.command_topic, AckermannDriveStamped(stamp, command))


if __name__ == "__main__":  # python examples/follow_the_gap.py: 60 s round walker, printing the odometry
    with Simulator(world="walker", camera=False) as sim:
        sim.add_node(FollowTheGap)
        sim.subscribe("/vesc/odom", lambda odom: print(sim.time, odom.pose.pose.position.x, odom.pose.pose.position.y))
        sim.run_until(60.0)
