"""servo_commands' law is written once (control/servo_law.py): the node (one command, floats) and the batch of
worlds (an array of commands) compute it with the same formulas, and agree bit for bit, signed zeros and clamped
turns included."""

from __future__ import annotations

import numpy as np
import pytest

from racecar_sim.control.servo_law import FLOATS, ServoLaw
from racecar_sim.envs.batch_command import BatchCommands
from racecar_sim.msgs import AckermannDriveStamped
from racecar_sim.runtime.simulator import Simulator

# random commands, then the edges: signed zeros, past the hinge limits, past a quarter turn (the heading wraps)
RNG = np.random.default_rng(7)
SPEEDS = np.concatenate([RNG.uniform(-3.0, 3.0, 400), [0.0, -0.0, 0.0, -0.0, 2.0, -2.0, 1e-300, 40.0]])
STEERS = np.concatenate([RNG.uniform(-1.6, 1.6, 400), [0.0, -0.0, -0.0, 0.0, 1.5707963, -1.5707963, 0.34, -1e-12]])


@pytest.fixture(scope="module", params=["seed", "mit-2017"])
def sim(request):
    sim = Simulator(world="empty", profile=request.param, camera=False, lidar=False)
    yield sim
    sim.close()


def bits(values) -> bytes:
    return np.asarray(values, np.float64).tobytes()


def test_one_command_and_an_array_of_them_give_the_same_bits(sim):
    law: ServoLaw = sim.car.servo.law
    many, clamped = law.commands(SPEEDS, STEERS)
    assert len(many) == len(law.outputs) == 6 and clamped.shape == SPEEDS.shape
    for k, (speed, steer) in enumerate(zip(SPEEDS.tolist(), STEERS.tolist())):
        one, one_clamped = law.command(speed, steer)
        assert bits(one) == bits([row[k] for row in many]), (speed, steer)
        assert one_clamped == clamped[k]
    assert clamped.any() == (law.mode == "ackermann")  # the seed's revolute hinges limit the turn


def test_the_node_publishes_the_laws_outputs_and_the_batch_sets_them(sim):
    servo, law = sim.car.servo, sim.car.servo.law
    published: list[tuple[str, float]] = []
    subscribers = [
        sim.bus.subscribe(topic, lambda msg, t=topic: published.append((t, msg.data))) for topic in servo.topics
    ]
    batch = BatchCommands(sim.car)
    ctrl = np.zeros((len(SPEEDS), batch.nu))
    batch.ctrl(SPEEDS, STEERS, ctrl)
    limits = sim.car.commands.limits
    by_topic = {sim.car.names.topic(c.command_topic): c.name for c in sim.car.controllers.controllers}
    for k, (speed, steer) in enumerate(zip(SPEEDS.tolist(), STEERS.tolist())):
        published.clear()
        msg = AckermannDriveStamped()
        msg.drive.speed, msg.drive.steering_angle = speed, steer
        sim.bus.publish(servo.input_topic, msg)
        values, _ = law.command(speed, steer)
        assert published == list(zip(servo.topics, values)) and bits([v for _, v in published]) == bits(values)
        for topic, value in published:  # the batch's setpoint: the same value, clamped as the controller clamps it
            lo, hi = limits.get(by_topic[topic], (-np.inf, np.inf))
            for adr in sim.car.state.actuator_ctrl(by_topic[topic]):
                assert bits(ctrl[k, adr]) == bits(min(max(value, lo), hi))
    for subscriber in subscribers:
        subscriber.unsubscribe()


def test_a_repeated_command_gives_what_the_law_gives_zero_signs_included(sim):
    """ServoLaw.command keeps its last result: commands in a row, repeats, 0.0 and -0.0 among them, give each time
    exactly what the law itself works out for that command (copysign in the law tells -0.0 apart), in a list of the
    caller's own."""
    law: ServoLaw = sim.car.servo.law
    commands = [(1.0, 0.2), (1.0, 0.2), (1.0, -0.0), (1.0, 0.0), (-0.0, 0.0), (0.0, 0.0), (2.0, 9.0), (2.0, 9.0)]
    for speed, steer in commands:
        values, clamped = law.command(speed, steer)
        expected, expected_clamped = law._law(speed, steer, FLOATS)
        assert bits(values) == bits(expected), (speed, steer)
        assert clamped == expected_clamped
        values.append(0.0)  # the caller's list is its own
        assert bits(law.command(speed, steer)[0]) == bits(expected)
