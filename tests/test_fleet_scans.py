"""A fleet's scans of one tick, cast in one compiled call (sensors/fleet_scans.py), are the scans each lidar casts on
its own (LidarPublisher.scan), to the bit: at random poses, level and tilted, with a noise switch flipped between ticks,
and when a subscriber moves a car between two lidars' ticks of one time."""

from __future__ import annotations

import numpy as np
import pytest

from racecar_sim import Car, Simulator
from racecar_sim.core.transforms import quat_from_rpy
from racecar_sim.worlds import load_world
from racecar_sim.worlds.row import starting_row


def row(world: str, count: int, ahead: float = 8.0) -> Simulator:
    """`count` cars in the CLI's row in `world`, camera off, moved `ahead` m along +x (in the tunnel: off its mouth,
    where the walls alone answer a level scan)."""
    spawns = starting_row(load_world(world), count)
    sim = Simulator(world=world, cars=[Car(f"car{k + 1}", spawn=s, camera=False) for k, s in enumerate(spawns)])
    for car in sim.cars:
        sim.data.qpos[car.lidar.mount.qpos_adr] += ahead
    return sim


@pytest.mark.parametrize("world", ["tunnel", "empty"])
def test_the_scans_of_a_tick_cast_together_equal_the_scans_cast_one_by_one(world):
    """Each car's published scan is what its lidar casts alone at that stamp and state (its own compiled call, or the
    general path where that call refuses a tilted scan), at random poses of four cars close together, some tilted,
    one car's noise switched off and on again between ticks; and the ticks were cast as batches."""
    sim = row(world, 4)
    lidars = [car.lidar for car in sim.cars]
    published: dict[str, list] = {car.name: [] for car in sim.cars}
    for car in sim.cars:
        sim.subscribe(car.lidar.topic, published[car.name].append)
    sim.run_until(0.2)
    fleet = lidars[0]._fleet
    assert fleet.batches_cast > 0 and fleet.taken > 0  # the run's ticks took the batch
    rng = np.random.default_rng(5)
    base = sim.data.qpos.copy()
    tilted = 0
    for k in range(40):
        sim.data.qpos[:] = base
        centre = sim.data.qpos[lidars[0].mount.qpos_adr : lidars[0].mount.qpos_adr + 2].copy()
        for lidar in lidars[1:]:
            adr = lidar.mount.qpos_adr
            sim.data.qpos[adr : adr + 2] = centre + rng.uniform(-3.0, 3.0, 2)
        for lidar in lidars:
            adr = lidar.mount.qpos_adr
            tilt = rng.normal(0, 0.03, 2) if k % 3 == 0 else (0.0, 0.0)
            tilted += k % 3 == 0
            sim.data.qpos[adr + 3 : adr + 7] = quat_from_rpy((*tilt, rng.uniform(-np.pi, np.pi)))
        lidars[2].noise = k % 4 != 1
        stamp = 1_000_000_000 + k * 25_000_000
        before = fleet.batches_cast
        for lidar in lidars:  # the ticks of one time, in the scheduler's order
            lidar._tick(stamp)
        assert fleet.batches_cast == before + 1
        for car in sim.cars:
            got = published[car.name][-1]
            assert got.header.stamp.to_ns() == stamp
            np.testing.assert_array_equal(got.ranges, car.lidar.scan(stamp), err_msg=f"pose {k}, {car.name}")
    assert tilted
    assert fleet.taken >= 100, fleet.taken  # most of the 160 scans were the batches' (the rest refused: tilted)


def test_a_car_moved_between_two_ticks_of_one_time_is_scanned_where_it_is_now():
    """A subscriber of the first car's scan moves the third car before the other lidars tick: their scans are cast
    again from the new state (not taken from the batch cast at the first tick), as they were before batches."""
    sim = row("tunnel", 3)
    lidars = [car.lidar for car in sim.cars]
    third: list = []
    sim.subscribe(lidars[2].topic, third.append)
    sim.subscribe(lidars[1].topic, lambda msg: None)
    adr = lidars[2].mount.qpos_adr

    def move_the_third(msg) -> None:
        sim.data.qpos[adr + 1] += 0.3  # towards a wall

    sim.subscribe(lidars[0].topic, move_the_third)
    sim.run_until(0.1)
    stamp = 2_000_000_000
    fleet = lidars[0]._fleet
    taken = fleet.taken
    for lidar in lidars:
        lidar._tick(stamp)
    assert fleet.taken == taken + 1  # the first from the batch; the state changed after it: the others cast again
    np.testing.assert_array_equal(third[-1].ranges, lidars[2].scan(stamp))
    sim.data.qpos[adr + 1] -= 0.3
    assert not np.array_equal(third[-1].ranges, lidars[2].scan(stamp))  # the batch's scan was of the old place


def test_when_the_first_lidar_is_not_listened_to_the_next_casts_the_batch_for_the_others():
    """Nobody listens to the first car's scan: it casts nothing, and the second lidar's tick casts the batch of the
    second and third (the same scans as cast one by one); the noise tables are stacked once per set of lidars."""
    sim = row("tunnel", 3)
    lidars = [car.lidar for car in sim.cars]
    published: dict[int, list] = {1: [], 2: []}
    first = sim.subscribe(lidars[0].topic, lambda msg: None)
    for k in (1, 2):
        sim.subscribe(lidars[k].topic, published[k].append)
    sim.run_until(0.1)
    fleet = lidars[0]._fleet
    assert len(fleet._stacks) == 1
    first.unsubscribe()
    cast = lidars[0].scans_cast
    sim.run_until(0.2)
    assert lidars[0].scans_cast == cast  # not listened to: no scan
    assert len(fleet._stacks) == 1 and len(next(iter(fleet._stacks.values())).members) == 2
    taken = fleet.taken
    stamp = 3_000_000_000
    for lidar in lidars:
        lidar._tick(stamp)
    assert fleet.taken == taken + 2
    for k in (1, 2):
        np.testing.assert_array_equal(published[k][-1].ranges, lidars[k].scan(stamp))
