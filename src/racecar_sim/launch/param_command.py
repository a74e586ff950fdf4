"""`<param command="...">`: the commands launch files run for a parameter's text, run in-process (never a shell).

Only xacro is a command the original stack runs (`$(find xacro)/xacro file.xacro name:=value`, also the older
`xacro.py` and `--inorder`); it expands through racecar_sim.description's xacro, with `$(find)` on the package path.
"""

from __future__ import annotations

import shlex
from pathlib import Path

from racecar_sim.core.errors import RacecarSimError
from racecar_sim.description import expand_xacro
from racecar_sim.launch.errors import SubstitutionError

XACRO_NAMES = ("xacro", "xacro.py")
_IGNORED_FLAGS = ("--inorder", "-i", "--check-order", "--legacy")


def run_param_command(command: str) -> str:
    """The text a `<param command>` gives; SubstitutionError (problem; fix) for what cannot run."""
    try:
        words = shlex.split(command)
    except ValueError as exc:
        raise SubstitutionError(f"command {command!r} cannot be split into words ({exc})") from None
    if not words or Path(words[0]).name not in XACRO_NAMES:
        program = words[0] if words else "(empty)"
        raise SubstitutionError(
            f"command {program!r} is not run by the sim (it runs no shell); only "
            '"$(find xacro)/xacro FILE name:=value" is: use value= or textfile= instead'
        )
    files, mappings = [], {}
    for word in words[1:]:
        if ":=" in word:
            name, value = word.split(":=", 1)
            mappings[name] = value
        elif word in _IGNORED_FLAGS:
            continue
        elif word.startswith("-"):
            raise SubstitutionError(f"xacro option {word} is not supported in a launch file's command; drop it")
        else:
            files.append(word)
    if len(files) != 1:
        raise SubstitutionError(f"xacro command {command!r} names {len(files)} files; give exactly one .xacro file")
    try:
        return expand_xacro(Path(files[0]), mappings)
    except RacecarSimError as exc:
        raise SubstitutionError(str(exc)) from None
