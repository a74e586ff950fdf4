"""A whole sweep: its episodes on Ray (or one by one here), their files under OUT/runs/, the table in OUT."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from racecar_sim.sweep.episode import run_episode
from racecar_sim.sweep.spec import Episode, SweepSpec
from racecar_sim.sweep.table import write_table

RUNS = "runs"  # OUT/runs/<index>-<world>-<driver>-seed<k>/: each episode's run.mcap and summary
SPEC_COPY = "sweep.yaml"  # the sweep file as run, beside its results


@dataclass(frozen=True)
class SweepResult:
    """What a sweep left: its folder, the rows in index order, and the table files written."""

    out: Path
    rows: list[dict[str, Any]]
    tables: list[Path]

    @property
    def failed(self) -> list[dict[str, Any]]:
        """The rows of the episodes that stopped on an error."""
        return [row for row in self.rows if row.get("error")]


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    *,
    local: bool = False,
    address: str | None = None,
    num_cpus: int | None = None,
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> SweepResult:
    """Run every episode of `spec` into `out`: on Ray (ray_runner.run_on_ray: `address`, `num_cpus`), or with
    `local` sequentially in this process. `on_row(row)` is called as each episode completes (in completion order);
    the table is written once all have."""
    out = Path(out)
    runs = out / RUNS
    runs.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(spec.source, out / SPEC_COPY)
    if local:
        rows_done = _run_here(spec.iter_episodes(), runs)
    else:
        from racecar_sim.sweep.ray_runner import run_on_ray

        rows_done = run_on_ray(spec.iter_episodes(), runs, address, num_cpus)
    rows = []
    for row in rows_done:
        rows.append(row)
        if on_row is not None:
            on_row(row)
    rows.sort(key=lambda row: row["index"])
    return SweepResult(out, rows, write_table(rows, spec.param_names, out))


def _run_here(episodes: Iterable[Episode], runs: Path) -> Iterator[dict[str, Any]]:
    for episode in episodes:
        row = run_episode(episode, runs / episode.folder_name)
        row["folder"] = f"{RUNS}/{episode.folder_name}"
        yield row
