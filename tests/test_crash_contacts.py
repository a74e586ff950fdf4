"""CrashContacts.touching reads a few contacts element by element and many with numpy: both ways find the same crashes
(car into car, car into wall, wheels resting on the floor left out) on the contact lists of a real run."""

from __future__ import annotations

import math

import mujoco
import pytest

import racecar_sim.physics.crash_contacts as crash_contacts
from racecar_sim import Car, Simulator, Spawn
from racecar_sim.msgs import AckermannDrive, AckermannDriveStamped, Header


def _drive(sim: Simulator, car: Car, speed: float, steering: float) -> None:
    def send(now_ns: int) -> None:
        command = AckermannDrive(steering_angle=steering, speed=speed)
        sim.publish(
            car.topic("/vesc/ackermann_cmd_mux/input/navigation"),
            AckermannDriveStamped(Header.at(now_ns, car.names.frame("base_link")), command),
        )

    sim.scheduler.every(20.0, send, f"{car.name} driver")


def _crashing_trio() -> Simulator:
    """Three cars in the tunnel: a drives into a wall (at 1.5 s), b and c into each other (at 0.6 s)."""
    cars = [
        Car("a", spawn=Spawn(0.0, 0.0, 0.05, -math.pi / 2), camera=False),
        Car("b", spawn=Spawn(3.0, 0.0, 0.05, math.pi), camera=False),
        Car("c", spawn=Spawn(1.5, 1.0, 0.05, -1.5), camera=False),
    ]
    sim = Simulator(world="tunnel", cars=cars, sensor_noise=False)
    for car, steering in zip(sim.cars, (0.0, 0.0, 0.3)):
        _drive(sim, car, 2.0, steering)
    return sim


def test_the_few_contacts_path_finds_what_the_numpy_path_finds(monkeypatch: pytest.MonkeyPatch) -> None:
    sim = _crashing_trio()
    contacts = sim.collisions._contacts
    assert contacts is not None
    seen: set[tuple[int, int]] = set()
    for _ in range(300):  # until both kinds of crash were compared
        if any(b >= 0 for _, b in seen) and any(b < 0 for _, b in seen):
            break
        sim.run_for(0.02)
        monkeypatch.setattr(crash_contacts, "_FEW", -1)  # every contact list through numpy
        contacts._quiet = None  # looked at afresh, not as the same contacts as the last look
        by_numpy = contacts.touching(sim.data)
        monkeypatch.setattr(crash_contacts, "_FEW", 10**9)  # every one element by element
        contacts._quiet = None
        assert contacts.touching(sim.data) == by_numpy
        seen |= {(a, b) for a, b, _ in by_numpy}
    monkeypatch.undo()
    assert any(b >= 0 for _, b in seen), "no car-car crash to compare"
    assert any(b < 0 for _, b in seen), "no wall crash to compare"
    assert sim.collisions.count > 0


@pytest.mark.parametrize("few", [10**9, -1])
def test_the_same_contacts_again_are_looked_at_again_where_a_wheel_tilts(
    monkeypatch: pytest.MonkeyPatch, few: int
) -> None:
    """The contacts of the last look that found no crash are no crash again only while the wheels' normals stay within
    45 degrees of vertical: a wheel whose contact normal tips to horizontal (as against a wall) is a crash."""
    monkeypatch.setattr(crash_contacts, "_FEW", few)
    sim = Simulator(world="empty", cars=[Car("a", camera=False)], sensor_noise=False)
    sim.run_for(0.3)  # settled on its four wheels
    contacts = sim.collisions._contacts
    assert contacts is not None
    data = sim.data
    assert data.ncon >= 4 and contacts.touching(data) == set()
    assert contacts.touching(data) == set()  # the same contacts, as remembered
    wheel = next(i for i in range(data.ncon) if contacts._wheel_list[int(data.contact.geom[i, 0])]
                 or contacts._wheel_list[int(data.contact.geom[i, 1])])  # fmt: skip
    ga, gb = (int(g) for g in data.contact.geom[wheel])
    floor = gb if contacts._owner_list[gb] < 0 else ga
    data.contact.frame[wheel, 2] = -1.0  # its normal vertical, pointing down (the pair the other way round): resting
    assert contacts.touching(data) == set()
    data.contact.frame[wheel, 2] = 0.0  # its normal horizontal: driving into what it touches
    assert contacts.touching(data) == {(0, -1, floor)}
    data.contact.frame[wheel, 2] = 1.0
    assert contacts.touching(data) == set()
    data.contact.frame[wheel, 2] = -0.5  # tipped past 45 degrees, pointing down: a crash on the remembered look too
    assert contacts.touching(data) == {(0, -1, floor)}
    sim.close()


def test_the_kept_contact_views_read_each_later_step_as_a_fresh_look_does() -> None:
    """touching() keeps views of MuJoCo's contact array per contact count (MuJoCo keeps an MjData's contacts at the
    start of its arena): over a run whose contact count goes up and down (crashes into a wall and into a car, an
    MjData copied back in and a reset in between), each look with the kept views finds what a CrashContacts made
    afresh for that look finds, and the views lie where data.contact does."""
    sim = _crashing_trio()
    kept = sim.collisions._contacts
    assert kept is not None
    watched = sim.collisions._cars
    roots, wheels = [car.root for car in watched], [w for car in watched for w in car.wheels]
    counts: set[int] = set()
    found: set[tuple[int, int]] = set()
    saved = mujoco.MjData(sim.model)
    for step in range(150):
        if step == 60:
            mujoco.mj_copyData(saved, sim.model, sim.data)
        if step == 80:  # back to the state of step 60, copied in as a failed spawn check restores it
            mujoco.mj_copyData(sim.data, sim.model, saved)
        if step == 100:
            sim.reset()
        sim.run_for(0.02)
        data = sim.data
        fresh = crash_contacts.CrashContacts(sim.model, roots, wheels).touching(data)
        assert kept.touching(data) == fresh
        if data.ncon:
            pairs, normals_z = kept._live[data.ncon]
            assert pairs.ctypes.data == data.contact.geom.ctypes.data
            assert normals_z.ctypes.data == data.contact.frame[:, 2].ctypes.data
        counts.add(data.ncon)
        found |= {(a, b) for a, b, _ in fresh}
    assert len(counts) > 3, "the contact count hardly changed"
    assert any(b >= 0 for _, b in found) and any(b < 0 for _, b in found), "not both kinds of crash"
    sim.close()
