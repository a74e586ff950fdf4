"""The `racecar-sim` command line: run, describe, bench."""
