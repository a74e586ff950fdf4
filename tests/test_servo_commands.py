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


def _drive_ctrl(sim: Simulator, commands: list[tuple[float, float]]) -> list[bytes]:
    """The actuators' setpoints after each command, handed to the servo as the command chain hands them."""
    servo = sim.car.servo
    assert servo is not None
    ctrl = []
    for speed, steer in commands:
        servo._on_drive(AckermannDriveStamped(Header.at(0), AckermannDrive(steering_angle=steer, speed=speed)))
        ctrl.append(sim.data.ctrl.tobytes())
    return ctrl


def test_values_handed_straight_to_the_controllers_set_what_published_commands_set() -> None:
    """Where only the controllers take the servo's commands, it hands them the law's values without Float64 messages:
    the actuators get the very setpoints that the published messages give them (with a listener on one command topic,
    which makes the servo publish every message again), the topics count the same messages, and a listener that comes
    later hears the law's values, as it always did."""
    commands = [(1.5, 0.2), (1.5, 0.2), (-0.5, -0.3), (3.0, 0.0), (0.0, -0.0), (40.0, 1.0)]  # 40 m/s: past a limit
    sims = [Simulator(world="empty", camera=False, lidar=False) for _ in range(2)]
    try:
        direct, published = sims
        servo, other = direct.car.servo, published.car.servo
        assert servo is not None and other is not None
        heard: list[tuple[str, float]] = []
        published.bus.subscribe(other.topics[0], lambda msg: heard.append((other.topics[0], msg.data)), Float64)
        before = [direct.bus.count(topic) for topic in servo.topics]
        direct_ctrl = _drive_ctrl(direct, commands)
        assert servo._takers(servo.bus)[0] is not None and other._takers(other.bus)[0] is None  # each took its path
        assert direct_ctrl == _drive_ctrl(published, commands)
        assert len(heard) == len(commands)
        assert [direct.bus.count(t) - b for t, b in zip(servo.topics, before)] == [len(commands)] * len(servo.topics)
        assert all(direct.bus.topics()[topic] is Float64 for topic in servo.topics)
        late: list[tuple[str, float]] = []
        for topic in servo.topics:
            direct.bus.subscribe(topic, lambda msg, topic=topic: late.append((topic, msg.data)), Float64)
        _drive_ctrl(direct, [(-0.5, -0.3)])
        values, _ = servo.law.command(-0.5, -0.3)
        assert [(t, repr(v)) for t, v in late] == [(t, repr(v)) for t, v in zip(servo.topics, values)]
        assert servo._takers(servo.bus)[0] is None
    finally:
        for sim in sims:
            sim.close()
