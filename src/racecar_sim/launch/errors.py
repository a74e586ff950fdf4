"""Launch-file errors: one line naming the file (and line), the element and the fix."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from racecar_sim.core.errors import ConfigError


@dataclass(frozen=True)
class Where:
    """An element of a launch file: its file, line (None if unknown) and how it reads (`<node name="x">`)."""

    file: Path
    line: int | None
    element: str

    def __str__(self) -> str:
        line = f":{self.line}" if self.line else ""
        return f"{self.file}{line}: {self.element}"


class LaunchError(ConfigError):
    """A launch file the sim cannot run; the message is `file:line: <element>: problem; fix`. `where` is None for
    a NodeSpec made without one (not by the loader)."""

    def __init__(self, where: Where | Path | str | None, problem: str, fix: str = "") -> None:
        self.where, self.problem, self.fix = where, problem, fix
        super().__init__(f"{where}: {problem}" + (f"; {fix}" if fix else ""))


class SubstitutionError(ConfigError):
    """A `$(...)` that cannot be resolved; the loader adds the file and element (message: problem; fix)."""
