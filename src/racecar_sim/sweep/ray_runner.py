"""A sweep's episodes as Ray tasks, on a Ray cluster or a local Ray started for the sweep.

Each task runs its episode in a scratch folder on whichever node it lands and sends back the row and the folder's
files (run.mcap, summary.json, summary.png), which are written here under OUT/runs/<folder>/: no shared file system
is needed between the nodes.
"""

from __future__ import annotations

import itertools
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from racecar_sim.core.errors import ConfigError
from racecar_sim.sweep.episode import run_episode
from racecar_sim.sweep.spec import Episode

PENDING_PER_CPU = 2  # Ray tasks in flight per CPU of the cluster: each CPU has its next episode queued
INSTALL_HINT = 'the sweep runs on Ray: pip install -e ".[ray]" (or run it here one episode at a time with --local)'


def ray_available() -> bool:
    """Whether Ray is installed (the `[ray]` extra)."""
    import importlib.util

    return importlib.util.find_spec("ray") is not None


def episode_with_files(episode: Episode) -> tuple[dict[str, Any], dict[str, bytes]]:
    """Run `episode` in a scratch folder on this node; its row and its files by name."""
    with tempfile.TemporaryDirectory(prefix="racecar-sweep-") as scratch:
        row = run_episode(episode, scratch)
        files = {path.name: path.read_bytes() for path in Path(scratch).iterdir() if path.is_file()}
    return row, files


def run_on_ray(
    episodes: Iterable[Episode], runs: Path, address: str | None = None, num_cpus: int | None = None
) -> Iterator[dict[str, Any]]:
    """Run the episodes as Ray tasks (one CPU each) and yield their rows as they complete, each episode's files
    written to `runs`/<episode.folder_name>/ first.

    Uses the Ray session already initialised in this process if there is one; else `ray.init(address)`: None
    joins the cluster of RAY_ADDRESS or of `ray start` on this machine, or starts a local one (`num_cpus` CPUs,
    default all), "auto" only joins, "local" always starts one. A Ray started here is shut down at the end.
    """
    if not ray_available():
        raise ConfigError(INSTALL_HINT)
    import ray

    started = not ray.is_initialized()
    if started:
        if address is not None and address != "local" and num_cpus is not None:
            raise ConfigError("--num-cpus sizes a local Ray: a cluster joined with --address has its own CPUs")
        ray.init(
            address=address, num_cpus=num_cpus, include_dashboard=False, log_to_driver=False, configure_logging=False
        )
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(episode_with_files)
        # a window of tasks in flight, the next episode made as one completes (the grid is never made whole)
        window = max(PENDING_PER_CPU * int(ray.cluster_resources().get("CPU", 1)), 1)
        upcoming = iter(episodes)
        pending = {task.remote(episode): episode for episode in itertools.islice(upcoming, window)}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            episode = pending.pop(done[0])
            row, files = ray.get(done[0])
            for following in itertools.islice(upcoming, 1):
                pending[task.remote(following)] = following
            folder = runs / episode.folder_name
            folder.mkdir(parents=True, exist_ok=True)
            for name, data in files.items():
                (folder / name).write_bytes(data)
            row["folder"] = f"{runs.name}/{episode.folder_name}"
            yield row
    finally:
        if started:
            ray.shutdown()
