"""servo_commands as a node: what it publishes per command is the servo law's, whether a command repeats the last
one's very floats (a constant driver's) or not."""

from __future__ import annotations

from racecar_sim import Simulator
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Float64, Header


def test_a_repeated_command_object_and_a_changed_one_both_publish_the_laws_values() -> None:
    sim = Simulator(world="empty", camera=False, lidar=False)
    try:
        servo = sim.car.servo
        assert servo is not None
        heard: list[tuple[str, float]] = []
        for topic in servo.topics:
            sim.bus.subscribe(topic, lambda msg, topic=topic: heard.append((topic, msg.data)), Float64)
        drive = AckermannDrive(steering_angle=0.2, speed=1.5)
        sent = []
        for speed, steer in ((1.5, 0.2), (1.5, 0.2), (-0.5, 0.2), (-0.5, -0.0), (-0.5, 0.0)):
            if (speed, steer) != (1.5, 0.2):  # the same command object, its fields changed in place
                drive.speed, drive.steering_angle = speed, steer
            heard.clear()
            servo._on_drive(AckermannDriveStamped(Header.at(0), drive))
            values, _ = servo.law.command(speed, steer)
            # repr tells -0.0 from 0.0: a hinge angle's sign follows the steering angle's
            assert [(t, repr(v)) for t, v in heard] == [(t, repr(v)) for t, v in zip(servo.topics, values)]
            sent.append([v for _, v in heard])
        assert sent[0] == sent[1] and sent[2] != sent[1]  # the law's values moved with the speed
    finally:
        sim.close()
