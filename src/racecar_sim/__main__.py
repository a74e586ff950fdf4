"""`python -m racecar_sim` is the `racecar-sim` command."""

from racecar_sim.cli.main import entry

raise SystemExit(entry())
