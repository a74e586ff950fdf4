"""A starting row: where N cars stand in a world, the first at its spawn pose and each next one behind the one before.

Used by `racecar-sim run --cars N` (cli/run.py) and the race env (envs/race.py). Behind means back along the world's
centerline where the spawn pose stands on its first point (a track's own start: the cars follow the track round, each
facing the way it runs there), else straight back along the spawn heading.
"""

from __future__ import annotations

import math

import numpy as np

from racecar_sim.worlds.world import Spawn, World

CAR_SPACING = 1.5  # m between the base_links of two cars in a row


def row_centerline(world: World) -> np.ndarray | None:
    """The closed centerline (N, 2) a row in `world` follows back from its spawn pose: the world's own where the
    spawn stands on its first point (a track's start), else None (a straight row along the spawn heading)."""
    line = world.centerline
    if line is None or not line.closed:
        return None
    x0, y0 = line.points[0]
    return line.points if (world.spawn.x, world.spawn.y) == (x0, y0) else None


def starting_row(
    world: World, count: int, spacing: float = CAR_SPACING, centerline: np.ndarray | None = None
) -> list[Spawn]:
    """Poses for `count` cars in a row: the first at the world's spawn pose, each next one `spacing` m behind the one
    before, back along a closed `centerline` (N, 2) from its first point, each car facing the way the line runs there
    (default: the world's own where the row follows it, row_centerline), or straight back along the spawn heading."""
    first = world.spawn
    points = row_centerline(world) if centerline is None else np.asarray(centerline, dtype=float)
    if points is None:
        back_x, back_y = math.cos(first.yaw), math.sin(first.yaw)
        return [
            Spawn(first.x - k * spacing * back_x, first.y - k * spacing * back_y, first.z, first.yaw)
            for k in range(count)
        ]
    # walk the loop backwards, P0 -> P(N-1) -> ... -> P1 -> P0: segment j goes from tail[j] back to head[j]
    tail = np.roll(points[::-1], 1, axis=0)  # P0, P(N-1), ..., P1
    head = np.roll(tail, -1, axis=0)  # P(N-1), ..., P1, P0
    lengths = np.hypot(*(head - tail).T)
    station = np.concatenate([[0.0], np.cumsum(lengths)])  # arc length walked back at the start of each segment
    spawns = []
    for k in range(count):
        s = (k * spacing) % station[-1]  # past a whole lap it lands on a car before it: the spawn check says so
        j = min(int(np.searchsorted(station, s, side="right")) - 1, len(lengths) - 1)
        x, y = tail[j] + (s - station[j]) / lengths[j] * (head[j] - tail[j])
        forward = tail[j] - head[j]  # the direction the track runs
        yaw = first.yaw if k == 0 else math.atan2(forward[1], forward[0])
        spawns.append(Spawn(float(x), float(y), first.z, yaw))
    return spawns
