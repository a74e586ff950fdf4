"""The speed benches run: `racecar-sim bench --speed --quick` (bench/bench_speed.py and the five benches behind the
speed figures) finishes and prints every table. A check that they do not rot, not a timing test."""

from __future__ import annotations

import subprocess
import sys


def test_speed_benches_run_and_print_their_tables():
    result = subprocess.run([sys.executable, "-m", "racecar_sim", "bench", "--speed", "--quick"], capture_output=True,
                            text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    for header in ("1. main job", "2. lidar pipeline", "3. start-up", "4. real maps", "5. scaling"):
        assert f"=== {header}" in out
    for line in ("main job (camera, noise, MCAP, video)", "tunnel ", "walker ", "start -> first physics step",
                 "import racecar_sim.msgs", "basement-like (generated)", "lidar beams (tunnel)", "cars in empty"):
        assert line in out, line
